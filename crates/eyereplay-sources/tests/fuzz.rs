//! Seeded mutation fuzzing of every reader: a valid seed file is mutated
//! (bit flips, truncations, inserted garbage lines, swapped columns, huge /
//! NaN / infinite numbers, deleted and duplicated lines) and read. Each call
//! must return a clean one-line error naming the file, or recordings that
//! keep the readers' guarantees; never panic, never hang. The number of
//! cases is bounded so the suite stays fast; `EYEREPLAY_FUZZ_CASES` raises
//! it for a longer local run.

mod common;
use common::{csv_spec, eyelink_spec};
use eyereplay_sources::{
    read_source, EyeChoice, ReadOptions, Recording, SourceSpec, TimeUnit, ViewingGeometry,
};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};

fn cases() -> usize {
    std::env::var("EYEREPLAY_FUZZ_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(150)
}

const GARBAGE: &[&str] = &[
    "",
    "NaN",
    "nan",
    "inf",
    "-inf",
    "1e308",
    "-1e308",
    "1e-320",
    "0",
    "-0",
    "99999999999999999999999",
    ".",
    "n/a",
    "\u{fffd}",
    "\"",
    ",,,,",
    "\t\t",
    "SAMPLES GAZE LEFT",
    "EBLINK L 1 2 3",
    "MSG 0 DISPLAY_COORDS 0 0 -1 -1",
];

/// One random mutation of `text`.
/// A line's separator (tab, comma, else space) and its fields.
fn fields(line: &[u8]) -> (u8, Vec<Vec<u8>>) {
    let sep = if line.contains(&b'\t') {
        b'\t'
    } else if line.contains(&b',') {
        b','
    } else {
        b' '
    };
    (sep, line.split(|c| *c == sep).map(<[u8]>::to_vec).collect())
}

fn mutate(rng: &mut ChaCha8Rng, text: &[u8]) -> Vec<u8> {
    let mut b = text.to_vec();
    let lines =
        |b: &[u8]| -> Vec<Vec<u8>> { b.split(|c| *c == b'\n').map(<[u8]>::to_vec).collect() };
    match rng.gen_range(0..8) {
        // Bit flip.
        0 if !b.is_empty() => {
            let i = rng.gen_range(0..b.len());
            b[i] ^= 1 << rng.gen_range(0..8);
        }
        // Truncation.
        1 => b.truncate(rng.gen_range(0..=b.len())),
        // Garbage line inserted.
        2 => {
            let mut l = lines(&b);
            let at = rng.gen_range(0..=l.len());
            l.insert(
                at,
                GARBAGE[rng.gen_range(0..GARBAGE.len())].as_bytes().to_vec(),
            );
            b = l.join(&b'\n');
        }
        // Two fields of a line swapped.
        3 => {
            let mut l = lines(&b);
            let k = rng.gen_range(0..l.len());
            let (sep, mut f) = fields(&l[k]);
            if f.len() >= 2 {
                let (i, j) = (rng.gen_range(0..f.len()), rng.gen_range(0..f.len()));
                f.swap(i, j);
            }
            l[k] = f.join(&sep);
            b = l.join(&b'\n');
        }
        // A field replaced by a huge, tiny, NaN, infinite or empty value.
        4 | 5 => {
            let mut l = lines(&b);
            let k = rng.gen_range(0..l.len());
            let (sep, mut f) = fields(&l[k]);
            let i = rng.gen_range(0..f.len());
            f[i] = GARBAGE[rng.gen_range(0..GARBAGE.len())].as_bytes().to_vec();
            l[k] = f.join(&sep);
            b = l.join(&b'\n');
        }
        // A line deleted.
        6 => {
            let mut l = lines(&b);
            let k = rng.gen_range(0..l.len());
            l.remove(k);
            b = l.join(&b'\n');
        }
        // A line duplicated.
        _ => {
            let mut l = lines(&b);
            let k = rng.gen_range(0..l.len());
            let dup = l[k].clone();
            l.insert(k, dup);
            b = l.join(&b'\n');
        }
    }
    b
}

/// Applies 1-3 mutations.
fn mutated(rng: &mut ChaCha8Rng, seed: &[u8]) -> Vec<u8> {
    let mut b = seed.to_vec();
    for _ in 0..rng.gen_range(1..=3) {
        b = mutate(rng, &b);
    }
    b
}

/// Reads `spec` and checks the contract: no panic; an error is one line and
/// names `file_name`; recordings hold strictly increasing finite times, at
/// least two gaze samples per segment and a finite positive rate.
fn check(spec: &SourceSpec, file_name: &str, case: &str) {
    let r = catch_unwind(AssertUnwindSafe(|| {
        read_source(spec, &ReadOptions::default())
    }));
    let r = r.unwrap_or_else(|_| panic!("reader panicked on {case}"));
    match r {
        Err(e) => {
            let m = e.to_string();
            assert!(
                m.contains(file_name),
                "{case}: error does not name the file: {m}"
            );
            assert!(!m.contains('\n'), "{case}: error is not one line: {m}");
        }
        Ok(recs) => {
            assert!(!recs.is_empty(), "{case}");
            for rec in &recs {
                check_recording(rec, case);
            }
        }
    }
}

fn check_recording(rec: &Recording, case: &str) {
    assert!(
        rec.rate_hz.is_finite() && rec.rate_hz > 0.0,
        "{case}: rate {}",
        rec.rate_hz
    );
    assert!(!rec.segments.is_empty(), "{case}");
    for seg in &rec.segments {
        let s = seg.samples();
        assert!(s.iter().filter(|x| x.is_gaze()).count() >= 2, "{case}");
        assert!(s.iter().all(|x| x.t_s.is_finite()), "{case}");
        assert!(s.windows(2).all(|w| w[1].t_s > w[0].t_s), "{case}");
    }
    if let Some(p) = rec.px_per_deg {
        assert!(p.is_finite() && p > 0.0, "{case}: px_per_deg {p}");
    }
}

/// Runs `cases()` mutations of `seed` written to `dir/name`, reading each
/// with `spec(path)`. `extra` writes companion files (a BIDS sidecar).
fn fuzz(
    name: &str,
    seed: &[u8],
    rng_seed: u64,
    spec: impl Fn(PathBuf) -> SourceSpec,
    extra: impl Fn(&Path, &mut ChaCha8Rng),
) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(name);
    // The seed itself must read.
    std::fs::write(&path, seed).unwrap();
    extra(dir.path(), &mut ChaCha8Rng::seed_from_u64(0));
    let ok = read_source(&spec(path.clone()), &ReadOptions::default());
    assert!(ok.is_ok(), "seed of {name} does not read: {:?}", ok.err());
    let mut rng = ChaCha8Rng::seed_from_u64(rng_seed);
    for case in 0..cases() {
        let body = mutated(&mut rng, seed);
        std::fs::write(&path, &body).unwrap();
        extra(dir.path(), &mut rng);
        check(
            &spec(path.clone()),
            name,
            &format!(
                "{name} case {case} (rng seed {rng_seed}): {:?}",
                String::from_utf8_lossy(&body)
            ),
        );
    }
}

