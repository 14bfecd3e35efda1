//! The reading model: a word-target semi-Markov generator.
//!
//! Each fixation lands on a word; how long it lasts and where the next
//! saccade goes follow published models of reading, simplified to what a
//! 25 fps video can show (a lexical effect of tens of ms is below one
//! frame):
//!
//! | step | rule | source |
//! |---|---|---|
//! | duration | `Gamma(k, mu / k)`, `mu = mu_p + 4 ms (letters - 5) - 4.56 ms (ln f - ln 100)`, times 1.25 aloud; a refixation 0.8 mu | E-Z Reader 10 (`alpha2 (1 + Delta) = 3.4 x 1.34`); shape 6.9-8.0 measured on OneStop |
//! | skipping | `1 - P(fixate | letters)` from EyeSyn's table, times the person's skip scale (0.7 aloud) | Lan et al. 2022 (`fixationProByLength.m`) |
//! | landing | `N(centre + 2.4 - 0.3 d, 0.8 + 0.03 d)` chars, `d` the launch distance | SWIFT (Engbert et al. 2005), McConkie et al. 1988 |
//! | refixation | probability `lambda |landing - centre|` on a first fixation | E-Z Reader (lambda = 0.16 / char) |
//! | regression | probability `p_reg` (x 0.6 aloud); 60 % to the same word, else the previous | Rayner 1998 (10-15 %); E-Z Reader |
//! | return sweep | lands about 6 chars into the next line; with `p_corr` it undershoots by 5-15 % of its length, an undersweep fixation (138-176 ms) and a leftward corrective saccade follow | Slattery & Vasilev 2019; Slattery & Parker 2019; 38-52 % measured on OneStop |
//! | page | past the last line of a page the eyes pause 0.4-0.9 s and go back to the top (scrolling surfaces stay on one line) | ours |
//!
//! Saccades follow the person's main sequence (`crate::saccade`); blinks
//! are a Poisson process at the person's reading rate (Bentivoglio et al.
//! 1997: 4.5 a minute, 1.4-14.4 over people).

use crate::geometry::{angles_to, head_towards, Angles, TextPlane};
use crate::saccade::MainSequence;
use crate::text::Layout;
use crate::timeline::{Plan, Shift};
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Gamma, Normal};
use serde::{Deserialize, Serialize};

/// EyeSyn's probability of fixating a word by its letter count (1, 2, ...
/// 9, 10 and more).
pub const FIXATION_PROB_BY_LETTERS: [f64; 10] = [
    0.077, 0.50, 0.72, 0.78, 0.80, 0.825, 0.875, 0.915, 0.94, 0.925,
];

/// A reader's drawn parameters (recorded in the dataset's metadata).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ReaderParams {
    pub aloud: bool,
    pub fixation_mean_ms: f64,
    pub fixation_shape: f64,
    pub regression_prob: f64,
    pub refixation_per_char: f64,
    pub skip_scale: f64,
    pub corrective_prob: f64,
    pub undersweep_ms: f64,
    /// Chance of a glance at the camera at a line end (interviews).
    pub glance_prob: f64,
}

/// Mean fixation duration on a word, ms, before the gamma draw: the
/// formula of the module table.
pub fn mean_fixation_ms(p: &ReaderParams, letters: usize, per_million: f64) -> f64 {
    let mu = p.fixation_mean_ms + 4.0 * (letters as f64 - 5.0)
        - 3.4 * 1.34 * (per_million.ln() - 100f64.ln());
    let mu = mu.max(0.6 * p.fixation_mean_ms);
    if p.aloud {
        mu * 1.25
    } else {
        mu
    }
}

/// Probability of skipping a word of `letters` letters on first pass.
pub fn skip_prob(p: &ReaderParams, letters: usize) -> f64 {
    let i = letters.clamp(1, 10) - 1;
    let s = (1.0 - FIXATION_PROB_BY_LETTERS[i]) * p.skip_scale * if p.aloud { 0.7 } else { 1.0 };
    s.clamp(0.0, 0.95)
}

/// What a stretch of reading did.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ReadingStats {
    pub fixations: usize,
    pub words_read: usize,
    pub reading_s: f64,
    pub regressions: usize,
    pub refixations: usize,
    pub skips: usize,
    pub return_sweeps: usize,
    pub corrective_saccades: usize,
    pub glances: usize,
    /// Sum of fixation durations, ms (for the mean).
    pub fixation_ms_total: f64,
}

impl ReadingStats {
    pub fn words_per_min(&self) -> f64 {
        if self.reading_s > 0.0 {
            self.words_read as f64 / self.reading_s * 60.0
        } else {
            0.0
        }
    }

    pub fn mean_fixation_ms(&self) -> f64 {
        self.fixation_ms_total / self.fixations.max(1) as f64
    }

