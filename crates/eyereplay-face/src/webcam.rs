//! Webcam realism: makes a rendered face frame look like it came out of a
//! laptop webcam.
//!
//! A rendered frame is too clean: perfectly exposed, perfectly white
//! balanced, pin sharp, noiseless, evenly lit. A gaze model trained on such
//! frames meets something else in a video call. Each session therefore
//! draws one [`WebcamLook`] from [`WebcamRanges`] (recorded in the
//! dataset's metadata) and every frame of the session goes through the
//! same [`Webcam`]. What each effect models, in the order light meets it
//! (optics, then sensor, then the camera's image signal processor, ISP):
//!
//! 1. **Side light** ([`WebcamLook::light_strength`],
//!    [`WebcamLook::light_azimuth_deg`], [`WebcamLook::light_temperature_k`]):
//!    rooms are lit unevenly, by a window or a lamp to one side, often of a
//!    different colour than the rest of the room. Modelled as a linear
//!    brightness gradient across the frame, tinted by the light's colour
//!    (a low-frequency stand-in for shading; the face's own relief is not
//!    relit).
//! 2. **Vignetting** ([`WebcamLook::vignetting`]): the tiny lenses of laptop
//!    webcams lose light towards the corners (the cos^4 law of natural
//!    vignetting plus mechanical vignetting); the corners are typically
//!    10-35 % darker than the centre after the ISP's partial correction.
//! 3. **Defocus** ([`WebcamLook::defocus_sigma_px`]): fixed-focus plastic
//!    lenses, a sensor with 1-1.4 um pixels and the ISP's noise reduction
//!    soften the image; a gaussian of 0.4-1.1 px at 480 rows (scaled with
//!    the frame height) matches the softness of VGA webcam video.
//! 4. **Motion blur** ([`WebcamLook::motion_blur`]): indoors the auto
//!    exposure opens the shutter for 1/60-1/30 s, a large fraction of the
//!    frame interval, so head and eye motion smear. The smear is a box
//!    along the frame's motion, `motion_blur * |motion_px|` long, centred on
//!    the frame's pose (the renderer's pose is the mid-exposure pose).
//! 5. **Exposure** ([`WebcamLook::exposure_ev`]): auto exposure metres the
//!    whole frame, not the face, and lands within about half a stop.
//! 6. **White balance** ([`WebcamLook::white_balance_k`]): auto white
//!    balance guesses the illuminant's colour temperature and errs in mixed
//!    indoor light; the scene is rendered for 6500 K, and a camera that
//!    assumes a warmer light (lower K) makes it bluer, a colder one redder.
//! 7. **Sensor noise** ([`WebcamLook::noise_sigma`],
//!    [`WebcamLook::shot_noise`]): small pixels in indoor light are noisy:
//!    read noise (constant) plus photon shot noise (std growing with the
//!    square root of the signal), gaussian, added to the 8-bit code values
//!    after the tone curve, as webcam noise is seen, then clamped.
//! 8. **Compression** ([`WebcamLook::bitrate_kbps`]): video calls send
//!    H.264 at a few hundred kbps to about 1.5 Mbps; the bitrate is only
//!    recorded here, the video encoder applies it
//!    ([`WebcamLook::bitrate_kbps_for`]).
//!
//! The lens field of view ([`WebcamLook::vfov_deg`]) is also drawn here, for
//! the renderer's camera: a typical laptop webcam is 720p with a 70-80 deg
//! diagonal field of view, i.e. about 40-45 deg vertically at 16:9; the
//! default range 38-48 deg covers that and slightly wider or narrower lenses.
//!
//! # How it is computed
//!
//! Everything up to the noise is linear in light, so it is done in linear
//! light (sRGB decoded through a 256-entry table), in f32. Exposure and
//! white balance are constant per channel and linear, so they commute with
//! the blurs: they are folded into the light/vignetting gain applied while
//! decoding (mathematically the same order as above; only the clipping,
//! which happens at the end, is after the blurs, which is where a sensor
//! clips optical blur too). The gaussian is separable (truncated at 3
//! sigma, edges replicated); the motion smear is a small 2-D kernel of
//! bilinear taps merged on the integer grid. Encoding back to sRGB is a
//! degree-7 polynomial in `sqrt(linear)` (within 0.05 code value of the
//! exact curve, so every code value survives decode-encode exactly), and
//! the noise std a degree-4 one: no table lookups, so it vectorizes.
//!
//! Determinism: the noise of value `i` (pixel times 3 plus channel) of
//! frame `f` comes from a counter-based hash, lowbias32 of `i` keyed by
//! splitmix64 of (seed, f), its four bytes summed and shaped into a
//! near-normal deviate; each row's result
//! depends only on the input rows, never on how the frame was cut into
//! rayon bands, so the bytes are the same for any thread count. The code
//! uses only IEEE-exact operations (add, multiply, divide, sqrt, fused
//! multiply-add via `mul_add`), so its AVX-512 and AVX2+FMA builds (the
//! widest the CPU has is picked at run time) and the portable build (where
//! `mul_add` is libm's correctly rounded `fmaf`: the same bytes, slowly)
//! agree bit for bit.
//!
//! The frame is processed in place, cut into bands of rows, one rayon task
//! each (the few input rows a band reads beyond its ends are copied first);
//! a band streams its rows through small ring buffers (horizontally blurred
//! rows, then vertically blurred rows for the motion smear), so the working
//! set stays in cache. No allocation per frame once the buffers have grown
//! to the largest motion smear seen.

use crate::{FaceError, RgbImage};
use eyereplay_core::color::srgb_to_linear;
use eyereplay_core::mix64;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Uniform};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::sync::Mutex;

/// Frame height that [`WebcamLook::defocus_sigma_px`] refers to (VGA rows).
pub const REFERENCE_HEIGHT_PX: usize = 480;
/// Frame width that [`WebcamLook::bitrate_kbps`] refers to (VGA).
pub const REFERENCE_WIDTH_PX: usize = 640;
/// Colour temperature the scene is rendered for (D65, sRGB's white).
pub const SCENE_TEMPERATURE_K: f64 = 6500.0;
/// Longest motion smear applied, px; longer smears are shortened to this
/// (a head never moves that far within one exposure of a webcam frame).
pub const MAX_SMEAR_PX: f32 = 128.0;

/// sRGB's linear segment: below this linear value the code is
/// `12.92 * 255 * linear`.
const SRGB_KNEE: f32 = 0.003_130_8;
const SRGB_SLOPE: f32 = 12.92 * 255.0;
/// sRGB code (0-255) above the knee as a polynomial in
/// `u = sqrt(linear) * ENC_SCALE + ENC_OFFSET` (sqrt(linear) from the knee
/// to 1 mapped onto -1..1): the degree-7 Chebyshev interpolant of
/// `255 (1.055 linear^(1/2.4) - 0.055)`, coefficients lowest first, rounded
/// to f32. Within 0.041 code value of the exact curve in f32 arithmetic.
const ENC_SCALE: f32 = 2.118_539_8;
const ENC_OFFSET: f32 = -1.118_539_8;
const ENC_POLY: [f32; 8] = [
    143.976_64,
    117.701_43,
    -9.035_501,
    3.252_136_7,
    -0.278_796_37,
    -0.075_982_995,
    -1.981_953_5,
    1.446_838_5,
];
/// Noise: the sum S of the four bytes of a hash (Irwin-Hall, mean 510,
/// std 147.8) made standard normal-like by `y = z (NOISE_C1 + NOISE_C3
/// z^2)`, z = S - 510: unit variance and the normal's kurtosis of 3
/// (solved from the exact moments of S); tails within 15 % of the normal's
/// at 2 and 3 sigma, cut at 4 sigma.
const NOISE_C1: f32 = 0.006_421_040_6;
const NOISE_C3: f32 = 5.773_954e-9;
/// 2^23: adding it to a float in [0, 2^22] rounds it (to nearest) to an
/// integer held in the low mantissa bits; unlike a float-to-int cast this
/// vectorizes.
const MAGIC: f32 = 8_388_608.0;
const MAGIC_BITS: i32 = 0x4B00_0000;
/// Smallest gaussian sigma that blurs at all, px (the neighbours of a
/// smaller one weigh under 1e-80).
const MIN_SIGMA_PX: f64 = 0.05;
/// Shortest motion smear applied, px.
const MIN_SMEAR_PX: f32 = 0.25;

/// Ranges a session's look is drawn from (uniform in each `[lo, hi]`).
/// The defaults are a laptop webcam in a video call, see the module doc.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct WebcamRanges {
    /// Lens vertical field of view, degrees (laptop webcams 40-45 at 16:9).
    pub vfov_deg: [f64; 2],
    /// Exposure offset, stops.
    pub exposure_ev: [f64; 2],
    /// Colour temperature the camera assumes, K, against a 6500 K scene.
    pub white_balance_k: [f64; 2],
    /// Read-noise std, 8-bit code values.
    pub noise_sigma: [f64; 2],
    /// Shot-noise std at white, code values (std grows with sqrt(linear)).
    pub shot_noise: [f64; 2],
    /// Gaussian blur sigma, px of a 480-row frame (scaled with the height).
    pub defocus_sigma_px: [f64; 2],
    /// Fraction of a frame's motion smeared (shutter open fraction).
    pub motion_blur: [f64; 2],
    /// Direction the side light comes from in the image, degrees: 0 from
    /// the top, 90 from the right, -90 from the left.
    pub light_azimuth_deg: [f64; 2],
    /// Brightness difference across the frame from the side light, fraction.
    pub light_strength: [f64; 2],
    /// Colour temperature of the side light, K.
    pub light_temperature_k: [f64; 2],
    /// Brightness loss at the corners, fraction.
    pub vignetting: [f64; 2],
    /// H.264 bitrate at 640x480, kbps (scaled by [`WebcamLook::bitrate_kbps_for`]).
    pub bitrate_kbps: [f64; 2],
}

