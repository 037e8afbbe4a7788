//! Near-field scenery (issue 22 item 2): clutter hides the drones behind it
//! in the picture and in the labels, is deterministic, and costs nothing
//! when off.

mod common;

use glam::DVec3;
use swarmshot::pipeline::FramePipeline;
use swarmshot::preset::clutter::Clutter;
use swarmshot::preset::{Placement, Preset};
use swarmshot::render::scenery;
use swarmshot::render::{RenderRequest, Renderer};
use swarmshot::scene::FrameScene;
use swarmshot::scene::clutter::{FrameClutter, Primitive, Shape};

/// The tiny preset with one drone per frame, seen from close by.
fn one_drone() -> Preset {
    let mut p = common::tiny_preset();
    p.camera.z = swarmshot::preset::sweep::SweepRange::fixed(0.25);
    if let Placement::Randomized { count, .. } = &mut p.placement {
        *count = (1, 1);
    }
    p
}

/// A vertical pole of `radius_m` halfway between the camera and drone 0,
/// moved sideways (camera right) by `offset_m`.
fn with_pole(scene: &FrameScene, radius_m: f64, offset_m: f64) -> FrameScene {
    let mut s = scene.clone();
    let right = s.camera.camera_from_world.row(0);
    let mid = (s.camera.position + s.drones[0].position) * 0.5 + right * offset_m;
    s.clutter = Some(FrameClutter::from_primitives(vec![Primitive {
        shape: Shape::Segment {
            a: mid - DVec3::Y * 50.0,
            b: mid + DVec3::Y * 50.0,
            radius_a_m: radius_m,
            radius_b_m: radius_m,
        },
        albedo: [0.05, 0.04, 0.03],
        sun_facing: 0.3,
    }]));
    s
}

fn render(renderer: &mut Renderer, scene: &FrameScene, msaa: u32) -> (Vec<u8>, u64, u64) {
    let request = RenderRequest {
        msaa,
        color: true,
        visibility: true,
    };
    let frame = renderer.render_frame(scene, &request).expect("render");
    let v = frame.visibility.expect("visibility")[0];
    (frame.rgba, v.visible_pixels, v.unoccluded_pixels)
}

#[test]
fn a_pole_hides_exactly_the_drone_pixels_it_covers() {
    let ctx = common::gpu();
    let pipeline = FramePipeline::new(one_drone()).expect("preset");
    let mut renderer = pipeline.renderer(&ctx);
    let mut checked = 0;
    for index in 0..8 {
        let scene = pipeline.scene(index).expect("scene");
        let size = scene.drones[0].size_m;
        let poled = with_pole(&scene, size * 0.06, size * 0.1);
        let (_, bare_visible, bare_unoccluded) = render(&mut renderer, &scene, 1);
        let (_, visible, unoccluded) = render(&mut renderer, &poled, 1);
        // The drone's pixels (one sample: the pixel centre) and the pole's.
        let ids = renderer.render_ids(&scene, &|_| true).expect("ids");
        let layer = scenery::rasterize(&poled, 1);
        let hidden = (0..ids.height)
            .flat_map(|y| (0..ids.width).map(move |x| (x, y)))
            .filter(|&(x, y)| ids.ids[(y * ids.width + x) as usize] == 1 && layer.mask(x, y) == 1)
            .count() as u64;
        if hidden == 0 {
            continue; // the pole passes between the drone's parts
        }
        assert!(
            visible < bare_visible,
            "frame {index}: {visible} of {bare_visible}"
        );
        assert_eq!(
            bare_visible, bare_unoccluded,
            "frame {index}: one drone, nothing in front"
        );
        assert_eq!(visible, bare_visible - hidden, "frame {index}");
        assert_eq!(
            unoccluded, bare_unoccluded,
            "frame {index}: the pole leaves the unoccluded count"
        );
        eprintln!("frame {index}: {bare_visible} visible, the pole hides {hidden}");
        checked += 1;
    }
    assert!(checked >= 3, "only {checked} frames had a visible drone");
}

