//! How the extractor reads a full-face identity: the face mode's
//! `render.match_extractor`.
//!
//! The extractor's iris model finds the eye corners and lids of a rendered
//! face a little elsewhere than the mesh's lid contour that the renderer
//! aims at (wider corners, lids that follow the gaze differently), so it
//! reads a smaller excursion than drawn: 0.45-0.7 of the horizontal one on
//! the bundled identities before this correction; and its reading moves
//! when the head turns with the eye still in the head (about -0.003 nx per
//! degree of yaw, as much at 12 deg as a conversation's whole horizontal
//! spread). As in the close-up mode, probe frames of the session's
//! identity, framing and webcam look are read by the extractor and an
//! affine [`ResponseMap`] `measured = A drawn + b` is fitted, here together
//! with the reading's slopes per degree of head yaw and pitch; the session
//! is drawn through the inverse of both.
//!
//! The probe is a clip read as `eyereplay extract` reads a video: the face
//! tracked from frame to frame, the mesh on every second frame, the eye
//! crops in between moved with the eyes; the head turning all the while,
//! uncorrelated with the probed eye positions, about the middle of the
//! session's planned head range ([`ProbeHeadRange`]: the reading's slope
//! per degree is not the same at every pose, and a reading session looks
//! down). An earlier probe read still
//! frames, each afresh (detection, landmarks, iris), at the rest pose and
//! at +-8 deg yaw and +-6 pitch, and measured the map and the slopes
//! apart. The video's read-back saw other slopes than the still frames
//! gave, and where the head's pitch follows the eye's (reading: r 0.75-0.94
//! between them in the bundled default) the misread slope showed as a
//! vertical gain of 0.64-1.44 instead of 1.

use crate::error::Result;
use crate::photo::PhotoFitter;
use crate::raster::{Rasterizer, RgbImage, TexturedMesh};
use crate::scene::{FaceScene, FaceState};
use crate::session::{HEAD_PITCH_LIMIT_DEG, HEAD_YAW_LIMIT_DEG};
use crate::webcam::{Webcam, WebcamLook};
use eyereplay_core::NormPos;
use eyereplay_render::{probe_grid, ResponseMap};

/// What the extractor's unmodified still path (detection, landmarks, iris;
/// [`PhotoFitter::landmarks`]) reads in `frame`: the mean `(nx, ny)` of both
/// eyes, as in its CSV; `None` without a face or with a degenerate eye.
pub fn read_frame(fitter: &mut PhotoFitter, frame: &RgbImage) -> Result<Option<NormPos>> {
    Ok(fitter.landmarks(frame)?.and_then(|face| {
        let [a, b] = face.eyes.map(|e| e.measure());
        let n = NormPos {
            nx: 0.5 * (a.nx + b.nx),
            ny: 0.5 * (a.ny + b.ny),
        };
        (n.nx.is_finite() && n.ny.is_finite()).then_some(n)
    }))
}

/// Probe points per axis.
const GRID: usize = 5;
/// Smallest probed span per axis (normalized units): a still session
/// still gets a usable slope.
const MIN_SPAN: f64 = 0.08;

/// The probe grid over the session's targets ([`probe_grid`]).
fn grid(targets: &[NormPos], min_span: f64) -> (Vec<NormPos>, NormPos) {
    probe_grid(targets, GRID, GRID, min_span)
}

/// A grid this wide per axis is probed when the session's own range gave
/// no usable fit (a reading session's vertical range can be a few
/// hundredths, where the read-back's noise hides the slope).
const RETRY_SPAN: f64 = 0.2;

/// Frames each probe position is held in the tracked clip.
const HOLD_FRAMES: usize = 3;
/// Passes over the grid: the first as targeted, each later one through the
/// fit so far, all kept in the final fit. Four passes instead of two moved
/// the bundled default's gains and r only as much as another probe path
/// does (the largest gain errors stayed: vertical 1.53 instead of 1.56 on
/// one reading session), so the clip stays at two (6 s of frames).
const PASSES: usize = 2;
/// The tracked clip's head turns (deg, each way), and the periods of its
/// yaw and pitch sinusoids (frames): with the grid's order (`ORDER_STRIDE`)
/// chosen so that head and eye positions are uncorrelated over each pass
/// and both (|r| <= 0.03 for every pair on the 5 x 5 grid), and yaw and
/// pitch with each other. At the fastest about 1 deg a frame of yaw and 1.3
/// of pitch (25 and 32 deg/s).
const CLIP_YAW_DEG: f64 = 8.0;
const CLIP_PITCH_DEG: f64 = 6.0;
const CLIP_YAW_PERIOD: f64 = 49.0;
const CLIP_PITCH_PERIOD: f64 = 29.0;
const CLIP_PITCH_PHASE_RAD: f64 = 0.25;
/// The grid is drawn in the order `i * ORDER_STRIDE mod 25` (coprime with
/// 25, so each point once), which jumps about the grid.
const ORDER_STRIDE: usize = 13;

