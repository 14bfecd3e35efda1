//! `eyereplay extract`: iris trajectories from videos (stage 1).

use anyhow::{bail, Context, Result};
use clap::Parser;
use eyereplay_extract as ex;
use indicatif::{MultiProgress, ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::path::{Path, PathBuf};

#[derive(Parser, Debug)]
#[command(
    about = "Extract normalized iris positions from videos (one CSV row per frame)",
    long_about = "Runs MediaPipe's face detection, face mesh (every --mesh-every frames) and iris \
networks (fetched by 'eyereplay models fetch') and writes one CSV row per decoded frame: \
frame, time_s (the frame's own presentation time), valid, nx, ny, blink, then per-eye \
values, iris centres and eye corners in pixels.\n\n\
nx runs from the image-left eye corner (0) to the image-right one (1) for BOTH eyes; \
ny from the upper lid (0) to the lower lid (1); 'left'/'right' name the eye on the \
image's left/right. Blinks (lid aperture below --blink-ratio x the video's median) \
are flagged and get valid=0.",
    after_help = "Examples:\n  \
eyereplay extract interview.mp4 --out interview.csv\n  \
eyereplay extract a.mp4 b.webm c.mov --out iris/            # several videos in parallel\n  \
eyereplay extract clip.mp4 --out iris/ --preview previews/  # annotated PNGs every 5 s\n  \
eyereplay extract franck.mp4 --out /tmp/f.csv --compare crates/eyereplay-extract/tests/data/franck_mediapipe.csv\n  \
eyereplay extract franck.mp4 --out /tmp/f.csv --bench-mediapipe   # speed vs MediaPipe Python, same run"
)]
pub struct Args {
    /// Video files (mp4, mov, webm, mkv, avi, ...).
    #[arg(required = true)]
    pub videos: Vec<PathBuf>,
    /// Output: a .csv file (one video) or a folder (one <video stem>.csv each).
    #[arg(short, long)]
    pub out: PathBuf,
    /// Models folder [default: $EYEREPLAY_MODELS or .cache/models].
    #[arg(long)]
    pub models: Option<PathBuf>,
    /// Worker threads (0 = all cores).
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
    /// Write annotated PNG frames (landmarks drawn) to this folder.
    #[arg(long)]
    pub preview: Option<PathBuf>,
    /// Seconds between preview frames.
    #[arg(long, default_value_t = 5.0)]
    pub preview_every: f64,
    /// A frame is a blink when its lid aperture is below this fraction of the video's median.
    #[arg(long, default_value_t = ex::DEFAULT_BLINK_RATIO)]
    pub blink_ratio: f64,
    /// Only the first this many seconds of each video.
    #[arg(long)]
    pub max_seconds: Option<f64>,
    /// Run the face mesh on one frame in N (1 = MediaPipe's full pipeline on every
    /// frame; larger is faster but agrees less with MediaPipe).
    #[arg(long, default_value_t = ex::DEFAULT_MESH_EVERY)]
    pub mesh_every: u32,
    /// Compare with a MediaPipe reference CSV (scripts/dev/mediapipe_ref.sh) and print
    /// detection rate, Pearson r per axis and |difference| (one video only).
    #[arg(long)]
    pub compare: Option<PathBuf>,
    /// Benchmark: run MediaPipe Python's face mesh on the same video in this same run
    /// (scripts/dev/mediapipe_ref.sh) and print both frame rates and their ratio.
    #[arg(long)]
    pub bench_mediapipe: bool,
    /// With --bench-mediapipe: alternate MediaPipe and eyereplay this many times and
    /// also print the median ratios (steadier when the machine's load varies).
    #[arg(long, default_value_t = 1)]
    pub bench_rounds: usize,
    /// No progress bars.
    #[arg(short, long)]
    pub quiet: bool,
}

struct Bars {
    bars: Vec<ProgressBar>,
}

impl ex::Progress for Bars {
    fn start(&self, video: usize, frames: Option<u64>) {
        if let Some(n) = frames {
            self.bars[video].set_length(n);
        }
    }
    fn advance(&self, video: usize, n: u64) {
        self.bars[video].inc(n);
    }
}

fn find_upwards(rel: &str) -> Option<PathBuf> {
    if let Some(root) = std::env::var_os("EYEREPLAY_ROOT") {
        let p = PathBuf::from(root).join(rel);
        if p.is_file() {
            return Some(p);
        }
    }
    let mut starts = vec![];
    if let Ok(c) = std::env::current_dir() {
        starts.push(c);
    }
    if let Ok(e) = std::env::current_exe() {
        starts.push(e);
    }
    starts
        .iter()
        .flat_map(|s| s.ancestors().map(|d| d.join(rel)).collect::<Vec<_>>())
        .find(|p| p.is_file())
}

