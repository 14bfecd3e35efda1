//! The conversation model: a semi-Markov chain of looking at the partner's
//! face and looking away, in speaking and listening turns.
//!
//! | part | rule | source |
//! |---|---|---|
//! | turns | speaking and listening alternate; durations `Gamma(2, mean / 2)` around the person's means | ours |
//! | face / away | alternating dwells, `Gamma(2, mean / 2)`; the face dwell mean is drawn per role and the away mean follows from the person's face share: `away = face (1 - share) / share` | Argyle & Ingham 1972 (75 % listening, 41 % speaking; glances 2.95 s) |
//! | cognitive aversion | with `p_cog` (0.7) a speaking turn starts looking away, from 1.0 s before speech to 1.2 s after; 70 % up, 20 % down, 10 % sideways, head share 0.4 | Kendon 1967; Andrist, Mutlu & Gleicher 2013 |
//! | other aversions | 70 % sideways, 10 % up, 20 % down, head share 0.1 | Andrist et al. 2013 |
//! | look back | the last 2.3 s of a speaking turn are on the face | Andrist et al. 2013; Ho et al. 2015 |
//! | face scanning | saccades among the partner's eyes and mouth every `Gamma(4, scan / 4)` s, at least 0.2 s apart | Rogers et al. 2018 |
//! | nods | while listening, a Poisson process of nods of 1-3 cycles at 2.6-6.5 Hz; the eyes counter-rotate (VOR) | Hale et al. 2020 |
//! | head sway | the head moves continuously (three sinusoids an axis at 0.2-1.1 Hz); the eyes counter-rotate to hold their target, so the eye in the head sways against it | Hale et al. 2020 (coherent head motion at 0.2-1.1 Hz) |
//! | blinks | Poisson at the person's rate (Bentivoglio et al. 1997: 26 a minute in conversation, 10.5-32.5 over people) | |
//!
//! The partner is the face on the screen, below the camera (a face 10 cm
//! under a lens at 55 cm is 10.3 deg down).

use crate::geometry::Angles;
use crate::timeline::{Nod, Plan, Shift};
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Gamma, LogNormal};
use serde::{Deserialize, Serialize};

/// A talker's drawn parameters (recorded in the dataset's metadata).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TalkerParams {
    /// Direction of the partner's face from the head's straight ahead.
    pub partner: Angles,
    pub face_share_listening: f64,
    pub face_share_speaking: f64,
    pub face_dwell_listening_s: f64,
    pub face_dwell_speaking_s: f64,
    pub speaking_turn_s: f64,
    pub listening_turn_s: f64,
    /// Median aversion amplitude, deg.
    pub aversion_deg: f64,
    pub cognitive_aversion_prob: f64,
    /// Mean interval between saccades within the face, s.
    pub face_scan_s: f64,
    /// Nods a second while listening.
    pub nods_per_s: f64,
    pub nod_deg: f64,
    /// Share of looks at the face that go to the eyes rather than the
    /// mouth or nose (a stable personal trait: Rogers et al. 2018).
    pub eye_preference: f64,
    /// Amplitude of the head's continuous sway, deg (split over three
    /// sinusoids a axis at 0.2-1.1 Hz).
    pub head_sway_deg: f64,
}

impl TalkerParams {
    /// Mean away dwell for a role: what makes the face share come out.
    pub fn away_dwell_s(&self, speaking: bool) -> f64 {
        let (face, share) = if speaking {
            (self.face_dwell_speaking_s, self.face_share_speaking)
        } else {
            (self.face_dwell_listening_s, self.face_share_listening)
        };
        (face * (1.0 - share) / share.max(0.01)).clamp(0.3, 6.0)
    }
}

/// What a stretch of conversation did.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ConversationStats {
    pub speaking_s: f64,
    pub listening_s: f64,
    pub face_speaking_s: f64,
    pub face_listening_s: f64,
    pub aversions: usize,
    pub cognitive_aversions: usize,
    pub nods: usize,
}

impl ConversationStats {
    pub fn add(&mut self, o: &ConversationStats) {
        self.speaking_s += o.speaking_s;
        self.listening_s += o.listening_s;
        self.face_speaking_s += o.face_speaking_s;
        self.face_listening_s += o.face_listening_s;
        self.aversions += o.aversions;
        self.cognitive_aversions += o.cognitive_aversions;
        self.nods += o.nods;
    }
}

fn gamma2(mean: f64, rng: &mut ChaCha8Rng) -> f64 {
    Gamma::new(2.0, mean.max(1e-3) / 2.0)
        .expect("positive mean")
        .sample(rng)
}

