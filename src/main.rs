//! The `swarmshot` command line: batch, check, frame, bench, assets, gallery,
//! and the desktop app (`swarmshot gui [PRESET]`, or `swarmshot` with no
//! arguments). Every command that makes frames goes through
//! [`swarmshot::pipeline::FramePipeline`].

use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

use anyhow::Context;
use clap::{Parser, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};

use swarmshot::pipeline::{BatchOptions, FramePipeline, run_batch};
use swarmshot::preset::Preset;
use swarmshot::preset::budget::human_bytes;
use swarmshot::render::GpuContext;
use swarmshot::tools::{bench, gallery};
use swarmshot::write::shard::Shard;

#[derive(Parser)]
#[command(
    name = "swarmshot",
    version,
    about = "Synthetic training data for UAV-swarm detection"
)]
struct Cli {
    /// With no subcommand, the desktop app opens.
    #[command(subcommand)]
    command: Option<Command>,
}

#[derive(Subcommand)]
enum Command {
    /// Open the desktop app (the default when no subcommand is given).
    Gui {
        /// A RON preset to open (default: the last session's preset).
        preset: Option<PathBuf>,
    },
    /// Render every frame of a preset into an image/label dataset.
    Batch {
        /// The RON preset.
        preset: PathBuf,
        /// Output folder (created if missing).
        #[arg(long)]
        out: PathBuf,
        /// Make only the first N frames.
        #[arg(long)]
        limit: Option<u64>,
        /// Delete an earlier run's own files in the folder and start again
        /// (files swarmshot did not write are kept). Also lets the batch write
        /// into a non-empty folder that holds no swarmshot run.
        #[arg(long, conflicts_with = "resume")]
        overwrite: bool,
        /// Continue an interrupted run in --out from its first incomplete
        /// frame (the preset must be the locked one; without --limit, the
        /// earlier run's frame count is kept). Rerunning the same command
        /// without --resume also continues it.
        #[arg(long)]
        resume: bool,
        /// Image encoder threads (default: one per spare core).
        #[arg(long, default_value_t = 0)]
        threads: usize,
        /// Frames made at once, each by its own renderer (default 1; more can help on a real GPU).
        #[arg(long, default_value_t = 0)]
        makers: usize,
        /// Print each stage's share of the time at the end.
        #[arg(long)]
        timings: bool,
        /// Plan only: every label from geometry, no rendering and no GPU;
        /// writes labels, COCO, manifest, stats and PLAN.txt but no images and
        /// no data.yaml (Visible boxes are estimated by amodal ones; see
        /// docs/datasets.md). --threads sets the planning threads.
        #[arg(long, conflicts_with = "makers")]
        labels_only: bool,
        /// Make only shard K of N (K from 0) of the frames, for `swarmshot
        /// merge` to join: K/N, or `auto` from a Slurm job array
        /// (SLURM_ARRAY_TASK_ID …), or `auto/N` in a Kubernetes Indexed Job
        /// (JOB_COMPLETION_INDEX). See docs/scale.md.
        #[arg(long, value_name = "K/N|auto|auto/N", conflicts_with = "labels_only")]
        shard: Option<String>,
    },
    /// Join the folders of `batch --shard K/N` runs into the dataset one
    /// process makes (images and labels hard-linked, COCO ids numbered on,
    /// manifests and statistics joined); run again after an interruption, it continues.
    Merge {
        /// Output folder for the merged dataset (created if missing).
        out: PathBuf,
        /// The shard folders, every shard 0..N-1 of one run, in any order.
        #[arg(required = true)]
        shards: Vec<PathBuf>,
        /// Delete an earlier run's own files in OUT and start again.
        #[arg(long)]
        overwrite: bool,
        /// Copy the shards' files instead of hard-linking them (later edits
        /// to a shard then cannot change the merged dataset).
        #[arg(long)]
        copy: bool,
    },
    /// Validate a preset and print what it will make.
    Check { preset: PathBuf },
    /// The paper's Table 2 for a dataset or labels-only plan (images,
    /// resolution, instances, UAVs per image, small/medium/large) with
    /// per-split, per-model, per-environment and per-distance breakdowns,
    /// read from its manifest; writes histogram PNGs.
    Stats {
        /// The dataset folder (`swarmshot batch --out`, with or without --labels-only).
        dir: PathBuf,
        /// Where the histogram PNGs go (default: DIR/stats-plots).
        #[arg(long)]
        plots: Option<PathBuf>,
        /// Print the statistics as JSON (the numbers of the batch's stats.json) instead.
        #[arg(long)]
        json: bool,
    },
    /// Make one frame alone, exactly as the batch writes it: the image (the
    /// preset's format and quality), its YOLO labels (.txt) and its manifest record (.json).
    Frame {
        preset: PathBuf,
        /// Frame index (0-based).
        #[arg(long, default_value_t = 0)]
        index: u64,
        /// Output image; its extension must match the preset's image format
        /// (.jpg for JPEG, .png for PNG). The labels go beside it.
        #[arg(long)]
        out: PathBuf,
        /// Draw the label boxes on the image (the image then differs from the batch's).
        #[arg(long)]
        overlay: bool,
    },
    /// The domain-gap report: the same image statistics (noise, blur, gradients,
    /// edges, sky colour, brightness, drone size, contrast and polarity, JPEG quality)
    /// on a folder of real frames and on a swarmshot dataset, side by side with a verdict
    /// each and proposed camera-model ranges (docs/realism.md).
    Gap {
        /// Folder of real frames (JPEG/PNG; YOLO labels in a sibling labels/ or beside them).
        #[arg(long)]
        real: PathBuf,
        /// A swarmshot dataset folder (`swarmshot batch --out`).
        #[arg(long)]
        synthetic: PathBuf,
        /// Write report.json, report.txt and histogram PNGs here (created if missing).
        #[arg(long)]
        out: Option<PathBuf>,
        /// At most N frames per side, evenly spaced in name order (0: all).
        #[arg(long, default_value_t = 200)]
        max_images: usize,
        /// Print the report as JSON instead of the table.
        #[arg(long)]
        json: bool,
    },
    /// Benchmarks that produce the tables in docs/ (run a release build).
    Bench {
        #[command(subcommand)]
        which: BenchCommand,
    },
    /// Regenerate the built-in models into assets/models/.
    Assets {
        #[arg(long, default_value = "assets/models")]
        dir: PathBuf,
    },
    /// Render the built-in models' contact sheet and one frame per named environment.
    Gallery {
        /// Output folder for models.png, confusers.png and env-NAME.jpg.
        #[arg(long, default_value = "docs/img")]
        out: PathBuf,
        /// Environment frame size.
        #[arg(long, default_value_t = 480)]
        width: u32,
        #[arg(long, default_value_t = 270)]
        height: u32,
        /// Instead of pictures: median 1080p frame time, gradient sky vs each environment.
        #[arg(long)]
        bench: bool,
    },
}

