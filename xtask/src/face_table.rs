//! `cargo xtask face-table`: the visual fidelity of every rendered session
//! of one or more datasets, one row each, as `eyereplay evaluate
//! --read-back-all` measured it (`report/metrics.json`'s
//! `visual.sessions`). Nothing is measured here: r, amplitude ratio, gain,
//! the detection rate and the read-back budget are the evaluation's; this
//! only adds what metrics.json does not hold (the photo and the drawn head
//! yaw's range, from the session's own files) and the summaries over
//! sessions.

use anyhow::{bail, Context, Result};
use eyereplay_dataset::{read_head_yaw_csv, SessionIdentity, SessionPaths};
use eyereplay_signal::stats::{mean, median};
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::Command;

#[derive(clap::Args, Debug)]
#[command(after_help = "Examples:\n  \
eyereplay evaluate out/default --read-back-all && cargo xtask face-table out/default\n  \
cargo xtask face-table out/default --evaluate --vertical     # evaluate first, then the table\n  \
cargo xtask face-table out/seed1 out/seed2 out/seed3 --horizontal --vertical   # pooled over seeds")]
pub struct Args {
    /// Dataset folders; with several, a pooled summary per class follows.
    #[arg(required = true)]
    pub datasets: Vec<PathBuf>,
    /// Run `eyereplay evaluate DATASET --read-back-all` on each dataset
    /// first (one extraction of every video), which rewrites its report.
    /// Without it, a report without the per-session read-back is an error
    /// saying so.
    #[arg(long)]
    pub evaluate: bool,
    /// The `eyereplay` binary --evaluate runs [default: this checkout's
    /// target/release/eyereplay].
    #[arg(long, value_name = "PATH")]
    pub eyereplay: Option<PathBuf>,
    /// With --evaluate: the models folder (`eyereplay evaluate --models`).
    #[arg(long, value_name = "DIR")]
    pub models: Option<PathBuf>,
    /// Also the vertical read-back budget per session: the movement to be
    /// read in image pixels (the source's ny std times the extracted
    /// lid-to-lid height), the extractor's own error on the iris centre's
    /// height (px), and r with the drawn iris centre put in place of the
    /// extracted one: what r would be if the iris network found the centre
    /// exactly.
    #[arg(long)]
    pub vertical: bool,
    /// Also the horizontal read-back budget (as --vertical, along each
    /// eye's corner-to-corner axis).
    #[arg(long)]
    pub horizontal: bool,
}

/// One axis of a session row: `None` where metrics.json has null.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Axis {
    pub r: Option<f64>,
    pub ratio: Option<f64>,
    pub gain: Option<f64>,
}

/// One axis of the read-back budget (see `eyereplay_eval::AxisBudget`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Budget {
    pub movement_px: Option<f64>,
    pub iris_error_px: Option<f64>,
    pub r_drawn_iris: Option<f64>,
}

/// One session of `visual.sessions`, plus its photo and drawn yaw range.
#[derive(Clone, Debug, PartialEq)]
pub struct Row {
    pub session: String,
    pub class: String,
    pub photo: String,
    /// Share of compared frames in which the extractor measured an iris.
    pub found: f64,
    pub frames: usize,
    pub x: Axis,
    pub y: Axis,
    /// The drawn head's yaw range (degrees), full-face sessions only.
    pub yaw: Option<(f64, f64)>,
    /// The head yaw read back against the drawn one (Pearson r).
    pub yaw_r: Option<f64>,
    pub budget: Option<[Budget; 2]>,
    /// With the read-back match, where it refined the session: the fit's
    /// vertical gain (the response map's ny/ny term) over the probe's,
    /// from the identity file. How far the probe alone was from the map
    /// the session was drawn through.
    pub refit_over_probe_y: Option<f64>,
}

fn num(v: &Value, path: &[&str]) -> Option<f64> {
    path.iter().try_fold(v, |v, k| v.get(k))?.as_f64()
}

