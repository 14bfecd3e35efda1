//! The reading detector on real inputs: gaze tracks from videos (through
//! the extractor, cached), from `eyereplay extract` CSVs and from session
//! CSVs; training on generated datasets; detection on one recording.
//! The model itself is [`eyereplay_detect`]'s.

use crate::inputs::{check_models, extract_cached, extraction_cache_path};
use crate::{Error, Result};
use eyereplay_core::{NormPos, Sample};
use eyereplay_core::{Progress, Stage};
use eyereplay_detect::clip::{score_clip, ClipScore};
use eyereplay_detect::{windows, DetectorModel, Example, Track, TrainOptions, WindowSpec, FPS};
use eyereplay_extract::StageFrames;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// Video file extensions `detect` and `train` send through the extractor.
pub const VIDEO_EXTENSIONS: [&str; 8] = ["mp4", "mov", "avi", "mkv", "webm", "m4v", "mpg", "mpeg"];

/// Frames further apart than this are not interpolated across: the track
/// gets `NaN` (no gaze) between them.
const MAX_INTERP_GAP_S: f64 = 0.2;

/// Whether `detect` reads `path` as a video: by its extension where it is
/// one of [`VIDEO_EXTENSIONS`] (a video) or a table's (`.csv`, `.tsv`,
/// `.txt`: not), else by its first bytes: a file that does not start as
/// text is a video (an MPEG-TS `.ts`, a `.3gp`, a `.flv`, a name without
/// an extension), where it used to be read as a CSV and fail with
/// "stream did not contain valid UTF-8".
pub fn is_video(path: &Path) -> bool {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    match ext.as_deref() {
        Some(e) if VIDEO_EXTENSIONS.contains(&e) => true,
        Some("csv" | "tsv" | "txt") => false,
        _ => !starts_as_text(path),
    }
}

/// The first 1 KiB is UTF-8 (but for a character cut at its end) without
/// NUL bytes; false for a file that cannot be read (the reader then says
/// why).
fn starts_as_text(path: &Path) -> bool {
    use std::io::Read;
    let mut head = Vec::with_capacity(1024);
    let read = std::fs::File::open(path).and_then(|f| f.take(1024).read_to_end(&mut head));
    if read.is_err() {
        return false;
    }
    let text = match std::str::from_utf8(&head) {
        Ok(_) => true,
        // A multi-byte character cut by the 1 KiB limit.
        Err(e) => e.error_len().is_none(),
    };
    text && !head.contains(&0)
}

/// What a track was made from.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TrackInfo {
    pub path: String,
    /// `video`, `extract` (an `eyereplay extract` CSV) or `session` (a
    /// `frame,x,y` session CSV at 25 fps).
    pub kind: String,
    pub frames: usize,
    pub gaze_fraction: f64,
}

/// The 25 fps gaze track of a video (extracted, cached), an `eyereplay
/// extract` CSV or a session CSV, told apart by extension and header.
pub fn load_track(
    path: &Path,
    cache: &Path,
    progress: &dyn Progress,
) -> Result<(Track, TrackInfo)> {
    if !path.exists() {
        return Err(Error::input(path, "no such file"));
    }
    if path.is_dir() {
        return Err(Error::input(
            path,
            "a folder; give a video, an 'eyereplay extract' CSV or a session CSV",
        ));
    }
    // An extraction's frame times, to tell a stream too sparse to join.
    let from_samples = |samples: Vec<Sample<NormPos>>| -> Track {
        let times: Vec<f64> = samples.iter().map(|s| s.t_s).collect();
        if let Some(w) = sparse_frames_warning(&times) {
            progress.warn(&format!("warning: {}: {w}", path.display()));
        }
        let refs: Vec<&Sample<NormPos>> = samples.iter().collect();
        resample_samples(&refs)
    };
    let (track, kind) = if is_video(path) {
        let csv = extract_cached(&[path.to_path_buf()], cache, progress)?.remove(0);
        // The extraction read too little gaze to make a track of: say so
        // of the video, not of the cache file it went to (a still image,
        // a face never found with open eyes). Other errors, a damaged
        // cache file among them, name that file.
        let samples = match extract_csv_samples(&csv) {
            Err(Error::Source(eyereplay_sources::SourceError::File { message, .. }))
                if message == eyereplay_sources::NO_GAZE_SEGMENT =>
            {
                return Err(Error::input(
                    path,
                    format!(
                        "gaze in fewer than 2 frames (a still image, or no face with open eyes found); \
                         a detection needs at least {} s of it",
                        eyereplay_detect::clip::MIN_CLIP_S
                    ),
                ));
            }
            r => r?,
        };
        (from_samples(samples), "video")
    } else {
        let head = std::fs::read_to_string(path)
            .map_err(|e| Error::io(path, e))?
            .lines()
            .next()
            .unwrap_or("")
            // A byte-order mark (spreadsheets write one) is no column's.
            .trim_start_matches('\u{feff}')
            .to_string();
        let cols: Vec<&str> = head.split(',').map(str::trim).collect();
        if cols.contains(&"nx") && cols.contains(&"time_s") {
            (from_samples(extract_csv_samples(path)?), "extract")
        } else if cols.starts_with(&["frame", "x", "y"]) {
            (session_csv_track(path)?, "session")
        } else {
            return Err(Error::input(
                path,
                format!(
                    "not a video ({}), an 'eyereplay extract' CSV (time_s,...,nx,ny) or a session CSV (frame,x,y); header: {head}",
                    VIDEO_EXTENSIONS.join(", ")
                ),
            ));
        }
    };
    let gaze = track.xy.iter().filter(|p| p[0].is_finite()).count();
    let info = TrackInfo {
        path: path.display().to_string(),
        kind: kind.into(),
        frames: track.len(),
        gaze_fraction: gaze as f64 / track.len().max(1) as f64,
    };
    Ok((track, info))
}

/// An `eyereplay extract` CSV, resampled to 25 fps on its timestamps.
pub fn extract_csv_track(csv: &Path) -> Result<Track> {
    let samples = extract_csv_samples(csv)?;
    let refs: Vec<&Sample<NormPos>> = samples.iter().collect();
    Ok(resample_samples(&refs))
}

/// Every row of an `eyereplay extract` CSV as a sample, in time order.
fn extract_csv_samples(csv: &Path) -> Result<Vec<Sample<NormPos>>> {
    let spec = eyereplay_sources::SourceSpec::Extract {
        path: csv.to_path_buf(),
    };
    let opts = eyereplay_sources::ReadOptions {
        // Keep every frame: gaps are handled here, as NaN.
        max_gap_s: f64::INFINITY,
        ..Default::default()
    };
    let rec = eyereplay_sources::read_source(&spec, &opts)?.remove(0);
    Ok(rec
        .segments
        .iter()
        .flat_map(|s| s.samples())
        .cloned()
        .collect())
}

