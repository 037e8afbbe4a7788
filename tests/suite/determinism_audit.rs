//! Determinism across machines (the determinism audit): a dataset's bytes
//! do not depend on the machine that makes it. Each test runs a small
//! dataset as a child process under the default environment and again
//! under what differs between machines: a narrower SIMD level
//! (`SWARMSHOT_SIMD=base`, `=avx2`: every vectorised kernel in the binary
//! then runs its scalar or AVX2 build), fewer or more rayon threads
//! (`RAYON_NUM_THREADS`), one lavapipe rasteriser thread (`LP_NUM_THREADS`),
//! and more frames made at once (`--makers`); every file must be the same
//! bytes. A kernel whose SIMD build differs from its scalar build, or a
//! parallel reduction that depends on its split, fails here; so does a
//! frame whose bytes depend on the frames its maker made before it (it
//! must be the frame `swarmshot frame` makes alone).

use crate::common;

use std::path::{Path, PathBuf};

use swarmshot::preset::{Preset, Resolution};

use common::cli::{command, os};

/// What one run changes from the default: environment variables and extra
/// `batch` arguments.
struct Variant {
    env: &'static [(&'static str, &'static str)],
    args: &'static [&'static str],
}

/// The machine differences each dataset is made under.
const VARIANTS: &[Variant] = &[
    Variant {
        env: &[("SWARMSHOT_SIMD", "base")],
        args: &[],
    },
    Variant {
        env: &[("SWARMSHOT_SIMD", "avx2")],
        args: &[],
    },
    Variant {
        env: &[("RAYON_NUM_THREADS", "1")],
        args: &[],
    },
    Variant {
        env: &[("RAYON_NUM_THREADS", "3")],
        args: &[],
    },
    Variant {
        env: &[("LP_NUM_THREADS", "1")],
        args: &["--makers", "2"],
    },
];

/// The variables a variant sets, removed from the default run so that the
/// test's own environment cannot make the two agree.
const MACHINE_VARS: &[&str] = &[
    "SWARMSHOT_SIMD",
    "SWARMSHOT_CAMERA_SIMD",
    "RAYON_NUM_THREADS",
    "LP_NUM_THREADS",
];

/// A shipped preset, read from `presets/`.
fn shipped(name: &str) -> Preset {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("presets")
        .join(name);
    Preset::open(&path).unwrap_or_else(|e| panic!("presets/{name}: {e}"))
}

/// The camera model of a shipped preset.
fn camera_model_of(name: &str) -> swarmshot::preset::camera_model::CameraModel {
    shipped(name)
        .camera_model
        .unwrap_or_else(|| panic!("presets/{name} has a camera model"))
}

/// All frames in train (a short run of a sequence preset must not ask for
/// val and test frames it cannot have), at `width`×`height`.
fn small(mut p: Preset, width: u32, height: u32) -> Preset {
    p.render.resolution = Resolution::Custom { width, height };
    p.render.msaa = 1;
    p.output.split.train = 1.0;
    p.output.split.val = 0.0;
    p.output.split.test = 0.0;
    p
}

/// presets/flow_sequence.ron's wedge (a sequence, instance masks, depth
/// and optical flow) at 192×108 under presets/realistic.ron's procedural
/// skies (shaded at a reduced size and upsampled on the CPU) through its
/// camera (exposure, PSF, aberration, vignetting, saturation, sensor grid,
/// noise, sharpening, JPEG) with presets/rolling_shutter.ron's readout, in
/// presets/rain.ron's rain.
fn sequence_preset() -> Preset {
    let mut p = small(shipped("flow_sequence.ron"), 192, 108);
    p.sky = shipped("realistic.ron").sky;
    let mut camera = camera_model_of("realistic.ron");
    camera.rolling_shutter = camera_model_of("rolling_shutter.ron").rolling_shutter;
    p.camera_model = Some(camera);
    p.weather = shipped("rain.ron").weather;
    p
}

