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
use eyereplay_render::ResponseMap;

/// Probe points per axis.
const GRID: usize = 5;
/// Smallest probed span per axis (normalized units): a still session
/// still gets a usable slope.
const MIN_SPAN: f64 = 0.08;

/// The probe grid over the 5th-95th percentiles of `targets`, and its centre.
pub fn probe_grid(targets: &[NormPos]) -> (Vec<NormPos>, NormPos) {
    let pct = |mut v: Vec<f64>, q: f64| -> f64 {
        v.sort_by(f64::total_cmp);
        if v.is_empty() {
            return 0.5;
        }
        v[((v.len() - 1) as f64 * q).round() as usize]
    };
    let range = |v: Vec<f64>| -> (f64, f64) {
        let (lo, hi) = (pct(v.clone(), 0.05), pct(v, 0.95));
        let mid = 0.5 * (lo + hi);
        let half = (0.5 * (hi - lo)).max(MIN_SPAN / 2.0);
        (mid - half, mid + half)
    };
    let (x0, x1) = range(targets.iter().map(|t| t.nx).collect());
    let (y0, y1) = range(targets.iter().map(|t| t.ny).collect());
    let mut grid = vec![];
    for j in 0..GRID {
        for i in 0..GRID {
            let f = |k: usize| k as f64 / (GRID - 1) as f64;
            grid.push(NormPos {
                nx: x0 + (x1 - x0) * f(i),
                ny: y0 + (y1 - y0) * f(j),
            });
        }
    }
    let centre = NormPos {
        nx: 0.5 * (x0 + x1),
        ny: 0.5 * (y0 + y1),
    };
    (grid, centre)
}

/// Measures the response map of `scene` with `look` over the session's
/// `targets` (uncorrected); `Ok(None)` when the probe frames could not be
/// read well enough to fit one (the session is then drawn geometrically).
pub fn measure_response(
    scene: &FaceScene,
    look: &WebcamLook,
    fitter: &mut PhotoFitter,
    targets: &[NormPos],
) -> Result<Option<ResponseMap>> {
    let (grid, centre) = probe_grid(targets);
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
        if let Some(face) = fitter.landmarks(&frame)? {
            let m: Vec<(f64, f64)> = face
                .eyes
                .iter()
                .map(|e| {
                    let r = e.measure_against(e.corner_left, e.corner_right);
                    (r.nx, r.ny)
                })
                .collect();
            let (nx, ny) = (0.5 * (m[0].0 + m[1].0), 0.5 * (m[0].1 + m[1].1));
            if nx.is_finite() && ny.is_finite() {
                pairs.push((drawn, NormPos { nx, ny }));
            }
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
