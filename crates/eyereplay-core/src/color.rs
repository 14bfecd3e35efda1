//! The sRGB transfer function (IEC 61966-2-1), written once.
//!
//! The formulas are instantiated in f64 and in f32 from the same text: the
//! f32 versions compute in f32 throughout (the renderers' colours and
//! tables depend on those exact bits), the f64 ones in f64.

macro_rules! srgb_fns {
    ($t:ty, $decode:ident, $encode:ident) => {
        /// sRGB code value (0-255, not necessarily whole) to linear light
        /// (0-1), IEC 61966-2-1.
        #[inline]
        pub fn $decode(code: $t) -> $t {
            let c = code / 255.0;
            if c <= 0.04045 {
                c / 12.92
            } else {
                ((c + 0.055) / 1.055).powf(2.4)
            }
        }

        /// Linear light to an sRGB code value (0-255, not rounded); linear
        /// values outside 0..=1 are clamped first.
        #[inline]
        pub fn $encode(linear: $t) -> $t {
            let l = linear.clamp(0.0, 1.0);
            255.0
                * if l <= 0.0031308 {
                    12.92 * l
                } else {
                    1.055 * l.powf(1.0 / 2.4) - 0.055
                }
        }
    };
}

srgb_fns!(f64, srgb_to_linear, linear_to_srgb);
srgb_fns!(f32, srgb_to_linear_f32, linear_to_srgb_f32);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn known_points() {
        assert_eq!(srgb_to_linear(0.0), 0.0);
        assert_eq!(srgb_to_linear(255.0), 1.0);
        assert_eq!(linear_to_srgb(0.0), 0.0);
        assert!((linear_to_srgb(1.0) - 255.0).abs() < 1e-9);
        // sRGB 128/255 is linear 0.2159 (IEC 61966-2-1).
        assert!((srgb_to_linear(128.0) - 0.21586).abs() < 1e-5);
        assert!((srgb_to_linear_f32(128.0) - 0.21586).abs() < 1e-5);
        for code in 0..=255 {
            let c = code as f64;
            assert!((linear_to_srgb(srgb_to_linear(c)) - c).abs() < 1e-9);
        }
    }

    /// The f32 decode gives the bits of the formula written out in f32
    /// (as the renderer had it), for whole and fractional codes.
    #[test]
    fn f32_decode_is_the_f32_formula() {
        fn old(c: f32) -> f32 {
            let c = c / 255.0;
            if c <= 0.04045 {
                c / 12.92
            } else {
                ((c + 0.055) / 1.055).powf(2.4)
            }
        }
        for i in 0..=255 * 64 {
            let c = i as f32 / 64.0;
            assert_eq!(srgb_to_linear_f32(c).to_bits(), old(c).to_bits(), "{c}");
        }
    }
}
