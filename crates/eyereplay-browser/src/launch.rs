//! Finding and starting the headless browser, and making sure it is gone.
//!
//! The browser runs in its own process group with a fresh profile folder.
//! [`Browser`]'s `Drop` kills the whole group (renderer, GPU and utility
//! processes included) and removes the profile, on success, on error and on
//! panic alike; the browser also gets SIGKILL when the thread that started it
//! dies (PR_SET_PDEATHSIG), so even a killed eyereplay leaves no browser.

use crate::BrowserError;
use std::collections::VecDeque;
use std::io::{BufRead, BufReader};
use std::os::unix::process::CommandExt;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::mpsc;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// Where Debian's `chromium-headless-shell` puts the real binary; the one on
/// PATH is a shell wrapper around it.
pub const DEBIAN_HEADLESS_SHELL: &str = "/usr/lib/chromium/chromium-headless-shell";
/// Environment variable naming the browser executable.
pub const BROWSER_ENV: &str = "EYEREPLAY_BROWSER";

/// Finds the browser: `explicit`, else `$EYEREPLAY_BROWSER`, else Debian's
/// headless shell, else `chromium-headless-shell` on PATH.
pub fn find_browser(explicit: Option<&Path>) -> Result<PathBuf, BrowserError> {
    let env = std::env::var_os(BROWSER_ENV).map(PathBuf::from);
    let path_var = std::env::var_os("PATH").unwrap_or_default();
    find_browser_in(
        explicit,
        env.as_deref(),
        &path_var,
        Path::new(DEBIAN_HEADLESS_SHELL),
    )
}

/// [`find_browser`] with its inputs explicit (testable without touching the
/// process environment).
pub fn find_browser_in(
    explicit: Option<&Path>,
    env: Option<&Path>,
    path_var: &std::ffi::OsStr,
    debian: &Path,
) -> Result<PathBuf, BrowserError> {
    // A browser named by the user must exist: do not silently fall back.
    if let Some(p) = explicit.or(env) {
        return if is_executable(p) {
            Ok(p.to_path_buf())
        } else {
            Err(BrowserError::BrowserMissing {
                searched: p.display().to_string(),
            })
        };
    }
    if is_executable(debian) {
        return Ok(debian.to_path_buf());
    }
    for dir in std::env::split_paths(path_var) {
        let p = dir.join("chromium-headless-shell");
        if is_executable(&p) {
            return Ok(p);
        }
    }
    Err(BrowserError::BrowserMissing {
        searched: format!("{}, chromium-headless-shell on PATH", debian.display()),
    })
}

fn is_executable(p: &Path) -> bool {
    use std::os::unix::fs::PermissionsExt;
    std::fs::metadata(p)
        .map(|m| m.is_file() && m.permissions().mode() & 0o111 != 0)
        .unwrap_or(false)
}

/// Flags of the old headless mode with frame control (research note
/// browser-backend.md): software WebGL through SwiftShader, no background
/// traffic, sRGB output, and every compositor stage run before a frame is
/// drawn so that `HeadlessExperimental.beginFrame` captures what the page
/// drew in that frame.
const FLAGS: &[&str] = &[
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--enable-unsafe-swiftshader",
    "--use-angle=swiftshader",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-default-apps",
    "--disable-extensions",
    "--disable-sync",
    "--no-first-run",
    "--no-default-browser-check",
    "--disable-quic",
    "--hide-scrollbars",
    "--mute-audio",
    "--force-color-profile=srgb",
    "--remote-debugging-port=0",
    "--enable-begin-frame-control",
    "--run-all-compositor-stages-before-draw",
    "--disable-new-content-rendering-timeout",
    "--disable-threaded-animation",
    "--disable-threaded-scrolling",
    "--disable-checker-imaging",
    "--disable-dev-shm-usage",
];

/// A running browser. Dropping it kills its process group and removes its
/// profile folder.
pub struct Browser {
    child: Option<Child>,
    pgid: i32,
    profile: Option<tempfile::TempDir>,
    /// The profile folder and the browser, listed for the binary's Ctrl-C
    /// handler (the browser killed, then the folder removed).
    _listed: (
        eyereplay_core::inflight::InFlight,
        eyereplay_core::inflight::ChildInFlight,
    ),
    /// The DevTools browser endpoint (`ws://127.0.0.1:PORT/devtools/browser/ID`).
    pub ws_url: String,
    pub program: PathBuf,
    stderr_tail: Arc<Mutex<VecDeque<String>>>,
}

