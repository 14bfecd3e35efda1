//! A perspective-correct textured triangle rasterizer on the CPU.
//!
//! The frame is cut into bands of rows; each band is drawn by one rayon
//! task from the triangles whose screen bounding box meets it (binned once
//! per frame), with its own slice of the z-buffer, so no two tasks touch the
//! same pixel. Texture coordinates and depth are interpolated as
//! `u/z, v/z, 1/z` (linear in screen space) and divided per pixel, and the
//! texture is sampled bilinearly. The depth test keeps the nearest surface
//! (the nose in front of the far cheek in a turned head); triangles seen
//! from behind are culled.
//!
//! What is drawn over: whatever the frame holds. The face renderer fills it
//! with the background and the eyeballs first, then draws the face mesh
//! without its eye-opening triangles, so the eyeballs show through the lids.

use crate::error::{FaceError, Result};
use crate::pose::{Camera, HeadPose};
use rayon::prelude::*;
use std::path::Path;

pub use eyereplay_core::RgbImage;

/// Writing an [`RgbImage`] as an 8-bit RGB PNG (temp file, then rename):
/// the image type lives in eyereplay-core, which has no PNG encoder.
pub trait SavePng {
    /// Writes the image as an 8-bit RGB PNG (temp file, then rename).
    fn save_png(&self, path: &Path) -> Result<()>;
}

impl SavePng for RgbImage {
    fn save_png(&self, path: &Path) -> Result<()> {
        let mut bytes = vec![];
        {
            let mut enc = png::Encoder::new(&mut bytes, self.width as u32, self.height as u32);
            enc.set_color(png::ColorType::Rgb);
            enc.set_depth(png::BitDepth::Eight);
            let png_err = |e: png::EncodingError| FaceError::Png {
                path: path.to_path_buf(),
                message: e.to_string(),
            };
            let mut w = enc.write_header().map_err(png_err)?;
            w.write_image_data(&self.data).map_err(png_err)?;
        }
        eyereplay_core::atomic_write(path, &bytes)?;
        Ok(())
    }
}

/// A textured mesh in the head frame: positions in cm, texture coordinates
/// in the texture's pixels, and the triangles to draw.
#[derive(Clone, Debug)]
pub struct TexturedMesh {
    pub positions_cm: Vec<[f32; 3]>,
    pub uv_px: Vec<[f32; 2]>,
    pub triangles: Vec<[u32; 3]>,
    /// Sign of the screen-space area (x right, y down) of a triangle that
    /// faces the camera, found from the mesh's frontal view.
    front_sign: f32,
}

impl TexturedMesh {
    pub fn new(
        positions_cm: Vec<[f32; 3]>,
        uv_px: Vec<[f32; 2]>,
        triangles: Vec<[u32; 3]>,
    ) -> Self {
        // Frontal view: screen (x, -y). The sign most of the face's area has
        // there is the facing one (every triangle of a face mesh faces
        // forward except a few folded at the nose wings).
        let area: f32 = triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| positions_cm[i as usize]);
                edge([a[0], -a[1]], [b[0], -b[1]], [c[0], -c[1]])
            })
            .sum();
        TexturedMesh {
            positions_cm,
            uv_px,
            triangles,
            front_sign: area.signum(),
        }
    }
}

/// Twice the signed area of (a, b, c); > 0 when c lies to the right of a->b
/// with y down.
#[inline(always)]
fn edge(a: [f32; 2], b: [f32; 2], c: [f32; 2]) -> f32 {
    (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
}

/// One projected vertex: screen position, 1/depth, texture coordinates over depth.
#[derive(Clone, Copy, Debug, Default)]
struct ScreenVertex {
    x: f32,
    y: f32,
    inv_z: f32,
    u_z: f32,
    v_z: f32,
}

/// A triangle ready to fill: vertices in positive-area order, bounding box.
#[derive(Clone, Copy, Debug)]
struct Setup {
    v: [ScreenVertex; 3],
    inv_area: f32,
    x0: usize,
    x1: usize,
    y0: usize,
    y1: usize,
}

/// Per-frame statistics.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DrawStats {
    pub triangles_drawn: usize,
    pub triangles_culled: usize,
    pub pixels_written: usize,
}

