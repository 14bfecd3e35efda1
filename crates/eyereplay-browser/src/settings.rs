//! What the browser backend is configured with (`[render.browser]` in the
//! config). Every field has a default, so an empty table renders the bundled
//! test page at 1280x720.

use crate::BrowserError;
use eyereplay_core::CanvasPos;
use serde::{Deserialize, Serialize};
use std::path::PathBuf;

/// The bundled offline test page (see `assets/test_eye.html`).
pub const TEST_PAGE_URL: &str = "builtin:test_eye";

/// Settings of the browser backend.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct BrowserSettings {
    /// The page: `http://` or `https://` URL, `file://` URL, a local file
    /// path, or `builtin:test_eye` (the bundled test page, the default; a
    /// query string such as `?marker=0` may follow).
    pub url: String,
    /// Browser window (CSS px at device scale 1), width and height.
    /// Default 1280x720.
    pub viewport_px: [u32; 2],
    /// Canvas px (the session CSVs) -> page px.
    pub mapping: PageMapping,
    /// What must hold before the first frame is captured.
    pub ready: ReadySettings,
    /// Part of the viewport that becomes the video; default the whole
    /// viewport. Width and height must be even (yuv420p).
    pub crop: Option<CropPx>,
    /// Screenshot format: `jpeg` (default, fastest) or `png` (lossless
    /// before the encoder, about a third slower).
    pub format: ImageFormat,
    /// JPEG quality 1..=100 (default 90).
    pub jpeg_quality: u32,
    /// Frames rendered after the page is ready and before the first captured
    /// frame (default 2), without mouse input.
    pub warmup_frames: u32,
    /// The browser executable. Default: `$EYEREPLAY_BROWSER`, else
    /// `/usr/lib/chromium/chromium-headless-shell` (Debian's
    /// `chromium-headless-shell`), else `chromium-headless-shell` on PATH.
    pub browser: Option<PathBuf>,
    /// Where each browser's temporary profile folder goes (default: the
    /// system temporary folder). It is removed when the browser is closed.
    pub temp_dir: Option<PathBuf>,
    /// A JavaScript expression evaluated after each captured frame that
    /// returns a flat object of numbers (booleans count as 0/1), written as
    /// extra columns of the truth CSV in the object's key order. The test
    /// page's `eyereplayTruth()` returns the renderer's column names
    /// (`left_nx`, ...). Default: none.
    pub truth_js: Option<String>,
    /// Seed of the page's `Math.random` (replaced by a seeded generator so
    /// reruns are identical). Default 1.
    pub random_seed: u32,
    /// Fail when the browser offers no WebGL (default true).
    pub require_webgl: bool,
    /// How long one DevTools command may take, s (default 30).
    pub command_timeout_s: f64,
    /// More browser command-line flags, appended to the built-in ones.
    pub extra_args: Vec<String>,
}

impl Default for BrowserSettings {
    fn default() -> Self {
        BrowserSettings {
            url: TEST_PAGE_URL.into(),
            viewport_px: [1280, 720],
            mapping: PageMapping::default(),
            ready: ReadySettings::default(),
            crop: None,
            format: ImageFormat::Jpeg,
            jpeg_quality: 90,
            warmup_frames: 2,
            browser: None,
            temp_dir: None,
            truth_js: None,
            random_seed: 1,
            require_webgl: true,
            command_timeout_s: 30.0,
            extra_args: Vec::new(),
        }
    }
}

/// Canvas px -> page px: `page = offset_px + scale * c`, where `c` is the
/// canvas position, mirrored first when asked (`x -> canvas_w - x`,
/// `y -> canvas_h - y`). The default maps a 1280x720 canvas 1:1.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct PageMapping {
    /// Size of the canvas the trajectories are in (default 1280x720).
    pub canvas_px: [u32; 2],
    pub offset_px: [f64; 2],
    pub scale: [f64; 2],
    pub mirror_x: bool,
    pub mirror_y: bool,
}

impl Default for PageMapping {
    fn default() -> Self {
        PageMapping {
            canvas_px: [1280, 720],
            offset_px: [0.0, 0.0],
            scale: [1.0, 1.0],
            mirror_x: false,
            mirror_y: false,
        }
    }
}

impl PageMapping {
    /// Page position of a canvas position (no clamping).
    pub fn to_page(&self, p: CanvasPos) -> [f64; 2] {
        let x = if self.mirror_x {
            self.canvas_px[0] as f64 - p.x_px
        } else {
            p.x_px
        };
        let y = if self.mirror_y {
            self.canvas_px[1] as f64 - p.y_px
        } else {
            p.y_px
        };
        [
            self.offset_px[0] + self.scale[0] * x,
            self.offset_px[1] + self.scale[1] * y,
        ]
    }
}

