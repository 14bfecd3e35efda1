//! The whole job: validate every input, extract (cached), prepare, render,
//! finalize and evaluate. Resumable and shardable.

use crate::evaluate::EvaluateOptions;
use crate::inputs::{check_models, free_bytes, video_sources};
use crate::{prepare_dataset, Error, Result};
use eyereplay_backends::{render_params, render_sessions, RenderSummary};
use eyereplay_core::{cache_dir, Progress, Shard};
use eyereplay_dataset::{BackendSettings, HeadMotion, RenderSettings};
use eyereplay_prepare::DatasetConfig;
use eyereplay_render::RenderParams;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// What [`generate`] and [`plan`] need besides the config.
#[derive(Clone, Debug, Default)]
pub struct GenerateOptions {
    /// Output dataset folder.
    pub out: PathBuf,
    /// Render only this shard's sessions (finish with [`crate::finalize`]).
    pub shard: Option<Shard>,
    /// Extraction cache (default: [`cache_dir`]`(None)`).
    pub cache: Option<PathBuf>,
    /// Evaluation of the finished dataset; `None` skips the report.
    pub evaluate: Option<EvaluateOptions>,
}

/// A validated job: everything checked, nothing written yet.
pub struct Job {
    pub config_path: PathBuf,
    pub config: DatasetConfig,
    pub settings: RenderSettings,
    pub params: RenderParams,
    pub shard: Option<Shard>,
    /// Sessions this process renders.
    pub sessions: usize,
    /// Projected size of the videos (bytes).
    pub video_bytes: u64,
}

impl Job {
    /// Frames this process renders.
    pub fn frames(&self) -> usize {
        self.sessions * self.config.session_frames
    }
}

/// Loads the config and checks every input before hours of work start:
/// source files, render settings, models (with video sources, or for
/// `render.match_extractor`), ffmpeg. What the checks measure (a replay
/// carrier's geometry) is cached in `cache`, where the run finds it.
pub fn plan(config_path: &Path, shard: Option<Shard>, cache: &Path) -> Result<Job> {
    plan_config(DatasetConfig::load(config_path)?, config_path, shard, cache)
}

/// The config's `[render]` table typed and its values checked (keys of
/// the backend, video size, encoder, the face mode's ranges), without
/// the backend's heavier checks (photos, carriers, the browser): what
/// `prepare` checks so that a typo there is not found only when the
/// dataset is rendered. Errors name `config_path`.
pub fn render_table(
    config: &DatasetConfig,
    config_path: &Path,
) -> Result<(RenderSettings, RenderParams)> {
    let settings = RenderSettings::from_config(config, config_path)?;
    let params =
        render_params(&settings, config).map_err(|e| render_error(config_path, e.to_string()))?;
    if let BackendSettings::Face(f) = &settings.backend {
        eyereplay_backends::face::FaceSettings::from_backend(f)
            .map_err(|e| render_error(config_path, e.to_string()))?;
    }
    Ok((settings, params))
}

/// An error in the config's `[render]` tables, naming the config and, when
/// the file has it, the line of the key the message names: those tables
/// are typed apart from the text, so their errors carry no position.
fn render_error(config_path: &Path, message: String) -> Error {
    match eyereplay_dataset::render_key_line(config_path, &message) {
        Some(line) => Error::input(config_path, format!("line {line}: {message}")),
        None => Error::input(config_path, message),
    }
}

