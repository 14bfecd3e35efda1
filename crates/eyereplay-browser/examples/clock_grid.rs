//! Checks that the bundled test page's state stays on the capture's frame
//! schedule over a long session: at every captured frame the page's rAF
//! time (from its pixel codes) and its `Date.now()` must be
//! `floor(round((f + h) x frame_us) / 1000)` ms, `f` being the page's own
//! rAF frame counter and `h` the frames drawn before the harness let the
//! page's animation frames run (read off the first captured frame; the
//! document started at virtual time 0), and every frame must bring exactly
//! one `pointermove`. Prints the first captured frame's codes, `h`, and how
//! many frames were off. Run several at once, or
//! beside busy loops, to look for timing-dependent state (the browser
//! README, "Frame exactness and reruns").
//!
//!     cargo run --release -p eyereplay-browser --example clock_grid -- [FRAMES] [FPS]

use eyereplay_browser::{
    decode_image, test_page, BrowserSettings, Capture, ImageFormat, INITIAL_VIRTUAL_TIME_S,
};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let frames: usize = args.first().map(|s| s.parse()).transpose()?.unwrap_or(1000);
    let fps: f64 = args.get(1).map(|s| s.parse()).transpose()?.unwrap_or(30.0);
    let settings = BrowserSettings {
        format: ImageFormat::Png,
        ..Default::default()
    };
    let mut cap = Capture::open(&settings, fps)?;
    let date0_ms = INITIAL_VIRTUAL_TIME_S * 1000.0;
    let grid_ms = |f: f64| ((f * (1000.0 / fps) * 1000.0).round() / 1000.0).floor();
    let (mut off, mut prev) = (0usize, None::<test_page::PageCodes>);
    let mut held = 0u32;
    for i in 0..frames {
        let t = i as f64 * 0.05;
        let pos = [640.0 + 500.0 * t.cos() + 0.3, 360.0 + 300.0 * t.sin() + 0.7];
        let shot = cap.frame(pos)?;
        let now_ms = cap
            .eval("Date.now()")?
            .as_f64()
            .ok_or("Date.now() not a number")?
            - date0_ms;
        let (rgb, w, h) = decode_image(&shot.image, settings.format)?;
        let c = test_page::decode_codes(&rgb, w, h)?;
        if i == 0 {
            held = ((c.time_ms as f64 / (1000.0 / fps)).round() as u32).saturating_sub(c.frame);
            println!("first captured frame: {c:?}; animation frames held for {held} frame(s)");
        }
        let want = grid_ms((c.frame + held) as f64);
        let one_move = prev.is_none_or(|p| c.moves == p.moves + 1);
        if c.time_ms as f64 != want || now_ms != want || !one_move {
            off += 1;
            if off <= 10 {
                println!("frame {i}: codes {c:?}, Date.now() {now_ms} ms, expected {want} ms");
            }
        }
        prev = Some(c);
    }
    println!("{frames} frames at {fps} fps: {off} off the schedule");
    cap.close();
    if off > 0 {
        std::process::exit(1);
    }
    Ok(())
}
