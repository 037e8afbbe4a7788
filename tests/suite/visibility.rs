//! Visible boxes and visibility from the instance-id pass: agreement with a
//! 4× reference on single drones, fractions against per-drone renders in a
//! crafted overlap and in a dense swarm (where only the drones the main pass
//! shows something in front of get a layer pass), filters, and only running
//! the passes a preset needs.

use crate::common;

use glam::DVec3;
use swarmshot::annotate::{LabelStatus, PixelBox};
use swarmshot::pipeline::FramePipeline;
use swarmshot::preset::sweep::SweepRange;
use swarmshot::preset::{BoxMethod, FilteredDrones, Placement, Preset, Resolution};
use swarmshot::render::visibility::{self, pixel_stats};
use swarmshot::scene::math::{EulerDeg, look_at_cv};
use swarmshot::scene::{DronePose, FrameScene, build_frame};

fn single_drone_preset() -> Preset {
    let mut p = Preset::default();
    p.placement = Placement::Structured {
        x_count: 1,
        y_count: 1,
        z_count: 1,
        load_factor: 1.0,
    };
    p.render.resolution = Resolution::Custom {
        width: 320,
        height: 180,
    };
    p.render.msaa = 1;
    p.camera.z = SweepRange::fixed(1.0);
    p.camera.y = SweepRange::new(-0.6, 0.6, 0.6);
    p.attitude.roll_deg = (-80.0, 80.0);
    p.attitude.pitch_deg = (-80.0, 80.0);
    p.repeats = 4;
    p
}

fn upscaled(scene: &FrameScene, k: u32) -> FrameScene {
    let mut s = scene.clone();
    s.camera.width *= k;
    s.camera.height *= k;
    s
}

#[test]
fn single_drones_agree_with_a_4x_reference_and_paper_boxes_are_looser() {
    let ctx = common::gpu();
    let p = single_drone_preset();
    let maker = FramePipeline::new(p.clone()).expect("models");
    let mut renderer = maker.renderer(&ctx);
    let (mut iou_amodal, mut iou_paper, mut n) = (0.0, 0.0, 0.0);
    for index in 0..p.frame_count() {
        let scene = build_frame(&p, index).expect("frame");
        let labels = maker.labels(&mut renderer, &scene).expect("labels");
        assert_eq!(labels.len(), 1);
        let l = &labels[0];
        assert_eq!(l.status, LabelStatus::Kept);
        let big = upscaled(&scene, 4);
        let ids = renderer.render_ids(&big, &|_| true).expect("4x ids");
        let r = pixel_stats(&ids, 1)[0].0.expect("visible at 4x");
        let reference = PixelBox {
            x0: r.x0 / 4.0,
            y0: r.y0 / 4.0,
            x1: r.x1 / 4.0,
            y1: r.y1 / 4.0,
        };
        let visible = l
            .visibility
            .and_then(|v| v.visible_box)
            .expect("visible box");
        assert_eq!(l.bbox, visible, "Visible is the default method");
        for (name, b) in [("visible", visible), ("amodal", l.amodal)] {
            for (edge, a, r) in [
                ("x0", b.x0, reference.x0),
                ("y0", b.y0, reference.y0),
                ("x1", b.x1, reference.x1),
                ("y1", b.y1, reference.y1),
            ] {
                assert!(
                    (a - r).abs() <= 1.0,
                    "frame {index}: {name} {edge} {a:.2} vs 4× reference {r:.2}"
                );
            }
        }
        iou_amodal += l.amodal.iou(&reference);
        iou_paper += l.paper_aabb.iou(&reference);
        n += 1.0;
        // Nothing occludes a lone drone.
        let v = l.visibility.expect("measured");
        assert_eq!(v.visible_pixels, v.unoccluded_pixels);
        assert!(v.visible_pixels > 0);
    }
    let (iou_amodal, iou_paper) = (iou_amodal / n, iou_paper / n);
    assert!(iou_amodal > 0.85, "amodal mean IoU {iou_amodal}");
    assert!(
        iou_paper < iou_amodal - 0.1,
        "paper boxes should be looser: {iou_paper} vs {iou_amodal}"
    );
}

fn crafted_overlap(p: &Preset) -> FrameScene {
    let mut scene = build_frame(p, 0).expect("frame");
    let eye = DVec3::new(0.0, 0.0, 6.0);
    scene.camera.position = eye;
    scene.camera.camera_from_world = look_at_cv(eye, DVec3::ZERO).expect("look-at");
    scene.camera.fov_y_deg = 12.0;
    let pose = |x: f64, y: f64, z: f64, yaw: f64| {
        let e = EulerDeg {
            roll: 10.0,
            pitch: 25.0,
            yaw,
        };
        DronePose {
            model: 0,
            position: DVec3::new(x, y, z),
            rotation: e.to_quat(),
            euler_deg: e,
            size_m: 0.35,
        }
    };
    scene.drones = vec![
        pose(0.0, 0.0, 1.0, 20.0),    // nearest, in the middle
        pose(0.12, 0.03, 0.0, 60.0),  // partly behind the first
        pose(-0.1, -0.02, -1.0, 0.0), // behind both
        pose(0.45, 0.2, 0.5, 45.0),   // apart from the others
    ];
    scene
}