/// [`plan`] for a config already loaded (from text or built in code);
/// `config_path` is the name errors give it.
pub fn plan_config(
    config: DatasetConfig,
    config_path: &Path,
    shard: Option<Shard>,
    cache: &Path,
) -> Result<Job> {
    let (settings, params) = render_table(&config, config_path)?;
    eyereplay_prepare::check_source_files(&config)?;
    if let BackendSettings::Face(f) = &settings.backend {
        if f.head_motion == HeadMotion::Source && video_sources(&config).is_empty() {
            return Err(Error::input(
                config_path,
                "[render]: head_motion = \"source\" needs at least one source with format = \"video\" (its head pose drives the head)",
            ));
        }
    }
    // The backend's own checks (photos fitted, carriers measured, the
    // browser found), its paths resolved against the config's folder.
    let settings =
        eyereplay_backends::check_settings(&settings, &|p: &Path| config.resolve(p), cache)
            .map_err(|e| match e {
                eyereplay_backends::BackendError::Setting(m) => render_error(config_path, m),
                e => e.into(),
            })?;
    let probe = settings
        .backend
        .extractor()
        .is_some_and(|e| e.match_extractor)
        && !matches!(settings.backend, BackendSettings::Face(_));
    if !video_sources(&config).is_empty() || probe {
        check_models()?;
    }
    // One frame through the encoder as configured: ffmpeg missing (said
    // with how to install it), without libx264, or refusing the settings
    // when it opens, named now rather than at the first session.
    params.encoder.check_with_ffmpeg().map_err(|e| match e {
        eyereplay_render::RenderError::Params(m) => {
            Error::input(config_path, format!("[render]: {m}"))
        }
        e => e.into(),
    })?;
    let total: usize = config.classes.values().map(|c| c.sessions).sum();
    let sessions = shard.map_or(total, |s| s.count_of(total));
    let video_bytes = (sessions * config.session_frames) as u64
        * estimate_bytes_per_frame(params.width, params.height);
    Ok(Job {
        config_path: config_path.to_path_buf(),
        config,
        settings,
        params,
        shard,
        sessions,
        video_bytes,
    })
}

impl Job {
    /// The evaluation compares each class with its sources and the classes
    /// with each other: a class without sessions would fail it only after
    /// every session is rendered, so `generate` (and its dry run) refuse
    /// such a config up front unless the evaluation is skipped.
    pub fn check_evaluable(&self) -> Result<()> {
        for class in eyereplay_core::GazeClass::ALL {
            if self
                .config
                .classes
                .get(&class)
                .is_none_or(|c| c.sessions == 0)
            {
                return Err(Error::input(
                    &self.config_path,
                    format!(
                        "class '{class}' has no sessions, and the evaluation needs both classes: add [classes.{class}], or skip the evaluation (--no-evaluate)"
                    ),
                ));
            }
        }
        Ok(())
    }
}

/// MP4 bytes per rendered frame at x264 veryfast, CRF 18, from measured
/// 1280x720 sessions (about 4 KB), scaled by pixel count, with a margin.
pub fn estimate_bytes_per_frame(width: usize, height: usize) -> u64 {
    let px = (width * height) as f64 / (1280.0 * 720.0);
    (6_000.0 * px).ceil() as u64
}

/// What [`generate`] did, stage by stage.
#[derive(Clone, Debug, Default)]
pub struct GenerateSummary {
    pub render: RenderSummary,
    /// `(stage, seconds)` in order.
    pub stage_s: Vec<(&'static str, f64)>,
    /// Set when the dataset was finished and evaluated here (no shard).
    pub report: Option<PathBuf>,
    /// The report's checks (its summary), with it.
    pub checks: Option<eyereplay_eval::report::Checks>,
}

/// Runs a validated [`Job`] into `opts.out`. Kill it at any moment and run
/// it again: finished sessions are verified and skipped.
pub fn generate(
    job: &Job,
    opts: &GenerateOptions,
    progress: &dyn Progress,
) -> Result<GenerateSummary> {
    let out = &opts.out;
    if opts.evaluate.is_some() && job.shard.is_none() {
        job.check_evaluable()?;
    }
    eyereplay_dataset::check_output_folder(out)?;
    std::fs::create_dir_all(out).map_err(|e| Error::input(out, format!("cannot create: {e}")))?;
    if let Some(free) = free_bytes(out) {
        if free < job.video_bytes {
            return Err(Error::input(
                out,
                format!(
                    "{:.1} GB free, the videos need about {:.1} GB ({} frames)",
                    free as f64 / 1e9,
                    job.video_bytes as f64 / 1e9,
                    job.frames()
                ),
            ));
        }
    }
    let recorded = recorded_metadata(out, &job.config)?;
    forget_renders_of_another_config(out, recorded.as_ref(), &job.config, job.shard, progress)?;
    // A shard run again over a merged dataset (a retried task, a check)
    // writes the trajectories' metadata afresh, without the merge's render
    // section: the dataset is no longer finished, and a line says so.
    let merged = job.shard.is_some() && recorded.is_some_and(|m| m.render.is_some());
    let mut log = RunLog::open(out)?;
    let mut summary = GenerateSummary::default();
    let mut stage = |name: &'static str, t: Instant, log: &mut RunLog| {
        let s = t.elapsed().as_secs_f64();
        log.stage(name, s);
        summary.stage_s.push((name, s));
    };

