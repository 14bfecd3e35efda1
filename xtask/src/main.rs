//! `cargo xtask`: the developer tasks of the eyereplay checkout, in one
//! place and out of the library and the `eyereplay` command line: model
//! conversion, the MediaPipe benchmark, the face table over seeds, the
//! module-cycle check, and every developer script under `scripts/`.
//! The README's two commands, `scripts/run.sh` and `scripts/test.sh`
//! (with `scripts/setup.sh`), stay as they are.

use anyhow::{bail, Result};
use clap::{
    Arg, ArgAction, ArgMatches, Command, CommandFactory, FromArgMatches, Parser, Subcommand,
};
use std::ffi::OsString;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

mod bench;
mod cycles;
mod face_table;
mod scripts;

#[derive(Parser)]
#[command(
    name = "cargo xtask",
    bin_name = "cargo xtask",
    about = "Developer tasks of the eyereplay checkout",
    long_about = "Developer tasks of the eyereplay checkout: model conversion, benchmarks, \
tables, the module-cycle check and the developer scripts under scripts/, behind one entry \
point (`cargo xtask`, an alias in .cargo/config.toml). Script tasks run the script from this \
checkout and pass their arguments on unchanged; `cargo xtask <task> --help` shows the \
script's own header. The README's commands stay scripts: scripts/setup.sh (install), \
scripts/run.sh (the main job), scripts/test.sh (every test).",
    after_help = "Examples:\n  \
cargo xtask                                   # this list\n  \
cargo xtask models                            # fetch and convert the face/iris models\n  \
cargo xtask bench-mediapipe .cache/data/franck.mp4 --rounds 5\n  \
cargo xtask face-table out/default --evaluate --vertical\n  \
cargo xtask cycles                            # module import cycles, per crate\n  \
cargo xtask fetch-data                        # a script task: scripts/fetch-data.sh",
    arg_required_else_help = true
)]
struct Cli {
    #[command(subcommand)]
    task: Task,
}

#[derive(Subcommand)]
enum Task {
    /// Fetch and convert the face/iris models (scripts/models.sh)
    #[command(
        long_about = "Fetches the models `eyereplay extract` uses and converts them: runs \
scripts/models.sh from this checkout, which downloads the mediapipe==0.10.21 and \
onnxruntime==1.22.1 wheels with pip (pinned by version and sha256), extracts the four \
.tflite models and libonnxruntime.so, and converts the models to ONNX \
(scripts/tflite_to_onnx.py, in a pinned venv). Idempotent: every step checks what is in \
place and skips it. scripts/setup.sh runs the same script.",
        after_help = "Examples:\n  \
cargo xtask models                              # into $EYEREPLAY_MODELS or .cache/models\n  \
cargo xtask models --dir /opt/eyereplay-models\n  \
cargo xtask models --check                      # then `eyereplay models check`"
    )]
    Models {
        /// Models folder [default: $EYEREPLAY_MODELS or .cache/models].
        #[arg(long, value_name = "DIR")]
        dir: Option<PathBuf>,
        /// Then run `eyereplay models check` (one inference per model;
        /// builds the command line in the dev profile if needed).
        #[arg(long)]
        check: bool,
    },
    /// CPU per frame of `eyereplay extract` against MediaPipe Python
    #[command(
        long_about = "Benchmarks `eyereplay extract` against MediaPipe Python's face mesh \
(scripts/dev/mediapipe_ref.py, refine_landmarks=True, in the venv of \
scripts/dev/mediapipe-venv.sh, made on first use): whole processes (start-up, imports and \
model loading included) on the same video, alternating MediaPipe (A) and this checkout's \
release build of `eyereplay extract` (B) --rounds times, so that a change in the machine's \
load hits both. Prints each round's CPU seconds (user + system of the whole process) per \
frame on both sides and eyereplay's frames per CPU-second over MediaPipe's, then the \
medians over the rounds; warns about rounds with many major page faults."
    )]
    BenchMediapipe(bench::Args),
    /// Read-back fidelity per session, from report/metrics.json
    #[command(
        long_about = "The visual fidelity of every rendered session of one or more datasets, \
one row each, as `eyereplay evaluate --read-back-all` measured it and wrote it to \
report/metrics.json (visual.sessions): the share of compared frames in which the extractor \
found the iris, frames compared, r, amplitude ratio (std ratio) and gain (slope) per axis, \
the drawn head's yaw range (from _head.csv) and the head yaw's read-back r, then a summary \
per class. With several datasets (the same config at several seeds, say; \
scripts/dev/face-seeds.sh makes them), each gets its table, then a pooled summary per class \
adds the means of r and of |gain - 1| and the count of amplitude ratios outside the \
report's target: one run moves single sessions by about 0.01, so comparisons of renderer \
versions rest on those. Exit status 0: it reports, it does not judge."
    )]
    FaceTable(face_table::Args),
    /// Module import cycles per workspace crate; exit 1 if any
    #[command(
        long_about = "Checks that no top-level module of a workspace crate (crates/*, xtask) \
imports, directly or through others, a module that imports it back. A text scan of src/: \
module `a` imports `b` when `a`'s files (src/a.rs, src/a/**) name a `crate::b` path or list \
`b` in a `use crate::{..}` group, outside comments, strings and #[cfg(test)] items. Prints \
each cycle (a strongly connected component of more than one module) with one place of each \
import in it, and exits 1 when there is one.",
        after_help = "Examples:\n  \
cargo xtask cycles\n  \
git worktree add /tmp/old HEAD~10 && cargo xtask cycles --root /tmp/old   # an older commit"
    )]
    Cycles {
        /// The checkout to scan [default: this one].
        #[arg(long, value_name = "DIR")]
        root: Option<PathBuf>,
    },
}

