//! A batch's CPU a frame against the JPEG floor (a measurement, not a test):
//! how many plain JPEG encodes of its own frames one frame of a preset costs.
//!
//! In one process, on the same machine load:
//! 1. the batch's CPU a frame: `run_batch` (every thread of the process:
//!    makers, lavapipe, encoders, the sink) over 1 frame and over N frames
//!    into a scratch folder, after one batch of 1 frame not measured (what
//!    a first batch alone pays); (CPU(N) − CPU(1)) / (N − 1) leaves the
//!    start-up (renderers, shaders) out;
//! 2. the floor: the same N frames made again (not timed) and each encoded
//!    once with `encode_image` in the preset's format and quality (JPEG:
//!    libjpeg-turbo from RGBA, no tile reuse), this thread's CPU alone;
//! 3. their ratio: the batch's CPU a frame in JPEG encodes, i.e. in cores
//!    busy per core of plain encoding (issue 37's target: ≤ 5).
//!
//! Run: `cargo run --release --example floor_bench -- PRESET [N] [SCRATCH]`
//! (N defaults to 100, SCRATCH, the batch's folder, to a new folder in the
//! system's temporary folder; /dev/shm keeps the disk out). Unix only.
//! `FLOOR_BENCH_MAKERS=N` runs the batch with N makers (`--makers N`; unset:
//! the default for this machine), to compare makers side by side;
//! `FLOOR_BENCH_RUNS=N` measures N times in the process and prints the median ratio.
#![allow(clippy::unwrap_used)]

use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

use swarmshot::pipeline::{BatchOptions, FramePipeline, run_batch};
use swarmshot::render::GpuContext;
use swarmshot::write::encode_image;

/// CPU seconds of `clock` (the process's or this thread's).
#[cfg(unix)]
fn cpu_seconds(clock: libc::clockid_t) -> f64 {
    let mut t = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `t` is a valid timespec for the call to fill.
    #[allow(unsafe_code)]
    let rc = unsafe { libc::clock_gettime(clock, &mut t) };
    assert_eq!(rc, 0, "clock_gettime");
    t.tv_sec as f64 + t.tv_nsec as f64 * 1e-9
}

/// The process's CPU seconds over a batch of `limit` frames into `out`.
#[cfg(unix)]
fn batch_cpu(pipeline: &FramePipeline, ctx: &GpuContext, out: &Path, limit: u64) -> f64 {
    let makers = std::env::var("FLOOR_BENCH_MAKERS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(0);
    let options = BatchOptions {
        limit: Some(limit),
        overwrite: true,
        makers,
        ..BatchOptions::new(out)
    };
    let before = cpu_seconds(libc::CLOCK_PROCESS_CPUTIME_ID);
    run_batch(pipeline, &options, ctx, &AtomicBool::new(false), |_| {}).unwrap();
    cpu_seconds(libc::CLOCK_PROCESS_CPUTIME_ID) - before
}

#[cfg(unix)]
fn main() -> anyhow::Result<()> {
    let mut args = std::env::args().skip(1);
    let preset = PathBuf::from(
        args.next()
            .expect("usage: floor_bench PRESET [N] [SCRATCH]"),
    );
    let n: u64 = args.next().map_or(100, |s| s.parse().unwrap());
    assert!(n >= 2, "N of at least 2");
    let scratch = args.next().map_or_else(
        || std::env::temp_dir().join(format!("floor_bench_{}", std::process::id())),
        PathBuf::from,
    );
    let runs: usize = std::env::var("FLOOR_BENCH_RUNS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(1)
        .max(1);
    let pipeline = FramePipeline::open(&preset)?;
    let n = n.min(pipeline.frame_count());
    let ctx = GpuContext::headless()?;
    println!("{}: {n} frames", preset.display());
    // A first batch pays what later ones find done (the allocator's first
    // pages, the levels-of-detail caches): left out, so that the one-frame
    // and the n-frame batches measured start alike.
    batch_cpu(&pipeline, &ctx, &scratch, 1);
    let mut ratios = Vec::new();
    for _ in 0..runs {
        ratios.push(run(&pipeline, &ctx, &scratch, n)?);
    }
    if runs > 1 {
        ratios.sort_by(f64::total_cmp);
        println!(
            "median of {runs} runs {:.2}× the floor (runs {:.2}–{:.2}×)",
            ratios[runs / 2],
            ratios[0],
            ratios[runs - 1]
        );
    }
    std::fs::remove_dir_all(&scratch)?;
    Ok(())
}

/// One measurement: the batch's CPU a frame over `n` frames, the plain
/// encodes of the same frames, their ratio (printed, and returned).
#[cfg(unix)]
fn run(pipeline: &FramePipeline, ctx: &GpuContext, scratch: &Path, n: u64) -> anyhow::Result<f64> {
    let one = batch_cpu(pipeline, ctx, scratch, 1);
    let all = batch_cpu(pipeline, ctx, scratch, n);
    let batch_ms = (all - one) / (n - 1) as f64 * 1e3;
    let mut renderer = pipeline.renderer(ctx);
    let mut encode_s = 0.0;
    let mut bytes = 0;
    for i in 0..n {
        let frame = pipeline.make(&mut renderer, i)?;
        let (w, h) = (frame.scene.camera.width, frame.scene.camera.height);
        let format = pipeline.image_format(&frame.scene);
        let start = cpu_seconds(libc::CLOCK_THREAD_CPUTIME_ID);
        let encoded = std::hint::black_box(encode_image(&frame.rgba, w, h, format)?);
        encode_s += cpu_seconds(libc::CLOCK_THREAD_CPUTIME_ID) - start;
        bytes += encoded.len();
        renderer.recycle(frame.rgba, frame.painted);
    }
    let floor_ms = encode_s / n as f64 * 1e3;
    println!(
        "batch CPU a frame {batch_ms:.2} ms (1 frame {one:.3} s, {n} frames {all:.3} s of CPU)"
    );
    println!(
        "floor: a plain encode {floor_ms:.2} ms of one core a frame ({} KiB a frame)",
        bytes / n as usize / 1024
    );
    let ratio = batch_ms / floor_ms;
    println!("ratio {ratio:.2}× the floor");
    Ok(ratio)
}

#[cfg(not(unix))]
fn main() {
    eprintln!("floor_bench reads the CPU clocks of Unix");
}
