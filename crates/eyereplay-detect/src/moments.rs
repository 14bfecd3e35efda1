//! Moments of a sample, shared by the orientation of a window and by the
//! features (they import it; it imports nothing of theirs).

/// Sample skewness `m3 / m2^1.5` (scipy.stats.skew's default, biased);
/// 0 for fewer than 3 values or no spread.
pub fn skewness(v: &[f64]) -> f64 {
    if v.len() < 3 {
        return 0.0;
    }
    let n = v.len() as f64;
    let m = v.iter().sum::<f64>() / n;
    let (mut m2, mut m3) = (0.0, 0.0);
    for &a in v {
        let d = a - m;
        m2 += d * d;
        m3 += d * d * d;
    }
    m2 /= n;
    m3 /= n;
    if m2 <= 1e-300 {
        return 0.0;
    }
    m3 / m2.powf(1.5)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn skewness_matches_scipy() {
        // scipy.stats.skew([1, 2, 3, 10]), worked by hand: mean 4, deviations -3 -2 -1 6, m2 = 50/4 = 12.5, m3 = 180/4 = 45,
        // 45 / 12.5^1.5 = 1.01823...
        let s = skewness(&[1.0, 2.0, 3.0, 10.0]);
        assert!((s - 45.0 / 12.5f64.powf(1.5)).abs() < 1e-12, "{s}");
        assert!((s - 1.018_233_764_908_628).abs() < 1e-12);
        assert_eq!(skewness(&[2.0, 2.0, 2.0]), 0.0);
    }
}
