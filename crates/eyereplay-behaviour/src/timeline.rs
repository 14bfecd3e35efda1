//! A gaze plan (where the eye goes, when) and its synthesis into samples.
//!
//! The models below write a [`Plan`]: a list of shifts (at `t_s` the eye
//! starts a saccade to `to`, an eye-in-head rotation), blink intervals,
//! head-nod intervals and the intervals in which the person reads. The
//! plan is turned into samples at [`SAMPLE_RATE_HZ`]: saccades follow the
//! person's main sequence; between them the eye drifts (Brownian motion)
//! and makes microsaccades; during a nod the eye counter-rotates against
//! the head (the vestibulo-ocular reflex keeps gaze on the target, so the
//! eye in the head moves opposite to the nod).

use crate::geometry::{Angles, Gains};
use crate::saccade::{MainSequence, SaccadeShape};
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use serde::{Deserialize, Serialize};

/// Rate of the synthesized samples. The pipeline low-pass filters and
/// decimates them to the dataset's frame rate as it does a 500 Hz tracker,
/// so a saccade looks in a 25 fps frame as it would to a fast tracker.
pub const SAMPLE_RATE_HZ: f64 = 500.0;

/// A saccade starting at `t_s` towards `to`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Shift {
    pub t_s: f64,
    pub to: Angles,
}

/// A head nod: the head pitches `amp_deg` at `freq_hz` for `cycles`
/// cycles; the eye counter-rotates.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Nod {
    pub t_s: f64,
    pub amp_deg: f64,
    pub freq_hz: f64,
    pub cycles: f64,
}

/// Fixational eye movements of one person.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Fixational {
    /// Drift diffusion coefficient, deg^2/s.
    pub drift_deg2_per_s: f64,
    /// Microsaccades per second of fixation.
    pub microsaccade_hz: f64,
    /// Median microsaccade amplitude, deg.
    pub microsaccade_deg: f64,
}

/// What a model planned; [`Plan::synthesize`] makes samples of it.
#[derive(Clone, Debug, Default)]
pub struct Plan {
    pub start: Angles,
    pub shifts: Vec<Shift>,
    /// `[start, end)` of each blink, s.
    pub blinks: Vec<[f64; 2]>,
    pub nods: Vec<Nod>,
    /// `[start, end)` of each stretch of reading, s.
    pub reading: Vec<[f64; 2]>,
    /// Where the head turns, and when (`to` relative to where it points
    /// at the start): the eye saccades to the gaze target first, then
    /// counter-rotates while the head follows with time constant
    /// `head_tau_s`, as in natural eye-head gaze shifts.
    pub head: Vec<Shift>,
    pub head_tau_s: f64,
    /// Continuous head sway as sinusoids `(amplitude deg, frequency Hz,
    /// phase rad)` on yaw and pitch; the eye counter-rotates (VOR).
    pub sway: Vec<Sway>,
}

/// One sinusoid of head sway on one axis.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Sway {
    pub amp_deg: f64,
    pub freq_hz: f64,
    pub phase: f64,
    /// Yaw (true) or pitch.
    pub yaw: bool,
}

/// One synthesized sample.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlanSample {
    pub t_s: f64,
    /// Normalized iris position.
    pub n: [f64; 2],
    pub blink: bool,
}

