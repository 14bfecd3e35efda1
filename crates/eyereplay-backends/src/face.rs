//! `backend = "face"`: identities fitted once from the configured photos
//! (or the bundled ones), then each session drawn by eyereplay-face with
//! its own identity, head-movement person, and webcam look, all from its
//! seed.

use crate::backend::{Rendered, Session, SessionBackend, SessionOutputs};
use crate::{BackendError as Error, Result};
use eyereplay_core::profile::lap;
use eyereplay_core::{CanvasPos, GazeClass, NormPos, Progress};
use eyereplay_dataset::{
    DatasetMetadata, FaceBackendSettings, HeadMotion, PoseRow, SessionIdentity,
};
use eyereplay_face::coordination::{CoordinationParams, HeadDynamics, Task, DEFAULT_SWAY_RMS};
use eyereplay_face::webcam::{WebcamLook, WebcamRanges};
use eyereplay_face::{
    default_faces_dir, Axis, CanonicalMesh, ExtractorMatch, FaceScene, FaceSessionParams, Framing,
    PhotoFitter, PhotoIdentity, ProbeHeadRange, ProbeRefusal, MESH_FILE,
};
use eyereplay_face::{DrawnFrame, FaceSessionStats, SessionRead};
use eyereplay_render::{EncoderSettings, GazeMapping, Identity, RenderParams, ResponseMap};
use rand::SeedableRng;
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// The photos a face-mode config uses: its `identities` resolved against
/// the config's folder, or the bundled photos.
pub fn identity_photos(
    settings: &FaceBackendSettings,
    resolve: impl Fn(&Path) -> PathBuf,
) -> Vec<PathBuf> {
    if settings.identities.is_empty() {
        eyereplay_face::bundled_faces()
    } else {
        settings.identities.iter().map(|p| resolve(p)).collect()
    }
}

/// x264 preset of the face mode unless `[render.webcam] x264_preset` says
/// otherwise: video-call encoders are real-time, low-complexity ones, and
/// at 1280x720 it costs 7.6 CPU-ms a frame where veryfast costs 11.6
/// (webcam-noisy frames at 1.5 Mbit/s, measured with ffmpeg here).
pub const FACE_X264_PRESET: &str = "superfast";

/// x264 tune of the face mode: a video call's encoder is real-time (no
/// B-frames, no lookahead); with `superfast` it costs 3.0 CPU-ms per
/// 640x480 frame where plain `superfast` costs 3.8 (measured here on a
/// rendered session at 800 kbit/s, same size).
pub const FACE_X264_TUNE: &str = "zerolatency";

/// The face mode's own settings, typed and checked.
#[derive(Clone, Debug)]
pub struct FaceSettings {
    /// `[render.webcam]`: the look's ranges.
    pub webcam: WebcamRanges,
    /// `[render.webcam] x264_preset`, default [`FACE_X264_PRESET`].
    pub x264_preset: String,
}

impl FaceSettings {
    /// `[render.webcam]` typed, and the face mode's `[render]` keys
    /// (`face_height_frac`, `head_sway`) checked: one-line errors naming
    /// the key.
    pub fn from_backend(settings: &FaceBackendSettings) -> Result<FaceSettings> {
        let mut table = settings.webcam.clone().unwrap_or_default();
        let x264_preset = match table.remove("x264_preset") {
            None => FACE_X264_PRESET.to_string(),
            Some(toml::Value::String(p)) => {
                eyereplay_render::check_x264_preset(&p)
                    .map_err(|e| Error::Setting(format!("[render.webcam]: {e}")))?;
                p
            }
            Some(v) => {
                return Err(Error::Setting(format!(
                    "[render.webcam]: x264_preset must be a string (an x264 preset name), got {v}"
                )))
            }
        };
        let webcam: WebcamRanges = toml::Value::Table(table).try_into().map_err(|e| {
            let message = eyereplay_prepare::describe_toml_error("", &e);
            Error::Setting(format!("[render.webcam]: {message}"))
        })?;
        webcam
            .validate()
            .map_err(|e| Error::Setting(e.to_string()))?;
        let [lo, hi] = settings.face_height_frac;
        if !(lo.is_finite() && hi.is_finite() && 0.15 <= lo && lo <= hi && hi <= 0.8) {
            return Err(Error::Setting(format!(
                "[render]: face_height_frac [{lo}, {hi}] must be a range inside [0.15, 0.8]"
            )));
        }
        if !(settings.head_sway.is_finite() && (0.0..=5.0).contains(&settings.head_sway)) {
            return Err(Error::Setting(format!(
                "[render]: head_sway {} must be between 0 and 5",
                settings.head_sway
            )));
        }
        Ok(FaceSettings {
            webcam,
            x264_preset,
        })
    }

