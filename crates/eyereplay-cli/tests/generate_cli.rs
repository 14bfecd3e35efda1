//! `eyereplay generate` / `merge` on the tiny config (real eye-tracker
//! recordings from scripts/fetch-data.sh): determinism, resuming after
//! kill -9, sharding + merge equal to a single-machine run.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::Duration;

mod common;
use common::{eyereplay, root, stopped_when};

fn tiny() -> String {
    root().join("examples/tiny.toml").display().to_string()
}

fn generate(out: &Path, extra: &[&str]) -> Output {
    let cfg = tiny();
    let mut a = vec![
        "generate",
        "--config",
        cfg.as_str(),
        "--out",
        out.to_str().unwrap(),
    ];
    a.extend_from_slice(extra);
    eyereplay(&a)
}

/// A run into a finished folder made with another config: every session
/// is drawn again, and a line says why.
fn rendered_again(o: &Output) {
    ok(o);
    let said = format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(
        said.contains("rendered 8 sessions") && said.contains("rendered again"),
        "{said}"
    );
}

/// sha256 of every CSV and JSON below `dir` (the run log is not data).
fn hashes(dir: &Path) -> BTreeMap<String, String> {
    let mut m = BTreeMap::new();
    walk(dir, dir, &mut m);
    m
}

fn walk(base: &Path, dir: &Path, m: &mut BTreeMap<String, String>) {
    for e in std::fs::read_dir(dir).unwrap().flatten() {
        let p = e.path();
        if p.is_dir() {
            walk(base, &p, m);
        } else if matches!(p.extension().and_then(|x| x.to_str()), Some("csv" | "json")) {
            let rel = p.strip_prefix(base).unwrap().display().to_string();
            m.insert(rel, eyereplay_core::sha256_file(&p).unwrap());
        }
    }
}

fn ok(o: &Output) {
    assert!(
        o.status.success(),
        "{}\n{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
}

#[test]
#[cfg_attr(
    not(all(has_sample_data, has_ffmpeg)),
    ignore = "needs .cache/data and ffmpeg: run scripts/setup.sh"
)]
fn dry_run_measures_and_projects_and_profile_times_stages_writing_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("never");
    let json = dir.path().join("dry.json");
    let o = generate(
        &out,
        &["--dry-run", "--profile-json", json.to_str().unwrap()],
    );
    ok(&o);
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        text.contains("projected:") && text.contains("nothing written"),
        "{text}"
    );
    assert!(!out.exists(), "a dry run wrote {}", out.display());
    // A shard writes no report: its projection has none, and merge's is
    // on a line of its own.
    let o = generate(&out, &["--dry-run", "--shard", "0/2"]);
    ok(&o);
    let shard = String::from_utf8_lossy(&o.stdout);
    assert!(
        shard.contains(", evaluate 0 s)") && shard.contains("then 'eyereplay merge', once"),
        "{shard}"
    );
    let p: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    // tiny.toml renders one session at a time (jobs = 1) of 50 frames; its
    // job is 8 of them.
    assert_eq!(p["sessions_measured"].as_array().unwrap().len(), 1);
    assert_eq!(
        (p["frames"].as_u64(), p["job_frames"].as_u64()),
        (Some(50), Some(400))
    );
    assert!(p["render_total"]["wall_s"].as_f64().unwrap() > 0.0);
    // The encoder's CPU is its own column.
    assert!(
        p["render_total"]["child_cpu_s"].as_f64().unwrap() > 0.0,
        "{p}"
    );
    // --profile: one session alone, its stages in a table whose shares
    // come to the whole.
    let o = generate(
        &out,
        &[
            "--profile",
            "--session",
            "conversation/conversation_0001.csv",
        ],
    );
    ok(&o);
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        text.contains("conversation/conversation_0001.csv (50 frames"),
        "{text}"
    );
    // Top-level rows (two spaces in; nested ones have four) end in their
    // share.
    let top: Vec<&str> = text
        .lines()
        .filter(|l| l.starts_with("  ") && !l.starts_with("    ") && l.ends_with('%'))
        .collect();
    assert!(top.iter().any(|l| l.contains("draw and encode")), "{text}");
    assert!(
        top.iter().any(|l| l.contains("read the video back")),
        "{text}"
    );
    let sum: f64 = top
        .iter()
        .map(|l| {
            let v = l.trim_end_matches('%').rsplit(' ').next().unwrap();
            v.parse::<f64>().unwrap()
        })
        .sum();
    assert!((sum - 100.0).abs() < 0.3, "{sum}: {text}");
    assert!(!out.exists());
    // A session the job does not have: one line naming it.
    let o = generate(&out, &["--profile", "--session", "reading/nope.csv"]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("no session 'reading/nope.csv'"));
}