#[test]
fn visible_fractions_match_rendering_each_drone_alone() {
    let ctx = common::gpu();
    let mut p = single_drone_preset();
    p.render.resolution = Resolution::Custom {
        width: 480,
        height: 270,
    };
    let maker = FramePipeline::new(p.clone()).expect("models");
    let mut renderer = maker.renderer(&ctx);
    let scene = crafted_overlap(&p);
    let vis = visibility::measure(&mut renderer, &scene, 1, 1).expect("measure");
    let all = renderer.render_ids(&scene, &|_| true).expect("ids");
    let nonzero = all.ids.iter().filter(|&&id| id != 0).count() as u64;
    assert_eq!(vis.iter().map(|v| v.visible_pixels).sum::<u64>(), nonzero);
    for (i, v) in vis.iter().enumerate() {
        let alone = renderer.render_ids(&scene, &|j| j == i).expect("alone");
        let count = alone.ids.iter().filter(|&&id| id == i as u32 + 1).count() as u64;
        assert_eq!(v.unoccluded_pixels, count, "drone {i}");
        let seen = all.ids.iter().filter(|&&id| id == i as u32 + 1).count() as u64;
        assert_eq!(v.visible_pixels, seen, "drone {i}");
    }
    assert!(vis[0].fraction() == 1.0, "the nearest drone is whole");
    assert!(
        vis[1].fraction() < 0.95 && vis[1].fraction() > 0.0,
        "drone 1 is partly hidden: {}",
        vis[1].fraction()
    );
    assert!(vis[2].fraction() < vis[1].fraction() + 0.5);
    assert_eq!(vis[3].fraction(), 1.0);
}

/// With MSAA, each drone's unoccluded count equals what it shows measured
/// alone, both for drones that a nearer one overlaps (drawn in a layer pass)
/// and for the nearest, which overlaps only drones behind it (whole in the
/// main pass, drawn once).
#[test]
fn unoccluded_counts_equal_each_drone_measured_alone_with_msaa() {
    let ctx = common::gpu();
    let mut p = single_drone_preset();
    p.render.resolution = Resolution::Custom {
        width: 480,
        height: 270,
    };
    let maker = FramePipeline::new(p.clone()).expect("models");
    let mut renderer = maker.renderer(&ctx);
    let scene = crafted_overlap(&p);
    let vis = visibility::measure(&mut renderer, &scene, 4, 1).expect("measure");
    for (i, v) in vis.iter().enumerate() {
        let mut alone = scene.clone();
        alone.drones = vec![scene.drones[i].clone()];
        alone.looks = scene.looks.iter().skip(i).take(1).cloned().collect();
        let a = visibility::measure(&mut renderer, &alone, 4, 1).expect("alone")[0];
        assert!(a.visible_pixels > 0, "drone {i}");
        assert_eq!(a.visible_pixels, a.unoccluded_pixels, "drone {i} alone");
        assert_eq!(v.unoccluded_pixels, a.visible_pixels, "drone {i}");
    }
    assert_eq!(
        vis[0].fraction(),
        1.0,
        "nothing is in front of the nearest drone"
    );
    assert!(
        vis[1].visible_pixels < vis[1].unoccluded_pixels,
        "drone 1 is partly hidden"
    );
}

/// A dense swarm: 60 drones (about 30 px) in a 2.4 m box seen from 6 m,
/// most of them overlapping others on screen.
fn dense_swarm(p: &Preset) -> FrameScene {
    let mut scene = crafted_overlap(p);
    scene.camera.fov_y_deg = 30.0;
    let mut seed = 12345u64;
    let mut next = move || {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (seed >> 11) as f64 / (1u64 << 53) as f64
    };
    let template = scene.drones[0].clone();
    scene.drones = (0..60)
        .map(|_| {
            let e = EulerDeg {
                roll: next() * 60.0 - 30.0,
                pitch: next() * 60.0 - 30.0,
                yaw: next() * 360.0,
            };
            let position = DVec3::new(next() - 0.5, next() - 0.5, next() - 0.5) * 2.4;
            DronePose {
                position,
                rotation: e.to_quat(),
                euler_deg: e,
                ..template.clone()
            }
        })
        .collect();
    let look = scene.looks.first().cloned();
    scene.looks = look.map(|l| vec![l; 60]).unwrap_or_default();
    scene
}

