//! Near-field scenery (issue 22 item 2): clutter hides the drones behind it
//! in the picture and in the labels, is deterministic, and costs nothing
//! when off.

use crate::common;

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

/// Over a background made on the CPU (a procedural environment) the
/// texture takes its pixels without the scenery tile by tile, where the
/// regions read them. While the camera moves (a new background every
/// frame) no copy without the scenery is kept: each frame's regions are
/// uploaded before the scenery is drawn in. When the camera stops, the
/// next frame's regions (other drones, other places) must not be uploaded
/// from the pixels with the scenery: the background is drawn once more.
/// Every frame equals the same frame made alone, with or without the
/// frames taking their backgrounds' pixels.
#[test]
fn a_camera_that_stops_after_moving_gets_the_background_without_scenery() {
    let ctx = common::gpu();
    let mut p = cluttered();
    p.placement = Placement::Randomized {
        count: (12, 12),
        count_distribution: Default::default(),
        volume: swarmshot::preset::Volume::Box {
            size_m: (12.0, 6.0, 8.0),
        },
        min_separation_m: 0.7,
    };
    p.sky = common::procedural_sky();
    let pipeline = FramePipeline::new(p).expect("preset");
    let request = RenderRequest {
        msaa: 4,
        color: true,
        visibility: false,
    };
    // Frames 0..3 widen the view (a new background each), frames 3..7 keep
    // it with other drones in other places (each frame's drones under the
    // camera, sky and scenery of frame 0).
    let first = pipeline.scene(0).expect("scene");
    let scene = |index: u64| {
        let mut scene = pipeline.scene(index).expect("scene");
        (scene.camera, scene.sky, scene.clutter) = (first.camera, first.sky, first.clutter.clone());
        scene.camera.fov_y_deg += index.min(3) as f64;
        scene
    };
    for lend in [false, true] {
        let mut renderer = pipeline.renderer(&ctx);
        renderer.set_lend_backgrounds(lend);
        for index in 0..7 {
            let got = renderer
                .render_frame(&scene(index), &request)
                .expect("render");
            let alone = (pipeline.renderer(&ctx))
                .render_frame(&scene(index), &request)
                .expect("render");
            assert!(got.rgba == alone.rgba, "frame {index}, lending {lend}");
            renderer.recycle(got.rgba, got.painted);
        }
        // One background a pose, and the stopped camera's once more.
        assert_eq!(renderer.background_draws(), 5, "lending {lend}");
    }
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

/// A pole beside drone 0 and a wire (far thinner than a pixel) across it,
/// both halfway between the camera and the drone.
fn with_pole_and_wire(scene: &FrameScene, pole_offset_m: f64, wire_drop_m: f64) -> FrameScene {
    let mut s = scene.clone();
    let right = s.camera.camera_from_world.row(0);
    let up = -s.camera.camera_from_world.row(1);
    let mid = (s.camera.position + s.drones[0].position) * 0.5;
    let size = s.drones[0].size_m;
    let pole = mid + right * pole_offset_m;
    let wire = mid + up * wire_drop_m;
    let dark = |shape| Primitive {
        shape,
        albedo: [0.05, 0.04, 0.03],
        sun_facing: 0.3,
    };
    s.clutter = Some(FrameClutter::from_primitives(vec![
        dark(Shape::Segment {
            a: pole - DVec3::Y * 50.0,
            b: pole + DVec3::Y * 50.0,
            radius_a_m: size * 0.05,
            radius_b_m: size * 0.05,
        }),
        dark(Shape::Segment {
            a: wire - right * 50.0,
            b: wire + right * 50.0,
            radius_a_m: size * 0.004,
            radius_b_m: size * 0.004,
        }),
    ]));
    s
}

/// Next to thin scenery (a drone on a wire beside a pole), the visible box
/// and pixel count under the camera model are exactly the pixels the drone
/// changes: the frame against the same frame without the drone, same draws.
#[test]
fn visible_boxes_next_to_a_wire_and_a_pole_are_the_pixels_the_drone_changes() {
    use swarmshot::preset::camera_model::{CameraModel, Psf};
    let ctx = common::gpu();
    let mut p = common::single_drone_preset(1.5);
    p.camera_model = Some(CameraModel {
        psf: Psf::Gaussian {
            sigma_px: (0.7, 0.7),
        },
        ..CameraModel::default()
    });
    let pipeline = FramePipeline::new(p.clone()).expect("pipeline");
    let mut renderer = pipeline.renderer(&ctx);
    let mut checked = 0;
    for index in 0..p.frame_count() {
        let bare = pipeline.scene(index).expect("scene");
        let size = bare.drones[0].size_m;
        for (pole, wire) in [(0.2, 0.0), (0.3, 0.05), (-0.25, -0.08), (0.1, 0.12)] {
            let scene = with_pole_and_wire(&bare, size * pole, size * wire);
            let frame = pipeline.make_scene(&mut renderer, scene).expect("frame");
            let draw = frame.scene.camera_model.expect("drawn");
            let msaa = p.render.msaa;
            let a = common::camera_image(&mut renderer, &frame.scene, msaa, &draw);
            let mut empty = frame.scene.clone();
            empty.drones.clear();
            let b = common::camera_image(&mut renderer, &empty, msaa, &draw);
            let truth = common::changed_box(&a, &b, frame.scene.camera.width);
            let vis = frame.labels[0].visibility.expect("measured");
            let case = format!("frame {index}, pole {pole}, wire {wire}");
            match truth {
                Some((r, n)) => {
                    let got = vis.visible_box.expect(&case);
                    assert_eq!(
                        [got.x0, got.y0, got.x1, got.y1],
                        [r.x0, r.y0, r.x1, r.y1].map(f64::from),
                        "{case}"
                    );
                    assert_eq!(vis.visible_pixels, n, "{case}");
                }
                None => assert_eq!(vis.visible_pixels, 0, "{case}"),
            }
            checked += 1;
        }
    }
    assert!(checked >= 4, "{checked}");
}

/// The same in the shipped cluttered scene (tree lines, trees, poles with
/// wires, buildings; the preset's camera model, noise off): each drone
/// apart from the others has the visible box and pixel count of the pixels
/// that change when it alone is taken out of the frame (moved behind the
/// camera, so nothing else of the scene moves), and some of them are partly
/// hidden by the scenery.
#[test]
fn visible_boxes_in_the_cluttered_scene_are_the_pixels_each_drone_changes() {
    use swarmshot::scene::projection::PixelBox;
    let ctx = common::gpu();
    let path = std::path::Path::new("presets/bench/realistic_cluttered.ron");
    let mut p = Preset::load(path).expect("preset");
    if let Some(c) = &mut p.camera_model {
        c.shot_noise_gain = (0.0, 0.0);
        c.read_noise_levels = (0.0, 0.0);
    }
    let pipeline = FramePipeline::new(p.clone()).expect("pipeline");
    let mut renderer = pipeline.renderer(&ctx);
    let (mut checked, mut hidden_in_part) = (0, 0);
    for index in 0..10 {
        let frame = pipeline.make(&mut renderer, index).expect("frame");
        let draw = frame.scene.camera_model.expect("drawn");
        let w = frame.scene.camera.width;
        let msaa = p.render.msaa;
        let a = common::camera_image(&mut renderer, &frame.scene, msaa, &draw);
        let boxes: Vec<Option<PixelBox>> = (frame.labels.iter())
            .map(|l| l.visibility.and_then(|v| v.visible_box))
            .collect();
        let apart = |b: PixelBox, o: PixelBox| {
            let m = 4.0;
            o.x1 + m < b.x0 || b.x1 + m < o.x0 || o.y1 + m < b.y0 || b.y1 + m < o.y0
        };
        for (k, label) in frame.labels.iter().enumerate() {
            let Some(b) = boxes[k] else { continue };
            let alone =
                (boxes.iter().enumerate()).all(|(j, o)| j == k || o.is_none_or(|o| apart(b, o)));
            if !alone || label.class_id != 0 {
                continue; // drones only (birds and aircraft are larger than the camera's reach)
            }
            let mut without = frame.scene.clone();
            let drone = &mut without.drones[label.drone];
            let forward = without.camera.camera_from_world.row(2);
            drone.position = without.camera.position - forward * (10.0 * drone.size_m + 1.0);
            let truth = common::changed_box(
                &a,
                &common::camera_image(&mut renderer, &without, msaa, &draw),
                w,
            );
            let vis = label.visibility.expect("measured");
            let case = format!("frame {index}, drone {}", label.drone);
            let (r, n) = truth.expect(&case);
            assert_eq!(
                [b.x0, b.y0, b.x1, b.y1],
                [r.x0, r.y0, r.x1, r.y1].map(f64::from),
                "{case}"
            );
            assert_eq!(vis.visible_pixels, n, "{case}");
            hidden_in_part += usize::from(vis.visible_pixels < vis.unoccluded_pixels);
            checked += 1;
        }
    }
    assert!(checked >= 20, "{checked} drones apart from the others");
    assert!(
        hidden_in_part >= 2,
        "{hidden_in_part} of {checked} drones partly behind scenery"
    );
}

/// A tree line's points along an arc 300 m ahead, 40° wide: a foot 1 m
/// under the ground and a rough top 12–20 m over it every 1.5 pixels, seen
/// by a 640×360 camera 1.7 m over the ground.
fn tree_line_points(camera: &swarmshot::scene::camera::Camera) -> Vec<(DVec3, DVec3)> {
    let (distance, width) = (300.0, 40f64.to_radians());
    let step = 1.5 / camera.focal_px() * distance;
    let points = (distance * width / step) as usize;
    (0..=points)
        .map(|i| {
            let angle = -width / 2.0 + width * i as f64 / points as f64;
            let ground =
                DVec3::new(angle.sin(), -1.7, angle.cos()) * DVec3::new(distance, 1.0, distance);
            // Crowns every 8 points and leaves at each: a fixed rough top.
            let top =
                16.0 + 4.0 * (i as f64 * 0.4).sin() + 0.6 * ((i * 7919 % 13) as f64 / 13.0 - 0.5);
            (ground - DVec3::Y, ground + DVec3::Y * top)
        })
        .collect()
}

/// A tree line's bodies and caps (`band_shapes` taking 8 strips at a time)
/// cover the samples its strips cover, with their colour and depth: the
/// strips under a body take the nearest of theirs, which differs from each
/// strip's own by the few metres of distance across the body. Seen level
/// and rolled by 10°.
#[test]
fn a_tree_lines_bodies_and_caps_cover_what_its_strips_cover() {
    use swarmshot::scene::clutter::band_shapes;
    for roll_deg in [0.0f64, 10.0] {
        let mut scene = swarmshot::scene::build_frame(&common::tiny_preset(), 0).expect("frame");
        let eye = DVec3::ZERO;
        let look_at = swarmshot::scene::math::look_at_cv(eye, DVec3::new(0.0, 5.0, 300.0));
        scene.camera = swarmshot::scene::camera::Camera {
            width: 640,
            height: 360,
            fov_y_deg: 40.0,
            position: eye,
            camera_from_world: glam::DMat3::from_rotation_z(roll_deg.to_radians())
                * look_at.expect("look-at"),
            near_m: 0.1,
        };
        let tops = tree_line_points(&scene.camera);
        let look = ([0.03, 0.05, 0.02], 0.5);
        let light = scenery::SceneryLight {
            sun: [1.0; 3],
            ambient: [0.3; 3],
            horizon: [0.7, 0.75, 0.8],
            extinction_per_m: 3.912 / 2000.0,
            exposure: 4.0,
        };
        let layer = |strips: usize| {
            let mut shapes = Vec::new();
            band_shapes(&tops, strips, look, &mut shapes);
            let mut s = scene.clone();
            s.clutter = Some(FrameClutter::from_primitives(shapes));
            scenery::rasterize_with(&s, 4, &light)
        };
        let (strips, bodies) = (layer(1), layer(8));
        let covered = strips.covered_pixels();
        assert!(covered > 5_000, "{covered}");
        let (mut masks_differ, mut worst_colour, mut worst_depth) = (0, 0u8, 0f32);
        for (i, (a, b)) in strips.color.iter().zip(&bodies.color).enumerate() {
            if a[3] != b[3] {
                masks_differ += 1;
            }
            if a[3] != 0 && b[3] != 0 {
                worst_colour = (0..3)
                    .map(|c| a[c].abs_diff(b[c]))
                    .fold(worst_colour, u8::max);
                let (da, db) = (strips.depth[i], bodies.depth[i]);
                worst_depth = worst_depth.max((db - da) / da);
            }
        }
        let case = format!("roll {roll_deg}°, {covered} pixels covered");
        assert!(
            masks_differ * 1000 <= covered,
            "{case}: {masks_differ} masks differ"
        );
        assert!(worst_colour <= 1, "{case}: colours {worst_colour} apart");
        // Reversed-Z depth: a body is at most 1 % nearer than a strip under it, never farther.
        assert!(
            (0.0..0.01).contains(&worst_depth),
            "{case}: depth {worst_depth}"
        );
    }
}
