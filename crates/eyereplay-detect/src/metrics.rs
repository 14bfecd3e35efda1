//! How well scores separate the classes: AUROC, the ROC curve, a
//! threshold's rates, and confidence intervals from a bootstrap over
//! people (windows of one person are not independent, and there are few
//! people, so resampling windows would make the interval far too narrow).

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

/// Area under the ROC curve: the probability that a random positive scores
/// above a random negative, ties counting half (the Mann-Whitney U over
/// `n_pos * n_neg`, what scikit-learn's `roc_auc_score` computes). `None`
/// when a class is empty.
pub fn auroc(scores: &[f64], labels: &[bool]) -> Option<f64> {
    let mut idx: Vec<usize> = (0..scores.len().min(labels.len())).collect();
    idx.sort_by(|&a, &b| scores[a].total_cmp(&scores[b]));
    let n_pos = idx.iter().filter(|&&i| labels[i]).count();
    let n_neg = idx.len() - n_pos;
    if n_pos == 0 || n_neg == 0 {
        return None;
    }
    // Sum of the positives' mid-ranks.
    let mut rank_sum = 0.0;
    let mut i = 0;
    while i < idx.len() {
        let mut j = i;
        while j + 1 < idx.len() && scores[idx[j + 1]] == scores[idx[i]] {
            j += 1;
        }
        let mid_rank = (i + j) as f64 / 2.0 + 1.0;
        rank_sum += mid_rank * idx[i..=j].iter().filter(|&&k| labels[k]).count() as f64;
        i = j + 1;
    }
    let u = rank_sum - (n_pos * (n_pos + 1)) as f64 / 2.0;
    Some(u / (n_pos * n_neg) as f64)
}

/// ROC curve points `(false-positive rate, true-positive rate)` from the
/// highest threshold down, starting at (0, 0) and ending at (1, 1).
pub fn roc_curve(scores: &[f64], labels: &[bool]) -> Vec<(f64, f64)> {
    let mut idx: Vec<usize> = (0..scores.len().min(labels.len())).collect();
    idx.sort_by(|&a, &b| scores[b].total_cmp(&scores[a]));
    let n_pos = idx.iter().filter(|&&i| labels[i]).count().max(1) as f64;
    let n_neg = idx.iter().filter(|&&i| !labels[i]).count().max(1) as f64;
    let mut out = vec![(0.0, 0.0)];
    let (mut tp, mut fp) = (0.0, 0.0);
    let mut i = 0;
    while i < idx.len() {
        let s = scores[idx[i]];
        while i < idx.len() && scores[idx[i]] == s {
            if labels[idx[i]] {
                tp += 1.0;
            } else {
                fp += 1.0;
            }
            i += 1;
        }
        out.push((fp / n_neg, tp / n_pos));
    }
    out
}

/// The share of `scores` at or above `threshold`: the false-positive rate
/// on negatives, the true-positive rate on positives.
pub fn rate_at(scores: &[f64], threshold: f64) -> f64 {
    if scores.is_empty() {
        return f64::NAN;
    }
    scores.iter().filter(|&&s| s >= threshold).count() as f64 / scores.len() as f64
}

