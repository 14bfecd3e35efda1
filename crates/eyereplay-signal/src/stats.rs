//! The one statistics module of eyereplay. Every order statistic uses
//! numpy's default convention (`method="linear"`, `q` in [0, 1]), so
//! percentiles match what users compute in Python; the one deliberate
//! exception, [`upper_median`], says why it exists.

/// Ascending copy; NaN sorts last (total order).
pub fn sorted(values: &[f64]) -> Vec<f64> {
    let mut s = values.to_vec();
    s.sort_unstable_by(f64::total_cmp);
    s
}

/// Quantile `q` in [0, 1] of ascending-sorted data, linear interpolation
/// between closest ranks (numpy `quantile(..., method="linear")`). `None`
/// when empty.
pub fn quantile_sorted(sorted: &[f64], q: f64) -> Option<f64> {
    let n = sorted.len();
    if n == 0 {
        return None;
    }
    let pos = q.clamp(0.0, 1.0) * (n - 1) as f64;
    let lo = pos.floor() as usize;
    let hi = (lo + 1).min(n - 1);
    let frac = pos - lo as f64;
    Some(sorted[lo] + (sorted[hi] - sorted[lo]) * frac)
}

/// Quantile `q` in [0, 1] of unsorted data (see [`quantile_sorted`]).
pub fn quantile(values: &[f64], q: f64) -> Option<f64> {
    quantile_sorted(&sorted(values), q)
}

/// numpy `median`: the mean of the two middle values for even counts.
pub fn median(values: &[f64]) -> Option<f64> {
    quantile(values, 0.5)
}

/// The element at rank `n / 2` of the sorted data (the upper of the two
/// middle values for even counts), found by selection in O(n). Used where a
/// value that actually occurs in the data is wanted and where results were
/// defined this way before statistics were unified (the extractor's blink
/// threshold, EdgeGauss's sampling interval): changing them would change
/// every cached extraction.
pub fn upper_median(values: &[f64]) -> Option<f64> {
    if values.is_empty() {
        return None;
    }
    let mut v = values.to_vec();
    let mid = v.len() / 2;
    Some(*v.select_nth_unstable_by(mid, f64::total_cmp).1)
}

/// (Q1, Q3) with numpy's linear interpolation.
pub fn quartiles(values: &[f64]) -> Option<(f64, f64)> {
    let s = sorted(values);
    Some((quantile_sorted(&s, 0.25)?, quantile_sorted(&s, 0.75)?))
}

pub fn mean(values: &[f64]) -> Option<f64> {
    (!values.is_empty()).then(|| values.iter().sum::<f64>() / values.len() as f64)
}

/// Population standard deviation (numpy `std`, ddof = 0).
pub fn std_pop(values: &[f64]) -> Option<f64> {
    let m = mean(values)?;
    Some((values.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / values.len() as f64).sqrt())
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

/// Least-squares line `y = slope * x + intercept`; `None` if x is constant.
pub fn linear_fit(x: &[f64], y: &[f64]) -> Option<(f64, f64)> {
    if x.len() != y.len() || x.len() < 2 {
        return None;
    }
    let (mx, my) = (mean(x)?, mean(y)?);
    let (mut sxy, mut sxx) = (0.0, 0.0);
    for (a, b) in x.iter().zip(y) {
        sxy += (a - mx) * (b - my);
        sxx += (a - mx) * (a - mx);
    }
    if sxx == 0.0 {
        return None;
    }
    let slope = sxy / sxx;
    Some((slope, my - slope * mx))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantiles_match_numpy_linear() {
        // numpy.quantile([1, 2, 3, 4, 10], [0.05, 0.25, 0.5, 0.95]) = [1.2, 2, 3, 8.8]
        let v = [10.0, 2.0, 4.0, 1.0, 3.0];
        assert!((quantile(&v, 0.05).unwrap() - 1.2).abs() < 1e-12);
        assert_eq!(quantile(&v, 0.25).unwrap(), 2.0);
        assert_eq!(median(&v).unwrap(), 3.0);
        assert!((quantile(&v, 0.95).unwrap() - 8.8).abs() < 1e-12);
        assert_eq!(quartiles(&v).unwrap(), (2.0, 4.0));
        // numpy.quantile([1, 2, 3, 4], [0, 0.25, 0.5, 0.95]) = 1, 1.75, 2.5, 3.85
        let s = [1.0, 2.0, 3.0, 4.0];
        assert_eq!(quantile_sorted(&s, 0.0), Some(1.0));
        assert_eq!(quantile_sorted(&s, 0.25), Some(1.75));
        assert_eq!(quantile_sorted(&s, 0.5), Some(2.5));
        assert!((quantile_sorted(&s, 0.95).unwrap() - 3.85).abs() < 1e-12);
        assert!(quantile(&[], 0.5).is_none());
        assert!(quartiles(&[]).is_none());
    }

    #[test]
    fn upper_median_is_an_element() {
        assert_eq!(upper_median(&[4.0, 1.0, 3.0, 2.0]), Some(3.0));
        assert_eq!(upper_median(&[5.0, 1.0, 3.0]), Some(3.0));
        assert_eq!(median(&[4.0, 1.0, 3.0, 2.0]), Some(2.5));
        assert_eq!(upper_median(&[]), None);
    }

    #[test]
    fn pearson_std_and_fit_by_hand() {
        let a = [1.0, 2.0, 3.0, 4.0];
        // cov = 1.0, var_a = 1.25, var_b = 1.25 -> r = 0.8
        assert!((pearson(&a, &[1.0, 3.0, 2.0, 4.0]).unwrap() - 0.8).abs() < 1e-12);
        assert!((pearson(&a, &[8.0, 6.0, 4.0, 2.0]).unwrap() + 1.0).abs() < 1e-15);
        assert_eq!(pearson(&a, &[1.0; 4]), None);
        assert_eq!(pearson(&a, &[1.0, 2.0]), None);
        // population std of 1,2,3 = sqrt(2/3)
        assert!((std_pop(&[1.0, 2.0, 3.0]).unwrap() - (2.0f64 / 3.0).sqrt()).abs() < 1e-15);
        assert_eq!(linear_fit(&a, &[3.0, 5.0, 7.0, 9.0]), Some((2.0, 1.0)));
        assert_eq!(linear_fit(&[1.0, 1.0], &[0.0, 1.0]), None);
    }
}