fn axis(v: &Value, k: &str) -> Axis {
    Axis {
        r: num(v, &[k, "r"]),
        ratio: num(v, &[k, "amplitude_ratio"]),
        gain: num(v, &[k, "gain"]),
    }
}

/// The session rows of a parsed metrics.json, without photo and yaw
/// range; an error when it has no per-session read-back.
pub fn session_rows(metrics: &Value) -> Result<Vec<Row>> {
    let Some(sessions) = metrics
        .pointer("/visual/sessions")
        .and_then(Value::as_array)
        .filter(|s| !s.is_empty())
    else {
        bail!("no per-session read-back (visual.sessions)");
    };
    sessions
        .iter()
        .map(|s| {
            let text = |k: &str| {
                s.get(k)
                    .and_then(Value::as_str)
                    .map(str::to_string)
                    .with_context(|| format!("a session without \"{k}\""))
            };
            let budget = s.get("budget").filter(|b| !b.is_null()).map(|b| {
                ["x", "y"].map(|k| Budget {
                    movement_px: num(b, &[k, "movement_px"]),
                    iris_error_px: num(b, &[k, "iris_error_px"]),
                    r_drawn_iris: num(b, &[k, "r_drawn_iris"]),
                })
            });
            Ok(Row {
                session: text("session")?,
                class: text("class")?,
                photo: "?".into(),
                found: num(s, &["detection_rate"]).unwrap_or(f64::NAN),
                frames: s.get("n_frames").and_then(Value::as_u64).unwrap_or(0) as usize,
                x: axis(s, "x"),
                y: axis(s, "y"),
                yaw: None,
                yaw_r: num(s, &["head_yaw", "r"]),
                budget,
                refit_over_probe_y: None,
            })
        })
        .collect()
}

/// The amplitude-ratio target of the report (0.9-1.1 when absent).
fn ratio_target(metrics: &Value) -> (f64, f64) {
    (
        num(metrics, &["visual", "target", "amplitude_ratio_min"]).unwrap_or(0.9),
        num(metrics, &["visual", "target", "amplitude_ratio_max"]).unwrap_or(1.1),
    )
}

/// Reads `dir/report/metrics.json` and each session's photo and drawn yaw.
fn dataset_rows(dir: &Path) -> Result<(Vec<Row>, (f64, f64))> {
    let path = dir.join("report/metrics.json");
    let text = std::fs::read_to_string(&path).with_context(|| {
        format!(
            "{}: not evaluated yet (run `eyereplay evaluate {} --read-back-all`, or pass --evaluate)",
            path.display(),
            dir.display()
        )
    })?;
    let metrics: Value =
        serde_json::from_str(&text).with_context(|| format!("{}: not JSON", path.display()))?;
    let mut rows = session_rows(&metrics).with_context(|| {
        format!(
            "{}: run `eyereplay evaluate {} --read-back-all` (or pass --evaluate)",
            path.display(),
            dir.display()
        )
    })?;
    for row in &mut rows {
        let paths = SessionPaths::new(dir, &row.session).map_err(anyhow::Error::msg)?;
        if paths.identity_json.is_file() {
            let id: SessionIdentity = SessionIdentity::read(&paths.identity_json)?;
            if let Some(p) = id.identity.get("photo").and_then(Value::as_str) {
                row.photo = p.to_string();
            }
            row.refit_over_probe_y = refit_over_probe_y(&id.identity, &id.mapping);
        }
        let head = paths.head_csv();
        if head.is_file() {
            let yaw = read_head_yaw_csv(&head)?;
            row.yaw = Some(
                yaw.iter()
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| {
                        (lo.min(v), hi.max(v))
                    }),
            )
            .filter(|(lo, hi)| lo <= hi);
        }
    }
    Ok((rows, ratio_target(&metrics)))
}

