use serde::{Deserialize, Serialize};

/// A point in a 2-D plane whose unit is fixed by the implementing type.
///
/// Stage code that only needs "two numbers per sample" (filters, resampling,
/// path length) is generic over this trait; the type keeps the unit.
pub trait PlanePos: Copy + Clone + std::fmt::Debug + PartialEq + Send + Sync {
    fn xy(self) -> [f64; 2];
    fn from_xy(xy: [f64; 2]) -> Self;
}

/// Iris position normalized within the eye aperture (paper eq. 1):
/// `nx` = 0 at the image-left eye corner, 1 at the image-right one; `ny` = 0 at
/// the upper lid, 1 at the lower lid. Nominally in [0, 1].
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, Default)]
pub struct NormPos {
    pub nx: f64,
    pub ny: f64,
}

/// Cursor position on the simulator canvas, in canvas pixels, origin top-left.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, Default)]
pub struct CanvasPos {
    pub x_px: f64,
    pub y_px: f64,
}

/// Gaze point on an eye tracker's screen, in screen pixels, origin top-left.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, Default)]
pub struct ScreenPos {
    pub x_px: f64,
    pub y_px: f64,
}

macro_rules! plane_pos {
    ($t:ty, $a:ident, $b:ident) => {
        impl PlanePos for $t {
            #[inline]
            fn xy(self) -> [f64; 2] {
                [self.$a, self.$b]
            }
            #[inline]
            fn from_xy(xy: [f64; 2]) -> Self {
                Self {
                    $a: xy[0],
                    $b: xy[1],
                }
            }
        }
    };
}
plane_pos!(NormPos, nx, ny);
plane_pos!(CanvasPos, x_px, y_px);
plane_pos!(ScreenPos, x_px, y_px);

/// Size of the simulator canvas in pixels (the paper: 1280x720).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Canvas {
    pub width_px: u32,
    pub height_px: u32,
}

impl Default for Canvas {
    fn default() -> Self {
        Canvas {
            width_px: 1280,
            height_px: 720,
        }
    }
}

impl Canvas {
    pub fn extent(self) -> [f64; 2] {
        [self.width_px as f64, self.height_px as f64]
    }
    pub fn center(self) -> CanvasPos {
        CanvasPos {
            x_px: self.width_px as f64 / 2.0,
            y_px: self.height_px as f64 / 2.0,
        }
    }
    pub fn contains(self, p: CanvasPos) -> bool {
        p.x_px >= 0.0
            && p.y_px >= 0.0
            && p.x_px <= self.width_px as f64
            && p.y_px <= self.height_px as f64
    }
}

/// Size of an eye tracker's screen in pixels.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ScreenSize {
    pub width_px: f64,
    pub height_px: f64,
}

impl ScreenSize {
    /// Position as a fraction of the screen, the screen analogue of [`NormPos`].
    pub fn fraction(self, p: ScreenPos) -> [f64; 2] {
        [p.x_px / self.width_px, p.y_px / self.height_px]
    }
}
