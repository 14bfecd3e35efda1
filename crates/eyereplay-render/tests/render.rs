//! End-to-end checks of the simulator against independently known values:
//! pixels measured in the rendered image, ffprobe's view of the video, and
//! the error contract.

use eyereplay_core::{Canvas, CanvasPos};
use eyereplay_render::*;
use std::path::Path;

const W: usize = 640;
const H: usize = 360;

fn params() -> RenderParams {
    let mut id = Identity::reference();
    // Blond lashes and brows: the pupil is then the only near-black thing in
    // the image, so its centroid can be measured from pixels alone.
    id.hair_rgb = [0.45, 0.35, 0.2];
    let mut p = RenderParams::new(id);
    p.width = W;
    p.height = H;
    p
}

fn pearson(a: &[f64], b: &[f64]) -> f64 {
    eyereplay_signal::pearson(a, b).unwrap_or(f64::NAN)
}

/// Centroid of the darkest pixels (the pupil) inside an eye's box: those
/// within 10 levels of the darkest one, which must be near black.
fn pupil_centroid(rgb: &[u8], width: usize, g: &EyeGeometry) -> Option<[f64; 2]> {
    let [x0, y0, x1, y1] = g.box_px;
    let maxc = |x: usize, y: usize| {
        let i = (y * width + x) * 3;
        rgb[i].max(rgb[i + 1]).max(rgb[i + 2])
    };
    let mut darkest = 255;
    for y in y0 as usize..y1 as usize {
        for x in x0 as usize..x1 as usize {
            darkest = darkest.min(maxc(x, y));
        }
    }
    if darkest > 40 {
        return None;
    }
    let (mut sx, mut sy, mut n) = (0.0, 0.0, 0.0);
    for y in y0 as usize..y1 as usize {
        for x in x0 as usize..x1 as usize {
            // Soft threshold: rim pixels count by how dark they are, which
            // gives the centroid sub-pixel precision.
            let w = ((darkest as f64 + 20.0 - maxc(x, y) as f64) / 10.0).clamp(0.0, 1.0);
            if w > 0.0 {
                sx += (x as f64 + 0.5) * w;
                sy += (y as f64 + 0.5) * w;
                n += w;
            }
        }
    }
    (n > 0.0).then(|| [sx / n, sy / n])
}

fn render_rgb(scene: &Scene, t: &FrameTruth) -> Vec<u8> {
    let mut rgb = scene.background_rgb().to_vec();
    let mut scratch = Vec::new();
    scene.render_eyes(
        [t.eyes[0].pose, t.eyes[1].pose],
        t.closure,
        t.pupil_scale,
        Some(&mut rgb),
        None,
        &mut scratch,
    );
    rgb
}

