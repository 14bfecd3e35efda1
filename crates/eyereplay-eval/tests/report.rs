//! Whole-dataset evaluation: hand-worked values on a tiny dataset, the
//! report's contents, byte-identical reruns, and the bad-input errors.

mod common;

use eyereplay_eval::json::Json;
use eyereplay_eval::{evaluate_dataset, metrics_json, write_report, EvalConfig};
use std::fmt::Write;
use std::path::Path;

fn walk(x0: f64, steps: &[f64]) -> Vec<[f64; 2]> {
    let mut p = vec![[x0, 100.0]];
    for s in steps {
        let l = *p.last().unwrap();
        p.push([l[0] + s, 100.0]);
    }
    p
}

fn csv3(points: &[[f64; 2]]) -> String {
    let mut s = String::from("frame,x,y\n");
    for (i, p) in points.iter().enumerate() {
        writeln!(s, "{i},{},{}", p[0], p[1]).unwrap();
    }
    s
}

/// Pool: two source segments, far apart (the join would be a 1000 px jump
/// if it were counted). Sessions of 5 frames.
fn tiny_dataset(dir: &Path) {
    std::fs::create_dir_all(dir.join("pool")).unwrap();
    let seg0 = walk(0.0, &[1.0, 1.0, 1.0, 20.0, 30.0, 1.0, 1.0]); // fix 3,2; sacc 50
    let seg1 = walk(1000.0, &[2.0, 2.0, 16.0, 2.0]); // fix 2,1; sacc 16
    let mut labels = String::from("file,label,class,sources\n");
    for (class, label) in [("reading", 1), ("conversation", 0)] {
        let mut pool = String::from("frame,x,y,source\n");
        for (i, p) in seg0.iter().enumerate() {
            writeln!(pool, "{i},{},{},0", p[0], p[1]).unwrap();
        }
        for (i, p) in seg1.iter().enumerate() {
            writeln!(pool, "{},{},{},1", i + seg0.len(), p[0], p[1]).unwrap();
        }
        std::fs::write(dir.join("pool").join(format!("{class}.csv")), pool).unwrap();
        std::fs::create_dir_all(dir.join(class)).unwrap();
        let a = walk(0.0, &[1.0, 1.0, 1.0, 1.0]); // fix 4
        let b = walk(0.0, &[20.0, 1.0, 1.0, 20.0]); // fix 2; sacc 20, 20
        for (i, s) in [a, b].iter().enumerate() {
            let rel = format!("{class}/{class}_{i:04}.csv");
            std::fs::write(dir.join(&rel), csv3(s)).unwrap();
            writeln!(labels, "{rel},{label},{class},0;1").unwrap();
        }
    }
    std::fs::write(dir.join("labels.csv"), labels).unwrap();
    write_tiny_meta(dir, None, Vec::new());
}

/// metadata.json of [`tiny_dataset`]: 25 fps, 5-frame sessions, two
/// sessions per class over a 13-frame pool (8 frames of source 0, then 5 of
/// source 1).
fn write_tiny_meta(
    dir: &Path,
    calibration: Option<[f64; 4]>,
    sources: Vec<eyereplay_prepare::SourceReport>,
) {
    use eyereplay_core::GazeClass::{Conversation, Reading};
    common::write_meta(
        dir,
        25.0,
        5,
        calibration,
        &[(Reading, 2, 13), (Conversation, 2, 13)],
        sources,
    );
}

fn num(j: &Json, path: &str) -> f64 {
    j.get(path)
        .and_then(Json::as_f64)
        .unwrap_or_else(|| panic!("{path} missing"))
}

