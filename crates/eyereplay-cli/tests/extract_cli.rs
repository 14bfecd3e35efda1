//! `eyereplay extract`'s choice of networks: MediaPipe's attention face mesh
//! unless the cascade is asked for, by name or by one of its own options.

mod common;
use common::*;

use std::path::{Path, PathBuf};

/// What the tests on `franck.mp4` read of it: its first two seconds.
const FIRST_TWO_S: [&str; 2] = ["--max-seconds", "2"];

fn franck() -> PathBuf {
    root().join(".cache/data/franck.mp4")
}

/// `eyereplay extract VIDEO --out OUT --quiet FLAGS`.
fn extract_run_on(video: &Path, out: &Path, flags: &[&str]) -> std::process::Output {
    let mut args = vec!["extract", s(video), "--out", s(out), "--quiet"];
    args.extend_from_slice(flags);
    eyereplay(&args)
}

/// [`extract_run_on`] the first two seconds of `franck.mp4`.
fn extract_run(out: &Path, flags: &[&str]) -> std::process::Output {
    extract_run_on(&franck(), out, &[&FIRST_TWO_S[..], flags].concat())
}

/// The CSV's bytes of [`extract_run_on`] into `dir/name`.
fn extract_on(video: &Path, dir: &Path, name: &str, flags: &[&str]) -> Vec<u8> {
    let out = dir.join(name);
    ok(&extract_run_on(video, &out, flags));
    std::fs::read(&out).unwrap()
}

/// The CSV's bytes of [`extract_run`] into `dir/name`.
fn extract(dir: &Path, name: &str, flags: &[&str]) -> Vec<u8> {
    extract_on(&franck(), dir, name, &[&FIRST_TWO_S[..], flags].concat())
}

#[test]
#[cfg_attr(
    not(all(has_sample_data, has_models)),
    ignore = "needs .cache/data and the models: run scripts/setup.sh"
)]
fn extract_reads_with_the_attention_mesh_unless_the_cascade_is_asked_for() {
    let dir = tempfile::tempdir().unwrap();
    let default = extract(dir.path(), "default.csv", &[]);
    let attention = extract(dir.path(), "attention.csv", &["--landmarks", "attention"]);
    let cascade = extract(dir.path(), "cascade.csv", &["--landmarks", "cascade"]);
    assert_eq!(default, attention);
    assert_ne!(default, cascade, "two networks, two readings");
    // The cascade's own options select it.
    let every = extract(dir.path(), "every.csv", &["--mesh-every", "2"]);
    assert_eq!(every, cascade);
    let views = extract(dir.path(), "views.csv", &["--iris-views", "3"]);
    let cascade_views = extract(
        dir.path(),
        "cascade_views.csv",
        &["--landmarks", "cascade", "--iris-views", "3"],
    );
    assert_eq!(views, cascade_views);
    assert_ne!(views, cascade);
}

#[test]
#[cfg_attr(
    not(all(has_sample_data, has_models)),
    ignore = "needs .cache/data and the models: run scripts/setup.sh"
)]
fn a_cascade_option_asked_of_the_attention_mesh_is_one_line_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.csv");
    let e = one_line_error(&extract_run(
        &out,
        &["--landmarks", "attention", "--iris-views", "5"],
    ));
    assert!(
        e.contains("--iris-views applies to the cascade landmarks only")
            && e.contains("use --landmarks cascade"),
        "{e}"
    );
    assert!(!out.exists());
}

