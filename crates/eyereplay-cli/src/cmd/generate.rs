//! `eyereplay generate`: one command from real recordings to a finished
//! dataset: validate everything, extract (cached), prepare, render, merge,
//! evaluate. Resumable and shardable.

use crate::cmd::{self, shard::Shard};
use anyhow::{bail, Context, Result};
use eyereplay_prepare::{load_sources, prepare, write_dataset, DatasetConfig};
use eyereplay_render::{render_dataset, DatasetOptions, RenderParams, SessionOutcome};
use indicatif::{ProgressBar, ProgressStyle};
use serde::{Deserialize, Serialize};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// One command from real recordings to a finished dataset: videos, trajectory
/// CSVs, labels.csv, metadata.json and the evaluation report.
///
/// Validates every input first (sources, models, ffmpeg, disk space), then
/// extracts video sources (cached by sha256), prepares the trajectories,
/// renders every session, and evaluates. Kill it at any moment and run the
/// same command again: finished sessions are verified and skipped. With
/// --shard K/N (or SLURM_ARRAY_TASK_ID/COUNT, or JOB_COMPLETION_INDEX with
/// --shards N) only shard K's sessions are rendered; 'eyereplay merge DIR'
/// finishes the dataset once every shard is done.
#[derive(clap::Args)]
#[command(after_help = "Examples:\n  \
eyereplay generate --out out/default                        # the bundled default sample\n  \
eyereplay generate --config dataset.toml --out data/ --dry-run\n  \
eyereplay generate --config dataset.toml --out /shared/data --shard 2/8   # on a cluster node\n  \
eyereplay merge /shared/data                                # after all shards\n\n\
The config is a 'prepare' config (see examples/dataset.toml) with an optional [render] table:\n  \
[render]\n  \
width = 1280        height = 720      # video size (default: the canvas)\n  \
gain = 1.0                            # trajectory amplification of the iris excursion\n  \
natural_blinks = true                 # blink at a natural rate\n  \
preset = \"veryfast\"  crf = 18         # x264\n  \
jobs = 2                              # sessions rendered at once")]
pub struct Args {
    /// Dataset config (TOML); default: the bundled default sample (examples/default.toml).
    #[arg(long, value_name = "TOML")]
    pub config: Option<PathBuf>,
    /// Output dataset folder.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Render only shard K of N (0-based), e.g. 3/8.
    #[arg(long, value_name = "K/N")]
    pub shard: Option<String>,
    /// Shard count for engines that give only an index (JOB_COMPLETION_INDEX).
    #[arg(long, value_name = "N", env = "EYEREPLAY_SHARDS")]
    pub shards: Option<usize>,
    /// Print the plan and the projected wall time, write nothing.
    #[arg(long)]
    pub dry_run: bool,
    /// Skip the evaluation report.
    #[arg(long)]
    pub no_evaluate: bool,
    /// Folder for cached extractions (default: $EYEREPLAY_CACHE or ~/.cache/eyereplay).
    #[arg(long, value_name = "DIR")]
    pub cache: Option<PathBuf>,
}

/// The `[render]` table of a dataset config.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RenderSettings {
    pub width: Option<usize>,
    pub height: Option<usize>,
    pub gain: f64,
    pub viewing_distance_mm: f64,
    pub natural_blinks: bool,
    pub preset: String,
    pub crf: u32,
    /// Sessions rendered at once; 0 = one per core.
    pub jobs: usize,
}

impl Default for RenderSettings {
    fn default() -> Self {
        RenderSettings {
            width: None,
            height: None,
            gain: 1.0,
            viewing_distance_mm: 600.0,
            natural_blinks: true,
            preset: "veryfast".into(),
            crf: 18,
            jobs: 0,
        }
    }
}

impl RenderSettings {
    pub fn from_config(cfg: &DatasetConfig, path: &Path) -> Result<Self> {
        match &cfg.render {
            None => Ok(RenderSettings::default()),
            Some(v) => {
                let text = toml::to_string(v).expect("a TOML table serializes");
                toml::from_str::<RenderSettings>(&text).map_err(|e| {
                    anyhow::anyhow!(
                        "{}: [render]: {}",
                        path.display(),
                        eyereplay_prepare::describe_toml_error("", &e)
                    )
                })
            }
        }
    }

    pub fn params(&self, cfg: &DatasetConfig) -> RenderParams {
        let mut p = RenderParams::new(eyereplay_render::Identity::sample(0));
        p.width = self.width.unwrap_or(cfg.canvas.width_px as usize);
        p.height = self.height.unwrap_or(cfg.canvas.height_px as usize);
        p.fps = cfg.fps;
        p.mapping = eyereplay_render::GazeMapping::new(cfg.canvas);
        p.mapping.gain = self.gain;
        p.mapping.viewing_distance_mm = self.viewing_distance_mm;
        p.natural_blinks = self.natural_blinks;
        p.encoder.preset = self.preset.clone();
        p.encoder.crf = self.crf;
        p
    }