#[test]
fn hand_worked_distribution() {
    let tmp = tempfile::tempdir().unwrap();
    tiny_dataset(tmp.path());
    let ev = evaluate_dataset(tmp.path(), &EvalConfig::default()).unwrap();
    let j = metrics_json(&ev);
    for cls in ["reading", "conversation"] {
        // 7 + 4 source speeds (the join is not a speed); 4 + 4 generated.
        assert_eq!(num(&j, &format!("distribution.{cls}.speed.n_source")), 11.0);
        assert_eq!(
            num(&j, &format!("distribution.{cls}.speed.n_generated")),
            8.0
        );
        // Fixations: source {3,2,2,1}, generated {4,2}: D = 0.5 (at 2:
        // 3/4 - 1/2 = 0.25; at 3: 1 - 1/2 = 0.5).
        assert_eq!(
            num(
                &j,
                &format!("distribution.{cls}.fixation_duration.n_source")
            ),
            4.0
        );
        assert_eq!(
            num(
                &j,
                &format!("distribution.{cls}.fixation_duration.n_generated")
            ),
            2.0
        );
        assert!(
            (num(&j, &format!("distribution.{cls}.fixation_duration.ks_d")) - 0.5).abs() < 1e-12
        );
        // Saccades: source {50, 16}, generated {20, 20}: D = 0.5.
        assert_eq!(
            num(
                &j,
                &format!("distribution.{cls}.saccade_amplitude.n_source")
            ),
            2.0
        );
        assert!(
            (num(&j, &format!("distribution.{cls}.saccade_amplitude.ks_d")) - 0.5).abs() < 1e-12
        );
        assert!(
            (num(
                &j,
                &format!("distribution.{cls}.saccade_amplitude.median_source")
            ) - 33.0)
                .abs()
                < 1e-12
        );
        let p = num(&j, &format!("distribution.{cls}.speed.ks_p"));
        assert!((0.0..=1.0).contains(&p));
    }
    assert_eq!(j.get("visual.computed"), Some(&Json::Bool(false)));
    assert_eq!(j.get("visual.x.r"), Some(&Json::Null));
    assert_eq!(j.get("visual.error.p95"), Some(&Json::Null));
    // The time-series window (30 s by default) is shown at most a session
    // long, 5 frames, on both sides: the pool's 13 frames beside a
    // session's 5 had time axes that did not match.
    for c in &ev.classes {
        assert_eq!((c.window_source.len(), c.window_generated.len()), (5, 5));
    }
}

#[test]
fn report_holds_plots_and_tables_and_reruns_identically() {
    let tmp = tempfile::tempdir().unwrap();
    common::write_dataset(tmp.path(), &common::Spec::default());
    let cfg = EvalConfig::default();
    let ev = evaluate_dataset(tmp.path(), &cfg).unwrap();
    let (paths, metrics) = write_report(tmp.path(), &ev).unwrap();
    let html = std::fs::read_to_string(&paths.html).unwrap();
    assert_eq!(
        html.matches("src=\"data:image/png;base64,").count(),
        3,
        "three inline figures"
    );
    assert!(html.contains("<h2>Distributional fidelity</h2>"));
    assert!(html.contains("Saccade amplitude (px)"));
    assert!(html.contains("Visual mapping fidelity"));
    assert!(html.contains("not computed"));
    assert!(!html.contains("src=\"http"), "no external resources");
    for name in ["qq", "timeseries", "main_sequence"] {
        for ext in ["png", "svg"] {
            let p = paths.dir.join("figures").join(format!("{name}.{ext}"));
            assert!(
                std::fs::metadata(&p).unwrap().len() > 1000,
                "{}",
                p.display()
            );
        }
    }
    let svg = std::fs::read_to_string(paths.dir.join("figures/qq.svg")).unwrap();
    assert!(svg.contains("D = "), "Q-Q panels annotate D");
    let ev_csv =
        std::fs::read_to_string(paths.dir.join("events/reading/reading_0000.csv")).unwrap();
    assert!(
        ev_csv.starts_with("name,onset,offset\nfixation,0.000,"),
        "{}",
        &ev_csv[..60]
    );
    let j: serde_json::Value = serde_json::from_str(&metrics).unwrap();
    for cls in ["reading", "conversation"] {
        for m in ["speed", "fixation_duration", "saccade_amplitude"] {
            for k in ["ks_d", "ks_p", "n_source", "n_generated"] {
                assert!(j["distribution"][cls][m].get(k).is_some(), "{cls}.{m}.{k}");
            }
            assert!(j["distribution"][cls][m]["ks_d"].is_number(), "{cls}.{m}");
        }
    }
    for k in ["x", "y"] {
        assert!(
            j["visual"][k].get("r").is_some() && j["visual"][k].get("amplitude_ratio").is_some()
        );
    }
    // Rerun: byte-identical outputs.
    let first_html = html;
    let ev2 = evaluate_dataset(tmp.path(), &cfg).unwrap();
    let (_, metrics2) = write_report(tmp.path(), &ev2).unwrap();
    assert_eq!(metrics, metrics2);
    assert_eq!(first_html, std::fs::read_to_string(&paths.html).unwrap());
}

fn err_of(dir: &Path) -> String {
    evaluate_dataset(dir, &EvalConfig::default())
        .unwrap_err()
        .to_string()
}

