//! Eye-movement metrics of a trajectory at a constant frame rate, as the
//! paper defines them (section 5.1), plus extras.
//!
//! * **Speed**: `s_i = ||p_{i+1} - p_i||_2` in px/frame, one value per pair
//!   of consecutive frames (`n - 1` values for `n` frames).
//! * **Fixation** (I-VT): a maximal run of consecutive speeds strictly below
//!   `fixation_below_px_per_frame` (5). Duration = run length, in frames.
//! * **Saccade** (I-VT): a maximal run of consecutive speeds strictly above
//!   `saccade_above_px_per_frame` (15). Amplitude = sum of the run's speeds
//!   (total Euclidean displacement, px); peak speed = the run's largest speed.
//! * A run covering speeds `i..=j` spans frames `i..=j+1`: onset frame `i`,
//!   offset frame `j+1`, so `offset - onset` = duration in frames.
//! * Runs touching the start or end of a segment are kept (they are censored,
//!   not dropped), as a plain run-length detector does.
//! * **Dispersion** of a fixation: `(max x - min x) + (max y - min y)` over
//!   its frames (the I-DT measure).
//! * **Held-position runs** (blink proxy): stage 2 replaces blink samples by
//!   the last valid position, so a blink leaves a run of exactly zero speed.
//!   A maximal run of `>= hold_min_frames` zero speeds counts as one.
//!
//! Metrics are computed per *segment*: a segment is a stretch of frames that
//! is continuous in time (one session, or one source recording inside the
//! concatenated source pool). Speeds and runs never cross segment borders.

use serde::Serialize;

/// I-VT thresholds (paper: 5 and 15 px/frame) and the blink-proxy length.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct IvtThresholds {
    pub fixation_below_px_per_frame: f64,
    pub saccade_above_px_per_frame: f64,
    /// Minimum number of zero-speed steps for a held-position run.
    pub hold_min_frames: usize,
}

impl Default for IvtThresholds {
    fn default() -> Self {
        IvtThresholds {
            fixation_below_px_per_frame: 5.0,
            saccade_above_px_per_frame: 15.0,
            hold_min_frames: 3,
        }
    }
}

/// What kind of event a run is, with pymovements' event names.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum EventKind {
    Fixation,
    Saccade,
    /// A held-position run, the trace a forward-filled blink leaves.
    Blink,
}

impl EventKind {
    pub fn name(self) -> &'static str {
        match self {
            EventKind::Fixation => "fixation",
            EventKind::Saccade => "saccade",
            EventKind::Blink => "blink",
        }
    }
}

/// One detected event, frames relative to the segment start.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Event {
    pub kind: EventKind,
    pub onset_frame: usize,
    /// Last frame of the event (inclusive).
    pub offset_frame: usize,
    /// Sum of speeds over the run (px).
    pub amplitude_px: f64,
    pub peak_speed_px_per_frame: f64,
    /// `(max x - min x) + (max y - min y)` over the event's frames (px).
    pub dispersion_px: f64,
}

impl Event {
    pub fn duration_frames(&self) -> usize {
        self.offset_frame - self.onset_frame
    }
}

/// Frame-to-frame Euclidean displacement, px/frame.
pub fn speeds_px_per_frame(points: &[[f64; 2]]) -> Vec<f64> {
    points
        .windows(2)
        .map(|w| (w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1]))
        .collect()
}

/// Maximal runs of indices where `pred(speed)` holds: `(start, len)`.
pub fn runs(speeds: &[f64], pred: impl Fn(f64) -> bool) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut start: Option<usize> = None;
    for (i, &s) in speeds.iter().enumerate() {
        match (pred(s), start) {
            (true, None) => start = Some(i),
            (false, Some(st)) => {
                out.push((st, i - st));
                start = None;
            }
            _ => {}
        }
    }
    if let Some(st) = start {
        out.push((st, speeds.len() - st));
    }
    out
}