/// The threshold that maximizes balanced accuracy (Youden's J) on
/// `scores`. Where a range of thresholds reaches the best J (classes that
/// separate cleanly leave a gap between them), the middle of that range:
/// as far from both classes as the data allow.
pub fn balanced_threshold(scores: &[f64], labels: &[bool]) -> f64 {
    let mut v: Vec<(f64, bool)> = scores.iter().copied().zip(labels.iter().copied()).collect();
    v.sort_by(|a, b| a.0.total_cmp(&b.0));
    if v.is_empty() {
        return 0.5;
    }
    let n_pos = v.iter().filter(|p| p.1).count().max(1) as f64;
    let n_neg = v.iter().filter(|p| !p.1).count().max(1) as f64;
    // Candidate k: everything from v[k] up is called positive. Its threshold
    // interval runs from v[k-1] (exclusive) to v[k] (inclusive).
    let mut cands: Vec<(usize, f64)> = Vec::new();
    let (mut neg_below, mut pos_below) = (0.0, 0.0);
    for k in 0..=v.len() {
        if k == 0 || k == v.len() || v[k].0 != v[k - 1].0 {
            let j = (1.0 - pos_below / n_pos) + neg_below / n_neg - 1.0;
            cands.push((k, j));
        }
        if k < v.len() {
            if v[k].1 {
                pos_below += 1.0;
            } else {
                neg_below += 1.0;
            }
        }
    }
    let best = cands.iter().map(|c| c.1).fold(f64::NEG_INFINITY, f64::max);
    let optimal: Vec<usize> = cands
        .iter()
        .filter(|c| c.1 >= best - 1e-12)
        .map(|c| c.0)
        .collect();
    let (k_lo, k_hi) = (optimal[0], optimal[optimal.len() - 1]);
    let n = v.len();
    // Lowest and highest thresholds of the optimal range.
    let lo = if k_lo == 0 {
        v[0].0
    } else {
        0.5 * (v[k_lo - 1].0 + v[k_lo].0.min(v[n - 1].0))
    };
    let hi = if k_hi >= n {
        v[n - 1].0 + 1e-9
    } else {
        v[k_hi].0
    };
    if k_lo == k_hi {
        return match k_lo {
            0 => v[0].0,
            k if k >= n => v[n - 1].0 + 1e-9,
            k => 0.5 * (v[k - 1].0 + v[k].0),
        };
    }
    0.5 * (lo + hi)
}

/// AUROC with a percentile confidence interval from a bootstrap over
/// people ([`pairwise_auroc`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct AurocCi {
    pub auroc: f64,
    pub low: f64,
    pub high: f64,
    pub level: f64,
    pub replicates: usize,
    pub windows_other: usize,
    pub units_reading: usize,
    pub units_other: usize,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn auroc_matches_scikit_learn_worked_by_hand() {
        // sklearn.metrics.roc_auc_score([0, 0, 1, 1], [0.1, 0.4, 0.35, 0.8])
        // = 0.75: of the 4 positive-negative pairs, (0.35 vs 0.4) is wrong.
        let a = auroc(&[0.1, 0.4, 0.35, 0.8], &[false, false, true, true]).unwrap();
        assert!((a - 0.75).abs() < 1e-12);
        // A tie between classes counts half: pairs (0.5,0.5) tie, (0.5,0.2) right.
        let t = auroc(&[0.5, 0.5, 0.2], &[true, false, false]).unwrap();
        assert!((t - 0.75).abs() < 1e-12);
        assert!(auroc(&[0.1, 0.2], &[true, true]).is_none());
    }

    #[test]
    fn roc_curve_runs_from_corner_to_corner_and_its_area_is_the_auroc() {
        let s = [0.1, 0.4, 0.35, 0.8, 0.7, 0.2];
        let l = [false, false, true, true, false, true];
        let c = roc_curve(&s, &l);
        assert_eq!(c[0], (0.0, 0.0));
        assert_eq!(*c.last().unwrap(), (1.0, 1.0));
        let area: f64 = c
            .windows(2)
            .map(|p| (p[1].0 - p[0].0) * (p[1].1 + p[0].1) / 2.0)
            .sum();
        assert!((area - auroc(&s, &l).unwrap()).abs() < 1e-12);
    }

    #[test]
    fn balanced_threshold_separates_separable_scores() {
        let t = balanced_threshold(
            &[0.1, 0.2, 0.3, 0.7, 0.8],
            &[false, false, false, true, true],
        );
        assert!((t - 0.5).abs() < 1e-12);
        assert_eq!(rate_at(&[0.1, 0.6, 0.7, 0.2], 0.5), 0.5);
    }
}

/// The AUROC of one reading person against one non-reading person, under
/// one model: what [`pairwise_auroc`] averages.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PairAuroc {
    pub reader: String,
    pub other: String,
    pub auroc: f64,
    pub other_windows: usize,
}

