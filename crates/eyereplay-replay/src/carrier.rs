//! A carrier's per-frame eye geometry, measured once with our extractor
//! (the unmodified MediaPipe pipeline, the face mesh on every frame) and
//! cached, and the checks that refuse a carrier before any work.

use crate::error::{ReplayError, Result};
use eyereplay_extract::{Decoder, Models, Pt, Row, Tracker};
use serde::{Deserialize, Serialize};
use std::ops::ControlFlow;
use std::path::Path;

/// Version of the cached geometry format; bump when its meaning changes.
pub const TRACK_FORMAT_VERSION: u32 = 1;

/// An eye narrower than this (corner to corner, median over the clip) is
/// too small to redraw: its iris would be about 7 px across, where the
/// iris model's own read-back of a drawn iris is no longer reliable.
pub const MIN_EYE_WIDTH_PX: f64 = 16.0;

/// A frame whose narrower eye is narrower than this is left as it is (the
/// clip as a whole needs [`MIN_EYE_WIDTH_PX`]; single frames may dip a
/// little below, as a head moves back).
pub const MIN_FRAME_EYE_WIDTH_PX: f64 = 0.8 * MIN_EYE_WIDTH_PX;

/// A frame whose narrower eye is less than this fraction of the wider one
/// shows a head turned about 35 degrees or more (a turned eye foreshortens
/// as the cosine of the turn, and the far eye more): the frontal lid model
/// no longer holds, so such frames are left as they are, and marked.
pub const MIN_EYE_WIDTH_RATIO: f64 = 0.65;

/// At least this fraction of a carrier's frames must be usable (a face,
/// eyes wide enough, not turned, not a blink), or the carrier is refused.
pub const MIN_USABLE_FRACTION: f64 = 0.5;

/// The fewest frames a carrier may have: one second at 25 fps. A session
/// longer than its carrier plays it back and forth, but a few frames do
/// not make a person moving.
pub const MIN_CARRIER_FRAMES: usize = 25;

/// Mesh landmarks at the two corners of each eye.
const MESH_EYE_CORNERS: [(usize, usize); 2] = [(33, 133), (362, 263)];

/// One eye in one frame, in upright image pixels.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CarrierEye {
    /// The lid contour as a closed polygon of 16 points: the lower lid from
    /// one corner to the other (0..=8), then the upper lid back (9..=15):
    /// the first 16 points of the iris model's eye contour, reordered.
    pub lid: Vec<[f32; 2]>,
    pub iris: [f32; 2],
    /// Mean distance from the iris centre to the model's four rim points.
    pub iris_radius_px: f32,
    /// The corners on the image's left and right, and the lid midpoints,
    /// as the extractor normalizes `n` against them.
    pub corner_left: [f32; 2],
    pub corner_right: [f32; 2],
    pub upper_lid: [f32; 2],
    pub lower_lid: [f32; 2],
    /// The same eye's corners from the 468-point face mesh (33/133 and
    /// 362/263), image-left first. The iris model's corners lean towards
    /// its iris; the mesh sees the whole face and barely moves with the
    /// gaze, so the new iris is placed between these (else the carrier's
    /// own gaze would steer where the new iris goes).
    pub mesh_corner_left: [f32; 2],
    pub mesh_corner_right: [f32; 2],
}

impl CarrierEye {
    /// Lid gap over corner-to-corner width.
    pub fn aperture(&self) -> f64 {
        let [a, b] = [self.upper_lid, self.lower_lid];
        ((b[0] - a[0]) as f64).hypot((b[1] - a[1]) as f64) / self.width_px().max(1e-6)
    }

    pub fn width_px(&self) -> f64 {
        let [a, b] = [self.corner_left, self.corner_right];
        ((b[0] - a[0]) as f64).hypot((b[1] - a[1]) as f64)
    }
}

/// Why a frame is left as the carrier shows it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Skip {
    NoFace,
    Blink,
    SmallEyes,
    Turned,
}

