//! How fast behaviour is generated, against real time: one 30 s person of
//! each model, planned and synthesized at 500 Hz. The generator must cost
//! nothing next to rendering (goal: >= 10,000x real time). Prints the
//! ratio; `cargo bench -p eyereplay-behaviour`.

use criterion::{criterion_group, criterion_main, Criterion};
use eyereplay_behaviour::{draw_person, generate, Gains, GeneratorSpec, Model, ReadingText};
use std::time::Instant;

fn spec(model: Model) -> GeneratorSpec {
    GeneratorSpec::new(model)
}

fn bench(c: &mut Criterion) {
    let text = ReadingText::bundled();
    let gains = Gains::default();
    let duration_s = 30.0;
    for model in [Model::Reading, Model::Conversation, Model::Interview] {
        let s = spec(model);
        // The ratio first, over 200 people, so it prints even with
        // criterion's filters.
        let t = Instant::now();
        let n = 200u64;
        for i in 0..n {
            let p = draw_person(&s, i, duration_s, &text.name);
            std::hint::black_box(generate(&p, &text, &gains));
        }
        let per = t.elapsed().as_secs_f64() / n as f64;
        println!(
            "behaviour {}: {:.2} ms per 30 s person = {:.0}x real time (goal >= 10000x)",
            model.name(),
            per * 1e3,
            duration_s / per
        );
        c.bench_function(&format!("generate_{}_30s", model.name()), |b| {
            let mut i = 0u64;
            b.iter(|| {
                i += 1;
                let p = draw_person(&s, i, duration_s, &text.name);
                generate(&p, &text, &gains)
            })
        });
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
