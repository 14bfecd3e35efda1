//! `backend = "eyes"`: eyereplay's own ray-traced close-up of two eyes
//! (eyereplay-render), sessions in parallel.

use crate::backend::{Rendered, Session, SessionBackend, SessionOutputs};
use crate::probe::ResponseProbe;
use crate::Result;
use eyereplay_core::profile::lap;
use eyereplay_core::Progress;
use eyereplay_dataset::SessionIdentity;
use eyereplay_render::{render_session, DatasetInfo, Identity, RenderParams};

/// The eyes backend, ready to draw sessions.
pub struct EyesBackend {
    /// Template for every session; identity and mapping are set per session.
    params: RenderParams,
    info: DatasetInfo,
    jobs: usize,
    probe: Option<ResponseProbe>,
}

impl EyesBackend {
    /// `params` as the `[render]` settings give them; `info` the dataset's
    /// canvas, rate and calibration; `jobs` sessions at once; `probe` for
    /// `match_extractor`.
    pub fn new(
        params: RenderParams,
        info: DatasetInfo,
        jobs: usize,
        probe: Option<ResponseProbe>,
    ) -> Self {
        EyesBackend {
            params,
            info,
            jobs,
            probe,
        }
    }
}

impl SessionBackend for EyesBackend {
    fn name(&self) -> &'static str {
        "eyes"
    }

    fn parallel_sessions(&self) -> usize {
        self.jobs
    }

    fn render(&self, s: &Session, out: &SessionOutputs, _: &dyn Progress) -> Result<Rendered> {
        let mut params = self.params.clone();
        params.identity = Identity::sample(s.job.seed);
        params.mapping = self.info.mapping(&self.params.mapping);
        params.fps = self.info.fps;
        if let Some(probe) = &self.probe {
            params.mapping.extractor_response = lap("probe clip (match_extractor)", || {
                probe.measure(&params, &s.trajectory)
            })?;
        }
        // The encoder is an ffmpeg child: its CPU time is counted in this
        // lap, when the session's end waits for it.
        let stats = lap("draw and encode", || {
            render_session(
                &s.trajectory,
                s.blinks.as_deref(),
                &params,
                &out.mp4(),
                &out.truth(),
            )
        })?;
        out.write_identity(&SessionIdentity {
            file: s.job.paths.file.clone(),
            seed: s.job.seed,
            identity: &params.identity,
            mapping: &params.mapping,
            width: params.width,
            height: params.height,
            fps: params.fps,
            eyes: stats.eyes.clone(),
            extractor_iris_views: self.probe.as_ref().map(|p| p.iris_views),
        })?;
        Ok(Rendered {
            frames: stats.frames,
            clamped_points: stats.clamped_points,
        })
    }
}