impl Plan {
    /// Samples from 0 to `duration_s` at [`SAMPLE_RATE_HZ`].
    pub fn synthesize(
        &self,
        duration_s: f64,
        ms: &MainSequence,
        fix: &Fixational,
        gains: &Gains,
        rng: &mut ChaCha8Rng,
    ) -> Vec<PlanSample> {
        let dt = 1.0 / SAMPLE_RATE_HZ;
        let n = (duration_s * SAMPLE_RATE_HZ).round() as usize;
        let mut out = Vec::with_capacity(n);
        let sigma = (2.0 * fix.drift_deg2_per_s * dt).sqrt();
        let step = Normal::new(0.0, sigma.max(1e-12)).expect("finite sigma");
        let micro_p = fix.microsaccade_hz * dt;
        // The planned position the eye holds, the saccade under way (start,
        // from, to, waveform), and the fixational offset (drift plus
        // microsaccades).
        let mut base = self.start;
        let mut sacc: Option<(f64, Angles, Angles, SaccadeShape)> = None;
        let mut offset = Angles::default();
        let mut micro: Option<(f64, Angles, Angles, SaccadeShape)> = None;
        let mut next_shift = 0;
        let (mut head, mut head_to, mut next_head) = (Angles::default(), Angles::default(), 0);
        let head_k = if self.head_tau_s > 0.0 {
            1.0 - (-dt / self.head_tau_s).exp()
        } else {
            1.0
        };
        let mut blink_i = 0;
        let mut nod_i = 0;
        // Head sway by rotating phasors: (amplitude, yaw?, cos, sin, cos step, sin step).
        let mut sway: Vec<(f64, bool, f64, f64, f64, f64)> = self
            .sway
            .iter()
            .map(|w| {
                let d = std::f64::consts::TAU * w.freq_hz * dt;
                (
                    w.amp_deg,
                    w.yaw,
                    w.phase.cos(),
                    w.phase.sin(),
                    d.cos(),
                    d.sin(),
                )
            })
            .collect();
        for i in 0..n {
            let t = i as f64 * dt;
            while next_shift < self.shifts.len() && self.shifts[next_shift].t_s <= t {
                let s = self.shifts[next_shift];
                // From where the eye is, fixational offset included.
                let from = current(base, &sacc, t).plus(offset);
                sacc = Some((s.t_s, from, s.to, ms.shape(from.distance(s.to))));
                base = s.to;
                // A saccade lands where it was aimed; drift starts anew.
                offset = Angles::default();
                micro = None;
                next_shift += 1;
            }
            if let Some((t0, _, _, shape)) = &sacc {
                if t - t0 >= shape.span {
                    sacc = None;
                }
            }
            let gaze = current(base, &sacc, t);
            while next_head < self.head.len() && self.head[next_head].t_s <= t {
                head_to = self.head[next_head].to;
                next_head += 1;
            }
            head = head.plus(head_to.minus(head).scale(head_k));
            if sacc.is_none() {
                match &micro {
                    Some((t0, from, to, shape)) => {
                        let u = shape.progress(t - t0);
                        offset = from.lerp(*to, u);
                        if u >= 1.0 {
                            micro = None;
                        }
                    }
                    None => {
                        if sigma > 0.0 {
                            offset = offset
                                .plus(Angles::new(step.sample(&mut *rng), step.sample(&mut *rng)));
                        }
                        if rng.gen::<f64>() < micro_p {
                            // Microsaccades tend to correct drift: aim back
                            // past the target by a random amount.
                            let amp = fix.microsaccade_deg * (0.5 + rng.gen::<f64>());
                            let dir = rng.gen::<f64>() * std::f64::consts::TAU;
                            let to = offset
                                .scale(0.3)
                                .plus(Angles::new(amp * dir.cos(), amp * dir.sin()));
                            micro = Some((t, offset, to, ms.shape(offset.distance(to))));
                        }
                    }
                }
            }
            // Head nods: the eye turns against the head to hold the target.
            while nod_i < self.nods.len() && nod_end(&self.nods[nod_i]) <= t {
                nod_i += 1;
            }
            let mut vor = 0.0;
            if let Some(nd) = self.nods.get(nod_i) {
                if t >= nd.t_s {
                    let ph = (t - nd.t_s) * nd.freq_hz * std::f64::consts::TAU;
                    vor = -nd.amp_deg * ph.sin();
                }
            }
            while blink_i < self.blinks.len() && self.blinks[blink_i][1] <= t {
                blink_i += 1;
            }
            let blink = self
                .blinks
                .get(blink_i)
                .is_some_and(|b| t >= b[0] && t < b[1]);
            let (mut sway_yaw, mut sway_pitch) = (0.0, 0.0);
            for (amp, yaw, c, s, dc, ds) in sway.iter_mut() {
                let v = *amp * *s;
                if *yaw {
                    sway_yaw -= v;
                } else {
                    sway_pitch -= v;
                }
                (*c, *s) = (*c * *dc - *s * *ds, *s * *dc + *c * *ds);
            }
            let eye = gaze
                .minus(head)
                .plus(offset)
                .plus(Angles::new(sway_yaw, vor + sway_pitch));
            out.push(PlanSample {
                t_s: t,
                n: gains.to_norm(eye),
                blink,
            });
        }
        out
    }
}