#[derive(Subcommand)]
enum BenchCommand {
    /// Label error of each box method against a 4× id-pass reference, next to run time;
    /// then frame time by resolution × MSAA × passes on the quickstart scene.
    Accuracy {
        /// Frames per scene family.
        #[arg(long, default_value_t = 12)]
        frames: u32,
        #[arg(long, default_value_t = 960)]
        width: u32,
        #[arg(long, default_value_t = 540)]
        height: u32,
        /// Where to write the error-against-time plot (PNG).
        #[arg(long, default_value = "docs/img/accuracy.png")]
        plot: PathBuf,
        /// Frames timed per resolution × MSAA × passes cell.
        #[arg(long, default_value_t = 9)]
        timing_frames: u64,
    },
    /// Median ms per frame (render + labels, no encode) and peak RSS: 15 drones
    /// at 1080p and 4K, 1 500 drones at 1080p, and the peer scene.
    Frames {
        /// At most this many frames per scene (default: every frame of the
        /// 15-drone and peer scenes, 12 of the 1 500-drone one); the first,
        /// which builds pipelines, is left out of the median.
        #[arg(long)]
        frames: Option<u64>,
        /// The peer scene's preset (skipped when its files are missing).
        #[arg(long, default_value = "presets/bench/peer.ron")]
        peer: PathBuf,
        /// Time only the scenes whose name contains this text (e.g. "1 500", "3840", "peer").
        #[arg(long)]
        scene: Option<String>,
    },
}

/// The most image encoder threads `--threads` accepts.
const MAX_THREADS: usize = 256;

