//! `<stem>_identity.json` beside each rendered video: who was rendered and
//! where the eyes are in the image. The renderer writes it with its own
//! identity and mapping types; readers that need only the geometry read the
//! identity parameters as plain JSON.

use crate::error::read_text;
use crate::DatasetError;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// Which eye, by its side in the image (the image-left eye is the subject's
/// right eye).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Side {
    Left,
    Right,
}

impl Side {
    pub const BOTH: [Side; 2] = [Side::Left, Side::Right];

    /// 0 for the image-left eye, 1 for the image-right one (array order
    /// everywhere in eyereplay).
    #[inline]
    pub fn index(self) -> usize {
        match self {
            Side::Left => 0,
            Side::Right => 1,
        }
    }
}

/// Where things are in the image for one eye (pixels).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct EyeGeometry {
    pub side: Side,
    /// Image position of the inner (nasal) and outer (temporal) eye corner.
    pub inner_corner_px: [f64; 2],
    pub outer_corner_px: [f64; 2],
    /// Projection of the eyeball centre.
    pub centre_px: [f64; 2],
    /// Region redrawn per frame: x0, y0, x1, y1 (exclusive); everything
    /// outside it is the static face background.
    pub box_px: [u32; 4],
    /// Pixels per millimetre at the eye's depth.
    pub px_per_mm: f64,
}

/// Contents of `<stem>_identity.json`. `I` and `M` are the renderer's
/// identity and gaze-mapping types when writing; readers use the default,
/// plain JSON.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SessionIdentity<I = serde_json::Value, M = serde_json::Value> {
    /// The session CSV, relative to the dataset folder.
    pub file: String,
    pub seed: u64,
    pub identity: I,
    pub mapping: M,
    pub width: usize,
    pub height: usize,
    pub fps: f64,
    /// Image-left eye first; absent when the simulator does not say where
    /// it draws the eyes (a browser page without configured eye corners).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub eyes: Option<[EyeGeometry; 2]>,
    /// Crops per eye the extractor that drew this session's response map
    /// read with (`render.extractor_iris_views`); the read-back reads the
    /// same way. Absent: one (no probe, or a file from before the setting).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub extractor_iris_views: Option<usize>,
}

impl SessionIdentity {
    /// Reads an identity file; errors name it.
    pub fn read(path: &Path) -> Result<Self, DatasetError> {
        let text = read_text(path)?;
        serde_json::from_str(&text).map_err(|e| {
            DatasetError::invalid(path, format!("not an eyereplay identity file: {e}"))
        })
    }

    /// `(inner, outer)` corner of each eye in image px, in file order
    /// (image-left eye first as the renderer writes it).
    pub fn corner_pairs_px(&self) -> Option<[([f64; 2], [f64; 2]); 2]> {
        let e = self.eyes.as_ref()?;
        Some([
            (e[0].inner_corner_px, e[0].outer_corner_px),
            (e[1].inner_corner_px, e[1].outer_corner_px),
        ])
    }

    /// Eye geometry from corners alone (`[inner_x, inner_y, outer_x,
    /// outer_y]` per eye, image-left first): centre between the corners, box
    /// around them, scale unknown (0).
    pub fn eyes_from_corners(corners: [[f64; 4]; 2]) -> [EyeGeometry; 2] {
        let eye = |side: Side, c: [f64; 4]| {
            let (x0, x1) = (c[0].min(c[2]), c[0].max(c[2]));
            let (y0, y1) = (c[1].min(c[3]), c[1].max(c[3]));
            let w = x1 - x0;
            EyeGeometry {
                side,
                inner_corner_px: [c[0], c[1]],
                outer_corner_px: [c[2], c[3]],
                centre_px: [(c[0] + c[2]) / 2.0, (c[1] + c[3]) / 2.0],
                box_px: [
                    x0.max(0.0) as u32,
                    (y0 - w / 2.0).max(0.0) as u32,
                    x1.ceil() as u32,
                    (y1 + w / 2.0).ceil() as u32,
                ],
                px_per_mm: 0.0,
            }
        };
        [eye(Side::Left, corners[0]), eye(Side::Right, corners[1])]
    }
}

impl<I: Serialize, M: Serialize> SessionIdentity<I, M> {
    /// Writes the file atomically, pretty JSON as the renderer always has.
    pub fn write(&self, path: &Path) -> Result<(), DatasetError> {
        let json = serde_json::to_vec_pretty(self)
            .map_err(|e| DatasetError::invalid(path, format!("cannot serialize: {e}")))?;
        eyereplay_core::atomic_write(path, &json)?;
        Ok(())
    }
}
