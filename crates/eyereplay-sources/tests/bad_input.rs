//! Each bad input gets one line naming the file (and line) and the problem.

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

/// The error of reading `path` as a samples table with the default
/// columns, in milliseconds, on a 1920x1080 screen.
fn csv_err(path: std::path::PathBuf) -> String {
    read_source(
        &SourceSpec::Csv {
            path,
            time_column: None,
            x_column: None,
            y_column: None,
            time_unit: TimeUnit::Ms,
            screen_px: [1920.0, 1080.0],
            geometry: ViewingGeometry::default(),
        },
        &ReadOptions::default(),
    )
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

#[test]
fn bids_sidecar_with_absurd_distance_is_an_error() {
    // ScreenDistance 1e308 m makes px_per_deg infinite: every position was
    // infinite and the recording still "read".
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("s_physio.tsv");
    std::fs::write(&p, "0\t600\t400\n2\t601\t400\n4\t602\t401\n").unwrap();
    std::fs::write(
        dir.path().join("s_physio.json"),
        r#"{"SamplingFrequency": 500, "Columns": ["timestamp", "x_coordinate", "y_coordinate"],
            "timestamp": {"Units": "ms"}, "ScreenResolution": [1280, 1024],
            "ScreenSize": [0.531, 0.299], "ScreenDistance": 1e308}"#,
    )
    .unwrap();
    let e = read_source(
        &SourceSpec::Bids {
            path: p,
            screen_px: None,
            geometry: ViewingGeometry::default(),
        },
        &ReadOptions::default(),
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("s_physio.tsv") && e.contains("px per degree"),
        "{e}"
    );
}
