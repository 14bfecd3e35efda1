//! Rendering a dataset laid out like `eyereplay prepare` writes it.

use eyereplay_core::{write_session_csv, CanvasPos};
use eyereplay_render::*;
use std::path::Path;
use std::sync::Mutex;

fn make_dataset(dir: &Path) {
    let sweep: Vec<CanvasPos> = reading_trajectory(20, 1280.0, 720.0);
    let talk: Vec<CanvasPos> = conversation_trajectory(15, 1280.0, 720.0, 1);
    write_session_csv(&dir.join("reading/reading_0000.csv"), &sweep).unwrap();
    write_session_csv(&dir.join("conversation/conversation_0000.csv"), &talk).unwrap();
    std::fs::write(
        dir.join("labels.csv"),
        "file,label,class,sources\nreading/reading_0000.csv,1,reading,a\nconversation/conversation_0000.csv,0,conversation,b\n",
    )
    .unwrap();
    let cal = eyereplay_core::Calibration {
        s_x: 5120.0,
        s_y: 3000.0,
        mu_x: 640.0,
        mu_y: 360.0,
    };
    let classes = [
        (eyereplay_core::GazeClass::Reading, 1, 20),
        (eyereplay_core::GazeClass::Conversation, 1, 15),
    ];
    let meta = eyereplay_dataset::DatasetMetadata::assembled(
        25.0,
        20,
        eyereplay_core::Canvas::default(),
        Some(cal),
        &classes,
    );
    eyereplay_dataset::write_metadata(dir, &meta).unwrap();
}

fn opts() -> DatasetOptions {
    let mut p = RenderParams::new(Identity::reference());
    p.width = 320;
    p.height = 180;
    DatasetOptions {
        dataset_seed: 5,
        jobs: 2,
        params: p,
        natural_blinks: false,
        shard: None,
        response: None,
    }
}

#[test]
fn renders_every_session_then_skips_complete_ones() {
    let dir = tempfile::tempdir().unwrap();
    make_dataset(dir.path());
    let seen = Mutex::new(Vec::new());
    let s = render_dataset(dir.path(), &opts(), &|job, o| {
        seen.lock()
            .unwrap()
            .push((job.paths.file.clone(), format!("{o:?}")));
    })
    .unwrap();
    assert_eq!(
        (s.sessions, s.rendered, s.skipped, s.frames),
        (2, 2, 0, 35),
        "{s:?}"
    );
    assert_eq!(seen.lock().unwrap().len(), 2);
    let r = dir.path().join("reading");
    for f in [
        "reading_0000.mp4",
        "reading_0000_truth.csv",
        "reading_0000_identity.json",
    ] {
        assert!(r.join(f).exists(), "{f}");
    }
    let info = probe_video(&r.join("reading_0000.mp4"), Path::new("ffprobe")).unwrap();
    assert_eq!((info.width, info.height, info.frames), (320, 180, 20));
    // The dataset's calibration is used: 100 px right of mu is n = 0.5 + 100/5120.
    let truth = std::fs::read_to_string(r.join("reading_0000_truth.csv")).unwrap();
    let meta: serde_json::Value =
        serde_json::from_slice(&std::fs::read(r.join("reading_0000_identity.json")).unwrap())
            .unwrap();
    assert_eq!(meta["mapping"]["calibration"]["s_x"], 5120.0);
    let id: Identity = serde_json::from_value(meta["identity"].clone()).unwrap();
    assert_eq!(
        id,
        Identity::sample(session_seed(5, "reading/reading_0000.csv"))
    );
    assert_eq!(truth.lines().count(), 21);

    // Second run: everything verifies, nothing is re-rendered.
    let before = std::fs::metadata(r.join("reading_0000.mp4"))
        .unwrap()
        .modified()
        .unwrap();
    let s = render_dataset(dir.path(), &opts(), &|_, _| {}).unwrap();
    assert_eq!((s.rendered, s.skipped), (0, 2));
    let after = std::fs::metadata(r.join("reading_0000.mp4"))
        .unwrap()
        .modified()
        .unwrap();
    assert_eq!(before, after);

    // A truncated video (wrong frame count) is rendered again, and what an
    // interrupted run left behind is removed; another session's name is kept.
    std::fs::write(r.join("reading_0000.mp4"), b"not a video").unwrap();
    std::fs::write(r.join(".reading_0000.mp4.4242.part"), b"half").unwrap();
    std::fs::write(r.join(".reading_0000_truth.csv.x1y2.tmp"), b"half").unwrap();
    std::fs::write(r.join(".reading_0009.mp4.1.part"), b"other").unwrap();
    let s = render_dataset(dir.path(), &opts(), &|_, _| {}).unwrap();
    assert_eq!((s.rendered, s.skipped), (1, 1));
    assert!(!r.join(".reading_0000.mp4.4242.part").exists());
    assert!(!r.join(".reading_0000_truth.csv.x1y2.tmp").exists());
    assert!(r.join(".reading_0009.mp4.1.part").exists());
}