fn main() -> std::process::ExitCode {
    // A panic the glTF loader catches becomes its typed error; nothing else is printed for it.
    let default_hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        if !swarmshot::model::in_guarded_load() {
            default_hook(info);
        }
    }));
    match run() {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            // `{:#}`: the message and its causes on one line, never a backtrace
            // (RUST_BACKTRACE is for bugs, not for a user's typo).
            eprintln!(
                "error: {}",
                swarmshot::preset::text::for_terminal(&one_line(&e))
            );
            std::process::ExitCode::FAILURE
        }
    }
}

/// The error and its causes on one line, each cause added only when the
/// message does not already quote it (typed errors often include their source).
fn one_line(e: &anyhow::Error) -> String {
    let mut line = String::new();
    for cause in e.chain() {
        let text = cause.to_string();
        if line.is_empty() {
            line = text;
        } else if !line.contains(&text) {
            line = format!("{line}: {text}");
        }
    }
    line
}

fn run() -> anyhow::Result<()> {
    let Some(command) = Cli::parse().command else {
        return gui(None);
    };
    if !matches!(command, Command::Gui { .. }) {
        // SAFETY: still one thread: nothing has been spawned before this point.
        #[allow(unsafe_code)]
        unsafe {
            swarmshot::render::quiet_headless_vulkan()
        };
    }
    match command {
        Command::Gui { preset } => gui(preset),
        Command::Batch {
            preset,
            out,
            limit,
            overwrite,
            resume,
            threads,
            makers: _,
            timings,
            labels_only: true,
            shard: _,
        } => plan(
            &preset,
            swarmshot::pipeline::PlanOptions {
                out_dir: out,
                limit,
                overwrite,
                resume,
                threads,
            },
            timings,
        ),
        Command::Batch {
            preset,
            out,
            limit,
            overwrite,
            resume,
            threads,
            makers,
            timings,
            shard,
            labels_only: false,
        } => batch(
            &preset,
            &shard,
            BatchOptions {
                out_dir: out,
                limit,
                overwrite,
                resume,
                encoder_threads: threads,
                makers,
                shard: shard
                    .as_deref()
                    .map(|s| Shard::parse(s, |name| std::env::var(name).ok()))
                    .transpose()?,
                every: None,
            },
            timings,
        ),
        Command::Merge {
            out,
            shards,
            overwrite,
            copy,
        } => merge(&out, &shards, overwrite, copy),
        Command::Check { preset } => check(&preset),
        Command::Stats { dir, plots, json } => stats(&dir, plots, json),
        Command::Gap {
            real,
            synthetic,
            out,
            max_images,
            json,
        } => gap(real, synthetic, out.as_deref(), max_images, json),
        Command::Frame {
            preset,
            index,
            out,
            overlay,
        } => frame(&preset, index, &out, overlay),
        Command::Bench {
            which:
                BenchCommand::Accuracy {
                    frames,
                    width,
                    height,
                    plot,
                    timing_frames,
                },
        } => bench_accuracy(frames, (width, height), &plot, timing_frames),
        Command::Bench {
            which:
                BenchCommand::Frames {
                    frames,
                    peer,
                    scene,
                },
        } => bench_frames(frames, &peer, scene.as_deref()),
        Command::Gallery { bench: true, .. } => gallery_bench(),
        Command::Gallery {
            out, width, height, ..
        } => gallery_pictures(&out, width, height),
        Command::Assets { dir } => assets(&dir),
    }
}

/// The desktop app, when this binary was built with it (the `app` feature, on by default).
#[cfg(feature = "app")]
fn gui(preset: Option<PathBuf>) -> anyhow::Result<()> {
    swarmshot::app::run_or_exit(preset);
    Ok(())
}

/// A headless build (`--no-default-features`) has no desktop app.
#[cfg(not(feature = "app"))]
fn gui(_preset: Option<PathBuf>) -> anyhow::Result<()> {
    anyhow::bail!(
        "this swarmshot was built without the desktop app (cargo build --no-default-features, for cluster nodes); `swarmshot gui` needs a build with the default features. The batch, check, frame, merge and bench commands are all here: see swarmshot --help"
    )
}

