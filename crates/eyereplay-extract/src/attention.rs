//! The attention face mesh's three custom operators, between its two ONNX
//! halves (`scripts/tflite_to_onnx.py --split-eyes`): where each eye's crop
//! of the face model's feature map lies (`Landmarks2TransformMatrix`), the
//! crop itself (`TransformTensorBilinear`), and the eye model's points back
//! in the face crop (`TransformLandmarks`), after MediaPipe's reference
//! kernels (`mediapipe/util/tflite/operations`, version 2 of each).
//!
//! Why here and not in the graph: written with standard ONNX operators
//! (the converter's default, which the split is checked against to 1e-5
//! px) they were about a hundred tiny operators that cost ONNX Runtime a
//! sixth of the network's time; here they take some tens of microseconds.

use crate::error::{ExtractError, Result};
use crate::shapes::FACE_MESH_LANDMARKS;

/// Where one eye's crop lies and how its points return, as the eye
/// model's metadata states them (`<eye>.crop`, `<eye>.points`).
#[derive(Clone, Debug, PartialEq)]
pub struct EyeCropSpec {
    /// The mesh points whose line sets the crop's rotation.
    pub rotation_idx: [usize; 2],
    /// The mesh points whose bounding box (along that line) the crop
    /// covers.
    pub subset: Vec<usize>,
    /// The crop's size in feature-map cells (width, height).
    pub output: [usize; 2],
    /// The crop's side over the box's, per axis.
    pub scale: [f32; 2],
    /// Face-crop pixels to feature-map cells.
    pub landmark_scale: f32,
    /// Elementwise factors of the 4 x 4 matrix before the points go back
    /// (row-major).
    pub matrix_scale: [f32; 16],
}

impl EyeCropSpec {
    /// Parses the metadata values `crop` (`key=value` words) and `points`
    /// (`matrix_scale=` 16 numbers); `what` names the model in errors.
    pub fn parse(crop: &str, points: &str, what: &str) -> Result<EyeCropSpec> {
        let bad = |why: String| ExtractError::Runtime(format!("{what}: eye crop metadata: {why}"));
        let field = |text: &str, key: &str| -> Result<String> {
            text.split_whitespace()
                .find_map(|w| w.strip_prefix(key).and_then(|r| r.strip_prefix('=')))
                .map(str::to_string)
                .ok_or_else(|| bad(format!("no {key}")))
        };
        let num = |key: &str| -> Result<f32> {
            field(crop, key)?
                .parse::<f32>()
                .map_err(|e| bad(format!("{key}: {e}")))
        };
        let index = |key: &str| -> Result<usize> {
            field(crop, key)?
                .parse::<usize>()
                .map_err(|e| bad(format!("{key}: {e}")))
        };
        if num("target_rotation_radians")? != 0.0 {
            return Err(bad("a target rotation is not handled".into()));
        }
        let subset = field(crop, "subset_idxs")?
            .split(',')
            .map(|v| {
                v.parse::<usize>()
                    .map_err(|e| bad(format!("subset_idxs: {e}")))
            })
            .collect::<Result<Vec<_>>>()?;
        let factors = field(points, "matrix_scale")?
            .split(',')
            .map(|v| {
                v.parse::<f32>()
                    .map_err(|e| bad(format!("matrix_scale: {e}")))
            })
            .collect::<Result<Vec<_>>>()?;
        let matrix_scale: [f32; 16] = factors
            .try_into()
            .map_err(|v: Vec<f32>| bad(format!("matrix_scale has {} values, not 16", v.len())))?;
        let spec = EyeCropSpec {
            rotation_idx: [index("left_rotation_idx")?, index("right_rotation_idx")?],
            subset,
            output: [index("output_width")?, index("output_height")?],
            scale: [num("scale_x")?, num("scale_y")?],
            landmark_scale: num("landmark_scale")?,
            matrix_scale,
        };
        let top = spec.subset.iter().chain(&spec.rotation_idx).max();
        if spec.subset.is_empty() || top.is_some_and(|&i| i >= FACE_MESH_LANDMARKS) {
            return Err(bad(format!(
                "mesh indices outside 0..{FACE_MESH_LANDMARKS}"
            )));
        }
        Ok(spec)
    }

