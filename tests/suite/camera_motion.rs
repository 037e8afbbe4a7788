//! Motion blur for sequences (`camera_model.exposure_time_s`, src/sensor/motion.rs):
//! the visible box of a moving drone is the pixels where the written
//! (noise-free) frame differs by ≥ 1 level from the drone-free frame through
//! the same camera draws, and the streak is as long as the drone's image
//! motion during the exposure (lavapipe).

use crate::common;

use swarmshot::pipeline::FramePipeline;
use swarmshot::preset::camera_model::{CameraModel, Psf};
use swarmshot::preset::{BoxMethod, Placement, Preset};
use swarmshot::sensor::{self, PixelRect};

/// One drone flying across a fixed camera, 5 frames at 10 frames/s.
fn moving(exposure_s: f64) -> Preset {
    let mut p = common::sequence_preset();
    p.placement = Placement::Structured {
        x_count: 1,
        y_count: 1,
        z_count: 1,
        load_factor: 1.0,
    };
    p.repeats = 1;
    p.labels.box_method = BoxMethod::Visible;
    p.camera_model = Some(CameraModel {
        psf: Psf::Gaussian {
            sigma_px: (0.7, 0.7),
        },
        exposure_time_s: (exposure_s, exposure_s),
        ..CameraModel::default()
    });
    p
}

#[test]
fn a_moving_drone_streaks_and_its_box_is_the_pixels_it_changes() {
    let ctx = common::gpu();
    let exposure_s = 0.1; // the whole frame interval at 10 frames/s
    let p = moving(exposure_s);
    assert!(p.validate().is_ok());
    let pipeline = FramePipeline::new(p.clone()).expect("pipeline");
    let sharp_pipeline = FramePipeline::new(moving(0.0)).expect("pipeline");
    let mut renderer = pipeline.renderer(&ctx);
    let n = p.frame_count();
    assert_eq!(n, 5);
    let sharp: Vec<_> = (0..n)
        .map(|i| sharp_pipeline.make(&mut renderer, i).expect("frame"))
        .collect();
    let centre = |i: usize| {
        let a = sharp[i].labels[0].amodal;
        ((a.x0 + a.x1) / 2.0, (a.y0 + a.y1) / 2.0)
    };
    let mut longer = 0;
    for index in 0..n {
        let frame = pipeline.make(&mut renderer, index).expect("frame");
        let draw = frame.scene.camera_model.expect("drawn");
        assert_eq!(draw.exposure_time_s, exposure_s);
        let (w, h) = (frame.scene.camera.width, frame.scene.camera.height);
        // The drone-free frame through the same draws, noise-free (the draw has no noise).
        let mut empty = frame.scene.clone();
        empty.camera_model = None;
        empty.drones.clear();
        let without = pipeline.make_scene(&mut renderer, empty).expect("empty");
        let full = PixelRect {
            x0: 0,
            y0: 0,
            x1: w,
            y1: h,
        };
        let background = sensor::develop(&without.rgba, w, h, &draw, full, false);
        let (truth, pixels) =
            common::changed_box(&frame.rgba, &background, w).expect("a visible drone");
        let vis = frame.labels[0].visibility.expect("measured");
        let b = vis.visible_box.expect("visible");
        let case = format!("frame {index}");
        assert_eq!(
            [b.x0, b.y0, b.x1, b.y1],
            [truth.x0, truth.y0, truth.x1, truth.y1].map(f64::from),
            "{case}"
        );
        assert_eq!(vis.visible_pixels, pixels, "{case}");
        assert_eq!(frame.labels[0].bbox, b, "{case}");
        // The amodal box stays the geometry at the frame's time.
        assert_eq!(
            frame.labels[0].amodal,
            sharp[index as usize].labels[0].amodal
        );
        // The streak: the sharp box swept by the image motion of one frame
        // interval (central difference of the neighbours' amodal centres).
        let i = index as usize;
        let (a, c) = (i.saturating_sub(1), (i + 1).min(n as usize - 1));
        let (ca, cc) = (centre(a), centre(c));
        let steps = (c - a) as f64;
        let shift = ((cc.0 - ca.0) / steps, (cc.1 - ca.1) / steps);
        let s = sharp[i].labels[0].bbox;
        let (grow_x, grow_y) = ((b.x1 - b.x0) - (s.x1 - s.x0), (b.y1 - b.y0) - (s.y1 - s.y0));
        assert!(
            (grow_x - shift.0.abs()).abs() <= 3.0 && (grow_y - shift.1.abs()).abs() <= 3.0,
            "{case}: box grew by ({grow_x}, {grow_y}), motion ({:.1}, {:.1}) px",
            shift.0,
            shift.1
        );
        longer += usize::from(shift.0.abs().max(shift.1.abs()) >= 4.0);
    }
    assert!(longer >= 3, "the drone moves ≥ 4 px a frame in most frames");
}

#[test]
fn motion_blur_is_checked_and_off_by_default() {
    assert_eq!(CameraModel::default().exposure_time_s, (0.0, 0.0));
    // Stills have no motion.
    let mut still = common::tiny_preset();
    still.camera_model = Some(CameraModel {
        exposure_time_s: (0.01, 0.01),
        ..CameraModel::default()
    });
    let errors = still.validate().expect_err("invalid");
    assert!(
        errors
            .iter()
            .any(|e| e.field == "camera_model.exposure_time_s" && e.message.contains("sequence")),
        "{errors:?}"
    );
    // Longer than the frame interval (10 frames/s).
    let long = moving(0.2);
    let errors = long.validate().expect_err("invalid");
    assert!(
        errors
            .iter()
            .any(|e| e.field == "camera_model.exposure_time_s"),
        "{errors:?}"
    );
    assert!(
        Preset::from_ron("(camera_model: Some((exposure_time_s: (-1.0, 0.0))))")
            .map_or(true, |p| p.validate().is_err())
    );
}
