//! The camera model against an independent K[R|t] computation, hull boxes
//! against brute force, and rendered pixels against the labels.

use crate::common;

use glam::{DMat3, DVec3};
use swarmshot::annotate::{PixelBox, amodal_box};
use swarmshot::pipeline::FramePipeline;
use swarmshot::preset::sweep::SweepRange;
use swarmshot::preset::{Placement, Preset, Resolution};
use swarmshot::scene::build_frame;

/// Independent projection: build K, R, t from first principles (forward to the
/// origin, right = forward × up, down = forward × right) and apply Eq. 8.
fn project_independent(eye: DVec3, fov_y_deg: f64, w: f64, h: f64, x: DVec3) -> (f64, f64) {
    let forward = (-eye).normalize();
    let right = forward.cross(DVec3::Y).normalize();
    let down = forward.cross(right);
    let r = DMat3::from_cols(right, down, forward).transpose();
    let t = -(r * eye);
    let f = (h / 2.0) / (fov_y_deg.to_radians() / 2.0).tan();
    let k = DMat3::from_cols(
        DVec3::new(f, 0.0, 0.0),
        DVec3::new(0.0, f, 0.0),
        DVec3::new(w / 2.0, h / 2.0, 1.0),
    );
    let p = k * (r * x + t);
    (p.x / p.z, p.y / p.z)
}

#[test]
fn camera_matches_an_independent_k_r_t() {
    let mut p = common::tiny_preset();
    p.camera.x = SweepRange::new(-0.5, 0.5, 0.5);
    p.camera.y = SweepRange::new(-0.4, 0.4, 0.4);
    p.camera.z = SweepRange::new(0.8, 1.6, 0.8);
    for index in 0..p.frame_count() {
        let scene = build_frame(&p, index).expect("frame");
        let cam = &scene.camera;
        for d in &scene.drones {
            let Some(uv) = cam.project_camera_point(cam.camera_from_world_point(d.position)) else {
                continue;
            };
            let (u, v) = project_independent(
                cam.position,
                cam.fov_y_deg,
                f64::from(cam.width),
                f64::from(cam.height),
                d.position,
            );
            assert!(
                (uv.x - u).abs() < 1e-9 && (uv.y - v).abs() < 1e-9,
                "frame {index}: {uv} vs ({u}, {v})"
            );
            // K, R, t as the manifest writes them give the same pixel.
            let q = cam.k() * (cam.camera_from_world * d.position + cam.t());
            assert!((q.x / q.z - u).abs() < 1e-9 && (q.y / q.z - v).abs() < 1e-9);
        }
    }
}

#[test]
fn hull_box_equals_brute_force_over_every_vertex() {
    let p = common::tiny_preset();
    let maker = FramePipeline::new(p.clone()).expect("models");
    let model = &maker.assets().models[0];
    assert!(
        model.hull.len() < model.vertices.len(),
        "the hull should be a reduction"
    );
    for index in 0..p.frame_count() {
        let scene = build_frame(&p, index).expect("frame");
        for d in &scene.drones {
            let hull = amodal_box(&scene.camera, d, &maker.assets().geometry[0]).expect("in view");
            let mut all = swarmshot::annotate::LabelGeometry::from(model);
            all.hull = model
                .vertices
                .iter()
                .map(|v| DVec3::from(v.position.map(f64::from)))
                .collect();
            let brute = amodal_box(&scene.camera, d, &all).expect("in view");
            for (a, b) in [
                (hull.x0, brute.x0),
                (hull.y0, brute.y0),
                (hull.x1, brute.x1),
                (hull.y1, brute.y1),
            ] {
                assert!((a - b).abs() < 1e-4, "hull {hull:?} vs brute {brute:?}");
            }
        }
    }
}

/// The pixel bounding box of where `image` differs from `background`.
fn diff_box(image: &[u8], background: &[u8], width: u32) -> Option<PixelBox> {
    let mut b: Option<PixelBox> = None;
    for (i, (a, s)) in image
        .chunks_exact(4)
        .zip(background.chunks_exact(4))
        .enumerate()
    {
        if a[..3] != s[..3] {
            let (x, y) = ((i as u32 % width) as f64, (i as u32 / width) as f64);
            let nb = b.get_or_insert(PixelBox {
                x0: x,
                y0: y,
                x1: x + 1.0,
                y1: y + 1.0,
            });
            nb.x0 = nb.x0.min(x);
            nb.y0 = nb.y0.min(y);
            nb.x1 = nb.x1.max(x + 1.0);
            nb.y1 = nb.y1.max(y + 1.0);
        }
    }
    b
}

#[test]
fn rendered_silhouette_matches_the_amodal_box() {
    let ctx = common::gpu();
    let mut p = Preset::default();
    p.placement = Placement::Structured {
        x_count: 1,
        y_count: 1,
        z_count: 1,
        load_factor: 1.0,
    };
    p.render.resolution = Resolution::Custom {
        width: 480,
        height: 270,
    };
    p.render.msaa = 1;
    p.camera.z = SweepRange::fixed(1.0);
    p.camera.y = SweepRange::fixed(0.4);
    p.attitude.yaw_deg = (-180.0, 180.0);
    p.repeats = 6;
    let maker = FramePipeline::new(p.clone()).expect("models");
    let mut renderer = maker.renderer(&ctx);
    for index in 0..p.frame_count() {
        let (scene, labels) = maker.plan(index).expect("frame");
        assert_eq!(labels.len(), 1);
        let image = renderer.render_rgba(&scene, 1).expect("render");
        let mut empty = scene.clone();
        empty.drones.clear();
        let sky = renderer.render_rgba(&empty, 1).expect("render");
        let seen = diff_box(&image, &sky, 480).expect("the drone is visible");
        let b = labels[0].bbox;
        for (name, px, label) in [
            ("x0", seen.x0, b.x0),
            ("y0", seen.y0, b.y0),
            ("x1", seen.x1, b.x1),
            ("y1", seen.y1, b.y1),
        ] {
            assert!(
                (px - label).abs() <= 1.0,
                "frame {index} edge {name}: pixels {px} vs label {label:.3}"
            );
        }
    }
}
