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

use crate::{BackendError as Error, Result};
use eyereplay_core::{ArtifactCache, ArtifactKey, GazeClass, Progress, Stage};
use eyereplay_dataset::{pool_head_file, DatasetMetadata, PoseRow};
use eyereplay_extract::StageFrames;
use eyereplay_face::{
    default_faces_dir, video_head_poses, CanonicalMesh, HeadPose, SourceHeadTrack, MESH_FILE,
    SOURCE_HEAD_SMOOTHING_S, SOURCE_VFOV_DEG,
};
use eyereplay_prepare::{DatasetConfig, Prepared};
use eyereplay_sources::RecordingKind;
use std::collections::btree_map::Entry;
use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

/// Version of the cached per-frame poses: bump when the solve changes.
const HEAD_CACHE_VERSION: u32 = 1;

/// The cache key of a video's per-frame head poses: the video, the
/// solve's version, the extractor's rows revision and networks (the poses
/// come from its face mesh) and the field of view assumed.
fn cache_key(sha256: &str) -> Result<ArtifactKey> {
    Ok(eyereplay_extract::keyed_by_extractor(
        ArtifactKey::new("head", sha256, "json").version("v", HEAD_CACHE_VERSION),
    )?
    .version("vfov", SOURCE_VFOV_DEG))
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
    ArtifactCache::new(cache).get_or_make(
        &cache_key(sha256)?,
        |file| Ok(eyereplay_core::read_json_cache(file, "head pose cache")?),
        || {
            progress.info(&format!(
                "head pose of {}: solving every frame's landmarks (once; cached)",
                video.display()
            ));
            Ok(video_head_poses(
                video,
                &eyereplay_extract::default_models_dir(),
                mesh,
                &mesh.positions_cm,
                SOURCE_VFOV_DEG,
                &StageFrames(progress),
            )?)
        },
        |file, poses: &Vec<(f64, Option<HeadPose>)>| Ok(eyereplay_core::write_json(file, poses)?),
    )
}

/// Every video source's head track (by the video's sha256; a video that
/// shows no face at all has none, so its frames use the model), and the
/// sha256 of each video source by source index.
type Tracks = (BTreeMap<String, SourceHeadTrack>, BTreeMap<u32, String>);

fn source_tracks(
    config: &DatasetConfig,
    prepared: &Prepared,
    cache: &Path,
    progress: &dyn Progress,
) -> Result<Tracks> {
    let videos: Vec<_> = prepared
        .sources
        .iter()
        // A video file, not an `extract` CSV (also of kind video): its
        // frames are needed.
        .filter(|s| s.kind == RecordingKind::Video && s.format == "video")
        .collect();
    let (mut tracks, mut sha_of) = (BTreeMap::new(), BTreeMap::new());
    if videos.is_empty() {
        return Ok((tracks, sha_of));
    }
    let mesh = CanonicalMesh::load(&default_faces_dir().join(MESH_FILE))?;
    // A progress bar only when some video is not cached yet.
    let mut solving = false;
    for s in &videos {
        solving |= !ArtifactCache::new(cache)
            .path(&cache_key(&s.sha256)?)
            .is_file();
    }
    if solving {
        progress.begin(Stage::Extract, 0);
    }
    let mut done = BTreeSet::new();
    for s in videos {
        sha_of.insert(s.index as u32, s.sha256.clone());
        // One track per video file, shared by its recordings.
        if !done.insert(s.sha256.clone()) {
            continue;
        }
        let path = config.resolve(Path::new(&s.file));
        let poses = video_poses(&path, &s.sha256, cache, &mesh, progress)?;
        match SourceHeadTrack::from_poses(&poses, SOURCE_HEAD_SMOOTHING_S) {
            Some(t) => {
                tracks.insert(s.sha256.clone(), t);
            }
            None => progress.warn(&format!(
                "warning: {}: no face found for a head pose; its frames use the head model",
                s.file
            )),
        }
    }
    if solving {
        progress.end(Stage::Extract);
    }
    Ok((tracks, sha_of))
}

/// Writes `pool/<class>_head.csv` for every class of `prepared` into `out`:
/// each pool frame's source head pose, solved (cached) from the config's
/// video sources. Deterministic: the same inputs give the same bytes.
pub fn write_source_heads(
    out: &Path,
    config: &DatasetConfig,
    prepared: &Prepared,
    cache: &Path,
    progress: &dyn Progress,
) -> Result<()> {
    let (tracks, sha_of) = source_tracks(config, prepared, cache, progress)?;
    for c in &prepared.classes {
        let poses: Vec<Option<PoseRow>> = c
            .pool_source
            .iter()
            .zip(&c.pool_time_s)
            .map(|(src, &t)| {
                let track = sha_of.get(src).and_then(|sha| tracks.get(sha))?;
                track.at(t).map(|p| p.components())
            })
            .collect();
        eyereplay_dataset::write_pool_heads(&out.join(pool_head_file(c.class)), &poses)?;
    }
    Ok(())
}

/// The source head pose of each frame of the session `file` of the dataset
/// in `out` (metadata `meta`): pool frame `(pool_start + j) mod T` of its
/// class's `pool/<class>_head.csv`. `pools` keeps each class's file once
/// read.
pub fn session_heads(
    out: &Path,
    meta: &DatasetMetadata,
    file: &str,
    pools: &mut BTreeMap<GazeClass, Vec<Option<PoseRow>>>,
) -> Result<Vec<Option<HeadPose>>> {
    let entry = meta
        .sessions
        .iter()
        .find(|s| s.file == file)
        .ok_or_else(|| Error::input(file, "not listed in metadata.json's sessions"))?;
    let path = out.join(pool_head_file(entry.class));
    if let Entry::Vacant(slot) = pools.entry(entry.class) {
        if !path.is_file() {
            return Err(Error::input(
                &path,
                "not found (render.head_motion = \"source\" reads it; `eyereplay generate` writes it)",
            ));
        }
        slot.insert(eyereplay_dataset::read_pool_heads(&path)?);
    }
    let heads = &pools[&entry.class];
    let expected = meta
        .classes
        .iter()
        .find(|c| c.class == entry.class)
        .map_or(0, |c| c.pool_frames);
    if heads.is_empty() || heads.len() != expected {
        return Err(Error::input(
            &path,
            format!(
                "{} frames where the pool has {expected}: written for another dataset (rerun `eyereplay generate`)",
                heads.len()
            ),
        ));
    }
    Ok((0..meta.session_frames)
        .map(|j| heads[(entry.pool_start + j) % heads.len()].map(HeadPose::from_components))
        .collect())
}