impl Browser {
    /// Starts `program` with a fresh profile in `temp_dir` and waits (up to
    /// `timeout`) for its DevTools endpoint.
    pub fn launch(
        program: &Path,
        viewport_px: [u32; 2],
        temp_dir: Option<&Path>,
        extra_args: &[String],
        timeout: Duration,
    ) -> Result<Browser, BrowserError> {
        let tmp_root = temp_dir
            .map(Path::to_path_buf)
            .unwrap_or_else(std::env::temp_dir);
        let profile = tempfile::Builder::new()
            .prefix("eyereplay-browser-")
            .tempdir_in(&tmp_root)
            .map_err(|e| BrowserError::io(&tmp_root, e))?;
        let mut cmd = Command::new(program);
        cmd.args(FLAGS)
            .arg(format!("--user-data-dir={}", profile.path().display()))
            .arg(format!(
                "--window-size={},{}",
                viewport_px[0], viewport_px[1]
            ))
            .args(extra_args)
            .arg("about:blank")
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            // Its own group, so one kill reaches every helper process.
            .process_group(0);
        // SAFETY: prctl is async-signal-safe; it only sets this child's
        // parent-death signal so the browser cannot outlive us.
        unsafe {
            cmd.pre_exec(|| {
                libc::prctl(libc::PR_SET_PDEATHSIG, libc::SIGKILL as libc::c_ulong);
                Ok(())
            });
        }
        let mut child = cmd.spawn().map_err(|e| {
            if e.kind() == std::io::ErrorKind::NotFound {
                BrowserError::BrowserMissing {
                    searched: program.display().to_string(),
                }
            } else {
                BrowserError::Launch {
                    program: program.into(),
                    message: e.to_string(),
                }
            }
        })?;
        let pgid = child.id() as i32;
        let listed = (
            eyereplay_core::inflight::InFlight::new(profile.path()),
            eyereplay_core::inflight::ChildInFlight::new(child.id()),
        );
        let stderr = child.stderr.take().expect("stderr is piped");
        let tail = Arc::new(Mutex::new(VecDeque::new()));
        let (tx, rx) = mpsc::channel();
        {
            // Drains stderr for the browser's whole life (a full pipe would
            // block it), handing over the endpoint line and keeping the last
            // lines for error messages.
            let tail = Arc::clone(&tail);
            std::thread::Builder::new()
                .name("browser-stderr".into())
                .spawn(move || {
                    let mut tx = Some(tx);
                    for line in BufReader::new(stderr).lines() {
                        let Ok(line) = line else { break };
                        if let Some(url) = line
                            .split_once("DevTools listening on ")
                            .map(|(_, u)| u.trim().to_string())
                        {
                            if let Some(tx) = tx.take() {
                                let _ = tx.send(url);
                            }
                        }
                        let mut t = tail.lock().unwrap_or_else(|p| p.into_inner());
                        if t.len() == 20 {
                            t.pop_front();
                        }
                        t.push_back(line);
                    }
                })
                .map_err(|e| BrowserError::Launch {
                    program: program.into(),
                    message: e.to_string(),
                })?;
        }
        let mut browser = Browser {
            child: Some(child),
            pgid,
            profile: Some(profile),
            _listed: listed,
            ws_url: String::new(),
            program: program.into(),
            stderr_tail: tail,
        };
        let deadline = Instant::now() + timeout;
        loop {
            match rx.recv_timeout(Duration::from_millis(50)) {
                Ok(url) => {
                    browser.ws_url = url;
                    return Ok(browser);
                }
                Err(mpsc::RecvTimeoutError::Timeout) => {
                    if let Some(Some(status)) =
                        browser.child.as_mut().and_then(|c| c.try_wait().ok())
                    {
                        // Let the reader thread collect the last lines.
                        std::thread::sleep(Duration::from_millis(50));
                        return Err(browser.launch_error(format!("exited ({status})")));
                    }
                    if Instant::now() > deadline {
                        return Err(browser.launch_error(format!(
                            "no DevTools endpoint within {:.0} s",
                            timeout.as_secs_f64()
                        )));
                    }
                }
                Err(mpsc::RecvTimeoutError::Disconnected) => {
                    std::thread::sleep(Duration::from_millis(50));
                    return Err(browser.launch_error("closed its output".into()));
                }
            }
        }
    }

