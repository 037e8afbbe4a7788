//! `swarmshot batch --labels-only`: the plan, every label from geometry, no
//! rendering and no GPU.

use swarmshot::pipeline::FramePipeline;

use super::args::{BatchArgs, MAX_THREADS};
use super::console::{
    frames_and_boxes, frames_bar, print_warnings, shell_word, stop_on_signals, stopped,
};

/// `batch --labels-only`: the plan, from geometry alone.
pub(crate) fn run(args: BatchArgs) -> anyhow::Result<()> {
    let (preset, timings) = (&args.preset, args.timings);
    let options = swarmshot::pipeline::PlanOptions {
        out_dir: args.out,
        limit: args.limit,
        overwrite: args.overwrite,
        resume: args.resume,
        threads: args.threads,
    };
    if options.limit == Some(0) {
        anyhow::bail!("--limit 0: the plan would hold no frame; give at least 1");
    }
    if options.threads > MAX_THREADS {
        anyhow::bail!(
            "--threads {}: at most {MAX_THREADS} planning threads (0: one per core)",
            options.threads
        );
    }
    let pipeline = FramePipeline::open(preset)?;
    print_warnings(&pipeline);
    let count = pipeline.frame_count();
    let bar = frames_bar(options.limit.map_or(count, |n| n.min(count)))?;
    let cancel = stop_on_signals()?;
    let report = swarmshot::pipeline::run_plan(&pipeline, &options, &cancel, |p| {
        bar.set_length(p.total);
        bar.set_position(p.done);
        bar.set_message(format!("{:.0} frames/s", p.images_per_s()));
    })?;
    bar.finish();
    let s = &report.stats;
    if report.cancelled {
        return Err(stopped(
            s.frames,
            bar.length().unwrap_or(0),
            &format!(
                "swarmshot batch {} --out {} --labels-only --resume",
                shell_word(preset),
                shell_word(&report.out_dir)
            ),
        ));
    }
    if report.planned == 0 {
        println!(
            "already complete: {} in {}; nothing planned (labels only: no images, no data.yaml)",
            frames_and_boxes(s),
            report.out_dir.display()
        );
    } else {
        println!(
            "planned {} to {} in {:.2} s ({:.0} frames/s), labels only: no images, no data.yaml",
            frames_and_boxes(s),
            report.out_dir.display(),
            report.elapsed.as_secs_f64(),
            report.frames_per_s(),
        );
    }
    if report.estimated {
        println!(
            "note: the preset asks for Visible boxes or visibility filters, which need pixels: these boxes are ESTIMATES (amodal boxes within the image, no visibility filter); a rendered run's differ on partly hidden drones"
        );
    }
    if timings {
        println!(
            "{:.1} µs per frame of wall time",
            report.elapsed.as_secs_f64() * 1e6 / report.planned.max(1) as f64
        );
    }
    Ok(())
}
