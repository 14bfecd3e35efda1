//! Frame-exact capture of one page: per frame, move the mouse, advance the
//! page's virtual time by exactly one frame interval, and draw and capture
//! one frame with `HeadlessExperimental.beginFrame` (Chromium's old headless
//! mode). See the research note browser-backend.md for the measurements
//! behind each step.

use crate::cdp::Cdp;
use crate::launch::{find_browser, Browser};
use crate::settings::{BrowserSettings, TEST_PAGE_URL};
use crate::{BrowserError, RemoteError};
use serde_json::{json, Value};
use std::path::Path;
use std::time::{Duration, Instant};

/// The bundled test page.
pub const TEST_PAGE_HTML: &str = include_str!("../assets/test_eye.html");

/// Fixed start of the page's wall clock (`Date.now()`) under virtual time,
/// s since 1970, so that pages that show the date render the same on reruns
/// (2024-01-01T00:00:00Z).
pub const INITIAL_VIRTUAL_TIME_S: f64 = 1_704_067_200.0;

/// Injected before any page script (research note, "Determinism"): virtual
/// time advances exactly one frame interval per frame, but Chromium adds
/// about 0.1 ms of random timer jitter (different in each browser process)
/// to `performance.now()` and the rAF timestamp. Rounding those to whole ms
/// was not enough: a frame whose true time fell within the jitter of a
/// half-ms rounded differently on a rerun, and the page's clock-driven
/// drawing with it. `Date.now()` runs on the same virtual time without the
/// jitter, in whole ms, so the page's clock is built on it: ms since this
/// document started. `Math.random` becomes a seeded generator (mulberry32)
/// for the same reason.
///
/// The page's animation-frame callbacks are held back until the harness
/// calls `RELEASE_FRAMES` (the first readiness check after the load event):
/// while a new document loads, Chromium may run no animation frame in a
/// begin-frame, and whether it does is a race in wall time, so a page that
/// counts its animation frames came out one frame shifted on one rerun in
/// a few (the browser README, "Frame exactness and reruns"). Held, a
/// callback is requested again for the next frame; its id stays the one the
/// page got, so `cancelAnimationFrame` still finds it.
fn time_shim(seed: u32) -> String {
    format!(
        r#"(() => {{
  const perf = window.performance;
  const date0 = Date.now();
  const now = () => Date.now() - date0;
  perf.now = now;
  const raf = window.requestAnimationFrame.bind(window);
  const caf = window.cancelAnimationFrame.bind(window);
  let held = true;
  let nextId = 1;
  const native = new Map();
  window.requestAnimationFrame = cb => {{
    const id = nextId++;
    const tick = () => {{
      if (held) {{ native.set(id, raf(tick)); return; }}
      native.delete(id);
      cb(now());
    }};
    native.set(id, raf(tick));
    return id;
  }};
  window.cancelAnimationFrame = id => {{
    const n = native.get(id);
    if (n !== undefined) {{ caf(n); native.delete(id); }}
  }};
  Object.defineProperty(window, "{RELEASE_FRAMES}", {{ value: () => {{ held = false; }} }});
  let s = {seed} >>> 0;
  Math.random = () => {{
    s = (s + 0x6D2B79F5) >>> 0;
    let t = s;
    t = Math.imul(t ^ (t >>> 15), t | 1);
    t ^= t + Math.imul(t ^ (t >>> 7), t | 61);
    return ((t ^ (t >>> 14)) >>> 0) / 4294967296;
  }};
}})();"#
    )
}

/// The shim's function that lets the page's animation frames run.
const RELEASE_FRAMES: &str = "__eyereplayReleaseFrames";

/// One captured frame.
pub struct Shot {
    /// The encoded screenshot (JPEG or PNG) as the browser sent it.
    pub image: Vec<u8>,
    /// False when the page did not change since the previous frame and the
    /// browser sent no new picture: `image` is then the previous one.
    pub fresh: bool,
}

