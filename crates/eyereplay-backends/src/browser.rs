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
    /// `[render.browser]` typed and checked (sizes, crop, the page's file);
    /// also finds the browser, so a missing one is reported before work
    /// starts (one line naming the Debian package), not once per session.
    pub fn settings(table: Option<&toml::Table>) -> Result<BrowserSettings> {
        let b: BrowserSettings = toml::Value::Table(table.cloned().unwrap_or_default())
            .try_into()
            .map_err(|e| {
                let message = eyereplay_prepare::describe_toml_error("", &e);
                BackendError::Setting(format!("[render.browser]: {message}"))
            })?;
        b.validate()
            .map_err(|e| BackendError::Setting(format!("[render.browser]: {e}")))?;
        eyereplay_browser::find_browser(b.browser.as_deref())
            .map_err(|e| BackendError::Setting(e.to_string()))?;
        Ok(b)
    }

    /// `jobs` browsers at once
    /// ([`eyereplay_dataset::RenderSettings::sessions_at_once`]).
    pub fn new(
        settings: BrowserSettings,
        encoder: EncoderSettings,
        eye_corners_px: Option<[[f64; 4]; 2]>,
        jobs: usize,
    ) -> Self {
        let jobs = jobs.max(1);
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

    fn render(
        &self,
        s: &Session,
        out: &SessionOutputs,
        progress: &dyn Progress,
    ) -> Result<Rendered> {
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
        // A page that does not follow the cursor gives a video of one
        // picture, which nothing else would say.
        if stats.frames > 1 && stats.unchanged_frames * 2 > stats.frames {
            progress.warn(&format!(
                "{}: the page redrew {} of {} frames, the video repeats the picture in the \
                 others (does the page move with the mouse? see the browser README, \
                 \"Frame exactness and reruns\")",
                s.job.paths.file,
                stats.frames - stats.unchanged_frames,
                stats.frames
            ));
        }
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
