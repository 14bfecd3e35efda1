//! The eye itself: a clean eye opening and an iris texture learned from the
//! carrier's own frames ([`EyeAppearance`]), and the per-frame redraw that
//! removes the carrier's iris and draws one at the trajectory's position
//! inside the carrier's lid contour ([`redraw_eye`]).
//!
//! Coordinates of an eye: `u` runs along the corner-to-corner axis (0 at
//! the image-left corner, 1 at the right one), `v` across it (down in the
//! image), both in eye widths, so a model learned in one frame applies to
//! any other whatever the head's distance and roll.

use crate::carrier::CarrierEye;
use crate::frame::RgbFrame;
use eyereplay_extract::ImageView;
use serde::Serialize;

const U_MIN: f32 = -0.1;
const U_SPAN: f32 = 1.2;
const U_BINS: usize = 48;
const V_MIN: f32 = -0.45;
const V_SPAN: f32 = 0.9;
const V_BINS: usize = 36;
/// Radius bins of the iris texture, over 0..1 of the iris radius.
const R_BINS: usize = 10;
/// Angle bins of the iris texture.
const A_BINS: usize = 32;
/// A frame's brightest iris pixel this much brighter (luma) than the
/// iris's mean is a corneal highlight; half the frames must show one.
const GLINT_CONTRAST: f32 = 40.0;
/// The drawn highlight's radius, in iris radii (at least 0.6 px).
const GLINT_RADIUS: f32 = 0.12;
/// Samples a bin needs before its median counts as seen.
const MIN_BIN_SAMPLES: usize = 3;
/// Samples kept per bin (the median of these is the bin's colour).
const MAX_SAMPLES: usize = 400;
/// Sclera samples are taken this far from the carrier's iris centre, in
/// iris radii: the limbus is soft and the radius estimate varies.
const SCLERA_CLEARANCE: f32 = 1.35;
/// Iris samples up to this fraction of the radius: the rim estimate is
/// noisy, and sclera must not leak into the texture.
const IRIS_SAMPLE_RADIUS: f32 = 0.95;
/// The redrawn region reaches this far outside the lid contour (px), fully
/// replaced, and fades out over [`FEATHER_PX`] beyond: the contour is
/// accurate to about a pixel, and the carrier's iris shows in the lid
/// margin it lies under (left there, it would keep the carrier's gaze in
/// the video). There the learned lid margin is drawn instead.
const BAND_PX: f32 = 1.0;
const FEATHER_PX: f32 = 1.0;

/// The frame of one eye: origin at the image-left corner, `ex` along the
/// corner axis, `ey` across it (down), `w` the corner-to-corner width.
#[derive(Clone, Copy, Debug)]
pub struct EyeAxes {
    o: [f32; 2],
    ex: [f32; 2],
    ey: [f32; 2],
    w: f32,
}

impl EyeAxes {
    /// The eye's head-fixed frame: from the face mesh's corners (see
    /// [`CarrierEye::mesh_corner_left`]).
    pub fn of(e: &CarrierEye) -> EyeAxes {
        let (a, b) = (e.mesh_corner_left, e.mesh_corner_right);
        let d = [b[0] - a[0], b[1] - a[1]];
        let w = d[0].hypot(d[1]).max(1e-3);
        let ex = [d[0] / w, d[1] / w];
        EyeAxes {
            o: a,
            ex,
            ey: [-ex[1], ex[0]],
            w,
        }
    }

    #[inline]
    pub fn uv(&self, p: [f32; 2]) -> [f32; 2] {
        let d = [p[0] - self.o[0], p[1] - self.o[1]];
        [
            (d[0] * self.ex[0] + d[1] * self.ex[1]) / self.w,
            (d[0] * self.ey[0] + d[1] * self.ey[1]) / self.w,
        ]
    }
}

