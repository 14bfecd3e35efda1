//! The bundled test page (`assets/test_eye.html`): reading the pixel codes
//! it draws into every frame, and the page's eye model written out again in
//! Rust, so tests can check captured frames against values known
//! independently of the browser.

use crate::BrowserError;

/// Side of one code cell, px (JPEG blocks are 8x8, so a cell never shares a
/// block with another).
pub const CELL_PX: usize = 8;
/// Cells per code row.
const ROW_CELLS: usize = 96;
const FIELDS: usize = 7;
/// Field 0 of every frame.
pub const MAGIC: u32 = 0xA5C35A;
/// Mouse field value before the first `mousemove`.
pub const NO_MOUSE: u32 = 0xFF_FFFF;
const MASK: u32 = 0xFF_FFFF;

/// Geometry of the page, px (the constants at the top of its script).
pub const EYE_RADIUS_PX: f64 = 140.0;
pub const HALF_WIDTH_PX: f64 = 150.0;
pub const UPPER_LID_PX: f64 = 58.0;
pub const LOWER_LID_PX: f64 = 44.0;
pub const IRIS_ANGLE_RAD: f64 = 0.427;
pub const PUPIL_ANGLE_RAD: f64 = 0.17;
pub const TARGET_DEPTH_PX: f64 = 900.0;
pub const MAX_ANGLE_RAD: f64 = 0.7;
pub const BLINK_PERIOD_MS: f64 = 4000.0;
pub const BLINK_START_MS: f64 = 3000.0;

/// What a frame's pixel codes say.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PageCodes {
    /// The page's requestAnimationFrame counter (1 in the first frame).
    pub frame: u32,
    /// The last `pointermove` clientX/clientY in 1/16 px (rounded), if any.
    pub mouse_16: Option<[u32; 2]>,
    /// `pointermove` events received.
    pub moves: u32,
    /// The rAF timestamp, whole ms.
    pub time_ms: u32,
}

impl PageCodes {
    /// The mouse position in page px.
    pub fn mouse_px(&self) -> Option<[f64; 2]> {
        self.mouse_16
            .map(|[x, y]| [x as f64 / 16.0, y as f64 / 16.0])
    }
}

/// Reads the codes from an RGB frame of the whole viewport (crop origin
/// 0,0). Each cell's value is the mean luma of its central 4x4 pixels
/// against 128, which survives JPEG and x264 at the qualities used here;
/// the magic field and the checksum reject anything misread
/// ([`BrowserError::Codes`]).
pub fn decode_codes(rgb: &[u8], width: usize, height: usize) -> Result<PageCodes, BrowserError> {
    if width < ROW_CELLS * CELL_PX || height < 2 * CELL_PX || rgb.len() < width * height * 3 {
        return Err(BrowserError::Codes(format!(
            "frame {width}x{height} too small for the codes"
        )));
    }
    let mut f = [0u32; FIELDS];
    for idx in 0..FIELDS * 24 {
        let (row, cell) = (idx / ROW_CELLS, idx % ROW_CELLS);
        let (x0, y0) = (cell * CELL_PX + 2, row * CELL_PX + 2);
        let mut sum = 0u32;
        for y in y0..y0 + 4 {
            for x in x0..x0 + 4 {
                let i = (y * width + x) * 3;
                // Integer BT.601 luma is plenty to tell black from white.
                sum += (77 * rgb[i] as u32 + 150 * rgb[i + 1] as u32 + 29 * rgb[i + 2] as u32) >> 8;
            }
        }
        let bit = (sum / 16 >= 128) as u32;
        f[idx / 24] |= bit << (23 - idx % 24);
    }
    if f[0] != MAGIC {
        return Err(BrowserError::Codes(format!(
            "no code strip (magic {:06x})",
            f[0]
        )));
    }
    let sum = f[1..6].iter().sum::<u32>();
    if ((sum ^ 0x5A5A5A) & MASK) != f[6] {
        return Err(BrowserError::Codes(format!(
            "code checksum mismatch (fields {f:?})"
        )));
    }
    Ok(PageCodes {
        frame: f[1],
        mouse_16: (f[2] != NO_MOUSE || f[3] != NO_MOUSE).then_some([f[2], f[3]]),
        moves: f[4],
        time_ms: f[5],
    })
}

/// One eye of the page as drawn for a mouse position and time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TestEye {
    pub centre_px: [f64; 2],
    pub yaw_rad: f64,
    pub pitch_rad: f64,
    /// Centre of the limbus circle, projected (orthographic view).
    pub iris_px: [f64; 2],
    /// Centre of the pupil's outline (the cap's rim circle, projected): the
    /// centroid of the black pupil pixels when the lids do not cover it.
    pub pupil_px: [f64; 2],
    /// Semi-major axis of the pupil's outline, px.
    pub pupil_radius_px: f64,
    pub nx: f64,
    pub ny: f64,
    pub aperture: f64,
}

/// Eye centres of the page for a viewport (image-left eye first).
pub fn eye_centres(viewport_px: [u32; 2]) -> [[f64; 2]; 2] {
    let (w, h) = (viewport_px[0] as f64, viewport_px[1] as f64);
    [
        [w / 2.0 - 0.25 * w, 0.53 * h],
        [w / 2.0 + 0.25 * w, 0.53 * h],
    ]
}

/// Lid closure at page time `t_ms` (0 open .. 1 closed).
pub fn closure(t_ms: f64) -> f64 {
    let ph = t_ms % BLINK_PERIOD_MS - BLINK_START_MS;
    if ph < 0.0 {
        0.0
    } else if ph < 60.0 {
        ph / 60.0
    } else if ph < 80.0 {
        1.0
    } else if ph < 180.0 {
        1.0 - (ph - 80.0) / 100.0
    } else {
        0.0
    }
}

