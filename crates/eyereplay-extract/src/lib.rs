//! Stage 1 of eyereplay: iris positions from real video.
//!
//! The pipeline is MediaPipe's face mesh with iris refinement, rebuilt in
//! Rust around its own networks (taken from the `mediapipe==0.10.21` wheel
//! and converted to ONNX by `scripts/models.sh`), run with ONNX Runtime:
//! face detection -> rotated face crop -> 468 landmarks -> two eye crops ->
//! iris model (iris centre, rim and a 71-point eye contour), mapped back to
//! image pixels. The face crop of the next frame comes from this frame's
//! landmarks; the detector runs again when the face score drops below 0.5.
//!
//! # Conventions of the output
//!
//! - "left"/"right" name the eye on the image's left/right (not the
//!   person's), whatever the head's roll.
//! - `nx = (iris_x - left_corner_x) / (right_corner_x - left_corner_x)`,
//!   the same image direction for both eyes, so a sideways gaze moves both
//!   eyes' `nx` the same way and their mean keeps it. (Anatomical
//!   inner/outer corners would make the eyes move in opposite directions
//!   and the mean would cancel the horizontal signal.)
//! - `ny = (iris_y - upper_lid_y) / (lower_lid_y - upper_lid_y)`.
//! - Corners and lids come from the iris model's eye contour, as in
//!   MediaPipe's iris tracking (the 468-point mesh's lids gave a vertical
//!   signal uncorrelated with MediaPipe's).
//! - `aperture` = lid gap / corner-to-corner width; frames whose aperture
//!   drops below 0.6 x the video's median (and their neighbours) are
//!   blinks: `blink=1`, `valid=0`.
//! - `time_s` is the frame's presentation time on the stream's clock
//!   (`best_effort_timestamp x time_base`, as ffprobe's `pts_time`), so
//!   variable-frame-rate video keeps its real timing.

mod anchor;
pub mod attention;
mod compare;
mod decode;
mod detect;
mod error;
mod eyecrop;
mod geom;
mod image;
mod models;
mod output;
mod preview;
mod profile;
mod readback;
mod run;
mod shapes;
mod stage_progress;
mod tracker;

pub use anchor::{anchor_to_head, HeadAnchor, MAX_ANCHOR_GAP_S};
pub use compare::{compare, pearson, percentile, Agreement, Series};
pub use decode::{count_video_packets, probe, video_stream_size, Decoder, VideoInfo};
pub use detect::{anchors, decode as decode_detections, weighted_nms, Detection};
pub use error::{ExtractError, Result};
pub use eyecrop::{
    area_samples, eye_crop_roi, order_eye_corners, CornerReference, EyeCorners, EyeCropTracker,
    EYE_CROP_SCALE,
};
pub use geom::{Pt, Roi};
pub use image::{Border, ImageView, Planes, Rotation, YuvMatrix};
pub use models::{
    check as check_models, check_strict as check_models_strict, default_models_dir, init_runtime,
    landmarks_for_real_video, missing_files, networks_fingerprint, runtime_library,
    use_package_files, AttentionOut, DetectorOutput, Device, FaceMeshOutput, IrisOutput,
    LandmarkModel, Models, IRIS_CPU_BATCH,
};
pub use output::{
    blink_threshold, flag_blinks, flag_blinks_below, output_csv_paths, save_csv, write_csv, EyeRow,
    Row, CSV_HEADER, DEFAULT_BLINK_RATIO,
};
pub use profile::{process_cpu_s, thread_cpu_s, Stage, StageClock, StageTimes};
pub use readback::{
    extract_at_corners, extract_with_detector, row_norm, widen_blinks, BLINK_MARGIN_FRAMES,
};
pub use run::{
    extract_many, extract_video_to_csv, ExtractOptions, Extraction, FrameExtraction, FrameStream,
    NoProgress, Progress, DEFAULT_MESH_EVERY,
};
pub use shapes::{
    DETECTOR_ANCHORS, DETECTOR_ANCHOR_VALUES, EYE_CONTOUR_POINTS, FACE_MESH_LANDMARKS, HEAD_POINTS,
    IRIS_POINTS,
};
pub use stage_progress::StageFrames;
pub use tracker::{Eye, EyeMeasure, Face, Tracker, IRIS_VIEW_SHIFT_PX, MAX_IRIS_VIEWS};

/// The revision of the rows an extraction writes: raised whenever a change
/// moves them (not for speed-ups that keep them bit for bit). Cached
/// extractions carry it in their file name, so a new extractor never
/// reuses an older one's rows. Not raised for the last column, `nx_head`
/// (every other column stays bit for bit, readers find columns by name and
/// nothing reads `nx_head` from the cache). 3: the converter writes the models' channel
/// padding as a 1x1 convolution, so ONNX Runtime fuses the residual
/// additions and rounds them differently (nx within 7e-4 of revision 2 on
/// `franck.mp4`). 2: segments of about 15 s starting on keyframes,
/// whatever the number of workers (1: one segment per worker).
pub const ROWS_REVISION: u32 = 3;

/// `key` with what an extraction's rows depend on besides the video and
/// the tool: the rows revision and the networks in use
/// ([`networks_fingerprint`] of [`default_models_dir`]). Every artifact
/// made from extractor rows (cached extractions, head poses, carrier
/// tracks) is keyed through it.
pub fn keyed_by_extractor(key: eyereplay_core::ArtifactKey) -> Result<eyereplay_core::ArtifactKey> {
    Ok(key
        .version("r", ROWS_REVISION)
        .version("n", networks_fingerprint(&default_models_dir())?))
}