#[test]
fn bad_input_gives_one_line_errors_naming_the_file() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    tiny_dataset(d);

    std::fs::rename(d.join("labels.csv"), d.join("labels.bak")).unwrap();
    let e = err_of(d);
    assert!(e.contains("labels.csv") && e.contains("not found"), "{e}");
    std::fs::rename(d.join("labels.bak"), d.join("labels.csv")).unwrap();

    std::fs::rename(d.join("metadata.json"), d.join("metadata.bak")).unwrap();
    let e = err_of(d);
    assert!(
        e.contains("metadata.json") && e.contains("not found"),
        "{e}"
    );
    std::fs::rename(d.join("metadata.bak"), d.join("metadata.json")).unwrap();

    let s1 = d.join("reading/reading_0001.csv");
    let good = std::fs::read_to_string(&s1).unwrap();
    std::fs::write(&s1, csv3(&walk(0.0, &[1.0, 1.0]))).unwrap();
    let e = err_of(d);
    assert!(
        e.contains("reading_0001.csv")
            && e.contains("3 frames")
            && e.contains("session_frames = 5"),
        "{e}"
    );
    std::fs::write(&s1, good).unwrap();

    let labels = std::fs::read_to_string(d.join("labels.csv")).unwrap();
    let only_reading: String = labels
        .lines()
        .filter(|l| !l.contains(",conversation,"))
        .map(|l| format!("{l}\n"))
        .collect();
    std::fs::write(d.join("labels.csv"), only_reading).unwrap();
    let e = err_of(d);
    assert!(
        e.contains("labels.csv") && e.contains("'conversation' has no sessions"),
        "{e}"
    );
    std::fs::write(d.join("labels.csv"), labels).unwrap();

    std::fs::remove_file(d.join("pool/conversation.csv")).unwrap();
    let e = err_of(d);
    assert!(
        e.contains("conversation.csv") && e.contains("not found"),
        "{e}"
    );

    assert!(!e.contains('\n'), "one line: {e}");
    assert!(evaluate_dataset(&d.join("nope"), &EvalConfig::default())
        .unwrap_err()
        .to_string()
        .contains("not a folder"));
}

#[test]
fn computed_visual_section_reaches_html_and_json() {
    use eyereplay_eval::{compare_visual, VisualRun, VisualSection};
    let tmp = tempfile::tempdir().unwrap();
    common::write_dataset(tmp.path(), &common::Spec::default());
    let mut ev = evaluate_dataset(tmp.path(), &EvalConfig::default()).unwrap();
    // A rendered signal at 95 % amplitude with a little deterministic noise.
    let mut rng = common::Rng::new(3);
    let src: Vec<[f64; 2]> = (0..300)
        .map(|i| {
            let t = i as f64 / 25.0;
            [0.5 + 0.1 * (t * 1.3).sin(), 0.5 + 0.05 * (t * 0.7).cos()]
        })
        .collect();
    let ren: Vec<[f64; 2]> = src
        .iter()
        .map(|p| {
            [
                0.5 + 0.95 * (p[0] - 0.5) + 0.002 * rng.normal(),
                0.5 + 0.95 * (p[1] - 0.5) + 0.002 * rng.normal(),
            ]
        })
        .collect();
    let fidelity = compare_visual(&src, &ren, None).unwrap();
    assert!(fidelity.meets_targets());
    ev.visual = VisualSection::Computed(Box::new(VisualRun {
        fidelity,
        source_n: src,
        rendered_n: ren,
        video: "reading/reading_0000.mp4".into(),
        eye_locator: "test".into(),
        detection_rate: 1.0,
    }));
    let (paths, metrics) = write_report(tmp.path(), &ev).unwrap();
    let html = std::fs::read_to_string(&paths.html).unwrap();
    assert_eq!(html.matches("src=\"data:image/png;base64,").count(), 4);
    assert!(html.contains("Pearson r (x)"));
    let j: serde_json::Value = serde_json::from_str(&metrics).unwrap();
    assert!(j["visual"]["x"]["r"].as_f64().unwrap() > 0.99);
    assert!((j["visual"]["y"]["amplitude_ratio"].as_f64().unwrap() - 0.95).abs() < 0.02);
    for k in ["mean", "median", "p95"] {
        assert!(j["visual"]["error"][k].is_number());
    }
    assert!(paths.dir.join("figures/visual.svg").is_file());
}

