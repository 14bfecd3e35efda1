//! Where things are relative to the eyes, in millimetres, and what that
//! makes of gaze in degrees and of the iris position `n` in the eye
//! aperture.
//!
//! Axes: the eyes at the origin, `x` to the person's right, `y` up, `z`
//! forward towards the camera, which sits straight ahead at `camera_mm`.
//! A point `(x, y, z)` is looked at with `yaw = atan2(x, z)` (right
//! positive) and `pitch = atan2(y, hypot(x, z))` (up positive).
//!
//! The eye model is the one eyereplay uses for every eye-tracker source
//! (`read.eye_gains`): `nx = 0.5 - nx_per_deg yaw`, `ny = 0.5 - ny_per_deg
//! pitch` for the eye's rotation in the head. The camera mirrors the scene,
//! so a rightward gaze moves the iris image-left (smaller `nx`), and a
//! downward gaze moves it down (larger `ny`), as `eyereplay extract` reads a
//! face.

use serde::{Deserialize, Serialize};

/// Gaze or eye rotation, degrees.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Angles {
    pub yaw_deg: f64,
    pub pitch_deg: f64,
}

impl Angles {
    pub fn new(yaw_deg: f64, pitch_deg: f64) -> Self {
        Angles { yaw_deg, pitch_deg }
    }

    /// Angular distance, deg (small-angle Euclidean).
    pub fn distance(self, o: Angles) -> f64 {
        (self.yaw_deg - o.yaw_deg).hypot(self.pitch_deg - o.pitch_deg)
    }

    pub fn plus(self, o: Angles) -> Angles {
        Angles::new(self.yaw_deg + o.yaw_deg, self.pitch_deg + o.pitch_deg)
    }

    pub fn minus(self, o: Angles) -> Angles {
        Angles::new(self.yaw_deg - o.yaw_deg, self.pitch_deg - o.pitch_deg)
    }

    pub fn scale(self, k: f64) -> Angles {
        Angles::new(self.yaw_deg * k, self.pitch_deg * k)
    }

    pub fn lerp(self, to: Angles, u: f64) -> Angles {
        self.plus(to.minus(self).scale(u))
    }
}

/// Gaze direction to a point `[x, y, z]` mm (eyes at the origin).
pub fn angles_to(p_mm: [f64; 3]) -> Angles {
    let [x, y, z] = p_mm;
    Angles::new(x.atan2(z).to_degrees(), y.atan2(x.hypot(z)).to_degrees())
}

/// The share of a gaze shift that the head takes, for a target
/// `eccentricity_deg` away from straight ahead: none up to 15 deg (the eyes
/// alone serve small shifts), then rising linearly to 0.7 at 45 deg and
/// beyond (Freedman & Sparks 1997; Freedman 2008). Used for where the head
/// points while a surface is read; the eyes do the rest.
pub fn head_share(eccentricity_deg: f64) -> f64 {
    let e = eccentricity_deg.abs();
    if e <= 15.0 {
        0.0
    } else {
        (0.7 * (e - 15.0) / 30.0).min(0.7)
    }
}

/// The head direction for gazing about `centre`: each axis takes its
/// [`head_share`] of the centre's angle.
pub fn head_towards(centre: Angles) -> Angles {
    Angles::new(
        centre.yaw_deg * head_share(centre.yaw_deg),
        centre.pitch_deg * head_share(centre.pitch_deg),
    )
}

/// Change of normalized iris position per degree of eye-in-head rotation
/// (`read.eye_gains`; defaults 0.0061 and 0.0092, docs/PIPELINE.md).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Gains {
    pub nx_per_deg: f64,
    pub ny_per_deg: f64,
}

impl Default for Gains {
    fn default() -> Self {
        Gains {
            nx_per_deg: 0.0061,
            ny_per_deg: 0.0092,
        }
    }
}

impl Gains {
    /// Iris position for an eye-in-head rotation.
    pub fn to_norm(&self, eye: Angles) -> [f64; 2] {
        [
            0.5 - self.nx_per_deg * eye.yaw_deg,
            0.5 - self.ny_per_deg * eye.pitch_deg,
        ]
    }
}

/// Where a text is read from. Every preset gives physical ranges a person
/// draws from; a config can override each.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Surface {
    /// A laptop screen under its webcam: text about 10 cm below the lens at
    /// arm's length.
    Laptop,
    /// A teleprompter (or a prompter window at the lens): short lines of
    /// large text that scroll, read at one height, centred on the camera.
    Teleprompter,
    /// A second monitor beside the one with the camera.
    MonitorSide,
    /// A printed sheet on the desk in front of the keyboard.
    DeskSheet,
}