/// In a dense swarm every drone's unoccluded count, with and without MSAA,
/// equals what it shows rendered alone: the drones that get no layer pass
/// (nothing shown in front of them) as well as the ones that do.
#[test]
fn dense_swarm_unoccluded_counts_equal_each_drone_alone() {
    let ctx = common::gpu();
    let mut p = single_drone_preset();
    p.render.resolution = Resolution::Custom {
        width: 480,
        height: 270,
    };
    let maker = FramePipeline::new(p.clone()).expect("models");
    let mut renderer = maker.renderer(&ctx);
    let scene = dense_swarm(&p);
    for msaa in [4, 1] {
        let vis = visibility::measure(&mut renderer, &scene, msaa, 1).expect("measure");
        let (mut hidden, mut whole) = (0, 0);
        for (i, v) in vis.iter().enumerate() {
            let mut alone = scene.clone();
            alone.drones = vec![scene.drones[i].clone()];
            alone.looks = scene.looks.iter().skip(i).take(1).cloned().collect();
            let a = visibility::measure(&mut renderer, &alone, msaa, 1).expect("alone")[0];
            assert_eq!(
                v.unoccluded_pixels, a.visible_pixels,
                "msaa {msaa}, drone {i}"
            );
            assert!(v.visible_pixels <= v.unoccluded_pixels);
            if v.visible_pixels < v.unoccluded_pixels {
                hidden += 1;
            } else if v.visible_pixels > 0 {
                whole += 1;
            }
        }
        assert!(
            hidden >= 10 && whole >= 10,
            "msaa {msaa}: {hidden} hidden, {whole} whole"
        );
    }
}

#[test]
fn visibility_filters_drop_or_mark_crowd() {
    let ctx = common::gpu();
    let mut p = single_drone_preset();
    p.render.resolution = Resolution::Custom {
        width: 480,
        height: 270,
    };
    p.labels.min_visible_fraction = 0.9;
    for (policy, expected) in [
        (FilteredDrones::Drop, LabelStatus::Filtered),
        (FilteredDrones::Crowd, LabelStatus::Crowd),
    ] {
        p.labels.filtered = policy;
        let maker = FramePipeline::new(p.clone()).expect("models");
        let mut renderer = maker.renderer(&ctx);
        let scene = crafted_overlap(&p);
        let labels = maker.labels(&mut renderer, &scene).expect("labels");
        let hidden = labels
            .iter()
            .find(|l| l.drone == 1)
            .expect("drone 1 is in front of the camera");
        assert_eq!(hidden.status, expected);
        assert!(
            labels
                .iter()
                .find(|l| l.drone == 0)
                .is_some_and(|l| l.is_kept())
        );
    }
}

#[test]
fn only_the_passes_a_preset_needs_run() {
    let ctx = common::gpu();
    let mut p = single_drone_preset();
    p.labels.box_method = BoxMethod::Amodal;
    let maker = FramePipeline::new(p.clone()).expect("models");
    let mut renderer = maker.renderer(&ctx);
    let scene = build_frame(&p, 0).expect("frame");
    maker.labels(&mut renderer, &scene).expect("labels");
    renderer.render_rgba(&scene, 1).expect("render");
    assert_eq!(renderer.pass_counts().ids, 0);
    assert!(
        !renderer.has_id_pipeline(),
        "no id pipeline for an Amodal preset"
    );

    p.labels.min_visible_pixels = 5; // a visibility filter needs the id pass
    let maker = FramePipeline::new(p.clone()).expect("models");
    maker.labels(&mut renderer, &scene).expect("labels");
    assert_eq!(
        renderer.pass_counts().ids,
        1,
        "a lone drone needs one id pass"
    );
}

#[test]
fn supersampled_id_pass_refines_the_same_box() {
    let ctx = common::gpu();
    let p = single_drone_preset();
    let maker = FramePipeline::new(p.clone()).expect("models");
    let mut renderer = maker.renderer(&ctx);
    for index in 0..p.frame_count() {
        let scene = build_frame(&p, index).expect("frame");
        let one = visibility::measure(&mut renderer, &scene, 1, 1).expect("1x")[0];
        let two = visibility::measure(&mut renderer, &scene, 1, 2).expect("2x")[0];
        let (a, b) = (
            one.visible_box.expect("1x box"),
            two.visible_box.expect("2x box"),
        );
        for (x, y) in [(a.x0, b.x0), (a.y0, b.y0), (a.x1, b.x1), (a.y1, b.y1)] {
            assert!((x - y).abs() <= 1.0, "frame {index}: 1× {a:?} vs 2× {b:?}");
        }
        // Four times the pixels at 2×, give or take the edges.
        let ratio = two.visible_pixels as f64 / one.visible_pixels as f64;
        assert!((2.5..6.0).contains(&ratio), "{ratio}");
    }
}