#[test]
#[cfg_attr(
    not(all(has_sample_data, has_models)),
    ignore = "needs .cache/data and the models: run scripts/setup.sh"
)]
fn a_video_source_is_read_with_the_landmarks_it_names() {
    let dir = tempfile::tempdir().unwrap();
    // Four seconds of franck.mp4, its own frames (no re-encoding).
    let clip = dir.path().join("clip.mp4");
    ffmpeg(&["-i", s(&franck()), "-t", "4", "-c", "copy", "-an", s(&clip)]);
    let cfg = dir.path().join("c.toml");
    std::fs::write(
        &cfg,
        // The clip twice in one class (one recording in two classes is
        // refused), the other class generated.
        "session_frames = 25\n\
         [classes.reading]\nsources = [{ format = \"video\", path = \"clip.mp4\", landmarks = \"attention\" }, \
         { format = \"video\", path = \"clip.mp4\" }]\n\
         [classes.conversation]\n[[classes.conversation.generators]]\nmodel = \"conversation\"\n",
    )
    .unwrap();
    let cache = dir.path().join("cache");
    ok(&eyereplay(&[
        "prepare",
        "--config",
        s(&cfg),
        "--out",
        s(&dir.path().join("ds")),
        "--cache",
        s(&cache),
    ]));
    // One extraction per model, each what `eyereplay extract` writes.
    let mut cached: Vec<Vec<u8>> = std::fs::read_dir(cache.join("extract"))
        .unwrap()
        .map(|e| std::fs::read(e.unwrap().path()).unwrap())
        .collect();
    cached.sort();
    let mut expected: Vec<Vec<u8>> = ["attention", "cascade"]
        .into_iter()
        .map(|m| extract_on(&clip, dir.path(), &format!("{m}.csv"), &["--landmarks", m]))
        .collect();
    expected.sort();
    assert_eq!(cached.len(), 2);
    assert!(
        cached == expected,
        "the cached extractions are not extract's"
    );
    // The metadata names the model where it is not the default.
    let meta = std::fs::read_to_string(dir.path().join("ds/metadata.json")).unwrap();
    assert_eq!(
        meta.matches("\"landmarks\": \"attention\"").count(),
        1,
        "{meta}"
    );
    assert!(!meta.contains("\"landmarks\": \"cascade\""));
}

/// A file cut off part-way (a download or copy stopped short, its index
/// first so that it still opens) is read as far as its frames go, and the
/// summary says it stopped short of what the file declares: without that
/// the rows pass for the whole recording.
#[test]
#[cfg_attr(
    not(all(has_sample_data, has_models, has_ffmpeg)),
    ignore = "needs .cache/data, the models and ffmpeg: run scripts/setup.sh"
)]
fn a_video_cut_off_part_way_is_read_as_far_as_it_goes_and_said_to_be() {
    let dir = tempfile::tempdir().unwrap();
    let whole = dir.path().join("whole.mp4");
    ffmpeg(&[
        "-i",
        s(&franck()),
        "-t",
        "12",
        "-c",
        "copy",
        "-movflags",
        "+faststart",
        s(&whole),
    ]);
    let bytes = std::fs::read(&whole).unwrap();
    let cut = dir.path().join("cut.mp4");
    std::fs::write(&cut, &bytes[..bytes.len() / 2]).unwrap();

    let said = ok(&extract_run_on(&whole, &dir.path().join("whole.csv"), &[]));
    assert!(!said.contains("warning"), "{said}");
    let said = ok(&extract_run_on(&cut, &dir.path().join("cut.csv"), &[]));
    let line = said
        .lines()
        .find(|l| l.contains("(cut off?)"))
        .unwrap_or_else(|| panic!("no cut-off warning in:\n{said}"));
    // The number in the warning after `before`.
    let seconds_after = |before: &str| -> f64 {
        line.split(before)
            .nth(1)
            .and_then(|r| r.split(' ').next())
            .and_then(|v| v.parse().ok())
            .unwrap_or_else(|| panic!("{line}"))
    };
    // Half the bytes hold about half of the 12 s.
    let end_s = seconds_after("the frames end at ");
    assert!((3.0..10.0).contains(&end_s), "{line}");
    // The copy of 12 s ends on a whole frame after the cut: 12.0-12.5 s.
    let declared_s = seconds_after("of the ");
    assert!((12.0..=12.5).contains(&declared_s), "{line}");
    // The rows cover what the warning says: from the first frame's time
    // to the last's, plus the last frame's 1/24 s (the video's rate).
    let rows = std::fs::read_to_string(dir.path().join("cut.csv")).unwrap();
    let time_s = |l: &str| -> f64 { l.split(',').nth(1).unwrap().parse().unwrap() };
    let mut lines = rows.lines().skip(1);
    let first = time_s(lines.next().unwrap());
    let last = time_s(lines.last().unwrap());
    let covered_s = last - first + 1.0 / 24.0;
    assert!(
        (covered_s - end_s).abs() <= 0.051,
        "{covered_s} s of rows, {line}"
    );
}

