//! Writes a small synthetic dataset folder (the layout `eyereplay prepare`
//! writes) for trying `eyereplay evaluate` before real data exists:
//!   cargo run -p eyereplay-eval --example synth_dataset -- OUT_DIR [SESSION_FRAMES [SESSIONS_PER_CLASS [SOURCE_FRAMES]]]

#[path = "../tests/common/mod.rs"]
mod common;

fn main() {
    let mut args = std::env::args().skip(1);
    let out = args
        .next()
        .expect("usage: synth_dataset OUT_DIR [SESSION_FRAMES]");
    let mut spec = common::Spec::default();
    if let Some(f) = args.next() {
        spec.session_frames = f.parse().expect("SESSION_FRAMES must be a number");
        spec.source_frames = spec.session_frames * 3 / 2;
    }
    if let Some(n) = args.next() {
        spec.sessions_per_class = n.parse().expect("SESSIONS_PER_CLASS must be a number");
    }
    if let Some(n) = args.next() {
        spec.source_frames = n.parse().expect("SOURCE_FRAMES must be a number");
    }
    common::write_dataset(std::path::Path::new(&out), &spec);
    println!("wrote {out}");
}
