//! Seeded randomization of the face: iris, skin, eye shape, lids, lighting
//! and camera, so a dataset is not one face. Every field is plain data with
//! its unit in its name; the whole struct serializes to JSON for metadata.

use crate::math::srgb_to_linear;
use crate::rng::SplitMix64;
use serde::{Deserialize, Serialize};

/// Colour and texture of one iris (both eyes share it).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct IrisStyle {
    /// Name of the palette entry the colour was drawn from.
    pub palette: String,
    /// Stroma colour of the outer (ciliary) zone, linear RGB.
    pub outer_rgb: [f32; 3],
    /// Colour of the inner (pupillary) zone inside the collarette, linear RGB.
    pub inner_rgb: [f32; 3],
    /// Collarette radius as a fraction of the iris radius.
    pub collarette_frac: f32,
    /// Contrast of the radial fibres, 0..1.
    pub fibre_contrast: f32,
    /// Dark crypts per iris (Fuchs crypts), roughly.
    pub crypt_count: u32,
    /// Darkness of the limbal ring at the iris rim, 0..1.
    pub limbal_darkness: f32,
}

/// Geometry of the eyes and lids, in millimetres in the head frame.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct EyeShape {
    /// Distance between the two eyeball centres.
    pub ipd_mm: f64,
    pub eyeball_radius_mm: f64,
    /// Visible iris (limbus) radius.
    pub iris_radius_mm: f64,
    /// Corner-to-corner width of the lid opening (palpebral fissure).
    pub fissure_width_mm: f64,
    /// Upper-lid margin height above the corner line at primary gaze.
    pub upper_lid_mm: f64,
    /// Lower-lid margin depth below the corner line at primary gaze.
    pub lower_lid_mm: f64,
    /// Outer corner higher than the inner one by this angle.
    pub canthal_tilt_deg: f64,
    /// Where along the lid (0 inner corner, 1 outer) the upper lid peaks.
    pub upper_peak_frac: f64,
    /// How much the upper lid follows vertical iris motion (1 = fully).
    pub upper_lid_follow: f64,
    pub lower_lid_follow: f64,
    /// Height of the upper-lid crease above the lid margin.
    pub crease_mm: f64,
    pub lash_length_mm: f64,
    /// Upper lashes per eye.
    pub lash_count: u32,
    /// Brow centre height above the eye centre.
    pub brow_height_mm: f64,
    pub brow_thickness_mm: f64,
    /// Mean pupil radius and the relative amplitude of its slow variation.
    pub pupil_radius_mm: f64,
    pub pupil_variation: f64,
}

/// A key light plus ambient light.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Lighting {
    /// Direction of the key light seen from the face: azimuth toward image
    /// right, elevation upward, in degrees.
    pub key_azimuth_deg: f64,
    pub key_elevation_deg: f64,
    pub key_intensity: f32,
    pub ambient: f32,
    /// Colour of the light, linear RGB multiplier (warm or cool white).
    pub tint_rgb: [f32; 3],
}

/// The camera looks at the point between the eyes from `distance_mm`, with
/// small orbit angles. `field_width_mm` is the width covered at the eye plane.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CameraPose {
    pub distance_mm: f64,
    pub field_width_mm: f64,
    pub yaw_deg: f64,
    pub pitch_deg: f64,
    pub roll_deg: f64,
}

/// One synthetic person and recording set-up.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Identity {
    pub seed: u64,
    pub iris: IrisStyle,
    /// Base skin colour, linear RGB.
    pub skin_rgb: [f32; 3],
    /// Hair (lashes, brows) colour, linear RGB.
    pub hair_rgb: [f32; 3],
    pub eye: EyeShape,
    pub lighting: Lighting,
    pub camera: CameraPose,
    /// Natural blink rate used when blinks are generated.
    pub blink_rate_per_min: f64,
}

fn lin(rgb: [f32; 3]) -> [f32; 3] {
    [
        srgb_to_linear(rgb[0]),
        srgb_to_linear(rgb[1]),
        srgb_to_linear(rgb[2]),
    ]
}