/// A browser with one page, ready to capture frames.
pub struct Capture {
    cdp: Cdp,
    session: String,
    /// Drop order: the connection first, then the browser.
    browser: Browser,
    frame_ms: f64,
    /// Monotonic time of frame 0, ms (see `begin_frame`).
    t0_ms: f64,
    /// Frames drawn so far (readiness, warm-up and captured).
    drawn: u64,
    /// The page's virtual time already granted, in whole microseconds, so
    /// that rounding never accumulates over a session.
    granted_us: u64,
    settings: BrowserSettings,
    url: String,
    last_image: Option<Vec<u8>>,
    closed: bool,
    pub browser_version: String,
}

impl Capture {
    /// Starts a browser, loads the page under paused virtual time, waits for
    /// readiness and renders the warm-up frames.
    pub fn open(settings: &BrowserSettings, fps: f64) -> Result<Capture, BrowserError> {
        settings.validate()?;
        if !(fps > 0.0 && fps.is_finite() && fps <= 1000.0) {
            return Err(BrowserError::Input(format!(
                "fps {fps} must be in (0, 1000]"
            )));
        }
        let program = find_browser(settings.browser.as_deref())?;
        let timeout = Duration::from_secs_f64(settings.command_timeout_s);
        let browser = Browser::launch(
            &program,
            settings.viewport_px,
            settings.temp_dir.as_deref(),
            &settings.extra_args,
            timeout,
        )?;
        let url = page_url(&settings.url, browser.profile_dir())?;
        let cdp = Cdp::connect(&browser.ws_url, timeout)?;
        let mut cap = Capture {
            cdp,
            session: String::new(),
            browser,
            frame_ms: 1000.0 / fps,
            t0_ms: monotonic_ms(),
            drawn: 0,
            granted_us: 0,
            settings: settings.clone(),
            url,
            last_image: None,
            closed: false,
            browser_version: String::new(),
        };
        cap.setup()?;
        Ok(cap)
    }

    /// The URL actually loaded (the bundled page becomes a `file://` URL).
    pub fn url(&self) -> &str {
        &self.url
    }

    /// The browser's process id (its process group id too).
    pub fn browser_pid(&self) -> i32 {
        self.browser.pid()
    }

    fn page(&mut self, method: &str, params: Value) -> Result<Value, BrowserError> {
        let s = self.session.clone();
        self.cdp.call(Some(&s), method, params)
    }

    fn setup(&mut self) -> Result<(), BrowserError> {
        let v = self.cdp.call(None, "Browser.getVersion", json!({}))?;
        self.browser_version = v["product"].as_str().unwrap_or("").to_string();
        let [w, h] = self.settings.viewport_px;
        let target = self.cdp.call(
            None,
            "Target.createTarget",
            json!({ "url": "about:blank", "enableBeginFrameControl": true }),
        )?;
        let target_id = target["targetId"]
            .as_str()
            .ok_or_else(|| BrowserError::protocol("Target.createTarget", "no targetId"))?
            .to_string();
        let att = self.cdp.call(
            None,
            "Target.attachToTarget",
            json!({ "targetId": target_id, "flatten": true }),
        )?;
        self.session = att["sessionId"]
            .as_str()
            .ok_or_else(|| BrowserError::protocol("Target.attachToTarget", "no sessionId"))?
            .to_string();
        self.page("Page.enable", json!({}))?;
        self.page("Inspector.enable", json!({}))?;
        self.page(
            "Emulation.setDeviceMetricsOverride",
            json!({ "width": w, "height": h, "deviceScaleFactor": 1, "mobile": false }),
        )?;
        let shim = time_shim(self.settings.random_seed);
        self.page(
            "Page.addScriptToEvaluateOnNewDocument",
            json!({ "source": shim }),
        )?;
        self.page(
            "Emulation.setVirtualTimePolicy",
            json!({ "policy": "pause", "initialVirtualTime": INITIAL_VIRTUAL_TIME_S }),
        )?;
        // Navigation only progresses while frames are drawn, so its answer
        // is collected inside the readiness loop.
        let s = self.session.clone();
        let nav_id = self
            .cdp
            .send(Some(&s), "Page.navigate", json!({ "url": self.url }))?;
        self.wait_ready(nav_id)?;
        if self.settings.require_webgl {
            let ok = self.eval("!!document.createElement('canvas').getContext('webgl')")?;
            if ok != Value::Bool(true) {
                return Err(BrowserError::NoWebGl);
            }
        }
        // From here on the page must stay where it is.
        self.cdp.watch_navigation = true;
        for _ in 0..self.settings.warmup_frames {
            self.advance()?;
            self.begin_frame(true)?;
        }
        Ok(())
    }