/// A warning for frames too far apart to be joined: where the median
/// interval between frames is near or past `MAX_INTERP_GAP_S` (5 frames a
/// second or fewer), most of the 25 fps track has no gaze, and the windows
/// say "too little gaze" without saying why.
pub fn sparse_frames_warning(times_s: &[f64]) -> Option<String> {
    let mut gaps: Vec<f64> = times_s
        .windows(2)
        .map(|w| w[1] - w[0])
        .filter(|g| g.is_finite() && *g > 0.0)
        .collect();
    if gaps.len() < 10 {
        return None;
    }
    gaps.sort_by(f64::total_cmp);
    let median = gaps[gaps.len() / 2];
    (median > 0.9 * MAX_INTERP_GAP_S).then(|| {
        format!(
            "its frames come {:.1} a second; the detector joins frames at most {MAX_INTERP_GAP_S} s \
             apart (over {:.0} a second), so much of it has no gaze to score",
            1.0 / median,
            1.0 / MAX_INTERP_GAP_S
        )
    })
}

/// Linear interpolation at 25 fps between neighbouring samples that both
/// show gaze and are at most `MAX_INTERP_GAP_S` apart; `NaN` elsewhere.
/// The last sample lasts one frame interval, as a video's last frame does
/// ([`recording_end_s`]): 20 s of 24 fps video is 500 frames at 25 fps,
/// not 499 (which cost such a clip its last 10-s window).
pub fn resample_samples(samples: &[&Sample<NormPos>]) -> Track {
    let (Some(first), Some(last)) = (samples.first(), samples.last()) else {
        return Track::default();
    };
    let (t0, t1) = (first.t_s, last.t_s);
    let end_s = recording_end_s(samples);
    let through_last = ((t1 - t0) * FPS + 1e-6).floor() as usize + 1;
    let before_end = ((end_s - t0) * FPS - 1e-6).ceil().max(0.0) as usize;
    resample_grid(samples, t0, 0..through_last.max(before_end), end_s)
}

/// When a recording whose last samples are `samples`' ends: its last
/// sample's time plus the interval before it (the frame interval of a
/// video; at most `MAX_INTERP_GAP_S`, so a last sample after a gap lasts
/// no longer than gaze is ever joined).
pub fn recording_end_s(samples: &[&Sample<NormPos>]) -> f64 {
    match samples {
        [.., a, b] => b.t_s + (b.t_s - a.t_s).clamp(0.0, MAX_INTERP_GAP_S),
        [b] => b.t_s,
        [] => 0.0,
    }
}

/// Frames `frames` of the 25 fps grid that starts at `t0`, as
/// [`resample_samples`] makes them from `samples` (which must reach past
/// the range's ends for its first and last frames to have gaze, or to the
/// recording's end, `end_s`, which the last sample holds until): the same
/// values for a frame whatever part of the recording `samples` holds.
pub fn resample_grid(
    samples: &[&Sample<NormPos>],
    t0: f64,
    frames: std::ops::Range<usize>,
    end_s: f64,
) -> Track {
    let mut xy = Vec::with_capacity(frames.len());
    let mut j = 0;
    for k in frames {
        let t = t0 + k as f64 / FPS;
        while j + 1 < samples.len() && samples[j + 1].t_s <= t + 1e-9 {
            j += 1;
        }
        let Some(&a) = samples.get(j).filter(|a| a.t_s <= t + 1e-9) else {
            xy.push([f64::NAN, f64::NAN]);
            continue;
        };
        let p = if (a.t_s - t).abs() < 1e-9 {
            a.is_gaze().then_some([a.pos.nx, a.pos.ny])
        } else if j + 1 < samples.len() {
            let b = samples[j + 1];
            (a.is_gaze() && b.is_gaze() && b.t_s - a.t_s <= MAX_INTERP_GAP_S).then(|| {
                let f = (t - a.t_s) / (b.t_s - a.t_s);
                [
                    a.pos.nx + f * (b.pos.nx - a.pos.nx),
                    a.pos.ny + f * (b.pos.ny - a.pos.ny),
                ]
            })
        } else if t < end_s - 1e-9 {
            // After the last sample, within its frame: what the video shows.
            a.is_gaze().then_some([a.pos.nx, a.pos.ny])
        } else {
            None
        };
        xy.push(p.unwrap_or([f64::NAN, f64::NAN]));
    }
    Track::new(xy)
}

/// A `frame,x,y[,blink]` session CSV (25 fps canvas px); blink frames are
/// no gaze.
pub fn session_csv_track(csv: &Path) -> Result<Track> {
    let points = eyereplay_core::read_session_csv(csv)?;
    let blinks = eyereplay_dataset::read_blink_column(csv)?;
    Ok(Track::new(
        points
            .iter()
            .enumerate()
            .map(|(i, p)| {
                let blink = blinks.as_ref().is_some_and(|b| b.get(i) == Some(&true));
                if blink {
                    [f64::NAN, f64::NAN]
                } else {
                    [p.x_px, p.y_px]
                }
            })
            .collect(),
    ))
}

/// The drawn eyes' mean `(nx, ny)` in each frame of a renderer's truth CSV
/// (`<stem>_truth.csv`), `NaN` where the lids are closed, as the extractor
/// leaves a blink: the track a perfect extractor would read.
pub fn truth_csv_track(csv: &Path) -> Result<Track> {
    let rows = eyereplay_dataset::read_truth_csv(csv)?;
    Ok(Track::new(
        rows.iter()
            .map(|r| {
                if r.blink {
                    [f64::NAN, f64::NAN]
                } else {
                    r.mean_norm()
                }
            })
            .collect(),
    ))
}

/// What training reads from each session.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum TrainInput {
    /// What `eyereplay extract` measures on the session's rendered video:
    /// what the detector sees in use.
    Extracted,
    /// The session CSV that drove the renderer (no video needed; for
    /// trajectory-only datasets and quick experiments).
    Trajectory,
    /// The drawn eyes' own position in their apertures, from the
    /// renderer's `_truth.csv` (both eyes' nx, ny averaged; closed-lid
    /// frames are gaps): what a perfect extractor would read from the
    /// video. Beside `extracted` it tells what the read-back loses, beside
    /// `trajectory` what the drawing does (the head's share of a gaze
    /// shift, the eye's size in the frame).
    Drawn,
}

