//! Eye corners anchored to the head: `nx_head`.
//!
//! The iris model's eye contour follows the iris: on rendered faces whose
//! true corners are known, its corners move by 0.2-0.8 of the iris's own
//! move within the eye, so `nx` against them shows 40-70 % of the true
//! movement, and their frame-to-frame jitter adds to the iris's own (a
//! scratch comparison of `extract` rows with a render's `_truth.csv`; the
//! figures are in docs/EXTRACTION.md). The face mesh's points away from the
//! eyes (forehead, nose, cheekbones, temples) do not follow the gaze.
//!
//! So, for a recording: every frame that ran the face mesh gets an affine
//! map from those points in a template (the recording's first mesh frame)
//! to where they are now; each eye's corners, mapped back into the
//! template, have one median place per recording; mapped forward again
//! they are where that frame's corners are if they move with the head
//! alone. `nx_head` is the iris against them, as `nx` is against the
//! model's own corners. Frames between mesh frames (the cascade runs the
//! mesh on one frame in `--mesh-every`) take the affine map interpolated
//! between their neighbours in time.

use crate::geom::Pt;
use crate::output::Row;
use crate::shapes::HEAD_POINTS;

/// Frames further than this from a mesh frame get no `nx_head`.
pub const MAX_ANCHOR_GAP_S: f64 = 0.5;

/// An affine map of image points: `p' = [a b; c d] p + [e f]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Affine([f64; 6]);

impl Affine {
    /// The least-squares affine map taking `from[i]` to `to[i]`; `None`
    /// when the points are too few or on a line.
    pub fn fit(from: &[[f64; 2]], to: &[[f64; 2]]) -> Option<Affine> {
        if from.len() != to.len() || from.len() < 3 {
            return None;
        }
        // Centred, so the normal equations stay well conditioned.
        let n = from.len() as f64;
        let mean = |v: &[[f64; 2]]| {
            let s = v.iter().fold([0.0, 0.0], |a, p| [a[0] + p[0], a[1] + p[1]]);
            [s[0] / n, s[1] / n]
        };
        let (mf, mt) = (mean(from), mean(to));
        let (mut sxx, mut sxy, mut syy) = (0.0, 0.0, 0.0);
        let (mut ux, mut vx, mut uy, mut vy) = (0.0, 0.0, 0.0, 0.0);
        for (f, t) in from.iter().zip(to) {
            let (x, y) = (f[0] - mf[0], f[1] - mf[1]);
            let (u, v) = (t[0] - mt[0], t[1] - mt[1]);
            sxx += x * x;
            sxy += x * y;
            syy += y * y;
            ux += u * x;
            uy += u * y;
            vx += v * x;
            vy += v * y;
        }
        let det = sxx * syy - sxy * sxy;
        if det.abs() <= 1e-9 * (sxx * syy).max(1e-300) {
            return None;
        }
        let a = (ux * syy - uy * sxy) / det;
        let b = (uy * sxx - ux * sxy) / det;
        let c = (vx * syy - vy * sxy) / det;
        let d = (vy * sxx - vx * sxy) / det;
        let e = mt[0] - a * mf[0] - b * mf[1];
        let f = mt[1] - c * mf[0] - d * mf[1];
        Some(Affine([a, b, c, d, e, f]))
    }

    pub fn apply(&self, p: [f64; 2]) -> [f64; 2] {
        let [a, b, c, d, e, f] = self.0;
        [a * p[0] + b * p[1] + e, c * p[0] + d * p[1] + f]
    }

    /// The inverse map; `None` when this one is singular.
    pub fn inverse(&self) -> Option<Affine> {
        let [a, b, c, d, e, f] = self.0;
        let det = a * d - b * c;
        if det.abs() < 1e-12 {
            return None;
        }
        let (ia, ib, ic, id) = (d / det, -b / det, -c / det, a / det);
        Some(Affine([
            ia,
            ib,
            ic,
            id,
            -(ia * e + ib * f),
            -(ic * e + id * f),
        ]))
    }