    fn wait_ready(&mut self, nav_id: u64) -> Result<(), BrowserError> {
        let start = Instant::now();
        let limit = Duration::from_secs_f64(self.settings.ready.timeout_s);
        let mut navigated = false;
        let mut loaded = false;
        let mut last_error = String::new();
        // The page's own code runs as virtual time advances; the wall-clock
        // limit bounds pages that never get there.
        // Each check first lets the page's animation frames run (see
        // `time_shim`): they start at the same point on every rerun, and a
        // condition that waits for a drawing still gets its frames.
        let mut check =
            format!("(() => {{ if (window.{RELEASE_FRAMES}) window.{RELEASE_FRAMES}(); ");
        if let Some(sel) = &self.settings.ready.selector {
            check += &format!(
                "if (!document.querySelector({})) return false; ",
                serde_json::to_string(sel).unwrap_or_default()
            );
        }
        if let Some(js) = &self.settings.ready.js {
            check += &format!("if (!({js})) return false; ");
        }
        check += "return true; })()";
        let not_ready = |me: &Self, detail: String| BrowserError::NotReady {
            url: me.url.clone(),
            waited_s: start.elapsed().as_secs_f64(),
            condition: me.settings.ready_condition(),
            detail,
        };
        loop {
            if start.elapsed() > limit {
                let detail = if last_error.is_empty() {
                    String::new()
                } else {
                    format!("; last error: {last_error}")
                };
                return Err(not_ready(self, detail));
            }
            match self.advance_bounded(start + limit) {
                Err(BrowserError::Timeout { .. }) => {
                    // Virtual time waits for pending fetches.
                    let detail = "; page time stood still (a network fetch never finished)";
                    return Err(not_ready(self, detail.into()));
                }
                r => r?,
            }
            self.begin_frame(false)?;
            if !navigated {
                if let Some(r) = self.cdp.take_response(nav_id) {
                    let r = r.map_err(|e| BrowserError::Load {
                        url: self.url.clone(),
                        message: e.0,
                    })?;
                    if let Some(err) = r.get("errorText").and_then(Value::as_str) {
                        return Err(BrowserError::Load {
                            url: self.url.clone(),
                            message: err.to_string(),
                        });
                    }
                    navigated = true;
                }
            }
            if navigated && !loaded {
                loaded = self.cdp.take_event("Page.loadEventFired").is_some();
            }
            if loaded {
                match self.eval_raw(&check)? {
                    Ok(Value::Bool(true)) => return Ok(()),
                    Ok(_) => {}
                    Err(e) => last_error = e.0,
                }
            }
        }
    }

    /// Grants the page one frame interval of virtual time and waits until it
    /// has run it (timers, network callbacks).
    fn advance(&mut self) -> Result<(), BrowserError> {
        let deadline = Instant::now() + self.cdp.timeout;
        self.advance_bounded(deadline)
    }

