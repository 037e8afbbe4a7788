//! The rolling shutter (`camera_model.rolling_shutter`, issue 41) end to end
//! (renders on lavapipe): a drone crossing the view skews by its image speed
//! times the readout per image height; a readout of 0 is byte-identical to
//! no shutter; the labels are the pixels changed against the drone-free
//! frame under the same draws and the same shutter; frames are deterministic
//! and made alone; and the fast design (each drone moved row by row over the
//! background turned row by row) stays within a bound of a reference
//! rendered in two-row bands, each band at its own time.

use crate::common;

use swarmshot::annotate::masks::FrameMasks;
use swarmshot::pipeline::{Frame, FramePipeline};
use swarmshot::preset::camera_model::CameraModel;
use swarmshot::preset::rolling_shutter::RollingShutter;
use swarmshot::preset::sweep::SweepRange;
use swarmshot::preset::{BoxMethod, Motion, Placement, Preset, SequenceSpec};
use swarmshot::render::Renderer;
use swarmshot::scene::{FrameScene, build_frame, build_frame_at};
use swarmshot::sensor::PixelRect;

/// The MOT tests' wedge crossing a fixed camera sideways (`count` drones,
/// 320×180), a neutral camera model with a rolling shutter of `readout_s`
/// turning at `yaw_deg_s` (`None`: no shutter).
fn preset(count: u32, shutter: Option<(f64, f64)>) -> Preset {
    let mut p = common::sequence_preset();
    p.name = "rolling".into();
    if let Placement::Formation(f) = &mut p.placement {
        f.count = count;
    }
    // From 40° above: the flat quad spans tens of rows.
    p.camera.y = SweepRange::fixed(1.0);
    p.camera.z = SweepRange::fixed(0.7);
    p.repeats = 1;
    p.models[0].size_m = 1.5;
    p.render.msaa = 4;
    p.labels.box_method = BoxMethod::Visible;
    if let Some(seq) = p.sequence.as_mut() {
        seq.motion = Motion {
            translate_m: (3.0, 0.0, 0.0),
            ..Motion::default()
        };
    }
    p.camera_model = Some(CameraModel {
        rolling_shutter: shutter.map(|(r, w)| RollingShutter {
            readout_s: (r, r),
            yaw_rate_deg_s: (w, w),
        }),
        ..CameraModel::default()
    });
    p
}

fn make(pipeline: &FramePipeline, renderer: &mut Renderer, index: u64) -> Frame {
    pipeline.make(renderer, index).expect("frame")
}

/// `scene` without its drones: the drone-free frame under the same draws.
fn drone_free(scene: &FrameScene) -> FrameScene {
    let mut s = scene.clone();
    s.drones.clear();
    s
}

/// Per row: the x centroid of the colour change between `a` and `b`
/// (weighted by its size), `None` where less than 2 levels change in all.
fn row_centroids(a: &[u8], b: &[u8], (w, h): (u32, u32)) -> Vec<Option<f64>> {
    (0..h)
        .map(|y| {
            let (mut sum, mut mass) = (0.0, 0.0);
            for x in 0..w {
                let i = ((y * w + x) * 4) as usize;
                let d: f64 = (0..3)
                    .map(|c| (f64::from(a[i + c]) - f64::from(b[i + c])).abs())
                    .sum();
                sum += d * (f64::from(x) + 0.5);
                mass += d;
            }
            (mass >= 2.0).then(|| sum / mass)
        })
        .collect()
}

#[test]
fn a_readout_of_zero_is_byte_identical_to_no_shutter() {
    let ctx = common::gpu();
    let none = FramePipeline::new(preset(3, None)).expect("pipeline");
    let zero = FramePipeline::new(preset(3, Some((0.0, 25.0)))).expect("pipeline");
    let (mut ra, mut rb) = (none.renderer(&ctx), zero.renderer(&ctx));
    for index in 0..3 {
        let (a, b) = (make(&none, &mut ra, index), make(&zero, &mut rb, index));
        assert_eq!(a.rgba, b.rgba, "frame {index}");
        assert_eq!(a.labels, b.labels, "frame {index}");
    }
}

