//! `eyereplay`: real human eye movements in, labeled synthetic eye-movement
//! video out. Each subcommand lives in its own module under `cmd/` and is a
//! thin layer over a pipeline crate.

use clap::{Parser, Subcommand};

/// `eprintln!` for this binary, which never panics: std's panics when
/// standard error is a closed pipe (`... 2>&1 | grep -m1 reading`), which
/// ended a live watch or a render before its files were written. Standard
/// error carries messages, not results, so a message nobody can read is
/// dropped and the work goes on. Defined before the modules, so that it
/// shadows std's in all of them.
macro_rules! eprintln {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stderr(), $($arg)*);
    }};
}

mod cmd;

#[derive(Parser)]
#[command(
    name = "eyereplay",
    version,
    about = "Turn real human eye movements into labeled synthetic eye-movement video",
    long_about = "eyereplay extracts iris trajectories from real video and eye-tracker \
recordings, calibrates, resamples, normalizes and slices them into sessions (the \
pipeline of 'A Synthetic Eye Movement Dataset for Script Reading Detection'), renders \
each session on a 3D eye simulator, and measures how faithful the result is.",
    after_help = "Examples:\n  \
# the whole job: the bundled default sample, or your config\n  \
eyereplay generate --config examples/default.toml --out data/\n  \
eyereplay generate --config dataset.toml --out data/ --dry-run\n  \
# stages 2-5 only: trajectories\n  \
eyereplay prepare --config dataset.toml --out data/\n  \
# is the person in this video reading, and when?\n  \
eyereplay detect interview.mp4\n\n\
Run 'eyereplay <command> --help' for each command's options and examples."
)]
struct Cli {
    /// More log output (-v info, -vv debug); RUST_LOG overrides.
    #[arg(short, long, action = clap::ArgAction::Count, global = true)]
    verbose: u8,
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    Prepare(cmd::prepare::Args),
    Evaluate(cmd::evaluate::Args),
    Render(cmd::render::Args),
    Extract(cmd::extract::Args),
    Models(cmd::models::Args),
    Generate(cmd::generate::Args),
    Merge(cmd::merge::Args),
    Train(cmd::train::Args),
    Detect(cmd::detect::Args),
    EvaluateDetector(cmd::evaluate_detector::Args),
    EvaluateReplay(cmd::evaluate_replay::Args),
    EvaluateLocalization(cmd::evaluate_localization::Args),
}

/// Ends the program quietly, as other Unix tools end, when whoever reads
/// its standard output has gone (`eyereplay train ... | head -1`): Rust
/// ignores SIGPIPE, so `println!` panics with a backtrace there. Commands
/// write their files before they print their results, so the files are
/// whole by then. Not by
/// restoring SIGPIPE itself: a closed pipe to ffmpeg must stay an error
/// that names ffmpeg's own message.
fn quiet_when_stdout_is_gone() {
    let default_hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        let payload = info.payload();
        let message = payload
            .downcast_ref::<String>()
            .map(String::as_str)
            .or_else(|| payload.downcast_ref::<&str>().copied())
            .unwrap_or("");
        // Standard error too, for a message printed outside this binary's
        // own `eprintln!` (above).
        let gone = message.starts_with("failed printing to stdout")
            || message.starts_with("failed printing to stderr");
        if gone && message.contains("Broken pipe") {
            // 128 + SIGPIPE: what a shell reports for a tool ended by it.
            std::process::exit(141);
        }
        default_hook(info);
    }));
}

fn main() -> std::process::ExitCode {
    // First: a stop in the first milliseconds ends the run as any other.
    remove_partial_files_when_stopped();
    quiet_when_stdout_is_gone();
    let cli = match parse_args() {
        Ok(cli) => cli,
        Err(e) => {
            use clap::error::ErrorKind;
            if matches!(
                e.kind(),
                ErrorKind::DisplayHelp
                    | ErrorKind::DisplayVersion
                    | ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand
            ) {
                e.exit();
            }
            let args: Vec<String> = std::env::args().collect();
            eprintln!("{}", one_line_usage_error(&e.to_string(), &args));
            return std::process::ExitCode::from(2);
        }
    };
    init_tracing(cli.verbose);
    if let Some(bad) = cmd::log_every_s_problem() {
        eprintln!("error: {bad}");
        return std::process::ExitCode::from(2);
    }
    let result = match cli.command {
        Command::Prepare(a) => cmd::prepare::run(a),
        Command::Evaluate(a) => cmd::evaluate::run(a),
        Command::Render(a) => cmd::render::run(a),
        Command::Extract(a) => cmd::extract::run(a),
        Command::Models(a) => cmd::models::run(a),
        Command::Generate(a) => cmd::generate::run(a),
        Command::Merge(a) => cmd::merge::run(a),
        Command::Train(a) => cmd::train::run(a),
        Command::Detect(a) => cmd::detect::run(a),
        Command::EvaluateDetector(a) => cmd::evaluate_detector::run(a),
        Command::EvaluateReplay(a) => cmd::evaluate_replay::run(a),
        Command::EvaluateLocalization(a) => cmd::evaluate_localization::run(a),
    };
    // A stop under way ends the process itself (status 130 or 143); what failed
    // here may be its removal of files this run was writing. Otherwise
    // the work is over: a stop from now on changes nothing, so it is
    // ignored and the command ends with its own status and output.
    cmd::work_done();
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            // One line: the chain of causes joined, so scripts can grep it.
            eprintln!("error: {}", format_chain(&e));
            std::process::ExitCode::FAILURE
        }
    }
}

