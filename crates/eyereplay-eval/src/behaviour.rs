//! Behaviour models against real recordings: within each class's source
//! pool, the segments a behaviour model generated (`kind = "model"` in
//! `metadata.json`) against the real ones, with the report's metrics and
//! KS test, beside the D between two real people of the same class. A
//! model is as realistic as the data can tell when its D to the real
//! recordings is no larger than the D between two real people.

use crate::dataset::Dataset;
use crate::distribution::{compare_metric, extras, ClassEvaluation, EvalConfig, Metric};
use crate::metrics::MetricSamples;
use eyereplay_core::GazeClass;
use eyereplay_sources::RecordingKind;
use serde::Serialize;
use std::collections::BTreeMap;

/// One metric of one class.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct BehaviourRow {
    pub metric: Metric,
    /// KS D of the model's segments against every real segment pooled.
    pub d_model: Option<f64>,
    /// The largest KS D between two real people of the class.
    pub d_real: Option<f64>,
    /// Which two people gave `d_real`.
    pub real_pair: Option<(String, String)>,
    pub n_model: usize,
    pub n_real: usize,
}

impl BehaviourRow {
    /// D(model, real) <= D(real, real); `None` when either is missing.
    pub fn pass(&self) -> Option<bool> {
        Some(self.d_model? <= self.d_real?)
    }
}

/// One class's check, with what the report's figures need.
#[derive(Clone, Debug)]
pub struct BehaviourCheck {
    pub class: GazeClass,
    pub model_sources: usize,
    /// Real people (sources grouped by person: a fixation report's groups
    /// of one participant count as one).
    pub real_people: Vec<String>,
    pub rows: Vec<BehaviourRow>,
    /// Real as "source", the model as "generated", for the Q-Q and
    /// time-series figures.
    pub figures: ClassEvaluation,
}

/// The person a source id names: `file#participant/trial` -> `file#participant`.
fn person_of(id: &str) -> String {
    match (id.find('#'), id.rfind('/')) {
        (Some(h), Some(s)) if s > h && !id.contains("_model#") => id[..s].to_string(),
        _ => id.to_string(),
    }
}

/// The check of every class that has both generated and real sources.
pub fn check_behaviour(ds: &Dataset, cfg: &EvalConfig) -> Vec<BehaviourCheck> {
    let sources = &ds.metadata.sources;
    let mut out = Vec::new();
    for cd in &ds.classes {
        let is_model = |i: u32| {
            sources
                .get(i as usize)
                .is_some_and(|s| s.kind == RecordingKind::Model)
        };
        let model_segs: Vec<&[[f64; 2]]> = cd
            .pool
            .iter()
            .filter(|s| is_model(s.source))
            .map(|s| s.points.as_slice())
            .collect();
        let real: Vec<(String, &[[f64; 2]])> = cd
            .pool
            .iter()
            .filter(|s| !is_model(s.source))
            .map(|s| {
                let id = sources
                    .get(s.source as usize)
                    .map_or_else(|| s.source.to_string(), |r| r.id.clone());
                (person_of(&id), s.points.as_slice())
            })
            .collect();
        if model_segs.is_empty() || real.is_empty() {
            continue;
        }
        let thr = &cfg.thresholds;
        let mut model = MetricSamples::default();
        for s in &model_segs {
            model.add_segment(s, thr);
        }
        let mut all_real = MetricSamples::default();
        let mut people: BTreeMap<String, MetricSamples> = BTreeMap::new();
        for (p, s) in &real {
            all_real.add_segment(s, thr);
            people.entry(p.clone()).or_default().add_segment(s, thr);
        }
        let names: Vec<String> = people.keys().cloned().collect();
        let rows = Metric::ALL
            .iter()
            .map(|&m| {
                let d_model = compare_metric(m, m.samples(&all_real), m.samples(&model), 2)
                    .ks
                    .map(|k| k.d);
                let mut d_real: Option<f64> = None;
                let mut pair = None;
                for i in 0..names.len() {
                    for j in i + 1..names.len() {
                        let d = compare_metric(
                            m,
                            m.samples(&people[&names[i]]),
                            m.samples(&people[&names[j]]),
                            2,
                        )
                        .ks
                        .map(|k| k.d);
                        if let Some(d) = d {
                            if d_real.is_none_or(|x| d > x) {
                                d_real = Some(d);
                                pair = Some((names[i].clone(), names[j].clone()));
                            }
                        }
                    }
                }
                BehaviourRow {
                    metric: m,
                    d_model,
                    d_real,
                    real_pair: pair,
                    n_model: m.samples(&model).len(),
                    n_real: m.samples(&all_real).len(),
                }
            })
            .collect();
        let win = ((cfg.window_s * ds.fps).round() as usize).max(2);
        let first_real = real[0].1;
        let first_model = model_segs[0];
        let comparisons = Metric::ALL
            .iter()
            .map(|&m| compare_metric(m, m.samples(&all_real), m.samples(&model), cfg.qq_points))
            .collect();
        let figures = ClassEvaluation {
            class: cd.class,
            n_sessions: model_segs.len(),
            extras_source: extras(&all_real, ds.fps, cfg.px_per_deg),
            extras_generated: extras(&model, ds.fps, cfg.px_per_deg),
            source: all_real,
            generated: model,
            comparisons,
            window_source: first_real[..win.min(first_real.len())].to_vec(),
            window_generated: first_model[..win.min(first_model.len())].to_vec(),
            window_generated_file: "behaviour model".into(),
            events: vec![],
        };
        out.push(BehaviourCheck {
            class: cd.class,
            model_sources: model_segs.len(),
            real_people: names,
            rows,
            figures,
        });
    }
    out
}

/// The check as text, one line a row (what `eyereplay evaluate` prints).
pub fn behaviour_table(checks: &[BehaviourCheck]) -> String {
    let mut s = String::new();
    for c in checks {
        s.push_str(&format!(
            "behaviour {}: {} generated recordings against {} real people ({})\n",
            c.class,
            c.model_sources,
            c.real_people.len(),
            c.real_people.join(", ")
        ));
        for r in &c.rows {
            let f = |v: Option<f64>| v.map_or("-".to_string(), |d| format!("{d:.3}"));
            s.push_str(&format!(
                "  {:<18} D(model, real) {}   D(real, real) {}   {}\n",
                r.metric.key(),
                f(r.d_model),
                f(r.d_real),
                match r.pass() {
                    Some(true) => "ok: within the real spread",
                    Some(false) => "MISS: further than two real people",
                    None => "n/a",
                }
            ));
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::person_of;

    #[test]
    fn person_groups_trials_of_one_participant() {
        assert_eq!(person_of("onestop.csv#l37_1129/44"), "onestop.csv#l37_1129");
        assert_eq!(person_of("franck.mp4"), "franck.mp4");
        assert_eq!(
            person_of("reading_model#reading/0/3"),
            "reading_model#reading/0/3"
        );
    }
}
