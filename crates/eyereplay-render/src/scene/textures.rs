//! The eye's precomputed textures (iris and sclera) and how the shader
//! samples them.
//!
//! Both are generated once per identity from its seed, so the per-pixel
//! shader only fetches texels; generating them is most of the procedural
//! detail of the eye (fibres, crypts, collarette, vessels).

use crate::identity::Identity;
use crate::math::{f3, smoothstep, F3};
use crate::rng::{Noise2, SplitMix64};

/// Iris texture side, texels.
const IRIS_TEX: usize = 256;
/// Sclera texture side, texels.
const SCLERA_TEX: usize = 128;

/// An identity's eye textures, linear RGB, row-major squares.
pub(super) struct Textures {
    /// Iris colour over [-r, r]^2 of the iris plane, linear RGB.
    iris: Vec<F3>,
    /// Sclera colour over the eye's front hemisphere (x/R, y/R in [-1, 1]).
    sclera: Vec<F3>,
}

impl Textures {
    pub(super) fn new(id: &Identity) -> Textures {
        Textures {
            iris: iris_texture(id),
            sclera: sclera_texture(id),
        }
    }

    /// The iris at iris-plane point (u, v) in units of the iris radius
    /// (bilinear).
    #[inline(always)]
    pub(super) fn iris_at(&self, u: f32, v: f32) -> F3 {
        sample_bilinear(&self.iris, IRIS_TEX, u, v)
    }

    /// The sclera at unit-sphere coordinates (x, y) in the eye frame
    /// (nearest texel: one fetch, on every sclera pixel of every frame).
    #[inline(always)]
    pub(super) fn sclera_at(&self, x: f32, y: f32) -> F3 {
        sample_nearest(&self.sclera, SCLERA_TEX, x, y)
    }
}

/// Bilinear fetch from an `n` x `n` texture; u, v in [-1, 1].
#[inline(always)]
fn sample_bilinear(tex: &[F3], n: usize, u: f32, v: f32) -> F3 {
    // u, v in [-1, 1] map to texel centres across the texture.
    let fx = ((u + 1.0) * 0.5 * (n - 1) as f32).clamp(0.0, (n - 1) as f32 - 0.001);
    let fy = ((v + 1.0) * 0.5 * (n - 1) as f32).clamp(0.0, (n - 1) as f32 - 0.001);
    let (ix, iy) = (fx as usize, fy as usize);
    let (tx, ty) = (fx - ix as f32, fy - iy as f32);
    let i = iy * n + ix;
    let top = tex[i].lerp(tex[i + 1], tx);
    let bot = tex[i + n].lerp(tex[i + n + 1], tx);
    top.lerp(bot, ty)
}

/// Nearest-texel fetch from an `n` x `n` texture; u, v in [-1, 1].
#[inline(always)]
fn sample_nearest(tex: &[F3], n: usize, u: f32, v: f32) -> F3 {
    let ix = (((u + 1.0) * 0.5 * n as f32) as isize).clamp(0, n as isize - 1) as usize;
    let iy = (((v + 1.0) * 0.5 * n as f32) as isize).clamp(0, n as isize - 1) as usize;
    tex[iy * n + ix]
}

