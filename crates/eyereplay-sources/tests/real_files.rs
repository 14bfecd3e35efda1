//! Readers on real recordings fetched by `scripts/fetch-data.sh` into
//! `.cache/data`. Without them these tests are listed as ignored, with the
//! reason; with `CI` set the build fails instead (build.rs).

mod common;
use common::eyelink_spec;
use eyereplay_core::NormPos;
use eyereplay_sources::{
    read_source, screen::screen_to_iris, EyeChoice, EyeGains, ReadOptions, Recording,
    RecordingKind, SourceSpec, TimeUnit, ViewingGeometry,
};
use std::path::PathBuf;

/// A file of the sample data; the tests calling this are ignored (see
/// build.rs) when it was missing at build time.
fn data(rel: &str) -> PathBuf {
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../.cache/data")
        .join(rel);
    assert!(p.exists(), "{} missing: run scripts/setup.sh", p.display());
    p
}

fn one(spec: SourceSpec) -> Recording {
    let mut v = read_source(&spec, &ReadOptions::default()).unwrap();
    assert_eq!(v.len(), 1);
    v.remove(0)
}

/// Screen px back from a normalized iris position (inverse of the eye model).
fn to_screen(n: NormPos, screen: [f64; 2], ppd: f64) -> [f64; 2] {
    let g = EyeGains::default();
    [
        screen[0] / 2.0 - (n.nx - 0.5) / g.nx_per_deg * ppd,
        screen[1] / 2.0 + (n.ny - 0.5) / g.ny_per_deg * ppd,
    ]
}

/// syelink's own CSV export of the same EDF: (timestamp ms, x, y) for RECORD rows.
fn syelink_samples(path: &std::path::Path) -> Vec<(f64, Option<[f64; 2]>)> {
    let mut rdr = csv::Reader::from_path(path).unwrap();
    let h = rdr.headers().unwrap().clone();
    let col = |n: &str| h.iter().position(|c| c == n).unwrap();
    let (t, m, x, y) = (
        col("timestamp"),
        col("mode"),
        col("left_gaze_x"),
        col("left_gaze_y"),
    );
    rdr.records()
        .map(|r| r.unwrap())
        .filter(|r| &r[m] == "RECORD")
        .map(|r| {
            let g = match (r[x].parse::<f64>(), r[y].parse::<f64>()) {
                (Ok(a), Ok(b)) => Some([a, b]),
                _ => None,
            };
            (r[t].parse().unwrap(), g)
        })
        .collect()
}

