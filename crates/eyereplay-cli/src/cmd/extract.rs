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
networks, or with --landmarks attention MediaPipe's attention face mesh (the network of its \
refine_landmarks=True: closer to MediaPipe's output, half its CPU time), all fetched by \
'eyereplay models fetch', and writes one CSV row per decoded frame: \
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
eyereplay extract franck.mp4 --out /tmp/f.csv --profile           # CPU time per frame by stage\n  \
eyereplay extract talk.mp4 --out talk.csv --landmarks attention   # MediaPipe's own network, fastest\n  \
eyereplay extract franck.mp4 --out /tmp/f.csv --bench-mediapipe   # CPU per frame vs MediaPipe Python, A B A B"
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
    /// Worker threads (0 = all cores). The rows do not depend on it: a
    /// video is cut into segments of about 15 s whatever the count.
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
    /// Read each eye from N crops (1-9) and average: the tracked crop and copies
    /// shifted by 2 px of the iris model's 64-px input, in one batched inference. The
    /// model's error depends on where the eye sits in its crop, so averaged views
    /// follow small eye movements more closely: the bundled default's rendered faces,
    /// matched and read back with 5 views, follow their source with r 0.977-0.996
    /// horizontally and 0.75-0.98 vertically, against 0.948-0.994 and 0.64-0.95 with 1.
    /// Costs about N times the iris model's CPU time. 1 = MediaPipe's single crop.
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=ex::MAX_IRIS_VIEWS as i64))]
    pub iris_views: u32,
    /// Which networks read the face and eyes. cascade: the face mesh (every
    /// --mesh-every frames), then the iris model on a 64-px crop of each eye, as
    /// MediaPipe's iris pipeline does. attention: MediaPipe's attention face mesh,
    /// which its Python face mesh runs with refine_landmarks=True, reading mesh, eye
    /// contours and irises from the one face crop on every frame: the peer tool's
    /// own network, and fewer CPU-seconds per frame (docs/EXTRACTION.md, "Where extraction's CPU
    /// time goes"). --iris-views and --mesh-every do not apply to it.
    #[arg(long, value_enum, default_value_t = LandmarksArg::Cascade)]
    pub landmarks: LandmarksArg,
    /// Compare with a MediaPipe reference CSV (scripts/dev/mediapipe_ref.sh) and print
    /// detection rate, Pearson r per axis and |difference| (one video only).
    #[arg(long)]
    pub compare: Option<PathBuf>,
    /// Where the networks run: cpu; cuda (needs EYEREPLAY_ORT_LIB pointing at an
    /// onnxruntime-gpu build's libonnxruntime.so; falls back to the CPU with a
    /// warning); or auto (CUDA when that library has it, else the CPU). The CPU is the
    /// default because these small networks ran slower on a GPU (H200: 2.2-2.5x the
    /// wall time, 1.8-2x the CPU time per frame).
    #[arg(long, value_enum, default_value_t = DeviceArg::Cpu)]
    pub device: DeviceArg,
    /// Print the CPU time per frame of each stage (decode, crops, each network,
    /// post-processing, CSV writing, set-up), summing to the process's CPU time.
    #[arg(long)]
    pub profile: bool,
    /// Benchmark against MediaPipe Python's face mesh (scripts/dev/mediapipe_ref.py):
    /// whole processes, alternating MediaPipe and eyereplay --bench-rounds times, and
    /// print each one's CPU seconds per frame and the ratio (medians over the rounds).
    /// --out gets the last eyereplay round's CSV.
    #[arg(long)]
    pub bench_mediapipe: bool,
    /// With --bench-mediapipe: how many A B rounds.
    #[arg(long, default_value_t = 3)]
    pub bench_rounds: usize,
    /// No progress bars.
    #[arg(short, long)]
    pub quiet: bool,
}

#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum LandmarksArg {
    Cascade,
    Attention,
}

impl LandmarksArg {
    fn model(self) -> ex::LandmarkModel {
        match self {
            LandmarksArg::Cascade => ex::LandmarkModel::Cascade,
            LandmarksArg::Attention => ex::LandmarkModel::Attention,
        }
    }
    fn name(self) -> &'static str {
        match self {
            LandmarksArg::Cascade => "cascade",
            LandmarksArg::Attention => "attention",
        }
    }
}

#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum DeviceArg {
    Auto,
    Cpu,
    Cuda,
}

impl DeviceArg {
    fn device(self) -> ex::Device {
        match self {
            DeviceArg::Auto => ex::Device::Auto,
            DeviceArg::Cpu => ex::Device::Cpu,
            DeviceArg::Cuda => ex::Device::Cuda,
        }
    }
    fn name(self) -> &'static str {
        match self {
            DeviceArg::Auto => "auto",
            DeviceArg::Cpu => "cpu",
            DeviceArg::Cuda => "cuda",
        }
    }
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

