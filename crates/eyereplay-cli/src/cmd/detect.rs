use super::Bars;
use eyereplay::detect::DetectorModel;
use eyereplay::detector::{detect_track, detection_figure, load_track, Detection};
use std::path::{Path, PathBuf};

/// The default model, built in: the file the Python package ships as
/// `eyereplay.DEFAULT_DETECTOR` (`cargo xtask default-detector` trains it
/// again and puts it there).
const BUILT_IN_MODEL: &str =
    include_str!("../../../eyereplay-py/python/eyereplay/default_detector.json");

/// How results (a detection's `model.path`) name the built-in model.
const BUILT_IN_MODEL_NAME: &str = "built-in default model";

/// The model in `file`, or the built-in one; with the path that names it
/// in errors and results.
pub fn load_model(file: Option<&Path>) -> anyhow::Result<(DetectorModel, PathBuf)> {
    Ok(match file {
        Some(path) => {
            // Not the bare "No such file or directory" of the read: say it
            // is the model, and that the command has one of its own.
            anyhow::ensure!(
                path.exists(),
                "--model {}: no such file (a model 'eyereplay train' writes; without --model the built-in one is used)",
                path.display()
            );
            (DetectorModel::load(path)?, path.to_path_buf())
        }
        None => {
            let name = PathBuf::from(BUILT_IN_MODEL_NAME);
            (DetectorModel::parse(BUILT_IN_MODEL, &name)?, name)
        }
    })
}