    pub fn jobs(&self) -> usize {
        if self.jobs > 0 {
            self.jobs
        } else {
            std::thread::available_parallelism()
                .map(|n| n.get())
                .unwrap_or(1)
        }
    }
}

/// The bundled default config, found beside the binary's repository.
pub fn default_config() -> Result<PathBuf> {
    let mut tried = Vec::new();
    let mut starts: Vec<PathBuf> = Vec::new();
    if let Ok(cwd) = std::env::current_dir() {
        starts.push(cwd);
    }
    if let Ok(exe) = std::env::current_exe() {
        starts.push(exe);
    }
    for s in starts {
        for dir in s.ancestors() {
            let p = dir.join("examples/default.toml");
            if p.is_file() {
                return Ok(p);
            }
            tried.push(dir.to_path_buf());
            if tried.len() > 12 {
                break;
            }
        }
    }
    bail!("no --config given and examples/default.toml not found above the current folder; run from the eyereplay checkout or pass --config")
}

pub fn run(args: Args) -> Result<()> {
    let started = Instant::now();
    let config_path = match &args.config {
        Some(p) => p.clone(),
        None => default_config()?,
    };
    let shard = Shard::resolve(args.shard.as_deref(), args.shards)?;
    let cfg = DatasetConfig::load(&config_path)?;
    let settings = RenderSettings::from_config(&cfg, &config_path)?;
    let params = settings.params(&cfg);
    params
        .validate()
        .with_context(|| format!("{}: [render]", config_path.display()))?;
    let mut log = RunLog::new(&args.out, args.dry_run)?;

    // 1. Validate every input before hours of work start.
    eyereplay_prepare::check_source_files(&cfg)?;
    let videos = cmd::video_sources(&cfg);
    if !videos.is_empty() {
        cmd::check_models()?;
    }
    cmd::check_ffmpeg(&params.encoder.ffmpeg)?;
    let total_sessions: usize = cfg.classes.values().map(|c| c.sessions).sum();
    let my_sessions = shard.map_or(total_sessions, |s| s.count_of(total_sessions));
    let frames = my_sessions * cfg.session_frames;
    let bytes_per_frame = estimate_bytes_per_frame(params.width, params.height);
    let need = frames as u64 * bytes_per_frame;
    if !args.dry_run {
        std::fs::create_dir_all(&args.out)
            .with_context(|| format!("{}: cannot create", args.out.display()))?;
        if let Some(free) = cmd::free_bytes(&args.out) {
            if free < need {
                bail!(
                    "{}: {:.1} GB free, the videos need about {:.1} GB ({} frames x {} KB)",
                    args.out.display(),
                    free as f64 / 1e9,
                    need as f64 / 1e9,
                    frames,
                    bytes_per_frame / 1000
                );
            }
        }
    }
    log.stage("validate", started);

    if args.dry_run {
        return dry_run(&cfg, &settings, &params, shard, my_sessions, need);
    }

    // 2. Extract videos (cached by content).
    let t = Instant::now();
    let cache = cmd::cache_dir(args.cache.as_deref());
    let extracted = cmd::extract_videos_cached(&cfg, &cache)?;
    log.stage("extract", t);

    // 3. Prepare the trajectories (every shard writes identical files).
    let t = Instant::now();
    let inputs = load_sources(&cfg, |v| cmd::lookup_extracted(&extracted, v))?;
    let prepared = prepare(&cfg, &inputs)?;
    for w in &prepared.warnings {
        eprintln!("warning: {w}");
    }
    write_dataset(
        &args.out,
        &cfg,
        &prepared,
        crate::cmd::prepare::tool_info(&cfg)?,
    )?;
    log.stage("prepare", t);

    // 4. Render this shard's sessions (the renderer first removes what a
    // killed run left half-written of each of them).
    let t = Instant::now();
    render(&args.out, &cfg, &settings, params, shard, my_sessions)?;
    log.stage("render", t);

    // 5. Finish: merge and evaluate (the last step of a single machine run;
    // a sharded run leaves it to 'eyereplay merge').
    if shard.is_none() {
        let t = Instant::now();
        crate::cmd::merge::finalize(&args.out, !args.no_evaluate)?;
        log.stage("merge+evaluate", t);
        println!(
            "dataset ready in {} ({:.1} min): open {}",
            args.out.display(),
            started.elapsed().as_secs_f64() / 60.0,
            args.out.join("report/index.html").display()
        );
    } else if let Some(s) = shard {
        println!(
            "shard {}/{} done in {:.1} min; run 'eyereplay merge {}' when every shard is",
            s.index,
            s.count,
            started.elapsed().as_secs_f64() / 60.0,
            args.out.display()
        );
    }
    Ok(())
}

