//! Stage-level behaviour on small hand-built recordings whose right answer is
//! known by hand: the blink filter per axis, the rate rule of the resampler,
//! and which samples feed the calibration percentiles.

use eyereplay_core::{GazeClass, NormPos, Sample, Trajectory};
use eyereplay_prepare::{
    prepare, DatasetConfig, PrepareError, Prepared, ResampleMethod, SourceInput,
};
use eyereplay_sources::{read_source, ReadOptions, Recording, RecordingKind, SourceSpec};

/// A config for one conversation source; `extra` adds top-level tables.
fn config(session_frames: usize, extra: &str) -> DatasetConfig {
    let text = format!(
        "session_frames = {session_frames}\n{extra}\n[classes.conversation]\nsessions = 1\nsources = [{{ format = \"extract\", path = \"unused.csv\" }}]\n"
    );
    let cfg = DatasetConfig::parse(&text).unwrap();
    cfg.validate().unwrap();
    cfg
}

const MANUAL: &str = "[calibration]\nmode = \"manual\"\ns_x = 1000.0\ns_y = 1000.0\nmu_x = 640.0\nmu_y = 360.0\n[smoothing]\nmethod = \"none\"\n";

fn input(samples: Vec<Sample<NormPos>>, rate_hz: f64, kind: RecordingKind) -> SourceInput {
    SourceInput {
        class: GazeClass::Conversation,
        recording: Recording {
            id: "hand.csv".into(),
            path: "hand.csv".into(),
            kind,
            rate_hz,
            segments: vec![Trajectory::new(samples).unwrap()],
            px_per_deg: None,
        },
        file: "hand.csv".into(),
        format: "extract".into(),
        sha256: String::new(),
        behaviour: None,
    }
}

fn run(cfg: &DatasetConfig, inputs: &[SourceInput]) -> Result<Prepared, PrepareError> {
    prepare(cfg, inputs)
}

#[test]
fn blink_filter_replaces_only_the_axis_outside_its_fence() {
    // 20 frames at 25 fps; nx spikes at frame 10 (a landmark glitch on x),
    // ny is a steady ramp well inside its fence. The paper's rule is per
    // axis: y at frame 10 must follow the ramp, x holds frame 9's value.
    let samples: Vec<Sample<NormPos>> = (0..20)
        .map(|i| {
            let nx = if i == 10 {
                0.95
            } else {
                0.5 + 0.001 * (i % 3) as f64
            };
            Sample::new(
                i as f64 / 25.0,
                NormPos {
                    nx,
                    ny: 0.40 + 0.01 * i as f64,
                },
            )
        })
        .collect();
    let cfg = config(20, MANUAL);
    let p = run(&cfg, &[input(samples, 25.0, RecordingKind::Video)]).unwrap();
    let s = &p.classes[0].sessions[0];
    assert_eq!(s.len(), 20);
    // One source: its normalization shift is the global mean minus its own
    // mean, zero up to rounding, and speed scale 1 for conversation; at 25
    // fps onto 25 fps every frame is a sample, so alpha = 1. So frame k sits
    // at c = 1000 (n - 0.5) + mu.
    for (k, f) in s.iter().enumerate() {
        let want_y = 1000.0 * (0.40 + 0.01 * k as f64 - 0.5) + 360.0;
        assert!(
            (f.y_px - want_y).abs() < 1e-6,
            "frame {k}: y {} vs {want_y}",
            f.y_px
        );
    }
    assert!(
        (s[10].x_px - s[9].x_px).abs() < 1e-9,
        "{:?} {:?}",
        s[9],
        s[10]
    );
    let filled = p.sources[0].filled;
    assert_eq!(
        (
            filled.outlier_x,
            filled.outlier_y,
            filled.invalid_or_blink,
            filled.total
        ),
        (1, 0, 0, 1),
        "{filled:?}"
    );
}

