//! Statistics for evaluation: the workspace's one statistics module
//! ([`eyereplay_signal::stats`], numpy's conventions), re-exported so
//! evaluation code and its users have them at hand.

pub use eyereplay_signal::stats::{
    linear_fit, mean, median, pearson, quantile, quantile_sorted, sorted, std_pop,
};