    /// The face mode's encoder from the renderer's: its preset, tuned as a
    /// video call's real-time encoder, without the close-up's extra x264
    /// options (they tune veryfast).
    pub fn encoder(&self, base: &EncoderSettings) -> EncoderSettings {
        EncoderSettings {
            preset: self.x264_preset.clone(),
            tune: Some(FACE_X264_TUNE.into()),
            x264_params: None,
            ..base.clone()
        }
    }
}

/// A session's framing: the look's field of view, and its side light for
/// the eyes.
fn framing(look: &WebcamLook, width: usize, height: usize, face_height_frac: f64) -> Framing {
    Framing {
        width,
        height,
        vfov_deg: look.vfov_deg,
        face_height_frac,
        light_dir: look.light_dir_head(),
    }
}

/// The canonical mesh and every photo fitted (a photo without a usable face
/// fails here, with its name, before any session), and the fitter for the
/// probes.
pub fn fit_identities(
    photos: &[PathBuf],
) -> Result<(CanonicalMesh, Vec<PhotoIdentity>, PhotoFitter)> {
    let mesh_path = default_faces_dir().join(MESH_FILE);
    let mesh = CanonicalMesh::load(&mesh_path)?;
    let mut fitter = PhotoFitter::new(&eyereplay_extract::default_models_dir(), mesh.clone())?;
    let ids = photos
        .iter()
        .map(|p| fitter.fit(p))
        .collect::<std::result::Result<Vec<_>, _>>()?;
    Ok((mesh, ids, fitter))
}

/// What a face-mode session records in its identity file.
#[derive(Serialize)]
struct FaceIdentityRecord<'a> {
    backend: &'static str,
    photo: String,
    eye_identity: &'a Identity,
    webcam: &'a WebcamLook,
    face_height_frac: f64,
    coordination_e0_deg: f64,
    coordination_k: f64,
    task: &'static str,
    max_head_yaw_deg: f64,
    max_head_pitch_deg: f64,
    /// d(nx, ny)/d(head yaw, pitch) per degree, subtracted per frame.
    pose_slopes: Option<[[f64; 2]; 2]>,
    /// The head pose (yaw, pitch relative to rest, deg) the probe clip
    /// turned about: the middle of the session's planned head range.
    probe_head_centre_deg: Option<[f64; 2]>,
    /// `render.head_motion`: `model` or `source`.
    head_motion: HeadMotion,
    /// Frames whose head came from the source video (head_motion = source).
    source_head_frames: usize,
    /// `render.match_readback`: what the probe measured, and the fit to
    /// the first pass's read-back that the session was drawn through
    /// instead (`mapping.extractor_response`, `pose_slopes`).
    #[serde(skip_serializing_if = "Option::is_none")]
    readback_match: Option<ReadbackMatchRecord>,
    /// `horizontal` or `vertical`: the axis drawn at the geometric
    /// position where the extractor match could match only the other
    /// (`mapping.extractor_response` then has that axis's identity row).
    #[serde(skip_serializing_if = "Option::is_none")]
    geometric_axis: Option<&'static str>,
}

/// The axis a session's map left at the geometric position, matching only
/// the other, and why; `None` where it matched both or neither.
type GeometricAxis = Option<(Axis, ProbeRefusal)>;

/// What `render.match_readback` did for a session.
#[derive(Clone, Copy, Debug, Serialize)]
struct ReadbackMatchRecord {
    /// The probe's response map and pose slopes, which the first pass was
    /// drawn through.
    probe_response: Option<ResponseMap>,
    probe_pose_slopes: Option<[[f64; 2]; 2]>,
    /// The first pass drew every this many frames
    /// (`render.match_readback_every`).
    first_pass_every: usize,
    /// Open-eye frames of the first pass that the extractor read and the
    /// fit used.
    frames_fitted: usize,
    /// The fit was used; `false`: too few frames or an implausible fit,
    /// and the session is drawn through the probe's match (the first pass
    /// itself where it drew every frame).
    refined: bool,
}

