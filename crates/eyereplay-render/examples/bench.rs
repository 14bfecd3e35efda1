//! Same as `eyereplay render --bench`: `bench [FRAMES]`.
fn main() {
    let n: usize = std::env::args()
        .nth(1)
        .map(|s| s.parse().unwrap())
        .unwrap_or(500);
    let p = eyereplay_render::RenderParams::new(eyereplay_render::Identity::reference());
    println!("{}", eyereplay_render::run_bench(&p, n).unwrap());
}
