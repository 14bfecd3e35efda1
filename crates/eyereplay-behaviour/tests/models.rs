//! The models against worked values and invariants: determinism by seed,
//! emergent reading statistics inside the published ranges, a return
//! sweep's geometry, face shares by role, interview labels.

use eyereplay_behaviour::{
    draw_person, generate, geometry::Surface, Gains, GeneratorSpec, Model, ReadingText,
};

fn spec(model: Model) -> GeneratorSpec {
    GeneratorSpec::new(model)
}

#[test]
fn same_seed_same_samples_other_seed_other_samples() {
    let text = ReadingText::bundled();
    for model in [Model::Reading, Model::Conversation, Model::Interview] {
        let s = spec(model);
        let a = generate(
            &draw_person(&s, 42, 20.0, "bundled"),
            &text,
            &Gains::default(),
        );
        let b = generate(
            &draw_person(&s, 42, 20.0, "bundled"),
            &text,
            &Gains::default(),
        );
        let c = generate(
            &draw_person(&s, 43, 20.0, "bundled"),
            &text,
            &Gains::default(),
        );
        assert_eq!(a.samples, b.samples, "{model:?}");
        assert_eq!(a.person, b.person);
        assert_ne!(a.samples, c.samples);
        assert_eq!(a.samples.len(), 10_000);
    }
}

#[test]
fn readers_fall_in_published_ranges() {
    let text = ReadingText::bundled();
    let s = spec(Model::Reading);
    for seed in 0..40 {
        let p = draw_person(&s, seed, 120.0, "bundled");
        let g = generate(&p, &text, &Gains::default());
        let r = g.outcome.reading.as_ref().unwrap();
        let c = &r.counts;
        // Brysbaert 2019: most adults 175-300 wpm silently, 183 aloud; a
        // person's range is wider.
        assert!(
            (90.0..=480.0).contains(&r.words_per_min),
            "seed {seed}: {} wpm ({:?}, aloud {})",
            r.words_per_min,
            p.plane.unwrap().surface,
            p.reader.as_ref().unwrap().aloud
        );
        assert!(
            (150.0..=340.0).contains(&r.mean_fixation_ms),
            "{}",
            r.mean_fixation_ms
        );
        let reg = c.regressions as f64 / c.fixations as f64;
        assert!(reg < 0.3, "regressions {reg}");
        assert!(c.return_sweeps > 5);
        // 38-52 % of sweeps are corrected on OneStop; the drawn range is 35-55 %.
        let corr = c.corrective_saccades as f64 / c.return_sweeps as f64;
        assert!((0.1..=0.8).contains(&corr), "corrective {corr}");
        assert!(g.reading_spans == vec![[0.0, 120.0]]);
    }
}

#[test]
fn a_return_sweep_spans_the_line_on_a_laptop() {
    // A laptop reader: the sweep's horizontal extent in n is the line's
    // angle times the gain, up to undershoot: line_chars x char width at
    // the distance.
    let text = ReadingText::bundled();
    let mut s = spec(Model::Reading);
    s.surfaces = Some(vec![Surface::Laptop]);
    let p = draw_person(&s, 5, 60.0, "bundled");
    let plane = p.plane.unwrap();
    let g = generate(&p, &text, &Gains::default());
    let line_deg =
        plane.gaze_to(0, plane.line_chars as f64).yaw_deg - plane.gaze_to(0, 0.0).yaw_deg;
    let nx: Vec<f64> = g
        .samples
        .iter()
        .filter(|s| !s.blink)
        .map(|s| s.n[0])
        .collect();
    let lo = nx.iter().cloned().fold(f64::INFINITY, f64::min);
    let hi = nx.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
    let span_deg = (hi - lo) / 0.0061;
    // The eye covers the line (a little less: first and last fixations sit
    // inside it; a little more: drift and microsaccades).
    assert!(
        span_deg > 0.75 * line_deg && span_deg < 1.15 * line_deg,
        "span {span_deg} deg for a {line_deg} deg line"
    );
}

