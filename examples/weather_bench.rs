//! The weather stage's CPU cost (issue 41 item 4; docs/benchmarks.md): the
//! particles of `presets/rain.ron` and `presets/snow.ron` (1920×1080)
//! drawn and composited over a frame and its drone-free background
//! (`pipeline::weather::over_pixels`), the median wall time of 30 frames
//! each and the process's CPU time a frame (all threads, from
//! `/proc/self/stat`, Linux only), and the median time of making the
//! particles alone (`FrameWeather::particles`).
//!
//! ```sh
//! cargo build --release --locked --no-default-features --example weather_bench
//! target/release/examples/weather_bench
//! ```

use std::time::Instant;

use swarmshot::pipeline::FramePipeline;

#[path = "support/timing.rs"]
#[allow(dead_code)] // its `median_ms` times a fixed run; these frames differ run to run
mod timing;
use timing::{cpu_s, median};

fn main() -> anyhow::Result<()> {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    for name in ["rain", "snow"] {
        let pipeline = FramePipeline::open(&root.join("presets").join(format!("{name}.ron")))?;
        let geometry = &pipeline.assets().geometry;
        let (mut times, mut making) = (Vec::new(), Vec::new());
        let (mut particles, mut cpu) = (0, 0.0);
        // The drone-free frame's buffer, the background and the frame reused
        // as the pipeline reuses the renderer's buffers.
        let (mut buffer, mut background, mut rgba) = (Vec::new(), Vec::new(), Vec::new());
        for index in 0..30 {
            let scene = pipeline.scene(index % pipeline.frame_count())?;
            let (w, h) = (scene.camera.width, scene.camera.height);
            background.resize((w * h * 4) as usize, 180u8);
            rgba.clear();
            rgba.extend_from_slice(&background);
            if let Some(weather) = &scene.weather {
                let t = Instant::now();
                particles += weather.particles(&scene.camera, None).len();
                making.push(t.elapsed().as_secs_f64() * 1e3);
            }
            let (t, c) = (Instant::now(), cpu_s());
            let clear = swarmshot::pipeline::weather::over_pixels(
                (&scene, geometry),
                &mut rgba,
                Some(&background),
                Some(std::mem::take(&mut buffer)),
            );
            times.push(t.elapsed().as_secs_f64() * 1e3);
            cpu += (cpu_s() - c) * 1e3;
            buffer = clear.expect("the drone-free frame under the particles");
        }
        let (min, max) = (
            times.iter().copied().fold(f64::INFINITY, f64::min),
            times.iter().copied().fold(0.0, f64::max),
        );
        let (wall, make) = (median(times), median(making));
        println!(
            "{name}: {wall:.2} ms a frame (median of 30; min {min:.2}, max {max:.2}; CPU {:.1} ms \
             a frame), {} particles a frame: making them {make:.2} ms, compositing {:.2} ms",
            cpu / 30.0,
            particles / 30,
            wall - make,
        );
    }
    Ok(())
}
