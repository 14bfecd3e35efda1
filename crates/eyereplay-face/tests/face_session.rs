//! A full-face session end to end: rendered to H.264 with the default
//! webcam look, read back by the extractor's unmodified video path, and
//! compared with the ground truth (needs scripts/setup.sh's models and
//! face assets).

mod common;

use eyereplay_core::{Canvas, NormPos};
use eyereplay_extract::{extract_video_to_csv, ExtractOptions};
use eyereplay_face::coordination::{CoordinationParams, HeadDynamics, Task, DEFAULT_SWAY_RMS};
use eyereplay_face::webcam::{WebcamLook, WebcamRanges};
use eyereplay_face::*;
use eyereplay_render::{reading_trajectory, EncoderSettings, GazeMapping, Identity};

fn pearson(a: &[f64], b: &[f64]) -> (f64, f64) {
    let n = a.len() as f64;
    let (ma, mb) = (a.iter().sum::<f64>() / n, b.iter().sum::<f64>() / n);
    let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
    for (x, y) in a.iter().zip(b) {
        sab += (x - ma) * (y - mb);
        saa += (x - ma) * (x - ma);
        sbb += (y - mb) * (y - mb);
    }
    (sab / (saa * sbb).sqrt(), sab / saa)
}

/// A scene of a bundled photo at 640x480 with the look `look_seed` draws.
fn scene_of(
    photo: &str,
    look_seed: u64,
) -> Option<(std::path::PathBuf, PhotoFitter, FaceScene, WebcamLook)> {
    let (models, mesh, photo) = (
        common::models()?,
        common::mesh()?,
        common::faces_file(photo)?,
    );
    let mut fitter = PhotoFitter::new(&models, mesh.clone()).unwrap();
    let id = fitter.fit(&photo).unwrap();
    let look = WebcamRanges::default().sample(look_seed);
    let framing = Framing {
        width: 640,
        height: 480,
        vfov_deg: look.vfov_deg,
        face_height_frac: 0.42,
        light_dir: look.light_dir_head(),
    };
    let scene = FaceScene::new(id, &mesh, Identity::sample(look_seed), &framing);
    Some((models, fitter, scene, look))
}

/// Session parameters with the default encoder, no blinks and no probes.
fn params_of(
    mapping: GazeMapping,
    look: WebcamLook,
    task: Task,
    coordination: CoordinationParams,
    seed: u64,
) -> FaceSessionParams {
    FaceSessionParams {
        fps: 25.0,
        mapping,
        natural_blinks: false,
        blink_rate_per_min: 0.0,
        task,
        reading_frames: None,
        coordination,
        dynamics: HeadDynamics::default(),
        sway_rms: DEFAULT_SWAY_RMS,
        look,
        encoder: EncoderSettings::default(),
        seed,
        pose_slopes: None,
        source_head: None,
        head_path: None,
    }
}

/// A reading session of `frames` frames on the astronaut photo, its look
/// and seed `seed`: the scene, the trajectory and plain parameters.
fn reading_session(
    seed: u64,
    frames: usize,
) -> Option<(FaceScene, Vec<eyereplay_core::CanvasPos>, FaceSessionParams)> {
    let (_, _, scene, look) = scene_of("astronaut.png", seed)?;
    let canvas = Canvas::default();
    let traj = reading_trajectory(frames, canvas.width_px as f64, canvas.height_px as f64);
    let p = params_of(
        GazeMapping::new(canvas),
        look,
        Task::Reading,
        CoordinationParams::default(),
        seed,
    );
    Some((scene, traj, p))
}

/// A session's three files under `dir`, named `tag`.
fn files_in(dir: &std::path::Path, tag: &str) -> [std::path::PathBuf; 3] {
    ["mp4", "truth.csv", "head.csv"].map(|e| dir.join(format!("{tag}.{e}")))
}

/// `p` drawn through a response map of gain `a` about (0.5, 0.5): the
/// eyes 1/a times as far from the middle.
fn eyes_farther(p: &FaceSessionParams, a: f64) -> FaceSessionParams {
    let mut p = p.clone();
    p.mapping.extractor_response = Some(eyereplay_render::ResponseMap {
        a: [[a, 0.0], [0.0, a]],
        b: [0.5 * (1.0 - a); 2],
    });
    p
}