#[test]
fn a_drone_crossing_the_view_skews_by_its_speed_times_the_readout() {
    let ctx = common::gpu();
    let readout = 0.05;
    let p = preset(1, Some((readout, 0.0)));
    let rate = f64::from(p.sequence.as_ref().expect("sequence").frame_rate);
    let pipeline = FramePipeline::new(p.clone()).expect("pipeline");
    let mut renderer = pipeline.renderer(&ctx);
    let index = 1;
    let frame = make(&pipeline, &mut renderer, index);
    let scene = &frame.scene;
    let (w, h) = (scene.camera.width, scene.camera.height);
    // The image speed from the sequence's own steps (eq. 4), pixels per second.
    let image = |s: &FrameScene| {
        let c = s.camera.camera_from_world_point(s.drones[0].position);
        s.camera.project_camera_point(c).expect("in front")
    };
    let next = build_frame(&p, index + 1).expect("next");
    let speed = (image(&next) - image(scene)) * rate;
    assert!(speed.x.abs() > 100.0, "the drone crosses the view: {speed}");
    let background = common::rendered_at_exposure(&mut renderer, &drone_free(scene), 4);
    let still = common::rendered_at_exposure(&mut renderer, scene, 4);
    let shuttered = row_centroids(&frame.rgba, &background, (w, h));
    let global = row_centroids(&still, &background, (w, h));
    // Row y is exposed readout·y/H late: the drone has moved speed·that.
    let want = |y: usize| speed.x * readout * y as f64 / f64::from(h);
    let pairs: Vec<(f64, f64)> = (shuttered.iter().zip(&global).enumerate())
        .filter_map(|(y, (s, g))| Some((y as f64, (*s)? - (*g)?)))
        .collect();
    assert!(pairs.len() >= 10, "the drone spans {} rows", pairs.len());
    for &(y, d) in &pairs {
        // Each row within a pixel (the rows also move a little vertically).
        assert!(
            (d - want(y as usize)).abs() < 1.0,
            "row {y}: {d} px, want {}",
            want(y as usize)
        );
    }
    // The skew: the least-squares slope of the shift over the rows.
    let n = pairs.len() as f64;
    let (my, md) = (
        pairs.iter().map(|p| p.0).sum::<f64>() / n,
        pairs.iter().map(|p| p.1).sum::<f64>() / n,
    );
    let cov: f64 = pairs.iter().map(|&(y, d)| (y - my) * (d - md)).sum();
    let var: f64 = pairs.iter().map(|&(y, _)| (y - my) * (y - my)).sum();
    let (slope, wanted) = (cov / var, speed.x * readout / f64::from(h));
    println!("skew {slope:.5} px/row, speed × readout / H = {wanted:.5}");
    assert!(
        (slope - wanted).abs() < 0.15 * wanted.abs(),
        "skew {slope} px/row, want {wanted}"
    );
    let mean = pairs
        .iter()
        .map(|&(y, d)| d - want(y as usize))
        .sum::<f64>()
        / n;
    assert!(mean.abs() < 0.3, "mean offset {mean} px");
}

#[test]
fn labels_are_the_pixels_changed_against_the_drone_free_frame_under_the_shutter() {
    let ctx = common::gpu();
    let mut p = preset(4, Some((0.04, 40.0)));
    p.output.masks.instance_png = true;
    let pipeline = FramePipeline::new(p).expect("pipeline");
    let mut renderer = pipeline.renderer(&ctx);
    let frame = make(&pipeline, &mut renderer, 2);
    let empty = pipeline
        .make_scene(&mut renderer, drone_free(&frame.scene))
        .expect("drone-free frame");
    let w = frame.scene.camera.width;
    let masks = frame.masks.as_ref().expect("masks");
    let changed = |i: u32| {
        let (a, b) = (
            &frame.rgba[i as usize * 4..][..3],
            &empty.rgba[i as usize * 4..][..3],
        );
        a != b
    };
    let all: Vec<u32> = (0..frame.rgba.len() as u32 / 4)
        .filter(|&i| changed(i))
        .collect();
    let masked: Vec<u32> = masks.instance.iter().map(|&(i, _)| i).collect();
    assert!(!all.is_empty());
    assert_eq!(all, masked, "the masks are the changed pixels");
    let mut kept = 0;
    for label in &frame.labels {
        let mine: Vec<u32> = (masks.instance.iter())
            .filter(|&&(_, d)| d as usize == label.drone)
            .map(|&(i, _)| i)
            .collect();
        let vis = label.visibility.expect("measured");
        assert_eq!(
            vis.visible_pixels,
            mine.len() as u64,
            "drone {}",
            label.drone
        );
        let Some(b) = vis.visible_box else {
            continue;
        };
        let (x0, x1) = (
            mine.iter().map(|i| i % w).min(),
            mine.iter().map(|i| i % w).max(),
        );
        let (y0, y1) = (
            mine.iter().map(|i| i / w).min(),
            mine.iter().map(|i| i / w).max(),
        );
        assert_eq!(
            (b.x0, b.y0),
            (f64::from(x0.expect("x")), f64::from(y0.expect("y")))
        );
        assert_eq!(
            (b.x1, b.y1),
            (f64::from(x1.expect("x") + 1), f64::from(y1.expect("y") + 1))
        );
        // The amodal box (each hull point at its own row's time) holds the visible one.
        let a = label.amodal;
        // The anti-aliased edge and the bilinear tap of the row shift.
        let slack = 2.0;
        assert!(
            a.x0 - slack <= b.x0
                && a.y0 - slack <= b.y0
                && b.x1 <= a.x1 + slack
                && b.y1 <= a.y1 + slack,
            "drone {}: visible {b:?} outside amodal {a:?}",
            label.drone
        );
        kept += 1;
    }
    assert!(kept >= 2, "{kept} drones seen");
}

