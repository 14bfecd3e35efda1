//! Each bad input gets one line naming the file (and line) and the problem.

mod common;
use common::{csv_spec, eyelink_spec};
use eyereplay_sources::{read_source, ReadOptions, SourceSpec, TimeUnit, ViewingGeometry};
use std::path::Path;

fn extract_err(body: &str) -> String {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("iris.csv");
    std::fs::write(&p, body).unwrap();
    let e = read_source(&SourceSpec::Extract { path: p }, &ReadOptions::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("iris.csv"), "{e}");
    assert!(!e.contains('\n'), "{e}");
    e
}

#[test]
fn empty_file() {
    assert!(extract_err("").contains("empty file"));
}

#[test]
fn missing_column() {
    let e = extract_err("frame,time_s,valid,nx\n0,0,1,0.5\n");
    assert!(e.contains("missing column 'ny'"), "{e}");
}

#[test]
fn non_numeric_cell_names_line_and_column() {
    let e = extract_err("frame,time_s,valid,nx,ny\n0,0.00,1,0.5,0.5\n1,0.04,1,abc,0.5\n");
    assert!(
        e.contains("line 3") && e.contains("'nx'") && e.contains("'abc'"),
        "{e}"
    );
}

#[test]
fn non_increasing_timestamps() {
    let e = extract_err("frame,time_s,valid,nx,ny\n0,0.04,1,0.5,0.5\n1,0.04,1,0.5,0.5\n");
    assert!(e.contains("line 3") && e.contains("must increase"), "{e}");
}

#[test]
fn every_sample_invalid() {
    let e = extract_err("frame,time_s,valid,nx,ny\n0,0.00,0,,\n1,0.04,0,,\n");
    assert!(e.contains("no usable gaze"), "{e}");
}

#[test]
fn extract_csv_reads_blinks_apertures_and_invalid_frames() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("iris.csv");
    std::fs::write(
        &p,
        "frame,time_s,valid,nx,ny,aperture_left,aperture_right,blink\n\
         0,0.000,1,0.50,0.40,0.30,0.32,0\n\
         1,0.041,1,0.52,0.41,0.05,0.07,1\n\
         2,0.083,0,,,,,0\n\
         3,0.125,1,0.55,0.45,0.31,0.29,0\n",
    )
    .unwrap();
    let r = read_source(&SourceSpec::Extract { path: p }, &ReadOptions::default())
        .unwrap()
        .remove(0);
    let s = r.segments[0].samples();
    assert_eq!(s.len(), 4);
    assert!(s[1].blink && !s[1].is_gaze());
    assert!(!s[2].valid);
    assert_eq!(s[0].aperture, Some(0.31));
    assert!((s[3].pos.nx - 0.55).abs() < 1e-15);
    // Median interval 0.0417 s -> 24 fps.
    assert!((r.rate_hz - 1.0 / 0.042).abs() < 0.1, "{}", r.rate_hz);
}

#[test]
fn csv_without_xy_columns_says_how_to_name_them() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("gaze.tsv");
    std::fs::write(&p, "time\tgx\tgy\n0\t1\t2\n").unwrap();
    let e = csv_err(p);
    assert!(e.contains("gaze.tsv") && e.contains("x_column"), "{e}");
}

/// Tracking loss as R (`NA`), BIDS (`n/a`), pandas' object columns
/// (`None`) or SAS (`.`) write it reads as the gap an empty cell is, not as
/// "NA is not a number".
#[test]
fn missing_value_tokens_are_gaps_like_empty_cells() {
    let dir = tempfile::tempdir().unwrap();
    let table = |missing: &str| {
        let mut s = String::from("time,x,y\n");
        for i in 0..60 {
            let (x, y) = if (20..23).contains(&i) {
                (missing.to_string(), missing.to_string())
            } else {
                (format!("{}", 900 + 3 * i), format!("{}", 500 - 2 * i))
            };
            s.push_str(&format!("{},{x},{y}\n", 1000 + 2 * i));
        }
        s
    };
    let read = |name: &str, missing: &str| {
        let p = dir.path().join(name);
        std::fs::write(&p, table(missing)).unwrap();
        let r = read_source(&csv_spec(p), &ReadOptions::default())
            .unwrap_or_else(|e| panic!("{missing:?}: {e}"));
        r.into_iter().flat_map(|r| r.segments).collect::<Vec<_>>()
    };
    let empty = read("empty.csv", "");
    // 60 rows, 3 of them lost.
    let gaze: usize = empty.iter().map(|s| s.gaze_count()).sum();
    assert_eq!(gaze, 57);
    for token in ["NA", "n/a", "N/A", "None", "null", ".", "NaN"] {
        // Debug text: lost samples hold NaN, which equals nothing.
        assert_eq!(
            format!("{:?}", read("t.csv", token)),
            format!("{empty:?}"),
            "{token}"
        );
    }
}