/// The read-back match's vertical gain over the probe's (`identity`'s
/// `readback_match` record against `mapping`'s response, the map drawn
/// through); `None` unless the match refined the session.
fn refit_over_probe_y(identity: &Value, mapping: &Value) -> Option<f64> {
    let record = identity.get("readback_match")?;
    if record.get("refined").and_then(Value::as_bool) != Some(true) {
        return None;
    }
    let yy = |map: &Value| map.pointer("/a/1/1").and_then(Value::as_f64);
    let probe = yy(record.get("probe_response")?)?;
    let refit = yy(mapping.get("extractor_response")?)?;
    (probe != 0.0).then(|| refit / probe)
}

/// One line over the sessions the read-back match refined: the range of
/// the fit's vertical gain over the probe's, and in how many it came
/// within 5 % (where the probe alone would have done); empty when none.
pub fn refit_line(rows: &[Row]) -> String {
    let v: Vec<f64> = rows.iter().filter_map(|r| r.refit_over_probe_y).collect();
    if v.is_empty() {
        return String::new();
    }
    let lo = v.iter().cloned().fold(f64::INFINITY, f64::min);
    let hi = v.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
    let near = v.iter().filter(|g| (0.95..=1.05).contains(*g)).count();
    format!(
        "read-back match: vertical gain refit over the probe's {lo:.2}-{hi:.2}, within 0.95-1.05 in {near} of {} refined sessions\n",
        v.len()
    )
}

fn f(v: Option<f64>) -> f64 {
    v.unwrap_or(f64::NAN)
}

/// The per-session table, the summary per class and the asked-for budget
/// tables of one dataset.
pub fn dataset_table(rows: &[Row], target: (f64, f64), horizontal: bool, vertical: bool) -> String {
    let mut s = String::new();
    let mut line = |l: String| {
        s.push_str(&l);
        s.push('\n');
    };
    line(format!(
        "{:<34} {:<20} {:>6} {:>5} {:>6} {:>7} {:>6} {:>6} {:>7} {:>6} {:>12} {:>6}",
        "session",
        "photo",
        "found",
        "n",
        "x r",
        "x ratio",
        "x gain",
        "y r",
        "y ratio",
        "y gain",
        "yaw deg",
        "yaw r"
    ));
    for r in rows {
        let yaw = r
            .yaw
            .map_or("-".to_string(), |(lo, hi)| format!("{lo:5.1}..{hi:4.1}"));
        let yaw_r = r.yaw_r.map_or("-".to_string(), |v| format!("{v:.3}"));
        line(format!(
            "{:<34} {:<20} {:5.1}% {:5} {:6.3} {:7.2} {:6.2} {:6.3} {:7.2} {:6.2} {:>12} {:>6}",
            r.session,
            r.photo,
            100.0 * r.found,
            r.frames,
            f(r.x.r),
            f(r.x.ratio),
            f(r.x.gain),
            f(r.y.r),
            f(r.y.ratio),
            f(r.y.gain),
            yaw,
            yaw_r
        ));
    }
    s.push_str(&summary(rows, target, false));
    s.push_str(&overall(rows, target));
    s.push_str(&refit_line(rows));
    for (on, k, name) in [(vertical, 1, "y"), (horizontal, 0, "x")] {
        if !on {
            continue;
        }
        let mut line = |l: String| {
            s.push_str(&l);
            s.push('\n');
        };
        line(String::new());
        line(format!(
            "{:<34} {:>6} {:>9} {:>11} {:>15} {:>6}",
            "session",
            format!("{name} r"),
            "signal px",
            "iris err px",
            format!("{name} r, drawn iris"),
            format!("{name} gain")
        ));
        let mut without = 0;
        for r in rows {
            let Some(b) = r.budget else {
                without += 1;
                continue;
            };
            let a = if k == 0 { r.x } else { r.y };
            line(format!(
                "{:<34} {:6.3} {:9.2} {:11.2} {:15.3} {:6.2}",
                r.session,
                f(a.r),
                f(b[k].movement_px),
                f(b[k].iris_error_px),
                f(b[k].r_drawn_iris),
                f(a.gain)
            ));
        }
        if without > 0 {
            line(format!(
                "({without} session(s) without a budget: not read by the face detector's pipeline, or no truth CSV)"
            ));
        }
    }
    s
}

