use crate::position::PlanePos;
use crate::CoreError;
use serde::{Deserialize, Serialize};

/// One gaze sample.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Sample<P> {
    /// Presentation time in seconds from the start of the recording.
    pub t_s: f64,
    pub pos: P,
    /// False when the source had no usable gaze for this sample (tracking
    /// loss, no face). An invalid sample's position is not to be trusted.
    pub valid: bool,
    /// Lid gap divided by eye width, when the source measures it.
    pub aperture: Option<f64>,
    /// The source marked this sample as part of a blink.
    pub blink: bool,
}

impl<P: PlanePos> Sample<P> {
    /// A valid, open-eye sample.
    pub fn new(t_s: f64, pos: P) -> Self {
        Sample {
            t_s,
            pos,
            valid: true,
            aperture: None,
            blink: false,
        }
    }

    /// Whether this sample shows gaze: valid, not in a blink, finite.
    pub fn is_gaze(&self) -> bool {
        let [x, y] = self.pos.xy();
        self.valid && !self.blink && x.is_finite() && y.is_finite()
    }
}

/// A time series of gaze samples with strictly increasing timestamps.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Trajectory<P> {
    samples: Vec<Sample<P>>,
}

impl<P: PlanePos> Trajectory<P> {
    /// Builds a trajectory, checking that timestamps are finite and strictly
    /// increasing (resampling on real timestamps depends on it).
    pub fn new(samples: Vec<Sample<P>>) -> Result<Self, CoreError> {
        for (i, w) in samples.windows(2).enumerate() {
            // Written so that NaN fails too.
            if w[1].t_s.partial_cmp(&w[0].t_s) != Some(std::cmp::Ordering::Greater) {
                return Err(CoreError::Trajectory(format!(
                    "timestamps must increase strictly: sample {} at {} s follows {} s",
                    i + 1,
                    w[1].t_s,
                    w[0].t_s
                )));
            }
        }
        if let Some(s) = samples.iter().find(|s| !s.t_s.is_finite()) {
            return Err(CoreError::Trajectory(format!(
                "timestamp is not finite: {}",
                s.t_s
            )));
        }
        Ok(Trajectory { samples })
    }

    /// Builds a trajectory of valid samples at a constant rate starting at 0 s.
    pub fn from_positions(positions: impl IntoIterator<Item = P>, rate_hz: f64) -> Self {
        let samples = positions
            .into_iter()
            .enumerate()
            .map(|(i, p)| Sample::new(i as f64 / rate_hz, p))
            .collect();
        Trajectory { samples }
    }

    pub fn samples(&self) -> &[Sample<P>] {
        &self.samples
    }

    pub fn into_samples(self) -> Vec<Sample<P>> {
        self.samples
    }

    pub fn len(&self) -> usize {
        self.samples.len()
    }

    pub fn is_empty(&self) -> bool {
        self.samples.is_empty()
    }

    pub fn positions(&self) -> impl ExactSizeIterator<Item = P> + '_ {
        self.samples.iter().map(|s| s.pos)
    }

    pub fn duration_s(&self) -> f64 {
        match (self.samples.first(), self.samples.last()) {
            (Some(a), Some(b)) => b.t_s - a.t_s,
            _ => 0.0,
        }
    }

    /// Median sampling rate from the median inter-sample interval; robust to
    /// the dropped or duplicated frames of variable-rate video.
    pub fn median_rate_hz(&self) -> Option<f64> {
        if self.samples.len() < 2 {
            return None;
        }
        let mut dt: Vec<f64> = self
            .samples
            .windows(2)
            .map(|w| w[1].t_s - w[0].t_s)
            .collect();
        let mid = dt.len() / 2;
        let (_, m, _) = dt.select_nth_unstable_by(mid, |a, b| a.total_cmp(b));
        Some(1.0 / *m)
    }

    /// Count of samples that carry gaze (see [`Sample::is_gaze`]).
    pub fn gaze_count(&self) -> usize {
        self.samples.iter().filter(|s| s.is_gaze()).count()
    }

    /// Maps every position, keeping time and flags; the unit may change.
    pub fn map<Q: PlanePos>(&self, f: impl Fn(P) -> Q) -> Trajectory<Q> {
        Trajectory {
            samples: self
                .samples
                .iter()
                .map(|s| Sample {
                    t_s: s.t_s,
                    pos: f(s.pos),
                    valid: s.valid,
                    aperture: s.aperture,
                    blink: s.blink,
                })
                .collect(),
        }
    }

    /// Mean position over all samples.
    pub fn mean(&self) -> Option<P> {
        mean_of(self.positions())
    }

    /// Summed Euclidean step length (the paper's `L`).
    pub fn path_length(&self) -> f64 {
        path_length(self.positions())
    }
}

/// Mean of a set of positions; `None` when empty.
pub fn mean_of<P: PlanePos>(it: impl IntoIterator<Item = P>) -> Option<P> {
    let (mut sx, mut sy, mut n) = (0.0, 0.0, 0usize);
    for p in it {
        let [x, y] = p.xy();
        sx += x;
        sy += y;
        n += 1;
    }
    (n > 0).then(|| P::from_xy([sx / n as f64, sy / n as f64]))
}

/// `L = sum_i ||x_{i+1} - x_i||_2` (paper appendix, speed correction).
pub fn path_length<P: PlanePos>(it: impl IntoIterator<Item = P>) -> f64 {
    let mut it = it.into_iter();
    let Some(mut prev) = it.next() else {
        return 0.0;
    };
    let mut total = 0.0;
    for p in it {
        let ([x0, y0], [x1, y1]) = (prev.xy(), p.xy());
        total += (x1 - x0).hypot(y1 - y0);
        prev = p;
    }
    total
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::CanvasPos;

    #[test]
    fn path_length_of_3_4_5_triangle_legs() {
        let pts = [
            CanvasPos {
                x_px: 0.0,
                y_px: 0.0,
            },
            CanvasPos {
                x_px: 3.0,
                y_px: 4.0,
            },
            CanvasPos {
                x_px: 3.0,
                y_px: 10.0,
            },
        ];
        assert_eq!(path_length(pts), 11.0);
    }

    #[test]
    fn rejects_non_increasing_time() {
        let s = |t| Sample::new(t, CanvasPos::default());
        let err = Trajectory::new(vec![s(0.0), s(0.04), s(0.04)]).unwrap_err();
        assert!(err.to_string().contains("increase strictly"), "{err}");
    }

    #[test]
    fn median_rate_ignores_one_dropped_frame() {
        let mut t: Vec<f64> = (0..10).map(|i| i as f64 / 25.0).collect();
        t.remove(5);
        let tr = Trajectory::new(
            t.into_iter()
                .map(|t| Sample::new(t, CanvasPos::default()))
                .collect(),
        )
        .unwrap();
        assert!((tr.median_rate_hz().unwrap() - 25.0).abs() < 1e-9);
    }
}
