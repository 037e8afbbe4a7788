//! Visible boxes are what the picture shows: for every drone of a rendered
//! frame, the pixels that change when that drone alone is left out lie inside
//! its visible box, every edge of the box touches such a pixel, and their
//! number is its visible pixel count. Over frames of 10–30 px drones at
//! extreme attitudes (thin legs and edge-on rotors), overlaps, and drones cut
//! by the image border; MSAA 4× and 1×.
//!
//! Why the test is exact (no tolerance): every drone is drawn unlit in a
//! colour whose channels are each 0 or 255, distinct from every drone it can
//! overlap on screen, and at an L1 distance > 48 from every sky pixel (other
//! colours are ≥ 255 away). Leaving a drone out changes each of its samples
//! from its colour C to what lies behind (sky or another drone); in each
//! channel all those changes have the sign of C's channel (0 can only rise,
//! 255 only fall), so they add up instead of cancelling. Summed over the 3
//! channels they exceed 48 / 4 samples = 12 levels, so some channel of the
//! resolved pixel moves by more than 4 levels before rounding: at least 1
//! after it. A pixel none of whose samples shows the drone cannot change.

use crate::common;

use glam::{DMat3, DVec3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use swarmshot::model::CpuModel;
use swarmshot::pipeline::{FramePipeline, load_model};
use swarmshot::preset::{Preset, Resolution};
use swarmshot::render::{RenderRequest, Renderer};
use swarmshot::scene::math::{EulerDeg, look_at_cv};
use swarmshot::scene::projection::{LabelGeometry, amodal_box};
use swarmshot::scene::{DronePose, FrameScene};

const WIDTH: u32 = 480;
const HEIGHT: u32 = 270;

/// Every colour with channels 0 or 255 (linear 0 and 1 encode to exactly 0 and 255).
fn palette() -> Vec<[f32; 3]> {
    (0..8)
        .map(|k| [(k & 1) as f32, ((k >> 1) & 1) as f32, ((k >> 2) & 1) as f32])
        .collect()
}

/// The model drawn unlit in one flat colour (textures dropped, alpha cutoffs kept).
fn flat(model: &CpuModel, rgb: [f32; 3]) -> CpuModel {
    let mut m = model.clone();
    for v in &mut m.vertices {
        v.color = [rgb[0], rgb[1], rgb[2], v.color[3]];
        v.material[2] = 1.0;
    }
    for d in &mut m.draws {
        d.texture = None;
    }
    m.textures.clear();
    m
}

/// A scene of `count` drones of `size_m` between `near` and `far` metres
/// (camera frame), at any attitude; `edge` of them straddle the image border.
fn scene_of(
    base: &FrameScene,
    seed: u64,
    count: usize,
    (near, far): (f64, f64),
    cluster: bool,
    edge: usize,
) -> FrameScene {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut scene = base.clone();
    scene.camera.width = WIDTH;
    scene.camera.height = HEIGHT;
    scene.camera.fov_y_deg = 40.0;
    let eye = DVec3::new(0.0, 2.0, 0.0);
    scene.camera.position = eye;
    scene.camera.camera_from_world = look_at_cv(eye, DVec3::new(0.0, 2.0, 10.0)).expect("look-at");
    let world_from_camera: DMat3 = scene.camera.camera_from_world.transpose();
    let f = scene.camera.focal_px();
    let (hw, hh) = (f64::from(WIDTH) * 0.5 / f, f64::from(HEIGHT) * 0.5 / f);
    let centre = (rng.random_range(-0.5..0.5), rng.random_range(-0.5..0.5));
    scene.drones = (0..count)
        .map(|k| {
            let z = rng.random_range(near..far);
            let (u, v) = if k < edge {
                // On the border: the drone's centre within a few pixels of an edge.
                let side = rng.random_range(0..4);
                let t: f64 = rng.random_range(-0.9..0.9);
                match side {
                    0 => (-hw, t * hh),
                    1 => (hw, t * hh),
                    2 => (t * hw, -hh),
                    _ => (t * hw, hh),
                }
            } else if cluster {
                (
                    centre.0 * hw + rng.random_range(-0.12..0.12),
                    centre.1 * hh + rng.random_range(-0.12..0.12),
                )
            } else {
                (
                    rng.random_range(-0.95..0.95) * hw,
                    rng.random_range(-0.95..0.95) * hh,
                )
            };
            let e = EulerDeg {
                roll: rng.random_range(-90.0..90.0),
                pitch: rng.random_range(-90.0..90.0),
                yaw: rng.random_range(-180.0..180.0),
            };
            DronePose {
                model: 0,
                position: eye + world_from_camera * DVec3::new(u * z, v * z, z),
                rotation: e.to_quat(),
                euler_deg: e,
                size_m: 0.35,
            }
        })
        .collect();
    scene
}

/// Give drones that can share a pixel different colours (greedy), among `allowed`.
fn colour(scene: &mut FrameScene, geometry: &LabelGeometry, allowed: &[usize]) {
    let boxes: Vec<_> = scene
        .drones
        .iter()
        .map(|d| amodal_box(&scene.camera, d, geometry))
        .collect();
    let near = |a: usize, b: usize| match (&boxes[a], &boxes[b]) {
        (Some(p), Some(q)) => {
            p.x0 - 2.0 < q.x1 && q.x0 - 2.0 < p.x1 && p.y0 - 2.0 < q.y1 && q.y0 - 2.0 < p.y1
        }
        _ => false,
    };
    for i in 0..scene.drones.len() {
        let taken: Vec<usize> = (0..i)
            .filter(|&j| near(i, j))
            .map(|j| scene.drones[j].model)
            .collect();
        let Some(&c) = allowed.iter().find(|c| !taken.contains(c)) else {
            panic!(
                "drone {i} overlaps {} others: not enough colours",
                taken.len()
            );
        };
        scene.drones[i].model = c;
    }
}

fn l1(a: &[u8], b: [f32; 3]) -> f64 {
    (0..3)
        .map(|c| (f64::from(a[c]) - f64::from(b[c]) * 255.0).abs())
        .sum()
}

#[test]
fn changed_pixels_lie_in_the_visible_box_and_touch_every_edge() {
    let ctx = common::gpu();
    let mut p = Preset::default();
    p.render.resolution = Resolution::Custom {
        width: WIDTH,
        height: HEIGHT,
    };
    let pipeline = FramePipeline::new(p.clone()).expect("preset");
    let base = pipeline.scene(0).expect("scene");
    let source = p.models[0].source.clone();
    let model = load_model(&source).expect("model");
    let geometry = LabelGeometry::from(&model);
    let colours = palette();
    let models: Vec<CpuModel> = colours.iter().map(|&c| flat(&model, c)).collect();
    let mut renderer = Renderer::new(&ctx, &models);
    renderer.set_environment(&pipeline.assets().sky);

    // Colours far from the sky (and, being corners of the RGB cube, from each other).
    let mut empty = scene_of(&base, 0, 0, (1.0, 2.0), false, 0);
    empty.drones.clear();
    let sky = renderer
        .render_frame(
            &empty,
            &RenderRequest {
                msaa: 1,
                color: true,
                visibility: false,
            },
        )
        .expect("sky")
        .rgba;
    let allowed: Vec<usize> = (0..colours.len())
        .filter(|&c| sky.chunks_exact(4).all(|px| l1(px, colours[c]) > 48.0))
        .collect();
    assert!(
        allowed.len() >= 5,
        "the sky is too close to too many colours: {allowed:?}"
    );

    let cases = [
        // (seed, drones, depth range m, clustered, on the border, msaa)
        (1, 14, (6.0, 16.0), false, 3, 4), // 10–30 px, spread out, some cut by the border
        (2, 10, (6.0, 16.0), true, 0, 4),  // 10–30 px, overlapping in a cluster
        (3, 8, (12.0, 18.0), true, 2, 1),  // ~10 px, MSAA off
        (4, 6, (3.0, 6.0), true, 1, 4),    // larger drones overlapping
    ];
    let (mut checked, mut with_overlap, mut truncated) = (0, 0, 0);
    for (seed, count, depth, cluster, edge, msaa) in cases {
        let mut scene = scene_of(&base, seed, count, depth, cluster, edge);
        colour(&mut scene, &geometry, &allowed);
        let request = RenderRequest {
            msaa,
            color: true,
            visibility: true,
        };
        let all = renderer.render_frame(&scene, &request).expect("render");
        let vis = all.visibility.expect("visibility");
        for (i, v) in vis.iter().enumerate() {
            let mut without = scene.clone();
            without.drones.remove(i);
            let other = renderer
                .render_frame(
                    &without,
                    &RenderRequest {
                        visibility: false,
                        ..request
                    },
                )
                .expect("render without");
            let changed: Vec<(u32, u32)> = all
                .rgba
                .chunks_exact(4)
                .zip(other.rgba.chunks_exact(4))
                .enumerate()
                .filter(|(_, (a, b))| a != b)
                .map(|(k, _)| (k as u32 % WIDTH, k as u32 / WIDTH))
                .collect();
            let what = format!("case {seed}, drone {i} (msaa {msaa}): {v:?}");
            assert_eq!(v.visible_pixels, changed.len() as u64, "{what}");
            let Some(b) = v.visible_box else {
                assert!(changed.is_empty(), "{what}");
                continue;
            };
            for &(x, y) in &changed {
                let (x, y) = (f64::from(x), f64::from(y));
                assert!(
                    x >= b.x0 && x + 1.0 <= b.x1 && y >= b.y0 && y + 1.0 <= b.y1,
                    "{what}: pixel ({x}, {y}) changes outside the box"
                );
            }
            let touches = |f: &dyn Fn(f64, f64) -> bool| {
                changed.iter().any(|&(x, y)| f(f64::from(x), f64::from(y)))
            };
            assert!(touches(&|x, _| x == b.x0), "{what}: left edge");
            assert!(touches(&|x, _| x + 1.0 == b.x1), "{what}: right edge");
            assert!(touches(&|_, y| y == b.y0), "{what}: top edge");
            assert!(touches(&|_, y| y + 1.0 == b.y1), "{what}: bottom edge");
            checked += 1;
            if v.visible_pixels < v.unoccluded_pixels {
                with_overlap += 1;
            }
            if b.x0 == 0.0 || b.y0 == 0.0 || b.x1 == f64::from(WIDTH) || b.y1 == f64::from(HEIGHT) {
                truncated += 1;
            }
        }
    }
    // The cases must contain what they claim to, or the test proves less than it says.
    assert!(checked >= 30, "{checked} drones checked");
    assert!(
        with_overlap >= 3,
        "only {with_overlap} partly hidden drones"
    );
    assert!(truncated >= 2, "only {truncated} drones cut by the border");
}
