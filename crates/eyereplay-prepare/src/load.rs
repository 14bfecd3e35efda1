//! Reading every configured source before any processing starts, so a bad
//! file stops the run at once with its name.

use crate::{DatasetConfig, GeneratedSource, PrepareError, SourceInput};
use eyereplay_behaviour::{draw_person, generate, person_seed, Gains, ReadingText};
use eyereplay_core::{
    sha256_file, sha256_hex, GazeClass, LandmarkModel, NormPos, Sample, Trajectory,
};
use eyereplay_sources::{read_source, SourceSpec};
use eyereplay_sources::{Recording, RecordingKind};
use rayon::prelude::*;
use std::path::{Path, PathBuf};

/// Checks that every source file exists and is readable; lists all the
/// missing ones in one line.
pub fn check_source_files(cfg: &DatasetConfig) -> Result<(), PrepareError> {
    let mut missing = Vec::new();
    for p in cfg.source_paths() {
        if let Err(e) = std::fs::File::open(&p) {
            missing.push(format!("{} ({e})", p.display()));
        }
    }
    // A relative path is taken from the config's folder, not the current
    // one; a path that exists from the current folder says which was meant.
    let from_here: Vec<String> = cfg
        .classes
        .values()
        .flat_map(|c| c.sources.iter().map(|s| s.path()))
        .filter(|w| w.is_relative() && !cfg.resolve(w).exists() && w.exists())
        .map(|w| w.display().to_string())
        .collect();
    if !from_here.is_empty() {
        missing.push(format!(
            "a config's relative paths are taken from its own folder ({}), and {} exists from the current \
             folder instead: write it relative to the config, or absolute",
            cfg.base_dir.display(),
            from_here.join(", ")
        ));
    }
    if missing.is_empty() {
        Ok(())
    } else {
        Err(PrepareError::Source {
            id: "sources".into(),
            message: format!("cannot read {}", missing.join("; ")),
        })
    }
}

/// Reads all sources in parallel, in config order. `video_to_csv` turns a
/// video path, read with the landmark networks its source names, into the
/// path of its extracted iris CSV (the caller decides how: cached
/// extraction, or an error saying extraction is unavailable).
pub fn load_sources<F>(
    cfg: &DatasetConfig,
    video_to_csv: F,
) -> Result<Vec<SourceInput>, PrepareError>
where
    F: Fn(&Path, LandmarkModel) -> Result<PathBuf, PrepareError> + Sync,
{
    check_source_files(cfg)?;
    let mut read = cfg.read;
    read.seed = cfg.seed;
    let jobs: Vec<(GazeClass, &SourceSpec)> = cfg
        .classes
        .iter()
        .flat_map(|(c, cc)| cc.sources.iter().map(move |s| (*c, s)))
        .collect();
    let loaded: Vec<Result<Vec<SourceInput>, PrepareError>> = jobs
        .par_iter()
        .map(|(class, written)| {
            let spec = &cfg.resolved_spec(written);
            let sha256 = sha256_file(spec.path())?;
            let (recs, format) = match spec {
                SourceSpec::Video { path, landmarks } => {
                    let csv = video_to_csv(path, *landmarks)?;
                    (
                        read_source(&SourceSpec::Extract { path: csv }, &read)?,
                        "video",
                    )
                }
                other => (read_source(other, &read)?, other.format_name()),
            };
            Ok(recs
                .into_iter()
                .map(|mut r| {
                    // Ids name the configured file, also for extracted videos.
                    if let SourceSpec::Video { path, .. } = spec {
                        r.id = display_name(path);
                        r.path = path.clone();
                    }
                    SourceInput {
                        class: *class,
                        file: written.path().display().to_string(),
                        format: format.to_string(),
                        sha256: sha256.clone(),
                        recording: r,
                        behaviour: None,
                    }
                })
                .collect())
        })
        .collect();
    let mut out = Vec::new();
    for l in loaded {
        out.extend(l?);
    }
    check_no_recording_in_two_classes(&out)?;
    out.extend(generated_sources(cfg)?);
    Ok(out)
}