/// Is the person in this video reading? Per-window probabilities and a verdict.
///
/// INPUT is a video (the iris is extracted first, cached), an 'eyereplay
/// extract' CSV, or a session CSV (frame,x,y at 25 fps). It is cut into
/// non-overlapping windows of the model's length; each gets a reading
/// probability, and the recording a verdict from their mean; reading
/// segments with their times come from overlapping windows (docs/DETECTOR.md).
/// A clip shorter than one window (from 3 s of gaze) is scored from its
/// best stretch with a 90 % bootstrap interval, and called `uncertain`
/// when the interval holds the threshold. Writes OUT/<name>_detect.json,
/// a plot of the probability over time under the gaze track
/// (OUT/<name>_detect.png) and a reviewer's page, the video with its
/// timeline (OUT/<name>_detect.html); --live with --out writes them as
/// live_detect.*.
#[derive(clap::Args)]
// One group, so that the usage line and a missing input both show the
// two ways in: `<INPUT|--live <SOURCE>>`.
#[command(group = clap::ArgGroup::new("source").required(true).args(["input", "live"]))]
#[command(after_help = "Examples:\n  \
eyereplay detect interview.mp4                 # the built-in model\n  \
eyereplay detect iris.csv --model m.json --out results/ --json\n  \
# a camera\n  \
eyereplay detect --live /dev/video0\n  \
eyereplay detect --live rtsp://camera.local/stream --model m.json\n  \
# a call played at real speed through standard input\n  \
ffmpeg -re -i call.mp4 -f nut -c:v rawvideo -pix_fmt yuv420p - | \\\n      \
eyereplay detect --live -\n\n\
Your own model: 'eyereplay train DATASET --out m.json' (docs/DETECTOR.md).")]
pub struct Args {
    /// A video, an 'eyereplay extract' CSV, or a frame,x,y session CSV.
    pub input: Option<PathBuf>,
    /// Watch a live stream instead: a camera (/dev/video0, opened through
    /// --ffmpeg), a network stream (rtsp://, http://), '-' for a video
    /// stream on standard input (NUT, Matroska, MPEG-TS; raw frames as
    /// yuv420p or rgb24, or any codec FFmpeg decodes), or a file, read as
    /// fast as it decodes. From the first window's end (10 s with the
    /// built-in model), prints each window as it closes, one a second,
    /// overlapping: start_s end_s P(reading) call gaze_s (seconds with
    /// gaze in it) lag_s (how long after the window's end it was printed).
    /// Then the whole stream's result as for a file: its non-overlapping
    /// windows scored again from the whole track (a figure can differ a
    /// little from its live line), the segments and the verdict. The rows,
    /// segments and verdict go to standard output, the table and messages
    /// to standard error (with --json, all but the JSON); with --out, the JSON and the reviewer's page as
    /// for a file. Ctrl-C ends the watch with that result, status 0, as
    /// the stream's end does; a second Ctrl-C stops at once.
    #[arg(long, value_name = "SOURCE")]
    pub live: Option<String>,
    /// The ffmpeg program that opens a camera for --live (streams, files
    /// and standard input are read in-process).
    #[arg(long, value_name = "PATH", default_value = "ffmpeg")]
    pub ffmpeg: PathBuf,
    /// With --live: a stream that gives no frame for this many seconds is
    /// taken as ended (network streams; a pipe waits for data or Ctrl-C).
    /// 0 waits as long as it takes [default: 30].
    #[arg(long, value_name = "S")]
    pub stall_timeout_s: Option<f64>,
    /// A model written by 'eyereplay train' (default: the built-in one,
    /// the model the Python package ships: bagged trees on 10-s windows,
    /// trained on 32 generated people drawn as whole faces; the model
    /// scripts/run.sh trains into out/default/detector.json).
    #[arg(long, value_name = "MODEL")]
    pub model: Option<PathBuf>,
    /// Folder for the JSON, the plot and the page (default: beside the
    /// input; with --live, none unless given).
    #[arg(short, long, value_name = "DIR")]
    pub out: Option<PathBuf>,
    /// Also print the JSON to standard output; everything else then goes
    /// to standard error, so the output is the JSON alone.
    #[arg(long)]
    pub json: bool,
    /// Extraction cache (default: $EYEREPLAY_CACHE, else $XDG_CACHE_HOME/eyereplay, else ~/.cache/eyereplay).
    #[arg(long, value_name = "DIR")]
    pub cache: Option<PathBuf>,
    /// Time the detector on the loaded track (windows, features, model;
    /// repeated for at least a second) and print its speed against real
    /// time (goal: at least 100x). Writes nothing.
    #[arg(long, conflicts_with = "live")]
    pub bench: bool,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    // Said here, not by clap's `requires`: its "required arguments were
    // not provided: --live" does not say what the option is for.
    anyhow::ensure!(
        args.live.is_some() || args.stall_timeout_s.is_none(),
        "--stall-timeout-s is for --live only (a stream that stops sending frames)"
    );
    // The model first: a bad one stops before any extraction.
    let (model, model_path) = load_model(args.model.as_deref())?;
    // And the output folder: a file there would fail only after the
    // video is read.
    if let Some(out) = &args.out {
        anyhow::ensure!(
            !out.exists() || out.is_dir(),
            "{}: --out takes a folder (the results are written into it), and this is a file",
            out.display()
        );
        // Made and tried now: an hour of a live call must not end in a
        // folder that cannot be written.
        let probe = out.join(format!(".eyereplay-write-test-{}", std::process::id()));
        std::fs::create_dir_all(out)
            .and_then(|()| std::fs::write(&probe, b""))
            .and_then(|()| std::fs::remove_file(&probe))
            .map_err(|e| anyhow::anyhow!("{}: --out cannot be written: {e}", out.display()))?;
    }
    if let Some(source) = &args.live {
        return live(&args, source, &model, &model_path);
    }
    let input = args.input.clone().expect("clap requires it");
    let out_dir = args.out.clone().unwrap_or_else(|| {
        input
            .parent()
            .filter(|p| !p.as_os_str().is_empty())
            .map_or_else(|| PathBuf::from("."), Path::to_path_buf)
    });
    let stem = input
        .file_stem()
        .map_or_else(|| "input".into(), |s| s.to_string_lossy().into_owned());
    // The results beside the input (no --out) can be written, before the
    // extraction: a read-only folder must not cost the whole video first.
    if args.out.is_none() && !args.bench && input.is_file() {
        for ext in ["json", "png", "html"] {
            eyereplay_core::check_writable(&out_dir.join(format!("{stem}_detect.{ext}")))?;
        }
    }
    let cache = super::cache_dir(args.cache.as_deref())?;
    let (track, info) = load_track(&input, &cache, &Bars::default())?;
    if args.bench {
        return bench(&track, info, &model, &model_path);
    }
    let d = detect_track(&track, info, &model, &model_path)?;
    let href = (d.input.kind == "video").then(|| relative_href(&input, &out_dir));
    let (text, [json_path, png_path, html_path]) =
        write_detection(&track, &d, &out_dir, &stem, href.as_deref())?;
    print_detection(&d, args.json);
    eprintln!(
        "wrote {}, {} and {}",
        json_path.display(),
        png_path.display(),
        html_path.display()
    );
    if args.json {
        print!("{text}");
    }
    Ok(())
}

