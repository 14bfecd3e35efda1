//! Stage 6 through a web page, as the paper did: a headless Chromium (the
//! old headless mode of Debian's `chromium-headless-shell`) loads a web eye
//! simulator, and for every trajectory frame the mouse is moved to the
//! mapped position, the page's virtual time advances by exactly 1/fps, and
//! that one frame is drawn and captured (`HeadlessExperimental.beginFrame`
//! with a screenshot). Frames go through the renderer's x264 encoder
//! ([`eyereplay_render::Encoder`]), so videos have the same settings and
//! layout as ours; a truth CSV records the cursor per frame.
//!
//! Entry points: [`render_session_browser`] (one trajectory to MP4 + truth
//! CSV), [`render_sessions`] (many, in parallel browsers), [`run_bench`]
//! (speed against the encoder alone), [`Capture`] (frame by frame, for
//! tools and tests), [`test_page`] (the bundled offline test page).
//!
//! # Frame exactness and determinism
//!
//! Per frame: `Input.dispatchMouseEvent` is sent without waiting (with
//! begin-frame control it is acknowledged only after the next frame),
//! `Emulation.setVirtualTimePolicy` grants one frame interval and its
//! `virtualTimeBudgetExpired` event is awaited, then `beginFrame` draws and
//! captures. Each captured frame is one `requestAnimationFrame` of the page
//! that has seen that frame's mouse position. A script injected before the
//! page's own rounds `performance.now()` and the rAF timestamp to whole ms
//! (Chromium adds ~0.1 ms of timer jitter under virtual time) and seeds
//! `Math.random`, so reruns give byte-identical videos and CSVs.
//!
//! # Lifetime
//!
//! Each session has its own browser in its own process group with a fresh
//! profile folder; dropping it (success, error or panic) kills the group and
//! removes the folder. Errors name the session; the video and truth CSV
//! appear only complete.

mod capture;
mod cdp;
mod error;
mod launch;
mod settings;

mod bench;
mod session;
pub mod test_page;

pub use bench::{run_bench, BrowserBenchReport};
pub use capture::{file_url, Capture, Shot, INITIAL_VIRTUAL_TIME_S, TEST_PAGE_HTML};
pub use error::{BrowserError, RemoteError};
pub use launch::{find_browser, find_browser_in, BROWSER_ENV, DEBIAN_HEADLESS_SHELL};
pub use session::{
    decode_image, render_session_browser, render_sessions, session_name, BrowserJob,
    BrowserSessionStats,
};
pub use settings::{
    BrowserSettings, CropPx, ImageFormat, PageMapping, ReadySettings, TEST_PAGE_URL,
};