    /// `Landmarks2TransformMatrix`: the first two rows of the 4 x 4 matrix
    /// that maps the crop's cell coordinates into the feature map, from
    /// the mesh (`mesh`: 468 x (x, y, z) in face-crop pixels). The crop is
    /// turned to the line from the first rotation point to the second,
    /// centred on the subset's bounding box measured along that line, and
    /// `scale` times the box.
    pub fn matrix(&self, mesh: &[f32]) -> [[f32; 4]; 2] {
        let at = |i: usize| {
            (
                mesh[3 * i] * self.landmark_scale,
                mesh[3 * i + 1] * self.landmark_scale,
            )
        };
        let (l, r) = (at(self.rotation_idx[0]), at(self.rotation_idx[1]));
        // MediaPipe turns the points by r = -atan2(dy, dx) and back; cos and
        // sin of the line's angle are all it needs.
        let angle = (r.1 - l.1).atan2(r.0 - l.0);
        let (sa, ca) = angle.sin_cos();
        let (mut lo, mut hi) = ([f32::MAX; 2], [f32::MIN; 2]);
        for &i in &self.subset {
            let (x, y) = at(i);
            let along = [ca * x + sa * y, -sa * x + ca * y];
            for k in 0..2 {
                lo[k] = lo[k].min(along[k]);
                hi[k] = hi[k].max(along[k]);
            }
        }
        let mid = [(lo[0] + hi[0]) / 2.0, (lo[1] + hi[1]) / 2.0];
        let centre = [ca * mid[0] - sa * mid[1], sa * mid[0] + ca * mid[1]];
        let (ow, oh) = (self.output[0] as f32, self.output[1] as f32);
        let sx = self.scale[0] * (hi[0] - lo[0]) / ow;
        let sy = self.scale[1] * (hi[1] - lo[1]) / oh;
        let (a00, a01, a10, a11) = (ca * sx, -sa * sy, sa * sx, ca * sy);
        [
            [a00, a01, 0.0, centre[0] - (a00 * ow / 2.0 + a01 * oh / 2.0)],
            [a10, a11, 0.0, centre[1] - (a10 * ow / 2.0 + a11 * oh / 2.0)],
        ]
    }

    /// `TransformTensorBilinear`: the crop of the `channels` x `h` x `w`
    /// feature map (NCHW, one image) that `m` places, `output` cells
    /// (NCHW) into `out`. Cell (i, j) reads the map bilinearly at
    /// m (j + 0.5, i + 0.5, 0, 1) - 0.5; a cell whose point lies outside
    /// the map is 0, and a neighbour past the last row or column reads 0
    /// (the reference kernel's rules).
    pub fn crop(
        &self,
        map: &[f32],
        channels: usize,
        h: usize,
        w: usize,
        m: &[[f32; 4]; 2],
        out: &mut [f32],
    ) {
        let [ow, oh] = self.output;
        let cells = ow * oh;
        assert_eq!(map.len(), channels * h * w);
        assert_eq!(out.len(), channels * cells);
        // Where each cell reads, worked out once for all channels; then one
        // channel at a time, so that the reads stay in one plane and the
        // writes run in order (channel-inner loops strode across the whole
        // map for every cell). The same arithmetic per value as the
        // reference kernel.
        struct Tap {
            /// Index of (x0, y0) in a plane; `None`: the cell is outside.
            at: Option<usize>,
            fx: f32,
            fy: f32,
            /// Whether the column x0 + 1 and the row y0 + 1 exist.
            right: bool,
            below: bool,
        }
        let taps: Vec<Tap> = (0..oh)
            .flat_map(|i| (0..ow).map(move |j| (i, j)))
            .map(|(i, j)| {
                let (u, v) = (j as f32 + 0.5, i as f32 + 0.5);
                let x = m[0][0] * u + m[0][1] * v + m[0][3] - 0.5;
                let y = m[1][0] * u + m[1][1] * v + m[1][3] - 0.5;
                if !(x >= 0.0 && y >= 0.0 && x <= (w - 1) as f32 && y <= (h - 1) as f32) {
                    return Tap {
                        at: None,
                        fx: 0.0,
                        fy: 0.0,
                        right: false,
                        below: false,
                    };
                }
                let (x0, y0) = (x.floor() as usize, y.floor() as usize);
                Tap {
                    at: Some(y0 * w + x0),
                    fx: x - x0 as f32,
                    fy: y - y0 as f32,
                    right: x0 + 1 < w,
                    below: y0 + 1 < h,
                }
            })
            .collect();
        for (plane, dst) in map.chunks_exact(h * w).zip(out.chunks_exact_mut(cells)) {
            for (tap, o) in taps.iter().zip(dst.iter_mut()) {
                let Some(a) = tap.at else {
                    *o = 0.0;
                    continue;
                };
                let (fx, fy) = (tap.fx, tap.fy);
                let p00 = plane[a];
                let p01 = if tap.right { plane[a + 1] } else { 0.0 };
                let (p10, p11) = if tap.below {
                    (plane[a + w], if tap.right { plane[a + w + 1] } else { 0.0 })
                } else {
                    (0.0, 0.0)
                };
                let upper = (1.0 - fx) * p00 + fx * p01;
                let lower = (1.0 - fx) * p10 + fx * p11;
                *o = fy * lower + (1.0 - fy) * upper;
            }
        }
    }

