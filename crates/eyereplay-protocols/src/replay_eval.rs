//! The replay mode's proofs on a rendered dataset (`eyereplay
//! evaluate-replay DATASET`): each session video read back with the
//! unmodified extractor and compared, over the frames whose eyes were
//! redrawn and read as open, with the trajectory (fidelity), with the
//! carrier's own gaze in the same frames (removal), with the carrier's
//! face score (detector unaffected), and, outside the eyes, with the
//! carrier's decoded frames (PSNR).

use eyereplay::{Error, Result};
use eyereplay_core::Progress;
use eyereplay_eval::stats::{linear_fit, mean, pearson};
use eyereplay_eval::visual::{compare_visual, AxisFidelity};
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Output frames between PSNR samples.
const PSNR_EVERY: usize = 10;

/// One session's or one group's numbers.
#[derive(Clone, Debug, Serialize)]
pub struct ReplayCheck {
    pub carrier: String,
    pub class: String,
    pub sessions: usize,
    /// Frames compared (redrawn, and open with a face in the read-back).
    pub frames: usize,
    /// Read-back `n` against the trajectory.
    pub x: AxisFidelity,
    pub y: AxisFidelity,
    /// Pearson r of the read-back `n` with the carrier's own `n` in the
    /// same frames (the carrier's gaze must be gone).
    pub removal_r_x: Option<f64>,
    pub removal_r_y: Option<f64>,
    /// Pearson r of the trajectory with the carrier's own `n` (x): two
    /// unrelated signals of a few seconds correlate by chance, and the
    /// read-back inherits that; a removal r near this is no leak.
    pub chance_r_x: Option<f64>,
    /// Pearson r of the carrier's own `n` (x) with what the read-back has
    /// beyond the trajectory (its residual from the least-squares line on
    /// the trajectory): the leak itself, chance alignment taken out.
    pub removal_partial_r_x: Option<f64>,
    /// Mean face score of the read-back and of the carrier's frames shown.
    pub face_score_output: f64,
    pub face_score_carrier: f64,
    /// Outside the eye regions, against the decoded carrier frames.
    pub psnr_outside_eyes_db: f64,
}

/// Everything `evaluate-replay` measured.
#[derive(Clone, Debug, Serialize)]
pub struct ReplayEval {
    pub dataset: String,
    /// Per carrier and class, sessions pooled.
    pub groups: Vec<ReplayCheck>,
    pub sessions: Vec<(String, ReplayCheck)>,
}

struct Columns {
    header: Vec<String>,
    rows: Vec<Vec<String>>,
}

impl Columns {
    fn read(path: &Path) -> Result<Columns> {
        let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
        let mut lines = text.lines();
        let header = lines
            .next()
            .ok_or_else(|| Error::input(path, "empty CSV"))?
            .split(',')
            .map(str::to_string)
            .collect();
        let rows = lines
            .map(|l| l.split(',').map(str::to_string).collect())
            .collect();
        Ok(Columns { header, rows })
    }

    fn col(&self, path: &Path, name: &str) -> Result<Vec<Option<f64>>> {
        let i = self
            .header
            .iter()
            .position(|h| h == name)
            .ok_or_else(|| Error::input(path, format!("no column '{name}'")))?;
        Ok(self
            .rows
            .iter()
            .map(|r| r.get(i).and_then(|v| v.parse::<f64>().ok()))
            .collect())
    }
}

/// Per-frame values of one session, for pooling.
#[derive(Default)]
struct Frames {
    target: Vec<[f64; 2]>,
    read: Vec<[f64; 2]>,
    carrier_n: Vec<[f64; 2]>,
    score_out: Vec<f64>,
    score_carrier: Vec<f64>,
    psnr_db: Vec<f64>,
    sessions: usize,
}

/// `y` minus its least-squares line on `x` (unchanged when x is constant).
fn residual(y: &[f64], x: &[f64]) -> Vec<f64> {
    let (slope, icept) = linear_fit(x, y).unwrap_or((0.0, mean(y).unwrap_or(0.0)));
    x.iter()
        .zip(y)
        .map(|(a, v)| v - icept - slope * a)
        .collect()
}