/// Linearity of the iris in the image, measured two ways: from the ground
/// truth projection and from the pupil's pixels in the rendered frames.
fn check_linear(traj: &[CanvasPos], p: &RenderParams, label: &str, step: usize) {
    let scene = Scene::new(&p.identity, p.width, p.height);
    let truth = solve_truth(&scene, traj, None, p);
    let geo = scene.geometry();
    let ix: Vec<f64> = traj.iter().map(|c| c.x_px).collect();
    let iy: Vec<f64> = traj.iter().map(|c| c.y_px).collect();
    for (k, g) in geo.iter().enumerate() {
        let tx: Vec<f64> = truth.iter().map(|t| t.eyes[k].iris_px[0]).collect();
        let ty: Vec<f64> = truth.iter().map(|t| t.eyes[k].iris_px[1]).collect();
        let (rx, ry) = (pearson(&ix, &tx), pearson(&iy, &ty));
        assert!(
            rx >= 0.99 && ry >= 0.99,
            "{label} eye {k}: truth r = {rx:.4}, {ry:.4}"
        );
        let mut px = Vec::new();
        let mut py = Vec::new();
        for t in truth.iter().step_by(step) {
            let rgb = render_rgb(&scene, t);
            let c = pupil_centroid(&rgb, p.width, g).expect("pupil visible");
            // The drawn pupil sits where the ground truth says the iris is.
            let err = ((c[0] - t.eyes[k].iris_px[0]).powi(2)
                + (c[1] - t.eyes[k].iris_px[1]).powi(2))
            .sqrt();
            // Within 10 % of the iris radius (refraction and lid occlusion
            // move the apparent pupil slightly at large rotations).
            let tol = 0.1 * p.identity.eye.iris_radius_mm * g.px_per_mm;
            if err >= tol {
                let _ = write_png(
                    Path::new(&format!("/tmp/fail_{label}_{k}.png")),
                    &rgb,
                    p.width,
                    p.height,
                );
            }
            assert!(
                err < tol,
                "{label} eye {k}: pupil at {c:?}, truth {:?}",
                t.eyes[k].iris_px
            );
            if std::env::var("EYE_DEBUG").is_ok() {
                eprintln!(
                    "{k} in {:.1} truth {:.2} pix {:.2} pose {:.3} cl {:.3} pupil {:.3}",
                    t.input.y_px,
                    t.eyes[k].iris_px[1],
                    c[1],
                    t.eyes[k].pose.pitch_rad.to_degrees(),
                    t.closure,
                    t.pupil_scale
                );
            }
            px.push(c[0]);
            py.push(c[1]);
        }
        let sx: Vec<f64> = ix.iter().step_by(step).cloned().collect();
        let sy: Vec<f64> = iy.iter().step_by(step).cloned().collect();
        let (rx, ry) = (pearson(&sx, &px), pearson(&sy, &py));
        assert!(
            rx >= 0.99 && ry >= 0.99,
            "{label} eye {k}: pixel r = {rx:.4}, {ry:.4}"
        );
    }
    // Amplitude: the two eyes' mean normalized position reproduces the
    // source's (the paper's simulator showed 30-42 %).
    let cal = p.mapping.calibration;
    let src: Vec<f64> = traj.iter().map(|c| cal.canvas_to_norm(*c).nx).collect();
    let out: Vec<f64> = truth
        .iter()
        .map(|t| (t.eyes[0].norm.nx + t.eyes[1].norm.nx) / 2.0)
        .collect();
    let range = |v: &[f64]| {
        v.iter().cloned().fold(f64::MIN, f64::max) - v.iter().cloned().fold(f64::MAX, f64::min)
    };
    let ratio = range(&out) / range(&src);
    assert!(
        (ratio - 1.0).abs() < 0.03,
        "{label}: amplitude ratio {ratio:.3}"
    );
}

#[test]
fn iris_follows_reading_scale_input_linearly() {
    let p = params();
    // Sweeps over 8 % of the canvas width, lines stepping down.
    // 8 lines of 60 frames each.
    let traj = reading_trajectory(480, 1280.0, 720.0);
    let xs: Vec<f64> = traj.iter().map(|c| c.x_px).collect();
    let span =
        xs.iter().cloned().fold(f64::MIN, f64::max) - xs.iter().cloned().fold(f64::MAX, f64::min);
    assert!((span / 1280.0 - 0.08).abs() < 0.01);
    // Full HD-ish resolution: the vertical line steps move the iris only a
    // few pixels, so measure them at the production size.
    let mut p = p;
    p.width = 1280;
    p.height = 720;
    check_linear(&traj, &p, "reading", 8);
}

#[test]
fn iris_follows_conversation_scale_input_linearly() {
    let p = params();
    let traj = conversation_trajectory(90, 1280.0, 720.0, 3);
    check_linear(&traj, &p, "conversation", 3);
}

#[test]
fn gain_scales_amplitude_and_vergence_turns_eyes_nasally() {
    let mut p = params();
    let scene = Scene::new(&p.identity, W, H);
    let a = CanvasPos {
        x_px: 600.0,
        y_px: 360.0,
    };
    let b = CanvasPos {
        x_px: 700.0,
        y_px: 360.0,
    };
    let dx = |p: &RenderParams| {
        let t = solve_truth(&scene, &[a, b], None, p);
        t[1].eyes[0].iris_px[0] - t[0].eyes[0].iris_px[0]
    };
    let d1 = dx(&p);
    p.mapping.gain = 2.0;
    let d2 = dx(&p);
    assert!(d1 > 1.0, "{d1}");
    assert!((d2 / d1 - 2.0).abs() < 0.05, "{d1} {d2}");
    // Converging on a screen at 600 mm turns each eye toward the nose by
    // atan(ipd / 2 / 600) relative to looking at infinity.
    p.mapping.gain = 1.0;
    let c = [Canvas::default().center()];
    p.mapping.viewing_distance_mm = 1e9;
    let far = solve_truth(&scene, &c, None, &p);
    p.mapping.viewing_distance_mm = 600.0;
    let near = solve_truth(&scene, &c, None, &p);
    let expect = (p.identity.eye.ipd_mm / 2.0 / 600.0).atan();
    let dl = near[0].eyes[0].pose.yaw_rad - far[0].eyes[0].pose.yaw_rad;
    let dr = near[0].eyes[1].pose.yaw_rad - far[0].eyes[1].pose.yaw_rad;
    assert!(
        (dl - expect).abs() < 1e-6 && (dr + expect).abs() < 1e-6,
        "{dl} {dr} {expect}"
    );
    // Looking at infinity, the eyes are near primary position (within 5 deg).
    assert!(
        far[0].eyes[0].pose.yaw_rad.abs() < 0.09,
        "{:?}",
        far[0].eyes[0].pose
    );
}

