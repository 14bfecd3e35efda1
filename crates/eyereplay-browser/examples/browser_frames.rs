//! Captures a few frames of a page and writes them as PNG files, printing
//! what the bundled test page's pixel codes say (for looking at the frames).
//!
//!     cargo run --release -p eyereplay-browser --example browser_frames -- OUT_DIR [URL] [FRAMES]

use eyereplay_browser::{decode_image, test_page, BrowserSettings, Capture};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let out = std::path::PathBuf::from(
        args.first()
            .ok_or("usage: browser_frames OUT_DIR [URL] [FRAMES]")?,
    );
    let mut settings = BrowserSettings::default();
    if let Some(url) = args.get(1) {
        settings.url = url.clone();
    }
    let n: usize = args.get(2).map(|s| s.parse()).transpose()?.unwrap_or(5);
    std::fs::create_dir_all(&out)?;
    let mut cap = Capture::open(&settings, 25.0)?;
    println!("{} {}", cap.browser_version, cap.url());
    for i in 0..n {
        let t = i as f64 / n.max(1) as f64 * std::f64::consts::TAU;
        let pos = [640.0 + 500.0 * t.cos() + 0.3, 360.0 + 300.0 * t.sin() + 0.7];
        let shot = cap.frame(pos)?;
        let (rgb, w, h) = decode_image(&shot.image, settings.format)?;
        let codes = test_page::decode_codes(&rgb, w, h);
        println!(
            "frame {i}: mouse {pos:?} fresh {} codes {codes:?}",
            shot.fresh
        );
        eyereplay_render::write_png(&out.join(format!("frame_{i:04}.png")), &rgb, w, h)?;
    }
    cap.close();
    Ok(())
}
