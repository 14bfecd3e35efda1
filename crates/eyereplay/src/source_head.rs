//! `render.head_motion = "source"`: the full-face mode's head driven by the
//! source videos' own head motion instead of the eye-head coordination
//! model.
//!
//! Each video source's head pose is solved once per frame from the
//! landmarks our extractor finds (the canonical face shape, a laptop
//! webcam's field of view: [`eyereplay_face::SOURCE_VFOV_DEG`]), cached by
//! the video's sha256, taken relative to its median pose and smoothed
//! ([`SourceHeadTrack`]). While the dataset is written, every pool frame
//! gets the pose of its source at its time in that source
//! (`pool/<class>_head.csv`, empty where the source is not a video or no
//! face was found there); a session's frames are pool frames
//! `(pool_start + j) mod T`, so the renderer finds each frame's head there.

use crate::progress::{ExtractFrames, Progress, Stage};
use crate::{Error, Result};
use eyereplay_core::GazeClass;
use eyereplay_dataset::DatasetMetadata;
use eyereplay_face::{
    default_faces_dir, video_head_poses, CanonicalMesh, HeadPose, SourceHeadTrack, MESH_FILE,
    SOURCE_HEAD_SMOOTHING_S, SOURCE_VFOV_DEG,
};
use eyereplay_prepare::{DatasetConfig, Prepared};
use eyereplay_sources::RecordingKind;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Columns of `pool/<class>_head.csv`: per pool frame, its source and time
/// in it, and that source video's head pose there relative to its median
/// pose (deg; cm, camera frame x right, y down, z away); the pose fields
/// are empty where there is none.
pub const HEAD_POOL_HEADER: &str = "frame,source,source_t_s,head_yaw_deg,head_pitch_deg,\
head_roll_deg,head_x_cm,head_y_cm,head_z_cm";

/// Version of the cached per-frame poses: bump when the solve changes.
const HEAD_CACHE_VERSION: u32 = 1;

/// `pool/<class>_head.csv`, relative to the dataset folder.
pub fn head_pool_file(class: GazeClass) -> String {
    format!("pool/{}_head.csv", class.name())
}

/// Where a video's per-frame head poses are cached.
fn cache_file(cache: &Path, sha256: &str) -> PathBuf {
    cache.join("head").join(format!(
        "{sha256}-v{HEAD_CACHE_VERSION}-vfov{SOURCE_VFOV_DEG}.json"
    ))
}

/// A video's raw per-frame head poses, from the cache or solved now (and
/// cached). Both paths return what the cache file holds, so a first run and
/// a rerun give identical values.
fn video_poses(
    video: &Path,
    sha256: &str,
    cache: &Path,
    mesh: &CanonicalMesh,
    progress: &dyn Progress,
) -> Result<Vec<(f64, Option<HeadPose>)>> {
    let file = cache_file(cache, sha256);
    let dir = cache.join("head");
    if let Ok(text) = std::fs::read_to_string(&file) {
        if let Ok(poses) = serde_json::from_str(&text) {
            return Ok(poses);
        }
    }
    progress.info(&format!(
        "head pose of {}: solving every frame's landmarks (once; cached)",
        video.display()
    ));
    let poses = video_head_poses(
        video,
        &eyereplay_extract::default_models_dir(),
        mesh,
        &mesh.positions_cm,
        SOURCE_VFOV_DEG,
        &ExtractFrames(progress),
    )?;
    let text = serde_json::to_string(&poses).map_err(|e| Error::input(&file, e.to_string()))?;
    std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
    eyereplay_core::atomic_write_with(&file, |w| w.write_all(text.as_bytes()))?;
    serde_json::from_str(&text).map_err(|e| Error::input(&file, e.to_string()))
}

/// Every video source's head track, by source index (sources whose video
/// shows no face at all are left out, so their frames use the model).
fn source_tracks(
    config: &DatasetConfig,
    prepared: &Prepared,
    cache: &Path,
    progress: &dyn Progress,
) -> Result<BTreeMap<u32, SourceHeadTrack>> {
    let videos: Vec<_> = prepared
        .sources
        .iter()
        // A video file, not an `extract` CSV (also of kind video): its
        // frames are needed.
        .filter(|s| s.kind == RecordingKind::Video && s.format == "video")
        .collect();
    let mut tracks = BTreeMap::new();
    if videos.is_empty() {
        return Ok(tracks);
    }
    let mesh_path = default_faces_dir().join(MESH_FILE);
    let mesh = CanonicalMesh::load(&mesh_path)?;
    // A progress bar only when some video is not cached yet.
    let solving = videos
        .iter()
        .any(|s| !cache_file(cache, &s.sha256).is_file());
    if solving {
        progress.begin(Stage::Extract, 0);
    }
    // One pose track per video file, shared by its recordings (a video's
    // recordings differ only by eye or segment).
    let mut by_sha: BTreeMap<&str, Option<SourceHeadTrack>> = BTreeMap::new();
    for s in videos {
        if !by_sha.contains_key(s.sha256.as_str()) {
            let path: PathBuf = config.resolve(Path::new(&s.file));
            let poses = video_poses(&path, &s.sha256, cache, &mesh, progress)?;
            let track = SourceHeadTrack::from_poses(&poses, SOURCE_HEAD_SMOOTHING_S);
            if track.is_none() {
                progress.warn(&format!(
                    "warning: {}: no face found for a head pose; its frames use the head model",
                    s.file
                ));
            }
            by_sha.insert(s.sha256.as_str(), track);
        }
        if let Some(Some(t)) = by_sha.get(s.sha256.as_str()) {
            tracks.insert(s.index as u32, t.clone());
        }
    }
    if solving {
        progress.end(Stage::Extract);
    }
    Ok(tracks)
}

