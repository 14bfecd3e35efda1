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
# the bundled default sample\n  \
eyereplay generate --out out/default\n  \
# projected time and disk, from one session\n  \
eyereplay generate --config dataset.toml --dry-run\n  \
# where one default session's CPU goes\n  \
eyereplay generate --profile\n  \
# on a cluster node\n  \
eyereplay generate --config dataset.toml --out /shared/data --shard 2/8\n  \
# after all shards\n  \
eyereplay merge /shared/data\n\n\
The config is a 'prepare' config (examples/dataset.toml, docs/CONFIG.md)\n\
with an optional [render] table; each backend takes its own keys:\n  \
[render]\n  \
backend = \"eyes\"        # or \"face\", \"replay\", \"browser\" (examples/*.toml)\n  \
width = 1280            # video size (default: the canvas)\n  \
height = 720\n  \
gain = 1.0              # amplification of the iris excursion\n  \
natural_blinks = true   # blink at a natural rate\n  \
preset = \"veryfast\"     # x264\n  \
crf = 18\n  \
jobs = 0                # sessions rendered at once (0: one per core; not for replay)\n\
With backend = \"replay\": carriers = [\"me.mp4\"], real talking-head clips\n\
(default: the bundled ones).")]
pub struct Args {
    /// Dataset config (TOML); default: the bundled default sample (examples/default.toml).
    #[arg(long, value_name = "TOML")]
    pub config: Option<PathBuf>,
    /// Output dataset folder.
    #[arg(short, long, value_name = "DIR", required_unless_present_any = ["dry_run", "profile"])]
    pub out: Option<PathBuf>,
    /// Draw with this seed instead of the config's `seed`: a second draw
    /// of the same config (other people, other sessions) without copying
    /// it. Give every shard of a job the same one.
    #[arg(long, value_name = "N", value_parser = super::values::whole::<u64>)]
    pub seed: Option<u64>,
    /// Render only shard K of N (0-based), e.g. 3/8.
    #[arg(long, value_name = "K/N")]
    pub shard: Option<String>,
    /// Shard count for engines that give only an index (JOB_COMPLETION_INDEX);
    /// $EYEREPLAY_SHARDS when not given (an empty value is no value).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..))]
    pub shards: Option<u32>,
    /// Print the plan, and the wall time and disk it projects from one
    /// session rendered now in a scratch folder (as --profile); write
    /// nothing under --out.
    #[arg(long)]
    pub dry_run: bool,
    /// Render one session alone in a scratch folder, read it back as the
    /// report does, and print where its cost goes, stage by stage, in
    /// CPU-ms per frame (this process and the ffmpeg encoder apart), with
    /// the projection for the whole job. Writes nothing under --out.
    #[arg(long, conflicts_with = "dry_run")]
    pub profile: bool,
    /// With --profile: the session to measure (labels.csv's file, e.g.
    /// conversation/conversation_0002.csv; default: the first).
    #[arg(long, value_name = "FILE", requires = "profile")]
    pub session: Option<String>,
    /// With --profile or --dry-run: also write the measurement as JSON.
    #[arg(long, value_name = "FILE")]
    pub profile_json: Option<PathBuf>,
    /// Skip the evaluation report.
    #[arg(long)]
    pub no_evaluate: bool,
    /// In the report, read every rendered session back whole and tabulate
    /// each one (one extraction of every video).
    #[arg(long, conflicts_with = "no_evaluate")]
    pub read_back_all: bool,
    /// Without --read-back-all: the report reads back the first N sessions
    /// of each class whole and tabulates them (0: none; the visual section
    /// reads one session whatever this says).
    #[arg(
        long,
        default_value_t = 1,
        value_name = "N",
        conflicts_with_all = ["no_evaluate", "read_back_all"],
        value_parser = super::values::whole::<usize>
    )]
    pub read_back: usize,
    /// Folder for cached extractions (default: $EYEREPLAY_CACHE, else $XDG_CACHE_HOME/eyereplay, else ~/.cache/eyereplay).
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
    // clap drops these requirements when --dry-run, which conflicts with
    // --profile, is given; they would be ignored.
    anyhow::ensure!(
        args.session.is_none() || args.profile,
        "--session names the session --profile measures; add --profile"
    );
    anyhow::ensure!(
        args.profile_json.is_none() || args.profile || args.dry_run,
        "--profile-json writes the measurement of --profile or --dry-run; add one of them"
    );
    let shards = match args.shards {
        Some(n) => Some(n as usize),
        None => shards_from_env(std::env::var("EYEREPLAY_SHARDS").ok().as_deref())?,
    };
    let shard = Shard::resolve(args.shard.as_deref(), shards)?;
    let mut config = eyereplay::DatasetConfig::load(&config_path)?;
    if let Some(seed) = args.seed {
        config.seed = seed;
    }
    let job = eyereplay::plan_config(
        config,
        &config_path,
        shard,
        &super::cache_dir(args.cache.as_deref())?,
    )?;
    if args.dry_run && !args.no_evaluate && shard.is_none() {
        job.check_evaluable()?;
    }
    if args.dry_run || args.profile {
        let cache = super::cache_dir(args.cache.as_deref())?;
        let bars = super::Bars::default();
        eprintln!(
            "measuring {} of {} in a scratch folder ...",
            if args.profile {
                "one session alone"
            } else {
                "the sessions the job renders at once"
            },
            config_path.display()
        );
        let what = if args.profile {
            eyereplay::profile::Measure::Alone(args.session.as_deref())
        } else {
            eyereplay::profile::Measure::AsTheJobRuns
        };
        let p = eyereplay::profile::profile_session(&job, what, &cache, &bars)?;
        super::work_done();
        if let Some(path) = &args.profile_json {
            eyereplay_core::write_json(path, &p)?;
        }
        if args.profile {
            print_profile(&p);
            return Ok(());
        }
        let read_back = if args.read_back_all {
            job.sessions
        } else {
            job.config
                .classes
                .values()
                .map(|c| c.sessions.min(args.read_back))
                .sum()
        };
        // A shard and --no-evaluate write no report: `merge` does, once.
        let evaluates = !args.no_evaluate && job.shard.is_none();
        return dry_run(&job, &p, read_back, evaluates);
    }
    let out = args.out.clone().expect("clap requires --out");
    let opts = GenerateOptions {
        out: out.clone(),
        shard,
        cache: Some(super::cache_dir(args.cache.as_deref())?),
        evaluate: (!args.no_evaluate).then(|| eyereplay::EvaluateOptions {
            read_back_all: args.read_back_all,
            read_back_per_class: args.read_back,
            ..Default::default()
        }),
    };
    let bars = super::Bars::default();
    let summary = eyereplay::generate(&job, &opts, &bars)?;
    super::work_done();
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
    let took = took(minutes, r.frames, job.config.fps);
    // The report's summary: how many of its checks pass, which fail.
    if let Some(c) = &summary.checks {
        println!("report: {}", c.line());
    }
    match (shard, &summary.report) {
        (Some(s), _) => println!(
            "shard {}/{} done in {took}; run 'eyereplay merge {}' when every shard is done",
            s.index,
            s.count,
            out.display()
        ),
        (None, Some(report)) => println!(
            "dataset ready in {} ({took}): open {}",
            out.display(),
            report.display()
        ),
        (None, None) => println!("dataset ready in {} ({took})", out.display()),
    }
    Ok(())
}

