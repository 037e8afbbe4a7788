//! Numerical robustness on stiff and extreme cases. Each test asserts a
//! property of the result, not merely that nothing panicked.

use crate::common;

use glam::{DMat3, DQuat, DVec3};
use swarmshot::annotate::{LabelGeometry, LabelStatus, amodal_box, label_frame, paper_aabb_box};
use swarmshot::pipeline::FramePipeline;
use swarmshot::preset::sweep::SweepRange;
use swarmshot::preset::{BoxMethod, LabelSettings, Placement, Preset, Resolution, Volume};
use swarmshot::render::visibility::pixel_stats;
use swarmshot::scene::math::{EulerDeg, look_at_cv, slerp};
use swarmshot::scene::{DronePose, FrameScene, build_frame};

fn mat_close(a: DMat3, b: DMat3, tol: f64) -> bool {
    a.to_cols_array()
        .iter()
        .zip(b.to_cols_array())
        .all(|(x, y)| (x - y).abs() < tol)
}

fn is_rotation(m: DMat3) -> bool {
    (m.determinant() - 1.0).abs() < 1e-9 && mat_close(m * m.transpose(), DMat3::IDENTITY, 1e-9)
}

#[test]
fn slerp_near_identical_and_opposite_hemispheres() {
    let q0 = EulerDeg {
        roll: 3.0,
        pitch: -7.0,
        yaw: 40.0,
    }
    .to_quat();
    // Ω → 0: a rotation 1e-9 rad away.
    let q1 = (q0 * DQuat::from_rotation_y(1e-9)).normalize();
    for t in [0.0, 0.25, 0.5, 1.0] {
        let r = slerp(q0, q1, t);
        assert!(
            r.is_finite() && (r.length() - 1.0).abs() < 1e-12,
            "t={t}: {r:?}"
        );
        assert!(r.angle_between(q0) <= 1e-8);
    }
    // q0·q1 < 0: the same rotation as −q1, so interpolation takes the short way.
    let q2 = -(q0 * DQuat::from_rotation_x(0.2)).normalize();
    assert!(q0.dot(q2) < 0.0);
    let mid = slerp(q0, q2, 0.5);
    let expected = (q0 * DQuat::from_rotation_x(0.1)).normalize();
    assert!(mat_close(
        DMat3::from_quat(mid),
        DMat3::from_quat(expected),
        1e-12
    ));
    // Exactly equal inputs.
    assert!(mat_close(
        DMat3::from_quat(slerp(q0, q0, 0.7)),
        DMat3::from_quat(q0),
        1e-15
    ));
}

#[test]
fn euler_quaternion_round_trip_at_gimbal_lock() {
    for pitch in [90.0, -90.0, 89.999_999, -89.999_999] {
        for (roll, yaw) in [(0.0, 0.0), (30.0, 60.0), (-170.0, 175.0), (90.0, -90.0)] {
            let e = EulerDeg { roll, pitch, yaw };
            let back = EulerDeg::from_quat(e.to_quat());
            assert!(back.roll.is_finite() && back.pitch.is_finite() && back.yaw.is_finite());
            assert!(
                mat_close(
                    DMat3::from_quat(e.to_quat()),
                    DMat3::from_quat(back.to_quat()),
                    1e-9
                ),
                "{e:?} -> {back:?}"
            );
        }
    }
}

#[test]
fn camera_straight_above_and_below_is_a_proper_rotation() {
    for y in [5.0, -5.0] {
        let mut p = common::tiny_preset();
        p.camera.x = SweepRange::fixed(0.0);
        p.camera.y = SweepRange::fixed(y);
        p.camera.z = SweepRange::fixed(0.0);
        p.plane.ry = SweepRange::fixed(0.0);
        assert!(p.validate().is_ok(), "{:?}", p.validate());
        let scene = build_frame(&p, 0).expect("frame");
        let r = scene.camera.camera_from_world;
        assert!(is_rotation(r));
        // The centre is dead ahead.
        let dir = r * (-scene.camera.position).normalize();
        assert!((dir - DVec3::Z).length() < 1e-12);
        let maker = FramePipeline::new(p.clone()).expect("models");
        let (_, labels) = maker.plan(0).expect("labels");
        assert_eq!(
            labels.len(),
            scene.drones.len(),
            "every drone is in view from above/below"
        );
    }
    // Nearly (not exactly) vertical, on both sides of the fallback threshold.
    for dx in [1e-12, 1e-7, 1e-3] {
        let m = look_at_cv(DVec3::new(dx, 10.0, 0.0), DVec3::ZERO).expect("look-at");
        assert!(is_rotation(m));
        assert!((m * DVec3::new(-dx, -10.0, 0.0).normalize() - DVec3::Z).length() < 1e-9);
    }
}

