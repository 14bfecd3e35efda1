//! Where the CPU time of an extraction goes, stage by stage
//! (`eyereplay extract --profile`).
//!
//! Every worker thread owns a [`StageClock`]: at each stage boundary it reads
//! the thread's own CPU clock (`CLOCK_THREAD_CPUTIME_ID`) and charges the
//! time since the previous boundary to the stage that just ended. The
//! stages therefore partition the worker's CPU time with no gap and no
//! overlap, so they sum to the total exactly, and other processes on the
//! machine do not inflate them the way wall time would be inflated. With
//! profiling off the clock is never read.

/// A stage of the per-frame pipeline.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stage {
    /// Demuxing and decoding the next frame (libavcodec), and the RGB
    /// conversion of pixel formats other than 8-bit 4:2:0.
    Decode,
    /// Colour conversion and resampling of the detector, mesh and eye crops
    /// straight from the decoded planes.
    Crop,
    /// The face detector network.
    Detector,
    /// The face mesh network; with the attention mesh, its face and eye
    /// models.
    Mesh,
    /// The iris network (both eyes in one batch).
    Iris,
    /// Everything else per frame: decoding detections, mapping landmarks
    /// back to the image, tracking, per-frame rows, blink flagging.
    Post,
}

impl Stage {
    pub const ALL: [Stage; 6] = [
        Stage::Decode,
        Stage::Crop,
        Stage::Detector,
        Stage::Mesh,
        Stage::Iris,
        Stage::Post,
    ];

    /// The stage's name when `landmarks` read the face and eyes; `None` for
    /// a stage those networks never run (the iris network of the attention
    /// mesh, whose eye models run in [`Stage::Mesh`]).
    pub fn label_for(self, landmarks: crate::LandmarkModel) -> Option<&'static str> {
        use crate::LandmarkModel::{Attention, Cascade};
        Some(match (self, landmarks) {
            (Stage::Decode, _) => "decode (demux + video decoder)",
            (Stage::Crop, _) => "colour conversion + crops",
            (Stage::Detector, _) => "face detector network",
            (Stage::Mesh, Cascade) => "face mesh network",
            (Stage::Mesh, Attention) => "attention mesh networks (face + eyes)",
            (Stage::Iris, Cascade) => "iris network (all eye crops, 2 a run)",
            (Stage::Iris, Attention) => return None,
            (Stage::Post, _) => "post-processing + tracking",
        })
    }
}

/// CPU seconds per [`Stage`], summed over the threads that ran them.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StageTimes {
    cpu_s: [f64; 6],
}

impl StageTimes {
    pub fn get(&self, stage: Stage) -> f64 {
        self.cpu_s[stage as usize]
    }
    pub fn charge(&mut self, stage: Stage, cpu_s: f64) {
        self.cpu_s[stage as usize] += cpu_s;
    }
    pub fn add(&mut self, other: &StageTimes) {
        for (a, b) in self.cpu_s.iter_mut().zip(other.cpu_s) {
            *a += b;
        }
    }
    /// The sum over all stages.
    pub fn total_s(&self) -> f64 {
        self.cpu_s.iter().sum()
    }
}

/// A per-thread lap clock over [`Stage`]s (see the module docs).
#[derive(Clone, Debug)]
pub struct StageClock {
    enabled: bool,
    last_s: f64,
    pub times: StageTimes,
}

impl StageClock {
    /// A clock that measures when `enabled`, and otherwise costs nothing.
    pub fn new(enabled: bool) -> StageClock {
        StageClock {
            enabled,
            last_s: 0.0,
            times: StageTimes::default(),
        }
    }

    pub fn enabled(&self) -> bool {
        self.enabled
    }

    /// Starts timing on the calling thread (the time before is charged to
    /// nothing).
    pub fn start(&mut self) {
        if self.enabled {
            self.last_s = thread_cpu_s();
        }
    }

    /// Charges the calling thread's CPU time since the last lap (or
    /// [`StageClock::start`]) to `stage`.
    #[inline]
    pub fn lap(&mut self, stage: Stage) {
        if self.enabled {
            let now = thread_cpu_s();
            self.times.charge(stage, now - self.last_s);
            self.last_s = now;
        }
    }
}

pub use eyereplay_core::profile::{process_cpu_s, thread_cpu_s};

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_landmark_model_names_the_stages_it_runs() {
        use crate::LandmarkModel::{Attention, Cascade};
        let names = |m| Stage::ALL.iter().filter_map(|s| s.label_for(m)).count();
        assert_eq!(names(Cascade), 6);
        assert_eq!(names(Attention), 5);
        assert_eq!(Stage::Iris.label_for(Attention), None);
        assert_eq!(Stage::Mesh.label_for(Cascade), Some("face mesh network"));
        assert!(Stage::Mesh
            .label_for(Attention)
            .unwrap()
            .contains("attention"));
    }

    /// Burns CPU on this thread until its CPU clock has advanced `s`.
    fn spin(s: f64) -> u64 {
        let t0 = thread_cpu_s();
        let mut x = 0u64;
        while thread_cpu_s() - t0 < s {
            for i in 0..1000u64 {
                x = x.wrapping_mul(6364136223846793005).wrapping_add(i);
            }
        }
        x
    }

    #[test]
    fn laps_partition_the_thread_time_so_stages_sum_to_the_total() {
        let mut clock = StageClock::new(true);
        clock.start();
        let started_s = clock.last_s;
        let mut sink = 0;
        for (k, stage) in Stage::ALL.iter().enumerate() {
            sink ^= spin(0.002 * (k + 1) as f64);
            clock.lap(*stage);
        }
        std::hint::black_box(sink);
        // Each stage got at least the CPU time it spun for.
        for (k, stage) in Stage::ALL.iter().enumerate() {
            assert!(clock.times.get(*stage) >= 0.002 * (k + 1) as f64);
        }
        // The laps telescope: the stages sum to the thread's CPU time from
        // start to the last lap, nothing lost or counted twice.
        let total = clock.times.total_s();
        assert!((total - (clock.last_s - started_s)).abs() < 1e-9, "{total}");
        assert!(total >= 0.002 * 21.0);
    }

    #[test]
    fn a_disabled_clock_charges_nothing() {
        let mut clock = StageClock::new(false);
        clock.start();
        std::hint::black_box(spin(0.002));
        clock.lap(Stage::Iris);
        assert_eq!(clock.times, StageTimes::default());
    }

    #[test]
    fn times_add_stage_by_stage() {
        let mut a = StageTimes::default();
        a.charge(Stage::Mesh, 1.5);
        a.charge(Stage::Decode, 0.25);
        let mut b = StageTimes::default();
        b.charge(Stage::Mesh, 0.5);
        b.charge(Stage::Post, 2.0);
        a.add(&b);
        assert_eq!(a.get(Stage::Mesh), 2.0);
        assert_eq!(a.get(Stage::Decode), 0.25);
        assert_eq!(a.get(Stage::Post), 2.0);
        assert_eq!(a.total_s(), 4.25);
    }
}