/// Reusable buffers for drawing meshes into frames of one size.
pub struct Rasterizer {
    width: usize,
    height: usize,
    band_rows: usize,
    /// 1/depth of the nearest surface drawn per pixel; 0 = nothing drawn.
    inv_depth: Vec<f32>,
    verts: Vec<ScreenVertex>,
    setups: Vec<Setup>,
    bins: Vec<Vec<u32>>,
}

/// Nearer than this (cm) a vertex is behind or too close to the camera; its
/// triangles are skipped (a head never gets there in a webcam framing).
const NEAR_CM: f32 = 1.0;

impl Rasterizer {
    pub fn new(width: usize, height: usize) -> Rasterizer {
        // Bands of 16 rows: a 480-row frame gives 30 tasks, enough to
        // balance two to sixteen cores while keeping per-band binning cheap.
        let band_rows = 16;
        let bands = height.div_ceil(band_rows);
        Rasterizer {
            width,
            height,
            band_rows,
            inv_depth: vec![0.0; width * height],
            verts: vec![],
            setups: vec![],
            bins: vec![vec![]; bands],
        }
    }

    /// 1/depth (1/cm) of what the last [`Rasterizer::draw`] drew at each
    /// pixel, 0 where it drew nothing: the face's coverage mask.
    pub fn inv_depth(&self) -> &[f32] {
        &self.inv_depth
    }

    /// Draws `mesh` under `pose` seen by `camera` over what `frame` holds.
    pub fn draw(
        &mut self,
        frame: &mut RgbImage,
        camera: &Camera,
        pose: &HeadPose,
        mesh: &TexturedMesh,
        texture: &RgbImage,
    ) -> DrawStats {
        let rows = 0..self.height;
        self.draw_rows(frame, camera, pose, mesh, texture, rows)
    }

    /// [`Rasterizer::draw`] inside image rows `rows` only: there, the same
    /// pixels and [`Rasterizer::inv_depth`] to the bit (each pixel's
    /// arithmetic does not depend on which rows are drawn); elsewhere the
    /// frame is left as it was and the depth is stale.
    pub fn draw_rows(
        &mut self,
        frame: &mut RgbImage,
        camera: &Camera,
        pose: &HeadPose,
        mesh: &TexturedMesh,
        texture: &RgbImage,
        rows: std::ops::Range<usize>,
    ) -> DrawStats {
        assert_eq!((frame.width, frame.height), (self.width, self.height));
        assert_eq!(
            (camera.width_px, camera.height_px),
            (self.width, self.height)
        );
        let (m, t) = pose.to_camera();
        let m = m.cast::<f32>();
        let t = t.cast::<f32>();
        let (f, cx, cy) = (
            camera.focal_px as f32,
            camera.cx_px as f32,
            camera.cy_px as f32,
        );
        self.verts.clear();
        self.verts
            .extend(mesh.positions_cm.iter().zip(&mesh.uv_px).map(|(p, uv)| {
                let q = m * nalgebra::Vector3::new(p[0], p[1], p[2]) + t;
                let inv_z = if q.z > NEAR_CM { 1.0 / q.z } else { 0.0 };
                ScreenVertex {
                    x: cx + f * q.x * inv_z,
                    y: cy + f * q.y * inv_z,
                    inv_z,
                    u_z: uv[0] * inv_z,
                    v_z: uv[1] * inv_z,
                }
            }));
        let mut stats = DrawStats::default();
        self.setups.clear();
        for b in &mut self.bins {
            b.clear();
        }
        let (w, h) = (self.width as f32, self.height as f32);
        for tri in &mesh.triangles {
            let mut v = tri.map(|i| self.verts[i as usize]);
            if v.iter().any(|s| s.inv_z == 0.0) {
                stats.triangles_culled += 1;
                continue;
            }
            let area = edge([v[0].x, v[0].y], [v[1].x, v[1].y], [v[2].x, v[2].y]);
            if area * mesh.front_sign <= 0.0 {
                stats.triangles_culled += 1;
                continue;
            }
            if area < 0.0 {
                v.swap(1, 2);
            }
            let minx = v.iter().map(|s| s.x).fold(f32::MAX, f32::min);
            let maxx = v.iter().map(|s| s.x).fold(f32::MIN, f32::max);
            let miny = v.iter().map(|s| s.y).fold(f32::MAX, f32::min);
            let maxy = v.iter().map(|s| s.y).fold(f32::MIN, f32::max);
            // Pixel centres inside [min, max]: i + 0.5 >= min.
            if maxx < 0.5 || maxy < 0.5 || minx > w - 0.5 || miny > h - 0.5 {
                stats.triangles_culled += 1;
                continue;
            }
            let x0 = (minx - 0.5).ceil().max(0.0) as usize;
            let y0 = (miny - 0.5).ceil().max(0.0) as usize;
            let x1 = ((maxx - 0.5).floor() as usize).min(self.width - 1);
            let y1 = ((maxy - 0.5).floor() as usize).min(self.height - 1);
            if x0 > x1 || y0 > y1 {
                stats.triangles_culled += 1;
                continue;
            }
            let id = self.setups.len() as u32;
            self.setups.push(Setup {
                v,
                inv_area: 1.0 / area.abs(),
                x0,
                x1,
                y0,
                y1,
            });
            for band in y0 / self.band_rows..=y1 / self.band_rows {
                self.bins[band].push(id);
            }
        }
        stats.triangles_drawn = self.setups.len();
        let (width, band_rows) = (self.width, self.band_rows);
        let setups = &self.setups;
        let bins = &self.bins;
        stats.pixels_written = frame
            .data
            .par_chunks_mut(band_rows * width * 3)
            .zip(self.inv_depth.par_chunks_mut(band_rows * width))
            .enumerate()
            .map(|(band, (rgb, depth))| {
                let row0 = band * band_rows;
                // The band's rows that are drawn.
                let (ra, rb) = (
                    row0.max(rows.start),
                    (row0 + depth.len() / width).min(rows.end),
                );
                if ra >= rb {
                    return 0;
                }
                depth[(ra - row0) * width..(rb - row0) * width].fill(0.0);
                let mut written = 0;
                for &id in &bins[band] {
                    let s = &setups[id as usize];
                    let ya = s.y0.max(ra);
                    let yb = s.y1.min(rb - 1);
                    if ya <= yb {
                        written += fill(s, ya, yb, row0, width, rgb, depth, texture);
                    }
                }
                written
            })
            .sum();
        stats
    }
}