/// The AUROC of reading people against non-reading people when each reader
/// may be scored by a different model (one per fold, or one per held-out
/// pair): for each reader, the Mann-Whitney AUROC against all non-readers
/// is the window-weighted mean of its pair AUROCs, which needs no score to
/// be compared across models; readers are then averaged. The interval
/// comes from a bootstrap over people: each replicate draws readers and
/// non-readers with replacement and recomputes the same mean.
pub fn pairwise_auroc(
    pairs: &[PairAuroc],
    replicates: usize,
    level: f64,
    seed: u64,
) -> Option<AurocCi> {
    let mut readers: Vec<&str> = pairs.iter().map(|p| p.reader.as_str()).collect();
    readers.sort_unstable();
    readers.dedup();
    let mut others: Vec<&str> = pairs.iter().map(|p| p.other.as_str()).collect();
    others.sort_unstable();
    others.dedup();
    if readers.is_empty() || others.is_empty() {
        return None;
    }
    let value = |rs: &[&str], os: &[&str]| -> Option<f64> {
        let mut per_reader = Vec::new();
        for r in rs {
            let (mut num, mut den) = (0.0, 0.0);
            for o in os {
                for p in pairs.iter().filter(|p| p.reader == *r && p.other == *o) {
                    num += p.auroc * p.other_windows as f64;
                    den += p.other_windows as f64;
                }
            }
            if den > 0.0 {
                per_reader.push(num / den);
            }
        }
        (!per_reader.is_empty()).then(|| per_reader.iter().sum::<f64>() / per_reader.len() as f64)
    };
    let point = value(&readers, &others)?;
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut values = Vec::with_capacity(replicates);
    for _ in 0..replicates {
        let rs: Vec<&str> = (0..readers.len())
            .map(|_| readers[rng.gen_range(0..readers.len())])
            .collect();
        let os: Vec<&str> = (0..others.len())
            .map(|_| others[rng.gen_range(0..others.len())])
            .collect();
        if let Some(v) = value(&rs, &os) {
            values.push(v);
        }
    }
    values.sort_by(f64::total_cmp);
    let alpha = (1.0 - level) / 2.0;
    let q = |p: f64| eyereplay_signal::stats::quantile_sorted(&values, p).unwrap_or(point);
    Some(AurocCi {
        auroc: point,
        low: q(alpha),
        high: q(1.0 - alpha),
        level,
        replicates,
        windows_other: pairs.iter().map(|p| p.other_windows).sum(),
        units_reading: readers.len(),
        units_other: others.len(),
    })
}

#[cfg(test)]
mod pair_tests {
    use super::*;

    #[test]
    fn pairwise_auroc_is_the_window_weighted_mean_per_reader() {
        let p = |r: &str, o: &str, a: f64, n: usize| PairAuroc {
            reader: r.into(),
            other: o.into(),
            auroc: a,
            other_windows: n,
        };
        // Reader a: (1.0 * 10 + 0.5 * 30) / 40 = 0.625; reader b: 0.9.
        let pairs = [
            p("a", "x", 1.0, 10),
            p("a", "y", 0.5, 30),
            p("b", "x", 0.9, 10),
            p("b", "y", 0.9, 30),
        ];
        let ci = pairwise_auroc(&pairs, 300, 0.95, 3).unwrap();
        assert!((ci.auroc - (0.625 + 0.9) / 2.0).abs() < 1e-12);
        assert!(ci.low >= 0.5 && ci.high <= 1.0 && ci.low <= ci.auroc && ci.auroc <= ci.high);
        assert_eq!((ci.units_reading, ci.units_other), (2, 2));
        // Equal to the pooled AUROC when one model scores everything.
        let scores = [0.9, 0.8, 0.3, 0.85, 0.2, 0.1];
        let labels = [true, true, false, false, false, false];
        let pooled = auroc(&scores, &labels).unwrap();
        let ax = auroc(&[0.9, 0.8, 0.3, 0.85], &[true, true, false, false]).unwrap();
        let ay = auroc(&[0.9, 0.8, 0.2, 0.1], &[true, true, false, false]).unwrap();
        let split = pairwise_auroc(&[p("r", "x", ax, 2), p("r", "y", ay, 2)], 10, 0.95, 1).unwrap();
        assert!((split.auroc - pooled).abs() < 1e-12);
    }
}