#[test]
#[cfg_attr(
    not(all(has_sample_data, has_ffmpeg)),
    ignore = "needs .cache/data and ffmpeg: run scripts/setup.sh"
)]
fn generate_is_deterministic_resumable_and_shardable() {
    let dir = tempfile::tempdir().unwrap();
    let a = dir.path().join("a");
    let o = generate(&a, &[]);
    ok(&o);
    // The closing line states the speed against the video drawn: 8
    // sessions x 50 frames at 25 fps = 16 s = 0.3 min.
    let said = String::from_utf8_lossy(&o.stdout);
    assert!(
        said.contains("min for 0.3 min of video: ") && said.contains("x real time): open "),
        "{said}"
    );
    let ha = hashes(&a);
    for f in [
        "labels.csv",
        "metadata.json",
        "reading/reading_0003.csv",
        "conversation/conversation_0000_truth.csv",
        "report/metrics.json",
    ] {
        assert!(ha.contains_key(f), "{f} missing: {:?}", ha.keys());
    }
    assert_eq!(walk_count(&a, "mp4"), 8);
    let meta: serde_json::Value =
        serde_json::from_slice(&std::fs::read(a.join("metadata.json")).unwrap()).unwrap();
    assert_eq!(meta["render"]["sessions"].as_array().unwrap().len(), 8);
    assert!(meta["tool"]["version"].is_string());

    // Rerun in place: everything is skipped and nothing changes.
    let o = generate(&a, &[]);
    ok(&o);
    let said = String::from_utf8_lossy(&o.stdout);
    assert!(said.contains("rendered 0 sessions"), "{said}");
    // Nothing drawn: no speed to state.
    assert!(!said.contains("real time"), "{said}");
    assert_eq!(hashes(&a), ha);

    // A [render] setting changed since (here the close-up probe reading
    // each eye from 3 crops): the sessions are rendered again (not skipped
    // as finished), and the same config as before gives back the same
    // files.
    let changed = dir.path().join("changed.toml");
    let text = std::fs::read_to_string(tiny())
        .unwrap()
        .replace("\"../", &format!("\"{}/", root().display()))
        .replace("jobs = 1\n", "jobs = 1\nextractor_iris_views = 3\n");
    assert!(text.contains("extractor_iris_views = 3"));
    std::fs::write(&changed, text).unwrap();
    let mp4 = a.join("reading/reading_0000.mp4");
    let before = std::fs::read(&mp4).unwrap();
    let o = eyereplay(&[
        "generate",
        "--config",
        changed.to_str().unwrap(),
        "--out",
        a.to_str().unwrap(),
        "--no-evaluate",
    ]);
    rendered_again(&o);
    assert_ne!(
        std::fs::read(&mp4).unwrap(),
        before,
        "drawn through the 3-crop reading's response"
    );
    // Each session records the crops its probe read with (the read-back
    // reads the same way); one crop before.
    let views = |dir: &Path| -> serde_json::Value {
        serde_json::from_slice::<serde_json::Value>(
            &std::fs::read(dir.join("reading/reading_0000_identity.json")).unwrap(),
        )
        .unwrap()["extractor_iris_views"]
            .clone()
    };
    assert_eq!(views(&a), serde_json::json!(3));
    ok(&generate(&a, &[]));
    assert_eq!(hashes(&a), ha);
    assert_eq!(std::fs::read(&mp4).unwrap(), before);
    assert_eq!(views(&a), serde_json::json!(1));

    // Another seed from the command line: a second draw of the same config
    // (other sessions, rendered again though the old files are complete);
    // the config's own seed then gives back the first draw's files.
    let o = generate(&a, &["--seed", "8", "--no-evaluate"]);
    rendered_again(&o);
    let meta: serde_json::Value =
        serde_json::from_slice(&std::fs::read(a.join("metadata.json")).unwrap()).unwrap();
    assert_eq!(meta["seed"], serde_json::json!(8));
    assert_ne!(std::fs::read(&mp4).unwrap(), before);
    ok(&generate(&a, &[]));
    assert_eq!(hashes(&a), ha);

    // Two shards into one folder, then merge: same files as one machine.
    let s = dir.path().join("s");
    ok(&generate(&s, &["--shard", "0/2"]));
    // Before the second shard, merge refuses and names what is missing.
    let o = eyereplay(&["merge", s.to_str().unwrap(), "--no-evaluate"]);
    assert!(!o.status.success());
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(
        e.contains("4 of 8 sessions are not rendered")
            && e.contains("reading/reading_0001.mp4 (session 1): missing"),
        "{e}"
    );
    ok(&generate(&s, &["--shard", "1/2"]));
    ok(&eyereplay(&["merge", s.to_str().unwrap()]));
    assert_eq!(hashes(&s), ha);
    // A shard of another config (here another seed) into that folder is
    // refused before it touches it: it removed the other shards' sessions,
    // and one drawing beside them left videos that did not match the
    // trajectories merge then passed.
    let o = generate(&s, &["--shard", "1/2", "--seed", "9"]);
    assert!(!o.status.success());
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(
        e.contains("made with another config than this shard's") && e.contains("shard 1/2"),
        "{e}"
    );
    assert_eq!(hashes(&s), ha);
    merge_refuses_damage_leaving_the_dataset_as_it_was(&s, &dir.path().join("damaged"));

    // kill -9 in the middle of rendering, then the same command again.
    let k = dir.path().join("k");
    let mut child = Command::new(env!("CARGO_BIN_EXE_eyereplay"))
        .args([
            "generate",
            "--config",
            &tiny(),
            "--out",
            k.to_str().unwrap(),
        ])
        .current_dir(root())
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    // Wait until at least one video is finished, then kill.
    let t0 = std::time::Instant::now();
    while walk_count(&k, "mp4") < 1 && t0.elapsed().as_secs() < 120 {
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    // No half-written file is visible under a final name: every video there
    // is complete (its truth CSV, written after the frames, is there too).
    for p in walk_files(&k) {
        let name = p.file_name().unwrap().to_string_lossy().into_owned();
        assert!(
            !name.ends_with(".tmp") && !name.ends_with(".part") || name.starts_with('.'),
            "{name}"
        );
    }
    ok(&generate(&k, &[]));
    assert_eq!(hashes(&k), ha);
    // The rerun cleaned up what the killed run left behind.
    let hidden: Vec<_> = walk_files(&k)
        .into_iter()
        .filter(|p| p.file_name().unwrap().to_string_lossy().starts_with('.'))
        .collect();
    assert!(hidden.is_empty(), "{hidden:?}");
}

#[test]
#[cfg_attr(
    not(all(has_sample_data, has_ffmpeg)),
    ignore = "needs .cache/data and ffmpeg: run scripts/setup.sh"
)]
fn render_dataset_draws_what_generate_draws() {
    // `prepare` then `render --dataset` is `generate`'s render stage: the
    // same driver, backend and settings (from the recorded [render]
    // table), so the same files, byte for byte, videos included.
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = (dir.path().join("a"), dir.path().join("b"));
    ok(&generate(&a, &["--no-evaluate"]));
    let cfg = tiny();
    ok(&eyereplay(&[
        "prepare",
        "--config",
        cfg.as_str(),
        "--out",
        b.to_str().unwrap(),
    ]));
    let o = eyereplay(&["render", "--dataset", b.to_str().unwrap()]);
    ok(&o);
    assert!(
        String::from_utf8_lossy(&o.stderr).contains("8 sessions drawn by the eyes backend"),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    for f in walk_files(&a) {
        let rel = f.strip_prefix(&a).unwrap();
        let name = rel.display().to_string();
        if !(name.ends_with(".mp4")
            || name.ends_with("_truth.csv")
            || name.ends_with("_identity.json"))
        {
            continue;
        }
        assert_eq!(
            eyereplay_core::sha256_file(&f).unwrap(),
            eyereplay_core::sha256_file(&b.join(rel)).unwrap(),
            "{name}"
        );
    }
    assert_eq!(walk_count(&a, "mp4"), 8);
    assert_eq!(walk_count(&b, "mp4"), 8);
    // A rerun finds every session whole.
    let o = eyereplay(&["render", "--dataset", b.to_str().unwrap()]);
    ok(&o);
    assert!(
        String::from_utf8_lossy(&o.stderr)
            .contains("0 sessions drawn by the eyes backend, 8 already complete"),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
}

/// `merge` on copies of the finished dataset `done`, each damaged one way
/// a disk, a copy or a hand can: refused in one line naming what is wrong,
/// with `metadata.json` left as it was (every check runs before it is
/// rewritten).
fn merge_refuses_damage_leaving_the_dataset_as_it_was(done: &Path, scratch: &Path) {
    let keep_lines = |p: &Path, n: usize| {
        let text = std::fs::read_to_string(p).unwrap();
        let kept: String = text.lines().take(n).map(|l| format!("{l}\n")).collect();
        std::fs::write(p, kept).unwrap();
    };
    type Damage = fn(&Path, &dyn Fn(&Path, usize));
    let cases: [(&str, Damage, &str); 7] = [
        (
            "a row of labels.csv lost",
            |d, keep| keep(&d.join("labels.csv"), 8),
            "labels.csv: lists 7 sessions where metadata.json plans 8",
        ),
        (
            "a row of labels.csv repeated",
            |d, _| {
                let p = d.join("labels.csv");
                let mut text = std::fs::read_to_string(&p).unwrap();
                let row = text.lines().nth(1).unwrap().to_string();
                text.push_str(&format!("{row}\n"));
                std::fs::write(&p, text).unwrap();
            },
            "lists 9 sessions where metadata.json plans 8; from session 9 on",
        ),
        (
            "a session trajectory cut short",
            |d, keep| keep(&d.join("reading/reading_0002.csv"), 20),
            "reading/reading_0002.csv (19 rows)",
        ),
        (
            "a truth file cut short",
            |d, keep| keep(&d.join("conversation/conversation_0001_truth.csv"), 30),
            "1 of 8 sessions are not rendered whole: conversation/conversation_0001_truth.csv (session 5): 29 of 50 rows",
        ),
        (
            "a truth value turned to NaN, the rows all there",
            |d, _| {
                let p = d.join("reading/reading_0001_truth.csv");
                let text = std::fs::read_to_string(&p).unwrap();
                let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
                let mut fields: Vec<&str> = lines[5].split(',').collect();
                fields[11] = "NaN";
                lines[5] = fields.join(",");
                std::fs::write(&p, lines.join("\n") + "\n").unwrap();
            },
            "reading_0001_truth.csv: line 6: column 12 is not a finite number",
        ),
        (
            "another session's identity copied over",
            |d, _| {
                std::fs::copy(
                    d.join("reading/reading_0001_identity.json"),
                    d.join("reading/reading_0000_identity.json"),
                )
                .unwrap();
            },
            "reading_0000_identity.json: is the identity of reading/reading_0001.csv, not of reading/reading_0000.csv",
        ),
        (
            "a video of another size, as many frames",
            |d, _| {
                let mp4 = d.join("reading/reading_0003.mp4");
                let small = d.join("small.mp4");
                let status = Command::new("ffmpeg")
                    .args(["-v", "error", "-i", mp4.to_str().unwrap()])
                    .args(["-vf", "scale=160:90", small.to_str().unwrap()])
                    .status()
                    .unwrap();
                assert!(status.success());
                std::fs::rename(&small, &mp4).unwrap();
            },
            "reading_0003.mp4: is 160x90 where its identity file says 320x180",
        ),
    ];
    for (what, damage, says) in cases {
        fresh_copy(done, scratch);
        damage(scratch, &keep_lines);
        let before = std::fs::read(scratch.join("metadata.json")).unwrap();
        let o = eyereplay(&["merge", scratch.to_str().unwrap(), "--no-evaluate"]);
        let e = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{what}: merged");
        assert!(
            e.contains(says) && e.trim_end().lines().count() == 1,
            "{what}: {e}"
        );
        assert_eq!(
            std::fs::read(scratch.join("metadata.json")).unwrap(),
            before,
            "{what}: metadata.json rewritten"
        );
    }
    // `evaluate` scored a video cut short on the frames it had, with no word.
    // A whole one read back over fewer seconds than its session is fine
    // (each session is 2 s; the visual section reads 1).
    fresh_copy(done, scratch);
    ok(&eyereplay(&[
        "evaluate",
        scratch.to_str().unwrap(),
        "--visual-seconds",
        "1",
    ]));
    // Its bytes cut in half, as an interrupted copy leaves it: the
    // container still says 50 frames (its index comes first).
    let mp4 = scratch.join("reading/reading_0000.mp4");
    let bytes = std::fs::read(&mp4).unwrap();
    std::fs::write(&mp4, &bytes[..bytes.len() / 2]).unwrap();
    let o = eyereplay(&["evaluate", scratch.to_str().unwrap()]);
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success()
            && e.contains("reading_0000.mp4: ")
            && e.contains(" video frames, but its trajectory has 50: cut short or replaced?")
            && e.trim_end().lines().count() == 1,
        "{e}"
    );
}

/// `to` made a copy of the dataset `from` (whatever was there removed).
fn fresh_copy(from: &Path, to: &Path) {
    let _ = std::fs::remove_dir_all(to);
    for f in walk_files(from) {
        let dest = to.join(f.strip_prefix(from).unwrap());
        std::fs::create_dir_all(dest.parent().unwrap()).unwrap();
        std::fs::copy(&f, &dest).unwrap();
    }
}

fn walk_files(dir: &Path) -> Vec<PathBuf> {
    let mut v = Vec::new();
    if let Ok(rd) = std::fs::read_dir(dir) {
        for e in rd.flatten() {
            if e.path().is_dir() {
                v.extend(walk_files(&e.path()));
            } else {
                v.push(e.path());
            }
        }
    }
    v
}

fn walk_count(dir: &Path, ext: &str) -> usize {
    walk_files(dir)
        .iter()
        .filter(|p| p.extension().and_then(|x| x.to_str()) == Some(ext))
        .count()
}

#[test]
fn bad_inputs_stop_before_work() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = dir.path().join("c.toml");
    let out = dir.path().join("out");
    // `eyereplay generate` on `config`, plus extra arguments: its stderr.
    let generate = |config: &str, extra: &[&str]| {
        std::fs::write(&cfg, config).unwrap();
        let (c, o) = (cfg.to_str().unwrap(), out.to_str().unwrap());
        let args = [&["generate", "--config", c, "--out", o][..], extra].concat();
        let o = eyereplay(&args);
        assert!(!o.status.success());
        String::from_utf8_lossy(&o.stderr).into_owned()
    };
    let e = generate(
        "[render]\nwidht = 3\n[classes.reading]\nsources = [{ format = \"extract\", path = \"x.csv\" }]\n",
        &[],
    );
    assert!(e.contains("did you mean 'width'"), "{e}");
    assert_eq!(e.trim_end().lines().count(), 1, "{e}");

    let missing = "[classes.reading]\nsources = [{ format = \"video\", path = \"missing.mp4\" }]\n";
    let e = generate(missing, &[]);
    assert!(e.contains("missing.mp4"), "{e}");
    assert!(!out.join("metadata.json").exists());

    let e = generate(missing, &["--shard", "3/3"]);
    assert!(e.contains("0-based"), "{e}");

    // The full-face mode checks its own settings and photos before work.
    let onestop = root().join(".cache/data/onestop_fixations.csv");
    let face = |render: &str| {
        format!(
            "[render]\nbackend = \"face\"\n{render}\n[classes.reading]\nsources = [{{ format = \"fixations\", path = \"{}\", group_columns = [\"participant_id\", \"TRIAL_INDEX\"], amplitude_column = \"NEXT_SAC_AMPLITUDE\", screen_px = [2560, 1440] }}]\n",
            onestop.display()
        )
    };
    let e = generate(&face("identities = [\"nobody.jpg\"]"), &[]);
    assert!(e.contains("nobody.jpg") && e.contains("not found"), "{e}");
    assert_eq!(e.trim_end().lines().count(), 1, "{e}");
    let not_a_photo = dir.path().join("me.jpg");
    std::fs::write(&not_a_photo, "not an image").unwrap();
    let e = generate(
        &face(&format!("identities = [\"{}\"]", not_a_photo.display())),
        &[],
    );
    assert!(
        e.contains("me.jpg") && e.contains("cannot read the image"),
        "{e}"
    );
    assert_eq!(e.trim_end().lines().count(), 1, "{e}");
    let e = generate(&face("[render.webcam]\nnoise_sigma = [4.0, 2.0]"), &[]);
    assert!(e.contains("noise_sigma"), "{e}");
    assert_eq!(e.trim_end().lines().count(), 1, "{e}");
    let e = generate(&face("[render.webcam]\nnoise = [1.0, 2.0]"), &[]);
    assert!(e.contains("noise"), "{e}");
    let e = generate(&face("face_height_frac = [0.5, 0.3]"), &[]);
    assert!(e.contains("face_height_frac"), "{e}");
    for views in ["0", "10"] {
        let e = generate(&face(&format!("extractor_iris_views = {views}")), &[]);
        assert!(
            e.contains("extractor_iris_views") && e.contains("between 1 and 9"),
            "{e}"
        );
        assert_eq!(e.trim_end().lines().count(), 1, "{e}");
    }
    // A head driven by the sources needs a video source, and the face mode.
    let e = generate(&face("head_motion = \"source\""), &[]);
    assert!(
        e.contains("head_motion") && e.contains("format = \"video\""),
        "{e}"
    );
    assert_eq!(e.trim_end().lines().count(), 1, "{e}");
    let e = generate(
        &face("head_motion = \"source\"").replace("backend = \"face\"", "backend = \"eyes\""),
        &[],
    );
    assert!(e.contains("head_motion") && e.contains("face"), "{e}");
    // The read-back match refines the face mode's probe: it needs both,
    // and no other backend has it.
    let e = generate(&face("match_readback = true\nmatch_extractor = false"), &[]);
    assert!(
        e.contains("match_readback") && e.contains("match_extractor = true"),
        "{e}"
    );
    assert_eq!(e.trim_end().lines().count(), 1, "{e}");
    for every in [0, 11] {
        let e = generate(
            &face(&format!(
                "match_readback = true\nmatch_readback_every = {every}"
            )),
            &[],
        );
        assert!(
            e.contains(&format!(
                "match_readback_every {every} must be between 1 and 10"
            )),
            "{e}"
        );
        assert_eq!(e.trim_end().lines().count(), 1, "{e}");
    }
    let e = generate(
        &face("match_readback = true").replace("backend = \"face\"", "backend = \"eyes\""),
        &[],
    );
    assert!(
        e.contains("'match_readback' does not apply to backend = \"eyes\" (only to \"face\")"),
        "{e}"
    );
    assert_eq!(e.trim_end().lines().count(), 1, "{e}");
    // One class only: the evaluation would fail after the rendering.
    let e = generate(&face("").replace("backend = \"face\"", ""), &[]);
    assert!(
        e.contains("'conversation' has no sessions") && e.contains("--no-evaluate"),
        "{e}"
    );
    assert_eq!(e.trim_end().lines().count(), 1, "{e}");
    assert!(!out.join("metadata.json").exists());

    // A folder of the user's own files is not taken for a dataset (writing
    // one there removed their session-named files and replaced
    // labels.csv); nor is a file.
    let tiny = root().join("examples/tiny.toml");
    let mine = dir.path().join("mine");
    std::fs::create_dir_all(mine.join("reading")).unwrap();
    std::fs::write(mine.join("reading/reading_0009.csv"), "mine").unwrap();
    std::fs::write(mine.join("notes.txt"), "mine").unwrap();
    for (target, says) in [
        (
            &mine,
            "holds files that are not part of an eyereplay dataset (notes.txt)",
        ),
        (&not_a_photo, "is a file, not a folder"),
    ] {
        let o = eyereplay(&[
            "generate",
            "--config",
            tiny.to_str().unwrap(),
            "--out",
            target.to_str().unwrap(),
        ]);
        let e = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success() && e.contains(says), "{e}");
        assert_eq!(e.trim_end().lines().count(), 1, "{e}");
    }
    assert_eq!(
        std::fs::read_to_string(mine.join("reading/reading_0009.csv")).unwrap(),
        "mine"
    );
    assert_eq!(std::fs::read_dir(&mine).unwrap().count(), 2);
}