/// `scene` with every drone but `keep` shrunk to nothing: the same
/// indices, motion and shutter, only drone `keep` drawn.
fn alone(scene: &FrameScene, keep: usize) -> FrameScene {
    let mut s = scene.clone();
    for (i, d) in s.drones.iter_mut().enumerate() {
        if i != keep {
            d.size_m = 1e-30;
        }
    }
    s
}

/// Whether `a` grown by a pixel meets `b`.
fn touch(a: PixelRect, b: PixelRect) -> bool {
    a.x0 <= b.x1 && b.x0 <= a.x1 && a.y0 <= b.y1 && b.y0 <= a.y1
}

#[test]
fn under_a_fast_pan_each_drone_is_drawn_and_labelled_with_its_own_pixels() {
    let ctx = common::gpu();
    // The fastest pan and readout validation accepts: a drone's rows move
    // tens of pixels from where it was rendered.
    let mut p = preset(4, Some((0.1, 360.0)));
    p.models[0].size_m = 0.8;
    let pipeline = FramePipeline::new(p).expect("pipeline");
    let mut renderer = pipeline.renderer(&ctx);
    let mut checked = 0;
    for index in 0..5 {
        let frame = make(&pipeline, &mut renderer, index);
        let scene = &frame.scene;
        let w = scene.camera.width;
        let empty = (pipeline.make_scene(&mut renderer, drone_free(scene))).expect("drone-free");
        // Each drone's own pixels: the frame with it alone against the drone-free one.
        let alone: Vec<Vec<u8>> = (0..scene.drones.len())
            .map(|i| alone_rgba(&pipeline, &mut renderer, scene, i))
            .collect();
        let own: Vec<Option<(PixelRect, u64)>> = (alone.iter())
            .map(|a| common::changed_box(a, &empty.rgba, w))
            .collect();
        for label in &frame.labels {
            let Some((mine, n)) = own[label.drone] else {
                continue;
            };
            let apart = (own.iter().enumerate())
                .filter(|&(j, _)| j != label.drone)
                .all(|(_, o)| o.is_none_or(|(r, _)| !touch(mine, r)));
            if !apart {
                continue;
            }
            let case = format!("frame {index}, drone {}", label.drone);
            // Drawn: the full frame shows the same pixels there.
            let crop = |rgba: &[u8]| -> Vec<u8> {
                (mine.y0..mine.y1)
                    .flat_map(|y| (mine.x0..mine.x1).map(move |x| ((y * w + x) * 4) as usize))
                    .flat_map(|i| rgba[i..i + 3].to_vec())
                    .collect()
            };
            let drawn = crop(&frame.rgba) == crop(&alone[label.drone]);
            assert!(drawn, "{case}: not drawn as alone");
            // Labelled with its own pixels, no neighbour's.
            let vis = label.visibility.expect("measured");
            let vb = vis.visible_box.expect(&case);
            assert_eq!(
                [vb.x0, vb.y0, vb.x1, vb.y1],
                [mine.x0, mine.y0, mine.x1, mine.y1].map(f64::from),
                "{case}"
            );
            assert_eq!(vis.visible_pixels, n, "{case}");
            checked += 1;
        }
    }
    assert!(checked >= 6, "{checked} drones checked");
}