    fn advance_bounded(&mut self, deadline: Instant) -> Result<(), BrowserError> {
        let target_us = ((self.drawn + 1) as f64 * self.frame_ms * 1000.0).round() as u64;
        let budget_ms = (target_us - self.granted_us) as f64 / 1000.0;
        self.granted_us = target_us;
        // While a fetch is pending the page's clock stands still, so a slow
        // network cannot make a page animate differently on reruns.
        self.page(
            "Emulation.setVirtualTimePolicy",
            json!({ "policy": "pauseIfNetworkFetchesPending", "budget": budget_ms }),
        )?;
        let saved = self.cdp.timeout;
        self.cdp.timeout = deadline
            .saturating_duration_since(Instant::now())
            .max(Duration::from_millis(1));
        let r = self.cdp.wait_event("Emulation.virtualTimeBudgetExpired");
        self.cdp.timeout = saved;
        r.map(|_| ())
    }

    /// Draws one frame (and captures it when `shot`), returning the
    /// screenshot bytes if the browser sent any.
    fn begin_frame(&mut self, shot: bool) -> Result<Option<Vec<u8>>, BrowserError> {
        let id = self.send_begin_frame(shot)?;
        self.finish_begin_frame(id)
    }

    fn send_begin_frame(&mut self, shot: bool) -> Result<u64, BrowserError> {
        // frameTimeTicks is on the browser's monotonic clock: a small
        // constant would put frames before the page's time origin.
        let mut params = json!({
            "frameTimeTicks": self.t0_ms + self.drawn as f64 * self.frame_ms,
            "interval": self.frame_ms,
        });
        if shot {
            let mut s = json!({ "format": self.settings.format.as_str() });
            if self.settings.format == crate::ImageFormat::Jpeg {
                s["quality"] = json!(self.settings.jpeg_quality);
            }
            params["screenshot"] = s;
        }
        self.drawn += 1;
        let s = self.session.clone();
        self.cdp
            .send(Some(&s), "HeadlessExperimental.beginFrame", params)
    }

    fn finish_begin_frame(&mut self, id: u64) -> Result<Option<Vec<u8>>, BrowserError> {
        let r = self.cdp.wait(id, "HeadlessExperimental.beginFrame")?;
        match r.get("screenshotData").and_then(Value::as_str) {
            Some(b64) => {
                use base64::Engine;
                let bytes = base64::engine::general_purpose::STANDARD
                    .decode(b64)
                    .map_err(|e| {
                        BrowserError::protocol("HeadlessExperimental.beginFrame", e.to_string())
                    })?;
                self.last_image = Some(bytes.clone());
                Ok(Some(bytes))
            }
            None => Ok(None),
        }
    }

    /// Moves the mouse to `page_px`, advances one frame interval and
    /// captures the frame.
    pub fn frame(&mut self, page_px: [f64; 2]) -> Result<Shot, BrowserError> {
        let s = self.session.clone();
        // Not awaited here: with begin-frame control the browser answers
        // only after the next frame is drawn.
        let mouse = self.cdp.send(
            Some(&s),
            "Input.dispatchMouseEvent",
            json!({ "type": "mouseMoved", "x": page_px[0], "y": page_px[1],
                    "button": "none", "modifiers": 0 }),
        )?;
        self.advance()?;
        let id = self.send_begin_frame(true)?;
        let image = self.finish_begin_frame(id)?;
        self.cdp.wait(mouse, "Input.dispatchMouseEvent")?;
        self.cdp.check_fatal()?;
        match image {
            Some(image) => Ok(Shot { image, fresh: true }),
            None => match &self.last_image {
                Some(prev) => Ok(Shot {
                    image: prev.clone(),
                    fresh: false,
                }),
                None => Err(BrowserError::Frame {
                    frame: 0,
                    message: "the page drew nothing since it became ready (raise warmup_frames)"
                        .into(),
                }),
            },
        }
    }

