//! Signal processing on gaze time series.
//!
//! Everything here works on plain `[f64; 2]` points with explicit timestamps
//! in seconds; the unit-carrying types live in `eyereplay-core` and are
//! converted at the stage boundary.

mod edge_gauss;
mod resample;
pub mod stats;

pub use edge_gauss::{edge_gauss, EdgeGaussParams, EdgeGaussReport};
pub use resample::{
    antialias_sigma_for_gain_s, antialias_sigma_s, gaussian_resample, linear_resample,
    resample_times, ANTIALIAS_STOP_GAIN,
};
pub use stats::{median, pearson, quantile, quartiles};

/// A 2-D point; x and y are in whatever unit the caller's stage uses.
pub type Point = [f64; 2];

#[inline]
pub(crate) fn dist(a: Point, b: Point) -> f64 {
    (b[0] - a[0]).hypot(b[1] - a[1])
}