/// A face so small that its rows are mostly noise is found in every
/// frame and its rows look valid: the summary says so. `franck.mp4`'s
/// eyes are about 25 px wide; scaled to 60x48 they are about 4 px
/// (docs/EXTRACTION.md, "Small faces": r_y 0.27 against MediaPipe).
#[test]
#[cfg_attr(
    not(all(has_sample_data, has_models, has_ffmpeg)),
    ignore = "needs .cache/data, the models and ffmpeg: run scripts/setup.sh"
)]
fn a_face_too_small_to_read_is_warned_of() {
    let dir = tempfile::tempdir().unwrap();
    let small = dir.path().join("small.mp4");
    ffmpeg(&[
        "-i",
        s(&franck()),
        "-t",
        "4",
        "-vf",
        "scale=60:48",
        "-c:v",
        "libx264",
        "-crf",
        "18",
        "-an",
        s(&small),
    ]);
    let said = ok(&extract_run_on(&small, &dir.path().join("small.csv"), &[]));
    let line = said
        .lines()
        .find(|l| l.contains("px wide (median, corner to corner)"))
        .unwrap_or_else(|| panic!("no small-eyes warning in:\n{said}"));
    let width_px: f64 = line
        .split("the eyes are ")
        .nth(1)
        .and_then(|r| r.split(' ').next())
        .and_then(|v| v.parse().ok())
        .unwrap_or_else(|| panic!("{line}"));
    // A sixth of 25.5 px, give or take the networks' reading of so few pixels.
    assert!((2.5..7.0).contains(&width_px), "{line}");
    // The rows are written all the same.
    assert!(dir.path().join("small.csv").is_file());
}

/// `scripts/models.sh` puts the models in `$EYEREPLAY_CACHE/models` when
/// that is set: the binary finds them there from any folder, where it
/// used to look only for `.cache/models` up from the current folder and
/// from its own (a copy outside the checkout here, so neither has them).
#[test]
#[cfg_attr(not(has_models), ignore = "needs the models: run scripts/setup.sh")]
fn the_models_are_found_through_eyereplay_cache_from_any_folder() {
    let elsewhere = tempfile::tempdir().unwrap();
    let bin = elsewhere.path().join("eyereplay");
    std::fs::copy(env!("CARGO_BIN_EXE_eyereplay"), &bin).unwrap();
    let models = |cache: Option<&Path>| {
        let mut c = std::process::Command::new(&bin);
        c.args(["models", "check"])
            .current_dir(elsewhere.path())
            .env_remove("EYEREPLAY_MODELS")
            .env_remove("EYEREPLAY_CACHE");
        if let Some(cache) = cache {
            c.env("EYEREPLAY_CACHE", cache);
        }
        c.output().unwrap()
    };
    let said = ok(&models(Some(&root().join(".cache"))));
    assert!(said.contains("runs"), "{said}");
    // Without it, nothing up from that folder holds them: one line.
    let e = one_line_error(&models(None));
    assert!(e.contains("models"), "{e}");
}