/// The checkout this xtask was built from.
pub fn checkout_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("xtask/ sits in the checkout")
        .to_path_buf()
}

/// The whole command line: the Rust tasks, then one subcommand per script.
fn command(root: &Path) -> Command {
    let mut cmd = Cli::command();
    for s in scripts::SCRIPTS {
        let header = scripts::header(root, s);
        cmd = cmd.subcommand(
            Command::new(s.name)
                .about(s.about)
                .long_about(format!(
                    "Runs {} from this checkout; the arguments after `{}` go to it \
                     unchanged. Its header:\n\n{header}",
                    s.path, s.name
                ))
                .arg(
                    Arg::new("args")
                        .action(ArgAction::Append)
                        .num_args(0..)
                        .trailing_var_arg(true)
                        .allow_hyphen_values(true)
                        .value_parser(clap::value_parser!(OsString))
                        .help("Arguments for the script"),
                ),
        );
    }
    cmd
}

fn run_task(root: &Path, matches: &ArgMatches) -> Result<bool> {
    if let Some((name, sub)) = matches.subcommand() {
        if let Some(s) = scripts::find(name) {
            let args: Vec<OsString> = sub
                .get_many::<OsString>("args")
                .map(|v| v.cloned().collect())
                .unwrap_or_default();
            scripts::run(root, s.path, &args)?;
            return Ok(true);
        }
    }
    let cli = match Cli::from_arg_matches(matches) {
        Ok(cli) => cli,
        Err(e) => e.exit(),
    };
    match cli.task {
        Task::Models { dir, check } => {
            let mut args: Vec<OsString> = vec![];
            if let Some(d) = &dir {
                args.push(d.clone().into());
            }
            scripts::run(root, "scripts/models.sh", &args)?;
            if check {
                let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
                let mut cmd = std::process::Command::new(cargo);
                cmd.args([
                    "run",
                    "--quiet",
                    "-p",
                    "eyereplay-cli",
                    "--",
                    "models",
                    "check",
                ])
                .current_dir(root);
                if let Some(d) = &dir {
                    cmd.arg("--dir").arg(d);
                }
                if !cmd.status()?.success() {
                    bail!("eyereplay models check failed");
                }
            }
            Ok(true)
        }
        Task::BenchMediapipe(a) => bench::run(root, &a).map(|()| true),
        Task::FaceTable(a) => face_table::run(root, &a).map(|()| true),
        Task::Cycles { root: other } => cycles::run(other.as_deref().unwrap_or(root)),
    }
}

fn main() -> ExitCode {
    let root = checkout_root();
    if std::env::args_os().len() < 2 {
        // The list, as a successful answer rather than a usage error.
        let _ = command(&root).print_help();
        return ExitCode::SUCCESS;
    }
    let matches = command(&root).get_matches();
    match run_task(&root, &matches) {
        Ok(true) => ExitCode::SUCCESS,
        Ok(false) => ExitCode::FAILURE,
        Err(e) => {
            eprintln!("xtask: {e:#}");
            ExitCode::FAILURE
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn command_line_is_consistent() {
        command(&checkout_root()).debug_assert();
    }

    #[test]
    fn script_arguments_pass_through() {
        let m = command(&checkout_root())
            .try_get_matches_from(["cargo xtask", "rows-diff", "a.csv", "--flag", "b"])
            .unwrap();
        let (name, sub) = m.subcommand().unwrap();
        assert_eq!(name, "rows-diff");
        let args: Vec<&OsString> = sub.get_many::<OsString>("args").unwrap().collect();
        assert_eq!(args, ["a.csv", "--flag", "b"]);
    }
}
