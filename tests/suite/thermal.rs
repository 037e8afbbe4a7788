//! The thermal camera (issue 41 item 1; src/sensor/thermal/,
//! src/pipeline/thermal.rs): grey frames, warm drones on a cold sky (and
//! cold ones darker than it: `cold_share`), the sky warming towards the
//! horizon, the gain control's range, labels equal to the visible render's,
//! determinism, 16-bit grey PNG frames, rain and snow in the radiance with
//! labels against the drone-free radiance under the same particles, the
//! recording's capture chain, the optics' narcissus and the background's
//! texture changing the picture and not the labels
//! (lavapipe).

use crate::common;

use std::path::Path;

use swarmshot::pipeline::{Frame, FramePipeline};
use swarmshot::preset::{Preset, Resolution};

/// presets/thermal.ron at 320×256 without its birds.
fn thermal_preset() -> Preset {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("presets/thermal.ron");
    let mut p = Preset::open(&path).expect("presets/thermal.ron");
    p.render.resolution = Resolution::Custom {
        width: 320,
        height: 256,
    };
    p.confusers.clear();
    p
}

fn make(p: &Preset, index: u64) -> Frame {
    let ctx = common::gpu();
    let pipe = FramePipeline::new(p.clone()).expect("pipeline");
    let mut r = pipe.renderer(&ctx);
    pipe.make(&mut r, index).expect("frame")
}

fn grey_at(f: &Frame, x: u32, y: u32) -> f64 {
    f64::from(f.rgba[((y * f.scene.camera.width + x) * 4) as usize])
}

#[test]
fn thermal_frames_are_grey_and_use_the_gain_controls_range() {
    let f = make(&thermal_preset(), 0);
    assert!(
        f.rgba
            .chunks_exact(4)
            .all(|p| p[0] == p[1] && p[1] == p[2] && p[3] == 255),
        "a thermal frame is grey"
    );
    // The sky spans some tens of levels about the mid level (110), the
    // drones sit above it; nothing stays at one level.
    let mut levels: Vec<u8> = f.rgba.iter().step_by(4).copied().collect();
    levels.sort_unstable();
    let n = levels.len();
    let (p5, p50, p95) = (levels[n / 20], levels[n / 2], levels[n * 19 / 20]);
    assert!(p95 > p5 + 10, "spread {p5}..{p95}");
    assert!((60..=160).contains(&p50), "median {p50}");
}

/// Each kept drone's (extreme pixel in its box, mean of a ring 3 px out):
/// the brightest pixel with `brightest`, else the darkest.
fn drone_and_ring(f: &Frame, brightest: bool) -> Vec<(f64, f64)> {
    let (w, h) = (f.scene.camera.width, f.scene.camera.height);
    let extreme = if brightest { f64::max } else { f64::min };
    let start = if brightest { 0.0 } else { 255.0 };
    (f.labels.iter().filter(|l| l.is_kept()))
        .map(|l| {
            let b = l.bbox;
            let (x0, y0) = (b.x0.floor() as u32, b.y0.floor() as u32);
            let (x1, y1) = ((b.x1.ceil() as u32).min(w), (b.y1.ceil() as u32).min(h));
            let peak = (y0..y1)
                .flat_map(|y| (x0..x1).map(move |x| (x, y)))
                .map(|(x, y)| grey_at(f, x, y))
                .fold(start, extreme);
            let ring: Vec<f64> = (y0.saturating_sub(3)..(y1 + 3).min(h))
                .flat_map(|y| (x0.saturating_sub(3)..(x1 + 3).min(w)).map(move |x| (x, y)))
                .filter(|&(x, y)| x + 2 < x0 || x >= x1 + 2 || y + 2 < y0 || y >= y1 + 2)
                .map(|(x, y)| grey_at(f, x, y))
                .collect();
            (peak, ring.iter().sum::<f64>() / ring.len().max(1) as f64)
        })
        .collect()
}

#[test]
fn drones_are_warm_on_a_cold_sky_which_warms_towards_the_horizon() {
    let mut p = thermal_preset();
    if let Some(t) = p.thermal.as_mut() {
        t.drone.cold_share = 0.0;
    }
    let mut checked = 0;
    for index in 0..4 {
        let f = make(&p, index);
        let (w, h) = (f.scene.camera.width, f.scene.camera.height);
        // The sky: rows of the upper fifth darker than those of the lower fifth.
        let row_mean = |y0: u32, y1: u32| {
            let v: Vec<f64> = (y0..y1)
                .flat_map(|y| (0..w).map(move |x| (x, y)))
                .map(|(x, y)| grey_at(&f, x, y))
                .collect();
            v.iter().sum::<f64>() / v.len() as f64
        };
        let (top, bottom) = (row_mean(0, h / 5), row_mean(h * 4 / 5, h));
        assert!(
            bottom > top + 5.0,
            "frame {index}: top {top:.1}, bottom {bottom:.1}"
        );
        // Each kept drone's brightest pixel is above its surroundings' (a ring 3 px out).
        for (peak, ring) in drone_and_ring(&f, true) {
            assert!(
                peak > ring + 20.0,
                "frame {index}: drone peak {peak}, ring {ring:.1}"
            );
            checked += 1;
        }
    }
    assert!(checked >= 3, "only {checked} drones checked");
}

