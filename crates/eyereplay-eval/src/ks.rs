//! Two-sample Kolmogorov-Smirnov test, two-sided, agreeing with
//! `scipy.stats.ks_2samp(a, b, alternative='two-sided', method='auto')`.
//!
//! No crate on crates.io reproduces scipy's method (statrs 0.19 uses the
//! limiting Kolmogorov distribution for large samples, not the finite-n one,
//! and its exact mode keeps an `m x n` matrix), so this is a port of scipy's
//! own algorithms (scipy 1.17, `scipy/stats/_stats_py.py`,
//! `_stats_pythran.py`, `_ksstats.py` and xsf's `cephes/kolmogorov.h`):
//!
//! * **Method choice**: exact when `max(n1, n2) <= 10000`, else asymptotic.
//! * **Exact**: `h = round(D * lcm(n1, n2))`; for `n1 == n2` the Horner-like
//!   alternating sum of `_compute_prob_outside_square`, otherwise the lattice
//!   path recursion of `_compute_outer_prob_inside_method` (Hodges' inside
//!   method rewritten to give `1 - p` directly, Viehmann 2021). If the result
//!   is not a probability, scipy falls back to the asymptotic p; so do we.
//! * **Asymptotic**: `kstwo.sf(D, round(n1*n2/(n1+n2)))`, the finite-n
//!   two-sided one-sample Kolmogorov distribution, evaluated as in Simard &
//!   L'Ecuyer (2011): Ruben-Gambino closed forms at the ends, Durbin's matrix
//!   (Marsaglia-Tsang-Wang), Pomeranz's recursion, the Pelz-Good expansion,
//!   and `2 * smirnov(n, D)` (Birnbaum-Tingey sum) for small p-values.
//!
//! Tested against scipy's output stored in `tests/data/ks_scipy.json`.

use crate::EvalError;
use serde::Serialize;

/// `ks_2samp`'s `MAX_AUTO_N`: exact p when neither sample is larger.
pub const KS_MAX_EXACT_N: usize = 10_000;

/// How the p-value was computed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum KsMethod {
    Exact,
    Asymptotic,
}

/// Result of a two-sided two-sample KS test.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct KsResult {
    /// `sup_x |F1(x) - F2(x)|` of the two empirical CDFs.
    pub d: f64,
    /// Two-sided p-value.
    pub p: f64,
    pub method: KsMethod,
    pub n1: usize,
    pub n2: usize,
}

/// Two-sided two-sample KS test (scipy's `method='auto'`).
///
/// Errors when a sample is empty or holds a NaN.
pub fn ks_2samp(a: &[f64], b: &[f64]) -> Result<KsResult, EvalError> {
    let mut a = a.to_vec();
    let mut b = b.to_vec();
    if a.is_empty() || b.is_empty() {
        return Err(EvalError::Stats(format!(
            "KS test needs two non-empty samples (sizes {} and {})",
            a.len(),
            b.len()
        )));
    }
    if a.iter().chain(b.iter()).any(|v| v.is_nan()) {
        return Err(EvalError::Stats("KS test sample holds NaN".into()));
    }
    a.sort_unstable_by(f64::total_cmp);
    b.sort_unstable_by(f64::total_cmp);
    Ok(ks_2samp_sorted(&a, &b))
}

/// [`ks_2samp`] on samples already sorted ascending, without NaN.
pub fn ks_2samp_sorted(a: &[f64], b: &[f64]) -> KsResult {
    let (n1, n2) = (a.len(), b.len());
    let d = ks_statistic_sorted(a, b);
    let (p, method) = ks_2samp_pvalue(d, n1, n2);
    KsResult {
        d,
        p,
        method,
        n1,
        n2,
    }
}

/// ECDF value `k/n` as numpy's `linspace(0, 1, n + 1)` produces it.
#[inline]
fn linspace_frac(k: usize, n: usize) -> f64 {
    if k == n {
        1.0
    } else {
        k as f64 * (1.0 / n as f64)
    }
}

