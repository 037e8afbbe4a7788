//! The GPU side of the commands that render (`batch`, `frame`, `check`): the
//! context started beside the preset's loading, and the refusal of a preset
//! the adapter cannot make.

use swarmshot::pipeline::FramePipeline;
use swarmshot::render::GpuContext;

/// Refuse what the adapter cannot do before anything is written; print the preset's warnings.
pub(crate) fn device_check(pipeline: &FramePipeline, ctx: &GpuContext) -> anyhow::Result<()> {
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

/// `open` (the preset, its models, hulls and levels of detail) with the GPU
/// context starting on a second thread meanwhile: the instance and device
/// (a sixth of a cached start-up on lavapipe) no longer wait for the
/// single-threaded loading. `open`'s error comes first, as when the context
/// was made after it: a bad preset reports the preset, not the GPU.
pub(crate) fn with_gpu_starting<T>(
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