#[test]
fn cold_drones_read_darker_than_the_sky_behind_them() {
    // `cold_share` 1: every drone's skin 30 K below the air and no warm spot,
    // colder than the sky at the preset's 0–14° elevations.
    let mut p = thermal_preset();
    if let Some(t) = p.thermal.as_mut() {
        (t.drone.cold_share, t.drone.skin_k) = (1.0, 30.0);
    }
    let mut checked = 0;
    for index in 0..4 {
        for (low, ring) in drone_and_ring(&make(&p, index), false) {
            assert!(
                low < ring - 10.0,
                "frame {index}: darkest {low}, ring {ring:.1}"
            );
            checked += 1;
        }
    }
    assert!(checked >= 3, "only {checked} drones checked");
}

#[test]
fn labels_are_the_visible_renders_and_frames_are_deterministic() {
    let p = thermal_preset();
    let visible = Preset {
        thermal: None,
        ..p.clone()
    };
    for index in [0, 5] {
        let (a, b) = (make(&p, index), make(&p, index));
        assert_eq!(a.rgba, b.rgba, "frame {index}: the same bytes twice");
        let v = make(&visible, index);
        assert_ne!(a.rgba, v.rgba);
        let boxes = |f: &Frame| -> Vec<_> {
            (f.labels.iter())
                .map(|l| (l.drone, l.bbox, l.status, l.visibility))
                .collect()
        };
        assert_eq!(
            boxes(&a),
            boxes(&v),
            "frame {index}: labels as the visible render's"
        );
    }
    // The temporal noise differs from frame to frame of one scene: two
    // frames' difference away from the drones is not zero.
    let (a, b) = (make(&p, 0), make(&p, 1));
    assert_ne!(a.rgba, b.rgba);
}

#[test]
fn thermal_cannot_be_combined_with_the_camera_model() {
    let p = Preset {
        camera_model: Some(Default::default()),
        ..thermal_preset()
    };
    let errors = p.validate().expect_err("thermal + camera_model");
    assert!(errors.iter().any(|e| e.field == "thermal"), "{errors:?}");
    let p = Preset {
        thermal: Some(swarmshot::preset::thermal::Thermal {
            netd_mk: -1.0,
            ..Default::default()
        }),
        ..thermal_preset()
    };
    let errors = p.validate().expect_err("negative NETD");
    assert!(
        errors.iter().any(|e| e.field == "thermal.netd_mk"),
        "{errors:?}"
    );
}

/// The preset with 16-bit grey PNG frames.
fn sixteen_bit(mut p: Preset) -> Preset {
    p.output.image_format = swarmshot::preset::ImageFormat::Png;
    if let Some(t) = p.thermal.as_mut() {
        t.bits = 16;
    }
    p
}

#[test]
fn sixteen_bit_frames_are_the_gain_controls_levels_times_257_as_grey_png() {
    let eight = thermal_preset();
    let p = sixteen_bit(eight.clone());
    let (a, b) = (make(&eight, 0), make(&p, 0));
    assert!(a.grey16.is_none());
    let grey = b.grey16.as_deref().expect("16-bit levels");
    let (w, h) = (b.scene.camera.width, b.scene.camera.height);
    assert_eq!(grey.len(), (w * h) as usize);
    // The same development: each 16-bit level ÷ 257 within one 8-bit level.
    let worst = (grey.iter().zip(a.rgba.chunks_exact(4)))
        .map(|(&g, px)| (f64::from(g) / 257.0 - f64::from(px[0])).abs())
        .fold(0.0, f64::max);
    assert!(
        worst <= 0.5 + 1e-9,
        "16-bit ÷ 257 off the 8-bit level by {worst}"
    );
    // Finer than 8 bits: many more distinct levels than 256.
    let mut levels = grey.to_vec();
    levels.sort_unstable();
    levels.dedup();
    assert!(
        levels.len() > 1000,
        "{} distinct 16-bit levels",
        levels.len()
    );
    assert_eq!(a.labels.len(), b.labels.len());
    // Written as a 16-bit grey PNG that reads back to the same samples.
    let dir = tempfile::tempdir().expect("temp dir");
    let out = dir.path().join("t.png");
    let pipe = FramePipeline::new(p.clone()).expect("pipeline");
    let mut lone = swarmshot::write::single::LoneDir::open(&out, false).expect("folder");
    let written = swarmshot::write::single::write_lone_frame(
        &mut lone,
        &swarmshot::write::single::LoneFrame {
            scene: &b.scene,
            labels: &b.labels,
            rgba: &b.rgba,
            grey16: b.grey16.as_deref(),
            grey: true,
            masks: None,
        },
        &swarmshot::write::single::LoneFormat {
            image: p.output.image_format,
            masks: &p.output.masks,
            model_names: pipe.model_names(),
            classes: pipe.classes(),
        },
    )
    .expect("written");
    assert_eq!(written[0], out);
    let bytes = std::fs::read(&out).expect("read back");
    match image::load_from_memory(&bytes).expect("a PNG") {
        image::DynamicImage::ImageLuma16(img) => {
            assert_eq!(img.dimensions(), (w, h));
            assert_eq!(img.as_raw(), &grey.to_vec());
        }
        other => panic!("not 16-bit grey: {:?}", other.color()),
    }
}