/// The full-face backend, ready to draw sessions: photos fitted, mesh
/// loaded, the probe's fitter shared.
pub struct FaceBackend {
    settings: FaceBackendSettings,
    face: FaceSettings,
    encoder: EncoderSettings,
    width: usize,
    height: usize,
    natural_blinks: bool,
    mapping: GazeMapping,
    meta: DatasetMetadata,
    out: PathBuf,
    mesh: CanonicalMesh,
    identities: Vec<PhotoIdentity>,
    fitter: Mutex<PhotoFitter>,
    /// head_motion = source: each class's source head poses, read once.
    pool_heads: Mutex<BTreeMap<GazeClass, Vec<Option<PoseRow>>>>,
    /// Sessions drawn at once (`render.jobs`).
    parallel: usize,
}

impl FaceBackend {
    /// The backend for the dataset in `out`: photos fitted (a photo
    /// without a usable face fails here, with its name, before any
    /// session). `params` carries the video size, encoder and mapping
    /// template of the `[render]` settings.
    pub fn new(
        out: &Path,
        settings: &FaceBackendSettings,
        params: &RenderParams,
        natural_blinks: bool,
        parallel: usize,
    ) -> Result<Self> {
        let face = FaceSettings::from_backend(settings)?;
        let encoder = face.encoder(&params.encoder);
        let photos = identity_photos(settings, |p| p.to_path_buf());
        let (mesh, identities, mut fitter) = fit_identities(&photos)?;
        fitter.set_iris_views(settings.extractor.extractor_iris_views);
        let mapping = eyereplay_render::read_dataset_info(out)?.mapping(&params.mapping);
        Ok(FaceBackend {
            settings: settings.clone(),
            face,
            encoder,
            width: params.width,
            height: params.height,
            natural_blinks,
            mapping,
            meta: eyereplay_dataset::read_metadata(out)?.dataset,
            out: out.to_path_buf(),
            mesh,
            identities,
            fitter: Mutex::new(fitter),
            pool_heads: Mutex::new(BTreeMap::new()),
            parallel,
        })
    }
}