/// Writes `<stem>_detect.{json,png,html}` into `out_dir`; returns the JSON
/// text and the three paths.
fn write_detection(
    track: &eyereplay::detect::Track,
    d: &Detection,
    out_dir: &Path,
    stem: &str,
    video_href: Option<&str>,
) -> anyhow::Result<(String, [PathBuf; 3])> {
    let json_path = out_dir.join(format!("{stem}_detect.json"));
    let png_path = out_dir.join(format!("{stem}_detect.png"));
    let html_path = out_dir.join(format!("{stem}_detect.html"));
    let mut text = serde_json::to_string_pretty(d)?;
    text.push('\n');
    eyereplay::core::atomic_write(&json_path, text.as_bytes())?;
    let fig = detection_figure(track, d)?;
    eyereplay::core::atomic_write(&png_path, &fig.png)?;
    // The reviewer's page links the video by a path relative to itself.
    let page = eyereplay::detection_page(track, d, video_href);
    eyereplay::core::atomic_write(&html_path, page.as_bytes())?;
    Ok((text, [json_path, png_path, html_path]))
}

/// `detect --live SOURCE`: windows as they close, then the stream's result.
fn live(args: &Args, source: &str, model: &DetectorModel, model_path: &Path) -> anyhow::Result<()> {
    use std::io::IsTerminal;
    let stall_s = args.stall_timeout_s.unwrap_or(30.0);
    anyhow::ensure!(
        !source.trim().is_empty(),
        "--live takes a source: a camera (/dev/video0), a stream URL (rtsp://, http://) or - for standard input"
    );
    let src = eyereplay::live::LiveSource::parse(source);
    anyhow::ensure!(
        src != eyereplay::live::LiveSource::Stdin || !std::io::stdin().is_terminal(),
        "--live -: standard input is a terminal; pipe a video stream into it, for example: \
         ffmpeg -re -i call.mp4 -f nut -c:v rawvideo -pix_fmt yuv420p - | eyereplay detect --live -"
    );
    anyhow::ensure!(
        stall_s.is_finite() && stall_s >= 0.0,
        "--stall-timeout-s takes seconds, 0 or more (0: wait as long as it takes)"
    );
    let stop = eyereplay::live::Stop {
        requested: Default::default(),
        stall_s: (stall_s > 0.0).then_some(stall_s),
    };
    stop_on_signals(stop.requested.clone());
    let mut table = LiveTable {
        header: true,
        to_stderr: args.json,
        banner: format!(
            "one {} s window a second, scored when {:.1} s of it have gaze, threshold {:.3} \
             (Ctrl-C, or the end of the stream, ends the watch with its result)",
            model.window_s,
            model.window_s * (1.0 - eyereplay::detect::window::MAX_MISSING_FRACTION),
            model.threshold
        ),
        label: src.label(),
    };
    let outcome = eyereplay::live::watch(&src, model, model_path, &args.ffmpeg, &stop, &mut table)?;
    let ended = match outcome.end {
        eyereplay::live::LiveEnd::StreamEnded => "the stream ended",
        eyereplay::live::LiveEnd::Stopped => "stopped",
        eyereplay::live::LiveEnd::Stalled => "the stream stalled",
    };
    // The source's frames, and the 25 fps track the detector reads (the
    // JSON's `frames` and `gaze_fraction`), each named.
    let track_s = outcome.track.len() as f64 / eyereplay::detect::FPS;
    let gaze = outcome.track.xy.iter().filter(|p| p[0].is_finite()).count();
    eprintln!(
        "{ended}: {} frame{} over {track_s:.1} s, a face in {:.1} % of them, gaze in {:.1} % of the time",
        outcome.frames,
        if outcome.frames == 1 { "" } else { "s" },
        100.0 * outcome.face_frames as f64 / outcome.frames.max(1) as f64,
        100.0 * gaze as f64 / outcome.track.len().max(1) as f64
    );
    let d = match outcome.detection {
        Ok(d) => d,
        Err(_) if outcome.face_frames == 0 => {
            // As a file with no face is refused, not "not enough gaze".
            anyhow::bail!(
                "{}: no face found in any of its {} frames",
                src.label(),
                outcome.frames
            );
        }
        Err(why) => {
            let label = src.label();
            anyhow::bail!(
                "{label}: the whole stream cannot be scored: {}",
                why.strip_prefix(&format!("{label}: ")).unwrap_or(&why)
            );
        }
    };
    // The files first: a reader of standard output that has gone (`| head`)
    // ends the program at the next line printed.
    let text = match &args.out {
        Some(out_dir) => {
            let (text, paths) = write_detection(&outcome.track, &d, out_dir, "live", None)?;
            eprintln!(
                "wrote {}",
                paths
                    .iter()
                    .map(|p| p.display().to_string())
                    .collect::<Vec<_>>()
                    .join(", ")
            );
            text
        }
        None => serde_json::to_string_pretty(&d)? + "\n",
    };
    print_detection(&d, args.json);
    if args.json {
        print!("{text}");
    }
    Ok(())
}