/// Writes `pool/<class>_head.csv` for every class of `prepared` into `out`
/// (atomically): each pool frame's source head pose, solved (cached) from
/// the config's video sources. Deterministic: the same inputs give the
/// same bytes.
pub fn write_source_heads(
    out: &Path,
    config: &DatasetConfig,
    prepared: &Prepared,
    cache: &Path,
    progress: &dyn Progress,
) -> Result<()> {
    let tracks = source_tracks(config, prepared, cache, progress)?;
    for c in &prepared.classes {
        let path = out.join(head_pool_file(c.class));
        eyereplay_core::atomic_write_with(&path, |w| {
            writeln!(w, "{HEAD_POOL_HEADER}")?;
            for (i, (&src, &t)) in c.pool_source.iter().zip(&c.pool_time_s).enumerate() {
                write!(w, "{i},{src},{t:.3}")?;
                match tracks.get(&src).and_then(|tr| tr.at(t)) {
                    Some(p) => writeln!(
                        w,
                        ",{:.4},{:.4},{:.4},{:.4},{:.4},{:.4}",
                        p.yaw_deg,
                        p.pitch_deg,
                        p.roll_deg,
                        p.translation_cm[0],
                        p.translation_cm[1],
                        p.translation_cm[2]
                    )?,
                    None => writeln!(w, ",,,,,,")?,
                }
            }
            Ok(())
        })?;
    }
    Ok(())
}

/// Reads `pool/<class>_head.csv` of the dataset in `out`: the source head
/// pose of each pool frame (`None` where empty).
pub fn read_source_heads(out: &Path, class: GazeClass) -> Result<Vec<Option<HeadPose>>> {
    let path = out.join(head_pool_file(class));
    let text = std::fs::read_to_string(&path).map_err(|e| {
        Error::input(
            &path,
            format!(
                "{e} (render.head_motion = \"source\" needs it: written by `eyereplay generate`)"
            ),
        )
    })?;
    let mut lines = text.lines();
    if lines.next() != Some(HEAD_POOL_HEADER) {
        return Err(Error::input(
            &path,
            format!("line 1: expected header {HEAD_POOL_HEADER}"),
        ));
    }
    let mut out = vec![];
    for (k, line) in lines.enumerate() {
        let bad = |m: &str| Error::input(&path, format!("line {}: {m}", k + 2));
        let f: Vec<&str> = line.split(',').collect();
        if f.len() != 9 {
            return Err(bad(&format!("expected 9 fields, found {}", f.len())));
        }
        if f[0].parse::<usize>() != Ok(k) {
            return Err(bad(&format!("frame {} out of order (expected {k})", f[0])));
        }
        if f[3..].iter().all(|x| x.is_empty()) {
            out.push(None);
            continue;
        }
        let mut v = [0.0f64; 6];
        for (x, s) in v.iter_mut().zip(&f[3..]) {
            *x = s
                .parse::<f64>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or_else(|| bad(&format!("'{s}' is not a number")))?;
        }
        out.push(Some(HeadPose {
            yaw_deg: v[0],
            pitch_deg: v[1],
            roll_deg: v[2],
            translation_cm: [v[3], v[4], v[5]],
        }));
    }
    Ok(out)
}

/// The source head pose of each frame of the session `file` of `meta`:
/// pool frame `(pool_start + j) mod T` of its class (`pools`: each class's
/// poses read by [`read_source_heads`]).
pub fn session_heads(
    meta: &DatasetMetadata,
    file: &str,
    pools: &BTreeMap<GazeClass, Vec<Option<HeadPose>>>,
) -> Result<Vec<Option<HeadPose>>> {
    let entry = meta
        .sessions
        .iter()
        .find(|s| s.file == file)
        .ok_or_else(|| Error::input(file, "not listed in metadata.json's sessions"))?;
    let heads = pools.get(&entry.class).map_or(&[][..], |h| &h[..]);
    let expected = meta
        .classes
        .iter()
        .find(|c| c.class == entry.class)
        .map_or(0, |c| c.pool_frames);
    if heads.is_empty() || heads.len() != expected {
        return Err(Error::input(
            head_pool_file(entry.class),
            format!(
                "{} frames where the pool has {expected}: written for another dataset (rerun `eyereplay generate`)",
                heads.len()
            ),
        ));
    }
    Ok((0..meta.session_frames)
        .map(|j| heads[(entry.pool_start + j) % heads.len()])
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn head_pool_reads_back_with_empty_rows_and_clear_errors() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        std::fs::create_dir_all(d.join("pool")).unwrap();
        let path = d.join(head_pool_file(GazeClass::Conversation));
        std::fs::write(
            &path,
            format!("{HEAD_POOL_HEADER}\n0,3,1.000,2.5000,-1.0000,0.2500,0.1000,0.0000,-0.5000\n1,0,0.040,,,,,,\n"),
        )
        .unwrap();
        let h = read_source_heads(d, GazeClass::Conversation).unwrap();
        assert_eq!(h.len(), 2);
        let p = h[0].unwrap();
        assert_eq!(
            (p.yaw_deg, p.pitch_deg, p.translation_cm[2]),
            (2.5, -1.0, -0.5)
        );
        assert_eq!(h[1], None);
        std::fs::write(&path, format!("{HEAD_POOL_HEADER}\n0,3,1.0,x,,,,,\n")).unwrap();
        let e = read_source_heads(d, GazeClass::Conversation)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("conversation_head.csv: line 2") && e.contains("'x'"),
            "{e}"
        );
        let e = read_source_heads(d, GazeClass::Reading)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("reading_head.csv") && e.contains("eyereplay generate"),
            "{e}"
        );
    }
}
