//! `eyereplay prepare` as a user runs it: exit codes, one-line errors,
//! nothing written on failure or dry run.

use std::path::Path;
use std::process::{Command, Output};

mod common;
use common::{one_line_error, stopped_when};

fn eyereplay(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_eyereplay"))
        .args(args)
        .output()
        .unwrap()
}

fn webcam_csv(path: &Path, frames: usize) {
    let mut s = String::from("frame,time_s,valid,nx,ny\n");
    for i in 0..frames {
        let x = 0.45 + 0.1 * ((i / 10) % 2) as f64 + 0.001 * ((i * 37 % 11) as f64);
        let y = 0.5 + 0.05 * ((i / 25) % 2) as f64;
        s.push_str(&format!("{i},{:.4},1,{x:.5},{y:.5}\n", i as f64 / 24.0));
    }
    std::fs::write(path, s).unwrap();
}

/// `prepare --config CFG --out OUT`.
fn prepare(cfg: &Path, out: &Path) -> Output {
    eyereplay(&[
        "prepare",
        "--config",
        cfg.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ])
}

/// `prepare --config CFG --out OUT --dry-run`.
fn dry_run<'a>(cfg: &'a Path, out: &'a Path) -> [&'a str; 6] {
    [
        "prepare",
        "--config",
        cfg.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--dry-run",
    ]
}

/// Output into a pipe nobody reads any more (`| head -1` after its line):
/// the program ends quietly with 141 (128 + SIGPIPE), as other Unix tools
/// do, not with a panic and a backtrace.
#[test]
fn a_closed_standard_output_ends_the_program_quietly() {
    let dir = tempfile::tempdir().unwrap();
    webcam_csv(&dir.path().join("r.csv"), 600);
    let cfg = dir.path().join("d.toml");
    std::fs::write(
        &cfg,
        "session_frames = 100\n[classes.reading]\nsessions = 3\nsources = [{ format = \"extract\", path = \"r.csv\" }]\n",
    )
    .unwrap();
    let (reader, writer) = std::io::pipe().unwrap();
    // Closed before the program starts, so its first line already fails.
    drop(reader);
    let out = dir.path().join("o");
    let o = Command::new(env!("CARGO_BIN_EXE_eyereplay"))
        .args(dry_run(&cfg, &out))
        .stdout(writer)
        .stderr(std::process::Stdio::piped())
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(141), "{err}");
    assert!(!err.contains("panicked"), "{err}");
}

