//! The GPU side of the commands that render (`batch`, `frame`, `check`): the
//! context started beside the preset's loading, and the refusal of a preset
//! the adapter cannot make.

use std::sync::atomic::{AtomicBool, Ordering};

use swarmshot::pipeline::FramePipeline;
use swarmshot::preset::Preset;
use swarmshot::render::GpuContext;

/// What `ctx` can do, and the memory a frame may use.
fn device_limits(ctx: &GpuContext) -> swarmshot::preset::DeviceLimits {
    swarmshot::preset::DeviceLimits {
        max_texture_side: ctx.max_texture_side,
        max_buffer_bytes: ctx.device.limits().max_buffer_size,
        // Three quarters of what is free, within the process's `ulimit -v`/`-d`.
        memory_bytes: swarmshot::preset::budget::usable_memory_bytes(),
    }
}

/// Refuse what the adapter cannot do before anything is written; print the preset's warnings.
pub(crate) fn device_check(pipeline: &FramePipeline, ctx: &GpuContext) -> anyhow::Result<()> {
    pipeline
        .preset()
        .check_limits(&device_limits(ctx))
        .map_err(|errors| {
            let list: Vec<String> = errors.iter().map(|e| format!("  - {e}")).collect();
            anyhow::anyhow!(
                "the preset asks more than {} can do:\n{}",
                ctx.describe(),
                list.join("\n")
            )
        })
}

/// `open` (the preset, its models, hulls and levels of detail) with the GPU
/// context starting on a second thread meanwhile: the instance and device
/// (a sixth of a cached start-up on lavapipe) no longer wait for the
/// single-threaded loading. `open` hands the preset to the callback it is
/// given as soon as it is read; the context then makes that preset's frame
/// targets (when the device and memory can hold them) and has the device
/// zero them while the models load ([`GpuContext::prepare_frame_targets`]).
/// `open`'s error comes first, as when the context was made after it: a bad
/// preset reports the preset, not the GPU.
pub(crate) fn with_gpu_starting<T>(
    open: impl FnOnce(&dyn Fn(&Preset)) -> anyhow::Result<T>,
) -> anyhow::Result<(T, GpuContext)> {
    let (preset_tx, preset_rx) = crossbeam_channel::bounded::<Box<Preset>>(1);
    // Set when `open` fails: a preset refused before the context is up
    // gets no targets (its error is not kept waiting for them).
    let failed = &AtomicBool::new(false);
    std::thread::scope(|scope| {
        // A thread the system refuses only loses the overlap: the context
        // then starts after `open`, and not when `open` failed.
        let gpu = swarmshot::threads::spawn_or_defer(scope, move || {
            let ctx = GpuContext::headless()?;
            // Only a frame the device and the memory can hold (what
            // `device_check` later requires of the preset).
            if let Ok(preset) = preset_rx.recv()
                && !failed.load(Ordering::Relaxed)
                && preset.check_limits(&device_limits(&ctx)).is_ok()
            {
                ctx.prepare_frame_targets(preset.image_size(), preset.render.msaa);
            }
            Ok(ctx)
        });
        let parsed = |preset: &Preset| {
            let _ = preset_tx.try_send(Box::new(preset.clone()));
        };
        let opened = open(&parsed);
        failed.store(opened.is_err(), Ordering::Relaxed);
        // The context's thread waits for the preset only while `open` runs.
        drop(preset_tx);
        let opened = opened?;
        // A panic there is the main thread's, as it was before the thread.
        let ctx = gpu
            .join()
            .unwrap_or_else(|panic| std::panic::resume_unwind(panic));
        Ok((opened, ctx.map_err(under_address_space_limit)?))
    })
}

/// A GPU that fails to start under an address-space limit names the limit
/// first: lavapipe maps over a gigabyte as it starts, and under `ulimit -v
/// 262144` it reported "no GPU adapter found: install Mesa's software Vulkan
/// driver", which sent the user after a driver that was there.
fn under_address_space_limit(e: swarmshot::render::RenderError) -> anyhow::Error {
    let Some(limit) = swarmshot::preset::budget::address_space_limit_bytes() else {
        return e.into();
    };
    anyhow::Error::new(e).context(format!(
        "the GPU could not start within this process's address-space limit of {} MiB (`ulimit -v` or `ulimit -d`; lavapipe alone maps over 1 GiB as it starts): raise the limit (or the job's memory request)",
        limit >> 20
    ))
}