/// Readiness: the page's load event, then `selector` present and `js`
/// truthy (each when given), within `timeout_s` of wall-clock time.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ReadySettings {
    /// A CSS selector that must match an element.
    pub selector: Option<String>,
    /// A JavaScript expression that must be truthy.
    pub js: Option<String>,
    /// Default 30 s.
    pub timeout_s: f64,
}

impl Default for ReadySettings {
    fn default() -> Self {
        ReadySettings {
            selector: None,
            js: None,
            timeout_s: 30.0,
        }
    }
}

/// A rectangle of the viewport, px.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CropPx {
    pub x: u32,
    pub y: u32,
    pub width: u32,
    pub height: u32,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ImageFormat {
    Jpeg,
    Png,
}

impl ImageFormat {
    pub fn as_str(self) -> &'static str {
        match self {
            ImageFormat::Jpeg => "jpeg",
            ImageFormat::Png => "png",
        }
    }
}

impl BrowserSettings {
    /// Checks the settings; the error says which field is wrong.
    pub fn validate(&self) -> Result<(), BrowserError> {
        let bad = |m: String| Err(BrowserError::Settings(m));
        let [w, h] = self.viewport_px;
        if !(16..=8192).contains(&w) || !(16..=8192).contains(&h) {
            return bad(format!("viewport_px {w}x{h} must be 16..8192 each"));
        }
        let (vw, vh) = self.video_size();
        if (vw | vh) & 1 != 0 {
            return bad(format!(
                "video size {vw}x{vh} (viewport or crop) must be even for yuv420p"
            ));
        }
        if let Some(c) = self.crop {
            if c.width == 0 || c.height == 0 || c.x + c.width > w || c.y + c.height > h {
                return bad(format!(
                    "crop {}x{} at ({}, {}) is not inside the {w}x{h} viewport",
                    c.width, c.height, c.x, c.y
                ));
            }
        }
        if !(1..=100).contains(&self.jpeg_quality) {
            return bad(format!("jpeg_quality {} must be 1..100", self.jpeg_quality));
        }
        let m = &self.mapping;
        if m.canvas_px[0] == 0 || m.canvas_px[1] == 0 {
            return bad("mapping.canvas_px must be non-zero".into());
        }
        if !m.offset_px.iter().chain(&m.scale).all(|v| v.is_finite()) || m.scale.contains(&0.0) {
            return bad(
                "mapping.offset_px and mapping.scale must be finite, scale non-zero".into(),
            );
        }
        if !(self.ready.timeout_s > 0.0 && self.ready.timeout_s.is_finite()) {
            return bad(format!(
                "ready.timeout_s {} must be > 0",
                self.ready.timeout_s
            ));
        }
        if !(self.command_timeout_s > 0.0 && self.command_timeout_s.is_finite()) {
            return bad(format!(
                "command_timeout_s {} must be > 0",
                self.command_timeout_s
            ));
        }
        if self.url.trim().is_empty() {
            return bad("url is empty".into());
        }
        self.check_page()
    }

    /// The page can be loaded as far as can be told before a browser
    /// starts: a bundled page that exists, a supported scheme, a local
    /// file that is there. Each was found only once a browser had started
    /// for every session ("No such file or directory (os error 2)" for
    /// `builtin:nope`).
    fn check_page(&self) -> Result<(), BrowserError> {
        let url = self.url.as_str();
        let bad = |m: String| Err(BrowserError::Settings(m));
        if url.starts_with("builtin:") {
            if !url.starts_with(TEST_PAGE_URL) {
                return bad(format!(
                    "url {url}: no such bundled page (the bundled one is {TEST_PAGE_URL})"
                ));
            }
            return Ok(());
        }
        if url.starts_with("about:") || url.starts_with("data:") {
            return Ok(());
        }
        let local = match url.split_once("://") {
            Some(("http" | "https", _)) => return Ok(()),
            Some(("file", rest)) => {
                // Percent-encoded names are left to the browser.
                let path = rest.split(['?', '#']).next().unwrap_or(rest);
                if path.contains('%') {
                    return Ok(());
                }
                path
            }
            Some((scheme, _)) => {
                return bad(format!(
                    "url {url}: scheme {scheme} not supported (http, https, file, or a local path)"
                ))
            }
            None => url,
        };
        if !std::path::Path::new(local).is_file() {
            return bad(format!("url {url}: no such file ({local})"));
        }
        Ok(())
    }

    /// Width and height of the video: the crop, else the viewport.
    pub fn video_size(&self) -> (usize, usize) {
        match self.crop {
            Some(c) => (c.width as usize, c.height as usize),
            None => (self.viewport_px[0] as usize, self.viewport_px[1] as usize),
        }
    }

    /// What the readiness check waits for, in words (for errors).
    pub(crate) fn ready_condition(&self) -> String {
        let mut parts = vec!["the load event".to_string()];
        if let Some(s) = &self.ready.selector {
            parts.push(format!("selector {s:?}"));
        }
        if let Some(js) = &self.ready.js {
            parts.push(format!("js {js:?}"));
        }
        parts.join(" and ")
    }
}
