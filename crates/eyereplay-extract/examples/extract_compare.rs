//! Extracts one video and compares it with a MediaPipe reference CSV, the
//! library-level twin of `eyereplay extract --compare`, for experiments:
//! `cargo run --release --example extract_compare -- VIDEO REF.csv [OUT.csv]`
//! Environment: THREADS (workers), MESH_EVERY, MAX_S (seconds to process).
use eyereplay_extract::*;
use std::path::PathBuf;

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().collect();
    let video = PathBuf::from(&args[1]);
    let opts = ExtractOptions {
        threads: std::env::var("THREADS")
            .ok()
            .and_then(|s| s.parse().ok())
            .unwrap_or(0),
        mesh_every: std::env::var("MESH_EVERY")
            .ok()
            .and_then(|s| s.parse().ok())
            .unwrap_or(1),
        max_duration_s: std::env::var("MAX_S").ok().and_then(|s| s.parse().ok()),
        ..Default::default()
    };
    let ex = extract_many(std::slice::from_ref(&video), &opts, &NoProgress)
        .pop()
        .expect("one result")?;
    println!(
        "{} frames in {:.2} s = {:.1} fps; faces {} detector runs {} segments {} blinks {}",
        ex.rows.len(),
        ex.elapsed_s,
        ex.rows.len() as f64 / ex.elapsed_s,
        ex.face_frames,
        ex.detector_runs,
        ex.segments,
        ex.blinks
    );
    println!("{:?} (on CUDA: {})", ex.stage_times, ex.on_cuda);
    if let Some(out) = args.get(3) {
        save_csv(std::path::Path::new(out), &ex.rows)?;
    }
    let reference = Series::read_reference(std::path::Path::new(&args[2]))?;
    println!(
        "{}",
        compare(
            &Series::from_rows(&ex.rows),
            &reference,
            DEFAULT_BLINK_RATIO
        )
    );
    Ok(())
}
