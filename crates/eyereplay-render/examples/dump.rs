//! Profiling helper: renders N frames of a reading trajectory and writes the
//! raw yuv420p stream to a file (default /tmp/frames.yuv) for timing x264
//! settings by hand: `dump [FRAMES] [OUT.yuv]`.
use eyereplay_render::*;
use std::io::Write;
struct F(std::fs::File);
impl FrameSink for F {
    fn frame(&mut self, _i: usize, yuv: &[u8]) -> Result<(), RenderError> {
        self.0.write_all(yuv).unwrap();
        Ok(())
    }
}
fn main() {
    let n: usize = std::env::args()
        .nth(1)
        .map(|s| s.parse().unwrap())
        .unwrap_or(300);
    let p = RenderParams::new(Identity::reference());
    let traj = reading_trajectory(n, 1280.0, 720.0);
    let scene = Scene::new(&p.identity, 1280, 720);
    let truth = solve_truth(&scene, &traj, None, &p);
    let mut f = F(std::fs::File::create(
        std::env::args().nth(2).unwrap_or("/tmp/frames.yuv".into()),
    )
    .unwrap());
    let c0 = cpu_times().unwrap().0;
    let t = std::time::Instant::now();
    render_frames(&scene, &truth, &mut f).unwrap();
    let c1 = cpu_times().unwrap().0;
    eprintln!(
        "render {:?} wall, {:.2} ms cpu/frame",
        t.elapsed(),
        (c1 - c0) * 1000.0 / n as f64
    );
}