    /// `TransformLandmarks` through the matrix times `matrix_scale`: the
    /// eye model's points (x, y pairs) in face-crop pixels.
    pub fn points_back(&self, local: &[f32], m: &[[f32; 4]; 2]) -> Vec<f32> {
        let k = &self.matrix_scale;
        let row = |r: usize| {
            [
                m[r][0] * k[4 * r],
                m[r][1] * k[4 * r + 1],
                m[r][3] * k[4 * r + 3],
            ]
        };
        let (a, b) = (row(0), row(1));
        local
            .chunks_exact(2)
            .flat_map(|p| {
                [
                    a[0] * p[0] + a[1] * p[1] + a[2],
                    b[0] * p[0] + b[1] * p[1] + b[2],
                ]
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec() -> EyeCropSpec {
        EyeCropSpec::parse(
            "left_rotation_idx=0 right_rotation_idx=1 output_width=4 output_height=2 scale_x=1.5 \
             scale_y=2.0 target_rotation_radians=0.0 landmark_scale=0.25 subset_idxs=0,1,2,3",
            "matrix_scale=1,1,4,4,1,1,4,4,0.25,0.25,1,1,0.25,0.25,1,1",
            "test",
        )
        .unwrap()
    }

    /// 468 points, all at the origin except the first four.
    fn mesh(points: &[(f32, f32)]) -> Vec<f32> {
        let mut m = vec![0.0; 468 * 3];
        for (i, &(x, y)) in points.iter().enumerate() {
            m[3 * i] = x;
            m[3 * i + 1] = y;
        }
        m
    }

    /// A level rectangle 40 x 8 face-crop px (10 x 2 cells) centred at
    /// (100, 60) px = (25, 15) cells: no rotation, the crop 1.5 x 10 cells
    /// wide over 4 cells and 2 x 2 high over 2, so a cell is 3.75 x 2 map
    /// cells and the crop's centre (cell coordinates (2, 1)) lands on the
    /// box's centre. Worked by hand.
    #[test]
    fn matrix_centres_and_scales_the_crop_on_the_box() {
        let s = spec();
        let m = s.matrix(&mesh(&[
            (80.0, 60.0),
            (120.0, 60.0),
            (100.0, 56.0),
            (100.0, 64.0),
        ]));
        let close = |a: f32, b: f32| (a - b).abs() < 1e-5;
        assert!(close(m[0][0], 3.75) && close(m[1][1], 2.0), "{m:?}");
        assert!(close(m[0][1], 0.0) && close(m[1][0], 0.0), "{m:?}");
        assert!(close(m[0][0] * 2.0 + m[0][3], 25.0), "{m:?}");
        assert!(close(m[1][1] * 1.0 + m[1][3], 15.0), "{m:?}");
    }

    /// The same box turned by 90 degrees (the line from point 0 to point 1
    /// runs down the image): the crop's x axis runs down too.
    #[test]
    fn matrix_turns_with_the_line_between_the_rotation_points() {
        let s = spec();
        let m = s.matrix(&mesh(&[
            (100.0, 40.0),
            (100.0, 80.0),
            (104.0, 60.0),
            (96.0, 60.0),
        ]));
        let close = |a: f32, b: f32| (a - b).abs() < 1e-5;
        // The crop's x axis (first column) points along +y of the map.
        assert!(close(m[0][0], 0.0) && close(m[1][0], 3.75), "{m:?}");
        assert!(close(m[0][1], -2.0) && close(m[1][1], 0.0), "{m:?}");
        assert!(close(m[0][0] * 2.0 + m[0][1] + m[0][3], 25.0), "{m:?}");
        assert!(close(m[1][0] * 2.0 + m[1][1] + m[1][3], 15.0), "{m:?}");
    }

    /// Bilinear reading of a map that is linear in x and y gives that
    /// linear function exactly; a cell placed outside the map is 0.
    #[test]
    fn crop_reads_bilinearly_and_zeroes_outside() {
        let s = spec();
        let (c, h, w) = (2, 6, 8);
        let map: Vec<f32> = (0..c * h * w)
            .map(|k| {
                let (ch, y, x) = (k / (h * w), (k / w) % h, k % w);
                (ch as f32 + 1.0) * (x as f32 + 10.0 * y as f32)
            })
            .collect();
        // Cell (i, j) at (0.5 j + 1.2, 0.5 i + 2.3) in the map.
        let m = [[0.5, 0.0, 0.0, 1.45], [0.0, 0.5, 0.0, 2.55]];
        let mut out = vec![0.0; c * 8];
        s.crop(&map, c, h, w, &m, &mut out);
        for ch in 0..c {
            for i in 0..2 {
                for j in 0..4 {
                    let (x, y) = (0.5 * j as f32 + 1.2, 0.5 * i as f32 + 2.3);
                    let want = (ch as f32 + 1.0) * (x + 10.0 * y);
                    let got = out[ch * 8 + i * 4 + j];
                    assert!(
                        (got - want).abs() < 1e-4,
                        "channel {ch} cell ({i}, {j}): {got} vs {want}"
                    );
                }
            }
        }
        let outside = [[1.0, 0.0, 0.0, -3.0], [0.0, 1.0, 0.0, 0.5]];
        s.crop(&map, c, h, w, &outside, &mut out);
        assert_eq!(out[0], 0.0, "x = -3: outside");
        assert!(out[3] > 0.0, "x = 0, y = 0.5: inside");
    }

    /// Points go back through the matrix with its translation scaled 4x
    /// (the model's factors): p' = A p + 4 t.
    #[test]
    fn points_back_apply_the_scaled_matrix() {
        let s = spec();
        let m = [[2.0, 0.5, 0.0, 1.0], [-0.5, 3.0, 0.0, 2.0]];
        let got = s.points_back(&[1.0, 2.0, -1.0, 0.0], &m);
        assert_eq!(
            got,
            vec![2.0 + 1.0 + 4.0, -0.5 + 6.0 + 8.0, -2.0 + 4.0, 0.5 + 8.0]
        );
    }

    #[test]
    fn bad_metadata_is_refused_with_the_reason() {
        let e =
            EyeCropSpec::parse("left_rotation_idx=0", "matrix_scale=1", "eyes.onnx").unwrap_err();
        assert!(e.to_string().contains("eyes.onnx"), "{e}");
        let e = EyeCropSpec::parse(
            "left_rotation_idx=0 right_rotation_idx=1 output_width=4 output_height=2 scale_x=1.5 \
             scale_y=2.0 target_rotation_radians=0.0 landmark_scale=0.25 subset_idxs=0,1,2,3",
            "matrix_scale=1,2,3",
            "eyes.onnx",
        )
        .unwrap_err();
        assert!(e.to_string().contains("3 values, not 16"), "{e}");
    }
}
