//! Golden hashes of rendered output: an invariant test for refactors of the
//! renderer that must not change a single byte.
//!
//! The hashes below were recorded at commit ef65e40, before `scene.rs` was
//! split into modules (issue 11). Any change to them means rendered frames,
//! ground truth or lid margins changed. A deliberate change to how the eyes
//! look must re-record them (and say why in the commit); a refactor must not.
//!
//! Each identity is rendered at a small size through every public path that
//! makes pixels: the parallel yuv frame renderer (`render_frames`, the hot
//! path), `render_eyes` into yuv and into RGB, and `rgb_to_yuv420` of the
//! RGB frame. The frames include a blink (lids closing and closed) and gaze
//! at the canvas corners. Hashes are FNV-1a 64 (stable across Rust
//! versions, unlike `DefaultHasher`). The three yuv hashes of an identity
//! are equal because the fast path writes exactly what converting the full
//! RGB frame gives.

use eyereplay_core::CanvasPos;
use eyereplay_render::*;

const W: usize = 320;
const H: usize = 180;

/// FNV-1a, 64 bit.
#[derive(Clone, Copy)]
struct Fnv(u64);

impl Fnv {
    fn new() -> Fnv {
        Fnv(0xcbf2_9ce4_8422_2325)
    }
    fn bytes(&mut self, b: &[u8]) {
        for &x in b {
            self.0 ^= x as u64;
            self.0 = self.0.wrapping_mul(0x0000_0100_0000_01b3);
        }
    }
    fn f64s(&mut self, v: impl IntoIterator<Item = f64>) {
        for x in v {
            self.bytes(&x.to_bits().to_le_bytes());
        }
    }
}

struct Collect(Vec<Vec<u8>>);
impl FrameSink for Collect {
    fn frame(&mut self, _i: usize, yuv: &[u8]) -> Result<(), RenderError> {
        self.0.push(yuv.to_vec());
        Ok(())
    }
}

/// Hashes of one identity's output: frames via `render_frames`, frames via
/// `render_eyes` (yuv, RGB, and RGB converted by `rgb_to_yuv420`), the
/// ground-truth CSV, and lid margins plus geometry.
#[derive(Debug, PartialEq, Eq)]
struct Golden {
    frames_yuv: u64,
    eyes_yuv: u64,
    eyes_rgb: u64,
    rgb_to_yuv: u64,
    truth_csv: u64,
    margins: u64,
}

fn golden(id: Identity) -> Golden {
    let mut p = RenderParams::new(id);
    p.width = W;
    p.height = H;
    // Corners and centre of the default 1280x720 canvas, then a blink.
    let traj: Vec<CanvasPos> = [
        (640.0, 360.0),
        (0.0, 0.0),
        (1280.0, 0.0),
        (0.0, 720.0),
        (1280.0, 720.0),
        (900.0, 200.0),
        (300.0, 500.0),
        (640.0, 360.0),
        (700.0, 380.0),
        (720.0, 400.0),
    ]
    .iter()
    .map(|&(x_px, y_px)| CanvasPos { x_px, y_px })
    .collect();
    let mut blinks = vec![false; traj.len()];
    blinks[6..9].iter_mut().for_each(|b| *b = true);
    let scene = Scene::new(&p.identity, W, H);
    let truth = solve_truth(&scene, &traj, Some(&blinks), &p);
    assert!(
        truth.iter().any(|t| t.blink()),
        "the test must cover a blink"
    );

    let mut c = Collect(Vec::new());
    render_frames(&scene, &truth, &mut c).unwrap();
    let mut frames_yuv = Fnv::new();
    c.0.iter().for_each(|f| frames_yuv.bytes(f));

    let (mut eyes_yuv, mut eyes_rgb, mut rgb_to_yuv) = (Fnv::new(), Fnv::new(), Fnv::new());
    let mut scratch = Vec::new();
    for t in &truth {
        let poses = [t.eyes[0].pose, t.eyes[1].pose];
        let mut rgb = scene.background_rgb().to_vec();
        let mut yuv = scene.background_yuv().to_vec();
        scene.render_eyes(
            poses,
            t.closure,
            t.pupil_scale,
            Some(&mut rgb),
            Some(&mut yuv),
            &mut scratch,
        );
        eyes_yuv.bytes(&yuv);
        eyes_rgb.bytes(&rgb);
        let mut conv = vec![0u8; W * H * 3 / 2];
        rgb_to_yuv420(&rgb, W, [0, 0, W, H], &mut conv, W, H);
        rgb_to_yuv.bytes(&conv);
    }

    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("truth.csv");
    write_truth_csv(&csv, &truth).unwrap();
    let mut truth_csv = Fnv::new();
    truth_csv.bytes(&std::fs::read(&csv).unwrap());

    let mut margins = Fnv::new();
    for g in scene.geometry() {
        margins.bytes(&[g.side as u8]);
        margins.f64s(g.inner_corner_px.into_iter().chain(g.outer_corner_px));
        margins.f64s(g.centre_px.into_iter().chain([g.px_per_mm]));
        margins.f64s(g.box_px.map(f64::from));
    }
    for t in truth.iter().step_by(3) {
        for side in [Side::Left, Side::Right] {
            let e = &t.eyes[side.index()];
            let [up, lo] = scene.lid_margins_px(side, e.pose, t.closure, 24);
            margins.f64s(up.iter().chain(&lo).flatten().copied());
        }
    }
    Golden {
        frames_yuv: frames_yuv.0,
        eyes_yuv: eyes_yuv.0,
        eyes_rgb: eyes_rgb.0,
        rgb_to_yuv: rgb_to_yuv.0,
        truth_csv: truth_csv.0,
        margins: margins.0,
    }
}

#[test]
fn rendered_output_matches_hashes_recorded_before_the_scene_split() {
    let cases = [
        (
            "reference",
            Identity::reference(),
            Golden {
                frames_yuv: 0x72c4_7dda_816b_69a7,
                eyes_yuv: 0x72c4_7dda_816b_69a7,
                eyes_rgb: 0xbbc1_bac1_61f5_886c,
                rgb_to_yuv: 0x72c4_7dda_816b_69a7,
                truth_csv: 0x9b7f_b611_19c6_2747,
                margins: 0x3fcf_6e1f_4575_b635,
            },
        ),
        (
            "seed 3",
            Identity::sample(3),
            Golden {
                frames_yuv: 0xd633_c5b9_dd4c_324e,
                eyes_yuv: 0xd633_c5b9_dd4c_324e,
                eyes_rgb: 0x55ba_2b88_8902_02dc,
                rgb_to_yuv: 0xd633_c5b9_dd4c_324e,
                truth_csv: 0x369b_42ce_87d3_004e,
                margins: 0x7ccd_223d_8583_b4e0,
            },
        ),
        (
            "seed 11",
            Identity::sample(11),
            Golden {
                frames_yuv: 0xffc1_efca_528d_bc9d,
                eyes_yuv: 0xffc1_efca_528d_bc9d,
                eyes_rgb: 0x29d7_7520_34c1_301d,
                rgb_to_yuv: 0xffc1_efca_528d_bc9d,
                truth_csv: 0xcf16_d4f3_37db_25a7,
                margins: 0xb061_0c22_523b_b49a,
            },
        ),
    ];
    let mut failures = Vec::new();
    for (name, id, want) in cases {
        let got = golden(id);
        if got != want {
            failures.push(format!("{name}: got {got:#x?}"));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
