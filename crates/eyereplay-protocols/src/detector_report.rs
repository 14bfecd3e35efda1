//! `evaluate-detector`'s outputs: `detector_eval.json` (every number) and
//! `index.html` (tables and ROC curves a person can read), plus the
//! figures as PNG and SVG under `figures/`.

use crate::detector_eval::{ConditionResult, DetectorEvaluation};
use eyereplay::Result;
use eyereplay_core::atomic_write;
use eyereplay_detect::AurocCi;
use eyereplay_eval::plot::{reliability_figure, roc_figure, Figure, RocCurve};
use std::fmt::Write as _;
use std::path::Path;

use eyereplay_eval::html_escape as esc;

fn auc(a: &Option<AurocCi>) -> String {
    match a {
        Some(a) => format!("{:.3} [{:.2}, {:.2}]", a.auroc, a.low, a.high),
        None => "n/a".into(),
    }
}

fn condition_label(c: &str) -> String {
    match c.strip_prefix("noise_") {
        Some(k) => format!("clean + noise k = {k}"),
        None => "rendered, then extracted".into(),
    }
}

fn png_b64(f: &Figure) -> String {
    use base64::Engine;
    base64::engine::general_purpose::STANDARD.encode(&f.png)
}

pub fn write(out: &Path, ev: &DetectorEvaluation) -> Result<()> {
    let mut json = serde_json::to_string_pretty(ev).expect("evaluation serializes");
    json.push('\n');
    atomic_write(&out.join("detector_eval.json"), json.as_bytes())?;
    let figs_dir = out.join("figures");
    let mut figs = Vec::new();
    let mut keys: Vec<(f64, String)> = ev
        .conditions
        .iter()
        .map(|c| (c.window_s, c.mode.clone()))
        .collect();
    keys.dedup();
    for (w, mode) in &keys {
        let panels: Vec<(String, Vec<RocCurve>)> = ev
            .conditions
            .iter()
            .filter(|c| c.window_s == *w && &c.mode == mode)
            .map(|c| {
                let mut curves: Vec<RocCurve> = c
                    .roc_model
                    .iter()
                    .map(|(label, pts)| RocCurve {
                        label: format!("synthetic-trained, {label}"),
                        points: pts.clone(),
                    })
                    .collect();
                if let Some(a) = &c.rule {
                    curves.push(RocCurve {
                        label: format!("zero-training rule {:.2}", a.auroc),
                        points: c.roc_rule.clone(),
                    });
                }
                if let Some(a) = &c.ceiling {
                    curves.push(RocCurve {
                        label: format!("real-trained ceiling {:.2}", a.auroc),
                        points: c.roc_ceiling.clone(),
                    });
                }
                (
                    format!("{} ({} s)", condition_label(&c.condition), w),
                    curves,
                )
            })
            .collect();
        let name = format!("roc_{mode}_{w}s");
        let f = roc_figure(&name, &panels)?;
        atomic_write(&figs_dir.join(format!("{name}.png")), &f.png)?;
        atomic_write(&figs_dir.join(format!("{name}.svg")), f.svg.as_bytes())?;
        figs.push((w, mode.clone(), f));
    }
    // Reliability: one figure, a panel per condition of the first window
    // length, a curve per training video.
    let first_w = ev.conditions.first().map_or(10.0, |c| c.window_s);
    let mut conds: Vec<String> = ev
        .conditions
        .iter()
        .filter(|c| c.window_s == first_w)
        .map(|c| c.condition.clone())
        .collect();
    conds.dedup();
    let panels: Vec<(String, Vec<RocCurve>)> = conds
        .iter()
        .map(|cond| {
            let curves = ev
                .conditions
                .iter()
                .filter(|c| c.window_s == first_w && &c.condition == cond)
                .map(|c| RocCurve {
                    label: format!("{} video, ECE {:.3}", c.mode, c.expected_calibration_error),
                    points: c
                        .reliability
                        .iter()
                        .filter(|b| b.count > 0)
                        .map(|b| (b.mean_probability, b.positive_fraction))
                        .collect(),
                })
                .collect();
            (format!("{} ({first_w} s)", condition_label(cond)), curves)
        })
        .collect();
    let rel = reliability_figure("reliability", &panels)?;
    atomic_write(&figs_dir.join("reliability.png"), &rel.png)?;
    atomic_write(&figs_dir.join("reliability.svg"), rel.svg.as_bytes())?;
    let html = html(ev, &figs, &rel);
    atomic_write(&out.join("index.html"), html.as_bytes())?;
    Ok(())
}

fn table_head(h: &mut String, cols: &[&str]) {
    h.push_str("<table><tr>");
    for c in cols {
        let _ = write!(h, "<th>{c}</th>");
    }
    h.push_str("</tr>\n");
}

