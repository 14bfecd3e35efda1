//! `eyereplay generate`: one command from real recordings to a finished
//! dataset (the library's [`eyereplay::plan`] and [`eyereplay::generate`]).

use anyhow::Result;
use eyereplay::{GenerateOptions, Job, Shard};
use std::path::PathBuf;
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
The config is a 'prepare' config (see examples/dataset.toml and docs/CONFIG.md) with an optional [render] table:\n  \
[render]\n  \
width = 1280        height = 720      # video size (default: the canvas)\n  \
gain = 1.0                            # trajectory amplification of the iris excursion\n  \
natural_blinks = true                 # blink at a natural rate\n  \
preset = \"veryfast\"  crf = 18         # x264\n  \
jobs = 2                              # sessions rendered at once\n  \
backend = \"eyes\"                      # or \"face\" (examples/face.toml), \"replay\" (examples/replay.toml), \"browser\"\n  \
carriers = [\"me.mp4\"]                 # replay: real talking-head clips (default: the bundled ones)")]
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
    /// In the report, read every rendered session back whole and tabulate
    /// each one (one extraction of every video).
    #[arg(long, conflicts_with = "no_evaluate")]
    pub read_back_all: bool,
    /// Folder for cached extractions (default: $EYEREPLAY_CACHE or ~/.cache/eyereplay).
    #[arg(long, value_name = "DIR")]
    pub cache: Option<PathBuf>,
}

/// The bundled default config, found above the current folder or the binary.
pub fn default_config() -> Result<PathBuf> {
    eyereplay_core::find_upwards(std::path::Path::new("examples/default.toml")).ok_or_else(|| {
        anyhow::anyhow!("no --config given and examples/default.toml not found above the current folder; run from the eyereplay checkout or pass --config")
    })
}

pub fn run(args: Args) -> Result<()> {
    let started = Instant::now();
    let config_path = match &args.config {
        Some(p) => p.clone(),
        None => default_config()?,
    };
    let shard = Shard::resolve(args.shard.as_deref(), args.shards)?;
    let job = eyereplay::plan(&config_path, shard)?;
    if args.dry_run {
        return dry_run(&job);
    }
    let opts = GenerateOptions {
        out: args.out.clone(),
        shard,
        cache: Some(eyereplay::cache_dir(args.cache.as_deref())),
        evaluate: (!args.no_evaluate).then(|| eyereplay::EvaluateOptions {
            read_back_all: args.read_back_all,
            ..Default::default()
        }),
    };
    let bars = super::Bars::default();
    let summary = eyereplay::generate(&job, &opts, &bars)?;
    let r = &summary.render;
    println!(
        "rendered {} sessions ({} frames), {} already complete and skipped",
        r.rendered, r.frames, r.skipped
    );
    if r.clamped_points > 0 {
        eprintln!(
            "warning: {} trajectory points were off the canvas and clamped",
            r.clamped_points
        );
    }
    let minutes = started.elapsed().as_secs_f64() / 60.0;
    match (shard, &summary.report) {
        (Some(s), _) => println!(
            "shard {}/{} done in {minutes:.1} min; run 'eyereplay merge {}' when every shard is",
            s.index,
            s.count,
            args.out.display()
        ),
        (None, Some(report)) => println!(
            "dataset ready in {} ({minutes:.1} min): open {}",
            args.out.display(),
            report.display()
        ),
        (None, None) => println!("dataset ready in {} ({minutes:.1} min)", args.out.display()),
    }
    Ok(())
}

fn dry_run(job: &Job) -> Result<()> {
    let cfg = &job.config;
    println!("plan:");
    for (class, cc) in &cfg.classes {
        println!(
            "  {:<13} {} sessions x {} frames",
            class.name(),
            cc.sessions,
            cfg.session_frames
        );
    }
    if let Some(s) = job.shard {
        println!("  shard {}/{}: {} sessions", s.index, s.count, job.sessions);
    }
    let frames = job.frames();
    println!(
        "  video: {} frames = {:.2} h at {} fps, {}x{}, about {:.2} GB",
        frames,
        frames as f64 / cfg.fps / 3600.0,
        cfg.fps,
        job.params.width,
        job.params.height,
        job.video_bytes as f64 / 1e9
    );
    // Projected wall time from throughput measured now, on this machine.
    let report = eyereplay_render::run_bench(&job.params, 100)?;
    let fps = report.end_to_end_fps;
    println!(
        "  measured now: {:.0} frames/s end to end ({:.1}x real time), render + x264 {}",
        fps,
        fps / cfg.fps,
        job.settings.preset
    );
    println!(
        "  projected render time: {:.1} min on this machine",
        frames as f64 / fps / 60.0
    );
    println!("nothing written (dry run)");
    Ok(())
}