/// An extract CSV at `fps` starting 10 s into a video, timestamps written to
/// 0.1 ms as the extractor does: the measured rate carries rounding error
/// (50 fps measures as 50.000000000001 Hz).
fn extract_csv_at(dir: &std::path::Path, fps: f64) -> Recording {
    let mut s = String::from("frame,time_s,valid,nx,ny\n");
    for i in 0..20 {
        let t = 10.0 + i as f64 / fps;
        let nx = 0.5 + 0.02 * ((i * 7) % 5) as f64;
        let ny = 0.5 + 0.015 * ((i * 3) % 4) as f64;
        s.push_str(&format!("{i},{t:.4},1,{nx},{ny}\n"));
    }
    let p = dir.join(format!("v{fps}.csv"));
    std::fs::write(&p, s).unwrap();
    read_source(&SourceSpec::Extract { path: p }, &ReadOptions::default())
        .unwrap()
        .remove(0)
}

#[test]
fn a_50_fps_source_is_interpolated_and_corrected_a_60_fps_one_decimated() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = config(5, MANUAL);
    for (fps, method, applied) in [
        (50.0, ResampleMethod::Linear, true),
        (60.0, ResampleMethod::AntiAliasDecimate, false),
    ] {
        let rec = extract_csv_at(dir.path(), fps);
        assert!((rec.rate_hz - fps).abs() < 0.5, "{}", rec.rate_hz);
        let samples = rec.segments[0].samples().to_vec();
        let p = run(&cfg, &[input(samples, rec.rate_hz, RecordingKind::Video)]).unwrap();
        let sc = &p.sources[0].speed_correction;
        assert_eq!(
            (sc.method, sc.applied),
            (method, applied),
            "{fps} fps measured as {} Hz: {sc:?}",
            rec.rate_hz
        );
    }
}

#[test]
fn per_source_calibration_uses_every_sample() {
    // A 100 Hz recording whose every 4th sample (the ones thinning to about
    // one per 25 fps frame keeps) sits at the centre, the others on a wide
    // ramp. With scope = "per_source" nothing outweighs this source, so its
    // percentiles come from all samples: p5..p95 of all 400 values.
    let n = 400;
    let nx_of = |i: usize| {
        if (i / 4) * 4 == i {
            0.5 + 0.0001 * (i % 8) as f64
        } else {
            0.2 + 0.6 * i as f64 / n as f64
        }
    };
    let ny_of = |i: usize| 0.3 + 0.4 * ((i * 37) % n) as f64 / n as f64;
    let samples: Vec<Sample<NormPos>> = (0..n)
        .map(|i| {
            Sample::new(
                i as f64 / 100.0,
                NormPos {
                    nx: nx_of(i),
                    ny: ny_of(i),
                },
            )
        })
        .collect();
    let cfg = config(
        5,
        "[calibration]\nscope = \"per_source\"\n[smoothing]\nmethod = \"none\"\n",
    );
    let p = run(&cfg, &[input(samples, 100.0, RecordingKind::EyeTracker)]).unwrap();
    let c = p.sources[0].calibration;
    let xs: Vec<f64> = (0..n).map(nx_of).collect();
    let (lo, hi) = (
        eyereplay_signal::quantile(&xs, 0.05).unwrap(),
        eyereplay_signal::quantile(&xs, 0.95).unwrap(),
    );
    let want_s_x = 0.8 * 1280.0 / (hi - lo);
    assert!(
        (c.s_x - want_s_x).abs() < 1e-9 * want_s_x,
        "s_x {} vs {want_s_x} (all samples)",
        c.s_x
    );
}

/// 200 samples at 25 Hz on a slow walk inside the screen.
fn walk(n: usize) -> Vec<Sample<NormPos>> {
    (0..n)
        .map(|i| {
            Sample::new(
                i as f64 / 25.0,
                NormPos {
                    nx: 0.3 + 0.4 * ((i * 13) % n) as f64 / n as f64,
                    ny: 0.4 + 0.2 * ((i * 7) % n) as f64 / n as f64,
                },
            )
        })
        .collect()
}

