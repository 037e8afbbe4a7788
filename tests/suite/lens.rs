//! Lens distortion (issue 41) end to end on the CPU Vulkan device: visible
//! boxes are the pixels a drone changes in the distorted picture, amodal
//! boxes hold them, a lens with every coefficient 0 changes no byte, and a
//! lens that folds the picture is refused by its field.

use crate::common;

use swarmshot::pipeline::FramePipeline;
use swarmshot::preset::Preset;
use swarmshot::preset::camera_model::CameraModel;
use swarmshot::preset::lens::Lens;
use swarmshot::preset::sweep::SweepRange;
use swarmshot::sensor::PixelRect;
use swarmshot::sensor::lens::LensMap;

fn barrel(k1: f64) -> Lens {
    Lens::BrownConrady {
        k1: (k1, k1),
        k2: (0.05, 0.05),
        k3: (0.0, 0.0),
        p1: (0.002, 0.002),
        p2: (-0.001, -0.001),
    }
}

/// One drone at the picture's centre through a noisy camera with `lens`.
fn lens_preset(lens: Option<Lens>) -> Preset {
    let mut p = common::single_drone_preset(1.2);
    p.camera.x = SweepRange::new(-0.7, 0.7, 1.4);
    p.camera_model = Some(CameraModel {
        read_noise_levels: (1.0, 1.0),
        lens,
        ..CameraModel::default()
    });
    p
}

/// The noise-free camera image of `scene` through its lens, as the truth to compare with.
fn lensed_image(
    renderer: &mut swarmshot::render::Renderer,
    scene: &swarmshot::scene::FrameScene,
    msaa: u32,
) -> Vec<u8> {
    let (w, h) = (scene.camera.width, scene.camera.height);
    let rendered = common::rendered_at_exposure(renderer, scene, msaa);
    let geo = swarmshot::scene::projection::frame_lens(scene).expect("a lens");
    let lensed = LensMap::of(&geo).remap(&rendered);
    let draw = scene.camera_model.expect("drawn").after_render();
    let full = PixelRect {
        x0: 0,
        y0: 0,
        x1: w,
        y1: h,
    };
    swarmshot::sensor::develop(&lensed, w, h, &draw, full, false)
}

#[test]
fn visible_boxes_through_a_lens_are_the_pixels_a_drone_changes() {
    let ctx = common::gpu();
    let fisheye = Lens::Fisheye {
        k1: (0.05, 0.05),
        k2: (0.0, 0.0),
        k3: (0.0, 0.0),
        k4: (0.0, 0.0),
    };
    let mut checked = 0;
    // The drone at the centre, and off it (an absolute camera looking beside
    // the drone at the origin), where the lens bends it most.
    let beside = swarmshot::preset::formation::AbsoluteCamera {
        position_m: (0.0, 0.0, 2.0),
        look_at_m: (0.5, 0.3, 0.0),
    };
    let cases = [barrel(-0.3), barrel(0.15), fisheye]
        .into_iter()
        .flat_map(|l| [(l.clone(), None), (l, Some(beside.clone()))]);
    for (lens, absolute) in cases {
        let mut p = lens_preset(Some(lens.clone()));
        p.camera.absolute = absolute.clone();
        let pipeline = FramePipeline::new(p.clone()).expect("pipeline");
        let mut renderer = pipeline.renderer(&ctx);
        for index in 0..p.frame_count() {
            let frame = pipeline.make(&mut renderer, index).expect("frame");
            let w = frame.scene.camera.width;
            let a = lensed_image(&mut renderer, &frame.scene, p.render.msaa);
            let mut empty = frame.scene.clone();
            empty.drones.clear();
            let b = lensed_image(&mut renderer, &empty, p.render.msaa);
            let case = format!("{lens:?}, {absolute:?}, frame {index}");
            let (r, n) = common::changed_box(&a, &b, w).expect(&case);
            let label = &frame.labels[0];
            let vis = label.visibility.expect("measured");
            let vb = vis.visible_box.expect(&case);
            assert_eq!(
                [vb.x0, vb.y0, vb.x1, vb.y1],
                [r.x0, r.y0, r.x1, r.y1].map(f64::from),
                "{case}"
            );
            assert_eq!(vis.visible_pixels, n, "{case}");
            assert!(label.is_kept(), "{case}");
            // The amodal box is the lens-mapped hull's: it reaches the changed
            // pixels' box to within the edge pixel a partly covered pixel adds
            // and the bilinear taps' source pixel (≤ 1.3 output px at these
            // lenses' zoom), and it moved with the lens.
            let am = label.amodal;
            let tol = 2.5;
            assert!(
                am.x0 <= vb.x0 + tol
                    && am.y0 <= vb.y0 + tol
                    && am.x1 >= vb.x1 - tol
                    && am.y1 >= vb.y1 - tol,
                "{case}: amodal {am:?} visible {vb:?}"
            );
            assert!(am.iou(&vb) > 0.5, "{case}: amodal {am:?} visible {vb:?}");
            let mut plain = frame.scene.clone();
            plain.camera_model = None;
            let plain = pipeline.estimate_labels(&plain);
            let pa = plain[0].amodal;
            let moved = [pa.x0 - am.x0, pa.y0 - am.y0, pa.x1 - am.x1, pa.y1 - am.y1]
                .map(f64::abs)
                .into_iter()
                .fold(0.0, f64::max);
            // Off the centre the lens moves the box (at the centre only its zoom
            // does); a box the lens did not reach would not move at all.
            assert!(
                absolute.is_none() || moved > 0.25,
                "{case}: the lens moved the amodal box by {moved} px"
            );
            checked += 1;
        }
    }
    assert!(checked >= 12, "{checked}");
}