#[test]
fn sixteen_bits_need_png_and_bits_are_8_or_16() {
    let mut p = sixteen_bit(thermal_preset());
    assert!(p.validate().is_ok());
    p.output.image_format = swarmshot::preset::ImageFormat::Jpeg { quality: 95 };
    let errors = p.validate().expect_err("16 bits as JPEG");
    assert!(
        errors.iter().any(|e| e.field == "thermal.bits"),
        "{errors:?}"
    );
    let mut p = thermal_preset();
    if let Some(t) = p.thermal.as_mut() {
        t.bits = 12;
    }
    let errors = p.validate().expect_err("12 bits");
    assert!(
        errors.iter().any(|e| e.field == "thermal.bits"),
        "{errors:?}"
    );
}

#[test]
fn fit_takes_a_thermal_base_with_its_thermal_camera() {
    // `fit` fits a thermal base's own camera (tests/suite/fit_thermal.rs); the base loads as it is.
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("presets/thermal.ron");
    let base = swarmshot::fit::preset_out::load_base(&path).expect("thermal base");
    assert!(base.thermal.is_some() && base.camera_model.is_none());
}

/// The thermal preset at 160×128 under `weather`.
fn thermal_weather(weather: swarmshot::preset::weather::Weather) -> Preset {
    let mut p = thermal_preset();
    p.render.resolution = Resolution::Custom {
        width: 160,
        height: 128,
    };
    p.weather = Some(weather);
    p
}

/// (pixels whose radiance differs, their box) between two planes.
fn changed(a: &[f32], b: &[f32], w: usize) -> (u64, Option<[f64; 4]>) {
    let mut n = 0;
    let mut bbox: Option<[f64; 4]> = None;
    for (i, _) in (a.iter().zip(b).enumerate()).filter(|(_, (p, q))| p != q) {
        n += 1;
        let (x, y) = ((i % w) as f64, (i / w) as f64);
        let b = bbox.get_or_insert([x, y, x + 1.0, y + 1.0]);
        *b = [
            b[0].min(x),
            b[1].min(y),
            b[2].max(x + 1.0),
            b[3].max(y + 1.0),
        ];
    }
    (n, bbox)
}

#[test]
fn under_snow_thermal_labels_are_the_radiance_the_drones_still_change() {
    use swarmshot::preset::weather::Weather;
    // Flakes big and close enough that some cover a drone, some do not.
    let snow = Weather {
        intensity_per_m3: (40.0, 40.0),
        diameter_mm: (5.0, 15.0),
        depth_m: (0.5, 6.0),
        exposure_s: (0.0, 0.001),
        ..Weather::snow()
    };
    let mut p = thermal_weather(snow);
    // One drone, in view: the observer looks at the volume's centre.
    if let swarmshot::preset::Placement::Randomized { count, volume, .. } = &mut p.placement {
        *count = (1, 1);
        *volume = swarmshot::preset::Volume::Box {
            size_m: (0.1, 0.1, 0.1),
        };
    }
    p.validate().expect("thermal with weather is valid");
    let ctx = common::gpu();
    let pipe = FramePipeline::new(p).expect("pipeline");
    let mut r = pipe.renderer(&ctx);
    let (mut hidden, mut shown, mut counts) = (0, 0, Vec::new());
    for index in 0..6 {
        let f = pipe.make(&mut r, index).expect("frame");
        let radiance = |r: &mut _, s| pipe.thermal_radiance(r, s).expect("radiance");
        let with = radiance(&mut r, &f.scene).expect("thermal");
        let mut empty = f.scene.clone();
        empty.drones.clear();
        let without = radiance(&mut r, &empty).expect("thermal");
        let (n, truth) = changed(&with, &without, f.scene.camera.width as usize);
        // One drone a pixel: the labels' visible pixels and boxes are the changed ones.
        let vis: Vec<_> = (f.labels.iter()).filter_map(|l| l.visibility).collect();
        let counted: u64 = vis.iter().map(|v| v.visible_pixels).sum();
        assert_eq!(counted, n, "frame {index}");
        let union =
            (vis.iter().filter_map(|v| v.visible_box)).fold(None, |u: Option<[f64; 4]>, b| {
                let b = [b.x0, b.y0, b.x1, b.y1];
                Some(u.map_or(b, |u| {
                    [
                        u[0].min(b[0]),
                        u[1].min(b[1]),
                        u[2].max(b[2]),
                        u[3].max(b[3]),
                    ]
                }))
            });
        assert_eq!(union, truth, "frame {index}");
        // Against the same scene without weather: the snow hides, never adds.
        let mut dry = f.scene.clone();
        dry.weather = None;
        let dry = pipe.make_scene(&mut r, dry).expect("dry");
        for (l, d) in f.labels.iter().zip(&dry.labels) {
            let (v, d) = (
                l.visibility.expect("measured"),
                d.visibility.expect("measured"),
            );
            assert!(v.visible_pixels <= d.visible_pixels, "frame {index}");
            hidden += u64::from(v.visible_pixels < d.visible_pixels);
            counts.push((v.visible_pixels, d.visible_pixels));
            shown += u64::from(v.visible_pixels > 0);
        }
    }
    assert!(
        hidden > 0 && shown > 0,
        "{hidden} hidden, {shown} shown: {counts:?}"
    );
}

