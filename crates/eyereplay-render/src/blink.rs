//! Blink animation. Lid closure over time follows the measured shape of
//! spontaneous blinks: a fast closing phase (about 80 ms), a short closed
//! phase, and a slower opening phase (about 200 ms).

use crate::rng::SplitMix64;

const CLOSE_S: f64 = 0.08;
const OPEN_S: f64 = 0.20;

/// Closure (0 open, 1 closed) at `t_s` for a blink starting at `onset_s`
/// whose lids stay fully closed for `hold_s`.
pub fn closure_at(t_s: f64, onset_s: f64, hold_s: f64) -> f64 {
    let dt = t_s - onset_s;
    if dt < 0.0 {
        0.0
    } else if dt < CLOSE_S {
        let x = dt / CLOSE_S;
        x * x * (3.0 - 2.0 * x)
    } else if dt < CLOSE_S + hold_s {
        1.0
    } else if dt < CLOSE_S + hold_s + OPEN_S {
        let x = (dt - CLOSE_S - hold_s) / OPEN_S;
        // Opening decelerates: fast at first, slow as the lid reaches rest.
        (1.0 - x).powi(2)
    } else {
        0.0
    }
}

/// Per-frame lid closure in [0, 1].
///
/// `flags` marks frames where the source saw a blink: each run of flagged
/// frames becomes one blink, fully closed on every flagged frame (closing
/// starts 80 ms before the run, opening after it). With `natural_rate_per_min`, blinks
/// are also placed at random (seeded, at least 1.5 s apart) where none are
/// flagged.
pub fn closure_track(
    frames: usize,
    fps: f64,
    flags: Option<&[bool]>,
    natural_rate_per_min: Option<f64>,
    seed: u64,
) -> Vec<f64> {
    let mut events: Vec<(f64, f64)> = Vec::new(); // (onset_s, hold_s)
    if let Some(f) = flags {
        let mut i = 0;
        while i < f.len().min(frames) {
            if f[i] {
                let start = i;
                while i < f.len().min(frames) && f[i] {
                    i += 1;
                }
                // The source saw closed eyes on the flagged frames: start
                // closing just before the first so the lids are shut on
                // every flagged frame, and open after the last.
                let first_s = start as f64 / fps;
                let last_s = (i - 1) as f64 / fps;
                // Half a frame of slack keeps the last flagged frame fully
                // closed despite rounding.
                events.push((first_s - CLOSE_S, last_s - first_s + 0.5 / fps));
            } else {
                i += 1;
            }
        }
    }
    if let Some(rate) = natural_rate_per_min.filter(|r| *r > 0.0) {
        let mut rng = SplitMix64::new(seed ^ 0xB11E);
        let dur_s = frames as f64 / fps;
        let mean_gap = 60.0 / rate;
        let flagged = events.clone();
        let mut t = rng.range(0.2, mean_gap);
        while t < dur_s {
            let clear = flagged
                .iter()
                .all(|(o, h)| t + 0.4 < *o || t > o + h + CLOSE_S + OPEN_S + 1.5);
            if clear {
                events.push((t, rng.range(0.0, 0.05)));
            }
            // Exponential gaps (Poisson process), floored so blinks do not overlap.
            t += (-mean_gap * (1.0 - rng.f64()).ln()).max(1.5);
        }
    }
    (0..frames)
        .map(|i| {
            let t = i as f64 / fps;
            events
                .iter()
                .map(|(o, h)| closure_at(t, *o, *h))
                .fold(0.0, f64::max)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    #[test]
    fn profile_closes_fast_and_opens_slowly() {
        assert_eq!(closure_at(-0.01, 0.0, 0.0), 0.0);
        assert_eq!(closure_at(0.08, 0.0, 0.0), 1.0);
        assert!((closure_at(0.04, 0.0, 0.0) - 0.5).abs() < 1e-12);
        // Halfway through opening the lid is still 1/4 closed.
        assert!((closure_at(0.08 + 0.1, 0.0, 0.0) - 0.25).abs() < 1e-12);
        assert_eq!(closure_at(0.5, 0.0, 0.0), 0.0);
    }
    #[test]
    fn flagged_run_closes_and_natural_rate_is_close() {
        let mut flags = vec![false; 50];
        for f in &mut flags[10..14] {
            *f = true;
        }
        let c = closure_track(50, 25.0, Some(&flags), None, 1);
        assert_eq!(c[7], 0.0);
        // Half closed 40 ms before the run (halfway through the 80 ms close).
        assert!((c[9] - 0.5).abs() < 1e-6, "{}", c[9]);
        assert!(c[10..14].iter().all(|&v| v == 1.0), "{:?}", &c[9..16]);
        // 60 ms into the 200 ms opening: (1 - 0.3)^2 closed.
        assert!((c[15] - 0.49).abs() < 1e-6, "{}", c[15]);
        assert_eq!(c[30], 0.0);
        // 10 minutes at 15 blinks/min: expect about 150 closed frames groups.
        let c = closure_track(25 * 600, 25.0, None, Some(15.0), 7);
        let onsets = c.windows(2).filter(|w| w[0] < 0.5 && w[1] >= 0.5).count();
        assert!((100..=170).contains(&onsets), "{onsets}");
        assert_eq!(c, closure_track(25 * 600, 25.0, None, Some(15.0), 7));
    }
}