/// The live table: a line for each window as it closes, on standard
/// output (standard error with --json); warnings on standard error.
struct LiveTable {
    /// The header goes with the first row, so that a source that never
    /// opens leaves the output empty.
    header: bool,
    to_stderr: bool,
    /// "watching SOURCE: ...", said once the source has opened.
    label: String,
    banner: String,
}

impl eyereplay::live::LiveObserver for LiveTable {
    fn window(&mut self, w: &eyereplay::live::LiveWindow) {
        use std::io::Write;
        let mut line = String::new();
        if std::mem::take(&mut self.header) {
            line += &format!(
                "{:>8} {:>8}  {:>10}  {:>7}  {:>6}  {:>6}\n",
                "start_s", "end_s", "P(reading)", "call", "gaze_s", "lag_s"
            );
        }
        // A window with some gaze, but less than a score needs, is not one
        // without any.
        let p = match w.reading_probability {
            Some(p) => format!("{p:.3}"),
            None if w.gaze_s > 0.0 => "too little".into(),
            None => "no gaze".into(),
        };
        line += &format!(
            "{:>8.1} {:>8.1}  {:>10}  {:>7}  {:>6.1}  {:>6.2}\n",
            w.start_s,
            w.end_s,
            p,
            if w.reading { "reading" } else { "-" },
            w.gaze_s,
            w.lag_s.max(0.0)
        );
        // Each line as it is decided, even into a pipe.
        if self.to_stderr {
            let _ = std::io::stderr().write_all(line.as_bytes());
        } else {
            let mut out = std::io::stdout().lock();
            let _ = out.write_all(line.as_bytes());
            let _ = out.flush();
        }
    }

    fn warning(&mut self, message: &str) {
        eprintln!("warning: {message}");
    }

    fn opened(&mut self, width: usize, height: usize) {
        eprintln!(
            "watching {} ({width}x{height}): {}",
            self.label, self.banner
        );
    }
}

