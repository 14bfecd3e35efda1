//! `eyereplay extract`: iris trajectories from videos (stage 1).

use anyhow::{bail, Result};
use clap::Parser;
use eyereplay_extract as ex;
use indicatif::{MultiProgress, ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::path::PathBuf;

#[derive(Parser, Debug)]
#[command(
    about = "Extract normalized iris positions from videos (one CSV row per frame)",
    long_about = "Runs MediaPipe's face detection and attention face mesh (the network of \
MediaPipe Python's refine_landmarks=True: its own numbers, in about half its CPU time), or with \
--landmarks cascade the face mesh (every --mesh-every frames) and then the iris network on \
a 64-px crop of each eye, all fetched by scripts/setup.sh (scripts/models.sh), and writes one \
CSV row per decoded frame: frame, time_s (the frame's own presentation time), valid, nx, ny, \
blink, then per-eye values, iris centres and eye corners in pixels.\n\n\
nx runs from the image-left eye corner (0) to the image-right one (1) for BOTH eyes; \
ny from the upper lid (0) to the lower lid (1); 'left'/'right' name the eye on the \
image's left/right. Blinks (lid aperture below --blink-ratio x the video's median) \
are flagged and get valid=0.\n\n\
The cascade reads small eye movements more finely (eyereplay reads its rendered \
video back with it, each eye from 5 crops: --iris-views 5); the attention mesh \
follows MediaPipe to r 0.99 (docs/EXTRACTION.md).",
    after_help = "Examples:\n  \
eyereplay extract interview.mp4 --out interview.csv\n  \
# several videos in parallel\n  \
eyereplay extract a.mp4 b.webm c.mov --out iris/\n  \
# annotated PNGs every 5 s\n  \
eyereplay extract clip.mp4 --out iris/ --preview previews/\n  \
eyereplay extract .cache/data/franck.mp4 --out /tmp/f.csv --compare \\\n      \
crates/eyereplay-extract/tests/data/franck_mediapipe.csv\n  \
# CPU time per frame by stage\n  \
eyereplay extract .cache/data/franck.mp4 --out /tmp/f.csv --profile\n  \
# finest on small movements, ~7x the CPU\n  \
eyereplay extract talk.mp4 --out talk.csv --landmarks cascade --iris-views 5"
)]
pub struct Args {
    /// Video files (mp4, mov, webm, mkv, avi, ...).
    #[arg(required = true)]
    pub videos: Vec<PathBuf>,
    /// Output: a .csv file (one video) or a folder (one <video stem>.csv each).
    #[arg(short, long, value_name = "CSV|DIR")]
    pub out: PathBuf,
    /// Models folder [default: $EYEREPLAY_MODELS, else the Python package's, else $EYEREPLAY_CACHE/models, else .cache/models up from the current folder].
    #[arg(long)]
    pub models: Option<PathBuf>,
    /// Worker threads (0 = all cores). The rows do not depend on it: a
    /// video is cut into segments of about 15 s whatever the count.
    #[arg(long, default_value_t = 0, value_parser = super::values::whole::<usize>)]
    pub threads: usize,
    /// Write annotated PNG frames (landmarks drawn) to this folder.
    #[arg(long)]
    pub preview: Option<PathBuf>,
    /// Seconds between preview frames.
    #[arg(long, default_value_t = 5.0, value_parser = super::values::positive, requires = "preview")]
    pub preview_every: f64,
    /// A frame is a blink when its lid aperture is below this fraction of the video's median.
    #[arg(long, default_value_t = ex::DEFAULT_BLINK_RATIO, value_parser = super::values::open_fraction)]
    pub blink_ratio: f64,
    /// Only the first this many seconds of each video.
    #[arg(long, value_parser = super::values::positive)]
    pub max_seconds: Option<f64>,
    /// Cascade: run the face mesh on one frame in N (1 = MediaPipe's iris pipeline
    /// on every frame; larger is faster but agrees less with MediaPipe). Giving it
    /// selects the cascade when --landmarks is not given; the cascade's default is 2.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
    pub mesh_every: Option<u32>,
    /// Read each eye from N crops (1-9) and average: the tracked crop and copies
    /// shifted by 2 px of the iris model's 64-px input, in one batched inference. The
    /// model's error depends on where the eye sits in its crop, so averaged views
    /// follow small eye movements more closely: the bundled default's rendered faces,
    /// matched and read back with 5 views, follow their source with r 0.977-0.996
    /// horizontally and 0.75-0.98 vertically, against 0.948-0.994 and 0.64-0.95 with 1.
    /// Costs about N times the iris model's CPU time. 1 = MediaPipe's single crop.
    /// Cascade only: a value above 1 selects the cascade when --landmarks is not given.
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=ex::MAX_IRIS_VIEWS as i64))]
    pub iris_views: u32,
    /// Which networks read the face and eyes. attention (the default): MediaPipe's
    /// attention face mesh, which its Python face mesh runs with
    /// refine_landmarks=True, reading mesh, eye contours and irises from the one face
    /// crop on every frame: the peer tool's own network and numbers (r 0.99 on
    /// franck.mp4), about 2x its frames per CPU-second. cascade: the face mesh (every
    /// --mesh-every frames), then the iris model on a 64-px crop of each eye, as
    /// MediaPipe's iris pipeline does: finer on small eye movements (what eyereplay
    /// reads its rendered video back with), about twice the CPU time
    /// (docs/EXTRACTION.md). --iris-views and --mesh-every are the cascade's and
    /// select it when this is not given.
    #[arg(long, value_enum)]
    pub landmarks: Option<LandmarksArg>,
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
}