/// Fewer frames than this compared give no fidelity figures (n/a): a
/// correlation needs a few points, and `compare_visual` refuses fewer.
const MIN_FRAMES: usize = 3;

fn check(carrier: &str, class: &str, f: &Frames) -> Result<ReplayCheck> {
    let (n_frames, x, y) = if f.target.len() < MIN_FRAMES {
        let none = AxisFidelity {
            r: None,
            amplitude_ratio: None,
            gain: None,
            std_source: f64::NAN,
            std_rendered: f64::NAN,
        };
        (f.target.len(), none, none)
    } else {
        let v = compare_visual(&f.target, &f.read, None)?;
        (v.n_frames, v.x, v.y)
    };
    let col = |v: &[[f64; 2]], k: usize| v.iter().map(|p| p[k]).collect::<Vec<_>>();
    let mean = |v: &[f64]| mean(v).unwrap_or(f64::NAN);
    Ok(ReplayCheck {
        carrier: carrier.into(),
        class: class.into(),
        sessions: f.sessions,
        frames: n_frames,
        x,
        y,
        removal_r_x: pearson(&col(&f.read, 0), &col(&f.carrier_n, 0)),
        removal_r_y: pearson(&col(&f.read, 1), &col(&f.carrier_n, 1)),
        chance_r_x: pearson(&col(&f.target, 0), &col(&f.carrier_n, 0)),
        removal_partial_r_x: pearson(
            &residual(&col(&f.read, 0), &col(&f.target, 0)),
            &col(&f.carrier_n, 0),
        ),
        face_score_output: mean(&f.score_out),
        face_score_carrier: mean(&f.score_carrier),
        // Mean squared errors would pool better; sessions have equal
        // frame counts, so the mean of dB is close and readable.
        psnr_outside_eyes_db: mean(&f.psnr_db),
    })
}

/// Finds the carrier video whose sha256 the session's identity file
/// records, among `candidates` (hashed once each).
fn find_carrier(
    sha: &str,
    candidates: &[PathBuf],
    hashes: &mut BTreeMap<PathBuf, String>,
) -> Result<Option<PathBuf>> {
    for c in candidates.iter().filter(|c| c.is_file()) {
        if !hashes.contains_key(c) {
            hashes.insert(c.clone(), eyereplay_core::sha256_file(c)?);
        }
        if hashes[c] == sha {
            return Ok(Some(c.clone()));
        }
    }
    Ok(None)
}

