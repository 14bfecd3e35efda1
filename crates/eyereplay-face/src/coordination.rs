//! Eye-head coordination: how a gaze shift is shared between the eye (in
//! the head) and the head, plus slow head drift and sway.
//!
//! # Model
//!
//! Static split, per axis (yaw/horizontal, pitch/vertical), for a gaze
//! target at eccentricity `g` (deg, relative to the head's rest direction):
//!
//! ```text
//! head(g) = 0                           for |g| <= E0
//!         = sign(g) * k * (|g| - E0)    beyond
//! eye(g)  = g - head(g)
//! ```
//!
//! so the head's share `head/g` is 0 for small shifts and grows with the
//! amplitude toward `k`. The rule is fitted to these findings:
//!
//! - Stahl 1999 (Exp Brain Res 126:41-54, PubMed 10333006): an eye-only
//!   range (no head movement) 35.8 +- 31.9 deg wide, different between
//!   people and reproducible within one; beyond it head amplitude grows
//!   with slope 0.77 +- 0.16. Hence per identity `E0 = range / 2` with
//!   range ~ N(35.8, 31.9) clamped to [10, 80] deg, and k ~ N(0.77, 0.16)
//!   clamped to [0.4, 1.0] ([`CoordinationParams::sample`]).
//! - Freedman & Sparks 1997 (J Neurophysiol 77:2328-2348): no head below
//!   about 20 deg horizontally with the eyes centred; less head for more
//!   vertical shifts. Hence the vertical gain is the horizontal one times
//!   [`VERTICAL_GAIN_FACTOR`] (a design choice: the paper gives no number).
//! - Guitton & Volle 1987 (J Neurophysiol 58:427-459): the oculomotor range
//!   is about +-55 deg; the eye-in-head angle is clamped to
//!   [`EYE_RANGE_DEG`].
//!
//! Reading is different (Proudlock, Shekhar & Gottlob 2003, IOVS
//! 44:2991-2998): over A4 text (28.6 deg wide) the head gives 4.7 % of the
//! horizontal and 28.7 % of the vertical gaze shift, less than in a saccade
//! task. [`Task::Reading`] uses these constant shares instead.
//!
//! Dynamics ([`head_track`]): the head follows its target with an onset
//! delay (20-50 ms after the eye for reactive shifts, Ruhland et al. 2015,
//! Computer Graphics Forum, STAR; default 30 ms) and a critically damped
//! second-order response (time constant 80 ms; a 24 deg head movement then
//! peaks near 110 deg/s, the range Andrist et al. 2012 used as a design
//! choice). The gaze itself jumps with the saccade, so the eye-in-head
//! angle `gaze - head` overshoots and then counter-rotates as the head
//! arrives, as the vestibulo-ocular reflex does.
//!
//! Drift and sway ([`Sway`]): a seeded sum of slow sinusoids per axis
//! (0.03-0.4 Hz), a smooth random motion with a set RMS, added to the head.
//! Lee 1999 (Vision Res 39:3761-3768) describes reading head motion as a
//! saccade-coupled part plus a slow drift; the sway is that drift.

use rand::Rng;
use rand_chacha::rand_core::SeedableRng;
use rand_chacha::ChaCha8Rng;

/// The vertical head gain relative to the horizontal one (less head for
/// vertical shifts, Freedman & Sparks 1997; the value is a design choice).
pub const VERTICAL_GAIN_FACTOR: f64 = 0.6;
/// The eye-in-head range, +- deg (Guitton & Volle 1987: about 55).
pub const EYE_RANGE_DEG: f64 = 55.0;

/// Reading shares of the head in the gaze shift (Proudlock et al. 2003, A4 text).
pub const READING_HEAD_SHARE_H: f64 = 0.047;
pub const READING_HEAD_SHARE_V: f64 = 0.287;

/// What the person is doing.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Task {
    /// Looking around (conversation, saccade tasks): the E0/k rule.
    Saccades,
    /// Reading text: constant small shares.
    Reading,
}

/// One person's eye-head coordination.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CoordinationParams {
    /// Half-width of the eye-only range (deg): no head within +-E0.
    pub e0_deg: f64,
    /// Head gain beyond E0, horizontal.
    pub k: f64,
}

impl Default for CoordinationParams {
    /// Stahl 1999's means: a 35.8 deg eye-only range, slope 0.77.
    fn default() -> Self {
        CoordinationParams {
            e0_deg: 35.8 / 2.0,
            k: 0.77,
        }
    }
}

impl CoordinationParams {
    /// A person drawn from Stahl 1999's between-subject spread.
    pub fn sample(rng: &mut impl Rng) -> CoordinationParams {
        let range = (35.8 + 31.9 * std_normal(rng)).clamp(10.0, 80.0);
        let k = (0.77 + 0.16 * std_normal(rng)).clamp(0.4, 1.0);
        CoordinationParams {
            e0_deg: range / 2.0,
            k,
        }
    }