/// The probe grid in the order the clip draws it ([`ORDER_STRIDE`]).
fn clip_order(grid: &[NormPos]) -> Vec<NormPos> {
    (0..grid.len())
        .map(|i| grid[(i * ORDER_STRIDE) % grid.len()])
        .collect()
}

/// The head turns of a session that a probe clip is centred on (relative
/// to the rest pose, deg): the clip's head turns `CLIP_YAW_DEG` /
/// `CLIP_PITCH_DEG` each way about the middle of the session's planned
/// range, kept within the mode's limits. The extractor's reading moves
/// with the head by a slope that is not the same at every pose (a reading
/// session looks down by 4-5 deg on average; a conversation session may
/// turn 12 deg to look aside), so the probe measures it about where the
/// session goes. (The plan is made before the response is known, from the
/// session's targets drawn geometrically: it underestimates the drawn
/// head's range, so the range sets the middle, not the amplitude.)
/// `Default`: about the rest pose.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ProbeHeadRange {
    pub yaw_deg: (f64, f64),
    pub pitch_deg: (f64, f64),
}

impl ProbeHeadRange {
    /// The range of a planned head path (yaw, pitch relative to rest, deg).
    pub fn of_path(path: impl IntoIterator<Item = (f64, f64)>) -> Self {
        let mut r: Option<ProbeHeadRange> = None;
        for (yaw, pitch) in path {
            let q = r.get_or_insert(ProbeHeadRange {
                yaw_deg: (yaw, yaw),
                pitch_deg: (pitch, pitch),
            });
            q.yaw_deg = (q.yaw_deg.0.min(yaw), q.yaw_deg.1.max(yaw));
            q.pitch_deg = (q.pitch_deg.0.min(pitch), q.pitch_deg.1.max(pitch));
        }
        r.unwrap_or_default()
    }

    /// The pose the clip turns about: (yaw, pitch) relative to rest, deg,
    /// to 4 decimals (as recorded).
    pub fn centre_deg(&self) -> [f64; 2] {
        let [(yaw, _), (pitch, _)] = self.sinusoids();
        [yaw, pitch].map(|v| (v * 1e4).round() / 1e4)
    }

    /// (centre, amplitude) per axis (yaw, pitch) of the clip's sinusoids.
    fn sinusoids(&self) -> [(f64, f64); 2] {
        let axis = |(lo, hi): (f64, f64), amp: f64, limit: f64| {
            let mid = 0.5 * (lo + hi);
            let (lo, hi) = ((mid - amp).max(-limit), (mid + amp).min(limit));
            (0.5 * (lo + hi), 0.5 * (hi - lo))
        };
        [
            axis(self.yaw_deg, CLIP_YAW_DEG, HEAD_YAW_LIMIT_DEG),
            axis(self.pitch_deg, CLIP_PITCH_DEG, HEAD_PITCH_LIMIT_DEG),
        ]
    }
}

/// The head pose (relative to rest: yaw, pitch) of frame `j` of a tracked
/// probe clip over `range`.
fn clip_head(range: &ProbeHeadRange, j: usize) -> (f64, f64) {
    let t = j as f64;
    let [(yc, ya), (pc, pa)] = range.sinusoids();
    (
        yc + ya * (std::f64::consts::TAU * t / CLIP_YAW_PERIOD).sin(),
        pc + pa * (std::f64::consts::TAU * t / CLIP_PITCH_PERIOD + CLIP_PITCH_PHASE_RAD).sin(),
    )
}

/// One read frame of a tracked clip: drawn position, head (yaw, pitch
/// relative to rest, deg), what the extractor read.
type ClipRead = (NormPos, (f64, f64), NormPos);