/// Measures every session of a replay dataset. Each session's carrier is
/// found by the sha256 its identity file records, among `carriers` (for
/// clips elsewhere), the config's carriers (paths as written, from the
/// current folder: metadata.json keeps them as the config had them) and
/// the bundled ones. Extractions and carrier measurements are cached in
/// `cache`.
pub fn evaluate_replay(
    dataset: &Path,
    carriers: &[PathBuf],
    cache: &Path,
    progress: &dyn Progress,
) -> Result<ReplayEval> {
    let meta_path = dataset.join(eyereplay_dataset::layout::METADATA_FILE);
    let meta = eyereplay_dataset::read_metadata(dataset)?;
    let settings =
        eyereplay_dataset::RenderSettings::from_config(&meta.dataset.config, &meta_path)?;
    let eyereplay_dataset::BackendSettings::Replay {
        carriers: configured,
    } = &settings.backend
    else {
        return Err(Error::input(
            &meta_path,
            "not a replay dataset (render.backend is not \"replay\")",
        ));
    };
    for c in carriers {
        if c.is_dir() {
            return Err(Error::input(c, "--carrier: is a folder, not a video"));
        }
        if !c.is_file() {
            return Err(Error::input(c, "--carrier: no such video"));
        }
    }
    let mut candidates = carriers.to_vec();
    candidates.extend(configured.iter().cloned());
    candidates.extend(eyereplay_backends::replay::carrier_videos(&[], |p| {
        p.to_path_buf()
    }));
    let labels = eyereplay_dataset::read_labels(dataset)?;
    let listed: Vec<(&str, eyereplay_core::GazeClass)> =
        labels.iter().map(|l| (l.file.as_str(), l.class)).collect();
    eyereplay::check_labels_against_plan(dataset, &meta.dataset, &listed)?;
    let frames = meta.dataset.session_frames;

    // Every session's files read and checked, and every carrier found,
    // before any video is extracted (minutes on a large dataset).
    struct Ready {
        name: String,
        sha: String,
        kept: Vec<eyereplay_replay::CarrierCsvRow>,
        truth: Vec<eyereplay_dataset::TruthRow>,
    }
    let mut ready = Vec::with_capacity(labels.len());
    let mut paths = Vec::with_capacity(labels.len());
    for label in &labels {
        let p = eyereplay_dataset::SessionPaths::new(dataset, &label.file)
            .map_err(|e| Error::input(dataset.join("labels.csv"), e.to_string()))?;
        if !p.mp4.is_file() {
            return Err(Error::input(&p.mp4, "no such video"));
        }
        let ident = eyereplay_dataset::SessionIdentity::read(&p.identity_json)?;
        if ident.file != label.file {
            return Err(Error::input(
                &p.identity_json,
                format!("is the identity of {}, not of {}", ident.file, label.file),
            ));
        }
        let field = |k: &str| {
            ident.identity[k]
                .as_str()
                .map(str::to_string)
                .ok_or_else(|| Error::input(&p.identity_json, format!("no {k}")))
        };
        let (name, sha) = (field("carrier")?, field("carrier_sha256")?);
        let kept = eyereplay_replay::read_carrier_csv(&p.carrier_csv())?;
        let truth = eyereplay_dataset::read_truth_csv(&p.truth)?;
        for (file, rows) in [
            (p.carrier_csv(), kept.len()),
            (p.truth.clone(), truth.len()),
        ] {
            if rows != frames {
                return Err(Error::input(
                    &file,
                    format!("{rows} rows; the dataset's sessions have {frames} frames"),
                ));
            }
        }
        ready.push(Ready {
            name,
            sha,
            kept,
            truth,
        });
        paths.push(p);
    }
    let mut hashes = BTreeMap::new();
    let mut prepared: BTreeMap<String, eyereplay_replay::Carrier> = BTreeMap::new();
    for (r, p) in ready.iter().zip(&paths) {
        if !prepared.contains_key(&r.sha) {
            let video = find_carrier(&r.sha, &candidates, &mut hashes)?.ok_or_else(|| {
                Error::input(
                    &p.identity_json,
                    format!(
                        "carrier {} (sha256 {}) not found; pass it with --carrier PATH",
                        r.name, r.sha
                    ),
                )
            })?;
            let track = eyereplay_backends::replay::carrier_track(&video, cache, progress)?;
            let carrier = eyereplay_replay::Carrier::prepare(&video, track)?;
            prepared.insert(r.sha.clone(), carrier);
        }
        let carrier_frames = prepared[&r.sha].track.frames.len();
        if let Some(k) = r
            .kept
            .iter()
            .position(|c| c.carrier_frame >= carrier_frames)
        {
            return Err(Error::input(
                p.carrier_csv(),
                format!(
                    "line {}: carrier_frame {} is past the carrier's {carrier_frames} frames ({})",
                    k + 2,
                    r.kept[k].carrier_frame,
                    r.name
                ),
            ));
        }
    }
    for c in carriers {
        if !hashes
            .get(c)
            .is_some_and(|h| prepared.contains_key(h.as_str()))
        {
            progress.warn(&format!(
                "warning: --carrier {}: no session of {} was replayed on it",
                c.display(),
                dataset.display()
            ));
        }
    }

    let videos: Vec<PathBuf> = paths.iter().map(|p| p.mp4.clone()).collect();
    let csvs = eyereplay::extract_cached(&videos, cache, progress)?;
    let mut groups: BTreeMap<(String, String), Frames> = BTreeMap::new();
    let mut sessions = vec![];
    for (((label, paths), read_csv), r) in labels.iter().zip(&paths).zip(&csvs).zip(&ready) {
        let (name, kept, truth) = (&r.name, &r.kept, &r.truth);
        let carrier = &prepared[&r.sha];
        let rc = Columns::read(read_csv)?;
        let (valid, rnx, rny, rscore) = (
            rc.col(read_csv, "valid")?,
            rc.col(read_csv, "nx")?,
            rc.col(read_csv, "ny")?,
            rc.col(read_csv, "face_score")?,
        );
        let mut f = Frames {
            sessions: 1,
            ..Default::default()
        };
        for (k, (c, t)) in kept.iter().zip(truth).enumerate().take(valid.len()) {
            f.score_out.push(rscore[k].unwrap_or(0.0));
            f.score_carrier.push(c.face_score);
            let ok = c.redrawn && valid[k] == Some(1.0);
            if let (true, Some(x), Some(y), Some(own)) = (ok, rnx[k], rny[k], c.carrier_n) {
                f.target.push(t.mean_norm());
                f.read.push([x, y]);
                f.carrier_n.push(own);
            }
        }
        if f.target.len() < MIN_FRAMES {
            progress.warn(&format!(
                "warning: {}: {} of its frames were redrawn and read back open ({} redrawn); its fidelity is n/a",
                paths.mp4.display(),
                f.target.len(),
                kept.iter().filter(|c| c.redrawn).count()
            ));
        }
        let plan: Vec<usize> = kept.iter().map(|c| c.carrier_frame).collect();
        f.psnr_db.push(eyereplay_replay::psnr_outside_eyes(
            carrier, &paths.mp4, &plan, PSNR_EVERY,
        )?);
        let class = label.class.to_string();
        sessions.push((label.file.clone(), check(name, &class, &f)?));
        // Per class, and per carrier over both classes.
        for key in [(name.clone(), class), (name.clone(), "both".to_string())] {
            let g = groups.entry(key).or_default();
            g.target.extend(&f.target);
            g.read.extend(&f.read);
            g.carrier_n.extend(&f.carrier_n);
            g.score_out.extend(&f.score_out);
            g.score_carrier.extend(&f.score_carrier);
            g.psnr_db.extend(&f.psnr_db);
            g.sessions += 1;
        }
    }
    let groups = groups
        .iter()
        .map(|((c, k), f)| check(c, k, f))
        .collect::<Result<Vec<_>>>()?;
    Ok(ReplayEval {
        dataset: dataset.display().to_string(),
        groups,
        sessions,
    })
}

