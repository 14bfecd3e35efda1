//! How long work reports progress. The library never prints; the binary
//! shows these events as progress bars and lines, a notebook could show
//! them as widgets.

/// The stages that report progress in units of work.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stage {
    /// Stage 1 on the video sources; units are video frames.
    Extract,
    /// Stage 6 on the dataset's sessions; units are rendered frames.
    Render,
}

/// Receives progress events. Every method has a do-nothing default, so an
/// implementation picks what it shows. Called from worker threads.
pub trait Progress: Sync {
    /// `stage` starts with `total` units (more may be added with
    /// [`add_total`](Progress::add_total) as videos are opened).
    fn begin(&self, _stage: Stage, _total: u64) {}
    fn add_total(&self, _units: u64) {}
    fn advance(&self, _units: u64) {}
    /// Short status text for the running stage (e.g. "3/12 sessions").
    fn status(&self, _text: &str) {}
    fn end(&self, _stage: Stage) {}
    /// A result line worth showing (e.g. "extracted x.mp4: 4,800 frames").
    fn info(&self, _line: &str) {}
    /// Something the user should know that does not stop the job.
    fn warn(&self, _line: &str) {}
}

/// Shows nothing.
pub struct NoProgress;

impl Progress for NoProgress {}
