//! Stages 2-5 at the paper's scale: 310,000 source frames from 16 webcam
//! recordings -> 144 sessions x 7,500 frames, written to disk.
//!
//! Prints the wall time against the 2 s budget, and the write phase against
//! plain disk speed measured in the same run (writing the same number of
//! bytes with one `write_all` per file).
//!
//! Run: `cargo bench -p eyereplay-prepare --bench prepare`

use eyereplay_core::{GazeClass, NormPos, Sample, Trajectory};
use eyereplay_dataset::{write_dataset, ToolInfo};
use eyereplay_prepare::{prepare, DatasetConfig, SourceInput};
use eyereplay_sources::{Recording, RecordingKind};
use std::time::Instant;

fn recording(id: usize, frames: usize) -> Recording {
    // A deterministic fixation/saccade pattern with jitter at ~24 fps.
    let mut seed = id as u64 * 7919 + 1;
    let mut rnd = move || {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (seed >> 11) as f64 / (1u64 << 53) as f64
    };
    let mut target = NormPos { nx: 0.5, ny: 0.5 };
    let samples = (0..frames)
        .map(|i| {
            if i % 8 == 0 {
                target = NormPos {
                    nx: 0.4 + 0.2 * rnd(),
                    ny: 0.4 + 0.2 * rnd(),
                };
            }
            let t = i as f64 / 24.0 + 0.003 * rnd();
            Sample::new(
                t,
                NormPos {
                    nx: target.nx + 0.004 * (rnd() - 0.5),
                    ny: target.ny + 0.004 * (rnd() - 0.5),
                },
            )
        })
        .collect();
    Recording {
        id: format!("synthetic_{id}.csv"),
        path: format!("synthetic_{id}.csv").into(),
        kind: RecordingKind::Video,
        rate_hz: 24.0,
        segments: vec![Trajectory::new(samples).unwrap()],
        px_per_deg: None,
    }
}

fn main() {
    let src = |class| {
        format!("[classes.{class}]\nsessions = 72\nsources = [{{ format = \"extract\", path = \"x.csv\" }}]\n")
    };
    let cfg = DatasetConfig::parse(&format!("{}{}", src("reading"), src("conversation"))).unwrap();
    let inputs: Vec<SourceInput> = (0..16)
        .map(|i| SourceInput {
            class: if i < 11 {
                GazeClass::Reading
            } else {
                GazeClass::Conversation
            },
            recording: recording(i, 310_000 / 16),
            file: format!("synthetic_{i}.csv"),
            format: "extract".into(),
            sha256: String::new(),
            behaviour: None,
        })
        .collect();
    let dir = tempfile::tempdir().unwrap();
    let tool = ToolInfo {
        name: "eyereplay".into(),
        version: "bench".into(),
        git_revision: None,
        models: vec![],
    };

    let t0 = Instant::now();
    let prepared = prepare(&cfg, &inputs).unwrap();
    let t_prepare = t0.elapsed().as_secs_f64();
    let t1 = Instant::now();
    let (_, summary) = write_dataset(dir.path(), &cfg, &prepared, tool).unwrap();
    let t_write = t1.elapsed().as_secs_f64();
    let total = t0.elapsed().as_secs_f64();

    // Peer: the same bytes written as plain files, no formatting.
    let peer_dir = tempfile::tempdir().unwrap();
    let per_file = vec![b'7'; (summary.bytes / 144) as usize];
    let t2 = Instant::now();
    for i in 0..144 {
        std::fs::write(peer_dir.path().join(format!("{i}.csv")), &per_file).unwrap();
    }
    let t_disk = t2.elapsed().as_secs_f64();

    println!("prepare: 310000 source frames -> 144 x 7500 frames");
    println!("  stages 2-5      {:>8.3} s", t_prepare);
    println!(
        "  write dataset   {:>8.3} s  ({} files, {:.1} MB)",
        t_write,
        summary.files,
        summary.bytes as f64 / 1e6
    );
    println!(
        "  total           {:>8.3} s  = {:.2} x the 2 s budget",
        total,
        total / 2.0
    );
    println!(
        "  plain disk write of the same bytes {:.3} s: dataset writing is {:.2} x disk speed",
        t_disk,
        t_write / t_disk
    );
}