/// Refuse what the adapter cannot do before anything is written; print the preset's warnings.
fn device_check(pipeline: &FramePipeline, ctx: &GpuContext) -> anyhow::Result<()> {
    let limits = swarmshot::preset::DeviceLimits {
        max_texture_side: ctx.max_texture_side,
        max_buffer_bytes: ctx.device.limits().max_buffer_size,
        // A frame may use three quarters of what is free; the rest is the encoders' and the system's.
        memory_bytes: available_memory_bytes().map(|b| b / 4 * 3),
    };
    pipeline.preset().check_limits(&limits).map_err(|errors| {
        let list: Vec<String> = errors.iter().map(|e| format!("  - {e}")).collect();
        anyhow::anyhow!(
            "the preset asks more than {} can do:\n{}",
            ctx.describe(),
            list.join("\n")
        )
    })
}

/// `MemAvailable` from /proc/meminfo (Linux), in bytes.
fn available_memory_bytes() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    kib.checked_mul(1024)
}

/// Print the preset's warnings (overlapping drones and the like) to stderr.
fn print_warnings(pipeline: &FramePipeline) {
    for w in pipeline.preset().warnings() {
        eprintln!(
            "warning: {}",
            swarmshot::preset::text::for_terminal(&w.to_string())
        );
    }
}

/// The progress bar of a batch or plan of `limit` frames (all when None).
fn frames_bar(pipeline: &FramePipeline, limit: Option<u64>) -> anyhow::Result<ProgressBar> {
    let total = limit.map_or(pipeline.frame_count(), |n| n.min(pipeline.frame_count()));
    let bar = ProgressBar::new(total);
    bar.set_style(
        ProgressStyle::with_template("{bar:40.cyan/blue} {pos}/{len} frames  {msg}  ETA {eta}")
            .context("progress template")?,
    );
    Ok(bar)
}

/// "N frames (train / val / test), B boxes (small / medium / large)" of a finished run.
fn frames_and_boxes(s: &swarmshot::write::DatasetStats) -> String {
    format!(
        "{} frames ({} train / {} val / {} test), {} boxes (small {} / medium {} / large {})",
        s.frames,
        s.frames_per_split[0],
        s.frames_per_split[1],
        s.frames_per_split[2],
        s.boxes,
        s.small,
        s.medium,
        s.large,
    )
}

/// A flag set by the first SIGINT or SIGTERM: the batch stops between frames
/// (docs/reliability.md, "Clean stop"); a second signal ends the process at once.
fn stop_on_signals() -> anyhow::Result<std::sync::Arc<AtomicBool>> {
    use signal_hook::consts::{SIGINT, SIGTERM};
    let flag = std::sync::Arc::new(AtomicBool::new(false));
    for signal in [SIGINT, SIGTERM] {
        // Registered first, so it sees the flag as the earlier signal left it.
        signal_hook::flag::register_conditional_shutdown(signal, 1, flag.clone())
            .context("installing the signal handler")?;
        signal_hook::flag::register(signal, flag.clone())
            .context("installing the signal handler")?;
    }
    Ok(flag)
}

/// The refusal after a clean stop: what is complete and how to continue.
fn stopped(done: u64, total: u64, resume: &str) -> anyhow::Error {
    anyhow::anyhow!(
        "stopped by SIGINT/SIGTERM after {done} of {total} frames: every frame before it is complete and checkpointed, nothing half-written is left; continue with: {resume}"
    )
}

