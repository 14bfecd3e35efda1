//! The one render driver over a dataset laid out like `eyereplay prepare`
//! writes it, with the eyes backend: render, resume, clean up after a
//! killed run, fail one session alone, commit a session whole or not at
//! all.

use eyereplay_backends::eyes::EyesBackend;
use eyereplay_backends::{render_dataset, BackendError, SessionBackend};
use eyereplay_core::{write_session_csv, CanvasPos, NoProgress, Shard};
use eyereplay_render::*;
use std::path::Path;

fn make_dataset(dir: &Path) {
    let sweep: Vec<CanvasPos> = reading_trajectory(20, 1280.0, 720.0);
    let talk: Vec<CanvasPos> = conversation_trajectory(20, 1280.0, 720.0, 1);
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
        (eyereplay_core::GazeClass::Conversation, 1, 20),
    ];
    let meta = eyereplay_dataset::DatasetMetadata::assembled(
        25.0,
        20,
        eyereplay_core::Canvas::default(),
        Some(cal),
        &classes,
    );
    let mut meta = meta;
    meta.seed = 5;
    eyereplay_dataset::write_metadata(dir, &meta).unwrap();
}

fn backend(dir: &Path) -> EyesBackend {
    let mut p = RenderParams::new(Identity::reference());
    p.width = 320;
    p.height = 180;
    p.natural_blinks = false;
    EyesBackend::new(p, read_dataset_info(dir).unwrap(), 2, None)
}

#[test]
fn renders_every_session_then_skips_complete_ones() {
    let dir = tempfile::tempdir().unwrap();
    make_dataset(dir.path());
    let b = backend(dir.path());
    let s = render_dataset(dir.path(), &b, None, &NoProgress).unwrap();
    assert_eq!((s.rendered, s.skipped, s.frames), (2, 0, 40), "{s:?}");
    let r = dir.path().join("reading");
    for f in [
        "reading_0000.mp4",
        "reading_0000_truth.csv",
        "reading_0000_identity.json",
    ] {
        assert!(r.join(f).exists(), "{f}");
    }
    // Nothing staged is left beside the committed files.
    let hidden: Vec<_> = std::fs::read_dir(&r)
        .unwrap()
        .flatten()
        .filter(|e| e.file_name().to_string_lossy().starts_with('.'))
        .map(|e| e.file_name())
        .collect();
    assert!(hidden.is_empty(), "{hidden:?}");
    let info = probe_video(&r.join("reading_0000.mp4"), Path::new("ffprobe")).unwrap();
    assert_eq!((info.width, info.height, info.frames), (320, 180, 20));
    // The dataset's calibration is used: 100 px right of mu is n = 0.5 + 100/5120.
    let truth = std::fs::read_to_string(r.join("reading_0000_truth.csv")).unwrap();
    let meta: serde_json::Value =
        serde_json::from_slice(&std::fs::read(r.join("reading_0000_identity.json")).unwrap())
            .unwrap();
    assert_eq!(meta["mapping"]["calibration"]["s_x"], 5120.0);
    // Each session's identity is drawn from the dataset's seed (5) and
    // its file name.
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
    let s = render_dataset(dir.path(), &b, None, &NoProgress).unwrap();
    assert_eq!((s.rendered, s.skipped), (0, 2));
    let after = std::fs::metadata(r.join("reading_0000.mp4"))
        .unwrap()
        .modified()
        .unwrap();
    assert_eq!(before, after);

    // A truncated video (wrong frame count) is rendered again, and what an
    // interrupted run left behind is removed (its staged files among
    // them); another session's name is kept.
    std::fs::write(r.join("reading_0000.mp4"), b"not a video").unwrap();
    std::fs::write(r.join(".reading_0000.mp4.4242.part"), b"half").unwrap();
    std::fs::write(r.join(".reading_0000_truth.csv.x1y2.tmp"), b"half").unwrap();
    std::fs::write(r.join(".staged.reading_0000.mp4"), b"half").unwrap();
    std::fs::write(r.join(".reading_0009.mp4.1.part"), b"other").unwrap();
    let s = render_dataset(dir.path(), &b, None, &NoProgress).unwrap();
    assert_eq!((s.rendered, s.skipped), (1, 1));
    assert!(!r.join(".reading_0000.mp4.4242.part").exists());
    assert!(!r.join(".reading_0000_truth.csv.x1y2.tmp").exists());
    assert!(!r.join(".staged.reading_0000.mp4").exists());
    assert!(r.join(".reading_0009.mp4.1.part").exists());

    // A damaged identity file (a copy cut short) is drawn again too; it
    // was found only after the other sessions were drawn, by what read it.
    let id = r.join("reading_0000_identity.json");
    let good = std::fs::read(&id).unwrap();
    std::fs::write(&id, b"{").unwrap();
    let s = render_dataset(dir.path(), &b, None, &NoProgress).unwrap();
    assert_eq!((s.rendered, s.skipped), (1, 1));
    assert_eq!(std::fs::read(&id).unwrap(), good);
}

