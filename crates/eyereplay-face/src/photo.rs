//! Face identities from real frontal photos.
//!
//! Our own extractor (eyereplay-extract: face detection, 468 landmarks,
//! iris) runs on the photo. The canonical mesh is fitted to the landmarks:
//! the photo's head pose is solved by weighted Procrustes on MediaPipe's
//! 33-point basis (see [`solve_pose`]) under an assumed portrait camera
//! ([`PHOTO_VFOV_DEG`]), and each vertex keeps the depth of the posed
//! canonical mesh while its landmark's line of sight fixes x and y. So the
//! identity's 3D shape seen from the photo's camera and pose projects
//! exactly onto the photo's landmarks, and the photo itself is the texture
//! (texture coordinates = landmark positions). The iris colour is sampled
//! from the photo's irises.

use crate::error::{FaceError, Result};
use crate::mesh::{lm, CanonicalMesh, LEFT_EYE_CONTOUR, MESH_VERTICES, RIGHT_EYE_CONTOUR};
use crate::pose::{Camera, HeadPose};
use crate::raster::{RgbImage, TexturedMesh};
use eyereplay_extract::{
    Decoder, ExtractError, Face, ImageView, Models, Planes, Rotation, Tracker, DEFAULT_MESH_EVERY,
};
use nalgebra::Vector3;
use std::ops::ControlFlow;
use std::path::{Path, PathBuf};

/// Vertical field of view assumed for a portrait photo whose camera is
/// unknown. Only the depth relief's perspective depends on it: at 30 deg a
/// face filling half the frame is about 65 cm away, where the nose's 7.6 cm
/// of relief changes its scale by 12 %.
pub const PHOTO_VFOV_DEG: f64 = 30.0;

/// Smallest forehead-to-chin distance (landmarks 10-152) a photo must
/// have: below it the eyes are under ~15 px wide and the texture turns to
/// mush at webcam framing.
pub const MIN_FACE_HEIGHT_PX: f32 = 100.0;

/// One eye of the photo.
#[derive(Clone, Debug, PartialEq)]
pub struct PhotoEye {
    /// Mesh ids of the eye's contour (corners and lids), in order.
    pub contour: [u32; 16],
    /// Iris centre and radius in the photo, from the iris model.
    pub iris_center_px: [f32; 2],
    pub iris_radius_px: f32,
}

/// A face identity made from one photo.
#[derive(Clone, Debug)]
pub struct PhotoIdentity {
    pub name: String,
    pub source: PathBuf,
    /// The photo, used as the texture.
    pub texture: RgbImage,
    /// The extractor's 468 landmarks in the photo's pixels.
    pub landmarks_px: Vec<[f32; 2]>,
    /// The face's shape in the head frame (cm), one point per landmark.
    pub shape_cm: Vec<[f32; 3]>,
    /// The assumed camera of the photo and the head pose solved in it:
    /// together they project `shape_cm` onto `landmarks_px`.
    pub photo_camera: Camera,
    pub photo_pose: HeadPose,
    /// Mean colour of the irises' visible stroma.
    pub iris_rgb: [u8; 3],
    /// The subject's right eye (image left) first.
    pub eyes: [PhotoEye; 2],
    pub face_height_px: f32,
}

impl PhotoIdentity {
    /// The textured mesh to render; `open_eyes` drops the triangles that
    /// fill the eye openings, so that what is drawn behind shows.
    pub fn textured_mesh(&self, mesh: &CanonicalMesh, open_eyes: bool) -> TexturedMesh {
        let dropped = if open_eyes {
            mesh.eye_fill_triangles()
        } else {
            vec![]
        };
        let triangles = mesh
            .triangles
            .iter()
            .enumerate()
            .filter(|(i, _)| !dropped.contains(i))
            .map(|(_, t)| *t)
            .collect();
        TexturedMesh::new(self.shape_cm.clone(), self.landmarks_px.clone(), triangles)
    }
}

/// Runs the extractor and fits identities; holds the ONNX sessions.
pub struct PhotoFitter {
    tracker: Tracker,
    mesh: CanonicalMesh,
    /// Crops per eye when reading a clip ([`PhotoFitter::track`]).
    iris_views: usize,
}

/// The extractor's view of an RGB image.
fn rgb_view(image: &RgbImage) -> ImageView<'_> {
    ImageView {
        planes: Planes::Rgb24 {
            data: &image.data,
            stride: image.width * 3,
        },
        raw_w: image.width,
        raw_h: image.height,
        rotation: Rotation::None,
    }
}

impl PhotoFitter {
    pub fn new(models_dir: &Path, mesh: CanonicalMesh) -> Result<PhotoFitter> {
        Ok(PhotoFitter {
            // The extractor's default: `landmarks` forces the mesh on every
            // call anyway, and `track` then reads a clip as `eyereplay
            // extract` reads a video.
            tracker: Tracker::new(Models::load(models_dir)?, DEFAULT_MESH_EVERY),
            mesh,
            iris_views: 1,
        })
    }

