//! The developer tools: `bench` (the tables of docs/accuracy.md and
//! docs/benchmarks.md), `gallery` (the docs' pictures) and `assets` (the
//! built-in models' GLB files).

use std::path::Path;

use anyhow::Context;
use swarmshot::pipeline::FramePipeline;
use swarmshot::preset::Preset;
use swarmshot::render::GpuContext;
use swarmshot::tools::{bench, gallery};

use super::args::{AccuracyArgs, FramesArgs, GalleryArgs};

/// `swarmshot bench accuracy`: label error against run time, then frame time by setting.
pub(crate) fn bench_accuracy(args: &AccuracyArgs) -> anyhow::Result<()> {
    let (frames, width, height) = (args.frames, args.width, args.height);
    let (plot, timing_frames) = (&args.plot, args.timing_frames);
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

/// `swarmshot bench frames`: median frame time and peak RSS of the benchmark scenes.
pub(crate) fn bench_frames(args: &FramesArgs) -> anyhow::Result<()> {
    let (frames, peer, only) = (args.frames, &args.peer, args.scene.as_deref());
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

/// `swarmshot gallery`: the docs' pictures, or with --bench the environments' frame times.
pub(crate) fn gallery(args: &GalleryArgs) -> anyhow::Result<()> {
    if args.bench {
        gallery_bench()
    } else {
        gallery_pictures(&args.out, args.width, args.height)
    }
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
    let sequence = Preset::from_ron(include_str!("../../presets/formation_sequence.ron"))
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

/// `swarmshot assets`: the built-in models and confusers regenerated as GLB files.
pub(crate) fn assets(dir: &Path) -> anyhow::Result<()> {
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