/// Draws `drawn` (in the order given, each held [`HOLD_FRAMES`]) as a clip
/// whose head turns by [`clip_head`], films it with `look` (per-frame
/// noise, motion blur along the head's motion), and reads it with the
/// extractor's video path ([`PhotoFitter::track`]), continuing the track
/// from frame `first_frame`.
fn read_clip(
    scene: &FaceScene,
    look: &WebcamLook,
    range: &ProbeHeadRange,
    fitter: &mut PhotoFitter,
    drawn: &[NormPos],
    first_frame: usize,
    out: &mut Vec<ClipRead>,
) -> Result<()> {
    let (w, h) = (scene.width(), scene.height());
    let mut raster = Rasterizer::new(w, h);
    let mut mesh = TexturedMesh::new(vec![], vec![], vec![]);
    let mut frame = RgbImage::filled(w, h, [0, 0, 0]);
    let mut webcam = Webcam::new(look, w, h);
    let rest = scene.rest_pose;
    let rel = |j: usize| clip_head(range, j);
    let pose = |j: usize| {
        let (yaw, pitch) = rel(j);
        let mut head = rest;
        head.yaw_deg += yaw;
        head.pitch_deg += pitch;
        head
    };
    for (k, &d) in drawn.iter().enumerate() {
        for hold in 0..HOLD_FRAMES {
            let j = first_frame + k * HOLD_FRAMES + hold;
            let head = pose(j);
            let state = FaceState {
                head,
                eyes: scene.solve_eyes(&head, (d.nx, d.ny), 0.0),
                closure: 0.0,
                pupil_scale: 1.0,
            };
            scene.draw(&state, &mut raster, &mut mesh, &mut frame);
            let motion = match j.checked_sub(1) {
                Some(prev) => {
                    let (a, b) = (scene.nose_px(&head), scene.nose_px(&pose(prev)));
                    [(a[0] - b[0]) as f32, (a[1] - b[1]) as f32]
                }
                None => [0.0, 0.0],
            };
            webcam.apply(&mut frame, j as u64, motion);
            let Some(face) = fitter.track(&frame, j == 0)? else {
                continue;
            };
            let [a, b] = face.eyes.map(|e| e.measure());
            let n = NormPos {
                nx: 0.5 * (a.nx + b.nx),
                ny: 0.5 * (a.ny + b.ny),
            };
            if n.nx.is_finite() && n.ny.is_finite() {
                out.push((d, rel(j), n));
            }
        }
    }
    Ok(())
}

/// An axis of the eye's position in its aperture.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Axis {
    Horizontal,
    Vertical,
}

impl Axis {
    /// `horizontally` or `vertically`.
    pub fn adverb(self) -> &'static str {
        match self {
            Axis::Horizontal => "horizontally",
            Axis::Vertical => "vertically",
        }
    }

    /// `horizontal` or `vertical`, as identity files name it.
    pub fn name(self) -> &'static str {
        match self {
            Axis::Horizontal => "horizontal",
            Axis::Vertical => "vertical",
        }
    }

    /// The other axis.
    pub fn other(self) -> Axis {
        match self {
            Axis::Horizontal => Axis::Vertical,
            Axis::Vertical => Axis::Horizontal,
        }
    }

    fn index(self) -> usize {
        match self {
            Axis::Horizontal => 0,
            Axis::Vertical => 1,
        }
    }
}

/// A response map and pose slopes fitted to a clip's or a session's reads
/// ([`fit_joint_or_why`]).
#[derive(Clone, Copy, Debug, PartialEq)]
struct JointFit {
    map: ResponseMap,
    slopes: [[f64; 2]; 2],
    /// Matched on one axis only: the other, drawn at the geometric
    /// position, and why its fit was not used.
    geometric: Option<(Axis, ProbeRefusal)>,
}

/// Why a probe found no usable response map: what `generate`'s warning
/// says of a session drawn at the geometric position.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ProbeRefusal {
    /// The extractor saw open eyes in this many of the clip's frames.
    TooFewReads(usize),
    /// The reads do not determine the map: the frames where the eyes were
    /// found do not vary enough in drawn position and head pose.
    Undetermined,
    /// A map no extractor reading an eye has
    /// ([`ResponseMap::checked`]): its gains and cross terms, as fitted.
    Implausible { a: [[f64; 2]; 2] },
}

impl std::fmt::Display for ProbeRefusal {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ProbeRefusal::TooFewReads(n) => {
                write!(f, "the extractor found open eyes in only {n} of its frames")
            }
            ProbeRefusal::Undetermined => {
                write!(
                    f,
                    "the frames where it found the eyes do not span the positions the clip drew"
                )
            }
            ProbeRefusal::Implausible { a } => write!(
                f,
                "it read the eye's movement at {:.2} of its size horizontally and {:.2} \
vertically, cross terms {:.2} and {:.2}: {} (eyes small in the frame read this way)",
                a[0][0],
                a[1][1],
                a[0][1],
                a[1][0],
                ResponseMap { a: *a, b: [0.0; 2] }.faults().join(", and ")
            ),
        }
    }
}

