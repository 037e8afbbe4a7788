//! `swarmshot check`: validate a preset and print what it will make.

use std::path::Path;

use swarmshot::pipeline::FramePipeline;
use swarmshot::preset::budget::human_bytes;
use swarmshot::render::GpuContext;

use super::console::print_empty_splits;
use super::gpu::device_check;

pub(crate) fn check(path: &Path) -> anyhow::Result<()> {
    let pipeline = FramePipeline::open(path)?;
    let preset = pipeline.preset();
    let (w, h) = preset.image_size();
    // Everything the batch loads (models, sky images) is loaded above; the
    // adapter's limits are checked here too when one is found.
    match GpuContext::headless() {
        Ok(ctx) => device_check(&pipeline, &ctx)?,
        Err(e) => eprintln!("warning: {e:#}; the adapter's limits were not checked"),
    }
    // A preset whose whole run keeps too few groups (sequences) whole: the batch refuses it.
    if let Some(e) = swarmshot::pipeline::check::run_split_error(preset, pipeline.frame_count(), 1)
    {
        anyhow::bail!("{e}");
    }
    println!(
        "preset {} is valid",
        swarmshot::preset::printable(&path.display().to_string())
    );
    for w in swarmshot::pipeline::check::warnings(preset) {
        println!("warning: {}", swarmshot::text::for_terminal(&w.to_string()));
    }
    println!("frames: {}", pipeline.frame_count());
    let summary = swarmshot::pipeline::check::summary(preset);
    if let Some((groups, [train, val, test])) = summary.split_groups {
        println!(
            "split by {:?}: {groups} groups, {train} train / {val} val / {test} test",
            preset.output.split.by
        );
    }
    println!(
        "image: {w}×{h}, {:?}, MSAA {}",
        preset.output.image_format, preset.render.msaa
    );
    println!("placement: {}", summary.placement);
    if let Some(seq) = &preset.sequence {
        let len = preset.sequence_len();
        println!(
            "sequences: {} of T + 1 = {len} frames ({:?} camera, {} fps), MOT ground truth in mot/",
            pipeline.frame_count() / len,
            seq.camera,
            seq.frame_rate
        );
    }
    if let Err(e) = preset.check_render_budget() {
        println!("warning: {e}; a rendered batch refuses this preset");
    }
    print_empty_splits(preset, pipeline.frame_count(), &mut std::io::stdout());
    let drones_per_frame = print_estimate(&pipeline)?;
    let disk = preset.disk_estimate(pipeline.frame_count(), drones_per_frame);
    println!(
        "disk: about {} for {} ({} images, {} labels, {} ledger; typical sizes measured on the quickstart, docs/reliability.md)",
        human_bytes(disk.total_bytes()),
        swarmshot::text::plural(disk.frames, "frame", "frames"),
        human_bytes(disk.image_bytes),
        human_bytes(disk.label_bytes),
        human_bytes(disk.ledger_bytes),
    );
    for (spec, model) in preset.models.iter().zip(&pipeline.assets().models) {
        println!(
            "model {}: {} triangles, {} hull vertices, size {} m, class {}",
            spec.source,
            model.indices.len() / 3,
            model.hull.len(),
            spec.size_m,
            swarmshot::preset::printable(&spec.class)
        );
        for w in &model.warnings {
            println!("  warning: {}", swarmshot::text::for_terminal(w));
        }
    }
    Ok(())
}

/// The geometry-only estimate from the first frames `check` samples: drones
/// and boxes per frame and their sizes. Returns the drones per frame (the
/// preset's most when no frame was sampled).
fn print_estimate(pipeline: &FramePipeline) -> anyhow::Result<f64> {
    let preset = pipeline.preset();
    // Geometry only (no rendering): amodal boxes stand in for visible ones,
    // from as many first frames as fit the sampling budget.
    let sample = preset.check_sample_frames();
    if sample == 0 && pipeline.frame_count() > 0 {
        println!(
            "estimate skipped: a frame holds up to {} drones and confusers, more than the {} `check` samples",
            preset.max_objects_per_frame(),
            swarmshot::preset::budget::CHECK_SAMPLE_DRONES
        );
    }
    let mut stats = swarmshot::write::DatasetStats::default();
    let started = std::time::Instant::now();
    let mut over_budget = false;
    for i in 0..sample {
        let scene = pipeline.scene(i)?;
        let labels = pipeline.estimate_labels(&scene);
        // The first frame a rendered batch would stop at: said now, not hours into a run.
        if !over_budget && let Err(e) = pipeline.check_budgets(&scene, &labels) {
            println!("warning: {e}; a rendered batch stops at this frame");
            over_budget = true;
        }
        stats.add(&scene, &labels, pipeline.model_names(), pipeline.classes());
        // Progress when the estimate takes more than a second.
        if started.elapsed().as_secs_f64() > 1.0 {
            eprint!("\restimating boxes: frame {}/{sample}", i + 1);
        }
    }
    if started.elapsed().as_secs_f64() > 1.0 {
        eprintln!();
    }
    let drones_per_frame = if sample > 0 {
        stats.drones_placed as f64 / sample as f64
    } else {
        preset.max_drones_per_frame() as f64
    };
    if sample > 0 {
        let share = |n: u64| 100.0 * n as f64 / stats.boxes.max(1) as f64;
        println!(
            "estimated from the first {sample} frames (geometry only): {:.2} drones and {:.2} boxes per frame; small {:.1} % / medium {:.1} % / large {:.1} % (√(w·h) < 32, 32–96, > 96 px)",
            stats.drones_placed as f64 / sample as f64,
            stats.boxes as f64 / sample as f64,
            share(stats.small),
            share(stats.medium),
            share(stats.large),
        );
        if stats.boxes == 0 {
            println!(
                "warning: none of the first {sample} frames would get a single box (drones too small, too far or out of view?)"
            );
        }
    }
    Ok(drones_per_frame)
}
