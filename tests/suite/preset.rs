//! Presets: the shipped files load, RON round-trips, and every invalid value
//! is rejected with a message that names its field.

use crate::common;

use std::path::Path;

use swarmshot::preset::sweep::SweepRange;
use swarmshot::preset::{ImageFormat, Placement, Preset, Resolution, Volume};

fn errors_of(p: &Preset) -> Vec<String> {
    match p.validate() {
        Ok(()) => Vec::new(),
        Err(errors) => errors.iter().map(ToString::to_string).collect(),
    }
}

#[track_caller]
fn assert_rejected(p: &Preset, field: &str, needle: &str) {
    let errors = errors_of(p);
    assert!(
        errors
            .iter()
            .any(|e| e.starts_with(&format!("{field}:")) && e.contains(needle)),
        "expected an error on `{field}` mentioning {needle:?}, got {errors:#?}"
    );
}

#[test]
fn shipped_presets_load_and_validate() {
    // presets/ and its folders (bench/, sim2real/).
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("presets");
    let mut dirs = vec![root.clone()];
    let mut n = 0;
    while let Some(dir) = dirs.pop() {
        for entry in std::fs::read_dir(&dir).expect("presets/ exists") {
            let path = entry.expect("dir entry").path();
            if path.is_dir() {
                dirs.push(path);
            } else if path.extension().is_some_and(|e| e == "ron") {
                let preset = Preset::load(&path).unwrap_or_else(|e| panic!("{e}"));
                assert!(preset.frame_count() > 0, "{}", path.display());
                n += 1;
            }
        }
    }
    // 19 in presets/, 15 in bench/, 4 in sim2real/: a folder the walk missed fails here.
    assert!(n >= 38, "{n} presets");
    // The sim-to-real presets are the shipped ones at the real footage's size.
    let sim2real = root.join("sim2real/realistic_640x512.ron");
    let preset = Preset::load(&sim2real).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(preset.image_size(), (640, 512));
}

/// The bench preset that times `realistic.ron` without its camera model is that preset,
/// its camera model and name aside: an edit of one that the other misses fails here.
#[test]
fn realistic_no_camera_is_realistic_without_its_camera_model() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("presets");
    let load = |p: &str| Preset::load(&root.join(p)).unwrap_or_else(|e| panic!("{e}"));
    let mut realistic = load("realistic.ron");
    let bench = load("bench/realistic_no_camera.ron");
    assert!(realistic.camera_model.is_some() && bench.camera_model.is_none());
    realistic.camera_model = None;
    realistic.name.clone_from(&bench.name);
    assert_eq!(realistic, bench);
}

#[test]
fn quickstart_is_paper_like() {
    let p = Preset::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("presets/quickstart.ron"))
        .expect("quickstart loads");
    assert!(p.frame_count() >= 100, "{} frames", p.frame_count());
    assert_eq!(p.image_size(), (1920, 1080));
    assert!(matches!(
        p.placement,
        Placement::Randomized { count: (1, 15), .. }
    ));
    assert_eq!(p.output.image_format, ImageFormat::Jpeg { quality: 85 });
}

#[test]
fn ron_round_trip_is_exact() {
    let p = common::tiny_preset();
    let text = p.to_ron();
    let back = Preset::from_ron(&text).expect("own output parses");
    assert_eq!(back, p);
    assert_eq!(back.to_ron(), text);
}

#[test]
fn missing_fields_take_defaults() {
    let p = Preset::from_ron("(name: \"sparse\", seed: 3)").expect("parses");
    assert_eq!(p.seed, 3);
    assert_eq!(p.output.split.train, 0.7);
    assert!(p.validate().is_ok());
}

#[test]
fn parse_errors_name_the_file_and_position() {
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("bad.ron");
    std::fs::write(&path, "(seed: \"not a number\")").expect("write");
    let msg = Preset::load(&path).expect_err("must fail").to_string();
    assert!(msg.contains("bad.ron") && msg.contains("1:"), "{msg}");
}