/// presets/lens_distortion.ron at 192×108 under presets/realistic.ron's
/// skies, through its camera and the preset's own lens (a lens cannot be
/// combined with the rolling shutter), in presets/snow.ron's snow.
fn lens_preset() -> Preset {
    let mut p = small(shipped("lens_distortion.ron"), 192, 108);
    p.sky = shipped("realistic.ron").sky;
    let mut camera = camera_model_of("realistic.ron");
    camera.lens = camera_model_of("lens_distortion.ron").lens;
    p.camera_model = Some(camera);
    p.weather = shipped("snow.ron").weather;
    p
}

/// presets/thermal_rain.ron at 160×128: the thermal camera's blur, noise
/// and gain (its AVX-512 and AVX2 builds, its parallel histogram and
/// ranks) and its rain.
fn thermal_preset() -> Preset {
    let mut p = small(shipped("thermal_rain.ron"), 160, 128);
    p.render.msaa = shipped("thermal_rain.ron").render.msaa;
    p
}

/// `batch PRESET --out OUT --limit FRAMES ARGS…` under the default
/// environment with `env` set; it must succeed.
fn batch_under(preset: &Path, out: &Path, frames: u32, variant: &Variant) {
    let frames = frames.to_string();
    let mut args = vec![
        os("batch"),
        preset.as_os_str(),
        os("--out"),
        out.as_os_str(),
        os("--limit"),
        os(&frames),
    ];
    args.extend(variant.args.iter().map(os));
    let mut cmd = command(&args);
    for var in MACHINE_VARS {
        cmd.env_remove(var);
    }
    cmd.envs(variant.env.iter().copied());
    let o = cmd.output().expect("run swarmshot");
    assert!(
        o.status.success(),
        "batch under {:?} {:?} failed:\n{}",
        variant.env,
        variant.args,
        String::from_utf8_lossy(&o.stderr)
    );
}

/// `preset`'s first `frames` frames made under the default environment and
/// under each of [`VARIANTS`]: every file the same bytes. The files made.
fn same_bytes_on_every_machine(preset: &Preset, frames: u32) -> Vec<PathBuf> {
    let tmp = tempfile::tempdir().expect("tempdir");
    let file = common::preset_file(tmp.path(), preset, "p.ron");
    let default = Variant {
        env: &[],
        args: &[],
    };
    let want: PathBuf = tmp.path().join("default");
    batch_under(&file, &want, frames, &default);
    for (k, variant) in VARIANTS.iter().enumerate() {
        let got = tmp.path().join(format!("variant{k}"));
        batch_under(&file, &got, frames, variant);
        let what = format!("{} under {:?} {:?}", preset.name, variant.env, variant.args);
        common::assert_same_dataset(&want, &got, &what);
    }
    common::files_under(&want)
}

#[test]
fn a_sequence_with_rolling_shutter_rain_and_flow_is_the_same_on_every_machine() {
    let files = same_bytes_on_every_machine(&sequence_preset(), 3);
    for dir in ["flow", "masks", "depth"] {
        assert!(
            files.iter().any(|f| f.starts_with(dir)),
            "no {dir}/ file: {files:?}"
        );
    }
}

#[test]
fn a_distorting_lens_in_snow_is_the_same_on_every_machine() {
    same_bytes_on_every_machine(&lens_preset(), 2);
}

#[test]
fn the_thermal_camera_in_rain_is_the_same_on_every_machine() {
    same_bytes_on_every_machine(&thermal_preset(), 2);
}

/// presets/bench/peer_moving.ron (a camera that moves every frame under a
/// 1024×512 HDR sky) at 192×108 and 8°: the sky magnified enough to be
/// shaded at half the resolution on the CPU (render/sky/equirect.rs, its
/// samples gathered in AVX2) and upsampled.
fn reduced_sky_preset() -> Preset {
    let mut p = small(shipped("bench/peer_moving.ron"), 192, 108);
    p.camera.fov_y_deg = 8.0;
    p
}

#[test]
fn an_image_sky_shaded_on_the_cpu_is_the_same_on_every_machine() {
    same_bytes_on_every_machine(&reduced_sky_preset(), 3);
}