/// A stop at the worst moments leaves nothing behind and loses nothing:
/// while the report is being written, the report stays whole, the old one
/// or the new one, which has the same data files (its swap is never cut
/// between its two renames), and no `.report.*` folder is left; in `generate --profile`, the scratch dataset in the
/// temporary folder is removed.
#[test]
fn a_stop_while_the_report_or_a_scratch_dataset_is_written_leaves_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().join("d");
    ok(&generate(&d, &[]));
    let before = hashes(&d.join("report"));
    assert!(before.contains_key("metrics.json"), "{before:?}");
    for signal in [libc::SIGINT, libc::SIGTERM] {
        let o = stopped_when(
            &["evaluate", d.to_str().unwrap()],
            &[],
            &d,
            ".report.tmp",
            Duration::ZERO,
            signal,
        );
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!err.contains("error:"), "{err}");
        match o.status.code() {
            // Stopped: the stop's one line last, and no summary; the
            // status a shell gives a process the signal killed.
            Some(code) if code == 128 + signal => {
                let last = err.trim_end().lines().last().unwrap_or_default();
                assert!(last.starts_with("stopped"), "{err}");
                assert!(!err.contains("report: "), "{err}");
            }
            // The stop landed once the report was in place: it stopped
            // nothing, and the command ends as it would have.
            Some(0) => assert!(err.trim_end().ends_with("metrics.json"), "{err}"),
            other => panic!("status {other:?}: {err}"),
        }
        let hidden: Vec<String> = std::fs::read_dir(&d)
            .unwrap()
            .flatten()
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .filter(|n| n.starts_with('.'))
            .collect();
        assert!(hidden.is_empty(), "{hidden:?}");
        assert_eq!(hashes(&d.join("report")), before, "the old report changed");
        assert!(d.join("report/index.html").is_file());
    }
    let tmp = dir.path().join("tmp");
    std::fs::create_dir(&tmp).unwrap();
    let cfg = tiny();
    let o = stopped_when(
        &["generate", "--config", &cfg, "--profile"],
        &[("TMPDIR", &tmp)],
        &tmp,
        ".tmp",
        Duration::ZERO,
        libc::SIGINT,
    );
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(130), "{err}");
    let left: Vec<_> = std::fs::read_dir(&tmp)
        .unwrap()
        .flatten()
        .map(|e| e.path())
        .collect();
    assert!(left.is_empty(), "{left:?} {err}");
}