#[test]
#[cfg_attr(
    not(has_sample_data),
    ignore = "needs .cache/data: run scripts/setup.sh"
)]
fn eyelink_asc_agrees_with_syelinks_own_parser() {
    let (asc, csvp) = (
        data("syelink/left_eye.asc"),
        data("syelink/left_eye_samples.csv"),
    );
    let rec = one(eyelink_spec(asc, EyeChoice::Left));
    assert_eq!(rec.kind, RecordingKind::EyeTracker);
    assert!((rec.rate_hz - 500.0).abs() < 1e-6, "{}", rec.rate_hz);
    // DISPLAY_COORDS 0 0 1279 1023 -> 1280 px wide at the default geometry.
    let ppd = rec.px_per_deg.unwrap();
    assert!((ppd - ViewingGeometry::default().px_per_deg(1280.0)).abs() < 1e-12);

    let peer = syelink_samples(&csvp);
    let ours: Vec<_> = rec
        .segments
        .iter()
        .flat_map(|s| s.samples().iter().copied())
        .collect();
    let peer_valid: Vec<_> = peer.iter().filter(|p| p.1.is_some()).collect();
    let ours_valid: Vec<_> = ours.iter().filter(|s| s.valid).collect();
    assert!(peer_valid.len() > 60_000, "{}", peer_valid.len());
    assert_eq!(ours_valid.len(), peer_valid.len());
    for (o, p) in ours_valid.iter().zip(&peer_valid) {
        assert!((o.t_s * 1e3 - p.0).abs() < 1e-6);
        let xy = to_screen(o.pos, [1280.0, 1024.0], ppd);
        let g = p.1.unwrap();
        assert!(
            (xy[0] - g[0]).abs() < 1e-6 && (xy[1] - g[1]).abs() < 1e-6,
            "{xy:?} vs {g:?}"
        );
    }
    // The file has 17 EBLINK events; samples inside them are flagged.
    assert!(ours.iter().filter(|s| s.blink).count() > 1000);

    // And so are those of the saccade that holds a blink. In both_eyes.asc
    // the left eye's "ESACC L 350559 350823" holds "EBLINK L 350599
    // 350789"; the samples just before the blink swing down past the
    // 1024-px display (y 841.8 at 350589, 1408.5 at 350597) and are not
    // the gaze. Those of the saccade are flagged, the ones before it not.
    let both = one(eyelink_spec(data("syelink/both_eyes.asc"), EyeChoice::Left));
    let at = |t_ms: f64| {
        both.segments
            .iter()
            .flat_map(|s| s.samples().iter())
            .find(|s| (s.t_s * 1e3 - t_ms).abs() < 0.5)
            .copied()
            .unwrap()
    };
    for t in [350_559.0, 350_589.0, 350_597.0, 350_801.0, 350_823.0] {
        assert!(at(t).blink, "{t} ms is in the blink's saccade");
    }
    for t in [350_557.0, 350_825.0] {
        assert!(!at(t).blink, "{t} ms is outside it");
    }
    // Three recording blocks separated by minutes: three segments.
    assert!(rec.segments.len() >= 2, "{}", rec.segments.len());
    // The right eye of a left-eye recording: said as the config spells it,
    // with the eye the file has.
    let e = eyereplay_sources::read_source(
        &eyelink_spec(data("syelink/left_eye.asc"), EyeChoice::Right),
        &ReadOptions::default(),
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("eye = \"right\" asked for, but the file records only the left eye"),
        "{e}"
    );
}

#[test]
#[cfg_attr(
    not(has_sample_data),
    ignore = "needs .cache/data: run scripts/setup.sh"
)]
fn binocular_asc_mean_lies_between_the_eyes() {
    let asc = data("syelink/both_eyes.asc");
    let spec = |eye| eyelink_spec(asc.clone(), eye);
    let (l, r, m) = (
        one(spec(EyeChoice::Left)),
        one(spec(EyeChoice::Right)),
        one(spec(EyeChoice::Mean)),
    );
    let first = |rec: &Recording| rec.segments[0].samples()[0];
    let (a, b, c) = (first(&l), first(&r), first(&m));
    // First line: 744.1 712.3 | 659.7 489.7 -> mean 701.9 601.0.
    let ppd = m.px_per_deg.unwrap();
    let xy = to_screen(c.pos, [1280.0, 1024.0], ppd);
    assert!(
        (xy[0] - 701.9).abs() < 1e-9 && (xy[1] - 601.0).abs() < 1e-9,
        "{xy:?}"
    );
    assert!((c.pos.nx - 0.5 * (a.pos.nx + b.pos.nx)).abs() < 1e-12);
}

#[test]
#[cfg_attr(
    not(has_sample_data),
    ignore = "needs .cache/data: run scripts/setup.sh"
)]
fn bids_physio_matches_the_same_samples_as_asc() {
    let (bids, asc) = (
        data("bids/sub-01/beh/sub-01_task-reading_recording-eye1_physio.tsv.gz"),
        data("syelink/left_eye.asc"),
    );
    let b = one(SourceSpec::Bids {
        path: bids,
        screen_px: None,
        geometry: ViewingGeometry::default(),
    });
    let a = one(eyelink_spec(asc, EyeChoice::Left));
    let valid = |r: &Recording| -> Vec<(f64, NormPos)> {
        r.segments
            .iter()
            .flat_map(|s| {
                s.samples()
                    .iter()
                    .filter(|x| x.valid)
                    .map(|x| (x.t_s, x.pos))
                    .collect::<Vec<_>>()
            })
            .collect()
    };
    let (vb, va) = (valid(&b), valid(&a));
    assert_eq!(vb.len(), va.len());
    for (x, y) in vb.iter().zip(&va) {
        assert!((x.0 - y.0).abs() < 1e-9);
        assert!((x.1.nx - y.1.nx).abs() < 1e-12 && (x.1.ny - y.1.ny).abs() < 1e-12);
    }
}

