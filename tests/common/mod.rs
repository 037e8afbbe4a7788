//! Shared test fixtures: a GPU context that fails loudly, and small presets.
#![allow(dead_code)]

use std::path::PathBuf;

use swarmshot::preset::sweep::SweepRange;
use swarmshot::preset::{ImageFormat, Placement, Preset, Resolution, Volume};
use swarmshot::render::GpuContext;

/// The headless adapter CI installs (lavapipe). Panics with the reason if none
/// is found: a rendering test must never pass by skipping.
pub fn gpu() -> GpuContext {
    match GpuContext::headless() {
        Ok(ctx) => ctx,
        Err(e) => panic!("rendering tests need a wgpu adapter (CI installs Mesa lavapipe): {e}"),
    }
}

/// Path into tests/data, the bundled third-party files (see tests/data/README.md).
pub fn testdata(rel: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(rel)
}

/// A small, fast preset: 320×180 PNG, a few drones, a 2×1×2 sweep.
pub fn tiny_preset() -> Preset {
    let mut p = Preset {
        name: "tiny".into(),
        seed: 7,
        placement: Placement::Randomized {
            count: (3, 6),
            volume: Volume::Box {
                size_m: (6.0, 3.0, 6.0),
            },
            min_separation_m: 0.7,
        },
        repeats: 2,
        ..Preset::default()
    };
    p.camera.y = SweepRange::new(-0.2, 0.2, 0.4);
    p.camera.z = SweepRange::fixed(0.9);
    p.plane.ry = SweepRange::new(0.0, 90.0, 90.0);
    p.render.resolution = Resolution::Custom {
        width: 320,
        height: 180,
    };
    p.render.msaa = 1;
    p.output.image_format = ImageFormat::Png;
    p
}