impl Default for WebcamRanges {
    fn default() -> WebcamRanges {
        WebcamRanges {
            vfov_deg: [38.0, 48.0],
            exposure_ev: [-0.4, 0.3],
            white_balance_k: [4200.0, 7500.0],
            noise_sigma: [1.5, 4.0],
            shot_noise: [2.0, 5.0],
            defocus_sigma_px: [0.4, 1.1],
            motion_blur: [0.2, 0.6],
            light_azimuth_deg: [-60.0, 60.0],
            light_strength: [0.0, 0.35],
            light_temperature_k: [3000.0, 6500.0],
            vignetting: [0.1, 0.35],
            bitrate_kbps: [400.0, 1200.0],
        }
    }
}

impl WebcamRanges {
    /// The fields with their limits: (name, range, min, max).
    fn fields(&self) -> [(&'static str, [f64; 2], f64, f64); 12] {
        [
            // Wider than 120 deg is a fisheye, narrower than 10 a telephoto.
            ("vfov_deg", self.vfov_deg, 10.0, 120.0),
            ("exposure_ev", self.exposure_ev, -4.0, 4.0),
            // The Planckian locus approximation holds over 1000-15000 K.
            ("white_balance_k", self.white_balance_k, 1500.0, 15000.0),
            ("noise_sigma", self.noise_sigma, 0.0, 64.0),
            ("shot_noise", self.shot_noise, 0.0, 64.0),
            ("defocus_sigma_px", self.defocus_sigma_px, 0.0, 16.0),
            ("motion_blur", self.motion_blur, 0.0, 1.0),
            ("light_azimuth_deg", self.light_azimuth_deg, -180.0, 180.0),
            ("light_strength", self.light_strength, 0.0, 1.0),
            (
                "light_temperature_k",
                self.light_temperature_k,
                1500.0,
                15000.0,
            ),
            ("vignetting", self.vignetting, 0.0, 1.0),
            // Below 50 kbps even a 160x120 call is a smear of blocks.
            ("bitrate_kbps", self.bitrate_kbps, 50.0, 100_000.0),
        ]
    }

    /// Checks every range: finite, lo <= hi, and inside physically
    /// meaningful limits. Error: a one-line message naming the field, e.g.
    /// "render.webcam.noise_sigma: lo 4 > hi 2" ([`FaceError::Webcam`]).
    pub fn validate(&self) -> Result<(), FaceError> {
        for (name, [lo, hi], min, max) in self.fields() {
            for (end, v) in [("lo", lo), ("hi", hi)] {
                if !v.is_finite() {
                    return Err(FaceError::Webcam(format!(
                        "render.webcam.{name}: {end} {v} is not finite"
                    )));
                }
            }
            if lo > hi {
                return Err(FaceError::Webcam(format!(
                    "render.webcam.{name}: lo {lo} > hi {hi}"
                )));
            }
            for (end, v) in [("lo", lo), ("hi", hi)] {
                if v < min || v > max {
                    return Err(FaceError::Webcam(format!(
                        "render.webcam.{name}: {end} {v} is outside the limits {min}..={max}"
                    )));
                }
            }
        }
        Ok(())
    }

    /// Draws one session's look from `seed` (ChaCha8, uniform in each
    /// range, fields in declaration order, one draw per field even for an
    /// empty range, so narrowing one range leaves the others' draws alone).
    /// Same seed, same look. Meant for validated ranges; an invalid range
    /// yields its `lo`.
    pub fn sample(&self, seed: u64) -> WebcamLook {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut v = self.fields().map(|(_, [lo, hi], _, _)| {
            if lo.is_finite() && hi.is_finite() && lo <= hi {
                Uniform::new_inclusive(lo, hi)
                    .sample(&mut rng)
                    .clamp(lo, hi)
            } else {
                let _ = Uniform::new_inclusive(0.0, 1.0).sample(&mut rng);
                lo
            }
        });
        let mut next = {
            let mut i = 0;
            move || {
                i += 1;
                std::mem::take(&mut v[i - 1])
            }
        };
        WebcamLook {
            seed,
            vfov_deg: next(),
            exposure_ev: next(),
            white_balance_k: next(),
            noise_sigma: next(),
            shot_noise: next(),
            defocus_sigma_px: next(),
            motion_blur: next(),
            light_azimuth_deg: next(),
            light_strength: next(),
            light_temperature_k: next(),
            vignetting: next(),
            bitrate_kbps: next(),
        }
    }
}

/// One session's camera look (recorded in the dataset's metadata). Units
/// and meanings as in [`WebcamRanges`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct WebcamLook {
    /// Seed of the look and of its per-frame noise.
    pub seed: u64,
    pub vfov_deg: f64,
    pub exposure_ev: f64,
    pub white_balance_k: f64,
    pub noise_sigma: f64,
    pub shot_noise: f64,
    pub defocus_sigma_px: f64,
    pub motion_blur: f64,
    pub light_azimuth_deg: f64,
    pub light_strength: f64,
    pub light_temperature_k: f64,
    pub vignetting: f64,
    /// 0 in [`WebcamLook::identity`]: no bitrate limit (a clean encode).
    pub bitrate_kbps: f64,
}

impl WebcamLook {
    /// No effect at all: [`Webcam::apply`] leaves frames unchanged byte for
    /// byte. The field of view is the middle of the default range (43 deg),
    /// the bitrate 0 (no limit).
    pub fn identity() -> WebcamLook {
        WebcamLook {
            seed: 0,
            vfov_deg: 43.0,
            exposure_ev: 0.0,
            white_balance_k: SCENE_TEMPERATURE_K,
            noise_sigma: 0.0,
            shot_noise: 0.0,
            defocus_sigma_px: 0.0,
            motion_blur: 0.0,
            light_azimuth_deg: 0.0,
            light_strength: 0.0,
            light_temperature_k: SCENE_TEMPERATURE_K,
            vignetting: 0.0,
            bitrate_kbps: 0.0,
        }
    }

    /// The side light's direction in the head frame (x toward image right,
    /// y up, z toward the camera; pointing at the light), for shading what
    /// is drawn in 3D (the eyes) as the frame's gradient shades the image:
    /// 45 deg off the camera axis toward where the gradient's light comes
    /// from (azimuth 0 the top of the frame, +90 the right).
    pub fn light_dir_head(&self) -> [f64; 3] {
        let a = self.light_azimuth_deg.to_radians();
        let off = std::f64::consts::FRAC_PI_4;
        [off.sin() * a.sin(), off.sin() * a.cos(), off.cos()]
    }

    /// Linear RGB gains of the white balance, green = 1: the camera
    /// divides by the colour of the illuminant it assumes
    /// (`white_balance_k`) while the scene is lit at 6500 K, so the gains
    /// are `rgb(6500 K) / rgb(white_balance_k)` with `rgb` the blackbody
    /// colour of [`blackbody_linear_srgb`]. [1, 1, 1] at 6500 K; an assumed
    /// warmer light (lower K) raises blue against red.
    pub fn white_balance_gains(&self) -> [f32; 3] {
        let scene = blackbody_linear_srgb(SCENE_TEMPERATURE_K);
        let assumed = blackbody_linear_srgb(self.white_balance_k);
        let g = [0, 1, 2].map(|c| scene[c] / assumed[c]);
        g.map(|v| (v / g[1]) as f32)
    }

    /// Linear RGB colour of the side light against the 6500 K main light,
    /// `rgb(light_temperature_k) / rgb(6500 K)`, scaled to luminance 1
    /// (Rec. 709 weights), so [`WebcamLook::light_strength`] is a brightness.
    pub fn light_tint(&self) -> [f32; 3] {
        let scene = blackbody_linear_srgb(SCENE_TEMPERATURE_K);
        let light = blackbody_linear_srgb(self.light_temperature_k);
        let t = [0, 1, 2].map(|c| light[c] / scene[c]);
        let y = 0.2126 * t[0] + 0.7152 * t[1] + 0.0722 * t[2];
        t.map(|v| (v / y) as f32)
    }

    /// The bitrate for a frame of `width` x `height`, kbps: `bitrate_kbps`
    /// (at 640x480) times the square root of the pixel-count ratio. Square
    /// root, not linear: more pixels of the same face are more redundant,
    /// and video-call apps raise the bitrate far less than the pixel count
    /// (roughly 0.5-1 Mbps at 480p against 1.2-2.5 Mbps at 720p, i.e. about
    /// 2x for 3x the pixels); sqrt gives 1.73x. 0 stays 0 (no limit).
    pub fn bitrate_kbps_for(&self, width: usize, height: usize) -> u32 {
        if self.bitrate_kbps.is_nan() || self.bitrate_kbps <= 0.0 {
            return 0;
        }
        let ratio = (width * height) as f64 / (REFERENCE_WIDTH_PX * REFERENCE_HEIGHT_PX) as f64;
        (self.bitrate_kbps * ratio.sqrt()).round().max(1.0) as u32
    }