/// 60 drones around a camera in their midst, looking down −Z with a 100°
/// field (drones at the near plane, behind the camera, hiding each other),
/// under a 0.1 s readout panning at −360 °/s, with masks.
fn among_the_drones() -> Preset {
    let mut p = common::tiny_preset();
    p.placement = Placement::Randomized {
        count: (60, 60),
        count_distribution: Default::default(),
        volume: swarmshot::preset::Volume::Box {
            size_m: (6.0, 3.0, 6.0),
        },
        min_separation_m: 0.36,
    };
    p.camera.absolute = Some(swarmshot::preset::formation::AbsoluteCamera {
        position_m: (0.0, 0.0, 0.0),
        look_at_m: (0.0, 0.0, -1.0),
    });
    p.camera.fov_y_deg = 100.0;
    p.render.msaa = 4;
    p.labels.min_box_px = 0.0;
    p.output.masks.instance_png = true;
    p.camera_model = Some(CameraModel {
        rolling_shutter: Some(RollingShutter {
            readout_s: (0.1, 0.1),
            yaw_rate_deg_s: (-360.0, -360.0),
        }),
        ..CameraModel::default()
    });
    p
}

#[test]
fn among_the_drones_under_a_fast_pan_every_changed_pixel_is_a_labelled_drones() {
    let ctx = common::gpu();
    let pipeline = FramePipeline::new(among_the_drones()).expect("pipeline");
    let mut renderer = pipeline.renderer(&ctx);
    for index in 0..3 {
        let frame = make(&pipeline, &mut renderer, index);
        let empty = (pipeline.make_scene(&mut renderer, drone_free(&frame.scene)))
            .expect("drone-free frame");
        let masks = frame.masks.as_ref().expect("masks");
        let changed: Vec<u32> = (0..frame.rgba.len() as u32 / 4)
            .filter(|&i| frame.rgba[i as usize * 4..][..3] != empty.rgba[i as usize * 4..][..3])
            .collect();
        let masked: Vec<u32> = masks.instance.iter().map(|&(i, _)| i).collect();
        assert_eq!(
            changed, masked,
            "frame {index}: the masks are the changed pixels"
        );
        // Each label's count is its mask's: none is kept from the render.
        for label in &frame.labels {
            let vis = label.visibility.expect("measured");
            let case = format!("frame {index}, drone {}", label.drone);
            assert_eq!(vis.visible_pixels, masks.count(label.drone), "{case}");
        }
    }
}

/// The shuttered picture of `scene` with drone `keep` alone.
fn alone_rgba(
    pipeline: &FramePipeline,
    renderer: &mut Renderer,
    scene: &FrameScene,
    keep: usize,
) -> Vec<u8> {
    let f = pipeline.make_scene(renderer, alone(scene, keep));
    f.expect("alone").rgba
}

#[test]
fn frames_are_deterministic_and_made_alone() {
    let ctx = common::gpu();
    let p = preset(3, Some((0.03, -30.0)));
    let a = FramePipeline::new(p.clone()).expect("pipeline");
    let mut ra = a.renderer(&ctx);
    let in_order: Vec<Frame> = (0..3).map(|i| make(&a, &mut ra, i)).collect();
    let b = FramePipeline::new(p).expect("pipeline");
    let mut rb = b.renderer(&ctx);
    let alone = make(&b, &mut rb, 2);
    assert_eq!(alone.rgba, in_order[2].rgba);
    assert_eq!(alone.labels, in_order[2].labels);
    let again = make(&b, &mut rb, 2);
    assert_eq!(again.rgba, alone.rgba);
    let global = FramePipeline::new(preset(3, None)).expect("pipeline");
    let mut rg = global.renderer(&ctx);
    assert_ne!(
        make(&global, &mut rg, 2).rgba,
        alone.rgba,
        "the shutter changes the picture"
    );
}

