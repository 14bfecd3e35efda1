//! Every reader of the dataset format against what the writers produce,
//! against another format version, and against mutated files: a reader
//! returns the data or a one-line error naming the file, never panics.

use eyereplay_core::{Calibration, Canvas, CanvasPos, GazeClass};
use eyereplay_dataset::*;
use std::path::Path;

fn meta() -> DatasetMetadata {
    let cal = Calibration {
        s_x: 1000.0,
        s_y: 600.0,
        mu_x: 640.0,
        mu_y: 360.0,
    };
    DatasetMetadata::assembled(
        25.0,
        4,
        Canvas::default(),
        Some(cal),
        &[(GazeClass::Reading, 2, 10), (GazeClass::Conversation, 1, 6)],
    )
}

fn write_all(dir: &Path) {
    write_metadata(dir, &meta()).unwrap();
    write_labels(
        dir,
        &[LabelRow {
            file: session_file(GazeClass::Reading, 0),
            class: GazeClass::Reading,
            sources: vec!["a.csv".into()],
        }],
    )
    .unwrap();
    let pts: Vec<CanvasPos> = (0..10)
        .map(|i| CanvasPos {
            x_px: 100.0 + i as f64,
            y_px: 200.5,
        })
        .collect();
    let src: Vec<u32> = (0..10).map(|i| (i >= 6) as u32).collect();
    let t_s: Vec<f64> = (0..10).map(|i| 0.04 * i as f64).collect();
    write_pool(&dir.join(pool_file(GazeClass::Reading)), &pts, &src, &t_s).unwrap();
    write_session_csv_with_blinks(
        &dir.join(session_file(GazeClass::Reading, 0)),
        &pts[..4],
        &[false, true, false, false],
    )
    .unwrap();
    write_truth_csv(&dir.join("t_truth.csv"), &[TruthRow::default(); 3]).unwrap();
}

#[test]
fn readers_return_what_writers_wrote() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write_all(d);
    let m = read_metadata(d).unwrap();
    assert_eq!(m.dataset, meta());
    assert_eq!(m.dataset.format_version, FORMAT_VERSION);
    assert!(m.render.is_none());
    let pool = read_pool(&d.join("pool/reading.csv")).unwrap();
    assert_eq!(pool.len(), 2);
    assert_eq!((pool[0].points.len(), pool[1].source), (6, 1));
    assert_eq!(frame_sources(&pool).len(), 10);
    // Each frame's time in its source, three decimals like the positions.
    let text = std::fs::read_to_string(d.join("pool/reading.csv")).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines[0], "frame,x,y,source,source_t_s");
    assert_eq!(lines[7], "6,106.000,200.500,1,0.240");
    let csv = d.join("reading/reading_0000.csv");
    assert_eq!(
        read_blink_column(&csv).unwrap(),
        Some(vec![false, true, false, false])
    );
    assert_eq!(read_labels(d).unwrap()[0].sources, vec!["a.csv"]);
    assert_eq!(read_truth_csv(&d.join("t_truth.csv")).unwrap().len(), 3);
    // The pooled calibration serves every frame of every session.
    let c = session_calibrations(d, &m.dataset, "reading/reading_0001.csv", 4).unwrap();
    assert_eq!(c.len(), 4);
}

#[test]
fn another_format_version_is_one_clear_error() {
    let dir = tempfile::tempdir().unwrap();
    write_all(dir.path());
    let p = dir.path().join("metadata.json");
    let text = std::fs::read_to_string(&p).unwrap();
    assert!(text.starts_with("{\n  \"format_version\": 1,\n"), "{text}");
    std::fs::write(
        &p,
        text.replacen("\"format_version\": 1", "\"format_version\": 7", 1),
    )
    .unwrap();
    let e = read_metadata(dir.path()).unwrap_err().to_string();
    assert!(
        e.contains("metadata.json")
            && e.contains("format version 7")
            && e.contains(&format!("reads version {FORMAT_VERSION}"))
            && !e.contains('\n'),
        "{e}"
    );
    // Written before the field existed: the same layout, read as version 1.
    std::fs::write(&p, text.replacen("\"format_version\": 1,\n", "", 1)).unwrap();
    assert_eq!(read_metadata(dir.path()).unwrap().dataset.format_version, 1);
}

/// A small deterministic generator (xorshift), so failures reproduce.
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
}

/// One mutation of `text`: a flipped byte, a cut, a deleted or duplicated
/// line, or an inserted token that readers trip over.
fn mutate(text: &[u8], r: &mut Rng) -> Vec<u8> {
    let mut t = text.to_vec();
    if t.is_empty() {
        return b"\"".to_vec();
    }
    let i = r.below(t.len());
    match r.below(6) {
        0 => t[i] ^= 1 << r.below(8),
        1 => t.truncate(i),
        2 => {
            let tok: &[&[u8]] = &[
                b",",
                b"\"",
                b"\n",
                b"NaN",
                b"-1e309",
                b"{",
                b"]",
                b"\xff",
                b"999999999999999999999",
            ];
            let k = tok[r.below(tok.len())];
            t.splice(i..i, k.iter().copied());
        }
        3 => {
            let lines: Vec<&[u8]> = text.split(|b| *b == b'\n').collect();
            let k = r.below(lines.len());
            let mut out = Vec::new();
            for (j, l) in lines.iter().enumerate() {
                if j != k {
                    out.extend_from_slice(l);
                    out.push(b'\n');
                }
            }
            t = out;
        }
        4 => {
            let end = (i + 1 + r.below(40)).min(t.len());
            let chunk = t[i..end].to_vec();
            t.splice(i..i, chunk);
        }
        _ => t[i] = b"0123456789.-eE,:"[r.below(16)],
    }
    t
}