fn nod_end(n: &Nod) -> f64 {
    n.t_s + n.cycles / n.freq_hz
}

fn current(base: Angles, sacc: &Option<(f64, Angles, Angles, SaccadeShape)>, t: f64) -> Angles {
    match sacc {
        Some((t0, from, to, shape)) => from.lerp(*to, shape.progress(t - t0)),
        None => base,
    }
}

/// Blinks as a Poisson process of `per_min` a minute over `[0, duration_s)`,
/// each lasting 100-250 ms (a full lid closure at video rates), none
/// overlapping.
pub fn poisson_blinks(per_min: f64, duration_s: f64, rng: &mut ChaCha8Rng) -> Vec<[f64; 2]> {
    let mut out = Vec::new();
    if per_min <= 0.0 {
        return out;
    }
    let rate = per_min / 60.0;
    let mut t = 0.0;
    loop {
        t += -(1.0 - rng.gen::<f64>()).ln() / rate;
        if t >= duration_s {
            return out;
        }
        let d = 0.1 + 0.15 * rng.gen::<f64>();
        out.push([t, (t + d).min(duration_s)]);
        t += d;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    /// Samples of `plan` with no fixational movement, default eye.
    fn still(plan: &Plan, duration_s: f64) -> Vec<PlanSample> {
        let fix = Fixational {
            drift_deg2_per_s: 0.0,
            microsaccade_hz: 0.0,
            microsaccade_deg: 0.0,
        };
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        plan.synthesize(
            duration_s,
            &MainSequence::default(),
            &fix,
            &Gains::default(),
            &mut rng,
        )
    }

    #[test]
    fn a_planned_shift_arrives_and_stays_without_noise() {
        let plan = Plan {
            start: Angles::new(0.0, 0.0),
            shifts: vec![Shift {
                t_s: 0.1,
                to: Angles::new(10.0, 0.0),
            }],
            ..Plan::default()
        };
        let s = still(&plan, 0.5);
        assert_eq!(s.len(), 250);
        assert_eq!(s[0].n, [0.5, 0.5]);
        // 10 deg right: nx = 0.5 - 0.061.
        assert!((s[249].n[0] - 0.439).abs() < 1e-12);
        // The saccade takes 10/600 + 4 * 6/600 s = 56.7 ms: done by 0.16 s.
        assert!((s[80].n[0] - 0.439).abs() < 1e-12);
        assert!(s[51].n[0] < 0.5 && s[51].n[0] > 0.439);
    }

    #[test]
    fn the_eye_counter_rotates_while_the_head_follows() {
        // Gaze 10 deg right at 0.1 s; the head takes 4 deg from 0.15 s with
        // a 0.2 s time constant. The eye in the head goes out to 10 deg,
        // then back to 10 - 4 = 6 deg: at 0.15 + 0.2 s it is 4 (1 - 1/e)
        // = 2.528 deg back.
        let plan = Plan {
            shifts: vec![Shift {
                t_s: 0.1,
                to: Angles::new(10.0, 0.0),
            }],
            head: vec![Shift {
                t_s: 0.15,
                to: Angles::new(4.0, 0.0),
            }],
            head_tau_s: 0.2,
            ..Plan::default()
        };
        let g = Gains::default();
        let s = still(&plan, 2.0);
        let yaw = |i: usize| (0.5 - s[i].n[0]) / g.nx_per_deg;
        // 0.35 s is sample 175 (the per-sample approach is within 0.02 deg).
        assert!(
            (yaw(175) - (10.0 - 4.0 * (1.0 - (-1.0f64).exp()))).abs() < 0.02,
            "{}",
            yaw(175)
        );
        assert!((yaw(999) - 6.0).abs() < 1e-3);
        // Out fast: within 60 ms of the saccade's start the eye is past 9 deg.
        assert!(yaw(80) > 9.0, "{}", yaw(80));
    }

    #[test]
    fn blink_rate_is_what_was_asked() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let b = poisson_blinks(20.0, 3600.0, &mut rng);
        // 1200 expected in an hour; Poisson sd ~35.
        assert!((b.len() as f64 - 1200.0).abs() < 150.0, "{}", b.len());
        assert!(b.windows(2).all(|w| w[0][1] <= w[1][0]));
    }
}