    /// `(1 - w) self + w other`, element by element.
    pub fn lerp(&self, other: &Affine, w: f64) -> Affine {
        let mut out = [0.0; 6];
        for (k, o) in out.iter_mut().enumerate() {
            *o = (1.0 - w) * self.0[k] + w * other.0[k];
        }
        Affine(out)
    }
}

fn xy(p: Pt) -> [f64; 2] {
    [p.x as f64, p.y as f64]
}

fn median(mut v: Vec<f64>) -> Option<f64> {
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    Some(v[v.len() / 2])
}

/// A recording's head template and its eyes' corners in it.
#[derive(Clone, Debug, PartialEq)]
pub struct HeadAnchor {
    template: Vec<[f64; 2]>,
    /// Image-left eye first; each eye's image-left corner first.
    corners: [[[f64; 2]; 2]; 2],
}

impl HeadAnchor {
    /// The template (the first row with head points) and the median place
    /// of each corner in it over the open-eyed mesh frames of `rows`;
    /// `None` without any.
    pub fn fit(rows: &[Row]) -> Option<HeadAnchor> {
        Self::fit_with_maps(rows).map(|(anchor, _)| anchor)
    }

    /// [`HeadAnchor::fit`], with each row's map from the template (`None`
    /// where the row has no head points), for [`HeadAnchor::apply_maps`].
    fn fit_with_maps(rows: &[Row]) -> Option<(HeadAnchor, Vec<Option<Affine>>)> {
        let first = rows.iter().find(|r| r.head.len() == HEAD_POINTS.len())?;
        let template: Vec<[f64; 2]> = first.head.iter().map(|&p| xy(p)).collect();
        let maps = head_maps(&template, rows);
        let mut coords: Vec<Vec<f64>> = vec![Vec::new(); 8];
        for (r, map) in rows.iter().zip(&maps).filter(|(r, _)| !r.blink) {
            let (Some(eyes), Some(map)) = (r.eyes, map) else {
                continue;
            };
            let Some(back) = map.inverse() else {
                continue;
            };
            for (k, eye) in eyes.iter().enumerate() {
                for (j, c) in [eye.corner_left, eye.corner_right].into_iter().enumerate() {
                    let q = back.apply(xy(c));
                    if q[0].is_finite() && q[1].is_finite() {
                        coords[4 * k + 2 * j].push(q[0]);
                        coords[4 * k + 2 * j + 1].push(q[1]);
                    }
                }
            }
        }
        let mut med = coords.into_iter().map(median);
        let mut next = || med.next().flatten();
        let mut corner = || Some([next()?, next()?]);
        let corners = [[corner()?, corner()?], [corner()?, corner()?]];
        Some((HeadAnchor { template, corners }, maps))
    }

    /// Sets each eye's `nx_head` in `rows` (consecutive rows of the
    /// recording `self` was fitted on, in time order): NaN where no mesh
    /// frame lies within [`MAX_ANCHOR_GAP_S`].
    pub fn apply(&self, rows: &mut [Row]) {
        let maps = head_maps(&self.template, rows);
        self.apply_maps(rows, &maps);
    }

