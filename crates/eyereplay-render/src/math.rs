//! Small 3-vector in f32 (per-pixel shading) and f64 (geometry, gaze solve).

use std::ops::{Add, Mul, Neg, Sub};

#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct V3 {
    pub x: f64,
    pub y: f64,
    pub z: f64,
}

pub const fn v3(x: f64, y: f64, z: f64) -> V3 {
    V3 { x, y, z }
}

impl V3 {
    #[inline(always)]
    pub fn dot(self, o: V3) -> f64 {
        self.x * o.x + self.y * o.y + self.z * o.z
    }
    #[inline(always)]
    pub fn cross(self, o: V3) -> V3 {
        v3(
            self.y * o.z - self.z * o.y,
            self.z * o.x - self.x * o.z,
            self.x * o.y - self.y * o.x,
        )
    }
    #[inline(always)]
    pub fn len(self) -> f64 {
        self.dot(self).sqrt()
    }
    #[inline(always)]
    pub fn norm(self) -> V3 {
        self * (1.0 / self.len())
    }
    pub fn f(self) -> F3 {
        F3 {
            x: self.x as f32,
            y: self.y as f32,
            z: self.z as f32,
        }
    }
}
impl Add for V3 {
    type Output = V3;
    #[inline(always)]
    fn add(self, o: V3) -> V3 {
        v3(self.x + o.x, self.y + o.y, self.z + o.z)
    }
}
impl Sub for V3 {
    type Output = V3;
    #[inline(always)]
    fn sub(self, o: V3) -> V3 {
        v3(self.x - o.x, self.y - o.y, self.z - o.z)
    }
}
impl Mul<f64> for V3 {
    type Output = V3;
    #[inline(always)]
    fn mul(self, s: f64) -> V3 {
        v3(self.x * s, self.y * s, self.z * s)
    }
}
impl Neg for V3 {
    type Output = V3;
    #[inline(always)]
    fn neg(self) -> V3 {
        v3(-self.x, -self.y, -self.z)
    }
}

/// Orthonormal basis stored as its three axes (columns of a rotation).
#[derive(Clone, Copy, Debug)]
pub struct Basis {
    pub x: V3,
    pub y: V3,
    pub z: V3,
}

impl Basis {
    pub const IDENTITY: Basis = Basis {
        x: v3(1.0, 0.0, 0.0),
        y: v3(0.0, 1.0, 0.0),
        z: v3(0.0, 0.0, 1.0),
    };
    /// World -> local.
    #[inline(always)]
    pub fn to_local(self, w: V3) -> V3 {
        v3(w.dot(self.x), w.dot(self.y), w.dot(self.z))
    }
    /// Eye orientation for a gaze (Fick gimbal: yaw about the head's vertical
    /// axis, then pitch). Head frame: x image-right, y down, z toward the
    /// camera. Positive yaw looks image-right, positive pitch looks up.
    pub fn gaze(yaw_rad: f64, pitch_rad: f64) -> Basis {
        let (sy, cy) = yaw_rad.sin_cos();
        let (sp, cp) = pitch_rad.sin_cos();
        let z = v3(sy * cp, -sp, cy * cp);
        let x = v3(cy, 0.0, -sy);
        let y = z.cross(x);
        Basis { x, y, z }
    }
    /// Rotation of a whole basis by yaw (about y), pitch (about x) and roll
    /// (about z), applied in that order to this basis' axes.
    pub fn rotated(&self, yaw_rad: f64, pitch_rad: f64, roll_rad: f64) -> Basis {
        let r = |v: V3| -> V3 {
            // roll about z
            let (sr, cr) = roll_rad.sin_cos();
            let v = v3(cr * v.x - sr * v.y, sr * v.x + cr * v.y, v.z);
            // pitch about x
            let (sp, cp) = pitch_rad.sin_cos();
            let v = v3(v.x, cp * v.y - sp * v.z, sp * v.y + cp * v.z);
            // yaw about y
            let (sy, cy) = yaw_rad.sin_cos();
            v3(cy * v.x + sy * v.z, v.y, -sy * v.x + cy * v.z)
        };
        Basis {
            x: r(self.x),
            y: r(self.y),
            z: r(self.z),
        }
    }
}

#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct F3 {
    pub x: f32,
    pub y: f32,
    pub z: f32,
}

#[inline(always)]
pub const fn f3(x: f32, y: f32, z: f32) -> F3 {
    F3 { x, y, z }
}

impl F3 {
    #[inline(always)]
    pub fn dot(self, o: F3) -> f32 {
        self.x * o.x + self.y * o.y + self.z * o.z
    }
    #[inline(always)]
    pub fn lerp(self, o: F3, t: f32) -> F3 {
        self + (o - self) * t
    }
    #[inline(always)]
    pub fn mulv(self, o: F3) -> F3 {
        f3(self.x * o.x, self.y * o.y, self.z * o.z)
    }
}
impl Neg for F3 {
    type Output = F3;
    #[inline(always)]
    fn neg(self) -> F3 {
        f3(-self.x, -self.y, -self.z)
    }
}
impl Add for F3 {
    type Output = F3;
    #[inline(always)]
    fn add(self, o: F3) -> F3 {
        f3(self.x + o.x, self.y + o.y, self.z + o.z)
    }
}
impl Sub for F3 {
    type Output = F3;
    #[inline(always)]
    fn sub(self, o: F3) -> F3 {
        f3(self.x - o.x, self.y - o.y, self.z - o.z)
    }
}
impl Mul<f32> for F3 {
    type Output = F3;
    #[inline(always)]
    fn mul(self, s: f32) -> F3 {
        f3(self.x * s, self.y * s, self.z * s)
    }
}