/// Where `n = (nx, ny)` lies in this eye, in the extractor's
/// normalization: `nx` of the way from the image-left corner to the right
/// one along their axis (the mesh's corners, which do not follow the
/// carrier's own gaze), and on the image row `ny` of the way from the
/// upper lid midpoint to the lower one (the extractor's `ny` is measured
/// in image y).
pub fn place(e: &CarrierEye, n: [f64; 2]) -> [f32; 2] {
    let (a, b) = (e.mesh_corner_left, e.mesh_corner_right);
    let nx = n[0] as f32;
    let p = [a[0] + nx * (b[0] - a[0]), a[1] + nx * (b[1] - a[1])];
    let ty = e.upper_lid[1] + n[1] as f32 * (e.lower_lid[1] - e.upper_lid[1]);
    let ax = EyeAxes::of(e);
    // Along the across-axis direction to that row.
    let t = if ax.ey[1].abs() > 1e-3 {
        (ty - p[1]) / ax.ey[1]
    } else {
        0.0
    };
    [p[0] + t * ax.ey[0], p[1] + t * ax.ey[1]]
}

/// Signed distance from `p` to a closed polygon: positive inside.
pub fn signed_distance(poly: &[[f32; 2]], p: [f32; 2]) -> f32 {
    let mut best = f32::INFINITY;
    let mut inside = false;
    let n = poly.len();
    for i in 0..n {
        let a = poly[i];
        let b = poly[(i + 1) % n];
        // Crossing test for the inside flag.
        if (a[1] > p[1]) != (b[1] > p[1]) {
            let x = a[0] + (p[1] - a[1]) / (b[1] - a[1]) * (b[0] - a[0]);
            if p[0] < x {
                inside = !inside;
            }
        }
        let d = [b[0] - a[0], b[1] - a[1]];
        let len2 = d[0] * d[0] + d[1] * d[1];
        let t = if len2 > 0.0 {
            (((p[0] - a[0]) * d[0] + (p[1] - a[1]) * d[1]) / len2).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let q = [a[0] + t * d[0] - p[0], a[1] + t * d[1] - p[1]];
        best = best.min(q[0].hypot(q[1]));
    }
    if inside {
        best
    } else {
        -best
    }
}

/// Pixel bounds `[x0, y0, x1, y1)` around a polygon, grown by `pad`.
fn bounds(poly: &[[f32; 2]], pad: f32, w: usize, h: usize) -> [usize; 4] {
    let (mut x0, mut y0, mut x1, mut y1) = (f32::MAX, f32::MAX, f32::MIN, f32::MIN);
    for p in poly {
        x0 = x0.min(p[0]);
        y0 = y0.min(p[1]);
        x1 = x1.max(p[0]);
        y1 = y1.max(p[1]);
    }
    let c = |v: f32, hi: usize| (v.max(0.0) as usize).min(hi);
    [
        c((x0 - pad).floor(), w),
        c((y0 - pad).floor(), h),
        c((x1 + pad).ceil() + 1.0, w),
        c((y1 + pad).ceil() + 1.0, h),
    ]
}

fn luma(c: [f32; 3]) -> f32 {
    0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
}

fn median3(v: &mut [[u8; 3]]) -> [f32; 3] {
    let mut out = [0.0; 3];
    for (c, o) in out.iter_mut().enumerate() {
        let mid = v.len() / 2;
        v.select_nth_unstable_by_key(mid, |p| p[c]);
        *o = v[mid][c] as f32;
    }
    out
}

/// Collects an eye's samples over the carrier's frames.
#[derive(Clone, Debug)]
pub struct AppearanceBuilder {
    plate: Vec<Vec<[u8; 3]>>,
    iris: Vec<Vec<[u8; 3]>>,
    radius_ratios: Vec<f32>,
    /// Per frame: the brightest iris pixel's contrast over the iris mean,
    /// its offset from the iris centre in radii, and its colour.
    glints: Vec<(f32, [f32; 2], [u8; 3])>,
}

impl Default for AppearanceBuilder {
    fn default() -> Self {
        AppearanceBuilder {
            plate: vec![vec![]; U_BINS * V_BINS],
            iris: vec![vec![]; R_BINS * A_BINS],
            radius_ratios: vec![],
            glints: vec![],
        }
    }
}

fn plate_cell(uv: [f32; 2]) -> Option<usize> {
    let iu = ((uv[0] - U_MIN) / U_SPAN * U_BINS as f32).floor();
    let iv = ((uv[1] - V_MIN) / V_SPAN * V_BINS as f32).floor();
    (iu >= 0.0 && iv >= 0.0 && (iu as usize) < U_BINS && (iv as usize) < V_BINS)
        .then(|| iv as usize * U_BINS + iu as usize)
}

fn iris_cell(rho: f32, angle: f32) -> usize {
    let ir = ((rho * R_BINS as f32) as usize).min(R_BINS - 1);
    let a = (angle / std::f32::consts::TAU + 1.0).fract();
    let ia = ((a * A_BINS as f32) as usize).min(A_BINS - 1);
    ir * A_BINS + ia
}

impl AppearanceBuilder {
    /// Adds one frame's eye: pixels inside the lid contour become samples
    /// of the clean opening (away from the iris) or of the iris texture
    /// (inside it).
    pub fn add(&mut self, img: &ImageView, e: &CarrierEye) {
        let (w, h) = img.size();
        let ax = EyeAxes::of(e);
        let r = e.iris_radius_px.max(1.0);
        self.radius_ratios.push(r / ax.w);
        let [x0, y0, x1, y1] = bounds(&e.lid, BAND_PX + FEATHER_PX + 1.0, w, h);
        let (mut sum_luma, mut n_iris) = (0.0f32, 0usize);
        let mut brightest: Option<(f32, [f32; 2], [u8; 3])> = None;
        for y in y0..y1 {
            for x in x0..x1 {
                let p = [x as f32 + 0.5, y as f32 + 0.5];
                // The opening and the lid margin around it, as far as a
                // redraw reaches.
                let s = signed_distance(&e.lid, p);
                if s < -(BAND_PX + FEATHER_PX + 0.5) {
                    continue;
                }
                let c = img.sample(eyereplay_extract::Pt::new(p[0], p[1]));
                let c8 = [c[0] as u8, c[1] as u8, c[2] as u8];
                let d = [p[0] - e.iris[0], p[1] - e.iris[1]];
                let dist = d[0].hypot(d[1]);
                if dist > SCLERA_CLEARANCE * r {
                    if let Some(i) = plate_cell(ax.uv(p)) {
                        if self.plate[i].len() < MAX_SAMPLES {
                            self.plate[i].push(c8);
                        }
                    }
                } else if dist < IRIS_SAMPLE_RADIUS * r && s >= 0.5 {
                    let i = iris_cell(dist / r, d[1].atan2(d[0]));
                    if self.iris[i].len() < MAX_SAMPLES {
                        self.iris[i].push(c8);
                    }
                    let l = luma(c);
                    sum_luma += l;
                    n_iris += 1;
                    if brightest.is_none_or(|b| l > b.0) {
                        brightest = Some((l, [d[0] / r, d[1] / r], c8));
                    }
                }
            }
        }
        if let Some((l, off, c)) = brightest.filter(|_| n_iris >= 4) {
            self.glints.push((l - sum_luma / n_iris as f32, off, c));
        }
    }

    /// The medians, with bins never seen filled in: opening cells from
    /// the nearest seen cells of their row (the middle of the opening is
    /// often always under the iris of a person who looks at the camera),
    /// iris bins from their ring (the top is often under the lid).
    pub fn build(mut self) -> Option<EyeAppearance> {
        let seen_plate: Vec<Option<[f32; 3]>> = self
            .plate
            .iter_mut()
            .map(|s| (s.len() >= MIN_BIN_SAMPLES).then(|| median3(s)))
            .collect();
        if seen_plate.iter().filter(|c| c.is_some()).count() < 8 {
            return None;
        }
        let mut plate = vec![[0.0f32; 3]; U_BINS * V_BINS];
        let mut row_seen = [false; V_BINS];
        for iv in 0..V_BINS {
            let row = &seen_plate[iv * U_BINS..(iv + 1) * U_BINS];
            let seen: Vec<usize> = (0..U_BINS).filter(|&i| row[i].is_some()).collect();
            if seen.is_empty() {
                continue;
            }
            row_seen[iv] = true;
            for iu in 0..U_BINS {
                let left = seen.iter().rev().find(|&&i| i <= iu);
                let right = seen.iter().find(|&&i| i >= iu);
                plate[iv * U_BINS + iu] = match (left, right) {
                    (Some(&l), Some(&r)) if l != r => {
                        let t = (iu - l) as f32 / (r - l) as f32;
                        let (a, b) = (row[l].unwrap(), row[r].unwrap());
                        [0, 1, 2].map(|c| a[c] + t * (b[c] - a[c]))
                    }
                    (Some(&i), _) | (_, Some(&i)) => row[i].unwrap(),
                    (None, None) => unreachable!("seen is not empty"),
                };
            }
        }
        for iv in 0..V_BINS {
            if !row_seen[iv] {
                let from = (0..V_BINS)
                    .filter(|&j| row_seen[j])
                    .min_by_key(|&j| j.abs_diff(iv))
                    .expect("some row seen");
                for iu in 0..U_BINS {
                    plate[iv * U_BINS + iu] = plate[from * U_BINS + iu];
                }
            }
        }
        // A 3x3 mean over the cells: the medians of neighbouring cells come
        // from different frames, and their patchwork would show.
        let raw = plate.clone();
        for iv in 0..V_BINS {
            for iu in 0..U_BINS {
                let mut acc = [0.0f32; 3];
                let mut k = 0.0;
                for jv in iv.saturating_sub(1)..(iv + 2).min(V_BINS) {
                    for ju in iu.saturating_sub(1)..(iu + 2).min(U_BINS) {
                        let c = raw[jv * U_BINS + ju];
                        for (a, v) in acc.iter_mut().zip(c) {
                            *a += v;
                        }
                        k += 1.0;
                    }
                }
                plate[iv * U_BINS + iu] = acc.map(|a| a / k);
            }
        }
        // The sclera's own brightness: the brighter half of the seen cells.
        let mut lum: Vec<f32> = seen_plate.iter().flatten().map(|&c| luma(c)).collect();
        lum.sort_by(f32::total_cmp);
        let top = &lum[lum.len() / 2..];
        let sclera_luma = top.iter().sum::<f32>() / top.len() as f32;

        let seen_iris: Vec<Option<[f32; 3]>> = self
            .iris
            .iter_mut()
            .map(|s| (s.len() >= MIN_BIN_SAMPLES).then(|| median3(s)))
            .collect();
        let mut iris = vec![[0.0f32; 3]; R_BINS * A_BINS];
        let mut ring_mean: Vec<Option<[f32; 3]>> = vec![None; R_BINS];
        for (ir, m) in ring_mean.iter_mut().enumerate() {
            let seen: Vec<[f32; 3]> = seen_iris[ir * A_BINS..(ir + 1) * A_BINS]
                .iter()
                .flatten()
                .copied()
                .collect();
            if !seen.is_empty() {
                let k = seen.len() as f32;
                *m = Some([0, 1, 2].map(|c| seen.iter().map(|s| s[c]).sum::<f32>() / k));
            }
        }
        if ring_mean.iter().all(|m| m.is_none()) {
            return None;
        }
        for ir in 0..R_BINS {
            let ring = match ring_mean[ir] {
                Some(m) => m,
                None => {
                    (0..R_BINS)
                        .filter_map(|j| ring_mean[j].map(|m| (j.abs_diff(ir), m)))
                        .min_by_key(|(d, _)| *d)
                        .expect("some ring seen")
                        .1
                }
            };
            for ia in 0..A_BINS {
                iris[ir * A_BINS + ia] = seen_iris[ir * A_BINS + ia].unwrap_or(ring);
            }
        }
        self.radius_ratios.sort_by(f32::total_cmp);
        let radius_ratio = self.radius_ratios[self.radius_ratios.len() / 2];
        // The corneal highlight: where the frames' brightest iris pixel
        // stands out clearly, its median place and colour.
        let bright: Vec<&(f32, [f32; 2], [u8; 3])> = self
            .glints
            .iter()
            .filter(|g| g.0 >= GLINT_CONTRAST)
            .collect();
        let glint = (bright.len() * 2 >= self.glints.len() && !bright.is_empty()).then(|| {
            let med = |mut v: Vec<f32>| {
                v.sort_by(f32::total_cmp);
                v[v.len() / 2]
            };
            let off = [
                med(bright.iter().map(|g| g.1[0]).collect()),
                med(bright.iter().map(|g| g.1[1]).collect()),
            ];
            let colour = [0, 1, 2].map(|k| med(bright.iter().map(|g| g.2[k] as f32).collect()));
            Glint {
                offset: off,
                colour,
            }
        });
        Some(EyeAppearance {
            plate,
            iris,
            sclera_luma,
            radius_ratio,
            glint,
        })
    }
}

/// One eye of a carrier, learned from its frames.
#[derive(Clone, Debug, Serialize)]
pub struct EyeAppearance {
    /// The opening without the iris (sclera, lid shading, corners), RGB per
    /// `(u, v)` cell.
    #[serde(skip)]
    plate: Vec<[f32; 3]>,
    /// The iris (with pupil and limbus) by radius and angle.
    #[serde(skip)]
    iris: Vec<[f32; 3]>,
    /// Luma of the sclera proper (the brighter half of the opening).
    pub sclera_luma: f32,
    /// Iris radius over corner-to-corner width (median over the frames).
    pub radius_ratio: f32,
    /// The corneal highlight, when the carrier's eyes show one.
    pub glint: Option<Glint>,
}

/// A corneal highlight learned from the carrier's frames.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Glint {
    /// From the iris centre, in iris radii (image x right, y down).
    pub offset: [f32; 2],
    pub colour: [f32; 3],
}