impl Skip {
    pub fn label(self) -> &'static str {
        match self {
            Skip::NoFace => "no_face",
            Skip::Blink => "blink",
            Skip::SmallEyes => "small_eyes",
            Skip::Turned => "turned",
        }
    }
}

/// One decoded frame of the carrier.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CarrierFrame {
    /// Presentation time on the stream's clock.
    pub time_s: f64,
    /// The landmark model's face presence score (0 without a face).
    pub face_score: f32,
    /// Image-left eye first; `None` without a face.
    pub eyes: Option<[CarrierEye; 2]>,
    /// The carrier's own gaze as the extractor reads it (mean of both
    /// eyes), for the check that the output no longer shows it.
    pub n: Option<[f64; 2]>,
    /// The extractor's blink flag (lid aperture below 0.6 x the clip's
    /// median, and its neighbours).
    pub blink: bool,
}

/// A carrier clip's geometry, frame by frame.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CarrierTrack {
    pub format_version: u32,
    pub width: usize,
    pub height: usize,
    pub frames: Vec<CarrierFrame>,
    /// Median lid aperture over the frames with a face.
    pub median_aperture: f64,
}

fn arr(p: Pt) -> [f32; 2] {
    [p.x, p.y]
}

impl CarrierTrack {
    /// Runs the extractor over every frame of `video` (`progress(done,
    /// estimated_total)` after each).
    pub fn measure(
        video: &Path,
        models: Models,
        mut progress: impl FnMut(u64, u64),
    ) -> Result<CarrierTrack> {
        let mut dec = Decoder::open(video)?;
        let (width, height) = (dec.info.width, dec.info.height);
        let total = dec.info.frames_estimate.unwrap_or(0);
        // The full pipeline on every frame: the carrier's lids must be
        // right in each frame, not only on mesh frames.
        let mut tracker = Tracker::new(models, 1);
        let mut frames = Vec::new();
        let mut rows = Vec::new();
        dec.frames(|t, img| {
            let face = tracker.process(img)?;
            rows.push(Row::from_face(rows.len() as u64, t, face.as_ref()));
            let eyes = face.as_ref().map(|f| {
                let mesh = eyereplay_extract::order_eye_corners(
                    MESH_EYE_CORNERS.map(|(a, b)| (f.mesh[a], f.mesh[b])),
                );
                let eye = |k: usize| {
                    let e = &f.eyes[k];
                    let c = &e.contour;
                    // Lower lid 0..=8 corner to corner, then the upper
                    // lid 15..=9 back, so the polygon closes.
                    let order = (0..=8).chain((9..=15).rev());
                    let lid = order.map(|i| arr(c[i])).collect();
                    let centre = e.iris_rim[0];
                    let r = e.iris_rim[1..].iter().map(|p| p.dist(centre)).sum::<f32>() / 4.0;
                    CarrierEye {
                        lid,
                        iris: arr(e.iris),
                        iris_radius_px: r,
                        corner_left: arr(e.corner_left),
                        corner_right: arr(e.corner_right),
                        upper_lid: arr(e.upper_lid),
                        lower_lid: arr(e.lower_lid),
                        mesh_corner_left: arr(mesh[k].0),
                        mesh_corner_right: arr(mesh[k].1),
                    }
                };
                [eye(0), eye(1)]
            });
            frames.push(CarrierFrame {
                time_s: t,
                face_score: face.as_ref().map_or(0.0, |f| f.score),
                eyes,
                n: None,
                blink: false,
            });
            progress(frames.len() as u64, total);
            Ok(ControlFlow::Continue(()))
        })?;
        eyereplay_extract::flag_blinks(&mut rows, eyereplay_extract::DEFAULT_BLINK_RATIO);
        for (f, r) in frames.iter_mut().zip(&rows) {
            f.blink = r.blink;
            f.n = r.mean_n().map(|(x, y)| [x, y]);
        }
        if frames.is_empty() {
            return Err(ReplayError::carrier(video, "no video frames decoded"));
        }
        let mut ap: Vec<f64> = frames
            .iter()
            .filter_map(|f| f.eyes.as_ref())
            .map(|e| (e[0].aperture() + e[1].aperture()) / 2.0)
            .collect();
        ap.sort_by(f64::total_cmp);
        let median_aperture = ap.get(ap.len() / 2).copied().unwrap_or(0.0);
        Ok(CarrierTrack {
            format_version: TRACK_FORMAT_VERSION,
            width,
            height,
            frames,
            median_aperture,
        })
    }