    /// Evaluates `expr` in the page; a thrown exception is an error.
    pub fn eval(&mut self, expr: &str) -> Result<Value, BrowserError> {
        self.eval_raw(expr)?
            .map_err(|e| BrowserError::protocol("Runtime.evaluate", e.0))
    }

    /// Evaluates `expr`: Ok(Ok(value)), or Ok(Err(exception text)).
    fn eval_raw(&mut self, expr: &str) -> Result<Result<Value, RemoteError>, BrowserError> {
        let r = self.page(
            "Runtime.evaluate",
            json!({ "expression": expr, "returnByValue": true }),
        )?;
        if let Some(ex) = r.get("exceptionDetails") {
            let text = ex["exception"]["description"]
                .as_str()
                .or_else(|| ex["text"].as_str())
                .unwrap_or("exception")
                .lines()
                .next()
                .unwrap_or("")
                .to_string();
            return Ok(Err(RemoteError(text)));
        }
        Ok(Ok(r["result"].get("value").cloned().unwrap_or(Value::Null)))
    }

    /// Closes the browser cleanly: asks it to exit, waits briefly, then
    /// kills what is left and removes the profile (as `Drop` does, which
    /// skips the polite part).
    pub fn close(mut self) {
        self.close_inner();
    }

    fn close_inner(&mut self) {
        if std::mem::replace(&mut self.closed, true) {
            return;
        }
        if self.cdp.call(None, "Browser.close", json!({})).is_ok() {
            self.cdp.close();
            self.browser.shutdown(Duration::from_secs(2));
        } else {
            self.browser.shutdown(Duration::ZERO);
        }
    }
}

impl Drop for Capture {
    fn drop(&mut self) {
        // Also on errors: let the browser reap its own helpers first, so no
        // zombie is left to an init process that may not reap.
        let saved = self.cdp.timeout;
        self.cdp.timeout = saved.min(Duration::from_secs(2));
        self.close_inner();
    }
}

/// The URL to load: http(s)/file/about/data URLs as given, a local path as
/// a `file://` URL, the bundled page written into the profile folder.
fn page_url(url: &str, profile: Option<&Path>) -> Result<String, BrowserError> {
    if let Some(rest) = url.strip_prefix(TEST_PAGE_URL) {
        let dir = profile.ok_or_else(|| BrowserError::Settings("no profile folder".into()))?;
        let path = dir.join("test_eye.html");
        std::fs::write(&path, TEST_PAGE_HTML).map_err(|e| BrowserError::io(&path, e))?;
        return Ok(format!("{}{rest}", file_url(&path)));
    }
    if let Some(scheme) = url.split_once("://").map(|(s, _)| s) {
        if ["http", "https", "file"].contains(&scheme) {
            return Ok(url.to_string());
        }
        return Err(BrowserError::Settings(format!(
            "url {url}: scheme {scheme} not supported (http, https, file, or a local path)"
        )));
    }
    if url.starts_with("about:") || url.starts_with("data:") {
        return Ok(url.to_string());
    }
    let path = Path::new(url);
    let abs = std::fs::canonicalize(path).map_err(|e| BrowserError::io(path, e))?;
    Ok(file_url(&abs))
}

/// `file://` URL of an absolute path, percent-encoding what is not a plain
/// URL path character.
pub fn file_url(abs: &Path) -> String {
    let mut out = String::from("file://");
    for b in abs.to_string_lossy().bytes() {
        if b.is_ascii_alphanumeric() || b"/-_.~".contains(&b) {
            out.push(b as char);
        } else {
            out += &format!("%{b:02X}");
        }
    }
    out
}

/// CLOCK_MONOTONIC in ms, the clock of `frameTimeTicks`.
fn monotonic_ms() -> f64 {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: clock_gettime writes into the timespec we pass.
    unsafe {
        libc::clock_gettime(libc::CLOCK_MONOTONIC, &mut ts);
    }
    ts.tv_sec as f64 * 1000.0 + ts.tv_nsec as f64 / 1e6
}
