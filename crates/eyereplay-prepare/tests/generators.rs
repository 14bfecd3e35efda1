//! Behaviour-model sources through the pipeline: one synthetic person a
//! session, per-frame reading labels, parameters in metadata.json, config
//! errors, and byte-identical output for the same seed.

use eyereplay_dataset::{write_dataset, ToolInfo};
use eyereplay_prepare::{load_sources, prepare, DatasetConfig};
use std::path::Path;

const CONFIG: &str = r#"fps = 25.0
session_frames = 250
seed = 3
[classes.reading]
sessions = 3
[[classes.reading.generators]]
model = "reading"
[classes.conversation]
sessions = 4
[[classes.conversation.generators]]
model = "interview"
interview = { talk_s = [3.0, 4.0], read_s = [3.0, 4.0] }
"#;

fn config(text: &str) -> DatasetConfig {
    DatasetConfig::from_text(text, Path::new("gen.toml"), Path::new(".")).unwrap()
}

fn tool() -> ToolInfo {
    ToolInfo {
        name: "eyereplay".into(),
        version: "test".into(),
        git_revision: None,
        models: vec![],
    }
}

#[test]
fn each_session_is_one_generated_person_with_labels() {
    let cfg = config(CONFIG);
    let inputs = load_sources(&cfg, |_, _| unreachable!("no video")).unwrap();
    assert_eq!(inputs.len(), 7);
    let p = prepare(&cfg, &inputs).unwrap();
    for c in &p.classes {
        for (i, s) in c.session_sources.iter().enumerate() {
            // The default duration is one session and one frame: the stride
            // is a whole person, so no session straddles two.
            assert_eq!(s.len(), 1, "{} session {i}: {s:?}", c.class);
            assert_eq!(c.sessions[i].len(), 250);
        }
        let read: usize = c.session_reading.iter().flatten().filter(|r| **r).count();
        let all = c.session_reading.iter().flatten().count();
        match c.class.name() {
            "reading" => assert_eq!(read, all),
            // 10 s interviews of 3-4 s stretches: both kinds in every session.
            _ => {
                assert!(read > 0 && read < all, "{read} of {all}");
                for s in &c.session_reading {
                    assert!(s.iter().any(|r| *r) && s.iter().any(|r| !*r));
                }
            }
        }
    }
    let rep = &p.sources[0];
    assert_eq!(rep.format, "reading_model");
    let b = rep.behaviour.as_ref().unwrap();
    assert!(b["params"]["reader"]["fixation_mean_ms"].as_f64().unwrap() >= 170.0);
    assert!(b["outcome"]["reading"]["words_per_min"].as_f64().unwrap() > 50.0);
}

#[test]
fn same_seed_same_bytes_and_a_reading_column() {
    let cfg = config(CONFIG);
    let write = || {
        let dir = tempfile::tempdir().unwrap();
        let inputs = load_sources(&cfg, |_, _| unreachable!()).unwrap();
        let p = prepare(&cfg, &inputs).unwrap();
        write_dataset(dir.path(), &cfg, &p, tool()).unwrap();
        dir
    };
    let (a, b) = (write(), write());
    for f in [
        "conversation/conversation_0001.csv",
        "reading/reading_0002.csv",
        "metadata.json",
        "labels.csv",
    ] {
        let (x, y) = (
            std::fs::read(a.path().join(f)).unwrap(),
            std::fs::read(b.path().join(f)).unwrap(),
        );
        assert!(x == y, "{f} differs between runs");
    }
    let text =
        std::fs::read_to_string(a.path().join("conversation/conversation_0001.csv")).unwrap();
    let header = text.lines().next().unwrap();
    assert!(header.ends_with(",reading"), "{header}");
    assert!(text.lines().skip(1).any(|l| l.ends_with(",1")));
    assert!(text.lines().skip(1).any(|l| l.ends_with(",0")));
    // Another seed, other people.
    let other = config(&CONFIG.replace("seed = 3", "seed = 4"));
    let p = prepare(
        &other,
        &load_sources(&other, |_, _| unreachable!()).unwrap(),
    )
    .unwrap();
    let first = prepare(&cfg, &load_sources(&cfg, |_, _| unreachable!()).unwrap()).unwrap();
    assert_ne!(p.classes[0].sessions[0], first.classes[0].sessions[0]);
}

#[test]
fn bad_generator_tables_are_one_line_errors() {
    let cases = [
        (
            "[classes.reading]\nsessions = 1\n[[classes.reading.generators]]\nmodel = \"conversation\"\nreader = { aloud_prob = 0.5 }\n",
            "'reader' does not apply to model = \"conversation\"",
        ),
        (
            "[classes.reading]\nsessions = 1\n[[classes.reading.generators]]\nmodel = \"reading\"\nreader = { fixation_mean_ms = [250.0, 200.0] }\n",
            "reader.fixation_mean_ms = [250, 200] must be [low, high]",
        ),
        (
            "[classes.reading]\nsessions = 1\n[[classes.reading.generators]]\nmodel = \"writing\"\n",
            "unknown variant `writing`",
        ),
        ("[classes.reading]\nsessions = 1\n", "has no sources and no generators"),
    ];
    for (text, want) in cases {
        let e = DatasetConfig::from_text(text, Path::new("bad.toml"), Path::new("."))
            .unwrap_err()
            .to_string();
        assert!(e.contains(want), "{e}");
        assert!(e.contains("bad.toml"), "{e}");
        assert!(!e.contains('\n'), "{e}");
    }
    // A text file that does not exist stops the run before any work.
    let cfg = config("[classes.reading]\nsessions = 1\n[[classes.reading.generators]]\nmodel = \"reading\"\ntext = \"no_such_script.txt\"\n");
    let e = load_sources(&cfg, |_, _| unreachable!())
        .unwrap_err()
        .to_string();
    assert!(e.contains("no_such_script.txt"), "{e}");
}

#[test]
fn behaviour_doc_examples_parse_and_every_range_is_documented() {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../docs/BEHAVIOUR.md");
    let text = std::fs::read_to_string(&p).unwrap();
    let blocks: Vec<&str> = text
        .split("```toml\n")
        .skip(1)
        .map(|b| b.split("```").next().unwrap())
        .collect();
    assert!(!blocks.is_empty());
    for b in blocks {
        let cfg = DatasetConfig::parse(b).unwrap_or_else(|e| panic!("{e}\n{b}"));
        cfg.validate().unwrap_or_else(|e| panic!("{e}\n{b}"));
    }
    // Every key of every range table is named in the doc.
    let tables = [
        serde_json::to_value(eyereplay_behaviour::ReaderRanges::default()).unwrap(),
        serde_json::to_value(eyereplay_behaviour::TalkerRanges::default()).unwrap(),
        serde_json::to_value(eyereplay_behaviour::EyeRanges::default()).unwrap(),
        serde_json::to_value(eyereplay_behaviour::InterviewRanges::default()).unwrap(),
    ];
    for t in tables {
        for key in t.as_object().unwrap().keys() {
            assert!(
                text.contains(&format!("`{key}`")) || text.contains(&format!("{key} =")),
                "docs/BEHAVIOUR.md does not name '{key}'"
            );
        }
    }
}
