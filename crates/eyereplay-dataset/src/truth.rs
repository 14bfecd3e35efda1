//! `<stem>_truth.csv`: the renderer's per-frame ground truth. One row per
//! frame; `left` is the image-left eye (the subject's right). Fixed decimals
//! keep the file byte-identical across runs.

use crate::error::read_text;
use crate::DatasetError;
use std::path::Path;

pub const TRUTH_HEADER: &str =
    "frame,x,y,left_yaw_deg,left_pitch_deg,right_yaw_deg,right_pitch_deg,\
left_iris_x_px,left_iris_y_px,right_iris_x_px,right_iris_y_px,left_nx,left_ny,right_nx,right_ny,\
left_aperture,right_aperture,lid_closure,blink";

/// One eye in one frame.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct EyeTruthRow {
    /// Eye rotation; + is image-right.
    pub yaw_deg: f64,
    /// Eye rotation; + is up.
    pub pitch_deg: f64,
    /// Projected limbus centre.
    pub iris_px: [f64; 2],
    /// Iris position normalized between the eye corners and between the
    /// lid midpoints (the paper's eq. 1).
    pub nx: f64,
    pub ny: f64,
    /// Lid gap at the lid midpoint over the corner-to-corner width.
    pub aperture: f64,
}

/// One row of the truth CSV.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TruthRow {
    pub frame: u64,
    /// The input canvas position after clamping.
    pub x_px: f64,
    pub y_px: f64,
    /// Image-left eye, then image-right eye.
    pub eyes: [EyeTruthRow; 2],
    /// 0 open .. 1 closed.
    pub lid_closure: f64,
    /// `lid_closure >= 0.5`.
    pub blink: bool,
}

impl TruthRow {
    /// Mean `(nx, ny)` of both eyes.
    pub fn mean_norm(&self) -> [f64; 2] {
        let [l, r] = &self.eyes;
        [(l.nx + r.nx) / 2.0, (l.ny + r.ny) / 2.0]
    }
}

/// Writes the truth CSV atomically.
pub fn write_truth_csv(path: &Path, rows: &[TruthRow]) -> Result<(), DatasetError> {
    eyereplay_core::atomic_write_with(path, |w| {
        writeln!(w, "{TRUTH_HEADER}")?;
        for t in rows {
            let [l, r] = &t.eyes;
            writeln!(
                w,
                "{},{:.3},{:.3},{:.4},{:.4},{:.4},{:.4},{:.3},{:.3},{:.3},{:.3},{:.5},{:.5},{:.5},{:.5},{:.4},{:.4},{:.3},{}",
                t.frame,
                t.x_px,
                t.y_px,
                l.yaw_deg,
                l.pitch_deg,
                r.yaw_deg,
                r.pitch_deg,
                l.iris_px[0],
                l.iris_px[1],
                r.iris_px[0],
                r.iris_px[1],
                l.nx,
                l.ny,
                r.nx,
                r.ny,
                l.aperture,
                r.aperture,
                t.lid_closure,
                t.blink as u8
            )?;
        }
        Ok(())
    })?;
    Ok(())
}

/// The drawn head's yaw per frame (degrees, relative to the rest pose)
/// from a full-face session's `_head.csv` (`frame,head_yaw_deg,...`, as
/// the face renderer writes it); errors name the file and line.
pub fn read_head_yaw_csv(path: &Path) -> Result<Vec<f64>, DatasetError> {
    let text = read_text(path)?;
    let t = crate::table::Table::parse(&text, path)?;
    let c = t.col("head_yaw_deg", " (a full-face session's _head.csv)")?;
    t.records
        .iter()
        .map(|(line, rec)| t.number(rec, *line, c))
        .collect()
}

/// Reads a truth CSV (columns by name, so added columns do not break it).
/// Whether a truth CSV has the renderer's columns ([`TRUTH_HEADER`]): the
/// close-up, full-face and replay modes write them; the browser mode
/// writes `frame,x,y,page_x,page_y` and whatever columns its page's
/// `truth_js` gives, which may be none of them. `false` for a file that
/// cannot be read (its reader then names why).
pub fn has_renderer_truth(path: &Path) -> bool {
    let Ok(text) = read_text(path) else {
        return false;
    };
    let header: Vec<&str> = text
        .lines()
        .next()
        .unwrap_or("")
        .split(',')
        .map(str::trim)
        .collect();
    TRUTH_HEADER.split(',').all(|c| header.contains(&c))
}

/// Every field of a truth CSV, whatever its columns, is a finite number:
/// the check for a browser page's own columns, which [`read_truth_csv`]
/// does not know. The first bad field is named with its line.
pub fn check_truth_numbers(path: &Path) -> Result<(), DatasetError> {
    let text = read_text(path)?;
    let t = crate::table::Table::parse(&text, path)?;
    for (line, rec) in &t.records {
        for c in 0..t.headers.len() {
            t.number(rec, *line, c)?;
        }
    }
    Ok(())
}

pub fn read_truth_csv(path: &Path) -> Result<Vec<TruthRow>, DatasetError> {
    let text = read_text(path)?;
    let t = crate::table::Table::parse(&text, path)?;
    let names: Vec<&str> = TRUTH_HEADER.split(',').collect();
    let cols: Vec<usize> = names
        .iter()
        .map(|n| t.col(n, ""))
        .collect::<Result<_, _>>()?;
    let mut out = Vec::with_capacity(t.records.len());
    for (line, rec) in &t.records {
        let mut v = [0.0f64; 19];
        for (k, c) in cols.iter().enumerate() {
            v[k] = t.number(rec, *line, *c)?;
        }
        // Column offsets of eye `k` (0 left, 1 right) in TRUTH_HEADER order.
        let eye = |k: usize| EyeTruthRow {
            yaw_deg: v[3 + 2 * k],
            pitch_deg: v[4 + 2 * k],
            iris_px: [v[7 + 2 * k], v[8 + 2 * k]],
            nx: v[11 + 2 * k],
            ny: v[12 + 2 * k],
            aperture: v[15 + k],
        };
        out.push(TruthRow {
            frame: v[0] as u64,
            x_px: v[1],
            y_px: v[2],
            eyes: [eye(0), eye(1)],
            lid_closure: v[17],
            blink: v[18] != 0.0,
        });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn truth_round_trips_at_written_precision() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("s_truth.csv");
        let row = TruthRow {
            frame: 7,
            x_px: 640.25,
            y_px: 360.5,
            eyes: [
                EyeTruthRow {
                    yaw_deg: 1.5,
                    pitch_deg: -2.25,
                    iris_px: [330.125, 400.0],
                    nx: 0.41,
                    ny: 0.52,
                    aperture: 0.3,
                },
                EyeTruthRow {
                    yaw_deg: 1.25,
                    pitch_deg: -2.0,
                    iris_px: [950.0, 401.5],
                    nx: 0.43,
                    ny: 0.5,
                    aperture: 0.31,
                },
            ],
            lid_closure: 0.6,
            blink: true,
        };
        write_truth_csv(&p, &[row]).unwrap();
        let text = std::fs::read_to_string(&p).unwrap();
        assert!(text.starts_with(TRUTH_HEADER));
        assert!(text.contains("\n7,640.250,360.500,1.5000,-2.2500,1.2500,-2.0000,330.125,400.000,950.000,401.500,0.41000,0.52000,0.43000,0.50000,0.3000,0.3100,0.600,1\n"), "{text}");
        let back = read_truth_csv(&p).unwrap();
        assert_eq!(back, vec![row]);
        assert_eq!(back[0].mean_norm(), [0.42, 0.51]);
    }
}
