//! Helpers shared by the CLI test files: the binary run from the
//! repository root, and checks of its output.
#![allow(dead_code)] // each test file uses some of them

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// Runs `ffmpeg -v error -y ARGS` (making a test's clip), which must succeed.
pub fn ffmpeg(args: &[&str]) {
    let o = Command::new("ffmpeg")
        .args(["-nostdin", "-v", "error", "-y"])
        .args(args)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

pub fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .canonicalize()
        .unwrap()
}

pub fn eyereplay(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_eyereplay"))
        .args(args)
        .current_dir(root())
        .output()
        .unwrap()
}

pub fn ok(o: &Output) -> String {
    assert!(
        o.status.success(),
        "{}\n{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    String::from_utf8_lossy(&o.stdout).into_owned()
}

pub fn one_line_error(o: &Output) -> String {
    assert!(!o.status.success());
    let e = String::from_utf8_lossy(&o.stderr).to_string();
    assert_eq!(e.trim_end().lines().count(), 1, "{e}");
    assert!(e.starts_with("error: "), "{e}");
    e
}

pub fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// Starts `eyereplay ARGS` (environment `env` added) from the repository
/// root, waits until a file or folder whose name starts with `prefix`
/// appears in `watch`, waits `after` more, sends `signal` to the process
/// alone (not its group: FFmpeg must be stopped by eyereplay itself, as
/// when a supervisor signals one pid), and returns its output.
pub fn stopped_when(
    args: &[&str],
    env: &[(&str, &Path)],
    watch: &Path,
    prefix: &str,
    after: std::time::Duration,
    signal: libc::c_int,
) -> Output {
    let child = Command::new(env!("CARGO_BIN_EXE_eyereplay"))
        .args(args)
        .envs(env.iter().map(|(k, v)| (k, v.as_os_str())))
        .current_dir(root())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let started = std::time::Instant::now();
    let appeared = || {
        std::fs::read_dir(watch)
            .into_iter()
            .flatten()
            .flatten()
            .any(|e| e.file_name().to_string_lossy().starts_with(prefix))
    };
    while !appeared() {
        assert!(
            started.elapsed().as_secs() < 120,
            "{prefix}* never appeared in {}",
            watch.display()
        );
        std::thread::sleep(std::time::Duration::from_millis(2));
    }
    std::thread::sleep(after);
    // SAFETY: kill(2) on our own child's pid.
    assert_eq!(unsafe { libc::kill(child.id() as libc::pid_t, signal) }, 0);
    child.wait_with_output().unwrap()
}
