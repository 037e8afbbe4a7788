//! `swarmshot batch` (without --labels-only, which is `plan.rs`): every frame
//! of a preset rendered into a dataset, after the checks that refuse a run
//! before anything is written (frame and thread counts, the render budget,
//! free space, the adapter's limits).

use std::path::Path;

use swarmshot::pipeline::{BatchOptions, FramePipeline, run_batch};
use swarmshot::preset::budget::human_bytes;
use swarmshot::write::shard::Shard;

use super::args::{BatchArgs, MAX_MAKERS, MAX_THREADS};
use super::console::{
    frames_and_boxes, frames_bar, print_empty_splits, print_warnings, shell_word, stop_on_signals,
    stopped,
};
use super::gpu::{device_check, with_gpu_starting};

/// `swarmshot batch PRESET --out DIR …`: the options from the flags, then the run.
pub(crate) fn run(args: BatchArgs) -> anyhow::Result<()> {
    let options = BatchOptions {
        out_dir: args.out.clone(),
        limit: args.limit,
        overwrite: args.overwrite,
        resume: args.resume,
        encoder_threads: args.threads,
        makers: args.makers,
        shard: (args.shard.as_deref())
            .map(|s| Shard::parse(s, |name| std::env::var(name).ok()))
            .transpose()?,
        every: args.every,
    };
    batch(&args, options)
}

/// The run: refused before anything is written when it cannot be made, then
/// every frame through [`run_batch`] with a progress bar, stopped cleanly on a signal.
fn batch(args: &BatchArgs, options: BatchOptions) -> anyhow::Result<()> {
    let (preset, shard_arg, timings) = (&args.preset, &args.shard, args.timings);
    if options.limit == Some(0) {
        anyhow::bail!("--limit 0: the batch would make no frame; give at least 1");
    }
    if options.encoder_threads > MAX_THREADS {
        anyhow::bail!(
            "--threads {}: at most {MAX_THREADS} encoder threads (0: one per spare core)",
            options.encoder_threads
        );
    }
    super::process::check_open_files("batch")?;
    // Before the models load and fill the cache (`run_batch` checks again, for the app).
    swarmshot::pipeline::check_cache_apart(&options.out_dir)?;
    let ((pipeline, frames), ctx) = with_gpu_starting(|parsed| {
        let pipeline = FramePipeline::open_then(preset, parsed)?;
        print_warnings(&pipeline);
        pipeline
            .preset()
            .check_render_budget()
            .map_err(|e| anyhow::anyhow!("{e}"))?;
        let frames = frames_of_run(&pipeline, &options);
        if frames == 0 {
            let all = pipeline.frame_count();
            eprintln!(
                "warning: --shard {}/{}: this shard holds no frame of the {} there are (more shards than frames); it writes an empty dataset",
                options.shard.map_or(0, |s| s.index),
                options.shard.map_or(1, |s| s.count),
                options.limit.map_or(all, |limit| limit.min(all))
            );
        }
        check_makers(pipeline.preset(), options.makers, frames)?;
        print_empty_splits(pipeline.preset(), frames, &mut std::io::stderr());
        if !options.resume {
            check_free_space(&pipeline, &options.out_dir, frames)?;
        }
        Ok((pipeline, frames))
    })?;
    device_check(&pipeline, &ctx)?;
    let bar = frames_bar(frames)?;
    let cancel = stop_on_signals()?;
    let report = run_batch(&pipeline, &options, &ctx, &cancel, |p| {
        bar.set_length(p.total);
        bar.set_position(p.done);
        bar.set_message(format!("{:.1} images/s", p.images_per_s()));
    })?;
    bar.finish();
    let s = &report.stats;
    if report.cancelled {
        let shard = shard_arg
            .as_ref()
            .map_or(String::new(), |k| format!(" --shard {k}"));
        return Err(stopped(
            s.frames,
            bar.length().unwrap_or(0),
            &format!(
                "swarmshot batch {} --out {}{shard} --resume",
                shell_word(preset),
                shell_word(&report.out_dir)
            ),
        ));
    }
    if frames == 0 {
        // A shard that holds no frame (more shards than frames): a valid,
        // empty part for `merge`, not an earlier run found complete.
        println!(
            "wrote an empty dataset (this shard holds no frame) to {}",
            report.out_dir.display()
        );
    } else if report.already_complete() {
        // Nothing was rendered: no rate to give.
        println!(
            "already complete: {} in {}; nothing rendered",
            frames_and_boxes(s),
            report.out_dir.display()
        );
    } else {
        // A continued run's rate counts the frames it made, not the earlier run's.
        let continued = match report.resumed_at() {
            Some(at) => format!(", {} made from frame {at} on", report.made),
            None => String::new(),
        };
        println!(
            "wrote {} to {} in {:.1} s ({:.2} images/s{continued}) on {}",
            frames_and_boxes(s),
            report.out_dir.display(),
            report.elapsed.as_secs_f64(),
            report.images_per_s(),
            ctx.describe()
        );
    }
    if timings {
        println!("{}", report.times.describe(s.frames, report.elapsed));
    }
    Ok(())
}