#[test]
fn a_shard_renders_its_sessions_only() {
    let dir = tempfile::tempdir().unwrap();
    make_dataset(dir.path());
    let b = backend(dir.path());
    // Session 1 (labels.csv order) is conversation_0000.
    let s = render_dataset(dir.path(), &b, Some(Shard::new(1, 2).unwrap()), &NoProgress).unwrap();
    assert_eq!((s.rendered, s.frames), (1, 20));
    assert!(dir
        .path()
        .join("conversation/conversation_0000.mp4")
        .is_file());
    assert!(!dir.path().join("reading/reading_0000.mp4").exists());
}

#[test]
fn an_unreadable_session_stops_the_job_before_any_drawing() {
    let dir = tempfile::tempdir().unwrap();
    make_dataset(dir.path());
    std::fs::write(
        dir.path().join("conversation/conversation_0000.csv"),
        "frame,x,y\n0,1,nan\n",
    )
    .unwrap();
    let b = backend(dir.path());
    let e = render_dataset(dir.path(), &b, None, &NoProgress).unwrap_err();
    let BackendError::UnreadableSessions(failed) = &e else {
        panic!("{e}")
    };
    assert_eq!(failed.len(), 1);
    // Named once, with its line.
    let said = e.to_string();
    assert_eq!(said.matches("conversation_0000.csv").count(), 1, "{said}");
    assert!(said.contains("line 2") && !said.contains('\n'), "{said}");
    // Nothing was drawn: not the good session, not the bad one.
    assert!(!dir.path().join("reading/reading_0000.mp4").exists());
    let c: Vec<_> = std::fs::read_dir(dir.path().join("conversation"))
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(c, ["conversation_0000.csv"]);
    // A dataset without labels.csv is a one-line error.
    std::fs::remove_file(dir.path().join("labels.csv")).unwrap();
    let e = render_dataset(dir.path(), &b, None, &NoProgress)
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
    let s = render_dataset(dir.path(), &backend(dir.path()), None, &NoProgress).unwrap();
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

/// A backend that writes its files, then fails: the driver must leave
/// none of them.
struct FailsAfterWriting;

impl SessionBackend for FailsAfterWriting {
    fn name(&self) -> &'static str {
        "fails"
    }
    fn render(
        &self,
        _: &eyereplay_backends::Session,
        out: &eyereplay_backends::SessionOutputs,
        _: &dyn eyereplay_core::Progress,
    ) -> eyereplay_backends::Result<eyereplay_backends::Rendered> {
        std::fs::write(out.mp4(), b"video").unwrap();
        std::fs::write(out.truth(), b"truth").unwrap();
        Err(BackendError::Setting("the encoder died".into()))
    }
}

#[test]
fn a_failed_session_is_rolled_back_for_any_backend() {
    let dir = tempfile::tempdir().unwrap();
    make_dataset(dir.path());
    let e = render_dataset(dir.path(), &FailsAfterWriting, None, &NoProgress)
        .unwrap_err()
        .to_string();
    assert!(
        e.starts_with("2 session(s) failed") && e.contains("the encoder died"),
        "{e}"
    );
    for class in ["reading", "conversation"] {
        let left: Vec<_> = std::fs::read_dir(dir.path().join(class))
            .unwrap()
            .flatten()
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .filter(|n| !n.ends_with("_0000.csv"))
            .collect();
        assert!(left.is_empty(), "{left:?}");
    }
}

/// Every session of a dataset has `session_frames` rows (`merge` refuses
/// one that has not): a session cut short is refused before any is
/// drawn, naming its file and both lengths, not drawn as a shorter one.
#[test]
fn a_session_of_another_length_is_refused_before_any_is_drawn() {
    let dir = tempfile::tempdir().unwrap();
    make_dataset(dir.path());
    let talk = conversation_trajectory(15, 1280.0, 720.0, 1);
    write_session_csv(
        &dir.path().join("conversation/conversation_0000.csv"),
        &talk,
    )
    .unwrap();
    let e = render_dataset(dir.path(), &backend(dir.path()), None, &NoProgress).unwrap_err();
    assert!(matches!(e, BackendError::UnreadableSessions(_)), "{e}");
    let e = e.to_string();
    assert!(
        e.contains("conversation_0000.csv: 15 rows where the dataset's sessions have 20"),
        "{e}"
    );
    assert!(!dir.path().join("reading/reading_0000.mp4").exists());
    // And no lock is left behind by the refused run.
    assert!(!dir.path().join(".eyereplay-render.lock").exists());
}