fn no_extra(_: &Path, _: &mut ChaCha8Rng) {}

/// Screen-pixel gaze samples at 500 Hz with a tracking loss.
fn samples_table(sep: char) -> String {
    let mut s = format!("time{sep}x{sep}y\n");
    for i in 0..60 {
        let (x, y) = if (20..23).contains(&i) {
            (String::new(), String::new())
        } else {
            (
                format!("{:.1}", 900.0 + 3.0 * i as f64),
                format!("{:.1}", 500.0 - 2.0 * i as f64),
            )
        };
        s.push_str(&format!("{}{sep}{x}{sep}{y}\n", 1000 + 2 * i));
    }
    s
}

#[test]
fn samples_csv_and_tsv_survive_mutation() {
    fuzz(
        "gaze.csv",
        samples_table(',').as_bytes(),
        1,
        csv_spec,
        no_extra,
    );
    fuzz(
        "gaze.tsv",
        samples_table('\t').as_bytes(),
        2,
        csv_spec,
        no_extra,
    );
}

#[test]
fn eyelink_asc_survives_mutation() {
    let mut s = String::from(
        "** CONVERTED FROM test.edf\nMSG\t100 DISPLAY_COORDS 0 0 1279 1023\nSTART\t1000 \tLEFT\tRIGHT\tSAMPLES\tEVENTS\nSAMPLES\tGAZE\tLEFT\tRIGHT\tRATE\t500.00\n",
    );
    for i in 0..50 {
        let t = 1000 + 2 * i;
        if i == 20 {
            s.push_str(&format!("SBLINK L {t}\n"));
        }
        if (20..24).contains(&i) {
            s.push_str(&format!(
                "{t}\t   .\t   .\t    0.0\t  650.0\t  480.0\t 1000.0\t.....\n"
            ));
        } else {
            s.push_str(&format!(
                "{t}\t {:.1}\t {:.1}\t 1000.0\t {:.1}\t {:.1}\t 1000.0\t.....\n",
                640.0 + i as f64,
                500.0 - i as f64,
                650.0 + i as f64,
                480.0
            ));
        }
        if i == 23 {
            s.push_str(&format!("EBLINK L {} {t} 8\n", t - 6));
        }
    }
    s.push_str("END\t1100 \tSAMPLES\tEVENTS\n");
    for (k, eye) in [EyeChoice::Mean, EyeChoice::Left, EyeChoice::Right]
        .into_iter()
        .enumerate()
    {
        fuzz(
            "rec.asc",
            s.as_bytes(),
            10 + k as u64,
            |path| eyelink_spec(path, eye),
            no_extra,
        );
    }
}