/// How long the run took, and against the video it rendered: the speed
/// as video seconds per wall second (issue figures and the README's are
/// this ratio), left out when nothing was rendered (every session
/// already complete).
fn took(minutes: f64, frames_rendered: usize, fps: f64) -> String {
    let video_min = frames_rendered as f64 / fps / 60.0;
    if frames_rendered == 0 || minutes <= 0.0 {
        return format!("{minutes:.1} min");
    }
    format!(
        "{minutes:.1} min for {video_min:.1} min of video: {:.2}x real time",
        video_min / minutes
    )
}

/// The profile's table: each stage's CPU per frame of the session, this
/// process's and the encoder's apart, and its share of the session.
fn print_profile(p: &eyereplay::profile::SessionProfile) {
    let per_frame = |s: f64| 1000.0 * s / p.frames.max(1) as f64;
    let t = &p.render_total;
    let (cpu, child, wall) = (t.cpu_s, t.child_cpu_s, t.wall_s);
    let rb = &p.report_read_back;
    let total = p.session_cpu_s(true);
    println!(
        "session {} ({} frames, {:.0} s of video), rendered alone; CPU-ms per frame of it:",
        p.sessions_measured.join(", "),
        p.frames,
        p.frames as f64 / p.fps
    );
    println!(
        "  {:<62} {:>9} {:>9} {:>9} {:>6}",
        "stage", "process", "ffmpeg", "wall", "share"
    );
    let row = |name: String, l: &eyereplay_core::profile::Lap| {
        println!(
            "  {:<62} {:>9.2} {:>9.2} {:>9.2} {:>5.1}%",
            name,
            per_frame(l.cpu_s),
            per_frame(l.child_cpu_s),
            per_frame(l.wall_s),
            100.0 * (l.cpu_s + l.child_cpu_s) / total.max(1e-12)
        );
    };
    for l in &p.render {
        let name = l.stage.rsplit(" / ").next().unwrap_or(&l.stage);
        row(format!("{}{}", "  ".repeat(l.depth), name), l);
    }
    let top: f64 = p
        .render
        .iter()
        .filter(|l| l.depth == 0)
        .map(|l| l.cpu_s + l.child_cpu_s)
        .sum();
    let other = eyereplay_core::profile::Lap {
        stage: String::new(),
        depth: 0,
        cpu_s: (cpu + child - top).max(0.0),
        child_cpu_s: 0.0,
        wall_s: 0.0,
    };
    row("other (driver: files, checks)".into(), &other);
    row("report (--read-back-all): read the video back".into(), rb);
    let head = p.report_head_read_back.as_ref();
    if let Some(h) = head {
        row(
            "report (--read-back-all): read the head pose back".into(),
            h,
        );
    }
    println!(
        "  {:<62} {:>9.2} {:>9.2} {:>9.2}",
        "session total",
        per_frame(cpu + rb.cpu_s + head.map_or(0.0, |h| h.cpu_s)),
        per_frame(child + rb.child_cpu_s + head.map_or(0.0, |h| h.child_cpu_s)),
        per_frame(wall + rb.wall_s + head.map_or(0.0, |h| h.wall_s))
    );
    println!(
        "  = {:.2}x real time per core ({:.1} CPU-ms per frame at {} fps: 1000/{} ms is real time)",
        1000.0 / p.fps / per_frame(total),
        per_frame(total),
        p.fps,
        p.fps
    );
    println!(
        "  extract+prepare of the whole job: {:.2} s wall, {:.2} CPU-ms per frame of the job",
        p.prepare.wall_s,
        1000.0 * (p.prepare.cpu_s + p.prepare.child_cpu_s) / p.job_frames.max(1) as f64
    );
}