/// Least-squares fit of `measured = A drawn + S head + b` over a tracked
/// clip's reads: the response map and the pose slopes (per degree of yaw
/// and pitch) at once; or why there is none (too few reads, a singular
/// design, an implausible response: [`ResponseMap::checked`]).
///
/// Where one axis's response is implausible and the other's is not (a
/// face small in the frame can read the vertical at a fifth of its size
/// while the horizontal reads at half), the plausible axis is matched and
/// the other drawn at the geometric position ([`one_axis`]): refusing both
/// would leave the horizontal, which reading is told by, unmatched too.
fn fit_joint_or_why(reads: &[ClipRead]) -> Result<JointFit, ProbeRefusal> {
    use nalgebra::{SMatrix, SVector};
    if reads.len() < 10 {
        return Err(ProbeRefusal::TooFewReads(reads.len()));
    }
    let mut g = SMatrix::<f64, 5, 5>::zeros();
    let mut r = [SVector::<f64, 5>::zeros(); 2];
    for &(d, (yaw, pitch), m) in reads {
        let v = SVector::<f64, 5>::from([d.nx, d.ny, yaw, pitch, 1.0]);
        g += v * v.transpose();
        r[0] += v * m.nx;
        r[1] += v * m.ny;
    }
    let lu = g.lu();
    let (Some(x), Some(y)) = (lu.solve(&r[0]), lu.solve(&r[1])) else {
        return Err(ProbeRefusal::Undetermined);
    };
    if !x.iter().chain(y.iter()).all(|v| v.is_finite()) {
        return Err(ProbeRefusal::Undetermined);
    }
    let fitted = ResponseMap {
        a: [[x[0], x[1]], [y[0], y[1]]],
        b: [x[4], y[4]],
    };
    let q = |v: f64| (v * 1e5).round() / 1e5;
    let slopes = [[q(x[2]), q(x[3])], [q(y[2]), q(y[3])]];
    if let Some(map) = fitted.checked() {
        return Ok(JointFit {
            map,
            slopes,
            geometric: None,
        });
    }
    let why = ProbeRefusal::Implausible { a: fitted.a };
    for axis in [Axis::Vertical, Axis::Horizontal] {
        if let Some((map, slopes)) = one_axis(fitted, slopes, axis) {
            return Ok(JointFit {
                map,
                slopes,
                geometric: Some((axis, why)),
            });
        }
    }
    Err(why)
}

/// `fitted` and `slopes` with `geometric`'s row replaced by the identity
/// (that axis measured as drawn, no offset, no pose slope: drawing through
/// the map leaves it at the geometric position), where the other row alone
/// passes [`ResponseMap::checked`].
fn one_axis(
    fitted: ResponseMap,
    slopes: [[f64; 2]; 2],
    geometric: Axis,
) -> Option<(ResponseMap, [[f64; 2]; 2])> {
    let g = geometric.index();
    let mut map = fitted;
    map.a[g] = [0.0; 2];
    map.a[g][g] = 1.0;
    map.b[g] = 0.0;
    let mut slopes = slopes;
    slopes[g] = [0.0; 2];
    Some((map.checked()?, slopes))
}

/// What `match_extractor` measures for one session: the response map
/// drawn through, and the reading's slopes as the head turns.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ExtractorMatch {
    pub response: Option<ResponseMap>,
    /// d(nx, ny) / d(head yaw, pitch) per degree (rows nx, ny; columns yaw,
    /// pitch), in measured units; subtracted per frame.
    pub pose_slopes: Option<[[f64; 2]; 2]>,
    /// Without a response: why the probe's last try gave none.
    pub refused: Option<ProbeRefusal>,
    /// With a response that matches one axis only ([`fit_joint_or_why`]):
    /// the other, drawn at the geometric position, and why its fit was not
    /// used.
    pub geometric: Option<(Axis, ProbeRefusal)>,
}

impl ExtractorMatch {
    fn of(fit: JointFit) -> ExtractorMatch {
        ExtractorMatch {
            response: Some(fit.map),
            pose_slopes: Some(fit.slopes),
            refused: None,
            geometric: fit.geometric,
        }
    }
}