/// The MOT tests' sequence (a fixed camera: its frames share the sky)
/// under a procedural sky and an exposure drawn per frame: the same
/// background under a new exposure in every frame.
fn same_sky_new_exposures() -> Preset {
    let mut p = common::sequence_preset();
    p.sky = swarmshot::preset::Sky::procedural(swarmshot::preset::EnvironmentName::Daytime);
    p.camera_model = Some(swarmshot::preset::camera_model::CameraModel {
        exposure_ev: (-1.5, 0.0),
        ..Default::default()
    });
    p.output.split.train = 1.0;
    p.output.split.val = 0.0;
    p.output.split.test = 0.0;
    p
}

#[test]
fn a_frame_after_others_with_the_same_sky_is_the_frame_made_alone() {
    // The renderer kept a procedural sky's (or a backplate's) pixels
    // unexposed once it met the same background again and exposed the kept
    // 8-bit copy by a table: quantised twice, where a frame made alone (or
    // by another maker) was drawn at its exposure: frame 1 of a batch
    // differed from `swarmshot frame --index 1`.
    let tmp = tempfile::tempdir().expect("tempdir");
    let file = common::preset_file(tmp.path(), &same_sky_new_exposures(), "p.ron");
    let out = tmp.path().join("ds");
    common::cli::batch(&file, &out, &["--limit", "3", "--makers", "1"]);
    let images = common::files_under(&out.join("images"));
    for index in 1..3u64 {
        let name = format!("{index:08}.png");
        let in_batch = images
            .iter()
            .find(|f| f.file_name().is_some_and(|n| n == name.as_str()))
            .unwrap_or_else(|| panic!("no {name} in {images:?}"));
        let alone = tmp.path().join(format!("alone{index}.png"));
        let index_arg = index.to_string();
        common::cli::ok(&[
            os("frame"),
            file.as_os_str(),
            os("--index"),
            os(&index_arg),
            os("--out"),
            alone.as_os_str(),
        ]);
        let read = |p: &Path| std::fs::read(p).expect("read image");
        assert!(
            read(&out.join("images").join(in_batch)) == read(&alone),
            "frame {index}: the batch's image is not the frame made alone"
        );
    }
}

/// Where `file`'s test code starts: its `#[cfg(test)]` module (test code
/// may detect the CPU to run both builds), or the end of the file.
fn non_test_code(text: &str) -> &str {
    let end = text.find("#[cfg(test)]\nmod tests").unwrap_or(text.len());
    &text[..end]
}

/// Every `.rs` file under `dir`, but the tests' own files (`tests.rs`).
fn sources(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    for e in std::fs::read_dir(dir).expect("read src") {
        let path = e.expect("entry").path();
        if path.is_dir() {
            out.extend(sources(&path));
        } else if path.extension().is_some_and(|x| x == "rs")
            && path.file_name().is_some_and(|n| n != "tests.rs")
        {
            out.push(path);
        }
    }
    out
}

#[test]
fn only_the_one_simd_level_detects_cpu_features() {
    // The upsampling (AVX2, F16C) and the optical flow's background rows
    // (AVX2) asked the CPU themselves, so `SWARMSHOT_SIMD=base` left them
    // vectorised and the tests above could not compare their builds. Every
    // dispatch now asks `crate::simd` (src/simd.rs), the one place that detects features.
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let allowed = src.join("simd.rs");
    let offenders: Vec<String> = sources(&src)
        .into_iter()
        .filter(|f| *f != allowed)
        .filter(|f| {
            let text = std::fs::read_to_string(f).expect("read source");
            non_test_code(&text).contains("is_x86_feature_detected!")
        })
        .map(|f| {
            f.strip_prefix(&src)
                .expect("under src")
                .display()
                .to_string()
        })
        .collect();
    assert!(
        offenders.is_empty(),
        "these detect CPU features themselves instead of asking crate::simd \
         (SWARMSHOT_SIMD cannot cap them): {offenders:?}"
    );
}