    /// The head's target angles (yaw, pitch) for a gaze at (`h`, `v`) deg.
    pub fn head_target(&self, task: Task, gaze_h_deg: f64, gaze_v_deg: f64) -> (f64, f64) {
        let (h, v) = match task {
            Task::Saccades => (
                self.rule(gaze_h_deg, self.k),
                self.rule(gaze_v_deg, self.k * VERTICAL_GAIN_FACTOR),
            ),
            Task::Reading => (
                READING_HEAD_SHARE_H * gaze_h_deg,
                READING_HEAD_SHARE_V * gaze_v_deg,
            ),
        };
        // Whatever the rule, the eye stays inside its range.
        (
            keep_eye_in_range(gaze_h_deg, h),
            keep_eye_in_range(gaze_v_deg, v),
        )
    }

    fn rule(&self, g: f64, k: f64) -> f64 {
        g.signum() * k * (g.abs() - self.e0_deg).max(0.0)
    }
}

fn keep_eye_in_range(gaze: f64, head: f64) -> f64 {
    let eye = (gaze - head).clamp(-EYE_RANGE_DEG, EYE_RANGE_DEG);
    gaze - eye
}

/// Standard normal by Box-Muller (rand_distr would add a dependency for one call).
fn std_normal(rng: &mut impl Rng) -> f64 {
    let u1: f64 = rng.gen_range(f64::EPSILON..1.0);
    let u2: f64 = rng.gen();
    (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
}

/// Head dynamics.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HeadDynamics {
    /// Delay of the head's response after the gaze target changes (s).
    pub onset_s: f64,
    /// Time constant of the critically damped response (s).
    pub tau_s: f64,
}

impl Default for HeadDynamics {
    fn default() -> Self {
        HeadDynamics {
            onset_s: 0.030,
            tau_s: 0.080,
        }
    }
}

/// Per-sample head and eye-in-head angles (yaw, pitch; deg) for a gaze
/// track sampled every `dt_s`, each sample's head target by its task in
/// `tasks` (the last one past its end: one task for a whole track). The head
/// starts at rest on the first sample's target; `gaze = head + eye` holds
/// at every sample (angles add for the small rotations of a webcam session).
pub fn head_track(
    params: &CoordinationParams,
    dynamics: &HeadDynamics,
    tasks: &[Task],
    gaze_deg: &[(f64, f64)],
    dt_s: f64,
) -> HeadEyeTrack {
    let n = gaze_deg.len();
    if n == 0 {
        return HeadEyeTrack::default();
    }
    let targets: Vec<(f64, f64)> = gaze_deg
        .iter()
        .enumerate()
        .map(|(i, &(h, v))| {
            let task = tasks
                .get(i)
                .or(tasks.last())
                .copied()
                .unwrap_or(Task::Saccades);
            params.head_target(task, h, v)
        })
        .collect();
    let delay = (dynamics.onset_s / dt_s).round() as usize;
    // Critically damped: x'' = w^2 (target - x) - 2 w x', integrated
    // exactly per step for a held target (so the result does not depend on
    // dt beyond the target's sampling).
    let w = 1.0 / dynamics.tau_s;
    let e = (-w * dt_s).exp();
    let step = |x: f64, vel: f64, target: f64| {
        let d = x - target;
        let c2 = vel + w * d;
        let nd = (d + c2 * dt_s) * e;
        let nv = (c2 - w * (d + c2 * dt_s)) * e;
        (target + nd, nv)
    };
    let mut head = Vec::with_capacity(n);
    let mut eye = Vec::with_capacity(n);
    let (mut x, mut vx) = (targets[0].0, 0.0);
    let (mut y, mut vy) = (targets[0].1, 0.0);
    for i in 0..n {
        head.push((x, y));
        eye.push((gaze_deg[i].0 - x, gaze_deg[i].1 - y));
        let t = targets[i.saturating_sub(delay)];
        (x, vx) = step(x, vx, t.0);
        (y, vy) = step(y, vy, t.1);
    }
    HeadEyeTrack {
        head_deg: head,
        eye_deg: eye,
    }
}

/// What [`head_track`] returns, one entry per gaze sample.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct HeadEyeTrack {
    /// Head (yaw, pitch), deg.
    pub head_deg: Vec<(f64, f64)>,
    /// Eye-in-head (yaw, pitch), deg.
    pub eye_deg: Vec<(f64, f64)>,
}

/// Slow head drift and sway: per axis a sum of sinusoids with seeded
/// frequencies (log-uniform in 0.03-0.4 Hz) and phases, scaled to a set
/// RMS. Smooth, zero-mean, deterministic for a seed.
#[derive(Clone, Debug, PartialEq)]
pub struct Sway {
    /// Per axis (yaw, pitch, roll in deg; x, y, z in cm): (freq Hz, phase rad, amplitude).
    axes: [Vec<(f64, f64, f64)>; 6],
}