    /// [`HeadAnchor::apply`] with the rows' maps from the template.
    fn apply_maps(&self, rows: &mut [Row], maps: &[Option<Affine>]) {
        // The mesh frames before (at) and after each row, and the one
        // before that, for rows past the last mesh frame.
        let mut prev = vec![None; rows.len()];
        let mut before_prev = vec![None; rows.len()];
        let (mut p, mut pp) = (None, None);
        for i in 0..rows.len() {
            if maps[i].is_some() {
                (pp, p) = (p, Some(i));
            }
            (prev[i], before_prev[i]) = (p, pp);
        }
        let mut next_mesh = vec![None; rows.len()];
        let mut following = None;
        for i in (0..rows.len()).rev() {
            if maps[i].is_some() {
                following = Some(i);
            }
            next_mesh[i] = following;
        }
        let times: Vec<f64> = rows.iter().map(|r| r.time_s).collect();
        let between = |a: usize, b: usize, t: f64| {
            let (ta, tb) = (times[a], times[b]);
            let w = if tb != ta { (t - ta) / (tb - ta) } else { 0.0 };
            maps[a].zip(maps[b]).map(|(ma, mb)| ma.lerp(&mb, w))
        };
        for i in 0..rows.len() {
            let t = times[i];
            let near = |j: Option<usize>| j.filter(|&j| (times[j] - t).abs() <= MAX_ANCHOR_GAP_S);
            let map = match (near(prev[i]), near(next_mesh[i])) {
                (Some(a), Some(b)) if a == b => maps[a],
                (Some(a), Some(b)) => between(a, b, t),
                // Past the last mesh frame (a stream's newest rows, a
                // video's last): the head's motion carried on from the two
                // mesh frames before, as the tracker carries the eye crops.
                (Some(a), None) => match near(before_prev[i]) {
                    Some(aa) => between(aa, a, t),
                    None => maps[a],
                },
                (None, Some(b)) => maps[b],
                (None, None) => None,
            };
            let Some(eyes) = rows[i].eyes.as_mut() else {
                continue;
            };
            for (k, eye) in eyes.iter_mut().enumerate() {
                eye.nx_head = map.map_or(f64::NAN, |m| {
                    let cl = m.apply(self.corners[k][0]);
                    let cr = m.apply(self.corners[k][1]);
                    (eye.iris.x as f64 - cl[0]) / (cr[0] - cl[0])
                });
            }
        }
    }
}

/// The affine map from `template` to each row's head points, where it
/// has them.
fn head_maps(template: &[[f64; 2]], rows: &[Row]) -> Vec<Option<Affine>> {
    rows.iter()
        .map(|r| {
            if r.head.len() != template.len() {
                return None;
            }
            let to: Vec<[f64; 2]> = r.head.iter().map(|&p| xy(p)).collect();
            Affine::fit(template, &to)
        })
        .collect()
}