/// The two-sided statistic: the larger of `max(F1 - F2)` and `max(F2 - F1)`,
/// the ECDFs evaluated (right-continuous) at every pooled observation.
pub fn ks_statistic_sorted(a: &[f64], b: &[f64]) -> f64 {
    let (n1, n2) = (a.len(), b.len());
    let (mut i, mut j) = (0usize, 0usize);
    let mut max_s = f64::NEG_INFINITY;
    let mut min_s = f64::INFINITY;
    while i < n1 || j < n2 {
        let v = match (a.get(i), b.get(j)) {
            (Some(&x), Some(&y)) => x.min(y),
            (Some(&x), None) => x,
            (None, Some(&y)) => y,
            (None, None) => unreachable!(),
        };
        while i < n1 && a[i] <= v {
            i += 1;
        }
        while j < n2 && b[j] <= v {
            j += 1;
        }
        let diff = linspace_frac(i, n1) - linspace_frac(j, n2);
        max_s = max_s.max(diff);
        min_s = min_s.min(diff);
    }
    let min_s = (-min_s).clamp(0.0, 1.0);
    if min_s > max_s {
        min_s
    } else {
        max_s
    }
}

fn gcd(mut a: u64, mut b: u64) -> u64 {
    while b != 0 {
        (a, b) = (b, a % b);
    }
    a
}

/// Two-sided p-value for statistic `d` of samples of sizes `n1`, `n2`
/// (scipy's `_ks_2samp_prob` with `mode='auto'`).
pub fn ks_2samp_pvalue(d: f64, n1: usize, n2: usize) -> (f64, KsMethod) {
    let mut d = d;
    if n1.max(n2) <= KS_MAX_EXACT_N {
        let g = gcd(n1 as u64, n2 as u64);
        let lcm = (n1 as u64 / g) * n2 as u64;
        let h = (d * lcm as f64).round_ties_even() as i64;
        let d_exact = h as f64 / lcm as f64;
        if h == 0 {
            return (1.0, KsMethod::Exact);
        }
        let prob = if n1 == n2 {
            prob_outside_square(n1 as i64, h)
        } else {
            outer_prob_inside_method(n1 as i64, n2 as i64, g as i64, h)
        };
        if (0.0..=1.0).contains(&prob) {
            return (prob, KsMethod::Exact);
        }
        // scipy: "Exact calculation unsuccessful. Switching to method=asymp",
        // with D rounded to h/lcm.
        d = d_exact;
    }
    let (m, n) = if n1 >= n2 {
        (n1 as f64, n2 as f64)
    } else {
        (n2 as f64, n1 as f64)
    };
    let en = m * n / (m + n);
    let p = kolmogn_sf(en.round_ties_even() as i64, d);
    (p.clamp(0.0, 1.0), KsMethod::Asymptotic)
}

/// `Pr(D_{n,n} >= h/n)` (scipy `_compute_prob_outside_square`).
fn prob_outside_square(n: i64, h: i64) -> f64 {
    let mut p = 0.0f64;
    let mut k = n / h;
    while k >= 0 {
        let mut p1 = 1.0f64;
        for j in 0..h {
            p1 = (n - k * h - j) as f64 * p1 / (n + k * h + j + 1) as f64;
        }
        p = p1 * (1.0 - p);
        k -= 1;
    }
    2.0 * p
}

/// Proportion of lattice paths not staying strictly inside the diagonal band
/// (scipy `_compute_outer_prob_inside_method`).
fn outer_prob_inside_method(m: i64, n: i64, g: i64, h: i64) -> f64 {
    let (m, n) = if m < n { (n, m) } else { (m, n) };
    let mg = m / g;
    let ng = n / g;
    let mut minj: i64 = 0;
    let mut maxj: i64 = ((h as f64 / mg as f64).ceil() as i64).min(n + 1);
    let mut curlen = maxj - minj;
    let len_a = (2 * maxj + 2).min(n + 1) as usize;
    let mut a = vec![1.0f64; len_a];
    for v in a.iter_mut().take(maxj as usize).skip(minj as usize) {
        *v = 0.0;
    }
    for i in 1..=m {
        let lastminj = minj;
        let lastlen = curlen;
        minj = ((((ng * i - h) as f64) / mg as f64).floor() as i64 + 1).max(0);
        minj = minj.min(n);
        maxj = ((((ng * i + h) as f64) / mg as f64).ceil() as i64).min(n + 1);
        if maxj <= minj {
            return 1.0;
        }
        let mut val = if minj == 0 { 0.0 } else { 1.0 };
        for jj in 0..(maxj - minj) {
            let j = jj + minj;
            val = (a[(jj + minj - lastminj) as usize] * i as f64 + val * j as f64) / (i + j) as f64;
            a[jj as usize] = val;
        }
        curlen = maxj - minj;
        if lastlen > curlen {
            let start = ((maxj - minj) as usize).min(len_a);
            let end = ((maxj - minj + (lastlen - curlen)) as usize).min(len_a);
            for v in &mut a[start..end] {
                *v = 1.0;
            }
        }
    }
    a[(maxj - minj - 1) as usize]
}