#[test]
fn a_bad_session_fails_alone() {
    let dir = tempfile::tempdir().unwrap();
    make_dataset(dir.path());
    std::fs::write(
        dir.path().join("conversation/conversation_0000.csv"),
        "frame,x,y\n0,1,nan\n",
    )
    .unwrap();
    let s = render_dataset(dir.path(), &opts(), &|_, _| {}).unwrap();
    assert_eq!(s.rendered, 1);
    assert_eq!(s.failed.len(), 1);
    assert!(
        s.failed[0].contains("conversation_0000.csv"),
        "{:?}",
        s.failed
    );
    assert!(!dir
        .path()
        .join("conversation/conversation_0000.mp4")
        .exists());
    // A dataset without labels.csv is a one-line error.
    std::fs::remove_file(dir.path().join("labels.csv")).unwrap();
    let e = render_dataset(dir.path(), &opts(), &|_, _| {})
        .unwrap_err()
        .to_string();
    assert!(e.contains("labels.csv") && !e.contains('\n'), "{e}");
}

#[test]
fn session_blink_column_closes_the_lids() {
    let dir = tempfile::tempdir().unwrap();
    make_dataset(dir.path());
    let sweep = reading_trajectory(20, 1280.0, 720.0);
    let mut blinks = vec![false; 20];
    blinks[8..12].iter_mut().for_each(|b| *b = true);
    eyereplay_core::write_session_csv_with_blinks(
        &dir.path().join("reading/reading_0000.csv"),
        &sweep,
        &blinks,
    )
    .unwrap();
    let s = render_dataset(dir.path(), &opts(), &|_, _| {}).unwrap();
    assert_eq!(s.rendered, 2, "{s:?}");
    let truth = std::fs::read_to_string(dir.path().join("reading/reading_0000_truth.csv")).unwrap();
    let blink_col: Vec<&str> = truth
        .lines()
        .skip(1)
        .map(|l| l.rsplit(',').next().unwrap())
        .collect();
    // Closed on every flagged frame, open well before and after the run.
    assert_eq!(blink_col[6], "0");
    assert!(blink_col[8..12].iter().all(|b| *b == "1"), "{blink_col:?}");
    assert_eq!(blink_col[14], "0");
}

#[test]
fn each_class_takes_the_shared_choices_in_turn() {
    // 7 reading and 5 conversation sessions, interleaved in labels.csv.
    let dir = tempfile::tempdir().unwrap();
    let mut labels = String::from("file,label,class,sources\n");
    for k in 0..7 {
        labels += &format!("reading/reading_{k:04}.csv,1,reading,a\n");
        if k < 5 {
            labels += &format!("conversation/conversation_{k:04}.csv,0,conversation,b\n");
        }
    }
    std::fs::write(dir.path().join("labels.csv"), labels).unwrap();
    for seed in [0u64, 1, 5, 1 << 40] {
        let jobs = list_sessions(dir.path(), seed).unwrap();
        let of = |class: &str| -> Vec<usize> {
            jobs.iter()
                .filter(|j| j.paths.file.starts_with(class))
                .map(|j| j.balanced_choice(seed, 3))
                .collect()
        };
        let (r, c) = (of("reading/"), of("conversation/"));
        // Positions within the class, in labels.csv order.
        let idx: Vec<usize> = jobs
            .iter()
            .filter(|j| j.paths.file.starts_with("reading/"))
            .map(|j| j.class_index)
            .collect();
        assert_eq!(idx, (0..7).collect::<Vec<_>>());
        // In turn from one start, the same in both classes: the
        // conversation sessions take what the first five reading ones take.
        let s = r[0];
        assert_eq!(r, (0..7).map(|k| (s + k) % 3).collect::<Vec<_>>());
        assert_eq!(c, r[..5].to_vec());
        // So each choice appears 2 or 3 times in reading and 1 or 2 in
        // conversation, never more than one apart within a class.
        for (v, n) in [(&r, 7), (&c, 5)] {
            let counts: Vec<usize> = (0..3)
                .map(|k| v.iter().filter(|&&x| x == k).count())
                .collect();
            assert_eq!(counts.iter().sum::<usize>(), n);
            assert!(counts.iter().max().unwrap() - counts.iter().min().unwrap() <= 1);
        }
    }
    // The start moves with the dataset seed (over these seeds, more than one).
    let starts: std::collections::BTreeSet<usize> = (0..16u64)
        .map(|seed| list_sessions(dir.path(), seed).unwrap()[0].balanced_choice(seed, 3))
        .collect();
    assert!(starts.len() > 1);
}