    /// How many crops [`PhotoFitter::track`] reads each eye from (the
    /// extractor's `--iris-views`, [`Tracker::set_iris_views`]), so a probe
    /// reads as the read-back will. Photo fits keep one.
    pub fn set_iris_views(&mut self, views: usize) {
        self.iris_views = views;
    }

    pub fn mesh(&self) -> &CanonicalMesh {
        &self.mesh
    }

    /// The extractor's unmodified per-frame path on one RGB image: face
    /// detection, 468 landmarks, iris. It runs twice, the second time from
    /// the first pass's landmarks, as every frame but the first of a video
    /// is processed; `None` when no face is found.
    pub fn landmarks(&mut self, image: &RgbImage) -> Result<Option<Face>> {
        let view = rgb_view(image);
        self.tracker.reset();
        self.tracker.set_iris_views(1);
        if self.tracker.process_with_mesh(&view)?.is_none() {
            return Ok(None);
        }
        Ok(self.tracker.process_with_mesh(&view)?)
    }

    /// The extractor's unmodified video path on the next frame of a clip
    /// (`first`: the clip's first frame, which starts a new track): the
    /// face tracked from the last frame, the mesh on every
    /// [`DEFAULT_MESH_EVERY`]-th frame, the same tracker calls `eyereplay
    /// extract` makes on a video's frames (here on RGB frames rather than
    /// decoded YUV ones); `None` when no face is found.
    pub fn track(&mut self, image: &RgbImage, first: bool) -> Result<Option<Face>> {
        let view = rgb_view(image);
        if first {
            self.tracker.reset();
        }
        self.tracker.set_iris_views(self.iris_views);
        Ok(self.tracker.process(&view)?)
    }

    /// Reads a photo (any format ffmpeg reads) and fits its identity.
    pub fn fit(&mut self, path: &Path) -> Result<PhotoIdentity> {
        let image = read_image(path)?;
        let name = path
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        self.fit_image(&name, path, image)
    }

    /// Fits an identity to an image already in memory (`source` names it
    /// in errors).
    pub fn fit_image(
        &mut self,
        name: &str,
        source: &Path,
        image: RgbImage,
    ) -> Result<PhotoIdentity> {
        let face = self.landmarks(&image)?.ok_or_else(|| FaceError::NoFace {
            path: source.to_path_buf(),
        })?;
        if face.mesh.len() != MESH_VERTICES {
            return Err(FaceError::Identity {
                path: source.to_path_buf(),
                message: format!(
                    "the extractor gave {} landmarks, expected 468",
                    face.mesh.len()
                ),
            });
        }
        let landmarks_px: Vec<[f32; 2]> = face.mesh.iter().map(|p| [p.x, p.y]).collect();
        let d = |a: usize, b: usize| {
            let (p, q) = (landmarks_px[a], landmarks_px[b]);
            ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2)).sqrt()
        };
        let face_height_px = d(lm::FOREHEAD, lm::CHIN);
        if face_height_px < MIN_FACE_HEIGHT_PX {
            return Err(FaceError::FaceTooSmall {
                path: source.to_path_buf(),
                height_px: face_height_px,
                min_px: MIN_FACE_HEIGHT_PX,
            });
        }
        let camera = Camera::from_vfov(image.width, image.height, PHOTO_VFOV_DEG);
        let (photo_pose, shape_cm) = fit_shape(&self.mesh, &camera, &landmarks_px);
        // face.eyes is ordered by image side; pair each mesh eye contour
        // with the iris nearest its centroid, whatever the head's roll.
        let eyes = [RIGHT_EYE_CONTOUR, LEFT_EYE_CONTOUR].map(|contour| {
            let n = contour.len() as f32;
            let mx = contour
                .iter()
                .map(|&i| landmarks_px[i as usize][0])
                .sum::<f32>()
                / n;
            let my = contour
                .iter()
                .map(|&i| landmarks_px[i as usize][1])
                .sum::<f32>()
                / n;
            let e = face
                .eyes
                .iter()
                .min_by(|a, b| {
                    let da = (a.iris.x - mx).powi(2) + (a.iris.y - my).powi(2);
                    let db = (b.iris.x - mx).powi(2) + (b.iris.y - my).powi(2);
                    da.total_cmp(&db)
                })
                .expect("two eyes");
            let c = e.iris_rim[0];
            let r = e.iris_rim[1..].iter().map(|p| p.dist(c)).sum::<f32>() / 4.0;
            PhotoEye {
                contour,
                iris_center_px: [c.x, c.y],
                iris_radius_px: r,
            }
        });
        let iris_rgb =
            sample_iris(&image, &landmarks_px, &eyes).ok_or_else(|| FaceError::Identity {
                path: source.to_path_buf(),
                message: "no iris pixels visible between the lids (eyes closed?)".into(),
            })?;
        Ok(PhotoIdentity {
            name: name.to_string(),
            source: source.to_path_buf(),
            texture: image,
            landmarks_px,
            shape_cm,
            photo_camera: camera,
            photo_pose,
            iris_rgb,
            eyes,
            face_height_px,
        })
    }
}