/// The reference: the frame rendered in bands of `band` rows, each band's
/// scene at its middle row's time (drones and camera), the camera turned
/// by the yaw rate; and the drone-free frame made the same way.
fn banded_reference(
    p: &Preset,
    renderer: &mut Renderer,
    index: u64,
    (readout, yaw_deg_s): (f64, f64),
    band: u32,
) -> (Vec<u8>, Vec<u8>) {
    let first = build_frame(p, index).expect("scene");
    let (w, h) = (first.camera.width, first.camera.height);
    let (mut with, mut without) = (
        vec![0u8; (w * h * 4) as usize],
        vec![0u8; (w * h * 4) as usize],
    );
    for y0 in (0..h).step_by(band as usize) {
        let y1 = (y0 + band).min(h);
        // Row y is exposed at readout·y/H: the band at its rows' mean.
        let tau = readout * f64::from(y0 + y1 - 1) / 2.0 / f64::from(h);
        let mut scene = build_frame_at(p, index, 0, tau).expect("scene at tau");
        scene.camera_model = first.camera_model;
        let turn = glam::DMat3::from_rotation_y((yaw_deg_s * tau).to_radians()).transpose();
        scene.camera.camera_from_world = turn * first.camera.camera_from_world;
        let rows = (y0 * w * 4) as usize..(y1 * w * 4) as usize;
        let a = common::rendered_at_exposure(renderer, &scene, 4);
        let b = common::rendered_at_exposure(renderer, &drone_free(&scene), 4);
        with[rows.clone()].copy_from_slice(&a[rows.clone()]);
        without[rows.clone()].copy_from_slice(&b[rows]);
    }
    (with, without)
}

#[test]
fn the_fast_design_stays_within_its_bound_of_a_banded_reference() {
    let ctx = common::gpu();
    // Measured: a still camera 0.98 px worst row, 0.03 px mean; panning at
    // 60°/s, 2.69 px worst row, 0.29 px mean (docs/realism.md, "Rolling shutter").
    for (readout, yaw, worst_px, mean_px) in [(0.05, 0.0, 1.25, 0.15), (0.04, 60.0, 3.0, 0.4)] {
        let p = preset(1, Some((readout, yaw)));
        let pipeline = FramePipeline::new(p.clone()).expect("pipeline");
        let mut renderer = pipeline.renderer(&ctx);
        let frame = make(&pipeline, &mut renderer, 1);
        let empty = pipeline
            .make_scene(&mut renderer, drone_free(&frame.scene))
            .expect("drone-free");
        let size = (frame.scene.camera.width, frame.scene.camera.height);
        let (reference, reference_free) = banded_reference(&p, &mut renderer, 1, (readout, yaw), 2);
        let fast = row_centroids(&frame.rgba, &empty.rgba, size);
        let slow = row_centroids(&reference, &reference_free, size);
        let errors: Vec<f64> = (fast.iter().zip(&slow))
            .filter_map(|(f, s)| Some((*f)? - (*s)?))
            .collect();
        let worst = errors.iter().fold(0.0f64, |m, e| m.max(e.abs()));
        let mean = errors.iter().sum::<f64>() / errors.len().max(1) as f64;
        println!(
            "readout {readout} s, yaw {yaw}°/s: row centroids {} rows, worst {worst:.3} px, mean {mean:.3} px",
            errors.len()
        );
        assert!(errors.len() >= 10, "{} rows", errors.len());
        // A row's centroid moves with how the band's render samples the drone's
        // edge; the drone as a whole must sit where the reference has it.
        assert!(
            worst < worst_px,
            "readout {readout}, yaw {yaw}: worst row {worst} px"
        );
        assert!(
            mean.abs() < mean_px,
            "readout {readout}, yaw {yaw}: mean {mean} px"
        );
        // The sky turned row by row matches the sky rendered band by band.
        // Away from the left and right edges, which repeat the last rendered
        // pixel over the f·tan(ω·readout) the pan reveals (7 px here).
        let w = size.0 as usize;
        let sky: f64 = (empty.rgba.iter().zip(&reference_free).enumerate())
            .filter(|(i, _)| (8..w - 8).contains(&(i / 4 % w)))
            .map(|(_, (a, b))| (f64::from(*a) - f64::from(*b)).abs())
            .fold(0.0, f64::max);
        println!("  sky: worst {sky} levels");
        assert!(sky <= 3.0, "the turned sky is {sky} levels off");
    }
}

#[test]
fn a_rolling_shutter_is_refused_through_a_lens_but_not_with_depth_and_flow() {
    let mut p = preset(2, Some((0.03, 0.0)));
    p.output.masks.depth = true;
    p.output.masks.flow = true;
    assert_eq!(p.validate(), Ok(()));
    if let Some(c) = p.camera_model.as_mut() {
        c.lens = Some(swarmshot::preset::lens::Lens::BrownConrady {
            k1: (-0.2, -0.2),
            k2: (0.0, 0.0),
            k3: (0.0, 0.0),
            p1: (0.0, 0.0),
            p2: (0.0, 0.0),
        });
    }
    let errors = p.validate().expect_err("refused");
    // The shutter's field, its reason naming the lens it meets.
    let refused = errors.iter().any(|e| {
        e.field == "camera_model.rolling_shutter" && e.message.contains("camera_model.lens")
    });
    assert!(refused, "{errors:?}");
}