/// Reads one file of the dataset at the given folder.
type Reader = fn(&Path) -> Result<(), DatasetError>;

#[test]
fn mutated_files_give_clean_errors_never_panics() {
    let cases: usize = std::env::var("EYEREPLAY_FUZZ_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(150);
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write_all(d);
    let targets: [(&str, Reader); 5] = [
        ("metadata.json", |d| read_metadata(d).map(drop)),
        ("labels.csv", |d| read_labels(d).map(drop)),
        ("pool/reading.csv", |d| {
            read_pool(&d.join("pool/reading.csv")).map(drop)
        }),
        ("reading/reading_0000.csv", |d| {
            read_blink_column(&d.join("reading/reading_0000.csv")).map(drop)
        }),
        ("t_truth.csv", |d| {
            read_truth_csv(&d.join("t_truth.csv")).map(drop)
        }),
    ];
    let mut r = Rng(0x5EED_1234_ABCD_0001);
    for (file, read) in targets {
        let path = d.join(file);
        let good = std::fs::read(&path).unwrap();
        let mut errors = 0;
        for case in 0..cases {
            let mut bad = mutate(&good, &mut r);
            if case % 5 == 4 {
                bad = mutate(&bad, &mut r);
            }
            std::fs::write(&path, &bad).unwrap();
            let outcome = std::panic::catch_unwind(|| read(d));
            match outcome {
                Err(_) => panic!(
                    "{file}: reader panicked on case {case}: {:?}",
                    String::from_utf8_lossy(&bad)
                ),
                Ok(Err(e)) => {
                    errors += 1;
                    let msg = e.to_string();
                    let name = Path::new(file).file_name().unwrap().to_string_lossy();
                    assert!(
                        msg.contains(name.as_ref()),
                        "{file}: error does not name the file: {msg}"
                    );
                    assert!(!msg.contains('\n'), "{file}: multi-line error: {msg}");
                }
                Ok(Ok(())) => {}
            }
        }
        // The mutations are harsh enough that most inputs are refused.
        assert!(
            errors > cases / 4,
            "{file}: only {errors} of {cases} refused"
        );
        std::fs::write(&path, &good).unwrap();
    }
}

#[test]
fn pool_heads_read_back_with_empty_rows_and_line_errors() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join(pool_head_file(GazeClass::Conversation));
    std::fs::create_dir_all(p.parent().unwrap()).unwrap();
    let poses = [Some([2.5, -1.0, 0.25, 0.1, 0.0, -0.5]), None];
    write_pool_heads(&p, &poses).unwrap();
    let text = std::fs::read_to_string(&p).unwrap();
    assert_eq!(
        text,
        format!("{POOL_HEAD_HEADER}\n0,2.5000,-1.0000,0.2500,0.1000,0.0000,-0.5000\n1,,,,,,\n")
    );
    assert_eq!(read_pool_heads(&p).unwrap(), poses.to_vec());
    for (body, want) in [
        ("0,x,,,,,\n", "line 2: column 2 is not a finite number"),
        ("0,1,2,,,,\n", "line 2: a pose has all six fields or none"),
        ("1,,,,,,\n", "line 2: frame out of order (expected 0)"),
    ] {
        std::fs::write(&p, format!("{POOL_HEAD_HEADER}\n{body}")).unwrap();
        let e = read_pool_heads(&p).unwrap_err().to_string();
        assert!(
            e.contains("conversation_head.csv") && e.contains(want),
            "{e}"
        );
    }
}

#[test]
fn head_yaw_reads_its_column_by_name_and_names_bad_lines() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("s_head.csv");
    // The face renderer's header (eyereplay_face::HEAD_TRUTH_HEADER), two
    // frames; the yaw is the second column.
    let header = "frame,head_yaw_deg,head_pitch_deg,head_roll_deg,head_x_cm,head_y_cm,head_z_cm,\
eye_yaw_deg,eye_pitch_deg,gaze_yaw_deg,gaze_pitch_deg";
    std::fs::write(
        &p,
        format!("{header}\n0,-1.2500,0.5,0,0,0,0,3,1,1.75,1.5\n1,2.0000,0,0,0,0,0,0,0,2,0\n"),
    )
    .unwrap();
    assert_eq!(read_head_yaw_csv(&p).unwrap(), vec![-1.25, 2.0]);
    for (text, want) in [
        (
            format!("{header}\n0,nan,0,0,0,0,0,0,0,0,0\n"),
            "line 2: column 2 is not a finite number",
        ),
        (
            "frame,x,y\n0,1,2\n".to_string(),
            "missing column 'head_yaw_deg'",
        ),
    ] {
        std::fs::write(&p, text).unwrap();
        let e = read_head_yaw_csv(&p).unwrap_err().to_string();
        assert!(e.contains("s_head.csv") && e.contains(want), "{e}");
    }
}