/// `rel` under `$EYEREPLAY_ROOT`, else above the current folder or binary.
fn find_upwards(rel: &str) -> Option<PathBuf> {
    std::env::var_os("EYEREPLAY_ROOT")
        .map(|root| PathBuf::from(root).join(rel))
        .filter(|p| p.is_file())
        .or_else(|| eyereplay_core::find_upwards(Path::new(rel)))
}

/// One whole process of a benchmark: CPU seconds (user + system, all its
/// threads and children), wall seconds and frames.
struct ProcessRun {
    cpu_s: f64,
    wall_s: f64,
    frames: f64,
    major_faults: u64,
}

impl ProcessRun {
    fn cpu_ms_per_frame(&self) -> f64 {
        1e3 * self.cpu_s / self.frames.max(1.0)
    }
}

/// Runs `cmd` to completion and measures it as a whole process (start-up,
/// imports and model loading included). `frames` reads the frame count from
/// its standard output.
fn measure_process(
    cmd: &mut std::process::Command,
    what: &str,
    frames: impl FnOnce(&str) -> Option<f64>,
) -> Result<ProcessRun> {
    let cpu0 = ex::children_cpu_s();
    let faults0 = ex::children_major_faults();
    let t0 = std::time::Instant::now();
    let out = cmd
        .stderr(std::process::Stdio::piped())
        .output()
        .with_context(|| format!("starting {what}"))?;
    let wall_s = t0.elapsed().as_secs_f64();
    let cpu_s = ex::children_cpu_s() - cpu0;
    let major_faults = ex::children_major_faults().saturating_sub(faults0);
    let text = String::from_utf8_lossy(&out.stdout);
    if !out.status.success() {
        let err = String::from_utf8_lossy(&out.stderr);
        let last = err.lines().last().unwrap_or("").trim().to_string();
        bail!("{what} failed: {last}");
    }
    let frames = frames(&text)
        .with_context(|| format!("no frame count in {what}'s output: {}", text.trim()))?;
    Ok(ProcessRun {
        cpu_s,
        wall_s,
        frames,
        major_faults,
    })
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// `--bench-mediapipe`: MediaPipe Python (A) and this same binary (B) on the
/// same video, whole processes, A B A B, so that a change in the machine's
/// load hits both; prints CPU seconds per frame and the frames-per-CPU-second
/// ratio per round and their medians.
fn bench_mediapipe(a: &Args, opts: &ex::ExtractOptions) -> Result<()> {
    if a.max_seconds.is_some() || a.compare.is_some() || a.profile || a.preview.is_some() {
        bail!("--bench-mediapipe runs whole videos alone; drop --max-seconds, --compare, --profile and --preview");
    }
    let video = &a.videos[0];
    let venv_script = find_upwards("scripts/dev/mediapipe-venv.sh").context(
        "scripts/dev/mediapipe-venv.sh not found (run from the eyereplay checkout or set EYEREPLAY_ROOT)",
    )?;
    let dev = venv_script.parent().expect("a file has a folder");
    let root = dev.join("../..");
    let cache = std::env::var_os("EYEREPLAY_CACHE")
        .map(PathBuf::from)
        .unwrap_or_else(|| root.join(".cache"));
    // Set-up once, untimed: the venv check imports mediapipe.
    let st = std::process::Command::new("bash")
        .arg(&venv_script)
        .stdout(std::process::Stdio::null())
        .status()
        .with_context(|| format!("running {}", venv_script.display()))?;
    if !st.success() {
        bail!("{} failed", venv_script.display());
    }
    let python = cache.join("venv-mediapipe/bin/python");
    let me = std::env::current_exe().context("locating the eyereplay binary")?;
    // Each eyereplay round writes --out itself (atomically), as a user's run would.
    let ours_csv = ex::output_csv_paths(&a.out, std::slice::from_ref(video))
        .map_err(anyhow::Error::msg)?
        .remove(0);
    let rounds = a.bench_rounds.max(1);
    eprintln!(
        "benchmark: {} rounds of MediaPipe Python then eyereplay on {}, whole processes",
        rounds,
        video.display()
    );
    let mut ratios = vec![];
    let (mut mp_ms, mut our_ms) = (vec![], vec![]);
    for k in 1..=rounds {
        let mp = measure_process(
            std::process::Command::new(&python)
                .arg(dev.join("mediapipe_ref.py"))
                .arg(video),
            "MediaPipe Python (mediapipe_ref.py)",
            |out| {
                out.split_whitespace()
                    .find_map(|w| w.strip_prefix("frames="))
                    .and_then(|v| v.parse().ok())
            },
        )?;
        let mut cmd = std::process::Command::new(&me);
        cmd.arg("extract")
            .arg(video)
            .arg("--out")
            .arg(&a.out)
            .arg("--quiet")
            .args(["--threads", &opts.threads.to_string()])
            .args(["--mesh-every", &opts.mesh_every.to_string()])
            .args(["--iris-views", &opts.iris_views.to_string()])
            .args(["--landmarks", a.landmarks.name()])
            .args(["--device", a.device.name()])
            .args(["--blink-ratio", &opts.blink_ratio.to_string()])
            .arg("--models")
            .arg(&opts.models_dir);
        let ours = measure_process(&mut cmd, "eyereplay extract", |_| {
            let text = std::fs::read_to_string(&ours_csv).ok()?;
            Some(text.lines().count().saturating_sub(1) as f64)
        })?;
        // Frames per CPU-second, eyereplay over MediaPipe.
        let ratio = mp.cpu_ms_per_frame() / ours.cpu_ms_per_frame();
        println!(
            "round {k}: MediaPipe {:.2} CPU-s / {:.0} frames = {:.3} ms/frame (wall {:.1} s); \
             eyereplay {:.2} CPU-s / {:.0} frames = {:.3} ms/frame (wall {:.1} s); \
             frames per CPU-second ratio {:.2}x",
            mp.cpu_s,
            mp.frames,
            mp.cpu_ms_per_frame(),
            mp.wall_s,
            ours.cpu_s,
            ours.frames,
            ours.cpu_ms_per_frame(),
            ours.wall_s,
            ratio
        );
        for (who, run) in [("MediaPipe", &mp), ("eyereplay", &ours)] {
            // A few hundred come from loading libraries; thousands mean the
            // machine was swapping out pages, which inflates CPU time.
            if run.major_faults > 2000 {
                println!(
                    "  warning: {who} had {} major page faults (memory pressure on the machine); \
                     this round's CPU time is suspect",
                    run.major_faults
                );
            }
        }
        mp_ms.push(mp.cpu_ms_per_frame());
        our_ms.push(ours.cpu_ms_per_frame());
        ratios.push(ratio);
    }
    println!(
        "median over {rounds} rounds: MediaPipe {:.3} CPU-ms/frame, eyereplay {:.3} CPU-ms/frame; \
         eyereplay / MediaPipe frames per CPU-second: {:.2}x (range {:.2}-{:.2}x)",
        median(mp_ms),
        median(our_ms),
        median(ratios.clone()),
        ratios.iter().cloned().fold(f64::INFINITY, f64::min),
        ratios.iter().cloned().fold(f64::NEG_INFINITY, f64::max),
    );
    println!("last eyereplay round's CSV -> {}", ours_csv.display());
    Ok(())
}

/// `--profile`: CPU time per frame of each stage; the rows sum to the
/// process's CPU time.
fn print_profile(stages: &ex::StageTimes, csv_s: f64, frames: usize, workers: usize, cuda: bool) {
    let frames = frames.max(1) as f64;
    let total_s = ex::process_cpu_s();
    let measured = stages.total_s() + csv_s;
    let setup_s = (total_s - measured).max(0.0);
    println!(
        "CPU time by stage ({frames:.0} frames, {workers} workers, networks on {}; thread CPU clocks):",
        if cuda { "CUDA" } else { "CPU" }
    );
    println!("  {:<42} {:>9} {:>7}", "stage", "ms/frame", "share");
    let row = |label: &str, s: f64| {
        println!(
            "  {:<42} {:>9.3} {:>6.1}%",
            label,
            1e3 * s / frames,
            100.0 * s / total_s.max(1e-12)
        );
    };
    for st in ex::Stage::ALL {
        row(st.label(), stages.get(st));
    }
    row("CSV writing", csv_s);
    row("set-up (probe, model loading, threads)", setup_s);
    row("total = process CPU time (user + sys)", setup_s + measured);
}

/// Peak resident memory of this process (Linux), in MiB.
fn peak_rss_mib() -> Option<f64> {
    let s = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = s.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb / 1024.0)
}

