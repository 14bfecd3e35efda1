//! Stages 2-5 end to end on real recordings (OneStop reading fixations, raw
//! EyeLink and BIDS samples) and on hand-built webcam-like CSVs.

use eyereplay_core::LandmarkModel;
use eyereplay_core::{read_session_csv, CanvasPos, GazeClass};
use eyereplay_dataset::{write_dataset, ToolInfo};
use eyereplay_prepare::{load_sources, prepare, DatasetConfig, PrepareError};
use std::path::{Path, PathBuf};

/// The sample data folder; the test calling this is ignored (see build.rs)
/// when it was missing at build time.
fn cache() -> PathBuf {
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../.cache/data");
    assert!(
        p.join("onestop_fixations.csv").exists() && p.join("syelink/both_eyes.asc").exists(),
        "{} missing: run scripts/setup.sh",
        p.display()
    );
    p.canonicalize().unwrap()
}

fn real_config(data: &Path, dir: &Path) -> PathBuf {
    let cfg = format!(
        r#"
session_frames = 1500
seed = 7
[classes.reading]
sessions = 8
sources = [{{ format = "fixations", path = "{d}/onestop_fixations.csv", group_columns = ["participant_id", "TRIAL_INDEX"], amplitude_column = "NEXT_SAC_AMPLITUDE", screen_px = [2560, 1440] }}]
[classes.conversation]
sessions = 6
sources = [
  {{ format = "eyelink", path = "{d}/syelink/both_eyes.asc" }},
  {{ format = "bids", path = "{d}/bids/sub-01/beh/sub-01_task-reading_recording-eye1_physio.tsv.gz" }},
]
"#,
        d = data.display()
    );
    let p = dir.join("dataset.toml");
    std::fs::write(&p, cfg).unwrap();
    p
}

fn tool() -> ToolInfo {
    ToolInfo {
        name: "eyereplay".into(),
        version: "test".into(),
        git_revision: None,
        models: vec![],
    }
}

fn no_video(p: &Path, _: LandmarkModel) -> Result<PathBuf, PrepareError> {
    panic!("no video expected: {}", p.display())
}

#[test]
#[cfg_attr(
    not(has_sample_data),
    ignore = "needs .cache/data: run scripts/setup.sh"
)]
fn real_sources_make_a_complete_deterministic_dataset() {
    let data = cache();
    let dir = tempfile::tempdir().unwrap();
    let cfg = DatasetConfig::load(&real_config(&data, dir.path())).unwrap();
    let inputs = load_sources(&cfg, no_video).unwrap();
    assert_eq!(inputs.len(), 24 + 2);
    let prepared = prepare(&cfg, &inputs).unwrap();

    // Stage 4: after normalization every source's frames average to the global mean.
    for c in &prepared.classes {
        for src in 0..inputs.len() as u32 {
            let pts: Vec<CanvasPos> = c
                .pool
                .iter()
                .zip(&c.pool_source)
                .filter(|(_, s)| **s == src)
                .map(|(p, _)| *p)
                .collect();
            if pts.is_empty() {
                continue;
            }
            let m = eyereplay_core::mean_of(pts.iter().copied()).unwrap();
            assert!(
                (m.x_px - prepared.global_mean.x_px).abs() < 1e-6,
                "source {src}"
            );
            assert!(
                (m.y_px - prepared.global_mean.y_px).abs() < 1e-6,
                "source {src}"
            );
        }
    }
    // Fast sources are decimated, never speed-corrected.
    assert!(prepared.sources.iter().all(|s| !s.speed_correction.applied));
    // The EyeLink recordings have blinks: filled and counted.
    // EyeLink's own blink and tracking-loss flags are honoured; its real
    // wide saccades are not mistaken for blink spikes (the IQR rule is for
    // video landmarks).
    let f = prepared.sources[24].filled;
    assert!(
        f.invalid_or_blink > 500 && f.outlier_x + f.outlier_y == 0,
        "{f:?}"
    );

    let out_a = dir.path().join("a");
    let out_b = dir.path().join("b");
    write_dataset(&out_a, &cfg, &prepared, tool()).unwrap();
    // A second, independent run gives byte-identical files.
    let prepared2 = prepare(&cfg, &load_sources(&cfg, no_video).unwrap()).unwrap();
    write_dataset(&out_b, &cfg, &prepared2, tool()).unwrap();
    for f in [
        "labels.csv",
        "metadata.json",
        "pool/reading.csv",
        "reading/reading_0007.csv",
        "conversation/conversation_0005.csv",
    ] {
        assert_eq!(
            std::fs::read(out_a.join(f)).unwrap(),
            std::fs::read(out_b.join(f)).unwrap(),
            "{f}"
        );
    }

    // Stage 5: every session has F frames and follows idx = (i stride + j) mod T
    // on the speed-scaled pool.
    let reading = prepared
        .classes
        .iter()
        .find(|c| c.class == GazeClass::Reading)
        .unwrap();
    let t = reading.pool.len();
    let mut scaled = reading.pool.clone();
    eyereplay_prepare::scale_about_centroid(&mut scaled, 1.05);
    for i in 0..8 {
        let s = read_session_csv(&out_a.join(format!("reading/reading_{i:04}.csv"))).unwrap();
        assert_eq!(s.len(), 1500);
        for j in [0, 1, 777, 1499] {
            let want = scaled[(i * (t / 8) + j) % t];
            assert!((s[j].x_px - want.x_px).abs() <= 5e-4 && (s[j].y_px - want.y_px).abs() <= 5e-4);
        }
    }
    // EyeLink marks blinks: sessions carry a blink column, with blinks in it.
    let conv = std::fs::read_to_string(out_a.join("conversation/conversation_0000.csv")).unwrap();
    assert!(conv.starts_with("frame,x,y,blink\n"));
    let blink_frames: usize = (0..6)
        .map(|i| {
            std::fs::read_to_string(out_a.join(format!("conversation/conversation_{i:04}.csv")))
                .unwrap()
                .lines()
                .filter(|l| l.ends_with(",1"))
                .count()
        })
        .sum();
    assert!(blink_frames > 0);
    let labels = std::fs::read_to_string(out_a.join("labels.csv")).unwrap();
    assert_eq!(labels.lines().count(), 1 + 8 + 6);
    assert!(labels.contains("reading/reading_0000.csv,1,reading,onestop_fixations.csv#l37_1129/44"));
    assert!(labels.contains("conversation/conversation_0000.csv,0,conversation,both_eyes.asc"));
    let meta: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out_a.join("metadata.json")).unwrap()).unwrap();
    assert_eq!(meta["session_frames"], 1500);
    assert_eq!(meta["seed"], 7);
    assert_eq!(meta["sources"].as_array().unwrap().len(), 26);
    assert_eq!(meta["sources"][0]["sha256"].as_str().unwrap().len(), 64);
    assert!(meta["calibration"]["s_x"].as_f64().unwrap() > 0.0);
}