#[test]
#[cfg_attr(
    not(has_sample_data),
    ignore = "needs .cache/data: run scripts/setup.sh"
)]
fn generic_csv_with_named_columns_matches_asc() {
    let (csvp, asc) = (
        data("syelink/left_eye_samples.csv"),
        data("syelink/left_eye.asc"),
    );
    let r = read_source(
        &SourceSpec::Csv {
            path: csvp,
            time_column: Some("timestamp".into()),
            x_column: Some("left_gaze_x".into()),
            y_column: Some("left_gaze_y".into()),
            time_unit: TimeUnit::Ms,
            screen_px: [1280.0, 1024.0],
            geometry: ViewingGeometry::default(),
        },
        &ReadOptions::default(),
    );
    let a = one(eyelink_spec(asc, EyeChoice::Left));
    let v = r.unwrap();
    let valid = |r: &Recording| -> usize {
        r.segments
            .iter()
            .map(|s| s.samples().iter().filter(|x| x.valid).count())
            .sum()
    };
    assert_eq!(valid(&v[0]), valid(&a));
    assert!(valid(&a) > 60_000);
}

#[test]
#[cfg_attr(
    not(has_sample_data),
    ignore = "needs .cache/data: run scripts/setup.sh"
)]
fn onestop_fixations_become_trajectories() {
    let p = data("onestop_fixations.csv");
    let spec = SourceSpec::Fixations {
        path: p,
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
    };
    let recs = read_source(&spec, &ReadOptions::default()).unwrap();
    // 2 readers x 12 paragraphs.
    assert_eq!(recs.len(), 24);
    let r0 = &recs[0];
    assert_eq!(r0.id, "onestop_fixations.csv#l37_1129/44");
    assert_eq!(r0.kind, RecordingKind::FixationReport);
    // First two fixations: (374,196) -> (464,207), reported 1.24 deg:
    // about 73.7 px/deg; the median over all saccades is close to it.
    let ppd = r0.px_per_deg.unwrap();
    assert!((65.0..80.0).contains(&ppd), "{ppd}");
    // The first fixation lasts 18288..18319 ms: the first sample sits on it,
    // and mid-fixation the drift has moved it by a few hundredths of a degree.
    let s = r0.segments[0].samples();
    let want = screen_to_iris(
        eyereplay_core::ScreenPos {
            x_px: 374.0,
            y_px: 196.0,
        },
        [2560.0, 1440.0],
        ppd,
        &EyeGains::default(),
    );
    assert!((s[0].t_s - 18.288).abs() < 1e-9);
    assert!((s[0].pos.nx - want.nx).abs() < 1e-12 && (s[0].pos.ny - want.ny).abs() < 1e-12);
    let mid = s.iter().find(|x| (x.t_s - 18.3035).abs() < 0.0006).unwrap();
    let moved_deg = (mid.pos.nx - want.nx).abs() / 0.0061;
    assert!(moved_deg > 0.0 && moved_deg < 0.1, "{moved_deg}");
    // Without drift the fixation is held exactly.
    let still = match &spec {
        SourceSpec::Fixations { .. } => {
            let mut sp = spec.clone();
            if let SourceSpec::Fixations { saccade, .. } = &mut sp {
                saccade.drift_deg2_per_s = 0.0;
            }
            read_source(&sp, &ReadOptions::default()).unwrap()
        }
        _ => unreachable!(),
    };
    let mid = still[0].segments[0]
        .samples()
        .iter()
        .find(|x| (x.t_s - 18.3035).abs() < 0.0006)
        .copied()
        .unwrap();
    assert!((mid.pos.nx - want.nx).abs() < 1e-12 && (mid.pos.ny - want.ny).abs() < 1e-12);
    // Samples are on a 1 kHz grid.
    assert!((r0.rate_hz - 1000.0).abs() < 1e-9);
}