/// Ctrl-C (SIGINT) and SIGTERM set `flag`, which ends a live watch with
/// what it has; another one a second or more later ends the program at
/// once, as by default (one within the second is the same stop delivered
/// twice: a wrapper such as `timeout` passes on the Ctrl-C its process
/// group got too). The handler is installed without SA_RESTART, so a read
/// that waits on a pipe returns (EINTR) and FFmpeg asks its interrupt
/// callback, which reads the flag; a network read asks it on its own every
/// 100 ms or so.
fn stop_on_signals(flag: std::sync::Arc<std::sync::atomic::AtomicBool>) {
    use std::sync::atomic::{AtomicI64, Ordering};
    use std::sync::OnceLock;
    static FLAG: OnceLock<std::sync::Arc<std::sync::atomic::AtomicBool>> = OnceLock::new();
    // CLOCK_MONOTONIC milliseconds of the first signal.
    static FIRST_MS: AtomicI64 = AtomicI64::new(0);
    extern "C" fn on_signal(sig: libc::c_int) {
        // Only async-signal-safe work here: atomics, clock_gettime, and on
        // a later signal the default action restored and raised.
        let Some(flag) = FLAG.get() else { return };
        // SAFETY: clock_gettime is async-signal-safe; `now` is a valid out
        // pointer.
        let now_ms = unsafe {
            let mut now: libc::timespec = std::mem::zeroed();
            libc::clock_gettime(libc::CLOCK_MONOTONIC, &mut now);
            now.tv_sec as i64 * 1000 + now.tv_nsec as i64 / 1_000_000
        };
        if !flag.swap(true, Ordering::SeqCst) {
            FIRST_MS.store(now_ms, Ordering::SeqCst);
        } else if now_ms - FIRST_MS.load(Ordering::SeqCst) >= 1000 {
            // SAFETY: signal and raise are async-signal-safe.
            unsafe {
                libc::signal(sig, libc::SIG_DFL);
                libc::raise(sig);
            }
        }
    }
    if FLAG.set(flag).is_err() {
        return; // installed already
    }
    for sig in [libc::SIGINT, libc::SIGTERM] {
        // SAFETY: a zeroed sigaction is valid; the handler above only
        // touches atomics and async-signal-safe calls.
        unsafe {
            let mut act: libc::sigaction = std::mem::zeroed();
            act.sa_sigaction = on_signal as extern "C" fn(libc::c_int) as usize;
            act.sa_flags = 0;
            libc::sigemptyset(&mut act.sa_mask);
            libc::sigaction(sig, &act, std::ptr::null_mut());
        }
    }
}

/// `video` as a link from a page in `page_dir`: relative when both are
/// under one folder, else a `file://` URL of its absolute path.
fn relative_href(video: &Path, page_dir: &Path) -> String {
    let abs = |p: &Path| std::fs::canonicalize(p).unwrap_or_else(|_| p.to_path_buf());
    let (v, d) = (abs(video), abs(page_dir));
    let (vc, dc): (Vec<_>, Vec<_>) = (v.components().collect(), d.components().collect());
    let common = vc.iter().zip(&dc).take_while(|(a, b)| a == b).count();
    if common <= 1 {
        return format!("file://{}", v.display());
    }
    let mut parts: Vec<String> = vec!["..".into(); dc.len() - common];
    parts.extend(
        vc[common..]
            .iter()
            .map(|c| c.as_os_str().to_string_lossy().into_owned()),
    );
    parts.join("/")
}

/// `m:ss` (`h:mm:ss` from an hour), as a video player shows a time.
fn clock(t_s: f64) -> String {
    let t = t_s.max(0.0).round() as u64;
    let (h, m, s) = (t / 3600, t / 60 % 60, t % 60);
    if h > 0 {
        format!("{h}:{m:02}:{s:02}")
    } else {
        format!("{m}:{s:02}")
    }
}