impl TrainInput {
    pub fn name(self) -> &'static str {
        match self {
            TrainInput::Extracted => "extracted",
            TrainInput::Trajectory => "trajectory",
            TrainInput::Drawn => "drawn",
        }
    }

    /// The file this input reads for a session.
    fn file(self, paths: &eyereplay_dataset::SessionPaths) -> &Path {
        match self {
            TrainInput::Extracted => &paths.mp4,
            TrainInput::Trajectory => &paths.csv,
            TrainInput::Drawn => &paths.truth,
        }
    }

    /// What to do when that file is missing, after "missing".
    fn missing_hint(self) -> &'static str {
        match self {
            TrainInput::Extracted => "; render the dataset first ('eyereplay render'), or use its trajectories (--input trajectory)",
            TrainInput::Trajectory => "",
            TrainInput::Drawn => "; the drawn truth is written by 'eyereplay render' (and 'generate') beside each video",
        }
    }
}

#[derive(Clone, Debug)]
pub struct TrainDetectorOptions {
    pub window_s: f64,
    pub input: TrainInput,
    /// Label each window by the session CSV's per-frame `reading` column
    /// where it has one (interview sessions read some answers and talk
    /// through others), not by the session's class: see [`window_label`].
    pub frame_labels: bool,
    pub train: TrainOptions,
    pub cache: PathBuf,
}

/// One session's track with its label, for training and evaluation.
#[derive(Clone, Debug)]
pub struct LabeledTrack {
    /// `DATASET#reading/reading_0003.csv`.
    pub id: String,
    pub reading: bool,
    /// The source ids the session was cut from (labels.csv).
    pub sources: Vec<String>,
    pub track: Track,
    /// The session CSV's per-frame `reading` column, when it has one.
    pub frame_reading: Option<Vec<bool>>,
}

/// A window's label from per-frame labels: reading when at least 80 % of
/// its frames are, not reading when at most 20 % are; `None` (not used for
/// training) in between, where the window straddles a switch.
pub fn window_label(frame_reading: &[bool], start: usize, frames: usize) -> Option<bool> {
    let end = (start + frames).min(frame_reading.len());
    if end <= start {
        return None;
    }
    let share =
        frame_reading[start..end].iter().filter(|&&r| r).count() as f64 / (end - start) as f64;
    if share >= 0.8 {
        Some(true)
    } else if share <= 0.2 {
        Some(false)
    } else {
        None
    }
}

/// One session of a dataset, checked and not yet read: what
/// [`dataset_sessions`] finds before any extraction.
#[derive(Clone, Debug)]
pub struct SessionEntry {
    /// `DATASET#reading/reading_0003.csv`.
    pub id: String,
    pub reading: bool,
    pub sources: Vec<String>,
    /// The file `input` reads (video, session CSV or truth CSV).
    pub file: PathBuf,
    /// The session CSV's per-frame `reading` column, when it has one.
    pub frame_reading: Option<Vec<bool>>,
    /// Frames of the session CSV: what its video and truth file hold.
    pub frames: usize,
    /// The dataset's frame rate (metadata.json; 25 where it has none).
    pub fps: f64,
}

impl SessionEntry {
    pub fn duration_s(&self) -> f64 {
        self.frames as f64 / self.fps
    }
}

/// Every session of `datasets` (labels.csv, the file `input` reads, the
/// session CSV's frames and per-frame labels), checked before any is read.
pub fn dataset_sessions(datasets: &[PathBuf], input: TrainInput) -> Result<Vec<SessionEntry>> {
    let mut sessions = Vec::new();
    for dir in datasets {
        let labels = eyereplay_dataset::read_labels(dir)?;
        if labels.is_empty() {
            return Err(Error::input(dir.join("labels.csv"), "no sessions"));
        }
        let meta = eyereplay_dataset::read_metadata(dir).ok();
        let fps = meta
            .as_ref()
            .map(|m| m.dataset.fps)
            .filter(|f| *f > 0.0)
            .unwrap_or(FPS);
        for row in &labels {
            let paths = eyereplay_dataset::SessionPaths::new(dir, &row.file)
                .map_err(|e| Error::input(dir.join("labels.csv"), e.to_string()))?;
            let file = input.file(&paths).to_path_buf();
            if !file.is_file() {
                return Err(Error::input(
                    &file,
                    format!("missing{}", input.missing_hint()),
                ));
            }
            let frame_reading = eyereplay_dataset::read_reading_column(&paths.csv)?;
            // Its rows, counted (the reading column above has parsed it).
            let frames = eyereplay_backends::csv_data_rows(&paths.csv)
                .ok_or_else(|| Error::input(&paths.csv, "cannot be read"))?;
            if let Some(m) = &meta {
                eyereplay_dataset::check_session_rows(
                    &paths.csv,
                    frames,
                    m.dataset.session_frames,
                )?;
            }
            // A video or truth file cut short (a render killed mid-way, a
            // copy that stopped) would be read as a shorter session; its
            // frames are counted as `merge` counts them, without decoding.
            let held = match input {
                // A file that is no video is refused here, before the
                // other sessions' extraction, not after it.
                TrainInput::Extracted => {
                    Some(eyereplay_extract::count_video_packets(&file)? as usize)
                }
                TrainInput::Drawn => eyereplay_backends::csv_data_rows(&file),
                TrainInput::Trajectory => None,
            };
            if let Some(n) = held.filter(|&n| n < frames) {
                let unit = if input == TrainInput::Drawn {
                    "rows"
                } else {
                    "frames"
                };
                return Err(Error::input(
                    &file,
                    format!(
                        "{n} {unit} where its session has {frames}: cut short? (render it again)"
                    ),
                ));
            }
            sessions.push(SessionEntry {
                id: format!("{}#{}", dir.display(), row.file),
                reading: row.label() == 1,
                sources: row.sources.clone(),
                file,
                frame_reading,
                frames,
                fps,
            });
        }
    }
    Ok(sessions)
}

/// The tracks of every session of `datasets`, read as `input` says.
/// Checks every dataset (labels.csv, the videos) before extracting any.
pub fn dataset_tracks(
    datasets: &[PathBuf],
    input: TrainInput,
    cache: &Path,
    progress: &dyn Progress,
) -> Result<Vec<LabeledTrack>> {
    session_tracks(dataset_sessions(datasets, input)?, input, cache, progress)
}