fn render(
    out: &Path,
    cfg: &DatasetConfig,
    settings: &RenderSettings,
    params: RenderParams,
    shard: Option<Shard>,
    sessions: usize,
) -> Result<()> {
    let frames_per_session = cfg.session_frames as u64;
    let bar = ProgressBar::new(sessions as u64 * frames_per_session);
    bar.set_style(
        ProgressStyle::with_template(
            "render {bar:30} {msg} {human_pos}/{human_len} frames, {per_sec}, ETA {eta}",
        )
        .expect("static template"),
    );
    let done = std::sync::atomic::AtomicUsize::new(0);
    let opts = DatasetOptions {
        dataset_seed: cfg.seed,
        jobs: settings.jobs(),
        params,
        natural_blinks: settings.natural_blinks,
        shard: shard.map(|s| (s.index, s.count)),
    };
    let summary = render_dataset(out, &opts, &|job, outcome| {
        let n = done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
        bar.set_message(format!("{n}/{sessions} sessions"));
        bar.inc(frames_per_session);
        if let SessionOutcome::Failed(m) = outcome {
            bar.suspend(|| eprintln!("error: {}: {m}", job.file));
        }
    })?;
    bar.finish_and_clear();
    println!(
        "rendered {} sessions ({} frames), {} already complete and skipped",
        summary.rendered, summary.frames, summary.skipped
    );
    if summary.clamped_points > 0 {
        eprintln!(
            "warning: {} trajectory points were off the canvas and clamped",
            summary.clamped_points
        );
    }
    if !summary.failed.is_empty() {
        bail!(
            "{} session(s) failed (rerun the same command to retry): {}",
            summary.failed.len(),
            summary.failed.join("; ")
        );
    }
    Ok(())
}

/// MP4 bytes per rendered frame at x264 veryfast, CRF 18, from measured
/// 1280x720 sessions (about 4 KB), scaled by pixel count, with a margin.
fn estimate_bytes_per_frame(width: usize, height: usize) -> u64 {
    let px = (width * height) as f64 / (1280.0 * 720.0);
    (6_000.0 * px).ceil() as u64
}

fn dry_run(
    cfg: &DatasetConfig,
    settings: &RenderSettings,
    params: &RenderParams,
    shard: Option<Shard>,
    sessions: usize,
    bytes: u64,
) -> Result<()> {
    let frames = sessions * cfg.session_frames;
    println!("plan:");
    for (class, cc) in &cfg.classes {
        println!(
            "  {:<13} {} sessions x {} frames",
            class.name(),
            cc.sessions,
            cfg.session_frames
        );
    }
    if let Some(s) = shard {
        println!("  shard {}/{}: {} sessions", s.index, s.count, sessions);
    }
    println!(
        "  video: {} frames = {:.2} h at {} fps, {}x{}, about {:.2} GB",
        frames,
        frames as f64 / cfg.fps / 3600.0,
        cfg.fps,
        params.width,
        params.height,
        bytes as f64 / 1e9
    );
    // Projected wall time from throughput measured now, on this machine.
    let probe_frames = 100;
    let report = eyereplay_render::run_bench(params, probe_frames)?;
    let fps = report.end_to_end_fps;
    println!(
        "  measured now: {:.0} frames/s end to end ({:.1}x real time), render + x264 {}",
        fps,
        fps / cfg.fps,
        settings.preset
    );
    println!(
        "  projected render time: {:.1} min on this machine",
        frames as f64 / fps / 60.0
    );
    println!("nothing written (dry run)");
    Ok(())
}

/// Per-stage timings, appended to `<out>/run.log` (not to metadata.json,
/// which must come out identical on a rerun).
struct RunLog {
    file: Option<std::fs::File>,
}

impl RunLog {
    fn new(out: &Path, dry_run: bool) -> Result<Self> {
        if dry_run {
            return Ok(RunLog { file: None });
        }
        std::fs::create_dir_all(out)
            .with_context(|| format!("{}: cannot create", out.display()))?;
        let path = out.join("run.log");
        let mut f = std::fs::OpenOptions::new()
            .create(true)
            .append(true)
            .open(&path)
            .with_context(|| path.display().to_string())?;
        let argv: Vec<String> = std::env::args().collect();
        writeln!(
            f,
            "run {} (pid {}): {}",
            now_s(),
            std::process::id(),
            argv.join(" ")
        )?;
        Ok(RunLog { file: Some(f) })
    }

    fn stage(&mut self, name: &str, since: Instant) {
        if let Some(f) = &mut self.file {
            let _ = writeln!(f, "  {name}: {:.2} s", since.elapsed().as_secs_f64());
        }
    }
}

fn now_s() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_secs())
        .unwrap_or(0)
}