fn row(h: &mut String, cells: &[String]) {
    h.push_str("<tr>");
    for c in cells {
        let _ = write!(h, "<td>{c}</td>");
    }
    h.push_str("</tr>\n");
}

fn html(ev: &DetectorEvaluation, figs: &[(&f64, String, Figure)], reliability: &Figure) -> String {
    let mut h = String::from(
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\n<title>eyereplay: the reading detector on real recordings</title>\n<style>\n\
body{font-family:system-ui,-apple-system,'Segoe UI',sans-serif;max-width:1440px;margin:2em auto;padding:0 1em;color:#222}\n\
table{border-collapse:collapse;margin:0.8em 0}td,th{border:1px solid #ccc;padding:4px 10px;text-align:right}\n\
th{background:#f3f3f3}td:first-child,th:first-child{text-align:left}\n\
figure{margin:1em 0}img{max-width:100%;height:auto;border:1px solid #ddd}figcaption{color:#555;font-size:0.9em}\n\
.note{background:#fff8e1;border-left:4px solid #f0b400;padding:0.6em 1em}code{background:#f3f3f3;padding:0 3px}\n\
</style></head><body>\n<h1>The reading detector on real recordings</h1>\n",
    );
    let _ = writeln!(
        h,
        "<p>Protocol <code>{}</code>, seed {}. {} over 14 gaze features, trained only on synthetic \
video (what <code>eyereplay extract</code> reads from each rendered session), scored on real recordings it never saw. \
Beside it on the same windows: a <b>1D-CNN</b> trained on the same synthetic windows, the <b>zero-training rule</b> \
(share of saccades in runs of 3 or more forward saccades) and a <b>ceiling</b>: a logistic regression over the same \
features trained on the real windows themselves, leaving out the pair of people it is tested on. Each fold's model scores its own held-out reader; \
a reader's AUROC against the non-readers is computed within one model (scores of two models are not compared), then \
readers are averaged. 95 % intervals from a bootstrap over people (readers and non-readers drawn with replacement).</p>",
        esc(&ev.protocol),
        ev.seed,
        capitalized(&ev.classifier.describe())
    );
    h.push_str("<h2>AUROC on held-out real eye-tracker recordings</h2>\n");
    table_head(
        &mut h,
        &[
            "window",
            "training video",
            "test data",
            "synthetic-trained (features)",
            "synthetic-trained (1D-CNN)",
            "zero-training rule",
            "real-trained ceiling",
            "TPR / FPR at threshold",
            "without fixation tasks: features / CNN / rule / ceiling",
        ],
    );
    for c in &ev.conditions {
        row(
            &mut h,
            &[
                format!("{} s", c.window_s),
                esc(&c.mode),
                condition_label(&c.condition),
                auc(&c.model),
                auc(&c.cnn),
                auc(&c.rule),
                auc(&c.ceiling),
                format!("{:.2} / {:.2}", c.true_positive_rate, c.false_positive_rate),
                format!(
                    "{} / {} / {} / {}",
                    auc(&c.model_nontrivial),
                    auc(&c.cnn_nontrivial),
                    auc(&c.rule_nontrivial),
                    auc(&c.ceiling_nontrivial)
                ),
            ],
        );
    }
    h.push_str("</table>\n");
    h.push_str("<h2>False positives on real talking-face webcam video</h2>\n<p>Only negatives exist here, so the rate of windows called reading at the threshold fixed on synthetic validation data (the rule: at its threshold fixed on the synthetic training windows).</p>\n");
    table_head(
        &mut h,
        &[
            "window",
            "training video",
            "fold",
            "video",
            "windows",
            "synthetic-trained FPR (features)",
            "1D-CNN FPR",
            "rule FPR",
        ],
    );
    for w in &ev.webcam {
        row(
            &mut h,
            &[
                format!("{} s", w.window_s),
                esc(&w.mode),
                esc(&w.fold),
                esc(&w.recording),
                w.windows.to_string(),
                format!("{:.2}", w.false_positive_rate),
                format!("{:.2}", w.cnn_false_positive_rate),
                format!("{:.2}", w.rule_false_positive_rate),
            ],
        );
    }
    h.push_str("</table>\n<h2>Calibration: does a probability mean what it says?</h2>\n<p>Each fold's model calibrates its probabilities (Platt scaling) and fixes its threshold for a stated false-positive rate on its synthetic validation sessions; here both are checked on the real windows it never saw. Expected calibration error: the window-weighted mean gap between the predicted probability and the observed share reading, over 10 bins.</p>\n");
    table_head(
        &mut h,
        &[
            "window",
            "training video",
            "test data",
            "windows",
            "expected calibration error",
            "FPR at the threshold (stated)",
            "TPR at the threshold",
        ],
    );
    for c in &ev.conditions {
        let n: usize = c.reliability.iter().map(|b| b.count).sum();
        row(
            &mut h,
            &[
                format!("{} s", c.window_s),
                esc(&c.mode),
                condition_label(&c.condition),
                n.to_string(),
                format!("{:.3}", c.expected_calibration_error),
                format!(
                    "{:.3} ({:.3})",
                    c.false_positive_rate, c.target_false_positive_rate
                ),
                format!("{:.3}", c.true_positive_rate),
            ],
        );
    }
    let _ = writeln!(
        h,
        "</table>\n<figure><img alt=\"Reliability diagrams\" width=\"{}\" src=\"data:image/png;base64,{}\"><figcaption>Reliability: predicted probability of reading against the observed share reading, per bin of windows; on the dashed diagonal a probability means what it says (<a href=\"figures/reliability.svg\">SVG</a>)</figcaption></figure>",
        reliability.size.0,
        png_b64(reliability)
    );
    h.push_str("<h2>ROC curves</h2>\n");
    for (w, mode, f) in figs {
        let _ = writeln!(
            h,
            "<figure><img alt=\"ROC curves, {mode}, {w} s\" width=\"{}\" src=\"data:image/png;base64,{}\"><figcaption>ROC, training video {mode}, {w} s windows (<a href=\"figures/{}.svg\">SVG</a>)</figcaption></figure>",
            f.size.0,
            png_b64(f),
            f.name
        );
    }
    h.push_str("<h2>Real recordings</h2>\n");
    table_head(
        &mut h,
        &[
            "recording",
            "person",
            "class",
            "task",
            "duration",
            "held out in fold",
        ],
    );
    for r in &ev.recordings {
        row(
            &mut h,
            &[
                esc(&r.name),
                esc(&r.person),
                if r.reading { "reading" } else { "other" }.into(),
                format!(
                    "{}{}{}",
                    esc(&r.task),
                    if r.trivial { " (trivial)" } else { "" },
                    if r.webcam { " (webcam video)" } else { "" }
                ),
                format!("{:.0} s", r.duration_s),
                esc(&r.folds.join(", ")),
            ],
        );
    }
    h.push_str("</table>\n<h2>Per recording</h2>\n<p>Mean reading probability and the share of windows called reading, by the fold's model.</p>\n");
    table_head(
        &mut h,
        &[
            "window",
            "training video",
            "test data",
            "fold",
            "recording",
            "class",
            "windows",
            "mean P(reading)",
            "called reading",
        ],
    );
    for c in &ev.conditions {
        per_recording(&mut h, c);
    }
    h.push_str("</table>\n<h2>Fold models</h2>\n");
    table_head(
        &mut h,
        &[
            "window",
            "training video",
            "fold",
            "training windows",
            "synthetic validation AUROC",
            "threshold",
            "rule threshold",
            "largest weights (standardized features)",
        ],
    );
    for m in &ev.models {
        let mut w = m.weights.clone();
        w.sort_by(|a, b| b.1.abs().total_cmp(&a.1.abs()));
        let top: Vec<String> = w
            .iter()
            .take(4)
            .map(|(n, v)| format!("{n} {v:+.2}"))
            .collect();
        row(
            &mut h,
            &[
                format!("{} s", m.window_s),
                esc(&m.mode),
                esc(&m.fold),
                m.train_windows.to_string(),
                m.validation_auroc
                    .map_or("n/a".into(), |a| format!("{a:.3}")),
                format!("{:.3}", m.threshold),
                format!("{:.3}", m.rule_threshold),
                esc(&top.join(", ")),
            ],
        );
    }
    h.push_str("</table>\n<p>Every number is in <code>detector_eval.json</code> beside this page.</p>\n</body></html>\n");
    h
}

fn per_recording(h: &mut String, c: &ConditionResult) {
    for r in &c.per_recording {
        row(
            h,
            &[
                format!("{} s", c.window_s),
                esc(&c.mode),
                condition_label(&c.condition),
                esc(&r.fold),
                esc(&r.recording),
                if r.reading { "reading" } else { "other" }.into(),
                r.windows.to_string(),
                format!("{:.3}", r.mean_probability),
                format!("{:.2}", r.called_reading),
            ],
        );
    }
}

/// `text` with its first letter upper-case, to open a sentence.
fn capitalized(text: &str) -> String {
    let mut chars = text.chars();
    chars
        .next()
        .map_or(String::new(), |c| c.to_uppercase().chain(chars).collect())
}