/// The command line, with negative numbers taken as values (`--gain -1`
/// then meets its own range check, not clap's "unexpected argument '-1'"
/// and a tip to write `-- -1`).
fn parse_args() -> Result<Cli, clap::Error> {
    use clap::{CommandFactory, FromArgMatches};
    let mut command = Cli::command();
    let names: Vec<String> = command
        .get_subcommands()
        .map(|s| s.get_name().to_string())
        .collect();
    for name in names {
        command = command.mut_subcommand(name, |s| s.allow_negative_numbers(true));
    }
    command
        .try_get_matches()
        .and_then(|m| Cli::from_arg_matches(&m))
}

/// Ctrl-C, SIGTERM (a Slurm job's time limit, `kill`) or SIGHUP (the
/// terminal closed) ends the run
/// at once as it would by default, but first removes the temporary files
/// and folders being written (a video's `.NAME.PID.part`, a session's
/// staged files, a report's folder): finished outputs stay, and nothing
/// half-written is left beside them. Exit status 128 + the signal's
/// number, as a shell reports a process the signal killed: 130 for
/// Ctrl-C, 143 for SIGTERM, so a job scheduler's accounting tells a
/// time limit from a user's stop. `detect --live` replaces this with its
/// own handler (a stop there ends the watch with its result).
fn remove_partial_files_when_stopped() {
    use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};
    // signal-hook's iterator: the handler only writes to a pipe, and this
    // thread, woken with the signal's number, does the removal outside
    // the handler's restrictions.
    let mut signals = match signal_hook::iterator::Signals::new([SIGINT, SIGTERM, SIGHUP]) {
        Ok(s) => s,
        Err(e) => {
            tracing::debug!("no Ctrl-C handler: {e}");
            return;
        }
    };
    std::thread::spawn(move || {
        for signal in signals.forever() {
            let Some(removed) = eyereplay_core::inflight::remove_in_flight() else {
                // The work had finished: every output is in place.
                continue;
            };
            // The render's lock is bookkeeping, not a file the user saw
            // growing: named neither in the count nor as the example.
            let unfinished: Vec<_> = removed
                .iter()
                .filter(|p| p.extension().is_none_or(|e| e != "lock"))
                .collect();
            match unfinished.first() {
                None => eprintln!("stopped"),
                Some(example) => eprintln!(
                    "stopped: removed {} unfinished file(s), such as {}",
                    unfinished.len(),
                    example.display()
                ),
            }
            let _ = std::io::Write::flush(&mut std::io::stdout());
            // Not `exit`: its atexit work tears down ONNX Runtime's statics
            // while its threads still run, and they print errors on the way.
            // SAFETY: _exit ends the process without touching its state.
            unsafe { libc::_exit(128 + signal) }
        }
    });
}

/// clap's usage error on one line, as every other error is: its message
/// and any tip (clap puts a list of missing arguments, and a "did you
/// mean", on lines of their own), then which help to read: that of the
/// subcommand named in `args`, if any.
fn one_line_usage_error(rendered: &str, args: &[String]) -> String {
    let parts: Vec<&str> = rendered
        .lines()
        .map(str::trim)
        .filter(|l| {
            !l.is_empty() && !l.starts_with("Usage:") && !l.starts_with("For more information")
        })
        .collect();
    let mut line = parts.join(" ");
    let subcommands: Vec<String> = <Cli as clap::CommandFactory>::command()
        .get_subcommands()
        .map(|c| c.get_name().to_string())
        .collect();
    let command = match args.iter().skip(1).find(|a| subcommands.contains(a)) {
        Some(sub) => format!("eyereplay {sub}"),
        None => "eyereplay".to_string(),
    };
    line.push_str(&format!(" (see '{command} --help')"));
    line
}

fn format_chain(e: &anyhow::Error) -> String {
    let mut parts: Vec<String> = Vec::new();
    for cause in e.chain() {
        let s = cause.to_string();
        if !parts.iter().any(|p| p.contains(&s)) {
            parts.push(s);
        }
    }
    parts.join(": ")
}

fn init_tracing(verbose: u8) {
    let default = match verbose {
        0 => "warn",
        1 => "info",
        _ => "debug",
    };
    let filter = tracing_subscriber::EnvFilter::try_from_default_env()
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new(default));
    tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .with_target(false)
        .without_time()
        // Colour codes only where a terminal shows them, not in a log file.
        .with_ansi(std::io::IsTerminal::is_terminal(&std::io::stderr()))
        .init();
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Usage errors come out on one line naming what is wrong and the
    /// subcommand whose help to read.
    #[test]
    fn usage_errors_are_one_line() {
        for (args, says) in [
            (vec!["eyereplay", "train"], "--out <MODEL>"),
            (
                vec![
                    "eyereplay",
                    "extract",
                    "v.mp4",
                    "--out",
                    "x.csv",
                    "--blink-ratio",
                    "5",
                ],
                "--blink-ratio",
            ),
            (vec!["eyereplay", "trian"], "trian"),
        ] {
            let e = Cli::try_parse_from(&args).err().expect("a usage error");
            let args: Vec<String> = args.iter().map(|a| a.to_string()).collect();
            let line = one_line_usage_error(&e.to_string(), &args);
            assert!(!line.contains('\n'), "{line}");
            assert!(line.starts_with("error: ") && line.contains(says), "{line}");
            assert!(line.contains("--help"), "{line}");
        }
        let e = Cli::try_parse_from(["eyereplay", "train"]).err().unwrap();
        let args = ["eyereplay".to_string(), "train".to_string()];
        assert!(one_line_usage_error(&e.to_string(), &args).contains("'eyereplay train --help'"));
        // clap's "did you mean" is kept.
        let e = Cli::try_parse_from(["eyereplay", "trian"]).err().unwrap();
        assert!(one_line_usage_error(&e.to_string(), &[]).contains("'train'"));
    }
}