#[test]
fn a_lens_with_every_coefficient_zero_changes_no_byte() {
    let ctx = common::gpu();
    let zero = Lens::BrownConrady {
        k1: (0.0, 0.0),
        k2: (0.0, 0.0),
        k3: (0.0, 0.0),
        p1: (0.0, 0.0),
        p2: (0.0, 0.0),
    };
    let with = FramePipeline::new(lens_preset(Some(zero))).expect("pipeline");
    let without = FramePipeline::new(lens_preset(None)).expect("pipeline");
    let mut renderer = with.renderer(&ctx);
    for index in 0..with.frame_count() {
        let a = with.make(&mut renderer, index).expect("frame");
        let b = without.make(&mut renderer, index).expect("frame");
        assert_eq!(a.rgba, b.rgba, "frame {index}");
        assert_eq!(a.labels, b.labels, "frame {index}");
        let (da, db) = (
            a.scene.camera_model.expect("drawn"),
            b.scene.camera_model.expect("drawn"),
        );
        assert_eq!(swarmshot::sensor::CameraDraw { lens: None, ..da }, db);
    }
}

#[test]
fn a_lens_that_folds_the_picture_is_refused_by_its_field() {
    let check = |lens: Lens| {
        let errors =
            swarmshot::pipeline::check::validate(&lens_preset(Some(lens))).expect_err("refused");
        errors.iter().map(|e| e.field.clone()).collect::<Vec<_>>()
    };
    // k1 = −1.5 at this 50° view: r(1 − 1.5 r²) stops growing at r ≈ 0.47, inside the corner.
    assert_eq!(check(barrel(-1.5)), ["camera_model.lens"]);
    assert_eq!(
        check(barrel(-3.0)),
        ["camera_model.lens.k1", "camera_model.lens"]
    );
    let nan = Lens::Fisheye {
        k1: (f64::NAN, 0.0),
        k2: (0.0, 0.0),
        k3: (0.0, 0.0),
        k4: (0.0, 0.0),
    };
    assert_eq!(check(nan), ["camera_model.lens.k1"]);
    assert!(swarmshot::pipeline::check::validate(&lens_preset(Some(barrel(-0.3)))).is_ok());
}

#[test]
fn a_lens_with_depth_or_flow_maps_is_refused_by_its_field() {
    // Depth and flow are made for the rendered (pinhole) picture's pixels.
    for flow in [false, true] {
        let mut p = lens_preset(Some(barrel(-0.3)));
        p.output.masks.depth = !flow;
        p.output.masks.flow = flow;
        let errors = swarmshot::pipeline::check::validate(&p).expect_err("refused");
        let lens = errors.iter().find(|e| e.field == "camera_model.lens");
        let lens = lens.unwrap_or_else(|| panic!("{errors:?}"));
        let asked = if flow {
            "output.masks.flow"
        } else {
            "output.masks.depth"
        };
        assert!(lens.message.contains(asked), "{lens:?}");
        p.camera_model.as_mut().expect("a camera model").lens = None;
        let others = swarmshot::pipeline::check::validate(&p)
            .err()
            .unwrap_or_default();
        assert!(others.iter().all(|e| e.field != "camera_model.lens"));
    }
}

#[test]
fn the_manifest_records_the_written_pictures_focal_length_through_a_lens() {
    // A barrel lens zooms in: the written picture's focal length is not K's.
    let p = lens_preset(Some(barrel(-0.3)));
    let scene = swarmshot::scene::build_frame(&p, 0).expect("frame");
    let names = ["quad_x".to_string()];
    let line = swarmshot::write::manifest_line(&scene, &[], "x.png", &names, &[]);
    let record: serde_json::Value = serde_json::from_str(&line).expect("json");
    let lens = &record["camera_model"]["lens"];
    let focal = lens["focal_px"].as_f64().expect("lens.focal_px");
    let k = |r: usize, c: usize| record["camera"]["K"][r][c].as_f64().expect("K");
    let (fx, cx, cy) = (k(0, 0), k(0, 2), k(1, 2));
    assert!((focal - fx).abs() > 1.0, "{focal} vs K's {fx}");
    // K's pinhole, the recorded coefficients and focal_px put a rendered
    // point where the lens puts it in the written picture.
    let c = |name: &str| lens[name].as_f64().expect("coefficient");
    let (k1, k2, k3, p1, p2) = (c("k1"), c("k2"), c("k3"), c("p1"), c("p2"));
    let geo = swarmshot::scene::projection::frame_lens(&scene).expect("a lens");
    for (u, v) in [(3.0, 5.0), (cx, cy), (200.0, 150.0), (239.0, 159.0)] {
        let (x, y) = ((u - cx) / fx, (v - cy) / fx);
        let r2 = x * x + y * y;
        let radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
        let xd = x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x);
        let yd = y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y;
        let (wu, wv) = geo.forward((u, v));
        let (du, dv) = (cx + focal * xd - wu, cy + focal * yd - wv);
        assert!(
            du.abs() < 1e-3 && dv.abs() < 1e-3,
            "({u}, {v}): off by ({du}, {dv})"
        );
    }
}
