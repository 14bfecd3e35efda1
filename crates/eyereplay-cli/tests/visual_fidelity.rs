//! Visual mapping fidelity at reading scale (issue 5, section 4): a short
//! reading session rendered by `eyereplay render` at 1280x720, the iris
//! extracted back by `eyereplay evaluate` (the eye close-up has no
//! detectable face, so the eye-crop path on the render's geometry runs), and
//! the targets: Pearson r >= 0.95 on both axes, amplitude ratio 0.9-1.1.
//! Before the eye-crop path box-filtered its crops and measured nx against
//! the render's fixed corners, a 3000-frame session gave r y 0.92 and
//! ratio x 0.87.
//!
//! Needs ffmpeg and the models in .cache/models (scripts/models.sh): listed
//! as ignored with the reason when they are missing; with `CI` set the build
//! fails instead (build.rs).

use std::fmt::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .canonicalize()
        .unwrap()
}

fn models_dir() -> PathBuf {
    std::env::var_os("EYEREPLAY_MODELS")
        .map(PathBuf::from)
        .unwrap_or_else(|| root().join(".cache/models"))
}

/// Checks that ffmpeg and the models are there. The test is ignored when
/// they were missing at build time (build.rs; with `CI` set the build fails
/// instead), so a missing one here fails it.
fn prerequisites() {
    let ffmpeg = Command::new("ffmpeg")
        .arg("-version")
        .output()
        .is_ok_and(|o| o.status.success());
    let missing = eyereplay_extract::missing_files(&models_dir());
    if ffmpeg && missing.is_empty() {
        return;
    }
    let what = format!(
        "visual fidelity test needs ffmpeg (found: {ffmpeg}) and the models in {} (missing: {}); run scripts/models.sh",
        models_dir().display(),
        missing.join(", ")
    );
    panic!("{what}");
}

fn eyereplay(args: &[&str]) -> Output {
    let o = Command::new(env!("CARGO_BIN_EXE_eyereplay"))
        .args(args)
        .env("EYEREPLAY_MODELS", models_dir())
        .current_dir(root())
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "eyereplay {args:?}\n{}\n{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    o
}

/// The calibration of examples/default.toml's reading class (OneStop
/// readers): canvas px = (n - 0.5) * s + mu.
const CAL: [f64; 4] = [8675.47, 3947.50, 606.50, 515.25];

/// Reading in normalized iris units at the scale of that dataset (its
/// 5-95 % ranges: nx 0.44-0.56, ny 0.41-0.52): lines of 8 fixations of
/// 5 frames (200 ms at 25 fps), one-frame forward saccades, a 3-frame
/// return sweep, lines stepping down a page, a little fixation drift.
fn reading_norm(frames: usize) -> Vec<[f64; 2]> {
    let mut out = Vec::with_capacity(frames);
    let (x0, x1, y0, y1, lines) = (0.44, 0.56, 0.41, 0.52, 8);
    let mut line = 0usize;
    let mut seed = 12345u64;
    let mut jitter = || {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((seed >> 33) as f64 / (1u64 << 31) as f64 - 0.5) * 0.002
    };
    while out.len() < frames {
        let y = y0 + (y1 - y0) * (line % lines) as f64 / (lines - 1) as f64;
        let mut prev = [x1, y];
        for f in 0..8 {
            let x = x0 + (x1 - x0) * f as f64 / 7.0;
            let start = if f == 0 { 3 } else { 1 };
            for k in 1..=start {
                let t = k as f64 / (start + 1) as f64;
                out.push([prev[0] + (x - prev[0]) * t, prev[1] + (y - prev[1]) * t]);
            }
            for _ in 0..5 {
                out.push([x + jitter(), y + jitter()]);
            }
            prev = [x, y];
        }
        line += 1;
    }
    out.truncate(frames);
    out
}

fn session_csv(points: &[[f64; 2]]) -> String {
    let mut s = String::from("frame,x,y\n");
    for (i, p) in points.iter().enumerate() {
        writeln!(s, "{i},{:.3},{:.3}", p[0], p[1]).unwrap();
    }
    s
}

