//! `cargo xtask bench-mediapipe`: MediaPipe Python (A) against `eyereplay
//! extract` (B) on the same video, whole processes, A B A B.

use anyhow::{bail, Context, Result};
use eyereplay_signal::stats::median;
use std::path::{Path, PathBuf};
use std::process::Command;

/// What the benchmark runs; the extract options go to B unchanged, and B
/// takes `eyereplay extract`'s defaults for those not given.
#[derive(clap::Args, Debug)]
#[command(after_help = "Examples:\n  \
cargo xtask bench-mediapipe .cache/data/franck.mp4\n  \
cargo xtask bench-mediapipe .cache/data/franck.mp4 --landmarks cascade --rounds 5\n  \
cargo xtask bench-mediapipe talk.mp4 --eyereplay /tmp/old/target/release/eyereplay")]
pub struct Args {
    /// The video both sides read whole.
    pub video: PathBuf,
    /// How many A B rounds (medians over them are printed).
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(1..))]
    pub rounds: u32,
    /// The CSV each eyereplay round writes (the last one stays)
    /// [default: target/bench-mediapipe/<video stem>.csv].
    #[arg(long, value_name = "FILE.csv")]
    pub out: Option<PathBuf>,
    /// The `eyereplay` binary of side B. Default: this checkout's
    /// target/release/eyereplay, built first (`cargo build --release -p
    /// eyereplay-cli`) so that it is never a stale one.
    #[arg(long, value_name = "PATH")]
    pub eyereplay: Option<PathBuf>,
    /// `eyereplay extract --landmarks` (cascade or attention).
    #[arg(long)]
    pub landmarks: Option<String>,
    /// `eyereplay extract --threads` (0 = all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// `eyereplay extract --mesh-every`.
    #[arg(long)]
    pub mesh_every: Option<u32>,
    /// `eyereplay extract --iris-views`.
    #[arg(long)]
    pub iris_views: Option<u32>,
    /// `eyereplay extract --device` (cpu, cuda or auto).
    #[arg(long)]
    pub device: Option<String>,
    /// `eyereplay extract --blink-ratio`.
    #[arg(long)]
    pub blink_ratio: Option<f64>,
    /// `eyereplay extract --models`.
    #[arg(long, value_name = "DIR")]
    pub models: Option<PathBuf>,
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

/// Resource use of this process's waited-for children, all together.
fn children_rusage() -> libc::rusage {
    // SAFETY: an all-zero rusage is a valid value to be overwritten.
    let mut ru: libc::rusage = unsafe { std::mem::zeroed() };
    // SAFETY: `ru` is a valid, writable rusage; RUSAGE_CHILDREN always exists.
    unsafe {
        libc::getrusage(libc::RUSAGE_CHILDREN, &mut ru);
    }
    ru
}

/// CPU seconds (user + system) of the waited-for children, and their
/// major page faults (pages read back from disk: many mean the machine
/// was short of memory, which inflates CPU time).
fn children_cpu_s_and_faults() -> (f64, u64) {
    let ru = children_rusage();
    let tv = |t: libc::timeval| t.tv_sec as f64 + t.tv_usec as f64 * 1e-6;
    (
        tv(ru.ru_utime) + tv(ru.ru_stime),
        ru.ru_majflt.max(0) as u64,
    )
}

/// Runs `cmd` to completion and measures it as a whole process (start-up,
/// imports and model loading included). `frames` reads the frame count from
/// its standard output.
fn measure_process(
    cmd: &mut Command,
    what: &str,
    frames: impl FnOnce(&str) -> Option<f64>,
) -> Result<ProcessRun> {
    let (cpu0, faults0) = children_cpu_s_and_faults();
    let t0 = std::time::Instant::now();
    let out = cmd
        .stderr(std::process::Stdio::piped())
        .output()
        .with_context(|| format!("starting {what}"))?;
    let wall_s = t0.elapsed().as_secs_f64();
    let (cpu1, faults1) = children_cpu_s_and_faults();
    let text = String::from_utf8_lossy(&out.stdout);
    if !out.status.success() {
        let err = String::from_utf8_lossy(&out.stderr);
        let last = err.lines().last().unwrap_or("").trim().to_string();
        bail!("{what} failed: {last}");
    }
    let frames = frames(&text)
        .with_context(|| format!("no frame count in {what}'s output: {}", text.trim()))?;
    Ok(ProcessRun {
        cpu_s: cpu1 - cpu0,
        wall_s,
        frames,
        major_faults: faults1.saturating_sub(faults0),
    })
}