#[test]
fn rain_reads_as_warm_streaks_against_the_cold_sky() {
    use swarmshot::preset::weather::Weather;
    let rain = Weather {
        intensity_per_m3: (60.0, 60.0),
        depth_m: (0.3, 6.0),
        opacity: (0.6, 0.9),
        ..Weather::rain()
    };
    let p = thermal_weather(rain);
    let ctx = common::gpu();
    let pipe = FramePipeline::new(p).expect("pipeline");
    let mut r = pipe.renderer(&ctx);
    let mut scene = pipe.scene(1).expect("scene");
    scene.drones.clear();
    let wet = pipe.thermal_radiance(&mut r, &scene).expect("radiance");
    let mut dry = scene.clone();
    dry.weather = None;
    let dry = pipe.thermal_radiance(&mut r, &dry).expect("radiance");
    let (wet, dry) = (wet.expect("thermal"), dry.expect("thermal"));
    // Drops at the air's temperature: warmer than the sky they cross.
    let warmer = wet.iter().zip(&dry).filter(|(a, b)| a > b).count();
    let colder = wet.iter().zip(&dry).filter(|(a, b)| a < b).count();
    assert!(
        warmer > 200 && colder * 20 < warmer,
        "{warmer} warmer, {colder} colder"
    );
}

/// The local maxima of `plane` above `level`: pixels higher than every other
/// pixel within 2 px, as pixel centres.
fn maxima(plane: &[f32], w: usize, level: f32) -> Vec<(f64, f64)> {
    let h = plane.len() / w;
    let mut out = Vec::new();
    for y in 2..h - 2 {
        for x in 2..w - 2 {
            let v = plane[y * w + x];
            let top = (y - 2..=y + 2)
                .flat_map(|j| (x - 2..=x + 2).map(move |i| (i, j)))
                .filter(|&(i, j)| (i, j) != (x, y))
                .all(|(i, j)| plane[j * w + i] < v);
            if v > level && top {
                out.push((x as f64 + 0.5, y as f64 + 0.5));
            }
        }
    }
    out
}