fn jitter(r: &mut SplitMix64, c: [f32; 3], amount: f32) -> [f32; 3] {
    let k = 1.0 + r.f32r(-amount, amount);
    [
        (c[0] * k * (1.0 + r.f32r(-amount, amount) * 0.5)).clamp(0.0, 1.0),
        (c[1] * k * (1.0 + r.f32r(-amount, amount) * 0.5)).clamp(0.0, 1.0),
        (c[2] * k * (1.0 + r.f32r(-amount, amount) * 0.5)).clamp(0.0, 1.0),
    ]
}

impl Identity {
    /// The reference identity used by tests and the README: brown-green iris,
    /// medium skin, frontal camera.
    pub fn reference() -> Identity {
        Identity {
            seed: 0,
            iris: IrisStyle {
                palette: "hazel".into(),
                outer_rgb: lin([92.0, 80.0, 48.0]),
                inner_rgb: lin([112.0, 76.0, 38.0]),
                collarette_frac: 0.55,
                fibre_contrast: 0.55,
                crypt_count: 14,
                limbal_darkness: 0.7,
            },
            skin_rgb: lin([206.0, 160.0, 132.0]),
            hair_rgb: lin([40.0, 30.0, 24.0]),
            eye: EyeShape {
                ipd_mm: 63.0,
                eyeball_radius_mm: 12.0,
                iris_radius_mm: 5.9,
                fissure_width_mm: 28.5,
                upper_lid_mm: 4.7,
                lower_lid_mm: 5.0,
                canthal_tilt_deg: 4.0,
                upper_peak_frac: 0.42,
                upper_lid_follow: 0.7,
                lower_lid_follow: 0.25,
                crease_mm: 5.5,
                lash_length_mm: 7.5,
                lash_count: 90,
                brow_height_mm: 21.0,
                brow_thickness_mm: 7.0,
                pupil_radius_mm: 2.0,
                pupil_variation: 0.08,
            },
            lighting: Lighting {
                key_azimuth_deg: -25.0,
                key_elevation_deg: 30.0,
                key_intensity: 0.85,
                ambient: 0.32,
                tint_rgb: [1.0, 0.97, 0.92],
            },
            camera: CameraPose {
                distance_mm: 450.0,
                field_width_mm: 130.0,
                yaw_deg: 0.0,
                pitch_deg: 0.0,
                roll_deg: 0.0,
            },
            blink_rate_per_min: 15.0,
        }
    }

