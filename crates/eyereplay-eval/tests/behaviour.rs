//! The behaviour check: generated sources (kind "model") against the real
//! ones of their class, beside the D between two real people.

mod common;

use eyereplay_eval::{check_behaviour, ks_2samp, load_dataset, EvalConfig, Metric, MetricSamples};
use std::path::Path;

/// A dataset of three sources a class (ids 0-2 reading, 10-12
/// conversation), the third of each marked as generated; `model_like` picks
/// what the generated conversation source looks like.
fn dataset(dir: &Path, conversation_model_reads: bool) {
    let spec = common::Spec {
        sources_per_class: 3,
        ..common::Spec::default()
    };
    common::write_dataset(dir, &spec);
    if conversation_model_reads {
        // The generated talker reads instead: replace source 12's frames.
        let p = dir.join("pool/conversation.csv");
        let text = std::fs::read_to_string(&p).unwrap();
        let fake = common::reading_source(spec.source_frames, 99);
        let mut out = String::from("frame,x,y,source\n");
        let mut k = 0;
        for (i, line) in text.lines().skip(1).enumerate() {
            let f: Vec<&str> = line.split(',').collect();
            if f[3] == "12" {
                out.push_str(&format!("{i},{:.3},{:.3},12\n", fake[k][0], fake[k][1]));
                k += 1;
            } else {
                out.push_str(line);
                out.push('\n');
            }
        }
        std::fs::write(&p, out).unwrap();
    }
    let sources = (0..13)
        .map(|i| {
            let class = if i < 10 { "reading" } else { "conversation" };
            let kind = if i == 2 || i == 12 {
                "model"
            } else {
                "fixation_report"
            };
            let mut s = common::source(i, class, kind, [1000.0, 600.0, 640.0, 360.0]);
            s.id = if kind == "model" {
                format!("{class}_model#{class}/0/0")
            } else {
                format!("person{i}.csv")
            };
            s
        })
        .collect();
    let meta = eyereplay_dataset::read_metadata(dir).unwrap().dataset;
    let classes: Vec<_> = meta
        .classes
        .iter()
        .map(|c| (c.class, c.sessions, c.pool_frames))
        .collect();
    common::write_meta(
        dir,
        25.0,
        1000,
        Some([1000.0, 600.0, 640.0, 360.0]),
        &classes,
        sources,
    );
}

#[test]
fn model_against_pooled_real_and_real_against_real() {
    let dir = tempfile::tempdir().unwrap();
    dataset(dir.path(), false);
    let ds = load_dataset(dir.path()).unwrap();
    let cfg = EvalConfig::default();
    let checks = check_behaviour(&ds, &cfg);
    assert_eq!(checks.len(), 2);
    for (c, cd) in checks.iter().zip(&ds.classes) {
        assert_eq!(c.model_sources, 1);
        assert_eq!(c.real_people.len(), 2);
        // Worked independently: metrics of each source's own segment, KS
        // of the model against both real sources pooled, and of the two
        // real sources against each other.
        let seg = |src: u32| {
            let mut m = MetricSamples::default();
            for s in cd.pool.iter().filter(|s| s.source == src) {
                m.add_segment(&s.points, &cfg.thresholds);
            }
            m
        };
        let base = if c.class.name() == "reading" { 0 } else { 10 };
        let (a, b, g) = (seg(base), seg(base + 1), seg(base + 2));
        let mut ab = MetricSamples::default();
        for s in cd
            .pool
            .iter()
            .filter(|s| s.source == base || s.source == base + 1)
        {
            ab.add_segment(&s.points, &cfg.thresholds);
        }
        for r in &c.rows {
            let m: Metric = r.metric;
            let want_model = ks_2samp(m.samples(&ab), m.samples(&g)).unwrap().d;
            let want_real = ks_2samp(m.samples(&a), m.samples(&b)).unwrap().d;
            assert!((r.d_model.unwrap() - want_model).abs() < 1e-12, "{m:?}");
            assert!((r.d_real.unwrap() - want_real).abs() < 1e-12, "{m:?}");
        }
    }
}

#[test]
fn a_model_of_the_wrong_behaviour_fails_the_check() {
    let dir = tempfile::tempdir().unwrap();
    dataset(dir.path(), true);
    let ds = load_dataset(dir.path()).unwrap();
    let checks = check_behaviour(&ds, &EvalConfig::default());
    let conv = checks
        .iter()
        .find(|c| c.class.name() == "conversation")
        .unwrap();
    // A "talker" who reads is further from the real talkers than they are
    // from each other, on at least the speed and saccade metrics.
    let misses = conv.rows.iter().filter(|r| r.pass() == Some(false)).count();
    assert!(misses >= 2, "{:?}", conv.rows);
    let table = eyereplay_eval::behaviour_table(&checks);
    assert!(table.contains("MISS"), "{table}");
}
