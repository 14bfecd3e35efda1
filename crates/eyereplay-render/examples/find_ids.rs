fn main() {
    for s in 1..200u64 {
        let i = eyereplay_render::Identity::sample(s);
        let lum = i.skin_rgb[0] * 0.3 + i.skin_rgb[1] * 0.6 + i.skin_rgb[2] * 0.1;
        println!(
            "{s} {} skin {:.3} cam yaw {:.1}",
            i.iris.palette, lum, i.camera.yaw_deg
        );
    }
}
