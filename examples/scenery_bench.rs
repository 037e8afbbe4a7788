//! The near-field scenery's CPU raster (src/render/scenery.rs), alone: each
//! frame's clutter of a preset rasterised at the preset's sample count into
//! one recycled layer, as the renderer rasterises, the best of three tries
//! a frame (a shared machine's load only ever adds time); the sum, median
//! and slowest frame, and a BLAKE3 hash of every layer's colour, coverage
//! and depth, which two builds must share when a change claims the same
//! pixels. With `--cold`, each frame is rasterised once, after 64 MiB of
//! other memory was written: the layer out of the caches, as a batch finds
//! it after the rest of a frame's work.
//!
//! `cargo run --release --example scenery_bench -- [PRESET] [FRAMES] [--cold]`
//! (defaults: presets/bench/realistic_cluttered.ron, 60; docs/benchmarks.md,
//! "Realism stages").
#![allow(clippy::unwrap_used)]

use std::time::Instant;

use swarmshot::pipeline::FramePipeline;
use swarmshot::preset::Preset;
use swarmshot::render::scenery;

#[path = "support/timing.rs"]
#[allow(dead_code)]
mod timing;

fn main() -> anyhow::Result<()> {
    let cold = std::env::args().any(|a| a == "--cold");
    let mut args = std::env::args().skip(1).filter(|a| a != "--cold");
    let path = args
        .next()
        .unwrap_or_else(|| "presets/bench/realistic_cluttered.ron".into());
    let frames: u64 = args.next().map_or(60, |n| n.parse().unwrap());
    let preset = Preset::open(std::path::Path::new(&path))?;
    let samples = preset.render.msaa.max(1);
    let pipeline = FramePipeline::new(preset)?;
    let mut hash = blake3::Hasher::new();
    let (mut times, mut primitives) = (Vec::new(), 0usize);
    let mut scene_ms = 0.0;
    // One layer for every frame, as a renderer keeps it; unlit colours.
    let (mut layer, light) = (
        scenery::ClutterLayer::default(),
        scenery::SceneryLight::default(),
    );
    for index in 0..frames.min(pipeline.frame_count()) {
        let t = Instant::now();
        let scene = pipeline.scene(index)?;
        scene_ms += t.elapsed().as_secs_f64() * 1e3;
        primitives += scene.clutter.as_ref().map_or(0, |c| c.primitives.len());
        let mut best = f64::INFINITY;
        if cold {
            let mut other = vec![0u8; 64 << 20];
            for (i, b) in other.iter_mut().enumerate().step_by(64) {
                *b = i as u8;
            }
            std::hint::black_box(&other);
        }
        for _ in 0..if cold { 1 } else { 3 } {
            let t = Instant::now();
            scenery::rasterize_into(&scene, samples, &light, &mut layer);
            best = best.min(t.elapsed().as_secs_f64() * 1e3);
        }
        hash.update(layer.color.as_flattened());
        let depth: Vec<u8> = layer.depth.iter().flat_map(|d| d.to_le_bytes()).collect();
        hash.update(&depth);
        times.push(best);
    }
    let total: f64 = times.iter().sum();
    let slowest = times.iter().copied().fold(0.0, f64::max);
    println!(
        "{} frames, {primitives} primitives: {total:.1} ms in all, median {:.3} ms, slowest {slowest:.3} ms a frame",
        times.len(),
        timing::median(times),
    );
    println!("the frames' scenes (their clutter made with them): {scene_ms:.1} ms in all");
    println!("layers' hash {}", hash.finalize().to_hex());
    Ok(())
}
