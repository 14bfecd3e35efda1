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
/// warnings on stderr, printed above the bar.
#[derive(Default)]
pub struct Bars {
    bar: Mutex<Option<ProgressBar>>,
}

impl Bars {
    fn with_bar(&self, f: impl FnOnce(&ProgressBar)) {
        if let Some(b) = self.bar.lock().expect("progress lock").as_ref() {
            f(b);
        }
    }
}

impl Progress for Bars {
    fn begin(&self, stage: Stage, total: u64) {
        let template = match stage {
            Stage::Extract => {
                "extract {bar:30} {human_pos}/{human_len} frames, {per_sec}, ETA {eta}"
            }
            Stage::Render => {
                "render {bar:30} {msg} {human_pos}/{human_len} frames, {per_sec}, ETA {eta}"
            }
        };
        let bar = ProgressBar::new(total);
        bar.set_style(ProgressStyle::with_template(template).expect("static template"));
        *self.bar.lock().expect("progress lock") = Some(bar);
    }
    fn add_total(&self, units: u64) {
        self.with_bar(|b| b.inc_length(units));
    }
    fn advance(&self, units: u64) {
        self.with_bar(|b| b.inc(units));
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
