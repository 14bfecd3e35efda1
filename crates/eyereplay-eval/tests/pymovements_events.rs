//! The evaluation's fixations and saccades against pymovements' own event
//! detection and measures on the same trajectories, stored in
//! tests/data/pymovements_events.json by scripts/dev/pymovements_reference.sh
//! (pymovements pinned): two 30-s sessions of the bundled default.
//!
//! pymovements is given each frame-to-frame step's velocity at the step's
//! first frame; its `ivt` (below 5 px/frame) and `microsaccades` with a fixed
//! threshold (above 15 px/frame) then find runs of steps k0..k1. eyereplay's
//! event for the same run spans the frames the steps join, k0..k1 + 1. The
//! script says why each measure is taken over which frames.

use eyereplay_eval::{detect_events, EventKind, IvtThresholds, MetricSamples};
use serde_json::Value;

fn reference() -> Value {
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/data/pymovements_events.json"
    ))
    .unwrap();
    serde_json::from_str(&text).unwrap()
}

fn floats(v: &Value) -> Vec<f64> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect()
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-9 * a.abs().max(b.abs()).max(1.0)
}

#[test]
fn fixations_and_saccades_are_pymovements_ivt_runs_event_for_event() {
    let doc = reference();
    let fps = doc["fps"].as_f64().unwrap();
    let thr = IvtThresholds::default();
    // The reference was made with the thresholds the evaluation uses.
    assert_eq!(
        doc["fixation_below_px_per_frame"].as_f64().unwrap(),
        thr.fixation_below_px_per_frame
    );
    assert_eq!(
        doc["saccade_above_px_per_frame"].as_f64().unwrap(),
        thr.saccade_above_px_per_frame
    );
    let segments = doc["segments"].as_array().unwrap();
    assert_eq!(segments.len(), 2);
    let mut compared = 0;
    for seg in segments {
        let name = seg["name"].as_str().unwrap();
        let (x, y) = (floats(&seg["x"]), floats(&seg["y"]));
        let points: Vec<[f64; 2]> = x.iter().zip(&y).map(|(&x, &y)| [x, y]).collect();
        let events = detect_events(&points, &thr);
        let of = |kind| -> Vec<_> { events.iter().filter(|e| e.kind == kind).collect() };
        let (fixations, saccades) = (of(EventKind::Fixation), of(EventKind::Saccade));

        let want_fix = seg["fixations"].as_array().unwrap();
        let want_sac = seg["saccades"].as_array().unwrap();
        // Enough of each for the comparison to mean something.
        assert!(want_fix.len() >= 40 && want_sac.len() >= 40, "{name}");
        assert_eq!(fixations.len(), want_fix.len(), "{name}: fixations");
        assert_eq!(saccades.len(), want_sac.len(), "{name}: saccades");
        let step = |w: &Value, k: &str| w[k].as_u64().unwrap() as usize;
        // Each event: the same run of steps (its frames k0..k1 + 1), and the
        // measure pymovements gives it, in eyereplay's unit.
        let same_events = |kind: &str,
                           got: &[&eyereplay_eval::Event],
                           want: &[Value],
                           (key, per): (&str, f64),
                           ours: fn(&eyereplay_eval::Event) -> f64| {
            for (got, want) in got.iter().zip(want) {
                let (k0, k1) = (step(want, "onset_step"), step(want, "offset_step"));
                assert_eq!(
                    (got.onset_frame, got.offset_frame),
                    (k0, k1 + 1),
                    "{name}: {kind}"
                );
                let theirs = want[key].as_f64().unwrap() / per;
                assert!(
                    close(ours(got), theirs),
                    "{name}: {kind} at frame {k0}: {key} {} (ours), pymovements {theirs}",
                    ours(got)
                );
            }
        };
        same_events(
            "fixation",
            &fixations,
            want_fix,
            ("dispersion_px", 1.0),
            |e| e.dispersion_px,
        );
        // pymovements' peak velocity is in px/s, ours in px/frame.
        same_events(
            "saccade",
            &saccades,
            want_sac,
            ("peak_velocity_px_per_s", fps),
            |e| e.peak_speed_px_per_frame,
        );
        // The pooled samples the distributional table compares are the same
        // events: a fixation lasts its steps, one frame more than
        // pymovements' offset - onset (which counts from the first slow
        // step's frame to the last one's).
        let mut samples = MetricSamples::default();
        samples.add_segment(&points, &thr);
        let durations: Vec<f64> = want_fix
            .iter()
            .map(|w| (step(w, "offset_step") - step(w, "onset_step") + 1) as f64)
            .collect();
        assert_eq!(samples.fixation_duration_frames, durations, "{name}");
        compared += want_fix.len() + want_sac.len();
    }
    println!("{compared} events agree with pymovements");
}