// ---------------------------------------------------------------------------
// The finite-n Kolmogorov distribution (scipy `_ksstats._kolmogn`, sf only).

const E128: i32 = 128;
/// 2^128 and 2^-128, exact (powers of two).
fn ep128() -> f64 {
    2f64.powi(E128)
}
fn em128() -> f64 {
    2f64.powi(-E128)
}
const MIN_LOG: f64 = -708.0;
const LOG_2PI: f64 = 1.837_877_066_409_345_3;
const SQRT2PI: f64 = 2.506_628_274_631_000_7;
const SQRT3: f64 = 1.732_050_807_568_877_2;
const PI_SQUARED: f64 = std::f64::consts::PI * std::f64::consts::PI;
// Verbatim from scipy's _ksstats.py.
#[allow(clippy::excessive_precision)]
const STIRLING_COEFFS: [f64; 8] = [
    -2.955_065_359_477_124_183e-2,
    6.410_256_410_256_410_256_4e-3,
    -1.917_526_917_526_917_526_9e-3,
    8.417_508_417_508_417_508_4e-4,
    -5.952_380_952_380_952_381e-4,
    7.936_507_936_507_936_507_9e-4,
    -2.777_777_777_777_777_777_8e-3,
    8.333_333_333_333_333_333_3e-2,
];

fn ldexp(x: f64, e: i32) -> f64 {
    // Split so neither factor overflows or underflows on its own.
    let mut x = x;
    let mut e = e;
    while e > 1000 {
        x *= 2f64.powi(1000);
        e -= 1000;
    }
    while e < -1000 {
        x *= 2f64.powi(-1000);
        e += 1000;
    }
    x * 2f64.powi(e)
}

fn log_nfactorial_div_n_pow_n(n: f64) -> f64 {
    let rn = 1.0 / n;
    let z = rn / n;
    let poly = STIRLING_COEFFS.iter().fold(0.0, |acc, &c| acc * z + c);
    n.ln() / 2.0 - n + LOG_2PI / 2.0 + rn * poly
}

/// `Pr(D_n > x)`, the survival function of the two-sided one-sample KS
/// statistic for sample size `n` (scipy `kstwo.sf(x, n)`).
pub fn kolmogn_sf(n: i64, x: f64) -> f64 {
    if n <= 0 || x.is_nan() {
        return f64::NAN;
    }
    if x >= 1.0 {
        return 0.0;
    }
    if x <= 0.0 {
        return 1.0;
    }
    let nf = n as f64;
    let t = nf * x;
    if t <= 1.0 {
        // Ruben-Gambino: 1/2n <= x <= 1/n
        if t <= 0.5 {
            return 1.0;
        }
        let prob = if n <= 140 {
            let mut p = 1.0;
            for i in 1..=n {
                p *= i as f64 * (1.0 / nf) * (2.0 * t - 1.0);
            }
            p
        } else {
            (log_nfactorial_div_n_pow_n(nf) + nf * (2.0 * t - 1.0).ln()).exp()
        };
        return (1.0 - prob).clamp(0.0, 1.0);
    }
    if t >= nf - 1.0 {
        return (2.0 * (1.0 - x).powf(nf)).clamp(0.0, 1.0);
    }
    if x >= 0.5 {
        return (2.0 * smirnov_sf(n, x)).clamp(0.0, 1.0);
    }
    let nxsquared = t * x;
    if n <= 140 {
        if nxsquared <= 0.754693 {
            return (1.0 - kolmogn_durbin_cdf(n, x)).clamp(0.0, 1.0);
        }
        if nxsquared <= 4.0 {
            return (1.0 - kolmogn_pomeranz_cdf(n, x)).clamp(0.0, 1.0);
        }
        return (2.0 * smirnov_sf(n, x)).clamp(0.0, 1.0);
    }
    if nxsquared >= 370.0 {
        return 0.0;
    }
    if nxsquared >= 2.2 {
        return (2.0 * smirnov_sf(n, x)).clamp(0.0, 1.0);
    }
    let cdf = if nxsquared >= 18.0 {
        1.0
    } else if n <= 100_000 && nf * x.powf(1.5) <= 1.4 {
        kolmogn_durbin_cdf(n, x)
    } else {
        kolmogn_pelz_good_cdf(n, x)
    };
    (1.0 - cdf).clamp(0.0, 1.0)
}