    pub fn add(&mut self, o: &ReadingStats) {
        self.fixations += o.fixations;
        self.words_read += o.words_read;
        self.reading_s += o.reading_s;
        self.regressions += o.regressions;
        self.refixations += o.refixations;
        self.skips += o.skips;
        self.return_sweeps += o.return_sweeps;
        self.corrective_saccades += o.corrective_saccades;
        self.glances += o.glances;
        self.fixation_ms_total += o.fixation_ms_total;
    }
}

/// Why the eye is at a fixation: decides its duration.
#[derive(Clone, Copy, Debug, PartialEq)]
enum FixKind {
    First,
    Refixation,
    Undersweep,
}

/// A reader part-way through a text.
pub struct Reader<'a> {
    pub params: ReaderParams,
    pub plane: TextPlane,
    pub layout: &'a Layout,
    pub ms: MainSequence,
    /// Where the head points while reading this surface.
    pub head: Angles,
    /// Index of the word fixated and the furthest word reached.
    word: usize,
    frontier: usize,
    /// Landing position on the line, chars.
    pos: f64,
    /// Words passed in earlier passes through the text.
    passes: usize,
}

impl<'a> Reader<'a> {
    /// A reader at the start of line `start_line` (wrapped to the text).
    pub fn new(
        params: ReaderParams,
        plane: TextPlane,
        layout: &'a Layout,
        ms: MainSequence,
        start_line: usize,
    ) -> Self {
        let line = start_line % layout.lines.max(1);
        let word = layout
            .words
            .iter()
            .position(|w| w.line == line)
            .unwrap_or(0);
        // The middle of the page (a scrolling surface has one line).
        let centre = plane.gaze_to(
            plane.lines_per_page.saturating_sub(1) / 2,
            plane.line_chars as f64 / 2.0,
        );
        Reader {
            params,
            plane,
            layout,
            ms,
            head: head_towards(centre),
            word,
            frontier: word,
            pos: layout.words.get(word).map_or(0.0, |w| w.centre()),
            passes: 0,
        }
    }

    /// Eye-in-head rotation for looking at char `pos` of layout line `line`.
    pub fn eye_at(&self, line: usize, pos: f64) -> Angles {
        let page_line = line % self.plane.lines_per_page.max(1);
        self.plane.gaze_to(page_line, pos).minus(self.head)
    }

    /// Eye-in-head rotation for looking into the camera lens.
    pub fn eye_at_camera(&self) -> Angles {
        // The lens at the plane's distance, straight ahead.
        let d = self.plane.centre_mm[2].max(300.0);
        angles_to([0.0, 0.0, d]).minus(self.head)
    }

    fn line(&self) -> usize {
        self.layout.words[self.word].line
    }

