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
use swarmshot::write::shard::Shard;

mod cli;
use cli::tools::{
    assets, bench_accuracy, bench_frames, gallery_bench, gallery_pictures, gap, merge, stats,
};

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
        /// Make only the first N frames (with --every: the first N of those).
        #[arg(long)]
        limit: Option<u64>,
        /// A trial of every Kth frame: frames 0, K, 2K, … with their own
        /// indices and names, each byte-identical to the full run's frame of
        /// that index. --resume (or the same command again) continues the
        /// trial; --resume without --every keeps the earlier trial's K; a
        /// different K or --limit on the same folder is refused (--overwrite
        /// starts again). Not with --shard, --labels-only or sequence presets.
        #[arg(long, value_name = "K", conflicts_with = "labels_only")]
        every: Option<u64>,
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
        /// Frames made at once, each by its own renderer (default: 1 when frames share a background; when every frame draws a new one, 2 on a software rasteriser and 3/4 of the cores, at most 12, on a GPU).
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
    /// preset's format and quality), its YOLO labels (.txt), its manifest
    /// record (.json) and the masks output.masks asks for (.seg.txt,
    /// .mask.png, .depth.png).
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
    /// Fit a preset to your own footage: the frames become backplates (labelled
    /// drones removed), the camera and the drones' size are fitted, and rounds of
    /// render → gap report → adjust run until the report puts the dataset inside the
    /// footage's range (docs/realism.md, "Fitting to your footage").
    Fit {
        /// A folder of real frames (JPEG/PNG; YOLO labels in a sibling labels/ or
        /// beside them), or a video file (decoded by ffmpeg from PATH).
        #[arg(long)]
        real: PathBuf,
        /// Output folder: plates/, fitted.ron, footage.json, fit.json, rounds/NN/.
        #[arg(long)]
        out: PathBuf,
        /// The preset the fit starts from.
        #[arg(long, default_value = "presets/realistic.ron")]
        base: PathBuf,
        /// Frames rendered per round.
        #[arg(long, default_value_t = 32)]
        sample: u64,
        /// Fitted rounds at most (0: plates and the first fit only, no rendering).
        #[arg(long, default_value_t = 4)]
        rounds: usize,
        /// Use frames without labels (drones in them, if any, stay in the plates unlabelled).
        #[arg(long)]
        unlabelled_ok: bool,
        /// Replace an earlier fit's files in --out.
        #[arg(long)]
        overwrite: bool,
        /// At most N real frames, evenly spaced in name order (0: all).
        #[arg(long, default_value_t = 200)]
        max_frames: usize,
        /// The footage's horizontal field of view, degrees (default: from the base preset).
        #[arg(long)]
        hfov: Option<f64>,
        /// Frames per second taken from a video.
        #[arg(long, default_value_t = 2.0)]
        video_fps: f64,
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

/// lavapipe, the software Vulkan driver, rasterises on `LP_NUM_THREADS`
/// threads, one per core unless set. The batch's makers and encoders share
/// those cores, and a rasteriser thread they preempt holds up the whole pass
/// while the other core waits for it; two threads more than the cores keep
/// both cores busy (docs/benchmarks.md: −2.5 to −5 % wall time on
/// synthswarm_table2, realistic and peer_moving). A value the user set is
/// kept; a hardware GPU never reads it.
fn more_lavapipe_threads() {
    if std::env::var_os("LP_NUM_THREADS").is_some() {
        return;
    }
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    // SAFETY: called first thing in main, before any thread exists, so
    // nothing reads the environment meanwhile.
    #[allow(unsafe_code)]
    unsafe {
        std::env::set_var("LP_NUM_THREADS", (cores + 2).to_string());
    }
}

fn main() -> std::process::ExitCode {
    // Rust ignores SIGPIPE, so printing to a closed pipe (`swarmshot check P | head -1`)
    // panicked; a command-line tool ends quietly there instead, as `ls | head` does.
    #[cfg(unix)]
    // SAFETY: the first thing main does, before any thread exists; SIG_DFL is a valid handler.
    #[allow(unsafe_code)]
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    more_lavapipe_threads();
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
            eprintln!("error: {}", swarmshot::text::for_terminal(&one_line(&e)));
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
            every: _,
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
            every,
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
                every,
            },
            timings,
        ),
        Command::Merge {
            out,
            shards,
            overwrite,
            copy,
        } => merge(&out, &shards, overwrite, copy),
        Command::Check { preset } => cli::check::check(&preset),
        Command::Stats { dir, plots, json } => stats(&dir, plots, json),
        Command::Gap {
            real,
            synthetic,
            out,
            max_images,
            json,
        } => {
            // An --out inside --real or --synthetic is refused before measuring.
            if let Some(out) = &out {
                swarmshot::gap::report::check_out(
                    out,
                    &[("real", &real), ("synthetic", &synthetic)],
                )?;
            }
            gap(real, synthetic, out.as_deref(), max_images, json)
        }
        Command::Frame {
            preset,
            index,
            out,
            overlay,
        } => frame(&preset, index, &out, overlay),
        Command::Fit {
            real,
            out,
            base,
            sample,
            rounds,
            unlabelled_ok,
            overwrite,
            max_frames,
            hfov,
            video_fps,
        } => fit(swarmshot::fit::FitOptions {
            real,
            out,
            base,
            sample,
            rounds,
            unlabelled_ok,
            overwrite,
            max_frames,
            hfov_deg: hfov,
            video_fps,
        }),

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
    for w in swarmshot::pipeline::check::warnings(pipeline.preset()) {
        eprintln!("warning: {}", swarmshot::text::for_terminal(&w.to_string()));
    }
}

