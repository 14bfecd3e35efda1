//! Stage 6 of eyereplay: our own 3D eye simulator.
//!
//! A CPU ray tracer renders a close-up of two eyes (sclera, refracting
//! cornea with glints, textured iris, pupil, lids that follow vertical gaze
//! and blink, lashes, brows, shaded skin) following a session trajectory,
//! pipes yuv420p frames to an `ffmpeg` child running x264, and writes a
//! per-frame ground-truth CSV beside the video.
//!
//! Entry points: [`render_session`] (one trajectory to MP4 + truth CSV),
//! [`list_sessions`] (every session a `prepare` run wrote), [`run_bench`]
//! (speed), [`Identity::sample`] (a seeded face, serializable to JSON).
//!
//! # Gaze mapping
//!
//! See [`GazeMapping`]: canvas px -> the source's normalized iris position
//! `n` (inverse of the `prepare` calibration) -> optional gain -> each eye's
//! yaw/pitch solved so that the iris, measured in the rendered image like the
//! paper's eq. 1, sits at `n` -> plus nasal vergence for a screen at the
//! viewing distance. So by default the video reproduces the source's iris
//! amplitude (the paper's web simulator showed 30-42 % of it).
//!
//! # Where the eyes are
//!
//! See [`Scene`] for the head frame and camera, [`EyeGeometry`] for each
//! eye's corners, centre and redrawn box in image pixels (written to
//! `<stem>_identity.json` by the dataset render). With the default framing
//! the eye centres sit at 55 % of the image height and at
//! `width/2 -+ ipd/2 * px_per_mm` (about x = 330 and 950 of 1280).
//!
//! # Ground truth CSV (`<stem>_truth.csv`)
//!
//! One row per frame; `left` is the image-left eye (the subject's right):
//! `frame`, `x`, `y` (input canvas px after clamping), `*_yaw_deg`,
//! `*_pitch_deg` (eye rotation; + is image-right / up), `*_iris_x_px`,
//! `*_iris_y_px` (projected limbus centre), `*_nx`, `*_ny` (iris position
//! normalized between the eye corners and between the lid midpoints, the
//! paper's eq. 1), `*_aperture` (lid gap at the lid midpoint over the
//! corner-to-corner width), `lid_closure` (0 open .. 1 closed), `blink`
//! (closure >= 0.5).
//!
//! # Speed
//!
//! The face background is rendered once per session; each frame redraws only
//! the 2x2 blocks of the two eye boxes that lids, lashes or the eyeball can
//! reach, straight into yuv420p, with precomputed iris, sclera and lash
//! textures. The eyeball turns about its centre, so where each pixel's ray
//! meets the sclera and how that point is lit never change: they are
//! computed once per session, and per frame a sclera pixel costs a rotation
//! and a texture fetch; only rays that can meet the corneal cap are traced.
//! Whole frames render in parallel on worker threads while the
//! calling thread feeds ffmpeg. `eyereplay render --bench` measures it.

mod bench;
mod blink;
mod dataset;
mod encode;
mod error;
mod gaze;
mod identity;
pub mod math;
mod rng;
mod scene;
mod session;

pub use bench::{
    check_kept_frames, conversation_trajectory, cpu_times, reading_trajectory, run_bench,
    time_bench, BenchReport, BenchShape, SecondPassBench,
};
pub use blink::{closure_at, closure_track};
pub use dataset::{list_sessions, read_dataset_info, session_seed, DatasetInfo, SessionJob};
pub use encode::{
    check_x264_preset, ffprobe_for, probe_video, rgb_to_yuv420, Codec, Encoder, EncoderSettings,
    VideoInfo, DEFAULT_X264_PARAMS, MAX_CRF, X264_PRESETS, X264_TUNES,
};
pub use error::RenderError;
pub use eyereplay_dataset::{read_blink_column, TRUTH_HEADER};
pub use gaze::{default_calibration, probe_grid, Calibration, GazeMapping, ResponseMap};
pub use identity::{CameraPose, EyeShape, Identity, IrisStyle, Lighting};
pub use scene::{EyeGeometry, EyePose, EyeTruth, Eyeball, Scene, Side};
pub use session::{
    check_trajectory, pipeline_frames, render_frames, render_session, render_session_pngs,
    solve_truth, write_truth_csv, FrameSink, FrameTruth, RenderParams, RenderStats,
};

/// Writes an sRGB frame as PNG.
pub fn write_png(
    path: &std::path::Path,
    rgb: &[u8],
    w: usize,
    h: usize,
) -> Result<(), RenderError> {
    eyereplay_core::atomic_write_with(path, |out| {
        let mut enc = png::Encoder::new(out, w as u32, h as u32);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        let mut wr = enc.write_header().map_err(std::io::Error::other)?;
        wr.write_image_data(rgb).map_err(std::io::Error::other)?;
        wr.finish().map_err(std::io::Error::other)?;
        Ok(())
    })?;
    Ok(())
}