/// The photo's head pose, and the shape: each landmark's line of sight at
/// the depth the posed canonical vertex has, taken back to the head frame.
pub fn fit_shape(
    mesh: &CanonicalMesh,
    camera: &Camera,
    landmarks_px: &[[f32; 2]],
) -> (HeadPose, Vec<[f32; 3]>) {
    let px: Vec<[f64; 2]> = landmarks_px.iter().map(|p| p.map(f64::from)).collect();
    let pose = mesh.head_pose(camera, &mesh.positions_cm, &px);
    let (m, t) = pose.to_camera();
    let shape = mesh
        .positions_cm
        .iter()
        .zip(landmarks_px)
        .map(|(p, px)| {
            let q = m * Vector3::from(p.map(f64::from)) + t;
            let on_ray = camera.ray(px.map(f64::from)) * q.z;
            let s = m.transpose() * (on_ray - t);
            [s.x as f32, s.y as f32, s.z as f32]
        })
        .collect();
    (pose, shape)
}

/// Mean colour of the iris stroma: pixels between 40 % and 90 % of the
/// iris radius (outside the pupil, inside the limbus) that lie inside the
/// eye's lid contour, without the darkest and brightest fifth (lashes,
/// pupil edge, specular glints).
fn sample_iris(
    image: &RgbImage,
    landmarks_px: &[[f32; 2]],
    eyes: &[PhotoEye; 2],
) -> Option<[u8; 3]> {
    let mut px: Vec<[u8; 3]> = vec![];
    for e in eyes {
        let poly: Vec<[f32; 2]> = e
            .contour
            .iter()
            .map(|&i| landmarks_px[i as usize])
            .collect();
        let [cx, cy] = e.iris_center_px;
        let r = e.iris_radius_px;
        let (x0, x1) = ((cx - r).floor().max(0.0) as usize, (cx + r).ceil() as usize);
        let (y0, y1) = ((cy - r).floor().max(0.0) as usize, (cy + r).ceil() as usize);
        for y in y0..=y1.min(image.height - 1) {
            for x in x0..=x1.min(image.width - 1) {
                let p = [x as f32 + 0.5, y as f32 + 0.5];
                let d = ((p[0] - cx).powi(2) + (p[1] - cy).powi(2)).sqrt();
                if d >= 0.4 * r && d <= 0.9 * r && inside(&poly, p) {
                    px.push(image.pixel(x, y));
                }
            }
        }
    }
    if px.len() < 4 {
        return None;
    }
    let luma = |c: &[u8; 3]| 299 * c[0] as u32 + 587 * c[1] as u32 + 114 * c[2] as u32;
    px.sort_by_key(luma);
    let cut = px.len() / 5;
    let kept = &px[cut..px.len() - cut];
    let mut sum = [0u64; 3];
    for c in kept {
        for k in 0..3 {
            sum[k] += c[k] as u64;
        }
    }
    let n = kept.len() as u64;
    Some(sum.map(|s| ((s + n / 2) / n) as u8))
}

/// Even-odd point-in-polygon test.
pub(crate) fn inside(poly: &[[f32; 2]], p: [f32; 2]) -> bool {
    let mut c = false;
    let n = poly.len();
    for i in 0..n {
        let (a, b) = (poly[i], poly[(i + n - 1) % n]);
        if (a[1] > p[1]) != (b[1] > p[1])
            && p[0] < (b[0] - a[0]) * (p[1] - a[1]) / (b[1] - a[1]) + a[0]
        {
            c = !c;
        }
    }
    c
}

/// Decodes the first frame of an image file with the extractor's decoder
/// (FFmpeg: JPEG, PNG, WebP, ...), upright, as RGB.
pub fn read_image(path: &Path) -> Result<RgbImage> {
    let unreadable = |e: ExtractError| match e {
        ExtractError::Open { message, .. } | ExtractError::Decode { message, .. } => {
            FaceError::Unreadable {
                path: path.to_path_buf(),
                message,
            }
        }
        ExtractError::NoVideoStream { .. } | ExtractError::NoFrames { .. } => {
            FaceError::Unreadable {
                path: path.to_path_buf(),
                message: "no picture in it".into(),
            }
        }
        other => FaceError::Extract(other),
    };
    let mut dec = Decoder::open(path).map_err(unreadable)?;
    let mut out = None;
    dec.frames(|_, view| {
        let (w, h, data) = view.to_rgb8(1);
        out = Some(RgbImage {
            width: w,
            height: h,
            data,
        });
        Ok(ControlFlow::Break(()))
    })
    .map_err(unreadable)?;
    out.ok_or_else(|| FaceError::Unreadable {
        path: path.to_path_buf(),
        message: "no picture in it".into(),
    })
}