/// How the extractor reads this session's identity, framing and look, over
/// the range the session's `targets` (uncorrected) cover: a probe clip of
/// the 5 x 5 grid over that range, each point held `HOLD_FRAMES` frames
/// while the head turns (+-8 deg yaw, +-6 pitch about the middle of the
/// session's planned head range, `head`; uncorrelated with the grid),
/// filmed with the session's webcam look and read by the extractor's video
/// path ([`PhotoFitter::track`]); `measured = A drawn + S head + b` is
/// fitted to it, the response map (A, b; gains corrected
/// about the session's centre) and the pose slopes S at once. A second
/// pass draws the grid through the first fit; both are kept in the final
/// fit. When the session's own range gives no usable fit (a reading
/// session's vertical range can be a few hundredths, where the read-back's
/// noise hides the slope), a grid `RETRY_SPAN` wide is tried. When that
/// fails too, the first fit of one axis only is used (the other axis drawn
/// geometrically, `geometric`), else the session is drawn
/// geometrically (`response` and `pose_slopes` `None`).
pub fn match_extractor(
    scene: &FaceScene,
    look: &WebcamLook,
    fitter: &mut PhotoFitter,
    targets: &[NormPos],
    head: &ProbeHeadRange,
) -> Result<ExtractorMatch> {
    let mut refused = None;
    // A fit of one axis only counts as a refusal here, as it did before
    // one-axis matches were drawn: the wider grid is tried for both axes
    // (so a session that one matches is drawn as before, byte for byte),
    // and the first such fit is drawn through only where no grid fits both.
    let mut one_axis_match = None;
    'span: for span in [MIN_SPAN, RETRY_SPAN] {
        let (grid, centre) = grid(targets, span);
        let order = clip_order(&grid);
        let mut reads = vec![];
        let mut fit: Option<JointFit> = None;
        for pass in 0..PASSES {
            // The first pass as targeted, each later one through the fit.
            let drawn: Vec<NormPos> = match fit {
                None => order.clone(),
                Some(f) => order.iter().map(|&g| f.map.invert(g)).collect(),
            };
            let first_frame = pass * order.len() * HOLD_FRAMES;
            read_clip(scene, look, head, fitter, &drawn, first_frame, &mut reads)?;
            match fit_joint_or_why(&reads) {
                Ok(f) if f.geometric.is_none() => {
                    fit = Some(JointFit {
                        map: f.map.about(centre),
                        ..f
                    })
                }
                Ok(f) => {
                    one_axis_match.get_or_insert(ExtractorMatch::of(JointFit {
                        map: f.map.about(centre),
                        ..f
                    }));
                    continue 'span;
                }
                Err(why) => {
                    refused = Some(why);
                    continue 'span;
                }
            }
        }
        if let Some(f) = fit {
            return Ok(ExtractorMatch::of(f));
        }
    }
    Ok(one_axis_match.unwrap_or(ExtractorMatch {
        refused,
        ..ExtractorMatch::default()
    }))
}

/// The least open-eye frames a session's read-back must give for
/// [`refine_match`] to fit from it.
pub const REFINE_MIN_READS: usize = 50;

/// One read-back frame for [`refine_match`]: what was drawn, the head
/// relative to rest (yaw, pitch, deg), and what the extractor read (the
/// mean `(nx, ny)` of both eyes).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SessionRead {
    pub drawn: NormPos,
    pub head_deg: (f64, f64),
    pub measured: NormPos,
}