/// The tracks of checked sessions ([`dataset_sessions`]), read as `input`
/// says.
pub fn session_tracks(
    sessions: Vec<SessionEntry>,
    input: TrainInput,
    cache: &Path,
    progress: &dyn Progress,
) -> Result<Vec<LabeledTrack>> {
    let files: Vec<PathBuf> = sessions.iter().map(|s| s.file.clone()).collect();
    let tracks = match input {
        TrainInput::Extracted => video_tracks(&files, cache, progress)?,
        TrainInput::Trajectory => files
            .iter()
            .map(|f| session_csv_track(f))
            .collect::<Result<_>>()?,
        TrainInput::Drawn => files
            .iter()
            .map(|f| truth_csv_track(f))
            .collect::<Result<_>>()?,
    };
    Ok(sessions
        .into_iter()
        .zip(tracks)
        .map(|(s, track)| LabeledTrack {
            id: s.id,
            reading: s.reading,
            sources: s.sources,
            track,
            frame_reading: s.frame_reading,
        })
        .collect())
}

/// Before any extraction: what the sessions' lengths and labels already
/// tell. It refuses only what no extraction can change (no session as
/// long as a window, one class only), so a dataset it lets through may
/// still lack windows with enough gaze, which training then says.
fn check_trainable(sessions: &[SessionEntry], opts: &TrainDetectorOptions) -> Result<()> {
    if opts.frame_labels && sessions.iter().all(|s| s.frame_reading.is_none()) {
        return Err(Error::Setting(
            "--frame-labels: no session CSV has a per-frame `reading` column (interview \
             sessions have one); train without it to label windows by class"
                .into(),
        ));
    }
    let why = |why: String| {
        Error::Setting(format!(
            "training needs windows of both classes (reading and other): {why}"
        ))
    };
    let longest_s = sessions
        .iter()
        .map(SessionEntry::duration_s)
        .fold(0.0, f64::max);
    if longest_s < opts.window_s {
        return Err(why(format!(
            "the longest session is {longest_s:.1} s, shorter than a window ({} s; --window-s)",
            opts.window_s
        )));
    }
    // Each session's labels: its frames' where --frame-labels reads them,
    // its class's otherwise.
    let has = |reading: bool| {
        sessions
            .iter()
            .any(|s| match (&s.frame_reading, opts.frame_labels) {
                (Some(f), true) => f.contains(&reading),
                _ => s.reading == reading,
            })
    };
    if !(has(true) && has(false)) {
        let missing = if has(true) {
            "other (not reading)"
        } else {
            "reading"
        };
        let whose = if opts.frame_labels {
            "labels.csv or the sessions' per-frame `reading` columns"
        } else {
            "labels.csv"
        };
        return Err(why(format!(
            "no session of the {} is labeled {missing} in {whose}",
            sessions.len()
        )));
    }
    Ok(())
}

/// A rendered video whose face is found in fewer frames than this share is
/// worth a warning: its track is mostly gaps.
const MIN_FACE_SHARE: f64 = 0.5;

/// The 25 fps tracks of rendered session videos, each extracted once
/// (cached by content): the extractor's full pipeline, except for a
/// close-up render (its identity JSON gives the eye corners), which has no
/// face for the detector and is read as `eyereplay evaluate` reads it: the
/// iris model on eye crops at the render's known eye corners.
pub fn video_tracks(
    videos: &[PathBuf],
    cache: &Path,
    progress: &dyn Progress,
) -> Result<Vec<Track>> {
    let mut todo: Vec<usize> = Vec::new();
    let mut paths = Vec::with_capacity(videos.len());
    for (i, v) in videos.iter().enumerate() {
        let full = extraction_cache_path(v, cache)?;
        let corners = full.with_extension("corners.csv");
        if !full.is_file() && !corners.is_file() {
            todo.push(i);
        }
        paths.push((full, corners));
    }
    if !todo.is_empty() {
        check_models()?;
    }
    // Close-ups (their identity JSON gives the eye corners) go straight to
    // the corner read-back: the face detector would search them in vain.
    let mut full_todo = Vec::new();
    let mut corner_todo = Vec::new();
    for &i in &todo {
        let identity = eyereplay_dataset::SessionPaths::beside_video(&videos[i]).identity_json;
        let corners = if identity.is_file() {
            eyereplay_dataset::SessionIdentity::read(&identity)?.corner_pairs_px()
        } else {
            None
        };
        match corners {
            Some(c) => corner_todo.push((i, c)),
            None => full_todo.push(i),
        }
    }
    {
        use rayon::prelude::*;
        // One video a worker: each reads its frames in order.
        corner_todo
            .par_iter()
            .map(|&(i, c)| -> Result<()> {
                let n = eyereplay_extract::extract_at_corners(
                    &videos[i],
                    &eyereplay_extract::default_models_dir(),
                    c,
                    usize::MAX,
                    1,
                )?;
                save_corner_track(&paths[i].1, &n)?;
                progress.info(&format!(
                    "read {} at its eye corners (close-up)",
                    videos[i].display()
                ));
                Ok(())
            })
            .collect::<Result<Vec<()>>>()?;
    }
    if !full_todo.is_empty() {
        let list: Vec<PathBuf> = full_todo.iter().map(|&i| videos[i].clone()).collect();
        progress.begin(Stage::Extract, 0);
        let results = eyereplay_extract::extract_many(
            &list,
            &eyereplay_extract::ExtractOptions::default(),
            &StageFrames(progress),
        );
        progress.end(Stage::Extract);
        for (&i, r) in full_todo.iter().zip(results) {
            let ex = r?;
            if ex.detection_rate() < MIN_FACE_SHARE {
                progress.warn(&format!(
                    "warning: {}: the face was found in only {:.0} % of its frames",
                    videos[i].display(),
                    100.0 * ex.detection_rate()
                ));
            }
            eyereplay_extract::save_csv(&paths[i].0, &ex.rows)?;
        }
    }
    paths
        .iter()
        .map(|(full, corners)| {
            if full.is_file() {
                extract_csv_track(full)
            } else {
                read_corner_track(corners)
            }
        })
        .collect()
}

/// `frame,nx,ny` per frame, `nan` where no open eye was read.
fn save_corner_track(path: &Path, n: &[[f64; 2]]) -> Result<()> {
    let mut text = String::from("frame,nx,ny\n");
    for (i, p) in n.iter().enumerate() {
        text += &format!("{i},{},{}\n", p[0], p[1]);
    }
    eyereplay_core::atomic_write(path, text.as_bytes())?;
    Ok(())
}

fn read_corner_track(path: &Path) -> Result<Track> {
    let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
    let mut xy = Vec::new();
    for (k, line) in text.lines().enumerate().skip(1) {
        let cells: Vec<&str> = line.split(',').collect();
        let num = |c: Option<&&str>| c.and_then(|c| c.trim().parse::<f64>().ok());
        match (num(cells.get(1)), num(cells.get(2))) {
            (Some(x), Some(y)) => xy.push([x, y]),
            _ => {
                return Err(Error::input(
                    path,
                    format!("line {}: expected frame,nx,ny", k + 1),
                ))
            }
        }
    }
    Ok(Track::new(xy))
}