/// Three drones of the wedge crossing and receding under a rolling shutter
/// whose readout is drawn per frame from `readouts` (no pan), with depth
/// maps and optical flow on.
fn receding(readouts: (f64, f64)) -> Preset {
    let mut p = preset(3, Some((0.0, 0.0)));
    p.output.masks.depth = true;
    p.output.masks.flow = true;
    if let Some(seq) = p.sequence.as_mut() {
        seq.motion.translate_m = (3.0, 0.0, 4.0);
    }
    if let Some(r) = p
        .camera_model
        .as_mut()
        .and_then(|c| c.rolling_shutter.as_mut())
    {
        r.readout_s = readouts;
        r.yaw_rate_deg_s = (0.0, 0.0);
    }
    p
}

/// The readout drawn for `scene`.
fn readout_of(scene: &FrameScene) -> f64 {
    let draw = scene.camera_model.and_then(|c| c.rolling_shutter);
    draw.expect("a rolling shutter").readout_s
}

#[test]
fn under_a_rolling_shutter_each_rows_depth_is_that_of_the_scene_at_its_time() {
    let ctx = common::gpu();
    let p = receding((0.05, 0.05));
    assert_eq!(p.validate(), Ok(()));
    let pipeline = FramePipeline::new(p.clone()).expect("pipeline");
    let mut renderer = pipeline.renderer(&ctx);
    let frame = make(&pipeline, &mut renderer, 1);
    let masks = frame.masks.as_ref().expect("masks");
    let (w, h) = (frame.scene.camera.width, frame.scene.camera.height);
    let readout = readout_of(&frame.scene);
    let meshes = pipeline.assets().depth_meshes();
    // The frame's drone pixels rasterised with the whole scene at one time.
    let at = |tau: f64| {
        let scene = build_frame_at(&p, 1, frame.scene.redraw, tau).expect("scene at tau");
        swarmshot::annotate::depth::depth_m_of_meshes(&scene, meshes, masks)
    };
    let frame_time = at(0.0);
    let rows: std::collections::BTreeSet<u32> =
        masks.instance.iter().map(|&(i, _)| i / w).collect();
    let (mut same, mut moved, mut pixels) = (0, 0, 0);
    for &y in rows.iter().step_by(4) {
        // Row y is exposed readout·y/H after the frame's time.
        let row_time = at(readout * f64::from(y) / f64::from(h));
        for (k, &(i, _)) in masks.instance.iter().enumerate() {
            if i / w != y {
                continue;
            }
            let z = masks.depth_m[k];
            pixels += 1;
            same += usize::from((z - row_time[k]).abs() < 1e-6);
            moved += usize::from((row_time[k] - frame_time[k]).abs() > 1e-3);
        }
    }
    println!(
        "{pixels} pixels: {same} at their row's depth, {moved} whose row's depth is not the frame time's"
    );
    assert!(pixels >= 50, "{pixels} pixels checked");
    // A pixel the drone shows off its centre at its row's time takes a
    // neighbour's depth (a neighbouring row's time): a few.
    assert!(
        same * 10 >= pixels * 9,
        "{same} of {pixels} at their row's depth"
    );
    // The check sees the shutter: most rows' depths are not the frame time's.
    assert!(
        moved * 2 >= pixels,
        "only {moved} of {pixels} pixels' rows moved off the frame time's depth"
    );
}

