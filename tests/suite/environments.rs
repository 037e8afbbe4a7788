//! Environments: golden images of the seven procedural environments, image
//! skies from the bundled HDR/EXR files (tests/data), cubemaps, clamping, validation and
//! per-frame randomisation. Regenerate the goldens with `UPDATE_GOLDEN=1`.

use std::path::{Path, PathBuf};

use swarmshot::preset::{Preset, Sky, SkyImageSource};
use swarmshot::render::GpuContext;
use swarmshot::sky::{
    EnvironmentAssets, EnvironmentError, EnvironmentName, FrameEnvironment, SkyImageKind,
    frame_environment, procedural_lighting,
};
use swarmshot::tools::gallery::{environment_preset, fixed_environment, render_preset};

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

fn testdata(rel: &str) -> PathBuf {
    root().join("tests/data").join(rel)
}

fn gpu() -> GpuContext {
    // Fails loudly where no adapter exists (CI installs lavapipe).
    GpuContext::headless().expect("a GPU adapter (lavapipe) is required for rendering tests")
}

const W: u32 = 160;
const H: u32 = 90;

/// Mean absolute error (0–255) and the share of channels differing by more than 24.
fn compare(a: &[u8], b: &[u8]) -> (f64, f64) {
    let (mut sum, mut big) = (0u64, 0usize);
    for (x, y) in a.iter().zip(b) {
        let d = x.abs_diff(*y);
        sum += u64::from(d);
        big += usize::from(d > 24);
    }
    (sum as f64 / a.len() as f64, big as f64 / a.len() as f64)
}

fn check_golden(name: &str, rgba: &[u8]) {
    let path = root().join("tests/golden").join(format!("{name}.png"));
    if std::env::var_os("UPDATE_GOLDEN").is_some() {
        std::fs::create_dir_all(path.parent().expect("dir")).expect("mkdir");
        image::RgbaImage::from_raw(W, H, rgba.to_vec())
            .expect("size")
            .save(&path)
            .expect("write golden");
        return;
    }
    let golden = image::open(&path)
        .unwrap_or_else(|e| panic!("{}: {e} (run with UPDATE_GOLDEN=1)", path.display()))
        .to_rgba8();
    assert_eq!(golden.dimensions(), (W, H));
    let (mae, share) = compare(golden.as_raw(), rgba);
    assert!(
        mae < 2.0 && share < 0.01,
        "{name}: mean abs error {mae:.2}, {:.2}% of channels off by > 24",
        share * 100.0
    );
}

#[test]
fn each_environment_matches_its_golden_image_and_differs_from_the_others() {
    let ctx = gpu();
    let mut frames = Vec::new();
    for name in EnvironmentName::ALL {
        let rgba = render_preset(&ctx, &environment_preset(fixed_environment(name), W, H))
            .expect("render");
        check_golden(&format!("env-{}", name.as_str()), &rgba);
        frames.push((name, rgba));
    }
    let gradient = render_preset(&ctx, &environment_preset(Sky::default(), W, H)).expect("render");
    check_golden("gradient", &gradient);
    // Every environment looks different from every other and from the gradient.
    for (i, (a, fa)) in frames.iter().enumerate() {
        assert!(
            compare(fa, &gradient).0 > 8.0,
            "{a:?} looks like the gradient sky"
        );
        for (b, fb) in &frames[i + 1..] {
            assert!(compare(fa, fb).0 > 4.0, "{a:?} and {b:?} look alike");
        }
    }
}

#[test]
fn the_environment_is_deterministic_and_its_seed_moves_the_clouds() {
    let ctx = gpu();
    let sky = fixed_environment(EnvironmentName::BeautifulPasture);
    let a = render_preset(&ctx, &environment_preset(sky.clone(), W, H)).expect("render");
    let b = render_preset(&ctx, &environment_preset(sky, W, H)).expect("render");
    assert_eq!(a, b);
    let other = match fixed_environment(EnvironmentName::BeautifulPasture) {
        Sky::Procedural { environment, .. } => Sky::Procedural {
            environment,
            sun_elevation_deg: None,
            sun_azimuth_deg: None,
            turbidity: None,
            cloud_cover: None,
            seed: Some(1234),
            exposure_ev: 0.0,
            sun_ev: 0.0,
        },
        s => s,
    };
    let c = render_preset(&ctx, &environment_preset(other, W, H)).expect("render");
    assert!(
        compare(&a, &c).0 > 0.5,
        "another seed must move the clouds and fields"
    );
}