fn finite_box(b: &swarmshot::annotate::PixelBox) -> bool {
    [b.x0, b.y0, b.x1, b.y1].iter().all(|v| v.is_finite()) && b.x0 <= b.x1 && b.y0 <= b.y1
}

#[test]
fn camera_z_from_1e_minus_3_to_1e4() {
    let mut p = common::tiny_preset();
    p.labels.box_method = BoxMethod::Amodal;
    p.placement = Placement::Structured {
        x_count: 3,
        y_count: 3,
        z_count: 3,
        load_factor: 3.0,
    };
    for z in [1e-3, 1e4] {
        p.camera.z = SweepRange::fixed(z);
        p.camera.y = SweepRange::fixed(0.0);
        let maker = FramePipeline::new(p.clone()).expect("models");
        let (scene, labels) = maker.plan(0).expect("frame");
        for l in &labels {
            assert!(finite_box(&l.amodal) && finite_box(&l.bbox), "{l:?}");
            assert!(
                l.bbox.x0 >= 0.0 && l.bbox.x1 <= 320.0 && l.bbox.y0 >= 0.0 && l.bbox.y1 <= 180.0
            );
        }
        if z < 1.0 {
            // Inside the swarm: the drones behind the camera get no label at all.
            let behind = scene
                .drones
                .iter()
                .filter(|d| scene.camera.camera_from_world_point(d.position).z < 0.0)
                .count();
            assert!(behind > 0);
            assert!(
                labels.len() <= scene.drones.len() - behind + 9,
                "only drones in front (or crossing) are labelled"
            );
        } else {
            // 10 000 × farther than the fitting distance: sub-pixel, so nothing passes min_box_px.
            assert!(labels.iter().all(|l| l.status != LabelStatus::Kept));
            assert!(labels.iter().all(|l| l.amodal.width() < 1.0));
        }
    }
}

fn scene_with(p: &Preset, eye: DVec3, target: DVec3, drones: Vec<DronePose>) -> FrameScene {
    let mut scene = build_frame(p, 0).expect("frame");
    scene.camera.position = eye;
    scene.camera.camera_from_world = look_at_cv(eye, target).expect("look-at");
    scene.drones = drones;
    scene
}

fn drone(position: DVec3, size_m: f64) -> DronePose {
    DronePose {
        model: 0,
        position,
        rotation: DQuat::IDENTITY,
        euler_deg: EulerDeg::default(),
        size_m,
    }
}

#[test]
fn drones_crossing_the_near_plane_or_behind_the_camera() {
    let p = common::tiny_preset();
    let maker = FramePipeline::new(p.clone()).expect("models");
    let geom = &maker.assets().geometry[0];
    // Camera at the origin looking down −Z (world); camera x = world +X.
    let eye = DVec3::ZERO;
    let target = DVec3::new(0.0, 0.0, -1.0);
    // Straddles the camera plane, off to the right: part in front, part behind.
    let crossing = drone(DVec3::new(0.3, 0.0, 0.0), 0.35);
    let behind = drone(DVec3::new(0.0, 0.0, 2.0), 0.35);
    let scene = scene_with(&p, eye, target, vec![crossing.clone(), behind.clone()]);
    let b = amodal_box(&scene.camera, &crossing, geom).expect("the front part is visible");
    assert!(finite_box(&b));
    assert!(
        b.x0 > 160.0,
        "box stays on the right half, not wrapped: {b:?}"
    );
    assert!(
        b.x1 > 320.0 * 10.0,
        "near-plane points project far to the right: {b:?}"
    );
    assert!(amodal_box(&scene.camera, &behind, geom).is_none());
    assert!(paper_aabb_box(&scene.camera, &behind, geom).is_none());
    let labels = label_frame(
        &scene,
        &maker.assets().geometry,
        &[0],
        &LabelSettings {
            box_method: BoxMethod::Amodal,
            ..Default::default()
        },
        None,
    );
    assert_eq!(labels.len(), 1);
    let l = &labels[0];
    assert!(l.truncated);
    assert_eq!(l.bbox.x1, 320.0);
    assert!(l.bbox.x0 > 160.0 && l.bbox.y0 >= 0.0 && l.bbox.y1 <= 180.0);

    // A drone centred on the optical axis straddling the near plane covers the whole view.
    let straddle = drone(DVec3::new(0.0, 0.0, -scene.camera.near_m), 0.35);
    let scene = scene_with(&p, eye, target, vec![straddle]);
    let labels = label_frame(
        &scene,
        &maker.assets().geometry,
        &[0],
        &LabelSettings {
            box_method: BoxMethod::Amodal,
            ..Default::default()
        },
        None,
    );
    assert_eq!(
        labels[0].bbox,
        swarmshot::annotate::PixelBox {
            x0: 0.0,
            y0: 0.0,
            x1: 320.0,
            y1: 180.0
        }
    );
}

