//! Per-frame rows, blink flagging and the CSV file.
//!
//! Conventions (see the crate docs): "left"/"right" name the eye on the
//! image's left/right; `nx` runs from the image-left corner (0) to the
//! image-right corner (1) for both eyes, `ny` from the upper lid (0) to the
//! lower lid (1); `nx`, `ny` and `aperture` are the means of the two eyes.

use crate::error::{ExtractError, Result};
use crate::geom::Pt;
use crate::tracker::Face;
use std::io::Write;
use std::path::Path;

/// The CSV header; `frame,time_s,valid,nx,ny,blink` and
/// `aperture_left,aperture_right` are what trajectory readers rely on.
pub const CSV_HEADER: &str = "frame,time_s,valid,nx,ny,blink,face,face_score,aperture,\
nx_left,ny_left,nx_right,ny_right,aperture_left,aperture_right,\
iris_left_x_px,iris_left_y_px,iris_right_x_px,iris_right_y_px,\
left_eye_left_corner_x_px,left_eye_left_corner_y_px,left_eye_right_corner_x_px,left_eye_right_corner_y_px,\
right_eye_left_corner_x_px,right_eye_left_corner_y_px,right_eye_right_corner_x_px,right_eye_right_corner_y_px,\
nx_head";

/// One eye's values for a row.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EyeRow {
    pub nx: f64,
    pub ny: f64,
    pub aperture: f64,
    pub iris: Pt,
    pub corner_left: Pt,
    pub corner_right: Pt,
    /// `nx` against the corners anchored to the head (crate `anchor`);
    /// NaN until [`crate::anchor_to_head`] sets it.
    pub nx_head: f64,
}

/// One decoded frame.
#[derive(Clone, Debug, PartialEq)]
pub struct Row {
    /// 0-based index in presentation order.
    pub frame: u64,
    pub time_s: f64,
    pub face_score: f32,
    /// Image-left and image-right eye; `None` when no face was found.
    pub eyes: Option<[EyeRow; 2]>,
    /// Set by [`flag_blinks`].
    pub blink: bool,
    /// The face mesh's [`crate::HEAD_POINTS`] on frames that ran the mesh;
    /// empty on the others.
    pub head: Vec<Pt>,
}

impl Row {
    pub fn from_face(frame: u64, time_s: f64, face: Option<&Face>) -> Row {
        let eyes = face.map(|f| {
            let e = |k: usize| {
                let m = f.eyes[k].measure();
                EyeRow {
                    nx: m.nx,
                    ny: m.ny,
                    aperture: m.aperture,
                    iris: f.eyes[k].iris,
                    corner_left: f.eyes[k].corner_left,
                    corner_right: f.eyes[k].corner_right,
                    nx_head: f64::NAN,
                }
            };
            [e(0), e(1)]
        });
        Row {
            frame,
            time_s,
            face_score: face.map(|f| f.score).unwrap_or(0.0),
            eyes,
            blink: false,
            head: face.map(Face::head_points).unwrap_or_default(),
        }
    }
    /// A row carrying only a mean aperture and mean (nx, ny), both eyes
    /// equal (used to apply the blink rule to reference data).
    pub fn synthetic(values: Option<(f64, (f64, f64))>) -> Row {
        let eye = |a: f64, n: (f64, f64)| EyeRow {
            nx: n.0,
            ny: n.1,
            aperture: a,
            iris: Pt::default(),
            corner_left: Pt::default(),
            corner_right: Pt::default(),
            nx_head: f64::NAN,
        };
        Row {
            frame: 0,
            time_s: 0.0,
            face_score: 0.0,
            eyes: values.map(|(a, n)| [eye(a, n), eye(a, n)]),
            blink: false,
            head: Vec::new(),
        }
    }
    pub fn face(&self) -> bool {
        self.eyes.is_some()
    }
    /// Mean of the two eyes' (nx, ny).
    pub fn mean_n(&self) -> Option<(f64, f64)> {
        self.eyes
            .map(|e| ((e[0].nx + e[1].nx) / 2.0, (e[0].ny + e[1].ny) / 2.0))
    }
    /// Mean of the two eyes' `nx_head`.
    pub fn mean_nx_head(&self) -> Option<f64> {
        self.eyes.map(|e| (e[0].nx_head + e[1].nx_head) / 2.0)
    }
    pub fn aperture(&self) -> Option<f64> {
        self.eyes.map(|e| (e[0].aperture + e[1].aperture) / 2.0)
    }
    /// Gaze usable: a face, eyes open, finite values, the face upright
    /// enough for them ([`Row::upright`]).
    pub fn valid(&self) -> bool {
        !self.blink
            && self.upright()
            && self
                .mean_n()
                .is_some_and(|(x, y)| x.is_finite() && y.is_finite())
    }