impl EyeAppearance {
    /// The clean opening at `(u, v)`, bilinear between cells.
    fn plate_at(&self, uv: [f32; 2]) -> [f32; 3] {
        let fu = ((uv[0] - U_MIN) / U_SPAN * U_BINS as f32 - 0.5).clamp(0.0, (U_BINS - 1) as f32);
        let fv = ((uv[1] - V_MIN) / V_SPAN * V_BINS as f32 - 0.5).clamp(0.0, (V_BINS - 1) as f32);
        let (iu, iv) = (fu as usize, fv as usize);
        let (iu1, iv1) = ((iu + 1).min(U_BINS - 1), (iv + 1).min(V_BINS - 1));
        let (tu, tv) = (fu - iu as f32, fv - iv as f32);
        let at = |u: usize, v: usize| self.plate[v * U_BINS + u];
        let (a, b, c, d) = (at(iu, iv), at(iu1, iv), at(iu, iv1), at(iu1, iv1));
        [0, 1, 2].map(|k| {
            let top = a[k] + tu * (b[k] - a[k]);
            let bot = c[k] + tu * (d[k] - c[k]);
            top + tv * (bot - top)
        })
    }

    /// The iris texture at radius fraction `rho` (0..1) and `angle`,
    /// bilinear in radius.
    fn iris_at(&self, rho: f32, angle: f32) -> [f32; 3] {
        // Bilinear in radius and angle (wrapping): bins would show as
        // wedges and rings.
        let fa = (angle / std::f32::consts::TAU + 1.0).fract() * A_BINS as f32 - 0.5;
        let fa = fa.rem_euclid(A_BINS as f32);
        let ia = (fa as usize).min(A_BINS - 1);
        let ia1 = (ia + 1) % A_BINS;
        let ta = fa - ia as f32;
        let fr = (rho * R_BINS as f32 - 0.5).clamp(0.0, (R_BINS - 1) as f32);
        let ir = fr as usize;
        let ir1 = (ir + 1).min(R_BINS - 1);
        let tr = fr - ir as f32;
        let at = |r: usize, a: usize| self.iris[r * A_BINS + a];
        let (p, q, u, v) = (at(ir, ia), at(ir, ia1), at(ir1, ia), at(ir1, ia1));
        [0, 1, 2].map(|k| {
            let inner = p[k] + ta * (q[k] - p[k]);
            let outer = u[k] + ta * (v[k] - u[k]);
            inner + tr * (outer - inner)
        })
    }

