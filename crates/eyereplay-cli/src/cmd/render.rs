use eyereplay::backends::{face, render_dataset, replay, ResponseProbe};
use eyereplay_core::{read_session_csv, Canvas};
use eyereplay_render::{
    read_blink_column, read_dataset_info, render_session, render_session_pngs, run_bench, Codec,
    Identity, RenderParams,
};
use std::path::PathBuf;

/// Stage 6: render eye-movement video on eyereplay's own 3D eye simulator.
///
/// A session trajectory (canvas px, `frame,x,y`, optional `blink` column)
/// becomes an H.264 yuv420p MP4 (BT.709) of a close-up of two eyes that
/// follow it, plus `<out>_truth.csv` with per-frame eye rotation, iris
/// centre in the image, lid aperture and blink flag.
#[derive(clap::Args)]
// One group, so that the usage line shows the three ways in:
// `<TRAJECTORY|--dataset <DIR>|--bench>`.
#[command(group = clap::ArgGroup::new("what").required(true).args(["trajectory", "dataset", "bench"]))]
#[command(after_help = "Examples:\n  \
# s.mp4 + s_truth.csv\n  \
eyereplay render data/reading/reading_0000.csv --out s.mp4\n  \
eyereplay render traj.csv --out s.mp4 --seed 7 --gain 2 --natural-blinks\n  \
eyereplay render traj.csv --out s.mp4 --calibration data/metadata.json\n  \
# lossless stills\n  \
eyereplay render traj.csv --png-frames frames/\n  \
# every session of a prepared dataset, its [render] backend\n  \
eyereplay render --dataset data/\n  \
# frames/s, real-time factor\n  \
eyereplay render --bench --frames 1000\n  \
# the full-face webcam mode's speed\n  \
eyereplay render --bench --face --size 640x480\n  \
# real-face replay's speed on a carrier\n  \
eyereplay render --bench --replay clip.mp4")]
pub struct Args {
    /// Session trajectory CSV (frame,x,y in canvas pixels).
    pub trajectory: Option<PathBuf>,
    /// Output MP4 (default: the trajectory's path with .mp4).
    #[arg(long, short, value_name = "MP4")]
    pub out: Option<PathBuf>,
    /// Ground-truth CSV (default: <out stem>_truth.csv beside the video;
    /// with --png-frames, truth.csv among the frames).
    #[arg(long)]
    pub truth: Option<PathBuf>,
    /// Write PNG frames into this folder instead of a video (lossless).
    #[arg(long, value_name = "DIR", conflicts_with_all = ["lossless", "out"])]
    pub png_frames: Option<PathBuf>,
    /// Render every unfinished session of a dataset folder written by
    /// 'eyereplay prepare', with the backend and settings of the `[render]`
    /// table its metadata.json records (the same driver as 'eyereplay
    /// generate'; relative paths in it are taken from the current folder).
    #[arg(long, value_name = "DIR", conflicts_with_all = [
        "bench", "out", "truth", "png_frames", "seed", "gain", "viewing_distance_mm",
        "calibration", "size", "fps", "natural_blinks", "match_extractor", "lossless",
        "crf", "preset", "x264_params", "identity_out",
    ])]
    pub dataset: Option<PathBuf>,
    /// With --dataset: sessions rendered at once, instead of the table's
    /// `jobs` (eyes, browser and face backends; the replay backend draws
    /// one at a time).
    #[arg(long, value_parser = clap::value_parser!(u16).range(1..=eyereplay_dataset::MAX_JOBS as i64))]
    pub jobs: Option<u16>,
    /// Print render-only, encode-only and end-to-end speed, measured in one run.
    #[arg(long, conflicts_with_all = ["out", "truth", "png_frames", "identity_out"])]
    pub bench: bool,
    /// Frames for --bench (default 750; 25 to 100000). The bench keeps them
    /// all in memory, at most 4 GiB: 3,106 frames at 1280x720.
    #[arg(long, value_name = "N", value_parser = super::values::whole::<usize>)]
    pub frames: Option<usize>,
    /// With --bench: the full-face webcam mode (render.backend = "face":
    /// the first bundled photo, webcam look, head motion) instead of the
    /// close-up eyes; also times the read-back match's second pass drawn
    /// over a first pass's kept frames against drawn whole.
    #[arg(long, conflicts_with = "replay")]
    pub face: bool,
    /// With --bench: the real-face replay mode (render.backend = "replay")
    /// on this carrier video, at its own size (decode, redraw, encode). The
    /// carrier's one-time measurement (cached) is not timed.
    #[arg(long, value_name = "VIDEO")]
    pub replay: Option<PathBuf>,
    /// Cache of carrier measurements and head poses, for --dataset and
    /// --bench --replay (default: $EYEREPLAY_CACHE, else $XDG_CACHE_HOME/eyereplay, else ~/.cache/eyereplay).
    #[arg(long, value_name = "DIR")]
    pub cache: Option<PathBuf>,
    /// Identity seed (face, iris, lighting, camera); 0 is the reference face.
    /// With --dataset, each session's identity comes from the dataset's own
    /// seed (metadata.json), as `eyereplay generate` draws it.
    #[arg(long, default_value_t = 0, value_parser = super::values::whole::<u64>)]
    pub seed: u64,
    /// Amplify the normalized iris excursion by this factor (above 0, at
    /// most 10).
    #[arg(long, default_value_t = 1.0)]
    pub gain: f64,
    /// Distance of the fixated screen, for binocular vergence (mm, over 50).
    #[arg(long, default_value_t = 600.0, value_name = "MM")]
    pub viewing_distance_mm: f64,
    /// Take canvas, fps and calibration (s_x, s_y, mu_x, mu_y) from a
    /// dataset's metadata.json (or its folder), so the iris reproduces the
    /// source's amplitude.
    #[arg(long, value_name = "METADATA_JSON")]
    pub calibration: Option<PathBuf>,
    /// Video size WIDTHxHEIGHT (even numbers). Not with --bench --replay,
    /// which draws at the carrier's own size.
    #[arg(long, default_value = "1280x720", conflicts_with = "replay")]
    pub size: String,
    /// Frame rate of the trajectory and video, above 0 and at most 1000
    /// [default: 25, or --calibration's dataset's].
    #[arg(long)]
    pub fps: Option<f64>,
    /// Add blinks at the identity's natural rate (8-22 per minute).
    #[arg(long)]
    pub natural_blinks: bool,
    /// Draw each identity's eye where the extractor's iris model reads the
    /// trajectory's position (measured per identity from 35 probe frames;
    /// needs the models), as `generate` does; false draws the renderer's
    /// geometric position.
    #[arg(long, default_value_t = true, action = clap::ArgAction::Set, value_name = "BOOL")]
    pub match_extractor: bool,
    /// Lossless H.264 (qp 0) instead of constant quality.
    #[arg(long, conflicts_with = "crf")]
    pub lossless: bool,
    /// x264 constant rate factor, 0 to 51 (lower is better quality).
    #[arg(long, default_value_t = 18, value_parser = super::values::whole::<u32>)]
    pub crf: u32,
    /// x264 preset: ultrafast, superfast, veryfast, faster, fast, medium,
    /// slow, slower, veryslow or placebo.
    #[arg(long, default_value = "veryfast")]
    pub preset: String,
    /// Extra x264 options, as for ffmpeg's -x264-params ('' for none);
    /// tried on one frame before the drawing, so a key x264 does not know,
    /// or a value it refuses, is an error, not ignored (a value x264 itself
    /// clamps, such as a negative `bframes`, passes as x264 takes it).
    #[arg(long, default_value = eyereplay_render::DEFAULT_X264_PARAMS)]
    pub x264_params: String,
    /// Also write the identity and eye geometry as JSON here.
    #[arg(long, value_name = "PATH")]
    pub identity_out: Option<PathBuf>,
}