/// A webcam-like extract CSV: 24 fps with jittered timestamps, fixations on
/// a square pattern, and landmark jitter.
fn webcam_csv(path: &Path, seconds: usize, offset: f64) {
    let mut s = String::from("frame,time_s,valid,nx,ny,blink\n");
    for i in 0..seconds * 24 {
        let t = i as f64 / 24.0 + if i % 3 == 0 { 0.004 } else { 0.0 };
        let k = (i / 12) % 4;
        let (x, y) = [(0.45, 0.45), (0.55, 0.45), (0.55, 0.55), (0.45, 0.55)][k];
        let blink = i % 97 == 50;
        if blink {
            s.push_str(&format!("{i},{t:.4},0,,,1\n"));
        } else {
            // Landmark jitter: every sample turns a corner, which linear
            // interpolation cuts.
            let j = ((i * 7919) % 13) as f64 - 6.0;
            s.push_str(&format!(
                "{i},{t:.4},1,{:.5},{:.5},0\n",
                x + offset + 0.0004 * j,
                y + offset - 0.0003 * j
            ));
        }
    }
    std::fs::write(path, s).unwrap();
}

#[test]
fn webcam_sources_are_speed_corrected_and_centred() {
    let dir = tempfile::tempdir().unwrap();
    webcam_csv(&dir.path().join("a.csv"), 40, 0.0);
    webcam_csv(&dir.path().join("b.csv"), 30, 0.03);
    let cfgp = dir.path().join("d.toml");
    std::fs::write(
        &cfgp,
        "session_frames = 200\n[smoothing]\nmethod = \"none\"\n[classes.conversation]\nsessions = 5\nsources = [{ format = \"extract\", path = \"a.csv\" }, { format = \"extract\", path = \"b.csv\" }]\n",
    )
    .unwrap();
    let cfg = DatasetConfig::load(&cfgp).unwrap();
    let inputs = load_sources(&cfg, no_video).unwrap();
    let p = prepare(&cfg, &inputs).unwrap();
    for s in &p.sources {
        assert!(s.speed_correction.applied, "{s:?}");
        // Linear interpolation of square-wave corners loses path: alpha > 1.
        assert!(s.speed_correction.alpha > 1.0);
        // Every 97th frame is a blink, filled forward (7 in 30 s at 24 fps).
        assert!(s.filled.invalid_or_blink >= 7, "{:?}", s.filled);
    }
    // Offset source b is shifted onto the same global mean: its shift is
    // opposite in sign to a's, and their frames-weighted sum cancels.
    let (a, b) = (&p.sources[0], &p.sources[1]);
    let wx = a.normalization_shift_px[0] * a.frames as f64
        + b.normalization_shift_px[0] * b.frames as f64;
    assert!(wx.abs() < 1e-6 * a.frames as f64, "{wx}");
    assert!(a.normalization_shift_px[0] > 0.0 && b.normalization_shift_px[0] < 0.0);
    // The files written are in config order in metadata.
    assert_eq!(a.file, "a.csv");
}