/// Sets `nx_head` on every row of one recording (see the module docs);
/// returns false, leaving them NaN, when no row has head points.
pub fn anchor_to_head(rows: &mut [Row]) -> bool {
    // Each row's map is fitted once, for the corners' places and for
    // the rows' values.
    match HeadAnchor::fit_with_maps(rows) {
        Some((a, maps)) => {
            a.apply_maps(rows, &maps);
            true
        }
        None => false,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::output::EyeRow;

    #[test]
    fn an_affine_fit_recovers_the_map_and_its_inverse_undoes_it() {
        // x' = 2x - y + 5, y' = 0.5x + 3y - 1, worked on three points and
        // a fourth: the map is exact, so the fit is too.
        let from = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [2.0, 3.0]];
        let to = [[5.0, -1.0], [7.0, -0.5], [4.0, 2.0], [6.0, 9.0]];
        let m = Affine::fit(&from, &to).unwrap();
        for (a, b) in m.0.iter().zip([2.0, -1.0, 0.5, 3.0, 5.0, -1.0]) {
            assert!((a - b).abs() < 1e-12, "{:?}", m.0);
        }
        let back = m.inverse().unwrap().apply(m.apply([-3.0, 7.5]));
        assert!((back[0] + 3.0).abs() < 1e-12 && (back[1] - 7.5).abs() < 1e-12);
        // Points on a line fix no affine map.
        assert!(Affine::fit(&[[0.0, 0.0], [1.0, 1.0], [2.0, 2.0]], &to[..3]).is_none());
    }

    /// A head (template points moved by `shift` and scaled by `scale`
    /// about the origin) whose eyes' true corners are fixed in it; the
    /// iris at true `nx`; the model's corners dragged by `drag` x the
    /// iris's move from the eye's middle, as the iris model's are.
    fn row(k: usize, nx: f64, shift: [f64; 2], scale: f64, mesh: bool, drag: f64) -> Row {
        let head = |p: [f64; 2]| {
            Pt::new(
                (scale * p[0] + shift[0]) as f32,
                (scale * p[1] + shift[1]) as f32,
            )
        };
        let template: Vec<[f64; 2]> = (0..HEAD_POINTS.len())
            .map(|i| {
                let a = i as f64 * 0.7;
                [300.0 + 80.0 * a.cos(), 240.0 + 100.0 * a.sin()]
            })
            .collect();
        let eye = |x0: f64| {
            let (cl, cr) = ([x0, 200.0], [x0 + 40.0, 200.0]);
            let iris = [x0 + 40.0 * nx, 200.0];
            let off = scale * 40.0 * (nx - 0.5) * drag;
            let (l, r) = (head(cl), head(cr));
            EyeRow {
                nx: f64::NAN,
                ny: 0.5,
                aperture: 0.3,
                iris: head(iris),
                corner_left: Pt::new(l.x + off as f32, l.y),
                corner_right: Pt::new(r.x + off as f32, r.y),
                nx_head: f64::NAN,
            }
        };
        Row {
            frame: k as u64,
            time_s: k as f64 / 25.0,
            face_score: 1.0,
            eyes: Some([eye(240.0), eye(320.0)]),
            blink: false,
            head: if mesh {
                template.iter().map(|&p| head(p)).collect()
            } else {
                Vec::new()
            },
        }
    }

    #[test]
    fn corners_anchored_to_a_moving_head_give_the_true_nx_where_dragged_ones_do_not() {
        // The head drifts right and grows linearly in time; the mesh runs
        // on even frames only (the cascade's --mesh-every 2), so odd frames
        // use the map interpolated between their neighbours, which for a
        // linear motion is exact. The iris sweeps symmetrically about the
        // eye's middle, so the dragged corners' median place is the true one.
        let nx_of = |k: usize| 0.5 + 0.3 * (k as f64 * 0.37).sin();
        let mut rows: Vec<Row> = (0..101)
            .map(|k| {
                let t = k as f64;
                row(
                    k,
                    nx_of(k),
                    [0.5 * t, -0.2 * t],
                    1.0 + 0.002 * t,
                    k % 2 == 0,
                    0.4,
                )
            })
            .collect();
        assert!(anchor_to_head(&mut rows));
        for (k, r) in rows.iter().enumerate() {
            for e in r.eyes.unwrap() {
                // The anchored value is the truth; against the dragged
                // corners the sweep shows 1 - 0.4 of its size.
                assert!(
                    (e.nx_head - nx_of(k)).abs() < 2e-3,
                    "frame {k}: {}",
                    e.nx_head
                );
                let dragged = (e.iris.x - e.corner_left.x) / (e.corner_right.x - e.corner_left.x);
                let want = 0.5 + 0.6 * (nx_of(k) - 0.5);
                assert!((dragged as f64 - want).abs() < 1e-3, "{dragged} vs {want}");
            }
        }
    }

    #[test]
    fn frames_far_from_a_mesh_frame_get_no_anchored_nx() {
        let mut rows: Vec<Row> = (0..40)
            .map(|k| row(k, 0.5, [0.0, 0.0], 1.0, k < 5, 0.0))
            .collect();
        assert!(anchor_to_head(&mut rows));
        // Mesh frames 0-4 end at 0.16 s; rows up to 0.66 s are within 0.5 s.
        let has = |k: usize| rows[k].eyes.unwrap()[0].nx_head.is_finite();
        assert!((0..=16).all(has) && !(17..40).any(has));
        let mut none: Vec<Row> = (0..5)
            .map(|k| row(k, 0.5, [0.0; 2], 1.0, false, 0.0))
            .collect();
        assert!(!anchor_to_head(&mut none));
    }
}