    /// Reads from `t_start` until `t_end`, appending to `plan`; the first
    /// shift brings the eye from wherever it was to the current word.
    pub fn read(
        &mut self,
        plan: &mut Plan,
        t_start: f64,
        t_end: f64,
        rng: &mut ChaCha8Rng,
    ) -> ReadingStats {
        let mut st = ReadingStats::default();
        if self.layout.words.is_empty() {
            return st;
        }
        let words_before = self.words_done();
        let mut t = t_start;
        let mut kind = FixKind::First;
        let mut first_on_word = true;
        let mut target = self.eye_at(self.line(), self.pos);
        plan.shifts.push(Shift { t_s: t, to: target });
        t += self.ms.span_s(20.0);
        let unit = Normal::new(0.0, 1.0).expect("unit normal");
        while t < t_end {
            let dur_ms = self.duration_ms(kind, rng);
            let t_move = t + dur_ms * 1e-3;
            if t_move >= t_end {
                break;
            }
            // Counted once it is complete.
            st.fixations += 1;
            st.fixation_ms_total += dur_ms;
            let w = &self.layout.words[self.word];
            let line = w.line;
            // The next target.
            let (next_word, next_pos, next_kind, pause_s);
            // Past the end of the text: it starts again (committed with the
            // move, so a stretch that ends first leaves the reader as it was).
            let mut wrapped = false;
            if kind == FixKind::Undersweep {
                // The corrective saccade back to the line's first word.
                let first = self.first_word_of(line);
                st.corrective_saccades += 1;
                next_word = first;
                next_pos = self.clamp_to_word(
                    first,
                    self.layout.words[first].centre() - 0.5 + 0.8 * unit.sample(rng),
                );
                next_kind = FixKind::First;
                pause_s = 0.0;
            } else if self.word > 0 && rng.gen::<f64>() < self.regression_prob() {
                st.regressions += 1;
                let same = rng.gen::<f64>() < 0.6 && self.pos > w.start as f64 + 1.0;
                let back = if same {
                    self.word
                } else {
                    self.prev_word_on_line(self.word)
                };
                let bw = &self.layout.words[back];
                let c = if same {
                    w.start as f64 + (self.pos - w.start as f64) * rng.gen::<f64>()
                } else {
                    bw.centre()
                };
                let d = (c - self.pos).abs();
                next_word = back;
                next_pos = self.clamp_to_word(back, c + (0.8 + 0.03 * d) * unit.sample(rng));
                next_kind = FixKind::Refixation;
                pause_s = 0.0;
            } else if first_on_word
                && w.letters > 3
                && rng.gen::<f64>()
                    < (self.params.refixation_per_char * (self.pos - w.centre()).abs()).min(0.5)
            {
                st.refixations += 1;
                // The other side of the word.
                let c = w.centre() + (w.centre() - self.pos).signum() * w.len as f64 / 4.0;
                next_word = self.word;
                next_pos = self.clamp_to_word(self.word, c + 0.8 * unit.sample(rng));
                next_kind = FixKind::Refixation;
                pause_s = 0.0;
            } else {
                // Forward, skipping words by length, to the next unread word.
                let mut nxt = self.frontier.max(self.word) + 1;
                let mut skipped = 0;
                while skipped < 2
                    && nxt + 1 < self.layout.words.len()
                    && self.layout.words[nxt + 1].line == self.layout.words[nxt].line
                    && self.layout.words[nxt].line == line
                    && rng.gen::<f64>() < skip_prob(&self.params, self.layout.words[nxt].letters)
                {
                    nxt += 1;
                    skipped += 1;
                    st.skips += 1;
                }
                if nxt >= self.layout.words.len() {
                    // The end of the text: start it again (a new page).
                    nxt = 0;
                    wrapped = true;
                }
                let nw = &self.layout.words[nxt];
                if nw.line != line || nxt == 0 {
                    // A return sweep (or a new page).
                    st.return_sweeps += 1;
                    let new_page = nw.line.is_multiple_of(self.plane.lines_per_page.max(1))
                        && !self.plane.scroll;
                    pause_s = if new_page || nxt == 0 {
                        0.4 + 0.5 * rng.gen::<f64>()
                    } else {
                        0.0
                    };
                    if pause_s == 0.0 && rng.gen::<f64>() < self.params.glance_prob {
                        // A glance at the camera between lines.
                        st.glances += 1;
                        let cam = self.eye_at_camera();
                        plan.shifts.push(Shift {
                            t_s: t_move,
                            to: cam,
                        });
                        let back = t_move
                            + self.ms.span_s(cam.distance(target))
                            + 0.3
                            + 0.6 * rng.gen::<f64>();
                        t = back;
                        target = cam;
                        if t >= t_end {
                            break;
                        }
                        let (nw_i, np, nk) = self.sweep_landing(nxt, rng, &unit);
                        let to = self.eye_at(self.layout.words[nw_i].line, np);
                        plan.shifts.push(Shift { t_s: t, to });
                        t += self.ms.span_s(to.distance(target));
                        self.commit(wrapped, nw_i, np, nk);
                        target = to;
                        kind = nk;
                        first_on_word = true;
                        continue;
                    }
                    let (nw_i, np, nk) = self.sweep_landing(nxt, rng, &unit);
                    next_word = nw_i;
                    next_pos = np;
                    next_kind = nk;
                } else {
                    let c = nw.centre();
                    let d = (c - self.pos).abs();
                    let mean = c + 2.4 - 0.3 * d;
                    let land = mean + (0.8 + 0.03 * d) * unit.sample(rng);
                    next_word = nxt;
                    next_pos = self.clamp_to_word(nxt, land);
                    next_kind = FixKind::First;
                    pause_s = 0.0;
                }
            }
            let t_go = t_move + pause_s;
            if t_go >= t_end {
                break;
            }
            // A page's pause lengthens the fixation it follows.
            st.fixation_ms_total += pause_s * 1e3;
            let to = self.eye_at(self.layout.words[next_word].line, next_pos);
            plan.shifts.push(Shift { t_s: t_go, to });
            t = t_go + self.ms.span_s(to.distance(target));
            first_on_word = next_word != self.word || next_kind == FixKind::First;
            self.commit(wrapped, next_word, next_pos, next_kind);
            target = to;
            kind = next_kind;
        }
        st.words_read = self.words_done().saturating_sub(words_before);
        st.reading_s = (t_end - t_start).max(0.0);
        st
    }

    fn words_done(&self) -> usize {
        self.passes + self.frontier
    }