/// The `eyereplay` binary of side B: `--eyereplay`, else this checkout's
/// release build, brought up to date first.
fn eyereplay_binary(root: &Path, given: Option<&Path>) -> Result<PathBuf> {
    if let Some(p) = given {
        return Ok(p.to_path_buf());
    }
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    eprintln!("benchmark: cargo build --release -p eyereplay-cli");
    let st = Command::new(cargo)
        .args(["build", "--quiet", "--release", "-p", "eyereplay-cli"])
        .current_dir(root)
        .status()
        .context("running cargo build")?;
    if !st.success() {
        bail!("cargo build --release -p eyereplay-cli failed");
    }
    Ok(root.join("target/release/eyereplay"))
}

/// MediaPipe Python (A) and `eyereplay extract` (B) on the same video,
/// whole processes, A B A B, so that a change in the machine's load hits
/// both; prints CPU seconds per frame and the frames-per-CPU-second ratio
/// per round and their medians.
pub fn run(root: &Path, a: &Args) -> Result<()> {
    let video = &a.video;
    if !video.is_file() {
        bail!("{}: no such video", video.display());
    }
    let dev = root.join("scripts/dev");
    let venv_script = dev.join("mediapipe-venv.sh");
    let cache = std::env::var_os("EYEREPLAY_CACHE")
        .map(PathBuf::from)
        .unwrap_or_else(|| root.join(".cache"));
    let me = eyereplay_binary(root, a.eyereplay.as_deref())?;
    // Set-up once, untimed: the venv check imports mediapipe.
    let st = Command::new("bash")
        .arg(&venv_script)
        .stdout(std::process::Stdio::null())
        .status()
        .with_context(|| format!("running {}", venv_script.display()))?;
    if !st.success() {
        bail!("{} failed", venv_script.display());
    }
    let python = cache.join("venv-mediapipe/bin/python");
    // Each eyereplay round writes --out itself (atomically), as a user's run would.
    let ours_csv = match &a.out {
        Some(p) if p.extension().is_some_and(|e| e.eq_ignore_ascii_case("csv")) => p.clone(),
        Some(p) => bail!("--out {}: give a .csv file", p.display()),
        None => {
            let stem = video.file_stem().unwrap_or_default().to_string_lossy();
            root.join(format!("target/bench-mediapipe/{stem}.csv"))
        }
    };
    if let Some(dir) = ours_csv.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    let rounds = a.rounds.max(1) as usize;
    eprintln!(
        "benchmark: {} rounds of MediaPipe Python then eyereplay on {}, whole processes",
        rounds,
        video.display()
    );
    let mut ratios = vec![];
    let (mut mp_ms, mut our_ms) = (vec![], vec![]);
    for k in 1..=rounds {
        let mp = measure_process(
            Command::new(&python)
                .arg(dev.join("mediapipe_ref.py"))
                .arg(video),
            "MediaPipe Python (mediapipe_ref.py)",
            |out| {
                out.split_whitespace()
                    .find_map(|w| w.strip_prefix("frames="))
                    .and_then(|v| v.parse().ok())
            },
        )?;
        let mut cmd = Command::new(&me);
        cmd.arg("extract")
            .arg(video)
            .arg("--out")
            .arg(&ours_csv)
            .arg("--quiet");
        let opt = |cmd: &mut Command, flag: &str, v: Option<String>| {
            if let Some(v) = v {
                cmd.args([flag, &v]);
            }
        };
        opt(&mut cmd, "--threads", a.threads.map(|v| v.to_string()));
        opt(
            &mut cmd,
            "--mesh-every",
            a.mesh_every.map(|v| v.to_string()),
        );
        opt(
            &mut cmd,
            "--iris-views",
            a.iris_views.map(|v| v.to_string()),
        );
        opt(&mut cmd, "--landmarks", a.landmarks.clone());
        opt(&mut cmd, "--device", a.device.clone());
        opt(
            &mut cmd,
            "--blink-ratio",
            a.blink_ratio.map(|v| v.to_string()),
        );
        if let Some(m) = &a.models {
            cmd.arg("--models").arg(m);
        }
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
    let med = |v: &[f64]| median(v).unwrap_or(f64::NAN);
    println!(
        "median over {rounds} rounds: MediaPipe {:.3} CPU-ms/frame, eyereplay {:.3} CPU-ms/frame; \
         eyereplay / MediaPipe frames per CPU-second: {:.2}x (range {:.2}-{:.2}x)",
        med(&mp_ms),
        med(&our_ms),
        med(&ratios),
        ratios.iter().cloned().fold(f64::INFINITY, f64::min),
        ratios.iter().cloned().fold(f64::NEG_INFINITY, f64::max),
    );
    println!("last eyereplay round's CSV -> {}", ours_csv.display());
    Ok(())
}