/// `read_back`: how many sessions the report reads back whole;
/// `evaluates`: whether this run writes the report (not a shard's, nor
/// with --no-evaluate).
fn dry_run(
    job: &Job,
    p: &eyereplay::profile::SessionProfile,
    read_back: usize,
    evaluates: bool,
) -> Result<()> {
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
    // A replay session's video is its carrier's size, not the canvas's.
    let size = match job.settings.backend.kind() {
        eyereplay::dataset::RenderBackend::Replay => "each carrier video's own size".to_string(),
        _ => format!("{}x{}", job.params.width, job.params.height),
    };
    println!(
        "  video: {} frames = {:.2} h at {} fps, {size}",
        frames,
        frames as f64 / cfg.fps / 3600.0,
        cfg.fps,
    );
    let mut proj = p.projection(read_back);
    let report_s = proj.evaluate_s;
    if !evaluates {
        proj.evaluate_s = 0.0;
    }
    let wall_s = proj.total_s();
    let video_s = frames as f64 / cfg.fps;
    println!(
        "  measured now on {} ({} frames, {} cores, {} sessions at once): {:.1} CPU-ms per frame to render, {:.1} to read back; the report reads back {read_back} of {} sessions",
        p.sessions_measured.join(" and "),
        p.frames,
        p.cores,
        p.parallel_sessions,
        1000.0 * p.session_cpu_s(false) / p.frames.max(1) as f64,
        1000.0 * (p.session_cpu_s(true) - p.session_cpu_s(false)) / p.frames.max(1) as f64,
        // Of the whole dataset's: a shard's report is merge's.
        cfg.classes.values().map(|c| c.sessions).sum::<usize>()
    );
    println!(
        "  projected: {:.1} min wall on this machine ({:.2}x real time; extract+prepare {:.0} s, render {:.0} s, evaluate {:.0} s), videos {:.2} GB",
        wall_s / 60.0,
        video_s / wall_s.max(1e-9),
        proj.prepare_s,
        proj.render_s,
        proj.evaluate_s,
        p.projected_video_bytes() as f64 / 1e9
    );
    println!(
        "  one hour of this video costs {:.2} CPU-hours to render ({:.2} with every session read back), {:.2} GB",
        p.session_cpu_s(false) / (p.frames as f64 / p.fps),
        p.session_cpu_s(true) / (p.frames as f64 / p.fps),
        p.video_bytes as f64 / (p.frames as f64 / p.fps) * 3600.0 / 1e9
    );
    if job.shard.is_some() {
        println!(
            "  then 'eyereplay merge', once, after every shard: about {report_s:.0} s for its report on a machine like this"
        );
    } else if wall_s > 3600.0 {
        // A job of hours: say how to spread it.
        println!(
            "  to spread it over machines: '--shard K/N' on each (docs/cluster/README.md); N machines like this one take about {:.1} h / N",
            (proj.prepare_s + proj.render_s) / 3600.0
        );
    }
    println!("nothing written (dry run)");
    Ok(())
}