/// Amodal labels of `drone` alone, seen from the origin down −Z, with no
/// `min_box_px`: its label and the frame's YOLO text.
fn amodal_alone(drone: DronePose) -> (swarmshot::annotate::DroneLabel, String) {
    let p = common::tiny_preset();
    let maker = FramePipeline::new(p.clone()).expect("models");
    let scene = scene_with(&p, DVec3::ZERO, DVec3::new(0.0, 0.0, -1.0), vec![drone]);
    let settings = LabelSettings {
        box_method: BoxMethod::Amodal,
        min_box_px: 0.0,
        ..Default::default()
    };
    let labels = label_frame(&scene, &maker.assets().geometry, &[0], &settings, None);
    assert_eq!(labels.len(), 1);
    let text = swarmshot::write::formats::yolo::label_text(&scene, &labels);
    (labels[0].clone(), text)
}

#[test]
fn a_box_under_yolos_six_decimals_is_filtered_not_written_with_size_zero() {
    // A 1 µm drone 5 m away: about 4e-5 px wide, 1e-7 of the 320-px side.
    let (speck, text) = amodal_alone(drone(DVec3::new(0.0, 0.0, -5.0), 1e-6));
    assert!(speck.amodal.width() > 0.0 && speck.amodal.width() < 1e-3);
    assert_ne!(speck.status, LabelStatus::Kept, "{:?}", speck.amodal);
    assert!(text.is_empty(), "no YOLO row: {text}");
    // Ten times wider than a millionth of each side: kept, with a size.
    let (small, text) = amodal_alone(drone(DVec3::new(0.0, 0.0, -5.0), 1e-3));
    assert!(small.amodal.width() > 320.0 * 1e-5 && small.amodal.height() > 180.0 * 1e-5);
    assert_eq!(small.status, LabelStatus::Kept, "{:?}", small.amodal);
    let row: Vec<f64> = (text.split_whitespace().skip(1))
        .map(|v| v.parse().expect("number"))
        .collect();
    assert!(row.len() == 4 && row[2] > 0.0 && row[3] > 0.0, "{text}");
}

#[test]
fn one_pixel_drone_and_frame_filling_drone() {
    let ctx = common::gpu();
    let mut p = common::tiny_preset();
    p.labels.min_box_px = 0.0;
    let maker = FramePipeline::new(p.clone()).expect("models");
    let mut renderer = maker.renderer(&ctx);
    let f = 90.0 / (p.camera.fov_y_deg.to_radians() / 2.0).tan();
    // 0.35 m spanning ~1 px: distance = f·size.
    let tiny = drone(DVec3::new(0.0, 0.0, -0.35 * f), 0.35);
    let scene = scene_with(&p, DVec3::ZERO, DVec3::new(0.0, 0.0, -1.0), vec![tiny]);
    let labels = maker.labels(&mut renderer, &scene).expect("labels");
    let l = &labels[0];
    assert!(
        finite_box(&l.amodal) && l.amodal.width() < 1.5 && l.amodal.width() > 0.5,
        "{:?}",
        l.amodal
    );
    let v = l.visibility.expect("measured");
    assert!(v.visible_pixels <= 2);
    // Filling the frame: a 1.5 m drone 0.5 m away, the camera just outside its
    // body (from inside a body only back faces face the camera, and glTF's
    // single-sided materials cull them).
    let huge = drone(DVec3::new(0.0, 0.0, -0.5), 1.5);
    let scene = scene_with(&p, DVec3::ZERO, DVec3::new(0.0, 0.0, -1.0), vec![huge]);
    let labels = maker.labels(&mut renderer, &scene).expect("labels");
    let l = &labels[0];
    assert!(l.truncated);
    assert_eq!(
        l.bbox,
        swarmshot::annotate::PixelBox {
            x0: 0.0,
            y0: 0.0,
            x1: 320.0,
            y1: 180.0
        },
        "the visible box is the whole image"
    );
    assert!(l.visibility.expect("measured").visible_pixels > 320 * 180 / 2);
}