impl SessionBackend for FaceBackend {
    fn name(&self) -> &'static str {
        "face"
    }

    fn parallel_sessions(&self) -> usize {
        self.parallel
    }

    fn render(
        &self,
        s: &Session,
        out: &SessionOutputs,
        progress: &dyn Progress,
    ) -> Result<Rendered> {
        let settings = &self.settings;
        let files = &s.job.paths;
        let traj = &s.trajectory;
        let head_csv = out.extra(&files.head_csv());
        let mapping = self.mapping;
        let seed = s.job.seed;
        let photo = &self.identities[s.job.balanced_choice(s.dataset_seed, self.identities.len())];
        let look = self.face.webcam.sample(seed ^ 0x00ca_3e4a);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed ^ 0x4ead);
        let coordination = CoordinationParams::sample(&mut rng);
        let [lo, hi] = settings.face_height_frac;
        let frac = lo + (hi - lo) * rand::Rng::gen::<f64>(&mut rng);
        let eye_identity = Identity::sample(seed);
        let framing = framing(&look, self.width, self.height, frac);
        let scene = FaceScene::new(photo.clone(), &self.mesh, eye_identity.clone(), &framing);
        let task = match s.job.class {
            GazeClass::Reading => Task::Reading,
            GazeClass::Conversation => Task::Saccades,
        };
        // An interview reads some answers: its head moves as a reader's
        // there (Proudlock et al. 2003), as a talker's elsewhere.
        let reading_frames =
            eyereplay_dataset::read_reading_column(&files.csv)?.filter(|r| r.iter().any(|&x| x));
        let source_head = if settings.head_motion == HeadMotion::Source {
            let mut pools = self.pool_heads.lock().unwrap_or_else(|p| p.into_inner());
            Some(crate::source_head::session_heads(
                &self.out,
                &self.meta,
                &files.file,
                &mut pools,
            )?)
        } else {
            None
        };
        let mut p = FaceSessionParams {
            fps: s.fps,
            mapping,
            natural_blinks: self.natural_blinks,
            blink_rate_per_min: eye_identity.blink_rate_per_min,
            task,
            reading_frames: reading_frames.clone(),
            coordination,
            dynamics: HeadDynamics::default(),
            sway_rms: DEFAULT_SWAY_RMS.map(|r| r * settings.head_sway),
            look: look.clone(),
            encoder: self.encoder.clone(),
            seed,
            pose_slopes: None,
            source_head,
            head_path: None,
        };
        // match_extractor: measure how the extractor reads this identity,
        // framing and look, the probe's head turning about the middle of
        // the session's planned head range (ProbeHeadRange), and draw
        // through the inverse.
        let mut probe_head_centre_deg = None;
        let targets: Vec<NormPos> = traj.iter().map(|&c| mapping.target_norm(c)).collect();
        let iris_views = settings.extractor.extractor_iris_views;
        let matched = if settings.extractor.match_extractor {
            let planned = lap("plan the head path", || {
                eyereplay_face::head_path(&scene, traj, &p)
            });
            let head =
                ProbeHeadRange::of_path(planned.iter().map(|(h, _)| (h.yaw_deg, h.pitch_deg)));
            probe_head_centre_deg = Some(head.centre_deg());
            let mut fitter = self.fitter.lock().unwrap_or_else(|p| p.into_inner());
            lap(
                "probe clip (match_extractor: draw, encode, extract, fit)",
                || eyereplay_face::match_extractor(&scene, &look, &mut fitter, &targets, &head),
            )?
        } else {
            ExtractorMatch::default()
        };
        // Asked for and not had: the session is drawn at the geometric
        // position, which nothing else would say (its identity file only
        // lacks `mapping.extractor_response`).
        if settings.extractor.match_extractor && matched.response.is_none() {
            let why = matched.refused.map_or_else(
                || "the eyes too small, or cut off by the frame".to_string(),
                |r| r.to_string(),
            );
            progress.warn(&format!(
                "{}: drawn at the geometric position, not matched to the extractor, as the \
                 probe clip gave no usable fit of how the extractor reads this identity: {why}",
                files.file
            ));
        }
        p.mapping = GazeMapping {
            extractor_response: matched.response,
            ..mapping
        };
        p.pose_slopes = matched.pose_slopes;
        let probe_geometric = matched.geometric;
        let (mp4, truth) = (out.mp4(), out.truth());
        // Matched on one axis only: the other, and why (the read-back's
        // refit can match both where the probe matched one).
        let (stats, readback_match, geometric) =
            if settings.match_readback && matched.response.is_some() {
                progress.status(&format!("{} (first pass, then its read-back)", files.file));
                let (stats, record, geometric) = render_matched_to_readback(
                    &scene,
                    traj,
                    s.blinks.as_deref(),
                    &mut p,
                    [&mp4, &truth, &head_csv],
                    &targets,
                    iris_views,
                    settings.match_readback_every,
                    probe_geometric,
                )?;
                (stats, Some(record), geometric)
            } else {
                let stats = lap("draw and encode", || {
                    eyereplay_face::render_face_session(
                        &scene,
                        traj,
                        s.blinks.as_deref(),
                        &p,
                        &mp4,
                        &truth,
                        &head_csv,
                    )
                })?;
                (stats, None, probe_geometric)
            };
        // Drawn, but the reviewer should know.
        if let Some((axis, why)) = geometric {
            progress.warn(&format!(
                "{}: matched to the extractor {} only, and drawn at the geometric position {}: {why}",
                files.file,
                axis.other().adverb(),
                axis.adverb()
            ));
        }
        // What the session was drawn through in the end.
        out.write_identity(&SessionIdentity {
            file: files.file.clone(),
            seed,
            identity: FaceIdentityRecord {
                backend: "face",
                photo: photo.name.clone(),
                // The scene's: the eyeballs as drawn, the photo's iris.
                eye_identity: &scene.eye_identity,
                webcam: &look,
                face_height_frac: scene.face_frac,
                coordination_e0_deg: coordination.e0_deg,
                coordination_k: coordination.k,
                task: if reading_frames.is_some() {
                    "reading where the session reads, saccades elsewhere"
                } else if task == Task::Reading {
                    "reading"
                } else {
                    "saccades"
                },
                max_head_yaw_deg: stats.max_head_yaw_deg,
                max_head_pitch_deg: stats.max_head_pitch_deg,
                pose_slopes: p.pose_slopes,
                probe_head_centre_deg,
                head_motion: settings.head_motion,
                source_head_frames: stats.source_head_frames,
                readback_match,
                geometric_axis: geometric.map(|(axis, _)| axis.name()),
            },
            mapping: &p.mapping,
            width: self.width,
            height: self.height,
            fps: s.fps,
            eyes: None,
            extractor_iris_views: settings.extractor.match_extractor.then_some(iris_views),
        })?;
        Ok(Rendered {
            frames: stats.frames,
            clamped_points: stats.clamped_points,
        })
    }
}

