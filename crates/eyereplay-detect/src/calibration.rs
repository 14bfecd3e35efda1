//! Whether a reported probability means what it says: reliability bins,
//! the expected calibration error, and a decision threshold chosen for a
//! stated false-positive rate instead of whatever balances a validation
//! set.

use serde::{Deserialize, Serialize};

/// Platt scaling: `P = sigmoid(slope * z + intercept)` for a score `z` (a
/// model's log-odds), fitted on held-out windows so that a probability of
/// 0.7 is right about 70 % of the time there. A logistic regression fitted
/// with a penalty on balanced classes is sharper or flatter than the truth
/// in a new domain; this puts it back on the scale the data say.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Platt {
    pub slope: f64,
    pub intercept: f64,
}

impl Platt {
    pub fn apply(&self, z: f64) -> f64 {
        sigmoid(self.slope * z + self.intercept)
    }

    /// Fits by Newton's method on the log-loss with Platt's smoothed
    /// targets (`(n+ + 1) / (n+ + 2)` and `1 / (n- + 2)`, which keep a
    /// separable set from driving the slope to infinity). `None` without
    /// both classes, or when the scores rank the classes the wrong way
    /// round (a slope at or below zero).
    pub fn fit(scores: &[f64], labels: &[bool]) -> Option<Platt> {
        let n_pos = labels.iter().filter(|&&l| l).count() as f64;
        let n_neg = labels.len() as f64 - n_pos;
        if n_pos == 0.0 || n_neg == 0.0 {
            return None;
        }
        let (t_pos, t_neg) = ((n_pos + 1.0) / (n_pos + 2.0), 1.0 / (n_neg + 2.0));
        let (mut a, mut b) = (1.0, 0.0);
        for _ in 0..100 {
            // Gradient and Hessian of the summed log-loss in (a, b).
            let (mut ga, mut gb, mut haa, mut hab, mut hbb) = (0.0, 0.0, 0.0, 0.0, 0.0);
            for (&z, &l) in scores.iter().zip(labels) {
                let p = sigmoid(a * z + b);
                let d = p - if l { t_pos } else { t_neg };
                let w = (p * (1.0 - p)).max(1e-12);
                ga += d * z;
                gb += d;
                haa += w * z * z;
                hab += w * z;
                hbb += w;
            }
            // A tiny ridge keeps the step defined on degenerate scores.
            let (haa, hbb) = (haa + 1e-9, hbb + 1e-9);
            let det = haa * hbb - hab * hab;
            if det.abs() < 1e-18 {
                break;
            }
            let da = (hbb * ga - hab * gb) / det;
            let db = (haa * gb - hab * ga) / det;
            a -= da;
            b -= db;
            if da.abs() < 1e-10 && db.abs() < 1e-10 {
                break;
            }
        }
        // A slope at or below zero says the held-out windows rank against
        // the model: turning the model round on a few windows would hide
        // that, so there is no calibration to give.
        (a.is_finite() && b.is_finite() && a > 0.0).then_some(Platt {
            slope: a,
            intercept: b,
        })
    }
}

pub fn sigmoid(z: f64) -> f64 {
    1.0 / (1.0 + (-z).exp())
}

/// One bin of a reliability diagram.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ReliabilityBin {
    /// `[lo, hi)` (the last bin includes 1).
    pub lo: f64,
    pub hi: f64,
    pub count: usize,
    /// Mean predicted probability in the bin (NaN when empty).
    pub mean_probability: f64,
    /// Share of positives in the bin (NaN when empty).
    pub positive_fraction: f64,
}

/// `bins` equal-width bins over [0, 1] of `probabilities` against `labels`.
pub fn reliability(probabilities: &[f64], labels: &[bool], bins: usize) -> Vec<ReliabilityBin> {
    let bins = bins.max(1);
    let mut sum_p = vec![0.0; bins];
    let mut pos = vec![0usize; bins];
    let mut count = vec![0usize; bins];
    for (&p, &l) in probabilities.iter().zip(labels) {
        if !p.is_finite() {
            continue;
        }
        let b = ((p.clamp(0.0, 1.0) * bins as f64) as usize).min(bins - 1);
        sum_p[b] += p;
        pos[b] += l as usize;
        count[b] += 1;
    }
    (0..bins)
        .map(|b| {
            let n = count[b] as f64;
            ReliabilityBin {
                lo: b as f64 / bins as f64,
                hi: (b + 1) as f64 / bins as f64,
                count: count[b],
                mean_probability: sum_p[b] / n,
                positive_fraction: pos[b] as f64 / n,
            }
        })
        .collect()
}

/// Expected calibration error: the count-weighted mean over bins of
/// |share of positives - mean predicted probability|.
pub fn expected_calibration_error(bins: &[ReliabilityBin]) -> f64 {
    let total: usize = bins.iter().map(|b| b.count).sum();
    if total == 0 {
        return f64::NAN;
    }
    bins.iter()
        .filter(|b| b.count > 0)
        .map(|b| b.count as f64 * (b.positive_fraction - b.mean_probability).abs())
        .sum::<f64>()
        / total as f64
}