/// The windows, segments and verdict; all on standard error when
/// `all_to_stderr` (with --json, whose JSON is then standard output alone),
/// else the verdict on standard output.
fn print_detection(d: &Detection, all_to_stderr: bool) {
    let verdict = |line: String| {
        if all_to_stderr {
            eprintln!("{line}");
        } else {
            println!("{line}");
        }
    };
    // A clip shorter than one window has no windows and no segments: its
    // one line below says what it is, where an empty table and "reading
    // segments: none" above a verdict of "reading" read as a contradiction.
    if d.clip.is_none() {
        eprintln!(
            "{:>8} {:>8}  {:>9}  {:>7}",
            "start_s", "end_s", "P(reading)", "call"
        );
    }
    for w in &d.windows {
        eprintln!(
            "{:>8.1} {:>8.1}  {:>9.3}  {:>7}",
            w.start_s,
            w.end_s,
            w.reading_probability,
            if w.reading { "reading" } else { "-" }
        );
    }
    // The segments are the answer for an interview: on standard output
    // with the verdict (`> result.txt` keeps them), the table above on
    // standard error.
    let segs = &d.localization.segments;
    if segs.is_empty() {
        if d.clip.is_none() {
            verdict("reading segments: none".into());
        }
    } else {
        // Minutes and seconds beside the seconds where a recording is long
        // enough for them to help (a reviewer seeks a player by its clock).
        let long = d.windows.last().is_some_and(|w| w.end_s >= 120.0);
        let list: Vec<String> = segs
            .iter()
            .map(|g| {
                let clock = if long {
                    format!(" [{}-{}]", clock(g.start_s), clock(g.end_s))
                } else {
                    String::new()
                };
                format!(
                    "{:.1}-{:.1} s{clock} ({:.2})",
                    g.start_s, g.end_s, g.confidence
                )
            })
            .collect();
        verdict(format!(
            "reading segments (confidence): {}",
            list.join(", ")
        ));
    }
    // A short clip is scored whole below; its stretches need no list.
    for u in d.unscored() {
        eprintln!(
            "{:.1}-{:.1} s: {}",
            u.start_s,
            u.end_s,
            u.reason(d.model.window_s)
        );
    }
    if let Some(summary) = d.clip_summary() {
        verdict(format!(
            "{}: {} (a clip shorter than one {} s window: {summary})",
            d.input.path, d.verdict, d.model.window_s
        ));
        return;
    }
    // With segments, the recording's one verdict is its average: a long
    // interview with one read answer is "not reading" on average.
    let segs = &d.localization.segments;
    let dur = d.input.frames as f64 / eyereplay::detect::FPS;
    let lead = if segs.is_empty() {
        d.verdict.clone()
    } else {
        let read: f64 = segs.iter().map(|g| g.duration_s()).sum();
        format!(
            "reading in {} segment{}, {read:.1} of {dur:.1} s; {} on average",
            segs.len(),
            if segs.len() == 1 { "" } else { "s" },
            d.verdict
        )
    };
    verdict(format!(
        "{}: {lead} (mean P(reading) {:.3} against threshold {:.3}; {} of {} window{} of {} s called reading)",
        d.input.path,
        d.reading_probability,
        d.model.threshold,
        d.windows.iter().filter(|w| w.reading).count(),
        d.windows.len(),
        if d.windows.len() == 1 { "" } else { "s" },
        d.model.window_s
    ));
}

fn bench(
    track: &eyereplay::detect::Track,
    info: eyereplay::detector::TrackInfo,
    model: &DetectorModel,
    model_path: &Path,
) -> anyhow::Result<()> {
    let started = std::time::Instant::now();
    let mut runs = 0u32;
    while runs == 0 || started.elapsed().as_secs_f64() < 1.0 {
        std::hint::black_box(detect_track(track, info.clone(), model, model_path)?);
        runs += 1;
    }
    let per_run_s = started.elapsed().as_secs_f64() / f64::from(runs);
    let ratio = track.duration_s() / per_run_s;
    println!(
        "detect: {:.1} s of gaze scored in {:.2} ms ({runs} runs): {:.0}x real time (goal >= 100x: {})",
        track.duration_s(),
        per_run_s * 1e3,
        ratio,
        if ratio >= 100.0 { "met" } else { "NOT met" }
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    #[test]
    fn a_clock_reads_as_a_player_shows_it() {
        assert_eq!(super::clock(0.0), "0:00");
        assert_eq!(super::clock(754.4), "12:34");
        assert_eq!(super::clock(59.6), "1:00");
        assert_eq!(super::clock(3725.0), "1:02:05");
    }
}
