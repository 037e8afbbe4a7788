//! The lens distortion's cost per frame (src/sensor/lens.rs), on the CPU
//! alone: a 1920×1080 picture resampled through the lens of
//! presets/lens_distortion.ron's middle draw (the map cached, as for a fixed
//! draw), the map built anew (as for a draw that changes every frame), and
//! the two together (a new draw's whole frame); median wall of 30 runs
//! after 3 warm-ups and their mean CPU time.
//!
//! `cargo run --release --no-default-features --example lens_bench`
//! (docs/realism.md, "Lens distortion"). `RAYON_NUM_THREADS` sets the threads.

use swarmshot::sensor::lens::{LensDraw, LensGeometry, LensMap};

#[path = "support/picture.rs"]
mod picture;
#[path = "support/timing.rs"]
mod timing;
use timing::median_ms;

fn main() {
    let (w, h) = (1920u32, 1080u32);
    let rgba = picture::sky(w, h);
    // presets/lens_distortion.ron: fov_y 50° at 1080 rows.
    let focal = 540.0 / 25f64.to_radians().tan();
    let draw = LensDraw::BrownConrady {
        k1: -0.15,
        k2: 0.02,
        k3: 0.0,
        p1: 0.0005,
        p2: -0.0005,
    };
    let Some(geo) = LensGeometry::new(draw, w, h, focal) else {
        eprintln!("a neutral lens");
        return;
    };
    // As the pipeline does each frame: the map looked up, then the picture resampled.
    let remap = median_ms(|| {
        std::hint::black_box(LensMap::of(&geo).remap(&rgba));
    });
    // A new draw each run: the geometry's fill and the map are solved again.
    let mut k = 0u32;
    let mut next = || {
        k += 1;
        let d = LensDraw::BrownConrady {
            k1: -0.15 + f64::from(k) * 1e-6,
            k2: 0.02,
            k3: 0.0,
            p1: 0.0005,
            p2: -0.0005,
        };
        LensGeometry::new(d, w, h, focal).map(|g| LensMap::build(&g))
    };
    let build = median_ms(|| {
        std::hint::black_box(next());
    });
    let whole = median_ms(|| {
        if let Some(m) = next() {
            std::hint::black_box(m.remap(&rgba));
        }
    });
    println!("threads {}", rayon::current_num_threads());
    let show = |(wall, cpu): (f64, f64)| format!("{wall:.2} ms wall, {cpu:.1} ms CPU");
    println!("remap 1920x1080 (map cached): {}", show(remap));
    println!("new draw: geometry + map: {}", show(build));
    println!("new draw's frame: geometry + map + remap: {}", show(whole));
}