#[test]
fn the_environment_sun_lights_the_drones() {
    let env = |name: EnvironmentName| {
        let style = name.style();
        let f = FrameEnvironment {
            choice: 0,
            sun_elevation_deg: style.sun_elevation_deg,
            sun_azimuth_deg: 0.0,
            azimuth_offset_deg: 0.0,
            cloud_cover: style.cloud_cover,
            turbidity: style.turbidity,
            pattern_seed: 0,
            exposure_offset_ev: 0.0,
            sun_offset_ev: 0.0,
        };
        procedural_lighting(&style, &f, 1.0, 1.0)
    };
    let (day, sunset) = (env(EnvironmentName::Daytime), env(EnvironmentName::Sunset));
    let warmth = |c: [f32; 3]| c[0] / c[2].max(1e-6);
    assert!(
        warmth(sunset.sun_color) > 2.0 * warmth(day.sun_color),
        "{:?} vs {:?}",
        sunset.sun_color,
        day.sun_color
    );
    assert!(
        day.zenith[2] > day.zenith[0],
        "the day sky's ambient is blue: {:?}",
        day.zenith
    );
}

#[test]
fn bundled_hdr_and_exr_skies_load_clamped_and_render() {
    let ctx = gpu();
    let mut files: Vec<PathBuf> = ["sky/polyhaven_cc0", "sky/blender_cc0"]
        .iter()
        .flat_map(|d| {
            std::fs::read_dir(testdata(d))
                .expect("sky folder")
                .flatten()
                .map(|e| e.path())
        })
        .filter(|p| matches!(p.extension().and_then(|e| e.to_str()), Some("hdr" | "exr")))
        .collect();
    files.sort();
    // One Radiance .hdr and one OpenEXR: tests/data/README.md.
    let ext = |p: &PathBuf| p.extension().and_then(|e| e.to_str()).map(str::to_owned);
    assert_eq!(
        files.iter().map(ext).collect::<Vec<_>>(),
        [Some("exr".to_owned()), Some("hdr".to_owned())],
        "{files:?}"
    );
    for file in &files {
        let sky = Sky::Image {
            source: SkyImageSource::Equirect(file.clone()),
            exposure_ev: 0.0,
            rotation_deg: 0.0,
            sun_elevation_deg: 40.0,
            sun_azimuth_deg: 0.0,
        };
        let assets = EnvironmentAssets::load(&sky).unwrap_or_else(|e| panic!("{e}"));
        let image = &assets.images[0];
        assert!(image.hdr);
        let SkyImageKind::Equirect { width, height, rgb } = &image.kind else {
            panic!("equirect")
        };
        assert_eq!((*width, *height), (1024, 512), "{}", file.display());
        assert!(rgb.iter().all(|c| c.is_finite() && *c >= 0.0));
        assert!(image.mean_upper.iter().all(|c| *c > 0.0));
        let rgba = render_preset(&ctx, &environment_preset(sky.clone(), W, H)).expect("render");
        let mean = rgba.iter().map(|&c| f64::from(c)).sum::<f64>() / rgba.len() as f64;
        assert!(
            mean > 20.0,
            "{}: frame is nearly black ({mean})",
            file.display()
        );
        // Turning the image turns the view.
        let turned = match sky {
            Sky::Image { source, .. } => Sky::Image {
                source,
                exposure_ev: 0.0,
                rotation_deg: 180.0,
                sun_elevation_deg: 40.0,
                sun_azimuth_deg: 0.0,
            },
            s => s,
        };
        let rgba_turned = render_preset(&ctx, &environment_preset(turned, W, H)).expect("render");
        assert!(
            compare(&rgba, &rgba_turned).0 > 1.0,
            "{}: rotation had no effect",
            file.display()
        );
    }
}

#[test]
fn negative_and_non_finite_hdr_values_are_clamped() {
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("bad.exr");
    let mut img = image::Rgb32FImage::new(8, 4);
    for (i, p) in img.pixels_mut().enumerate() {
        p.0 = match i % 4 {
            0 => [f32::NAN, 1.0, 1.0],
            1 => [-5.0, 0.5, f32::INFINITY],
            2 => [1e9, 2.0, 3.0],
            _ => [0.25, 0.5, 0.75],
        };
    }
    img.save(&path).expect("write exr");
    let sky = Sky::Image {
        source: SkyImageSource::Equirect(path),
        exposure_ev: 0.0,
        rotation_deg: 0.0,
        sun_elevation_deg: 45.0,
        sun_azimuth_deg: 0.0,
    };
    let assets = EnvironmentAssets::load(&sky).expect("load");
    let SkyImageKind::Equirect { rgb, .. } = &assets.images[0].kind else {
        panic!("equirect")
    };
    assert!(
        rgb.iter()
            .all(|c| c.is_finite() && (0.0..=65_000.0).contains(c)),
        "{rgb:?}"
    );
    assert_eq!(&rgb[0..3], &[0.0, 1.0, 1.0]);
    assert_eq!(&rgb[3..6], &[0.0, 0.5, 65_000.0]);
}