struct Bars {
    bars: Vec<ProgressBar>,
    /// Plain lines where stderr is no terminal (not with `--quiet`).
    logged: Option<super::LogClock>,
}

impl ex::Progress for Bars {
    fn start(&self, video: usize, frames: Option<u64>) {
        if let Some(n) = frames {
            self.bars[video].set_length(n);
        }
    }
    fn advance(&self, video: usize, n: u64) {
        let b = &self.bars[video];
        b.inc(n);
        if self.logged.as_ref().is_some_and(|c| c.due()) {
            super::log_line(&format!("extract {}", b.prefix()), b);
        }
    }
}

/// `--profile`: CPU time per frame of each stage; the rows sum to the
/// process's CPU time.
fn print_profile(
    stages: &ex::StageTimes,
    csv_s: f64,
    frames: usize,
    workers: usize,
    cuda: bool,
    landmarks: ex::LandmarkModel,
) {
    let frames = frames.max(1) as f64;
    let total_s = ex::process_cpu_s();
    let measured = stages.total_s() + csv_s;
    let setup_s = (total_s - measured).max(0.0);
    println!(
        "CPU time by stage ({frames:.0} frames, {workers} workers, {} landmarks, networks on {}; thread CPU clocks):",
        landmarks.name(),
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
        if let Some(label) = st.label_for(landmarks) {
            row(label, stages.get(st));
        }
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
    // The arguments first: a refusal must not leave an output folder made.
    if a.compare.is_some() && a.videos.len() != 1 {
        bail!("--compare takes exactly one video");
    }
    let csv_paths = ex::output_csv_paths(&a.out, &a.videos).map_err(anyhow::Error::msg)?;
    // Every CSV can be written, before any video is read.
    for csv in &csv_paths {
        eyereplay_core::check_writable(csv)?;
    }
    if let Some(dir) = &a.preview {
        super::check_folder_arg(dir, "--preview")?;
    }
    // Every video opens (a missing, damaged or text file), before the
    // first one is read: a batch should not stop at its last video.
    for v in &a.videos {
        ex::probe(v)?;
    }
    let landmarks = ex::landmarks_for_real_video(
        a.landmarks.map(LandmarksArg::model),
        &[
            ("--iris-views", a.iris_views > 1),
            ("--mesh-every", a.mesh_every.is_some()),
        ],
        "--landmarks cascade",
    )?;
    let opts = ex::ExtractOptions {
        models_dir: a.models.clone().unwrap_or_else(ex::default_models_dir),
        threads: a.threads,
        blink_ratio: a.blink_ratio,
        max_duration_s: a.max_seconds,
        preview_dir: a.preview.clone(),
        preview_every_s: a.preview_every,
        mesh_every: a.mesh_every.unwrap_or(ex::DEFAULT_MESH_EVERY),
        iris_views: a.iris_views as usize,
        profile: a.profile,
        device: a.device.device(),
        landmarks,
    };
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
        logged: (!a.quiet).then(super::LogClock::default),
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
        for w in &x.warnings {
            println!("  warning: {w}");
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
            opts.landmarks,
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