/// `second` (the first pass's eyes moved, its head path given) drawn
/// whole into `whole` and over `kept` into `over`.
fn whole_and_over(
    (scene, traj): (&FaceScene, &[eyereplay_core::CanvasPos]),
    second: &FaceSessionParams,
    kept: &KeptFrames,
    [whole, over]: [&[std::path::PathBuf; 3]; 2],
) -> (FaceSessionStats, FaceSessionStats) {
    let w = render_face_session(scene, traj, None, second, &whole[0], &whole[1], &whole[2]);
    let o = render_face_session_over(
        scene,
        traj,
        None,
        second,
        [&over[0], &over[1], &over[2]],
        kept,
    );
    (w.unwrap(), o.unwrap())
}

/// A reading-scale session: the face is found in every frame, the
/// horizontal eye-in-head signal comes back with r >= 0.9 and a gain inside
/// 0.8-1.2 (drawn through `match_extractor`'s response map and pose
/// slopes), the head moves, and the same seed gives the same truth files
/// byte for byte.
#[test]
fn full_face_session_reads_back() {
    let Some((models, mut fitter, scene, look)) = scene_of("astronaut.png", 3) else {
        return;
    };
    let canvas = Canvas::default();
    let traj = reading_trajectory(150, canvas.width_px as f64, canvas.height_px as f64);
    let mut mapping = GazeMapping::new(canvas);
    let targets: Vec<NormPos> = traj.iter().map(|&c| mapping.target_norm(c)).collect();
    let matched =
        match_extractor(&scene, &look, &mut fitter, &targets, &Default::default()).unwrap();
    mapping.extractor_response = matched.response;
    let map = mapping.extractor_response.expect("a response map");
    let mut params = params_of(
        mapping,
        look,
        Task::Reading,
        CoordinationParams::default(),
        3,
    );
    params.pose_slopes = matched.pose_slopes;
    assert!(params.pose_slopes.is_some(), "pose slopes");
    let dir = tempfile::tempdir().unwrap();
    let (mp4, truth, head) = (
        dir.path().join("s.mp4"),
        dir.path().join("s_truth.csv"),
        dir.path().join("s_head.csv"),
    );
    let stats = render_face_session(&scene, &traj, None, &params, &mp4, &truth, &head).unwrap();
    assert_eq!(stats.frames, 150);
    assert!(stats.max_head_yaw_deg > 0.2, "the head sways");
    let ex = extract_video_to_csv(
        &mp4,
        &dir.path().join("x.csv"),
        &ExtractOptions {
            models_dir: models.clone(),
            ..Default::default()
        },
    )
    .unwrap();
    assert!(ex.detection_rate() >= 0.99, "{}", ex.detection_rate());
    let rows = eyereplay_dataset::read_truth_csv(&truth).unwrap();
    let (mut got, mut want) = (vec![], vec![]);
    for ((r, t), target) in ex.rows.iter().zip(&rows).zip(&targets) {
        if let (Some(e), false) = (r.eyes, r.blink || t.blink) {
            got.push(0.5 * (e[0].nx + e[1].nx));
            // The source's own n (the renderer drew its inverse through
            // the response map and the pose slopes).
            want.push(target.nx);
        }
    }
    let (r, gain) = pearson(&want, &got);
    let sd = |v: &[f64]| {
        let m = v.iter().sum::<f64>() / v.len() as f64;
        (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / v.len() as f64).sqrt()
    };
    eprintln!(
        "horizontal r {r:.3} gain {gain:.3} over {} frames; sd want {:.4} got {:.4}; map {map:?}",
        got.len(),
        sd(&want),
        sd(&got)
    );
    assert!(r >= 0.9, "r {r}");
    assert!((0.8..=1.2).contains(&gain), "gain {gain}");

    // Against the drawn eyes' own nx (the truth file): the iris model's
    // corners follow the iris, so `nx` shows less than the eye's movement;
    // `nx_head`, against corners carried by the head, shows more of it.
    let (mut drawn, mut model, mut anchored) = (vec![], vec![], vec![]);
    for (r, t) in ex.rows.iter().zip(&rows) {
        if let (Some(e), false) = (r.eyes, r.blink || t.blink) {
            let h = 0.5 * (e[0].nx_head + e[1].nx_head);
            if h.is_finite() {
                drawn.push(0.5 * (t.eyes[0].nx + t.eyes[1].nx));
                model.push(0.5 * (e[0].nx + e[1].nx));
                anchored.push(h);
            }
        }
    }
    assert!(drawn.len() >= 120, "{} frames with nx_head", drawn.len());
    let (r_model, gain_model) = pearson(&drawn, &model);
    let (r_head, gain_head) = pearson(&drawn, &anchored);
    eprintln!(
        "against the drawn nx: nx r {r_model:.3} gain {gain_model:.3}; nx_head r {r_head:.3} gain {gain_head:.3}"
    );
    assert!(gain_head > gain_model, "{gain_head} vs {gain_model}");
    assert!(r_head >= 0.9, "nx_head r {r_head}");

    // Five crops per eye (`--iris-views 5`) read the drawn iris centre more
    // precisely than one: the spread of extracted minus drawn, px, along
    // each image axis, over the frames both read with the eyes open.
    let ex5 = extract_video_to_csv(
        &mp4,
        &dir.path().join("x5.csv"),
        &ExtractOptions {
            models_dir: models.clone(),
            iris_views: 5,
            ..Default::default()
        },
    )
    .unwrap();
    let spread = |ex: &eyereplay_extract::Extraction, both: &dyn Fn(usize) -> bool| {
        let mut d = [vec![], vec![]];
        for (i, (r, t)) in ex.rows.iter().zip(&rows).enumerate() {
            if let (Some(e), true) = (r.eyes, both(i)) {
                for (got, drawn) in e.iter().zip(&t.eyes) {
                    d[0].push(got.iris.x as f64 - drawn.iris_px[0]);
                    d[1].push(got.iris.y as f64 - drawn.iris_px[1]);
                }
            }
        }
        [sd(&d[0]), sd(&d[1])]
    };
    let open = |ex: &eyereplay_extract::Extraction, i: usize| {
        ex.rows[i].eyes.is_some() && !ex.rows[i].blink && !rows[i].blink
    };
    let both = |i: usize| open(&ex, i) && open(&ex5, i);
    let (one, five) = (spread(&ex, &both), spread(&ex5, &both));
    eprintln!("iris centre error sd (x, y) px: 1 view {one:.3?}, 5 views {five:.3?}");
    assert!(
        five[0] < one[0] && five[1] < one[1],
        "1 view {one:?}, 5 views {five:?}"
    );

    // Determinism of the truth files.
    let (truth2, head2) = (dir.path().join("t2.csv"), dir.path().join("h2.csv"));
    render_face_session(
        &scene,
        &traj,
        None,
        &params,
        &dir.path().join("s2.mp4"),
        &truth2,
        &head2,
    )
    .unwrap();
    assert_eq!(
        std::fs::read(&truth).unwrap(),
        std::fs::read(&truth2).unwrap()
    );
    assert_eq!(
        std::fs::read(&head).unwrap(),
        std::fs::read(&head2).unwrap()
    );
}

