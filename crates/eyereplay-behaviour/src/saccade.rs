//! Saccade waveform and fixational eye movements.
//!
//! Saccades follow the closed-form main-sequence waveform of Dai, Selesnick,
//! Rizzo, Rucker and Hudson (2016, "A parametric model for saccadic eye
//! movement", IEEE SPMB):
//!
//! ```text
//! x(t) = c f(eta (t - t0) / c) - c f(eta (t - t0 - tau) / c),   tau = A / eta
//! f(u) = u + exp(-2u) / 4   (u >= 0),   exp(2u) / 4   (u < 0)
//! ```
//!
//! whose peak velocity `eta (1 - exp(-A / c))` rises with amplitude and
//! saturates at `eta`, the main sequence. The code defaults of the paper are
//! `eta = 600 deg/s`, `c = 6 deg`; `eta ~ 460`, `c ~ 9` fit Hopf et al.
//! (2018) better. Each synthetic person draws both from a range.

use serde::{Deserialize, Serialize};

/// Main-sequence parameters of one person.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct MainSequence {
    /// Asymptotic peak velocity, deg/s.
    pub eta_deg_per_s: f64,
    /// Amplitude constant, deg.
    pub c_deg: f64,
}

impl Default for MainSequence {
    fn default() -> Self {
        MainSequence {
            eta_deg_per_s: 600.0,
            c_deg: 6.0,
        }
    }
}

/// Lead time before `t0` at which a saccade is taken to start, in units of
/// `c / eta`: the waveform there is `c exp(-2 k) / 4`, under 1 % of `c`.
const LEAD_UNITS: f64 = 2.0;

fn f(u: f64) -> f64 {
    if u >= 0.0 {
        u + 0.25 * (-2.0 * u).exp()
    } else {
        0.25 * (2.0 * u).exp()
    }
}

fn f_prime(u: f64) -> f64 {
    if u >= 0.0 {
        1.0 - 0.5 * (-2.0 * u).exp()
    } else {
        0.5 * (2.0 * u).exp()
    }
}

impl MainSequence {
    /// Dai et al.'s `x(t)` in degrees for amplitude `amp_deg`, `t` seconds
    /// after `t0`.
    pub fn position_deg(&self, amp_deg: f64, t_s: f64) -> f64 {
        let (eta, c) = (self.eta_deg_per_s, self.c_deg);
        let tau = amp_deg / eta;
        c * f(eta * t_s / c) - c * f(eta * (t_s - tau) / c)
    }

    /// Velocity of the waveform, deg/s.
    pub fn velocity_deg_per_s(&self, amp_deg: f64, t_s: f64) -> f64 {
        let (eta, c) = (self.eta_deg_per_s, self.c_deg);
        let tau = amp_deg / eta;
        eta * (f_prime(eta * t_s / c) - f_prime(eta * (t_s - tau) / c))
    }

    /// Closed-form peak velocity `eta (1 - exp(-A / c))`, deg/s.
    pub fn peak_velocity_deg_per_s(&self, amp_deg: f64) -> f64 {
        self.eta_deg_per_s * (1.0 - (-amp_deg / self.c_deg).exp())
    }

    /// How long a saccade of `amp_deg` occupies the timeline: from
    /// `LEAD_UNITS c / eta` before `t0` to as long after `t0 + tau`.
    pub fn span_s(&self, amp_deg: f64) -> f64 {
        amp_deg.abs() / self.eta_deg_per_s + 2.0 * LEAD_UNITS * self.c_deg / self.eta_deg_per_s
    }

    /// Fraction of the way from start to end, `s` seconds into a saccade of
    /// `amp_deg` that lasts [`span_s`](Self::span_s): the waveform rescaled
    /// so it leaves and arrives exactly.
    pub fn progress(&self, amp_deg: f64, s: f64) -> f64 {
        let a = amp_deg.abs().max(1e-9);
        let lead = LEAD_UNITS * self.c_deg / self.eta_deg_per_s;
        let span = self.span_s(a);
        let x0 = self.position_deg(a, -lead);
        let x1 = self.position_deg(a, span - lead);
        let s = s.clamp(0.0, span);
        ((self.position_deg(a, s - lead) - x0) / (x1 - x0)).clamp(0.0, 1.0)
    }