fn batch(
    preset: &Path,
    shard_arg: &Option<String>,
    options: BatchOptions,
    timings: bool,
) -> anyhow::Result<()> {
    if options.limit == Some(0) {
        anyhow::bail!("--limit 0: the batch would make no frame; give at least 1");
    }
    if options.encoder_threads > MAX_THREADS {
        anyhow::bail!(
            "--threads {}: at most {MAX_THREADS} encoder threads (0: one per spare core)",
            options.encoder_threads
        );
    }
    let pipeline = FramePipeline::open(preset)?;
    print_warnings(&pipeline);
    pipeline
        .preset()
        .check_render_budget()
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    let frames = frames_of_run(&pipeline, &options);
    if frames == 0 {
        eprintln!(
            "warning: --shard {}/{}: this shard holds no frame of the {} there are (more shards than frames); it writes an empty dataset",
            options.shard.map_or(0, |s| s.index),
            options.shard.map_or(1, |s| s.count),
            pipeline.frame_count()
        );
    }
    print_empty_splits(pipeline.preset(), frames, &mut std::io::stderr());
    if !options.resume {
        check_free_space(&pipeline, &options.out_dir, frames)?;
    }
    let ctx = GpuContext::headless()?;
    device_check(&pipeline, &ctx)?;
    let bar = frames_bar(&pipeline, options.limit)?;
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
                preset.display(),
                report.out_dir.display()
            ),
        ));
    }
    println!(
        "wrote {} to {} in {:.1} s ({:.2} images/s) on {}",
        frames_and_boxes(s),
        report.out_dir.display(),
        report.elapsed.as_secs_f64(),
        s.frames as f64 / report.elapsed.as_secs_f64().max(1e-9),
        ctx.describe()
    );
    if timings {
        println!("{}", report.times.describe(s.frames, report.elapsed));
    }
    Ok(())
}

/// The frames this run makes: `--limit` of them, of its shard with `--shard`.
fn frames_of_run(pipeline: &FramePipeline, options: &BatchOptions) -> u64 {
    let count = options
        .limit
        .map_or(pipeline.frame_count(), |n| n.min(pipeline.frame_count()));
    match options.shard {
        Some(shard) => {
            let unit = pipeline.preset().sequence_len().max(1);
            let r = shard.range(count, unit);
            r.end.saturating_sub(r.start)
        }
        None => count,
    }
}

/// A warning for each split that gets no frame (counted for presets whose
/// frames draw their split one by one; grouped splits warn in `warnings`).
fn print_empty_splits(preset: &Preset, frames: u64, out: &mut dyn std::io::Write) {
    // Exact in O(100) whatever the count (`frame_split_counts`).
    const MAX_DRAWS: u64 = u64::MAX;
    let Some(counts) = swarmshot::scene::split::frame_split_counts(preset, frames, MAX_DRAWS)
    else {
        return;
    };
    let s = &preset.output.split;
    for ((name, n), share) in ["train", "val", "test"]
        .into_iter()
        .zip(counts)
        .zip([s.train, s.val, s.test])
    {
        if n == 0 && share > 0.0 && frames > 0 {
            let _ = writeln!(
                out,
                "warning: output.split.{name}: {share} of the frames, but the split draw gives it none of these {frames} ({} train / {} val / {} test); {}",
                counts[0],
                counts[1],
                counts[2],
                if name == "val" {
                    "data.yaml then names the train images as val; change the seed or the shares, or make more frames"
                } else {
                    "change the seed or the shares, or make more frames"
                }
            );
        }
    }
}

/// Refuse, before anything is written, a run whose estimated size is
/// more than the free space of the filesystem holding `out`.
fn check_free_space(pipeline: &FramePipeline, out: &Path, frames: u64) -> anyhow::Result<()> {
    let preset = pipeline.preset();
    let drones = match &preset.placement {
        swarmshot::preset::Placement::Randomized {
            count: (lo, hi),
            count_distribution,
            volume,
            ..
        } if !matches!(volume, swarmshot::preset::Volume::DensitySweep { .. }) => {
            swarmshot::scene::placement::count_mean(*lo, *hi, count_distribution)
        }
        _ => preset.max_drones_per_frame() as f64,
    };
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

/// `batch --labels-only`: the plan, from geometry alone.
fn plan(
    preset: &Path,
    options: swarmshot::pipeline::PlanOptions,
    timings: bool,
) -> anyhow::Result<()> {
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
    let bar = frames_bar(&pipeline, options.limit)?;
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
                preset.display(),
                report.out_dir.display()
            ),
        ));
    }
    println!(
        "planned {} to {} in {:.2} s ({:.0} frames/s), labels only: no images, no data.yaml",
        frames_and_boxes(s),
        report.out_dir.display(),
        report.elapsed.as_secs_f64(),
        report.frames_per_s(),
    );
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

