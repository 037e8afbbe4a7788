//! What `output.masks` adds to a frame's time (a measurement, not a test):
//! the quickstart's frames made with masks off and on, interleaved frame by
//! frame so both see the same machine load, each the best of three tries
//! (a shared machine's load only ever adds time), timed through make (render,
//! labels, pixel hits, masks, depth) + image encode + masks encode (RLE,
//! contours, PNGs); disk writes are left out (see docs/conventions.md,
//! "Masks and maps").
//!
//! Then, on the all-four frames, the depth map and each output's encode
//! timed alone (best of three each).
//!
//! Run: `cargo run --release --example masks_cost -- [PRESET] [FRAMES]`
//! (defaults: presets/quickstart.ron, 108; the dataset's frames are not written).
#![allow(clippy::unwrap_used)]

use std::time::{Duration, Instant};

use swarmshot::pipeline::FramePipeline;
use swarmshot::preset::Preset;
use swarmshot::preset::masks::MaskOutputs;
use swarmshot::render::GpuContext;

fn main() -> anyhow::Result<()> {
    let mut args = std::env::args().skip(1);
    let path = args
        .next()
        .unwrap_or_else(|| "presets/quickstart.ron".into());
    let frames: u64 = args.next().map_or(108, |n| n.parse().unwrap());
    let base = Preset::open(std::path::Path::new(&path))?;
    let variants = [
        ("off", MaskOutputs::default()),
        (
            "coco_rle",
            MaskOutputs {
                coco_rle: true,
                ..MaskOutputs::default()
            },
        ),
        (
            "all",
            MaskOutputs {
                coco_rle: true,
                yolo_seg: true,
                instance_png: true,
                depth: true,
                ..MaskOutputs::default()
            },
        ),
    ];
    let ctx = GpuContext::headless()?;
    let mut runs = Vec::new();
    for (name, masks) in variants {
        let mut p = base.clone();
        p.output.masks = masks;
        let pipeline = FramePipeline::new(p)?;
        let renderer = pipeline.renderer(&ctx);
        runs.push((name, pipeline, renderer, Vec::<Duration>::new()));
    }
    let frames = frames.min(runs[0].1.frame_count());
    for index in 0..frames {
        for (_, _, _, times) in &mut runs {
            times.push(Duration::MAX);
        }
        // Each try starts with another variant: no variant always runs first.
        for rotate in 0..3 {
            runs.rotate_left(usize::from(rotate > 0));
            for (_, pipeline, renderer, times) in &mut runs {
                let t = Instant::now();
                let frame = pipeline.make(renderer, index)?;
                let (w, h) = (frame.scene.camera.width, frame.scene.camera.height);
                let format = pipeline.image_format(&frame.scene);
                let image = swarmshot::write::encode_image(&frame.rgba, w, h, format)?;
                if let Some(m) = &frame.masks {
                    let outputs = &pipeline.preset().output.masks;
                    swarmshot::write::formats::masks::encode(m, &frame.labels, outputs)?;
                }
                let best = times.last_mut().unwrap();
                *best = (*best).min(t.elapsed());
                std::hint::black_box(image);
                renderer.recycle(frame.rgba, frame.painted);
            }
        }
    }
    runs.sort_by_key(|r| match r.0 {
        "off" => 0,
        "coco_rle" => 1,
        _ => 2,
    });
    // Mean over the frames (the first warms up): the batch's time per frame.
    let median = |t: &[Duration]| {
        t[1..].iter().map(Duration::as_secs_f64).sum::<f64>() * 1e3 / (t.len() - 1) as f64
    };
    let off = median(&runs[0].3);
    println!("{frames} frames of {path} on {}", ctx.describe());
    for (name, _, _, times) in &runs {
        let m = median(times);
        println!(
            "masks {name:>8}: mean of best-of-3 {m:6.2} ms per frame ({:+.1} %)",
            (m / off - 1.0) * 100.0
        );
    }
    // Where the all-four share goes: each output's encode and the depth map
    // alone, on the "all" variant's frames (best of three, mean over the frames).
    let (_, pipeline, renderer, _) = runs.iter_mut().find(|r| r.0 == "all").unwrap();
    let only = |f: fn(&mut MaskOutputs)| {
        let mut m = MaskOutputs::default();
        f(&mut m);
        m
    };
    let parts: [(&str, MaskOutputs); 4] = [
        ("coco_rle", only(|m| m.coco_rle = true)),
        ("yolo_seg", only(|m| m.yolo_seg = true)),
        ("instance_png", only(|m| m.instance_png = true)),
        ("depth_png", only(|m| m.depth = true)),
    ];
    let mut sums = [0.0f64; 5];
    for index in 1..frames {
        let frame = pipeline.make(renderer, index)?;
        let m = frame.masks.as_ref().unwrap();
        let best = |f: &mut dyn FnMut()| {
            (0..3)
                .map(|_| {
                    let t = Instant::now();
                    f();
                    t.elapsed().as_secs_f64() * 1e3
                })
                .fold(f64::INFINITY, f64::min)
        };
        let models = pipeline.assets().depth_meshes();
        sums[0] += best(&mut || {
            std::hint::black_box(swarmshot::annotate::depth::depth_m_of_meshes(
                &frame.scene,
                models,
                m,
            ));
        });
        for (k, (_, outputs)) in parts.iter().enumerate() {
            sums[k + 1] += best(&mut || {
                std::hint::black_box(swarmshot::write::formats::masks::encode(
                    m,
                    &frame.labels,
                    outputs,
                ))
                .unwrap();
            });
        }
        renderer.recycle(frame.rgba, frame.painted);
    }
    let n = (frames - 1).max(1) as f64;
    print!("parts of all (ms per frame): depth map {:.3}", sums[0] / n);
    for (k, (name, _)) in parts.iter().enumerate() {
        print!(", {name} {:.3}", sums[k + 1] / n);
    }
    println!();
    Ok(())
}
