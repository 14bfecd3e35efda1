//! Reading a dataset folder written by `eyereplay prepare`:
//! `labels.csv`, `metadata.json`, the session CSVs, and the per-class source
//! pool `pool/<class>.csv`.

use crate::EvalError;
use eyereplay_core::{read_session_csv, Canvas, GazeClass};
use std::path::{Path, PathBuf};

/// A continuous stretch of the source pool: one source recording.
#[derive(Clone, Debug, PartialEq)]
pub struct Segment {
    /// Index into metadata's sources.
    pub source: i64,
    pub points: Vec<[f64; 2]>,
}

/// One generated session.
#[derive(Clone, Debug, PartialEq)]
pub struct Session {
    /// Path relative to the dataset folder, as in labels.csv.
    pub file: String,
    pub points: Vec<[f64; 2]>,
    /// The optional `blink` column (1 where the source blinked).
    pub blinks: Option<Vec<bool>>,
}

#[derive(Clone, Debug, PartialEq)]
pub struct ClassData {
    pub class: GazeClass,
    pub sessions: Vec<Session>,
    /// The concatenated source pool, split where the source changes.
    pub pool: Vec<Segment>,
    /// How the class's sources were recorded (`metadata.json`
    /// `sources[].kind`: video, eye_tracker, fixation_report) and how many
    /// sources of each kind; empty when the metadata does not say.
    pub source_kinds: std::collections::BTreeMap<String, usize>,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Dataset {
    pub dir: PathBuf,
    pub fps: f64,
    pub canvas: Canvas,
    pub session_frames: usize,
    /// In [`GazeClass::ALL`] order.
    pub classes: Vec<ClassData>,
}

fn read_text(path: &Path) -> Result<String, EvalError> {
    std::fs::read_to_string(path).map_err(|e| {
        if e.kind() == std::io::ErrorKind::NotFound {
            EvalError::dataset(
                path,
                "not found (is this a dataset folder written by 'eyereplay prepare'?)",
            )
        } else {
            EvalError::io(path, e)
        }
    })
}

fn num(meta: &serde_json::Value, key: &str, path: &Path) -> Result<f64, EvalError> {
    let mut cur = meta;
    for k in key.split('.') {
        cur = cur
            .get(k)
            .ok_or_else(|| EvalError::dataset(path, format!("missing key '{key}'")))?;
    }
    cur.as_f64()
        .filter(|v| v.is_finite() && *v > 0.0)
        .ok_or_else(|| EvalError::dataset(path, format!("'{key}' must be a positive number")))
}

/// `<dir>/metadata.json`, parsed, with its path for error messages.
fn read_meta_json(dir: &Path) -> Result<(std::path::PathBuf, serde_json::Value), EvalError> {
    let path = dir.join("metadata.json");
    let meta = serde_json::from_str(&read_text(&path)?)
        .map_err(|e| EvalError::dataset(&path, format!("not valid JSON: {e}")))?;
    Ok((path, meta))
}

/// The parts of metadata.json evaluation needs.
pub fn read_metadata(dir: &Path) -> Result<(f64, Canvas, usize), EvalError> {
    let (path, meta) = read_meta_json(dir)?;
    metadata_fields(&meta, &path)
}

fn metadata_fields(
    meta: &serde_json::Value,
    path: &Path,
) -> Result<(f64, Canvas, usize), EvalError> {
    let fps = num(meta, "fps", path)?;
    let w = num(meta, "canvas.width_px", path)?;
    let h = num(meta, "canvas.height_px", path)?;
    let frames = num(meta, "session_frames", path)?;
    Ok((
        fps,
        Canvas {
            width_px: w as u32,
            height_px: h as u32,
        },
        frames as usize,
    ))
}

/// The `sources` array of `metadata.json` (empty when absent).
fn meta_sources(meta: &serde_json::Value) -> impl Iterator<Item = &serde_json::Value> {
    meta.get("sources")
        .and_then(|v| v.as_array())
        .into_iter()
        .flatten()
}

/// Counts of the class's sources by recording kind, from `metadata.json`.
fn source_kinds(
    meta: &serde_json::Value,
    class: GazeClass,
) -> std::collections::BTreeMap<String, usize> {
    let mut out = std::collections::BTreeMap::new();
    for s in meta_sources(meta) {
        if s.get("class").and_then(|c| c.as_str()) == Some(class.name()) {
            if let Some(kind) = s.get("kind").and_then(|k| k.as_str()) {
                *out.entry(kind.to_string()).or_insert(0) += 1;
            }
        }
    }
    out
}

/// `(file, class)` rows of labels.csv, checked for a consistent label.
pub fn read_labels(dir: &Path) -> Result<Vec<(String, GazeClass)>, EvalError> {
    let path = dir.join("labels.csv");
    let text = read_text(&path)?;
    let mut rdr = csv::ReaderBuilder::new().from_reader(text.as_bytes());
    let headers = rdr
        .headers()
        .map_err(|e| EvalError::dataset(&path, e.to_string()))?
        .clone();
    let col = |name: &str| -> Result<usize, EvalError> {
        headers
            .iter()
            .position(|h| h.trim() == name)
            .ok_or_else(|| {
                EvalError::dataset(
                    &path,
                    format!(
                        "missing column '{name}' (expected file,label,class,sources; found {})",
                        headers.iter().collect::<Vec<_>>().join(",")
                    ),
                )
            })
    };
    let (cf, cl, cc) = (col("file")?, col("label")?, col("class")?);
    let mut out = Vec::new();
    for (i, rec) in rdr.records().enumerate() {
        let line = i + 2;
        let rec = rec.map_err(|e| EvalError::dataset(&path, format!("line {line}: {e}")))?;
        let field = |c: usize| rec.get(c).unwrap_or("").trim().to_string();
        let class: GazeClass = field(cc)
            .parse()
            .map_err(|e: String| EvalError::dataset(&path, format!("line {line}: {e}")))?;
        let label = field(cl);
        if label != class.label().to_string() {
            return Err(EvalError::dataset(
                &path,
                format!(
                    "line {line}: label '{label}' does not match class '{class}' (expected {})",
                    class.label()
                ),
            ));
        }
        out.push((field(cf), class));
    }
    Ok(out)
}

/// A CSV file's header and records with their line numbers, and the column
/// and number look-ups that name the file and line when they fail.
struct Table<'a> {
    path: &'a Path,
    headers: csv::StringRecord,
    records: Vec<(usize, csv::StringRecord)>,
}