#[test]
fn under_a_still_rolling_shutter_depth_is_the_global_shutters() {
    let ctx = common::gpu();
    let still = |shutter: bool| {
        let mut p = receding((0.05, 0.05));
        // Nothing moves (the default motion carries the formation 10 m).
        p.sequence = p.sequence.map(|s| SequenceSpec {
            motion: Motion {
                translate_m: (0.0, 0.0, 0.0),
                ..Motion::default()
            },
            ..s
        });
        if !shutter {
            p.camera_model = Some(CameraModel::default());
        }
        let pipeline = FramePipeline::new(p).expect("pipeline");
        let mut renderer = pipeline.renderer(&ctx);
        make(&pipeline, &mut renderer, 1).masks.expect("masks")
    };
    let (rolling, global) = (still(true), still(false));
    assert!(!global.instance.is_empty());
    assert_eq!(rolling.instance, global.instance);
    let worst = rolling
        .depth_m
        .iter()
        .zip(&global.depth_m)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0f64, f64::max);
    let differ = rolling
        .depth_m
        .iter()
        .zip(&global.depth_m)
        .filter(|(a, b)| a != b)
        .count();
    // The same depths, but for the rounding of each row's own camera.
    assert!(worst < 1e-9, "{differ} depths differ, by up to {worst} m");
    let zero = |f: &Option<swarmshot::annotate::flow::FrameFlow>| {
        let f = f.as_ref().expect("flow");
        f.drones
            .iter()
            .all(|v| v.expect("in front").length() < 1e-9)
    };
    assert!(zero(&rolling.flow) && zero(&global.flow));
}

/// Each drone's centroid in `masks` carried by `flows` (one per instance
/// pixel), and its centroid in `next`, for drones of 20 pixels or more.
fn carried(
    (masks, flows): (&FrameMasks, &[Option<glam::DVec2>]),
    next: &FrameMasks,
    w: u32,
) -> Vec<(glam::DVec2, glam::DVec2)> {
    let centroid = |points: &mut dyn Iterator<Item = glam::DVec2>| {
        let (sum, n) = points.fold((glam::DVec2::ZERO, 0), |(s, n), p| (s + p, n + 1));
        (n >= 20).then(|| sum / f64::from(n))
    };
    let at = |i: u32| glam::DVec2::new(f64::from(i % w), f64::from(i / w));
    (0..3)
        .filter_map(|d| {
            let mut moved = (masks.instance.iter().zip(flows))
                .filter(|((_, e), _)| *e == d)
                .map(|((i, _), f)| at(*i) + f.expect("in front"));
            let mut then = (next.instance.iter())
                .filter(|(_, e)| *e == d)
                .map(|(i, _)| at(*i));
            Some((centroid(&mut moved)?, centroid(&mut then)?))
        })
        .collect()
}

#[test]
fn under_a_rolling_shutter_flow_carries_each_row_onto_the_next_frames_rows() {
    let ctx = common::gpu();
    // Readouts drawn per frame: consecutive frames read their rows at
    // different speeds, so a row's time moves between frames.
    let p = receding((0.01, 0.1));
    let pipeline = FramePipeline::new(p).expect("pipeline");
    let mut renderer = pipeline.renderer(&ctx);
    let frames: Vec<Frame> = (0..4).map(|i| make(&pipeline, &mut renderer, i)).collect();
    let w = frames[0].scene.camera.width;
    // Mean distances (px) between each drone's centroid carried by a flow
    // and its centroid in the next frame.
    let (mut rolling_err, mut global_err, mut n) = (0.0, 0.0, 0.0);
    for pair in frames.windows(2) {
        let (a, b) = (
            pair[0].masks.as_ref().expect("masks"),
            pair[1].masks.as_ref().expect("masks"),
        );
        let flow = a.flow.as_ref().expect("flow to the next frame");
        let (ra, rb) = (readout_of(&pair[0].scene), readout_of(&pair[1].scene));
        // The flow between the frames' times, every row at the frame's.
        let global = swarmshot::annotate::flow::flow_of(
            &pair[0].scene,
            &pair[1].scene,
            &a.instance,
            &a.depth_m,
        );
        let mine = carried((a, &flow.drones), b, w);
        let frame_time = carried((a, &global.drones), b, w);
        for ((m, then), (g, _)) in mine.iter().zip(&frame_time) {
            println!(
                "readouts {ra:.3} → {rb:.3}: carried {:.2}, frame time {:.2}",
                m - then,
                g - then
            );
            rolling_err += (*m - *then).length();
            global_err += (*g - *then).length();
            n += 1.0;
        }
    }
    let (rolling_err, global_err) = (rolling_err / n, global_err / n);
    println!("{n} drones: mean {rolling_err:.3} px off, frame time {global_err:.3} px");
    assert!(n >= 4.0, "{n} drones checked");
    // The centroids of masks of a few hundred pixels: within a pixel.
    assert!(
        rolling_err < 0.6,
        "carried off the next rows by {rolling_err} px"
    );
    assert!(
        global_err > 1.0 && global_err > 3.0 * rolling_err,
        "the frame time's flow lands within {global_err} px"
    );
}