/// Noisy copies of each session `train` makes at most.
pub const MAX_NOISE_COPIES: usize = 100;

/// Training windows of a class below which a model is called unreliable.
const FEW_WINDOWS: usize = 20;

/// Below this validation AUROC a model is called no better than chance
/// (0.5 is chance; the bundled detector's is about 0.9).
const CHANCE_AUROC: f64 = 0.6;

/// What a trained model's own figures say against using it, one line
/// each: too few windows of a class to trust it, or a validation AUROC no
/// better than chance. The model is still written (it is what the data
/// gave); `eyereplay train` prints these as warnings, the Python package
/// raises them as `EyereplayWarning`.
pub fn training_warnings(model: &DetectorModel) -> Vec<String> {
    let t = &model.training;
    let mut out = Vec::new();
    let fewest = t.train_windows_reading.min(t.train_windows_other);
    if fewest < FEW_WINDOWS {
        out.push(format!(
            "only {fewest} training windows of one class (fewer than {FEW_WINDOWS}): \
             the model and its AUROC are unreliable; more or longer sessions, or a shorter \
             --window-s, give more"
        ));
    }
    if let Some(auroc) = t.validation_auroc.filter(|a| *a < CHANCE_AUROC) {
        out.push(format!(
            "the model separates reading from other windows of held-out sessions \
             no better than chance (AUROC {auroc:.3}, below {CHANCE_AUROC}); it will call \
             nearly everything one class (more sessions, or classes whose gaze differs, \
             train a better one)"
        ));
    }
    out
}

/// Trains the feature model on every session of `datasets`: windows of
/// `window_s` overlapping by half, validation held out by session.
pub fn train_detector(
    datasets: &[PathBuf],
    opts: &TrainDetectorOptions,
    progress: &dyn Progress,
) -> Result<DetectorModel> {
    if !(eyereplay_detect::MIN_WINDOW_S..=eyereplay_detect::MAX_WINDOW_S).contains(&opts.window_s) {
        return Err(Error::Setting(format!(
            "--window-s must be {} to {} seconds, got {}",
            eyereplay_detect::MIN_WINDOW_S,
            eyereplay_detect::MAX_WINDOW_S,
            eyereplay_core::show_number(opts.window_s)
        )));
    }
    let t = &opts.train;
    if !(t.max_fpr > 0.0 && t.max_fpr < 1.0) {
        return Err(Error::Setting(format!(
            "--max-fpr must be a share above 0 and below 1 (e.g. 0.05), got {}",
            eyereplay_core::show_number(t.max_fpr)
        )));
    }
    if !(t.alpha >= 0.0 && t.alpha.is_finite()) {
        return Err(Error::Setting(format!(
            "--alpha must be a number >= 0, got {}",
            eyereplay_core::show_number(t.alpha)
        )));
    }
    if t.noise_copies > MAX_NOISE_COPIES {
        return Err(Error::Setting(format!(
            "--noise-copies must be at most {MAX_NOISE_COPIES} (each copy adds as many windows \
             as the sessions themselves give), got {}",
            t.noise_copies
        )));
    }
    // The same folder twice would put each session on both sides of the
    // validation split, and its AUROC would not be of unseen sessions.
    for (i, d) in datasets.iter().enumerate() {
        if datasets[..i]
            .iter()
            .any(|e| eyereplay_core::same_file(e, d))
        {
            return Err(Error::input(
                d,
                "given twice: each dataset may be trained on once",
            ));
        }
    }
    let sessions = dataset_sessions(datasets, opts.input)?;
    check_trainable(&sessions, opts)?;
    let tracks = session_tracks(sessions, opts.input, &opts.cache, progress)?;
    let examples = if opts.frame_labels {
        frame_labeled_examples(&tracks, opts.window_s)
    } else {
        training_examples(&tracks, opts.window_s, &opts.train)
    };
    let names = datasets.iter().map(|d| d.display().to_string()).collect();
    Ok(eyereplay_detect::train(
        &examples,
        opts.window_s,
        opts.train,
        names,
        opts.input.name(),
    )?)
}

/// The training windows of labeled session tracks: windows of `window_s`
/// overlapping by half, plus the noisy copies `train` asks for.
pub fn training_examples(
    tracks: &[LabeledTrack],
    window_s: f64,
    train: &TrainOptions,
) -> Vec<Example> {
    tracks
        .iter()
        .flat_map(|t| {
            eyereplay_detect::model::session_examples(
                &t.track,
                t.reading,
                &t.id,
                WindowSpec::half_overlap(window_s),
                train.noise_copies,
                train.seed,
            )
        })
        .collect()
}

/// Training windows labeled frame by frame ([`window_label`]) where a
/// session has per-frame labels, by its class elsewhere; windows of
/// `window_s` overlapping by half, no noisy copies.
pub fn frame_labeled_examples(tracks: &[LabeledTrack], window_s: f64) -> Vec<Example> {
    let spec = WindowSpec::half_overlap(window_s);
    tracks
        .iter()
        .flat_map(|t| {
            windows(&t.track, spec).into_iter().filter_map(|w| {
                let label = match &t.frame_reading {
                    Some(f) => window_label(f, w.start, spec.frames)?,
                    None => t.reading,
                };
                Some(Example::of(&w, label, &t.id))
            })
        })
        .collect()
}

/// One scored window of a recording.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct WindowScore {
    pub start_s: f64,
    pub end_s: f64,
    pub reading_probability: f64,
    pub reading: bool,
    /// The zero-training rule's score (share of saccades in forward runs).
    pub forward_run_fraction: f64,
}

/// A recording's detection: per window and as a whole.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Detection {
    pub input: TrackInfo,
    pub model: DetectionModelInfo,
    pub windows: Vec<WindowScore>,
    /// Mean of the windows' probabilities.
    pub reading_probability: f64,
    /// Share of windows called reading.
    pub reading_window_fraction: f64,
    /// `reading` when the mean probability reaches the model's threshold;
    /// for a short clip, `uncertain` when its interval holds the threshold.
    pub verdict: String,
    /// When: the probability per second and the reading segments
    /// ([`eyereplay_detect::localize::DEFAULT_METHOD`]: the hidden Markov
    /// model's segments, their ends where the window mean crosses;
    /// docs/DETECTOR.md measures it).
    pub localization: eyereplay_detect::localize::Localization,
    /// A recording without one whole window of gaze (a clip of 3-10 s, a
    /// patchy one): the score of its best stretch with a bootstrap
    /// interval ([`eyereplay_detect::clip`]); `null` otherwise.
    pub clip: Option<ClipScore>,
}

