//! `eyereplay`: real human eye movements in, labeled synthetic eye-movement
//! video out. Each subcommand lives in its own module under `cmd/` and is a
//! thin layer over a pipeline crate.

use clap::{Parser, Subcommand};

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
eyereplay prepare --config dataset.toml --out data/    # stages 2-5: trajectories\n  \
eyereplay prepare --config dataset.toml --out data/ --dry-run\n\n\
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
/// ignores SIGPIPE, so `println!` panics with a backtrace there. Not by
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
        if message.starts_with("failed printing to stdout") && message.contains("Broken pipe") {
            // 128 + SIGPIPE: what a shell reports for a tool ended by it.
            std::process::exit(141);
        }
        default_hook(info);
    }));
}

fn main() -> std::process::ExitCode {
    quiet_when_stdout_is_gone();
    let cli = Cli::parse();
    init_tracing(cli.verbose);
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
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            // One line: the chain of causes joined, so scripts can grep it.
            eprintln!("error: {}", format_chain(&e));
            std::process::ExitCode::FAILURE
        }
    }
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
        .init();
}