    /// This frame's light on the opening relative to the model's, per
    /// channel: the frame's sclera (inside the contour, away from its own
    /// iris) over the model's at the same places. 1 when too little sclera
    /// shows (a squint).
    fn gain(&self, frame: &RgbFrame, e: &CarrierEye, ax: &EyeAxes) -> [f32; 3] {
        let r = e.iris_radius_px.max(1.0);
        let [x0, y0, x1, y1] = bounds(&e.lid, 0.0, frame.width, frame.height);
        let (mut sf, mut sp, mut n) = ([0.0f32; 3], [0.0f32; 3], 0);
        for y in y0..y1 {
            for x in x0..x1 {
                let p = [x as f32 + 0.5, y as f32 + 0.5];
                let d = (p[0] - e.iris[0]).hypot(p[1] - e.iris[1]);
                if d <= SCLERA_CLEARANCE * r || signed_distance(&e.lid, p) < 1.0 {
                    continue;
                }
                let c = frame.pixel(x, y);
                let m = self.plate_at(ax.uv(p));
                for k in 0..3 {
                    sf[k] += c[k] as f32;
                    sp[k] += m[k];
                }
                n += 1;
            }
        }
        if n < 6 {
            return [1.0; 3];
        }
        [0, 1, 2].map(|k| (sf[k] / sp[k].max(1.0)).clamp(0.5, 2.0))
    }
}