    /// Gaussian sigma at a frame of `height` rows, px.
    fn defocus_sigma_at(&self, height: usize) -> f64 {
        self.defocus_sigma_px * height as f64 / REFERENCE_HEIGHT_PX as f64
    }
}

/// Linear sRGB colour (luminance Y = 1) of a blackbody at `kelvin`:
/// Krystek's (1985) rational approximation of the Planckian locus in CIE
/// 1960 (u, v), valid over 1000-15000 K (the argument is clamped to it),
/// converted to xy, to XYZ and through the sRGB (IEC 61966-2-1) matrix.
/// Components are floored at 1 % of the largest: below about 1900 K blue
/// falls outside the sRGB gamut.
pub fn blackbody_linear_srgb(kelvin: f64) -> [f64; 3] {
    let [x, y] = planckian_xy(kelvin);
    let (cx, cy, cz) = (x / y, 1.0, (1.0 - x - y) / y);
    let rgb = [
        3.2404542 * cx - 1.5371385 * cy - 0.4985314 * cz,
        -0.9692660 * cx + 1.8760108 * cy + 0.0415560 * cz,
        0.0556434 * cx - 0.2040259 * cy + 1.0572252 * cz,
    ];
    let floor = 0.01 * rgb[0].max(rgb[1]).max(rgb[2]);
    rgb.map(|c| c.max(floor))
}

/// CIE 1931 xy of a blackbody at `kelvin` (Krystek 1985, clamped to
/// 1000-15000 K).
fn planckian_xy(kelvin: f64) -> [f64; 2] {
    let t = kelvin.clamp(1000.0, 15000.0);
    let u = (0.860117757 + 1.54118254e-4 * t + 1.28641212e-7 * t * t)
        / (1.0 + 8.42420235e-4 * t + 7.08145163e-7 * t * t);
    let v = (0.317398726 + 4.22806245e-5 * t + 4.20481691e-8 * t * t)
        / (1.0 - 2.89741816e-5 * t + 1.61456053e-7 * t * t);
    let d = 2.0 * u - 8.0 * v + 4.0;
    [3.0 * u / d, 2.0 * v / d]
}

/// splitmix64's increment.
const GOLDEN: u64 = eyereplay_core::SPLITMIX_GOLDEN;

/// Chris Wellons' lowbias32: a bijective 32-bit mix with near-ideal
/// avalanche, cheap enough to vectorize (32-bit multiplies).
#[inline(always)]
fn lowbias32(mut x: u32) -> u32 {
    x ^= x >> 16;
    x = x.wrapping_mul(0x7FEB_352D);
    x ^= x >> 15;
    x = x.wrapping_mul(0x846C_A68B);
    x ^ (x >> 16)
}

/// Standard-normal-like noise for value `i` under the frame's keys `k1`
/// and `k2`: lowbias32 of `(i xor k1) + k2` (a different bijection of the
/// index per frame, mixing xor and add, so no two frames share a noise
/// pattern, not even shifted), then the cubic-corrected Irwin-Hall sum of
/// its four bytes.
#[inline(always)]
fn noise_at(i: u32, k1: u32, k2: u32) -> f32 {
    let h = lowbias32((i ^ k1).wrapping_add(k2));
    // Sum of the four bytes: pairs first, then the two 16-bit halves.
    let pairs = (h & 0x00FF_00FF) + ((h >> 8) & 0x00FF_00FF);
    let sum = (pairs & 0xFFFF) + (pairs >> 16);
    let z = (sum as i32 - 510) as f32;
    z * (z * z).mul_add(NOISE_C3, NOISE_C1)
}

/// Linear light to an sRGB code value (not rounded), in f32: the linear
/// segment, else the polynomial in sqrt(linear). `l` in 0..=1, `s` its
/// square root.
#[inline(always)]
fn encode_f32(l: f32, s: f32) -> f32 {
    let u = s.mul_add(ENC_SCALE, ENC_OFFSET);
    // Estrin's scheme: short dependency chains, so more values are in
    // flight at once than with Horner's.
    let c = ENC_POLY;
    let u2 = u * u;
    let u4 = u2 * u2;
    let lo = u2.mul_add(c[3].mul_add(u, c[2]), c[1].mul_add(u, c[0]));
    let hi = u2.mul_add(c[7].mul_add(u, c[6]), c[5].mul_add(u, c[4]));
    let p = u4.mul_add(hi, lo);
    if l <= SRGB_KNEE {
        l * SRGB_SLOPE
    } else {
        p
    }
}

/// The noise std `sqrt(read^2 + shot^2 s^2)` (code values; s =
/// sqrt(linear)) as a degree-4 polynomial in s, lowest power first: the
/// interpolant at the 5 Chebyshev nodes of 0..1, which saves a square root
/// per value. Within 0.2 % over the default ranges; exact for read or shot
/// noise alone; at worst 0.06 code values off (a tiny read noise under a
/// strong shot noise, near black). Only IEEE-exact operations, so every
/// machine gets the same coefficients.
fn noise_std_poly(read: f64, shot: f64) -> [f32; 5] {
    // 0.5 + 0.5 cos(pi (k + 0.5) / 5).
    const NODES: [f64; 5] = [
        0.975_528_258_147_576_8,
        0.793_892_626_146_236_6,
        0.5,
        0.206_107_373_853_763_4,
        0.024_471_741_852_423_2,
    ];
    let f = |s: f64| (read * read + shot * shot * s * s).sqrt();
    // Newton's divided differences, then expanded to powers of s.
    let mut c = NODES.map(f);
    for j in 1..5 {
        for i in (j..5).rev() {
            c[i] = (c[i] - c[i - 1]) / (NODES[i] - NODES[i - j]);
        }
    }
    let mut poly = [0.0f64; 5];
    for i in (0..5).rev() {
        // poly = poly * (s - NODES[i]) + c[i]
        let mut next = [0.0f64; 5];
        for k in 0..5 {
            next[k] = if k > 0 { poly[k - 1] } else { 0.0 } - NODES[i] * poly[k];
        }
        next[0] += c[i];
        poly = next;
    }
    poly.map(|v| v as f32)
}

/// Clamps to 0..=1, NaN to 0 (`clamp` would keep NaN, which would then
/// not round to a byte).
#[allow(clippy::manual_clamp)]
#[inline(always)]
fn unit(v: f32) -> f32 {
    v.max(0.0).min(1.0)
}

/// Rounds a code value (finite, |code| < 2^22) to the nearest byte,
/// clamped: the integer clamp compiles to saturating packs.
#[inline(always)]
fn to_byte(code: f32) -> u8 {
    ((code + MAGIC).to_bits() as i32 - MAGIC_BITS).clamp(0, 255) as u8
}

/// Everything of a [`Webcam`] fixed for the session.
struct Params {
    width: usize,
    height: usize,
    seed: u64,
    /// sRGB code -> linear.
    decode: [f32; 256],
    noise: bool,
    /// Noise std in code values, `sqrt(noise_sigma^2 + shot_noise^2
    /// linear)`, as a polynomial in sqrt(linear), lowest power first.
    noise_std: [f32; 5],
    /// Vignetting or side light present.
    spatial: bool,
    /// Exposure times white balance, per channel.
    gain: [f32; 3],
    /// `light_strength * light_tint * gain`, per channel.
    light: [f32; 3],
    /// cos^4 vignetting `(1 + k r^2)^-2`, r = 1 at the corners: r^2 as a
    /// column term plus a row term.
    vignette_k: f32,
    col_r2: Vec<f32>,
    row_r2: Vec<f32>,
    /// Side light: position along the light direction, -0.5..0.5 over the
    /// frame, as a column term plus a row term.
    col_d: Vec<f32>,
    row_d: Vec<f32>,
    /// Gaussian taps for offsets 0..=radius (symmetric), sum over -r..=r 1.
    kernel: Vec<f32>,
    motion_blur: f32,
}

/// A merged motion-smear tap: integer offset and weight.
#[derive(Clone, Copy, Debug)]
struct Tap {
    dx: isize,
    dy: isize,
    w: f32,
}

/// One band's working buffers (pooled, grown on demand).
#[derive(Default)]
struct Scratch {
    /// One decoded row padded by the gaussian radius.
    lin: Vec<f32>,
    /// Ring of horizontally blurred rows (2 r + 1).
    h_ring: Vec<f32>,
    /// Ring of vertically blurred rows padded by the smear (2 my + 1).
    v_ring: Vec<f32>,
    /// The finished linear row.
    row: Vec<f32>,
    /// Its noise std per value.
    std: Vec<f32>,
}

fn grow<T: Default + Clone>(v: &mut Vec<T>, n: usize) {
    if v.len() < n {
        v.resize(n, T::default());
    }
}

/// Which build of the per-band code runs: by default the widest vectors
/// the CPU has ([`Webcam::limit_simd`] narrows it). All three give the same
/// bits (only IEEE-exact operations).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Simd {
    Portable,
    /// 8 f32 lanes, with FMA.
    Avx2,
    /// 16 f32 lanes (F, BW, VL, DQ): on a 2-core AMD EPYC (Zen 4) the
    /// look takes 0.74-0.84x the time of the AVX2 build (`cargo bench
    /// -p eyereplay-face --bench webcam` prints both). Its target features
    /// need Rust 1.89 (the workspace's `rust-version`).
    Avx512,
}

