use eyereplay::detect::{features, windows, WindowSpec, FEATURE_NAMES};
use eyereplay::sources::{read_source, ReadOptions, SourceSpec};
fn main() {
    let args: Vec<String> = std::env::args().collect();
    let k: f64 = args[2].parse().unwrap();
    let spec: SourceSpec = toml::from_str::<toml::Table>(&format!("s = {}", args[1])).unwrap()["s"]
        .clone()
        .try_into()
        .unwrap();
    let recs = read_source(&spec, &ReadOptions::default()).unwrap();
    let mut tracks = Vec::new();
    for r in &recs {
        for s in &r.segments {
            let v: Vec<_> = s.samples().iter().collect();
            tracks.push(eyereplay::detector::resample_samples(&v));
        }
    }
    let xs: Vec<f64> = tracks
        .iter()
        .flat_map(|t| t.xy.iter().map(|p| p[0]))
        .filter(|v| v.is_finite())
        .collect();
    let mut s = xs.clone();
    s.sort_by(f64::total_cmp);
    let r = s[(s.len() as f64 * 0.95) as usize] - s[(s.len() as f64 * 0.05) as usize];
    println!(
        "segments {} frames {} x-range {r:.4}",
        tracks.len(),
        xs.len()
    );
    use rand::SeedableRng;
    use rand_distr::Distribution;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
    let nd = rand_distr::Normal::new(0.0, (k * r).max(1e-12)).unwrap();
    let mut sum = [0.0; 14];
    let mut n = 0.0;
    let mut mir = 0;
    for t in &tracks {
        let noisy = eyereplay::detect::Track::new(
            t.xy.iter()
                .map(|p| {
                    [
                        p[0] + if k > 0.0 { nd.sample(&mut rng) } else { 0.0 },
                        p[1] + if k > 0.0 { nd.sample(&mut rng) } else { 0.0 },
                    ]
                })
                .collect(),
        );
        for w in windows(&noisy, WindowSpec::seconds(10.0)) {
            let f = features(&w);
            for i in 0..14 {
                sum[i] += f[i];
            }
            n += 1.0;
            if w.mirrored {
                mir += 1;
            }
        }
    }
    println!("windows {n} mirrored {mir}");
    for i in 0..14 {
        println!("{:32} {:8.3}", FEATURE_NAMES[i], sum[i] / n);
    }
}