    /// Each eye's corners lie closer to the image's horizontal than to its
    /// vertical. `nx` and `ny` are measured along the image's axes (the
    /// paper's and MediaPipe's definition), so a face turned past 45 deg
    /// in the picture (someone lying down, or a video whose rotation
    /// metadata is wrong) reads its iris far outside the eye: such rows
    /// are not valid. True without a face.
    pub fn upright(&self) -> bool {
        self.eyes.is_none_or(|eyes| {
            eyes.iter().all(|e| {
                let (dx, dy) = (
                    e.corner_right.x - e.corner_left.x,
                    e.corner_right.y - e.corner_left.y,
                );
                dy.abs() <= dx.abs()
            })
        })
    }
}

/// Blink threshold as a fraction of the video's median aperture.
pub const DEFAULT_BLINK_RATIO: f64 = 0.6;

/// Flags blinks from the lid aperture (the iris model still returns iris
/// points with closed eyes, so the gaze values there are meaningless).
///
/// A frame is a blink when its mean aperture (lid gap / eye width) falls
/// below `ratio` x the median aperture of the video's face frames: relative
/// to the person's own open eye, so narrow and wide eyes both work. The
/// frame on each side of a blink is flagged too, as the lids are mid-way
/// there and ny swings far outside [0, 1]. Returns the number of blinks
/// (runs of flagged frames).
pub fn flag_blinks(rows: &mut [Row], ratio: f64) -> usize {
    match blink_threshold(rows, ratio) {
        Some(threshold) => flag_blinks_below(rows, threshold),
        None => 0,
    }
}

/// The aperture below which [`flag_blinks`] calls a frame closed: `ratio`
/// x the median aperture of `rows`' face frames; `None` without any.
pub fn blink_threshold(rows: &[Row], ratio: f64) -> Option<f64> {
    let aps: Vec<f64> = rows
        .iter()
        .filter_map(|r| r.aperture())
        .filter(|a| a.is_finite())
        .collect();
    eyereplay_signal::stats::upper_median(&aps).map(|m| ratio * m)
}

/// [`flag_blinks`] against a given `threshold` (a stream flags its newest
/// frames against the median of all it has seen).
pub fn flag_blinks_below(rows: &mut [Row], threshold: f64) -> usize {
    let closed: Vec<bool> = rows
        .iter()
        .map(|r| r.aperture().is_some_and(|a| a.is_nan() || a < threshold))
        .collect();
    let mut runs = 0;
    for i in 0..rows.len() {
        let near = closed[i]
            || (i > 0 && closed[i - 1] && rows[i].face())
            || (i + 1 < rows.len() && closed[i + 1] && rows[i].face());
        rows[i].blink = near;
        if closed[i] && (i == 0 || !closed[i - 1]) {
            runs += 1;
        }
    }
    runs
}

fn num(v: f64, digits: usize) -> String {
    if v.is_finite() {
        format!("{v:.digits$}")
    } else {
        String::new()
    }
}