pub fn run(a: Args) -> Result<()> {
    let csv_paths = ex::output_csv_paths(&a.out, &a.videos).map_err(anyhow::Error::msg)?;
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
        iris_views: a.iris_views as usize,
        profile: a.profile,
        device: a.device.device(),
        landmarks: a.landmarks.model(),
    };
    if a.bench_mediapipe {
        return bench_mediapipe(&a, &opts);
    }
    let reference = match &a.compare {
        Some(p) => Some(ex::Series::read_reference(p)?),
        None => None,
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
    let results = ex::extract_many(&a.videos, &opts, &bars);
    for b in &bars.bars {
        b.finish_and_clear();
    }

    let mut failed = vec![];
    let mut total_stages = ex::StageTimes::default();
    let (mut total_frames, mut csv_s, mut on_cuda) = (0usize, 0.0, false);
    for ((video, out), res) in a.videos.iter().zip(&csv_paths).zip(results) {
        let x = match res {
            Ok(x) => x,
            Err(e) => {
                failed.push(e.to_string());
                continue;
            }
        };
        let csv_t0 = ex::thread_cpu_s();
        ex::save_csv(out, &x.rows)?;
        csv_s += ex::thread_cpu_s() - csv_t0;
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
        total_stages.add(&x.stage_times);
        total_frames += x.rows.len();
        on_cuda |= x.on_cuda;
    }
    if a.profile {
        print_profile(
            &total_stages,
            csv_s,
            total_frames,
            opts.worker_count(),
            on_cuda,
        );
        if let Some(mib) = peak_rss_mib() {
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
