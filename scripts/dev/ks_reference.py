"""Reference values of scipy.stats.ks_2samp for eyereplay-eval's KS tests.

Writes a JSON file holding, for each case, the two samples and scipy's
two-sided D statistic and p-value (method='auto': exact when
max(n1, n2) <= 10000, else the asymptotic kstwo distribution with
n = round(n1*n2/(n1+n2))). The `branch` field names the code path scipy takes
for the p-value, so the cases can be seen to cover every path the Rust port
implements. Run through scripts/dev/ks_reference.sh (pinned scipy in a venv).
"""

import json
import math
import sys

import numpy as np
import scipy
from scipy import stats


def branch(n1, n2, d):
    """Mirror scipy's method choice (ks_2samp + _kolmogn, two-sided, sf)."""
    if max(n1, n2) <= 10000:
        g = math.gcd(n1, n2)
        lcm = (n1 // g) * n2
        h = int(np.round(d * lcm))
        if h == 0:
            return "exact-h0"
        return "exact-square" if n1 == n2 else "exact-inside"
    m, n = sorted([float(n1), float(n2)], reverse=True)
    n = int(np.round(m * n / (m + n)))
    x = d
    if x >= 1.0:
        return "asymp-x>=1"
    if x <= 0.0:
        return "asymp-x<=0"
    t = n * x
    if t <= 1.0:
        return "asymp-ruben-gambino-low"
    if t >= n - 1:
        return "asymp-ruben-gambino-high"
    if x >= 0.5:
        return "asymp-2smirnov-x>=0.5"
    nxx = t * x
    if n <= 140:
        if nxx <= 0.754693:
            return "asymp-n<=140-durbin"
        if nxx <= 4:
            return "asymp-n<=140-pomeranz"
        return "asymp-n<=140-2smirnov"
    if nxx >= 370.0:
        return "asymp-zero"
    if nxx >= 2.2:
        return "asymp-2smirnov"
    if n <= 100000 and n * x**1.5 <= 1.4:
        return "asymp-durbin"
    return "asymp-pelz-good"


def main(out_path):
    rng = np.random.default_rng(20261121)
    cases = []

    def add(name, a, b):
        a = np.asarray(a, dtype=np.float64)
        b = np.asarray(b, dtype=np.float64)
        # Large samples are stored with 4 decimals to keep the file small;
        # scipy sees exactly the rounded values.
        if len(a) + len(b) >= 2000:
            a, b = np.round(a, 4), np.round(b, 4)
        r = stats.ks_2samp(a, b, alternative="two-sided", method="auto")
        cases.append(
            {
                "name": name,
                "branch": branch(len(a), len(b), float(r.statistic)),
                "d": float(r.statistic),
                "p": float(r.pvalue),
                "a": [float(v) for v in a],
                "b": [float(v) for v in b],
            }
        )

    norm = rng.standard_normal
    # Small samples: exact p.
    add("equal_n8_no_ties", norm(8), norm(8) + 0.5)
    add("unequal_7_13", norm(7), norm(13) + 1.0)
    add("separated_5_6", norm(5), norm(6) + 100.0)
    add("identical_10", np.arange(10.0), np.arange(10.0))
    add("ties_poisson_40_55", rng.poisson(3.0, 40), rng.poisson(3.6, 55))
    add("ties_poisson_equal_60", rng.poisson(4.0, 60), rng.poisson(4.0, 60))
    add("unequal_1000_2500", norm(1000), norm(2500) * 1.1 + 0.05)
    add("equal_3000_ties", np.round(norm(3000), 1), np.round(norm(3000) + 0.1, 1))
    add("geometric_ties_4000_9999", rng.geometric(0.2, 4000), rng.geometric(0.21, 9999))
    add("unequal_37_10000", norm(37), norm(10000) + 0.3)
    add("exact_tiny_p_500_800", norm(500), norm(800) + 1.0)
    add("exact_tiny_p_equal_2000", norm(2000), norm(2000) + 0.5)
    # Large samples: asymptotic p (kstwo with n = round(n1*n2/(n1+n2))).
    add("asymp_same_10001_10100", np.round(norm(10001), 3), np.round(norm(10100), 3))
    add("asymp_smirnov_moderate_10001_12000",
        np.round(norm(10001), 3), np.round(norm(12000) + 0.04, 3))
    add("asymp_smirnov_10001_11000",
        np.round(norm(10001), 3), np.round(norm(11000) + 0.12, 3))
    add("asymp_zero_10001_10002",
        np.round(norm(10001), 3), np.round(norm(10002) + 0.9, 3))
    add("asymp_ties_geometric_12000_10001",
        rng.geometric(0.2, 12000), rng.geometric(0.205, 10001))
    add("asymp_small_n_durbin_10001_60", np.round(norm(10001), 3),
        np.round(stats.norm.ppf((np.arange(60) + 0.5) / 60), 3))
    add("asymp_small_n_pomeranz_10001_120",
        np.round(norm(10001), 3), np.round(norm(120) + 0.35, 3))
    add("asymp_small_n_smirnov_10001_100",
        np.round(norm(10001), 3), np.round(norm(100) + 0.6, 3))
    add("asymp_ruben_gambino_low_10001_3",
        np.round(norm(10001), 3), np.array([-0.97, 0.0, 0.97]))
    add("asymp_ruben_gambino_high_10001_3",
        np.round(norm(10001), 3), np.array([2.5, 3.0, 3.5]))
    base = np.round(norm(10001), 3)
    add("asymp_durbin_small_k_10001_10006",
        base, np.concatenate([base, [5.0, 5.1, 5.2, 5.3, 5.4]]))
    add("asymp_durbin_large_k_10001_10041",
        base, np.concatenate([base, 6.0 + np.arange(40) / 10.0]))
    add("asymp_x_ge_half_10001_9", np.round(norm(10001), 3), np.round(norm(9) + 1.2, 3))

    doc = {
        "generator": "scripts/dev/ks_reference.py",
        "scipy_version": scipy.__version__,
        "numpy_version": np.__version__,
        "function": "scipy.stats.ks_2samp(a, b, alternative='two-sided', method='auto')",
        "cases": cases,
    }
    with open(out_path, "w") as f:
        json.dump(doc, f, separators=(",", ":"))
        f.write("\n")
    for c in cases:
        print(f"{c['name']:40s} n={len(c['a'])},{len(c['b'])} {c['branch']:28s} "
              f"D={c['d']:.6g} p={c['p']:.6g}")


if __name__ == "__main__":
    main(sys.argv[1])
