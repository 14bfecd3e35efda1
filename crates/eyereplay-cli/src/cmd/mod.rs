//! One module per subcommand; each exposes `Args` (clap) and `run`. The work
//! is the `eyereplay` library's; this layer parses arguments and shows
//! progress.
pub mod detect;
pub mod evaluate;
pub mod evaluate_detector;
pub mod evaluate_localization;
pub mod evaluate_replay;
pub mod extract;
pub mod generate;
pub mod merge;
pub mod models;
pub mod prepare;
pub mod render;
pub mod train;

use eyereplay::{Progress, Stage};
use indicatif::{ProgressBar, ProgressStyle};
use std::sync::Mutex;

/// The library's progress events as terminal progress bars: one bar per
/// stage, counting frames, with rate and ETA; result lines on stdout,
/// warnings on stderr, printed above the bar. Where stderr is not a
/// terminal, plain lines instead ([`LogClock`]).
#[derive(Default)]
pub struct Bars {
    bar: Mutex<Option<ProgressBar>>,
    logged: LogClock,
    /// The stage's name, for the plain line.
    stage: Mutex<&'static str>,
}

impl Bars {
    fn with_bar(&self, f: impl FnOnce(&ProgressBar)) {
        if let Some(b) = self.bar.lock().expect("progress lock").as_ref() {
            f(b);
        }
    }
}

/// Seconds between plain progress lines where stderr is not a terminal;
/// `EYEREPLAY_LOG_EVERY_S` (a whole number, at least 1) overrides it.
pub const LOG_EVERY_S: u64 = 30;

/// The command's work is done and its outputs are in place: a stop from
/// here on changes nothing, so it is ignored and the command prints its
/// summary and ends with its own status. If a stop began first, this
/// waits for it to end the process (status 130 or 143), so that no summary
/// follows its line.
pub fn work_done() {
    if !eyereplay_core::inflight::finish() {
        loop {
            std::thread::park();
        }
    }
}

/// A folder argument that names a file ("File exists" from the OS, after
/// the work, said nothing of which path or why).
pub fn check_folder_arg(dir: &std::path::Path, flag: &str) -> anyhow::Result<()> {
    match dir.ancestors().find(|a| a.is_file()) {
        Some(file) if file == dir => {
            anyhow::bail!("{}: a file; {flag} takes a folder", dir.display())
        }
        Some(file) => anyhow::bail!(
            "{}: {} is a file, not a folder ({flag})",
            dir.display(),
            file.display()
        ),
        None => Ok(()),
    }
}

/// A JSON file a command writes (`--out` of `train`, `--json`), checked
/// before the work: a `.json` name, so that a slip of the keyboard cannot
/// write JSON over `labels.csv` or a session video; not one of the
/// command's `inputs` (a model written over the model it scores); not a
/// dataset's own `metadata.json` nor anything in a dataset's subfolders
/// (class folders, `report`, `pool`: files of the dataset); and writable.
/// A model beside a dataset's `labels.csv` is fine.
pub fn check_json_out(
    path: &std::path::Path,
    flag: &str,
    datasets: &[&std::path::Path],
    inputs: &[&std::path::Path],
) -> anyhow::Result<()> {
    use std::path::Path;
    if path.extension().and_then(|e| e.to_str()) != Some("json") {
        anyhow::bail!(
            "{}: {flag} takes a file name ending in .json",
            path.display()
        );
    }
    let parent = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    // Compared as the OS resolves them (`./d` and `d/../d` are `d`); a
    // folder that does not exist yet holds no dataset.
    if let (Ok(folder), Some(name)) = (parent.canonicalize(), path.file_name()) {
        let target = folder.join(name);
        for input in inputs {
            if input.canonicalize().is_ok_and(|i| i == target) {
                anyhow::bail!(
                    "{}: is an input of this command ({}); give {flag} another file",
                    path.display(),
                    input.display()
                );
            }
        }
        for dataset in datasets {
            let Ok(d) = dataset.canonicalize() else {
                continue;
            };
            if folder == d && name == eyereplay_dataset::layout::METADATA_FILE {
                anyhow::bail!(
                    "{}: is the dataset's own metadata; give {flag} another name",
                    path.display()
                );
            }
            if folder != d && folder.starts_with(&d) {
                anyhow::bail!(
                    "{}: inside the folders of the dataset {} (its sessions and report); give {flag} a path outside them",
                    path.display(),
                    dataset.display()
                );
            }
        }
    }
    eyereplay_core::check_writable(path)?;
    Ok(())
}

