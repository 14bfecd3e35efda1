//! `eyereplay prepare` as a user runs it: exit codes, one-line errors,
//! nothing written on failure or dry run.

use std::path::Path;
use std::process::{Command, Output};

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

fn one_line_error(o: &Output) -> String {
    assert!(!o.status.success());
    let e = String::from_utf8_lossy(&o.stderr).to_string();
    assert_eq!(e.trim_end().lines().count(), 1, "{e}");
    assert!(e.starts_with("error: "), "{e}");
    e
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
    webcam_csv(&d.join("r.csv"), 600);
    let source = "sources = [{ format = \"extract\", path = \"r.csv\" }]\n";
    let classes = format!(
        "[classes.reading]\nsessions = 2\n{source}[classes.conversation]\nsessions = 2\n{source}"
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