fn matmul(a: &[f64], b: &[f64], m: usize) -> Vec<f64> {
    let mut c = vec![0.0; m * m];
    for i in 0..m {
        for k in 0..m {
            let aik = a[i * m + k];
            if aik == 0.0 {
                continue;
            }
            let (brow, crow) = (&b[k * m..(k + 1) * m], &mut c[i * m..(i + 1) * m]);
            for (cv, bv) in crow.iter_mut().zip(brow) {
                *cv += aik * bv;
            }
        }
    }
    c
}

/// `Pr(D_n <= d)` by Durbin's matrix (Marsaglia, Tsang, Wang 2003).
fn kolmogn_durbin_cdf(n: i64, d: f64) -> f64 {
    if d >= 1.0 {
        return 1.0;
    }
    let nd = n as f64 * d;
    if nd <= 0.5 {
        return 0.0;
    }
    let k = nd.ceil() as usize;
    let h = k as f64 - nd;
    let m = 2 * k - 1;
    let mut hm = vec![0.0; m * m];
    let mut v: Vec<f64> = (1..=m).map(|j| 1.0 - h.powi(j as i32)).collect();
    let mut w = vec![0.0; m];
    let mut fac = 1.0f64;
    for j in 1..=m {
        w[j - 1] = fac;
        fac /= j as f64;
        v[j - 1] *= fac;
    }
    let tt = (2.0 * h - 1.0).max(0.0).powi(m as i32) - 2.0 * h.powi(m as i32);
    v[m - 1] = (1.0 + tt) * fac;
    for i in 1..m {
        for (r, wv) in (i - 1..m).zip(w.iter()) {
            hm[r * m + i] = *wv;
        }
    }
    for r in 0..m {
        hm[r * m] = v[r];
    }
    for c in 0..m {
        hm[(m - 1) * m + c] = v[m - 1 - c];
    }
    let mut hpwr = vec![0.0; m * m];
    for i in 0..m {
        hpwr[i * m + i] = 1.0;
    }
    let mut nn = n;
    let mut expnt: i32 = 0;
    let mut hexpnt: i32 = 0;
    while nn > 0 {
        if nn % 2 == 1 {
            hpwr = matmul(&hpwr, &hm, m);
            expnt += hexpnt;
        }
        hm = matmul(&hm, &hm, m);
        hexpnt *= 2;
        if hm[(k - 1) * m + (k - 1)].abs() > ep128() {
            for v in hm.iter_mut() {
                *v /= ep128();
            }
            hexpnt += E128;
        }
        nn /= 2;
    }
    let mut p = hpwr[(k - 1) * m + (k - 1)];
    for i in 1..=n {
        p = i as f64 * p / n as f64;
        if p.abs() < em128() {
            p *= ep128();
            expnt -= E128;
        }
    }
    if expnt != 0 {
        p = ldexp(p, expnt);
    }
    p.clamp(0.0, 1.0)
}

