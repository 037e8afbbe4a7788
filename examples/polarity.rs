//! Drone polarity against the sky (a measurement, not a test; docs/realism.md):
//! renders frames of a preset and, for every kept label, compares the drone's
//! peak pixel with the median of a ring around its box, as issue 21's table
//! measured real footage (68 % darker, 32 % brighter than their background).
//!
//! Run: `cargo run --release --example polarity -- PRESET.ron N [--appearance]
//! [--atmosphere] [--observer]`; the flags switch on the realism stages with
//! their defaults (`--observer`: apparent size 3–10 px, elevation 10–50°).
#![allow(clippy::unwrap_used)]

use swarmshot::pipeline::FramePipeline;
use swarmshot::preset::Preset;
use swarmshot::preset::appearance::Appearance;
use swarmshot::preset::atmosphere::Atmosphere;
use swarmshot::preset::observer::ObserverCamera;

fn luma(p: &[u8]) -> f64 {
    0.2126 * f64::from(p[0]) + 0.7152 * f64::from(p[1]) + 0.0722 * f64::from(p[2])
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let mut preset = Preset::load(std::path::Path::new(&args[1])).unwrap();
    let n: u64 = args[2].parse().unwrap();
    let has = |f: &str| args.iter().any(|a| a == f);
    if has("--appearance") {
        preset.appearance = Some(Appearance::default());
    }
    if has("--atmosphere") {
        preset.atmosphere = Some(Atmosphere::default());
    }
    if has("--observer") {
        preset.camera.observer = Some(ObserverCamera {
            elevation_deg: (10.0, 50.0),
            size_px: Some((3.0, 10.0)),
            ..ObserverCamera::default()
        });
    }
    let pipeline = FramePipeline::new(preset).unwrap();
    let ctx = swarmshot::render::GpuContext::headless().unwrap();
    let mut renderer = pipeline.renderer(&ctx);
    let (mut brighter, mut darker) = (0u32, 0u32);
    let mut contrasts = Vec::new();
    for i in 0..n.min(pipeline.frame_count()) {
        let frame = pipeline.make(&mut renderer, i).unwrap();
        let (w, h) = (
            frame.scene.camera.width as i64,
            frame.scene.camera.height as i64,
        );
        let px = |x: i64, y: i64| {
            let o = ((y * w + x) * 4) as usize;
            luma(&frame.rgba[o..o + 4])
        };
        for l in frame.labels.iter().filter(|l| l.is_kept()) {
            let b = l.bbox;
            let (x0, y0) = (b.x0.floor() as i64, b.y0.floor() as i64);
            let (x1, y1) = (b.x1.ceil() as i64, b.y1.ceil() as i64);
            let inside = |x: i64, y: i64| x >= x0 && x < x1 && y >= y0 && y < y1;
            let mut ring = Vec::new();
            for y in (y0 - 4).max(0)..(y1 + 4).min(h) {
                for x in (x0 - 4).max(0)..(x1 + 4).min(w) {
                    if !inside(x, y) {
                        ring.push(px(x, y));
                    }
                }
            }
            if ring.is_empty() {
                continue;
            }
            ring.sort_by(f64::total_cmp);
            let bg = ring[ring.len() / 2];
            let mut peak = 0.0f64;
            for y in y0.max(0)..y1.min(h) {
                for x in x0.max(0)..x1.min(w) {
                    let d = px(x, y) - bg;
                    if d.abs() > peak.abs() {
                        peak = d;
                    }
                }
            }
            if peak > 0.0 {
                brighter += 1;
            } else {
                darker += 1;
            }
            contrasts.push(peak.abs());
        }
    }
    contrasts.sort_by(f64::total_cmp);
    let total = brighter + darker;
    println!(
        "{total} drones: {:.1} % brighter, {:.1} % darker than the ring around their box; median peak contrast {:.1} levels",
        100.0 * f64::from(brighter) / f64::from(total.max(1)),
        100.0 * f64::from(darker) / f64::from(total.max(1)),
        contrasts.get(contrasts.len() / 2).copied().unwrap_or(0.0)
    );
}