    /// Moves the eye to `word` at `pos`. An undersweep landing does not
    /// count as reaching its word: the corrective saccade goes back to the
    /// line's start, and the words between are still to be read.
    fn commit(&mut self, wrapped: bool, word: usize, pos: f64, kind: FixKind) {
        if wrapped {
            self.passes += self.layout.words.len();
            self.frontier = 0;
        }
        self.word = word;
        self.pos = pos;
        if kind != FixKind::Undersweep {
            self.frontier = self.frontier.max(word);
        }
    }

    /// Where a return sweep to word `nxt` (first of its line) lands: about
    /// 6 chars in, or, undershooting, further right with an undersweep
    /// fixation to come.
    fn sweep_landing(
        &self,
        nxt: usize,
        rng: &mut ChaCha8Rng,
        unit: &Normal<f64>,
    ) -> (usize, f64, FixKind) {
        let line = self.layout.words[nxt].line;
        let sweep_chars = self.pos.max(10.0);
        if rng.gen::<f64>() < self.params.corrective_prob {
            let land = 6.0 + sweep_chars * (0.05 + 0.10 * rng.gen::<f64>());
            let w = self.word_at(line, land);
            (w, self.clamp_to_word(w, land), FixKind::Undersweep)
        } else {
            let land = (6.0 + 1.5 * unit.sample(rng)).max(0.5);
            let w = self.word_at(line, land);
            (w, self.clamp_to_word(w, land), FixKind::First)
        }
    }

    fn duration_ms(&self, kind: FixKind, rng: &mut ChaCha8Rng) -> f64 {
        let w = &self.layout.words[self.word];
        let mu = match kind {
            FixKind::Undersweep => {
                return self.params.undersweep_ms * (0.85 + 0.3 * rng.gen::<f64>())
            }
            FixKind::First => mean_fixation_ms(&self.params, w.letters, w.per_million),
            FixKind::Refixation => 0.8 * mean_fixation_ms(&self.params, w.letters, w.per_million),
        };
        let k = self.params.fixation_shape;
        let g = Gamma::new(k, mu / k).expect("positive shape and mean");
        g.sample(rng).clamp(80.0, 1200.0)
    }

    fn regression_prob(&self) -> f64 {
        self.params.regression_prob * if self.params.aloud { 0.6 } else { 1.0 }
    }

    fn first_word_of(&self, line: usize) -> usize {
        self.layout
            .words
            .iter()
            .position(|w| w.line == line)
            .unwrap_or(0)
    }

    fn prev_word_on_line(&self, i: usize) -> usize {
        if i > 0 && self.layout.words[i - 1].line == self.layout.words[i].line {
            i - 1
        } else {
            i
        }
    }

    /// The word of `line` under char position `pos` (the nearest one).
    fn word_at(&self, line: usize, pos: f64) -> usize {
        let first = self.first_word_of(line);
        let mut best = first;
        for (i, w) in self.layout.words.iter().enumerate().skip(first) {
            if w.line != line {
                break;
            }
            if (w.start as f64) <= pos {
                best = i;
            }
        }
        best
    }

    fn clamp_to_word(&self, i: usize, pos: f64) -> f64 {
        let w = &self.layout.words[i];
        pos.clamp(w.start as f64, (w.start + w.len) as f64)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn params() -> ReaderParams {
        ReaderParams {
            aloud: false,
            fixation_mean_ms: 220.0,
            fixation_shape: 8.0,
            regression_prob: 0.1,
            refixation_per_char: 0.16,
            skip_scale: 1.0,
            corrective_prob: 0.45,
            undersweep_ms: 150.0,
            glance_prob: 0.0,
        }
    }

    #[test]
    fn fixation_duration_formula_by_hand() {
        let p = params();
        // 7 letters, 30 per million: 220 + 4 * 2 - 4.556 ln(0.3) = 228 + 5.485 = 233.49 ms.
        let got = mean_fixation_ms(&p, 7, 30.0);
        assert!((got - 233.485).abs() < 0.01, "{got}");
        // 3 letters, 3000 per million: 220 - 8 - 4.556 ln(30) = 212 - 15.496 = 196.50.
        assert!((mean_fixation_ms(&p, 3, 3000.0) - 196.504).abs() < 0.01);
        // Aloud: 1.25 times.
        let aloud = ReaderParams { aloud: true, ..p };
        assert!((mean_fixation_ms(&aloud, 7, 30.0) - 1.25 * 233.485).abs() < 0.02);
    }

    #[test]
    fn skipping_follows_the_eyesyn_table() {
        let p = params();
        assert!((skip_prob(&p, 1) - 0.923).abs() < 1e-12);
        assert!((skip_prob(&p, 3) - 0.28).abs() < 1e-12);
        assert!((skip_prob(&p, 6) - 0.175).abs() < 1e-12);
        assert!((skip_prob(&p, 14) - 0.075).abs() < 1e-12);
    }
}