    /// Reads a cached track; `None` when the file is missing or from
    /// another format version (it is measured again).
    pub fn load(path: &Path) -> Result<Option<CarrierTrack>> {
        let track: Option<CarrierTrack> = eyereplay_core::read_json_cache(path, "carrier track")?;
        Ok(track.filter(|t| t.format_version == TRACK_FORMAT_VERSION))
    }

    /// Writes the track atomically.
    pub fn save(&self, path: &Path) -> Result<()> {
        Ok(eyereplay_core::write_json(path, self)?)
    }

    /// Presentation times of the frames.
    pub fn times_s(&self) -> Vec<f64> {
        self.frames.iter().map(|f| f.time_s).collect()
    }

    /// Median corner-to-corner eye width over the frames with a face.
    pub fn median_eye_width_px(&self) -> Option<f64> {
        let mut w: Vec<f64> = self
            .frames
            .iter()
            .filter_map(|f| f.eyes.as_ref())
            .map(|e| (e[0].width_px() + e[1].width_px()) / 2.0)
            .collect();
        if w.is_empty() {
            return None;
        }
        w.sort_by(f64::total_cmp);
        Some(w[w.len() / 2])
    }

    /// Why frame `i` is left as it is, or `None` when its eyes are redrawn.
    pub fn skip(&self, i: usize) -> Option<Skip> {
        let f = &self.frames[i];
        let Some(eyes) = &f.eyes else {
            return Some(Skip::NoFace);
        };
        let (a, b) = (eyes[0].width_px(), eyes[1].width_px());
        if a.min(b) < MIN_FRAME_EYE_WIDTH_PX {
            return Some(Skip::SmallEyes);
        }
        if a.min(b) < MIN_EYE_WIDTH_RATIO * a.max(b) {
            return Some(Skip::Turned);
        }
        // The extractor's own blink rule: such a frame reads as a blink
        // whatever is drawn in it, and squints and expressions it marks
        // leave too little of the eye to draw in.
        if f.blink {
            return Some(Skip::Blink);
        }
        None
    }

    /// Counts of frames by what happens to them: redrawn, then each skip.
    pub fn usage(&self) -> CarrierUsage {
        let mut u = CarrierUsage {
            frames: self.frames.len(),
            ..Default::default()
        };
        for i in 0..self.frames.len() {
            match self.skip(i) {
                None => u.redrawn += 1,
                Some(Skip::NoFace) => u.no_face += 1,
                Some(Skip::Blink) => u.blink += 1,
                Some(Skip::SmallEyes) => u.small_eyes += 1,
                Some(Skip::Turned) => u.turned += 1,
            }
        }
        u.median_eye_width_px = self.median_eye_width_px();
        u
    }

