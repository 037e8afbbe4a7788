//! The rolling shutter (`camera_model.rolling_shutter`, issue 41) end to end
//! (renders on lavapipe): a drone crossing the view skews by its image speed
//! times the readout per image height; a readout of 0 is byte-identical to
//! no shutter; the labels are the pixels changed against the drone-free
//! frame under the same draws and the same shutter; frames are deterministic
//! and made alone; and the fast design (each drone moved row by row over the
//! background turned row by row) stays within a bound of a reference
//! rendered in two-row bands, each band at its own time.

mod common;

use swarmshot::pipeline::{Frame, FramePipeline};
use swarmshot::preset::camera_model::CameraModel;
use swarmshot::preset::rolling_shutter::RollingShutter;
use swarmshot::preset::sweep::SweepRange;
use swarmshot::preset::{BoxMethod, Motion, Placement, Preset};
use swarmshot::render::Renderer;
use swarmshot::scene::{FrameScene, build_frame, build_frame_at};

/// The MOT tests' wedge crossing a fixed camera sideways (`count` drones,
/// 320×180), a neutral camera model with a rolling shutter of `readout_s`
/// turning at `yaw_deg_s` (`None`: no shutter).
fn preset(count: u32, shutter: Option<(f64, f64)>) -> Preset {
    let mut p = common::sequence_preset();
    p.name = "rolling".into();
    if let Placement::Formation(f) = &mut p.placement {
        f.count = count;
    }
    p.camera.y = SweepRange::fixed(0.1);
    p.camera.z = SweepRange::fixed(0.9);
    p.repeats = 1;
    p.models[0].size_m = 1.5;
    p.render.msaa = 4;
    p.labels.box_method = BoxMethod::Visible;
    if let Some(seq) = p.sequence.as_mut() {
        seq.motion = Motion {
            translate_m: (12.0, 0.0, 0.0),
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
    let mut rows = 0;
    for (y, (s, g)) in shuttered.iter().zip(&global).enumerate() {
        let (Some(s), Some(g)) = (s, g) else {
            continue;
        };
        // Row y is exposed readout·y/H late: the drone has moved speed·that.
        let want = speed.x * readout * y as f64 / f64::from(h);
        assert!((s - g - want).abs() < 0.35, "row {y}: {} px, want {want}", s - g);
        rows += 1;
    }
    assert!(rows >= 10, "the drone spans {rows} rows");
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
        let (a, b) = (&frame.rgba[i as usize * 4..][..3], &empty.rgba[i as usize * 4..][..3]);
        a != b
    };
    let all: Vec<u32> = (0..frame.rgba.len() as u32 / 4).filter(|&i| changed(i)).collect();
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
        assert_eq!(vis.visible_pixels, mine.len() as u64, "drone {}", label.drone);
        let Some(b) = vis.visible_box else {
            continue;
        };
        let (x0, x1) = (mine.iter().map(|i| i % w).min(), mine.iter().map(|i| i % w).max());
        let (y0, y1) = (mine.iter().map(|i| i / w).min(), mine.iter().map(|i| i / w).max());
        assert_eq!((b.x0, b.y0), (f64::from(x0.expect("x")), f64::from(y0.expect("y"))));
        assert_eq!((b.x1, b.y1), (f64::from(x1.expect("x") + 1), f64::from(y1.expect("y") + 1)));
        // The amodal box (each hull point at its own row's time) holds the visible one.
        let a = label.amodal;
        let slack = 1.5;
        assert!(
            a.x0 - slack <= b.x0 && a.y0 - slack <= b.y0 && b.x1 <= a.x1 + slack && b.y1 <= a.y1 + slack,
            "drone {}: visible {b:?} outside amodal {a:?}",
            label.drone
        );
        kept += 1;
    }
    assert!(kept >= 2, "{kept} drones seen");
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
    assert_ne!(make(&global, &mut rg, 2).rgba, alone.rgba, "the shutter changes the picture");
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
    let (mut with, mut without) = (vec![0u8; (w * h * 4) as usize], vec![0u8; (w * h * 4) as usize]);
    for y0 in (0..h).step_by(band as usize) {
        let y1 = (y0 + band).min(h);
        let tau = readout * f64::from(y0 + y1) / 2.0 / f64::from(h);
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
    for (readout, yaw) in [(0.05, 0.0), (0.04, 60.0)] {
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
        let mut worst: f64 = 0.0;
        let mut rows = 0;
        for (f, s) in fast.iter().zip(&slow) {
            if let (Some(f), Some(s)) = (f, s) {
                worst = worst.max((f - s).abs());
                rows += 1;
            }
        }
        println!("readout {readout} s, yaw {yaw}°/s: worst row centroid {worst:.3} px over {rows} rows");
        assert!(rows >= 10, "{rows} rows");
        assert!(worst < 0.35, "readout {readout}, yaw {yaw}: {worst} px");
        // The sky turned row by row matches the sky rendered band by band.
        let sky: f64 = (empty.rgba.iter().zip(&reference_free))
            .map(|(a, b)| (f64::from(*a) - f64::from(*b)).abs())
            .fold(0.0, f64::max);
        println!("  sky: worst {sky} levels");
        assert!(sky <= 3.0, "the turned sky is {sky} levels off");
    }
}