#[test]
fn per_source_calibrations_follow_the_pool() {
    use eyereplay_dataset::{read_metadata, session_calibrations};
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    tiny_dataset(d);
    // No pooled calibration; two sources with their own. The pool is 8
    // frames of source 0 then 5 of source 1 (13 in all); with 2 sessions the
    // stride is floor(13 / 2) = 6, so session 1 covers pool frames 6..=10:
    // sources 0,0,1,1,1; session 0 covers 0..=4, all source 0.
    write_tiny_meta(
        d,
        None,
        vec![
            common::source(0, "reading", "fixation_report", [100.0, 50.0, 640.0, 360.0]),
            common::source(1, "reading", "fixation_report", [200.0, 80.0, 600.0, 300.0]),
        ],
    );
    let meta = read_metadata(d).unwrap().dataset;
    assert!(meta.calibration.is_none());
    let c = session_calibrations(d, &meta, "reading/reading_0001.csv", 5).unwrap();
    let sx: Vec<f64> = c.iter().map(|c| c.s_x).collect();
    assert_eq!(sx, vec![100.0, 100.0, 200.0, 200.0, 200.0]);
    let c0 = session_calibrations(d, &meta, "reading/reading_0000.csv", 5).unwrap();
    assert!(c0.iter().all(|c| c.s_x == 100.0));
    // n = (c - mu) / s + 0.5: canvas (700, 380) with source 1 -> (1.0, 1.5).
    let n = c[4].canvas_to_norm(eyereplay_core::CanvasPos {
        x_px: 700.0,
        y_px: 380.0,
    });
    assert_eq!([n.nx, n.ny], [1.0, 1.5]);
    let e = session_calibrations(d, &meta, "reading/nope.csv", 5)
        .unwrap_err()
        .to_string();
    assert!(e.contains("metadata.json") && e.contains("nope.csv"), "{e}");
    // The evaluation itself does not need a calibration.
    assert!(evaluate_dataset(d, &EvalConfig::default()).is_ok());
}

#[test]
fn blink_column_becomes_blink_events_and_a_rate() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    tiny_dataset(d);
    // Session 0 with a blink column: one blink over frames 1..=2.
    std::fs::write(
        d.join("reading/reading_0000.csv"),
        "frame,x,y,blink\n0,0,100,0\n1,1,100,1\n2,2,100,1\n3,3,100,0\n4,4,100,0\n",
    )
    .unwrap();
    let ev = evaluate_dataset(d, &EvalConfig::default()).unwrap();
    let reading = &ev.classes[0];
    let (_, events) = &reading.events[0];
    let blinks: Vec<_> = events
        .iter()
        .filter(|e| e.kind == eyereplay_eval::EventKind::Blink)
        .map(|e| (e.onset_frame, e.offset_frame))
        .collect();
    assert_eq!(blinks, vec![(1, 2)]);
    // 1 blink in 2 sessions x 5 frames at 25 fps = 0.4 s -> 150 per minute.
    let r = reading.extras_generated.blink_column_rate_per_min.unwrap();
    assert!((r - 150.0).abs() < 1e-9, "{r}");
    assert_eq!(
        ev.classes[1].extras_generated.blink_column_rate_per_min,
        None
    );
    std::fs::write(
        d.join("reading/reading_0000.csv"),
        "frame,x,y,blink\n0,0,100,0\n1,1,100,x\n2,2,100,1\n3,3,100,0\n4,4,100,0\n",
    )
    .unwrap();
    let e = evaluate_dataset(d, &EvalConfig::default())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("reading_0000.csv") && e.contains("line 3"),
        "{e}"
    );
}

#[test]
fn report_says_when_classes_come_from_different_kinds_of_recording() {
    let tmp = tempfile::tempdir().unwrap();
    tiny_dataset(tmp.path());
    let html_for = |kinds: [&str; 2]| {
        let cal = [100.0, 50.0, 640.0, 360.0];
        write_tiny_meta(
            tmp.path(),
            Some(cal),
            vec![
                common::source(0, "reading", kinds[0], cal),
                common::source(1, "reading", kinds[1], cal),
                common::source(2, "conversation", "video", cal),
            ],
        );
        let ev = evaluate_dataset(tmp.path(), &EvalConfig::default()).unwrap();
        let (paths, _) = write_report(tmp.path(), &ev).unwrap();
        std::fs::read_to_string(&paths.html).unwrap()
    };
    let mixed = html_for(["fixation_report", "fixation_report"]);
    assert!(mixed.contains("<td>reading sources</td><td>2 fixation report</td>"));
    assert!(mixed.contains(
        "different kinds of recording (reading from fixation report; conversation from video)"
    ));
    let same = html_for(["video", "video"]);
    assert!(!same.contains("different kinds of recording"));
}