/// Writes rows as CSV to `w` (empty fields where there is no face).
pub fn write_csv(w: &mut dyn Write, rows: &[Row]) -> std::io::Result<()> {
    writeln!(w, "{CSV_HEADER}")?;
    for r in rows {
        write!(w, "{},{:.6},{}", r.frame, r.time_s, r.valid() as u8)?;
        match (r.eyes, r.mean_n(), r.aperture()) {
            (Some([l, rt]), Some((nx, ny)), Some(ap)) => {
                write!(
                    w,
                    ",{},{},{},1,{:.4},{}",
                    num(nx, 5),
                    num(ny, 5),
                    r.blink as u8,
                    r.face_score,
                    num(ap, 5)
                )?;
                for v in [l.nx, l.ny, rt.nx, rt.ny, l.aperture, rt.aperture] {
                    write!(w, ",{}", num(v, 5))?;
                }
                for p in [
                    l.iris,
                    rt.iris,
                    l.corner_left,
                    l.corner_right,
                    rt.corner_left,
                    rt.corner_right,
                ] {
                    write!(w, ",{:.2},{:.2}", p.x, p.y)?;
                }
                writeln!(w, ",{}", num(r.mean_nx_head().unwrap_or(f64::NAN), 5))?;
            }
            _ => {
                // No face: gaze fields empty, blink 0, face 0.
                writeln!(w, ",,,0,0,0{}", ",".repeat(20))?;
            }
        }
    }
    Ok(())
}

/// Where the extraction CSVs of `videos` go for an output `out`: `out`
/// itself when it names a `.csv` file (one video only), else `<out>/<video
/// stem>.csv` each. The error ([`ExtractError::Output`]) is the one line
/// the command line and the Python package print.
pub fn output_csv_paths(
    out: &Path,
    videos: &[std::path::PathBuf],
) -> Result<Vec<std::path::PathBuf>> {
    let single_file = out
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("csv"));
    if single_file && videos.len() > 1 {
        return Err(ExtractError::Output(format!(
            "the output {} is one file but {} videos were given; pass a folder",
            out.display(),
            videos.len()
        )));
    }
    if !single_file && out.exists() && !out.is_dir() {
        return Err(ExtractError::Output(format!(
            "{}: the output is a file that is not a .csv; give a .csv file (one video) or a folder",
            out.display()
        )));
    }
    // `--out rows.txt` (or .json, .tsv) would become a folder holding
    // `<stem>.csv`: almost surely meant as a file. A folder whose name
    // has a dot in it can be made first and then given.
    if !single_file && !out.exists() {
        if let Some(ext) = out.extension() {
            return Err(ExtractError::Output(format!(
                "{}: the output names a .{} file; extraction writes CSV: give a .csv file (one video) or a folder (an existing one, or a name without an extension)",
                out.display(),
                ext.to_string_lossy()
            )));
        }
    }
    if single_file && out.is_dir() {
        return Err(ExtractError::Output(format!(
            "{}: the output is a folder named .csv; give a file name or another folder",
            out.display()
        )));
    }
    let paths: Vec<std::path::PathBuf> = videos
        .iter()
        .map(|video| {
            if single_file {
                return out.to_path_buf();
            }
            let stem = video
                .file_stem()
                .map(|s| s.to_string_lossy().to_string())
                .unwrap_or_else(|| "video".into());
            out.join(format!("{stem}.csv"))
        })
        .collect();
    // `a/clip.mp4 b/clip.mov` (or one video given twice) would be written
    // to one CSV, the second over the first.
    for (j, p) in paths.iter().enumerate() {
        if let Some(i) = paths[..j].iter().position(|q| q == p) {
            return Err(ExtractError::Output(format!(
                "{} and {} would both be written to {}; extract them into separate folders (or give each video once)",
                videos[i].display(),
                videos[j].display(),
                p.display()
            )));
        }
    }
    Ok(paths)
}

