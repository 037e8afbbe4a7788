//! Rain and snow (issue 41 item 4; src/scene/weather.rs, src/pipeline/weather.rs):
//! the labels under weather against a drone-free frame made with the same
//! draws, a drone hidden whole by flakes, masks, the camera model and a
//! lens under weather, determinism (a frame alone equals the batch's), the draws left
//! alone and the preset's errors named (lavapipe).

use crate::common;

use swarmshot::pipeline::FramePipeline;
use swarmshot::preset::Preset;
use swarmshot::preset::weather::{Weather, WeatherKind};

/// One drone at 240×160, labelled by its visible box, behind `weather`.
fn preset(weather: Weather) -> Preset {
    let mut p = common::single_drone_preset(3.0);
    p.camera.y = swarmshot::preset::sweep::SweepRange::new(-0.6, 0.6, 0.4);
    p.repeats = 3;
    p.weather = Some(weather);
    p
}

/// Flakes so big and close that some cover the drone, some do not.
fn near_snow() -> Weather {
    Weather {
        intensity_per_m3: (40.0, 40.0),
        diameter_mm: (20.0, 50.0),
        depth_m: (0.05, 3.0),
        exposure_s: (0.0, 0.001),
        ..Weather::snow()
    }
}

/// The frame's labels against the truth: the pixels where the frame
/// differs from the same frame made without its drones (same draws, same
/// particles). Returns (visible pixels under weather, rendered without it).
fn check_against_drone_free(p: &Preset) -> Vec<(u64, u64)> {
    let ctx = common::gpu();
    let pipeline = FramePipeline::new(p.clone()).expect("pipeline");
    let mut renderer = pipeline.renderer(&ctx);
    let mut out = Vec::new();
    for index in 0..p.frame_count() {
        let frame = pipeline.make(&mut renderer, index).expect("frame");
        let w = frame.scene.camera.width;
        let mut empty = frame.scene.clone();
        empty.drones.clear();
        let empty = pipeline.make_scene(&mut renderer, empty).expect("empty");
        let mut dry = frame.scene.clone();
        dry.weather = None;
        let dry = pipeline.make_scene(&mut renderer, dry).expect("dry");
        let truth = common::changed_box(&frame.rgba, &empty.rgba, w);
        let label = &frame.labels[0];
        let vis = label.visibility.expect("measured");
        let rendered = dry.labels[0].visibility.expect("measured");
        let case = format!("frame {index} at {:.2} m", label.distance_m);
        match truth {
            Some((r, n)) => {
                let b = vis.visible_box.expect(&case);
                let want = [r.x0, r.y0, r.x1, r.y1].map(f64::from);
                assert_eq!([b.x0, b.y0, b.x1, b.y1], want, "{case}");
                assert_eq!(vis.visible_pixels, n, "{case}");
                assert_eq!(label.bbox, b, "{case}");
            }
            None => {
                assert_eq!(vis.visible_box, None, "{case}");
                assert_eq!(vis.visible_pixels, 0, "{case}");
                assert!(
                    !label.is_kept(),
                    "{case}: a hidden drone is no training box"
                );
            }
        }
        // Weather hides; it never adds to a drone or changes what it would cover.
        assert!(vis.visible_pixels <= rendered.visible_pixels, "{case}");
        assert_eq!(vis.unoccluded_pixels, rendered.unoccluded_pixels, "{case}");
        assert_eq!(label.amodal, dry.labels[0].amodal, "{case}");
        out.push((vis.visible_pixels, rendered.visible_pixels));
    }
    out
}

#[test]
fn visible_boxes_under_snow_are_the_pixels_that_still_show() {
    let counts = check_against_drone_free(&preset(near_snow()));
    let hidden = counts.iter().filter(|(v, r)| v < r).count();
    assert!(hidden > 0, "flakes cover some drone pixels: {counts:?}");
    assert!(
        counts.iter().any(|(v, _)| *v > 0),
        "some drone shows: {counts:?}"
    );
}

#[test]
fn visible_boxes_under_rain_are_the_pixels_that_still_show() {
    let rain = Weather {
        intensity_per_m3: (60.0, 60.0),
        depth_m: (0.3, 6.0),
        opacity: (0.6, 0.9),
        ..Weather::rain()
    };
    let counts = check_against_drone_free(&preset(rain));
    // Translucent streaks veil a drone; they hide (almost) none of it.
    let shown: u64 = counts.iter().map(|c| c.0).sum();
    let rendered: u64 = counts.iter().map(|c| c.1).sum();
    assert!(shown * 10 >= rendered * 9, "{shown} of {rendered}");
}

#[test]
fn a_drone_behind_a_wall_of_flakes_has_no_visible_box() {
    // About 18 flakes in front of every pixel on average (10⁴ m⁻³ · π·(25 mm)² · 0.95 m).
    let wall = Weather {
        intensity_per_m3: (10_000.0, 10_000.0),
        diameter_mm: (50.0, 50.0),
        depth_m: (0.05, 1.0),
        exposure_s: (0.0, 0.0),
        ..Weather::snow()
    };
    let counts = check_against_drone_free(&preset(wall));
    assert!(
        counts.iter().all(|&(v, r)| v == 0 && r > 0),
        "every drone drawn, none shows: {counts:?}"
    );
}

