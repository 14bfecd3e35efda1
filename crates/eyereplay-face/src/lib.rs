//! Full-face render mode (issue 12): foundations.
//!
//! Today's renderer (eyereplay-render) shows two ray-traced eyes in close-up
//! on a still, procedural face. This crate builds what a whole-face webcam
//! video needs, from real photos:
//!
//! - [`CanonicalMesh`]: MediaPipe's canonical face mesh (468 vertices in cm
//!   with UVs, 898 triangles, the Procrustes basis), read from the
//!   `binarypb` that `scripts/face-assets.sh` cuts out of the npm package
//!   @mediapipe/face_mesh. Its eye openings are filled by 14 triangles each
//!   ([`CanonicalMesh::eye_fill_triangles`]).
//! - [`PhotoFitter`] / [`PhotoIdentity`]: our own extractor runs on a
//!   frontal photo (detection, 468 landmarks, iris); the photo's head pose
//!   is solved against the canonical mesh, and each vertex takes its
//!   landmark's line of sight at the posed canonical depth. The photo is
//!   the texture, its landmarks the texture coordinates, and the iris
//!   colour is sampled from its irises.
//! - [`Rasterizer`]: a perspective-correct, z-buffered, bilinearly textured
//!   triangle rasterizer on the CPU (f32, rayon over row bands) that draws
//!   the textured mesh under a [`HeadPose`] seen by a pinhole [`Camera`].
//! - [`solve_pose`]: the head pose from 468 landmarks (weighted Procrustes
//!   in Lu-Hager-Mjolsness orthogonal iteration), used for the photo fit and
//!   meant for solving a source video's head pose and checking renders.
//! - [`coordination`]: the eye-head coordination model that splits a gaze
//!   shift between eye and head, plus slow head drift and sway.
//!
//! # How the eyes will be composited
//!
//! A frame is drawn back to front into one RGB buffer: the background
//! first, then the existing ray-traced eyeballs of eyereplay-render placed
//! at each eye's position in the posed head (the eyeball centre sits behind
//! the lid contour of [`PhotoIdentity::eyes`]), then the face mesh with its
//! 28 eye-opening triangles dropped ([`PhotoIdentity::textured_mesh`] with
//! `open_eyes`). The face's triangles overwrite everything they cover, so
//! the eyeballs show exactly through the photo's own lid contour; lids that
//! follow vertical gaze and blink move the contour vertices (the upper and
//! lower lid rows of the contour) before drawing. The photo's own irises
//! and sclera are never shown: they lie inside the dropped triangles.
//!
//! # Frames and angles
//!
//! See [`pose`](HeadPose): head frame +x subject's left, +y up, +z out of
//! the face (cm); camera frame +x right, +y down, +z depth; yaw > 0 turns
//! the nose image-right, pitch > 0 lifts it, roll > 0 is counterclockwise
//! as the camera sees it.

pub mod coordination;
mod error;
mod mesh;
mod photo;
mod pose;
mod probe;
mod raster;
mod scene;
mod session;
mod video_pose;
pub mod webcam;

pub use error::{FaceError, Result};
pub use mesh::{
    bundled_faces, default_faces_dir, lm, parse as parse_mesh, use_package_faces, CanonicalMesh,
    BUNDLED_FACES, INNER_LIPS, LEFT_EYE_CONTOUR, MESH_FILE, MESH_VERTICES, RIGHT_EYE_CONTOUR,
};
pub use photo::{
    exif_orientation, fit_shape, jpeg_is_whole, lids_without_the_photos_irises, read_image,
    PhotoEye, PhotoFitter, PhotoIdentity, MIN_FACE_HEIGHT_PX, PHOTO_IRIS_BAND_MIN_PX,
    PHOTO_IRIS_BAND_RADII, PHOTO_IRIS_REACH_RADII, PHOTO_VFOV_DEG,
};
pub use pose::{solve_pose, weighted_procrustes, Camera, HeadPose, Similarity};
pub use probe::{
    match_extractor, read_frame, refine_match, Axis, ExtractorMatch, ProbeHeadRange, ProbeRefusal,
    SessionRead, REFINE_MIN_READS,
};
pub use raster::{DrawStats, Rasterizer, RgbImage, SavePng, TexturedMesh};
pub use scene::{EyeImage, FaceScene, FaceState, Framing};
pub use session::{
    head_path, render_face_session, render_face_session_every, render_face_session_every_kept,
    render_face_session_over, run_face_bench, DrawnFrame, FaceSessionParams, FaceSessionStats,
    KeptFrames, HEAD_PITCH_LIMIT_DEG, HEAD_ROLL_LIMIT_DEG, HEAD_TRUTH_HEADER, HEAD_YAW_LIMIT_DEG,
    KEEP_FRAMES_BUDGET_BYTES,
};
pub use video_pose::{
    video_head_poses, video_head_poses_upto, SourceHeadTrack, SOURCE_HEAD_SMOOTHING_S,
    SOURCE_VFOV_DEG,
};