fn parse_size(s: &str) -> anyhow::Result<(usize, usize)> {
    Ok(eyereplay::parse_usize_pair(
        "--size",
        s,
        &['x', 'X'],
        "WIDTHxHEIGHT, e.g. 1280x720",
        ["width", "height"],
    )?)
}

fn params(args: &Args) -> anyhow::Result<RenderParams> {
    let identity = if args.seed == 0 {
        Identity::reference()
    } else {
        Identity::sample(args.seed)
    };
    let mut p = RenderParams::new(identity);
    (p.width, p.height) = parse_size(&args.size)?;
    if let Some(given) = &args.calibration {
        // A dataset folder or its metadata.json; any other file is refused
        // by its own name before anything is read.
        let dir = if given.is_dir() {
            given.as_path()
        } else {
            anyhow::ensure!(
                given
                    .file_name()
                    .is_some_and(|n| n == eyereplay_dataset::layout::METADATA_FILE),
                "{}: --calibration expects a dataset's metadata.json or its folder",
                given.display()
            );
            anyhow::ensure!(given.is_file(), "{}: no such file", given.display());
            match given.parent() {
                Some(d) if !d.as_os_str().is_empty() => d,
                _ => std::path::Path::new("."),
            }
        };
        let info = read_dataset_info(dir)?;
        p.mapping.canvas = info.canvas;
        p.fps = info.fps;
        match info.calibration {
            Some(c) => p.mapping.calibration = c,
            None => tracing::warn!("{}: no calibration; using the default", given.display()),
        }
    } else {
        p.mapping.canvas = Canvas::default();
    }
    if let Some(f) = args.fps {
        p.fps = f;
    }
    p.mapping.gain = args.gain;
    p.mapping.viewing_distance_mm = args.viewing_distance_mm;
    p.natural_blinks = args.natural_blinks;
    p.encoder.crf = args.crf;
    p.encoder.preset = args.preset.clone();
    p.encoder.x264_params = Some(args.x264_params.clone()).filter(|s| !s.is_empty());
    if args.lossless {
        p.encoder.codec = Codec::Lossless;
    }
    p.validate()?;
    Ok(p)
}