/// Where stderr is not a terminal (a Slurm log, `nohup`) the progress bar
/// draws nothing; a plain line with its counts goes there every
/// `EYEREPLAY_LOG_EVERY_S` seconds (30 by default) instead, and none with
/// `--quiet`. 60 s of `franck.mp4` take a few seconds to extract.
#[test]
#[cfg_attr(
    not(all(has_sample_data, has_models)),
    ignore = "needs .cache/data and the models: run scripts/setup.sh"
)]
fn a_log_shows_the_extraction_moving() {
    let dir = tempfile::tempdir().unwrap();
    let run = |quiet: bool| {
        let mut c = std::process::Command::new(env!("CARGO_BIN_EXE_eyereplay"));
        c.args(["extract", s(&franck()), "--max-seconds", "60", "--out"])
            .arg(dir.path().join("f.csv"))
            .current_dir(root())
            .env("EYEREPLAY_LOG_EVERY_S", "1");
        if quiet {
            c.arg("--quiet");
        }
        let o = c.output().unwrap();
        ok(&o);
        String::from_utf8_lossy(&o.stderr).into_owned()
    };
    let log = run(false);
    let lines: Vec<&str> = log
        .lines()
        .filter(|l| l.starts_with("extract franck.mp4: "))
        .collect();
    assert!(!lines.is_empty(), "{log}");
    for l in &lines {
        assert!(
            l.contains("/1440 frames (") && l.contains(" frames/s, ETA "),
            "{l}"
        );
    }
    assert!(!run(true).contains("frames/s"));

    // A value that is not a whole number of seconds was ignored.
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_eyereplay"))
        .args(["extract", s(&franck()), "--out"])
        .arg(dir.path().join("g.csv"))
        .env("EYEREPLAY_LOG_EVERY_S", "abc")
        .output()
        .unwrap();
    let e = one_line_error(&o);
    assert!(e.contains("EYEREPLAY_LOG_EVERY_S=abc"), "{e}");
    assert!(!dir.path().join("g.csv").exists());
    // -v tells what the extraction does (it said nothing more before), in
    // plain text where stderr is a file (colour codes were written there).
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_eyereplay"))
        .args([
            "-v",
            "extract",
            s(&franck()),
            "--max-seconds",
            "2",
            "--quiet",
            "--out",
        ])
        .arg(dir.path().join("v.csv"))
        .env_remove("RUST_LOG")
        .output()
        .unwrap();
    let log = ok(&o);
    let log = format!("{log}{}", String::from_utf8_lossy(&o.stderr));
    assert!(
        log.contains("extracting 1 video(s)") && log.contains("franck.mp4: h264 360x288"),
        "{log}"
    );
    assert!(!log.contains('\x1b'), "{log}");
}

