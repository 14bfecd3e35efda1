use super::Bars;
use eyereplay::detect::DetectorModel;
use eyereplay::detector::{detect_track, detection_figure, load_track, Detection};
use std::path::{Path, PathBuf};

/// Is the person in this video reading? Per-window probabilities and a verdict.
///
/// INPUT is a video (the iris is extracted first, cached), an 'eyereplay
/// extract' CSV, or a session CSV (frame,x,y at 25 fps). It is cut into
/// non-overlapping windows of the model's length; each gets a reading
/// probability, and the recording a verdict from their mean; reading
/// segments with their times come from overlapping windows (docs/DETECTOR.md).
/// A clip shorter than one window (from 3 s of gaze) is scored from its
/// best stretch with a 90 % bootstrap interval, and called `uncertain`
/// when the interval holds the threshold. Writes
/// OUT/<name>_detect.json and a plot of the probability over time under
/// the gaze track (OUT/<name>_detect.png).
#[derive(clap::Args)]
#[command(after_help = "Examples:\n  \
eyereplay detect interview.mp4 --model out/default/detector.json\n  \
eyereplay detect iris.csv --model m.json --out results/ --json\n  \
# a camera\n  \
eyereplay detect --live /dev/video0 --model m.json\n  \
eyereplay detect --live rtsp://camera.local/stream --model m.json\n  \
# a call played at real speed through standard input\n  \
ffmpeg -re -i call.mp4 -f nut -c:v rawvideo -pix_fmt yuv420p - | \\\n      \
eyereplay detect --live - --model m.json\n\n\
The bundled default's model: scripts/run.sh trains it into\n\
out/default/detector.json.")]
pub struct Args {
    /// A video, an 'eyereplay extract' CSV, or a frame,x,y session CSV.
    #[arg(required_unless_present = "live", conflicts_with = "live")]
    pub input: Option<PathBuf>,
    /// Watch a live stream instead: a camera (/dev/video0), a network
    /// stream (rtsp://, http://) or '-' for a video stream on standard
    /// input (NUT, Matroska, MPEG-TS). Prints each window's probability as
    /// it closes (one window a second), then the whole stream's segments;
    /// with --out, writes the JSON and the reviewer's page as for a file.
    #[arg(long, value_name = "SOURCE")]
    pub live: Option<String>,
    /// The ffmpeg program that opens a camera for --live.
    #[arg(long, value_name = "PATH", default_value = "ffmpeg")]
    pub ffmpeg: PathBuf,
    /// A model written by 'eyereplay train'.
    #[arg(long, value_name = "MODEL")]
    pub model: PathBuf,
    /// Folder for the JSON and the plot (default: beside the input).
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
    /// Also print the JSON to standard output.
    #[arg(long)]
    pub json: bool,
    /// Extraction cache (default: $EYEREPLAY_CACHE or ~/.cache/eyereplay).
    #[arg(long, value_name = "DIR")]
    pub cache: Option<PathBuf>,
    /// Time the detector on the loaded track (windows, features, model;
    /// repeated for at least a second) and print its speed against real
    /// time (goal: at least 100x). Writes nothing.
    #[arg(long)]
    pub bench: bool,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    // The model first: a bad one stops before any extraction.
    let model = DetectorModel::load(&args.model)?;
    // And the output folder: a file there would fail only after the
    // video is read.
    if let Some(out) = &args.out {
        anyhow::ensure!(
            !out.exists() || out.is_dir(),
            "{}: --out takes a folder (the results are written into it), and this is a file",
            out.display()
        );
    }
    if let Some(source) = &args.live {
        return live(&args, source, &model);
    }
    let input = args.input.clone().expect("clap requires it");
    let cache = eyereplay::cache_dir(args.cache.as_deref());
    let (track, info) = load_track(&input, &cache, &Bars::default())?;
    if args.bench {
        return bench(&track, info, &model, &args.model);
    }
    let d = detect_track(&track, info, &model, &args.model)?;
    let out_dir = args.out.clone().unwrap_or_else(|| {
        input
            .parent()
            .filter(|p| !p.as_os_str().is_empty())
            .map_or_else(|| PathBuf::from("."), Path::to_path_buf)
    });
    let stem = input
        .file_stem()
        .map_or_else(|| "input".into(), |s| s.to_string_lossy().into_owned());
    let href = (d.input.kind == "video").then(|| relative_href(&input, &out_dir));
    let (text, [json_path, png_path, html_path]) =
        write_detection(&track, &d, &out_dir, &stem, href.as_deref())?;
    print_detection(&d);
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
fn live(args: &Args, source: &str, model: &DetectorModel) -> anyhow::Result<()> {
    use std::io::Write;
    let src = eyereplay::live::LiveSource::parse(source);
    eprintln!(
        "watching {}: one {} s window a second, threshold {:.3} (Ctrl-C or the end of the stream stops)",
        src.label(),
        model.window_s,
        model.threshold
    );
    // The table's header with its first row, so that a source that never
    // opens leaves stdout empty.
    let mut header = true;
    let mut on_window = |w: &eyereplay::live::LiveWindow| {
        let mut out = std::io::stdout().lock();
        if std::mem::take(&mut header) {
            let _ = writeln!(
                out,
                "{:>8} {:>8}  {:>10}  {:>7}  {:>6}  {:>6}",
                "start_s", "end_s", "P(reading)", "call", "gaze_s", "lag_s"
            );
        }
        let p = w
            .reading_probability
            .map_or("no gaze".to_string(), |p| format!("{p:.3}"));
        let _ = writeln!(
            out,
            "{:>8.1} {:>8.1}  {:>10}  {:>7}  {:>6.1}  {:>6.2}",
            w.start_s,
            w.end_s,
            p,
            if w.reading { "reading" } else { "-" },
            w.gaze_s,
            w.lag_s.max(0.0)
        );
        // Each line as it is decided, even into a pipe.
        let _ = out.flush();
    };
    let outcome = eyereplay::live::watch(&src, model, &args.model, &args.ffmpeg, &mut on_window)?;
    eprintln!(
        "{} frames, face in {:.1} %",
        outcome.frames,
        100.0 * outcome.face_frames as f64 / outcome.frames.max(1) as f64
    );
    let Some(d) = outcome.detection else {
        anyhow::bail!(
            "{}: not enough gaze in the whole stream to score it",
            src.label()
        );
    };
    print_detection(&d);
    if let Some(out_dir) = &args.out {
        let (text, paths) = write_detection(&outcome.track, &d, out_dir, "live", None)?;
        eprintln!(
            "wrote {}",
            paths
                .iter()
                .map(|p| p.display().to_string())
                .collect::<Vec<_>>()
                .join(", ")
        );
        if args.json {
            print!("{text}");
        }
    }
    Ok(())
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

fn print_detection(d: &Detection) {
    eprintln!(
        "{:>8} {:>8}  {:>9}  {:>7}",
        "start_s", "end_s", "P(reading)", "call"
    );
    for w in &d.windows {
        eprintln!(
            "{:>8.1} {:>8.1}  {:>9.3}  {:>7}",
            w.start_s,
            w.end_s,
            w.reading_probability,
            if w.reading { "reading" } else { "-" }
        );
    }
    let segs = &d.localization.segments;
    if segs.is_empty() {
        eprintln!("reading segments: none");
    } else {
        let list: Vec<String> = segs
            .iter()
            .map(|g| format!("{:.1}-{:.1} s ({:.2})", g.start_s, g.end_s, g.confidence))
            .collect();
        eprintln!("reading segments (confidence): {}", list.join(", "));
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
    if let Some(c) = &d.clip {
        println!(
            "{}: {} (a clip shorter than one {} s window: {:.1} s of gaze in {:.1}-{:.1} s scored, P(reading) {:.3}, {:.0} % interval {:.3}-{:.3}, threshold {:.3})",
            d.input.path,
            d.verdict,
            d.model.window_s,
            c.usable_s,
            c.start_s,
            c.end_s,
            c.reading_probability,
            100.0 * c.level,
            c.low,
            c.high,
            d.model.threshold
        );
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
    println!(
        "{}: {lead} (mean P(reading) {:.3} against threshold {:.3}; {} of {} windows of {} s called reading)",
        d.input.path,
        d.reading_probability,
        d.model.threshold,
        d.windows.iter().filter(|w| w.reading).count(),
        d.windows.len(),
        d.model.window_s
    );
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