fn stats(dir: &Path, plots: Option<PathBuf>, json: bool) -> anyhow::Result<()> {
    let stats = swarmshot::write::stats::read_dataset(dir)?;
    if json {
        println!("{}", serde_json::to_string_pretty(&stats)?);
        return Ok(());
    }
    println!(
        "{} ({})",
        dir.display(),
        if stats.labels_only {
            "labels-only plan: no images"
        } else {
            "rendered dataset"
        }
    );
    println!("boxes: {}", stats.boxes_from);
    print!("{}", stats.table());
    let plots = plots.unwrap_or_else(|| dir.join("stats-plots"));
    for path in swarmshot::write::stats::write_histograms(&stats, &plots)? {
        println!("wrote {}", path.display());
    }
    Ok(())
}

fn gap(
    real: PathBuf,
    synthetic: PathBuf,
    out: Option<&Path>,
    max_images: usize,
    json: bool,
) -> anyhow::Result<()> {
    let report = swarmshot::gap::run_report(&swarmshot::gap::GapOptions {
        real,
        synthetic,
        max_images,
    })?;
    if json {
        println!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        print!("{}", report.table());
    }
    if let Some(out) = out {
        for path in report.write(out)? {
            eprintln!("wrote {}", path.display());
        }
    }
    Ok(())
}

fn merge(out: &Path, shards: &[PathBuf], overwrite: bool, copy: bool) -> anyhow::Result<()> {
    let t = std::time::Instant::now();
    let r = swarmshot::write::merge::merge(out, shards, overwrite, copy)?;
    let s = &r.stats;
    let before = if r.shards_before > 0 {
        format!(
            " ({} joined by an earlier, interrupted merge)",
            r.shards_before
        )
    } else {
        String::new()
    };
    println!(
        "merged {} shards{before} into {}: {} frames ({} train / {} val / {} test), {} boxes; {} files hard-linked, {} copied, in {:.1} s",
        r.shards,
        out.display(),
        s.frames,
        s.frames_per_split[0],
        s.frames_per_split[1],
        s.frames_per_split[2],
        s.boxes,
        r.linked,
        r.copied,
        t.elapsed().as_secs_f64()
    );
    Ok(())
}

fn check(path: &Path) -> anyhow::Result<()> {
    let pipeline = FramePipeline::open(path)?;
    let preset = pipeline.preset();
    let (w, h) = preset.image_size();
    // Everything the batch loads (models, sky images) is loaded above; the
    // adapter's limits are checked here too when one is found.
    match GpuContext::headless() {
        Ok(ctx) => device_check(&pipeline, &ctx)?,
        Err(e) => eprintln!("warning: {e:#}; the adapter's limits were not checked"),
    }
    println!(
        "preset {} is valid",
        swarmshot::preset::printable(&path.display().to_string())
    );
    for w in preset.warnings() {
        println!(
            "warning: {}",
            swarmshot::preset::text::for_terminal(&w.to_string())
        );
    }
    println!("frames: {}", pipeline.frame_count());
    if let Some(groups) = swarmshot::scene::split::groups(preset) {
        let [train, val, test] = swarmshot::scene::split::group_counts(preset, groups);
        println!(
            "split by {:?}: {groups} groups, {train} train / {val} val / {test} test",
            preset.output.split.by
        );
    }
    println!(
        "image: {w}×{h}, {:?}, MSAA {}",
        preset.output.image_format, preset.render.msaa
    );
    println!(
        "placement: {}",
        swarmshot::scene::placement::describe(preset)
    );
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
    // Geometry only (no rendering): amodal boxes stand in for visible ones,
    // from as many first frames as fit the sampling budget.
    let sample = preset.check_sample_frames();
    if sample == 0 && pipeline.frame_count() > 0 {
        println!(
            "estimate skipped: a frame holds up to {} drones, more than the {} drones `check` samples",
            preset.max_drones_per_frame(),
            swarmshot::preset::budget::CHECK_SAMPLE_DRONES
        );
    }
    let mut stats = swarmshot::write::DatasetStats::default();
    let started = std::time::Instant::now();
    for i in 0..sample {
        let scene = pipeline.scene(i)?;
        stats.add(
            &scene,
            &pipeline.estimate_labels(&scene),
            pipeline.model_names(),
            pipeline.classes(),
        );
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
    let disk = preset.disk_estimate(pipeline.frame_count(), drones_per_frame);
    println!(
        "disk: about {} for {} frames ({} images, {} labels, {} ledger; typical sizes measured on the quickstart, docs/reliability.md)",
        human_bytes(disk.total_bytes()),
        disk.frames,
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
            println!("  warning: {}", swarmshot::preset::text::for_terminal(w));
        }
    }
    Ok(())
}