impl Simd {
    /// The widest build this CPU runs.
    pub fn detect() -> Simd {
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::is_x86_feature_detected as has;
            if has!("avx512f") && has!("avx512bw") && has!("avx512vl") && has!("avx512dq") {
                return Simd::Avx512;
            }
            if has!("avx2") && has!("fma") {
                return Simd::Avx2;
            }
        }
        Simd::Portable
    }
}

/// Reusable buffers and lookup tables for one look and frame size (build
/// once per session).
pub struct Webcam {
    p: Params,
    noop: bool,
    simd: Simd,
    /// Per band, the input rows it needs from outside itself (copied
    /// before any band writes, so the frame can be processed in place).
    halo: Vec<u8>,
    taps: Vec<Tap>,
    pool: Mutex<Vec<Scratch>>,
}

impl Webcam {
    pub fn new(look: &WebcamLook, width: usize, height: usize) -> Webcam {
        let decode: [f32; 256] = std::array::from_fn(|c| srgb_to_linear(c as f64) as f32);
        let noise = look.noise_sigma > 0.0 || look.shot_noise > 0.0;
        let noise_std = noise_std_poly(look.noise_sigma, look.shot_noise);
        let wb = look.white_balance_gains();
        let ev = 2f64.powf(look.exposure_ev) as f32;
        let gain = wb.map(|g| g * ev);
        let tint = look.light_tint();
        let strength = look.light_strength as f32;
        let light = [0, 1, 2].map(|c| strength * tint[c] * gain[c]);
        // (1 + k)^-2 = 1 - vignetting at r = 1; 1 itself would be black.
        let vig = look.vignetting.clamp(0.0, 0.999);
        let vignette_k = ((1.0 - vig).powf(-0.5) - 1.0) as f32;
        let spatial = vignette_k > 0.0 || strength > 0.0;

        let (w, h) = (width as f64, height as f64);
        let half_diag2 = (w * w + h * h) / 4.0;
        let col_r2 = (0..width)
            .map(|x| ((x as f64 + 0.5 - w / 2.0).powi(2) / half_diag2) as f32)
            .collect();
        let row_r2 = (0..height)
            .map(|y| ((y as f64 + 0.5 - h / 2.0).powi(2) / half_diag2) as f32)
            .collect();
        // Unit vector towards the light in image coordinates (y down).
        let az = look.light_azimuth_deg.to_radians();
        let (lx, ly) = (az.sin(), -az.cos());
        // Half the frame's extent along it, in units of the height.
        let extent = 0.5 * (w / h.max(1.0)) * lx.abs() + 0.5 * ly.abs();
        let scale = 1.0 / (2.0 * extent.max(1e-9) * h.max(1.0));
        let col_d = (0..width)
            .map(|x| ((x as f64 + 0.5 - w / 2.0) * lx * scale) as f32)
            .collect();
        let row_d = (0..height)
            .map(|y| ((y as f64 + 0.5 - h / 2.0) * ly * scale) as f32)
            .collect();

        let sigma = look.defocus_sigma_at(height);
        let kernel = if sigma >= MIN_SIGMA_PX {
            // Truncated at 3 sigma (the taps beyond carry 0.3 % of the weight).
            let r = ((3.0 * sigma).floor() as usize).max(1);
            let k: Vec<f64> = (0..=r)
                .map(|i| (-((i * i) as f64) / (2.0 * sigma * sigma)).exp())
                .collect();
            let sum = k[0] + 2.0 * k[1..].iter().sum::<f64>();
            k.iter().map(|v| (v / sum) as f32).collect()
        } else {
            vec![1.0]
        };
        let motion_blur = look.motion_blur.max(0.0) as f32;
        let noop =
            !noise && !spatial && gain == [1.0; 3] && kernel.len() == 1 && motion_blur == 0.0;
        Webcam {
            p: Params {
                width,
                height,
                seed: look.seed,
                decode,
                noise,
                noise_std,
                spatial,
                gain,
                light,
                vignette_k,
                col_r2,
                row_r2,
                col_d,
                row_d,
                kernel,
                motion_blur,
            },
            noop,
            simd: Simd::detect(),
            halo: Vec::new(),
            taps: Vec::new(),
            pool: Mutex::new(Vec::new()),
        }
    }

    /// The build [`Webcam::apply`] runs.
    pub fn simd(&self) -> Simd {
        self.simd
    }

    /// Runs at most the `max` build from now on (to compare builds on one
    /// CPU; the bytes stay the same).
    pub fn limit_simd(&mut self, max: Simd) {
        self.simd = self.simd.min(max);
    }

    /// Applies the look to one frame in place. `frame_index` seeds the
    /// noise (different per frame, the same for the same index);
    /// `motion_px` is how far the image content moved since the previous
    /// frame (x, y pixels): the motion blur smears along it by
    /// `motion_blur * |motion_px|` (skipped below 0.25 px).
    ///
    /// Panics if the frame is not the size given to [`Webcam::new`].
    pub fn apply(&mut self, frame: &mut RgbImage, frame_index: u64, motion_px: [f32; 2]) {
        let h = frame.height;
        self.apply_rows(frame, frame_index, motion_px, 0..h);
    }

    /// How many rows above and below an output row its value reads (the
    /// defocus blur's radius plus the motion smear's vertical reach) for a
    /// frame that moved by `motion_px`: [`Webcam::apply_rows`] needs the
    /// input that far around the rows it writes.
    pub fn reach_rows(&self, motion_px: [f32; 2]) -> usize {
        if self.noop {
            return 0;
        }
        let mut taps = Vec::new();
        motion_taps(self.smear_px(motion_px), &mut taps);
        self.p.kernel.len() - 1 + tap_reach(&taps)[1]
    }

    /// The motion blur's smear (px) for a frame that moved by `motion_px`.
    fn smear_px(&self, motion_px: [f32; 2]) -> [f32; 2] {
        motion_px.map(|m| m * self.p.motion_blur)
    }

    /// [`Webcam::apply`] for output rows `rows` only, bit for bit what it
    /// writes there: the rows within [`Webcam::reach_rows`] of them must
    /// hold the frame's input, and rows outside `rows` are left as they
    /// were. (The read-back match's second pass redraws only the rows
    /// around the eyes of the frames its first pass drew.)
    ///
    /// Panics if the frame is not the size given to [`Webcam::new`] or
    /// `rows` reaches past it.
    pub fn apply_rows(
        &mut self,
        frame: &mut RgbImage,
        frame_index: u64,
        motion_px: [f32; 2],
        rows: std::ops::Range<usize>,
    ) {
        assert!(
            frame.width == self.p.width
                && frame.height == self.p.height
                && frame.data.len() == frame.width * frame.height * 3,
            "Webcam for {}x{} got a {}x{} frame of {} bytes",
            self.p.width,
            self.p.height,
            frame.width,
            frame.height,
            frame.data.len()
        );
        let (w, h) = (self.p.width, self.p.height);
        assert!(rows.end <= h, "rows {rows:?} of a {h}-row frame");
        if self.noop || w == 0 || rows.is_empty() {
            return;
        }
        motion_taps(self.smear_px(motion_px), &mut self.taps);
        let [mx, my] = tap_reach(&self.taps);
        let key = mix64(
            mix64(self.p.seed ^ 0x5745_4243_414D_0001)
                .wrapping_add(mix64(frame_index).wrapping_mul(GOLDEN)),
        );
        // Two bands per thread: balanced, and few halo rows recomputed.
        let w3 = w * 3;
        let (first, n) = (rows.start, rows.len());
        let band_rows = n.div_ceil((2 * rayon::current_num_threads()).clamp(1, n));
        let bands = n.div_ceil(band_rows);
        // Rows a band reads beyond each of its ends.
        let reach = self.p.kernel.len() - 1 + my;
        let halo_len = 2 * reach * w3;
        grow(&mut self.halo, bands * halo_len);
        if reach > 0 {
            let data = &frame.data;
            self.halo[..bands * halo_len]
                .par_chunks_mut(halo_len)
                .enumerate()
                .for_each(|(b, halo)| {
                    let y0 = first + b * band_rows;
                    let y1 = (y0 + band_rows).min(rows.end);
                    for k in 0..reach {
                        let above = (y0 + k).checked_sub(reach);
                        let below = Some(y1 + k).filter(|&y| y < h);
                        for (slot, y) in [(k, above), (reach + k, below)] {
                            if let Some(y) = y {
                                halo[slot * w3..(slot + 1) * w3]
                                    .copy_from_slice(&data[y * w3..(y + 1) * w3]);
                            }
                        }
                    }
                });
        }
        let job = Job {
            p: &self.p,
            taps: &self.taps,
            mx,
            my,
            reach,
            key,
        };
        let (pool, simd, halo) = (&self.pool, self.simd, &self.halo);
        frame.data[first * w3..rows.end * w3]
            .par_chunks_mut(band_rows * w3)
            .enumerate()
            .for_each(|(b, out)| {
                let halo = &halo[b * halo_len..(b + 1) * halo_len];
                let mut s = pool.lock().unwrap().pop().unwrap_or_default();
                let y0 = first + b * band_rows;
                let y1 = y0 + out.len() / w3;
                job.band(&mut s, out, halo, y0, y1, simd);
                pool.lock().unwrap().push(s);
            });
    }
}