/// Iris: two-zone colour split at a wavy collarette, radial fibres, crypts,
/// concentric furrows and a dark limbal ring.
fn iris_texture(id: &Identity) -> Vec<F3> {
    let st = &id.iris;
    let n = IRIS_TEX;
    let fib = Noise2::new(id.seed ^ 0x1815);
    let fib2 = Noise2::new(id.seed ^ 0x1816);
    let mut rng = SplitMix64::new(id.seed ^ 0xC8F7);
    let crypts: Vec<(f32, f32, f32)> = (0..st.crypt_count)
        .map(|_| {
            (
                rng.f32r(0.0, 1.0),
                rng.f32r(st.collarette_frac + 0.05, 0.85),
                rng.f32r(0.02, 0.06),
            )
        })
        .collect();
    let outer = f3(st.outer_rgb[0], st.outer_rgb[1], st.outer_rgb[2]);
    let inner = f3(st.inner_rgb[0], st.inner_rgb[1], st.inner_rgb[2]);
    (0..n * n)
        .map(|i| {
            let u = (i % n) as f32 / (n - 1) as f32 * 2.0 - 1.0;
            let v = (i / n) as f32 / (n - 1) as f32 * 2.0 - 1.0;
            let rr = (u * u + v * v).sqrt();
            let a = v.atan2(u) / std::f32::consts::TAU + 0.5; // 0..1 around
                                                              // Periodic in `a`: blend two noise samples one period apart.
            let per = |nz: &Noise2, k: f32, y: f32, oct: u32| {
                (1.0 - a) * nz.fbm(a * k, y, oct) + a * nz.fbm((a - 1.0) * k, y, oct)
            };
            // Radial stroma fibres at two scales: thin streaks, broader bands.
            let fine = per(&fib, 150.0, rr * 5.0, 2);
            let fibres = per(&fib, 70.0, rr * 2.5, 3);
            let coarse = per(&fib2, 16.0, rr * 1.2, 3);
            let col_r = st.collarette_frac * (1.0 + 0.12 * per(&fib2, 9.0, 0.5, 2));
            let zone = smoothstep(col_r - 0.06, col_r + 0.06, rr + 0.05 * fibres);
            let mut c = inner.lerp(outer, zone);
            let streak = 0.35 * fine + 0.45 * fibres + 0.3 * coarse;
            c = c * (1.0 + st.fibre_contrast * 1.2 * streak);
            // Brighter fibre crests catch light (trabeculae).
            let crest = smoothstep(0.25, 0.6, fibres) * (1.0 - zone * 0.3);
            c = c + f3(0.035, 0.03, 0.022) * (crest * st.fibre_contrast);
            // Collarette: a raised, lighter, ragged ridge.
            let ring = (-((rr - col_r) / 0.03).powi(2)).exp();
            c = c * (1.0 + 0.25 * ring * (0.6 + 0.4 * fibres));
            // Crypts: radially elongated dark pits near the collarette.
            for &(ca, cr, sz) in &crypts {
                let mut da = (a - ca).abs();
                da = da.min(1.0 - da) * std::f32::consts::TAU * rr.max(0.1);
                let dr = (rr - cr) * 0.5;
                let q = (da * da + dr * dr) / (sz * sz);
                c = c * (1.0 - 0.5 * (-q).exp());
            }
            // Stroma thins and darkens toward the rim.
            c = c * (1.0 - 0.25 * smoothstep(0.6, 0.85, rr));
            // Limbal ring and the darker, shadowed rim.
            let limb = smoothstep(0.8, 0.98, rr) * st.limbal_darkness;
            c = c * (1.0 - limb);
            f3(c.x.max(0.0), c.y.max(0.0), c.z.max(0.0))
        })
        .collect()
}

/// Sclera: warm white, pinker toward the back, with thin red vessels that
/// thicken away from the cornea.
fn sclera_texture(id: &Identity) -> Vec<F3> {
    let n = SCLERA_TEX;
    let vein = Noise2::new(id.seed ^ 0x5C7E);
    let vein2 = Noise2::new(id.seed ^ 0x5C7F);
    let tint = Noise2::new(id.seed ^ 0x5C80);
    let limb = (id.eye.iris_radius_mm / id.eye.eyeball_radius_mm) as f32;
    (0..n * n)
        .map(|i| {
            let u = ((i % n) as f32 + 0.5) / n as f32 * 2.0 - 1.0;
            let v = ((i / n) as f32 + 0.5) / n as f32 * 2.0 - 1.0;
            let r = (u * u + v * v).sqrt();
            let base = f3(0.80, 0.74, 0.67);
            let pink = f3(0.72, 0.50, 0.44);
            let mut c = base.lerp(pink, smoothstep(0.7, 1.0, r) * 0.6);
            c = c * (1.0 + 0.03 * tint.fbm(u * 6.0, v * 6.0, 3));
            let density = smoothstep(limb + 0.08, 0.9, r);
            // Vessels: zero crossings of smooth noise give long thin lines.
            let a = (vein.fbm(u * 2.5, v * 2.5, 2)).abs();
            let b = (vein2.fbm(u * 5.0 + 3.0, v * 5.0, 2)).abs();
            let vessel = smoothstep(0.03, 0.0, a) * 0.35 + smoothstep(0.02, 0.0, b) * 0.2;
            c = c.lerp(f3(0.55, 0.12, 0.10), (vessel * density).min(0.85));
            // Bluish-grey ring at the limbus.
            let lr = (-((r - limb - 0.02) / 0.04).powi(2)).exp();
            c.lerp(f3(0.45, 0.47, 0.5), lr * 0.35)
        })
        .collect()
}