/// Head yaw solved from the landmarks the extractor finds in a rendered
/// conversation-scale session (coordination and sway on, head turns up to
/// the mode's limit) against the session's head ground truth: r >= 0.9,
/// with the identity's own shape and with the canonical mesh (what an
/// unknown person's video gets).
#[test]
fn head_yaw_from_rendered_video() {
    let Some((models, _, scene, look)) = scene_of("grace_hopper.jpg", 8) else {
        return;
    };
    let mesh = common::mesh().expect("checked by scene_of");
    let own = scene.identity.shape_cm.clone();
    let canvas = Canvas::default();
    let traj = eyereplay_render::conversation_trajectory(
        200,
        canvas.width_px as f64,
        canvas.height_px as f64,
        8,
    );
    let params = params_of(
        GazeMapping::new(canvas),
        look.clone(),
        Task::Saccades,
        CoordinationParams {
            e0_deg: 8.0,
            k: 0.8,
        },
        8,
    );
    let dir = tempfile::tempdir().unwrap();
    let (mp4, head) = (dir.path().join("s.mp4"), dir.path().join("s_head.csv"));
    let stats = render_face_session(
        &scene,
        &traj,
        None,
        &params,
        &mp4,
        &dir.path().join("t.csv"),
        &head,
    )
    .unwrap();
    assert!(stats.max_head_yaw_deg > 5.0, "{}", stats.max_head_yaw_deg);
    let text = std::fs::read_to_string(&head).unwrap();
    let truth: Vec<f64> = text
        .lines()
        .skip(1)
        .map(|l| l.split(',').nth(1).unwrap().parse::<f64>().unwrap())
        .collect();
    for (name, shape) in [("own", &own), ("canonical", &mesh.positions_cm)] {
        let poses = video_head_poses(
            &mp4,
            &models,
            &mesh,
            shape,
            look.vfov_deg,
            &eyereplay_extract::NoProgress,
        )
        .unwrap();
        let (mut a, mut b) = (vec![], vec![]);
        for ((_, p), t) in poses.iter().zip(&truth) {
            if let Some(p) = p {
                a.push(*t);
                b.push(p.yaw_deg);
            }
        }
        assert!(a.len() >= 198, "face in {} of 200 frames", a.len());
        let (r, slope) = pearson(&a, &b);
        eprintln!("head yaw from landmarks ({name} shape): r {r:.3}, slope {slope:.2}");
        assert!(r >= 0.9, "{name}: r {r}");
        assert!((0.7..=1.3).contains(&slope), "{name}: slope {slope}");
    }
}