    /// Refuses a carrier that cannot serve, with the reason in one line:
    /// no face, eyes too small (in pixels), or too few usable frames.
    pub fn check(&self, video: &Path) -> Result<CarrierUsage> {
        let u = self.usage();
        let faces = u.frames - u.no_face;
        if (faces as f64) < MIN_USABLE_FRACTION * u.frames as f64 {
            return Err(ReplayError::carrier(
                video,
                format!(
                    "a face in only {faces} of {} frames; a carrier must show one face facing the camera",
                    u.frames
                ),
            ));
        }
        let w = u.median_eye_width_px.unwrap_or(0.0);
        if w < MIN_EYE_WIDTH_PX {
            return Err(ReplayError::carrier(
                video,
                format!(
                    "the eyes are {w:.1} px wide (corner to corner, median); at least {MIN_EYE_WIDTH_PX} px are needed to redraw an iris (use a closer or larger video)"
                ),
            ));
        }
        if (u.redrawn as f64) < MIN_USABLE_FRACTION * u.frames as f64 {
            return Err(ReplayError::carrier(
                video,
                format!(
                    "only {} of {} frames usable ({} turned more than about 35 degrees, {} with small eyes, {} blinks)",
                    u.redrawn, u.frames, u.turned, u.small_eyes, u.blink
                ),
            ));
        }
        // A still image (a photo given as a carrier) decodes as one
        // frame; what failed later ("too little of the eyes' whites
        // shows") did not say why.
        if u.frames < MIN_CARRIER_FRAMES {
            return Err(ReplayError::carrier(
                video,
                format!(
                    "{} frame(s): not a video (a still image?); a carrier is a video of a person, \
                     at least {MIN_CARRIER_FRAMES} frames (the full-face mode draws from a photo)",
                    u.frames
                ),
            ));
        }
        Ok(u)
    }

    /// The geometry averaged over up to `half` frames either side (frames
    /// with eyes only): the landmarks' frame-to-frame jitter is about a
    /// pixel, more than the iris moves in a fixation, while a head moves
    /// little in 80 ms. Blink frames are not averaged into open ones.
    pub fn smoothed(&self, half: usize) -> CarrierTrack {
        let mut out = self.clone();
        let n = self.frames.len();
        for i in 0..n {
            let Some(_) = &self.frames[i].eyes else {
                continue;
            };
            let blink = self.frames[i].blink;
            let near: Vec<&[CarrierEye; 2]> = (i.saturating_sub(half)..(i + half + 1).min(n))
                .filter(|&j| self.frames[j].blink == blink)
                .filter_map(|j| self.frames[j].eyes.as_ref())
                .collect();
            let k = near.len() as f32;
            let avg = |get: &dyn Fn(&[CarrierEye; 2]) -> [f32; 2]| {
                let s = near.iter().fold([0.0f32; 2], |a, e| {
                    let p = get(e);
                    [a[0] + p[0], a[1] + p[1]]
                });
                [s[0] / k, s[1] / k]
            };
            let eyes = out.frames[i].eyes.as_mut().expect("checked above");
            for (side, eye) in eyes.iter_mut().enumerate() {
                eye.corner_left = avg(&|e| e[side].corner_left);
                eye.corner_right = avg(&|e| e[side].corner_right);
                eye.upper_lid = avg(&|e| e[side].upper_lid);
                eye.lower_lid = avg(&|e| e[side].lower_lid);
                eye.mesh_corner_left = avg(&|e| e[side].mesh_corner_left);
                eye.mesh_corner_right = avg(&|e| e[side].mesh_corner_right);
                for p in 0..eye.lid.len() {
                    eye.lid[p] = avg(&|e| e[side].lid[p]);
                }
            }
        }
        out
    }
}

/// How a carrier's frames are used.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct CarrierUsage {
    pub frames: usize,
    pub redrawn: usize,
    pub no_face: usize,
    pub blink: usize,
    pub small_eyes: usize,
    pub turned: usize,
    pub median_eye_width_px: Option<f64>,
}

#[cfg(test)]
mod tests {
    use super::*;

    fn eye(x0: f32, w: f32) -> CarrierEye {
        CarrierEye {
            lid: vec![[x0, 0.0]; 16],
            iris: [x0 + w / 2.0, 0.0],
            iris_radius_px: w * 0.22,
            corner_left: [x0, 0.0],
            corner_right: [x0 + w, 0.0],
            upper_lid: [x0 + w / 2.0, -w / 6.0],
            lower_lid: [x0 + w / 2.0, w / 6.0],
            mesh_corner_left: [x0, 0.0],
            mesh_corner_right: [x0 + w, 0.0],
        }
    }

