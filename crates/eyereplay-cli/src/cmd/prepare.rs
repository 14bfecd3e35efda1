//! `eyereplay prepare`: paper stages 2-5, config in, trajectory dataset out.

use anyhow::Result;
use eyereplay::{DatasetConfig, Prepared};
use std::path::PathBuf;
use std::time::Instant;

/// Stages 2-5: calibrate, filter blinks, resample, normalize, slice into sessions.
///
/// Reads every source named in the config, then writes OUT/<class>/<class>_NNNN.csv
/// (frame,x,y in canvas px), OUT/pool/<class>.csv, OUT/labels.csv and
/// OUT/metadata.json. All inputs are read and checked before anything is written.
#[derive(clap::Args)]
#[command(after_help = "Examples:\n  \
eyereplay prepare --config examples/dataset.toml --out out/dataset\n  \
eyereplay prepare --config examples/dataset.toml --out out/dataset --dry-run\n\n\
A minimal config (paper defaults: 72 sessions x 7500 frames per class, 25 fps,\n\
1280x720):\n\n  \
[classes.reading]\n  \
sources = [{ format = \"eyelink\", path = \"reader1.asc\" }]\n  \
[classes.conversation]\n  \
sources = [{ format = \"extract\", path = \"interview_iris.csv\" }]\n\n\
Source formats (docs/CONFIG.md): extract (eyereplay extract CSV), video,\n\
csv (samples table), eyelink (.asc), bids (*_physio.tsv.gz + .json),\n\
fixations (one row per fixation).")]
pub struct Args {
    /// Dataset config (TOML).
    #[arg(long, value_name = "TOML")]
    pub config: PathBuf,
    /// Output dataset folder (created if missing).
    #[arg(short, long, value_name = "DIR", required_unless_present = "dry_run")]
    pub out: Option<PathBuf>,
    /// Read the sources and print what would be made, without writing anything.
    #[arg(long)]
    pub dry_run: bool,
    /// Folder for cached video extractions (default: $EYEREPLAY_CACHE, else $XDG_CACHE_HOME/eyereplay, else ~/.cache/eyereplay).
    #[arg(long, value_name = "DIR")]
    pub cache: Option<PathBuf>,
}

pub fn run(args: Args) -> Result<()> {
    let started = Instant::now();
    let cfg = DatasetConfig::load(&args.config)?;
    // The `[render]` table is rendered later, from metadata.json: checked
    // now, so that a typo in it does not wait for the render.
    eyereplay::render_table(&cfg, &args.config)?;
    let cache = super::cache_dir(args.cache.as_deref())?;
    let bars = super::Bars::default();
    let Some(out) = args.out.filter(|_| !args.dry_run) else {
        let prepared = eyereplay::prepare_only(&cfg, &cache, &bars)?;
        print_summary(&cfg, &prepared);
        let plan = prepared.plan(&cfg);
        println!(
            "dry run: would write {} sessions of {} frames ({:.2} h of video at {} fps); nothing written",
            plan.classes.values().map(|c| c.sessions).sum::<usize>(),
            cfg.session_frames,
            plan.video_hours,
            cfg.fps
        );
        return Ok(());
    };
    let ds = eyereplay::prepare_dataset(&cfg, &out, &cache, &bars)?;
    print_summary(&cfg, &ds.prepared);
    println!(
        "wrote {} files ({:.1} MB, {:.2} h of sessions) to {} in {:.2} s",
        ds.files,
        ds.bytes as f64 / 1e6,
        ds.prepared.plan(&cfg).video_hours,
        out.display(),
        started.elapsed().as_secs_f64()
    );
    Ok(())
}

fn print_summary(cfg: &DatasetConfig, p: &Prepared) {
    if let Some(c) = &p.calibration {
        println!(
            "calibration: s = ({:.1}, {:.1}) px per unit n, mu = ({:.1}, {:.1}) px{}",
            c.s_x,
            c.s_y,
            c.mu_x,
            c.mu_y,
            match p.calibration_ranges {
                Some(r) => format!(
                    " (n_x {:.4}..{:.4}, n_y {:.4}..{:.4} -> {} % of {}x{})",
                    r[0][0],
                    r[0][1],
                    r[1][0],
                    r[1][1],
                    eyereplay_core::show_number(100.0 * cfg.calibration.fill_fraction),
                    cfg.canvas.width_px,
                    cfg.canvas.height_px
                ),
                None => " (manual)".into(),
            }
        );
    }
    println!(
        "{:<44} {:>12} {:>8} {:>9} {:>8} {:>10} {:>8}",
        "source", "class", "rate_hz", "samples", "filled", "alpha", "frames"
    );
    for s in &p.sources {
        let alpha = if s.speed_correction.applied {
            format!("{:.3}", s.speed_correction.alpha)
        } else {
            "n/a".to_string()
        };
        println!(
            "{:<44} {:>12} {:>8.2} {:>9} {:>8} {:>10} {:>8}",
            truncate(&s.id, 44),
            s.class.name(),
            s.rate_hz,
            s.samples,
            s.filled.total,
            alpha,
            s.frames
        );
    }
    for c in &p.classes {
        println!(
            "class {:<12} {:>4} sessions x {} frames from a pool of {} frames (stride {}, reuse ratio {:.2}, speed scale {})",
            c.class.name(),
            c.sessions.len(),
            cfg.session_frames,
            c.pool.len(),
            c.stride,
            c.reuse_ratio,
            c.speed_scale
        );
    }
}

fn truncate(s: &str, n: usize) -> String {
    if s.chars().count() <= n {
        s.to_string()
    } else {
        let tail: String = s
            .chars()
            .rev()
            .take(n - 1)
            .collect::<Vec<_>>()
            .into_iter()
            .rev()
            .collect();
        format!("…{tail}")
    }
}