/// CPU seconds (user + system) of this process and of its waited-for
/// children, from /proc/self/stat (Linux; clock ticks are USER_HZ = 100).
fn cpu_seconds() -> Option<(f64, f64)> {
    let s = std::fs::read_to_string("/proc/self/stat").ok()?;
    // Fields after the parenthesised command name; utime is field 14.
    let rest = &s[s.rfind(')')? + 2..];
    let f: Vec<f64> = rest
        .split_whitespace()
        .filter_map(|v| v.parse().ok())
        .collect();
    // rest starts at field 3 (state, not numeric, so filtered out): field n
    // is at index n - 4.
    let tick = 100.0;
    Some(((f[10] + f[11]) / tick, (f[12] + f[13]) / tick))
}

/// MediaPipe's run: frames/s (wall) and CPU seconds per frame.
struct MediapipeRun {
    fps: f64,
    cpu_per_frame_s: Option<f64>,
}

/// Runs the MediaPipe reference on `video` and measures it.
fn mediapipe_fps(video: &Path, max_seconds: Option<f64>) -> Result<MediapipeRun> {
    if max_seconds.is_some() {
        bail!("--bench-mediapipe compares whole videos; drop --max-seconds");
    }
    let script = find_upwards("scripts/dev/mediapipe_ref.sh")
        .context("scripts/dev/mediapipe_ref.sh not found (run from the eyereplay checkout or set EYEREPLAY_ROOT)")?;
    eprintln!(
        "running MediaPipe Python face mesh on {} ...",
        video.display()
    );
    let children_before = cpu_seconds().map(|c| c.1);
    let out = std::process::Command::new("bash")
        .arg(&script)
        .arg(video)
        .stderr(std::process::Stdio::null())
        .output()
        .with_context(|| format!("running {}", script.display()))?;
    let text = String::from_utf8_lossy(&out.stdout);
    if !out.status.success() {
        bail!("{} failed: {}", script.display(), text.trim());
    }
    let field = |key: &str| {
        text.split_whitespace()
            .find_map(|w| w.strip_prefix(key))
            .and_then(|v| v.parse::<f64>().ok())
    };
    let fps = field("fps=")
        .with_context(|| format!("no fps= in the MediaPipe script's output: {}", text.trim()))?;
    let frames = field("frames=").unwrap_or(0.0);
    // Includes the interpreter's start-up and model loading, which its own
    // fps leaves out: a slight handicap for MediaPipe in the CPU ratio.
    let cpu_per_frame_s = children_before
        .zip(cpu_seconds().map(|c| c.1))
        .filter(|_| frames > 0.0)
        .map(|(a, b)| (b - a) / frames);
    Ok(MediapipeRun {
        fps,
        cpu_per_frame_s,
    })
}

/// Peak resident memory of this process (Linux), in MiB.
fn peak_rss_mib() -> Option<f64> {
    let s = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = s.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb / 1024.0)
}

