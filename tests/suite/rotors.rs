//! Translucent rotor discs (issue 21, item 3): `appearance.rotor_opacity`
//! draws the built-in models' spinning rotors (glTF `alphaMode: BLEND`) as
//! discs the sky shows through, by MSAA coverage; the visible box stays the
//! pixels the drone changes in the noise-free picture.

use crate::common;

use swarmshot::pipeline::FramePipeline;
use swarmshot::preset::Preset;
use swarmshot::preset::appearance::{Appearance, DroneColor};
use swarmshot::preset::camera_model::CameraModel;
use swarmshot::sensor::{self, PixelRect};

/// One white quadcopter seen from close by (its rotors large in the frame),
/// labelled by its visible box, through a neutral camera.
fn rotor_preset(opacity: f64) -> Preset {
    let mut p = common::single_drone_preset(1.2);
    p.appearance = Some(Appearance {
        palette: vec![(DroneColor::White, 1.0)],
        rotor_opacity: (opacity, opacity),
        ..Appearance::default()
    });
    p.camera_model = Some(CameraModel::default());
    p
}

/// Σ over pixels of |a − b| (RGB levels).
fn total_change(a: &[u8], b: &[u8]) -> u64 {
    a.chunks(4)
        .zip(b.chunks(4))
        .map(|(x, y)| (0..3).map(|c| u64::from(x[c].abs_diff(y[c]))).sum::<u64>())
        .sum()
}

#[test]
fn translucent_rotors_show_the_sky_and_label_only_the_pixels_they_change() {
    let ctx = common::gpu();
    let solid = FramePipeline::new(rotor_preset(1.0)).expect("pipeline");
    let clear = FramePipeline::new(rotor_preset(0.25)).expect("pipeline");
    let (mut rs, mut rc) = (solid.renderer(&ctx), clear.renderer(&ctx));
    for index in 0..solid.preset().frame_count() {
        let a = solid.make(&mut rs, index).expect("frame");
        let b = clear.make(&mut rc, index).expect("frame");
        let case = format!("frame {index}");
        assert_eq!(b.scene.looks[0].rotor_opacity, 0.25, "{case}");
        // Same drone, same geometry: the amodal box does not see the opacity.
        assert_eq!(a.labels[0].amodal, b.labels[0].amodal, "{case}");
        // The picture without the drone, through the same (neutral) camera.
        let draw = b.scene.camera_model.expect("drawn");
        let (w, h) = (b.scene.camera.width, b.scene.camera.height);
        let full = PixelRect {
            x0: 0,
            y0: 0,
            x1: w,
            y1: h,
        };
        let mut empty = b.scene.clone();
        empty.camera_model = None;
        empty.drones.clear();
        let without = clear.make_scene(&mut rc, empty).expect("empty");
        let bg = sensor::develop(&without.rgba, w, h, &draw, full, false);
        // The discs let the sky through: the drone changes the picture by
        // much less than with solid discs, but still changes it.
        let (solid_change, clear_change) = (total_change(&a.rgba, &bg), total_change(&b.rgba, &bg));
        assert!(clear_change > 0, "{case}");
        assert!(
            (clear_change as f64) < 0.8 * solid_change as f64,
            "{case}: translucent {clear_change}, solid {solid_change}"
        );
        // The visible box is exactly the pixels the drone changes by a level.
        let (r, n) = common::changed_box(&b.rgba, &bg, w).expect("a visible drone");
        let vis = b.labels[0].visibility.expect("measured");
        let vb = vis.visible_box.expect("visible");
        assert_eq!(
            [vb.x0, vb.y0, vb.x1, vb.y1],
            [r.x0, r.y0, r.x1, r.y1].map(f64::from),
            "{case}"
        );
        assert_eq!(vis.visible_pixels, n, "{case}");
        // Deterministic.
        let again = clear.make(&mut rc, index).expect("frame");
        assert_eq!(again.rgba, b.rgba, "{case}");
    }
}

#[test]
fn rotor_opacity_is_validated_and_off_by_default() {
    assert_eq!(Appearance::default().rotor_opacity, (1.0, 1.0));
    let p = rotor_preset(1.5);
    let e = format!("{:?}", p.validate().expect_err("rejected"));
    assert!(e.contains("appearance.rotor_opacity"), "{e}");
}
