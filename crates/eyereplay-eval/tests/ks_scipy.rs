//! The KS test against scipy.stats.ks_2samp's own output, stored in
//! tests/data/ks_scipy.json by scripts/dev/ks_reference.sh (scipy pinned).

use eyereplay_eval::{ks_2samp, KsMethod};

#[test]
fn ks_2samp_agrees_with_scipy() {
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/data/ks_scipy.json"
    ))
    .unwrap();
    let doc: serde_json::Value = serde_json::from_str(&text).unwrap();
    let cases = doc["cases"].as_array().unwrap();
    assert!(cases.len() >= 20);
    let mut failures = Vec::new();
    for c in cases {
        let name = c["name"].as_str().unwrap();
        let branch = c["branch"].as_str().unwrap();
        let v = |k: &str| -> Vec<f64> {
            c[k].as_array()
                .unwrap()
                .iter()
                .map(|x| x.as_f64().unwrap())
                .collect()
        };
        let (a, b) = (v("a"), v("b"));
        let (d_ref, p_ref) = (c["d"].as_f64().unwrap(), c["p"].as_f64().unwrap());
        let r = ks_2samp(&a, &b).unwrap();
        let want_method = if branch.starts_with("exact") {
            KsMethod::Exact
        } else {
            KsMethod::Asymptotic
        };
        let p_ok = if p_ref == 0.0 {
            r.p == 0.0
        } else {
            ((r.p - p_ref) / p_ref).abs() <= 1e-6
        };
        let d_ok = (r.d - d_ref).abs() <= 1e-9;
        println!(
            "{name:40} {branch:28} D {:.12} (scipy {:.12})  p {:.10e} (scipy {:.10e}) rel {:.2e}",
            r.d,
            d_ref,
            r.p,
            p_ref,
            if p_ref == 0.0 {
                0.0
            } else {
                ((r.p - p_ref) / p_ref).abs()
            }
        );
        if !(p_ok && d_ok && r.method == want_method) {
            failures.push(name.to_string());
        }
    }
    assert!(failures.is_empty(), "disagree with scipy: {failures:?}");
}