pub fn run(a: Args) -> Result<()> {
    let single_file = a
        .out
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("csv"));
    if single_file && a.videos.len() > 1 {
        bail!(
            "--out {} is one file but {} videos were given; pass a folder",
            a.out.display(),
            a.videos.len()
        );
    }
    if (a.compare.is_some() || a.bench_mediapipe) && a.videos.len() != 1 {
        bail!("--compare and --bench-mediapipe take exactly one video");
    }
    let opts = ex::ExtractOptions {
        models_dir: a.models.clone().unwrap_or_else(ex::default_models_dir),
        threads: a.threads,
        blink_ratio: a.blink_ratio,
        max_duration_s: a.max_seconds,
        preview_dir: a.preview.clone(),
        preview_every_s: a.preview_every,
        mesh_every: a.mesh_every,
    };
    let reference = match &a.compare {
        Some(p) => Some(ex::Series::read_reference(p)?),
        None => None,
    };
    // Extra benchmark rounds before the real one: (fps ratio, CPU ratio).
    let mut rounds: Vec<(f64, Option<f64>)> = vec![];
    if a.bench_mediapipe {
        for k in 1..a.bench_rounds.max(1) {
            let mp = mediapipe_fps(&a.videos[0], a.max_seconds)?;
            let c0 = cpu_seconds().map(|c| c.0);
            let t0 = std::time::Instant::now();
            let x = ex::extract_many(&a.videos, &opts, &ex::NoProgress)
                .pop()
                .expect("one video")?;
            let fps = x.rows.len() as f64 / t0.elapsed().as_secs_f64();
            let cpu = c0
                .zip(cpu_seconds().map(|c| c.0))
                .map(|(a, b)| (b - a) / x.rows.len() as f64);
            let cpu_ratio = cpu.zip(mp.cpu_per_frame_s).map(|(o, t)| t / o);
            println!(
                "round {k}: eyereplay {fps:.1} frames/s, MediaPipe {:.1} frames/s, ratio {:.2}x, \
                 CPU-per-frame ratio {}",
                mp.fps,
                fps / mp.fps,
                cpu_ratio
                    .map(|r| format!("{r:.2}x"))
                    .unwrap_or_else(|| "n/a".into())
            );
            rounds.push((fps / mp.fps, cpu_ratio));
        }
    }
    let mp_fps: Option<MediapipeRun> = if a.bench_mediapipe {
        Some(mediapipe_fps(&a.videos[0], a.max_seconds)?)
    } else {
        None
    };

    let multi = MultiProgress::with_draw_target(if a.quiet {
        ProgressDrawTarget::hidden()
    } else {
        ProgressDrawTarget::stderr()
    });
    let style = ProgressStyle::with_template(
        "{prefix:>20} [{bar:30}] {pos}/{len} frames  {per_sec}  ETA {eta}",
    )
    .expect("valid template")
    .progress_chars("=> ");
    let bars = Bars {
        bars: a
            .videos
            .iter()
            .map(|v| {
                let b = multi.add(ProgressBar::new(0));
                b.set_style(style.clone());
                let name = v
                    .file_name()
                    .map(|n| n.to_string_lossy().to_string())
                    .unwrap_or_default();
                b.set_prefix(name);
                b
            })
            .collect(),
    };
    let cpu_before = cpu_seconds().map(|c| c.0);
    let results = ex::extract_many(&a.videos, &opts, &bars);
    let cpu_used_s = cpu_before
        .zip(cpu_seconds().map(|c| c.0))
        .map(|(a, b)| b - a);
    for b in &bars.bars {
        b.finish_and_clear();
    }

    let mut failed = vec![];
    for (video, res) in a.videos.iter().zip(results) {
        let x = match res {
            Ok(x) => x,
            Err(e) => {
                failed.push(e.to_string());
                continue;
            }
        };
        let out = if single_file {
            a.out.clone()
        } else {
            let stem = video
                .file_stem()
                .map(|s| s.to_string_lossy().to_string())
                .unwrap_or_else(|| "video".into());
            a.out.join(format!("{stem}.csv"))
        };
        ex::save_csv(&out, &x.rows)?;
        let fps = x.rows.len() as f64 / x.elapsed_s.max(1e-9);
        println!(
            "{}: {} frames ({}x{}, {}), face in {:.1}%, {} valid, {} blinks -> {}",
            video.display(),
            x.rows.len(),
            x.info.width,
            x.info.height,
            x.info.codec,
            100.0 * x.detection_rate(),
            x.valid_frames(),
            x.blinks,
            out.display()
        );
        if x.decode_errors > 0 {
            println!(
                "  warning: {} corrupt packets or frames skipped",
                x.decode_errors
            );
        }
        if let Some(r) = &reference {
            let agreement = ex::compare(&ex::Series::from_rows(&x.rows), r, opts.blink_ratio);
            println!(
                "agreement with {}:",
                a.compare.as_ref().expect("set").display()
            );
            for line in agreement.to_string().lines() {
                println!("  {line}");
            }
        }
        if a.bench_mediapipe || a.verbose_timing() {
            let t = x.stage_times;
            println!(
                "eyereplay: {:.1} frames/s ({} workers, {} segments, decoding included); \
                 stage seconds summed over workers: detect {:.2}, mesh crop {:.2}, mesh {:.2}, \
                 iris crops {:.2}, iris {:.2}",
                fps,
                opts.worker_count(),
                x.segments,
                t.detect_s,
                t.mesh_crop_s,
                t.mesh_s,
                t.iris_crop_s,
                t.iris_s
            );
        }
        if let Some(mp) = &mp_fps {
            println!(
                "MediaPipe Python face mesh: {:.1} frames/s (decoding included)",
                mp.fps
            );
            println!(
                "speed ratio eyereplay / MediaPipe (frames/s, same run): {:.2}x",
                fps / mp.fps
            );
            let mut cpu_ratio = None;
            if let (Some(ours), Some(theirs)) = (cpu_used_s, mp.cpu_per_frame_s) {
                let ours = ours / x.rows.len() as f64;
                cpu_ratio = Some(theirs / ours);
                println!(
                    "CPU per frame: eyereplay {:.2} ms, MediaPipe {:.2} ms (ratio {:.2}x; the fair \
                     comparison when other processes load the machine)",
                    1e3 * ours,
                    1e3 * theirs,
                    theirs / ours
                );
            }
            if !rounds.is_empty() {
                rounds.push((fps / mp.fps, cpu_ratio));
                let median = |mut v: Vec<f64>| {
                    v.sort_by(f64::total_cmp);
                    v[v.len() / 2]
                };
                let cpu: Vec<f64> = rounds.iter().filter_map(|r| r.1).collect();
                println!(
                    "median over {} rounds: ratio {:.2}x, CPU-per-frame ratio {}",
                    rounds.len(),
                    median(rounds.iter().map(|r| r.0).collect()),
                    if cpu.is_empty() {
                        "n/a".to_string()
                    } else {
                        format!("{:.2}x", median(cpu))
                    }
                );
            }
        }
    }
    if let Some(mib) = peak_rss_mib() {
        if a.bench_mediapipe {
            println!("peak RSS: {mib:.0} MiB");
        }
    }
    match failed.len() {
        0 => Ok(()),
        1 => bail!("{}", failed[0]),
        n => bail!(
            "{n} of {} videos failed: {}",
            a.videos.len(),
            failed.join("; ")
        ),
    }
}

impl Args {
    fn verbose_timing(&self) -> bool {
        std::env::var_os("EYEREPLAY_TIMING").is_some()
    }
}
