//! `swarmshot frame PRESET --index I --out F`: one frame alone, the files the
//! batch writes for it.

use swarmshot::pipeline::FramePipeline;
use swarmshot::write::single;

use super::args::FrameArgs;
use super::console::print_warnings;
use super::gpu::{device_check, with_gpu_starting};

/// A batch of one: the files the batch writes for frame `index` (image, YOLO
/// labels, manifest record, and the masks `output.masks` asks for), beside `out`.
pub(crate) fn run(args: FrameArgs) -> anyhow::Result<()> {
    let (preset, index, out) = (&args.preset, args.index, &args.out);
    let ((pipeline, mut dir), ctx) = with_gpu_starting(|parsed| {
        let pipeline = FramePipeline::open_then(preset, parsed)?;
        pipeline
            .preset()
            .check_render_budget()
            .map_err(|e| anyhow::anyhow!("{e}"))?;
        swarmshot::write::single::check_image_name(out, pipeline.preset().output.image_format)
            .map_err(anyhow::Error::msg)?;
        let files = single::lone_frame_files(out, &pipeline.preset().output.masks);
        let mut inputs = vec![("the preset", preset.as_path())];
        inputs.extend(pipeline.preset().input_paths());
        single::check_lone_targets(out, &files, &inputs, args.overwrite)?;
        if index >= pipeline.frame_count() {
            let n = pipeline.frame_count();
            anyhow::bail!(
                "--index {index}: the preset has {} (indices 0 to {})",
                swarmshot::text::plural(n, "frame", "frames"),
                n.saturating_sub(1)
            );
        }
        // Opened before the frame is made: every file is written into this folder.
        let dir = single::LoneDir::open(out, args.overwrite)?;
        print_warnings(&pipeline);
        Ok((pipeline, dir))
    })?;
    device_check(&pipeline, &ctx)?;
    let mut renderer = pipeline.frame_renderer(&ctx);
    let mut frame = pipeline.make(&mut renderer, index)?;
    let (w, h) = (frame.scene.camera.width, frame.scene.camera.height);
    if args.overlay {
        swarmshot::annotate::overlay::draw_overlay(&mut frame.rgba, w, h, &frame.labels);
    }
    let written = swarmshot::write::single::write_lone_frame(
        &mut dir,
        &swarmshot::write::single::LoneFrame {
            scene: &frame.scene,
            labels: &frame.labels,
            rgba: &frame.rgba,
            // The overlay is drawn on the 8-bit picture.
            grey16: frame.grey16.as_deref().filter(|_| !args.overlay),
            grey: pipeline.preset().thermal.is_some() && !args.overlay,
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
    use swarmshot::text::plural;
    println!(
        "frame {index} ({} split): {}{}, {} -> {} (+ {})",
        frame.scene.split.as_str(),
        plural(frame.scene.drone_count() as u64, "drone", "drones"),
        match frame.scene.confusers.len() {
            0 => String::new(),
            n => format!(" and {}", plural(n as u64, "confuser", "confusers")),
        },
        plural(
            frame.labels.iter().filter(|l| l.is_kept()).count() as u64,
            "box",
            "boxes"
        ),
        out.display(),
        beside.join(", ")
    );
    Ok(())
}