/// What is wrong with `EYEREPLAY_LOG_EVERY_S`, if set to anything but a
/// whole number of seconds >= 1 (it was ignored, and a log then showed
/// lines every 30 s with no word why).
pub fn log_every_s_problem() -> Option<String> {
    let v = std::env::var("EYEREPLAY_LOG_EVERY_S").ok()?;
    match v.trim().parse::<u64>() {
        Ok(s) if s >= 1 => None,
        _ => Some(format!(
            "EYEREPLAY_LOG_EVERY_S={v}: the seconds between progress lines in a log, a whole number of at least 1 (unset it for {LOG_EVERY_S})"
        )),
    }
}

/// Where stderr is not a terminal (a Slurm log, `nohup`, a pipe)
/// indicatif draws nothing, so an hour-long job's log would show nothing
/// moving: a plain line with the bar's counts goes there every
/// [`LOG_EVERY_S`] instead. This says when.
#[derive(Default)]
pub struct LogClock(Mutex<Option<std::time::Instant>>);

impl LogClock {
    /// Starts the interval again (a stage begins).
    pub fn restart(&self) {
        *self.0.lock().expect("log clock") = Some(std::time::Instant::now());
    }

    /// Whether a plain line is due now (never on a terminal); if so, the
    /// interval starts again.
    pub fn due(&self) -> bool {
        use std::io::IsTerminal;
        if std::io::stderr().is_terminal() {
            return false;
        }
        // A bad value was refused at start (`log_every_s_problem`).
        let every_s = std::env::var("EYEREPLAY_LOG_EVERY_S")
            .ok()
            .and_then(|v| v.trim().parse::<u64>().ok())
            .filter(|s| *s >= 1)
            .unwrap_or(LOG_EVERY_S);
        let mut last = self.0.lock().expect("log clock");
        let now = std::time::Instant::now();
        match *last {
            Some(t) if now.duration_since(t).as_secs() < every_s => false,
            Some(_) => {
                *last = Some(now);
                true
            }
            None => {
                *last = Some(now);
                false
            }
        }
    }
}

/// The plain line of `bar`: `label: 200/400 frames (50.0 %), 70 frames/s,
/// ETA 3 seconds; its message`.
pub fn log_line(label: &str, bar: &ProgressBar) {
    let (pos, len) = (bar.position(), bar.length().unwrap_or(0));
    let share = if len > 0 {
        format!(" ({:.1} %)", 100.0 * pos as f64 / len as f64)
    } else {
        String::new()
    };
    let msg = bar.message();
    eprintln!(
        "{label}: {pos}/{len} frames{share}, {:.1} frames/s, ETA {}{}{msg}",
        bar.per_sec(),
        indicatif::HumanDuration(bar.eta()),
        if msg.is_empty() { "" } else { "; " },
    );
}

impl Progress for Bars {
    fn begin(&self, stage: Stage, total: u64) {
        let template = match stage {
            Stage::Extract => {
                "extract {bar:30} {human_pos}/{human_len} frames, {rate}, ETA {eta} {msg}"
            }
            Stage::Render => {
                "render {bar:30} {msg} {human_pos}/{human_len} frames, {rate}, ETA {eta}"
            }
        };
        let bar = ProgressBar::new(total);
        bar.set_style(
            ProgressStyle::with_template(template)
                .expect("static template")
                // Whole frames a second ("93/s"): indicatif's {per_sec}
                // shows four decimals of a rate that moves in the units.
                .with_key(
                    "rate",
                    |s: &indicatif::ProgressState, w: &mut dyn std::fmt::Write| {
                        let _ = write!(w, "{:.0}/s", s.per_sec());
                    },
                )
                // "?" until a frame is done: indicatif's {eta} says "0s"
                // before it knows anything.
                .with_key(
                    "eta",
                    |s: &indicatif::ProgressState, w: &mut dyn std::fmt::Write| {
                        if s.pos() == 0 {
                            let _ = write!(w, "?");
                        } else {
                            let _ = write!(w, "{:#}", indicatif::HumanDuration(s.eta()));
                        }
                    },
                ),
        );
        *self.bar.lock().expect("progress lock") = Some(bar);
        self.logged.restart();
        *self.stage.lock().expect("progress lock") = match stage {
            Stage::Extract => "extract",
            Stage::Render => "render",
        };
    }
    fn add_total(&self, units: u64) {
        self.with_bar(|b| b.inc_length(units));
    }
    fn advance(&self, units: u64) {
        self.with_bar(|b| b.inc(units));
        if self.logged.due() {
            let stage = *self.stage.lock().expect("progress lock");
            self.with_bar(|b| log_line(stage, b));
        }
    }
    fn status(&self, text: &str) {
        self.with_bar(|b| b.set_message(text.to_string()));
    }
    fn end(&self, _stage: Stage) {
        if let Some(b) = self.bar.lock().expect("progress lock").take() {
            b.finish_and_clear();
        }
    }
    fn info(&self, line: &str) {
        let guard = self.bar.lock().expect("progress lock");
        match guard.as_ref() {
            Some(b) => b.suspend(|| println!("{line}")),
            None => println!("{line}"),
        }
    }
    fn warn(&self, line: &str) {
        let guard = self.bar.lock().expect("progress lock");
        match guard.as_ref() {
            Some(b) => b.suspend(|| eprintln!("{line}")),
            None => eprintln!("{line}"),
        }
    }
}