impl Detection {
    /// A short clip's score, worded as `detect` prints it and the
    /// reviewer's page shows it ("8.0 s of gaze in 0.0-8.0 s scored,
    /// P(reading) 0.947, 90 % interval 0.900-0.990, threshold 0.775");
    /// `None` for a recording scored by its windows.
    pub fn clip_summary(&self) -> Option<String> {
        self.clip.as_ref().map(|c| {
            format!(
                "{:.1} s of gaze in {:.1}-{:.1} s scored, P(reading) {:.3}, {:.0} % interval {:.3}-{:.3}, threshold {:.3}",
                c.usable_s,
                c.start_s,
                c.end_s,
                c.reading_probability,
                100.0 * c.level,
                c.low,
                c.high,
                self.model.threshold
            )
        })
    }

    /// The stretches no window could score, to show and explain; none for
    /// a short clip, which is scored whole from its best stretch.
    pub fn unscored(&self) -> &[eyereplay_detect::localize::Unscored] {
        if self.clip.is_none() {
            &self.localization.unscored
        } else {
            &[]
        }
    }
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DetectionModelInfo {
    pub path: String,
    pub kind: String,
    pub window_s: f64,
    pub threshold: f64,
}

/// Scores a track with non-overlapping windows of the model's length.
pub fn detect_track(
    track: &Track,
    info: TrackInfo,
    model: &DetectorModel,
    model_path: &Path,
) -> Result<Detection> {
    let spec = WindowSpec::seconds(model.window_s);
    let ws = windows(track, spec);
    let model_info = DetectionModelInfo {
        path: model_path.display().to_string(),
        kind: model.kind.clone(),
        window_s: model.window_s,
        threshold: model.threshold,
    };
    let localization = eyereplay_detect::localize::localize(
        track,
        model,
        eyereplay_detect::localize::DEFAULT_METHOD,
        eyereplay_detect::localize::SEGMENT_THRESHOLD,
    );
    if ws.is_empty() {
        // Shorter or patchier than one window: score what there is, with
        // its interval, or say how much gaze is missing.
        let clip = score_clip(track, model).map_err(|e| {
            Error::input(
                &info.path,
                format!(
                    "not enough gaze: {:.1} s usable of {:.1} s, {:.1} s needed (in a stretch with gaze in at least {:.0} % of its frames)",
                    e.usable_s,
                    track.duration_s(),
                    e.needed_s,
                    100.0 * (1.0 - eyereplay_detect::window::MAX_MISSING_FRACTION)
                ),
            )
        })?;
        let verdict = if clip.low >= model.threshold {
            "reading"
        } else if clip.high < model.threshold {
            "not reading"
        } else {
            "uncertain"
        };
        return Ok(Detection {
            input: info,
            model: model_info,
            windows: Vec::new(),
            reading_probability: clip.reading_probability,
            reading_window_fraction: 0.0,
            verdict: verdict.into(),
            localization,
            clip: Some(clip),
        });
    }
    let scores: Vec<WindowScore> = ws
        .iter()
        .map(|w| {
            let p = model.probability(w);
            WindowScore {
                start_s: w.start as f64 / FPS,
                end_s: (w.start + spec.frames) as f64 / FPS,
                reading_probability: p,
                reading: p >= model.threshold,
                forward_run_fraction: eyereplay_detect::rule_score(w),
            }
        })
        .collect();
    let n = scores.len() as f64;
    let mean = scores.iter().map(|s| s.reading_probability).sum::<f64>() / n;
    let frac = scores.iter().filter(|s| s.reading).count() as f64 / n;
    Ok(Detection {
        input: info,
        model: model_info,
        windows: scores,
        reading_probability: mean,
        reading_window_fraction: frac,
        verdict: if mean >= model.threshold {
            "reading".into()
        } else {
            "not reading".into()
        },
        localization,
        clip: None,
    })
}

/// The detection figure: probability over time under the x and y track.
pub fn detection_figure(track: &Track, d: &Detection) -> Result<eyereplay_eval::plot::Figure> {
    let windows: Vec<(f64, f64, f64)> = d
        .windows
        .iter()
        .map(|w| (w.start_s, w.end_s, w.reading_probability))
        .collect();
    Ok(eyereplay_eval::plot::detection_figure(
        &track.xy,
        FPS,
        &windows,
        &figure_unscored(track.len(), d),
        d.model.threshold,
        &figure_title(d),
    )?)
}

/// The figure's title: the verdict, and with reading segments how many,
/// so that "not reading" (the recording's average) does not stand alone
/// over bars that show an answer read.
fn figure_title(d: &Detection) -> String {
    let n = d.localization.segments.len();
    if d.clip.is_some() || n == 0 {
        format!("{}: {}", file_label(&d.input.path), d.verdict)
    } else {
        format!(
            "{}: reading in {n} segment{}; {} on average",
            file_label(&d.input.path),
            if n == 1 { "" } else { "s" },
            d.verdict
        )
    }
}

/// What the figure greys: the stretches no window could score
/// ([`Detection::unscored`]) and, since its bars are `detect`'s own
/// back-to-back windows, each of those windows that had too little gaze
/// for a score (such a window can lie between stretches that overlapping
/// windows did score); merged, in seconds.
fn figure_unscored(track_frames: usize, d: &Detection) -> Vec<(f64, f64)> {
    let mut spans: Vec<(f64, f64)> = d.unscored().iter().map(|u| (u.start_s, u.end_s)).collect();
    if d.clip.is_none() {
        let spec = WindowSpec::seconds(d.model.window_s);
        let mut start = 0;
        while start + spec.frames <= track_frames {
            let (a, b) = (start as f64 / FPS, (start + spec.frames) as f64 / FPS);
            if !d.windows.iter().any(|w| (w.start_s - a).abs() < 0.5 / FPS) {
                spans.push((a, b));
            }
            start += spec.step;
        }
    }
    spans.sort_by(|p, q| p.0.total_cmp(&q.0));
    let mut merged: Vec<(f64, f64)> = Vec::with_capacity(spans.len());
    for (a, b) in spans {
        match merged.last_mut() {
            Some(last) if a <= last.1 => last.1 = last.1.max(b),
            _ => merged.push((a, b)),
        }
    }
    merged
}

fn file_label(path: &str) -> String {
    Path::new(path)
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| path.to_string())
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// A 100-s detection of `call.mp4` with nothing found, for tests.
    pub(crate) fn sample_detection() -> Detection {
        serde_json::from_value(serde_json::json!({
            "input": {"path": "call.mp4", "kind": "video", "frames": 2500, "gaze_fraction": 1.0},
            "model": {"path": "m.json", "kind": "logistic_regression", "window_s": 10.0, "threshold": 0.6},
            "windows": [], "reading_probability": 0.1, "reading_window_fraction": 0.0,
            "verdict": "not reading",
            "localization": {"method": "hmm_edges", "step_s": 1.0, "probability": [0.1],
                             "segments": [], "unscored": []},
            "clip": null
        }))
        .unwrap()
    }