#[test]
fn flakes_behind_the_drone_leave_it_whole() {
    // Every particle far behind the drone: its pixels are the rendered ones.
    let far = Weather {
        intensity_per_m3: (5.0, 5.0),
        diameter_mm: (40.0, 50.0),
        depth_m: (500.0, 600.0),
        ..Weather::snow()
    };
    let counts = check_against_drone_free(&preset(far));
    assert!(counts.iter().all(|(v, r)| v == r), "{counts:?}");
}

#[test]
fn masks_under_weather_are_the_visible_pixels() {
    let mut p = preset(near_snow());
    p.output.masks.instance_png = true;
    let ctx = common::gpu();
    let pipeline = FramePipeline::new(p.clone()).expect("pipeline");
    let mut renderer = pipeline.renderer(&ctx);
    for index in 0..p.frame_count() {
        let frame = pipeline.make(&mut renderer, index).expect("frame");
        let masks = frame.masks.expect("masks");
        let vis = frame.labels[0].visibility.expect("measured");
        assert_eq!(masks.count(0), vis.visible_pixels, "frame {index}");
    }
}

#[test]
fn weather_through_the_camera_model_labels_what_the_camera_shows() {
    let mut p = preset(near_snow());
    p.camera_model = Some(swarmshot::preset::camera_model::CameraModel::default());
    let ctx = common::gpu();
    let pipeline = FramePipeline::new(p.clone()).expect("pipeline");
    let mut renderer = pipeline.renderer(&ctx);
    let mut dry_p = p.clone();
    dry_p.weather = None;
    let dry_pipeline = FramePipeline::new(dry_p).expect("pipeline");
    let mut some_hidden = false;
    for index in 0..p.frame_count() {
        let frame = pipeline.make(&mut renderer, index).expect("frame");
        let dry = dry_pipeline.make(&mut renderer, index).expect("dry");
        let (v, d) = (frame.labels[0].visibility, dry.labels[0].visibility);
        let (v, d) = (v.expect("measured"), d.expect("measured"));
        assert!(v.visible_pixels <= d.visible_pixels, "frame {index}");
        some_hidden |= v.visible_pixels < d.visible_pixels;
        assert_eq!(frame.scene.camera_model, dry.scene.camera_model);
    }
    assert!(some_hidden);
}

/// The noise-free camera image of `rgba` (a rendered frame at the drawn
/// exposure) through `scene`'s lens.
fn through_lens(rgba: &[u8], scene: &swarmshot::scene::FrameScene) -> Vec<u8> {
    let (w, h) = (scene.camera.width, scene.camera.height);
    let geo = swarmshot::scene::projection::frame_lens(scene).expect("a lens");
    let lensed = swarmshot::sensor::lens::LensMap::of(&geo).remap(rgba);
    let draw = scene.camera_model.expect("drawn").after_render();
    let full = swarmshot::sensor::PixelRect {
        x0: 0,
        y0: 0,
        x1: w,
        y1: h,
    };
    swarmshot::sensor::develop(&lensed, w, h, &draw, full, false)
}

#[test]
fn weather_through_a_lens_labels_the_pixels_the_drone_changes() {
    use swarmshot::preset::lens::Lens;
    let mut p = preset(near_snow());
    p.camera_model = Some(swarmshot::preset::camera_model::CameraModel {
        read_noise_levels: (1.0, 1.0),
        lens: Some(Lens::BrownConrady {
            k1: (-0.25, -0.25),
            k2: (0.05, 0.05),
            k3: (0.0, 0.0),
            p1: (0.002, 0.002),
            p2: (-0.001, -0.001),
        }),
        ..Default::default()
    });
    p.validate().expect("weather and a lens together");
    let ctx = common::gpu();
    let pipeline = FramePipeline::new(p.clone()).expect("pipeline");
    let geometry = &pipeline.assets().geometry;
    let mut renderer = pipeline.renderer(&ctx);
    let (mut shown, mut hidden) = (0, 0);
    for index in 0..p.frame_count() {
        let frame = pipeline.make(&mut renderer, index).expect("frame");
        let scene = &frame.scene;
        // The truth: the particles over the frame and over its drone-free
        // render, each through the lens and the noise-free camera.
        let mut rgba = common::rendered_at_exposure(&mut renderer, scene, p.render.msaa);
        let mut empty = scene.clone();
        empty.drones.clear();
        let background = common::rendered_at_exposure(&mut renderer, &empty, p.render.msaa);
        let clear = swarmshot::pipeline::weather::over_pixels(
            (scene, geometry),
            &mut rgba,
            Some(&background),
            Some(Vec::new()),
        )
        .expect("weather");
        let (a, b) = (through_lens(&rgba, scene), through_lens(&clear, scene));
        let vis = frame.labels[0].visibility.expect("measured");
        let case = format!("frame {index}");
        match common::changed_box(&a, &b, scene.camera.width) {
            Some((r, n)) => {
                let vb = vis.visible_box.expect(&case);
                let want = [r.x0, r.y0, r.x1, r.y1].map(f64::from);
                assert_eq!([vb.x0, vb.y0, vb.x1, vb.y1], want, "{case}");
                assert_eq!(vis.visible_pixels, n, "{case}");
                shown += 1;
            }
            None => {
                assert_eq!(vis.visible_box, None, "{case}");
                hidden += 1;
            }
        }
        // The flakes hide some of the drone: fewer pixels than without them.
        let mut dry = scene.clone();
        dry.weather = None;
        let dry = pipeline.make_scene(&mut renderer, dry).expect("dry");
        let d = dry.labels[0].visibility.expect("measured");
        hidden += usize::from(vis.visible_pixels < d.visible_pixels);
    }
    assert!(shown > 0 && hidden > 0, "{shown} shown, {hidden} hidden");
}