/// A one-session-per-class dataset in `eyereplay prepare`'s layout around
/// the reading session (the conversation class only satisfies the layout).
fn write_dataset(dir: &Path, frames: usize) {
    let px: Vec<[f64; 2]> = reading_norm(frames)
        .iter()
        .map(|n| {
            [
                (n[0] - 0.5) * CAL[0] + CAL[2],
                (n[1] - 0.5) * CAL[1] + CAL[3],
            ]
        })
        .collect();
    let other: Vec<[f64; 2]> = (0..frames)
        .map(|i| {
            let t = i as f64 / 25.0;
            [
                640.0 + 80.0 * (0.3 * t).sin(),
                360.0 + 40.0 * (0.2 * t).cos(),
            ]
        })
        .collect();
    std::fs::create_dir_all(dir.join("pool")).unwrap();
    let mut labels = String::from("file,label,class,sources\n");
    for (class, label, pts) in [("reading", 1, &px), ("conversation", 0, &other)] {
        std::fs::create_dir_all(dir.join(class)).unwrap();
        let rel = format!("{class}/{class}_0000.csv");
        std::fs::write(dir.join(&rel), session_csv(pts)).unwrap();
        let mut pool = String::from("frame,x,y,source\n");
        for (i, p) in pts.iter().enumerate() {
            writeln!(pool, "{i},{:.3},{:.3},{label}", p[0], p[1]).unwrap();
        }
        std::fs::write(dir.join("pool").join(format!("{class}.csv")), pool).unwrap();
        writeln!(labels, "{rel},{label},{class},{label}").unwrap();
    }
    std::fs::write(dir.join("labels.csv"), labels).unwrap();
    let cal = eyereplay_core::Calibration {
        s_x: CAL[0],
        s_y: CAL[1],
        mu_x: CAL[2],
        mu_y: CAL[3],
    };
    let classes = [
        (eyereplay_core::GazeClass::Reading, 1, frames),
        (eyereplay_core::GazeClass::Conversation, 1, frames),
    ];
    let meta = eyereplay_dataset::DatasetMetadata::assembled(
        25.0,
        frames,
        eyereplay_core::Canvas::default(),
        Some(cal),
        &classes,
    );
    eyereplay_dataset::write_metadata(dir, &meta).unwrap();
}

/// Visual fidelity of one rendered reading session: `[r x, r y, ratio x,
/// ratio y]` and a printable report.
fn fidelity(frames: usize, seed: u64) -> ([f64; 4], String) {
    let started = std::time::Instant::now();
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    write_dataset(dir, frames);
    let s = |p: PathBuf| p.display().to_string();
    let seed_arg = seed.to_string();
    eyereplay(&[
        "render",
        &s(dir.join("reading/reading_0000.csv")),
        "--out",
        &s(dir.join("reading/reading_0000.mp4")),
        "--calibration",
        &s(dir.join("metadata.json")),
        "--identity-out",
        &s(dir.join("reading/reading_0000_identity.json")),
        // Blinks as in a real dataset: the comparison must mask them.
        "--natural-blinks",
        "--seed",
        &seed_arg,
    ]);
    let (vals, stderr) = read_back(dir);
    let report = format!(
        "seed {seed}: r x {:.3} y {:.3}, amplitude ratio x {:.3} y {:.3} ({:.0} s)\n{}",
        vals[0],
        vals[1],
        vals[2],
        vals[3],
        started.elapsed().as_secs_f64(),
        stderr
    );
    // The close-up has no face for the detector: the geometry path ran.
    let html = std::fs::read_to_string(dir.join("report/index.html")).unwrap();
    assert!(html.contains("known geometry"), "{report}");
    (vals, report)
}