    // Extract (cached) and prepare: every shard writes identical files.
    let t = Instant::now();
    let cache = opts.cache.clone().unwrap_or_else(|| cache_dir(None));
    let prepared = prepare_dataset(&job.config, out, &cache, progress)?;
    // (`plan` allows head_motion = source with the face backend only.)
    if matches!(&job.settings.backend, BackendSettings::Face(f) if f.head_motion == HeadMotion::Source)
    {
        eyereplay_backends::source_head::write_source_heads(
            out,
            &job.config,
            &prepared.prepared,
            &cache,
            progress,
        )?;
    }
    stage("extract+prepare", t, &mut log);
    if merged {
        progress.info(&format!(
            "{}: was merged; a shard run over it undoes that (metadata.json loses its render section), so run 'eyereplay merge {}' again when the shards are done",
            out.display(),
            out.display()
        ));
    }

    // Render this shard's sessions (the renderer first removes what a
    // killed run left half-written of each of them).
    let t = Instant::now();
    let render = render_sessions(
        out,
        &job.settings,
        job.params.clone(),
        job.shard,
        &cache,
        progress,
    )?;
    stage("render", t, &mut log);
    if let Some(shard) = job.shard {
        check_no_other_config_came(out, &job.config, shard)?;
    }

    // Finish (a sharded run leaves it to 'eyereplay merge').
    let (mut report, mut checks) = (None, None);
    if job.shard.is_none() {
        let t = Instant::now();
        if let Some(ev) = crate::finalize_with_progress(out, opts.evaluate.as_ref(), progress)? {
            checks = Some(eyereplay_eval::report::checks(&ev.evaluation));
            report = Some(ev.html);
        }
        stage("merge+evaluate", t, &mut log);
    }
    summary.render = render;
    summary.report = report;
    summary.checks = checks;
    Ok(summary)
}

/// A rerun resumes by skipping finished sessions, which is right only when
/// they were rendered as this config says: when `out` holds a dataset whose
/// recorded config differs from `config` (a `[render]` setting changed
/// since, another seed, other sources or sessions: each moves the
/// trajectories or their drawing), its sessions' rendered files are
/// removed so that they are rendered again, and a line says so. The
/// trajectories (`prepare`) are written anew anyway.
///
/// A shard refuses instead: it would remove the other shards' sessions
/// without drawing them, and a shard still drawing with the folder's
/// config would finish sessions that no longer match its trajectories.
fn forget_renders_of_another_config(
    out: &Path,
    recorded: Option<&eyereplay_dataset::Metadata>,
    config: &DatasetConfig,
    shard: Option<Shard>,
    progress: &dyn Progress,
) -> Result<()> {
    let Some(old) = recorded.map(|m| &m.dataset) else {
        return Ok(());
    };
    if old.config == *config {
        return Ok(());
    }
    if let Some(s) = shard {
        return Err(Error::input(
            out,
            format!(
                "made with another config than this shard's (its [render] table, seed, sources or sessions differ); \
                 every shard of a dataset must run the same config and seed, so shard {}/{} stops here. \
                 Run it with the config the folder was made with, or start again in an empty folder",
                s.index, s.count
            ),
        ));
    }
    let removed = remove_rendered(out, old.sessions.iter())?;
    if removed > 0 {
        progress.info(&format!(
            "{}: made with another config than this one (its [render] table, seed, sources or sessions); its {removed} rendered sessions are rendered again",
            out.display()
        ));
    }
    Ok(())
}

/// The metadata `out` records, its config's folder set to `config`'s
/// (the folder a config was read from is not recorded, nor does it move a
/// session); `None` when `out` holds none yet.
fn recorded_metadata(
    out: &Path,
    config: &DatasetConfig,
) -> Result<Option<eyereplay_dataset::Metadata>> {
    if !out.join(eyereplay_dataset::layout::METADATA_FILE).is_file() {
        return Ok(None);
    }
    let mut m = eyereplay_dataset::read_metadata(out)?;
    m.dataset.config.base_dir = config.base_dir.clone();
    Ok(Some(m))
}