    /// A plot of an interview with read answers says so in its title; the
    /// "not reading" of the average alone read as a contradiction.
    #[test]
    fn the_figure_title_names_the_segments() {
        let mut d = sample_detection();
        d.input.path = "out/gap_call.mp4".into();
        d.localization.segments = serde_json::from_value(serde_json::json!([
            {"start_s": 0.0, "end_s": 44.0, "confidence": 0.9},
            {"start_s": 78.0, "end_s": 108.0, "confidence": 0.8}
        ]))
        .unwrap();
        assert_eq!(
            figure_title(&d),
            "gap_call.mp4: reading in 2 segments; not reading on average"
        );
        d.localization.segments.clear();
        assert_eq!(figure_title(&d), "gap_call.mp4: not reading");
    }

    #[test]
    fn frames_too_sparse_to_join_are_said_to_be() {
        let at = |fps: f64| -> Vec<f64> { (0..50).map(|k| k as f64 / fps).collect() };
        // 5 a second: 0.2 s apart, the most the track joins.
        let w = sparse_frames_warning(&at(5.0)).unwrap();
        assert!(w.contains("come 5.0 a second"), "{w}");
        assert!(sparse_frames_warning(&at(2.0)).is_some());
        assert!(sparse_frames_warning(&at(10.0)).is_none());
        assert!(sparse_frames_warning(&at(25.0)).is_none());
        // A few frames say nothing either way.
        assert!(sparse_frames_warning(&at(1.0)[..5]).is_none());
    }

    #[test]
    fn a_video_is_told_by_its_extension_or_else_by_not_being_text() {
        let dir = tempfile::tempdir().unwrap();
        let file = |name: &str, bytes: &[u8]| {
            let p = dir.path().join(name);
            std::fs::write(&p, bytes).unwrap();
            p
        };
        // An MPEG-TS packet starts with the sync byte 0x47 and binary.
        let ts = [0x47u8, 0x40, 0x00, 0x10, 0x00, 0x00, 0xb0, 0x0d, 0xff, 0xfe];
        assert!(is_video(&file("call.ts", &ts)));
        assert!(is_video(&file("call", &ts)));
        assert!(is_video(&file("clip.MP4", b"frame,x,y\n")));
        assert!(!is_video(&file("gaze.csv", &ts)));
        assert!(!is_video(&file("gaze.dat", b"frame,x,y\n0,1.5,2.5\n")));
        // Text whose 1 KiB cut falls inside a two-byte character.
        let mut long = vec![b'a'; 1023];
        long.extend("é,x\n".as_bytes());
        assert!(!is_video(&file("notes", &long)));
        assert!(is_video(&dir.path().join("missing.bin")));
    }

    /// 65 s scored in back-to-back 10-s windows, of which 0-10, 30-40 and
    /// 40-50 s had a score, and 12-18 s that no window could score: the
    /// figure greys 10-30 s (two unscored windows around that stretch,
    /// merged) and 50-60 s; not the last 5 s, which no window covers.
    #[test]
    fn the_figure_greys_unscored_stretches_and_windows_merged() {
        use eyereplay_detect::localize::{Localization, Unscored, DEFAULT_METHOD};
        let window = |start_s: f64| WindowScore {
            start_s,
            end_s: start_s + 10.0,
            reading_probability: 0.0,
            reading: false,
            forward_run_fraction: 0.0,
        };
        let mut d = Detection {
            input: TrackInfo {
                path: "v.mp4".into(),
                kind: "video".into(),
                frames: 1625,
                gaze_fraction: 0.8,
            },
            model: DetectionModelInfo {
                path: "m.json".into(),
                kind: "features".into(),
                window_s: 10.0,
                threshold: 0.6,
            },
            windows: vec![window(0.0), window(30.0), window(40.0)],
            reading_probability: 0.0,
            reading_window_fraction: 0.0,
            verdict: "not reading".into(),
            localization: Localization {
                method: DEFAULT_METHOD,
                step_s: 1.0,
                probability: Vec::new(),
                segments: Vec::new(),
                unscored: vec![Unscored {
                    start_s: 12.0,
                    end_s: 18.0,
                    usable_s: 1.0,
                    needed_s: 7.0,
                }],
                window_mean: Vec::new(),
            },
            clip: None,
        };
        assert_eq!(figure_unscored(1625, &d), [(10.0, 30.0), (50.0, 60.0)]);
        // A short clip is scored whole: nothing grey.
        d.windows.clear();
        d.clip = Some(ClipScore {
            start_s: 0.0,
            end_s: 8.0,
            usable_s: 7.5,
            reading_probability: 0.3,
            low: 0.2,
            high: 0.4,
            level: 0.9,
        });
        assert_eq!(figure_unscored(1625, &d), []);
    }

    #[test]
    fn the_drawn_track_is_both_eyes_mean_with_closed_lids_as_gaps() {
        use eyereplay_dataset::{EyeTruthRow, TruthRow};
        let eye = |nx: f64, ny: f64| EyeTruthRow {
            nx,
            ny,
            ..Default::default()
        };
        let rows = vec![
            TruthRow {
                frame: 0,
                eyes: [eye(0.40, 0.50), eye(0.44, 0.56)],
                ..Default::default()
            },
            TruthRow {
                frame: 1,
                eyes: [eye(0.30, 0.50), eye(0.34, 0.50)],
                lid_closure: 0.9,
                blink: true,
                ..Default::default()
            },
            TruthRow {
                frame: 2,
                eyes: [eye(0.61, 0.40), eye(0.63, 0.42)],
                ..Default::default()
            },
        ];
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("s_truth.csv");
        eyereplay_dataset::write_truth_csv(&path, &rows).unwrap();
        let t = truth_csv_track(&path).unwrap();
        assert_eq!(t.len(), 3);
        // (0.40 + 0.44) / 2 and (0.50 + 0.56) / 2, through the file's 5 decimals.
        assert!((t.xy[0][0] - 0.42).abs() < 1e-9 && (t.xy[0][1] - 0.53).abs() < 1e-9);
        assert!(t.xy[1][0].is_nan() && t.xy[1][1].is_nan());
        assert!((t.xy[2][0] - 0.62).abs() < 1e-9 && (t.xy[2][1] - 0.41).abs() < 1e-9);
    }

