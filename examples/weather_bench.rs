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

/// The process's user + system CPU time so far, ms (`None` off Linux).
fn cpu_ms() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    // Fields after the command's closing parenthesis: utime and stime are 14 and 15.
    let rest = &stat[stat.rfind(')')? + 2..];
    let field = |i: usize| rest.split(' ').nth(i - 3)?.parse::<f64>().ok();
    // Clock ticks of 10 ms (USER_HZ is 100 on Linux).
    Some((field(14)? + field(15)?) * 10.0)
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 2).copied().unwrap_or(0.0)
}

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
            let (t, c) = (Instant::now(), cpu_ms());
            let clear = swarmshot::pipeline::weather::over_pixels(
                (&scene, geometry),
                &mut rgba,
                Some(&background),
                Some(std::mem::take(&mut buffer)),
            );
            times.push(t.elapsed().as_secs_f64() * 1e3);
            cpu += cpu_ms().zip(c).map_or(f64::NAN, |(b, a)| b - a);
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