/// Upper and lower lid of an eye at horizontal offset `dx_px` from its
/// centre (page y, px) for a lid closure.
pub fn lids_at(centre_px: [f64; 2], dx_px: f64, closure: f64) -> Option<[f64; 2]> {
    let s = dx_px / HALF_WIDTH_PX;
    if s.abs() >= 1.0 {
        return None;
    }
    let w = 1.0 - s * s;
    let upper = UPPER_LID_PX * (1.0 - closure) - LOWER_LID_PX * closure;
    Some([centre_px[1] - upper * w, centre_px[1] + LOWER_LID_PX * w])
}

/// Both eyes for a mouse position (page px; `None`: no mouse yet, the eyes
/// look straight ahead) at page time `t_ms`.
pub fn test_eyes(mouse_px: Option<[f64; 2]>, t_ms: f64, viewport_px: [u32; 2]) -> [TestEye; 2] {
    let cl = closure(t_ms);
    let upper = UPPER_LID_PX * (1.0 - cl) - LOWER_LID_PX * cl;
    eye_centres(viewport_px).map(|c| {
        let m = mouse_px.unwrap_or(c);
        let clamp = |a: f64| a.clamp(-MAX_ANGLE_RAD, MAX_ANGLE_RAD);
        let yaw = clamp((m[0] - c[0]).atan2(TARGET_DEPTH_PX));
        let pitch = clamp((c[1] - m[1]).atan2(TARGET_DEPTH_PX));
        let g = [
            yaw.sin() * pitch.cos(),
            pitch.sin(),
            yaw.cos() * pitch.cos(),
        ];
        let k = EYE_RADIUS_PX * IRIS_ANGLE_RAD.cos();
        let kp = EYE_RADIUS_PX * PUPIL_ANGLE_RAD.cos();
        let iris = [c[0] + k * g[0], c[1] - k * g[1]];
        let (top, top_open, bot) = (c[1] - upper, c[1] - UPPER_LID_PX, c[1] + LOWER_LID_PX);
        TestEye {
            centre_px: c,
            yaw_rad: yaw,
            pitch_rad: pitch,
            iris_px: iris,
            pupil_px: [c[0] + kp * g[0], c[1] - kp * g[1]],
            pupil_radius_px: EYE_RADIUS_PX * PUPIL_ANGLE_RAD.sin(),
            nx: (iris[0] - (c[0] - HALF_WIDTH_PX)) / (2.0 * HALF_WIDTH_PX),
            ny: (iris[1] - top_open) / (bot - top_open),
            aperture: (bot - top).max(0.0) / (2.0 * HALF_WIDTH_PX),
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Draws the code strip the way the page's shader does.
    fn strip(fields: [u32; FIELDS], w: usize, h: usize) -> Vec<u8> {
        let mut rgb = vec![0u8; w * h * 3];
        for idx in 0..FIELDS * 24 {
            let bit = fields[idx / 24] >> (23 - idx % 24) & 1;
            let (row, cell) = (idx / ROW_CELLS, idx % ROW_CELLS);
            for y in row * 8..row * 8 + 8 {
                for x in cell * 8..cell * 8 + 8 {
                    let i = (y * w + x) * 3;
                    rgb[i..i + 3].fill(bit as u8 * 255);
                }
            }
        }
        rgb
    }

    #[test]
    fn codes_round_trip_and_reject_corruption() {
        let (f1, f2, f3, f4, f5) = (1234, 640 * 16 + 8, 360 * 16, 77, 40_000);
        let ck = ((f1 + f2 + f3 + f4 + f5) ^ 0x5A5A5A) & MASK;
        let mut rgb = strip([MAGIC, f1, f2, f3, f4, f5, ck], 1280, 32);
        let c = decode_codes(&rgb, 1280, 32).unwrap();
        assert_eq!(c.frame, 1234);
        assert_eq!(c.mouse_px(), Some([640.5, 360.0]));
        assert_eq!((c.moves, c.time_ms), (77, 40_000));
        // Flip one bit of the frame field (its last cell): the checksum
        // catches it.
        for y in 0..8 {
            for x in (24 + 23) * 8..(24 + 24) * 8 {
                let i = (y * 1280 + x) * 3;
                let v = 255 - rgb[i];
                rgb[i..i + 3].fill(v);
            }
        }
        assert!(decode_codes(&rgb, 1280, 32)
            .unwrap_err()
            .to_string()
            .contains("checksum"));
    }

    #[test]
    fn eye_model_by_hand() {
        // Mouse straight in front of the left eye: no rotation, iris at the
        // centre, nx 0.5, ny = 58 / 102.
        let c = eye_centres([1280, 720]);
        assert_eq!(c, [[320.0, 381.6], [960.0, 381.6]]);
        let [l, r] = test_eyes(Some(c[0]), 0.0, [1280, 720]);
        assert_eq!((l.yaw_rad, l.pitch_rad), (0.0, 0.0));
        assert_eq!(l.iris_px, c[0]);
        assert!((l.nx - 0.5).abs() < 1e-12 && (l.ny - 58.0 / 102.0).abs() < 1e-12);
        // The right eye looks 640 px to the image-left at depth 900.
        assert!((r.yaw_rad - (-640f64).atan2(900.0)).abs() < 1e-12);
        let k = 140.0 * 0.427f64.cos();
        assert!((r.iris_px[0] - (960.0 + k * r.yaw_rad.sin())).abs() < 1e-9);
        // Blink: closed 60..80 ms into the blink, open before and after.
        assert_eq!(closure(2999.0), 0.0);
        assert_eq!(closure(3070.0), 1.0);
        assert_eq!(closure(3130.0), 0.5);
        assert_eq!(closure(7000.0 + 30.0), 0.5);
    }
}
