//! `render.match_extractor`: how the extractor's iris model reads each
//! rendered identity, measured before its session is drawn, so the video
//! shows the trajectory as the extractor (the one that measured the source)
//! will read it back. See [`eyereplay_render::ResponseMap`].

use crate::{BackendError, Result};
use eyereplay_core::{CanvasPos, NormPos};
use eyereplay_extract::{
    order_eye_corners, EyeCropTracker, ImageView, Models, Planes, Pt, Rotation, YuvMatrix,
};
use eyereplay_render::{probe_grid, RenderParams, ResponseMap, Scene};
use std::path::Path;
use std::sync::Mutex;

/// Probe grid: 5 x 7 targets (nx, ny) per pass, two passes per identity.
/// The iris model's per-frame noise is about 0.005 in n; over 35 frames
/// and a span of 0.08 a pass's fitted gain is good to about 4 %.
const PROBE_NX: usize = 5;
const PROBE_NY: usize = 7;
/// Smallest probed span per axis, so a session that hardly moves still
/// gets a well-conditioned fit.
const MIN_SPAN: f64 = 0.08;

/// The probe targets over the range `traj` covers ([`probe_grid`]).
fn session_probe_grid(params: &RenderParams, traj: &[CanvasPos]) -> (Vec<NormPos>, NormPos) {
    let mut mapping = params.mapping;
    mapping.extractor_response = None;
    let targets: Vec<NormPos> = traj.iter().map(|&c| mapping.target_norm(c)).collect();
    probe_grid(&targets, PROBE_NX, PROBE_NY, MIN_SPAN)
}

/// Renders the probe frames of `params`' identity at its size over the
/// range `traj` covers (lids open, vergence as in the session), measures
/// each with the iris model on crops at the render's own eye corners as
/// `eyereplay evaluate` reads a close-up back (`nx` against those corners,
/// `ny` against the model's lids, both eyes' mean), and fits the affine
/// response to them.
pub fn measure_response(
    params: &RenderParams,
    traj: &[CanvasPos],
    tracker: &mut EyeCropTracker,
) -> Result<Option<ResponseMap>> {
    if traj.is_empty() {
        return Ok(None);
    }
    let scene = Scene::new(&params.identity, params.width, params.height);
    let (grid, centre) = session_probe_grid(params, traj);
    // Pass 1 probes where the geometric targets are; the response there is
    // not quite the response where the corrected eye is then drawn, so pass
    // 2 probes the corrected positions and refines the map.
    let Some(first) = probe_pass(&scene, params, &grid, None, tracker)? else {
        return Ok(None);
    };
    let first = first.about(centre);
    let second = probe_pass(&scene, params, &grid, Some(&first), tracker)?;
    Ok(second.map(|m| m.about(centre).after(&first).rounded()))
}

/// Draws each grid target (through `correction`'s inverse when given) and
/// fits what the iris model reads against the grid target.
fn probe_pass(
    scene: &Scene,
    params: &RenderParams,
    grid: &[NormPos],
    correction: Option<&ResponseMap>,
    tracker: &mut EyeCropTracker,
) -> Result<Option<ResponseMap>> {
    let (w, h) = (params.width, params.height);
    let geo = scene.geometry();
    let pt = |p: [f64; 2]| Pt::new(p[0] as f32, p[1] as f32);
    let corners = order_eye_corners([
        (pt(geo[0].inner_corner_px), pt(geo[0].outer_corner_px)),
        (pt(geo[1].inner_corner_px), pt(geo[1].outer_corner_px)),
    ]);
    let verg = params.mapping.vergence_rad(params.identity.eye.ipd_mm);
    let mut pairs = Vec::with_capacity(grid.len());
    let mut scratch = Vec::new();
    for &target in grid {
        let drawn = correction.map_or(target, |c| c.invert(target));
        let poses = scene.solve_gaze(drawn, verg);
        // yuv420p BT.709 limited range: the frame as the encoder is
        // fed it and the decoder hands it to the extractor (less x264).
        let mut yuv = scene.background_yuv().to_vec();
        scene.render_eyes(poses, 0.0, 1.0, None, Some(&mut yuv), &mut scratch);
        let (luma, chroma) = (w * h, (w / 2) * (h / 2));
        let img = ImageView {
            planes: Planes::Yuv420 {
                y: &yuv[..luma],
                u: &yuv[luma..luma + chroma],
                v: &yuv[luma + chroma..luma + 2 * chroma],
                y_stride: w,
                c_stride: w / 2,
                matrix: YuvMatrix::new(true, false),
            },
            raw_w: w,
            raw_h: h,
            rotation: Rotation::None,
        };
        let eyes = tracker.measure(&img, &corners)?;
        let m = [0, 1].map(|k| eyes[k].measure_against(corners[k].0, corners[k].1));
        let mean = NormPos {
            nx: 0.5 * (m[0].nx + m[1].nx),
            ny: 0.5 * (m[0].ny + m[1].ny),
        };
        if mean.nx.is_finite() && mean.ny.is_finite() {
            pairs.push((target, mean));
        }
    }
    Ok(ResponseMap::fit(&pairs))
}

/// `render.match_extractor`'s probe: one iris model shared by the render
/// workers (probing takes about 1 s per session at 1280x720), each eye
/// read from `iris_views` crops.
pub struct ResponseProbe {
    tracker: Mutex<EyeCropTracker>,
    /// Crops per eye (`render.extractor_iris_views`), recorded in each
    /// session's identity file so the read-back reads the same way.
    pub iris_views: usize,
}

impl ResponseProbe {
    /// The probe on the models in `models_dir`.
    pub fn load(models_dir: &Path, iris_views: usize) -> Result<ResponseProbe> {
        eyereplay_extract::init_runtime(models_dir)?;
        let models = Models::load(models_dir).map_err(|e| {
            BackendError::Setting(format!(
                "render.match_extractor needs the iris model: {e} (or set match_extractor = false in [render])"
            ))
        })?;
        let mut tracker = EyeCropTracker::new(models);
        tracker.iris_views = iris_views;
        Ok(ResponseProbe {
            tracker: Mutex::new(tracker),
            iris_views,
        })
    }

    /// The probe on the default models folder when `enabled`
    /// (`render.match_extractor`), else `None`.
    pub fn when(enabled: bool, iris_views: usize) -> Result<Option<ResponseProbe>> {
        enabled
            .then(|| Self::load(&eyereplay_extract::default_models_dir(), iris_views))
            .transpose()
    }

    /// The response map for one session's parameters and trajectory
    /// ([`measure_response`]).
    pub fn measure(
        &self,
        params: &RenderParams,
        traj: &[CanvasPos],
    ) -> Result<Option<ResponseMap>> {
        let mut t = self.tracker.lock().unwrap_or_else(|p| p.into_inner());
        measure_response(params, traj, &mut t)
    }
}
