use super::Bars;
use eyereplay_protocols::localization_eval::{
    AnswerResult, ExtractorMatched, FeatureAuroc, MethodResult, WindowCalibration,
};
use eyereplay_protocols::{evaluate_localization, evaluate_spliced, SpliceOptions};
use std::path::PathBuf;

/// When does someone read? Scores reading segments against known ones.
///
/// On every session of DATASET with a per-frame `reading` column (made by
/// the behaviour models' interview scenarios), finds reading segments with
/// the detector MODEL, once per way of turning window scores into frames
/// (the mean of overlapping windows; the same smoothed by a two-state
/// hidden Markov model; the model's segments with their ends moved to the
/// window mean's crossings), and prints per method: segment F1 at IoU 0.5,
/// the median onset error, and the share of not-reading time called
/// reading; for `detect`'s method also where its segments' ends fall
/// against the true ones, signed (late or early). The sessions'
/// trajectories are scored (no video needed), or with --input extracted
/// what the extractor reads from their videos, or with --input drawn the
/// drawn eyes' own positions (what a perfect extractor would read): drawn
/// against extracted is what the read-back loses. It lists the read
/// answers `detect`'s method missed, each with its surface, its best IoU
/// and what else marks it (drawn without the extractor match, joined with
/// another answer into one segment, cut by the session's end); --json
/// keeps every answer. It also scores short clips (3, 5 and 8 s, each
/// wholly reading or wholly not) as `detect` scores a clip shorter than
/// one window.
///
/// With --spliced PROTOCOL instead of DATASET: the real eye-tracker
/// recordings of a detector protocol (docs/DETECTOR.md) cut into pieces
/// and joined into mixed streams, reading and not reading in turn by
/// different people, scored the same way (clean, with webcam-like white
/// noise, and rendered then read back when --rendered-from names that
/// protocol's output); and its real webcam talkers localized whole, where
/// every second called reading is a false one.
#[derive(clap::Args)]
// One group, so that the usage line shows the two inputs: `<DATASET|--spliced <PROTOCOL>>`.
#[command(group = clap::ArgGroup::new("what").required(true).args(["dataset", "spliced"]))]
#[command(after_help = "Examples:\n  \
eyereplay prepare --config examples/localize_train.toml \\\n      \
--out out/localize_train\n  \
eyereplay train out/localize_train --input trajectory --frame-labels \\\n      \
--window-s 6 --out out/interview.json\n  \
# other people\n  \
eyereplay prepare --config examples/localize.toml --out out/localize\n  \
eyereplay evaluate-localization out/localize --model out/interview.json\n  \
# rendered interviews (examples/interview_face.toml's header makes them),\n  \
# as a perfect extractor would read them\n  \
eyereplay generate --config examples/interview_face.toml \\\n      \
--out out/interview_test --no-evaluate\n  \
eyereplay evaluate-localization out/interview_test --input drawn \\\n      \
--model out/interview.json\n  \
eyereplay evaluate-localization \\\n      \
--spliced examples/detector/protocol_behaviour.toml \\\n      \
--model out/interview.json")]
pub struct Args {
    /// A dataset folder with interview sessions (`eyereplay prepare` or `generate`).
    pub dataset: Option<PathBuf>,
    /// Real recordings spliced into mixed streams: the recordings of this
    /// detector protocol (`scripts/detector-data.sh` fetches them).
    #[arg(long, value_name = "PROTOCOL")]
    pub spliced: Option<PathBuf>,
    /// With --spliced: the protocol's output folder (`evaluate-detector
    /// --out`), whose renderings of the recordings give the `rendered` streams.
    #[arg(long, value_name = "DIR", requires = "spliced")]
    pub rendered_from: Option<PathBuf>,
    /// With --spliced: how many streams of 5 minutes [default: 20].
    #[arg(long, requires = "spliced", value_parser = clap::value_parser!(u32).range(1..))]
    pub streams: Option<u32>,
    /// Where the short clips (above) are cut and, with --spliced, the
    /// streams' pieces.
    #[arg(long, default_value_t = 1, value_parser = super::values::whole::<u64>)]
    pub seed: u64,
    /// What to score: the sessions' trajectories, what the extractor
    /// reads back from their rendered videos (the user's path), or the
    /// drawn eyes' positions in their apertures (the videos' _truth.csv).
    /// (A dataset only: the spliced streams are what their protocol's
    /// recordings give.)
    #[arg(long, value_enum, default_value_t = super::train::InputArg::Trajectory, conflicts_with = "spliced")]
    pub input: super::train::InputArg,
    /// Extraction cache (default: $EYEREPLAY_CACHE, else $XDG_CACHE_HOME/eyereplay, else ~/.cache/eyereplay).
    #[arg(long, value_name = "DIR")]
    pub cache: Option<PathBuf>,
    /// The detector (`eyereplay train`; default: the built-in one, as for
    /// `detect`).
    #[arg(long, value_name = "FILE")]
    pub model: Option<PathBuf>,
    /// Cut segments where the per-frame probability of reading reaches this.
    #[arg(long, default_value_t = eyereplay::detect::localize::SEGMENT_THRESHOLD, value_parser = super::values::open_fraction)]
    pub threshold: f64,
    /// Also print each of the model's features alone as a score: the
    /// AUROC of each surface's reading windows, and of all of them,
    /// against every talk window (what a kind of reading keeps once drawn
    /// and read back; `--json` keeps them without this).
    #[arg(long, conflicts_with = "spliced")]
    pub by_feature: bool,
    /// Also write every number to this JSON file (a file name, where
    /// `evaluate --json` and `detect --json` print to standard output).
    #[arg(long, value_name = "FILE")]
    pub json: Option<PathBuf>,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    // The JSON is written last: a path it cannot go to is found first.
    if let Some(path) = &args.json {
        let datasets: Vec<&std::path::Path> = args
            .dataset
            .iter()
            .chain(&args.rendered_from)
            .map(|d| d.as_path())
            .collect();
        let inputs: Vec<&std::path::Path> = [args.model.as_ref(), args.spliced.as_ref()]
            .into_iter()
            .flatten()
            .map(|p| p.as_path())
            .collect();
        super::check_json_out(path, "--json", &datasets, &inputs)?;
    }
    // The model first: a bad one stops before any extraction.
    let (model, model_path) = super::detect::load_model(args.model.as_deref())?;
    if let Some(protocol) = &args.spliced {
        return run_spliced(&args, protocol, &model, &model_path);
    }
    // clap lets these through beside DATASET (it conflicts with --spliced,
    // which they require), where they would be ignored.
    for (given, name) in [
        (args.rendered_from.is_some(), "--rendered-from"),
        (args.streams.is_some(), "--streams"),
    ] {
        anyhow::ensure!(
            !given,
            "{name} applies to --spliced streams only, not to a dataset folder"
        );
    }
    let dataset = args.dataset.as_deref().expect("clap requires it");
    let cache = super::cache_dir(args.cache.as_deref())?;
    let detector = eyereplay_protocols::NamedDetector {
        model: &model,
        name: &model_path,
    };
    let ev = evaluate_localization(
        dataset,
        detector,
        args.threshold,
        args.input.into(),
        args.seed,
        &cache,
        &Bars::default(),
    )?;
    println!(
        "{} sessions ({}), {:.0} min, {} reading segments; model {}, segments cut where the per-frame probability reaches {:.3} (--threshold)",
        ev.sessions,
        ev.input,
        ev.seconds / 60.0,
        ev.reading_segments,
        ev.model,
        ev.threshold
    );
    print_methods("", &ev.methods);
    print_calibration("", &ev.calibration);
    if !ev.by_surface.is_empty() {
        println!(
            "by where the text is read from ({:?}, detect's method; a line's visual angle, median over people):",
            eyereplay::detect::localize::DEFAULT_METHOD
        );
        for s in &ev.by_surface {
            let m = &s.result;
            println!(
                "  {:<13} {:>2} sessions, line {:>4.1} deg: {:>2} of {:>2} read stretches found, F1 {:.3}, onset {}, false reading {:.1} %, windows' AUROC {}",
                s.surface,
                s.sessions,
                s.line_span_deg,
                m.segments.matched,
                m.segments.truth,
                m.segments.f1,
                m.onset_error_median_s
                    .map_or("n/a".to_string(), |v| format!("{v:.1} s")),
                100.0 * m.false_reading_fraction,
                s.window_auroc.map_or("n/a".into(), |a| format!("{a:.3}"))
            );
        }
    }
    print_missed(&ev.answers);
    if args.by_feature {
        print_by_feature(&ev);
    }
    println!("short clips, each inside one class, scored as `detect` scores a clip shorter than a window:");
    for c in &ev.clips {
        println!(
            "  {:>4.0} s: {} + {} clips (reading + other), {} refused; AUROC {}; {:.0} % uncertain (interval holds the threshold), the rest {} right; mean interval width {:.2}",
            c.clip_s,
            c.clips_reading,
            c.clips_other,
            c.refused,
            c.auroc.map_or("n/a".into(), |a| format!("{a:.3}")),
            100.0 * c.uncertain_fraction,
            c.decided_accuracy
                .map_or("n/a".into(), |a| format!("{:.1} %", 100.0 * a)),
            c.mean_interval_width
        );
    }
    if let Some(path) = &args.json {
        write_json(path, &ev)?;
    }
    Ok(())
}