impl<'a> Table<'a> {
    fn read(path: &'a Path) -> Result<Self, EvalError> {
        let text = read_text(path)?;
        let mut rdr = csv::ReaderBuilder::new().from_reader(text.as_bytes());
        let headers = rdr
            .headers()
            .map_err(|e| EvalError::dataset(path, e.to_string()))?
            .clone();
        let mut records = Vec::new();
        for (i, rec) in rdr.records().enumerate() {
            let line = i + 2;
            records.push((
                line,
                rec.map_err(|e| EvalError::dataset(path, format!("line {line}: {e}")))?,
            ));
        }
        Ok(Table {
            path,
            headers,
            records,
        })
    }

    fn col(&self, name: &str, expected: &str) -> Result<usize, EvalError> {
        self.headers
            .iter()
            .position(|h| h.trim() == name)
            .ok_or_else(|| {
                EvalError::dataset(self.path, format!("missing column '{name}'{expected}"))
            })
    }

    fn number(&self, rec: &csv::StringRecord, line: usize, c: usize) -> Result<f64, EvalError> {
        rec.get(c)
            .and_then(|s| s.trim().parse::<f64>().ok())
            .filter(|v| v.is_finite())
            .ok_or_else(|| {
                EvalError::dataset(
                    self.path,
                    format!("line {line}: column {} is not a finite number", c + 1),
                )
            })
    }
}

/// Reads `pool/<class>.csv` (`frame,x,y,source`), split into segments where
/// `source` changes.
pub fn read_pool(path: &Path) -> Result<Vec<Segment>, EvalError> {
    let t = Table::read(path)?;
    let expected = " (expected frame,x,y,source)";
    let (cx, cy, cs) = (
        t.col("x", expected)?,
        t.col("y", expected)?,
        t.col("source", expected)?,
    );
    let mut segs: Vec<Segment> = Vec::new();
    for (line, rec) in &t.records {
        let line = *line;
        let f = |c: usize| t.number(rec, line, c);
        let (x, y) = (f(cx)?, f(cy)?);
        let src = f(cs)?;
        if src.fract() != 0.0 {
            return Err(EvalError::dataset(
                path,
                format!("line {line}: source must be an integer index"),
            ));
        }
        let src = src as i64;
        match segs.last_mut() {
            Some(s) if s.source == src => s.points.push([x, y]),
            _ => segs.push(Segment {
                source: src,
                points: vec![[x, y]],
            }),
        }
    }
    if segs.is_empty() {
        return Err(EvalError::dataset(path, "source pool has no frames"));
    }
    Ok(segs)
}