/// How far `taps` reach, columns and rows (0 for none).
fn tap_reach(taps: &[Tap]) -> [usize; 2] {
    let most = |d: fn(&Tap) -> isize| taps.iter().map(|t| d(t).unsigned_abs()).max();
    [most(|t| t.dx).unwrap_or(0), most(|t| t.dy).unwrap_or(0)]
}

/// The motion smear `smear` (px) as merged integer taps: 2 |smear| (at
/// least 2) samples at the midpoints of equal parts of the segment centred
/// on 0, each spread bilinearly on the pixel grid; empty below 0.25 px.
fn motion_taps(smear: [f32; 2], taps: &mut Vec<Tap>) {
    taps.clear();
    let len = smear[0].hypot(smear[1]);
    // Also skips NaN and infinite motion.
    if !(len >= MIN_SMEAR_PX && len.is_finite()) {
        return;
    }
    let shorten = (MAX_SMEAR_PX / len).min(1.0);
    let (sx, sy) = (smear[0] * shorten, smear[1] * shorten);
    let n = ((2.0 * len * shorten).ceil() as usize).max(2);
    let wt = 1.0 / n as f32;
    for j in 0..n {
        let t = (j as f32 + 0.5) / n as f32 - 0.5;
        let (ox, oy) = (t * sx, t * sy);
        let (x0, y0) = (ox.floor(), oy.floor());
        let (fx, fy) = (ox - x0, oy - y0);
        for (dx, dy, w) in [
            (0, 0, (1.0 - fx) * (1.0 - fy)),
            (1, 0, fx * (1.0 - fy)),
            (0, 1, (1.0 - fx) * fy),
            (1, 1, fx * fy),
        ] {
            if w <= 0.0 {
                continue;
            }
            let (dx, dy) = (x0 as isize + dx, y0 as isize + dy);
            match taps.iter_mut().find(|t| t.dx == dx && t.dy == dy) {
                Some(t) => t.w += w * wt,
                None => taps.push(Tap { dx, dy, w: w * wt }),
            }
        }
    }
}

/// What the bands of one frame share.
struct Job<'a> {
    p: &'a Params,
    taps: &'a [Tap],
    mx: usize,
    my: usize,
    /// Rows a band reads beyond each of its ends.
    reach: usize,
    key: u64,
}

impl Job<'_> {
    /// One band: `out` holds its rows `y0..y1` (input, overwritten with
    /// the output), `halo` the `reach` input rows above and below it.
    fn band(&self, s: &mut Scratch, out: &mut [u8], halo: &[u8], y0: usize, y1: usize, simd: Simd) {
        match simd {
            #[cfg(target_arch = "x86_64")]
            // SAFETY: never wider than `Simd::detect` found (`limit_simd`
            // only narrows): AVX-512 (F, BW, VL, DQ) is on this CPU.
            Simd::Avx512 => unsafe { self.band_avx512(s, out, halo, y0, y1) },
            #[cfg(target_arch = "x86_64")]
            // SAFETY: as above, AVX2 and FMA are on this CPU.
            Simd::Avx2 => unsafe { self.band_avx2(s, out, halo, y0, y1) },
            _ => self.band_impl(s, out, halo, y0, y1),
        }
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f,avx512bw,avx512vl,avx512dq,avx2,fma")]
    unsafe fn band_avx512(
        &self,
        s: &mut Scratch,
        out: &mut [u8],
        halo: &[u8],
        y0: usize,
        y1: usize,
    ) {
        self.band_impl(s, out, halo, y0, y1);
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn band_avx2(&self, s: &mut Scratch, out: &mut [u8], halo: &[u8], y0: usize, y1: usize) {
        self.band_impl(s, out, halo, y0, y1);
    }

    /// Rows `y0..y1` into `out`: each output row needs the vertically
    /// blurred rows within the smear, each of those the horizontally
    /// blurred rows within the gaussian radius; both are computed once, in
    /// order, into rings (a row's ring slot is its index modulo the ring
    /// size, and the rings are just long enough that every row still needed
    /// is in them, edge rows included). Input row y is read before output
    /// row y - reach is written, so the band is processed in place.
    #[inline(always)]
    fn band_impl(&self, s: &mut Scratch, out: &mut [u8], halo: &[u8], y0: usize, y1: usize) {
        let p = self.p;
        let (w, h) = (p.width, p.height);
        let w3 = w * 3;
        let r = p.kernel.len() - 1;
        let motion = !self.taps.is_empty();
        let (mx, my) = (self.mx, self.my);
        let h_len = 2 * r + 1;
        let v_len = 2 * my + 1;
        let vw3 = (w + 2 * mx) * 3;
        grow(&mut s.lin, (w + 2 * r) * 3);
        grow(&mut s.h_ring, h_len * w3);
        if motion {
            grow(&mut s.v_ring, v_len * vw3);
        }
        grow(&mut s.row, w3);
        grow(&mut s.std, w3);
        let Scratch {
            lin,
            h_ring,
            v_ring,
            row,
            std,
        } = s;
        let row = &mut row[..w3];
        let last = h - 1;
        let clamp = |y: usize, k: isize| (y as isize + k).clamp(0, last as isize) as usize;
        let v_first = if motion { y0.saturating_sub(my) } else { y0 };
        let mut h_next = v_first.saturating_sub(r);
        let mut v_next = v_first;
        for y in y0..y1 {
            let v_need = if motion { (y + my).min(last) } else { y };
            while v_next <= v_need {
                let yv = v_next;
                while h_next <= (yv + r).min(last) {
                    let yh = h_next;
                    let src = if yh < y0 {
                        &halo[(yh + self.reach - y0) * w3..][..w3]
                    } else if yh < y1 {
                        &out[(yh - y0) * w3..][..w3]
                    } else {
                        &halo[(self.reach + yh - y1) * w3..][..w3]
                    };
                    let o = (yh % h_len) * w3;
                    self.h_row(yh, src, lin, &mut h_ring[o..o + w3]);
                    h_next += 1;
                }
                let dst = if motion {
                    let o = (yv % v_len) * vw3 + mx * 3;
                    &mut v_ring[o..o + w3]
                } else {
                    &mut row[..]
                };
                let h_ring = &h_ring[..];
                blur_rows(&p.kernel, dst, |k| {
                    let o = (clamp(yv, k) % h_len) * w3;
                    &h_ring[o..o + w3]
                });
                if motion {
                    let o = (yv % v_len) * vw3;
                    pad_row(&mut v_ring[o..o + vw3], mx);
                }
                v_next += 1;
            }
            if motion {
                for (i, t) in self.taps.iter().enumerate() {
                    let o = (clamp(y, t.dy) % v_len) * vw3 + (mx as isize + t.dx) as usize * 3;
                    let src = &v_ring[o..o + w3];
                    if i == 0 {
                        for (d, &v) in row.iter_mut().zip(src) {
                            *d = t.w * v;
                        }
                    } else {
                        for (d, &v) in row.iter_mut().zip(src) {
                            *d = t.w.mul_add(v, *d);
                        }
                    }
                }
            }
            let o = (y - y0) * w3;
            self.encode_row(row, &mut std[..w3], &mut out[o..o + w3], y);
        }
    }

    /// Row `y` decoded to linear light, times the vignetting, side light,
    /// exposure and white balance gains, blurred horizontally into `dst`.
    #[inline(always)]
    fn h_row(&self, y: usize, src: &[u8], lin: &mut [f32], dst: &mut [f32]) {
        let p = self.p;
        let w = p.width;
        let w3 = w * 3;
        let r = p.kernel.len() - 1;
        let lin = &mut lin[..(w + 2 * r) * 3];
        let body = &mut lin[r * 3..r * 3 + w3];
        for (o, &s) in body.iter_mut().zip(src) {
            *o = p.decode[s as usize];
        }
        if p.spatial {
            // Per pixel: v = (1 + k r^2)^-2, the cos^4 law; gain_c =
            // v (gain_c + d light_c), d the position along the light;
            // never negative.
            let (k, ry, dy) = (p.vignette_k, p.row_r2[y], p.row_d[y]);
            let (g, l) = (p.gain, p.light);
            for ((o, &rx), &dx) in body.chunks_exact_mut(3).zip(&p.col_r2).zip(&p.col_d) {
                let t = 1.0 / (1.0 + k * (rx + ry));
                let (v, d) = (t * t, dx + dy);
                o[0] *= (v * d.mul_add(l[0], g[0])).max(0.0);
                o[1] *= (v * d.mul_add(l[1], g[1])).max(0.0);
                o[2] *= (v * d.mul_add(l[2], g[2])).max(0.0);
            }
        } else if p.gain != [1.0; 3] {
            let g = p.gain;
            for o in body.chunks_exact_mut(3) {
                o[0] *= g[0];
                o[1] *= g[1];
                o[2] *= g[2];
            }
        }
        pad_row(lin, r);
        if r == 0 {
            dst.copy_from_slice(&lin[..w3]);
            return;
        }
        blur_rows(&p.kernel, dst, |k| {
            let o = (r as isize + k) as usize * 3;
            &lin[o..o + w3]
        });
    }

    /// A finished linear row to sRGB bytes plus noise (one pass that
    /// vectorizes: no table lookups).
    #[inline(always)]
    fn encode_row(&self, row: &mut [f32], std: &mut [f32], out: &mut [u8], y: usize) {
        let p = self.p;
        if p.noise {
            // Two passes: each has short enough dependency chains and few
            // enough live constants to keep many values in flight.
            let c = p.noise_std;
            for (v, sd) in row.iter_mut().zip(std.iter_mut()) {
                let l = unit(*v);
                let s = l.sqrt();
                let s2 = s * s;
                *sd = s2.mul_add(
                    s2.mul_add(c[4], s.mul_add(c[3], c[2])),
                    s.mul_add(c[1], c[0]),
                );
                *v = encode_f32(l, s);
            }
            let (k1, k2) = (self.key as u32, (self.key >> 32) as u32);
            // Index of the row's first value (wrapping: frames of up to 2^32
            // values get distinct noise per value).
            let i0 = (y * p.width * 3) as u32;
            for (j, ((o, &code), &sd)) in out.iter_mut().zip(row.iter()).zip(std.iter()).enumerate()
            {
                let z = noise_at(i0.wrapping_add(j as u32), k1, k2);
                *o = to_byte(sd.mul_add(z, code));
            }
        } else {
            for (o, &v) in out.iter_mut().zip(row.iter()) {
                let l = unit(v);
                *o = to_byte(encode_f32(l, l.sqrt()));
            }
        }
    }
}

/// `dst = k[0] row(0) + sum_j k[j] (row(-j) + row(j))`: a symmetric
/// kernel over whole rows (vectorizes along the row), up to three tap
/// pairs per pass over `dst` to save its loads and stores.
#[inline(always)]
fn blur_rows<'a>(k: &[f32], dst: &mut [f32], row: impl Fn(isize) -> &'a [f32]) {
    let r = k.len() - 1;
    let pair = |j: usize| (row(-(j as isize)), row(j as isize));
    let c = row(0);
    match r {
        0 => {
            for (d, &v) in dst.iter_mut().zip(c) {
                *d = k[0] * v;
            }
        }
        1 => {
            let (a, b) = pair(1);
            for (((d, &v), &a), &b) in dst.iter_mut().zip(c).zip(a).zip(b) {
                *d = k[1].mul_add(a + b, k[0] * v);
            }
        }
        _ => {
            let ((a1, b1), (a2, b2)) = (pair(1), pair(2));
            for (((((d, &v), &a1), &b1), &a2), &b2) in
                dst.iter_mut().zip(c).zip(a1).zip(b1).zip(a2).zip(b2)
            {
                *d = k[2].mul_add(a2 + b2, k[1].mul_add(a1 + b1, k[0] * v));
            }
        }
    }
    let mut j = 3;
    while j <= r {
        match r + 1 - j {
            1 => {
                let (a, b) = pair(j);
                for ((d, &a), &b) in dst.iter_mut().zip(a).zip(b) {
                    *d = k[j].mul_add(a + b, *d);
                }
            }
            2 => {
                let ((a1, b1), (a2, b2)) = (pair(j), pair(j + 1));
                for ((((d, &a1), &b1), &a2), &b2) in dst.iter_mut().zip(a1).zip(b1).zip(a2).zip(b2)
                {
                    *d = k[j + 1].mul_add(a2 + b2, k[j].mul_add(a1 + b1, *d));
                }
            }
            _ => {
                let ((a1, b1), (a2, b2), (a3, b3)) = (pair(j), pair(j + 1), pair(j + 2));
                for ((((((d, &a1), &b1), &a2), &b2), &a3), &b3) in dst
                    .iter_mut()
                    .zip(a1)
                    .zip(b1)
                    .zip(a2)
                    .zip(b2)
                    .zip(a3)
                    .zip(b3)
                {
                    let acc = k[j].mul_add(a1 + b1, *d);
                    *d = k[j + 2].mul_add(a3 + b3, k[j + 1].mul_add(a2 + b2, acc));
                }
            }
        }
        j += 3;
    }
}