/// Writes the CSV atomically: readers see the old file or the whole new one,
/// never a partial one.
pub fn save_csv(path: &Path, rows: &[Row]) -> Result<()> {
    eyereplay_core::atomic_write_with(path, |w| write_csv(w, rows))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(frame: u64, ap: Option<f64>) -> Row {
        let e = |a: f64| EyeRow {
            nx: 0.5,
            ny: 0.5,
            aperture: a,
            iris: Pt::default(),
            corner_left: Pt::default(),
            corner_right: Pt::default(),
            nx_head: f64::NAN,
        };
        Row {
            frame,
            time_s: frame as f64 / 25.0,
            face_score: 0.9,
            eyes: ap.map(|a| [e(a), e(a)]),
            blink: false,
            head: Vec::new(),
        }
    }

    #[test]
    fn a_face_turned_past_45_degrees_in_the_picture_is_not_valid() {
        // Corners 20 px apart: at 30 deg of roll the eye still lies along
        // the image's x axis more than its y; at 60 deg, and sideways, the
        // iris would read outside the eye.
        let at = |deg: f64| {
            let mut r = row(0, Some(0.3));
            let (c, s) = (deg.to_radians().cos() as f32, deg.to_radians().sin() as f32);
            for e in r.eyes.as_mut().unwrap() {
                e.corner_left = Pt { x: 100.0, y: 100.0 };
                e.corner_right = Pt {
                    x: 100.0 + 20.0 * c,
                    y: 100.0 + 20.0 * s,
                };
            }
            r
        };
        for deg in [0.0, 30.0, -30.0, 44.0] {
            assert!(at(deg).upright() && at(deg).valid(), "{deg}");
        }
        for deg in [60.0, 90.0, -90.0] {
            assert!(!at(deg).upright() && !at(deg).valid(), "{deg}");
        }
        // No face: nothing to turn (and not valid for want of a face).
        assert!(row(0, None).upright() && !row(0, None).valid());
    }

    #[test]
    fn two_videos_of_one_name_are_refused_before_either_is_read() {
        let v = |p: &str| std::path::PathBuf::from(p);
        let e = output_csv_paths(Path::new("x"), &[v("a/clip.mp4"), v("b/clip.mov")])
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("a/clip.mp4 and b/clip.mov would both be written to x/clip.csv"),
            "{e}"
        );
        let same = output_csv_paths(Path::new("x"), &[v("a.mp4"), v("b.mp4"), v("a.mp4")]);
        assert!(same.is_err());
        let ok = output_csv_paths(Path::new("x"), &[v("a/one.mp4"), v("a/two.mp4")]).unwrap();
        assert_eq!(ok, [v("x/one.csv"), v("x/two.csv")]);
    }

    #[test]
    fn an_output_named_as_another_kind_of_file_is_refused() {
        let v = |p: &str| std::path::PathBuf::from(p);
        let d = tempfile::tempdir().unwrap();
        let txt = d.path().join("x/out.txt");
        let e = output_csv_paths(&txt, &[v("a.mp4")])
            .unwrap_err()
            .to_string();
        assert!(e.contains("out.txt: the output names a .txt file"), "{e}");
        assert!(!d.path().join("x").exists(), "nothing made");
        // A folder with a dot in its name is taken once it exists.
        let dotted = d.path().join("run.v2");
        std::fs::create_dir(&dotted).unwrap();
        let ok = output_csv_paths(&dotted, &[v("a.mp4")]).unwrap();
        assert_eq!(ok, [dotted.join("a.csv")]);
        let plain = d.path().join("rows");
        assert_eq!(
            output_csv_paths(&plain, &[v("a.mp4")]).unwrap(),
            [plain.join("a.csv")]
        );
    }

    #[test]
    fn blink_is_a_dip_below_the_median_and_its_neighbours() {
        let aps = [0.3, 0.31, 0.29, 0.3, 0.25, 0.05, 0.04, 0.2, 0.3, 0.3, 0.3];
        let mut rows: Vec<Row> = aps
            .iter()
            .enumerate()
            .map(|(i, &a)| row(i as u64, Some(a)))
            .collect();
        // median 0.3 -> threshold 0.18: frames 5, 6 closed; 4 and 7 next to them.
        assert_eq!(flag_blinks(&mut rows, 0.6), 1);
        let flagged: Vec<u64> = rows.iter().filter(|r| r.blink).map(|r| r.frame).collect();
        assert_eq!(flagged, vec![4, 5, 6, 7]);
        assert!(!rows[5].valid() && rows[3].valid());
    }

    #[test]
    fn csv_rows_have_as_many_fields_as_the_header() {
        let mut rows = vec![row(0, Some(0.3)), row(1, None)];
        flag_blinks(&mut rows, 0.6);
        let mut buf = vec![];
        write_csv(&mut buf, &rows).unwrap();
        let text = String::from_utf8(buf).unwrap();
        let n = CSV_HEADER.split(',').count();
        for line in text.lines() {
            assert_eq!(line.split(',').count(), n, "{line}");
        }
        assert!(text
            .lines()
            .nth(2)
            .unwrap()
            .starts_with("1,0.040000,0,,,0,0,"));
        assert!(CSV_HEADER.starts_with("frame,time_s,valid,nx,ny,blink,"));
    }
}