/// A batch of one: the image bytes the batch writes for frame `index`, its YOLO
/// label file and its manifest record, beside `out`.
fn frame(preset: &Path, index: u64, out: &Path, overlay: bool) -> anyhow::Result<()> {
    let pipeline = FramePipeline::open(preset)?;
    pipeline
        .preset()
        .check_render_budget()
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    let format = pipeline.preset().output.image_format;
    let ext = out
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    let accepted: &[&str] = match format {
        swarmshot::preset::ImageFormat::Jpeg { .. } => &["jpg", "jpeg"],
        swarmshot::preset::ImageFormat::Png => &["png"],
    };
    if !ext.as_deref().is_some_and(|e| accepted.contains(&e)) {
        anyhow::bail!(
            "--out {}: the preset writes {} images (output.image_format); name the file .{}",
            out.display(),
            format.extension().to_uppercase(),
            format.extension()
        );
    }
    if index >= pipeline.frame_count() {
        anyhow::bail!(
            "--index {index}: the preset has {} frames (0..{})",
            pipeline.frame_count(),
            pipeline.frame_count()
        );
    }
    print_warnings(&pipeline);
    let ctx = GpuContext::headless()?;
    device_check(&pipeline, &ctx)?;
    let mut renderer = pipeline.renderer(&ctx);
    let mut frame = pipeline.make(&mut renderer, index)?;
    let (w, h) = (frame.scene.camera.width, frame.scene.camera.height);
    if overlay {
        swarmshot::annotate::overlay::draw_overlay(&mut frame.rgba, w, h, &frame.labels);
    }
    let format = pipeline.image_format(&frame.scene);
    let bytes = swarmshot::write::encode_image(&frame.rgba, w, h, format)?;
    let record = swarmshot::write::manifest_line(
        &frame.scene,
        &frame.labels,
        &swarmshot::write::image_rel_path(&frame.scene, format),
        pipeline.model_names(),
        pipeline.classes(),
    );
    let labels = swarmshot::write::yolo::label_text(&frame.scene, &frame.labels);
    let (txt, json) = (out.with_extension("txt"), out.with_extension("json"));
    swarmshot::write::write_atomic(out, &bytes)?;
    swarmshot::write::write_atomic(&txt, labels.as_bytes())?;
    swarmshot::write::write_atomic(&json, format!("{record}\n").as_bytes())?;
    println!(
        "frame {index} ({} split): {} drones{}, {} boxes -> {} (+ {}, {})",
        frame.scene.split.as_str(),
        frame.scene.drone_count(),
        match frame.scene.confusers.len() {
            0 => String::new(),
            n => format!(" and {n} confusers"),
        },
        frame.labels.iter().filter(|l| l.is_kept()).count(),
        out.display(),
        txt.display(),
        json.display()
    );
    Ok(())
}

fn bench_accuracy(
    frames: u32,
    (width, height): (u32, u32),
    plot: &Path,
    timing_frames: u64,
) -> anyhow::Result<()> {
    let ctx = GpuContext::headless()?;
    eprintln!("adapter: {}", ctx.describe());
    let acc = bench::accuracy(&ctx, frames, width, height)?;
    let quickstart = FramePipeline::open(Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/presets/quickstart.ron"
    )))?;
    let timing = bench::timings(&ctx, quickstart.preset(), timing_frames)?;
    print!("{}", bench::markdown(&acc, &timing));
    if let Some(dir) = plot.parent() {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    bench::plot(&acc, plot)?;
    eprintln!("plot written to {}", plot.display());
    Ok(())
}

fn bench_frames(frames: Option<u64>, peer: &Path, only: Option<&str>) -> anyhow::Result<()> {
    let ctx = GpuContext::headless()?;
    eprintln!("adapter: {}", ctx.describe());
    // Presets only: each scene's pipeline (and its models' levels of detail)
    // is built by `bench::frames`, so a scene left out by --scene costs nothing.
    let quickstart = Preset::open(Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/presets/quickstart.ron"
    )))?;
    let peer = match Preset::open(peer) {
        Ok(p) => Some(p),
        Err(e) => {
            eprintln!("peer scene skipped: {e:#}");
            None
        }
    };
    let mut scenes = bench::frame_scenes(&quickstart, peer);
    if let Some(only) = only {
        scenes.retain(|(name, ..)| name.contains(only));
        anyhow::ensure!(!scenes.is_empty(), "--scene {only:?} matches no scene");
    }
    let rows = bench::frames(&ctx, scenes, frames)?;
    print!("{}", bench::frames_markdown(&rows));
    Ok(())
}

