//! The eyeball alone, for renderers that place and light it themselves.
//!
//! The close-up renderer ([`Scene`](super::Scene)) knows its camera and
//! head, and precomputes per pixel what does not change as the eye turns.
//! The full-face mode moves the head every frame and draws the eye through
//! a face mesh's lid opening, so it needs the same eyeball as a plain
//! function of a ray: [`Eyeball::shade`]. Both go through the same cornea,
//! iris and sclera code ([`trace_cornea`], [`sclera_light`]) and the same
//! identity textures, so the eyes of both modes are the same eyes.

use super::eye_model::EyeModel;
use super::frame::EyeGeoF32;
use super::shade::{sclera_light, trace_cornea};
use super::textures::Textures;
use super::Side;
use crate::identity::Identity;
use crate::math::{f3, F3};

/// One identity's eyeball (both eyes share it), in the eye's own frame:
/// millimetres, origin at the eyeball centre, +z along the line of sight
/// out through the cornea, +x toward image right and +y toward image down
/// when the eye looks into the camera.
pub struct Eyeball {
    tex: Textures,
    geo: EyeGeoF32,
    light_rgb: F3,
    ambient: f32,
    pupil_radius_mm: f32,
}

impl Eyeball {
    /// The eyeball of `identity` (eye shape, iris and sclera textures, key
    /// light colour and ambient level, mean pupil).
    pub fn new(identity: &Identity) -> Eyeball {
        let m = EyeModel::new(&identity.eye, Side::Left);
        let t = identity.lighting.tint_rgb;
        Eyeball {
            tex: Textures::new(identity),
            geo: EyeGeoF32::of(&m),
            light_rgb: f3(t[0], t[1], t[2]) * identity.lighting.key_intensity,
            ambient: identity.lighting.ambient,
            pupil_radius_mm: identity.eye.pupil_radius_mm as f32,
        }
    }

    pub fn radius_mm(&self) -> f64 {
        self.geo.radius as f64
    }

    pub fn iris_radius_mm(&self) -> f64 {
        self.geo.iris_r as f64
    }

    /// Distance of the limbus plane (the visible iris's centre) in front of
    /// the eyeball centre.
    pub fn limbus_z_mm(&self) -> f64 {
        self.geo.limbus_z as f64
    }

    /// Linear RGB seen along the ray from `origin_mm` in unit direction
    /// `dir` (eye frame), lit from unit direction `light` (toward the light,
    /// eye frame), with the pupil at `pupil_scale` times its mean radius;
    /// `None` where the ray misses the eyeball. The origin should lie a few
    /// centimetres from the eye at most: the intersections are in f32.
    #[inline]
    pub fn shade(
        &self,
        origin_mm: [f32; 3],
        dir: [f32; 3],
        light: [f32; 3],
        pupil_scale: f32,
    ) -> Option<[f32; 3]> {
        let o = f3(origin_mm[0], origin_mm[1], origin_mm[2]);
        let d = f3(dir[0], dir[1], dir[2]);
        let l = f3(light[0], light[1], light[2]);
        let g = &self.geo;
        if let Some(c) = trace_cornea(
            &self.tex,
            self.light_rgb,
            self.ambient,
            g,
            self.pupil_radius_mm * pupil_scale,
            l,
            o,
            d,
        ) {
            return Some([c.x, c.y, c.z]);
        }
        let b = o.dot(d);
        let disc = b * b - (o.dot(o) - g.radius * g.radius);
        if disc <= 0.0 {
            return None;
        }
        let p = o + d * (-b - disc.sqrt());
        let n = p * (1.0 / g.radius);
        let (mul, add) = sclera_light(self.light_rgb, self.ambient, n, d, l);
        let c = self.tex.sclera_at(n.x, n.y).mulv(mul) + add;
        Some([c.x, c.y, c.z])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit(v: [f32; 3]) -> [f32; 3] {
        let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        [v[0] / n, v[1] / n, v[2] / n]
    }

    /// Looking straight down the line of sight hits the pupil (dark);
    /// a ray through the iris annulus shows iris colour; a ray that passes
    /// beside the ball misses; one that grazes the side hits the sclera
    /// (bright).
    #[test]
    fn rays_meet_what_the_geometry_says() {
        let id = Identity::reference();
        let eye = Eyeball::new(&id);
        // From above and to the side, so the corneal glint is off the rays
        // tested.
        let light = unit([0.5, -0.6, 0.6]);
        let from = |x: f32, y: f32| eye.shade([x, y, 30.0], [0.0, 0.0, -1.0], light, 1.0);
        let pupil = from(0.0, 0.0).unwrap();
        let lum = |c: [f32; 3]| 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2];
        assert!(lum(pupil) < 0.05, "pupil {pupil:?}");
        // Halfway between pupil and limbus: iris, brighter than the pupil
        // but darker than the sclera.
        let r_iris = eye.iris_radius_mm() as f32;
        let r_pupil = id.eye.pupil_radius_mm as f32;
        let iris = from(0.5 * (r_iris + r_pupil) * 0.8, 0.0).unwrap();
        let sclera = from(0.0, -(r_iris + 2.5)).unwrap();
        assert!(lum(iris) > lum(pupil));
        assert!(
            lum(sclera) > 2.0 * lum(iris),
            "sclera {sclera:?} iris {iris:?}"
        );
        let r = eye.radius_mm() as f32;
        assert!(from(r + 0.1, 0.0).is_none());
        assert!(from(0.0, r - 0.5).is_some());
        // An oblique ray through the cornea's centre of curvature is not
        // refracted and meets the iris plane 4.4 mm behind that centre at
        // 4.4 tan(10 deg) = 0.8 mm off axis: inside the pupil.
        let a = 10f32.to_radians();
        let c = eye.geo.cornea_z;
        let o = [30.0 * a.sin(), 0.0, c + 30.0 * a.cos()];
        let d = unit([-o[0], 0.0, c - o[2]]);
        assert!(lum(eye.shade(o, d, light, 1.0).unwrap()) < 0.05);
    }
}
