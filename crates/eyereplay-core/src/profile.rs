//! Where a job's CPU time goes, stage by stage (`eyereplay generate
//! --profile`).
//!
//! A stage is timed by wrapping it in [`lap`]. While recording is off (the
//! default) a lap is the closure and nothing else: no clock is read. While
//! it is on ([`start_recording`]), each lap records the process's CPU time
//! (every thread's, [`process_cpu_s`]), the CPU time of the child processes
//! it waited for (the x264 encoder is an `ffmpeg` child, [`children_cpu_s`])
//! and the wall time. Process-wide clocks are right only while one piece of
//! work runs at a time, so the profile renders one session alone.
//!
//! Laps nest: a lap inside another is recorded under both names
//! (`"first pass / draw"`), and [`Lap::depth`] says how deep, so the
//! top-level laps partition the work without counting anything twice.

use serde::Serialize;
use std::sync::Mutex;
use std::time::Instant;

/// One timed stage.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Lap {
    /// The names of the laps it is nested in and its own, joined by " / ".
    pub stage: String,
    /// 0 for a top-level lap.
    pub depth: usize,
    /// CPU time of this process (all threads), s.
    pub cpu_s: f64,
    /// CPU time of child processes that ended during the lap, s.
    pub child_cpu_s: f64,
    pub wall_s: f64,
}

#[derive(Default)]
struct Recording {
    open: Vec<&'static str>,
    laps: Vec<Lap>,
}

static RECORDING: Mutex<Option<Recording>> = Mutex::new(None);

fn recording() -> std::sync::MutexGuard<'static, Option<Recording>> {
    RECORDING.lock().unwrap_or_else(|p| p.into_inner())
}

/// Starts recording laps (dropping any recorded before).
pub fn start_recording() {
    *recording() = Some(Recording::default());
}

/// Stops recording and returns the laps in the order they ended.
pub fn stop_recording() -> Vec<Lap> {
    recording().take().map(|r| r.laps).unwrap_or_default()
}

/// Runs `f` as the stage `stage` (see the module docs).
pub fn lap<T>(stage: &'static str, f: impl FnOnce() -> T) -> T {
    {
        let mut r = recording();
        match r.as_mut() {
            None => {
                drop(r);
                return f();
            }
            Some(rec) => rec.open.push(stage),
        }
    }
    let (out, mut timed) = measure("", f);
    if let Some(rec) = recording().as_mut() {
        timed.stage = rec.open.join(" / ");
        rec.open.pop();
        timed.depth = rec.open.len();
        rec.laps.push(timed);
    }
    out
}

/// Runs `f` and times it as one top-level lap named `stage`, whether or not
/// laps are being recorded (the caller keeps the lap).
pub fn measure<T>(stage: &str, f: impl FnOnce() -> T) -> (T, Lap) {
    let (cpu0, child0, t0) = (process_cpu_s(), children_cpu_s(), Instant::now());
    let out = f();
    let lap = Lap {
        stage: stage.to_string(),
        depth: 0,
        cpu_s: process_cpu_s() - cpu0,
        child_cpu_s: children_cpu_s() - child0,
        wall_s: t0.elapsed().as_secs_f64(),
    };
    (out, lap)
}

/// CPU time (user + system) of the calling thread, in seconds.
pub fn thread_cpu_s() -> f64 {
    clock_s(libc::CLOCK_THREAD_CPUTIME_ID)
}

/// CPU time (user + system) of the whole process, all threads, in seconds.
pub fn process_cpu_s() -> f64 {
    clock_s(libc::CLOCK_PROCESS_CPUTIME_ID)
}

/// CPU time (user + system) of the child processes this process has
/// waited for, in seconds (`getrusage(RUSAGE_CHILDREN)`).
pub fn children_cpu_s() -> f64 {
    // SAFETY: an all-zero rusage is a valid value of the plain C struct.
    let mut u: libc::rusage = unsafe { std::mem::zeroed() };
    // SAFETY: `u` is a valid, writable rusage; RUSAGE_CHILDREN always exists.
    unsafe {
        libc::getrusage(libc::RUSAGE_CHILDREN, &mut u);
    }
    let s = |t: libc::timeval| t.tv_sec as f64 + t.tv_usec as f64 * 1e-6;
    s(u.ru_utime) + s(u.ru_stime)
}

fn clock_s(clock: libc::clockid_t) -> f64 {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `ts` is a valid, writable timespec; both clock ids exist on
    // Linux.
    unsafe {
        libc::clock_gettime(clock, &mut ts);
    }
    ts.tv_sec as f64 + ts.tv_nsec as f64 * 1e-9
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spin(s: f64) -> f64 {
        let t0 = thread_cpu_s();
        let mut x = 0.0f64;
        while thread_cpu_s() - t0 < s {
            x = (x + 1.0).sqrt();
        }
        x
    }

    #[test]
    fn laps_nest_record_cpu_and_children_and_cost_nothing_when_off() {
        // Off: the closure runs, nothing is recorded.
        assert_eq!(lap("off", || 7), 7);
        start_recording();
        lap("outer", || {
            spin(0.05);
            lap("inner", || spin(0.05));
            // A child process waited for is charged to the lap that waited.
            std::process::Command::new("sh")
                .args(["-c", "i=0; while [ $i -lt 20000 ]; do i=$((i+1)); done"])
                .status()
                .unwrap();
        });
        let laps = stop_recording();
        assert_eq!(laps.len(), 2);
        assert_eq!(
            (laps[0].stage.as_str(), laps[0].depth),
            ("outer / inner", 1)
        );
        assert_eq!((laps[1].stage.as_str(), laps[1].depth), ("outer", 0));
        // The inner lap spun 50 ms of CPU; the outer one holds it and its own.
        assert!(laps[0].cpu_s >= 0.05 && laps[1].cpu_s >= 0.1, "{laps:?}");
        assert!(laps[1].cpu_s >= laps[0].cpu_s);
        assert!(
            laps[1].child_cpu_s > 0.0 && laps[0].child_cpu_s == 0.0,
            "{laps:?}"
        );
        assert!(laps[1].wall_s >= laps[0].wall_s);
        // Stopped: off again.
        lap("after", || ());
        assert!(stop_recording().is_empty());
    }
}