fn make_event(
    kind: EventKind,
    points: &[[f64; 2]],
    speeds: &[f64],
    start: usize,
    len: usize,
) -> Event {
    let run = &speeds[start..start + len];
    let frames = &points[start..=start + len];
    let (mut x0, mut x1, mut y0, mut y1) = (
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
    );
    for p in frames {
        x0 = x0.min(p[0]);
        x1 = x1.max(p[0]);
        y0 = y0.min(p[1]);
        y1 = y1.max(p[1]);
    }
    Event {
        kind,
        onset_frame: start,
        offset_frame: start + len,
        amplitude_px: run.iter().sum(),
        peak_speed_px_per_frame: run.iter().cloned().fold(0.0, f64::max),
        dispersion_px: (x1 - x0) + (y1 - y0),
    }
}

/// All events of one continuous segment, ordered by onset then kind.
pub fn detect_events(points: &[[f64; 2]], thr: &IvtThresholds) -> Vec<Event> {
    let speeds = speeds_px_per_frame(points);
    detect_events_with_speeds(points, &speeds, thr)
}

fn detect_events_with_speeds(
    points: &[[f64; 2]],
    speeds: &[f64],
    thr: &IvtThresholds,
) -> Vec<Event> {
    let mut ev = Vec::new();
    for (s, l) in runs(speeds, |v| v < thr.fixation_below_px_per_frame) {
        ev.push(make_event(EventKind::Fixation, points, speeds, s, l));
    }
    for (s, l) in runs(speeds, |v| v > thr.saccade_above_px_per_frame) {
        ev.push(make_event(EventKind::Saccade, points, speeds, s, l));
    }
    for (s, l) in runs(speeds, |v| v == 0.0) {
        if l >= thr.hold_min_frames.max(1) {
            ev.push(make_event(EventKind::Blink, points, speeds, s, l));
        }
    }
    ev.sort_by_key(|e| (e.onset_frame, e.kind));
    ev
}

/// Pooled metric samples over any number of segments.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MetricSamples {
    pub speed_px_per_frame: Vec<f64>,
    pub fixation_duration_frames: Vec<f64>,
    pub saccade_amplitude_px: Vec<f64>,
    pub saccade_peak_speed_px_per_frame: Vec<f64>,
    pub fixation_dispersion_px: Vec<f64>,
    pub n_frames: usize,
    pub n_segments: usize,
    pub n_blinks: usize,
}

impl MetricSamples {
    /// Adds one continuous segment; returns its events.
    pub fn add_segment(&mut self, points: &[[f64; 2]], thr: &IvtThresholds) -> Vec<Event> {
        let speeds = speeds_px_per_frame(points);
        let events = detect_events_with_speeds(points, &speeds, thr);
        self.speed_px_per_frame.extend_from_slice(&speeds);
        for e in &events {
            match e.kind {
                EventKind::Fixation => {
                    self.fixation_duration_frames
                        .push(e.duration_frames() as f64);
                    self.fixation_dispersion_px.push(e.dispersion_px);
                }
                EventKind::Saccade => {
                    self.saccade_amplitude_px.push(e.amplitude_px);
                    self.saccade_peak_speed_px_per_frame
                        .push(e.peak_speed_px_per_frame);
                }
                EventKind::Blink => self.n_blinks += 1,
            }
        }
        self.n_frames += points.len();
        self.n_segments += 1;
        events
    }

    /// Time covered, in seconds, at `fps`.
    pub fn duration_s(&self, fps: f64) -> f64 {
        self.n_frames as f64 / fps
    }
}