#[test]
fn reversed_z_separates_drones_one_metre_apart_at_five_kilometres() {
    let ctx = common::gpu();
    let p = common::tiny_preset();
    let maker = FramePipeline::new(p.clone()).expect("models");
    let mut renderer = maker.renderer(&ctx);
    let target = DVec3::new(0.0, 0.0, -1.0);
    // 0.35 m drones (thin and wide seen from the side), 1 m apart in depth, 5 km away.
    let near = drone(DVec3::new(0.0, 0.0, -5000.0), 0.35);
    let far = drone(DVec3::new(0.1, 0.02, -5001.0), 0.35);
    for order in [
        vec![near.clone(), far.clone()],
        vec![far.clone(), near.clone()],
    ] {
        let near_id = if order[0] == near { 1 } else { 2 };
        let mut scene = scene_with(&p, DVec3::ZERO, target, order);
        scene.camera.fov_y_deg = 0.025; // a long lens: ~80 px per metre at 5 km
        let ids = renderer.render_ids(&scene, &|_| true).expect("ids");
        let stats = pixel_stats(&ids, 2);
        let (near_box, near_px) = stats[near_id as usize - 1];
        let (_, far_px) = stats[2 - near_id as usize];
        assert!(
            near_px > 50 && far_px > 10,
            "both visible: {near_px} {far_px}"
        );
        // Wherever the near drone covers a pixel on its own, the pair shows the near drone: no z-fighting.
        let alone = renderer
            .render_ids(&scene, &|i| i + 1 == near_id as usize)
            .expect("ids");
        assert!(near_box.is_some());
        let mut contested = 0;
        for (k, (&both, &own)) in ids.ids.iter().zip(&alone.ids).enumerate() {
            if own == near_id {
                assert_eq!(
                    both, near_id,
                    "pixel {k} shows the far drone through the near one"
                );
                contested += 1;
            }
        }
        let far_alone = renderer
            .render_ids(&scene, &|i| i + 1 != near_id as usize)
            .expect("ids");
        let overlap = alone
            .ids
            .iter()
            .zip(&far_alone.ids)
            .filter(|(a, b)| **a != 0 && **b != 0)
            .count();
        assert!(
            overlap > 10,
            "the drones must overlap on screen for the test to mean anything: {overlap}"
        );
        assert!(contested > 10, "{contested}");
    }
}

#[test]
fn grids_from_one_to_a_million_drones() {
    for n in [1u32, 10, 100] {
        let mut p = Preset::default();
        p.placement = Placement::Structured {
            x_count: n,
            y_count: n,
            z_count: n,
            load_factor: 1.0,
        };
        p.attitude.yaw_deg = (0.0, 0.0);
        p.attitude.roll_deg = (0.0, 0.0);
        p.attitude.pitch_deg = (0.0, 0.0);
        assert!(p.validate().is_ok());
        let scene = build_frame(&p, 0).expect("frame");
        assert_eq!(scene.drones.len() as u64, u64::from(n).pow(3));
        // LoadFactor 1 at its minimum: neighbours exactly one model size apart (touching, not overlapping).
        if n > 1 {
            let d = scene.drones[1].position - scene.drones[0].position;
            assert!((d.length() - 0.35).abs() < 1e-12, "{d}");
        }
        // CameraZ = 1 fits the volume: every drone centre projects inside the image.
        let cam = &scene.camera;
        for d in scene.drones.iter().step_by(997) {
            let uv = cam
                .project_camera_point(cam.camera_from_world_point(d.position))
                .expect("in front");
            assert!(
                uv.x >= 0.0 && uv.x <= 1920.0 && uv.y >= 0.0 && uv.y <= 1080.0,
                "{uv}"
            );
        }
    }
}