/// One row per feature, one column per surface and one for every reading
/// window.
fn print_by_feature(ev: &eyereplay_protocols::localization_eval::LocalizationEval) {
    println!(
        "each feature alone as a score: a surface's reading windows against every talk window ({} + {} windows; AUROC, 0.5 separates nothing, under 0.5 reading scores lower):",
        ev.calibration.windows_reading, ev.calibration.windows_other
    );
    let mut columns: Vec<(&str, &[FeatureAuroc])> = ev
        .by_surface
        .iter()
        .map(|s| (s.surface.as_str(), s.feature_auroc.as_slice()))
        .collect();
    columns.push(("all reading", ev.feature_auroc.as_slice()));
    let mut head = format!("  {:<28}", "feature");
    for &(name, _) in &columns {
        head.push_str(&format!(" {:>w$}", name, w = name.len().max(5)));
    }
    println!("{head}");
    for (k, f) in ev.feature_auroc.iter().enumerate() {
        let mut row = format!("  {:<28}", f.feature);
        for &(name, values) in &columns {
            let cell = values[k]
                .auroc
                .map_or("n/a".to_string(), |a| format!("{a:.3}"));
            row.push_str(&format!(" {:>w$}", cell, w = name.len().max(5)));
        }
        println!("{row}");
    }
}

