//! The pipeline's [`eyereplay_core::Progress`] seen as the extractor's
//! per-video progress, so an extraction inside a longer job moves the
//! job's bar.

/// Adapts a job's [`eyereplay_core::Progress`] to [`crate::Progress`]:
/// each video's frame count is added to the running stage's total.
pub struct StageFrames<'a>(pub &'a dyn eyereplay_core::Progress);

impl crate::Progress for StageFrames<'_> {
    fn start(&self, _video: usize, frames: Option<u64>) {
        if let Some(n) = frames {
            self.0.add_total(n);
        }
    }
    fn advance(&self, _video: usize, n: u64) {
        self.0.advance(n);
    }
}