/// The same recording (the same bytes, under any name) in two classes:
/// its sessions would carry both labels, and a detector would learn the
/// file, not the behaviour.
fn check_no_recording_in_two_classes(inputs: &[SourceInput]) -> Result<(), PrepareError> {
    for (i, a) in inputs.iter().enumerate() {
        if let Some(b) = inputs[..i]
            .iter()
            .find(|b| b.sha256 == a.sha256 && b.class != a.class)
        {
            let what = if a.file == b.file {
                "listed".to_string()
            } else {
                format!(
                    "the same recording as {} (sha256 {}...)",
                    b.file,
                    &a.sha256[..12.min(a.sha256.len())]
                )
            };
            return Err(PrepareError::Source {
                id: a.file.clone(),
                message: format!(
                    "{what} in class '{}' and in class '{}': its sessions would carry both labels \
                     (each recording belongs to one class)",
                    b.class, a.class
                ),
            });
        }
    }
    Ok(())
}

/// The recordings every class's behaviour models generate: one per
/// synthetic person, in class, generator and person order, after the real
/// sources. Each person's parameters are drawn from the generator's ranges
/// with a seed made of the dataset seed, the class, the generator's index
/// and the person's index, so adding a person changes no other.
pub fn generated_sources(cfg: &DatasetConfig) -> Result<Vec<SourceInput>, PrepareError> {
    let gains = Gains {
        nx_per_deg: cfg.read.eye_gains.nx_per_deg,
        ny_per_deg: cfg.read.eye_gains.ny_per_deg,
    };
    let mut jobs = Vec::new();
    for (class, cc) in &cfg.classes {
        // The class by its label, not its position: adding a class to a
        // config changes none of the other class's people.
        let ci = class.label() as usize;
        for (gi, g) in cc.generators.iter().enumerate() {
            let text = match &g.text {
                Some(p) => {
                    let path = cfg.resolve(p);
                    ReadingText::from_file(&path).map_err(|e| PrepareError::Source {
                        id: path.display().to_string(),
                        message: match e {
                            eyereplay_behaviour::BehaviourError::Text { message, .. } => message,
                            other => other.to_string(),
                        },
                    })?
                }
                None => ReadingText::bundled(),
            };
            let people = g.people.unwrap_or(cc.sessions);
            let duration_s = g.duration_s.unwrap_or_else(|| cfg.default_generated_s());
            for k in 0..people {
                jobs.push((*class, ci, gi, k, g, text.clone(), duration_s));
            }
        }
    }
    jobs.par_iter()
        .map(|(class, ci, gi, k, g, text, duration_s)| {
            let seed = person_seed(cfg.seed, *ci as u64, *gi as u64, *k as u64);
            let person = draw_person(g, seed, *duration_s, &text.name);
            let made = generate(&person, text, &gains);
            let samples: Vec<Sample<NormPos>> = made
                .samples
                .iter()
                .map(|s| Sample {
                    t_s: s.t_s,
                    pos: NormPos {
                        nx: s.n[0],
                        ny: s.n[1],
                    },
                    valid: true,
                    aperture: None,
                    blink: s.blink,
                })
                .collect();
            let id = format!("{}_model#{class}/{gi}/{k}", g.model.name());
            let record = serde_json::json!({
                "generator": gi,
                "person": k,
                "params": made.person,
                "outcome": made.outcome,
            });
            let text_json = serde_json::to_vec(&record).unwrap_or_default();
            Ok(SourceInput {
                class: *class,
                recording: Recording {
                    id: id.clone(),
                    path: g.text.clone().unwrap_or_else(|| "bundled".into()),
                    kind: RecordingKind::Model,
                    rate_hz: eyereplay_behaviour::SAMPLE_RATE_HZ,
                    segments: vec![Trajectory::new(samples)?],
                    px_per_deg: None,
                },
                file: format!("classes.{class}.generators[{gi}]"),
                format: format!("{}_model", g.model.name()),
                sha256: sha256_hex(&text_json),
                behaviour: Some(GeneratedSource {
                    record,
                    reading_spans: made.reading_spans,
                }),
            })
        })
        .collect()
}

/// File name of a path, for ids and labels.
fn display_name(path: &Path) -> String {
    path.file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| path.display().to_string())
}