fn pomeranz_j1j2(i: i64, n: i64, ll: i64, ceilf: i64, roundf: i64) -> (i64, i64) {
    let (j1, j2) = if i == 0 {
        (-ll - ceilf - 1, ll + ceilf - 1)
    } else {
        let (ip1div2, ip1mod2) = ((i + 1) / 2, (i + 1) % 2);
        if ip1mod2 == 0 {
            if ip1div2 == n + 1 {
                (n - ll - ceilf - 1, n + ll + ceilf - 1)
            } else {
                (ip1div2 - 1 - ll - roundf - 1, ip1div2 + ll - 1 + ceilf - 1)
            }
        } else {
            (ip1div2 - 1 - ll - 1, ip1div2 + ll + roundf - 1)
        }
    };
    ((j1 + 2).max(0), j2.min(n))
}

/// Python slice bounds `[start:end]` on a sequence of length `len`.
fn py_slice(start: i64, end: i64, len: usize) -> (usize, usize) {
    let norm = |i: i64| -> usize {
        if i < 0 {
            (len as i64 + i).max(0) as usize
        } else {
            (i as usize).min(len)
        }
    };
    let (s, e) = (norm(start), norm(end));
    (s, e.max(s))
}

fn convolve_full(a: &[f64], b: &[f64]) -> Vec<f64> {
    if a.is_empty() || b.is_empty() {
        return Vec::new();
    }
    let mut out = vec![0.0; a.len() + b.len() - 1];
    for (i, &av) in a.iter().enumerate() {
        for (j, &bv) in b.iter().enumerate() {
            out[i + j] += av * bv;
        }
    }
    out
}

/// `Pr(D_n <= x)` by Pomeranz's recursion (Pomeranz 1974).
fn kolmogn_pomeranz_cdf(n: i64, x: f64) -> f64 {
    let t = n as f64 * x;
    let ll = t.floor() as i64;
    let f = t - ll as f64;
    let g = f.min(1.0 - f);
    let ceilf = i64::from(f > 0.0);
    let roundf = i64::from(f > 0.5);
    let npwrs = (2 * (ll + 1)) as usize;
    let mut gpower = vec![0.0; npwrs];
    let mut twogpower = vec![0.0; npwrs];
    let mut onem2gpower = vec![0.0; npwrs];
    gpower[0] = 1.0;
    twogpower[0] = 1.0;
    onem2gpower[0] = 1.0;
    let nf = n as f64;
    let (g_over_n, two_g_over_n, one_minus_two_g_over_n) =
        (g / nf, 2.0 * g / nf, (1.0 - 2.0 * g) / nf);
    for m in 1..npwrs {
        gpower[m] = gpower[m - 1] * g_over_n / m as f64;
        twogpower[m] = twogpower[m - 1] * two_g_over_n / m as f64;
        onem2gpower[m] = onem2gpower[m - 1] * one_minus_two_g_over_n / m as f64;
    }
    let mut v0 = vec![0.0; npwrs];
    let mut v1 = vec![0.0; npwrs];
    v1[0] = 1.0;
    let (mut v0s, mut v1s): (i64, i64) = (0, 0);
    let mut expnt: i32 = 0;
    let mut j1 = pomeranz_j1j2(0, n, ll, ceilf, roundf).0;
    for i in 1..(2 * n + 2) {
        let k1 = j1;
        std::mem::swap(&mut v0, &mut v1);
        std::mem::swap(&mut v0s, &mut v1s);
        v1.fill(0.0);
        let (nj1, j2) = pomeranz_j1j2(i, n, ll, ceilf, roundf);
        j1 = nj1;
        let pwrs = if i == 1 || i == 2 * n + 1 {
            &gpower
        } else if i % 2 == 1 {
            &twogpower
        } else {
            &onem2gpower
        };
        let ln2 = j2 - k1 + 1;
        if ln2 > 0 {
            let (s0, e0) = py_slice(k1 - v0s, k1 - v0s + ln2, npwrs);
            let (s1, e1) = py_slice(0, ln2, npwrs);
            let conv = convolve_full(&v0[s0..e0], &pwrs[s1..e1]);
            let conv_start = j1 - k1;
            let conv_len = j2 - j1 + 1;
            let (cs, ce) = py_slice(conv_start, conv_start + conv_len, conv.len());
            let src = &conv[cs..ce];
            let (ds, de) = py_slice(0, conv_len, npwrs);
            let dst = &mut v1[ds..de];
            let k = dst.len().min(src.len());
            dst[..k].copy_from_slice(&src[..k]);
            let vmax = v1.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
            if 0.0 < vmax && vmax < em128() {
                for v in v1.iter_mut() {
                    *v *= ep128();
                }
                expnt -= E128;
            }
            v1s = v0s + j1 - k1;
        }
    }
    let mut ans = v1[(n - v1s) as usize];
    for m in 1..=n {
        if ans.abs() > ep128() {
            ans *= em128();
            expnt += E128;
        }
        ans *= m as f64;
    }
    if expnt != 0 {
        ans = ldexp(ans, expnt);
    }
    ans.clamp(0.0, 1.0)
}