#[test]
fn prepare_writes_dataset_and_dry_run_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    webcam_csv(&dir.path().join("r.csv"), 600);
    webcam_csv(&dir.path().join("c.csv"), 900);
    let cfg = dir.path().join("d.toml");
    std::fs::write(
        &cfg,
        "session_frames = 100\n[classes.reading]\nsessions = 3\nsources = [{ format = \"extract\", path = \"r.csv\" }]\n\
         [classes.conversation]\nsessions = 4\nsources = [{ format = \"extract\", path = \"c.csv\" }]\n",
    )
    .unwrap();
    let out = dir.path().join("out");
    let o = eyereplay(&dry_run(&cfg, &out));
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(String::from_utf8_lossy(&o.stdout).contains("dry run: would write 7 sessions"));
    assert!(!out.exists());

    let o = prepare(&cfg, &out);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for f in [
        "labels.csv",
        "metadata.json",
        "reading/reading_0002.csv",
        "conversation/conversation_0003.csv",
        "pool/reading.csv",
    ] {
        assert!(out.join(f).exists(), "{f}");
    }
    // No temporary files left behind.
    let tmp = walk(&out)
        .into_iter()
        .filter(|p| p.ends_with(".tmp"))
        .count();
    assert_eq!(tmp, 0);

    // `evaluate` on it, then with a row of labels.csv repeated (it was
    // evaluated twice, with other KS figures and no word), and with an
    // infinite saccade threshold (written to metrics.json as null).
    let out_s = out.to_str().unwrap();
    let o = eyereplay(&["evaluate", out_s, "--no-visual"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let e = one_line_error(&eyereplay(&[
        "evaluate",
        out_s,
        "--no-visual",
        "--saccade-above",
        "inf",
    ]));
    assert!(e.contains("both finite (got 5 and inf)"), "{e}");
    let labels = out.join("labels.csv");
    let text = std::fs::read_to_string(&labels).unwrap();
    let row = text.lines().nth(1).unwrap().to_string();
    std::fs::write(&labels, format!("{text}{row}\n")).unwrap();
    let e = one_line_error(&eyereplay(&["evaluate", out_s, "--no-visual"]));
    assert!(
        e.contains("labels.csv: lists 8 sessions where metadata.json plans 7"),
        "{e}"
    );
}

fn walk(p: &Path) -> Vec<String> {
    let mut v = Vec::new();
    for e in std::fs::read_dir(p).unwrap().flatten() {
        if e.path().is_dir() {
            v.extend(walk(&e.path()));
        } else {
            v.push(e.path().display().to_string());
        }
    }
    v
}

#[test]
fn bad_configs_fail_in_one_line_and_write_nothing() {
    let dir = tempfile::tempdir().unwrap();
    webcam_csv(&dir.path().join("r.csv"), 600);
    let out = dir.path().join("out");
    let cases = [
        ("[classes.reading]\nsesions = 3\nsources = [{ format = \"extract\", path = \"r.csv\" }]\n", "did you mean 'sessions'"),
        ("session_frames = 0\n[classes.reading]\nsources = [{ format = \"extract\", path = \"r.csv\" }]\n", "session_frames"),
        ("[classes.reading]\nsessions = 0\nsources = [{ format = \"extract\", path = \"r.csv\" }]\n", "sessions must be at least 1"),
        ("[classes.reading]\nsources = [{ format = \"extract\", path = \"missing.csv\" }]\n", "missing.csv"),
        ("[classes.reading]\nsessions = 5000\nsources = [{ format = \"extract\", path = \"r.csv\" }]\n", "5000 sessions"),
    ];
    for (i, (body, want)) in cases.iter().enumerate() {
        let cfg = dir.path().join(format!("c{i}.toml"));
        std::fs::write(&cfg, body).unwrap();
        let o = prepare(&cfg, &out);
        let e = one_line_error(&o);
        assert!(e.contains(want), "case {i}: {e}");
        assert!(!out.exists(), "case {i} wrote output");
    }
    let o = eyereplay(&[
        "prepare",
        "--config",
        "/nonexistent.toml",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(one_line_error(&o).contains("/nonexistent.toml"));
}

#[test]
fn help_teaches_with_examples() {
    let o = eyereplay(&["prepare", "--help"]);
    let h = String::from_utf8_lossy(&o.stdout);
    assert!(h.contains("Examples:") && h.contains("--dry-run") && h.contains("fixations"));
}

/// Mistakes found by trying every command as a user would (29 Nov 2026),
/// each refused in one line before any work, with nothing written: a bad
/// `[render]` table at `prepare` (which writes it for the render), a
/// usage error, a dataset given twice to `train`, a render whose output
/// cannot be written, and a detector's output folder that is a file.
#[test]
fn mistakes_are_refused_up_front_in_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // A recording for each class: one in both is refused.
    webcam_csv(&d.join("r.csv"), 600);
    webcam_csv(&d.join("c.csv"), 601);
    let source = "sources = [{ format = \"extract\", path = \"r.csv\" }]\n";
    let other = "sources = [{ format = \"extract\", path = \"c.csv\" }]\n";
    let classes = format!(
        "[classes.reading]\nsessions = 2\n{source}[classes.conversation]\nsessions = 2\n{other}"
    );
    for (i, (table, want)) in [
        ("[render]\njbos = 2\n", "did you mean 'jobs'"),
        ("[render]\ncrf = 200\n", "crf"),
        ("[render]\npreset = \"fastest\"\n", "'fastest'"),
        ("[render]\nwidth = 100000\nheight = 720\n", "8192"),
        ("[read]\nmax_gap_s = 0.0\n", "read.max_gap_s"),
    ]
    .iter()
    .enumerate()
    {
        let cfg = d.join(format!("r{i}.toml"));
        std::fs::write(&cfg, format!("session_frames = 100\n{table}{classes}")).unwrap();
        let out = d.join(format!("out{i}"));
        let e = one_line_error(&prepare(&cfg, &out));
        assert!(e.contains(want) && e.contains(&format!("r{i}.toml")), "{e}");
        assert!(!out.exists(), "case {i} wrote output");
    }
    // clap's usage errors: one line, the help to read named.
    let e = one_line_error(&eyereplay(&["train"]));
    assert!(
        e.contains("--out") && e.contains("'eyereplay train --help'"),
        "{e}"
    );
    let e = one_line_error(&eyereplay(&["evaluate", "x", "--d-max", "2"]));
    assert!(e.contains("--d-max"), "{e}");
    // Found by reading every --help as a new user (30 Nov 2026): a
    // negative number met clap's "unexpected argument '-1'" and a tip to
    // write `-- -1`, not its own range; a --live option without --live was
    // dropped; a refused extract had already made its output folder.
    let e = one_line_error(&eyereplay(&["render", "t.csv", "--gain", "-1"]));
    assert!(e.contains("gain must be above 0"), "{e}");
    // Whole-number options said "invalid digit found in string"; commands
    // with two ways in named only the first when given neither.
    let e = one_line_error(&eyereplay(&["extract", "a.mp4", "--threads", "-1"]));
    assert!(
        e.contains("must be a whole number, 0 or more, got -1"),
        "{e}"
    );
    let e = one_line_error(&eyereplay(&["detect"]));
    assert!(e.contains("<INPUT|--live <SOURCE>>"), "{e}");
    let e = one_line_error(&eyereplay(&["render"]));
    assert!(e.contains("<TRAJECTORY|--dataset <DIR>|--bench>"), "{e}");
    let traj = d.join("short.csv");
    std::fs::write(&traj, "frame,x,y\n0,640,360\n").unwrap();
    let e = one_line_error(&eyereplay(&[
        "detect",
        traj.to_str().unwrap(),
        "--stall-timeout-s",
        "5",
    ]));
    assert!(e.contains("--live only"), "{e}");
    let folder = d.join("made_too_soon");
    let e = one_line_error(&eyereplay(&[
        "extract",
        "a.mp4",
        "b.mp4",
        "--out",
        &format!("{}/", folder.display()),
        "--compare",
        "f.csv",
    ]));
    assert!(e.contains("--compare takes exactly one video"), "{e}");
    assert!(!folder.exists());
    // A bench that would keep more than 4 GiB of frames (it replays them
    // to time the encoder alone): 2^32 / (1280 * 720 * 3 / 2) = 3106.9.
    for mode in [&["--face"][..], &[]] {
        let mut args = vec!["render", "--bench", "--frames", "20000"];
        args.extend_from_slice(mode);
        let e = one_line_error(&eyereplay(&args));
        assert!(
            e.contains("27.6 GB") && e.contains("at most 3106 frames"),
            "{e}"
        );
    }
    // A dataset, then the same folder twice to `train`.
    let cfg = d.join("ok.toml");
    std::fs::write(&cfg, format!("session_frames = 100\n{classes}")).unwrap();
    let ds = d.join("ds");
    let o = prepare(&cfg, &ds);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let m = d.join("m.json");
    let (ds_s, m_s) = (ds.to_str().unwrap(), m.to_str().unwrap());
    // `train DATASETS --input trajectory --window-s 2 --out m.json`.
    let train = |datasets: &[&str]| {
        let mut args = vec!["train"];
        args.extend_from_slice(datasets);
        args.extend(["--input", "trajectory", "--window-s", "2", "--out", m_s]);
        eyereplay(&args)
    };
    let e = one_line_error(&train(&[ds_s, ds_s]));
    assert!(e.contains("given twice"), "{e}");
    assert!(!m.exists());
    // What the sessions' lengths and labels already tell, said before any
    // reading: 4-s sessions hold no 10-s window; these sessions have no
    // per-frame labels for --frame-labels.
    let mut long = vec!["train", ds_s, "--input", "trajectory", "--out", m_s];
    long.extend(["--window-s", "10"]);
    let e = one_line_error(&eyereplay(&long));
    assert!(
        e.contains("the longest session is 4.0 s, shorter than a window (10 s"),
        "{e}"
    );
    let labels = [
        "train",
        ds_s,
        "--input",
        "trajectory",
        "--out",
        m_s,
        "--frame-labels",
    ];
    let e = one_line_error(&eyereplay(&labels));
    assert!(
        e.contains("no session CSV has a per-frame `reading` column"),
        "{e}"
    );
    assert!(!m.exists());
    // A render whose truth file would land under a plain file: refused
    // before the probe and the drawing, naming that file; nothing written.
    let blocker = d.join("f");
    std::fs::write(&blocker, b"x").unwrap();
    let session = ds.join("reading/reading_0000.csv");
    let video = blocker.join("v.mp4");
    let e = one_line_error(&eyereplay(&[
        "render",
        session.to_str().unwrap(),
        "--out",
        video.to_str().unwrap(),
    ]));
    assert!(e.contains("f/v_truth.csv"), "{e}");
    // A detector whose --out is a file, refused before the input is read.
    let o = train(&[ds_s]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let e = one_line_error(&eyereplay(&[
        "detect",
        session.to_str().unwrap(),
        "--model",
        m_s,
        "--out",
        blocker.to_str().unwrap(),
    ]));
    assert!(e.contains("--out takes a folder"), "{e}");
}

/// `render` with a single trajectory: an output that is the input (or
/// another output) is refused before anything is written; options of
/// --bench or --dataset given without them are refused rather than
/// ignored (clap counts their `requires` as met: the trajectory conflicts
/// with both); a video not named .mp4 is refused; a killed render's
/// temporary files beside the outputs are gone after the next one.
#[test]
fn render_refuses_what_it_would_overwrite_or_ignore_and_clears_leftovers() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let traj = d.join("t.csv");
    let mut text = String::from("frame,x,y\n");
    for i in 0..30 {
        text.push_str(&format!("{i},{},{}\n", 600 + 4 * i, 360));
    }
    std::fs::write(&traj, &text).unwrap();
    let t = traj.to_str().unwrap();
    let small = ["--size", "320x240", "--match-extractor", "false"];
    let render = |extra: &[&str]| {
        let mut a = vec!["render", t];
        a.extend_from_slice(&small);
        a.extend_from_slice(extra);
        eyereplay(&a)
    };
    for (extra, says) in [
        (vec!["--out", t], "--out would overwrite the trajectory"),
        (
            vec!["--out", "x.mp4", "--truth", t],
            "the truth file would overwrite the trajectory",
        ),
        (vec!["--face"], "--face is for --bench only"),
        (vec!["--frames", "100"], "--frames is for --bench only"),
        (vec!["--jobs", "2"], "--jobs is for --dataset only"),
    ] {
        let e = one_line_error(&render(&extra));
        assert!(e.contains(says), "{extra:?}: {e}");
    }
    // The trajectory is untouched, nothing was written beside it.
    assert_eq!(std::fs::read_to_string(&traj).unwrap(), text);
    assert_eq!(std::fs::read_dir(d).unwrap().count(), 1);
    let avi = d.join("v.avi");
    let e = one_line_error(&render(&["--out", avi.to_str().unwrap()]));
    assert!(e.contains("v.avi") && e.contains(".mp4"), "{e}");
    let e = one_line_error(&eyereplay(&[
        "render",
        "--dataset",
        d.to_str().unwrap(),
        "--size",
        "640x480",
    ]));
    assert!(e.contains("'--size <SIZE>'"), "{e}");
    // A render killed mid-way left these (named as the encoder and the
    // atomic writes name theirs); the next render of the same outputs
    // clears them.
    let video = d.join("v.mp4");
    let leftovers = [d.join(".v.mp4.4242.part"), d.join(".v_truth.csv.4242.tmp")];
    for p in &leftovers {
        std::fs::write(p, b"half").unwrap();
    }
    let o = render(&["--out", video.to_str().unwrap()]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(video.is_file() && d.join("v_truth.csv").is_file());
    for p in &leftovers {
        assert!(!p.exists(), "{} left", p.display());
    }
    // The same with a bare file name (its folder is "", the current one).
    let bare = d.join(".w.mp4.4242.part");
    std::fs::write(&bare, b"half").unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_eyereplay"))
        .current_dir(d)
        .args(["render", "t.csv", "--out", "w.mp4"])
        .args(small)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(d.join("w.mp4").is_file() && !bare.exists());
}

/// Ctrl-C (SIGINT) or SIGTERM (a Slurm job's time limit) in the middle
/// of a render ends it with status 130 or 143 and removes the video it was
/// encoding (`.v.mp4.PID.part`): nothing unfinished is left beside the
/// user's files, and the finished ones stay.
#[test]
fn a_stopped_render_leaves_no_unfinished_file() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let traj = d.join("t.csv");
    // 200 s at 25 fps: seconds of work even at close-up speed.
    let mut text = String::from("frame,x,y\n");
    for i in 0..5000 {
        let x = 640.0 + 300.0 * (i as f64 / 20.0).sin();
        text.push_str(&format!("{i},{x:.3},360\n"));
    }
    std::fs::write(&traj, &text).unwrap();
    let done = d.join("done.csv");
    std::fs::write(&done, "kept").unwrap();
    // SIGINT some frames into the encoding, as a user's Ctrl-C would be;
    // SIGTERM at once, before FFmpeg has opened its output (it would make
    // it again after the removal, were it not stopped first).
    let stops = [(libc::SIGINT, "v.mp4", 300), (libc::SIGTERM, "w.mp4", 0)];
    for (signal, name, after_ms) in stops {
        let o = stopped_when(
            &[
                "render",
                traj.to_str().unwrap(),
                "--out",
                d.join(name).to_str().unwrap(),
                "--size",
                "320x240",
                "--match-extractor",
                "false",
            ],
            &[],
            d,
            &format!(".{name}."),
            std::time::Duration::from_millis(after_ms),
            signal,
        );
        let err = String::from_utf8_lossy(&o.stderr);
        // 128 + the signal's number: 130 for SIGINT, 143 for SIGTERM.
        assert_eq!(o.status.code(), Some(128 + signal), "{err}");
        assert!(
            err.contains("stopped: removed 1 unfinished file(s)"),
            "{err}"
        );
        let mut left: Vec<String> = std::fs::read_dir(d)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        left.sort();
        assert_eq!(left, ["done.csv", "t.csv"], "{err}");
    }
    assert_eq!(std::fs::read_to_string(&done).unwrap(), "kept");
}

/// Found by trying `train`, `render`, `evaluate-localization`, `merge` and
/// `detect` with a user's mistakes (30 Nov 2026, a third round): outputs
/// that landed on the command's own inputs, a render that drew a session
/// over its dataset's files, numbers that hung or crashed, and sessions
/// cut short that were used as they were.
#[test]
fn outputs_never_land_on_inputs_and_cut_sessions_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    webcam_csv(&d.join("r.csv"), 600);
    webcam_csv(&d.join("c.csv"), 601);
    let source = "sources = [{ format = \"extract\", path = \"r.csv\" }]\n";
    let other = "sources = [{ format = \"extract\", path = \"c.csv\" }]\n";
    let cfg = d.join("ok.toml");
    std::fs::write(
        &cfg,
        format!(
            "session_frames = 100\n[render]\nwidth = 160\nheight = 120\n\
             [classes.reading]\nsessions = 2\n{source}\
             [classes.conversation]\nsessions = 2\n{other}"
        ),
    )
    .unwrap();
    let ds = d.join("ds");
    let o = prepare(&cfg, &ds);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let s = |p: &Path| p.to_str().unwrap().to_string();
    let labels_before = std::fs::read(ds.join("labels.csv")).unwrap();
    let meta_before = std::fs::read(ds.join("metadata.json")).unwrap();
    // `train DS --input trajectory --window-s 2 --out OUT`.
    let train_to = |out: &Path| {
        eyereplay(&[
            "train",
            &s(&ds),
            "--input",
            "trajectory",
            "--window-s",
            "2",
            "--out",
            &s(out),
        ])
    };

    // `train --out` over the dataset's own files: refused, files as they were.
    for (out, says) in [
        (
            ds.join("labels.csv"),
            "--out takes a file name ending in .json",
        ),
        (ds.join("metadata.json"), "is the dataset's own metadata"),
        (
            ds.join("reading/m.json"),
            "inside the folders of the dataset",
        ),
    ] {
        let e = one_line_error(&train_to(&out));
        assert!(e.contains(says), "{}: {e}", out.display());
    }
    assert!(!ds.join("reading/m.json").exists());
    // Beside labels.csv is fine (the help's own example).
    let model = ds.join("model.json");
    let o = train_to(&model);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    // The chance warning is given when, and only when, the held-out AUROC
    // printed is under 0.6.
    let (out, err) = (
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr),
    );
    let auroc: Option<f64> = out
        .split("AUROC ")
        .nth(1)
        .and_then(|r| r.split(',').next())
        .and_then(|v| v.parse().ok());
    assert_eq!(
        err.contains("no better than chance"),
        auroc.is_some_and(|a| a < 0.6),
        "{out}{err}"
    );
    // `evaluate-localization --json` over the model it scores.
    let e = one_line_error(&eyereplay(&[
        "evaluate-localization",
        &s(&ds),
        "--model",
        &s(&model),
        "--json",
        &s(&model),
    ]));
    assert!(e.contains("is an input of this command"), "{e}");
    assert!(std::fs::read_to_string(&model)
        .unwrap()
        .contains("\"format\""));

    // A session CSV rendered without --out would draw over its dataset's
    // session video: refused. --png-frames keeps its truth with the frames.
    let session = ds.join("reading/reading_0000.csv");
    let e = one_line_error(&eyereplay(&[
        "render",
        &s(&session),
        "--match-extractor",
        "false",
    ]));
    assert!(e.contains("a session of the dataset"), "{e}");
    let frames = d.join("frames");
    let o = eyereplay(&[
        "render",
        &s(&session),
        "--png-frames",
        &s(&frames),
        "--size",
        "160x120",
        "--match-extractor",
        "false",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(frames.join("truth.csv").is_file());
    assert!(!ds.join("reading/reading_0000_truth.csv").exists());
    assert!(!ds.join("reading/reading_0000.mp4").exists());

    // Numbers that hung (100,000 threads) or aborted (a 1.6 TB allocation).
    for (args, says) in [
        (
            vec!["render", "--dataset", &s(&ds), "--jobs", "100000"],
            "1..=256",
        ),
        (
            vec!["render", "--dataset", &s(&ds), "--jobs", "0"],
            "1..=256",
        ),
        (
            vec!["render", "--bench", "--frames", "99999999999"],
            "between 25 and 100000",
        ),
    ] {
        let e = one_line_error(&eyereplay(&args));
        assert!(e.contains(says), "{args:?}: {e}");
    }
    // A second render of the dataset while one holds it: refused at once
    // (it would draw every session again and remove the first's
    // half-written files). The lock is held here as a running render holds it.
    let lock = std::fs::File::create(ds.join(".eyereplay-render.lock")).unwrap();
    lock.try_lock().unwrap();
    let e = one_line_error(&eyereplay(&["render", "--dataset", &s(&ds)]));
    assert!(
        e.contains("another eyereplay run is drawing this dataset"),
        "{e}"
    );
    drop(lock);
    // A file where the report folder goes: said before the evaluation.
    std::fs::write(ds.join("report"), b"mine").unwrap();
    let e = one_line_error(&eyereplay(&["evaluate", &s(&ds), "--no-visual"]));
    assert!(
        e.contains("a file where the dataset's report folder goes"),
        "{e}"
    );
    assert_eq!(std::fs::read(ds.join("report")).unwrap(), b"mine");
    std::fs::remove_file(ds.join("report")).unwrap();
    // A session CSV saved with a byte-order mark is read by `detect` as
    // `render` reads it.
    let bom = d.join("bom.csv");
    let mut bytes = "\u{feff}".as_bytes().to_vec();
    bytes.extend(std::fs::read(ds.join("reading/reading_0001.csv")).unwrap());
    std::fs::write(&bom, bytes).unwrap();
    let o = eyereplay(&[
        "detect",
        &s(&bom),
        "--model",
        &s(&model),
        "--out",
        &s(&d.join("det")),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    // A folder given to `detect`.
    let e = one_line_error(&eyereplay(&["detect", &s(d), "--model", &s(&model)]));
    assert!(e.contains("a folder; give a video"), "{e}");
    // A dataset given as a file, a models folder given as a file.
    let e = one_line_error(&eyereplay(&["render", "--dataset", &s(&model)]));
    assert!(e.contains("a file, not a dataset folder"), "{e}");
    let e = one_line_error(&eyereplay(&["models", "check", "--dir", &s(&model)]));
    assert!(e.contains("a file, not a models folder"), "{e}");

    // A session cut short is refused by `render --dataset` and `train`
    // before any work, not drawn or trained on as a shorter session.
    let cut = ds.join("conversation/conversation_0001.csv");
    let text = std::fs::read_to_string(&cut).unwrap();
    let short: String = text.lines().take(41).map(|l| format!("{l}\n")).collect();
    std::fs::write(&cut, short).unwrap();
    let e = one_line_error(&eyereplay(&["render", "--dataset", &s(&ds)]));
    assert!(
        e.contains("conversation_0001.csv: 40 rows where the dataset's sessions have 100"),
        "{e}"
    );
    assert!(
        !ds.join("reading/reading_0000.mp4").exists(),
        "drew a session"
    );
    let e = one_line_error(&train_to(&d.join("m2.json")));
    assert!(
        e.contains("40 rows where the dataset's sessions have 100"),
        "{e}"
    );
    // A session video that is no video: named before any extraction (it
    // used to be found after every other session was extracted).
    std::fs::write(ds.join("reading/reading_0000.mp4"), b"garbage").unwrap();
    let e = one_line_error(&eyereplay(&[
        "train",
        &s(&ds),
        "--out",
        &s(&d.join("m3.json")),
    ]));
    assert!(
        e.contains("reading_0000.mp4") && e.contains("cannot open video"),
        "{e}"
    );
    std::fs::remove_file(ds.join("reading/reading_0000.mp4")).unwrap();
    // Nothing of the dataset's own was touched along the way.
    assert_eq!(std::fs::read(ds.join("labels.csv")).unwrap(), labels_before);
    assert_eq!(
        std::fs::read(ds.join("metadata.json")).unwrap(),
        meta_before
    );
}