#[test]
fn talkers_look_at_the_face_more_while_listening() {
    let text = ReadingText::bundled();
    let s = spec(Model::Conversation);
    let (mut fl, mut l, mut fs, mut sp) = (0.0, 0.0, 0.0, 0.0);
    for seed in 0..30 {
        let g = generate(
            &draw_person(&s, seed, 120.0, "bundled"),
            &text,
            &Gains::default(),
        );
        let c = g.outcome.conversation.unwrap();
        fl += c.face_listening_s;
        l += c.listening_s;
        fs += c.face_speaking_s;
        sp += c.speaking_s;
        assert!(g.reading_spans.is_empty());
    }
    let (share_l, share_s) = (fl / l, fs / sp);
    // Argyle & Ingham: 75 % listening, 41 % speaking (drawn 65-88 / 35-60 %).
    assert!(
        share_l > share_s + 0.1,
        "listening {share_l}, speaking {share_s}"
    );
    assert!((0.55..=0.92).contains(&share_l), "{share_l}");
    assert!((0.25..=0.7).contains(&share_s), "{share_s}");
}

#[test]
fn interviews_alternate_and_label_reading() {
    let text = ReadingText::bundled();
    let s = spec(Model::Interview);
    let mut any_read = 0;
    for seed in 0..10 {
        let g = generate(
            &draw_person(&s, seed, 90.0, "bundled"),
            &text,
            &Gains::default(),
        );
        let spans = &g.reading_spans;
        assert!(spans.windows(2).all(|w| w[0][1] < w[1][0]), "{spans:?}");
        let read: f64 = spans.iter().map(|r| r[1] - r[0]).sum();
        assert!((g.outcome.reading_s - read).abs() < 1e-9);
        if read > 0.0 {
            any_read += 1;
            assert!(read < 90.0);
        }
        // Interview answers are read aloud.
        assert!(g.person.reader.as_ref().unwrap().aloud);
    }
    assert!(any_read >= 8);
}

#[test]
fn an_interview_never_ends_in_a_read_answer_shorter_than_the_shortest() {
    // read_s = [20, 60] over 100 s: without the rule, a read answer begun
    // near the end is cut to whatever is left (about a third of these
    // seeds ended in one under 20 s).
    let text = ReadingText::bundled();
    let mut s = spec(Model::Interview);
    s.interview = Some(eyereplay_behaviour::InterviewRanges {
        talk_s: [10.0, 30.0],
        read_s: [20.0, 60.0],
        ..Default::default()
    });
    let mut ended_in_talk_after_reading = 0;
    for seed in 0..30 {
        let g = generate(
            &draw_person(&s, seed, 100.0, "bundled"),
            &text,
            &Gains::default(),
        );
        for r in &g.reading_spans {
            assert!(r[1] - r[0] >= 20.0 - 1e-9, "seed {seed}: {r:?}");
        }
        let last_end = g.reading_spans.last().map_or(0.0, |r| r[1]);
        if last_end < 100.0 - 1e-9 && !g.reading_spans.is_empty() {
            ended_in_talk_after_reading += 1;
        }
    }
    assert!(ended_in_talk_after_reading > 0);
}

#[test]
fn a_reader_who_never_skips_fixates_every_word_once_corrections_included() {
    // No skips, regressions or refixations, every return sweep undershoots:
    // each word gets exactly one fixation, plus one undersweep fixation a
    // line; none is lost to the corrective saccade.
    let text = ReadingText::bundled();
    let mut s = spec(Model::Reading);
    s.surfaces = Some(vec![Surface::Teleprompter]);
    s.reader = Some(eyereplay_behaviour::ReaderRanges {
        aloud_prob: 0.0,
        regression_prob: [0.0, 0.0],
        refixation_per_char: [0.0, 0.0],
        skip_scale: [0.0, 0.0],
        corrective_prob: [1.0, 1.0],
        ..Default::default()
    });
    for seed in 0..5 {
        let g = generate(
            &draw_person(&s, seed, 60.0, "bundled"),
            &text,
            &Gains::default(),
        );
        let c = &g.outcome.reading.as_ref().unwrap().counts;
        assert_eq!(c.skips + c.regressions + c.refixations, 0);
        assert!(c.corrective_saccades > 10);
        // The fixation under way at the end may be on a word not yet
        // counted as read, and the first fixation on a line's first word is
        // not an undersweep: allow one either way.
        let diff = c.fixations as i64 - (c.words_read + c.corrective_saccades) as i64;
        assert!(diff.abs() <= 1, "seed {seed}: {c:?}");
    }
}