/// The progress bar of a batch or plan of `total` frames.
fn frames_bar(total: u64) -> anyhow::Result<ProgressBar> {
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

/// `open` (the preset, its models, hulls and levels of detail) with the GPU
/// context starting on a second thread meanwhile: the instance and device
/// (a sixth of a cached start-up on lavapipe) no longer wait for the
/// single-threaded loading. `open`'s error comes first, as when the context
/// was made after it: a bad preset reports the preset, not the GPU.
fn with_gpu_starting<T>(
    open: impl FnOnce() -> anyhow::Result<T>,
) -> anyhow::Result<(T, GpuContext)> {
    std::thread::scope(|scope| {
        let gpu = scope.spawn(GpuContext::headless);
        let opened = open();
        // A panic there is the main thread's, as it was before the thread.
        let ctx = gpu
            .join()
            .unwrap_or_else(|panic| std::panic::resume_unwind(panic));
        Ok((opened?, ctx?))
    })
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
    let ((pipeline, frames), ctx) = with_gpu_starting(|| {
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
                preset.display(),
                report.out_dir.display()
            ),
        ));
    }
    if report.already_complete() {
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

/// A warning for each split that gets no frame ([`swarmshot::pipeline::check::empty_splits`]).
fn print_empty_splits(preset: &Preset, frames: u64, out: &mut dyn std::io::Write) {
    for w in swarmshot::pipeline::check::empty_splits(preset, frames) {
        let _ = writeln!(out, "warning: {w}");
    }
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
                preset.display(),
                report.out_dir.display()
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

/// A batch of one: the files the batch writes for frame `index` (image, YOLO
/// labels, manifest record, and the masks `output.masks` asks for), beside `out`.
fn frame(preset: &Path, index: u64, out: &Path, overlay: bool) -> anyhow::Result<()> {
    let (pipeline, ctx) = with_gpu_starting(|| {
        let pipeline = FramePipeline::open(preset)?;
        pipeline
            .preset()
            .check_render_budget()
            .map_err(|e| anyhow::anyhow!("{e}"))?;
        swarmshot::write::single::check_image_name(out, pipeline.preset().output.image_format)
            .map_err(anyhow::Error::msg)?;
        if index >= pipeline.frame_count() {
            anyhow::bail!(
                "--index {index}: the preset has {} frames (0..{})",
                pipeline.frame_count(),
                pipeline.frame_count()
            );
        }
        print_warnings(&pipeline);
        Ok(pipeline)
    })?;
    device_check(&pipeline, &ctx)?;
    let mut renderer = pipeline.renderer(&ctx);
    let mut frame = pipeline.make(&mut renderer, index)?;
    let (w, h) = (frame.scene.camera.width, frame.scene.camera.height);
    if overlay {
        swarmshot::annotate::overlay::draw_overlay(&mut frame.rgba, w, h, &frame.labels);
    }
    let written = swarmshot::write::single::write_lone_frame(
        out,
        &swarmshot::write::single::LoneFrame {
            scene: &frame.scene,
            labels: &frame.labels,
            rgba: &frame.rgba,
            masks: frame.masks.as_ref(),
        },
        &swarmshot::write::single::LoneFormat {
            image: pipeline.image_format(&frame.scene),
            masks: &pipeline.preset().output.masks,
            model_names: pipeline.model_names(),
            classes: pipeline.classes(),
        },
    )?;
    let beside: Vec<String> = (written.iter().skip(1))
        .map(|p| p.display().to_string())
        .collect();
    println!(
        "frame {index} ({} split): {} drones{}, {} boxes -> {} (+ {})",
        frame.scene.split.as_str(),
        frame.scene.drone_count(),
        match frame.scene.confusers.len() {
            0 => String::new(),
            n => format!(" and {n} confusers"),
        },
        frame.labels.iter().filter(|l| l.is_kept()).count(),
        out.display(),
        beside.join(", ")
    );
    Ok(())
}

/// `swarmshot fit`: the footage read and checked (nothing written before), plates and
/// the first fit written, then the rounds on the GPU, `fitted.ron` and the before/after.
fn fit(options: swarmshot::fit::FitOptions) -> anyhow::Result<()> {
    if options.sample == 0 {
        anyhow::bail!("--sample 0: a round needs at least 1 frame");
    }
    let started = std::time::Instant::now();
    let prep = swarmshot::fit::prepare(&options)?;
    let f = &prep.footage;
    eprintln!(
        "read {} frames ({} labelled, {} drones) in {:.1} s; {} plates in {}",
        f.frames,
        f.labelled_frames,
        f.drones,
        started.elapsed().as_secs_f64(),
        prep.plates.plates.len(),
        options.out.join("plates").display()
    );
    if prep.plates.unlabelled > 0 {
        eprintln!(
            "warning: {} frames have no labels (--unlabelled-ok): any drone in them stays in its plate, unlabelled",
            prep.plates.unlabelled
        );
    }
    let ctx = if options.rounds > 0 {
        Some(GpuContext::headless()?)
    } else {
        None
    };
    let cancel = stop_on_signals()?;
    let done = swarmshot::fit::finish(&prep, ctx.as_ref(), &cancel, &mut |line| {
        eprintln!("{line}")
    })?;
    if let Some(before) = &done.before {
        println!("== before: the base preset (round 00) ==\n{before}");
    }
    if let Some(after) = &done.after {
        println!(
            "== after: the fitted preset (round {:02}) ==\n{after}",
            done.record.best_round.unwrap_or(0)
        );
    }
    let summary: Vec<String> = (done.record.rounds.iter())
        .map(|r| format!("{:02}: {}/{}", r.round, r.inside, r.applicable))
        .collect();
    println!(
        "wrote {} in {:.1} s{}",
        done.fitted.display(),
        started.elapsed().as_secs_f64(),
        if summary.is_empty() {
            String::new()
        } else {
            format!(" (statistics inside per round: {})", summary.join(", "))
        }
    );
    Ok(())
}
