//! `eyereplay extract`'s choice of networks: MediaPipe's attention face mesh
//! unless the cascade is asked for, by name or by one of its own options.

mod common;
use common::*;

/// `eyereplay extract` on the first two seconds of `franck.mp4`, the CSV
/// to `out`, with `flags`.
fn extract_run(out: &std::path::Path, flags: &[&str]) -> std::process::Output {
    let video = root().join(".cache/data/franck.mp4");
    let mut args = vec![
        "extract",
        s(&video),
        "--out",
        s(out),
        "--max-seconds",
        "2",
        "--quiet",
    ];
    args.extend_from_slice(flags);
    eyereplay(&args)
}

/// The CSV's bytes of [`extract_run`] into `dir/name`.
fn extract(dir: &std::path::Path, name: &str, flags: &[&str]) -> Vec<u8> {
    let out = dir.join(name);
    ok(&extract_run(&out, flags));
    std::fs::read(&out).unwrap()
}

#[test]
#[cfg_attr(
    not(all(has_sample_data, has_models)),
    ignore = "needs .cache/data and the models: run scripts/setup.sh"
)]
fn extract_reads_with_the_attention_mesh_unless_the_cascade_is_asked_for() {
    let dir = tempfile::tempdir().unwrap();
    let default = extract(dir.path(), "default.csv", &[]);
    let attention = extract(dir.path(), "attention.csv", &["--landmarks", "attention"]);
    let cascade = extract(dir.path(), "cascade.csv", &["--landmarks", "cascade"]);
    assert_eq!(default, attention);
    assert_ne!(default, cascade, "two networks, two readings");
    // The cascade's own options select it.
    let every = extract(dir.path(), "every.csv", &["--mesh-every", "2"]);
    assert_eq!(every, cascade);
    let views = extract(dir.path(), "views.csv", &["--iris-views", "3"]);
    let cascade_views = extract(
        dir.path(),
        "cascade_views.csv",
        &["--landmarks", "cascade", "--iris-views", "3"],
    );
    assert_eq!(views, cascade_views);
    assert_ne!(views, cascade);
}

#[test]
#[cfg_attr(
    not(all(has_sample_data, has_models)),
    ignore = "needs .cache/data and the models: run scripts/setup.sh"
)]
fn a_cascade_option_asked_of_the_attention_mesh_is_one_line_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.csv");
    let e = one_line_error(&extract_run(
        &out,
        &["--landmarks", "attention", "--iris-views", "5"],
    ));
    assert!(
        e.contains("--iris-views applies to the cascade landmarks only")
            && e.contains("use --landmarks cascade"),
        "{e}"
    );
    assert!(!out.exists());
}
