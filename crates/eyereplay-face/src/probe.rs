//! How the extractor reads a full-face identity: the face mode's
//! `render.match_extractor`.
//!
//! The extractor's iris model finds the eye corners and lids of a rendered
//! face a little elsewhere than the mesh's lid contour that the renderer
//! aims at (wider corners, lids that follow the gaze differently), so it
//! reads a smaller excursion than drawn: 0.45-0.7 of the horizontal one on
//! the bundled identities before this correction. As in the close-up mode,
//! probe frames of the session's identity, framing and webcam look, at the
//! rest pose over the range the session's targets cover, are read with the
//! extractor's unmodified per-frame path (detection, 468 landmarks, iris),
//! and an affine [`ResponseMap`] `measured = A drawn + b` is fitted; the
//! session is then drawn through its inverse (gains corrected about the
//! session's centre). Two passes: the grid, then the grid as corrected by
//! the first fit, both kept in the final fit.

use crate::error::Result;
use crate::photo::PhotoFitter;
use crate::raster::{Rasterizer, RgbImage, TexturedMesh};
use crate::scene::{FaceScene, FaceState};
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

/// Measures the response map of `scene` with `look` over the session's
/// `targets` (uncorrected), retrying once over a wider grid; `Ok(None)`
/// when the probe frames could not be read well enough to fit one (the
/// session is then drawn geometrically).
pub fn measure_response(
    scene: &FaceScene,
    look: &WebcamLook,
    fitter: &mut PhotoFitter,
    targets: &[NormPos],
) -> Result<Option<ResponseMap>> {
    if let Some(m) = measure_over(scene, look, fitter, grid(targets, MIN_SPAN))? {
        return Ok(Some(m));
    }
    measure_over(scene, look, fitter, grid(targets, RETRY_SPAN))
}

fn measure_over(
    scene: &FaceScene,
    look: &WebcamLook,
    fitter: &mut PhotoFitter,
    (grid, centre): (Vec<NormPos>, NormPos),
) -> Result<Option<ResponseMap>> {
    let (w, h) = (scene.width(), scene.height());
    let mut raster = Rasterizer::new(w, h);
    let mut mesh = TexturedMesh::new(vec![], vec![], vec![]);
    let mut frame = RgbImage::filled(w, h, [0, 0, 0]);
    let mut webcam = Webcam::new(look, w, h);
    let mut pairs: Vec<(NormPos, NormPos)> = vec![];
    let mut read = |drawn: NormPos, pairs: &mut Vec<(NormPos, NormPos)>| -> Result<()> {
        let head = scene.rest_pose;
        let state = FaceState {
            head,
            eyes: scene.solve_eyes(&head, (drawn.nx, drawn.ny), 0.0),
            closure: 0.0,
            pupil_scale: 1.0,
        };
        scene.draw(&state, &mut raster, &mut mesh, &mut frame);
        webcam.apply(&mut frame, 0, [0.0, 0.0]);
        if let Some(n) = read_frame(fitter, &frame)? {
            pairs.push((drawn, n));
        }
        Ok(())
    };
    for &g in &grid {
        read(g, &mut pairs)?;
    }
    let Some(first) = ResponseMap::fit(&pairs) else {
        return Ok(None);
    };
    let first = first.about(centre);
    for &g in &grid {
        read(first.invert(g), &mut pairs)?;
    }
    Ok(ResponseMap::fit(&pairs).map(|m| m.about(centre)))
}

/// Head turn used to measure [`measure_pose_slopes`] (deg each way).
const SLOPE_YAW_DEG: f64 = 8.0;
const SLOPE_PITCH_DEG: f64 = 6.0;