/// The frames this run makes: `--limit` of them (of every Kth with
/// `--every K`), of its shard with `--shard`.
fn frames_of_run(pipeline: &FramePipeline, options: &BatchOptions) -> u64 {
    let count = swarmshot::pipeline::batch::frames_of(pipeline.frame_count(), options);
    match options.shard {
        Some(shard) => {
            let unit = pipeline.preset().sequence_len().max(1);
            let r = shard.range(count, unit);
            r.end.saturating_sub(r.start)
        }
        None => count,
    }
}

/// Refuse, before anything is written, more makers than [`MAX_MAKERS`], or
/// more than the memory holds: each maker renders with its own renderer,
/// so `makers` (at most the run's frames) need that many frames' memory
/// ([`swarmshot::preset::Preset::frame_memory_bytes`]) within three quarters
/// of what is free, as one frame does.
fn check_makers(
    preset: &swarmshot::preset::Preset,
    makers: usize,
    frames: u64,
) -> anyhow::Result<()> {
    if makers > MAX_MAKERS {
        anyhow::bail!(
            "--makers {makers}: at most {MAX_MAKERS} makers (each renders its frames with its own renderer; 0: the default)"
        );
    }
    let at_once = (makers as u64).min(frames);
    let (Some(per), Some(free)) = (
        preset.frame_memory_bytes(),
        swarmshot::preset::budget::usable_memory_bytes(),
    ) else {
        return Ok(());
    };
    let (needed, usable) = (per.saturating_mul(at_once), free);
    if at_once > 1 && needed > usable {
        anyhow::bail!(
            "--makers {makers}: each maker renders its own frame (about {} at this resolution), so {at_once} of them need {}, more than the {} a run may use (three quarters of the free memory, within the process's `ulimit -v` and `ulimit -d`); use fewer makers",
            human_bytes(per as f64),
            human_bytes(needed as f64),
            human_bytes(usable as f64),
        );
    }
    Ok(())
}

/// Refuse, before anything is written, a run whose estimated size is
/// more than the free space of the filesystem holding `out`.
fn check_free_space(pipeline: &FramePipeline, out: &Path, frames: u64) -> anyhow::Result<()> {
    let preset = pipeline.preset();
    let drones = swarmshot::pipeline::check::mean_drones_per_frame(preset);
    let disk = preset.disk_estimate(frames, drones);
    let Some(free) = swarmshot::preset::budget::free_bytes(out) else {
        return Ok(());
    };
    if disk.total_bytes() > free as f64 {
        anyhow::bail!(
            "--out {}: {frames} frames need about {} ({} images, {} labels, {} ledger), but the filesystem has {} free; free space, choose another folder, or make fewer frames (--limit, --shard)",
            out.display(),
            human_bytes(disk.total_bytes()),
            human_bytes(disk.image_bytes),
            human_bytes(disk.label_bytes),
            human_bytes(disk.ledger_bytes),
            human_bytes(free as f64),
        );
    }
    Ok(())
}