#[test]
fn a_scale_too_large_for_any_number_is_refused_not_written_as_nan() {
    // s_x = 1e308 is finite, but the centred positions are not: the mean
    // of numbers near the largest float overflows.
    let big = MANUAL.replace("s_x = 1000.0", "s_x = 1e308");
    let cfg = config(5, &big);
    let Err(e) = run(&cfg, &[input(walk(200), 25.0, RecordingKind::EyeTracker)]) else {
        panic!("refused")
    };
    let e = e.to_string();
    assert!(
        e.starts_with("hand.csv: the calibration (s = (1.0000e308, 1.0000e3) px per unit n)"),
        "{e}"
    );
    // A zero scale is refused with the config, before anything is read.
    let zero = MANUAL.replace("s_x = 1000.0", "s_x = 0.0");
    let c = DatasetConfig::parse(&format!(
        "session_frames = 5\n{zero}\n[classes.conversation]\nsessions = 1\nsources = [{{ format = \"extract\", path = \"unused.csv\" }}]\n"
    ))
    .unwrap();
    let e = c.validate().unwrap_err().to_string();
    assert_eq!(
        e,
        "calibration.s_x must be a finite number other than 0, got 0"
    );
}

#[test]
fn a_source_mostly_filled_or_off_its_screen_is_warned_of() {
    let cfg = config(5, MANUAL);
    // Clean: no warning.
    let p = run(&cfg, &[input(walk(200), 25.0, RecordingKind::EyeTracker)]).unwrap();
    assert!(p.warnings.is_empty(), "{:?}", p.warnings);
    // 150 of 200 samples invalid: filled, and said to be (75.00 %).
    let mut s = walk(200);
    for x in &mut s[50..] {
        x.valid = false;
    }
    let p = run(&cfg, &[input(s, 25.0, RecordingKind::EyeTracker)]).unwrap();
    assert!(
        p.warnings.iter().any(|w| w
            == "hand.csv: 75.00 % of its 200 samples were invalid or blinks and were filled with the last valid one"),
        "{:?}",
        p.warnings
    );
    // Every sample a thousand screens to the right (a wrong screen_px).
    let mut s = walk(200);
    for x in &mut s {
        x.pos.nx += 1000.0;
    }
    let p = run(&cfg, &[input(s, 25.0, RecordingKind::EyeTracker)]).unwrap();
    assert!(
        p.warnings
            .iter()
            .any(|w| w.starts_with("hand.csv: 100.0 % of its gaze lies more than a screen away")),
        "{:?}",
        p.warnings
    );
}

/// A class that reuses its pool says how, in seconds and frames, and how
/// to mend it; the ratio alone read as jargon. 200 frames at 25 fps (8 s):
/// one 500-frame (20-s) session repeats them 2.5 times; with 50-frame
/// sessions, 8 of them step 200 / 8 = 25 frames, so consecutive ones share
/// 25 of their 50.
#[test]
fn a_reused_pool_is_said_in_seconds_and_with_the_fix() {
    let reuse_warning = |cfg: &DatasetConfig| {
        let p = run(cfg, &[input(walk(200), 25.0, RecordingKind::EyeTracker)]).unwrap();
        p.warnings
            .into_iter()
            .find(|w| w.contains("reuse ratio"))
            .unwrap()
    };
    let w = reuse_warning(&config(500, MANUAL));
    assert!(
        w.contains(
            "each 20-s session is longer than the class's 8 s of gaze, so it repeats it 2.5 times"
        ) && w.contains("add sources, or lower sessions or session_frames"),
        "{w}"
    );
    let text = format!(
        "session_frames = 50\n{MANUAL}\n[classes.conversation]\nsessions = 8\nsources = [{{ format = \"extract\", path = \"unused.csv\" }}]\n"
    );
    let w = reuse_warning(&DatasetConfig::parse(&text).unwrap());
    assert!(
        w.contains("consecutive sessions share 25 of their 50 frames (50 %)"),
        "{w}"
    );
}
