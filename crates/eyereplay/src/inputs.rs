//! Everything a job needs before work starts: which videos to extract, the
//! extraction cache, the models, ffmpeg, disk space, and provenance.

use crate::{Error, Result};
use eyereplay_core::{ArtifactCache, ArtifactKey, Progress, Stage};
use eyereplay_dataset::{FileDigest, ToolInfo};
use eyereplay_extract::{LandmarkModel, StageFrames};
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

/// Each video source's resolved path with the landmark networks it is read
/// with, each pair once, in the order the config first names them (a video
/// listed once per model is extracted once per model).
pub fn video_extractions(cfg: &DatasetConfig) -> Vec<(PathBuf, LandmarkModel)> {
    let mut seen = BTreeSet::new();
    cfg.classes
        .values()
        .flat_map(|c| c.sources.iter())
        .filter_map(|s| match s {
            SourceSpec::Video { path, landmarks } => Some((cfg.resolve(path), *landmarks)),
            _ => None,
        })
        .filter(|v| seen.insert(v.clone()))
        .collect()
}

/// Extractions of a config's videos: each video's iris CSV in the cache,
/// per landmark model.
#[derive(Clone, Debug, Default)]
pub struct Extracted {
    csv_of: BTreeMap<(PathBuf, LandmarkModel), PathBuf>,
}

impl Extracted {
    /// The cached CSV of `video` read with `landmarks`, for
    /// [`eyereplay_prepare::load_sources`].
    pub fn csv_of(&self, video: &Path, landmarks: LandmarkModel) -> Result<PathBuf, PrepareError> {
        self.csv_of
            .get(&(video.to_path_buf(), landmarks))
            .cloned()
            .ok_or_else(|| PrepareError::Source {
                id: video.display().to_string(),
                message: format!(
                    "video was not extracted with the {} landmarks",
                    landmarks.name()
                ),
            })
    }
}

/// Extracts every video source not yet in the cache, with the landmark
/// networks each names. Cached by the video's sha256, the extractor version
/// and the networks, so a renamed copy is not extracted twice and a new
/// extractor does not reuse old results.
pub fn extract_videos_cached(
    cfg: &DatasetConfig,
    cache: &Path,
    progress: &dyn Progress,
) -> Result<Extracted> {
    let wanted = video_extractions(cfg);
    let mut csv_of = BTreeMap::new();
    for model in LandmarkModel::ALL {
        let videos: Vec<PathBuf> = wanted
            .iter()
            .filter(|(_, l)| *l == model)
            .map(|(v, _)| v.clone())
            .collect();
        if videos.is_empty() {
            continue;
        }
        let csvs = extract_cached_with(&videos, model, cache, progress)?;
        csv_of.extend(videos.into_iter().map(|v| (v, model)).zip(csvs));
    }
    Ok(Extracted { csv_of })
}

/// The cache file of `video`'s extraction with the cascade: by content,
/// tool version and the extractor's rows revision, as for the dataset's
/// video sources.
pub fn extraction_cache_path(video: &Path, cache: &Path) -> Result<PathBuf> {
    extraction_cache_path_for(video, LandmarkModel::Cascade, cache)
}

/// The cache file of `video`'s extraction with `model`: by the video's
/// content, the tool version, the rows revision, the network files and
/// runtime in use ([`eyereplay_extract::networks_fingerprint`]; rows made
/// with other networks are not these) and, for the attention mesh, the
/// model's name.
pub fn extraction_cache_path_for(
    video: &Path,
    model: LandmarkModel,
    cache: &Path,
) -> Result<PathBuf> {
    let key = eyereplay_extract::keyed_by_extractor(
        ArtifactKey::of_file("extract", video, "csv")?.version("v", eyereplay_core::TOOL_VERSION),
    )?;
    let key = match model {
        LandmarkModel::Cascade => key,
        LandmarkModel::Attention => key.version("m", model.name()),
    };
    Ok(ArtifactCache::new(cache).path(&key))
}

/// Extracts every video not yet in the cache with the cascade (all at once,
/// so the extractor's workers share them) and returns each video's CSV.
/// Cached by the video's sha256 and the extractor version, so a renamed copy
/// is not extracted twice and a new extractor does not reuse old results.
pub fn extract_cached(
    videos: &[PathBuf],
    cache: &Path,
    progress: &dyn Progress,
) -> Result<Vec<PathBuf>> {
    extract_cached_with(videos, LandmarkModel::Cascade, cache, progress)
}

