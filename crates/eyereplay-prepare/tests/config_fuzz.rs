//! Seeded mutation fuzzing of the dataset config: `examples/dataset.toml`
//! (every key at its default) mutated by bit flips, truncations, inserted
//! garbage lines, swapped values, huge / NaN / infinite numbers. Loading
//! must give a one-line error naming the file, or a config that validated;
//! never a panic. `EYEREPLAY_FUZZ_CASES` raises the case count.

use eyereplay_prepare::DatasetConfig;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::panic::{catch_unwind, AssertUnwindSafe};

const GARBAGE: &[&str] = &[
    "nan",
    "inf",
    "-inf",
    "1e308",
    "-1",
    "0",
    "18446744073709551616",
    "\"\"",
    "[",
    "{",
    "[classes.reading]",
    "[classes.nonsense]",
    "fps = 0",
    "session_frames = -5",
    "= 3",
    "\u{e9}\u{301}",
    "\"\u{1F600}\"",
    "[[classes]]",
];

fn mutate(rng: &mut ChaCha8Rng, text: &str) -> String {
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    match rng.gen_range(0..6) {
        0 => {
            // Bit flip, then back to text (lossy, as a user's editor might).
            let mut b = text.as_bytes().to_vec();
            let i = rng.gen_range(0..b.len());
            b[i] ^= 1 << rng.gen_range(0..8);
            return String::from_utf8_lossy(&b).into_owned();
        }
        1 => {
            // Truncation at a char boundary.
            let mut n = rng.gen_range(0..=text.len());
            while !text.is_char_boundary(n) {
                n -= 1;
            }
            return text[..n].to_string();
        }
        2 => {
            let at = rng.gen_range(0..=lines.len());
            lines.insert(at, GARBAGE[rng.gen_range(0..GARBAGE.len())].to_string());
        }
        3 => {
            // The values of two assignments swapped.
            let with_eq: Vec<usize> = (0..lines.len())
                .filter(|&i| lines[i].contains(" = "))
                .collect();
            if with_eq.len() >= 2 {
                let (a, b) = (
                    with_eq[rng.gen_range(0..with_eq.len())],
                    with_eq[rng.gen_range(0..with_eq.len())],
                );
                let (ka, va) = lines[a]
                    .split_once(" = ")
                    .map(|(k, v)| (k.to_string(), v.to_string()))
                    .unwrap();
                let (kb, vb) = lines[b]
                    .split_once(" = ")
                    .map(|(k, v)| (k.to_string(), v.to_string()))
                    .unwrap();
                lines[a] = format!("{ka} = {vb}");
                lines[b] = format!("{kb} = {va}");
            }
        }
        4 => {
            // A value replaced by garbage.
            let k = rng.gen_range(0..lines.len());
            if let Some((key, _)) = lines[k].split_once(" = ") {
                lines[k] = format!("{key} = {}", GARBAGE[rng.gen_range(0..GARBAGE.len())]);
            }
        }
        _ => {
            let k = rng.gen_range(0..lines.len());
            lines.remove(k);
        }
    }
    lines.join("\n")
}

#[test]
fn dataset_config_survives_mutation() {
    let seed_path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/dataset.toml");
    let seed = std::fs::read_to_string(&seed_path).unwrap();
    let cases: usize = std::env::var("EYEREPLAY_FUZZ_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(400);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("mutated.toml");
    std::fs::write(&path, &seed).unwrap();
    DatasetConfig::load(&path).expect("the seed config loads");
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    for case in 0..cases {
        let mut text = seed.clone();
        for _ in 0..rng.gen_range(1..=3) {
            text = mutate(&mut rng, &text);
        }
        std::fs::write(&path, &text).unwrap();
        let r = catch_unwind(AssertUnwindSafe(|| {
            (
                DatasetConfig::load(&path).map(|_| ()),
                DatasetConfig::parse(&text).map(|c| c.validate()),
            )
        }))
        .unwrap_or_else(|_| panic!("case {case} panicked: {text:?}"));
        if let Err(e) = r.0 {
            let m = e.to_string();
            assert!(
                m.contains("mutated.toml") && !m.contains('\n'),
                "case {case}: {m}\n{text}"
            );
        }
        if let Err(m) = r.1 {
            let m = m.to_string();
            assert!(!m.contains('\n'), "case {case}: {m}");
        }
    }
}