#[test]
fn invalid_values_name_their_field() {
    let base = common::tiny_preset();
    assert!(base.validate().is_ok(), "{:?}", base.validate());

    let mut p = base.clone();
    p.camera.z = SweepRange::new(1.0, 2.0, 0.0);
    assert_rejected(&p, "camera.z.step", "step is 0");

    let mut p = base.clone();
    p.plane.rx = SweepRange::new(0.0, 90.0, -10.0);
    assert_rejected(&p, "plane.rx.step", "points away");

    let mut p = base.clone();
    p.camera.x = SweepRange::new(f64::NAN, 1.0, 0.1);
    assert_rejected(&p, "camera.x", "finite");

    let mut p = base.clone();
    p.camera.fov_y_deg = f64::INFINITY;
    assert_rejected(&p, "camera.fov_y_deg", "inf");

    let mut p = base.clone();
    p.placement = Placement::Structured {
        x_count: 0,
        y_count: 2,
        z_count: 2,
        load_factor: 2.0,
    };
    assert_rejected(&p, "placement.x_count", "at least 1");

    let mut p = base.clone();
    p.placement = Placement::Structured {
        x_count: 2,
        y_count: 2,
        z_count: 2,
        load_factor: 0.5,
    };
    assert_rejected(&p, "placement.load_factor", "overlap");

    let mut p = base.clone();
    p.placement = Placement::Randomized {
        count: (0, 3),
        count_distribution: Default::default(),
        volume: Volume::default(),
        min_separation_m: 0.5,
    };
    assert_rejected(&p, "placement.count", "at least 1");

    let mut p = base.clone();
    p.placement = Placement::Randomized {
        count: (500, 500),
        count_distribution: Default::default(),
        volume: Volume::Box {
            size_m: (2.0, 2.0, 2.0),
        },
        min_separation_m: 1.0,
    };
    assert_rejected(&p, "placement.min_separation_m", "fill");

    let mut p = base.clone();
    p.render.resolution = Resolution::Custom {
        width: 0,
        height: 100,
    };
    assert_rejected(&p, "render.resolution.width", "0 px");

    let mut p = base.clone();
    p.render.resolution = Resolution::Custom {
        width: 100_000,
        height: 100,
    };
    assert_rejected(&p, "render.resolution.width", "100000");

    let mut p = base.clone();
    p.camera.x = SweepRange::new(0.0, 100.0, 0.001);
    p.camera.y = SweepRange::new(0.0, 100.0, 0.001);
    assert_rejected(&p, "frames", "limit");

    let mut p = base.clone();
    p.camera.z = SweepRange::new(-1.0, 1.0, 1.0);
    p.camera.x = SweepRange::fixed(0.0);
    p.camera.y = SweepRange::fixed(0.0);
    assert_rejected(&p, "camera.z", "centre");

    let mut p = base.clone();
    p.output.split.train = 0.9;
    assert_rejected(&p, "output.split", "sum");

    let mut p = base.clone();
    p.render.msaa = 2;
    assert_rejected(&p, "render.msaa", "1 or 4");

    let mut p = base.clone();
    p.models[0].size_m = -1.0;
    assert_rejected(&p, "models[0].size_m", "> 0");

    let mut p = base;
    p.attitude.pitch_deg = (10.0, -10.0);
    assert_rejected(&p, "attitude.pitch_deg", "min ≤ max");
}

#[test]
fn a_count_range_upside_down_says_so_in_words() {
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/presets/quickstart.ron"
    ))
    .expect("reads the quickstart");
    let mut p = Preset::from_ron(&text).expect("parses");
    let Placement::Randomized { count, .. } = &mut p.placement else {
        panic!("the quickstart places drones at random");
    };
    *count = (1, 0);
    assert_rejected(&p, "placement.count", "minimum 1 is more than maximum 0");
}

#[test]
fn positional_fields_and_a_nan_size_are_named_plainly() {
    let e = Preset::from_ron("(render: (resolution: Custom(321, 241)))").expect_err("positional");
    assert!(
        e.reason
            .contains("`321` in `render.resolution` where a field's name goes"),
        "{}",
        e.reason
    );
    assert!(!e.reason.contains("raw identifier"), "{}", e.reason);
    let mut p = Preset::default();
    p.models[0].size_m = f64::NAN;
    let errors = p.validate().expect_err("a NaN size");
    let on_size: Vec<&str> = (errors.iter())
        .filter(|e| e.field == "models[0].size_m")
        .map(|e| e.message.as_str())
        .collect();
    assert_eq!(on_size.len(), 1, "{on_size:?}");
    assert!(on_size[0].contains("finite number > 0"), "{on_size:?}");
}
