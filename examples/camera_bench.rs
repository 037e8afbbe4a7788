//! The camera model's cost per frame (src/sensor/), on the CPU alone: a
//! 1920×1080 picture through `sensor::apply_into` (a recycled picture) with
//! a typical draw (every stage on) and with noise alone; median of 30 runs
//! after 3 warm-ups.
//! (The sweep's bytes are checked against the plane-by-plane reference by
//! the unit tests in src/sensor/reference.rs.)
//!
//! `cargo run --release --no-default-features --example camera_bench`
//! (docs/benchmarks.md, "The camera model"). `RAYON_NUM_THREADS` sets the threads;
//! `CAMERA_BENCH_STAGES=1` times `apply` with the typical draw's stages switched on one
//! after another (the per-stage breakdown; `=N` stops after N lines, for a profiler);
//! `CAMERA_BENCH_CASE=TEXT` runs only the draws whose name contains TEXT;
//! `SWARMSHOT_SIMD=avx2` or `=base` caps the sweep's SIMD build.

use swarmshot::preset::camera_model::CameraModel;
use swarmshot::sensor::{self, CameraDraw, PsfDraw};

#[path = "support/picture.rs"]
mod picture;
#[path = "support/timing.rs"]
mod timing;

/// The median wall time of `sensor::apply_into` with `draw` over `rgba` (30
/// runs after 3 warm-ups), into one recycled picture as the pipeline's
/// camera stage writes (src/pipeline/camera.rs: the renderer's spare buffer).
fn apply_ms(rgba: &[u8], (w, h): (u32, u32), draw: &CameraDraw) -> f64 {
    let mut out = Vec::new();
    let (wall, _cpu) = timing::median_ms(|| {
        sensor::apply_into((rgba, w, h), draw, &mut out);
        std::hint::black_box(&out);
    });
    wall
}

fn main() {
    let (w, h) = (1920u32, 1080u32);
    let rgba = picture::sky(w, h);
    let neutral = sensor::draw(&CameraModel::default(), 1, 0);
    let typical = CameraDraw {
        exposure_ev: 0.2,
        white_balance_red: 1.05,
        white_balance_blue: 0.95,
        psf: PsfDraw::Gaussian { sigma_px: 0.8 },
        vignetting: 0.2,
        ca_red_scale: 1.0005,
        ca_blue_scale: 0.9995,
        shot_noise_gain: 0.02,
        read_noise_levels: 1.0,
        ..neutral
    };
    let cases = [
        ("neutral (decode + encode only)", neutral),
        (
            "noise only",
            CameraDraw {
                read_noise_levels: 1.0,
                shot_noise_gain: 0.02,
                ..neutral
            },
        ),
        ("typical: every stage, Gaussian σ 0.8 px", typical),
        (
            "typical + sensor 0.75",
            CameraDraw {
                sensor_scale: Some(0.75),
                ..typical
            },
        ),
        (
            "typical, disc r 3 px",
            CameraDraw {
                psf: PsfDraw::Disc { radius_px: 3.0 },
                ..typical
            },
        ),
    ];
    if std::env::var_os("CAMERA_BENCH_STAGES").is_some() {
        stages(&rgba, (w, h), &typical);
        return;
    }
    println!(
        "camera model, {w}×{h}, {} rayon threads, median of 30 (ms)",
        rayon::current_num_threads()
    );
    // CAMERA_BENCH_CASE=TEXT: only the draws whose name contains TEXT (for a profiler).
    let only = std::env::var("CAMERA_BENCH_CASE").unwrap_or_default();
    for (name, draw) in cases.into_iter().filter(|(n, _)| n.contains(&only)) {
        let now = apply_ms(&rgba, (w, h), &draw);
        println!("  {name}: {now:.2}");
    }
}

/// CAMERA_BENCH_STAGES=1: `apply` with the typical draw's stages switched on
/// one after another; each line's increase over the one before is that
/// stage's cost.
fn stages(rgba: &[u8], (w, h): (u32, u32), typical: &CameraDraw) {
    let base = CameraDraw {
        exposure_ev: typical.exposure_ev,
        ..sensor::draw(&CameraModel::default(), 1, 0)
    };
    let wb = CameraDraw {
        white_balance_red: typical.white_balance_red,
        white_balance_blue: typical.white_balance_blue,
        ..base
    };
    let ca = CameraDraw {
        ca_red_scale: typical.ca_red_scale,
        ca_blue_scale: typical.ca_blue_scale,
        ..wb
    };
    let psf = CameraDraw {
        psf: typical.psf,
        ..ca
    };
    let vignette = CameraDraw {
        vignetting: typical.vignetting,
        ..psf
    };
    let cases = [
        ("decode + exposure + clip + encode", base),
        ("+ white balance", wb),
        ("+ chromatic aberration", ca),
        ("+ Gaussian PSF σ 0.8 px", psf),
        ("+ vignetting", vignette),
        ("+ noise (= typical)", *typical),
        (
            "+ saturation 1.35",
            CameraDraw {
                saturation: 1.35,
                ..*typical
            },
        ),
    ];
    println!(
        "camera model stages, {w}×{h}, {} rayon threads, median of 30 (ms), cumulative",
        rayon::current_num_threads()
    );
    // CAMERA_BENCH_STAGES=N > 1: the first N lines only (for profiling one).
    let upto = std::env::var("CAMERA_BENCH_STAGES")
        .ok()
        .and_then(|v| v.parse::<usize>().ok())
        .filter(|&n| n > 1)
        .unwrap_or(cases.len());
    let mut before = 0.0;
    for (name, draw) in cases.into_iter().take(upto) {
        let now = apply_ms(rgba, (w, h), &draw);
        println!("  {name}: {now:.2} (+{:.2})", now - before);
        before = now;
    }
}