#[test]
fn motors_battery_and_rotors_are_their_own_parts_and_the_labels_unchanged() {
    use glam::{DMat3, DQuat, DVec3};
    let mut p = thermal_preset();
    p.models.truncate(1); // quad_x, 0.35 m
    let ctx = common::gpu();
    // A level quadcopter seen straight down from 6 m (about 100 px across),
    // its centre off the pixels' corners.
    let at = DVec3::new(0.0013, 0.0, 0.0011);
    let top_down = |pipe: &FramePipeline| {
        let mut scene = pipe.scene(0).expect("scene");
        scene.drones.truncate(1);
        let d = &mut scene.drones[0];
        (d.model, d.rotation, d.position, d.size_m) = (0, DQuat::IDENTITY, at, 0.35);
        scene.camera.position = DVec3::new(0.0, 6.0, 0.0);
        scene.camera.camera_from_world =
            DMat3::from_cols(DVec3::X, DVec3::Z, DVec3::NEG_Y).transpose();
        scene.look_at = DVec3::ZERO;
        scene
    };
    // The hubs, independently of the thermal code: each quadrant's rotor-disc
    // (BLEND) corners' box centre, projected.
    let src = swarmshot::preset::ModelSource::Builtin("quad_x".into());
    let model = swarmshot::pipeline::load_model(&src).expect("quad_x");
    let blend: Vec<DVec3> = (model.vertices.iter())
        .filter(|v| v.material[3] < 0.0)
        .map(|v| DVec3::from(v.position.map(f64::from)))
        .collect();
    let mut labels = Vec::new();
    let mut planes = Vec::new();
    let cases = [
        (None, None, None, 0),
        (Some(20.0), None, None, 4),
        (Some(20.0), Some(20.0), None, 5),
        (Some(20.0), None, Some(0.0), 4),
    ];
    for (motor_k, battery_k, rotor_k, n) in cases {
        let mut p = p.clone();
        if let Some(t) = p.thermal.as_mut() {
            let d = &mut t.drone;
            (d.cold_share, d.motor_k, d.battery_k, d.rotor_k) = (0.0, motor_k, battery_k, rotor_k);
        }
        let pipe = FramePipeline::new(p).expect("pipeline");
        let mut r = pipe.renderer(&ctx);
        let scene = top_down(&pipe);
        let cam = &scene.camera;
        let project = |v: DVec3| {
            let c = cam.project_camera_point(cam.camera_from_world_point(at + v * 0.35));
            c.expect("in front")
        };
        let mut hubs: Vec<_> = [(1.0, 1.0), (1.0, -1.0), (-1.0, 1.0), (-1.0, -1.0)]
            .iter()
            .map(|&(sx, sz)| {
                let q: Vec<_> = (blend.iter())
                    .filter(|v| v.x * sx > 0.0 && v.z * sz > 0.0)
                    .collect();
                let lo = q.iter().fold(DVec3::INFINITY, |a, v| a.min(**v));
                let hi = q.iter().fold(DVec3::NEG_INFINITY, |a, v| a.max(**v));
                project((lo + hi) * 0.5)
            })
            .collect();
        let centre = project(DVec3::ZERO);
        let with = pipe.thermal_radiance(&mut r, &scene).expect("radiance");
        let mut empty = scene.clone();
        empty.drones.clear();
        let without = pipe.thermal_radiance(&mut r, &empty).expect("radiance");
        let (with, without) = (with.expect("thermal"), without.expect("thermal"));
        let floor = without.iter().copied().fold(f32::MIN, f32::max);
        let top = with.iter().copied().fold(f32::MIN, f32::max);
        let found = maxima(&with, cam.width as usize, floor + 0.5 * (top - floor));
        let case =
            format!("motor {motor_k:?}, battery {battery_k:?}: maxima {found:?}, hubs {hubs:?}");
        // One broad spot without parts (no sharp maximum to count).
        assert!(n == 0 || found.len() == n, "{case}");
        if battery_k.is_some() {
            hubs.push(centre);
        }
        for (x, y) in found.iter().filter(|_| n > 0) {
            let near = hubs.iter().any(|h| (h.x - x).hypot(h.y - y) <= 1.0);
            assert!(near, "{case}");
        }
        planes.push((with, found));
        let frame = pipe.make_scene(&mut r, scene).expect("frame");
        labels.push(
            (frame.labels.iter())
                .map(|l| (l.bbox, l.status, l.visibility))
                .collect::<Vec<_>>(),
        );
    }
    // Rotors at the air's temperature: the discs' pixels colder than the
    // skin (at the ground's here), the motors' peaks where they were.
    let ((motors, peaks), (rotors, rotor_peaks)) = (&planes[1], &planes[3]);
    let colder = (rotors.iter().zip(motors)).filter(|(r, m)| r < m).count();
    assert!(colder > 1000, "{colder} pixels colder with the rotors");
    assert_eq!(peaks, rotor_peaks);
    assert!(!labels[0].is_empty());
    assert!(
        labels.iter().all(|l| *l == labels[0]),
        "labels as without parts"
    );
}

/// The recording's capture chain of the Anti-UAV frames (docs/realism.md, "The capture
/// chain"): an earlier compression and blanking lines at the top and left.
fn capture(prior: bool, border: bool) -> swarmshot::preset::thermal::Capture {
    let mut c = swarmshot::preset::thermal::Capture::default();
    if prior {
        (c.prior_dc_step, c.prior_ac_step) = (16.0, 4.0);
    }
    if border {
        (c.top_rows, c.left_columns) = (vec![-50.0, -30.0], vec![25.0]);
    }
    c
}

fn with_capture(mut p: Preset, c: swarmshot::preset::thermal::Capture) -> Preset {
    p.thermal.as_mut().expect("thermal").capture = Some(c);
    p
}