/// What clap does not say: a `requires` whose target conflicts with an
/// argument given (the trajectory conflicts with --bench and --dataset)
/// counts as met, so a bench-only or dataset-only option given with a
/// trajectory would be ignored without a word.
fn check_bench_only(args: &Args) -> anyhow::Result<()> {
    anyhow::ensure!(
        args.jobs.is_none() || args.dataset.is_some(),
        "--jobs is for --dataset only (sessions rendered at once)"
    );
    if args.bench {
        return Ok(());
    }
    let given = [
        ("--face", args.face),
        ("--replay", args.replay.is_some()),
        ("--frames", args.frames.is_some()),
    ];
    if let Some((flag, _)) = given.iter().find(|(_, on)| *on) {
        let hint = if *flag == "--frames" {
            ""
        } else {
            "; to draw sessions in that mode, set render.backend in the dataset's config and run \
             'eyereplay render --dataset DIR'"
        };
        anyhow::bail!("{flag} is for --bench only (a speed measurement){hint}");
    }
    Ok(())
}

/// The longest --bench: a speed settles within a few hundred frames, and
/// its trajectory is held in memory (a typo of 10^11 frames asked for
/// 1.6 TB and aborted).
const MAX_BENCH_FRAMES: usize = 100_000;

pub fn run(args: Args) -> anyhow::Result<()> {
    check_bench_only(&args)?;
    if let Some(dir) = &args.dataset {
        return run_dataset(dir, &args);
    }
    let p = params(&args)?;
    if args.bench {
        let frames = args.frames.unwrap_or(750);
        anyhow::ensure!(
            (25..=MAX_BENCH_FRAMES).contains(&frames),
            "--frames must be between 25 and {MAX_BENCH_FRAMES} (a speed measurement), got {frames}"
        );
        if args.replay.is_none() {
            // At once, not after the scene's setup (the replay mode's size
            // is its carrier's, known once the carrier is measured).
            eyereplay_render::check_kept_frames(frames, p.width, p.height)?;
        }
        let report = if args.face {
            face::bench(p.width, p.height, frames)?
        } else if let Some(video) = &args.replay {
            replay::bench(
                video,
                frames,
                &p.encoder,
                &super::cache_dir(args.cache.as_deref())?,
                &eyereplay::NoProgress,
            )?
        } else {
            run_bench(&p, frames)?
        };
        println!("{report}");
        return Ok(());
    }
    let traj_path = args.trajectory.as_ref().expect("clap requires it");
    let traj = read_session_csv(traj_path)?;
    let blinks = read_blink_column(traj_path)?;
    let out = args
        .out
        .clone()
        .unwrap_or_else(|| traj_path.with_extension("mp4"));
    if let Some(dir) = &args.png_frames {
        super::check_folder_arg(dir, "--png-frames")?;
    }
    // With --png-frames the truth goes with the frames, not beside the
    // trajectory (where a dataset keeps its session's own truth).
    let truth = match (&args.truth, &args.png_frames) {
        (Some(t), _) => t.clone(),
        (None, Some(dir)) => dir.join("truth.csv"),
        (None, None) => eyereplay_dataset::SessionPaths::beside_video(&out).truth,
    };
    // No output may be the input or another output: the rename at the end
    // would replace the trajectory (or the video) without a word.
    let named = [
        ("the trajectory", Some(traj_path)),
        ("--out", args.png_frames.is_none().then_some(&out)),
        ("the truth file", Some(&truth)),
        ("--identity-out", args.identity_out.as_ref()),
    ];
    for (i, (a, pa)) in named.iter().enumerate() {
        for (b, pb) in &named[i + 1..] {
            if let (Some(pa), Some(pb)) = (pa, pb) {
                anyhow::ensure!(
                    !eyereplay_core::same_file(pa, pb),
                    "{}: {b} would overwrite {a}; give another path",
                    pb.display()
                );
            }
        }
    }
    // A dataset's session files are drawn by `render --dataset` with the
    // dataset's identities. The default --out of a session CSV is its own
    // video: drawn alone over it, with another identity, the session would
    // pass `merge` with a truth that is not its video's, or fail it far
    // from the cause. A path the user names is theirs to choose.
    if args.out.is_none() && args.png_frames.is_none() {
        for target in [&out, &truth] {
            if let Some(dataset) = eyereplay_dataset::layout::dataset_holding(target) {
                anyhow::bail!(
                    "{}: a session of the dataset {} (its sessions are drawn by 'eyereplay render --dataset {}'); give --out to draw it elsewhere",
                    target.display(),
                    dataset.display(),
                    dataset.display()
                );
            }
        }
    }
    // The video is H.264 in an MP4 container whatever the name says.
    if args.png_frames.is_none() {
        anyhow::ensure!(
            out.extension()
                .is_some_and(|e| e.eq_ignore_ascii_case("mp4")),
            "{}: the video is written as MP4; name it .mp4",
            out.display()
        );
    }
    // A render killed before its rename (Ctrl-C, kill) left its temporary
    // files beside the outputs; this one replaces them.
    let video = args.png_frames.is_none().then_some(&out);
    for target in [video, Some(&truth), args.identity_out.as_ref()]
        .into_iter()
        .flatten()
    {
        for stale in eyereplay_core::stale_temp_files(target) {
            let _ = std::fs::remove_file(&stale);
        }
    }
    // Every output can be written, before the probe and the drawing.
    let mut outputs = vec![&truth];
    if args.png_frames.is_none() {
        outputs.push(&out);
    }
    outputs.extend(args.identity_out.as_ref());
    for path in outputs {
        eyereplay_core::check_writable(path)?;
    }
    if args.png_frames.is_none() {
        // An --x264-params key x264 does not know is only a warning of
        // ffmpeg's, and a value it refuses fails after the drawing starts.
        p.encoder.check_with_ffmpeg()?;
    }
    let mut p = p;
    let probe = ResponseProbe::when(args.match_extractor, 1)?;
    if let Some(probe) = &probe {
        p.mapping.extractor_response = probe.measure(&p, &traj)?;
    }
    let stats = if let Some(dir) = &args.png_frames {
        render_session_pngs(&traj, blinks.as_deref(), &p, dir, &truth)?
    } else {
        render_session(&traj, blinks.as_deref(), &p, &out, &truth)?
    };
    if stats.clamped_points > 0 {
        eprintln!(
            "warning: {} of {} trajectory points were off the {}x{} canvas and were clamped to its edge",
            stats.clamped_points, stats.frames, p.mapping.canvas.width_px, p.mapping.canvas.height_px
        );
    }
    if let Some(path) = &args.identity_out {
        let eyes = stats.eyes.clone();
        eyereplay_dataset::SessionIdentity {
            file: traj_path.display().to_string(),
            seed: args.seed,
            identity: &p.identity,
            mapping: &p.mapping,
            width: p.width,
            height: p.height,
            fps: p.fps,
            eyes,
            extractor_iris_views: probe.as_ref().map(|p| p.iris_views),
        }
        .write(path)?;
    }
    let target = args.png_frames.as_ref().unwrap_or(&out);
    eprintln!(
        "{}: {} frames in {:.1} s ({:.0} frames/s, {:.1}x real time); truth {}",
        target.display(),
        stats.frames,
        stats.total_s,
        stats.fps(),
        stats.fps() / p.fps,
        truth.display()
    );
    Ok(())
}