/// `FaceSessionParams::head_path` (the read-back match's second pass): a
/// session drawn again through another response map plans another head
/// (the coordination model turns the head with the drawn eye), but with
/// the first render's head path it draws that head, to the head truth's
/// last digit, while the eye follows the new map; a path of another length
/// is refused before any file is written.
#[test]
fn a_given_head_path_is_drawn_as_given() {
    let Some((scene, traj, first)) = reading_session(4, 40) else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let render = |p: &FaceSessionParams, tag: &str| {
        let paths = files_in(dir.path(), tag);
        let stats =
            render_face_session(&scene, &traj, None, p, &paths[0], &paths[1], &paths[2]).unwrap();
        let text = |k: usize| std::fs::read_to_string(&paths[k]).unwrap();
        // The head truth's head columns (frame, yaw, pitch, roll, x, y, z);
        // the eye and gaze columns after them follow the drawn eye.
        let head: Vec<String> = text(2)
            .lines()
            .map(|l| l.split(',').take(7).collect::<Vec<_>>().join(","))
            .collect();
        (stats, text(1), head)
    };
    let (stats, truth, head) = render(&first, "first");
    assert_eq!(stats.drawn.len(), 40);
    // Another map: the eye is drawn 1.5x as far (a gain of 2/3).
    let mut second = eyes_farther(&first, 2.0 / 3.0);
    let (_, _, planned_head) = render(&second, "planned");
    assert_ne!(
        planned_head, head,
        "the planned head moves with the drawn eye"
    );
    second.head_path = Some(stats.head_path.clone());
    // A path of another length is refused before anything is written.
    let mut short = second.clone();
    short.head_path = Some(stats.head_path[..39].to_vec());
    let paths = files_in(dir.path(), "short");
    let e = render_face_session(&scene, &traj, None, &short, &paths[0], &paths[1], &paths[2])
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("head path has 39 frames") && e.contains("40"),
        "{e}"
    );
    assert!(paths.iter().all(|p| !p.exists()));
    let (again, again_truth, again_head) = render(&second, "kept");
    assert_eq!(again_head, head);
    assert_ne!(again_truth, truth);
    for (a, b) in again.drawn.iter().zip(&stats.drawn) {
        assert_eq!(a.head, b.head);
        // Drawn 1.5x as far from the map's fixed point (0.5, 0.5).
        let want = 0.5 + 1.5 * (b.drawn.nx - 0.5);
        assert!((a.drawn.nx - want).abs() < 1e-9, "{} vs {want}", a.drawn.nx);
    }
}