    #[test]
    fn drawn_input_reads_each_sessions_truth_beside_its_reading_labels() {
        use eyereplay_dataset::{EyeTruthRow, TruthRow};
        let dir = tempfile::tempdir().unwrap();
        let data = dir.path().join("d");
        std::fs::create_dir_all(data.join("conversation")).unwrap();
        std::fs::write(
            data.join("labels.csv"),
            "file,label,class,sources\nconversation/conversation_0000.csv,0,conversation,m#0\n",
        )
        .unwrap();
        std::fs::write(
            data.join("conversation/conversation_0000.csv"),
            "frame,x,y,blink,reading\n0,600.0,300.0,0,1\n1,610.0,300.0,0,1\n2,620.0,300.0,0,0\n",
        )
        .unwrap();
        let cache = dir.path().join("cache");
        let missing = dataset_tracks(
            std::slice::from_ref(&data),
            TrainInput::Drawn,
            &cache,
            &eyereplay_core::NoProgress,
        )
        .unwrap_err()
        .to_string();
        assert!(
            missing.contains("conversation_0000_truth.csv") && missing.contains("missing"),
            "{missing}"
        );
        let eye = |nx: f64| EyeTruthRow {
            nx,
            ny: 0.5,
            ..Default::default()
        };
        let rows: Vec<TruthRow> = (0..3)
            .map(|k| TruthRow {
                frame: k,
                eyes: [eye(0.4 + 0.1 * k as f64), eye(0.5 + 0.1 * k as f64)],
                ..Default::default()
            })
            .collect();
        // A truth file cut short (a render killed, a copy that stopped)
        // is named, with both lengths, not read as a shorter session.
        // One row short is short.
        let truth = data.join("conversation/conversation_0000_truth.csv");
        eyereplay_dataset::write_truth_csv(&truth, &rows[..2]).unwrap();
        let short = dataset_tracks(
            std::slice::from_ref(&data),
            TrainInput::Drawn,
            &cache,
            &eyereplay_core::NoProgress,
        )
        .unwrap_err()
        .to_string();
        assert!(
            short.contains(
                "conversation_0000_truth.csv: 2 rows where its session has 3: cut short?"
            ),
            "{short}"
        );
        eyereplay_dataset::write_truth_csv(&truth, &rows).unwrap();
        let t = dataset_tracks(
            &[data],
            TrainInput::Drawn,
            &cache,
            &eyereplay_core::NoProgress,
        )
        .unwrap();
        assert_eq!(t.len(), 1);
        assert!(!t[0].reading);
        assert_eq!(t[0].frame_reading, Some(vec![true, true, false]));
        // The eyes' means, not the session's canvas x (600-620 px).
        let x: Vec<f64> = t[0].track.xy.iter().map(|p| p[0]).collect();
        for (got, want) in x.iter().zip([0.45, 0.55, 0.65]) {
            assert!((got - want).abs() < 1e-9, "{x:?}");
        }
    }

    #[test]
    fn a_window_takes_its_frames_label_or_none_when_it_straddles_a_switch() {
        // 10 frames: 3 reading, then 7 not.
        let f: Vec<bool> = (0..10).map(|k| k < 3).collect();
        assert_eq!(window_label(&f, 0, 3), Some(true));
        assert_eq!(window_label(&f, 3, 5), Some(false));
        // 2 of 5 reading: 40 %, neither.
        assert_eq!(window_label(&f, 1, 5), None);
        // 1 of 5 reading: 20 %, not reading; past the end counts what is there.
        assert_eq!(window_label(&f, 2, 5), Some(false));
        assert_eq!(window_label(&f, 8, 5), Some(false));
        assert_eq!(window_label(&f, 10, 5), None);
    }

    fn s(t: f64, x: f64, gaze: bool) -> Sample<NormPos> {
        let mut v = Sample::new(t, NormPos { nx: x, ny: 0.5 });
        v.valid = gaze;
        v
    }

    #[test]
    fn resampling_interpolates_between_gaze_and_leaves_gaps_empty() {
        // 30 fps samples, x = t; one invalid frame at t = 0.1.
        let samples: Vec<Sample<NormPos>> = (0..31)
            .map(|i| s(i as f64 / 30.0, i as f64 / 30.0, i != 3))
            .collect();
        let refs: Vec<&Sample<NormPos>> = samples.iter().collect();
        let t = resample_samples(&refs);
        assert_eq!(t.len(), 26); // 0 .. 1 s at 25 fps
        assert!((t.xy[1][0] - 0.04).abs() < 1e-12); // between 1/30 and 2/30
        assert!(t.xy[3][0].is_nan()); // t = 0.12 lies between 0.1 (invalid) and 0.133
        assert!((t.xy[25][0] - 1.0).abs() < 1e-12);
    }

    /// 20 s of video at 24 fps (480 frames, the last at 19.958 s, lasting
    /// to 20.0 s) is 500 frames at 25 fps, the last at 19.96 s showing the
    /// video's last frame: two 10-s windows, as 20 s at 25 or 30 fps give.
    #[test]
    fn a_recording_lasts_to_the_end_of_its_last_frame() {
        for (fps, frames) in [(24.0, 480), (25.0, 500), (30.0, 600), (29.97, 599)] {
            let samples: Vec<Sample<NormPos>> = (0..frames)
                .map(|i| s(i as f64 / fps, i as f64, true))
                .collect();
            let refs: Vec<&Sample<NormPos>> = samples.iter().collect();
            let t = resample_samples(&refs);
            // Frames at k / 25 s before the end, frames / fps s.
            let expected = (frames as f64 / fps * FPS - 1e-6).ceil() as usize;
            assert_eq!(t.len(), expected, "{fps} fps");
            // The last frame shows the last sample, held, or lies between
            // the last two.
            let last = t.xy[t.len() - 1][0];
            assert!(
                last > (frames - 2) as f64 && last <= (frames - 1) as f64,
                "{fps}: {last}"
            );
        }
        // A last sample after a gap holds no longer than gaze is joined.
        let gap = [s(0.0, 0.0, true), s(5.0, 1.0, true)];
        let refs: Vec<&Sample<NormPos>> = gap.iter().collect();
        assert!((recording_end_s(&refs) - (5.0 + MAX_INTERP_GAP_S)).abs() < 1e-12);
        // One sample: one frame.
        assert_eq!(resample_samples(&refs[..1]).len(), 1);
    }
}