/// `--dataset`: every unfinished session of a prepared dataset with the
/// backend its recorded `[render]` table chooses, through the same driver
/// as `eyereplay generate`.
fn run_dataset(dir: &std::path::Path, args: &Args) -> anyhow::Result<()> {
    let t0 = std::time::Instant::now();
    let meta_path = dir.join(eyereplay_dataset::layout::METADATA_FILE);
    let config = eyereplay_dataset::read_metadata(dir)?.dataset.config;
    let mut settings = eyereplay::RenderSettings::from_config(&config, &meta_path)?;
    if let Some(jobs) = args.jobs {
        settings.jobs = jobs as usize;
    }
    let cache = super::cache_dir(args.cache.as_deref())?;
    // A setting's error names the file that holds the `[render]` table.
    let in_meta = |e: eyereplay::backends::BackendError| match e {
        eyereplay::backends::BackendError::Setting(m) => {
            anyhow::anyhow!("{}: {m}", meta_path.display())
        }
        e => e.into(),
    };
    let settings =
        eyereplay::check_settings(&settings, &|p: &std::path::Path| p.to_path_buf(), &cache)
            .map_err(in_meta)?;
    let params = eyereplay::render_params(&settings, &config).map_err(in_meta)?;
    params
        .encoder
        .check_with_ffmpeg()
        .map_err(|e| anyhow::anyhow!("{}: [render]: {e}", meta_path.display()))?;
    let bars = super::Bars::default();
    let backend = eyereplay::open_backend(dir, &settings, params, &cache, &bars)?;
    let summary = render_dataset(dir, backend.as_ref(), None, &bars)?;
    let secs = t0.elapsed().as_secs_f64();
    eprintln!(
        "{}: {} sessions drawn by the {} backend, {} already complete; {} frames in {:.1} s ({:.0} frames/s)",
        dir.display(),
        summary.rendered,
        backend.name(),
        summary.skipped,
        summary.frames,
        secs,
        summary.frames as f64 / secs.max(1e-9)
    );
    if summary.clamped_points > 0 {
        eprintln!(
            "warning: {} trajectory points were off the canvas and were clamped to its edge",
            summary.clamped_points
        );
    }
    Ok(())
}