const SIDECAR: &str = r#"{
  "SamplingFrequency": 500,
  "StartTime": 0,
  "Columns": ["timestamp", "x_coordinate", "y_coordinate", "pupil_size"],
  "timestamp": { "Units": "ms" },
  "ScreenResolution": [1280, 1024],
  "ScreenSize": [0.531, 0.299],
  "ScreenDistance": 0.6
}
"#;

#[test]
fn bids_physio_and_sidecar_survive_mutation() {
    let mut tsv = String::new();
    for i in 0..60 {
        if (30..33).contains(&i) {
            tsv.push_str(&format!("{}\tn/a\tn/a\tn/a\n", 5000 + 2 * i));
        } else {
            tsv.push_str(&format!(
                "{}\t{:.1}\t{:.1}\t1000\n",
                5000 + 2 * i,
                600.0 + i as f64,
                400.0
            ));
        }
    }
    let spec = |path| SourceSpec::Bids {
        path,
        screen_px: None,
        geometry: ViewingGeometry::default(),
    };
    let sidecar_as_is = |dir: &Path, _: &mut ChaCha8Rng| {
        std::fs::write(dir.join("sub-01_physio.json"), SIDECAR).unwrap();
    };
    // The table mutated, the sidecar intact.
    fuzz("sub-01_physio.tsv", tsv.as_bytes(), 20, spec, sidecar_as_is);
    // The sidecar mutated (and the unit left to inference when Units goes),
    // the table intact: the error names the sidecar, which shares the stem.
    let sidecar_mutated = |dir: &Path, rng: &mut ChaCha8Rng| {
        std::fs::write(
            dir.join("sub-01_physio.json"),
            mutated(rng, SIDECAR.as_bytes()),
        )
        .unwrap();
    };
    fuzz_sidecar(tsv.as_bytes(), 21, spec, sidecar_mutated);
}

/// Like [`fuzz`] with the table fixed and the sidecar mutated: errors name
/// the sidecar or the table, both `sub-01_physio.*`.
fn fuzz_sidecar(
    tsv: &[u8],
    rng_seed: u64,
    spec: impl Fn(PathBuf) -> SourceSpec,
    sidecar: impl Fn(&Path, &mut ChaCha8Rng),
) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("sub-01_physio.tsv");
    std::fs::write(&path, tsv).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(rng_seed);
    for case in 0..cases() {
        sidecar(dir.path(), &mut rng);
        let side =
            std::fs::read_to_string(dir.path().join("sub-01_physio.json")).unwrap_or_default();
        check(
            &spec(path.clone()),
            "sub-01_physio.",
            &format!("sidecar case {case}: {side:?}"),
        );
    }
}

#[test]
fn fixation_reports_survive_mutation() {
    let mut s = String::from("participant_id,TRIAL_INDEX,CURRENT_FIX_START,CURRENT_FIX_END,CURRENT_FIX_X,CURRENT_FIX_Y,NEXT_SAC_AMPLITUDE\n");
    let mut t = 100;
    for i in 0..12 {
        let dur = 150 + 20 * (i % 4);
        s.push_str(&format!(
            "p{},{},{},{},{:.1},{:.1},{:.2}\n",
            i / 6,
            1 + (i / 3) % 2,
            t,
            t + dur,
            300.0 + 90.0 * (i % 6) as f64,
            200.0 + 10.0 * (i % 2) as f64,
            1.2 + 0.1 * (i % 3) as f64
        ));
        t += dur + 35;
    }
    fuzz(
        "fixations.csv",
        s.as_bytes(),
        30,
        |path| SourceSpec::Fixations {
            path,
            start_column: "CURRENT_FIX_START".into(),
            end_column: "CURRENT_FIX_END".into(),
            x_column: "CURRENT_FIX_X".into(),
            y_column: "CURRENT_FIX_Y".into(),
            group_columns: vec!["participant_id".into(), "TRIAL_INDEX".into()],
            amplitude_column: Some("NEXT_SAC_AMPLITUDE".into()),
            time_unit: TimeUnit::Ms,
            screen_px: [2560.0, 1440.0],
            geometry: ViewingGeometry::default(),
            saccade: Default::default(),
        },
        no_extra,
    );
}

#[test]
fn extract_csv_survives_mutation() {
    let mut s = String::from("frame,time_s,valid,nx,ny,blink,aperture_left,aperture_right\n");
    for i in 0..50 {
        let t = i as f64 / 25.0;
        if i == 17 {
            s.push_str(&format!("{i},{t:.6},0,,,1,0.02,0.03\n"));
        } else {
            s.push_str(&format!(
                "{i},{t:.6},1,{:.5},{:.5},0,0.3,0.31\n",
                0.5 + 0.002 * (i % 7) as f64,
                0.45 + 0.001 * (i % 5) as f64
            ));
        }
    }
    fuzz(
        "iris.csv",
        s.as_bytes(),
        40,
        |path| SourceSpec::Extract { path },
        no_extra,
    );
}