    fn launch_error(&self, what: String) -> BrowserError {
        let last = self.last_stderr_line();
        BrowserError::Launch {
            program: self.program.clone(),
            message: if last.is_empty() {
                what
            } else {
                format!("{what}: {last}")
            },
        }
    }

    /// The browser's last meaningful stderr line (dbus noise skipped).
    pub fn last_stderr_line(&self) -> String {
        let t = self.stderr_tail.lock().unwrap_or_else(|p| p.into_inner());
        t.iter()
            .rev()
            .find(|l| !l.trim().is_empty() && !l.contains("dbus") && !l.contains("DevTools"))
            .cloned()
            .unwrap_or_default()
    }

    /// The profile folder (removed on drop).
    pub fn profile_dir(&self) -> Option<&Path> {
        self.profile.as_ref().map(|p| p.path())
    }

    /// The browser's process id (also its process group id).
    pub fn pid(&self) -> i32 {
        self.pgid
    }

    /// Waits up to `grace` for the browser to exit by itself (after
    /// `Browser.close`), then kills what is left of its group, reaps it and
    /// removes the profile.
    pub fn shutdown(&mut self, grace: Duration) {
        if let Some(mut child) = self.child.take() {
            let deadline = Instant::now() + grace;
            while Instant::now() < deadline {
                if let Ok(Some(_)) = child.try_wait() {
                    break;
                }
                std::thread::sleep(Duration::from_millis(10));
            }
            // SAFETY: signals our own child's process group (created by
            // process_group(0) with the child's pid as its id). Helpers that
            // are still alive die here; no-op when the group is gone.
            unsafe {
                libc::killpg(self.pgid, libc::SIGKILL);
            }
            let _ = child.kill();
            let _ = child.wait();
            wait_group_gone(self.pgid, Duration::from_secs(5));
        }
        if let Some(profile) = self.profile.take() {
            let path = profile.path().to_path_buf();
            if profile.close().is_err() {
                // A helper may have written a last file while dying.
                std::thread::sleep(Duration::from_millis(100));
                let _ = std::fs::remove_dir_all(&path);
            }
        }
    }
}

impl Drop for Browser {
    fn drop(&mut self) {
        self.shutdown(Duration::ZERO);
    }
}

/// Waits until no process of group `pgid` is left (zombies reparented to an
/// init that reaps slowly count as gone only once reaped; bounded wait).
fn wait_group_gone(pgid: i32, limit: Duration) {
    let deadline = Instant::now() + limit;
    // SAFETY: signal 0 only checks whether the group has any process.
    while unsafe { libc::killpg(pgid, 0) } == 0 && Instant::now() < deadline {
        std::thread::sleep(Duration::from_millis(5));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn missing_browser_names_the_debian_package() {
        let dir = tempfile::tempdir().unwrap();
        let e = find_browser_in(None, None, dir.path().as_os_str(), &dir.path().join("nope"))
            .unwrap_err();
        let msg = e.to_string();
        assert!(
            msg.contains("apt-get install chromium-headless-shell"),
            "{msg}"
        );
        assert!(!msg.contains('\n'));
        // A named browser that does not exist is an error, not a fallback.
        let e = find_browser_in(
            Some(Path::new("/no/such/browser")),
            None,
            "".as_ref(),
            Path::new("/bin/sh"),
        )
        .unwrap_err();
        assert!(e.to_string().contains("/no/such/browser"));
    }

    #[test]
    fn finds_the_browser_on_path() {
        let dir = tempfile::tempdir().unwrap();
        let exe = dir.path().join("chromium-headless-shell");
        std::fs::write(&exe, "#!/bin/sh\n").unwrap();
        use std::os::unix::fs::PermissionsExt;
        std::fs::set_permissions(&exe, std::fs::Permissions::from_mode(0o755)).unwrap();
        let found =
            find_browser_in(None, None, dir.path().as_os_str(), &dir.path().join("nope")).unwrap();
        assert_eq!(found, exe);
    }
}
