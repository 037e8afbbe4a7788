//! The weather stage's CPU cost (issue 41 item 4; docs/benchmarks.md): the
//! particles of `presets/rain.ron` and `presets/snow.ron` (1920×1080)
//! drawn and composited over a frame and its drone-free background
//! (`pipeline::weather::over_pixels`), the median of 30 frames each, and
//! the median time of drawing the particles alone (`FrameWeather::particles`).
//!
//! ```sh
//! cargo build --release --locked --no-default-features --example weather_bench
//! target/release/examples/weather_bench
//! ```

use std::time::Instant;

use swarmshot::pipeline::FramePipeline;

fn main() -> anyhow::Result<()> {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    for name in ["rain", "snow"] {
        let pipeline = FramePipeline::open(&root.join("presets").join(format!("{name}.ron")))?;
        let geometry = &pipeline.assets().geometry;
        let mut times = Vec::new();
        let mut particles = 0;
        let mut drawing = Vec::new();
        // The drone-free frame's buffer, reused as the pipeline reuses the renderer's.
        let mut buffer = Vec::new();
        for index in 0..30 {
            let scene = pipeline.scene(index % pipeline.frame_count())?;
            let (w, h) = (scene.camera.width, scene.camera.height);
            let background = vec![180u8; (w * h * 4) as usize];
            let mut rgba = background.clone();
            if let Some(weather) = &scene.weather {
                let t = Instant::now();
                particles += weather.particles(&scene.camera, None).len();
                drawing.push(t.elapsed().as_secs_f64() * 1e3);
            }
            let t = Instant::now();
            let clear = swarmshot::pipeline::weather::over_pixels(
                (&scene, geometry),
                &mut rgba,
                Some(&background),
                Some(std::mem::take(&mut buffer)),
            );
            times.push(t.elapsed().as_secs_f64() * 1e3);
            buffer = clear.expect("the drone-free frame under the particles");
        }
        times.sort_by(f64::total_cmp);
        drawing.sort_by(f64::total_cmp);
        println!(
            "{name}: {:.2} ms a frame (median of 30; min {:.2}, max {:.2}), {} particles a frame, \
             of which drawing them {:.2} ms",
            times[15],
            times[0],
            times[29],
            particles / 30,
            drawing.get(drawing.len() / 2).copied().unwrap_or(0.0)
        );
    }
    Ok(())
}