fn gallery_bench() -> anyhow::Result<()> {
    let ctx = GpuContext::headless()?;
    let frames = 20;
    let gradient = gallery::environment_preset(swarmshot::preset::Sky::default(), 1920, 1080);
    println!(
        "1920x1080, MSAA 4, 8 drones, median of {frames} frames on {}",
        ctx.describe()
    );
    println!(
        "gradient sky: {:.1} ms",
        gallery::median_frame_ms(&ctx, &gradient, frames)?
    );
    for name in swarmshot::preset::EnvironmentName::ALL {
        let p = gallery::environment_preset(gallery::fixed_environment(name), 1920, 1080);
        println!(
            "{}: {:.1} ms",
            name.as_str(),
            gallery::median_frame_ms(&ctx, &p, frames)?
        );
    }
    Ok(())
}

fn gallery_pictures(out: &Path, width: u32, height: u32) -> anyhow::Result<()> {
    let ctx = GpuContext::headless()?;
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let sheet = gallery::model_contact_sheet(&ctx, 256, 4)?;
    let path = out.join("models.png");
    sheet
        .save(&path)
        .with_context(|| format!("writing {}", path.display()))?;
    println!("wrote {}", path.display());
    let sheet = swarmshot::tools::confuser_gallery::confuser_contact_sheet(&ctx, 160, 6)?;
    let path = out.join("confusers.png");
    sheet
        .save(&path)
        .with_context(|| format!("writing {}", path.display()))?;
    println!("wrote {}", path.display());
    for (name, rgba) in gallery::environment_frames(&ctx, width, height)? {
        let img = image::RgbaImage::from_raw(width, height, rgba).context("frame size")?;
        let path = out.join(format!("env-{}.jpg", name.as_str()));
        image::DynamicImage::ImageRgba8(img)
            .to_rgb8()
            .save(&path)
            .with_context(|| format!("writing {}", path.display()))?;
        println!("wrote {}", path.display());
    }
    for (name, rgba) in gallery::formation_frames(&ctx, width, height)? {
        let img = image::RgbaImage::from_raw(width, height, rgba).context("frame size")?;
        let path = out.join(format!("formation-{name}.jpg"));
        image::DynamicImage::ImageRgba8(img)
            .to_rgb8()
            .save(&path)
            .with_context(|| format!("writing {}", path.display()))?;
        println!("wrote {}", path.display());
    }
    let sequence = Preset::from_ron(include_str!("../presets/formation_sequence.ron"))
        .map_err(|e| anyhow::anyhow!("presets/formation_sequence.ron: {e}"))?;
    let strip = gallery::sequence_strip(&ctx, &sequence, 5, width / 2, height / 2)?;
    let path = out.join("sequence-strip.jpg");
    image::DynamicImage::ImageRgba8(strip)
        .to_rgb8()
        .save(&path)
        .with_context(|| format!("writing {}", path.display()))?;
    println!("wrote {}", path.display());
    Ok(())
}

fn assets(dir: &Path) -> anyhow::Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    for name in swarmshot::model::builtin::NAMES {
        let bytes = swarmshot::tools::assets::generate_glb(name).context("built-in generator")?;
        let path = dir.join(format!("{name}.glb"));
        std::fs::write(&path, &bytes).with_context(|| format!("writing {}", path.display()))?;
        println!("wrote {} ({} bytes)", path.display(), bytes.len());
    }
    for name in swarmshot::model::confusers::NAMES {
        let bytes =
            swarmshot::tools::confusers::generate_glb(name).context("confuser generator")?;
        let path = dir.join(format!("{name}.glb"));
        std::fs::write(&path, &bytes).with_context(|| format!("writing {}", path.display()))?;
        println!("wrote {} ({} bytes)", path.display(), bytes.len());
    }
    Ok(())
}
