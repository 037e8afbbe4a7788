//! The rolling shutter (`camera_model.rolling_shutter`, issue 41) end to end
//! (renders on lavapipe): a drone crossing the view skews by its image speed
//! times the readout per image height; a readout of 0 is byte-identical to
//! no shutter; the labels are the pixels changed against the drone-free
//! frame under the same draws and the same shutter; frames are deterministic
//! and made alone; and the fast design (each drone moved row by row over the
//! background turned row by row) stays within a bound of a reference
//! rendered in two-row bands, each band at its own time.

use crate::common;

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
