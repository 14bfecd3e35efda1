//! The networks' output sizes, checked where each tensor is read: shared by
//! the model runner and the attention mesh's post-processing.

/// Anchors of the face detector (BlazeFace short range): a score logit
/// each.
pub const DETECTOR_ANCHORS: usize = 896;
/// Values the face detector regresses per anchor: the box (cx, cy, w, h)
/// and six keypoints (x, y).
pub const DETECTOR_ANCHOR_VALUES: usize = 16;
/// Landmarks of the face mesh (and of the attention mesh), each (x, y, z):
/// 1404 values.
pub const FACE_MESH_LANDMARKS: usize = 468;
/// Points of an eye's contour (lids and brows) in the iris model's layout,
/// each (x, y, z) from the iris model (213 values), (x, y) from the
/// attention mesh's eye model (142 values).
pub const EYE_CONTOUR_POINTS: usize = 71;
/// Iris points, the centre first, each (x, y, z) from the iris model (15
/// values), (x, y) from the attention mesh's eye model (10 values).
pub const IRIS_POINTS: usize = 5;

/// Face-mesh points that move with the skull, not with the eyes, lids,
/// brows, mouth or jaw: forehead, the nose's bridge and tip, cheekbones,
/// temples and the face's outline beside the eyes.
pub const HEAD_POINTS: [usize; 43] = [
    10, 151, 9, 8, 168, 6, 197, 195, 5, 4, 1, 109, 338, 67, 297, 103, 332, 54, 284, 21, 251, 162,
    389, 127, 356, 234, 454, 93, 323, 116, 345, 117, 346, 118, 347, 123, 352, 50, 280, 101, 330,
    36, 266,
];