#[test]
fn the_capture_chain_changes_the_picture_not_the_labels() {
    let boxes = |f: &Frame| -> Vec<_> {
        (f.labels.iter())
            .map(|l| (l.drone, l.bbox, l.status, l.visibility))
            .collect()
    };
    let snow = thermal_weather(swarmshot::preset::weather::Weather {
        intensity_per_m3: (40.0, 40.0),
        ..swarmshot::preset::weather::Weather::snow()
    });
    for (p, index) in [(thermal_preset(), 3), (snow, 1)] {
        let plain = make(&p, index);
        let prior = make(&with_capture(p.clone(), capture(true, false)), index);
        let both = make(&with_capture(p.clone(), capture(true, true)), index);
        let mut dark = p.clone();
        dark.thermal.as_mut().expect("thermal").narcissus =
            Some(swarmshot::preset::thermal::Narcissus {
                depth_k: 8.0,
                ..Default::default()
            });
        let dark = make(&dark, index);
        let mut sharp = p.clone();
        sharp.thermal.as_mut().expect("thermal").detail =
            Some(swarmshot::preset::thermal::Detail::default());
        let sharp = make(&sharp, index);
        assert!(!plain.labels.is_empty(), "frame {index} shows a drone");
        assert_eq!(
            boxes(&sharp),
            boxes(&plain),
            "frame {index}: detail enhancement, labels unchanged"
        );
        assert_ne!(sharp.rgba, plain.rgba, "the detail enhancement shows");
        assert_eq!(
            boxes(&both),
            boxes(&plain),
            "frame {index}: labels unchanged"
        );
        assert_eq!(
            boxes(&dark),
            boxes(&plain),
            "frame {index}: narcissus, labels unchanged"
        );
        assert_ne!(dark.rgba, plain.rgba, "the narcissus shows");
        assert_ne!(prior.rgba, plain.rgba, "the earlier compression shows");
        // The border lines move their rows and column by their offsets, and nothing
        // else.
        let w = plain.scene.camera.width;
        for (i, (a, b)) in prior
            .rgba
            .chunks_exact(4)
            .zip(both.rgba.chunks_exact(4))
            .enumerate()
        {
            let (x, y) = (i as u32 % w, i as u32 / w);
            // Rows first, then columns, each line's move clamped to 0–255 (a corner
            // pixel dark enough for its row's line stays at 0 before its column's).
            let step = |v: f64, off: f64| (v + off).round().clamp(0.0, 255.0);
            let mut want = f64::from(a[0]);
            if let Some(&off) = [-50.0, -30.0].get(y as usize) {
                want = step(want, off);
            }
            if x == 0 {
                want = step(want, 25.0);
            }
            assert_eq!(b[..3], [want as u8; 3], "({x}, {y})");
        }
    }
}

/// The mean absolute difference of grey levels 4 px apart along the rows.
fn roughness(f: &Frame) -> f64 {
    let w = f.scene.camera.width as usize;
    let grey: Vec<f64> = f.rgba.iter().step_by(4).map(|&v| f64::from(v)).collect();
    let pairs = grey
        .chunks_exact(w)
        .flat_map(|r| r.windows(5).map(|p| (p[4] - p[0]).abs()));
    let (sum, n) = pairs.fold((0.0, 0.0), |(s, n), d| (s + d, n + 1.0));
    sum / n
}

#[test]
fn the_background_texture_changes_the_picture_not_the_labels() {
    let plain = thermal_preset();
    let mut textured = plain.clone();
    textured.thermal.as_mut().expect("thermal").texture =
        Some(swarmshot::preset::thermal::Texture {
            rms_k: 3.0,
            ..Default::default()
        });
    let boxes = |f: &Frame| -> Vec<_> {
        (f.labels.iter())
            .map(|l| (l.drone, l.bbox, l.status, l.visibility))
            .collect()
    };
    for index in [1, 3] {
        let (a, b) = (make(&plain, index), make(&textured, index));
        assert!(!a.labels.is_empty(), "frame {index} shows a drone");
        assert_eq!(boxes(&b), boxes(&a), "frame {index}: labels unchanged");
        let (ra, rb) = (roughness(&a), roughness(&b));
        assert!(rb > 1.5 * ra, "frame {index}: roughness {ra:.3} → {rb:.3}");
        assert_eq!(
            b.rgba,
            make(&textured, index).rgba,
            "frame {index}: the same bytes"
        );
    }
}

/// Whether pixel (x, y) lies within 8 px of a box of `f`'s labels.
fn near_a_box(f: &Frame, x: u32, y: u32) -> bool {
    (f.labels.iter()).any(|l| {
        let b = l.bbox;
        f64::from(x) > b.x0 - 8.0
            && f64::from(x) < b.x1 + 8.0
            && f64::from(y) > b.y0 - 8.0
            && f64::from(y) < b.y1 + 8.0
    })
}