#[test]
fn weather_is_deterministic_and_a_frame_alone_equals_the_batch() {
    use std::sync::atomic::AtomicBool;
    use swarmshot::pipeline::{BatchOptions, run_batch};
    let mut p = preset(Weather::rain());
    p.output.image_format = swarmshot::preset::ImageFormat::Png;
    let ctx = common::gpu();
    let pipeline = FramePipeline::new(p.clone()).expect("pipeline");
    let dir = tempfile::tempdir().expect("dir");
    let mut options = BatchOptions::new(dir.path());
    options.makers = 2;
    run_batch(&pipeline, &options, &ctx, &AtomicBool::new(false), |_| {}).expect("batch");
    let manifest = std::fs::read_to_string(dir.path().join("manifest.jsonl")).expect("manifest");
    let mut renderer = pipeline.renderer(&ctx);
    // Backwards: each frame is made alone, after frames that follow it.
    for index in (0..p.frame_count()).rev() {
        let frame = pipeline.make(&mut renderer, index).expect("frame");
        let format = pipeline.image_format(&frame.scene);
        let (w, h) = (frame.scene.camera.width, frame.scene.camera.height);
        let bytes = swarmshot::write::encode_image(&frame.rgba, w, h, format).expect("encode");
        let rel = swarmshot::write::image_rel_path(&frame.scene, format);
        let written = std::fs::read(dir.path().join(&rel)).expect("image");
        assert!(
            written == bytes,
            "frame {index}: alone differs from the batch"
        );
        let line = manifest.lines().nth(index as usize).expect("line");
        let record: serde_json::Value = serde_json::from_str(line).expect("json");
        assert_eq!(record["weather"]["kind"], "rain", "frame {index}");
        let drawn = frame.scene.weather.expect("drawn");
        assert_eq!(
            record["weather"]["particle_seed"].as_u64(),
            Some(drawn.particle_seed)
        );
    }
}

#[test]
fn weather_leaves_every_other_draw_alone() {
    let mut p = common::tiny_preset();
    let plain: Vec<_> = (0..p.frame_count())
        .map(|i| swarmshot::scene::build_frame(&p, i).expect("frame"))
        .collect();
    p.weather = Some(Weather::snow());
    for (i, before) in plain.into_iter().enumerate() {
        let mut after = swarmshot::scene::build_frame(&p, i as u64).expect("frame");
        assert_eq!(after.weather.map(|w| w.kind), Some(WeatherKind::Snow));
        after.weather = None;
        assert_eq!(after, before, "frame {i}");
    }
}

#[test]
fn invalid_weather_fields_are_named() {
    let text = r#"(weather: Some((kind: Snow, opacity: (0.5, 1.5), fall_mps: (3.0, 1.0),
        depth_m: (5.0, 2.0), intensity_per_m3: (-1.0, 1.0))), labels: (box_method: Visible, id_scale: 2))"#;
    let p = Preset::from_ron(text).expect("parses");
    let errors = p.validate().expect_err("invalid");
    let fields: Vec<&str> = errors.iter().map(|e| e.field.as_str()).collect();
    for field in [
        "weather.opacity",
        "weather.fall_mps",
        "weather.depth_m",
        "weather.intensity_per_m3",
        "labels.id_scale",
    ] {
        assert!(fields.contains(&field), "{field} in {fields:?}");
    }
    assert!(Preset::from_ron("(weather: Some((kind: Hail)))").is_err());
    assert!(Preset::from_ron("(weather: Some((kind: Rain)))").is_ok());
}

#[test]
fn the_example_presets_parse_and_validate() {
    for name in ["rain", "snow", "thermal_rain"] {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("presets")
            .join(format!("{name}.ron"));
        let p = Preset::load(&path).expect("loads");
        swarmshot::pipeline::check::validate(&p).expect("valid");
        assert!(p.weather.is_some(), "{name}");
    }
}