/// One line over every session of every class: per axis, how many
/// amplitude ratios fall outside `target`, the median |ratio - 1|, the
/// median r and the mean |gain - 1| (the figures docs/PERFORMANCE.md
/// compares variants of the default by). Null values are left out.
pub fn overall(rows: &[Row], target: (f64, f64)) -> String {
    let median3 = |v: Vec<f64>| {
        let v: Vec<f64> = v.into_iter().filter(|x| x.is_finite()).collect();
        median(&v).map_or("n/a".to_string(), |m| format!("{m:.3}"))
    };
    let axis = |name: &str, get: &dyn Fn(&Row) -> Axis| {
        let ratios: Vec<f64> = rows
            .iter()
            .filter_map(|r| get(r).ratio)
            .filter(|v| v.is_finite())
            .collect();
        let gain_errors: Vec<f64> = rows
            .iter()
            .filter_map(|r| get(r).gain)
            .filter(|v| v.is_finite())
            .map(|g| (g - 1.0).abs())
            .collect();
        format!(
            "{name}: ratio outside {}-{} {} of {}, median |ratio - 1| {}, median r {}, mean |gain - 1| {}",
            target.0,
            target.1,
            count_outside(&ratios, target),
            ratios.len(),
            median3(ratios.iter().map(|v| (v - 1.0).abs()).collect()),
            median3(rows.iter().filter_map(|r| get(r).r).collect()),
            mean(&gain_errors).map_or("n/a".to_string(), |m| format!("{m:.3}")),
        )
    };
    format!(
        "all {} sessions: {}; {}\n",
        rows.len(),
        axis("x", &|r| r.x),
        axis("y", &|r| r.y)
    )
}

/// How many of `values` fall outside `target` (inclusive bounds).
fn count_outside(values: &[f64], target: (f64, f64)) -> usize {
    values
        .iter()
        .filter(|&&v| !(target.0..=target.1).contains(&v))
        .count()
}

/// One line per class: ranges of found share, r and amplitude ratio per
/// axis; `pooled`, also the means of r and of |gain - 1| and how many
/// amplitude ratios fall outside `target` (the figures a comparison over
/// seeds rests on: one run moves single sessions by about 0.01). Null
/// values are left out of ranges and means.
pub fn summary(rows: &[Row], target: (f64, f64), pooled: bool) -> String {
    let mut classes: Vec<&str> = rows.iter().map(|r| r.class.as_str()).collect();
    classes.sort();
    classes.dedup();
    let mut s = String::new();
    for cls in classes {
        let sel: Vec<&Row> = rows.iter().filter(|r| r.class == cls).collect();
        let vals = |get: &dyn Fn(&Row) -> Option<f64>| -> Vec<f64> {
            sel.iter()
                .filter_map(|r| get(r))
                .filter(|v| v.is_finite())
                .collect()
        };
        let range = |v: Vec<f64>, digits: usize| {
            let lo = v.iter().cloned().fold(f64::INFINITY, f64::min);
            let hi = v.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
            if v.is_empty() {
                "n/a".to_string()
            } else {
                format!("{lo:.digits$}-{hi:.digits$}")
            }
        };
        s.push_str(&format!(
            "{cls}: {} sessions, found {} %, x r {}, x ratio {}, y r {}, y ratio {}\n",
            sel.len(),
            range(vals(&|r| Some(100.0 * r.found)), 1),
            range(vals(&|r| r.x.r), 3),
            range(vals(&|r| r.x.ratio), 2),
            range(vals(&|r| r.y.r), 3),
            range(vals(&|r| r.y.ratio), 2),
        ));
        if pooled {
            let m = |v: Vec<f64>| mean(&v).unwrap_or(f64::NAN);
            let outside = |get: &dyn Fn(&Row) -> Option<f64>| count_outside(&vals(get), target);
            s.push_str(&format!(
                "  mean x r {:.4}, mean y r {:.3}, mean |x gain - 1| {:.3}, mean |y gain - 1| {:.3}, \
                 ratios outside {}-{}: x {}, y {} of {}\n",
                m(vals(&|r| r.x.r)),
                m(vals(&|r| r.y.r)),
                m(vals(&|r| r.x.gain.map(|g| (g - 1.0).abs()))),
                m(vals(&|r| r.y.gain.map(|g| (g - 1.0).abs()))),
                target.0,
                target.1,
                outside(&|r| r.x.ratio),
                outside(&|r| r.y.ratio),
                sel.len()
            ));
        }
    }
    s
}