/// clap value parsers for numbers with a range, so that a bad value is
/// refused in one line naming the option before any work starts.
pub mod values {
    fn number(s: &str) -> Result<f64, String> {
        let v: f64 = s
            .trim()
            .parse()
            .map_err(|_| format!("'{s}' is not a number"))?;
        if v.is_finite() {
            Ok(v)
        } else {
            Err(format!("'{s}' is not a finite number"))
        }
    }

    /// A whole number, 0 or more. The integer types' own parse error says
    /// "invalid digit found in string" for `-1` or `1.5`, which names
    /// neither what was wrong nor what is wanted.
    pub fn whole<T: std::str::FromStr>(s: &str) -> Result<T, String> {
        s.trim().parse().map_err(|_| match s.trim().parse::<f64>() {
            Ok(v) if v.is_finite() && v >= 0.0 && v.fract() == 0.0 => {
                format!("{s} is too large")
            }
            Ok(_) => format!("must be a whole number, 0 or more, got {s}"),
            Err(_) => format!("'{s}' is not a whole number"),
        })
    }

    /// A finite number above 0.
    pub fn positive(s: &str) -> Result<f64, String> {
        let v = number(s)?;
        if v > 0.0 {
            Ok(v)
        } else {
            Err(format!("must be above 0, got {v}"))
        }
    }

    /// A fraction strictly between 0 and 1.
    pub fn open_fraction(s: &str) -> Result<f64, String> {
        let v = number(s)?;
        if v > 0.0 && v < 1.0 {
            Ok(v)
        } else {
            Err(format!("must be between 0 and 1 (exclusive), got {v}"))
        }
    }

    /// A probability, 0 to 1 inclusive.
    pub fn probability(s: &str) -> Result<f64, String> {
        let v = number(s)?;
        if (0.0..=1.0).contains(&v) {
            Ok(v)
        } else {
            Err(format!("must be between 0 and 1, got {v}"))
        }
    }

    #[cfg(test)]
    mod tests {
        use super::*;

        #[test]
        fn ranges_hold_at_their_edges() {
            assert_eq!(positive("0.5"), Ok(0.5));
            assert!(positive("0").is_err() && positive("-1").is_err());
            assert!(positive("nan").is_err() && positive("inf").is_err());
            assert!(positive("abc").unwrap_err().contains("'abc'"));
            assert!(open_fraction("0").is_err() && open_fraction("1").is_err());
            assert_eq!(open_fraction("0.3"), Ok(0.3));
            assert_eq!(probability("1"), Ok(1.0));
            assert!(probability("1.01").is_err() && probability("-0.5").is_err());
            assert_eq!(whole::<usize>("0"), Ok(0));
            assert_eq!(whole::<u64>(" 7 "), Ok(7));
            let negative = whole::<usize>("-1").unwrap_err();
            assert_eq!(negative, "must be a whole number, 0 or more, got -1");
            assert!(whole::<u64>("1.5").unwrap_err().contains("whole number"));
            assert_eq!(whole::<u16>("70000").unwrap_err(), "70000 is too large");
            assert_eq!(whole::<u64>("x").unwrap_err(), "'x' is not a whole number");
        }
    }
}

/// The cache folder (`--cache`, `$EYEREPLAY_CACHE`, ...), refused up front
/// when a file stands at its path: otherwise the first extraction fails
/// minutes in, naming a path inside it.
pub fn cache_dir(flag: Option<&std::path::Path>) -> anyhow::Result<std::path::PathBuf> {
    let dir = eyereplay::cache_dir(flag);
    anyhow::ensure!(
        !dir.exists() || dir.is_dir(),
        "{}: the cache (--cache or $EYEREPLAY_CACHE) is a file, not a folder",
        dir.display()
    );
    Ok(dir)
}