/// The thermal preset over one 640×512 Anti-UAV frame as its only plate (copied into
/// `dir`), no noise, pattern or shading, the optics' blur `blur_px`; and the plate's grey.
fn plated(dir: &std::path::Path, blur_px: f64) -> (Preset, image::GrayImage) {
    let name = "antiuav2020_v7_f000281.png";
    std::fs::copy(
        common::testdata("real-anti-uav-ir/images").join(name),
        dir.join(name),
    )
    .expect("plate");
    let plate = image::open(dir.join(name)).expect("decodes").to_luma8();
    let mut p = thermal_preset();
    p.render.resolution = Resolution::Custom {
        width: 640,
        height: 512,
    };
    p.backplate = Some(swarmshot::preset::backplate::Backplate {
        folder: dir.to_owned(),
        hfov_deg: 10.0,
        flip: false,
        ..Default::default()
    });
    let t = p.thermal.as_mut().expect("thermal");
    (t.netd_mk, t.fixed_pattern_mk, t.shading_k, t.blur_px) = (0.0, 0.0, 0.0, blur_px);
    (p, plate)
}

/// Over a plate the optics' blur takes the drones, not the plate (which went through its
/// own camera's optics): 8 px and more from every box, the frame with a blur of 1.5 px
/// is the frame without one, and each drone's peak over the plate is lower, spread
/// around it.
#[test]
fn over_a_thermal_plate_the_blur_takes_the_drones_only() {
    let tmp = tempfile::tempdir().expect("tmp");
    let (sharp, _) = plated(tmp.path(), 0.0);
    let (blurred, plate) = plated(tmp.path(), 1.5);
    let (a, b) = (make(&sharp, 0), make(&blurred, 0));
    assert!(
        !a.labels.is_empty() && a.labels == b.labels,
        "the same drones, the same labels"
    );
    let near = |x: u32, y: u32| near_a_box(&a, x, y);
    let far: Vec<(u32, u32)> = (0..512)
        .flat_map(|y| (0..640).map(move |x| (x, y)))
        .filter(|&(x, y)| !near(x, y))
        .collect();
    let same = (far.iter())
        .filter(|&&(x, y)| grey_at(&b, x, y) == grey_at(&a, x, y))
        .count();
    assert_eq!(same, far.len(), "pixels far from the drones the same");
    // Blurring the whole frame would change the plate's own fine structure.
    let whole = image::imageops::blur(&plate, 1.5);
    let moved = (far.iter())
        .filter(|&&(x, y)| whole.get_pixel(x, y)[0] != plate.get_pixel(x, y)[0])
        .count();
    assert!(
        moved * 20 > far.len(),
        "the plate has structure a blur would change: {moved}"
    );
    for l in &a.labels {
        let (cx, cy) = (
            ((l.bbox.x0 + l.bbox.x1) / 2.0) as u32,
            ((l.bbox.y0 + l.bbox.y1) / 2.0) as u32,
        );
        let peak = |f: &Frame| {
            (cy.saturating_sub(3)..(cy + 4).min(512))
                .flat_map(|y| (cx.saturating_sub(3)..(cx + 4).min(640)).map(move |x| (x, y)))
                .map(|(x, y)| grey_at(f, x, y))
                .fold(f64::MIN, f64::max)
        };
        assert!(
            peak(&b) < peak(&a),
            "drone {:?}: the blur lowers its peak ({} against {})",
            l.bbox,
            peak(&b),
            peak(&a)
        );
    }
}

/// A thermal preset with backplates draws the plate's levels as the scene
/// (src/sensor/thermal/plate_plane.rs): with the camera's own noise, pattern, shading and
/// blur off, every background pixel away from the drones is the plate's own level (the
/// frame developed with the plate's gain, whatever the gain control's middle and the
/// drones' heat), and the drones read warm on it.
#[test]
fn thermal_backplates_draw_the_plates_levels_and_the_drones_warm_on_them() {
    let tmp = tempfile::tempdir().expect("tmp");
    let (mut p, plate) = plated(tmp.path(), 0.0);
    let t = p.thermal.as_mut().expect("thermal");
    // A middle level far from the plate's and hot drones: neither moves the plate.
    (t.agc_mid_level, t.drone.skin_k, t.drone.spot_k) = (200.0, 40.0, 120.0);
    let f = make(&p, 0);
    assert!(!f.labels.is_empty(), "a drone is drawn");
    let near = |x: u32, y: u32| near_a_box(&f, x, y);
    let far: Vec<(u32, u32)> = (0..512)
        .flat_map(|y| (0..640).map(move |x| (x, y)))
        .filter(|&(x, y)| !near(x, y))
        .collect();
    // The drawn plate's colour is the visible background's, within a level of the file's
    // (a white 255 can come back 254 from the visible draw).
    let off = |&(x, y): &(u32, u32)| grey_at(&f, x, y) - f64::from(plate.get_pixel(x, y)[0]);
    let same = far.iter().filter(|p| off(p) == 0.0).count();
    let worst = far.iter().map(|p| off(p).abs()).fold(0.0, f64::max);
    assert!(
        worst <= 1.0 && same as f64 >= 0.999 * far.len() as f64,
        "{same} of {} background pixels at the plate's level, the farthest {worst} levels off",
        far.len()
    );
    for l in &f.labels {
        let (cx, cy) = (
            ((l.bbox.x0 + l.bbox.x1) / 2.0) as u32,
            ((l.bbox.y0 + l.bbox.y1) / 2.0) as u32,
        );
        let peak = (cy.saturating_sub(2)..(cy + 3).min(512))
            .flat_map(|y| (cx.saturating_sub(2)..(cx + 3).min(640)).map(move |x| (x, y)))
            .map(|(x, y)| grey_at(&f, x, y) - f64::from(plate.get_pixel(x, y)[0]))
            .fold(f64::MIN, f64::max);
        assert!(
            peak > 10.0,
            "drone {:?}: {peak:.1} levels over the plate",
            l.bbox
        );
    }
}