/// `eyereplay evaluate DIR --visual-session reading/reading_0000.csv`:
/// that session read back from its video, `[r x, r y, ratio x, ratio y]`,
/// and what the command printed on standard error.
fn read_back(dir: &Path) -> ([f64; 4], String) {
    let o = eyereplay(&[
        "evaluate",
        &dir.display().to_string(),
        "--visual-session",
        "reading/reading_0000.csv",
        "--json",
    ]);
    let m: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let v = &m["visual"];
    let get = |axis: &str, key: &str| {
        v[axis][key]
            .as_f64()
            .unwrap_or_else(|| panic!("visual.{axis}.{key} missing in {v}"))
    };
    let vals = [
        get("x", "r"),
        get("y", "r"),
        get("x", "amplitude_ratio"),
        get("y", "amplitude_ratio"),
    ];
    (vals, String::from_utf8_lossy(&o.stderr).into_owned())
}

fn assert_targets(vals: [f64; 4], report: &str) {
    for (i, axis) in ["x", "y"].into_iter().enumerate() {
        assert!(vals[i] >= 0.95, "r {axis}: {report}");
        let ratio = vals[2 + i];
        assert!((0.9..=1.1).contains(&ratio), "ratio {axis}: {report}");
    }
}

#[test]
#[cfg_attr(
    not(all(has_models, has_ffmpeg)),
    ignore = "needs .cache/models and ffmpeg: run scripts/setup.sh"
)]
fn rendered_reading_session_meets_the_visual_fidelity_targets() {
    prerequisites();
    let (vals, report) = fidelity(400, 0);
    eprintln!("{report}");
    assert_targets(vals, &report);
}

/// Seed 5 is the identity whose lids the iris model reads most differently
/// from the renderer's own (vertical amplitude ratio 0.60 when drawn at the
/// geometric target): render.match_extractor brings it inside 0.9-1.1.
#[test]
#[cfg_attr(
    not(all(has_models, has_ffmpeg)),
    ignore = "needs .cache/models and ffmpeg: run scripts/setup.sh"
)]
fn extractor_matched_identity_keeps_its_vertical_amplitude() {
    prerequisites();
    let (vals, report) = fidelity(400, 5);
    eprintln!("{report}");
    assert!(vals[1] >= 0.9, "r y: {report}");
    assert!((0.9..=1.1).contains(&vals[3]), "ratio y: {report}");
}

/// The table over many identities, for tuning the renderer's lids:
/// `EYEREPLAY_SEEDS=0-11 EYEREPLAY_FRAMES=600 cargo test --release -p
/// eyereplay-cli --test visual_fidelity -- --ignored --nocapture seed_table`.
#[test]
#[ignore]
fn seed_table() {
    prerequisites();
    let env = |k: &str, d: &str| std::env::var(k).unwrap_or_else(|_| d.to_string());
    let seeds = env("EYEREPLAY_SEEDS", "0-11");
    let frames: usize = env("EYEREPLAY_FRAMES", "600").parse().unwrap();
    let seeds: Vec<u64> = seeds
        .split(',')
        .flat_map(|part| match part.split_once('-') {
            Some((a, b)) => (a.parse().unwrap()..=b.parse().unwrap()).collect::<Vec<u64>>(),
            None => vec![part.parse().unwrap()],
        })
        .collect();
    let mut table = String::from("seed   r_x    r_y    ratio_x ratio_y\n");
    let mut fails = 0;
    for seed in seeds {
        let (v, _) = fidelity(frames, seed);
        let ok =
            v[0] >= 0.95 && v[1] >= 0.95 && [v[2], v[3]].iter().all(|a| (0.9..=1.1).contains(a));
        fails += usize::from(!ok);
        let line = format!(
            "{seed:<6} {:.3}  {:.3}  {:.3}   {:.3}{}\n",
            v[0],
            v[1],
            v[2],
            v[3],
            if ok { "" } else { "  *" }
        );
        eprint!("{line}");
        table.push_str(&line);
    }
    eprintln!("{frames} frames per seed; {fails} off target\n{table}");
}

/// The bundled photo `giunchedi.jpg`: `$EYEREPLAY_CACHE/faces`, else the
/// checkout's `.cache/faces` (where scripts/setup.sh puts the photos with
/// the models).
fn bundled_photo(name: &str) -> PathBuf {
    let dir = std::env::var_os("EYEREPLAY_CACHE")
        .map(|d| PathBuf::from(d).join("faces"))
        .filter(|d| d.join(name).is_file())
        .unwrap_or_else(|| root().join(".cache/faces"));
    let path = dir.join(name);
    assert!(
        path.is_file(),
        "{} missing: run scripts/setup.sh",
        path.display()
    );
    path
}