/// `render.match_readback`: draws the session once through the probe's
/// match (`p`), reads that video back as `eyereplay extract` reads it (each
/// eye from `iris_views` crops), fits the response map and pose slopes to
/// its open-eye frames ([`eyereplay_face::refine_match`]), and draws the
/// session again through the fit into the session's files, with the first
/// pass's head path (the head's path depends on the drawn eye through the
/// coordination model; keeping it leaves the eye the only thing that
/// differs between the video measured and the one drawn; in an experiment
/// build, a head that moved with the refit eye misled the fit: one vertical
/// gain 0.63 became 1.53 instead of 1.18). `p` ends as the session was
/// drawn. The first
/// pass is written under hidden names beside the session's files and
/// removed; where the fit is unusable, it becomes the session (drawn again
/// whole if it drew only every `every`-th frame). Returns, with what was
/// drawn and done, the axis the final map left geometric and why: the
/// refit's, else the probe's (`probe_geometric`).
///
/// The first pass draws every `every`-th frame (`render.match_readback_every`),
/// each the frame the session would have there, encoded at the frame rate
/// over `every` and read back as such: the fit is per frame, and what
/// limits it is how many fixations it sees (each lasts several frames),
/// not how many frames of each.
#[allow(clippy::too_many_arguments)]
fn render_matched_to_readback(
    scene: &FaceScene,
    traj: &[CanvasPos],
    blinks: Option<&[bool]>,
    p: &mut FaceSessionParams,
    files: [&Path; 3],
    targets: &[NormPos],
    iris_views: usize,
    every: usize,
    probe_geometric: GeometricAxis,
) -> Result<(FaceSessionStats, ReadbackMatchRecord, GeometricAxis)> {
    let first_pass = |path: &Path| {
        let name = path.file_name().unwrap_or_default().to_string_lossy();
        path.with_file_name(format!(".first-pass.{name}"))
    };
    let temp = files.map(first_pass);
    let _listed = temp
        .each_ref()
        .map(|f| eyereplay_core::inflight::InFlight::new(f));
    let remove_temp = || {
        for f in &temp {
            let _ = std::fs::remove_file(f);
        }
    };
    let [mp4, truth, head] = &temp;
    // Its frames are kept: the second pass differs in the eyes only and
    // draws just the rows around them on the frames this one drew.
    let (first, kept) = lap("first pass: draw and encode", || {
        eyereplay_face::render_face_session_every_kept(
            scene,
            traj,
            blinks,
            p,
            every,
            [mp4, truth, head],
            eyereplay_face::KEEP_FRAMES_BUDGET_BYTES,
        )
    })?;
    let rows = match lap("first pass: read back (extract)", || {
        eyereplay_extract::extract_with_detector(
            mp4,
            &eyereplay_extract::default_models_dir(),
            first.drawn.len(),
            p.fps / every as f64,
            iris_views,
            &eyereplay_extract::NoProgress,
        )
    }) {
        Ok(rows) => rows,
        Err(e) => {
            remove_temp();
            return Err(e.into());
        }
    };
    let reads = session_reads(&first.drawn, &rows);
    let mut record = ReadbackMatchRecord {
        probe_response: p.mapping.extractor_response,
        probe_pose_slopes: p.pose_slopes,
        first_pass_every: every,
        frames_fitted: reads.len(),
        refined: false,
    };
    let Some(refit) = lap("fit the response to the read-back", || {
        eyereplay_face::refine_match(targets, &reads, probe_geometric.map(|(axis, _)| axis))
    }) else {
        if every > 1 {
            // The probe's match stands; the session is drawn whole with it.
            remove_temp();
            let [mp4, truth, head] = files;
            let whole = lap("draw and encode", || {
                eyereplay_face::render_face_session_over(
                    scene,
                    traj,
                    blinks,
                    p,
                    [mp4, truth, head],
                    &kept,
                )
            })?;
            return Ok((whole, record, probe_geometric));
        }
        // The first pass stands: it becomes the session (all three files
        // renamed, or none, as a stop finds them).
        eyereplay_core::inflight::guarded(|| {
            for (from, to) in temp.iter().zip(files) {
                if let Err(e) = std::fs::rename(from, to) {
                    remove_temp();
                    return Err(Error::io(to, e));
                }
            }
            Ok(())
        })?;
        return Ok((first, record, probe_geometric));
    };
    remove_temp();
    record.refined = true;
    p.mapping.extractor_response = refit.response;
    p.pose_slopes = refit.pose_slopes;
    p.head_path = Some(first.head_path);
    let [mp4, truth, head] = files;
    let second = lap("second pass: draw and encode", || {
        eyereplay_face::render_face_session_over(scene, traj, blinks, p, [mp4, truth, head], &kept)
    })?;
    Ok((second, record, refit.geometric))
}

