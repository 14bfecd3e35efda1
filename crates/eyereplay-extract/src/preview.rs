//! Annotated PNG frames, so a person can see what was tracked: mesh points
//! grey, eye contours green, corners blue, lids yellow, iris rim and centre
//! red, and the normalized (nx, ny) of each eye as a marker in a small box
//! under the eye.

use crate::error::{ExtractError, Result};
use crate::geom::Pt;
use crate::image::ImageView;
use crate::tracker::Face;
use std::path::Path;

struct Canvas {
    w: usize,
    h: usize,
    px: Vec<u8>,
    /// Image pixels -> canvas pixels.
    zoom: f32,
}

impl Canvas {
    /// A dot of radius `r` canvas pixels at image point `p`.
    fn dot(&mut self, p: Pt, r: i32, c: [u8; 3]) {
        let (cx, cy) = (
            (p.x * self.zoom).floor() as i32,
            (p.y * self.zoom).floor() as i32,
        );
        for dy in -r..=r {
            for dx in -r..=r {
                if dx * dx + dy * dy > r * r {
                    continue;
                }
                let (x, y) = (cx + dx, cy + dy);
                if x >= 0 && y >= 0 && (x as usize) < self.w && (y as usize) < self.h {
                    let i = (y as usize * self.w + x as usize) * 3;
                    self.px[i..i + 3].copy_from_slice(&c);
                }
            }
        }
    }
    fn line(&mut self, a: Pt, b: Pt, c: [u8; 3]) {
        let n = ((a.dist(b) * self.zoom).ceil() as usize).max(1);
        for k in 0..=n {
            let t = k as f32 / n as f32;
            self.dot(Pt::new(a.x + (b.x - a.x) * t, a.y + (b.y - a.y) * t), 0, c);
        }
    }
}

pub fn write_png(path: &Path, img: &ImageView, face: Option<&Face>) -> Result<()> {
    // Small videos are enlarged so the landmarks can be told apart.
    let (w0, h0) = img.size();
    let zoom = (960 / w0.max(h0).max(1)).clamp(1, 4);
    let (w, h, px) = img.to_rgb8(zoom);
    let mut cv = Canvas {
        w,
        h,
        px,
        zoom: zoom as f32,
    };
    let r = ((w.max(h) as f32 / 480.0).round() as i32).max(1);
    if let Some(f) = face {
        for p in &f.mesh {
            cv.dot(*p, (r - 1).max(0), [170, 170, 170]);
        }
        for e in &f.eyes {
            for p in e.contour.iter().take(16) {
                cv.dot(*p, r.max(1) - 1, [0, 220, 0]);
            }
            cv.dot(e.corner_left, r, [40, 90, 255]);
            cv.dot(e.corner_right, r, [40, 90, 255]);
            cv.dot(e.upper_lid, r, [255, 230, 0]);
            cv.dot(e.lower_lid, r, [255, 230, 0]);
            for p in &e.iris_rim[1..] {
                cv.dot(*p, 0, [255, 40, 40]);
            }
            cv.dot(e.iris, r, [255, 0, 0]);
            // A box under the eye with the normalized position as a dot.
            let m = e.measure();
            let bw = e.corner_left.dist(e.corner_right).max(8.0);
            let (x0, y0) = (
                e.corner_left.x,
                e.lower_lid.y.max(e.corner_left.y) + 2.0 * r as f32 / cv.zoom,
            );
            let (x1, y1) = (x0 + bw, y0 + bw * 0.5);
            cv.line(Pt::new(x0, y0), Pt::new(x1, y0), [255, 255, 255]);
            cv.line(Pt::new(x1, y0), Pt::new(x1, y1), [255, 255, 255]);
            cv.line(Pt::new(x1, y1), Pt::new(x0, y1), [255, 255, 255]);
            cv.line(Pt::new(x0, y1), Pt::new(x0, y0), [255, 255, 255]);
            if m.nx.is_finite() && m.ny.is_finite() {
                let p = Pt::new(
                    x0 + (m.nx.clamp(0.0, 1.0) as f32) * bw,
                    y0 + (m.ny.clamp(0.0, 1.0) as f32) * bw * 0.5,
                );
                cv.dot(p, r + 1, [255, 0, 255]);
            }
        }
    }
    let io = |e: std::io::Error| ExtractError::Io {
        path: path.to_path_buf(),
        source: e,
    };
    let mut bytes = vec![];
    {
        let mut enc = png::Encoder::new(&mut bytes, w as u32, h as u32);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        let mut wr = enc
            .write_header()
            .map_err(|e| io(std::io::Error::other(e)))?;
        wr.write_image_data(&cv.px)
            .map_err(|e| io(std::io::Error::other(e)))?;
    }
    eyereplay_core::atomic_write(path, &bytes)?;
    Ok(())
}
