//! The developer tools: `bench` (the tables of docs/accuracy.md and
//! docs/benchmarks.md), `gallery` (the docs' pictures) and `assets` (the
//! built-in models' GLB files).

use std::path::Path;

use anyhow::Context;
use swarmshot::pipeline::FramePipeline;
use swarmshot::preset::Preset;
use swarmshot::render::GpuContext;
use swarmshot::tools::{bench, gallery};
use swarmshot::write::outdir::OutDir;

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

/// `img` encoded as `format` and written into `out` as `name` (atomically,
/// never through a link: [`OutDir::write`]).
fn save_into(
    out: &mut OutDir,
    name: &str,
    img: &image::DynamicImage,
    format: image::ImageFormat,
) -> anyhow::Result<()> {
    let mut bytes = Vec::new();
    img.write_to(&mut std::io::Cursor::new(&mut bytes), format)
        .with_context(|| format!("encoding {name}"))?;
    let path = out.write(name, &bytes)?;
    println!("wrote {}", path.display());
    Ok(())
}

fn gallery_pictures(out: &Path, width: u32, height: u32) -> anyhow::Result<()> {
    use image::{DynamicImage, ImageFormat};
    let ctx = GpuContext::headless()?;
    let mut out = OutDir::create(out)?;
    let sheet = gallery::model_contact_sheet(&ctx, 256, 4)?;
    save_into(&mut out, "models.png", &sheet.into(), ImageFormat::Png)?;
    let sheet = swarmshot::tools::confuser_gallery::confuser_contact_sheet(&ctx, 160, 6)?;
    save_into(&mut out, "confusers.png", &sheet.into(), ImageFormat::Png)?;
    let frame = |rgba: Vec<u8>| -> anyhow::Result<DynamicImage> {
        let img = image::RgbaImage::from_raw(width, height, rgba).context("frame size")?;
        Ok(DynamicImage::ImageRgba8(img).to_rgb8().into())
    };
    for (name, rgba) in gallery::environment_frames(&ctx, width, height)? {
        let name = format!("env-{}.jpg", name.as_str());
        save_into(&mut out, &name, &frame(rgba)?, ImageFormat::Jpeg)?;
    }
    for (name, rgba) in gallery::formation_frames(&ctx, width, height)? {
        let name = format!("formation-{name}.jpg");
        save_into(&mut out, &name, &frame(rgba)?, ImageFormat::Jpeg)?;
    }
    let sequence = Preset::from_ron(include_str!("../../presets/formation_sequence.ron"))
        .map_err(|e| anyhow::anyhow!("presets/formation_sequence.ron: {e}"))?;
    let strip = gallery::sequence_strip(&ctx, &sequence, 5, width / 2, height / 2)?;
    let strip = DynamicImage::ImageRgba8(strip).to_rgb8().into();
    save_into(&mut out, "sequence-strip.jpg", &strip, ImageFormat::Jpeg)
}

/// `swarmshot assets`: the built-in models and confusers regenerated as GLB files.
pub(crate) fn assets(dir: &Path) -> anyhow::Result<()> {
    // Each file written atomically into the folder opened once, never through a link.
    let mut out = OutDir::create(dir)?;
    for name in swarmshot::model::builtin::NAMES {
        let bytes = swarmshot::tools::assets::generate_glb(name).context("built-in generator")?;
        let path = out.write(&format!("{name}.glb"), &bytes)?;
        println!("wrote {} ({} bytes)", path.display(), bytes.len());
    }
    for name in swarmshot::model::confusers::NAMES {
        let bytes =
            swarmshot::tools::confusers::generate_glb(name).context("confuser generator")?;
        let path = out.write(&format!("{name}.glb"), &bytes)?;
        println!("wrote {} ({} bytes)", path.display(), bytes.len());
    }
    Ok(())
}