fn run_spliced(
    args: &Args,
    protocol: &std::path::Path,
    model: &eyereplay::detect::DetectorModel,
    model_path: &std::path::Path,
) -> anyhow::Result<()> {
    if let Some(dir) = &args.rendered_from {
        anyhow::ensure!(
            dir.is_dir(),
            "{}: --rendered-from: no such folder (it is the --out of 'eyereplay evaluate-detector PROTOCOL')",
            dir.display()
        );
    }
    let cache = super::cache_dir(args.cache.as_deref())?;
    let opts = SpliceOptions {
        streams: args
            .streams
            .map_or(SpliceOptions::default().streams, |n| n as usize),
        seed: args.seed,
        ..Default::default()
    };
    let ev = evaluate_spliced(
        protocol,
        eyereplay_protocols::NamedDetector {
            model,
            name: model_path,
        },
        args.threshold,
        &opts,
        args.rendered_from.as_deref(),
        &cache,
        &Bars::default(),
    )?;
    println!(
        "{} streams of {:.0} s from real recordings ({} reading segments): readers {}; others {}",
        opts.streams,
        opts.stream_s,
        ev.reading_segments,
        ev.readers.join(", "),
        ev.others.join(", ")
    );
    println!(
        "model {}, segments cut where the per-frame probability reaches {:.3} (--threshold)",
        ev.model, ev.threshold
    );
    for c in &ev.conditions {
        print_methods(&c.condition, &c.methods);
    }
    for c in &ev.conditions {
        print_calibration(&c.condition, &c.calibration);
    }
    if !ev.webcam.is_empty() {
        println!("real webcam talkers (every reading second is false):");
        for w in &ev.webcam {
            println!(
                "  {:<10} {:>6.1} s, {:>6.1} s scored, {:>5.1} % called reading",
                w.recording,
                w.seconds,
                w.scored_s,
                100.0 * w.false_reading_fraction
            );
        }
        if let Some(f) = ev.webcam_false_reading_fraction {
            println!("  all        false reading time {:.1} %", 100.0 * f);
        }
    }
    if let Some(path) = &args.json {
        write_json(path, &ev)?;
    }
    Ok(())
}