#[test]
fn too_few_frames_for_the_sessions_is_an_error() {
    let dir = tempfile::tempdir().unwrap();
    webcam_csv(&dir.path().join("a.csv"), 2, 0.0);
    let cfgp = dir.path().join("d.toml");
    std::fs::write(&cfgp, "[classes.reading]\nsessions = 72\nsources = [{ format = \"extract\", path = \"a.csv\" }]\n").unwrap();
    let cfg = DatasetConfig::load(&cfgp).unwrap();
    let e = prepare(&cfg, &load_sources(&cfg, no_video).unwrap())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("class 'reading'") && e.contains("72 sessions"),
        "{e}"
    );
}

#[test]
fn missing_sources_are_all_named_before_any_work() {
    let dir = tempfile::tempdir().unwrap();
    let cfgp = dir.path().join("d.toml");
    std::fs::write(
        &cfgp,
        "[classes.reading]\nsources = [{ format = \"extract\", path = \"nope1.csv\" }, { format = \"eyelink\", path = \"nope2.asc\" }]\n",
    )
    .unwrap();
    let cfg = DatasetConfig::load(&cfgp).unwrap();
    let e = load_sources(&cfg, no_video).unwrap_err().to_string();
    assert!(
        e.contains("nope1.csv") && e.contains("nope2.asc") && !e.contains('\n'),
        "{e}"
    );
}

/// One recording as a source of both classes, under its own name or a
/// copy's: refused before any reading, both classes named. A copy in one
/// class twice is not refused (the same label).
#[test]
fn a_recording_in_two_classes_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let body: String = std::iter::once("time_ms,x,y\n".to_string())
        .chain((0..100).map(|k| format!("{},{},{}\n", 2 * k, 400 + k, 300 + (k * 7) % 50)))
        .collect();
    std::fs::write(dir.path().join("a.csv"), &body).unwrap();
    std::fs::write(dir.path().join("copy.csv"), &body).unwrap();
    let src = |f: &str| format!("{{ format = \"csv\", path = \"{f}\", screen_px = [1280, 720] }}");
    let cfg = |reading: &str, conversation: &str| {
        let text = format!(
            "session_frames = 5\n[classes.reading]\nsessions = 1\nsources = [{reading}]\n\
             [classes.conversation]\nsessions = 1\nsources = [{conversation}]\n"
        );
        let mut c = DatasetConfig::parse(&text).unwrap();
        c.base_dir = dir.path().to_path_buf();
        c
    };
    let refused = |c: DatasetConfig| {
        load_sources(&c, |_, _| unreachable!("no video"))
            .err()
            .map(|e| e.to_string())
    };
    let e = refused(cfg(&src("a.csv"), &src("a.csv"))).unwrap();
    assert!(
        e.contains("a.csv: listed in class 'reading' and in class 'conversation'"),
        "{e}"
    );
    let e = refused(cfg(&src("a.csv"), &src("copy.csv"))).unwrap();
    assert!(
        e.contains("copy.csv: the same recording as a.csv (sha256 ")
            && e.contains("each recording belongs to one class"),
        "{e}"
    );
    let twice = format!("{}, {}", src("a.csv"), src("copy.csv"));
    let other = dir.path().join("b.csv");
    std::fs::write(&other, body.replace("400", "401")).unwrap();
    assert_eq!(refused(cfg(&twice, &src("b.csv"))), None);
}

/// A relative source path is taken from the config's folder. One that
/// exists only from the current folder (the tests run in the crate's, where
/// `Cargo.toml` is) is refused with what was probably meant.
#[test]
fn a_path_written_from_the_current_folder_is_named_so() {
    let dir = tempfile::tempdir().unwrap();
    let text = "session_frames = 5\n[classes.reading]\nsessions = 1\n\
                sources = [{ format = \"csv\", path = \"Cargo.toml\", screen_px = [1280, 720] }]\n";
    let mut cfg = DatasetConfig::parse(text).unwrap();
    cfg.base_dir = dir.path().to_path_buf();
    let e = eyereplay_prepare::check_source_files(&cfg)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("taken from its own folder")
            && e.contains("Cargo.toml exists from the current folder instead"),
        "{e}"
    );
    // Written from the config's folder: no such line.
    std::fs::write(dir.path().join("Cargo.toml"), "x").unwrap();
    assert!(eyereplay_prepare::check_source_files(&cfg).is_ok());
}