/// Where to look away to: `(direction, head share)`.
fn aversion(p: &TalkerParams, cognitive: bool, rng: &mut ChaCha8Rng) -> (Angles, f64) {
    let amp = LogNormal::new(p.aversion_deg.max(0.1).ln(), 0.4)
        .expect("finite")
        .sample(rng)
        .min(35.0);
    let u = rng.gen::<f64>();
    let side = if rng.gen::<bool>() { 1.0 } else { -1.0 };
    // (up, down, side) shares.
    let (up, down) = if cognitive { (0.7, 0.2) } else { (0.1, 0.2) };
    let dir = if u < up {
        Angles::new(0.3 * amp * side * rng.gen::<f64>(), amp)
    } else if u < up + down {
        Angles::new(0.3 * amp * side * rng.gen::<f64>(), -amp)
    } else {
        Angles::new(side * amp, 0.3 * amp * (rng.gen::<f64>() - 0.5))
    };
    (dir, if cognitive { 0.4 } else { 0.1 })
}

/// A point on the partner's face: an eye or the mouth.
/// Chance that the next look at the face stays in the region the eyes are
/// in (a small refixation rather than a jump to another feature).
pub const FACE_REGION_PERSISTENCE: f64 = 0.4;

/// A point on the partner's face: an eye, the mouth or the nose, by the
/// person's preference for the eyes, staying in the current region
/// (`region`, updated) with [`FACE_REGION_PERSISTENCE`].
fn face_point(p: &TalkerParams, region: &mut usize, rng: &mut ChaCha8Rng) -> Angles {
    if rng.gen::<f64>() >= FACE_REGION_PERSISTENCE {
        let u = rng.gen::<f64>();
        let e = p.eye_preference;
        *region = if u < e / 2.0 {
            0
        } else if u < e {
            1
        } else if u < e + (1.0 - e) * 0.7 {
            2
        } else {
            3
        };
    }
    let local = match *region {
        0 => Angles::new(-1.2, 0.8),
        1 => Angles::new(1.2, 0.8),
        2 => Angles::new(0.0, -1.8),
        _ => Angles::new(0.0, 0.0),
    };
    p.partner.plus(local).plus(Angles::new(
        0.3 * (rng.gen::<f64>() - 0.5),
        0.3 * (rng.gen::<f64>() - 0.5),
    ))
}

/// A conversing person.
pub struct Talker {
    pub params: TalkerParams,
}

impl Talker {
    /// The person's head sway for the whole recording: three sinusoids an
    /// axis at 0.2-1.1 Hz, amplitudes around a third of `head_sway_deg`.
    pub fn sway(&self, plan: &mut Plan, rng: &mut ChaCha8Rng) {
        let p = &self.params;
        for yaw in [true, false] {
            // Talkers' heads sway more from side to side than up and down.
            let axis = if yaw { 1.0 } else { 0.5 };
            for _ in 0..3 {
                plan.sway.push(crate::timeline::Sway {
                    amp_deg: axis * p.head_sway_deg / 3.0 * (0.5 + rng.gen::<f64>()),
                    freq_hz: 0.2 + 0.9 * rng.gen::<f64>(),
                    phase: std::f64::consts::TAU * rng.gen::<f64>(),
                    yaw,
                });
            }
        }
    }

    /// Fills `[t_start, t_end)` with turns, starting with the given role.
    pub fn converse(
        &self,
        plan: &mut Plan,
        t_start: f64,
        t_end: f64,
        speaking_first: bool,
        rng: &mut ChaCha8Rng,
    ) -> ConversationStats {
        let p = &self.params;
        let mut st = ConversationStats::default();
        let mut t = t_start;
        let mut speaking = speaking_first;
        while t < t_end {
            let mean = if speaking {
                p.speaking_turn_s
            } else {
                p.listening_turn_s
            };
            let te = (t + gamma2(mean, rng).clamp(1.5, 60.0)).min(t_end);
            self.turn(plan, t, te, speaking, &mut st, rng);
            t = te;
            speaking = !speaking;
        }
        st
    }