#[test]
fn a_wide_pole_hides_the_whole_drone_in_the_picture_and_the_labels() {
    let ctx = common::gpu();
    let mut preset = one_drone();
    preset.render.msaa = 4;
    let pipeline = FramePipeline::new(preset).expect("preset");
    let mut renderer = pipeline.renderer(&ctx);
    let scene = pipeline.scene(0).expect("scene");
    let size = scene.drones[0].size_m;
    let poled = with_pole(&scene, size, 0.0);
    let (_, bare_visible, _) = render(&mut renderer, &scene, 4);
    assert!(bare_visible > 100, "{bare_visible}");
    let (rgba, visible, unoccluded) = render(&mut renderer, &poled, 4);
    assert_eq!(visible, 0);
    assert_eq!(unoccluded, bare_visible);
    // The picture is the pole's: the same as the frame without the drone.
    let mut empty = poled.clone();
    empty.drones.clear();
    let (without, _, _) = {
        let request = RenderRequest {
            msaa: 4,
            color: true,
            visibility: false,
        };
        let f = renderer.render_frame(&empty, &request).expect("render");
        (f.rgba, 0, 0)
    };
    let worst = rgba
        .iter()
        .zip(&without)
        .map(|(a, b)| a.abs_diff(*b))
        .max()
        .unwrap_or(0);
    assert!(
        worst <= 1,
        "a hidden drone changed a pixel by {worst} levels"
    );
    // The labels follow: the drone is not a training box.
    let labels = pipeline.labels(&mut renderer, &poled).expect("labels");
    assert!(
        labels
            .iter()
            .all(|l| l.status != swarmshot::annotate::LabelStatus::Kept),
        "{labels:?}"
    );
}

fn cluttered() -> Preset {
    let mut p = common::tiny_preset();
    let mut c = Clutter::default();
    c.trees.count = (2, 2);
    c.trees.distance_m = (8.0, 12.0);
    c.poles.count = (1, 1);
    c.buildings.count = (1, 1);
    p.clutter = Some(c);
    p
}

#[test]
fn cluttered_frames_are_deterministic_and_differ_from_bare_ones() {
    let ctx = common::gpu();
    let make = |preset: Preset, order: &[u64]| {
        let pipeline = FramePipeline::new(preset).expect("preset");
        let mut renderer = pipeline.renderer(&ctx);
        order
            .iter()
            .map(|&i| {
                let f = pipeline.make(&mut renderer, i).expect("frame");
                (i, f.rgba, format!("{:?}", f.labels))
            })
            .collect::<Vec<_>>()
    };
    let mut a = make(cluttered(), &[0, 1, 2]);
    let mut b = make(cluttered(), &[2, 1, 0]);
    b.sort_by_key(|f| f.0);
    a.sort_by_key(|f| f.0);
    assert_eq!(a, b, "a frame made alone or in another order is the same");
    let bare = make(common::tiny_preset(), &[0, 1, 2]);
    for (c, b) in a.iter().zip(&bare) {
        let changed =
            c.1.chunks(4)
                .zip(b.1.chunks(4))
                .filter(|(x, y)| x != y)
                .count();
        assert!(
            changed > 500,
            "frame {}: clutter changed {changed} pixels",
            c.0
        );
    }
    let scene = FramePipeline::new(cluttered())
        .expect("preset")
        .scene(0)
        .expect("scene");
    let drawn = scene.clutter.expect("clutter drawn");
    assert_eq!((drawn.trees, drawn.buildings), (2, 1));
    assert!(drawn.poles >= 2 && drawn.primitives.len() > 100);
}