impl std::fmt::Display for ReplayEval {
    fn fmt(&self, out: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let o = |v: Option<f64>| v.map_or("n/a".into(), |v| format!("{v:.3}"));
        writeln!(
            out,
            "{:<26} {:<13} {:>3} {:>6} {:>6} {:>6} {:>6} {:>6} {:>8} {:>8} {:>7} {:>8} {:>7} {:>7}",
            "carrier",
            "class",
            "ses",
            "frames",
            "r x",
            "amp x",
            "r y",
            "amp y",
            "rm r x",
            "rm r y",
            "chance",
            "leak x",
            "d face",
            "PSNR"
        )?;
        for g in &self.groups {
            writeln!(
                out,
                "{:<26} {:<13} {:>3} {:>6} {:>6} {:>6} {:>6} {:>6} {:>8} {:>8} {:>7} {:>8} {:>7.3} {:>7.1}",
                g.carrier,
                g.class,
                g.sessions,
                g.frames,
                o(g.x.r),
                o(g.x.amplitude_ratio),
                o(g.y.r),
                o(g.y.amplitude_ratio),
                o(g.removal_r_x),
                o(g.removal_r_y),
                o(g.chance_r_x),
                o(g.removal_partial_r_x),
                g.face_score_output - g.face_score_carrier,
                g.psnr_outside_eyes_db
            )?;
        }
        write!(
            out,
            "r/amp: read-back n against the trajectory; rm r: against the carrier's own n (removal); \
chance: the trajectory against the carrier's own n (x); leak x: the carrier's own n against \
the read-back's residual from the trajectory; d face: face score output - carrier; \
PSNR (dB) outside the eyes against the carrier"
        )
    }
}
