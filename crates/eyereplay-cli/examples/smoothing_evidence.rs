//! What EdgeGauss smoothing does to the paper's fixation/saccade metrics on
//! real webcam trajectories, for choosing its default.
//!
//! ```text
//! eyereplay extract .cache/data/franck.mp4 --out target/franck_iris.csv
//! cargo run --release -p eyereplay-cli --example smoothing_evidence -- target/franck_iris.csv
//! ```
//!
//! Each extract CSV goes through stages 2-4 exactly as `eyereplay prepare`
//! runs them (auto-scale to the 1280x720 canvas, blink filter, resampling to
//! 25 fps with speed correction), once per smoothing setting; the metrics are
//! the paper's I-VT ones (fixations below 5 px/frame, saccades above 15).

use eyereplay_eval::{IvtThresholds, MetricSamples};
use eyereplay_prepare::{load_sources, prepare, DatasetConfig, PrepareError};
use std::path::{Path, PathBuf};

fn main() -> anyhow::Result<()> {
    let files: Vec<PathBuf> = std::env::args().skip(1).map(PathBuf::from).collect();
    anyhow::ensure!(!files.is_empty(), "usage: smoothing_evidence IRIS.csv...");
    let settings: [(&str, &str); 5] = [
        ("none", "method = \"none\""),
        ("edge_gauss sigma 0.04 s", "sigma_s = 0.04"),
        ("edge_gauss sigma 0.08 s", "sigma_s = 0.08"),
        ("edge_gauss sigma 0.12 s (default)", "sigma_s = 0.12"),
        ("edge_gauss sigma 0.20 s", "sigma_s = 0.20"),
    ];
    for f in &files {
        println!("{}", f.display());
        println!(
            "  {:<36} {:>12} {:>11} {:>10} {:>12} {:>10} {:>12}",
            "smoothing",
            "median speed",
            "frames < 5",
            "fixations",
            "median fix",
            "saccades",
            "median amp"
        );
        for (name, toml) in settings {
            let m = metrics(f, toml)?;
            let min = m.duration_s(25.0) / 60.0;
            let frac_slow = m.speed_px_per_frame.iter().filter(|s| **s < 5.0).count() as f64
                / m.speed_px_per_frame.len().max(1) as f64;
            println!(
                "  {:<36} {:>9.2} px {:>10.1}% {:>7.1}/min {:>9.0} fr {:>7.1}/min {:>9.1} px",
                name,
                median(&m.speed_px_per_frame),
                100.0 * frac_slow,
                m.fixation_duration_frames.len() as f64 / min,
                median(&m.fixation_duration_frames),
                m.saccade_amplitude_px.len() as f64 / min,
                median(&m.saccade_amplitude_px),
            );
        }
    }
    Ok(())
}

fn metrics(file: &Path, smoothing: &str) -> anyhow::Result<MetricSamples> {
    let mut cfg = DatasetConfig::parse(&format!(
        "session_frames = 1\n[smoothing]\n{smoothing}\n[classes.conversation]\nsessions = 1\nsources = [{{ format = \"extract\", path = {:?} }}]\n",
        file.display().to_string()
    ))
    .map_err(anyhow::Error::msg)?;
    cfg.base_dir = PathBuf::from(".");
    let inputs = load_sources(&cfg, |p, _| -> Result<PathBuf, PrepareError> {
        Ok(p.to_path_buf())
    })?;
    let p = prepare(&cfg, &inputs)?;
    let mut m = MetricSamples::default();
    let c = &p.classes[0];
    // One segment per source, as the evaluation does.
    let mut start = 0;
    while start < c.pool.len() {
        let src = c.pool_source[start];
        let end = (start..c.pool.len())
            .find(|&i| c.pool_source[i] != src)
            .unwrap_or(c.pool.len());
        let pts: Vec<[f64; 2]> = c.pool[start..end]
            .iter()
            .map(|q| [q.x_px, q.y_px])
            .collect();
        m.add_segment(&pts, &IvtThresholds::default());
        start = end;
    }
    Ok(m)
}

fn median(v: &[f64]) -> f64 {
    eyereplay_signal::median(v).unwrap_or(f64::NAN)
}
