//! Speed of the browser backend on the bundled test page (or any page)
//! against the x264 encoder alone, in one run:
//!
//!     cargo run --release -p eyereplay-browser --example browser_bench -- [FRAMES] [URL]
//!
//! Prints frames/s of browser capture only, decoding, the encoder alone,
//! and browser + encode (the real session loop), with the ratio to the
//! encoder alone. On the test page it also checks every frame's pixel codes.

use eyereplay_browser::{run_bench, BrowserSettings};
use eyereplay_render::EncoderSettings;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let frames: usize = args.next().map(|s| s.parse()).transpose()?.unwrap_or(300);
    let mut settings = BrowserSettings::default();
    if let Some(url) = args.next() {
        settings.url = url;
    }
    let report = run_bench(&settings, &EncoderSettings::default(), frames, 25.0)?;
    print!("{report}");
    Ok(())
}