/// Pelz-Good approximation to `Pr(D_n <= x)` (Pelz & Good 1976).
fn kolmogn_pelz_good_cdf(n: i64, x: f64) -> f64 {
    if x <= 0.0 {
        return 0.0;
    }
    if x >= 1.0 {
        return 1.0;
    }
    let pi = std::f64::consts::PI;
    let pi_four = PI_SQUARED * PI_SQUARED;
    let pi_six = pi_four * PI_SQUARED;
    let z = (n as f64).sqrt() * x;
    let (zsquared, zthree, zfour, zsix) = (z.powi(2), z.powi(3), z.powi(4), z.powi(6));
    let qlog = -PI_SQUARED / 8.0 / zsquared;
    if qlog < MIN_LOG {
        return 0.0;
    }
    let q = qlog.exp();
    let k1a = -zsquared;
    let k1b = PI_SQUARED / 4.0;
    let k2a = 6.0 * zsix + 2.0 * zfour;
    let k2b = (2.0 * zfour - 5.0 * zsquared) * PI_SQUARED / 4.0;
    let k2c = pi_four * (1.0 - 2.0 * zsquared) / 16.0;
    let k3d = pi_six * (5.0 - 30.0 * zsquared) / 64.0;
    let k3c = pi_four * (-60.0 * zsquared + 212.0 * zfour) / 16.0;
    let k3b = PI_SQUARED * (135.0 * zfour - 96.0 * zsix) / 4.0;
    let k3a = -30.0 * zsix - 90.0 * z.powi(8);
    let mut kk = [0.0f64; 4];
    let maxk = (16.0 * z / pi).ceil() as i64;
    for k in (1..=maxk).rev() {
        let m = (2 * k - 1) as f64;
        let (msquared, mfour, msix) = (m.powi(2), m.powi(4), m.powi(6));
        let qpower = q.powf((8 * k) as f64);
        let coeffs = [
            1.0,
            k1a + k1b * msquared,
            k2a + k2b * msquared + k2c * mfour,
            k3a + k3b * msquared + k3c * mfour + k3d * msix,
        ];
        for (kv, c) in kk.iter_mut().zip(coeffs) {
            *kv *= qpower;
            *kv += c;
        }
    }
    let div = [z, 6.0 * zfour, 72.0 * z.powi(7), 6480.0 * z.powi(10)];
    for (kv, dv) in kk.iter_mut().zip(div) {
        *kv *= q;
        *kv *= SQRT2PI;
        *kv /= dv;
    }
    let q = (-PI_SQUARED / 2.0 / zsquared).exp();
    let sqrt3z = SQRT3 * z;
    let mut k2extra = 0.0;
    let mut k3extra = 0.0;
    for k in (1..=maxk).rev() {
        let kf = k as f64;
        let ksquared = kf * kf;
        let qp = q.powf(ksquared);
        let kspi = pi * kf;
        k2extra += ksquared * qp;
        k3extra += (sqrt3z + kspi) * (sqrt3z - kspi) * ksquared * qp;
    }
    k2extra *= PI_SQUARED * SQRT2PI / (-36.0 * zthree);
    kk[2] += k2extra;
    k3extra *= PI_SQUARED * SQRT2PI / (216.0 * zsix);
    kk[3] += k3extra;
    for (i, kv) in kk.iter_mut().enumerate() {
        *kv /= (n as f64).powf(i as f64 / 2.0);
    }
    kk.iter().sum()
}

