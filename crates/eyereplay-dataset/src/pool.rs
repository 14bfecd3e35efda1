//! `pool/<class>.csv`: `frame,x,y,source,source_t_s`, the class's
//! concatenated, normalized source pool (evaluation's reference), with the
//! index of the source each frame came from and its time in that source.

use crate::error::read_text;
use crate::table::Table;
use crate::DatasetError;
use eyereplay_core::{atomic_write_with, push_fixed3, push_point_row, push_u64, CanvasPos};
use std::path::Path;

pub const POOL_HEADER: &str = "frame,x,y,source,source_t_s";

/// A continuous stretch of the source pool: one source recording.
#[derive(Clone, Debug, PartialEq)]
pub struct Segment {
    /// Index into metadata's sources.
    pub source: u32,
    pub points: Vec<[f64; 2]>,
}

/// Per-frame source index of a pool (segments flattened).
pub fn frame_sources(pool: &[Segment]) -> Vec<u32> {
    pool.iter()
        .flat_map(|s| std::iter::repeat_n(s.source, s.points.len()))
        .collect()
}

/// Writes a pool CSV atomically.
pub fn write_pool(
    path: &Path,
    points: &[CanvasPos],
    sources: &[u32],
    times_s: &[f64],
) -> Result<(), DatasetError> {
    atomic_write_with(path, |w| {
        w.write_all(POOL_HEADER.as_bytes())?;
        w.write_all(b"\n")?;
        let mut line = Vec::with_capacity(48);
        for (i, ((p, s), t)) in points.iter().zip(sources).zip(times_s).enumerate() {
            line.clear();
            push_point_row(&mut line, i as u64, *p);
            line.push(b',');
            push_u64(&mut line, *s as u64);
            line.push(b',');
            push_fixed3(&mut line, *t);
            line.push(b'\n');
            w.write_all(&line)?;
        }
        Ok(())
    })?;
    Ok(())
}

/// Reads a pool CSV, split into segments where `source` changes.
pub fn read_pool(path: &Path) -> Result<Vec<Segment>, DatasetError> {
    let text = read_text(path)?;
    let t = Table::parse(&text, path)?;
    let expected = format!(" (expected {POOL_HEADER})");
    let (cx, cy, cs) = (
        t.col("x", &expected)?,
        t.col("y", &expected)?,
        t.col("source", &expected)?,
    );
    let mut segs: Vec<Segment> = Vec::new();
    for (line, rec) in &t.records {
        let line = *line;
        let f = |c: usize| t.number(rec, line, c);
        let (x, y) = (f(cx)?, f(cy)?);
        let src = f(cs)?;
        if src.fract() != 0.0 || !(0.0..=u32::MAX as f64).contains(&src) {
            return Err(DatasetError::invalid(
                path,
                format!("line {line}: source must be a non-negative integer index"),
            ));
        }
        let src = src as u32;
        match segs.last_mut() {
            Some(s) if s.source == src => s.points.push([x, y]),
            _ => segs.push(Segment {
                source: src,
                points: vec![[x, y]],
            }),
        }
    }
    if segs.is_empty() {
        return Err(DatasetError::invalid(path, "source pool has no frames"));
    }
    Ok(segs)
}

/// Columns of `pool/<class>_head.csv`: per pool frame (the rows of
/// `pool/<class>.csv`, in order), its source's head pose at that moment
/// relative to the source's median pose: yaw, pitch, roll (deg), x, y, z
/// (cm, camera frame x right, y down, z away); the pose fields are empty
/// where the source has none (an eye tracker, no face found).
pub const POOL_HEAD_HEADER: &str =
    "frame,head_yaw_deg,head_pitch_deg,head_roll_deg,head_x_cm,head_y_cm,head_z_cm";

/// A head pose as `[yaw, pitch, roll, x, y, z]` (deg, cm).
pub type PoseRow = [f64; 6];

/// Writes a pool head CSV atomically, one row per pool frame.
pub fn write_pool_heads(path: &Path, poses: &[Option<PoseRow>]) -> Result<(), DatasetError> {
    atomic_write_with(path, |w| {
        writeln!(w, "{POOL_HEAD_HEADER}")?;
        for (i, p) in poses.iter().enumerate() {
            match p {
                Some(p) => writeln!(
                    w,
                    "{i},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4}",
                    p[0], p[1], p[2], p[3], p[4], p[5]
                )?,
                None => writeln!(w, "{i},,,,,,")?,
            }
        }
        Ok(())
    })?;
    Ok(())
}

/// Reads a pool head CSV: each pool frame's pose, `None` where empty.
pub fn read_pool_heads(path: &Path) -> Result<Vec<Option<PoseRow>>, DatasetError> {
    let text = read_text(path)?;
    let t = Table::parse(&text, path)?;
    let expected = format!(" (expected {POOL_HEAD_HEADER})");
    let cols: Vec<usize> = POOL_HEAD_HEADER
        .split(',')
        .map(|name| t.col(name, &expected))
        .collect::<Result<_, _>>()?;
    let mut out = Vec::with_capacity(t.records.len());
    for (k, (line, rec)) in t.records.iter().enumerate() {
        if t.number(rec, *line, cols[0])? != k as f64 {
            return Err(DatasetError::invalid(
                path,
                format!("line {line}: frame out of order (expected {k})"),
            ));
        }
        let mut v = [None; 6];
        for (x, &c) in v.iter_mut().zip(&cols[1..]) {
            *x = t.optional_number(rec, *line, c)?;
        }
        out.push(match v {
            [Some(a), Some(b), Some(c), Some(d), Some(e), Some(f)] => Some([a, b, c, d, e, f]),
            [None, None, None, None, None, None] => None,
            _ => {
                return Err(DatasetError::invalid(
                    path,
                    format!("line {line}: a pose has all six fields or none"),
                ))
            }
        });
    }
    Ok(out)
}