    /// The waveform of one saccade with its constants worked out once, for
    /// sample-by-sample evaluation.
    pub fn shape(&self, amp_deg: f64) -> SaccadeShape {
        let a = amp_deg.abs().max(1e-9);
        let lead = LEAD_UNITS * self.c_deg / self.eta_deg_per_s;
        let span = self.span_s(a);
        let x0 = self.position_deg(a, -lead);
        let x1 = self.position_deg(a, span - lead);
        SaccadeShape {
            ms: *self,
            amp: a,
            lead,
            span,
            x0,
            inv_range: 1.0 / (x1 - x0),
        }
    }

    /// Time the waveform's speed stays above `threshold_deg_per_s`, s
    /// (numerically, 0.01 ms steps).
    pub fn duration_above_s(&self, amp_deg: f64, threshold_deg_per_s: f64) -> f64 {
        let lead = LEAD_UNITS * self.c_deg / self.eta_deg_per_s;
        let span = self.span_s(amp_deg);
        let dt = 1e-5;
        let n = (span / dt).ceil() as usize;
        (0..n)
            .filter(|&i| {
                self.velocity_deg_per_s(amp_deg, i as f64 * dt - lead) > threshold_deg_per_s
            })
            .count() as f64
            * dt
    }
}

/// One saccade's waveform, ready to evaluate ([`MainSequence::shape`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SaccadeShape {
    ms: MainSequence,
    amp: f64,
    lead: f64,
    pub span: f64,
    x0: f64,
    inv_range: f64,
}

impl SaccadeShape {
    /// As [`MainSequence::progress`], `s` seconds into the saccade.
    pub fn progress(&self, s: f64) -> f64 {
        let s = s.clamp(0.0, self.span);
        ((self.ms.position_deg(self.amp, s - self.lead) - self.x0) * self.inv_range).clamp(0.0, 1.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn waveform_ends_at_amplitude_and_peaks_by_formula() {
        let ms = MainSequence::default();
        for a in [0.5, 2.0, 10.0, 20.0] {
            // Long after the saccade the eye is A degrees on.
            assert!((ms.position_deg(a, 1.0) - a).abs() < 1e-9);
            // The peak is at the middle, t0 + tau / 2, and equals eta (1 - e^(-A/c)).
            let tau = a / ms.eta_deg_per_s;
            let v = ms.velocity_deg_per_s(a, tau / 2.0);
            assert!((v - ms.peak_velocity_deg_per_s(a)).abs() < 1e-6, "{a}: {v}");
        }
        // By hand: 10 deg, eta 600, c 6: 600 (1 - e^(-10/6)) = 486.7 deg/s.
        assert!((ms.peak_velocity_deg_per_s(10.0) - 486.67).abs() < 0.01);
    }

    #[test]
    fn durations_match_the_published_table() {
        // Time above 30 deg/s with eta 600, c 6 (computed in the behaviour
        // study from Dai et al.'s code defaults): 2 deg 19 ms, 10 deg 39 ms,
        // 20 deg 56 ms.
        let ms = MainSequence::default();
        for (a, want_ms) in [(2.0, 19.0), (10.0, 39.0), (20.0, 56.0)] {
            let got = ms.duration_above_s(a, 30.0) * 1e3;
            assert!((got - want_ms).abs() < 1.0, "{a} deg: {got} ms");
        }
    }

    #[test]
    fn progress_leaves_and_arrives_exactly_and_is_monotone() {
        let ms = MainSequence {
            eta_deg_per_s: 500.0,
            c_deg: 8.0,
        };
        let a = 7.0;
        let span = ms.span_s(a);
        assert_eq!(ms.progress(a, 0.0), 0.0);
        assert_eq!(ms.progress(a, span), 1.0);
        let shape = ms.shape(a);
        for i in 0..=10 {
            let t = span * i as f64 / 10.0;
            assert!((shape.progress(t) - ms.progress(a, t)).abs() < 1e-12);
        }
        let mut last = 0.0;
        for i in 0..=100 {
            let p = ms.progress(a, span * i as f64 / 100.0);
            assert!(p >= last);
            last = p;
        }
    }
}