    fn closed(x0: f32, w: f32) -> CarrierEye {
        let mut e = eye(x0, w);
        // Aperture 0.1 < 0.45 x 1/3.
        e.upper_lid[1] = -w / 20.0;
        e.lower_lid[1] = w / 20.0;
        e
    }

    fn frame(eyes: Option<[CarrierEye; 2]>, blink: bool) -> CarrierFrame {
        CarrierFrame {
            time_s: 0.0,
            face_score: 1.0,
            eyes,
            n: None,
            blink,
        }
    }

    #[test]
    fn skips_and_refusals_follow_the_documented_limits() {
        let t = CarrierTrack {
            format_version: TRACK_FORMAT_VERSION,
            width: 640,
            height: 480,
            frames: vec![
                frame(Some([eye(100.0, 40.0), eye(200.0, 40.0)]), false),
                frame(None, false),
                // 24 / 40 = 0.6 < 0.65: turned.
                frame(Some([eye(100.0, 24.0), eye(200.0, 40.0)]), false),
                frame(Some([closed(100.0, 40.0), closed(200.0, 40.0)]), true),
            ],
            median_aperture: 1.0 / 3.0,
        };
        assert_eq!(t.skip(0), None);
        assert_eq!(t.skip(1), Some(Skip::NoFace));
        assert_eq!(t.skip(2), Some(Skip::Turned));
        assert_eq!(t.skip(3), Some(Skip::Blink));
        let u = t.usage();
        assert_eq!((u.redrawn, u.no_face, u.turned, u.blink), (1, 1, 1, 1));
        // One usable frame of four is under half: refused, with counts.
        let e = t.check(Path::new("c.mp4")).unwrap_err().to_string();
        assert!(e.starts_with("c.mp4: only 1 of 4 frames usable"), "{e}");

        // Usable, but a still image's one frame: not a video.
        let still = CarrierTrack {
            frames: vec![frame(Some([eye(100.0, 40.0), eye(200.0, 40.0)]), false)],
            ..t.clone()
        };
        let e = still.check(Path::new("p.jpg")).unwrap_err().to_string();
        assert!(e.starts_with("p.jpg: 1 frame(s): not a video"), "{e}");

        let small = CarrierTrack {
            frames: vec![frame(Some([eye(100.0, 12.0), eye(200.0, 12.0)]), false); 3],
            ..t.clone()
        };
        let e = small.check(Path::new("s.mp4")).unwrap_err().to_string();
        assert!(e.contains("the eyes are 12.0 px wide"), "{e}");

        let none = CarrierTrack {
            frames: vec![frame(None, false); 3],
            ..t
        };
        let e = none.check(Path::new("n.mp4")).unwrap_err().to_string();
        assert!(e.contains("a face in only 0 of 3 frames"), "{e}");
    }

    #[test]
    fn smoothing_averages_neighbours_and_keeps_constant_geometry() {
        let mut frames: Vec<CarrierFrame> = (0..5)
            .map(|i| frame(Some([eye(100.0 + i as f32, 40.0), eye(200.0, 40.0)]), false))
            .collect();
        frames[4].blink = true;
        let t = CarrierTrack {
            format_version: TRACK_FORMAT_VERSION,
            width: 640,
            height: 480,
            frames,
            median_aperture: 1.0 / 3.0,
        };
        let s = t.smoothed(1);
        let e = |t: &CarrierTrack, i: usize| t.frames[i].eyes.as_ref().unwrap()[0].corner_left[0];
        // Frame 2: mean of 101, 102, 103.
        assert_eq!(e(&s, 2), 102.0);
        // Frame 3: the blink frame 4 is not averaged in: mean of 102, 103.
        assert_eq!(e(&s, 3), 102.5);
        // The other eye does not move: unchanged.
        assert_eq!(
            s.frames[2].eyes.as_ref().unwrap()[1],
            t.frames[2].eyes.as_ref().unwrap()[1]
        );
    }
}
