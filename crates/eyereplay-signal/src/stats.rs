//! Order statistics with the same interpolation as numpy's default
//! (`method="linear"`), so percentiles match what users compute in Python.

/// Percentile `q` in [0, 100] of `values`, linear interpolation between
/// closest ranks (numpy `percentile(..., method="linear")`). `None` if empty.
pub fn percentile(values: &[f64], q: f64) -> Option<f64> {
    if values.is_empty() {
        return None;
    }
    let mut v = values.to_vec();
    v.sort_by(|a, b| a.total_cmp(b));
    Some(percentile_sorted(&v, q))
}

pub(crate) fn percentile_sorted(sorted: &[f64], q: f64) -> f64 {
    let n = sorted.len();
    let pos = (q / 100.0).clamp(0.0, 1.0) * (n - 1) as f64;
    let lo = pos.floor() as usize;
    let hi = pos.ceil() as usize;
    let frac = pos - lo as f64;
    sorted[lo] + (sorted[hi] - sorted[lo]) * frac
}

/// (Q1, Q3) with numpy's linear interpolation.
pub fn quartiles(values: &[f64]) -> Option<(f64, f64)> {
    if values.is_empty() {
        return None;
    }
    let mut v = values.to_vec();
    v.sort_by(|a, b| a.total_cmp(b));
    Some((percentile_sorted(&v, 25.0), percentile_sorted(&v, 75.0)))
}

pub fn median(values: &[f64]) -> Option<f64> {
    percentile(values, 50.0)
}

/// Pearson correlation; `None` when lengths differ, n < 2 or a series is
/// constant.
pub fn pearson(a: &[f64], b: &[f64]) -> Option<f64> {
    if a.len() != b.len() || a.len() < 2 {
        return None;
    }
    let n = a.len() as f64;
    let (ma, mb) = (a.iter().sum::<f64>() / n, b.iter().sum::<f64>() / n);
    let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
    for (x, y) in a.iter().zip(b) {
        let (dx, dy) = (x - ma, y - mb);
        sab += dx * dy;
        saa += dx * dx;
        sbb += dy * dy;
    }
    if saa == 0.0 || sbb == 0.0 {
        return None;
    }
    Some((sab / (saa.sqrt() * sbb.sqrt())).clamp(-1.0, 1.0))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn percentiles_match_numpy_linear() {
        // numpy.percentile([1, 2, 3, 4, 10], [5, 25, 50, 95]) = [1.2, 2, 3, 8.8]
        let v = [10.0, 2.0, 4.0, 1.0, 3.0];
        assert!((percentile(&v, 5.0).unwrap() - 1.2).abs() < 1e-12);
        assert_eq!(percentile(&v, 25.0).unwrap(), 2.0);
        assert_eq!(median(&v).unwrap(), 3.0);
        assert!((percentile(&v, 95.0).unwrap() - 8.8).abs() < 1e-12);
        assert_eq!(quartiles(&v).unwrap(), (2.0, 4.0));
        assert!(percentile(&[], 50.0).is_none());
    }

    #[test]
    fn pearson_by_hand() {
        let a = [1.0, 2.0, 3.0, 4.0];
        // cov = 1.0, var_a = 1.25, var_b = 1.25 -> r = 0.8
        assert!((pearson(&a, &[1.0, 3.0, 2.0, 4.0]).unwrap() - 0.8).abs() < 1e-12);
        assert!((pearson(&a, &[8.0, 6.0, 4.0, 2.0]).unwrap() + 1.0).abs() < 1e-15);
        assert_eq!(pearson(&a, &[1.0; 4]), None);
        assert_eq!(pearson(&a, &[1.0, 2.0]), None);
    }
}
