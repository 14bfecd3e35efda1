//! Real-face replay (issue 13): a real video of a person facing the camera
//! (a *carrier*) whose eyes are given a session's eye movements, frame by
//! frame, while everything else stays the carrier's: head movement,
//! expressions, blinks, light, skin and the camera's own artefacts.
//!
//! Per carrier, once (cached by the caller):
//! - [`CarrierTrack::measure`]: our extractor (the unmodified MediaPipe
//!   pipeline, the face mesh on every frame) gives each frame's lid contour,
//!   eye corners, lid midpoints, iris centre and radius, face score and the
//!   carrier's own gaze `n`, and flags blinks;
//! - [`CarrierTrack::check`]: a clip without a face, with eyes under
//!   [`MIN_EYE_WIDTH_PX`], or with too few usable frames is refused with a
//!   one-line reason; frames turned too far, blinks and frames without a
//!   face are left untouched and marked;
//! - [`Carrier::prepare`]: each eye's appearance is learned from up to
//!   [`APPEARANCE_FRAMES`] of its frames ([`redraw::AppearanceBuilder`]):
//!   a clean eye opening (sclera, corners, lid shading) in eye-relative
//!   coordinates from the pixels away from the carrier's iris, the iris
//!   (pupil, limbus, colour) by radius and angle from the pixels inside it,
//!   and the corneal highlight where the carrier's eyes show one;
//! - [`Carrier::calibrate`]: how the extractor reads an iris drawn in this
//!   carrier (slope, and each frame's own offset), inverted when drawing.
//!
//! Per output frame ([`render_replay_session`]): the carrier frame at the
//! same time in a ping-pong loop ([`plan_frames`]), both eyes redrawn
//! ([`redraw::redraw_eye`]): inside the lid contour, feathered over a pixel,
//! the clean opening lit as this frame's own sclera, and the learned iris at
//! the place where the extractor's normalization puts the trajectory's `n`
//! ([`redraw::place`]); outside the contour the frame is the carrier's.
//! Then x264, as every mode.

mod carrier;
mod error;
pub mod frame;
pub mod redraw;
mod session;

pub use carrier::{
    CarrierEye, CarrierFrame, CarrierTrack, CarrierUsage, Skip, MIN_EYE_WIDTH_PX,
    MIN_EYE_WIDTH_RATIO, MIN_FRAME_EYE_WIDTH_PX, MIN_USABLE_FRACTION, TRACK_FORMAT_VERSION,
};
pub use error::{ReplayError, Result};
pub use frame::{FrameView, RgbFrame};
pub use session::{
    plan_frames, psnr_outside_eyes, read_carrier_csv, render_replay_session, run_replay_bench,
    start_frame, usable_start_frame, Calibration, Carrier, CarrierCsvRow, ReplayStats, Response,
    APPEARANCE_FRAMES, CALIBRATION_VERSION, CARRIER_CSV_HEADER, GEOMETRY_SMOOTHING_HALF,
};