/// `cargo xtask face-table`.
pub fn run(root: &Path, a: &Args) -> Result<()> {
    // Every folder checked before any evaluation starts.
    for d in &a.datasets {
        for need in ["labels.csv", "metadata.json"] {
            if !d.join(need).is_file() {
                bail!(
                    "{}: no such file (is {} a dataset folder written by `eyereplay generate`?)",
                    d.join(need).display(),
                    d.display()
                );
            }
        }
    }
    if a.evaluate {
        let bin = a
            .eyereplay
            .clone()
            .unwrap_or_else(|| root.join("target/release/eyereplay"));
        if !bin.is_file() {
            bail!(
                "{}: not built (cargo build --release -p eyereplay-cli, or pass --eyereplay)",
                bin.display()
            );
        }
        for d in &a.datasets {
            let mut cmd = Command::new(&bin);
            cmd.arg("evaluate").arg(d).arg("--read-back-all");
            if let Some(m) = &a.models {
                cmd.arg("--models").arg(m);
            }
            let st = cmd
                .status()
                .with_context(|| format!("running {}", bin.display()))?;
            if !st.success() {
                bail!("eyereplay evaluate {} --read-back-all failed", d.display());
            }
        }
    }
    let mut pooled = vec![];
    let mut target = (0.9, 1.1);
    for (k, d) in a.datasets.iter().enumerate() {
        let (rows, t) = dataset_rows(d)?;
        if a.datasets.len() > 1 {
            println!("{}== {}", if k > 0 { "\n" } else { "" }, d.display());
        }
        print!("{}", dataset_table(&rows, t, a.horizontal, a.vertical));
        target = t;
        pooled.extend(rows);
    }
    if a.datasets.len() > 1 {
        println!();
        println!("pooled over {} datasets:", a.datasets.len());
        print!("{}", summary(&pooled, target, true));
        print!("{}", overall(&pooled, target));
        print!("{}", refit_line(&pooled));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn metrics() -> Value {
        serde_json::json!({
            "visual": {
                "target": {"amplitude_ratio_min": 0.9, "amplitude_ratio_max": 1.1, "r_min": 0.95},
                "sessions": [
                    {"session": "reading/reading_0000.csv", "class": "reading", "n_frames": 688,
                     "detection_rate": 0.9,
                     "x": {"r": 0.99, "amplitude_ratio": 1.0, "gain": 0.98},
                     "y": {"r": 0.8, "amplitude_ratio": 1.2, "gain": 0.96},
                     "head_yaw": {"r": 0.95},
                     "budget": {"frames": 688,
                                "x": {"movement_px": 1.5, "iris_error_px": 0.2, "r_drawn_iris": 0.99},
                                "y": {"movement_px": 0.3, "iris_error_px": 0.5, "r_drawn_iris": 0.95}}},
                    {"session": "reading/reading_0001.csv", "class": "reading", "n_frames": 700,
                     "detection_rate": 1.0,
                     "x": {"r": 0.97, "amplitude_ratio": 0.8, "gain": 1.04},
                     "y": {"r": null, "amplitude_ratio": null, "gain": null}}
                ]
            }
        })
    }

    #[test]
    fn rows_come_from_the_json() {
        let rows = session_rows(&metrics()).unwrap();
        assert_eq!(rows.len(), 2);
        assert_eq!(rows[0].x.r, Some(0.99));
        assert_eq!(rows[0].yaw_r, Some(0.95));
        assert_eq!(rows[0].budget.unwrap()[1].iris_error_px, Some(0.5));
        assert_eq!(rows[1].y.r, None);
        assert_eq!(rows[1].budget, None);
        let none = serde_json::json!({"visual": {"computed": false}});
        assert!(session_rows(&none).is_err());
    }

    #[test]
    fn summary_pools_what_is_there() {
        let rows = session_rows(&metrics()).unwrap();
        let s = summary(&rows, ratio_target(&metrics()), true);
        assert!(
            s.starts_with("reading: 2 sessions, found 90.0-100.0 %, x r 0.970-0.990, x ratio 0.80-1.00, y r 0.800-0.800"),
            "{s}"
        );
        // Means of 0.99 and 0.97; |gain - 1| 0.02 and 0.04; one x ratio
        // (0.8) and one y ratio (1.2) outside 0.9-1.1.
        assert!(
            s.contains(
                "mean x r 0.9800, mean y r 0.800, mean |x gain - 1| 0.030, mean |y gain - 1| 0.040"
            ),
            "{s}"
        );
        assert!(s.contains("ratios outside 0.9-1.1: x 1, y 1 of 2"), "{s}");
        let t = dataset_table(&rows, (0.9, 1.1), true, true);
        assert!(t.contains("(1 session(s) without a budget"), "{t}");
        // x ratios 1.0 and 0.8: one outside, |ratio - 1| 0 and 0.2, median
        // 0.1; r 0.99 and 0.97, median 0.98; gains 0.98 and 1.04, mean
        // |gain - 1| 0.03. y: the one ratio 1.2, r 0.8, gain 0.96.
        assert!(
            t.contains(
                "all 2 sessions: x: ratio outside 0.9-1.1 1 of 2, median |ratio - 1| 0.100, \
                 median r 0.980, mean |gain - 1| 0.030; y: ratio outside 0.9-1.1 1 of 1, \
                 median |ratio - 1| 0.200, median r 0.800, mean |gain - 1| 0.040"
            ),
            "{t}"
        );
    }

    #[test]
    fn the_refit_is_compared_with_the_probe_where_it_refined() {
        // Probe ny/ny 0.40, refit 0.42: 1.05, within 5 %.
        let id = serde_json::json!({"readback_match": {
            "refined": true,
            "probe_response": {"a": [[0.6, 0.0], [0.0, 0.40]], "b": [0.0, 0.0]}}});
        let map = serde_json::json!({"extractor_response": {"a": [[0.6, 0.0], [0.0, 0.42]], "b": [0.0, 0.0]}});
        let g = refit_over_probe_y(&id, &map).unwrap();
        assert!((g - 1.05).abs() < 1e-12, "{g}");
        // Not refined, or no read-back match: nothing to compare.
        let mut kept = id.clone();
        kept["readback_match"]["refined"] = false.into();
        assert_eq!(refit_over_probe_y(&kept, &map), None);
        assert_eq!(refit_over_probe_y(&serde_json::json!({}), &map), None);
        let mut rows = session_rows(&metrics()).unwrap();
        assert_eq!(refit_line(&rows), "");
        // 0.60 and 1.02 (0.51 over 0.50): one of two within 0.95-1.05.
        rows[0].refit_over_probe_y = Some(0.6);
        rows[1].refit_over_probe_y = Some(0.51 / 0.5);
        assert_eq!(
            refit_line(&rows),
            "read-back match: vertical gain refit over the probe's 0.60-1.02, \
             within 0.95-1.05 in 1 of 2 refined sessions\n"
        );
    }
}