/// Removes the rendered files (video, truth, identity, ...) of `sessions`;
/// returns how many had any.
fn remove_rendered<'a>(
    out: &Path,
    sessions: impl Iterator<Item = &'a eyereplay_dataset::SessionEntry>,
) -> Result<usize> {
    let mut removed = 0;
    for s in sessions {
        let paths = eyereplay_dataset::SessionPaths::new(out, &s.file)
            .map_err(|e| Error::input(out.join(&s.file), e.to_string()))?;
        let mut any = false;
        for p in paths.outputs().iter().filter(|p| p.is_file()) {
            std::fs::remove_file(p).map_err(|e| Error::io(p, e))?;
            any = true;
        }
        removed += any as usize;
    }
    Ok(removed)
}

/// After a shard has drawn its sessions: the folder must still record its
/// config. Another shard started with another config while this one drew
/// (the check before drawing cannot see a start within seconds of its
/// own) leaves this shard's sessions drawn from trajectories the folder no
/// longer holds; they are removed, so that `merge` refuses the folder
/// rather than pass videos that do not match their CSVs.
fn check_no_other_config_came(out: &Path, config: &DatasetConfig, shard: Shard) -> Result<()> {
    let Some(now) = recorded_metadata(out, config)? else {
        return Ok(());
    };
    if now.dataset.config == *config {
        return Ok(());
    }
    let sessions = now.dataset.sessions.iter();
    remove_rendered(
        out,
        sessions
            .enumerate()
            .filter(|(i, _)| shard.contains(*i))
            .map(|(_, s)| s),
    )?;
    Err(Error::input(
        out,
        format!(
            "another config was written into this folder while shard {}/{} drew (a shard run with another config or seed?); \
             this shard's sessions were removed. Run every shard with one config, in an empty folder",
            shard.index, shard.count
        ),
    ))
}

/// Per-stage timings, appended to `<out>/run.log` (not to metadata.json,
/// which must come out identical on a rerun).
struct RunLog {
    file: std::fs::File,
}

impl RunLog {
    fn open(out: &Path) -> Result<Self> {
        let path = out.join(eyereplay_dataset::layout::RUN_LOG_FILE);
        let mut file = std::fs::OpenOptions::new()
            .create(true)
            .append(true)
            .open(&path)
            .map_err(|e| Error::io(&path, e))?;
        let argv: Vec<String> = std::env::args().collect();
        let now_s = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map(|d| d.as_secs())
            .unwrap_or(0);
        writeln!(
            file,
            "run {now_s} (pid {}): {}",
            std::process::id(),
            argv.join(" ")
        )
        .map_err(|e| Error::io(&path, e))?;
        Ok(RunLog { file })
    }

    fn stage(&mut self, name: &str, seconds: f64) {
        tracing::info!("{name}: {seconds:.2} s");
        // Timing is informative only: a full disk must not fail the job here.
        let _ = writeln!(self.file, "  {name}: {seconds:.2} s");
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Shard 0 of 2 has drawn its sessions (0 and 2 of four) when another
    /// seed's trajectories are written into the folder, as a shard started
    /// with another config at the same moment writes them: its sessions'
    /// files go, and it fails, so that `merge` refuses the folder; the
    /// other shard's files stay. With its own config there, it passes.
    #[test]
    fn a_shard_that_finds_another_config_after_drawing_removes_its_sessions() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("ds");
        let text = |seed: u64| {
            format!(
                "fps = 25.0\nsession_frames = 50\nseed = {seed}\n[classes.conversation]\nsessions = 4\n\
                 [[classes.conversation.generators]]\nmodel = \"conversation\"\n"
            )
        };
        let config = |seed: u64| {
            DatasetConfig::from_text(&text(seed), Path::new("t.toml"), dir.path()).unwrap()
        };
        let (mine, other) = (config(1), config(2));
        let cache = dir.path().join("cache");
        let quiet = eyereplay_core::NoProgress;
        prepare_dataset(&mine, &out, &cache, &quiet).unwrap();
        let video = |i: usize| out.join(format!("conversation/conversation_000{i}.mp4"));
        for i in 0..4 {
            std::fs::write(video(i), b"drawn").unwrap();
        }
        let shard = Shard::new(0, 2).unwrap();
        check_no_other_config_came(&out, &mine, shard).unwrap();
        assert!((0..4).all(|i| video(i).is_file()));
        prepare_dataset(&other, &out, &cache, &quiet).unwrap();
        let e = check_no_other_config_came(&out, &mine, shard)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("another config was written into this folder while shard 0/2 drew"),
            "{e}"
        );
        let left: Vec<bool> = (0..4).map(|i| video(i).is_file()).collect();
        assert_eq!(left, [false, true, false, true]);
    }
}