#[inline(always)]
pub fn smoothstep(e0: f32, e1: f32, x: f32) -> f32 {
    // Multiply by the reciprocal: with constant edges it folds at compile
    // time, and a division per call showed in the per-pixel profile.
    let t = ((x - e0) * (1.0 / (e1 - e0))).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// floor() without the libm call (valid for |x| < 2^31).
#[inline(always)]
pub fn floor_fast(x: f32) -> f32 {
    let i = x as i32 as f32;
    if i > x {
        i - 1.0
    } else {
        i
    }
}

#[inline(always)]
pub fn clamp01(x: f32) -> f32 {
    x.clamp(0.0, 1.0)
}

/// sRGB-encoded 0..255 to linear, in f32
/// ([`eyereplay_core::color::srgb_to_linear_f32`]).
pub fn srgb_to_linear(c: f32) -> f32 {
    eyereplay_core::color::srgb_to_linear_f32(c)
}

/// Linear 0..=1 -> sRGB byte through a lookup table, so per-pixel output
/// costs one multiply and one load instead of a `powf`.
pub struct SrgbLut {
    table: Vec<u8>,
}

impl SrgbLut {
    const N: usize = 16384; // a power of two, for the mask in `encode`
    pub fn new() -> Self {
        let table = (0..Self::N)
            .map(|i| {
                let l = i as f64 / (Self::N - 1) as f64;
                eyereplay_core::color::linear_to_srgb(l)
                    .round()
                    .clamp(0.0, 255.0) as u8
            })
            .collect();
        SrgbLut { table }
    }
    #[inline(always)]
    #[allow(clippy::manual_clamp)] // clamp would keep NaN; max(0.0) maps it to 0
    pub fn encode(&self, l: f32) -> u8 {
        // Adding 2^23 leaves round(l * (N - 1)) in the low mantissa bits: a
        // float-to-index conversion without the checks of a saturating `as`
        // (this ran for every pixel and showed in the profile). `max` also
        // maps NaN to 0.
        let v = l.max(0.0).min(1.0) * (Self::N - 1) as f32 + 8_388_608.0;
        self.table[(v.to_bits() & (Self::N as u32 - 1)) as usize]
    }
    #[inline(always)]
    pub fn rgb(&self, c: F3) -> [u8; 3] {
        [self.encode(c.x), self.encode(c.y), self.encode(c.z)]
    }
}

impl Default for SrgbLut {
    fn default() -> Self {
        Self::new()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    #[test]
    fn gaze_basis_points_where_asked() {
        let b = Basis::gaze(0.0, 0.0);
        assert!((b.z.z - 1.0).abs() < 1e-12);
        // 30 degrees right: x component sin(30) = 0.5.
        let b = Basis::gaze(30f64.to_radians(), 0.0);
        assert!((b.z.x - 0.5).abs() < 1e-12);
        // looking up means negative y (y points down).
        let b = Basis::gaze(0.0, 10f64.to_radians());
        assert!(b.z.y < 0.0);
        // orthonormal and right-handed
        assert!((b.x.cross(b.y).dot(b.z) - 1.0).abs() < 1e-12);
    }
    #[test]
    fn srgb_lut_matches_known_points() {
        let l = SrgbLut::new();
        assert_eq!(l.encode(0.0), 0);
        assert_eq!(l.encode(1.0), 255);
        // sRGB 128/255 is linear 0.2159 (IEC 61966-2-1); 0.2140 is 127.3.
        assert_eq!(l.encode(0.2159), 128);
        assert_eq!(l.encode(0.2140), 127);
        assert!((srgb_to_linear(128.0) - 0.2158).abs() < 1e-3);
    }
    /// The table built from eyereplay-core's encode holds the bytes of the
    /// formula the renderer wrote out itself before, entry for entry; and
    /// the f32 decode gives that formula's bits.
    #[test]
    fn srgb_lut_and_decode_match_the_former_formulas() {
        let n = SrgbLut::N;
        let old: Vec<u8> = (0..n)
            .map(|i| {
                let l = i as f64 / (n - 1) as f64;
                let s = if l <= 0.003_130_8 {
                    l * 12.92
                } else {
                    1.055 * l.powf(1.0 / 2.4) - 0.055
                };
                (s * 255.0).round().clamp(0.0, 255.0) as u8
            })
            .collect();
        assert_eq!(SrgbLut::new().table, old);
        let old_decode = |c: f32| {
            let c = c / 255.0;
            if c <= 0.04045 {
                c / 12.92
            } else {
                ((c + 0.055) / 1.055).powf(2.4)
            }
        };
        for i in 0..=255 * 256 {
            let c = i as f32 / 256.0;
            assert_eq!(srgb_to_linear(c).to_bits(), old_decode(c).to_bits(), "{c}");
        }
    }
}