/// Gaze written as fractions of the screen (Pupil Labs' `norm_pos_x`), or
/// recorded on a larger screen than `screen_px` says, is named: read as
/// pixels it would be movements of the wrong size, every fixation of the
/// fractions in one pixel.
#[test]
fn gaze_off_the_configured_screen_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let table = |x: &dyn Fn(usize) -> f64, y: &dyn Fn(usize) -> f64| {
        let mut s = String::from("time,x,y\n");
        for i in 0..50 {
            s.push_str(&format!("{},{:.4},{:.4}\n", 1000 + 2 * i, x(i), y(i)));
        }
        s
    };
    let p = dir.path().join("pupil.csv");
    std::fs::write(
        &p,
        table(&|i| 0.3 + 0.004 * i as f64, &|i| 0.6 - 0.002 * i as f64),
    )
    .unwrap();
    let e = csv_err(p);
    assert!(
        e.contains("pupil.csv") && e.contains("within 0-1") && e.contains("1920x1080"),
        "{e}"
    );
    // A 3840x2160 recording read as 1920x1080: 30 of 50 samples beyond
    // 1.25 x 1920 = 2400 px.
    let p = dir.path().join("uhd.csv");
    std::fs::write(
        &p,
        table(
            &|i| if i < 20 { 1800.0 } else { 3000.0 + i as f64 },
            &|_| 1000.0,
        ),
    )
    .unwrap();
    let e = csv_err(p);
    assert!(
        e.contains("uhd.csv") && e.contains("60 %") && e.contains("screen_px"),
        "{e}"
    );
    // Some gaze off the screen, as a glance at the keyboard gives, reads.
    let p = dir.path().join("glance.csv");
    std::fs::write(
        &p,
        table(&|i| if i < 30 { 900.0 } else { 3000.0 }, &|_| 500.0),
    )
    .unwrap();
    read_source(&csv_spec(p), &ReadOptions::default()).unwrap();
}

/// A binary EDF given as an EyeLink source is named as such, with the
/// conversion to run: its first bytes as the tracker writes them (those
/// of the EDFs bundled with the eyelinkio and eyelink-reader packages).
#[test]
fn a_binary_edf_is_named_with_its_conversion() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("rec.edf");
    let mut bytes =
        b"SR_RESEARCH_1000FILE\nDATE: Fri Mar 14 14:03:21 2014\nTYPE: EDF_FILE BINARY EVENT\n"
            .to_vec();
    bytes.extend([0u8, 7, 255, 3, 0, 0, 41]);
    std::fs::write(&p, bytes).unwrap();
    let e = read_source(
        &eyelink_spec(p, Default::default()),
        &ReadOptions::default(),
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("rec.edf") && e.contains("binary EDF") && e.contains("edf2asc"),
        "{e}"
    );
}

/// A BIDS source of three samples, `dir/NAME_physio.tsv`, with `sidecar`
/// written beside it when given.
fn bids_spec(
    dir: &Path,
    name: &str,
    sidecar: Option<&str>,
    geometry: ViewingGeometry,
) -> SourceSpec {
    let path = dir.join(format!("{name}_physio.tsv"));
    std::fs::write(&path, "0\t600\t400\n2\t601\t400\n4\t602\t401\n").unwrap();
    if let Some(json) = sidecar {
        std::fs::write(dir.join(format!("{name}_physio.json")), json).unwrap();
    }
    SourceSpec::Bids {
        path,
        screen_px: None,
        geometry,
    }
}

/// A sidecar for [`bids_spec`]'s samples: 500 Hz, milliseconds, a
/// 1280x1024 screen of `size_m` at `distance_m`.
fn sidecar(size_m: &str, distance_m: &str) -> String {
    format!(
        r#"{{"SamplingFrequency": 500, "Columns": ["timestamp", "x_coordinate", "y_coordinate"],
            "timestamp": {{"Units": "ms"}}, "ScreenResolution": [1280, 1024],
            "ScreenSize": {size_m}, "ScreenDistance": {distance_m}}}"#
    )
}

