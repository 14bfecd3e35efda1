//! Stage 6 of eyereplay: our own 3D eye simulator.
//!
//! A CPU ray tracer renders a close-up of two eyes (sclera, refracting
//! cornea with glints, textured iris, pupil, lids that follow vertical gaze
//! and blink, lashes, brows, shaded skin) following a session trajectory,
//! pipes yuv420p frames to an `ffmpeg` child running x264, and writes a
//! per-frame ground-truth CSV beside the video.
//!
//! Speed comes from caching what does not move: the face background is
//! rendered once per session, and each frame redraws only the two eye boxes
//! ([`EyeGeometry::box_px`]) with precomputed iris and sclera textures.

mod bench;
mod blink;
mod dataset;
mod encode;
mod error;
mod gaze;
mod identity;
mod math;
mod rng;
mod scene;
mod session;

pub use bench::{conversation_trajectory, cpu_times, reading_trajectory, run_bench, BenchReport};
pub use blink::{closure_at, closure_track};
pub use dataset::{
    is_complete, list_sessions, read_blink_column, read_dataset_info, render_dataset, session_seed,
    DatasetInfo, DatasetOptions, DatasetSummary, SessionJob, SessionOutcome,
};
pub use encode::{ffprobe_for, probe_video, Codec, Encoder, EncoderSettings, VideoInfo};
pub use error::RenderError;
pub use gaze::{Calibration, GazeMapping};
pub use identity::{CameraPose, EyeShape, Identity, IrisStyle, Lighting};
pub use scene::{rgb_to_yuv420, EyeGeometry, EyePose, EyeTruth, Scene, Side};
pub use session::{
    check_trajectory, render_frames, render_session, render_session_pngs, solve_truth,
    write_truth_csv, FrameSink, FrameTruth, RenderParams, RenderStats, TRUTH_HEADER,
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