/// [`extract_cached`] with the landmark networks `model`.
pub fn extract_cached_with(
    videos: &[PathBuf],
    model: LandmarkModel,
    cache: &Path,
    progress: &dyn Progress,
) -> Result<Vec<PathBuf>> {
    let mut csvs = Vec::with_capacity(videos.len());
    let mut todo: Vec<(PathBuf, PathBuf)> = Vec::new();
    for v in videos {
        if v.is_dir() {
            return Err(Error::input(v, "a folder, not a video"));
        }
        if !v.is_file() {
            return Err(Error::input(v, "no such video"));
        }
        let csv = extraction_cache_path_for(v, model, cache)?;
        if csv.is_file() {
            tracing::info!("{}: extraction cached as {}", v.display(), csv.display());
            // What the extraction said of the video (cut short, small
            // eyes) is said again: the video has not changed.
            if let Ok(text) = std::fs::read_to_string(warnings_path(&csv)) {
                for w in text.lines().filter(|l| !l.is_empty()) {
                    progress.warn(&format!("warning: {}: {w}", v.display()));
                }
            }
        } else if !todo.iter().any(|(_, c)| *c == csv) {
            todo.push((v.clone(), csv.clone()));
        }
        csvs.push(csv);
    }
    if todo.is_empty() {
        return Ok(csvs);
    }
    check_models()?;
    let paths: Vec<PathBuf> = todo.iter().map(|(v, _)| v.clone()).collect();
    progress.begin(Stage::Extract, 0);
    let results = eyereplay_extract::extract_many(
        &paths,
        &eyereplay_extract::ExtractOptions {
            landmarks: model,
            ..Default::default()
        },
        &StageFrames(progress),
    );
    progress.end(Stage::Extract);
    for ((video, csv), r) in todo.iter().zip(results) {
        let ex = r?;
        // Kept beside the rows, before them (rows in the cache mean their
        // warnings are too), for later cache hits to say again.
        if !ex.warnings.is_empty() {
            let text: String = ex.warnings.iter().map(|w| format!("{w}\n")).collect();
            eyereplay_core::atomic_write(&warnings_path(csv), text.as_bytes())?;
        }
        eyereplay_extract::save_csv(csv, &ex.rows)?;
        for w in &ex.warnings {
            progress.warn(&format!("warning: {}: {w}", video.display()));
        }
        progress.info(&format!(
            "extracted {} ({} landmarks): {} frames, face in {:.1} %, cached as {}",
            video.display(),
            model.name(),
            ex.rows.len(),
            100.0 * ex.detection_rate(),
            csv.display()
        ));
    }
    Ok(csvs)
}

/// The cached extraction `csv`'s warnings, one a line (absent: none).
fn warnings_path(csv: &Path) -> PathBuf {
    let mut name = csv.as_os_str().to_owned();
    name.push(".warnings");
    PathBuf::from(name)
}

/// Fails with the command that fetches the models when they are missing.
pub fn check_models() -> Result<()> {
    let dir = eyereplay_extract::default_models_dir();
    eyereplay_extract::check_models(&dir)?;
    Ok(())
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

    #[test]
    fn a_video_read_with_both_models_is_extracted_once_per_model() {
        let cfg = DatasetConfig::parse(
            r#"
[classes.reading]
sources = [{ format = "video", path = "a.mp4" }, { format = "video", path = "a.mp4", landmarks = "attention" }]
[classes.conversation]
sources = [{ format = "video", path = "a.mp4", landmarks = "cascade" }, { format = "video", path = "b.mp4", landmarks = "attention" }]
"#,
        )
        .unwrap();
        let got: Vec<(String, &str)> = video_extractions(&cfg)
            .iter()
            .map(|(p, l)| (p.display().to_string(), l.name()))
            .collect();
        assert_eq!(
            got,
            [
                ("a.mp4".to_string(), "cascade"),
                ("a.mp4".to_string(), "attention"),
                ("b.mp4".to_string(), "attention")
            ]
        );
        assert_eq!(video_sources(&cfg).len(), 2);
    }

    #[test]
    fn an_unknown_landmark_model_is_refused_with_its_names() {
        let e = DatasetConfig::parse(
            r#"
[classes.reading]
sources = [{ format = "video", path = "a.mp4", landmarks = "mesh" }]
"#,
        )
        .unwrap_err()
        .to_string();
        assert!(
            e.contains("mesh") && e.contains("cascade") && e.contains("attention"),
            "{e}"
        );
    }

    #[test]
    fn each_landmark_model_and_set_of_networks_has_its_own_cache_file() {
        let dir = tempfile::tempdir().unwrap();
        let video = dir.path().join("v.mp4");
        std::fs::write(&video, b"not really a video").unwrap();
        let cache = dir.path().join("cache");
        let cascade = extraction_cache_path_for(&video, LandmarkModel::Cascade, &cache).unwrap();
        let attention =
            extraction_cache_path_for(&video, LandmarkModel::Attention, &cache).unwrap();
        assert_eq!(cascade, extraction_cache_path(&video, &cache).unwrap());
        assert_ne!(cascade, attention);
        // The key holds the networks in use, so another models folder's rows
        // are never taken for these.
        let networks =
            eyereplay_extract::networks_fingerprint(&eyereplay_extract::default_models_dir())
                .unwrap();
        let key = ArtifactKey::of_file("extract", &video, "csv")
            .unwrap()
            .version("v", eyereplay_core::TOOL_VERSION)
            .version("r", eyereplay_extract::ROWS_REVISION)
            .version("n", &networks);
        assert_eq!(cascade, ArtifactCache::new(&cache).path(&key));
        assert_eq!(
            attention,
            ArtifactCache::new(&cache).path(&key.version("m", LandmarkModel::Attention.name()))
        );
    }
}