    /// A random identity, fully determined by `seed`.
    pub fn sample(seed: u64) -> Identity {
        let mut r = SplitMix64::new(seed.wrapping_mul(0x2545_F491_4F6C_DD1D) ^ 0x1D);
        // Iris palette: sRGB outer / inner colours observed in photos.
        const PALETTE: [(&str, [f32; 3], [f32; 3]); 7] = [
            ("dark brown", [52.0, 34.0, 22.0], [40.0, 26.0, 16.0]),
            ("brown", [96.0, 62.0, 36.0], [78.0, 48.0, 26.0]),
            ("hazel", [96.0, 84.0, 50.0], [124.0, 74.0, 32.0]),
            ("green", [86.0, 104.0, 72.0], [132.0, 100.0, 46.0]),
            ("blue", [92.0, 122.0, 150.0], [120.0, 128.0, 120.0]),
            ("grey", [118.0, 124.0, 126.0], [126.0, 116.0, 96.0]),
            ("amber", [150.0, 100.0, 40.0], [132.0, 84.0, 30.0]),
        ];
        // Brown eyes are the most common; weight the palette accordingly.
        const WEIGHTS: [f64; 7] = [0.28, 0.24, 0.14, 0.08, 0.14, 0.06, 0.06];
        let u = r.f64();
        let mut acc = 0.0;
        let mut pick = 0;
        for (i, w) in WEIGHTS.iter().enumerate() {
            acc += w;
            if u < acc {
                pick = i;
                break;
            }
        }
        let (name, outer, inner) = PALETTE[pick];
        let iris = IrisStyle {
            palette: name.into(),
            outer_rgb: jitter(&mut r, lin(outer), 0.15),
            // The pupillary zone differs from the stroma, but subtly.
            inner_rgb: jitter(
                &mut r,
                lin([0, 1, 2].map(|k| 0.5 * (outer[k] + inner[k]))),
                0.1,
            ),
            collarette_frac: r.f32r(0.5, 0.62),
            fibre_contrast: r.f32r(0.35, 0.7),
            crypt_count: 6 + r.below(18) as u32,
            limbal_darkness: r.f32r(0.45, 0.85),
        };
        // Skin: interpolate along a light-to-dark tone line (sRGB), jittered.
        const TONES: [[f32; 3]; 5] = [
            [236.0, 200.0, 178.0],
            [214.0, 170.0, 140.0],
            [190.0, 140.0, 106.0],
            [150.0, 102.0, 72.0],
            [96.0, 62.0, 44.0],
        ];
        let t = r.f64() * (TONES.len() - 1) as f64;
        let i0 = (t.floor() as usize).min(TONES.len() - 2);
        let f = (t - i0 as f64) as f32;
        let tone = [0, 1, 2].map(|k| TONES[i0][k] + (TONES[i0 + 1][k] - TONES[i0][k]) * f);
        let skin_rgb = jitter(&mut r, lin(tone), 0.05);
        let hair_l = r.f32r(12.0, 70.0);
        let hair_rgb = lin([hair_l * 1.1, hair_l * 0.85, hair_l * 0.7]);
        let eye = EyeShape {
            ipd_mm: r.range(58.0, 69.0),
            eyeball_radius_mm: r.range(11.7, 12.3),
            iris_radius_mm: r.range(5.6, 6.1),
            fissure_width_mm: r.range(26.5, 30.0),
            upper_lid_mm: r.range(4.0, 5.2),
            lower_lid_mm: r.range(4.5, 5.6),
            canthal_tilt_deg: r.range(-1.0, 8.0),
            upper_peak_frac: r.range(0.36, 0.5),
            upper_lid_follow: r.range(0.6, 0.8),
            lower_lid_follow: r.range(0.15, 0.35),
            crease_mm: r.range(3.5, 7.5),
            lash_length_mm: r.range(5.5, 9.0),
            lash_count: 70 + r.below(50) as u32,
            brow_height_mm: r.range(19.0, 24.0),
            brow_thickness_mm: r.range(5.0, 9.0),
            pupil_radius_mm: r.range(1.5, 2.3),
            pupil_variation: r.range(0.04, 0.12),
        };
        let warm = r.f32r(-1.0, 1.0);
        let lighting = Lighting {
            key_azimuth_deg: r.range(-40.0, 40.0),
            key_elevation_deg: r.range(10.0, 45.0),
            key_intensity: r.f32r(0.7, 1.0),
            ambient: r.f32r(0.22, 0.4),
            tint_rgb: [1.0 + 0.05 * warm, 1.0, 1.0 - 0.08 * warm],
        };
        let camera = CameraPose {
            distance_mm: r.range(380.0, 560.0),
            field_width_mm: r.range(118.0, 142.0),
            yaw_deg: r.range(-5.0, 5.0),
            pitch_deg: r.range(-4.0, 4.0),
            roll_deg: r.range(-3.0, 3.0),
        };
        Identity {
            seed,
            iris,
            skin_rgb,
            hair_rgb,
            eye,
            lighting,
            camera,
            blink_rate_per_min: r.range(8.0, 22.0),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    #[test]
    fn sample_is_deterministic_and_varies() {
        let a = Identity::sample(42);
        assert_eq!(a, Identity::sample(42));
        let b = Identity::sample(43);
        assert_ne!(a.eye.ipd_mm, b.eye.ipd_mm);
        let json = serde_json::to_string(&a).unwrap();
        let back: Identity = serde_json::from_str(&json).unwrap();
        assert_eq!(a, back);
        // Anatomically plausible ranges hold for many seeds.
        for s in 0..200 {
            let i = Identity::sample(s);
            assert!((58.0..=69.0).contains(&i.eye.ipd_mm));
            assert!(i.eye.fissure_width_mm > 2.0 * i.eye.iris_radius_mm + 10.0);
            assert!(i.camera.yaw_deg.abs() <= 5.0);
        }
    }
}
