//! The `swarmshot` command line: batch, check, frame, bench, assets, and the
//! desktop app (`swarmshot gui [PRESET]`, or `swarmshot` with no arguments).

use std::path::PathBuf;
use std::sync::atomic::AtomicBool;

use anyhow::Context;
use clap::{Parser, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};

use swarmshot::batch::{self, BatchOptions, FrameMaker};
use swarmshot::preset::Placement;
use swarmshot::render::GpuContext;

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
        /// Replace an existing dataset in a non-empty folder.
        #[arg(long)]
        overwrite: bool,
        /// Image encoder threads (default: one per spare core).
        #[arg(long, default_value_t = 0)]
        threads: usize,
    },
    /// Validate a preset and print what it will make.
    Check { preset: PathBuf },
    /// Render one frame alone to an image file.
    Frame {
        preset: PathBuf,
        /// Frame index (0-based).
        #[arg(long, default_value_t = 0)]
        index: u64,
        /// Output image (.png or .jpg).
        #[arg(long)]
        out: PathBuf,
        /// Draw the label boxes on the image.
        #[arg(long)]
        overlay: bool,
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
        /// Output folder for models.png and env-NAME.jpg.
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
}

fn main() -> anyhow::Result<()> {
    let cli = Cli::parse();
    let Some(command) = cli.command else {
        swarmshot::app::run_or_exit(None);
        return Ok(());
    };
    match command {
        Command::Gui { preset } => swarmshot::app::run_or_exit(preset),
        Command::Batch {
            preset,
            out,
            limit,
            overwrite,
            threads,
        } => {
            let preset = batch::load_preset(&preset)?;
            let ctx = GpuContext::headless()?;
            let total = limit.map_or(preset.frame_count(), |n| n.min(preset.frame_count()));
            let bar = ProgressBar::new(total);
            bar.set_style(
                ProgressStyle::with_template(
                    "{bar:40.cyan/blue} {pos}/{len} frames  {msg}  ETA {eta}",
                )
                .context("progress template")?,
            );
            let options = BatchOptions {
                out_dir: out,
                limit,
                overwrite,
                encoder_threads: threads,
            };
            let cancel = AtomicBool::new(false);
            let report = batch::run_batch(&preset, &options, &ctx, &cancel, |p| {
                bar.set_position(p.done);
                bar.set_message(format!("{:.1} images/s", p.images_per_s()));
            })?;
            bar.finish();
            let s = &report.stats;
            println!(
                "wrote {} frames ({} train / {} val / {} test), {} boxes (small {} / medium {} / large {}) to {} in {:.1} s ({:.2} images/s) on {}",
                s.frames,
                s.frames_per_split[0],
                s.frames_per_split[1],
                s.frames_per_split[2],
                s.boxes,
                s.small,
                s.medium,
                s.large,
                report.out_dir.display(),
                report.elapsed.as_secs_f64(),
                s.frames as f64 / report.elapsed.as_secs_f64().max(1e-9),
                ctx.describe()
            );
        }
        Command::Check { preset: path } => {
            let preset = batch::load_preset(&path)?;
            let maker = FrameMaker::new(preset.clone())?;
            let (w, h) = preset.image_size();
            println!("preset {} is valid", path.display());
            println!("frames: {}", preset.frame_count());
            println!(
                "image: {w}×{h}, {:?}, MSAA {}",
                preset.output.image_format, preset.render.msaa
            );
            match &preset.placement {
                Placement::Structured {
                    x_count,
                    y_count,
                    z_count,
                    load_factor,
                } => {
                    let spacing = load_factor * preset.max_model_size_m();
                    println!(
                        "placement: structured grid {x_count}×{y_count}×{z_count} = {} drones per frame, spacing {spacing:.3} m, volume {:.3} × {:.3} × {:.3} m",
                        x_count * y_count * z_count,
                        f64::from(x_count - 1) * spacing,
                        f64::from(y_count - 1) * spacing,
                        f64::from(z_count - 1) * spacing,
                    );
                }
                Placement::Randomized {
                    count: (lo, hi),
                    volume,
                    min_separation_m,
                } => {
                    println!(
                        "placement: randomized, {lo}–{hi} drones per frame (mean {:.1}), volume {volume:?}, min separation {min_separation_m} m",
                        (f64::from(*lo) + f64::from(*hi)) / 2.0
                    );
                }
            }
            // Geometry only (no rendering): amodal boxes stand in for visible ones.
            let sample = preset.frame_count().min(200);
            let mut stats = swarmshot::output::DatasetStats::default();
            for i in 0..sample {
                let (scene, labels) = maker.frame(i)?;
                stats.add(&scene, &labels);
            }
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
            }
            for (spec, model) in preset.models.iter().zip(&maker.models) {
                println!(
                    "model {}: {} triangles, {} hull vertices, size {} m, class {}",
                    spec.source,
                    model.indices.len() / 3,
                    model.hull.len(),
                    spec.size_m,
                    spec.class
                );
                for w in &model.warnings {
                    println!("  warning: {w}");
                }
            }
        }
        Command::Frame {
            preset,
            index,
            out,
            overlay,
        } => {
            let preset = batch::load_preset(&preset)?;
            let maker = FrameMaker::new(preset)?;
            let ctx = GpuContext::headless()?;
            let (scene, labels, mut rgba) = batch::render_single(&maker, &ctx, index)?;
            let (w, h) = (scene.camera.width, scene.camera.height);
            if overlay {
                batch::draw_overlay(&mut rgba, w, h, &labels);
            }
            let image = image::RgbaImage::from_raw(w, h, rgba).context("frame buffer size")?;
            image::DynamicImage::ImageRgba8(image)
                .to_rgb8()
                .save(&out)
                .with_context(|| format!("writing {}", out.display()))?;
            println!(
                "frame {index} ({} split): {} drones, {} boxes -> {}",
                scene.split.as_str(),
                scene.drones.len(),
                labels.iter().filter(|l| l.is_kept()).count(),
                out.display()
            );
        }
        Command::Bench {
            which:
                BenchCommand::Accuracy {
                    frames,
                    width,
                    height,
                    plot,
                    timing_frames,
                },
        } => {
            let ctx = GpuContext::headless()?;
            eprintln!("adapter: {}", ctx.describe());
            let acc = swarmshot::bench::accuracy(&ctx, frames, width, height)?;
            let quickstart = batch::load_preset(std::path::Path::new(concat!(
                env!("CARGO_MANIFEST_DIR"),
                "/presets/quickstart.ron"
            )))?;
            let timing = swarmshot::bench::timings(&ctx, &quickstart, timing_frames)?;
            print!("{}", swarmshot::bench::markdown(&acc, &timing));
            if let Some(dir) = plot.parent() {
                std::fs::create_dir_all(dir)
                    .with_context(|| format!("creating {}", dir.display()))?;
            }
            swarmshot::bench::plot(&acc, &plot)?;
            eprintln!("plot written to {}", plot.display());
        }
        Command::Gallery {
            out,
            width,
            height,
            bench,
        } => {
            use swarmshot::gallery;
            let ctx = GpuContext::headless()?;
            if bench {
                let frames = 20;
                let gradient =
                    gallery::environment_preset(swarmshot::preset::Sky::default(), 1920, 1080);
                println!(
                    "1920x1080, MSAA 4, 8 drones, median of {frames} frames on {}",
                    ctx.describe()
                );
                println!(
                    "gradient sky: {:.1} ms",
                    gallery::median_frame_ms(&ctx, &gradient, frames)?
                );
                for name in swarmshot::environment::EnvironmentName::ALL {
                    let p =
                        gallery::environment_preset(gallery::fixed_environment(name), 1920, 1080);
                    println!(
                        "{}: {:.1} ms",
                        name.as_str(),
                        gallery::median_frame_ms(&ctx, &p, frames)?
                    );
                }
                return Ok(());
            }
            std::fs::create_dir_all(&out).with_context(|| format!("creating {}", out.display()))?;
            let sheet = gallery::model_contact_sheet(&ctx, 256, 4)?;
            let path = out.join("models.png");
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
        }
        Command::Assets { dir } => {
            std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
            for name in swarmshot::assets::BUILTIN_NAMES {
                let bytes = swarmshot::assets::generate_glb(name).context("built-in generator")?;
                let path = dir.join(format!("{name}.glb"));
                std::fs::write(&path, &bytes)
                    .with_context(|| format!("writing {}", path.display()))?;
                println!("wrote {} ({} bytes)", path.display(), bytes.len());
            }
        }
    }
    Ok(())
}