struct Collect(Vec<Vec<u8>>);
impl FrameSink for Collect {
    fn frame(&mut self, _i: usize, yuv: &[u8]) -> Result<(), RenderError> {
        self.0.push(yuv.to_vec());
        Ok(())
    }
}

#[test]
fn yuv_fast_path_equals_full_rgb_conversion_and_is_deterministic() {
    let mut p = params();
    p.natural_blinks = true;
    let traj = conversation_trajectory(40, 1280.0, 720.0, 9);
    let mut blinks = vec![false; 40];
    blinks[20..24].iter_mut().for_each(|b| *b = true);
    let run = || {
        let scene = Scene::new(&p.identity, W, H);
        let truth = solve_truth(&scene, &traj, Some(&blinks), &p);
        let mut c = Collect(Vec::new());
        render_frames(&scene, &truth, &mut c).unwrap();
        (scene, truth, c.0)
    };
    let (scene, truth, a) = run();
    let (_, _, b) = run();
    assert_eq!(a, b, "same trajectory and seed must give identical frames");
    assert!(truth[22].blink());
    for i in [0, 21, 22, 30] {
        let rgb = render_rgb(&scene, &truth[i]);
        let mut full = vec![0u8; W * H * 3 / 2];
        eyereplay_render::rgb_to_yuv420(&rgb, W, [0, 0, W, H], &mut full, W, H);
        assert!(
            full == a[i],
            "frame {i}: active-region yuv differs from full conversion"
        );
    }
    // Closed lids hide the pupil; open ones show it.
    let geo = scene.geometry();
    assert!(pupil_centroid(&render_rgb(&scene, &truth[22]), W, &geo[0]).is_none());
    assert!(pupil_centroid(&render_rgb(&scene, &truth[0]), W, &geo[0]).is_some());
}

fn files_in(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

#[test]
fn mp4_has_expected_metadata_and_truth_rows() {
    let dir = tempfile::tempdir().unwrap();
    let p = params();
    let traj = reading_trajectory(30, 1280.0, 720.0);
    let mp4 = dir.path().join("s.mp4");
    let csv = dir.path().join("s_truth.csv");
    let stats = render_session(&traj, None, &p, &mp4, &csv).unwrap();
    assert_eq!(stats.frames, 30);
    let info = probe_video(&mp4, Path::new("ffprobe")).unwrap();
    assert_eq!((info.width, info.height), (W as u32, H as u32));
    assert!((info.fps - 25.0).abs() < 1e-9);
    assert_eq!(info.frames, 30);
    assert_eq!(info.pix_fmt, "yuv420p");
    assert_eq!(info.codec, "h264");
    assert_eq!(info.color_primaries, "bt709");
    let text = std::fs::read_to_string(&csv).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines[0], TRUTH_HEADER);
    assert_eq!(lines.len(), 31);
    assert!(lines[1].starts_with(&format!("0,{:.3},{:.3},", traj[0].x_px, traj[0].y_px)));
    // Only the two outputs, no temporary leftovers.
    assert_eq!(files_in(dir.path()), vec!["s.mp4", "s_truth.csv"]);
    // Byte-identical on a second run.
    let mp4b = dir.path().join("b.mp4");
    let csvb = dir.path().join("b_truth.csv");
    render_session(&traj, None, &p, &mp4b, &csvb).unwrap();
    assert_eq!(std::fs::read(&csv).unwrap(), std::fs::read(&csvb).unwrap());
    assert_eq!(std::fs::read(&mp4).unwrap(), std::fs::read(&mp4b).unwrap());
}

