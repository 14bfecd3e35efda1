//! A small synthetic dataset in the layout `eyereplay prepare` writes:
//! labels.csv, metadata.json, <class>/<class>_NNNN.csv, pool/<class>.csv.
//! Reading: fixations with small jitter, rightward saccades along a line,
//! a long return sweep at line end. Conversation: centre-biased wandering
//! with occasional large gaze shifts and held-position runs (blinks).
#![allow(dead_code)]

use eyereplay_core::{Calibration, Canvas, GazeClass};
use eyereplay_dataset::{write_metadata, DatasetMetadata};
use eyereplay_prepare::SourceReport;
use std::fmt::Write;
use std::path::Path;

/// A source entry of metadata.json with the given index, class, recording
/// kind and calibration `[s_x, s_y, mu_x, mu_y]` (the rest as `prepare`
/// writes it for a fixation report).
pub fn source(index: usize, class: &str, kind: &str, cal: [f64; 4]) -> SourceReport {
    serde_json::from_value(serde_json::json!({
        "index": index, "id": format!("s{index}"), "class": class, "file": "s.csv",
        "format": "fixations", "sha256": "0", "kind": kind, "rate_hz": 1000.0,
        "samples": 100, "segments": 1, "duration_s": 0.1, "frames": 3, "px_per_deg": null,
        "filled": {"invalid_or_blink": 0, "outlier_x": 0, "outlier_y": 0, "total": 0, "samples": 100},
        "calibration": {"s_x": cal[0], "s_y": cal[1], "mu_x": cal[2], "mu_y": cal[3]},
        "smoothing": null,
        "speed_correction": {"method": "linear", "applied": false, "alpha": 1.0,
            "path_length_orig_px": 1.0, "path_length_resampled_px": 1.0},
        "normalization_shift_px": [0.0, 0.0]
    }))
    .expect("a source report")
}

/// metadata.json for a hand-assembled dataset: 1280x720 canvas, the given
/// rate, session length, pooled calibration, `(class, sessions,
/// pool_frames)` and sources.
pub fn write_meta(
    dir: &Path,
    fps: f64,
    session_frames: usize,
    calibration: Option<[f64; 4]>,
    classes: &[(GazeClass, usize, usize)],
    sources: Vec<SourceReport>,
) {
    let cal = calibration.map(|c| Calibration {
        s_x: c[0],
        s_y: c[1],
        mu_x: c[2],
        mu_y: c[3],
    });
    let mut m = DatasetMetadata::assembled(fps, session_frames, Canvas::default(), cal, classes);
    m.sources = sources;
    write_metadata(dir, &m).unwrap();
}

pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Rng(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1)
    }
    pub fn uniform(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
    pub fn normal(&mut self) -> f64 {
        let (u, v) = (self.uniform().max(1e-300), self.uniform());
        (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
    }
}

pub fn reading_source(n: usize, seed: u64) -> Vec<[f64; 2]> {
    let mut r = Rng::new(seed);
    let (x0, y0) = (580.0, 330.0);
    let mut p = [x0, y0];
    let mut line = 0;
    let mut out = Vec::with_capacity(n);
    while out.len() < n {
        // fixation 5-9 frames
        let fix = 5 + (r.uniform() * 5.0) as usize;
        for _ in 0..fix {
            p = [p[0] + r.normal() * 0.8, p[1] + r.normal() * 0.6];
            out.push(p);
        }
        if p[0] > x0 + 110.0 {
            // return sweep over 3 frames, next line
            line = (line + 1) % 6;
            let target = [x0 + r.normal() * 3.0, y0 + line as f64 * 12.0];
            for k in 1..=3 {
                let t = k as f64 / 3.0;
                out.push([p[0] + (target[0] - p[0]) * t, p[1] + (target[1] - p[1]) * t]);
            }
            p = target;
        } else {
            // forward saccade 2 frames of 10-16 px each
            for _ in 0..2 {
                p = [p[0] + 10.0 + r.uniform() * 8.0, p[1] + r.normal()];
                out.push(p);
            }
        }
    }
    out.truncate(n);
    out
}

pub fn conversation_source(n: usize, seed: u64) -> Vec<[f64; 2]> {
    let mut r = Rng::new(seed);
    let c = [640.0, 360.0];
    let mut p = c;
    let mut out = Vec::with_capacity(n);
    while out.len() < n {
        let fix = 8 + (r.uniform() * 20.0) as usize;
        for _ in 0..fix {
            p = [
                p[0] + r.normal() * 1.5 + (c[0] - p[0]) * 0.02,
                p[1] + r.normal() * 1.5 + (c[1] - p[1]) * 0.02,
            ];
            out.push(p);
        }
        if r.uniform() < 0.15 {
            for _ in 0..4 {
                out.push(p); // blink: held position
            }
        }
        let target = [c[0] + r.normal() * 90.0, c[1] + r.normal() * 50.0];
        let steps = 2 + (r.uniform() * 2.0) as usize;
        let start = p;
        for k in 1..=steps {
            let t = k as f64 / steps as f64;
            p = [
                start[0] + (target[0] - start[0]) * t,
                start[1] + (target[1] - start[1]) * t,
            ];
            out.push(p);
        }
    }
    out.truncate(n);
    out
}

pub struct Spec {
    pub fps: f64,
    pub session_frames: usize,
    pub sessions_per_class: usize,
    pub source_frames: usize,
    pub sources_per_class: usize,
}

impl Default for Spec {
    fn default() -> Self {
        Spec {
            fps: 25.0,
            session_frames: 1000,
            sessions_per_class: 4,
            source_frames: 1500,
            sources_per_class: 2,
        }
    }
}

/// Writes the dataset; sessions are circular slices of the pool (paper
/// appendix), so they overlap like the real ones.
pub fn write_dataset(dir: &Path, spec: &Spec) {
    std::fs::create_dir_all(dir.join("pool")).unwrap();
    let mut labels = String::from("file,label,class,sources\n");
    for (ci, class) in ["reading", "conversation"].iter().enumerate() {
        let mut pool: Vec<([f64; 2], usize)> = Vec::new();
        for s in 0..spec.sources_per_class {
            let seed = (ci * 100 + s) as u64 + 7;
            let tr = if ci == 0 {
                reading_source(spec.source_frames, seed)
            } else {
                conversation_source(spec.source_frames, seed)
            };
            pool.extend(tr.into_iter().map(|p| (p, ci * 10 + s)));
        }
        let mut pcsv = String::from("frame,x,y,source\n");
        for (i, (p, s)) in pool.iter().enumerate() {
            writeln!(pcsv, "{i},{:.3},{:.3},{s}", p[0], p[1]).unwrap();
        }
        std::fs::write(dir.join("pool").join(format!("{class}.csv")), pcsv).unwrap();
        std::fs::create_dir_all(dir.join(class)).unwrap();
        let t = pool.len();
        let stride = t / spec.sessions_per_class;
        for i in 0..spec.sessions_per_class {
            let mut s = String::from("frame,x,y\n");
            for j in 0..spec.session_frames {
                let p = pool[(i * stride + j) % t].0;
                writeln!(s, "{j},{:.3},{:.3}", p[0], p[1]).unwrap();
            }
            let rel = format!("{class}/{class}_{i:04}.csv");
            std::fs::write(dir.join(&rel), s).unwrap();
            let label = if ci == 0 { 1 } else { 0 };
            writeln!(labels, "{rel},{label},{class},{}", ci * 10).unwrap();
        }
    }
    std::fs::write(dir.join("labels.csv"), labels).unwrap();
    let pool_frames = spec.sources_per_class * spec.source_frames;
    write_meta(
        dir,
        spec.fps,
        spec.session_frames,
        Some([1000.0, 600.0, 640.0, 360.0]),
        &[
            (GazeClass::Reading, spec.sessions_per_class, pool_frames),
            (
                GazeClass::Conversation,
                spec.sessions_per_class,
                pool_frames,
            ),
        ],
        Vec::new(),
    );
}