/// Every frame of a video as RGB, decoded by the extractor's decoder.
fn decoded_frames(video: &std::path::Path) -> Vec<Vec<u8>> {
    let mut dec = eyereplay_extract::Decoder::open(video).unwrap();
    let mut frames = vec![];
    dec.frames(|_, img| {
        frames.push(img.to_rgb8(1).2);
        Ok(std::ops::ControlFlow::Continue(()))
    })
    .unwrap();
    frames
}

/// Drawing every other frame (the read-back match's first pass) draws the
/// session's own frames: encoded losslessly, frame j of the half-rate
/// video decodes to frame 2j of the whole one to the byte (the head moves and the
/// lids blink, so the motion blur and the blink track are the session's,
/// not the half-rate's), the truth rows are the whole's even rows with
/// their frame numbers, the head path is the whole session's, and a step
/// of 0 is refused.
#[test]
fn every_other_frame_is_the_sessions_own() {
    let Some((scene, traj, mut p)) = reading_session(5, 30) else {
        return;
    };
    p.look.bitrate_kbps = 0.0;
    p.encoder.codec = eyereplay_render::Codec::Lossless;
    // Blinks at many times the natural rate: some fall in the 30 frames.
    p.natural_blinks = true;
    p.blink_rate_per_min = 200.0;
    let dir = tempfile::tempdir().unwrap();
    let render = |step: usize, tag: &str| {
        let paths = files_in(dir.path(), tag);
        let stats = render_face_session_every(
            &scene,
            &traj,
            None,
            &p,
            step,
            [&paths[0], &paths[1], &paths[2]],
        )?;
        let lines = |k: usize| -> Vec<String> {
            let text = std::fs::read_to_string(&paths[k]).unwrap();
            text.lines().map(str::to_string).collect()
        };
        let frames = decoded_frames(&paths[0]);
        Ok::<_, FaceError>((stats, lines(1), lines(2), frames))
    };
    let (whole, truth, head, frames) = render(1, "whole").unwrap();
    let (half, half_truth, half_head, half_frames) = render(2, "half").unwrap();
    assert_eq!((frames.len(), half_frames.len()), (30, 15));
    assert!(whole.blink_frames > 0, "a blink in the session");
    assert!(whole.max_head_yaw_deg > 0.05, "the head moves");
    for (j, f) in half_frames.iter().enumerate() {
        assert!(*f == frames[2 * j], "frame {j} of the half-rate video");
    }
    // Header, then every other row, numbered as in the whole session.
    let even = |lines: &[String]| -> Vec<String> {
        let mut v = vec![lines[0].clone()];
        v.extend(lines[1..].iter().step_by(2).cloned());
        v
    };
    assert_eq!(half_truth, even(&truth));
    assert_eq!(half_head, even(&head));
    assert!(half_truth[2].starts_with("2,"), "{}", half_truth[2]);
    assert_eq!(half.head_path, whole.head_path);
    assert_eq!(half.head_path.len(), 30);
    assert_eq!(half.drawn.len(), 15);
    for (j, d) in half.drawn.iter().enumerate() {
        assert_eq!(*d, whole.drawn[2 * j]);
    }
    let e = render(0, "none").unwrap_err().to_string();
    assert!(e.contains("frame step must be at least 1"), "{e}");
}