#[test]
fn millimetre_and_kilometre_models() {
    // The same scene in millimetres and in kilometres: every box is the same in pixels.
    let ctx = common::gpu();
    let mut results = Vec::new();
    for size in [0.001, 0.35, 1000.0] {
        let mut p = common::tiny_preset();
        p.models[0].size_m = size;
        p.labels.min_box_px = 0.0;
        p.render.resolution = Resolution::Custom {
            width: 640,
            height: 360,
        };
        p.placement = Placement::Randomized {
            count: (4, 4),
            count_distribution: Default::default(),
            volume: Volume::Box {
                size_m: (size * 10.0, size * 5.0, size * 10.0),
            },
            min_separation_m: size * 2.0,
        };
        assert!(p.validate().is_ok(), "{:?}", p.validate());
        let maker = FramePipeline::new(p.clone()).expect("models");
        let mut renderer = maker.renderer(&ctx);
        let scene = build_frame(&p, 0).expect("frame");
        let labels = maker.labels(&mut renderer, &scene).expect("labels");
        assert_eq!(
            labels.iter().filter(|l| l.is_kept()).count(),
            4,
            "size {size}"
        );
        results.push(labels);
    }
    for other in &results[1..] {
        for (a, b) in results[0].iter().zip(other) {
            for (x, y) in [
                (a.amodal.x0, b.amodal.x0),
                (a.amodal.y0, b.amodal.y0),
                (a.amodal.x1, b.amodal.x1),
                (a.amodal.y1, b.amodal.y1),
            ] {
                assert!(
                    (x - y).abs() < 1e-6,
                    "amodal {:?} vs {:?}",
                    a.amodal,
                    b.amodal
                );
            }
            assert_eq!(
                a.visibility.map(|v| v.visible_pixels),
                b.visibility.map(|v| v.visible_pixels)
            );
        }
    }
}

#[test]
fn float_steps_count_without_accumulated_error() {
    let cases = [
        ((0.0, 1.0, 0.1), 11),
        ((0.0, 0.3, 0.1), 4),
        ((1.0, 0.0, -0.1), 11),
        ((0.0, 2.0, 0.2), 11),
        ((-1.5, 1.5, 0.3), 11),
        ((0.0, 1.0, 1.0 / 3.0), 4),
    ];
    for ((s, e, st), n) in cases {
        let r = SweepRange::new(s, e, st);
        assert_eq!(r.count(), Ok(n), "{s}..{e} step {st}");
        assert!((r.value(n - 1) - e).abs() < 1e-12);
    }
    let mut p = common::tiny_preset();
    p.plane.rz = SweepRange::new(0.0, 1.0, 0.1);
    assert_eq!(p.frame_count(), common::tiny_preset().frame_count() * 11);
    let last = build_frame(&p, p.frame_count() - 1).expect("last frame");
    assert_eq!(last.sweep.PlaneRZ, 10.0 * 0.1);
    assert!(build_frame(&p, p.frame_count()).is_err());
}

#[test]
fn label_geometry_of_a_rotated_drone_is_inside_its_paper_box() {
    // Sanity across many attitudes: amodal ⊆ paper box, both finite.
    let p = common::tiny_preset();
    let maker = FramePipeline::new(p.clone()).expect("models");
    let geom: &LabelGeometry = &maker.assets().geometry[0];
    let scene = build_frame(&p, 0).expect("frame");
    for k in 0..200 {
        let e = EulerDeg {
            roll: f64::from(k) * 7.3,
            pitch: f64::from(k) * 3.1 - 90.0,
            yaw: f64::from(k) * 11.7,
        };
        let mut d = drone(DVec3::new(0.1, 0.2, 0.3), 0.35);
        d.rotation = e.to_quat();
        let a = amodal_box(&scene.camera, &d, geom).expect("in view");
        let b = paper_aabb_box(&scene.camera, &d, geom).expect("in view");
        assert!(finite_box(&a) && finite_box(&b));
        assert!(
            a.x0 >= b.x0 - 1e-9
                && a.y0 >= b.y0 - 1e-9
                && a.x1 <= b.x1 + 1e-9
                && a.y1 <= b.y1 + 1e-9
        );
    }
}

#[test]
fn resolution_beyond_the_adapter_limit_is_a_named_error() {
    let ctx = common::gpu();
    let p = common::tiny_preset();
    let maker = FramePipeline::new(p.clone()).expect("models");
    let mut renderer = maker.renderer(&ctx);
    let mut scene = build_frame(&p, 0).expect("frame");
    scene.camera.width = ctx.max_texture_side + 1;
    let err = renderer.render_rgba(&scene, 1).expect_err("too large");
    assert!(err.to_string().contains("render.resolution"), "{err}");
    let err = renderer
        .render_ids(&scene, &|_| true)
        .expect_err("too large");
    assert!(err.to_string().contains("render.resolution"), "{err}");
}