/// RMS of the sway per axis: yaw, pitch, roll (deg), x, y, z (cm). A design
/// choice for a seated person in a video call.
pub const DEFAULT_SWAY_RMS: [f64; 6] = [1.5, 1.0, 0.7, 0.5, 0.3, 0.5];

impl Sway {
    pub fn new(seed: u64, rms: [f64; 6]) -> Sway {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        const TERMS: usize = 5;
        let axes = rms.map(|r| {
            let mut terms: Vec<(f64, f64, f64)> = (0..TERMS)
                .map(|_| {
                    let f = (0.03f64.ln() + rng.gen::<f64>() * (0.4f64 / 0.03).ln()).exp();
                    let phase = rng.gen::<f64>() * std::f64::consts::TAU;
                    // Slower terms get more amplitude (drift dominates sway).
                    (f, phase, 1.0 / f.sqrt())
                })
                .collect();
            // A sinusoid of amplitude a has RMS a / sqrt(2); independent
            // terms add in power.
            let power: f64 = terms.iter().map(|t| t.2 * t.2 / 2.0).sum();
            let s = r / power.sqrt();
            for t in &mut terms {
                t.2 *= s;
            }
            terms
        });
        Sway { axes }
    }

    /// (yaw, pitch, roll deg, x, y, z cm) at time `t_s`.
    pub fn at(&self, t_s: f64) -> [f64; 6] {
        let mut out = [0.0; 6];
        for (o, terms) in out.iter_mut().zip(&self.axes) {
            *o = terms
                .iter()
                .map(|&(f, ph, a)| a * (std::f64::consts::TAU * f * t_s + ph).sin())
                .sum();
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn static_rule_by_hand() {
        let p = CoordinationParams {
            e0_deg: 20.0,
            k: 0.8,
        };
        // Inside the eye-only range: no head.
        assert_eq!(p.head_target(Task::Saccades, 15.0, -19.0), (0.0, 0.0));
        // 40 deg right: 0.8 * (40 - 20) = 16; 30 deg down: -0.8*0.6*(30-20) = -4.8.
        let (h, v) = p.head_target(Task::Saccades, 40.0, -30.0);
        assert!((h - 16.0).abs() < 1e-12 && (v + 4.8).abs() < 1e-12);
        // Mirror symmetric.
        assert_eq!(p.head_target(Task::Saccades, -40.0, 0.0).0, -16.0);
        // The head's share grows with amplitude.
        let share = |g: f64| p.head_target(Task::Saccades, g, 0.0).0 / g;
        assert!(share(25.0) < share(40.0) && share(40.0) < share(80.0));
        assert!(share(80.0) < p.k);
        // The eye stays within +-55 deg: at 100 deg with k = 0.3 the rule
        // gives 24 deg of head, 76 of eye; the clamp moves the head to 45.
        let q = CoordinationParams {
            e0_deg: 20.0,
            k: 0.3,
        };
        assert!((q.head_target(Task::Saccades, 100.0, 0.0).0 - 45.0).abs() < 1e-12);
    }

    #[test]
    fn reading_shares() {
        let p = CoordinationParams::default();
        let (h, v) = p.head_target(Task::Reading, 14.3, -10.0);
        assert!((h - 0.047 * 14.3).abs() < 1e-12 && (v + 2.87).abs() < 1e-12);
    }

    #[test]
    fn sampled_people_follow_stahl() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let ps: Vec<CoordinationParams> = (0..20000)
            .map(|_| CoordinationParams::sample(&mut rng))
            .collect();
        assert!(ps
            .iter()
            .all(|p| (5.0..=40.0).contains(&p.e0_deg) && (0.4..=1.0).contains(&p.k)));
        // Clamping leaves the medians where Stahl's means are (the normal
        // is symmetric and both clamps lie on opposite sides of it).
        let median = |mut v: Vec<f64>| {
            v.sort_by(f64::total_cmp);
            v[v.len() / 2]
        };
        let k = median(ps.iter().map(|p| p.k).collect());
        assert!((k - 0.77).abs() < 0.01, "{k}");
        let range = median(ps.iter().map(|p| 2.0 * p.e0_deg).collect());
        assert!((range - 35.8).abs() < 1.5, "{range}");
        // The spread: the inter-quartile range of N(m, s) is 1.349 s.
        let mut r: Vec<f64> = ps.iter().map(|p| 2.0 * p.e0_deg).collect();
        r.sort_by(f64::total_cmp);
        let iqr = r[r.len() * 3 / 4] - r[r.len() / 4];
        assert!((iqr / 1.349 - 31.9).abs() < 2.0, "{iqr}");
        // Same seed, same person.
        let a = CoordinationParams::sample(&mut ChaCha8Rng::seed_from_u64(3));
        let b = CoordinationParams::sample(&mut ChaCha8Rng::seed_from_u64(3));
        assert_eq!(a, b);
    }

    #[test]
    fn a_session_that_starts_reading_moves_its_head_as_a_reader() {
        // Gaze held at 50 deg for 4 s; the second half is reading. The
        // head settles at k (50 - E0) = 24 deg while looking, then at the
        // reading share 0.047 x 50 = 2.35 deg.
        let p = CoordinationParams {
            e0_deg: 20.0,
            k: 0.8,
        };
        let gaze = vec![(50.0, 0.0); 4000];
        let tasks: Vec<Task> = (0..4000)
            .map(|i| {
                if i < 2000 {
                    Task::Saccades
                } else {
                    Task::Reading
                }
            })
            .collect();
        let tr = head_track(&p, &HeadDynamics::default(), &tasks, &gaze, 0.001);
        assert!((tr.head_deg[1999].0 - 24.0).abs() < 1e-3);
        assert!((tr.head_deg[3999].0 - READING_HEAD_SHARE_H * 50.0).abs() < 1e-3);
    }

    #[test]
    fn step_response_lags_then_counter_rotates() {
        let p = CoordinationParams {
            e0_deg: 20.0,
            k: 0.8,
        };
        let dyn_ = HeadDynamics::default();
        let dt = 0.001;
        // Gaze at 0, then a 50 deg shift at t = 0.1 s, held 2 s.
        let gaze: Vec<(f64, f64)> = (0..2100)
            .map(|i| if i < 100 { (0.0, 0.0) } else { (50.0, 0.0) })
            .collect();
        let tr = head_track(&p, &dyn_, &[Task::Saccades], &gaze, dt);
        let (head, eye) = (tr.head_deg, tr.eye_deg);
        // Before the onset delay the head has not moved; the eye took the jump.
        assert_eq!(head[129].0, 0.0);
        assert!((eye[129].0 - 50.0).abs() < 1e-12);
        assert!(head[135].0 > 0.0);
        // Settles at k (50 - 20) = 24 deg; the eye counter-rotates to 26.
        let last = head.len() - 1;
        assert!((head[last].0 - 24.0).abs() < 1e-3, "{}", head[last].0);
        assert!((eye[last].0 - 26.0).abs() < 1e-3);
        // gaze = head + eye everywhere; the head never overshoots
        // (critically damped) and the eye-in-head angle only decreases
        // after the shift.
        for i in 100..last {
            assert!((head[i].0 + eye[i].0 - gaze[i].0).abs() < 1e-12);
            assert!(head[i].0 <= 24.0 + 1e-9);
            assert!(eye[i + 1].0 <= eye[i].0 + 1e-12);
        }
        // Peak head velocity of a critically damped step A/(e tau):
        // 24 / (e * 0.08) = 110 deg/s.
        let peak = (1..head.len())
            .map(|i| (head[i].0 - head[i - 1].0) / dt)
            .fold(0.0, f64::max);
        let want = 24.0 / (std::f64::consts::E * 0.08);
        assert!((peak - want).abs() / want < 0.02, "{peak} vs {want}");
    }

    #[test]
    fn sway_is_smooth_seeded_and_has_its_rms() {
        let rms = DEFAULT_SWAY_RMS;
        let a = Sway::new(11, rms);
        assert_eq!(a, Sway::new(11, rms));
        assert_ne!(a, Sway::new(12, rms));
        // Over 2000 s the RMS of each axis matches its setting (the terms'
        // frequencies differ, so cross terms average out) and the mean is ~0.
        let dt = 0.1;
        let n = 20000;
        let mut sum = [0.0; 6];
        let mut sq = [0.0; 6];
        let mut max_step: [f64; 6] = [0.0; 6];
        let mut prev = a.at(0.0);
        for i in 0..n {
            let s = a.at(i as f64 * dt);
            for k in 0..6 {
                sum[k] += s[k];
                sq[k] += s[k] * s[k];
                max_step[k] = max_step[k].max((s[k] - prev[k]).abs());
            }
            prev = s;
        }
        for k in 0..6 {
            let got = (sq[k] / n as f64).sqrt();
            assert!((got - rms[k]).abs() / rms[k] < 0.15, "axis {k}: rms {got}");
            assert!((sum[k] / n as f64).abs() < 0.25 * rms[k], "axis {k}: mean");
            // Slow: at most 0.4 Hz, so a 0.1 s step moves under
            // 2 pi 0.4 0.1 sum(amplitudes) <= 0.25 * sqrt(2 * 5) * rms.
            assert!(max_step[k] < 0.8 * rms[k], "axis {k}: step {}", max_step[k]);
        }
    }
}