/// The read answers `detect`'s method missed, counted by the
/// circumstances a miss is read against, then one line each.
fn print_missed(answers: &[AnswerResult]) {
    let missed: Vec<&AnswerResult> = answers.iter().filter(|a| !a.found).collect();
    println!(
        "read answers missed ({:?}, not matched at IoU 0.5): {} of {}",
        eyereplay::detect::localize::DEFAULT_METHOD,
        missed.len(),
        answers.len()
    );
    if missed.is_empty() {
        return;
    }
    let count = |f: &dyn Fn(&AnswerResult) -> bool| missed.iter().filter(|a| f(a)).count();
    let mut surfaces: Vec<&str> = missed.iter().filter_map(|a| a.surface.as_deref()).collect();
    surfaces.sort();
    surfaces.dedup();
    if !surfaces.is_empty() {
        let parts: Vec<String> = surfaces
            .iter()
            .map(|s| format!("{s} {}", count(&|a| a.surface.as_deref() == Some(s))))
            .collect();
        println!("  by where the text is read from: {}", parts.join(", "));
    }
    // The extractor match only applies to sessions read back from video.
    let unmatched = if answers.iter().any(|a| a.extractor_match.is_some()) {
        format!(
            "{} drawn without the extractor match, {} matched on one axis only; ",
            count(&|a| a.extractor_match == Some(ExtractorMatched::None)),
            count(&|a| {
                matches!(
                    a.extractor_match,
                    Some(ExtractorMatched::Horizontal | ExtractorMatched::Vertical)
                )
            })
        )
    } else {
        String::new()
    };
    println!(
        "  {unmatched}{} joined with another answer into one segment; {} running to the session's end; {} found in part (best IoU under 0.5), {} not touched",
        count(&|a| a.joined),
        count(&|a| a.at_session_end),
        count(&|a| a.best_iou > 0.0),
        count(&|a| a.best_iou == 0.0),
    );
    for a in missed {
        let mut notes = Vec::new();
        notes.extend(a.extractor_match.and_then(ExtractorMatched::caveat));
        if a.joined {
            notes.push("joined with another answer");
        }
        if a.at_session_end {
            notes.push("at the session's end");
        }
        println!(
            "  {} {:>6.1}-{:>6.1} s {:<13} best IoU {:.2}{}{}",
            a.session,
            a.start_s,
            a.end_s,
            a.surface.as_deref().unwrap_or("-"),
            a.best_iou,
            if notes.is_empty() { "" } else { "; " },
            notes.join(", ")
        );
    }
}

/// Every number, as pretty JSON, written atomically.
fn write_json(path: &std::path::Path, value: &impl serde::Serialize) -> anyhow::Result<()> {
    let mut text = serde_json::to_string_pretty(value)?;
    text.push('\n');
    eyereplay_core::atomic_write(path, text.as_bytes())?;
    Ok(())
}

/// One line on the windows' calibration.
fn print_calibration(condition: &str, c: &WindowCalibration) {
    let label = if condition.is_empty() {
        String::new()
    } else {
        format!("{condition}: ")
    };
    println!(
        "{label}{} + {} windows (reading + other): expected calibration error {:.3}; at the model's window threshold {:.3} (what `detect` calls a reading window; segments are cut from the per-frame probability instead), {:.1} % of other windows called reading (chosen for {:.1} %), {:.1} % of reading windows found",
        c.windows_reading,
        c.windows_other,
        c.expected_calibration_error,
        c.threshold,
        100.0 * c.false_positive_rate,
        100.0 * c.target_false_positive_rate,
        100.0 * c.true_positive_rate
    );
    let f = |v: Option<f64>| v.map_or("n/a".to_string(), |a| format!("{a:.3}"));
    println!(
        "{label}windows' AUROC {} pooled, {} within one recording (mean over the {} with both)",
        f(c.auroc),
        f(c.auroc_within_recording),
        c.recordings_with_both
    );
}

/// The table of one condition's methods.
fn print_methods(condition: &str, methods: &[MethodResult]) {
    println!(
        "{:<10} {:<12} {:>6} {:>9} {:>7} {:>6} {:>6} {:>12} {:>14}",
        "condition", "method", "found", "matched", "F1", "P", "R", "onset med s", "false reading"
    );
    for m in methods {
        println!(
            "{:<10} {:<12} {:>6} {:>9} {:>7.3} {:>6.3} {:>6.3} {:>12} {:>13.1}%",
            condition,
            format!("{:?}", m.method),
            m.segments.found,
            m.segments.matched,
            m.segments.f1,
            m.segments.precision,
            m.segments.recall,
            m.onset_error_median_s
                .map_or("n/a".to_string(), |v| format!("{v:.1}")),
            100.0 * m.false_reading_fraction
        );
    }
    // Where detect's method puts a segment's ends against the true ones,
    // signed: the onset error above is unsigned.
    if let Some(m) = methods
        .iter()
        .find(|m| m.method == eyereplay::detect::localize::DEFAULT_METHOD)
    {
        let signed = |v: Option<f64>| v.map_or("n/a".to_string(), |v| format!("{v:+.1} s"));
        println!(
            "{}ends ({:?}, detect's method): found starts {} from the true ones, found ends {} (medians; + later, - earlier; stretches at a session's start or end left out)",
            if condition.is_empty() { String::new() } else { format!("{condition}: ") },
            m.method,
            signed(m.start_offset_median_s),
            signed(m.end_offset_median_s)
        );
    }
}
