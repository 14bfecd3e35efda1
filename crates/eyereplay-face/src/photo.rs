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
//! (texture coordinates = landmark positions), less the strip of its iris
//! that shows past the lid contour ([`lids_without_the_photos_irises`]).
//! The iris colour is sampled from the photo's irises.

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

impl PhotoEye {
    /// The lid contour in the photo's pixels, in the contour's order.
    pub fn contour_px(&self, landmarks_px: &[[f32; 2]]) -> Vec<[f32; 2]> {
        self.contour
            .iter()
            .map(|&i| landmarks_px[i as usize])
            .collect()
    }
}

/// A face identity made from one photo.
#[derive(Clone, Debug)]
pub struct PhotoIdentity {
    pub name: String,
    pub source: PathBuf,
    /// The photo, used as the texture (its iris cleared from the lids:
    /// [`lids_without_the_photos_irises`]).
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
        // A face lying on its side (a photo turned without an EXIF
        // orientation to say so) fitted, and drew NaN.
        if photo_pose.roll_deg.abs() > MAX_PHOTO_ROLL_DEG {
            return Err(FaceError::Identity {
                path: source.to_path_buf(),
                message: format!(
                    "the face is tilted {:.0} deg (at most {MAX_PHOTO_ROLL_DEG}): is the photo \
                     on its side? Turn it upright",
                    photo_pose.roll_deg
                ),
            });
        }
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
        let texture = lids_without_the_photos_irises(&image, &landmarks_px, &eyes);
        Ok(PhotoIdentity {
            name: name.to_string(),
            source: source.to_path_buf(),
            texture,
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

/// The most a photo's face may be tilted (its head's roll): beyond, it is
/// taken for a photo on its side.
pub const MAX_PHOTO_ROLL_DEG: f64 = 35.0;

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

/// How far from the photo's iris centre its iris is taken to reach, in
/// iris radii: the iris model's radius ends at the limbus; the dark
/// limbal ring and the photo's blur reach a little beyond.
pub const PHOTO_IRIS_REACH_RADII: f32 = 1.2;

/// How far past the lid contour (along the image column) the photo's iris
/// is taken to show, in iris radii, and at least [`PHOTO_IRIS_BAND_MIN_PX`]:
/// the contour runs a pixel or two inside the visible iris; farther out
/// is the lid itself (lashes, skin), which stays the photo's.
pub const PHOTO_IRIS_BAND_RADII: f32 = 0.25;
pub const PHOTO_IRIS_BAND_MIN_PX: f32 = 1.5;

/// The photo as the face's texture: where a photo's iris reaches past the
/// lid contour the landmarks give (the contour often runs a pixel or two
/// inside the visible iris, above it or below), those pixels are the lid's
/// texture, and the photo's iris would be drawn on the lids: a crescent of
/// it beside the rendered eye, moving with the lid. In each image column
/// within [`PHOTO_IRIS_REACH_RADII`] of the iris centre, the pixels in a
/// thin band just outside the contour (above the upper lid, below the
/// lower; [`PHOTO_IRIS_BAND_RADII`]) and within that reach take the mean
/// colour of the two pixels just beyond the band: the lid margin's own
/// colour, so lashes and the lid's rim run on unbroken. Every other pixel
/// is the photo's (inside the contour the eye is traced, never textured).
pub fn lids_without_the_photos_irises(
    image: &RgbImage,
    landmarks_px: &[[f32; 2]],
    eyes: &[PhotoEye; 2],
) -> RgbImage {
    let mut out = image.clone();
    let (w, h) = (image.width as isize, image.height as isize);
    let at = |x: isize, y: isize| image.pixel(x as usize, y.clamp(0, h - 1) as usize);
    let mean2 = |a: [u8; 3], b: [u8; 3]| -> [u8; 3] {
        std::array::from_fn(|k| (a[k] as u16 + b[k] as u16).div_ceil(2) as u8)
    };
    for e in eyes {
        let poly = e.contour_px(landmarks_px);
        let [cx, cy] = e.iris_center_px;
        let reach = PHOTO_IRIS_REACH_RADII * e.iris_radius_px;
        let band = (PHOTO_IRIS_BAND_RADII * e.iris_radius_px).max(PHOTO_IRIS_BAND_MIN_PX);
        if !(reach > 0.0 && cx.is_finite() && cy.is_finite()) {
            continue;
        }
        let x0 = ((cx - reach).floor() as isize).max(0);
        let x1 = ((cx + reach).ceil() as isize).min(w - 1);
        for x in x0..=x1 {
            let px = x as f32 + 0.5;
            let dx = px - cx;
            if dx.abs() >= reach {
                continue;
            }
            // Where the column crosses the contour: its upper and lower lid.
            let crossings: Vec<f32> = (0..poly.len())
                .filter_map(|i| {
                    let (a, b) = (poly[i], poly[(i + 1) % poly.len()]);
                    ((a[0] <= px) != (b[0] <= px))
                        .then(|| a[1] + (b[1] - a[1]) * (px - a[0]) / (b[0] - a[0]))
                })
                .collect();
            if crossings.len() < 2 {
                continue;
            }
            let upper = crossings.iter().copied().fold(f32::MAX, f32::min);
            let lower = crossings.iter().copied().fold(f32::MIN, f32::max);
            let half = (reach * reach - dx * dx).sqrt();
            // Rows whose centres lie in the band: above the upper lid ...
            let up_first = (upper - band - 0.5).ceil() as isize;
            let up_last = (upper - 0.5).ceil() as isize - 1;
            // ... and below the lower one.
            let lo_first = (lower - 0.5).floor() as isize + 1;
            let lo_last = (lower + band - 0.5).floor() as isize;
            for (first, last, fill) in [
                (
                    up_first,
                    up_last,
                    mean2(at(x, up_first - 1), at(x, up_first - 2)),
                ),
                (
                    lo_first,
                    lo_last,
                    mean2(at(x, lo_last + 1), at(x, lo_last + 2)),
                ),
            ] {
                for y in first.max(0)..=last.min(h - 1) {
                    if ((y as f32 + 0.5) - cy).abs() > half {
                        continue;
                    }
                    let i = (y as usize * image.width + x as usize) * 3;
                    out.data[i..i + 3].copy_from_slice(&fill);
                }
            }
        }
    }
    out
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
        let poly = e.contour_px(landmarks_px);
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

/// Decodes the first frame of an image file, upright, as RGB: a PNG with
/// the `png` crate, anything else with the extractor's decoder (FFmpeg:
/// JPEG, WebP, ...). PNG is decoded here because the Python wheel's FFmpeg
/// is built without zlib (decoders for video only), and PNG is lossless:
/// the bytes are the file's whatever decodes it.
pub fn read_image(path: &Path) -> Result<RgbImage> {
    let unreadable = |message: String| FaceError::Unreadable {
        path: path.to_path_buf(),
        message,
    };
    // Read once: the kind, a JPEG's end and the EXIF orientation are all
    // in these bytes.
    let bytes = std::fs::read(path).map_err(|e| unreadable(e.to_string()))?;
    let png = bytes.starts_with(PNG_SIGNATURE);
    let jpeg = bytes.starts_with(&[0xFF, 0xD8]);
    // A file named as a PNG or JPEG that is not one (a text file renamed)
    // reached FFmpeg, whose "video stream has no picture size" named no
    // cause.
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    let named = match ext.as_str() {
        "png" if !png => Some("PNG"),
        "jpg" | "jpeg" if !jpeg => Some("JPEG"),
        _ => None,
    };
    if let Some(kind) = named {
        return Err(unreadable(format!(
            "not a {kind}, though named one (its first bytes are not a {kind}'s; a file of \
             another kind renamed, or empty?)"
        )));
    }
    // FFmpeg decodes a JPEG cut off part-way without an error, the missing
    // rows green in every frame drawn from it.
    if jpeg && !jpeg_is_whole(&bytes) {
        return Err(unreadable(
            "the JPEG ends before its picture does (a download or copy cut off?)".into(),
        ));
    }
    let image = if png {
        read_png(path, &bytes)?
    } else {
        decode_image(path)?
    };
    // A phone stores the sensor's rows and says in EXIF how to turn them:
    // read as stored, a portrait photo's face lay on its side, and its
    // fit gave a renderer input it could not draw (NaN in the truth
    // files, found only at the merge).
    Ok(match orientation_of(&bytes) {
        Some(o) => image.oriented(o),
        None => image,
    })
}

/// PNG's first eight bytes.
const PNG_SIGNATURE: &[u8] = b"\x89PNG\r\n\x1a\n";

/// The EXIF orientation (2-8) of an image file that has one other than
/// upright; `None` without EXIF, for 1, or for a value out of range.
pub fn exif_orientation(path: &Path) -> Option<u32> {
    orientation_of(&std::fs::read(path).ok()?)
}

/// [`exif_orientation`] of an image file's bytes.
fn orientation_of(bytes: &[u8]) -> Option<u32> {
    let exif = exif::Reader::new()
        .read_from_container(&mut std::io::Cursor::new(bytes))
        .ok()?;
    let field = exif.get_field(exif::Tag::Orientation, exif::In::PRIMARY)?;
    field.value.get_uint(0).filter(|o| (2..=8).contains(o))
}

/// Whether a JPEG's bytes hold its whole picture: an end-of-image marker
/// (FF D9) after its last start-of-scan (FF DA). FFmpeg decodes a JPEG
/// cut off part-way without an error, the missing rows green; neither
/// marker can occur inside the coded data (an FF there is followed by 00
/// or a restart marker), and an EXIF thumbnail's own markers come before
/// the picture's scans.
pub fn jpeg_is_whole(bytes: &[u8]) -> bool {
    let at = |m: u8| bytes.windows(2).rposition(|w| w == [0xFF, m]);
    match (at(0xDA), at(0xD9)) {
        (Some(scan), Some(end)) => end > scan,
        _ => false,
    }
}

/// The first picture of an image file other than a PNG, through the
/// extractor's decoder (FFmpeg).
fn decode_image(path: &Path) -> Result<RgbImage> {
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

/// A PNG as 8-bit RGB, as FFmpeg converts it to rgb24 (a test compares
/// the two in every layout): palettes expanded, 16-bit samples rounded to
/// 8 bits, grey repeated over the three channels, alpha dropped.
fn read_png(path: &Path, bytes: &[u8]) -> Result<RgbImage> {
    let unreadable = |message: String| FaceError::Unreadable {
        path: path.to_path_buf(),
        message,
    };
    let mut decoder = png::Decoder::new(std::io::Cursor::new(bytes));
    decoder.set_transformations(png::Transformations::EXPAND);
    let mut reader = decoder.read_info().map_err(|e| unreadable(e.to_string()))?;
    let mut buf = vec![0u8; reader.output_buffer_size()];
    let info = reader
        .next_frame(&mut buf)
        .map_err(|e| unreadable(e.to_string()))?;
    let (w, h) = (info.width as usize, info.height as usize);
    let channels = info.color_type.samples();
    // Bytes a sample (16-bit samples are big-endian), and its 8-bit value:
    // FFmpeg rounds a 16-bit one, (v + 128) >> 8.
    let bytes = if info.bit_depth == png::BitDepth::Sixteen {
        2
    } else {
        1
    };
    let sample = |b: &[u8]| -> u8 {
        match bytes {
            2 => ((u16::from_be_bytes([b[0], b[1]]) as u32 + 128) >> 8).min(255) as u8,
            _ => b[0],
        }
    };
    let mut data = Vec::with_capacity(w * h * 3);
    for row in buf[..info.buffer_size()].chunks_exact(info.line_size) {
        for px in row[..w * channels * bytes].chunks_exact(channels * bytes) {
            match channels {
                1 | 2 => data.extend_from_slice(&[sample(px); 3]),
                _ => data.extend(px.chunks_exact(bytes).take(3).map(sample)),
            }
        }
    }
    Ok(RgbImage {
        width: w,
        height: h,
        data,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::{LEFT_EYE_CONTOUR, RIGHT_EYE_CONTOUR};

    const SKIN_ABOVE: [u8; 3] = [180, 130, 110];
    const SKIN_BELOW: [u8; 3] = [200, 150, 130];
    const IRIS: [u8; 3] = [40, 80, 160];

    /// A 60 x 40 picture of one eye drawn by hand: a lid contour (a
    /// hexagon) whose lower lid runs 2 px above the bottom of a blue iris
    /// of radius 5 at (20, 16); skin of one colour above row 16 and of
    /// another below. The second eye's iris sits far off, inside its own
    /// contour, so it changes nothing.
    fn one_eye() -> (RgbImage, Vec<[f32; 2]>, [PhotoEye; 2]) {
        let (w, h) = (60usize, 40usize);
        let mut img = RgbImage::filled(w, h, SKIN_BELOW);
        for y in 0..16 {
            for x in 0..w {
                img.data[(y * w + x) * 3..][..3].copy_from_slice(&SKIN_ABOVE);
            }
        }
        let (cx, cy, r) = (20.0f32, 16.0f32, 5.0f32);
        for y in 0..h {
            for x in 0..w {
                let (px, py) = (x as f32 + 0.5, y as f32 + 0.5);
                if (px - cx).powi(2) + (py - cy).powi(2) <= r * r {
                    img.data[(y * w + x) * 3..][..3].copy_from_slice(&IRIS);
                }
            }
        }
        let mut lm = vec![[0.0f32; 2]; MESH_VERTICES];
        // Outer corner, lower lid (7), inner corner, upper lid (7): the
        // lids flat at y = 10 and y = 19 between x = 8 and x = 32.
        let contour_pts = |dx: f32| -> [[f32; 2]; 16] {
            std::array::from_fn(|k| match k {
                0 => [4.0 + dx, 14.5],
                1..=7 => [8.0 + dx + 24.0 * (k - 1) as f32 / 6.0, 19.0],
                8 => [36.0 + dx, 14.5],
                _ => [32.0 + dx - 24.0 * (k - 9) as f32 / 6.0, 10.0],
            })
        };
        for (c, pts) in [
            (RIGHT_EYE_CONTOUR, contour_pts(0.0)),
            (LEFT_EYE_CONTOUR, contour_pts(100.0)),
        ] {
            for (&i, p) in c.iter().zip(pts) {
                lm[i as usize] = p;
            }
        }
        let eyes = [
            PhotoEye {
                contour: RIGHT_EYE_CONTOUR,
                iris_center_px: [cx, cy],
                iris_radius_px: r,
            },
            PhotoEye {
                contour: LEFT_EYE_CONTOUR,
                iris_center_px: [120.0, 15.0],
                iris_radius_px: 3.0,
            },
        ];
        (img, lm, eyes)
    }

    /// The iris's part below the lower lid (rows 19-20 of its columns)
    /// becomes the skin below; the 1.5 px band above the upper lid (rows
    /// 8-9) takes the skin above (the same colour there); every other
    /// pixel, inside the contour or beyond the band or 1.2 iris radii, is
    /// the photo's.
    #[test]
    fn the_photos_iris_is_cleared_from_the_lids_only() {
        let (img, lm, eyes) = one_eye();
        let out = lids_without_the_photos_irises(&img, &lm, &eyes);
        let poly: Vec<[f32; 2]> = RIGHT_EYE_CONTOUR.iter().map(|&i| lm[i as usize]).collect();
        let mut cleared = 0;
        for y in 0..img.height {
            for x in 0..img.width {
                let p = [x as f32 + 0.5, y as f32 + 0.5];
                let d = ((p[0] - 20.0).powi(2) + (p[1] - 16.0).powi(2)).sqrt();
                // Band 1.5 px (0.25 x 5 < 1.5): centres 8.5-9.5 above the
                // lid at 10, 19.5-20.5 below the lid at 19.
                let want = match y {
                    8 | 9 if d <= 6.0 => SKIN_ABOVE,
                    19 | 20 if d <= 6.0 => SKIN_BELOW,
                    _ => img.pixel(x, y),
                };
                assert_eq!(out.pixel(x, y), want, "({x}, {y})");
                cleared += (want != img.pixel(x, y)) as usize;
            }
        }
        // The iris pixels below the lid (y = 19), by hand: row 19 (centre
        // 19.5, |dx| <= sqrt(25 - 3.5^2) = 3.57: 8 columns) and row 20
        // (centre 20.5, |dx| <= 2.18: 4 columns).
        assert_eq!(cleared, 12);
        // None is left anywhere outside the contour.
        let left = (0..img.height)
            .flat_map(|y| (0..img.width).map(move |x| (x, y)))
            .filter(|&(x, y)| {
                !inside(&poly, [x as f32 + 0.5, y as f32 + 0.5]) && out.pixel(x, y) == IRIS
            })
            .count();
        assert_eq!(left, 0);
    }
}