fn write_face(dir: &Path, name: &str, side: u32, rgb: [u8; 3]) -> PathBuf {
    let p = dir.join(format!("{name}.png"));
    image::RgbImage::from_pixel(side, side, image::Rgb(rgb))
        .save(&p)
        .expect("face");
    p
}

#[test]
fn cubemap_faces_are_drawn_in_their_directions_and_bad_faces_are_named() {
    let dir = tempfile::tempdir().expect("tempdir");
    let d = dir.path();
    let colours = [
        [255, 0, 0],
        [0, 255, 0],
        [0, 0, 255],
        [255, 255, 0],
        [255, 0, 255],
        [0, 255, 255],
    ];
    let names = ["px", "nx", "py", "ny", "pz", "nz"];
    let f: Vec<PathBuf> = names
        .iter()
        .zip(colours)
        .map(|(n, c)| write_face(d, n, 16, c))
        .collect();
    let source = SkyImageSource::Cubemap {
        px: f[0].clone(),
        nx: f[1].clone(),
        py: f[2].clone(),
        ny: f[3].clone(),
        pz: f[4].clone(),
        nz: f[5].clone(),
    };
    let sky = Sky::Image {
        source: source.clone(),
        exposure_ev: 0.0,
        rotation_deg: 0.0,
        sun_elevation_deg: 45.0,
        sun_azimuth_deg: 0.0,
    };
    let mut preset: Preset = environment_preset(sky, W, H);
    preset.camera.y = swarmshot::preset::sweep::SweepRange::fixed(0.0);
    // The sky alone: frame 0 with its drones taken out.
    let pipeline = swarmshot::pipeline::FramePipeline::new(preset).expect("pipeline");
    let mut renderer = pipeline.renderer(&gpu());
    let mut scene = pipeline.scene(0).expect("scene");
    scene.drones.clear();
    let rgba = pipeline
        .make_scene(&mut renderer, scene)
        .expect("render")
        .rgba;
    // The camera sits on +Z looking at the origin, i.e. along −Z: the centre shows the nz face.
    let centre = ((H / 2 * W + W / 2) * 4) as usize;
    assert_eq!(
        &rgba[centre..centre + 3],
        &[0, 255, 255],
        "centre pixel {:?}",
        &rgba[centre..centre + 4]
    );

    let small = write_face(d, "small", 8, [1, 2, 3]);
    let bad = SkyImageSource::Cubemap {
        px: f[0].clone(),
        nx: f[1].clone(),
        py: small,
        ny: f[3].clone(),
        pz: f[4].clone(),
        nz: f[5].clone(),
    };
    let sky = Sky::Image {
        source: bad,
        exposure_ev: 0.0,
        rotation_deg: 0.0,
        sun_elevation_deg: 45.0,
        sun_azimuth_deg: 0.0,
    };
    match EnvironmentAssets::load(&sky) {
        Err(e @ EnvironmentError::CubemapFace { face: "py", .. }) => {
            assert!(e.to_string().contains("small.png"), "{e}")
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn only_referenced_images_are_loaded_and_missing_ones_are_named() {
    assert!(
        EnvironmentAssets::load(&Sky::procedural(EnvironmentName::Sunset))
            .expect("no images")
            .images
            .is_empty()
    );
    assert!(
        EnvironmentAssets::load(&Sky::default())
            .expect("no images")
            .images
            .is_empty()
    );
    let hdr = testdata("sky/polyhaven_cc0/venice_sunset_1k.hdr");
    let image = |p: PathBuf| Sky::Image {
        source: SkyImageSource::Equirect(p),
        exposure_ev: 0.0,
        rotation_deg: 0.0,
        sun_elevation_deg: 45.0,
        sun_azimuth_deg: 0.0,
    };
    let random = Sky::Random {
        choices: vec![
            Sky::procedural(EnvironmentName::Daytime),
            image(hdr.clone()),
            image(hdr),
        ],
        azimuth_offset_deg: (0.0, 0.0),
        sun_elevation_deg: None,
        cloud_cover: None,
        exposure_ev: None,
        sun_ev: None,
    };
    assert_eq!(
        EnvironmentAssets::load(&random).expect("load").images.len(),
        1,
        "the same file is loaded once"
    );
    let missing = testdata("sky/does-not-exist.hdr");
    match EnvironmentAssets::load(&image(missing)) {
        Err(e @ EnvironmentError::Image { .. }) => {
            assert!(e.to_string().contains("does-not-exist.hdr"), "{e}")
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn sky_presets_parse_and_invalid_fields_are_named() {
    let text = r#"(sky: Random(choices: [Procedural(environment: Sunset), Procedural(environment: Tellsplatte, cloud_cover: 0.8)], azimuth_offset_deg: (0, 360), sun_elevation_deg: (5, 40)))"#;
    let p = Preset::from_ron(text).expect("parse");
    assert!(p.validate().is_ok(), "{:?}", p.validate());
    let envs: Vec<FrameEnvironment> = (0..50)
        .map(|i| frame_environment(&p.sky, p.seed, i))
        .collect();
    assert!(envs.iter().any(|e| e.choice == 0) && envs.iter().any(|e| e.choice == 1));
    assert!(
        envs.iter()
            .all(|e| (5.0..=40.0).contains(&e.sun_elevation_deg))
    );

    let bad = r#"(sky: Random(choices: [Procedural(environment: Daytime, turbidity: 30.0), Random(choices: [])], cloud_cover: (0.9, 0.1)))"#;
    let errors = Preset::from_ron(bad)
        .expect("parse")
        .validate()
        .expect_err("invalid");
    let fields: Vec<&str> = errors.iter().map(|e| e.field.as_str()).collect();
    for want in [
        "sky.choices[0].turbidity",
        "sky.choices[1]",
        "sky.choices[1].choices",
        "sky.cloud_cover",
    ] {
        assert!(fields.contains(&want), "{want} missing from {fields:?}");
    }
    assert!(Preset::from_ron("(sky: Procedural(environment: Mars))").is_err());
}

/// A sky drawn at random among every named environment, its sun and clouds too.
fn random_environments() -> Sky {
    Sky::Random {
        choices: EnvironmentName::ALL
            .iter()
            .map(|&n| Sky::procedural(n))
            .collect(),
        azimuth_offset_deg: (0.0, 360.0),
        sun_elevation_deg: Some((10.0, 60.0)),
        cloud_cover: Some((0.0, 1.0)),
        exposure_ev: None,
        sun_ev: None,
    }
}

#[test]
fn random_environments_do_not_change_the_drones() {
    let mut a = environment_preset(Sky::default(), W, H);
    let scene_a = swarmshot::scene::build_frame(&a, 0).expect("frame");
    a.sky = random_environments();
    let scene_b = swarmshot::scene::build_frame(&a, 0).expect("frame");
    assert_eq!(scene_a.drones, scene_b.drones);
    assert_ne!(scene_a.environment, scene_b.environment);
    assert_eq!(scene_b.sun_direction, scene_b.environment.sun_direction());
}

#[test]
fn a_frame_of_random_environments_is_the_same_made_alone_or_after_others() {
    // One renderer draws frames of another environment and horizon each in
    // turn (its environment targets kept from frame to frame); each must be
    // the frame a fresh renderer makes alone: nothing of a frame before it
    // may show through (the environment's passes write every texel).
    let mut preset = environment_preset(random_environments(), W, H);
    preset.camera.x = swarmshot::preset::sweep::SweepRange {
        start: -0.5,
        end: 0.5,
        step: 0.5,
    };
    preset.camera.y = swarmshot::preset::sweep::SweepRange {
        start: 0.05,
        end: 0.65,
        step: 0.3,
    };
    let pipeline = swarmshot::pipeline::FramePipeline::new(preset).expect("pipeline");
    let ctx = gpu();
    let mut renderer = pipeline.renderer(&ctx);
    let n = pipeline.frame_count();
    assert!(n >= 6, "{n} frames");
    let in_turn: Vec<Vec<u8>> = (0..n)
        .map(|i| pipeline.make(&mut renderer, i).expect("frame").rgba)
        .collect();
    for i in [1, n / 2, n - 1] {
        let alone = pipeline
            .make(&mut pipeline.renderer(&ctx), i)
            .expect("frame alone");
        assert!(
            alone.rgba == in_turn[i as usize],
            "frame {i} depends on the frames before it"
        );
        assert!(
            compare(&in_turn[i as usize], &in_turn[i as usize - 1]).0 > 1.0,
            "frames {i} and {} alike",
            i - 1
        );
    }
}