/// The read-back match's second pass drawn over the first pass's kept
/// frames (`render_face_session_over`) gives the video a whole drawing
/// gives, to the byte: the first pass draws every other frame through one
/// response map and keeps them; the second draws the same head through
/// another (the eyes 1.5x as far) twice, whole and over the kept frames;
/// the head moves and the lids blink (the motion blur, the closing lid's
/// band), the look blurs and adds noise, and the encoder is the session's
/// own at its video-call bitrate. The kept frames were used (every other
/// frame), and their eyes really were redrawn: decoded losslessly, the
/// second pass's even frames differ from the first pass's.
#[test]
fn the_second_pass_over_kept_frames_is_the_whole_drawing() {
    let Some((scene, traj, mut first)) = reading_session(6, 30) else {
        return;
    };
    first.natural_blinks = true;
    first.blink_rate_per_min = 200.0;
    let dir = tempfile::tempdir().unwrap();
    let paths = |tag: &str| files_in(dir.path(), tag);
    for lossless in [false, true] {
        let mut first = first.clone();
        if lossless {
            first.encoder.codec = eyereplay_render::Codec::Lossless;
            first.look.bitrate_kbps = 0.0;
        }
        let f = paths("first");
        let (stats, kept) = render_face_session_every_kept(
            &scene,
            &traj,
            None,
            &first,
            2,
            [&f[0], &f[1], &f[2]],
            KEEP_FRAMES_BUDGET_BYTES,
        )
        .unwrap();
        assert_eq!((kept.frames(), kept.step()), (15, 2));
        assert!(stats.blink_frames > 0, "a blink among the frames drawn");
        let mut second = eyes_farther(&first, 2.0 / 3.0);
        second.head_path = Some(stats.head_path.clone());
        let (w, o) = (paths("whole"), paths("over"));
        let (whole, over) = whole_and_over((&scene, &traj), &second, &kept, [&w, &o]);
        assert_eq!((whole.frames_over_kept, over.frames_over_kept), (0, 15));
        assert!(whole.max_head_yaw_deg > 0.05, "the head moves");
        for k in 0..3 {
            assert!(
                std::fs::read(&w[k]).unwrap() == std::fs::read(&o[k]).unwrap(),
                "{} (lossless {lossless})",
                o[k].display()
            );
        }
        if lossless {
            let (before, after) = (decoded_frames(&f[0]), decoded_frames(&o[0]));
            let redrawn = (0..15).filter(|&j| before[j] != after[2 * j]).count();
            assert!(redrawn >= 12, "{redrawn} of 15 kept frames redrawn");
        }
    }
}

/// A budget that holds only some frames keeps the first of them; the
/// second pass draws the rest whole, and the video is the same.
#[test]
fn a_kept_frames_budget_keeps_the_first_frames() {
    let Some((scene, traj, first)) = reading_session(7, 20) else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let paths = |tag: &str| files_in(dir.path(), tag);
    let f = paths("first");
    let frame_bytes = 640 * 480 * 3 / 2;
    let (stats, kept) = render_face_session_every_kept(
        &scene,
        &traj,
        None,
        &first,
        2,
        [&f[0], &f[1], &f[2]],
        4 * frame_bytes + frame_bytes / 2,
    )
    .unwrap();
    assert_eq!(kept.frames(), 4);
    let mut second = eyes_farther(&first, 0.8);
    second.head_path = Some(stats.head_path.clone());
    let (w, o) = (paths("whole"), paths("over"));
    let (_, over) = whole_and_over((&scene, &traj), &second, &kept, [&w, &o]);
    assert_eq!(over.frames_over_kept, 4);
    assert!(std::fs::read(&w[0]).unwrap() == std::fs::read(&o[0]).unwrap());
}

/// The face bench times the read-back match's second pass on its own
/// frames (`render --bench --face`'s last line): all of them, the budget
/// holding their kept half, both passes' CPU time read, every kept frame
/// redrawn in a strip, and the line printed with the ratio of the two and
/// the strip's share of the rows.
#[test]
fn the_face_bench_times_the_second_pass() {
    let Some((scene, traj, p)) = reading_session(8, 50) else {
        return;
    };
    let report = run_face_bench(&scene, &traj, &p).unwrap();
    let sp = report.second_pass.expect("CPU time is read on Linux");
    assert_eq!(sp.frames, 50);
    assert!(sp.whole_cpu_ms > 0.0 && sp.over_kept_cpu_ms > 0.0, "{sp:?}");
    // Every kept frame drawn over (a frame drawn whole would count all its
    // rows, and a strip is at most half of them), around the eyes only.
    assert!(sp.strip_frac > 0.05 && sp.strip_frac <= 0.5, "{sp:?}");
    let text = report.to_string();
    let want = format!("{:.2}x", sp.over_kept_cpu_ms / sp.whole_cpu_ms);
    let rows = format!("{:.0} % of the kept frames' rows", 100.0 * sp.strip_frac);
    let line = text.lines().last().unwrap();
    assert!(
        line.starts_with("second pass")
            && line.contains(&want)
            && line.contains("50 frames")
            && line.contains(&rows),
        "{text}"
    );
}
