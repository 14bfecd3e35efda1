//! `backend = "browser"`: a web page driven frame by frame in a headless
//! Chromium, as the paper's stage 6 did (eyereplay-browser); beside each
//! video the truth CSV (cursor per frame, plus the page's own truth
//! columns) and an identity file naming the page (and its eyes, when
//! configured).

use crate::backend::{Rendered, Session, SessionBackend, SessionOutputs};
use crate::{BackendError, Result};
use eyereplay_browser::BrowserSettings;
use eyereplay_core::Progress;
use eyereplay_dataset::SessionIdentity;
use eyereplay_render::EncoderSettings;

/// The browser backend, ready to draw sessions.
pub struct BrowserBackend {
    settings: BrowserSettings,
    encoder: EncoderSettings,
    eye_corners_px: Option<[[f64; 4]; 2]>,
    jobs: usize,
}

impl BrowserBackend {
    /// `[render.browser]` typed; also finds the browser, so a missing one
    /// is reported before work starts (one line naming the Debian package).
    pub fn settings(table: Option<&toml::Table>) -> Result<BrowserSettings> {
        let b: BrowserSettings = toml::Value::Table(table.cloned().unwrap_or_default())
            .try_into()
            .map_err(|e| BackendError::Setting(format!("[render.browser]: {}", e.message())))?;
        eyereplay_browser::find_browser(b.browser.as_deref())
            .map_err(|e| BackendError::Setting(e.to_string()))?;
        Ok(b)
    }

    /// `jobs` browsers at once (0: one per two cores: each keeps about two
    /// cores busy with its renderer and compositor).
    pub fn new(
        settings: BrowserSettings,
        encoder: EncoderSettings,
        eye_corners_px: Option<[[f64; 4]; 2]>,
        jobs: usize,
    ) -> Self {
        let jobs = if jobs > 0 {
            jobs
        } else {
            std::thread::available_parallelism().map_or(1, |n| (n.get() / 2).max(1))
        };
        BrowserBackend {
            settings,
            encoder,
            eye_corners_px,
            jobs,
        }
    }
}

impl SessionBackend for BrowserBackend {
    fn name(&self) -> &'static str {
        "browser"
    }

    fn parallel_sessions(&self) -> usize {
        self.jobs
    }

    fn render(&self, s: &Session, out: &SessionOutputs, _: &dyn Progress) -> Result<Rendered> {
        // The page runs in Chromium (launched per session) and the encoder
        // in ffmpeg: child processes, whose CPU time the lap's child column
        // holds once they have ended and been waited for.
        let stats = eyereplay_core::profile::lap("capture the page and encode", || {
            eyereplay_browser::render_session_browser(
                &self.settings,
                &self.encoder,
                &s.trajectory,
                s.fps,
                &out.mp4(),
                &out.truth(),
            )
        })?;
        out.write_identity(&SessionIdentity {
            file: s.job.paths.file.clone(),
            seed: s.job.seed,
            identity: serde_json::json!({ "backend": "browser", "url": self.settings.url }),
            mapping: &self.settings.mapping,
            width: stats.width,
            height: stats.height,
            fps: s.fps,
            eyes: self.eye_corners_px.map(SessionIdentity::eyes_from_corners),
            extractor_iris_views: None,
        })?;
        Ok(Rendered {
            frames: stats.frames,
            clamped_points: stats.clamped_points,
        })
    }
}