/// The frames of a first pass that the read-back fit uses: read by the
/// extractor (a face, both eyes, not its blink), and clear of any drawn
/// blink as the evaluation compares them
/// ([`eyereplay_extract::widen_blinks`]).
fn session_reads(drawn: &[DrawnFrame], rows: &[eyereplay_extract::Row]) -> Vec<SessionRead> {
    let closed =
        eyereplay_extract::widen_blinks(&drawn.iter().map(|d| d.blink).collect::<Vec<_>>());
    (0..drawn.len().min(rows.len()))
        .filter(|&k| !closed[k])
        .filter_map(|k| {
            let row = &rows[k];
            let (nx, ny) = row.mean_n().filter(|_| row.valid())?;
            let d = &drawn[k];
            Some(SessionRead {
                drawn: d.drawn,
                head_deg: (d.head.yaw_deg, d.head.pitch_deg),
                measured: NormPos { nx, ny },
            })
        })
        .collect()
}

/// The full-face mode's speed bench (`eyereplay render --bench --face`): the
/// first bundled photo, framed at `width` x `height` with a default webcam
/// look, head coordination and sway on, on a reading trajectory of
/// `frames` frames; render only, encode only and end to end in one run.
/// The per-session probes (`match_extractor`) are not included: they cost
/// a 150-frame clip per session (drawn, filmed and read by the extractor),
/// whatever the session's length.
pub fn bench(width: usize, height: usize, frames: usize) -> Result<eyereplay_render::BenchReport> {
    let settings = FaceBackendSettings::default();
    let photos = identity_photos(&settings, |p| p.to_path_buf());
    let (mesh, ids, _) = fit_identities(&photos[..1])?;
    let look = WebcamRanges::default().sample(1);
    let framing = framing(&look, width, height, 0.42);
    let eye_identity = Identity::sample(1);
    let scene = FaceScene::new(ids[0].clone(), &mesh, eye_identity.clone(), &framing);
    let canvas = eyereplay_core::Canvas::default();
    let traj = eyereplay_render::reading_trajectory(
        frames,
        canvas.width_px as f64,
        canvas.height_px as f64,
    );
    let p = FaceSessionParams {
        fps: 25.0,
        mapping: GazeMapping::new(canvas),
        natural_blinks: true,
        blink_rate_per_min: eye_identity.blink_rate_per_min,
        task: Task::Reading,
        reading_frames: None,
        coordination: CoordinationParams::default(),
        dynamics: HeadDynamics::default(),
        sway_rms: DEFAULT_SWAY_RMS,
        look,
        encoder: FaceSettings::from_backend(&settings)?.encoder(&EncoderSettings::default()),
        seed: 1,
        pose_slopes: None,
        source_head: None,
        head_path: None,
    };
    Ok(eyereplay_face::run_face_bench(&scene, &traj, &p)?)
}