/// Writes events in pymovements' events layout: `name,onset,offset`, times
/// in milliseconds from the segment's first frame (`frame * 1000 / fps`).
pub fn events_csv(events: &[Event], fps: f64) -> String {
    let mut s = String::from("name,onset,offset\n");
    for e in events {
        let ms = |f: usize| f as f64 * 1000.0 / fps;
        s.push_str(&format!(
            "{},{:.3},{:.3}\n",
            e.kind.name(),
            ms(e.onset_frame),
            ms(e.offset_frame)
        ));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A hand-built walk along x with chosen steps.
    fn walk(steps: &[f64]) -> Vec<[f64; 2]> {
        let mut p = vec![[0.0, 0.0]];
        for s in steps {
            let last = *p.last().unwrap();
            p.push([last[0] + s, last[1]]);
        }
        p
    }

    #[test]
    fn speeds_are_euclidean_steps() {
        let s = speeds_px_per_frame(&[[0.0, 0.0], [3.0, 4.0], [3.0, 4.0], [0.0, 0.0]]);
        assert_eq!(s, vec![5.0, 0.0, 5.0]);
    }

    #[test]
    fn known_runs() {
        // steps: 1 1 1 | 20 30 | 1 1 | 10 | 16 | 2   (px/frame)
        // fixations (<5): [0,3) len 3, [5,7) len 2, [10,11) len 1
        // saccades (>15): [3,5) amp 50 peak 30, [8,9) amp 16 peak 16
        // 10 is neither; exactly 5 or 15 would be neither too.
        let pts = walk(&[1.0, 1.0, 1.0, 20.0, 30.0, 1.0, 1.0, 10.0, 16.0, 2.0]);
        let mut m = MetricSamples::default();
        let ev = m.add_segment(&pts, &IvtThresholds::default());
        assert_eq!(m.fixation_duration_frames, vec![3.0, 2.0, 1.0]);
        assert_eq!(m.saccade_amplitude_px, vec![50.0, 16.0]);
        assert_eq!(m.saccade_peak_speed_px_per_frame, vec![30.0, 16.0]);
        assert_eq!(m.speed_px_per_frame.len(), 10);
        assert_eq!(m.n_frames, 11);
        // First fixation spans frames 0..=3: x from 0 to 3.
        assert_eq!(ev[0].kind, EventKind::Fixation);
        assert_eq!((ev[0].onset_frame, ev[0].offset_frame), (0, 3));
        assert_eq!(ev[0].dispersion_px, 3.0);
        assert_eq!(ev[1].kind, EventKind::Saccade);
        assert_eq!((ev[1].onset_frame, ev[1].offset_frame), (3, 5));
    }

    #[test]
    fn thresholds_are_strict() {
        let pts = walk(&[5.0, 15.0, 4.999, 15.001]);
        let mut m = MetricSamples::default();
        m.add_segment(&pts, &IvtThresholds::default());
        assert_eq!(m.fixation_duration_frames, vec![1.0]);
        assert_eq!(m.saccade_amplitude_px.len(), 1);
        assert!((m.saccade_amplitude_px[0] - 15.001).abs() < 1e-9);
    }

    #[test]
    fn held_runs_count_as_blinks_and_events_export() {
        // 3 zero steps (a held position) inside a fixation.
        let pts = walk(&[1.0, 0.0, 0.0, 0.0, 1.0, 20.0]);
        let mut m = MetricSamples::default();
        let ev = m.add_segment(&pts, &IvtThresholds::default());
        assert_eq!(m.n_blinks, 1);
        let csv = events_csv(&ev, 25.0);
        assert_eq!(
            csv,
            "name,onset,offset\nfixation,0.000,200.000\nblink,40.000,160.000\nsaccade,200.000,240.000\n"
        );
    }

    #[test]
    fn segments_do_not_join() {
        let mut m = MetricSamples::default();
        let t = IvtThresholds::default();
        m.add_segment(&walk(&[1.0, 1.0]), &t);
        m.add_segment(&walk(&[1.0]), &t);
        // Two fixations (2 and 1 frames), not one of 3; no 0-to-0 jump speed.
        assert_eq!(m.fixation_duration_frames, vec![2.0, 1.0]);
        assert_eq!(m.speed_px_per_frame, vec![1.0, 1.0, 1.0]);
        assert_eq!(m.n_segments, 2);
    }
}