/// The error of reading `path` as a samples table with the default
/// columns, in milliseconds, on a 1920x1080 screen.
fn csv_err(path: std::path::PathBuf) -> String {
    read_source(&csv_spec(path), &ReadOptions::default())
        .unwrap_err()
        .to_string()
}

/// A file separated otherwise than its name says: its header reads as one
/// column holding the names looked for, which "no time column (looked for
/// time_ms; header: time_ms<TAB>gaze_x...)" left the user to see.
#[test]
fn a_file_separated_otherwise_than_its_name_says_is_named_so() {
    let dir = tempfile::tempdir().unwrap();
    for (name, body, by) in [
        ("tabs.csv", "time_ms\tgaze_x\tgaze_y\n0\t1\t2\n", "tabs"),
        ("commas.tsv", "time_ms,gaze_x,gaze_y\n0,1,2\n", "commas"),
        ("excel.csv", "time_ms;gaze_x;gaze_y\n0;1;2\n", "semicolons"),
    ] {
        let p = dir.path().join(name);
        std::fs::write(&p, body).unwrap();
        let e = csv_err(p);
        assert!(
            e.contains(name)
                && e.contains(&format!(
                    "its header reads as one column, separated by {by}"
                )),
            "{e}"
        );
    }
}

#[test]
fn missing_file_is_named() {
    let e = read_source(
        &SourceSpec::Extract {
            path: Path::new("/nonexistent/iris.csv").into(),
        },
        &ReadOptions::default(),
    )
    .unwrap_err()
    .to_string();
    assert!(e.starts_with("/nonexistent/iris.csv:"), "{e}");
}

// Regression cases found by tests/fuzz.rs.

fn fixations_err(rows: &str) -> String {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("fix.csv");
    std::fs::write(
        &p,
        format!("CURRENT_FIX_START,CURRENT_FIX_END,CURRENT_FIX_X,CURRENT_FIX_Y\n{rows}"),
    )
    .unwrap();
    let spec = SourceSpec::Fixations {
        path: p,
        start_column: "CURRENT_FIX_START".into(),
        end_column: "CURRENT_FIX_END".into(),
        x_column: "CURRENT_FIX_X".into(),
        y_column: "CURRENT_FIX_Y".into(),
        group_columns: vec![],
        amplitude_column: None,
        time_unit: TimeUnit::Ms,
        screen_px: [1920.0, 1080.0],
        geometry: ViewingGeometry::default(),
        saccade: Default::default(),
    };
    let e = read_source(&spec, &ReadOptions::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("fix.csv") && !e.contains('\n'), "{e}");
    e
}

/// Two trials in one file, the second's clock starting again, with no
/// `group_columns`: sorted by time, the second trial's fixation of line 4
/// (50-200 ms) comes first, and line 2's (100-250 ms) starts before it
/// ends. Both lines are named, and the fix.
#[test]
fn overlapping_fixations_name_both_rows_and_group_columns() {
    let e = fixations_err(
        "100,250,300,200
300,450,400,200
50,200,500,300
",
    );
    assert!(
        e.contains("line 2: fixation starts at 0.100 s, before the one of line 4 ends (0.200 s)")
            && e.contains("group them with group_columns"),
        "{e}"
    );
}

#[test]
fn fixation_with_infinite_or_nan_end_is_an_error_not_an_endless_loop() {
    // Synthesis loops until the last fixation's end: with an end of inf or
    // NaN it never stopped.
    for end in ["inf", "NaN"] {
        let e = fixations_err(&format!("100,250,300,200\n300,{end},400,200\n"));
        assert!(e.contains("line 3") && e.contains("finite"), "{e}");
    }
}

#[test]
fn fixation_lasting_hours_is_an_error_not_a_memory_fill() {
    // 1e9 ms: 11 days of 1 kHz samples. Typical cause: microseconds read as ms.
    let e = fixations_err("100,1000000000,300,200\n");
    assert!(e.contains("line 2") && e.contains("time_unit"), "{e}");
}

#[test]
fn a_cell_spanning_lines_keeps_the_error_on_one_line() {
    // A stray quote makes the csv reader join lines into one cell.
    let e = extract_err(
        "frame,time_s,valid,nx,ny\n0,0.00,1,0.5,0.5\n1,0.04,1,\",0.5\n2,0.08,1,0.5,0.5\n",
    );
    assert!(e.contains("'nx'") && e.contains("\\n"), "{e}");
}

