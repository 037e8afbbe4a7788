//! Stiff cases of the camera model and the atmosphere (issue 21, item 9):
//! visibility near zero and very large, zero noise, zero and huge blur, a
//! PSF wider than the drone, exposures that clip. Each frame is made
//! through the whole pipeline (lavapipe) and its labels checked: finite,
//! inside the image, and what the case implies about them.

use crate::common;

use swarmshot::annotate::DroneLabel;
use swarmshot::pipeline::{Frame, FramePipeline};
use swarmshot::preset::atmosphere::Atmosphere;
use swarmshot::preset::camera_model::{CameraModel, Psf};
use swarmshot::preset::{BoxMethod, Preset};

/// A few drones 10–30 px wide, visible boxes through the camera.
fn preset(camera: Option<CameraModel>) -> Preset {
    let mut p = common::tiny_preset();
    p.labels.box_method = BoxMethod::Visible;
    p.camera_model = camera;
    p
}

fn frames(p: &Preset) -> Vec<Frame> {
    let ctx = common::gpu();
    let pipeline = FramePipeline::new(p.clone()).expect("pipeline");
    let mut renderer = pipeline.renderer(&ctx);
    (0..p.frame_count().min(4))
        .map(|i| pipeline.make(&mut renderer, i).expect("frame"))
        .collect()
}

/// Every number of every label is finite, boxes lie in the image with a
/// positive area, and a kept label has visible pixels.
fn sane(frames: &[Frame], case: &str) {
    for f in frames {
        let (w, h) = (
            f64::from(f.scene.camera.width),
            f64::from(f.scene.camera.height),
        );
        assert_eq!(f.rgba.len() as f64, w * h * 4.0, "{case}");
        for l in &f.labels {
            let DroneLabel {
                bbox: b, amodal: a, ..
            } = l;
            for v in [b.x0, b.y0, b.x1, b.y1, a.x0, a.y0, a.x1, a.y1, l.distance_m] {
                assert!(v.is_finite(), "{case}: frame {}: {l:?}", f.scene.index);
            }
            let vis = l.visibility.expect("measured");
            if l.is_kept() {
                assert!(vis.visible_pixels > 0, "{case}: {l:?}");
                assert!(
                    b.x0 >= 0.0 && b.y0 >= 0.0 && b.x1 <= w && b.y1 <= h,
                    "{case}: {l:?}"
                );
                assert!(b.x1 > b.x0 && b.y1 > b.y0, "{case}: {l:?}");
            }
            if let Some(v) = vis.visible_box {
                assert!(
                    v.x0 >= 0.0 && v.y0 >= 0.0 && v.x1 <= w && v.y1 <= h,
                    "{case}"
                );
                assert!(vis.visible_pixels as f64 <= (v.x1 - v.x0) * (v.y1 - v.y0));
            }
        }
    }
}

fn visible_pixels(frames: &[Frame]) -> u64 {
    frames
        .iter()
        .flat_map(|f| &f.labels)
        .filter_map(|l| l.visibility)
        .map(|v| v.visible_pixels)
        .sum()
}

fn kept(frames: &[Frame]) -> usize {
    frames
        .iter()
        .flat_map(|f| &f.labels)
        .filter(|l| l.is_kept())
        .count()
}

#[test]
fn visibility_near_zero_and_very_large() {
    let clear = frames(&preset(None));
    sane(&clear, "no atmosphere");
    let mut far = preset(None);
    far.atmosphere = Some(Atmosphere {
        visibility_m: (1e7, 1e7),
    });
    let far = frames(&far);
    sane(&far, "V = 10 000 km");
    // At 10 000 km the haze changes a drone 1–10 m away by < 10⁻⁵: the boxes are the clear air's.
    for (a, b) in clear.iter().zip(&far) {
        let boxes = |f: &Frame| f.labels.iter().map(|l| l.bbox).collect::<Vec<_>>();
        assert_eq!(boxes(a), boxes(b), "frame {}", a.scene.index);
    }
    let mut thick = preset(None);
    thick.atmosphere = Some(Atmosphere {
        visibility_m: (1e-3, 1e-3),
    });
    let thick = frames(&thick);
    sane(&thick, "V = 1 mm");
    // Through 1 mm of visibility every drone pixel is the air light towards it: the
    // drones' pixels change. (The sky behind them is not hazed, and the air light
    // differs from it, so they stay visible: the labels report what the picture shows.)
    let mut changed = 0;
    for (a, b) in clear.iter().zip(&thick) {
        for l in a.labels.iter().filter(|l| l.is_kept()) {
            let w = a.scene.camera.width as usize;
            let (x, y) = (
                ((l.bbox.x0 + l.bbox.x1) / 2.0) as usize,
                ((l.bbox.y0 + l.bbox.y1) / 2.0) as usize,
            );
            let i = (y * w + x) * 4;
            changed += usize::from(a.rgba[i..i + 3] != b.rgba[i..i + 3]);
        }
    }
    assert!(changed > 0);
    assert!(visible_pixels(&thick) <= visible_pixels(&clear));
    assert!(visible_pixels(&clear) > 0);
}