/// Eyes small in the frame: the giunchedi photo at 0.41 of a 640x480
/// frame reads the eye's vertical movement at about a fifth of its size,
/// under the quarter a match needs, and the horizontal at about half. The
/// probe then matches the horizontal alone: `generate` says so, the
/// identity file names the vertical as `geometric_axis` and holds that
/// axis's identity row, and the horizontal read back comes up to its size
/// from about half of it without the match (whose ratio the matched
/// horizontal gain predicts).
#[test]
#[cfg_attr(
    not(all(has_models, has_ffmpeg)),
    ignore = "needs .cache/models and ffmpeg: run scripts/setup.sh"
)]
fn eyes_too_small_for_a_vertical_match_are_matched_horizontally() {
    prerequisites();
    let photo = bundled_photo("giunchedi.jpg");
    let tmp = tempfile::tempdir().unwrap();
    let run = |matched: bool| -> (String, serde_json::Value, [f64; 4]) {
        let out = tmp
            .path()
            .join(if matched { "matched" } else { "geometric" });
        let config = tmp.path().join(format!("{matched}.toml"));
        std::fs::write(
            &config,
            format!(
                "session_frames = 250\nseed = 3\n[render]\nbackend = \"face\"\nwidth = 640\n\
                 height = 480\nidentities = [\"{}\"]\nface_height_frac = [0.41, 0.41]\n\
                 match_extractor = {matched}\n[classes.reading]\nsessions = 1\n\
                 [[classes.reading.generators]]\nmodel = \"reading\"\npeople = 1\n\
                 [classes.conversation]\nsessions = 1\n\
                 [[classes.conversation.generators]]\nmodel = \"conversation\"\npeople = 1\n",
                photo.display()
            ),
        )
        .unwrap();
        let s = |p: &Path| p.display().to_string();
        let o = eyereplay(&[
            "generate",
            "--config",
            &s(&config),
            "--out",
            &s(&out),
            "--no-evaluate",
        ]);
        let stderr = String::from_utf8_lossy(&o.stderr).into_owned();
        let identity: serde_json::Value = serde_json::from_slice(
            &std::fs::read(out.join("reading/reading_0000_identity.json")).unwrap(),
        )
        .unwrap();
        (stderr, identity, read_back(&out).0)
    };
    let (said, identity, matched) = run(true);
    let report = format!("{said}\n{identity}\nmatched: {matched:?}");
    assert!(
        said.contains(
            "reading/reading_0000.csv: matched to the extractor horizontally only, \
             and drawn at the geometric position vertically"
        ),
        "{report}"
    );
    assert_eq!(
        identity["identity"]["geometric_axis"], "vertical",
        "{report}"
    );
    let response = &identity["mapping"]["extractor_response"];
    let a = |i: usize, j: usize| response["a"][i][j].as_f64().unwrap();
    // The vertical row is the identity, its offset zero.
    assert_eq!([a(1, 0), a(1, 1)], [0.0, 1.0], "{report}");
    assert_eq!(response["b"][1].as_f64(), Some(0.0), "{report}");
    let gain_x = a(0, 0);
    assert!((0.3..0.7).contains(&gain_x), "{report}");
    let (said, identity, geometric) = run(false);
    let report = format!("{report}\n{said}\ngeometric: {geometric:?}");
    assert!(!said.contains("horizontally only"), "{report}");
    assert!(
        identity["identity"].get("geometric_axis").is_none(),
        "{report}"
    );
    // Unmatched, the horizontal reads at about the probe's gain; matched,
    // at its size.
    assert!((geometric[2] - gain_x).abs() < 0.15, "{report}");
    assert!((0.85..=1.15).contains(&matched[2]), "{report}");
    assert!(matched[0] >= 0.9, "{report}");
}