/// The config's `screen_width_mm` / `distance_mm` outrank the sidecar's
/// `ScreenSize` / `ScreenDistance`, as its `screen_px` outranks
/// `ScreenResolution` (docs/CONFIG.md); left at the defaults, the
/// sidecar's are read. By hand: 1280 px across 2 atan(200 / 800) =
/// 28.07 deg is 45.60 px/deg; across 2 atan(200 / 1000) = 22.62 deg,
/// 56.58 px/deg (the defaults, 531 mm at 600 mm, would give 26.81).
#[test]
fn bids_geometry_from_the_config_outranks_the_sidecar() {
    let dir = tempfile::tempdir().unwrap();
    let side = sidecar("[0.4, 0.3]", "0.8");
    let ppd = |geometry: ViewingGeometry| {
        read_source(
            &bids_spec(dir.path(), "s", Some(&side), geometry),
            &ReadOptions::default(),
        )
        .unwrap()[0]
            .px_per_deg
            .unwrap()
    };
    let from_sidecar = ppd(ViewingGeometry::default());
    assert!((from_sidecar - 45.60).abs() < 0.01, "{from_sidecar}");
    let from_config = ppd(ViewingGeometry {
        px_per_deg: None,
        screen_width_mm: 400.0,
        distance_mm: 1000.0,
    });
    assert!((from_config - 56.58).abs() < 0.01, "{from_config}");
    let given = ppd(ViewingGeometry {
        px_per_deg: Some(40.0),
        ..ViewingGeometry::default()
    });
    assert_eq!(given, 40.0);
}

/// BIDS's inheritance principle: a `task-reading_physio.json` at the
/// dataset's root applies to every reading recording below it, and the
/// file's own sidecar overrides its keys. Outside a dataset (no
/// `dataset_description.json` above) nothing is inherited, and the
/// missing sidecar is named.
#[test]
fn bids_sidecars_are_inherited_inside_a_dataset() {
    // Named by a relative path, as a config or a script in the dataset's
    // folder names it (the test's folder is the package's): the folders
    // above are found all the same.
    let dir = tempfile::Builder::new()
        .prefix("bids-inherit-")
        .tempdir_in(".")
        .unwrap();
    let root = Path::new(dir.path().file_name().unwrap());
    assert!(root.is_relative() && root.is_dir());
    let beh = root.join("sub-01/beh");
    std::fs::create_dir_all(&beh).unwrap();
    let spec = bids_spec(
        &beh,
        "sub-01_task-reading",
        None,
        ViewingGeometry::default(),
    );
    // The shared keys at the root; a sidecar of another task, which must
    // not apply.
    std::fs::write(
        root.join("task-reading_physio.json"),
        sidecar("[0.4, 0.3]", "0.6"),
    )
    .unwrap();
    std::fs::write(
        root.join("task-other_physio.json"),
        r#"{"SamplingFrequency": "not this one"}"#,
    )
    .unwrap();
    let outside = read_source(&spec, &ReadOptions::default())
        .unwrap_err()
        .to_string();
    assert!(
        outside.contains("sub-01_task-reading_physio.json") && outside.contains("missing"),
        "{outside}"
    );
    std::fs::write(root.join("dataset_description.json"), "{}").unwrap();
    // By hand: 1280 px across 2 atan(200 / 600) = 36.87 deg, 34.72 px/deg.
    let inherited = read_source(&spec, &ReadOptions::default())
        .unwrap()
        .remove(0);
    assert!(
        (inherited.px_per_deg.unwrap() - 34.72).abs() < 0.01,
        "{:?}",
        inherited.px_per_deg
    );
    assert_eq!(inherited.sample_count(), 3);
    // The file's own sidecar overrides one key: 2 atan(200 / 800), 45.60.
    std::fs::write(
        beh.join("sub-01_task-reading_physio.json"),
        r#"{"ScreenDistance": 0.8}"#,
    )
    .unwrap();
    let own = read_source(&spec, &ReadOptions::default())
        .unwrap()
        .remove(0);
    assert!(
        (own.px_per_deg.unwrap() - 45.60).abs() < 0.01,
        "{:?}",
        own.px_per_deg
    );
}

#[test]
fn bids_sidecar_with_absurd_distance_is_an_error() {
    // ScreenDistance 1e308 m makes px_per_deg infinite: every position was
    // infinite and the recording still "read".
    let dir = tempfile::tempdir().unwrap();
    let side = sidecar("[0.531, 0.299]", "1e308");
    let spec = bids_spec(dir.path(), "s", Some(&side), ViewingGeometry::default());
    let e = read_source(&spec, &ReadOptions::default())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("s_physio.tsv") && e.contains("px per degree"),
        "{e}"
    );
}