/// Loads and checks a whole dataset folder.
pub fn load_dataset(dir: &Path) -> Result<Dataset, EvalError> {
    if !dir.is_dir() {
        return Err(EvalError::dataset(dir, "not a folder"));
    }
    let labels = read_labels(dir)?;
    let (meta_path, meta) = read_meta_json(dir)?;
    let (fps, canvas, session_frames) = metadata_fields(&meta, &meta_path)?;
    let mut classes = Vec::new();
    for class in GazeClass::ALL {
        let files: Vec<&String> = labels
            .iter()
            .filter(|(_, c)| *c == class)
            .map(|(f, _)| f)
            .collect();
        if files.is_empty() {
            return Err(EvalError::dataset(
                dir.join("labels.csv"),
                format!("class '{class}' has no sessions (empty class)"),
            ));
        }
        let mut sessions = Vec::with_capacity(files.len());
        for f in files {
            let path = dir.join(f);
            let pts = read_session_csv(&path)?;
            if pts.len() != session_frames {
                return Err(EvalError::dataset(
                    &path,
                    format!(
                        "{} frames, but metadata.json says session_frames = {session_frames}",
                        pts.len()
                    ),
                ));
            }
            sessions.push(Session {
                file: f.clone(),
                points: pts.iter().map(|p| [p.x_px, p.y_px]).collect(),
                blinks: read_blink_column(&path)?,
            });
        }
        let pool = read_pool(&dir.join("pool").join(format!("{}.csv", class.name())))?;
        classes.push(ClassData {
            class,
            sessions,
            pool,
            source_kinds: source_kinds(&meta, class),
        });
    }
    Ok(Dataset {
        dir: dir.to_path_buf(),
        fps,
        canvas,
        session_frames,
        classes,
    })
}

/// The linear calibration of metadata.json (paper eq. `c = s (n - 0.5) + mu`).
pub use eyereplay_core::Calibration;

/// `calibration.{s_x,s_y,mu_x,mu_y}` of `<dir>/metadata.json`.
pub fn read_calibration(dir: &Path) -> Result<Calibration, EvalError> {
    let path = dir.join("metadata.json");
    let meta: serde_json::Value = serde_json::from_str(&read_text(&path)?)
        .map_err(|e| EvalError::dataset(&path, format!("not valid JSON: {e}")))?;
    let get = |k: &str| -> Result<f64, EvalError> {
        meta.get("calibration")
            .and_then(|c| c.get(k))
            .and_then(|v| v.as_f64())
            .filter(|v| v.is_finite())
            .ok_or_else(|| EvalError::dataset(&path, format!("missing number 'calibration.{k}'")))
    };
    let c = Calibration {
        s_x: get("s_x")?,
        s_y: get("s_y")?,
        mu_x: get("mu_x")?,
        mu_y: get("mu_y")?,
    };
    if c.s_x == 0.0 || c.s_y == 0.0 {
        return Err(EvalError::dataset(
            &path,
            "calibration scale s_x or s_y is 0",
        ));
    }
    Ok(c)
}

/// The rendered video of a session CSV: `<class>/<stem>.mp4` beside it.
pub fn rendered_video_path(dir: &Path, session_rel: &str) -> PathBuf {
    dir.join(session_rel).with_extension("mp4")
}

/// The renderer's per-frame ground truth beside a session:
/// `<class>/<stem>_truth.csv`.
pub fn truth_csv_path(dir: &Path, session_rel: &str) -> PathBuf {
    let p = dir.join(session_rel);
    let stem = p
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    p.with_file_name(format!("{stem}_truth.csv"))
}

/// Mean of both eyes' `(nx, ny)` per frame from a renderer truth CSV
/// (columns `left_nx,left_ny,right_nx,right_ny`).
pub fn read_truth_norm(path: &Path) -> Result<Vec<[f64; 2]>, EvalError> {
    let t = Table::read(path)?;
    let cols = [
        t.col("left_nx", "")?,
        t.col("left_ny", "")?,
        t.col("right_nx", "")?,
        t.col("right_ny", "")?,
    ];
    let mut out = Vec::with_capacity(t.records.len());
    for (line, rec) in &t.records {
        let mut v = [0.0; 4];
        for (k, c) in cols.iter().enumerate() {
            v[k] = t.number(rec, *line, *c)?;
        }
        out.push([(v[0] + v[2]) / 2.0, (v[1] + v[3]) / 2.0]);
    }
    Ok(out)
}