#[test]
fn a_neutral_camera_with_zero_noise_keeps_the_render() {
    let clean = frames(&preset(None));
    let neutral = frames(&preset(Some(CameraModel::default())));
    sane(&neutral, "neutral camera");
    for (a, b) in clean.iter().zip(&neutral) {
        assert!(a.rgba == b.rgba, "frame {}: pixels changed", a.scene.index);
        // The pixels a drone changes lie inside its rendered visible box.
        for (la, lb) in a.labels.iter().zip(&b.labels) {
            let (Some(ra), Some(rb)) = (
                la.visibility.and_then(|v| v.visible_box),
                lb.visibility.and_then(|v| v.visible_box),
            ) else {
                continue;
            };
            assert!(
                rb.x0 >= ra.x0 && rb.y0 >= ra.y0 && rb.x1 <= ra.x1 && rb.y1 <= ra.y1,
                "{ra:?} ⊉ {rb:?}"
            );
        }
    }
    // A Gaussian of σ 0 is no PSF.
    let zero = frames(&preset(Some(CameraModel {
        psf: Psf::Gaussian {
            sigma_px: (0.0, 0.0),
        },
        ..CameraModel::default()
    })));
    for (a, b) in neutral.iter().zip(&zero) {
        assert!(a.rgba == b.rgba, "frame {}", a.scene.index);
        assert_eq!(a.labels, b.labels);
    }
}

#[test]
fn psfs_wider_than_the_drone_and_huge_blurs_give_bounded_boxes() {
    let clean = frames(&preset(Some(CameraModel::default())));
    for sigma in [8.0, 20.0, 64.0] {
        let camera = CameraModel {
            psf: Psf::Gaussian {
                sigma_px: (sigma, sigma),
            },
            read_noise_levels: (1.0, 1.0),
            ..CameraModel::default()
        };
        let blurred = frames(&preset(Some(camera)));
        let case = format!("σ {sigma} px");
        sane(&blurred, &case);
        for (a, b) in clean.iter().zip(&blurred) {
            let draw = b.scene.camera_model.expect("drawn");
            let (w, h) = (b.scene.camera.width, b.scene.camera.height);
            let reach = f64::from(draw.reach_px(w, h));
            for (la, lb) in a.labels.iter().zip(&b.labels) {
                let (Some(ra), Some(rb)) = (
                    la.visibility.and_then(|v| v.visible_box),
                    lb.visibility.and_then(|v| v.visible_box),
                ) else {
                    continue;
                };
                // Within the clean box grown by the PSF's reach.
                assert!(
                    rb.x0 >= ra.x0 - reach
                        && rb.y0 >= ra.y0 - reach
                        && rb.x1 <= ra.x1 + reach
                        && rb.y1 <= ra.y1 + reach,
                    "{case}: {ra:?} grown by {reach} ⊉ {rb:?}"
                );
                // The amodal box stays the geometry.
                assert_eq!(la.amodal, lb.amodal, "{case}");
            }
        }
        // A PSF wider than the drones (8 px against 10–30 px drones) still shows them,
        // spread over more pixels than the sharp picture.
        if sigma == 8.0 {
            assert!(kept(&blurred) > 0, "{case}");
            assert!(visible_pixels(&blurred) > visible_pixels(&clean), "{case}");
        }
    }
}

#[test]
fn exposures_that_clip_give_sane_labels() {
    let normal = frames(&preset(Some(CameraModel::default())));
    for ev in [-10.0, 10.0] {
        let f = frames(&preset(Some(CameraModel {
            exposure_ev: (ev, ev),
            read_noise_levels: (2.0, 2.0),
            ..CameraModel::default()
        })));
        let case = format!("EV {ev}");
        sane(&f, &case);
        // Clipping hides detail: no more pixels differ from the drone-free frame.
        assert!(
            visible_pixels(&f) <= visible_pixels(&normal),
            "{case}: {} ≥ {}",
            visible_pixels(&f),
            visible_pixels(&normal)
        );
        if ev > 0.0 {
            // +10 EV: the sky clips to white (the read noise only pulls it down a few levels).
            let sky = &f[0].rgba[..4];
            assert!(sky[..3].iter().all(|&v| v >= 245), "{case}: {sky:?}");
        }
    }
}