/// One-sided `Pr(D+_n >= x)` (cephes `smirnov`), by the Birnbaum-Tingey
/// sum computed term by term in log space.
pub fn smirnov_sf(n: i64, x: f64) -> f64 {
    if !(n > 0 && (0.0..=1.0).contains(&x)) {
        return f64::NAN;
    }
    if n == 1 {
        return 1.0 - x;
    }
    if x == 0.0 {
        return 1.0;
    }
    if x == 1.0 {
        return 0.0;
    }
    let nf = n as f64;
    // floor(n x) and its remainder, exactly.
    let nx_hi = nf * x;
    let nx_lo = nf.mul_add(x, -nx_hi);
    let mut nxfl = nx_hi.floor();
    let mut alpha = (nx_hi - nxfl) + nx_lo;
    if alpha < 0.0 {
        nxfl -= 1.0;
        alpha += 1.0;
    }
    if alpha >= 1.0 {
        nxfl += 1.0;
        alpha = 0.0;
    }
    let nxfl = nxfl as i64;
    let mut n1mxfl = n - nxfl - if alpha == 0.0 { 0 } else { 1 };
    if alpha == 0.0 {
        n1mxfl -= 1;
    }
    if nxfl == 0 || (nxfl == 1 && alpha == 0.0) {
        let t = (1.0 + x).powf(nf - 1.0);
        return 1.0 - x * t;
    }
    const MINLOG: f64 = -7.451_332_191_019_412e2;
    if -2.0 * nf * x * x < MINLOG {
        return 0.0;
    }
    if nxfl >= n - 1 {
        return (1.0 - x).powf(nf);
    }
    if n > 1_000_000 {
        let logp = -(6.0 * nf * x + 1.0).powi(2) / 18.0 / nf;
        return if logp < -std::f64::consts::LN_2 {
            logp.exp()
        } else {
            1.0 + logp.exp_m1()
        };
    }
    // Lower sum: sf = x * sum_{v=0}^{n1mxfl} C(n,v) (1-x-v/n)^(n-v) (x+v/n)^(v-1)
    let n_terms = n1mxfl + 1;
    let vmid = n / 2;
    let mut sum = (1.0 - x).powf(nf) / x;
    let mut ln_c = 0.0f64;
    for j in 1..n_terms {
        let v = j;
        ln_c += ((n - v + 1) as f64).ln() - (v as f64).ln();
        let t2x = ((n - v - nxfl) as f64 - alpha) / nf;
        let t1x = ((v + nxfl) as f64 + alpha) / nf;
        let ln_term = ln_c + (n - v) as f64 * t2x.ln() + (v - 1) as f64 * t1x.ln();
        let aj = ln_term.exp();
        if aj.is_finite() && aj != 0.0 {
            sum += aj;
        }
        if aj != 0.0 {
            if 4.0 * (n_terms - j) as f64 * aj.abs() < f64::EPSILON * sum && j != n_terms - 1 {
                break;
            }
        } else if j > vmid {
            break;
        }
    }
    (x * sum).clamp(0.0, 1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn statistic_hand_worked() {
        // a = {1,2,3}, b = {2,4}: at 1: 1/3-0; at 2: 2/3-1/2; at 3: 1-1/2 = 1/2;
        // at 4: 0. D = 1/2.
        let r = ks_2samp(&[3.0, 1.0, 2.0], &[4.0, 2.0]).unwrap();
        assert!((r.d - 0.5).abs() < 1e-15);
        assert_eq!(r.method, KsMethod::Exact);
    }

    #[test]
    fn empty_or_nan_is_an_error() {
        assert!(ks_2samp(&[], &[1.0]).is_err());
        assert!(ks_2samp(&[f64::NAN], &[1.0]).is_err());
    }

    #[test]
    fn equal_n_exact_matches_closed_form() {
        // n1 = n2 = 2, fully separated: Pr(D >= 1) = 2 / C(4,2) = 1/3.
        let r = ks_2samp(&[0.0, 1.0], &[5.0, 6.0]).unwrap();
        assert_eq!(r.d, 1.0);
        assert!((r.p - 1.0 / 3.0).abs() < 1e-15, "{}", r.p);
    }
}