/// `models check` verifies every file it can: the `.tflite` sources and the
/// ONNX Runtime library against their pinned sha256, and each converted
/// network against the sha256 `scripts/models.sh` recorded when it made it.
/// A network with one byte changed is refused by name before anything runs
/// (it may well still run, with other weights), and so is a changed library
/// and a damaged record. The folder is a copy: links to the real files, the
/// damaged one copied.
#[test]
#[cfg_attr(not(has_models), ignore = "needs the models: run scripts/setup.sh")]
fn models_check_refuses_a_network_changed_since_its_conversion() {
    let real = root().join(".cache/models");
    let check = |dir: &Path| {
        std::process::Command::new(env!("CARGO_BIN_EXE_eyereplay"))
            .args(["models", "check", "--dir"])
            .arg(dir)
            .env_remove("EYEREPLAY_ORT_LIB")
            .output()
            .unwrap()
    };
    // A copy of the folder in which `damaged` is a real copy, changed by `f`.
    let copy_with = |damaged: &str, f: &dyn Fn(&mut Vec<u8>)| {
        let dir = tempfile::tempdir().unwrap();
        for e in std::fs::read_dir(&real).unwrap() {
            let p = e.unwrap().path();
            let to = dir.path().join(p.file_name().unwrap());
            if p.file_name().unwrap() == damaged {
                let mut bytes = std::fs::read(&p).unwrap();
                f(&mut bytes);
                std::fs::write(&to, bytes).unwrap();
            } else if std::fs::hard_link(&p, &to).is_err() {
                std::fs::copy(&p, &to).unwrap();
            }
        }
        dir
    };
    let said = ok(&check(&real));
    for file in [
        "iris_landmark.onnx",
        "face_landmark_with_attention_eyes.onnx",
    ] {
        assert!(
            said.contains(&format!("{file}: sha256 ")) && said.contains("(as converted, ok)"),
            "{said}"
        );
    }
    assert!(said.contains("libonnxruntime.so.1.22.1: sha256 "), "{said}");

    // One byte in the middle of the iris network's weights.
    let flip = |b: &mut Vec<u8>| {
        let mid = b.len() / 2;
        b[mid] ^= 0x01;
    };
    let dir = copy_with("iris_landmark.onnx", &flip);
    let e = one_line_error(&check(dir.path()));
    assert!(
        e.contains("iris_landmark.onnx: sha256 ")
            && e.contains("the sha256 recorded at its conversion is ")
            && e.contains("scripts/setup.sh"),
        "{e}"
    );
    // The eye model of the attention mesh, recorded in its face model's stamp.
    let dir = copy_with("face_landmark_with_attention_eyes.onnx", &flip);
    let e = one_line_error(&check(dir.path()));
    assert!(
        e.contains("face_landmark_with_attention_eyes.onnx: sha256 "),
        "{e}"
    );
    // The library, against its pinned sha256.
    let dir = copy_with("libonnxruntime.so.1.22.1", &flip);
    let e = one_line_error(&check(dir.path()));
    assert!(
        e.contains("libonnxruntime.so.1.22.1: sha256 ") && e.contains("the pinned sha256 is "),
        "{e}"
    );
    // A record that is not one names its file and line.
    let dir = copy_with("iris_landmark.onnx.src", &|b| {
        b.extend_from_slice(b"sha256 not-a-hash iris_landmark.onnx\n")
    });
    let e = one_line_error(&check(dir.path()));
    assert!(
        e.contains("iris_landmark.onnx.src: line 3: expected 'sha256 HEX FILE'"),
        "{e}"
    );
    // No record at all (the stamp kept, its sha256 lines gone): a network
    // that cannot be checked fails the check, where it used to pass.
    let dir = copy_with("iris_landmark.onnx.src", &|b| {
        let stamp = b.split(|&c| c == b'\n').next().unwrap_or_default().to_vec();
        *b = stamp;
        b.push(b'\n');
    });
    let e = one_line_error(&check(dir.path()));
    assert!(
        e.contains("iris_landmark.onnx: no sha256 was recorded at its conversion"),
        "{e}"
    );
}

#[test]
#[cfg_attr(
    not(all(has_sample_data, has_models)),
    ignore = "needs .cache/data and the models: run scripts/setup.sh"
)]
fn a_batch_is_checked_whole_before_its_first_video_is_read() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("csv");
    // A missing last video stopped the batch after the first was read,
    // leaving its CSV behind.
    let missing = dir.path().join("nothere.mp4");
    let e = one_line_error(&eyereplay(&[
        "extract",
        s(&franck()),
        s(&missing),
        "--out",
        s(&out),
        "--quiet",
    ]));
    assert!(
        e.contains("nothere.mp4") && e.contains("no such file"),
        "{e}"
    );
    assert!(!out.join("franck.csv").exists());
    // An eye-tracker export given as a video: FFmpeg plays text files as
    // ANSI art, which was decoded for minutes and then had no face.
    let text = dir.path().join("gaze.asc");
    std::fs::write(&text, "MSG 1000 start\n1001 512.0 384.0 900.0\n").unwrap();
    let e = one_line_error(&extract_run_on(&text, &dir.path().join("t.csv"), &[]));
    assert!(
        e.contains("gaze.asc") && e.contains("a text file, not a video"),
        "{e}"
    );
    // Two videos of one name would write one CSV, the second over the first.
    let other = dir.path().join("sub/franck.mp4");
    std::fs::create_dir_all(other.parent().unwrap()).unwrap();
    std::fs::copy(franck(), &other).unwrap();
    let e = one_line_error(&eyereplay(&[
        "extract",
        s(&franck()),
        s(&other),
        "--out",
        s(&out),
        "--quiet",
    ]));
    assert!(e.contains("would both be written to"), "{e}");
    assert!(!out.join("franck.csv").exists());
}