/// The read-back match (`render.match_readback`): the response map and
/// pose slopes fitted as the probe fits them (`measured = A drawn + S
/// head + b`), but to the session's own video as the extractor read it
/// back instead of to the probe clip. The probe's map misjudges
/// the vertical response of a session by up to a third (vertical gains
/// 0.63-1.15 in the bundled default), since the clip is not the session:
/// other eye and head movements, no H.264, a head that turns about a
/// planned range. The map keeps the probe's working point (`targets`'
/// grid centre maps to itself, [`ResponseMap::about`]). `None` with fewer
/// than [`REFINE_MIN_READS`] reads or where the fit fails the probe's
/// checks: the probe's match stands. A fit of one axis only is used where
/// the probe's match (`probe_geometric`) left the same axis geometric; a
/// probe that matched both keeps its map.
pub fn refine_match(
    targets: &[NormPos],
    reads: &[SessionRead],
    probe_geometric: Option<Axis>,
) -> Option<ExtractorMatch> {
    if reads.len() < REFINE_MIN_READS {
        return None;
    }
    let reads: Vec<ClipRead> = reads
        .iter()
        .map(|r| (r.drawn, r.head_deg, r.measured))
        .collect();
    let fit = fit_joint_or_why(&reads).ok()?;
    if let Some((axis, _)) = fit.geometric {
        if probe_geometric != Some(axis) {
            return None;
        }
    }
    let (_, centre) = grid(targets, MIN_SPAN);
    Some(ExtractorMatch::of(JointFit {
        map: fit.map.about(centre),
        ..fit
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Reads of a clip whose extractor responds exactly as
    /// `measured = A drawn + S head + b` (A, S, b chosen by hand), over the
    /// clip's own head path and the grid order `match_extractor` uses,
    /// every pass at the grid as targeted.
    fn exact_reads(a: [[f64; 2]; 2], s: [[f64; 2]; 2], b: [f64; 2]) -> Vec<ClipRead> {
        exact_reads_about(a, s, b, &ProbeHeadRange::default())
    }

    fn exact_reads_about(
        a: [[f64; 2]; 2],
        s: [[f64; 2]; 2],
        b: [f64; 2],
        head: &ProbeHeadRange,
    ) -> Vec<ClipRead> {
        let targets: Vec<NormPos> = (0..50)
            .map(|i| NormPos {
                nx: 0.45 + 0.002 * i as f64,
                ny: 0.5 - 0.001 * i as f64,
            })
            .collect();
        let (grid, _) = grid(&targets, MIN_SPAN);
        let order = clip_order(&grid);
        (0..PASSES * order.len() * HOLD_FRAMES)
            .map(|j| {
                let d = order[j / HOLD_FRAMES % order.len()];
                let h = clip_head(head, j);
                let m = NormPos {
                    nx: a[0][0] * d.nx + a[0][1] * d.ny + s[0][0] * h.0 + s[0][1] * h.1 + b[0],
                    ny: a[1][0] * d.nx + a[1][1] * d.ny + s[1][0] * h.0 + s[1][1] * h.1 + b[1],
                };
                (d, h, m)
            })
            .collect()
    }

    #[test]
    fn a_refused_axis_says_why_and_the_other_is_matched() {
        // An extractor that reads the vertical movement at a fifth of its
        // size (a small face): the map is fitted exactly, its vertical row
        // refused by ResponseMap::checked, and the refusal carries the
        // gains. The horizontal row is matched as fitted, its pose slopes
        // kept; the vertical is drawn as targeted (identity row, no slope).
        let s = [[-0.003, 0.0004], [0.001, 0.002]];
        let reads = exact_reads([[0.62, 0.01], [-0.02, 0.2]], s, [0.2, 0.3]);
        let fit = fit_joint_or_why(&reads).expect("the horizontal matched");
        let Some((Axis::Vertical, ProbeRefusal::Implausible { a })) = fit.geometric else {
            panic!("a vertical gain of 0.2 must be refused: {fit:?}");
        };
        assert!(
            (a[1][1] - 0.2).abs() < 1e-6 && (a[0][0] - 0.62).abs() < 1e-6,
            "{a:?}"
        );
        assert_eq!(fit.map.a[1], [0.0, 1.0]);
        assert_eq!(fit.map.b[1], 0.0);
        // What the warning and the identity file say of it.
        assert_eq!(
            (Axis::Vertical.other().adverb(), Axis::Vertical.name()),
            ("horizontally", "vertical")
        );
        assert!((fit.map.a[0][0] - 0.62).abs() < 1e-4 && (fit.map.a[0][1] - 0.01).abs() < 1e-4);
        assert!((fit.map.b[0] - 0.2).abs() < 1e-4, "{:?}", fit.map);
        assert_eq!(fit.slopes[1], [0.0, 0.0]);
        assert!((fit.slopes[0][0] + 0.003).abs() < 1e-5, "{:?}", fit.slopes);
        // Drawn through it, a target keeps its vertical and moves its
        // horizontal to where this extractor reads the target's.
        let t = NormPos { nx: 0.55, ny: 0.42 };
        let d = fit.map.invert(t);
        assert!((d.ny - 0.42).abs() < 1e-12);
        assert!(
            (0.62 * d.nx + 0.01 * d.ny + 0.2 - 0.55).abs() < 1e-3,
            "{d:?}"
        );
        // The horizontal refused instead: the vertical matched.
        let reads = exact_reads([[0.1, 0.0], [0.0, 0.8]], [[0.0; 2]; 2], [0.5, 0.5]);
        let fit = fit_joint_or_why(&reads).expect("the vertical matched");
        assert_eq!(fit.geometric.map(|(axis, _)| axis), Some(Axis::Horizontal));
        assert_eq!(fit.map.a[0], [1.0, 0.0]);
        // The read-back's fit of one axis stands only where the probe's
        // left that same axis geometric.
        let session: Vec<SessionRead> = reads
            .iter()
            .map(|&(drawn, head_deg, measured)| SessionRead {
                drawn,
                head_deg,
                measured,
            })
            .collect();
        let targets: Vec<NormPos> = session.iter().map(|r| r.drawn).collect();
        assert!(refine_match(&targets, &session, None).is_none());
        assert!(refine_match(&targets, &session, Some(Axis::Vertical)).is_none());
        let refit = refine_match(&targets, &session, Some(Axis::Horizontal)).expect("a fit");
        assert_eq!(
            refit.geometric.map(|(axis, _)| axis),
            Some(Axis::Horizontal)
        );
        let reads = exact_reads([[0.62, 0.01], [-0.02, 0.2]], [[0.0; 2]; 2], [0.2, 0.3]);
        let said = ProbeRefusal::Implausible { a }.to_string();
        assert!(
            said.contains(
                "0.62 of its size horizontally and 0.20 vertically, cross terms 0.01 and -0.02: \
                 the vertical gain, 0.2, is outside 0.25-4 (eyes small"
            ),
            "{said}"
        );
        // At the edge: shown at two decimals as the bound, named exactly.
        let edge = ProbeRefusal::Implausible {
            a: [[0.5, 0.0], [0.6, 0.2496]],
        };
        assert!(
            edge.to_string().contains(
                "0.25 vertically, cross terms 0.00 and 0.60: the vertical gain, 0.2496, is \
                 outside 0.25-4, and a cross term, 0.6, is over 0.5 ("
            ),
            "{edge}"
        );
        assert_eq!(
            fit_joint_or_why(&reads[..9]),
            Err(ProbeRefusal::TooFewReads(9))
        );
        // At 0.3 the same reads give a map of both axes.
        let reads = exact_reads([[0.62, 0.01], [-0.02, 0.3]], [[0.0; 2]; 2], [0.2, 0.3]);
        assert_eq!(fit_joint_or_why(&reads).map(|f| f.geometric), Ok(None));
    }

    #[test]
    fn joint_fit_recovers_the_response_and_the_pose_slopes() {
        let (a, s, b) = (
            [[0.62, -0.05], [0.19, 0.57]],
            [[-0.0031, 0.0004], [0.0010, 0.0024]],
            [0.21, 0.17],
        );
        // About the rest pose, and about a reading session's downward look:
        // the head enters the fit relative to rest either way, so b is the
        // reading at rest in both.
        let looking_down = ProbeHeadRange {
            yaw_deg: (-3.0, 2.0),
            pitch_deg: (0.5, 7.5),
        };
        for head in [ProbeHeadRange::default(), looking_down] {
            let fit = fit_joint_or_why(&exact_reads_about(a, s, b, &head)).expect("a fit");
            let (map, slopes) = (fit.map, fit.slopes);
            assert_eq!(fit.geometric, None);
            for i in 0..2 {
                for j in 0..2 {
                    assert!((map.a[i][j] - a[i][j]).abs() < 1e-4, "{map:?}");
                    assert!((slopes[i][j] - s[i][j]).abs() < 1e-5, "{slopes:?}");
                }
                assert!((map.b[i] - b[i]).abs() < 1e-4, "{map:?}");
            }
        }
    }

    #[test]
    fn probe_head_turns_about_the_sessions_range_within_the_limits() {
        // Worked by hand. Yaw -3..2: middle -0.5, +-8 -> -8.5..7.5.
        // Pitch 0.5..7.5: middle 4, +-6 -> -2..10, cut at the 8 deg limit
        // -> -2..8: centre 3, +-5.
        let r = ProbeHeadRange::of_path([(-3.0, 4.0), (2.0, 0.5), (0.0, 7.5)]);
        assert_eq!(
            r,
            ProbeHeadRange {
                yaw_deg: (-3.0, 2.0),
                pitch_deg: (0.5, 7.5)
            }
        );
        let [(yc, ya), (pc, pa)] = r.sinusoids();
        let close = |a: f64, b: f64| (a - b).abs() < 1e-12;
        assert!(close(yc, -0.5) && close(ya, 8.0), "yaw {yc} +- {ya}");
        assert!(close(pc, 3.0) && close(pa, 5.0), "pitch {pc} +- {pa}");
        assert_eq!(r.centre_deg(), [-0.5, 3.0]);
        // A look aside to the yaw limit: 0..12 -> 6 +- 8 -> -2..12 -> 5 +- 7.
        let [(yc, ya), _] = ProbeHeadRange::of_path([(0.0, 0.0), (12.0, 0.0)]).sinusoids();
        assert!(close(yc, 5.0) && close(ya, 7.0), "yaw {yc} +- {ya}");
        // No path: about rest, the full turns.
        assert_eq!(ProbeHeadRange::of_path([]), ProbeHeadRange::default());
        let [(yc, ya), (pc, pa)] = ProbeHeadRange::default().sinusoids();
        assert!(
            close(yc, 0.0)
                && close(ya, CLIP_YAW_DEG)
                && close(pc, 0.0)
                && close(pa, CLIP_PITCH_DEG)
        );
        // Every clip frame stays inside the limits.
        for j in 0..300 {
            let (yaw, pitch) = clip_head(&r, j);
            assert!(yaw.abs() <= HEAD_YAW_LIMIT_DEG && pitch.abs() <= HEAD_PITCH_LIMIT_DEG);
        }
    }

    /// A session's reads whose head follows the eye, as the coordination
    /// model moves it (yaw with nx, pitch with ny, plus a slow sway), read
    /// by an extractor that responds exactly as `measured = A drawn + S
    /// head + b`: the read-back fit gives A and S back, the probe's working
    /// point maps to itself, and too few reads give no refinement.
    #[test]
    fn refine_match_recovers_the_sessions_response() {
        let (a, s, b) = (
            [[0.52, 0.04], [0.22, 0.31]],
            [[-0.0007, -0.0005], [-0.0009, 0.0018]],
            [0.26, 0.17],
        );
        let reads: Vec<SessionRead> = (0..600)
            .map(|i| {
                let t = i as f64 / 25.0;
                let drawn = NormPos {
                    nx: 0.5 + 0.04 * (0.9 * t).sin() + 0.01 * (3.1 * t).cos(),
                    ny: 0.48 + 0.03 * (0.5 * t).cos() + 0.008 * (2.3 * t).sin(),
                };
                let head_deg = (
                    120.0 * (drawn.nx - 0.5) + 0.8 * (0.2 * t).sin(),
                    60.0 * (drawn.ny - 0.48) + 0.5 * (0.13 * t).cos(),
                );
                let m = |k: usize| {
                    a[k][0] * drawn.nx
                        + a[k][1] * drawn.ny
                        + s[k][0] * head_deg.0
                        + s[k][1] * head_deg.1
                        + b[k]
                };
                SessionRead {
                    drawn,
                    head_deg,
                    measured: NormPos { nx: m(0), ny: m(1) },
                }
            })
            .collect();
        let targets: Vec<NormPos> = reads.iter().map(|r| r.measured).collect();
        let refit = refine_match(&targets, &reads, None).expect("a fit");
        assert_eq!((refit.geometric, refit.refused), (None, None));
        let (map, slopes) = (refit.response.unwrap(), refit.pose_slopes.unwrap());
        for i in 0..2 {
            for j in 0..2 {
                // The map is rounded to 1e-4, the slopes to 1e-5.
                assert!((map.a[i][j] - a[i][j]).abs() <= 0.5e-4, "{map:?}");
                assert!((slopes[i][j] - s[i][j]).abs() <= 0.5e-5, "{slopes:?}");
            }
        }
        let (_, centre) = grid(&targets, MIN_SPAN);
        let back = map.invert(centre);
        assert!(
            (back.nx - centre.nx).abs() < 1e-3 && (back.ny - centre.ny).abs() < 1e-3,
            "{back:?} vs {centre:?}"
        );
        assert!(refine_match(&targets, &reads[..REFINE_MIN_READS - 1], None).is_none());
    }

    #[test]
    fn joint_fit_refuses_what_the_still_fit_refuses() {
        // Gains of 0.1 and 0.2 are outside ResponseMap::fit's 0.25-4.
        let reads = exact_reads([[0.1, 0.0], [0.0, 0.2]], [[0.0; 2]; 2], [0.5, 0.5]);
        assert!(matches!(
            fit_joint_or_why(&reads),
            Err(ProbeRefusal::Implausible { .. })
        ));
        // A cross term of 0.6 spoils the horizontal row as a gain would.
        let reads = exact_reads([[0.6, 0.6], [0.0, 0.2]], [[0.0; 2]; 2], [0.5, 0.5]);
        assert!(fit_joint_or_why(&reads).is_err());
        // No eye movement at all: the design is singular.
        let still: Vec<ClipRead> = (0..60)
            .map(|j| {
                let p = NormPos { nx: 0.5, ny: 0.5 };
                (p, clip_head(&ProbeHeadRange::default(), j), p)
            })
            .collect();
        assert_eq!(fit_joint_or_why(&still), Err(ProbeRefusal::Undetermined));
    }

    /// The clip's head is uncorrelated with the drawn eye, so the fit can
    /// tell the eye's gain from the head's slope: over the first pass and
    /// over the whole clip, |r| of yaw and pitch against drawn nx and ny,
    /// and of yaw against pitch, stays under 0.03 (the constants' doc).
    #[test]
    fn clip_head_is_uncorrelated_with_the_drawn_eye() {
        let all = exact_reads([[1.0, 0.0], [0.0, 1.0]], [[0.0; 2]; 2], [0.0, 0.0]);
        let pass = all.len() / PASSES;
        for reads in [&all[..pass], &all[..]] {
            let r =
                |a: &[f64], b: &[f64]| eyereplay_signal::stats::pearson(a, b).expect("both vary");
            let col = |f: &dyn Fn(&ClipRead) -> f64| reads.iter().map(f).collect::<Vec<f64>>();
            let (nx, ny) = (col(&|c| c.0.nx), col(&|c| c.0.ny));
            let (yaw, pitch) = (col(&|c| c.1 .0), col(&|c| c.1 .1));
            for (u, v) in [
                (&yaw, &nx),
                (&yaw, &ny),
                (&pitch, &nx),
                (&pitch, &ny),
                (&yaw, &pitch),
            ] {
                assert!(
                    r(u, v).abs() < 0.03,
                    "r {} over {} frames",
                    r(u, v),
                    reads.len()
                );
            }
        }
    }
}
