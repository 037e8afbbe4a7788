//! The rolling shutter's cost per frame (src/sensor/rolling.rs,
//! src/pipeline/rolling.rs), on the CPU alone, 1920×1080: the sky turned
//! row by row through each row's rotation homography (a panning camera),
//! seven 40×30-pixel drones moved row by row over it, and the scene built
//! again at the end of the readout (presets/rolling_shutter.ron, frame 5);
//! median wall of 30 runs after 3 warm-ups and their mean CPU time.
//!
//! `cargo run --release --no-default-features --example rolling_bench`
//! (docs/realism.md, "Rolling shutter"). `RAYON_NUM_THREADS` sets the threads.

use glam::{DMat3, DVec3};
use swarmshot::annotate::flow::BackgroundFlow;
use swarmshot::preset::Preset;
use swarmshot::scene::camera::Camera;
use swarmshot::scene::{build_frame_at, math::look_at_cv};
use swarmshot::sensor::PixelRect;
use swarmshot::sensor::rolling::{Shear, shear, shear_over, turn_background_twice};

#[path = "support/picture.rs"]
mod picture;
#[path = "support/timing.rs"]
mod timing;
use timing::median_ms;

fn main() -> anyhow::Result<()> {
    let (w, h) = (1920u32, 1080u32);
    let sky = picture::sky(w, h);
    let mut frame = sky.clone();
    let rects: Vec<PixelRect> = (0..7u32)
        .map(|k| PixelRect {
            x0: 300 + k * 200,
            y0: 200 + k * 90,
            x1: 340 + k * 200,
            y1: 230 + k * 90,
        })
        .collect();
    for r in &rects {
        for y in r.y0..r.y1 {
            for x in r.x0..r.x1 {
                let i = ((y * w + x) * 4) as usize;
                frame[i..i + 3].copy_from_slice(&[30, 30, 35]);
            }
        }
    }
    // 20°/s over a 33 ms readout; the drones 300 px/s across.
    let (readout, yaw) = (0.033, 20f64.to_radians());
    let camera = Camera {
        width: w,
        height: h,
        fov_y_deg: 50.0,
        position: DVec3::ZERO,
        camera_from_world: look_at_cv(DVec3::ZERO, DVec3::Z).unwrap_or(DMat3::IDENTITY),
        near_m: 0.01,
    };
    let turned_at = |y: f64| Camera {
        camera_from_world: DMat3::from_rotation_y(yaw * readout * y / f64::from(h)).transpose()
            * camera.camera_from_world,
        ..camera
    };
    // As `pipeline/rolling.rs`: each row's camera once, then its knots.
    let source = |y: f64, xs: &[f64], out: &mut [(f64, f64)]| {
        BackgroundFlow::new(&turned_at(y - 0.5), &camera).row_sources(y, xs, out);
    };
    let shears: Vec<Shear> = (rects.iter())
        .map(|&rect| Shear {
            rect,
            shift_px: (0..h)
                .map(|y| (300.0 * readout * f64::from(y) / f64::from(h), 0.0))
                .collect(),
        })
        .collect();
    // As `Shutter::apply`: the turned sky and its copy made together, the
    // drones drawn over the copy.
    let turn = median_ms(|| {
        std::hint::black_box(turn_background_twice(&sky, (w, h), &source));
    });
    let (_, mut turned) = turn_background_twice(&sky, (w, h), &source);
    let drones = median_ms(|| {
        shear_over(&mut turned, &frame, &sky, (w, h), &shears);
        std::hint::black_box(&turned);
    });
    // A still camera: the rendered frame copied, the drones drawn over it.
    let still = median_ms(|| {
        std::hint::black_box(shear(&frame, &sky, &sky, (w, h), &shears));
    });
    let preset = Preset::open(std::path::Path::new("presets/rolling_shutter.ron"))?;
    let scene = median_ms(|| {
        std::hint::black_box(build_frame_at(&preset, 5, 0, readout).ok());
    });
    println!("threads {}", rayon::current_num_threads());
    let show = |(wall, cpu): (f64, f64)| format!("{wall:.2} ms wall, {cpu:.1} ms CPU");
    let sum = |parts: &[(f64, f64)]| parts.iter().fold((0.0, 0.0), |a, p| (a.0 + p.0, a.1 + p.1));
    println!(
        "sky turned row by row, 1920x1080, and its copy: {}",
        show(turn)
    );
    println!("7 drones moved row by row over it: {}", show(drones));
    println!("scene at the end of the readout: {}", show(scene));
    println!("total with a pan: {}", show(sum(&[turn, drones, scene])));
    println!(
        "a still camera (frame copied, drones moved): {}",
        show(sum(&[still, scene]))
    );
    Ok(())
}