/// What one eye's redraw did in one frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Redrawn {
    /// Where the new iris centre is, and its radius (px).
    pub iris_px: [f32; 2],
    pub radius_px: f32,
}

/// Removes the carrier's iris from one eye of `frame` and draws the
/// learned one centred where `n` puts it. `e` is the frame's lid geometry:
/// everything inside its contour and `BAND_PX` beyond is replaced
/// (feathered over `FEATHER_PX` more); farther out, the frame is
/// untouched. The carrier's own iris centre
/// and radius in `e` place the frame's light measurement.
pub fn redraw_eye(
    frame: &mut RgbFrame,
    e: &CarrierEye,
    app: &EyeAppearance,
    n: [f64; 2],
) -> Redrawn {
    let ax = EyeAxes::of(e);
    let gain = app.gain(frame, e, &ax);
    let c = place(e, n);
    let r = app.radius_ratio * ax.w;
    let [x0, y0, x1, y1] = bounds(
        &e.lid,
        BAND_PX + FEATHER_PX + 1.0,
        frame.width,
        frame.height,
    );
    for y in y0..y1 {
        for x in x0..x1 {
            let p = [x as f32 + 0.5, y as f32 + 0.5];
            let s = signed_distance(&e.lid, p);
            let m = ((s + BAND_PX + FEATHER_PX) / FEATHER_PX).clamp(0.0, 1.0);
            if m <= 0.0 {
                continue;
            }
            let uv = ax.uv(p);
            let clean = app.plate_at(uv);
            let d = [p[0] - c[0], p[1] - c[1]];
            let dist = d[0].hypot(d[1]);
            // Anti-aliased iris edge over one pixel; the iris shows only
            // inside the lid contour.
            let a = (r + 0.5 - dist).clamp(0.0, 1.0) * (s + 0.5).clamp(0.0, 1.0);
            let content = if a > 0.0 {
                // The lids' shadow on the iris: the opening's darkening at
                // this place relative to bare sclera. (Without it, the
                // extractor reads the iris of a small, blurred eye worse:
                // r 0.80 instead of 0.95 on jwpIntro's conversation.)
                let shade = (luma(clean) / app.sclera_luma.max(1.0)).clamp(0.55, 1.0);
                let mut iris = app.iris_at((dist / r).min(0.999), d[1].atan2(d[0]));
                for v in &mut iris {
                    *v *= shade;
                }
                if let Some(g) = &app.glint {
                    let gc = [c[0] + g.offset[0] * r, c[1] + g.offset[1] * r];
                    let gr = (GLINT_RADIUS * r).max(0.6);
                    let gd2 = ((p[0] - gc[0]).powi(2) + (p[1] - gc[1]).powi(2)) / (gr * gr);
                    let w = 0.9 * (-gd2).exp();
                    for (v, gc) in iris.iter_mut().zip(g.colour) {
                        *v += w * (gc - *v);
                    }
                }
                [0, 1, 2].map(|k| clean[k] + a * (iris[k] - clean[k]))
            } else {
                clean
            };
            let old = frame.pixel(x, y);
            let px = [0, 1, 2].map(|k| {
                let v = content[k] * gain[k];
                (old[k] as f32 + m * (v - old[k] as f32))
                    .round()
                    .clamp(0.0, 255.0) as u8
            });
            frame.set(x, y, px);
        }
    }
    Redrawn {
        iris_px: c,
        radius_px: r,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::FrameView;

    fn eye() -> CarrierEye {
        // A 40 px eye on a level head: lower lid arc below, upper above.
        let mut lid = vec![];
        for i in 0..=8 {
            let t = i as f32 / 8.0;
            lid.push([
                100.0 + 40.0 * t,
                100.0 + 8.0 * (std::f32::consts::PI * t).sin(),
            ]);
        }
        for i in (1..=7).rev() {
            let t = i as f32 / 8.0;
            lid.push([
                100.0 + 40.0 * t,
                100.0 - 10.0 * (std::f32::consts::PI * t).sin(),
            ]);
        }
        CarrierEye {
            lid,
            iris: [120.0, 99.0],
            iris_radius_px: 8.0,
            corner_left: [100.0, 100.0],
            corner_right: [140.0, 100.0],
            upper_lid: [120.0, 90.0],
            lower_lid: [120.0, 108.0],
            mesh_corner_left: [100.0, 100.0],
            mesh_corner_right: [140.0, 100.0],
        }
    }

    #[test]
    fn place_inverts_the_extractors_normalization() {
        let e = eye();
        for n in [[0.5, 0.5], [0.3, 0.4], [0.7, 0.6]] {
            let p = place(&e, n);
            // nx = (x - left.x) / (right.x - left.x); ny = (y - top) / (bottom - top).
            let nx = (p[0] - 100.0) / 40.0;
            let ny = (p[1] - 90.0) / 18.0;
            assert!((nx as f64 - n[0]).abs() < 1e-6 && (ny as f64 - n[1]).abs() < 1e-6);
        }
        // A rolled eye: the point lies on the corner axis at nx when ny
        // puts it on the axis' own row.
        let mut r = e.clone();
        r.mesh_corner_right = [139.0, 110.0];
        let p = place(&r, [0.5, (105.0 - 90.0) / 18.0]);
        assert!(
            (p[0] - 119.5).abs() < 1e-3 && (p[1] - 105.0).abs() < 1e-3,
            "{p:?}"
        );
    }

    #[test]
    fn signed_distance_of_a_square() {
        let sq = [[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [0.0, 10.0]];
        assert_eq!(signed_distance(&sq, [5.0, 5.0]), 5.0);
        assert_eq!(signed_distance(&sq, [1.0, 5.0]), 1.0);
        assert_eq!(signed_distance(&sq, [-2.0, 5.0]), -2.0);
        assert_eq!(signed_distance(&sq, [13.0, 14.0]), -5.0);
    }

    /// A synthetic eye: white opening, a dark-blue iris disc with a black
    /// pupil. Learned from frames whose iris sits at the left and right,
    /// then redrawn at the centre: the centre shows the iris colour, the
    /// place the carrier's iris was shows sclera, and outside the contour
    /// nothing changes.
    #[test]
    fn removes_the_old_iris_and_draws_the_learned_one_at_n() {
        let e0 = eye();
        let (w, h) = (240usize, 200usize);
        let paint = |iris_x: f32| {
            let mut f = RgbFrame {
                width: w,
                height: h,
                data: vec![150; w * h * 3],
            };
            for y in 0..h {
                for x in 0..w {
                    let p = [x as f32 + 0.5, y as f32 + 0.5];
                    if signed_distance(&e0.lid, p) > 0.0 {
                        let d = (p[0] - iris_x).hypot(p[1] - 99.0);
                        let c = if d < 3.0 {
                            [10, 10, 10]
                        } else if d < 8.0 {
                            [40, 60, 140]
                        } else {
                            [235, 230, 225]
                        };
                        f.set(x, y, c);
                    }
                }
            }
            f
        };
        let mut b = AppearanceBuilder::default();
        for ix in [110.0, 112.0, 114.0, 116.0, 124.0, 126.0, 128.0, 130.0] {
            let f = paint(ix);
            let mut e = e0.clone();
            e.iris = [ix, 99.0];
            b.add(&f.view(), &e);
        }
        let app = b.build().expect("enough samples");
        assert!((app.radius_ratio - 0.2).abs() < 1e-6);

        let mut f = paint(112.0);
        let before = f.clone();
        let mut e = e0.clone();
        e.iris = [112.0, 99.0];
        let out = redraw_eye(&mut f, &e, &app, [0.75, 0.5]);
        assert_eq!(out.iris_px, [130.0, 99.0]);
        // The new pupil at (130, 99): dark.
        let c = f.pixel(130, 99);
        assert!(c.iter().all(|&v| v < 60), "pupil {c:?}");
        // The iris ring: blue over red.
        let c = f.pixel(135, 99);
        assert!(c[2] > c[0] + 50, "iris {c:?}");
        // The old iris place (112, 99): sclera now.
        let c = f.pixel(112, 99);
        assert!(c.iter().all(|&v| v > 180), "old iris place {c:?}");
        // Outside the contour: untouched.
        for (x, y) in [(90, 100), (120, 80), (150, 100), (10, 10)] {
            assert_eq!(f.pixel(x, y), before.pixel(x, y));
        }
    }
}
