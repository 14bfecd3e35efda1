//! Rotated rectangles (regions of interest) in image pixels and the mapping
//! between a model's square input and the image, as MediaPipe's
//! `ImageToTensor` and `LandmarkProjection` calculators define them.

/// A point in image pixels (continuous: pixel `i` covers `[i, i+1)`).
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Pt {
    pub x: f32,
    pub y: f32,
}

impl Pt {
    pub fn new(x: f32, y: f32) -> Self {
        Pt { x, y }
    }
    pub fn dist(self, o: Pt) -> f32 {
        ((self.x - o.x).powi(2) + (self.y - o.y).powi(2)).sqrt()
    }
}

/// A rotated rectangle in image pixels: centre, size and rotation.
///
/// `angle_rad` is the direction of the rectangle's x axis in the image (y
/// down), so a positive angle turns it clockwise on screen. A crop of the
/// rectangle shows its content upright.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Roi {
    pub cx: f32,
    pub cy: f32,
    pub w: f32,
    pub h: f32,
    pub angle_rad: f32,
}

impl Roi {
    /// Square ROI through two points: the axis runs from `a` to `b`, the side
    /// is `scale` times the larger extent of their bounding box (MediaPipe's
    /// detection-to-rect with `square_long`).
    pub fn from_two_points(a: Pt, b: Pt, scale: f32) -> Roi {
        let side = (b.x - a.x).abs().max((b.y - a.y).abs()) * scale;
        Roi {
            cx: (a.x + b.x) / 2.0,
            cy: (a.y + b.y) / 2.0,
            w: side,
            h: side,
            angle_rad: (b.y - a.y).atan2(b.x - a.x),
        }
    }

    /// Square ROI around a point set's axis-aligned bounding box, rotated by
    /// `angle_rad`, side `scale` times the box's longer side (MediaPipe's
    /// face-landmarks-to-ROI for tracking the next frame).
    pub fn around_points(pts: &[Pt], angle_rad: f32, scale: f32) -> Roi {
        let (mut x0, mut y0, mut x1, mut y1) = (f32::MAX, f32::MAX, f32::MIN, f32::MIN);
        for p in pts {
            x0 = x0.min(p.x);
            y0 = y0.min(p.y);
            x1 = x1.max(p.x);
            y1 = y1.max(p.y);
        }
        let side = (x1 - x0).max(y1 - y0) * scale;
        Roi {
            cx: (x0 + x1) / 2.0,
            cy: (y0 + y1) / 2.0,
            w: side,
            h: side,
            angle_rad,
        }
    }

    /// Maps a point given in the crop's normalized coordinates (0..1 across
    /// the rectangle, origin at its top-left) to image pixels.
    #[inline]
    pub fn to_image(&self, u: f32, v: f32) -> Pt {
        let (s, c) = self.angle_rad.sin_cos();
        let dx = (u - 0.5) * self.w;
        let dy = (v - 0.5) * self.h;
        Pt {
            x: self.cx + dx * c - dy * s,
            y: self.cy + dx * s + dy * c,
        }
    }

    /// Inverse of [`Roi::to_image`].
    pub fn to_crop(&self, p: Pt) -> (f32, f32) {
        let (s, c) = self.angle_rad.sin_cos();
        let dx = p.x - self.cx;
        let dy = p.y - self.cy;
        (
            (dx * c + dy * s) / self.w + 0.5,
            (-dx * s + dy * c) / self.h + 0.5,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn corners_of_a_rotated_square_land_where_hand_computed() {
        // 90 degrees clockwise: the crop's x axis points down the image.
        let r = Roi {
            cx: 100.0,
            cy: 50.0,
            w: 20.0,
            h: 20.0,
            angle_rad: std::f32::consts::FRAC_PI_2,
        };
        let tl = r.to_image(0.0, 0.0); // crop top-left = (-10,-10) rotated
        assert!(
            (tl.x - 110.0).abs() < 1e-4 && (tl.y - 40.0).abs() < 1e-4,
            "{tl:?}"
        );
        let tr = r.to_image(1.0, 0.0); // (+10,-10) -> (x=100+10, y=50+10)
        assert!(
            (tr.x - 110.0).abs() < 1e-4 && (tr.y - 60.0).abs() < 1e-4,
            "{tr:?}"
        );
        let (u, v) = r.to_crop(Pt::new(110.0, 60.0));
        assert!((u - 1.0).abs() < 1e-5 && v.abs() < 1e-5);
    }

    #[test]
    fn two_point_roi_is_level_for_level_points_and_scaled() {
        let r = Roi::from_two_points(Pt::new(10.0, 20.0), Pt::new(30.0, 20.0), 2.3);
        assert_eq!((r.cx, r.cy), (20.0, 20.0));
        assert!((r.w - 46.0).abs() < 1e-4 && r.angle_rad == 0.0);
        let tilted = Roi::from_two_points(Pt::new(0.0, 0.0), Pt::new(10.0, 10.0), 1.0);
        assert!((tilted.angle_rad - std::f32::consts::FRAC_PI_4).abs() < 1e-6);
    }
}