/// A full-face session's head yaw read back: the head pose solved from the
/// landmarks the extractor finds in `video`, whole up to
/// [`eyereplay_eval::HEAD_YAW_READ_BACK_S`] seconds (the
/// canonical face shape, the session's own field of view from its identity
/// file), against the drawn yaw in `head_csv`, each relative to its mean
/// over the frames compared. `frames` is the session's length: a head CSV
/// of another length is refused (one line naming it).
pub fn head_yaw_read_back(
    video: &Path,
    head_csv: &Path,
    identity_json: &Path,
    models_dir: &Path,
    fps: f64,
    frames: usize,
) -> Result<eyereplay_eval::HeadYawReadBack> {
    let truth = eyereplay_dataset::read_head_yaw_csv(head_csv)?;
    if truth.len() != frames {
        return Err(Error::input(
            head_csv,
            format!("{} frames, but its trajectory has {frames}", truth.len()),
        ));
    }
    let ident = SessionIdentity::read(identity_json)?;
    let vfov_deg = ident.identity["webcam"]["vfov_deg"]
        .as_f64()
        .ok_or_else(|| {
            Error::input(
                identity_json,
                "no identity.webcam.vfov_deg: not a full-face session",
            )
        })?;
    let mesh = CanonicalMesh::load(&default_faces_dir().join(MESH_FILE))?;
    let max_frames =
        ((eyereplay_eval::HEAD_YAW_READ_BACK_S * fps).round() as usize).min(truth.len());
    let poses = eyereplay_face::video_head_poses_upto(
        video,
        models_dir,
        &mesh,
        &mesh.positions_cm,
        vfov_deg,
        Some(max_frames),
        &eyereplay_extract::NoProgress,
    )?;
    let (drawn, read): (Vec<f64>, Vec<f64>) = poses
        .iter()
        .zip(&truth)
        .filter_map(|((_, p), t)| p.map(|p| (*t, p.yaw_deg)))
        .unzip();
    use eyereplay_signal::stats::{linear_fit, mean, pearson, std_pop};
    // Each relative to its own mean: the canonical shape's rest pose is not
    // the photo's (r and slope do not depend on it; the stored yaws are
    // then centred too, for whoever reads them).
    let centred = |v: &[f64]| -> Vec<f64> {
        let m = mean(v).unwrap_or(0.0);
        v.iter().map(|x| x - m).collect()
    };
    let (drawn, read) = (centred(&drawn), centred(&read));
    Ok(eyereplay_eval::HeadYawReadBack {
        frames: drawn.len(),
        frames_read: poses.len(),
        r: pearson(&drawn, &read),
        slope: linear_fit(&drawn, &read).map(|(slope, _)| slope),
        truth_sd_deg: std_pop(&drawn).unwrap_or(0.0),
    })
}

/// Checks the face backend's settings before any work: the look's ranges,
/// `match_readback`'s need of the probe, the photos (resolved by
/// `resolve`, replaced by their resolved paths) and the canonical mesh;
/// a user's photo without a usable face fails now, naming it.
pub fn check(settings: &mut FaceBackendSettings, resolve: &dyn Fn(&Path) -> PathBuf) -> Result<()> {
    FaceSettings::from_backend(settings)?;
    if settings.match_readback && !settings.extractor.match_extractor {
        return Err(Error::Setting(
            "[render]: match_readback needs match_extractor = true (it refines the probe's response map from the session's own read-back)".into(),
        ));
    }
    let photos = identity_photos(settings, resolve);
    for p in &photos {
        if !p.is_file() {
            // A photo the config names, or a bundled one not installed.
            let why = if settings.identities.is_empty() {
                "identity photo not found: set render.identities to face photos of your own (the bundled ones come with the Python package and with an eyereplay checkout's scripts/setup.sh)"
            } else {
                "identity photo not found (render.identities names it; a relative path is from the config's folder)"
            };
            return Err(Error::input(p, why));
        }
    }
    let mesh = default_faces_dir().join(MESH_FILE);
    if !mesh.is_file() {
        return Err(Error::input(
            mesh,
            "canonical face mesh not found (run scripts/setup.sh)",
        ));
    }
    eyereplay_extract::check_models(&eyereplay_extract::default_models_dir())?;
    // The bundled photos are known to fit.
    if !settings.identities.is_empty() {
        fit_identities(&photos)?;
    }
    settings.identities = photos;
    Ok(())
}
