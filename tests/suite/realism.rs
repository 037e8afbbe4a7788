//! Issue 21's realism stages, measured: haze with range follows Koschmieder's
//! law on the drones, drawn looks change the picture and not the labels, and
//! the observer camera puts the horizon low and the drones at the asked size.

use crate::common;

use glam::{DQuat, DVec3};
use swarmshot::pipeline::FramePipeline;
use swarmshot::preset::appearance::{Appearance, DroneColor};
use swarmshot::preset::atmosphere::Atmosphere;
use swarmshot::preset::observer::ObserverCamera;
use swarmshot::preset::{Placement, Preset, Resolution, Volume};
use swarmshot::render::{RenderRequest, Renderer};
use swarmshot::scene::FrameScene;
use swarmshot::scene::math::look_at_cv;
use swarmshot::scene::realism::{DroneLook, FrameAtmosphere};
use swarmshot::sky::FrameSky;

fn srgb_to_linear(v: u8) -> f64 {
    let c = f64::from(v) / 255.0;
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

fn luminance(px: &[u8]) -> f64 {
    0.2126 * srgb_to_linear(px[0]) + 0.7152 * srgb_to_linear(px[1]) + 0.0722 * srgb_to_linear(px[2])
}

/// Σ over the image of (L − L_sky) in linear light: the drone's integrated
/// contrast against the uniform sky (the sky pixels add exactly 0).
fn integrated_contrast(rgba: &[u8]) -> f64 {
    let sky = luminance(&rgba[..4]);
    rgba.chunks_exact(4).map(|p| luminance(p) - sky).sum()
}

const SKY: [f32; 3] = [0.55, 0.62, 0.75];
const V_M: f64 = 1000.0;

/// One drone at `distance_m` on the optical axis, scaled with the distance
/// (so its image is the same at every distance), against a uniform sky,
/// looking up 30° away from the sun so no sun glow reaches the frame.
fn haze_scene(
    p: &FrameFixture,
    distance_m: f64,
    atmosphere: Option<FrameAtmosphere>,
) -> FrameScene {
    let mut s = p.base.clone();
    let forward = DVec3::new(0.0, 0.5, 30f64.to_radians().cos()).normalize();
    s.camera.position = DVec3::ZERO;
    s.camera.camera_from_world = look_at_cv(DVec3::ZERO, forward).expect("look-at");
    s.camera.near_m = 0.01;
    s.sky = FrameSky::Gradient {
        zenith: SKY,
        horizon: SKY,
    };
    s.sun_direction = DVec3::new(0.3, 0.8, -0.5).normalize();
    s.drones.truncate(1);
    s.drones[0].position = forward * distance_m;
    s.drones[0].rotation = DQuat::from_rotation_y(0.4) * DQuat::from_rotation_x(-1.2);
    s.drones[0].size_m = distance_m * 0.012;
    s.looks = vec![DroneLook {
        color: DroneColor::Black,
        albedo: [0.03; 3],
        roughness: 0.6,
        metalness: 0.0,
        emissive: 0.0,
        rotor_opacity: 1.0,
    }];
    s.atmosphere = atmosphere;
    s
}

struct FrameFixture {
    base: FrameScene,
    renderer: Renderer,
}

fn fixture() -> FrameFixture {
    let mut p = common::tiny_preset();
    p.camera.fov_y_deg = 2.0;
    p.render.resolution = Resolution::Custom {
        width: 160,
        height: 120,
    };
    let pipeline = FramePipeline::new(p).expect("pipeline");
    let ctx = common::gpu();
    let renderer = pipeline.renderer(&ctx);
    FrameFixture {
        base: pipeline.scene(0).expect("scene"),
        renderer,
    }
}

fn render(f: &mut FrameFixture, scene: &FrameScene) -> Vec<u8> {
    let request = RenderRequest {
        msaa: 1,
        color: true,
        visibility: false,
    };
    f.renderer
        .render_frame(scene, &request)
        .expect("render")
        .rgba
}

#[test]
fn haze_contrast_follows_koschmieder_at_every_distance() {
    let mut f = fixture();
    let clear = haze_scene(&f, 100.0, None);
    let c0 = integrated_contrast(&render(&mut f, &clear));
    // The drone is much darker than the sky and covers hundreds of pixels.
    assert!(c0 < -150.0, "clear contrast {c0}");
    let atmosphere = Some(FrameAtmosphere { visibility_m: V_M });
    for distance_m in [50.0, 150.0, 300.0, 400.0, 700.0, 1000.0] {
        // Without an atmosphere the contrast does not fade (the old behaviour).
        let scene = haze_scene(&f, distance_m, None);
        let unhazed = integrated_contrast(&render(&mut f, &scene));
        assert!(
            (unhazed / c0 - 1.0).abs() < 0.01,
            "d = {distance_m}: {unhazed} vs {c0}"
        );
        let scene = haze_scene(&f, distance_m, atmosphere);
        let hazed = integrated_contrast(&render(&mut f, &scene));
        let t = (-3.912 * distance_m / V_M).exp();
        let measured = hazed / c0;
        eprintln!("d = {distance_m} m: contrast {measured:.4}, Koschmieder {t:.4}");
        if t >= 0.2 {
            assert!(
                (measured / t - 1.0).abs() <= 0.02,
                "d = {distance_m}: {measured} vs {t}"
            );
        }
        assert!(
            (measured - t).abs() <= 0.005,
            "d = {distance_m}: {measured} vs {t}"
        );
    }
}

#[test]
fn haze_fades_drones_into_the_horizon_colour_of_the_view_direction() {
    // At 4 V the drone is within half an 8-bit level of the sky it is seen against.
    let mut f = fixture();
    let far = haze_scene(&f, 4.0 * V_M, Some(FrameAtmosphere { visibility_m: V_M }));
    let rgba = render(&mut f, &far);
    let sky = &rgba[..4];
    let worst = rgba
        .chunks_exact(4)
        .map(|p| (0..3).map(|c| p[c].abs_diff(sky[c])).max().unwrap_or(0))
        .max()
        .unwrap_or(0);
    assert!(
        worst <= 1,
        "a drone at 4 V still differs from the sky by {worst} levels"
    );
    // The same drone without haze is plainly visible.
    let scene = haze_scene(&f, 4.0 * V_M, None);
    let clear = render(&mut f, &scene);
    assert!(clear.chunks_exact(4).any(|p| p[0].abs_diff(sky[0]) > 50));
}

fn observer_preset() -> Preset {
    let mut p = Preset {
        seed: 11,
        placement: Placement::Randomized {
            count: (3, 8),
            count_distribution: Default::default(),
            volume: Volume::Box {
                size_m: (30.0, 10.0, 30.0),
            },
            min_separation_m: 3.0,
        },
        repeats: 40,
        ..Preset::default()
    };
    p.render.resolution = Resolution::FullHd;
    p.camera.observer = Some(ObserverCamera {
        elevation_deg: (15.0, 45.0),
        size_px: Some((3.0, 6.0)),
        ..ObserverCamera::default()
    });
    p
}

#[test]
fn observer_camera_puts_the_horizon_low_and_drones_at_the_asked_size() {
    let p = observer_preset();
    p.validate().expect("valid");
    let pipeline = FramePipeline::new(p).expect("pipeline");
    let mut sizes = Vec::new();
    for i in 0..pipeline.frame_count() {
        let (scene, labels) = pipeline.plan(i).expect("plan");
        let cam = &scene.camera;
        // The horizon towards the camera's forward azimuth, 100 km away.
        let forward = cam.camera_from_world.transpose() * DVec3::Z;
        let flat = DVec3::new(forward.x, 0.0, forward.z).normalize();
        let v = cam
            .project_camera_point(cam.camera_from_world_point(cam.position + flat * 1e5))
            .expect("in front")
            .y;
        assert!(
            v > 0.5 * f64::from(cam.height),
            "frame {i}: horizon at row {v}"
        );
        // Drones are above the camera: against the sky.
        assert!(scene.drones.iter().all(|d| d.position.y > cam.position.y));
        // The drawn apparent size of the largest span at the volume's centre is in range.
        let f = cam.focal_px();
        let at_centre = f * 0.35 / cam.position.length();
        assert!(
            (3.0 - 1e-9..=6.0 + 1e-9).contains(&at_centre),
            "frame {i}: {at_centre}"
        );
        for l in &labels {
            let d = &scene.drones[l.drone];
            let side = l.amodal.width().max(l.amodal.height());
            // A box side is the span seen from the drone's own distance: at
            // most √3 × span (a cube's diagonal), at least a fraction of it.
            let span_px = f * d.size_m / (d.position - cam.position).length();
            assert!(
                side <= span_px * 3f64.sqrt() + 1e-6,
                "frame {i}: {side} vs {span_px}"
            );
            assert!(side >= span_px * 0.3, "frame {i}: {side} vs {span_px}");
            sizes.push(side);
        }
    }
    sizes.sort_by(f64::total_cmp);
    let pct = |q: f64| sizes[((sizes.len() - 1) as f64 * q) as usize];
    let under_6 = sizes.iter().filter(|&&s| s < 6.0).count() as f64 / sizes.len() as f64;
    eprintln!(
        "{} boxes, largest side: min {:.2}, quartiles {:.2} / {:.2} / {:.2}, max {:.2} px; {:.0} % under 6 px",
        sizes.len(),
        pct(0.0),
        pct(0.25),
        pct(0.5),
        pct(0.75),
        pct(1.0),
        under_6 * 100.0
    );
    assert!(sizes.len() > 100);
    assert!((3.0..=6.0).contains(&pct(0.5)), "median {}", pct(0.5));
    assert!(under_6 > 0.7, "{under_6}");
}

/// `camera.observer.centre_at` puts the volume's centre at that point of the frame, at
/// the drawn depth, along the same line of sight: frame for frame the camera turns as
/// without it (so the horizon keeps its row), the centre projects to (x·W, y·H) and lies
/// as deep as before (the same apparent size). A share outside [0, 1] is refused, named.
#[test]
fn observer_centre_at_puts_the_volume_centre_there_on_the_same_line_of_sight() {
    let plain = observer_preset();
    let mut moved = observer_preset();
    moved.camera.observer.as_mut().expect("observer").centre_at = Some((0.2, 0.7));
    moved.validate().expect("valid");
    let (w, h) = moved.image_size();
    let a = FramePipeline::new(plain).expect("pipeline");
    let b = FramePipeline::new(moved.clone()).expect("pipeline");
    for i in [0, 7, 23] {
        let (ca, cb) = (
            a.plan(i).expect("plan").0.camera,
            b.plan(i).expect("plan").0.camera,
        );
        assert!(
            ca.camera_from_world
                .abs_diff_eq(cb.camera_from_world, 1e-12),
            "frame {i}: the same rotation"
        );
        let (pa, pb) = (
            ca.camera_from_world_point(DVec3::ZERO),
            cb.camera_from_world_point(DVec3::ZERO),
        );
        let px = cb.project_camera_point(pb).expect("in front");
        assert!(
            (px.x - 0.2 * f64::from(w)).abs() < 1e-6 && (px.y - 0.7 * f64::from(h)).abs() < 1e-6,
            "frame {i}: the centre at {px}"
        );
        assert!(
            (pb.z - pa.z).abs() < 1e-9 * pa.z,
            "frame {i}: depth {} vs {}",
            pb.z,
            pa.z
        );
    }
    let mut bad = moved;
    bad.camera.observer.as_mut().expect("observer").centre_at = Some((1.5, 0.5));
    let errors = bad.validate().expect_err("outside the frame");
    assert!(
        errors
            .iter()
            .any(|e| e.field == "camera.observer.centre_at"),
        "{errors:?}"
    );
}

#[test]
fn observer_distance_range_is_kept_and_the_paper_sweep_is_untouched_without_it() {
    let mut p = observer_preset();
    p.camera.observer = Some(ObserverCamera {
        elevation_deg: (50.0, 50.0),
        azimuth_deg: (0.0, 0.0),
        distance_m: (400.0, 900.0),
        size_px: None,
        size_px_knots: None,
        centre_at: None,
    });
    let pipeline = FramePipeline::new(p.clone()).expect("pipeline");
    for i in 0..20 {
        let s = pipeline.scene(i).expect("scene");
        let d = s.camera.position.length();
        assert!((400.0..=900.0).contains(&d), "{d}");
        // Elevation 50° > half the 50° field of view: the horizon is out of frame.
        let el = (-s.camera.position.y / d).asin().to_degrees();
        assert!((el - 50.0).abs() < 1e-9, "{el}");
    }
    // Off: the same preset without the observer frames the paper's way.
    p.camera.observer = None;
    let a = FramePipeline::new(p.clone())
        .expect("pipeline")
        .scene(3)
        .expect("scene");
    let mut q = p.clone();
    q.atmosphere = None;
    q.appearance = None;
    let b = FramePipeline::new(q)
        .expect("pipeline")
        .scene(3)
        .expect("scene");
    assert_eq!(a, b);
    assert!(a.atmosphere.is_none() && a.looks.is_empty());
}

#[test]
fn drawn_looks_change_the_picture_but_not_the_labels() {
    let mut p = common::tiny_preset();
    let plain = FramePipeline::new(p.clone()).expect("pipeline");
    p.appearance = Some(Appearance {
        palette: vec![(DroneColor::White, 1.0)],
        ..Appearance::default()
    });
    p.atmosphere = Some(Atmosphere {
        visibility_m: (2_000.0, 2_000.0),
    });
    let styled = FramePipeline::new(p).expect("pipeline");
    let ctx = common::gpu();
    let mut r1 = plain.renderer(&ctx);
    let mut r2 = styled.renderer(&ctx);
    for i in 0..3 {
        let a = plain.make(&mut r1, i).expect("frame");
        let b = styled.make(&mut r2, i).expect("frame");
        assert_eq!(a.labels, b.labels, "frame {i}");
        assert_ne!(a.rgba, b.rgba, "frame {i}");
        assert_eq!(b.scene.looks.len(), b.scene.drones.len());
        // White drones are brighter than the models' own dark materials.
        let sum = |rgba: &[u8]| rgba.iter().map(|&v| u64::from(v)).sum::<u64>();
        assert!(sum(&b.rgba) > sum(&a.rgba), "frame {i}");
        // Deterministic: the same frame made again is the same.
        let again = styled.make(&mut r2, i).expect("frame");
        assert_eq!(again.rgba, b.rgba);
    }
}

#[test]
fn bad_realism_fields_are_named() {
    let mut p = common::tiny_preset();
    p.atmosphere = Some(Atmosphere {
        visibility_m: (0.0, 10.0),
    });
    p.appearance = Some(Appearance {
        palette: vec![],
        roughness: (0.5, 2.0),
        ..Appearance::default()
    });
    p.camera.observer = Some(ObserverCamera {
        elevation_deg: (10.0, 5.0),
        ..ObserverCamera::default()
    });
    let errors = p.validate().expect_err("invalid");
    let fields: Vec<&str> = errors.iter().map(|e| e.field.as_str()).collect();
    for f in [
        "atmosphere.visibility_m",
        "appearance.palette",
        "appearance.roughness",
        "camera.observer.elevation_deg",
    ] {
        assert!(fields.contains(&f), "{f} not in {fields:?}");
    }
    let text = "(atmosphere: Some((visibility_m: (900, 900), fog: 1)))";
    assert!(ron::from_str::<Preset>(text).is_err());
}

#[test]
fn drones_beyond_the_visibility_lose_their_label() {
    let mut p = common::tiny_preset();
    let plain = FramePipeline::new(p.clone()).expect("pipeline");
    let (scene, labels) = plain.plan(0).expect("plan");
    let distances: Vec<f64> = labels.iter().map(|l| l.distance_m).collect();
    let mut sorted = distances.clone();
    sorted.sort_by(f64::total_cmp);
    // V between the nearest and the farthest drone.
    let v = 0.5 * (sorted[0] + sorted[sorted.len() - 1]);
    p.atmosphere = Some(Atmosphere {
        visibility_m: (v, v),
    });
    let hazed = FramePipeline::new(p).expect("pipeline");
    let (hazed_scene, hazed_labels) = hazed.plan(0).expect("plan");
    assert_eq!(scene.drones, hazed_scene.drones);
    for (a, b) in labels.iter().zip(&hazed_labels) {
        if a.distance_m > v {
            assert!(
                !b.is_kept(),
                "a drone at {} m beyond V = {v} m kept",
                a.distance_m
            );
        } else {
            assert_eq!(a.status, b.status);
        }
    }
    assert!(labels.iter().any(|l| l.is_kept() && l.distance_m > v));
}

#[test]
fn the_procedural_ground_fogs_with_the_same_visibility() {
    // A procedural environment seen looking 40° down at its ground (60 m
    // below the camera, 80–170 m away in the lower half of the frame).
    let mut f = fixture();
    let mut s = f.base.clone();
    s.drones.clear();
    s.looks.clear();
    s.camera.fov_y_deg = 60.0;
    let down = DVec3::new(0.0, -40f64.to_radians().sin(), 40f64.to_radians().cos());
    s.camera.camera_from_world = look_at_cv(DVec3::ZERO, down).expect("look-at");
    s.camera.position = DVec3::ZERO;
    s.sky = FrameSky::Procedural {
        environment: swarmshot::preset::EnvironmentName::BeautifulPasture,
        exposure: 1.0,
        sun: 1.0,
    };
    // The ground's green: G over the mean of R and B, averaged over the lower
    // half (the haze colour is a grey-blue, the pasture green).
    let green = |f: &mut FrameFixture, v: f64| {
        let mut scene = s.clone();
        scene.atmosphere = Some(FrameAtmosphere { visibility_m: v });
        let rgba = render(f, &scene);
        let lower = &rgba[160 * 70 * 4..];
        let n = (lower.len() / 4) as f64;
        let mean = |c: usize| lower.chunks_exact(4).map(|p| f64::from(p[c])).sum::<f64>() / n;
        mean(1) - 0.5 * (mean(0) + mean(2))
    };
    let clear = green(&mut f, 1e6);
    let hazy = green(&mut f, 300.0);
    let thick = green(&mut f, 20.0);
    eprintln!(
        "ground green excess (levels): V = 1e6 m {clear:.1}, 300 m {hazy:.1}, 20 m {thick:.1}"
    );
    // Clear air shows the pasture; the fog grows with 3.912·d/V until the
    // ground is the haze colour (no green left).
    assert!(clear > 20.0, "{clear}");
    assert!(
        hazy < clear - 5.0 && hazy > thick + 5.0,
        "{clear} {hazy} {thick}"
    );
    assert!(thick < 3.0, "{thick}");
}

/// `sun_ev` turns the sunlight on the scene up against the sky: white drones
/// get brighter, the clear sky behind them keeps every byte, and an out-of-range
/// value is refused naming the field.
#[test]
fn the_sunlight_brightens_the_drones_and_leaves_the_sky() {
    use swarmshot::preset::{EnvironmentName, Sky};
    let ctx = common::gpu();
    let with_sun = |sun_ev: f64| {
        let mut p = common::tiny_preset();
        let mut sky = Sky::procedural(EnvironmentName::Daytime);
        if let Sky::Procedural {
            sun_ev: s,
            seed,
            cloud_cover,
            ..
        } = &mut sky
        {
            *s = sun_ev;
            *seed = Some(5);
            // A clear sky: clouds are lit by the sun and brighten with it.
            *cloud_cover = Some(0.0);
        }
        p.sky = sky;
        p.appearance = Some(Appearance {
            palette: vec![(DroneColor::White, 1.0)],
            ..Appearance::default()
        });
        p
    };
    let frame = |p: Preset| {
        let pipeline = FramePipeline::new(p).expect("pipeline");
        let mut renderer = pipeline.renderer(&ctx);
        pipeline.make(&mut renderer, 0).expect("frame")
    };
    let (a, b) = (frame(with_sun(0.0)), frame(with_sun(1.0)));
    let w = a.scene.camera.width as usize;
    let in_boxes = |f: &swarmshot::pipeline::Frame, x: usize, y: usize| {
        f.labels.iter().any(|l| {
            let b = l.amodal;
            (b.x0 - 3.0..b.x1 + 3.0).contains(&(x as f64))
                && (b.y0 - 3.0..b.y1 + 3.0).contains(&(y as f64))
        })
    };
    let (mut brighter, mut sky_pixels) = (0usize, 0usize);
    for y in 0..a.scene.camera.height as usize {
        for x in 0..w {
            let i = (y * w + x) * 4;
            if in_boxes(&a, x, y) {
                // More light only brightens: no channel goes down.
                for c in 0..3 {
                    assert!(b.rgba[i + c] >= a.rgba[i + c], "({x}, {y}) channel {c}");
                }
                brighter += usize::from(b.rgba[i..i + 3] != a.rgba[i..i + 3]);
            } else if y < a.scene.camera.height as usize / 3 {
                // The sky (the upper third, away from the drones): unchanged.
                assert_eq!(a.rgba[i..i + 4], b.rgba[i..i + 4], "sky at ({x}, {y})");
                sky_pixels += 1;
            }
        }
    }
    assert!(sky_pixels > 1000, "{sky_pixels}");
    let drone_pixels: u64 = a
        .labels
        .iter()
        .filter_map(|l| l.visibility)
        .map(|v| v.visible_pixels)
        .sum();
    assert!(drone_pixels > 20, "{drone_pixels}");
    assert!(
        brighter as u64 * 2 > drone_pixels,
        "{brighter} pixels brighter with twice the sunlight, of {drone_pixels} drone pixels"
    );
    let errors = with_sun(4.5).validate().expect_err("invalid");
    assert!(errors.iter().any(|e| e.field == "sky.sun_ev"), "{errors:?}");
    // A Random sky's per-frame sunlight range is checked the same way.
    let mut random = common::tiny_preset();
    random.sky = Sky::Random {
        choices: vec![Sky::procedural(EnvironmentName::Daytime)],
        azimuth_offset_deg: (0.0, 0.0),
        sun_elevation_deg: None,
        cloud_cover: None,
        exposure_ev: None,
        sun_ev: Some((-5.0, 0.0)),
    };
    let errors = random.validate().expect_err("invalid");
    assert!(errors.iter().any(|e| e.field == "sky.sun_ev"), "{errors:?}");
}

/// With `appearance`, every drone's manifest record says what it looked like
/// (its drawn palette entry and material); without it, no record has a look.
#[test]
fn the_manifest_records_each_drones_drawn_look() {
    let mut p = common::tiny_preset();
    let line = |p: &Preset, index: u64| {
        let scene = swarmshot::scene::build_frame(p, index).expect("scene");
        let names = vec!["quad_x".to_owned()];
        let text = swarmshot::write::manifest_line(&scene, &[], "x.png", &names, &[]);
        let v: serde_json::Value = serde_json::from_str(&text).expect("json");
        (scene, v)
    };
    let (_, plain) = line(&p, 0);
    assert!(
        plain["drones"]
            .as_array()
            .expect("drones")
            .iter()
            .all(|d| d.get("look").is_none())
    );
    p.appearance = Some(Appearance {
        palette: vec![(DroneColor::Black, 1.0), (DroneColor::White, 1.0)],
        roughness: (0.2, 0.9),
        ..Appearance::default()
    });
    let mut colors = std::collections::BTreeSet::new();
    for index in 0..p.frame_count().min(4) {
        let (scene, v) = line(&p, index);
        let drones = v["drones"].as_array().expect("drones");
        assert_eq!(drones.len(), scene.looks.len());
        for (d, look) in drones.iter().zip(&scene.looks) {
            let l = &d["look"];
            assert_eq!(l["color"], look.color.name());
            let want = if look.color == DroneColor::Black {
                0.03
            } else {
                0.8
            };
            assert_eq!(l["albedo"][1].as_f64(), Some(want));
            let r = l["roughness"].as_f64().expect("roughness");
            assert!((r - f64::from(look.roughness)).abs() < 1e-6 && (0.2..=0.9).contains(&r));
            colors.insert(look.color.name());
        }
    }
    assert_eq!(colors.len(), 2, "both palette entries drawn: {colors:?}");
}