/// `$EYEREPLAY_SHARDS`, refused by its own name (clap's `env` named the
/// flag, `--shards`, that the user never gave); an empty value, as
/// `export EYEREPLAY_SHARDS=$N` with N unset leaves, is no value.
fn shards_from_env(value: Option<&str>) -> anyhow::Result<Option<usize>> {
    let Some(v) = value.map(str::trim).filter(|v| !v.is_empty()) else {
        return Ok(None);
    };
    match v.parse::<usize>() {
        Ok(n) if n >= 1 => Ok(Some(n)),
        _ => anyhow::bail!(
            "EYEREPLAY_SHARDS='{v}': the shard count must be a whole number, 1 or more"
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::{shards_from_env, took};

    #[test]
    fn the_shard_count_from_the_environment_is_refused_by_its_name() {
        assert_eq!(shards_from_env(None).unwrap(), None);
        assert_eq!(shards_from_env(Some("")).unwrap(), None);
        assert_eq!(shards_from_env(Some(" 8 ")).unwrap(), Some(8));
        for bad in ["0", "x", "-2", "1.5"] {
            let e = shards_from_env(Some(bad)).unwrap_err().to_string();
            assert!(e.starts_with(&format!("EYEREPLAY_SHARDS='{bad}'")), "{e}");
        }
    }

    /// The `[render]` table `generate --help` shows can be pasted into a
    /// config: it parses, and every key in it is one the renderer takes.
    #[test]
    fn the_help_s_render_table_is_a_valid_config() {
        let cmd = <super::Args as clap::Args>::augment_args(clap::Command::new("generate"));
        let help = cmd.get_after_help().expect("examples").to_string();
        let table: Vec<&str> = help
            .lines()
            .skip_while(|l| l.trim() != "[render]")
            .take_while(|l| l.starts_with("  "))
            .map(str::trim)
            .collect();
        assert!(table.len() > 5, "{help}");
        let text = format!(
            "{}\n[classes.reading]\nsources = [{{ format = \"extract\", path = \"a.csv\" }}]\n",
            table.join("\n")
        );
        let cfg = eyereplay::DatasetConfig::parse(&text).expect("valid TOML");
        let settings =
            eyereplay::RenderSettings::from_config(&cfg, std::path::Path::new("help")).unwrap();
        assert_eq!((settings.width, settings.crf), (Some(1280), 18));
    }

    #[test]
    fn took_states_the_speed_against_the_video_rendered() {
        // 12 sessions x 750 frames at 25 fps = 6 min of video; in 3.5 min
        // that is 6 / 3.5 = 1.714x real time.
        assert_eq!(
            took(3.5, 9000, 25.0),
            "3.5 min for 6.0 min of video: 1.71x real time"
        );
        // 30 s of video at 30 fps in 2 min: 0.25x.
        assert_eq!(
            took(2.0, 900, 30.0),
            "2.0 min for 0.5 min of video: 0.25x real time"
        );
        // A resumed run with nothing left to draw states the time only.
        assert_eq!(took(0.2, 0, 25.0), "0.2 min");
    }
}