impl Surface {
    pub const ALL: [Surface; 4] = [
        Surface::Laptop,
        Surface::Teleprompter,
        Surface::MonitorSide,
        Surface::DeskSheet,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Surface::Laptop => "laptop",
            Surface::Teleprompter => "teleprompter",
            Surface::MonitorSide => "monitor_side",
            Surface::DeskSheet => "desk_sheet",
        }
    }

    /// The preset's ranges.
    pub fn preset(self) -> SurfacePreset {
        match self {
            // 500-650 mm: arm's length; 13-14" laptops put the text centre
            // 80-150 mm under the lens; 11-13 pt text is 1.8-2.4 mm a
            // character.
            Surface::Laptop => SurfacePreset {
                distance_mm: [500.0, 650.0],
                offset_x_mm: [-30.0, 30.0],
                offset_y_mm: [-150.0, -80.0],
                char_width_mm: [1.8, 2.4],
                line_chars: [50.0, 80.0],
                lines_per_page: [10.0, 22.0],
                scroll: false,
            },
            // Prompter text is large and short-lined so it can be read
            // from a distance; it scrolls under a fixed reading line.
            Surface::Teleprompter => SurfacePreset {
                distance_mm: [700.0, 1500.0],
                offset_x_mm: [-10.0, 10.0],
                offset_y_mm: [-30.0, 10.0],
                char_width_mm: [4.0, 7.0],
                line_chars: [22.0, 40.0],
                lines_per_page: [1.0, 1.0],
                scroll: true,
            },
            // A second 24" monitor next to the main one: its centre 35-50
            // cm to one side (the side is drawn per person).
            Surface::MonitorSide => SurfacePreset {
                distance_mm: [600.0, 750.0],
                offset_x_mm: [350.0, 500.0],
                offset_y_mm: [-80.0, 0.0],
                char_width_mm: [2.0, 2.8],
                line_chars: [60.0, 90.0],
                lines_per_page: [12.0, 25.0],
                scroll: false,
            },
            // A sheet flat on the desk: 30-40 cm below the eyes, 35-45 cm
            // forward; 11-12 pt print.
            Surface::DeskSheet => SurfacePreset {
                distance_mm: [350.0, 450.0],
                offset_x_mm: [-40.0, 40.0],
                offset_y_mm: [-400.0, -300.0],
                char_width_mm: [1.9, 2.4],
                line_chars: [60.0, 80.0],
                lines_per_page: [15.0, 30.0],
                scroll: false,
            },
        }
    }
}

/// A surface's physical ranges.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct SurfacePreset {
    /// Forward distance of the text centre from the eyes, mm.
    pub distance_mm: [f64; 2],
    /// Text centre to the right of the camera axis, mm (a side monitor's
    /// side is drawn per person).
    pub offset_x_mm: [f64; 2],
    /// Text centre above the eyes (negative: below), mm.
    pub offset_y_mm: [f64; 2],
    /// Advance width of one character, mm.
    pub char_width_mm: [f64; 2],
    pub line_chars: [f64; 2],
    pub lines_per_page: [f64; 2],
    /// Lines scroll under a fixed reading line (a teleprompter).
    pub scroll: bool,
}

/// A text laid out on a surface: where character `k` of line `l` is.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct TextPlane {
    pub surface: Surface,
    /// Centre of the text block, mm from the eyes.
    pub centre_mm: [f64; 3],
    pub char_width_mm: f64,
    /// Baseline to baseline, mm.
    pub line_pitch_mm: f64,
    pub line_chars: usize,
    pub lines_per_page: usize,
    pub scroll: bool,
}

impl TextPlane {
    /// Gaze direction to character position `char_pos` (may be fractional)
    /// of line `line` of the page. A desk sheet lies flat: lines further
    /// down the page are nearer the reader; every other surface faces the
    /// reader upright.
    pub fn gaze_to(&self, line: usize, char_pos: f64) -> Angles {
        let [cx, cy, cz] = self.centre_mm;
        let row = if self.scroll {
            0.0
        } else {
            line as f64 - (self.lines_per_page as f64 - 1.0) / 2.0
        };
        let x = cx + (char_pos - self.line_chars as f64 / 2.0) * self.char_width_mm;
        let down = row * self.line_pitch_mm;
        let p = match self.surface {
            // A sheet never reaches behind the eyes, however close it lies.
            Surface::DeskSheet => [x, cy, (cz - down).max(50.0)],
            _ => [x, cy - down, cz],
        };
        angles_to(p)
    }

    /// Visual angle of one character at the text centre, deg.
    pub fn deg_per_char(&self) -> f64 {
        let d = self.centre_mm.iter().map(|v| v * v).sum::<f64>().sqrt();
        (self.char_width_mm / d).atan().to_degrees()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn return_sweep_angle_by_hand() {
        // A 20 cm line at 60 cm spans 2 atan(10/60) = 18.92 deg (the
        // behaviour study's worked value).
        let plane = TextPlane {
            surface: Surface::Laptop,
            centre_mm: [0.0, 0.0, 600.0],
            char_width_mm: 2.5,
            line_pitch_mm: 5.0,
            line_chars: 80,
            lines_per_page: 1,
            scroll: false,
        };
        let a = plane.gaze_to(0, 0.0);
        let b = plane.gaze_to(0, 80.0);
        assert!((b.yaw_deg - a.yaw_deg - 18.92).abs() < 0.01, "{a:?} {b:?}");
        assert!(a.pitch_deg.abs() < 1e-12);
    }

    #[test]
    fn laptop_text_below_the_lens_looks_down_and_the_iris_moves_down() {
        let a = angles_to([0.0, -100.0, 550.0]);
        // atan(100 / 550) = 10.30 deg down (the study's 10.3 deg).
        assert!((a.pitch_deg + 10.30).abs() < 0.01);
        let n = Gains::default().to_norm(a);
        assert!(n[1] > 0.5 && (n[0] - 0.5).abs() < 1e-12);
        // Rightward gaze moves the iris image-left.
        assert!(Gains::default().to_norm(Angles::new(10.0, 0.0))[0] < 0.5);
    }

    #[test]
    fn head_takes_nothing_near_and_most_far() {
        assert_eq!(head_share(10.0), 0.0);
        assert!((head_share(30.0) - 0.35).abs() < 1e-12);
        assert!((head_share(80.0) - 0.7).abs() < 1e-12);
        let h = head_towards(Angles::new(-30.0, 5.0));
        assert!((h.yaw_deg + 10.5).abs() < 1e-12 && h.pitch_deg == 0.0);
    }
}
