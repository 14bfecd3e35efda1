//! Every dataset config under `examples/` parses, and its `[render]` table
//! types for its backend: a key of another backend is an error naming it,
//! so an example that carried one would fail here before a user's run.

use eyereplay_dataset::{RenderBackend, RenderSettings};
use eyereplay_prepare::DatasetConfig;
use std::path::{Path, PathBuf};

fn toml_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for e in std::fs::read_dir(dir).unwrap().flatten() {
        let p = e.path();
        if p.is_dir() {
            toml_files(&p, out);
        } else if p.extension().is_some_and(|x| x == "toml") {
            out.push(p);
        }
    }
}

#[test]
fn every_example_config_types_its_render_table() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples");
    let mut files = Vec::new();
    toml_files(&root, &mut files);
    files.sort();
    let mut backends = std::collections::BTreeSet::new();
    let mut configs = 0;
    for f in &files {
        let text = std::fs::read_to_string(f).unwrap();
        // Detector protocols and other non-dataset files have no classes.
        if !text.contains("[classes") {
            continue;
        }
        let cfg = DatasetConfig::parse(&text).unwrap_or_else(|e| panic!("{}: {e}", f.display()));
        let s = RenderSettings::from_config(&cfg, f).unwrap_or_else(|e| panic!("{e}"));
        backends.insert(s.backend.kind().name());
        configs += 1;
    }
    assert!(configs >= 10, "only {configs} dataset configs found");
    // The examples show every backend.
    for b in [
        RenderBackend::Eyes,
        RenderBackend::Browser,
        RenderBackend::Face,
        RenderBackend::Replay,
    ] {
        assert!(backends.contains(b.name()), "no example uses {}", b.name());
    }
}
