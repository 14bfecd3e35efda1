//! One module per subcommand; each exposes `Args` (clap) and `run`.
pub mod evaluate;
pub mod extract;
pub mod models;
pub mod prepare;
pub mod render;

pub mod generate;
pub mod merge;
pub mod shard;

use anyhow::{bail, Context, Result};
use eyereplay_prepare::{DatasetConfig, PrepareError};
use eyereplay_sources::SourceSpec;
use indicatif::{ProgressBar, ProgressStyle};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Two numbers joined by one of `seps`, as in `--shard 0/4` or `--size
/// 1280x720`; errors name the flag, the value and the expected form.
pub fn parse_usize_pair(
    flag: &str,
    s: &str,
    seps: &[char],
    form: &str,
    names: [&str; 2],
) -> Result<(usize, usize)> {
    let (a, b) = s
        .split_once(seps)
        .with_context(|| format!("{flag} '{s}': expected {form}"))?;
    let num = |v: &str, name: &str| -> Result<usize> {
        v.trim()
            .parse()
            .with_context(|| format!("{flag} '{s}': {name} is not a number"))
    };
    Ok((num(a, names[0])?, num(b, names[1])?))
}

/// Resolved paths of the config's video sources, in config order.
pub fn video_sources(cfg: &DatasetConfig) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = cfg
        .classes
        .values()
        .flat_map(|c| c.sources.iter())
        .filter(|s| matches!(s, SourceSpec::Video { .. }))
        .map(|s| cfg.resolve(s.path()))
        .collect();
    v.dedup();
    v
}

/// Where cached extractions live: `--cache`, `$EYEREPLAY_CACHE`, or
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
        _ => bail!(
            "{}: cannot run ffmpeg; install it with 'apt-get install ffmpeg' (or scripts/setup.sh)",
            ffmpeg.display()
        ),
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

/// Extracts every video source not yet in the cache and returns, for each
/// video, its iris CSV. Cached by the video's sha256 and the extractor
/// version, so a renamed copy is not extracted twice and a new extractor
/// does not reuse old results.
pub fn extract_videos_cached(
    cfg: &DatasetConfig,
    cache: &Path,
) -> Result<BTreeMap<PathBuf, PathBuf>> {
    let videos = video_sources(cfg);
    let mut out = BTreeMap::new();
    let mut todo: Vec<(PathBuf, PathBuf)> = Vec::new();
    for v in videos {
        let sha = eyereplay_core::sha256_file(&v)?;
        let csv = cache
            .join("extract")
            .join(format!("{sha}-v{}.csv", env!("CARGO_PKG_VERSION")));
        if !csv.is_file() {
            todo.push((v.clone(), csv.clone()));
        }
        out.insert(v, csv);
    }
    if todo.is_empty() {
        return Ok(out);
    }
    let paths: Vec<PathBuf> = todo.iter().map(|(v, _)| v.clone()).collect();
    let bar = ProgressBar::new(0);
    bar.set_style(
        ProgressStyle::with_template(
            "extract {bar:30} {human_pos}/{human_len} frames, {per_sec}, ETA {eta}",
        )
        .expect("static template"),
    );
    let progress = TotalBar { bar: &bar };
    let results = eyereplay_extract::extract_many(
        &paths,
        &eyereplay_extract::ExtractOptions::default(),
        &progress,
    );
    bar.finish_and_clear();
    for ((video, csv), r) in todo.iter().zip(results) {
        let ex = r.with_context(|| video.display().to_string())?;
        eyereplay_extract::save_csv(csv, &ex.rows).with_context(|| csv.display().to_string())?;
        println!(
            "extracted {}: {} frames, face in {:.1} %, cached as {}",
            video.display(),
            ex.rows.len(),
            100.0 * ex.detection_rate(),
            csv.display()
        );
    }
    Ok(out)
}

struct TotalBar<'a> {
    bar: &'a ProgressBar,
}

impl eyereplay_extract::Progress for TotalBar<'_> {
    fn start(&self, _video: usize, frames: Option<u64>) {
        if let Some(n) = frames {
            self.bar.inc_length(n);
        }
    }
    fn advance(&self, _video: usize, n: u64) {
        self.bar.inc(n);
    }
}

/// The cached CSV of a video extracted by [`extract_videos_cached`].
pub fn lookup_extracted(
    map: &BTreeMap<PathBuf, PathBuf>,
    video: &Path,
) -> Result<PathBuf, PrepareError> {
    map.get(video).cloned().ok_or_else(|| PrepareError::Source {
        id: video.display().to_string(),
        message: "video was not extracted".into(),
    })
}

/// sha256 of the model files (`*.onnx`, `*.tflite`), sorted by name.
pub fn model_digests() -> Result<Vec<eyereplay_prepare::FileDigest>> {
    let dir = eyereplay_extract::default_models_dir();
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .with_context(|| dir.display().to_string())?
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
            Ok(eyereplay_prepare::FileDigest {
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