/// The calibration(s) that turned normalized iris positions into a
/// session's canvas positions, frame by frame: the pooled calibration of
/// metadata.json when there is one; else each frame's source calibration
/// (`sources[k].calibration`), the frame's source found through the
/// session's `pool_start` in `metadata.sessions` and the pool's `source`
/// column (circular slicing: frame j is pool frame `(pool_start + j) mod T`).
pub fn session_calibrations(
    dir: &Path,
    session_rel: &str,
    frames: usize,
) -> Result<Vec<Calibration>, EvalError> {
    if let Ok(c) = read_calibration(dir) {
        return Ok(vec![c; frames]);
    }
    let path = dir.join("metadata.json");
    let meta: serde_json::Value = serde_json::from_str(&read_text(&path)?)
        .map_err(|e| EvalError::dataset(&path, format!("not valid JSON: {e}")))?;
    let bad = |m: String| EvalError::dataset(&path, m);
    let cal_of = |v: &serde_json::Value| -> Option<Calibration> {
        let g = |k: &str| v.get(k).and_then(|x| x.as_f64()).filter(|x| x.is_finite());
        let c = Calibration {
            s_x: g("s_x")?,
            s_y: g("s_y")?,
            mu_x: g("mu_x")?,
            mu_y: g("mu_y")?,
        };
        (c.s_x != 0.0 && c.s_y != 0.0).then_some(c)
    };
    let mut by_index = std::collections::BTreeMap::new();
    for s in meta_sources(&meta) {
        if let (Some(i), Some(c)) = (
            s.get("index").and_then(|v| v.as_i64()),
            s.get("calibration").and_then(cal_of),
        ) {
            by_index.insert(i, c);
        }
    }
    let entry = meta
        .get("sessions")
        .and_then(|v| v.as_array())
        .and_then(|a| a.iter().find(|s| s.get("file").and_then(|f| f.as_str()) == Some(session_rel)))
        .ok_or_else(|| {
            bad(format!(
                "no pooled calibration, and no entry for '{session_rel}' in 'sessions' to find its per-source calibrations"
            ))
        })?;
    let start = entry
        .get("pool_start")
        .and_then(|v| v.as_u64())
        .ok_or_else(|| {
            bad(format!(
                "sessions entry of '{session_rel}' has no pool_start"
            ))
        })? as usize;
    let class = entry
        .get("class")
        .and_then(|v| v.as_str())
        .ok_or_else(|| bad(format!("sessions entry of '{session_rel}' has no class")))?;
    let pool_path = dir.join("pool").join(format!("{class}.csv"));
    let pool = read_pool(&pool_path)?;
    let sources: Vec<i64> = pool
        .iter()
        .flat_map(|s| std::iter::repeat_n(s.source, s.points.len()))
        .collect();
    let t = sources.len();
    (0..frames)
        .map(|j| {
            let src = sources[(start + j) % t];
            by_index
                .get(&src)
                .copied()
                .ok_or_else(|| bad(format!("no calibration for source {src}")))
        })
        .collect()
}

/// The optional `blink` column of a session CSV (`frame,x,y,blink`); `None`
/// when the file has no such column.
pub fn read_blink_column(path: &Path) -> Result<Option<Vec<bool>>, EvalError> {
    let text = read_text(path)?;
    let mut rdr = csv::ReaderBuilder::new().from_reader(text.as_bytes());
    let headers = rdr
        .headers()
        .map_err(|e| EvalError::dataset(path, e.to_string()))?
        .clone();
    let Some(col) = headers.iter().position(|h| h.trim() == "blink") else {
        return Ok(None);
    };
    let mut out = Vec::new();
    for (i, rec) in rdr.records().enumerate() {
        let line = i + 2;
        let rec = rec.map_err(|e| EvalError::dataset(path, format!("line {line}: {e}")))?;
        out.push(match rec.get(col).map(str::trim) {
            Some("1") | Some("true") => true,
            Some("0") | Some("false") | Some("") => false,
            other => {
                return Err(EvalError::dataset(
                    path,
                    format!(
                        "line {line}: blink must be 0 or 1, found {:?}",
                        other.unwrap_or("")
                    ),
                ))
            }
        });
    }
    Ok(Some(out))
}