/// The lowest threshold `t` (scores at or above it are called positive)
/// whose false-positive rate on `negatives` is at most `fpr`: one of the
/// negatives' own scores, or just above the highest when even that one
/// would be too many.
pub fn threshold_for_fpr(negatives: &[f64], fpr: f64) -> f64 {
    let mut s: Vec<f64> = negatives
        .iter()
        .copied()
        .filter(|v| v.is_finite())
        .collect();
    if s.is_empty() {
        return 0.5;
    }
    s.sort_by(f64::total_cmp);
    let n = s.len() as f64;
    let rate = |t: f64| s.iter().filter(|&&v| v >= t).count() as f64 / n;
    s.iter()
        .copied()
        .find(|&t| rate(t) <= fpr + 1e-12)
        .unwrap_or_else(|| next_up(s[s.len() - 1]))
}

/// The smallest f64 above `v` (for a threshold just above a score).
fn next_up(v: f64) -> f64 {
    if v.is_nan() || v == f64::INFINITY {
        return v;
    }
    let bits = v.to_bits();
    let next = if v == 0.0 {
        1
    } else if v > 0.0 {
        bits + 1
    } else {
        bits - 1
    };
    f64::from_bits(next)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn platt_recovers_the_slope_and_intercept_that_made_the_labels() {
        // At each score z, 200 labels of which round(200 sigmoid(2z - 1))
        // are positive: the fit must find slope 2 and intercept -1 (up to
        // the smoothing of its targets, which is tiny at this size).
        let (mut z, mut l) = (Vec::new(), Vec::new());
        for i in 0..=60 {
            let s = -3.0 + i as f64 * 0.1;
            let pos = (200.0 * sigmoid(2.0 * s - 1.0)).round() as usize;
            for k in 0..200 {
                z.push(s);
                l.push(k < pos);
            }
        }
        let p = Platt::fit(&z, &l).unwrap();
        assert!((p.slope - 2.0).abs() < 0.05, "{p:?}");
        assert!((p.intercept + 1.0).abs() < 0.05, "{p:?}");
        assert!((p.apply(0.5) - 0.5).abs() < 0.02);
        // One class alone has nothing to calibrate against.
        assert_eq!(Platt::fit(&[0.0, 1.0], &[true, true]), None);
        // Scores that rank the wrong way round are not turned round.
        assert_eq!(
            Platt::fit(&[-2.0, -1.0, 1.0, 2.0], &[true, true, false, false]),
            None
        );
        // Separable scores stay finite thanks to the smoothed targets.
        let sep = Platt::fit(&[-2.0, -1.0, 1.0, 2.0], &[false, false, true, true]).unwrap();
        assert!(sep.slope.is_finite() && sep.slope > 0.0);
    }

    #[test]
    fn reliability_and_ece_by_hand() {
        // Two bins: [0, .5) holds 0.1, 0.2, 0.3 (one positive), [.5, 1]
        // holds 0.7 and 0.9 (both positive).
        let p = [0.1, 0.2, 0.3, 0.7, 0.9];
        let l = [false, true, false, true, true];
        let b = reliability(&p, &l, 2);
        assert_eq!((b[0].count, b[1].count), (3, 2));
        assert!((b[0].mean_probability - 0.2).abs() < 1e-12);
        assert!((b[0].positive_fraction - 1.0 / 3.0).abs() < 1e-12);
        assert!((b[1].mean_probability - 0.8).abs() < 1e-12);
        assert_eq!(b[1].positive_fraction, 1.0);
        // ECE = (3 |1/3 - 0.2| + 2 |1 - 0.8|) / 5 = (0.4 + 0.4) / 5 = 0.16.
        let ece = expected_calibration_error(&b);
        assert!((ece - 0.16).abs() < 1e-12, "{ece}");
        // A probability of exactly 1 falls in the last bin.
        assert_eq!(reliability(&[1.0], &[true], 4)[3].count, 1);
        // Perfectly calibrated in every bin: zero.
        let b = reliability(&[0.25, 0.25, 0.25, 0.25], &[true, false, false, false], 2);
        assert_eq!(expected_calibration_error(&b), 0.0);
    }

    #[test]
    fn threshold_for_a_stated_false_positive_rate() {
        let neg = [0.1, 0.2, 0.3, 0.4];
        // At most a quarter of negatives above: 0.4 (one of four).
        assert_eq!(threshold_for_fpr(&neg, 0.25), 0.4);
        assert_eq!(threshold_for_fpr(&neg, 0.5), 0.3);
        assert_eq!(threshold_for_fpr(&neg, 1.0), 0.1);
        // None may pass: just above the highest.
        let t = threshold_for_fpr(&neg, 0.0);
        assert!(t > 0.4 && t < 0.4 + 1e-12);
        // Ties count together: 0.3 twice of four is one half.
        assert_eq!(threshold_for_fpr(&[0.1, 0.3, 0.3, 0.2], 0.25), next_up(0.3));
    }
}