/// Replicates the first and last pixel of an RGB row into its `pad` pixels
/// each side.
#[inline(always)]
fn pad_row(row: &mut [f32], pad: usize) {
    if pad == 0 {
        return;
    }
    let n = row.len();
    let (first, last) = (pad * 3, n - pad * 3 - 3);
    for i in 0..pad {
        row.copy_within(first..first + 3, i * 3);
        row.copy_within(last..last + 3, n - (i + 1) * 3);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use eyereplay_core::color::linear_to_srgb;

    /// The eyes' light comes from where the frame's gradient does:
    /// azimuth 0 from above, +90 from the image's right, 45 deg off the
    /// camera axis, unit length.
    #[test]
    fn light_direction_follows_the_azimuth() {
        let mut l = WebcamLook::identity();
        let s = std::f64::consts::FRAC_1_SQRT_2;
        for (az, want) in [
            (0.0, [0.0, s, s]),
            (90.0, [s, 0.0, s]),
            (-90.0, [-s, 0.0, s]),
        ] {
            l.light_azimuth_deg = az;
            let d = l.light_dir_head();
            for k in 0..3 {
                assert!((d[k] - want[k]).abs() < 1e-12, "{az}: {d:?}");
            }
        }
    }

    /// The identity look with some fields changed.
    fn look_with(f: impl FnOnce(&mut WebcamLook)) -> WebcamLook {
        let mut l = WebcamLook::identity();
        f(&mut l);
        l
    }

    fn applied(look: &WebcamLook, frame: &RgbImage, index: u64, motion: [f32; 2]) -> RgbImage {
        let mut out = frame.clone();
        Webcam::new(look, frame.width, frame.height).apply(&mut out, index, motion);
        out
    }

    /// A deterministic frame of hashed colours.
    fn noise_frame(w: usize, h: usize) -> RgbImage {
        let mut f = RgbImage::filled(w, h, [0, 0, 0]);
        for (i, v) in f.data.iter_mut().enumerate() {
            *v = (mix64(i as u64) >> 56) as u8;
        }
        f
    }

    fn lin(code: u8) -> f64 {
        srgb_to_linear(code as f64)
    }

    fn mean_std(v: impl Iterator<Item = f64> + Clone) -> (f64, f64) {
        let n = v.clone().count() as f64;
        let m = v.clone().sum::<f64>() / n;
        let var = v.map(|x| (x - m) * (x - m)).sum::<f64>() / n;
        (m, var.sqrt())
    }

    #[test]
    fn identity_is_a_no_op() {
        let f = noise_frame(67, 43);
        let id = WebcamLook::identity();
        assert_eq!(applied(&id, &f, 5, [7.0, -3.0]), f);
        assert_eq!(id.white_balance_gains(), [1.0; 3]);
    }

    #[test]
    fn code_values_survive_decode_and_encode() {
        // Every stage active but doing nothing (motion blur set, no
        // motion): the frame goes through the tables and must come back.
        let f = noise_frame(64, 48);
        let l = look_with(|l| l.motion_blur = 1.0);
        assert_eq!(applied(&l, &f, 0, [0.0, 0.0]), f);
        // A smear below 0.25 px is skipped.
        assert_eq!(applied(&l, &f, 0, [0.2, 0.1]), f);
        let cam = Webcam::new(&l, 1, 1);
        for c in 0..=255u8 {
            assert_eq!(
                to_byte(encode_f32(
                    cam.p.decode[c as usize],
                    cam.p.decode[c as usize].sqrt()
                )),
                c
            );
        }
        // The polynomial against the exact curve.
        for i in 0..=100_000 {
            let l = i as f32 / 100_000.0;
            let err = encode_f32(l, l.sqrt()) as f64 - linear_to_srgb(l as f64);
            assert!(err.abs() < 0.05, "{l}: {err}");
        }
    }

    #[test]
    fn plus_one_ev_doubles_linear_light() {
        for code in [40u8, 100, 150, 180] {
            let f = RgbImage::filled(16, 8, [code; 3]);
            let out = applied(&look_with(|l| l.exposure_ev = 1.0), &f, 0, [0.0; 2]);
            let want = linear_to_srgb(2.0 * lin(code));
            for &v in &out.data {
                assert!((v as f64 - want).abs() <= 1.0, "{code}: {v} vs {want}");
            }
        }
    }

    #[test]
    fn planckian_locus_matches_cie_tables() {
        // Blackbody chromaticities from the CIE tables (Wyszecki & Stiles).
        for (t, x, y) in [
            (2856.0, 0.4476, 0.4074),
            (4000.0, 0.3805, 0.3768),
            (6500.0, 0.3135, 0.3237),
        ] {
            let [px, py] = planckian_xy(t);
            assert!(
                (px - x).abs() < 1e-3 && (py - y).abs() < 1e-3,
                "{t}: {px} {py}"
            );
        }
    }

    #[test]
    fn white_balance_gains() {
        let g = look_with(|l| l.white_balance_k = 6500.0).white_balance_gains();
        for v in g {
            assert!((v - 1.0).abs() < 1e-3, "{g:?}");
        }
        // A camera that assumes a warmer (lower K) light than the scene's
        // boosts blue against red; a colder one the opposite.
        let warm = look_with(|l| l.white_balance_k = 4200.0).white_balance_gains();
        let cold = look_with(|l| l.white_balance_k = 7500.0).white_balance_gains();
        assert!(warm[2] / warm[0] > 1.1, "{warm:?}");
        assert!(cold[2] / cold[0] < 0.95, "{cold:?}");
        assert_eq!(warm[1], 1.0);
        // The light's tint: white at 6500 K, reddish at 3000 K, luminance 1.
        let t = look_with(|l| l.light_temperature_k = 6500.0).light_tint();
        assert!(t.iter().all(|v| (v - 1.0).abs() < 1e-3), "{t:?}");
        let t = look_with(|l| l.light_temperature_k = 3000.0).light_tint();
        assert!(t[0] > 1.3 && t[2] < 0.5, "{t:?}");
        let y = 0.2126 * t[0] + 0.7152 * t[1] + 0.0722 * t[2];
        assert!((y - 1.0).abs() < 1e-5);
    }

    #[test]
    fn read_noise_has_the_given_std_and_no_bias() {
        let f = RgbImage::filled(256, 256, [128; 3]);
        for sigma in [1.5, 3.0, 6.0] {
            let out = applied(&look_with(|l| l.noise_sigma = sigma), &f, 3, [0.0; 2]);
            let d = out.data.iter().map(|&v| v as f64 - 128.0);
            let (m, s) = mean_std(d);
            assert!(m.abs() < 0.2, "sigma {sigma}: mean {m}");
            assert!((s / sigma - 1.0).abs() < 0.1, "sigma {sigma}: std {s}");
        }
    }

    #[test]
    fn shot_noise_grows_with_sqrt_of_linear_light() {
        let shot = 4.0;
        for code in [60u8, 200] {
            let f = RgbImage::filled(256, 128, [code; 3]);
            let out = applied(&look_with(|l| l.shot_noise = shot), &f, 9, [0.0; 2]);
            let (_, s) = mean_std(out.data.iter().map(|&v| v as f64));
            let want = shot * lin(code).sqrt();
            assert!(
                (s / want - 1.0).abs() < 0.1,
                "code {code}: std {s} vs {want}"
            );
        }
    }

    #[test]
    fn noise_differs_per_frame_and_repeats_per_index() {
        let f = RgbImage::filled(64, 64, [100; 3]);
        let l = look_with(|l| l.noise_sigma = 3.0);
        let a = applied(&l, &f, 1, [0.0; 2]);
        assert_eq!(a, applied(&l, &f, 1, [0.0; 2]));
        let b = applied(&l, &f, 2, [0.0; 2]);
        let same = a.data.iter().zip(&b.data).filter(|(x, y)| x == y).count();
        // Two independent draws of std 3 agree (after rounding) ~10 % of the time.
        assert!(same < a.data.len() / 4, "{same} of {}", a.data.len());
        let c = applied(
            &look_with(|l| l.noise_sigma = 3.0 + 0.0 * l.vignetting),
            &f,
            1,
            [0.0; 2],
        );
        assert_eq!(a, c);
        let mut other_seed = l.clone();
        other_seed.seed = 1;
        assert_ne!(a, applied(&other_seed, &f, 1, [0.0; 2]));
    }

    /// The 10-90 % rise width of a row crossing from dark to bright, in
    /// linear light (where the blur is a plain convolution: a step blurred
    /// by a gaussian of std s is the normal CDF, 10-90 % in 2.563 s).
    fn rise_width(row: &[f64]) -> f64 {
        let (lo, hi) = (row[0], row[row.len() - 1]);
        let cross = |frac: f64| {
            let t = lo + frac * (hi - lo);
            let i = row.windows(2).position(|p| p[0] < t && p[1] >= t).unwrap();
            i as f64 + (t - row[i]) / (row[i + 1] - row[i])
        };
        cross(0.9) - cross(0.1)
    }

    #[test]
    fn defocus_rise_width_is_2_563_sigma() {
        // sigma in px of a 480-row frame: at 240 rows it is half as wide.
        for (h, sigma_480, sigma_px) in [(480, 2.0, 2.0), (480, 1.2, 1.2), (240, 4.0, 2.0)] {
            let w = 64;
            let mut f = RgbImage::filled(w, h, [0; 3]);
            for y in 0..h {
                for x in w / 2..w {
                    f.data[(y * w + x) * 3..(y * w + x) * 3 + 3].fill(255);
                }
            }
            let out = applied(
                &look_with(|l| l.defocus_sigma_px = sigma_480),
                &f,
                0,
                [0.0; 2],
            );
            // Vertical edge: every row alike (edges replicated).
            let row: Vec<f64> = (0..w).map(|x| lin(out.pixel(x, h / 2)[1])).collect();
            let width = rise_width(&row);
            let want = 2.563 * sigma_px;
            assert!(
                (width / want - 1.0).abs() < 0.15,
                "h {h}: {width} vs {want}"
            );
            assert_eq!(out.pixel(0, 0), [0; 3]);
            assert_eq!(out.pixel(w - 1, h - 1), [255; 3]);
        }
    }

    #[test]
    fn blur_preserves_brightness() {
        // Bright squares on a flat background, all far from the borders:
        // the mean linear light over the frame must not change.
        let (w, h) = (128, 128);
        let mut f = RgbImage::filled(w, h, [60; 3]);
        for y in 0..h {
            for x in 0..w {
                if (24..104).contains(&x) && (24..104).contains(&y) && (x / 8 + y / 8) % 3 == 0 {
                    f.data[(y * w + x) * 3..(y * w + x) * 3 + 3].copy_from_slice(&[220, 180, 90]);
                }
            }
        }
        let sigma = 1.5 * 480.0 / h as f64;
        let cases = [
            look_with(|l| l.defocus_sigma_px = sigma),
            look_with(|l| l.motion_blur = 0.5),
            look_with(|l| {
                l.defocus_sigma_px = sigma;
                l.motion_blur = 0.5
            }),
        ];
        for l in &cases {
            let out = applied(l, &f, 0, [9.0, -5.0]);
            for c in 0..3 {
                let m = |img: &RgbImage| {
                    let v = img
                        .data
                        .iter()
                        .skip(c)
                        .step_by(3)
                        .map(|&v| lin(v))
                        .sum::<f64>();
                    linear_to_srgb(v / (w * h) as f64)
                };
                let (a, b) = (m(&f), m(&out));
                assert!((a - b).abs() < 0.5, "{l:?} channel {c}: {a} vs {b}");
            }
        }
    }

    #[test]
    fn motion_blur_smears_along_the_motion_only() {
        let (w, h) = (64, 64);
        let mut f = RgbImage::filled(w, h, [0; 3]);
        let at = (32 * w + 32) * 3;
        f.data[at..at + 3].fill(255);
        let l = look_with(|l| l.motion_blur = 0.5);
        for motion in [[12.0f32, 0.0], [0.0, -12.0], [8.0, 0.0]] {
            let smear = 0.5 * (motion[0].abs() + motion[1].abs()) as f64;
            let out = applied(&l, &f, 0, motion);
            let along = |i: usize| {
                if motion[0] != 0.0 {
                    lin(out.pixel(i, 32)[0])
                } else {
                    lin(out.pixel(32, i)[0])
                }
            };
            let across = |i: usize| {
                if motion[0] != 0.0 {
                    (0..w).map(|x| out.pixel(x, i)[0] as u32).sum::<u32>()
                } else {
                    (0..h).map(|y| out.pixel(i, y)[0] as u32).sum::<u32>()
                }
            };
            // All light stays on the pixel's row (column)...
            assert_eq!(across(31) + across(33), 0, "{motion:?}");
            let v: Vec<f64> = (0..64).map(along).collect();
            let total: f64 = v.iter().sum();
            assert!((total - 1.0).abs() < 0.03, "{motion:?}: {total}");
            // ... and spreads like a box as long as the smear: a box of
            // length L has variance L^2 / 12 (plus about 1/12 px^2 of
            // bilinear spread).
            let mean = v.iter().enumerate().map(|(i, x)| i as f64 * x).sum::<f64>() / total;
            let var = v
                .iter()
                .enumerate()
                .map(|(i, x)| (i as f64 - mean).powi(2) * x)
                .sum::<f64>()
                / total;
            let length = (12.0 * var).sqrt();
            assert!(
                (length / smear - 1.0).abs() < 0.15,
                "{motion:?}: {length} vs {smear}"
            );
            assert!((mean - 32.0).abs() < 0.1, "{motion:?}: centred at {mean}");
            let lit = v.iter().filter(|&&x| x > 0.0).count() as f64;
            assert!(
                lit >= smear && lit <= smear + 2.0,
                "{motion:?}: {lit} px lit"
            );
        }
    }

    #[test]
    fn vignetting_and_side_light_have_the_given_size() {
        let (w, h) = (160, 120);
        let f = RgbImage::filled(w, h, [200; 3]);
        let l0 = lin(200);
        let out = applied(&look_with(|l| l.vignetting = 0.3), &f, 0, [0.0; 2]);
        // Centre untouched, corners 30 % darker in linear light.
        assert_eq!(out.pixel(w / 2, h / 2), [200; 3]);
        for (x, y) in [(0, 0), (w - 1, 0), (0, h - 1), (w - 1, h - 1)] {
            let loss = 1.0 - lin(out.pixel(x, y)[1]) / l0;
            assert!((loss - 0.3).abs() < 0.01, "{x},{y}: {loss}");
        }
        // White light from the right: right edge 1 + s/2, left 1 - s/2.
        let s = 0.3;
        let out = applied(
            &look_with(|l| {
                l.light_strength = s;
                l.light_azimuth_deg = 90.0
            }),
            &f,
            0,
            [0.0; 2],
        );
        let right = lin(out.pixel(w - 1, 10)[1]) / l0;
        let left = lin(out.pixel(0, h - 10)[1]) / l0;
        assert!((right - (1.0 + s / 2.0)).abs() < 0.01, "{right}");
        assert!((left - (1.0 - s / 2.0)).abs() < 0.01, "{left}");
        // From the top (azimuth 0): top brighter, no left-right change.
        let out = applied(&look_with(|l| l.light_strength = s), &f, 0, [0.0; 2]);
        assert!(out.pixel(5, 0)[1] > out.pixel(5, h - 1)[1]);
        assert_eq!(out.pixel(0, 7), out.pixel(w - 1, 7));
        // A warm light reddens the side it comes from.
        let out = applied(
            &look_with(|l| {
                l.light_strength = s;
                l.light_temperature_k = 3000.0
            }),
            &f,
            0,
            [0.0; 2],
        );
        let (top, bottom) = (out.pixel(w / 2, 0), out.pixel(w / 2, h - 1));
        assert!(
            top[0] > top[2] + 5 && bottom[0] + 5 < bottom[2],
            "{top:?} {bottom:?}"
        );
    }

    #[test]
    fn output_does_not_depend_on_threads_or_simd() {
        let f = noise_frame(97, 61);
        let l = WebcamRanges::default().sample(3);
        let run = |threads: usize, simd: Simd| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            pool.install(|| {
                let mut cam = Webcam::new(&l, 97, 61);
                cam.limit_simd(simd);
                let mut a = f.clone();
                cam.apply(&mut a, 11, [5.0, -3.5]);
                let mut b = f.clone();
                cam.apply(&mut b, 11, [5.0, -3.5]);
                assert_eq!(a, b, "same webcam, same frame twice");
                a
            })
        };
        let best = Simd::detect();
        let one = run(1, best);
        assert_ne!(one, f);
        assert_eq!(one, run(2, best));
        assert_eq!(one, run(3, best));
        // Every narrower build this CPU can run gives the same bytes
        // (limiting to a wider one than the CPU has changes nothing).
        for simd in [Simd::Portable, Simd::Avx2, Simd::Avx512] {
            assert_eq!(one, run(2, simd), "{simd:?} against {best:?}");
        }
    }

    /// `apply_rows` writes the rows `apply` writes there, bit for bit,
    /// and leaves the others as they were; the rows it writes read no
    /// further than its reach: with the input beyond it spoiled they still
    /// come out the same, with the rows next to them spoiled they do not.
    #[test]
    fn rows_alone_are_the_whole_frames_rows() {
        let f = noise_frame(97, 61);
        let l = WebcamRanges::default().sample(3);
        let motion = [1.5, -4.0];
        let mut cam = Webcam::new(&l, 97, 61);
        let mut whole = f.clone();
        cam.apply(&mut whole, 11, motion);
        let reach = cam.reach_rows(motion);
        assert!(reach >= 2, "blur and smear reach {reach} rows");
        let row = |img: &RgbImage, y: usize| img.data[y * 97 * 3..(y + 1) * 97 * 3].to_vec();
        for rows in [0..61, 20..34, 0..5, 55..61, 30..31] {
            let mut part = f.clone();
            // Spoil the input out of reach.
            for y in (0..61).filter(|&y| y + reach < rows.start || y >= rows.end + reach) {
                part.data[y * 97 * 3..(y + 1) * 97 * 3].fill(7);
            }
            let spoiled = part.clone();
            cam.apply_rows(&mut part, 11, motion, rows.clone());
            for y in 0..61 {
                let want = if rows.contains(&y) {
                    row(&whole, y)
                } else {
                    row(&spoiled, y)
                };
                assert!(row(&part, y) == want, "rows {rows:?}: row {y}");
            }
        }
        // The rows next to them are read: spoiled, the output changes.
        let rows = 20..34;
        let mut part = f.clone();
        for y in [19, 34] {
            part.data[y * 97 * 3..(y + 1) * 97 * 3].fill(255);
        }
        cam.apply_rows(&mut part, 11, motion, rows.clone());
        assert!(rows.clone().any(|y| row(&part, y) != row(&whole, y)));
    }

    #[test]
    fn sample_stays_in_range_and_repeats() {
        let r = WebcamRanges::default();
        r.validate().unwrap();
        for seed in 0..200 {
            let l = r.sample(seed);
            assert_eq!(l.seed, seed);
            let v = [
                l.vfov_deg,
                l.exposure_ev,
                l.white_balance_k,
                l.noise_sigma,
                l.shot_noise,
                l.defocus_sigma_px,
                l.motion_blur,
                l.light_azimuth_deg,
                l.light_strength,
                l.light_temperature_k,
                l.vignetting,
                l.bitrate_kbps,
            ];
            for ((name, [lo, hi], _, _), x) in r.fields().iter().zip(v) {
                assert!(*lo <= x && x <= *hi, "{name}: {x}");
            }
            assert_eq!(l, r.sample(seed));
        }
        assert_ne!(r.sample(1), r.sample(2));
        // A collapsed range gives its value and leaves the others alone.
        let mut fixed = r.clone();
        fixed.noise_sigma = [2.0, 2.0];
        let (a, b) = (r.sample(5), fixed.sample(5));
        assert_eq!(b.noise_sigma, 2.0);
        assert_eq!((a.vfov_deg, a.bitrate_kbps), (b.vfov_deg, b.bitrate_kbps));
    }

    #[test]
    fn validate_names_the_bad_field() {
        let bad = |f: &dyn Fn(&mut WebcamRanges)| {
            let mut r = WebcamRanges::default();
            f(&mut r);
            r.validate().unwrap_err().to_string()
        };
        assert_eq!(
            bad(&|r| r.noise_sigma = [4.0, 2.0]),
            "render.webcam.noise_sigma: lo 4 > hi 2"
        );
        let e = bad(&|r| r.exposure_ev[1] = f64::NAN);
        assert!(e.starts_with("render.webcam.exposure_ev: hi NaN"), "{e}");
        let e = bad(&|r| r.vfov_deg = [30.0, 150.0]);
        assert!(e.starts_with("render.webcam.vfov_deg: hi 150"), "{e}");
        let e = bad(&|r| r.defocus_sigma_px[0] = -0.1);
        assert!(
            e.starts_with("render.webcam.defocus_sigma_px: lo -0.1"),
            "{e}"
        );
        let e = bad(&|r| r.motion_blur = [0.5, 1.5]);
        assert!(e.starts_with("render.webcam.motion_blur:"), "{e}");
        let e = bad(&|r| r.white_balance_k[0] = 1000.0);
        assert!(e.starts_with("render.webcam.white_balance_k:"), "{e}");
        let e = bad(&|r| r.light_temperature_k[1] = f64::INFINITY);
        assert!(e.starts_with("render.webcam.light_temperature_k:"), "{e}");
        let e = bad(&|r| r.bitrate_kbps = [10.0, 100.0]);
        assert!(e.starts_with("render.webcam.bitrate_kbps:"), "{e}");
        assert!(!e.contains('\n'));
    }

    #[test]
    fn bitrate_scales_with_the_square_root_of_pixels() {
        let l = look_with(|l| l.bitrate_kbps = 800.0);
        assert_eq!(l.bitrate_kbps_for(640, 480), 800);
        assert_eq!(l.bitrate_kbps_for(1280, 960), 1600);
        assert_eq!(
            l.bitrate_kbps_for(1280, 720),
            (800.0 * 3f64.sqrt()).round() as u32
        );
        assert_eq!(WebcamLook::identity().bitrate_kbps_for(1280, 720), 0);
    }

    #[test]
    fn noise_is_standard_normal_like() {
        let n = 1 << 20;
        let v: Vec<f64> = (0..n)
            .map(|i| noise_at(i, 0x1234_5678, 0x9ABC_DEF0) as f64)
            .collect();
        let (m, s) = mean_std(v.iter().copied());
        let kurt = v.iter().map(|x| ((x - m) / s).powi(4)).sum::<f64>() / n as f64;
        assert!(m.abs() < 0.005 && (s - 1.0).abs() < 0.005, "{m} {s}");
        assert!((kurt - 3.0).abs() < 0.05, "kurtosis {kurt}");
        // Two-sided tails of the standard normal: 4.55 % beyond 2, 0.27 %
        // beyond 3.
        for (t, want) in [(2.0, 0.0455), (3.0, 0.0027)] {
            let got = v.iter().filter(|x| x.abs() > t).count() as f64 / n as f64;
            assert!((got / want - 1.0).abs() < 0.15, "beyond {t}: {got}");
        }
        // Another key, another pattern.
        let same = (0..1000u32)
            .filter(|&i| noise_at(i, 0x1234_5678, 0x9ABC_DEF1) == v[i as usize] as f32)
            .count();
        assert!(same < 20, "{same}");
    }
}