#[test]
fn clutter_off_or_empty_leaves_the_frame_untouched() {
    let ctx = common::gpu();
    let mut empty = common::tiny_preset();
    let mut c = Clutter::default();
    c.tree_lines.count = (0, 0);
    c.trees.count = (0, 0);
    c.poles.count = (0, 0);
    c.buildings.count = (0, 0);
    empty.clutter = Some(c);
    let bare = FramePipeline::new(common::tiny_preset()).expect("preset");
    let none = FramePipeline::new(empty).expect("preset");
    let (mut r1, mut r2) = (bare.renderer(&ctx), none.renderer(&ctx));
    for i in 0..2 {
        let (a, b) = (
            bare.make(&mut r1, i).expect("frame"),
            none.make(&mut r2, i).expect("frame"),
        );
        assert_eq!(a.rgba, b.rgba);
        assert_eq!(format!("{:?}", a.labels), format!("{:?}", b.labels));
        assert!(a.scene.clutter.is_none());
    }
    // A preset without clutter writes no `clutter` key.
    let text = ron::to_string(&common::tiny_preset()).expect("ron");
    assert!(!text.contains("clutter"));
}

#[test]
fn the_gpu_draws_the_layers_samples() {
    // A thin diagonal wire across a close drone's region, MSAA 4: in the
    // region (away from the drone's own pixels) the GPU resolves the wire's
    // samples from the layer's masks; without the drone the same pixels are
    // the CPU's composite of the mask. A GPU that ignored the sample mask
    // (or wrote the wrong samples' count) moves them by tens of levels (83
    // when the shader's mask was forced to all four samples).
    let ctx = common::gpu();
    let mut preset = one_drone();
    preset.render.msaa = 4;
    let pipeline = FramePipeline::new(preset).expect("preset");
    let mut renderer = pipeline.renderer(&ctx);
    let scene = pipeline.scene(0).expect("scene");
    let mut wired = with_pole(&scene, 0.0, 0.0);
    let right = scene.camera.camera_from_world.row(0);
    let mid = (scene.camera.position + scene.drones[0].position) * 0.5;
    let radius_m = 0.15 / scene.camera.focal_px() * (mid - scene.camera.position).length();
    if let Some(c) = &mut wired.clutter {
        c.primitives = (0..5)
            .map(|k| Primitive {
                shape: Shape::Segment {
                    a: mid - (right + DVec3::Y * 0.6) * 100.0 + DVec3::Y * (f64::from(k) * 0.05),
                    b: mid + (right + DVec3::Y * 0.6) * 100.0 + DVec3::Y * (f64::from(k) * 0.05),
                    radius_a_m: radius_m,
                    radius_b_m: radius_m,
                },
                albedo: [0.9, 0.9, 0.1],
                sun_facing: 1.0,
            })
            .collect();
    }
    let request = RenderRequest {
        msaa: 4,
        color: true,
        visibility: false,
    };
    let with = renderer.render_frame(&wired, &request).expect("render");
    let rects = with.painted.rects().to_vec();
    let mut empty = wired.clone();
    empty.drones.clear();
    let without = renderer
        .render_frame(&empty, &request)
        .expect("render")
        .rgba;
    let ids = renderer.render_ids(&scene, &|_| true).expect("ids");
    let layer = scenery::rasterize(&wired, 4);
    let w = ids.width as i64;
    let near_drone = |x: i64, y: i64| {
        (-2..=2).any(|dy| {
            (-2..=2).any(|dx| {
                let (u, v) = (x + dx, y + dy);
                u >= 0
                    && v >= 0
                    && u < w
                    && v < ids.height as i64
                    && ids.ids[(v * w + u) as usize] != 0
            })
        })
    };
    let (mut checked, mut worst) = (0, 0);
    for r in &rects {
        for y in r.y0..r.y1 {
            for x in r.x0..r.x1 {
                let m = layer.mask(x, y);
                if m == 0 || m == 0b1111 || near_drone(i64::from(x), i64::from(y)) {
                    continue;
                }
                let i = ((y * ids.width + x) * 4) as usize;
                for c in 0..3 {
                    worst = worst.max(with.rgba[i + c].abs_diff(without[i + c]));
                }
                checked += 1;
            }
        }
    }
    assert!(
        checked >= 10,
        "only {checked} partly covered pixels in the region"
    );
    assert!(
        worst <= 1,
        "the GPU's wire differs from the layer by {worst} levels"
    );
}