/// How the extractor's reading moves when the head turns with the eye
/// still in the head: `d(nx, ny) / d(yaw, pitch)` per degree (rows nx,
/// ny; columns yaw, pitch), measured at five drawn positions around
/// `centre` with the head turned each way. The iris model reads a turned
/// head's eye a little off (about -0.003 nx per degree of yaw on the
/// bundled identities: 0.035 at 12 deg, as much as a conversation's
/// whole horizontal spread), so the renderer subtracts this per frame.
/// `Ok(None)` when a probe frame has no face.
pub fn measure_pose_slopes(
    scene: &FaceScene,
    look: &WebcamLook,
    fitter: &mut PhotoFitter,
    centre: NormPos,
) -> Result<Option<[[f64; 2]; 2]>> {
    let (w, h) = (scene.width(), scene.height());
    let mut raster = Rasterizer::new(w, h);
    let mut mesh = TexturedMesh::new(vec![], vec![], vec![]);
    let mut frame = RgbImage::filled(w, h, [0, 0, 0]);
    let mut webcam = Webcam::new(look, w, h);
    let pts = [
        (0.0, 0.0),
        (0.03, 0.0),
        (-0.03, 0.0),
        (0.0, 0.03),
        (0.0, -0.03),
    ];
    let mut mean_at = |d_yaw: f64, d_pitch: f64| -> Result<Option<(f64, f64)>> {
        let mut head = scene.rest_pose;
        head.yaw_deg += d_yaw;
        head.pitch_deg += d_pitch;
        let (mut sx, mut sy) = (0.0, 0.0);
        for (dx, dy) in pts {
            let target = (centre.nx + dx, centre.ny + dy);
            let state = FaceState {
                head,
                eyes: scene.solve_eyes(&head, target, 0.0),
                closure: 0.0,
                pupil_scale: 1.0,
            };
            scene.draw(&state, &mut raster, &mut mesh, &mut frame);
            webcam.apply(&mut frame, 0, [0.0, 0.0]);
            let Some(n) = read_frame(fitter, &frame)? else {
                return Ok(None);
            };
            sx += n.nx / pts.len() as f64;
            sy += n.ny / pts.len() as f64;
        }
        Ok(Some((sx, sy)))
    };
    let (Some(yl), Some(yr), Some(pd), Some(pu)) = (
        mean_at(-SLOPE_YAW_DEG, 0.0)?,
        mean_at(SLOPE_YAW_DEG, 0.0)?,
        mean_at(0.0, -SLOPE_PITCH_DEG)?,
        mean_at(0.0, SLOPE_PITCH_DEG)?,
    ) else {
        return Ok(None);
    };
    let q = |v: f64| (v * 1e5).round() / 1e5;
    Ok(Some([
        [
            q((yr.0 - yl.0) / (2.0 * SLOPE_YAW_DEG)),
            q((pu.0 - pd.0) / (2.0 * SLOPE_PITCH_DEG)),
        ],
        [
            q((yr.1 - yl.1) / (2.0 * SLOPE_YAW_DEG)),
            q((pu.1 - pd.1) / (2.0 * SLOPE_PITCH_DEG)),
        ],
    ]))
}

/// What `match_extractor` measures for one session: the response map
/// drawn through, and the reading's slopes as the head turns.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ExtractorMatch {
    pub response: Option<ResponseMap>,
    pub pose_slopes: Option<[[f64; 2]; 2]>,
}

/// Both probes of a session whose targets (before any correction) are
/// `targets`: [`measure_response`], then [`measure_pose_slopes`] about the
/// centre of the targets as corrected by that response.
pub fn match_extractor(
    scene: &FaceScene,
    look: &WebcamLook,
    fitter: &mut PhotoFitter,
    targets: &[NormPos],
) -> Result<ExtractorMatch> {
    let response = measure_response(scene, look, fitter, targets)?;
    let drawn: Vec<NormPos> = match response {
        Some(m) => targets.iter().map(|&t| m.invert(t)).collect(),
        None => targets.to_vec(),
    };
    let (_, centre) = grid(&drawn, MIN_SPAN);
    Ok(ExtractorMatch {
        response,
        pose_slopes: measure_pose_slopes(scene, look, fitter, centre)?,
    })
}