    /// One turn `[ts, te)` (an interview's question heard, or its answer).
    pub fn turn(
        &self,
        plan: &mut Plan,
        ts: f64,
        te: f64,
        speaking: bool,
        st: &mut ConversationStats,
        rng: &mut ChaCha8Rng,
    ) {
        let p = &self.params;
        if speaking {
            st.speaking_s += te - ts;
        } else {
            st.listening_s += te - ts;
        }
        let mut t = ts;
        if speaking && rng.gen::<f64>() < p.cognitive_aversion_prob {
            // Looking away to plan the utterance: it started about 1 s
            // before speech (the listening turn's last second) and lasts
            // until about 1.2 s after.
            let (dir, share) = aversion(p, true, rng);
            let start = (ts - 1.0 + 0.25 * (rng.gen::<f64>() - 0.5) * 2.0).max(0.0);
            // What the listening turn planned for its last second gives way.
            plan.shifts.retain(|s| s.t_s < start);
            plan.head.retain(|s| s.t_s < start);
            let end = (ts + 1.2 + 0.25 * (rng.gen::<f64>() - 0.5) * 2.0).min(te);
            look_away(plan, p, start.min(ts), dir, share);
            st.aversions += 1;
            st.cognitive_aversions += 1;
            t = end;
        } else if rng.gen::<f64>() >= if speaking { 0.5 } else { 0.8 } {
            // Otherwise the turn starts looking away (half the speaking
            // turns, a fifth of the listening ones) or on the face.
            let (dir, share) = aversion(p, false, rng);
            look_away(plan, p, t, dir, share);
            st.aversions += 1;
            t += gamma2(p.away_dwell_s(speaking), rng).min(te - t);
        }
        // Speakers look back at the partner for the end of their turn.
        let look_back = if speaking { (te - 2.3).max(t) } else { te };
        let mut face_next = true;
        while t < te {
            if face_next || t >= look_back {
                let dwell_mean = if speaking {
                    p.face_dwell_speaking_s
                } else {
                    p.face_dwell_listening_s
                };
                let end = if t >= look_back {
                    te
                } else {
                    (t + gamma2(dwell_mean, rng)).min(te)
                };
                let end = if speaking && end > look_back { te } else { end };
                // Back on the face, the head comes back too.
                plan.head.push(Shift {
                    t_s: t + HEAD_LAG_S,
                    to: Angles::default(),
                });
                // Scan the face while looking at it.
                let mut region = 3;
                let mut ft = t;
                while ft < end {
                    plan.shifts.push(Shift {
                        t_s: ft,
                        to: face_point(p, &mut region, rng),
                    });
                    // Shape 4: fixations on a face are rarely under 200 ms.
                    ft += Gamma::new(4.0, p.face_scan_s / 4.0)
                        .expect("positive scan interval")
                        .sample(rng)
                        .max(0.2);
                }
                if speaking {
                    st.face_speaking_s += end - t;
                } else {
                    st.face_listening_s += end - t;
                    // Nods while listening, on the face.
                    let mut nt = t + exp_interval(p.nods_per_s, rng);
                    while nt < end - 0.5 {
                        let freq = 2.6 + 3.9 * rng.gen::<f64>();
                        let cycles = (1 + rng.gen_range(0..3)) as f64;
                        plan.nods.push(Nod {
                            t_s: nt,
                            amp_deg: p.nod_deg * (0.5 + rng.gen::<f64>()),
                            freq_hz: freq,
                            cycles,
                        });
                        st.nods += 1;
                        // The next nod starts after this one ends.
                        nt += cycles / freq + exp_interval(p.nods_per_s, rng);
                    }
                }
                t = end;
                face_next = false;
            } else {
                let (dir, share) = aversion(p, false, rng);
                look_away(plan, p, t, dir, share);
                st.aversions += 1;
                let limit = look_back.max(t + 0.3).min(te);
                t = (t + gamma2(p.away_dwell_s(speaking), rng).max(0.3)).min(limit);
                // Now and then the eyes go on elsewhere before coming back.
                if t < limit && rng.gen::<f64>() < AVERSION_CHAIN_PROB {
                    let (dir, share) = aversion(p, false, rng);
                    look_away(plan, p, t, dir, share);
                    t = (t + gamma2(p.away_dwell_s(speaking), rng).max(0.3)).min(limit);
                }
                face_next = true;
            }
        }
    }
}

/// Chance that an aversion goes on to a second place before the eyes come
/// back to the partner.
pub const AVERSION_CHAIN_PROB: f64 = 0.3;

/// How long after the eyes the head starts to move, s.
pub const HEAD_LAG_S: f64 = 0.05;

/// An aversion: the eyes saccade to the whole gaze offset `dir` from the
/// partner; the head then takes its `share` of it, and the eyes
/// counter-rotate back by as much (fast out, slow back: the shape of a
/// real eye-head gaze shift in the eye-in-head track).
fn look_away(plan: &mut Plan, p: &TalkerParams, t: f64, dir: Angles, share: f64) {
    plan.shifts.push(Shift {
        t_s: t,
        to: p.partner.plus(dir),
    });
    plan.head.push(Shift {
        t_s: t + HEAD_LAG_S,
        to: dir.scale(share),
    });
}

fn exp_interval(rate: f64, rng: &mut ChaCha8Rng) -> f64 {
    if rate <= 0.0 {
        return f64::INFINITY;
    }
    -(1.0 - rng.gen::<f64>()).ln() / rate
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn away_dwell_gives_the_face_share() {
        let p = TalkerParams {
            partner: Angles::new(0.0, -10.0),
            face_share_listening: 0.75,
            face_share_speaking: 0.41,
            face_dwell_listening_s: 3.0,
            face_dwell_speaking_s: 1.5,
            speaking_turn_s: 8.0,
            listening_turn_s: 6.0,
            aversion_deg: 10.0,
            cognitive_aversion_prob: 0.7,
            face_scan_s: 0.8,
            nods_per_s: 0.1,
            nod_deg: 2.0,
            eye_preference: 0.7,
            head_sway_deg: 1.0,
        };
        // Listening: 3 (1 - 0.75) / 0.75 = 1.0 s; speaking: 1.5 x 0.59 / 0.41 = 2.159 s.
        assert!((p.away_dwell_s(false) - 1.0).abs() < 1e-12);
        assert!((p.away_dwell_s(true) - 2.158_536_6).abs() < 1e-6);
    }
}