#[test]
fn bad_input_gives_one_line_errors_and_no_files() {
    let dir = tempfile::tempdir().unwrap();
    let p = params();
    let mp4 = dir.path().join("s.mp4");
    let csv = dir.path().join("s_truth.csv");
    let ok = reading_trajectory(5, 1280.0, 720.0);
    let mut seen = Vec::new();
    let mut err = |r: Result<RenderStats, RenderError>| {
        let e = r.unwrap_err().to_string();
        seen.push(e.clone());
        e
    };

    let mut nan = ok.clone();
    nan[3].y_px = f64::NAN;
    let e = err(render_session(&nan, None, &p, &mp4, &csv));
    assert!(
        e.contains("frame 3") && e.contains("not a finite number"),
        "{e}"
    );

    let e = err(render_session(&[], None, &p, &mp4, &csv));
    assert!(e.contains("no frames"), "{e}");

    let e = err(render_session(&ok, Some(&[true]), &p, &mp4, &csv));
    assert!(
        e.contains("blink flags have 1 frames, trajectory has 5"),
        "{e}"
    );

    let mut missing = p.clone();
    missing.encoder.ffmpeg = dir.path().join("no-such-ffmpeg");
    let e = err(render_session(&ok, None, &missing, &mp4, &csv));
    assert!(e.contains("apt-get install ffmpeg"), "{e}");

    // A preset x264 does not have is refused before ffmpeg starts.
    let mut bad_preset = p.clone();
    bad_preset.encoder.preset = "no-such-preset".into();
    let e = err(render_session(&ok, None, &bad_preset, &mp4, &csv));
    assert!(e.contains("preset 'no-such-preset'"), "{e}");

    // A broken encoder (x264 refuses a negative quantizer when it opens)
    // fails after frames were sent.
    let mut broken = p.clone();
    broken.encoder.x264_params = Some("qp=-3".into());
    let e = err(render_session(&ok, None, &broken, &mp4, &csv));
    assert!(e.contains("ffmpeg failed"), "{e}");

    for e in &seen {
        assert!(!e.contains('\n'), "one line: {e}");
    }
    assert!(
        files_in(dir.path()).is_empty(),
        "{:?}",
        files_in(dir.path())
    );

    // Unwritable output: the parent is a regular file.
    let blocker = dir.path().join("file");
    std::fs::write(&blocker, b"x").unwrap();
    let e = render_session(
        &ok,
        None,
        &p,
        &blocker.join("s.mp4"),
        &blocker.join("t.csv"),
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("file"), "{e}");
    assert_eq!(files_in(dir.path()), vec!["file"]);

    // Off-canvas points are clamped and counted, not rejected.
    let mut off = ok.clone();
    off[0].x_px = -50.0;
    off[1].y_px = 5000.0;
    let stats = render_session(&off, None, &p, &mp4, &csv).unwrap();
    assert_eq!(stats.clamped_points, 2);
    let text = std::fs::read_to_string(&csv).unwrap();
    assert!(text.lines().nth(1).unwrap().starts_with("0,0.000,"));
    assert!(text.lines().nth(2).unwrap().contains(",720.000,"));
}

/// One frame through the encoder before a job's sessions start: x264 only
/// warns of an `x264_params` key it does not know and encodes without it
/// (`ffmpeg -loglevel warning` prints "Error parsing option 'foo = 1'."),
/// and refuses a negative quantizer only when it opens; an ffmpeg built
/// without libx264 says "Unknown encoder". Each is one line here.
#[test]
fn the_encoder_settings_are_tried_on_one_frame_first() {
    let ok = EncoderSettings::default();
    ok.check_with_ffmpeg().unwrap();
    let err = |s: &EncoderSettings| s.check_with_ffmpeg().unwrap_err().to_string();
    let mut typo = ok.clone();
    typo.x264_params = Some("keyint=50:bframe=0".into());
    let e = err(&typo);
    assert!(
        e.contains("x264_params 'keyint=50:bframe=0': x264 does not take option 'bframe = 0'"),
        "{e}"
    );
    let mut refused = ok.clone();
    refused.x264_params = Some("qp=-3".into());
    let e = err(&refused);
    assert!(
        e.contains("x264 refuses these encoder settings") && e.ends_with("qp not specified"),
        "{e}"
    );
    // A stand-in for an ffmpeg without libx264, printing what one prints.
    let dir = tempfile::tempdir().unwrap();
    let fake = dir.path().join("ffmpeg");
    std::fs::write(
        &fake,
        "#!/bin/sh\ncat > /dev/null\necho \"Unknown encoder 'libx264'\" >&2\nexit 1\n",
    )
    .unwrap();
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        std::fs::set_permissions(&fake, std::fs::Permissions::from_mode(0o755)).unwrap();
    }
    let mut plain = ok.clone();
    plain.ffmpeg = fake;
    let e = err(&plain);
    assert!(e.contains("has no libx264 encoder"), "{e}");
    for e in [err(&typo), err(&refused), err(&plain)] {
        assert!(!e.contains('\n'), "{e}");
    }
}