/// Fills rows `ya..=yb` of one triangle into a band starting at `row0`;
/// returns the pixels written.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn fill(
    s: &Setup,
    ya: usize,
    yb: usize,
    row0: usize,
    width: usize,
    rgb: &mut [u8],
    depth: &mut [f32],
    texture: &RgbImage,
) -> usize {
    let [a, b, c] = s.v;
    let (pa, pb, pc) = ([a.x, a.y], [b.x, b.y], [c.x, c.y]);
    // Edge functions are affine in (x, y): w = e0 + ex * x + ey * y.
    let coeffs = |p: [f32; 2], q: [f32; 2]| {
        let ex = -(q[1] - p[1]);
        let ey = q[0] - p[0];
        (-(ex * p[0] + ey * p[1]), ex, ey)
    };
    let (e0a, e0x, e0y) = coeffs(pb, pc); // weight of a
    let (e1a, e1x, e1y) = coeffs(pc, pa); // weight of b
    let (e2a, e2x, e2y) = coeffs(pa, pb); // weight of c
    let mut written = 0;
    for y in ya..=yb {
        let py = y as f32 + 0.5;
        let row = (y - row0) * width;
        // The row's span inside all three edges, widened by a pixel each
        // way (the edge tests below decide exactly): thin triangles' boxes
        // are mostly outside them.
        let (mut xa, mut xb) = (s.x0 as f32, s.x1 as f32);
        for (e0, ex, ey) in [(e0a, e0x, e0y), (e1a, e1x, e1y), (e2a, e2x, e2y)] {
            if ex != 0.0 {
                // w(x) = e0 + ex (x + 0.5) + ey py is 0 at x = at.
                let at = -(e0 + ey * py) / ex - 0.5;
                if ex > 0.0 {
                    xa = xa.max(at.floor() - 1.0);
                } else {
                    xb = xb.min(at.ceil() + 1.0);
                }
            }
        }
        if xa > xb {
            continue;
        }
        let (x_start, x_end) = (xa as usize, xb as usize);
        let px0 = x_start as f32 + 0.5;
        let mut w0 = e0a + e0x * px0 + e0y * py;
        let mut w1 = e1a + e1x * px0 + e1y * py;
        let mut w2 = e2a + e2x * px0 + e2y * py;
        for x in x_start..=x_end {
            if w0 >= 0.0 && w1 >= 0.0 && w2 >= 0.0 {
                let (l0, l1, l2) = (w0 * s.inv_area, w1 * s.inv_area, w2 * s.inv_area);
                let inv_z = l0 * a.inv_z + l1 * b.inv_z + l2 * c.inv_z;
                let k = row + x;
                if inv_z > depth[k] {
                    depth[k] = inv_z;
                    let z = 1.0 / inv_z;
                    let u = (l0 * a.u_z + l1 * b.u_z + l2 * c.u_z) * z;
                    let v = (l0 * a.v_z + l1 * b.v_z + l2 * c.v_z) * z;
                    let o = k * 3;
                    rgb[o..o + 3].copy_from_slice(&texture.sample_rgb8(u, v));
                    written += 1;
                }
            }
            w0 += e0x;
            w1 += e1x;
            w2 += e2x;
        }
    }
    written
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A flat square (two triangles) at z = 0 in the head frame, textured
    /// with a gradient, seen frontally: the rendered pixels are the texture
    /// mapped by the affine (here: scaled) map that the corners fix, and
    /// pixels outside keep the background.
    #[test]
    fn flat_quad_maps_the_texture() {
        let mut tex = RgbImage::filled(64, 64, [0, 0, 0]);
        for y in 0..64 {
            for x in 0..64 {
                let i = (y * 64 + x) * 3;
                tex.data[i] = (x * 4) as u8;
                tex.data[i + 1] = (y * 4) as u8;
            }
        }
        // 10 cm square at 100 cm, focal 200 px: 20 px wide on screen.
        let pos = vec![
            [-5.0, 5.0, 0.0],
            [5.0, 5.0, 0.0],
            [5.0, -5.0, 0.0],
            [-5.0, -5.0, 0.0],
        ];
        let uv = vec![[0.0, 0.0], [64.0, 0.0], [64.0, 64.0], [0.0, 64.0]];
        let mesh = TexturedMesh::new(pos, uv, vec![[0, 1, 2], [0, 2, 3]]);
        let cam = Camera {
            width_px: 40,
            height_px: 40,
            focal_px: 200.0,
            cx_px: 20.0,
            cy_px: 20.0,
        };
        let pose = HeadPose {
            translation_cm: [0.0, 0.0, 100.0],
            ..Default::default()
        };
        let mut frame = RgbImage::filled(40, 40, [9, 9, 9]);
        let mut r = Rasterizer::new(40, 40);
        let st = r.draw(&mut frame, &cam, &pose, &mesh, &tex);
        assert_eq!(st.triangles_drawn, 2);
        // The square spans x, y in [10, 30): 400 pixels, each written once
        // except none double (shared diagonal pixels are drawn by both but
        // the second fails the equal-depth test).
        assert_eq!(st.pixels_written, 400);
        for y in 0..40 {
            for x in 0..40 {
                let p = frame.pixel(x, y);
                if (10..30).contains(&x) && (10..30).contains(&y) {
                    // Pixel centre (x+0.5) maps to texture u = (x+0.5-10)*3.2.
                    let want =
                        tex.sample((x as f32 + 0.5 - 10.0) * 3.2, (y as f32 + 0.5 - 10.0) * 3.2);
                    assert!(
                        (p[0] as f32 - want[0]).abs() <= 1.0,
                        "({x},{y}) {p:?} vs {want:?}"
                    );
                    assert!((p[1] as f32 - want[1]).abs() <= 1.0);
                } else {
                    assert_eq!(p, [9, 9, 9], "({x},{y}) outside the square");
                }
            }
        }
        // Seen from behind (yaw 180 deg) both triangles are culled.
        let back = HeadPose {
            yaw_deg: 180.0,
            ..pose
        };
        let st = r.draw(&mut frame, &cam, &back, &mesh, &tex);
        assert_eq!((st.triangles_drawn, st.triangles_culled), (0, 2));
    }

    /// Perspective correctness: a quad tilted in depth, textured with
    /// stripes. Its texture coordinate at a pixel must be that of the 3D
    /// point the pixel's ray hits, not the screen-linear interpolation.
    #[test]
    fn perspective_correct_on_a_tilted_quad() {
        // Texture: u encoded in red, 0..=255 over 256 px.
        let mut tex = RgbImage::filled(256, 4, [0, 0, 0]);
        for y in 0..4 {
            for x in 0..256 {
                tex.data[(y * 256 + x) * 3] = x as u8;
            }
        }
        // Quad x in [-10, 10] cm, with depth varying along x: yaw 60 deg.
        let pos = vec![
            [-10.0, 2.0, 0.0],
            [10.0, 2.0, 0.0],
            [10.0, -2.0, 0.0],
            [-10.0, -2.0, 0.0],
        ];
        let uv = vec![[0.0, 0.0], [256.0, 0.0], [256.0, 4.0], [0.0, 4.0]];
        let mesh = TexturedMesh::new(pos.clone(), uv, vec![[0, 1, 2], [0, 2, 3]]);
        let cam = Camera {
            width_px: 200,
            height_px: 40,
            focal_px: 400.0,
            cx_px: 100.0,
            cy_px: 20.0,
        };
        let pose = HeadPose {
            yaw_deg: 60.0,
            translation_cm: [0.0, 0.0, 40.0],
            ..Default::default()
        };
        let mut frame = RgbImage::filled(200, 40, [0, 0, 0]);
        Rasterizer::new(200, 40).draw(&mut frame, &cam, &pose, &mesh, &tex);
        let (m, t) = pose.to_camera();
        // Along the middle row, intersect each pixel's ray with the quad's
        // plane and compare u.
        let y = 20usize;
        let mut checked = 0;
        for x in 0..200usize {
            let ray = cam.ray([x as f64 + 0.5, y as f64 + 0.5]);
            // Plane: points m * (s, q, 0) + t; normal m * z.
            let n = m * nalgebra::Vector3::z();
            let d = n.dot(&t) / n.dot(&ray);
            let hit = m.transpose() * (ray * d - t);
            if hit.x.abs() >= 9.9 {
                continue;
            }
            let u_true = (hit.x + 10.0) / 20.0 * 256.0;
            let got = frame.pixel(x, y)[0] as f64;
            // Red = floor-ish of u - 0.5 (pixel centres at +0.5).
            assert!(
                (got - (u_true - 0.5)).abs() <= 1.5,
                "x {x}: {got} vs {u_true}"
            );
            checked += 1;
        }
        assert!(checked > 40, "{checked}");
    }
    /// Bands are disjoint, so the frame is byte-identical whatever the
    /// number of threads (a curved grid of 800 triangles, turned).
    #[test]
    fn same_bytes_on_one_and_many_threads() {
        let n = 20;
        let mut pos = vec![];
        let mut uv = vec![];
        for j in 0..=n {
            for i in 0..=n {
                let (x, y) = (i as f32 - 10.0, 10.0 - j as f32);
                pos.push([x, y, 5.0 - 0.04 * (x * x + y * y)]);
                uv.push([i as f32 * 3.0, j as f32 * 3.0]);
            }
        }
        let mut tris = vec![];
        for j in 0..n as u32 {
            for i in 0..n as u32 {
                let a = j * (n as u32 + 1) + i;
                let b = a + n as u32 + 1;
                tris.push([a, a + 1, b + 1]);
                tris.push([a, b + 1, b]);
            }
        }
        let mesh = TexturedMesh::new(pos, uv, tris);
        let mut tex = RgbImage::filled(64, 64, [0, 0, 0]);
        for (k, v) in tex.data.iter_mut().enumerate() {
            *v = (k * 37 % 251) as u8;
        }
        let cam = Camera {
            width_px: 160,
            height_px: 120,
            focal_px: 150.0,
            cx_px: 80.0,
            cy_px: 60.0,
        };
        let pose = HeadPose {
            yaw_deg: 25.0,
            pitch_deg: 10.0,
            roll_deg: 5.0,
            translation_cm: [1.0, 0.5, 40.0],
        };
        let draw = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            pool.install(|| {
                let mut f = RgbImage::filled(160, 120, [1, 2, 3]);
                let st = Rasterizer::new(160, 120).draw(&mut f, &cam, &pose, &mesh, &tex);
                (f, st)
            })
        };
        let (a, sa) = draw(1);
        let (b, sb) = draw(3);
        assert!(sa.pixels_written > 3000, "{sa:?}");
        assert_eq!(sa, sb);
        assert!(a == b);
    }
}