/// A texture on the ground alone (`thermal.texture.ground_only`) leaves the sky's radiance
/// as it was, bit for bit, and textures the ground under the horizon as the whole-frame
/// texture does; over a backplate there is no ground to find, and the preset says so.
#[test]
fn a_texture_on_the_ground_alone_leaves_the_sky_as_it_was() {
    let mut p = thermal_preset();
    p.camera.observer.as_mut().expect("observer").elevation_deg = (1.0, 1.0);
    p.thermal.as_mut().expect("thermal").ground_k = 300.0;
    let with = |ground_only: Option<bool>| {
        let mut p = p.clone();
        p.thermal.as_mut().expect("thermal").texture =
            ground_only.map(|ground_only| swarmshot::preset::thermal::Texture {
                rms_k: 3.0,
                ground_only,
                ..Default::default()
            });
        let ctx = common::gpu();
        let pipe = FramePipeline::new(p).expect("pipeline");
        let mut r = pipe.renderer(&ctx);
        let mut scene = pipe.scene(2).expect("scene");
        scene.drones.clear();
        pipe.thermal_radiance(&mut r, &scene)
            .expect("radiance")
            .expect("thermal")
    };
    let (plain, ground, whole) = (with(None), with(Some(true)), with(Some(false)));
    let w = 320;
    // The horizon at 1° up lies at row 128 + tan 1° / tan 4° × 128 ≈ 160.
    let rows = |plane: &[f32], r: std::ops::Range<usize>| plane[r.start * w..r.end * w].to_vec();
    let moved = |a: &[f32], b: &[f32]| a.iter().zip(b).filter(|(x, y)| x != y).count();
    let sky = 0..100;
    assert_eq!(rows(&ground, sky.clone()), rows(&plain, sky.clone()));
    assert!(moved(&rows(&whole, sky.clone()), &rows(&plain, sky)) > 95 * 100 * w / 100);
    let below = 180..256;
    let n = below.len() * w;
    assert_eq!(rows(&ground, below.clone()), rows(&whole, below.clone()));
    assert!(moved(&rows(&ground, below.clone()), &rows(&plain, below)) > 95 * n / 100);
    let mut q = p.clone();
    q.thermal.as_mut().expect("thermal").texture = Some(swarmshot::preset::thermal::Texture {
        ground_only: true,
        ..Default::default()
    });
    q.backplate = Some(swarmshot::preset::backplate::Backplate::default());
    let errors = q.validate().expect_err("ground_only over a backplate");
    assert!(
        errors
            .iter()
            .any(|e| e.field == "thermal.texture.ground_only"),
        "{errors:?}"
    );
}

/// A detail enhancement's bad values and one over a backplate (whose plates hold their own
/// camera's) are named by their fields before anything is made.
#[test]
fn the_detail_enhancements_values_and_place_are_checked() {
    let fields = |p: &Preset| -> Vec<String> {
        (p.validate().err().unwrap_or_default().iter())
            .map(|e| e.field.clone())
            .collect()
    };
    let mut p = thermal_preset();
    let detail = |gain, size| Some(swarmshot::preset::thermal::Detail { gain, size });
    p.thermal.as_mut().expect("thermal").detail = detail(2.0, 0.15);
    assert_eq!(fields(&p), Vec::<String>::new());
    p.thermal.as_mut().expect("thermal").detail = detail(-1.0, 0.0);
    assert_eq!(fields(&p), ["thermal.detail.gain", "thermal.detail.size"]);
    p.thermal.as_mut().expect("thermal").detail = detail(f64::NAN, 0.15);
    assert_eq!(fields(&p), ["thermal.detail.gain"]);
    p.thermal.as_mut().expect("thermal").detail = detail(1.0, 0.15);
    p.backplate = Some(swarmshot::preset::backplate::Backplate::default());
    assert!(
        fields(&p).contains(&"thermal.detail".to_string()),
        "{:?}",
        fields(&p)
    );
}
