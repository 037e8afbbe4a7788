//! The camera model (src/sensor/): measured noise and blur against the set
//! values, extremes, determinism, and the labels under the camera model
//! against a drone-free frame made with the same camera draws (lavapipe).

use crate::common;

use swarmshot::preset::camera_model::{CameraModel, Psf};
use swarmshot::preset::{BoxMethod, Preset};
use swarmshot::sensor::{self, CameraDraw, PixelRect, PsfDraw};

fn neutral() -> CameraDraw {
    sensor::draw(&CameraModel::default(), 1, 0)
}

fn flat(w: u32, h: u32, v: u8) -> Vec<u8> {
    (0..w * h).flat_map(|_| [v, v, v, 255]).collect()
}

fn srgb_to_linear(c: f64) -> f64 {
    let c = c / 255.0;
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

fn linear_to_srgb(l: f64) -> f64 {
    255.0
        * if l <= 0.003_130_8 {
            12.92 * l
        } else {
            1.055 * l.powf(1.0 / 2.4) - 0.055
        }
}

fn std_dev(xs: impl Iterator<Item = f64> + Clone) -> f64 {
    let n = xs.clone().count() as f64;
    let m = xs.clone().sum::<f64>() / n;
    (xs.map(|x| (x - m).powi(2)).sum::<f64>() / n).sqrt()
}

#[test]
fn measured_noise_is_the_set_noise_within_5_percent() {
    let (w, h) = (512u32, 512u32);
    let level = 140u8;
    let signal = srgb_to_linear(f64::from(level));
    // The output is sRGB: the linear σ times the curve's slope at the signal,
    // plus the quantisation's 1/12 level² (σ large enough that it is small).
    let slope = (linear_to_srgb(signal + 1e-4) - linear_to_srgb(signal - 1e-4)) / 2e-4;
    for (gain, read) in [(0.0, 3.0), (0.05, 0.0), (0.02, 2.0)] {
        let draw = CameraDraw {
            shot_noise_gain: gain,
            read_noise_levels: read,
            ..neutral()
        };
        let out = sensor::apply(&flat(w, h, level), w, h, &draw);
        let set_linear_levels = (gain * 255.0 * signal + read * read).sqrt();
        let expected = ((slope * set_linear_levels / 255.0).powi(2) + 1.0 / 12.0).sqrt();
        for c in 0..3 {
            let measured = std_dev(out.iter().skip(c).step_by(4).map(|&v| f64::from(v)));
            assert!(
                (measured / expected - 1.0).abs() < 0.05,
                "gain {gain}, read {read}, channel {c}: σ {measured:.3} levels, set {expected:.3}"
            );
        }
        // Noise is per pixel: neighbours are uncorrelated.
        let g: Vec<f64> = out
            .iter()
            .skip(1)
            .step_by(4)
            .map(|&v| f64::from(v))
            .collect();
        let m = g.iter().sum::<f64>() / g.len() as f64;
        let var = g.iter().map(|x| (x - m).powi(2)).sum::<f64>();
        let cov: f64 = g.windows(2).map(|p| (p[0] - m) * (p[1] - m)).sum();
        assert!(
            (cov / var).abs() < 0.02,
            "neighbour correlation {}",
            cov / var
        );
    }
    // Shot noise grows with the signal: a brighter flat frame is noisier.
    let draw = CameraDraw {
        shot_noise_gain: 0.2,
        ..neutral()
    };
    let sigma_at = |v: u8| {
        let out = sensor::apply(&flat(256, 256, v), 256, 256, &draw);
        std_dev(out.iter().step_by(4).map(|&v| srgb_to_linear(f64::from(v))))
    };
    assert!(sigma_at(200) > 1.5 * sigma_at(60));
}

/// σ of the edge spread: the linear profile across a vertical step edge is
/// the PSF's cumulative; its derivative's second moment is σ².
fn edge_sigma(out: &[u8], w: u32, h: u32) -> f64 {
    let y = h / 2;
    let profile: Vec<f64> = (0..w)
        .map(|x| srgb_to_linear(f64::from(out[((y * w + x) * 4 + 1) as usize])))
        .collect();
    let d: Vec<f64> = profile.windows(2).map(|p| p[1] - p[0]).collect();
    let total: f64 = d.iter().sum();
    let mean = d.iter().enumerate().map(|(i, v)| i as f64 * v).sum::<f64>() / total;
    (d.iter()
        .enumerate()
        .map(|(i, v)| (i as f64 - mean).powi(2) * v)
        .sum::<f64>()
        / total)
        .sqrt()
}

#[test]
fn a_blurred_edge_has_the_set_sigma_within_10_percent() {
    let (w, h) = (96u32, 16u32);
    let edge: Vec<u8> = (0..w * h)
        .flat_map(|i| {
            let v = if i % w < w / 2 { 30 } else { 220 };
            [v, v, v, 255]
        })
        .collect();
    assert!(edge_sigma(&edge, w, h) < 0.1, "the sharp edge");
    for sigma_px in [1.0, 2.0, 4.5] {
        let draw = CameraDraw {
            psf: PsfDraw::Gaussian { sigma_px },
            ..neutral()
        };
        let measured = edge_sigma(&sensor::apply(&edge, w, h, &draw), w, h);
        assert!(
            (measured / sigma_px - 1.0).abs() < 0.1,
            "σ set {sigma_px}, measured {measured:.3}"
        );
    }
    // A disc of radius r has σ = r/2 across an edge (for a continuous disc).
    let draw = CameraDraw {
        psf: PsfDraw::Disc { radius_px: 6.0 },
        ..neutral()
    };
    let measured = edge_sigma(&sensor::apply(&edge, w, h, &draw), w, h);
    assert!((measured / 3.0 - 1.0).abs() < 0.1, "disc: {measured:.3}");
}

fn extreme_draws() -> Vec<(&'static str, CameraDraw)> {
    let n = neutral();
    vec![
        ("zero noise", n),
        (
            "huge blur",
            CameraDraw {
                psf: PsfDraw::Gaussian { sigma_px: 64.0 },
                ..n
            },
        ),
        (
            "huge disc",
            CameraDraw {
                psf: PsfDraw::Disc { radius_px: 64.0 },
                ..n
            },
        ),
        (
            "white",
            CameraDraw {
                exposure_ev: 10.0,
                ..n
            },
        ),
        (
            "black",
            CameraDraw {
                exposure_ev: -10.0,
                ..n
            },
        ),
        (
            "1 px sensor",
            CameraDraw {
                sensor_scale: Some(1e-6),
                ..n
            },
        ),
        (
            "everything",
            CameraDraw {
                exposure_ev: 1.5,
                white_balance_red: 1.3,
                white_balance_blue: 0.7,
                psf: PsfDraw::Gaussian { sigma_px: 1.2 },
                vignetting: 1.0,
                ca_red_scale: 1.01,
                ca_blue_scale: 0.99,
                shot_noise_gain: 50.0,
                read_noise_levels: 255.0,
                sensor_scale: Some(0.37),
                ..n
            },
        ),
        (
            "sharpened",
            CameraDraw {
                psf: PsfDraw::Gaussian { sigma_px: 0.8 },
                read_noise_levels: 2.0,
                sharpen: 1.5,
                ..n
            },
        ),
        (
            "everything, sharpened most",
            CameraDraw {
                exposure_ev: 1.5,
                psf: PsfDraw::Disc { radius_px: 2.0 },
                ca_red_scale: 1.01,
                shot_noise_gain: 50.0,
                sensor_scale: Some(0.37),
                sharpen: 4.0,
                ..n
            },
        ),
    ]
}

#[test]
fn extremes_give_images_and_windows_that_match_the_whole_frame() {
    let (w, h) = (67u32, 301u32);
    let rgba: Vec<u8> = (0..w * h * 4)
        .map(|i| ((i * 31 + i / 7) % 256) as u8)
        .collect();
    for (name, draw) in extreme_draws() {
        let out = sensor::apply(&rgba, w, h, &draw);
        assert_eq!(out.len(), rgba.len(), "{name}");
        let whole = PixelRect {
            x0: 0,
            y0: 0,
            x1: w,
            y1: h,
        };
        // `apply` works in bands of rows: the same bytes as the frame in one piece.
        assert!(
            out == sensor::develop(&rgba, w, h, &draw, whole, true),
            "{name}"
        );
        let clean = |r: PixelRect| sensor::develop(&rgba, w, h, &draw, r, false);
        let full = clean(PixelRect {
            x0: 0,
            y0: 0,
            x1: w,
            y1: h,
        });
        // A window of the noise-free image is exactly those pixels of the whole one.
        let r = PixelRect {
            x0: 20,
            y0: 9,
            x1: 33,
            y1: 30,
        };
        let part = clean(r);
        for y in r.y0..r.y1 {
            let a = &full[((y * w + r.x0) * 4) as usize..((y * w + r.x1) * 4) as usize];
            let b = &part[((y - r.y0) * (r.x1 - r.x0) * 4) as usize..][..a.len()];
            assert_eq!(a, b, "{name}: row {y}");
        }
        match name {
            "white" | "black" => {
                // A flat mid-grey frame clips to white at +10 EV and to black at −10 EV.
                let grey = sensor::apply(&flat(w, h, 100), w, h, &draw);
                let v = if name == "white" { 255 } else { 0 };
                assert!(grey.chunks(4).all(|p| p[..3] == [v, v, v]), "{name}");
            }
            "1 px sensor" => assert!(full.chunks(4).all(|p| p[..3] == full[..3]), "one value"),
            "zero noise" => assert_eq!(out, rgba),
            _ => {}
        }
    }
}

#[test]
fn draws_follow_the_ranges_and_the_seed() {
    let model = CameraModel {
        exposure_ev: (-1.0, 1.0),
        psf: Psf::Gaussian {
            sigma_px: (0.5, 1.5),
        },
        read_noise_levels: (2.0, 2.0),
        jpeg_quality: Some((60, 95)),
        ..CameraModel::default()
    };
    let draws: Vec<CameraDraw> = (0..200).map(|i| sensor::draw(&model, 7, i)).collect();
    assert!(draws.iter().all(|d| (-1.0..=1.0).contains(&d.exposure_ev)));
    assert!(draws.iter().all(|d| d.read_noise_levels == 2.0));
    assert!(
        draws
            .iter()
            .all(|d| d.jpeg_quality.is_some_and(|q| (60..=95).contains(&q)))
    );
    assert!(
        draws.iter().any(|d| d.exposure_ev > 0.5) && draws.iter().any(|d| d.exposure_ev < -0.5)
    );
    assert_eq!(draws[3], sensor::draw(&model, 7, 3));
    assert_ne!(draws[3], sensor::draw(&model, 8, 3));
    assert_ne!(draws[3].noise_seed, draws[4].noise_seed);
}

#[test]
fn invalid_ranges_are_named() {
    let mut p = Preset::default();
    p.camera_model = Some(CameraModel {
        exposure_ev: (1.0, -1.0),
        psf: Psf::Disc {
            radius_px: (0.0, 1000.0),
        },
        sensor_scale: Some((0.0, 0.5)),
        read_noise_levels: (f64::NAN, 1.0),
        recompress_quality: Some((0, 50)),
        sharpen: (0.0, 9.0),
        ..CameraModel::default()
    });
    let errors = p.validate().expect_err("invalid");
    let fields: Vec<&str> = errors.iter().map(|e| e.field.as_str()).collect();
    for f in [
        "camera_model.exposure_ev",
        "camera_model.psf.radius_px",
        "camera_model.sensor_scale",
        "camera_model.read_noise_levels",
        "camera_model.recompress_quality",
        "camera_model.sharpen",
    ] {
        assert!(fields.contains(&f), "{f} missing from {fields:?}");
    }
    // And the RON spelling parses.
    let text = r#"(camera_model: Some((exposure_ev: (-0.5, 0.5), psf: Gaussian(sigma_px: (0.6, 1.2)),
        read_noise_levels: (1.0, 2.0), jpeg_quality: Some((70, 90)))))"#;
    let p = Preset::from_ron(text).expect("parses");
    assert!(p.validate().is_ok());
    assert!(Preset::from_ron("(camera_model: Some((exposure: (0.0, 0.0))))").is_err());
}

/// One drone, labelled by its visible box, through a blurring, noisy camera.
fn blurred_preset(sigma_px: f64) -> Preset {
    let mut p = common::single_drone_preset(1.5);
    p.camera_model = Some(CameraModel {
        psf: Psf::Gaussian {
            sigma_px: (sigma_px, sigma_px),
        },
        exposure_ev: (0.3, 0.3),
        vignetting: (0.2, 0.2),
        ca_red_scale: (1.002, 1.002),
        read_noise_levels: (2.0, 2.0),
        ..CameraModel::default()
    });
    p
}

/// The visible box under the camera model is the box of the pixels where the
/// noise-free camera image of the frame differs by ≥ 1 level from that of the
/// same frame without its drone, under the same draws.
#[test]
fn visible_boxes_under_blur_are_the_pixels_a_drone_changes() {
    let ctx = common::gpu();
    let (mut checked, mut invisible) = (0, 0);
    for sigma_px in [0.0, 1.5, 6.0, 40.0] {
        for exposure in [0.3, -10.0, 10.0] {
            let mut p = blurred_preset(sigma_px);
            if let Some(c) = &mut p.camera_model {
                c.exposure_ev = (exposure, exposure);
            }
            let pipeline = swarmshot::pipeline::FramePipeline::new(p.clone()).expect("pipeline");
            let mut renderer = pipeline.renderer(&ctx);
            for index in 0..p.frame_count() {
                let frame = pipeline.make(&mut renderer, index).expect("frame");
                let draw = frame.scene.camera_model.expect("drawn");
                let w = frame.scene.camera.width;
                // The same scene as the renderer draws it (at the camera's
                // exposure), with and without its drone, then the rest of the camera.
                let msaa = p.render.msaa;
                let a = common::camera_image(&mut renderer, &frame.scene, msaa, &draw);
                let mut empty = frame.scene.clone();
                empty.drones.clear();
                let b = common::camera_image(&mut renderer, &empty, msaa, &draw);
                // The rendered labels: the scene without the camera model.
                let mut plain = frame.scene.clone();
                plain.camera_model = None;
                let plain = pipeline.make_scene(&mut renderer, plain).expect("plain");
                let truth = common::changed_box(&a, &b, w);
                let label = &frame.labels[0];
                let vis = label.visibility.expect("measured");
                let case = format!("σ {sigma_px}, EV {exposure}, frame {index}");
                match truth {
                    Some((r, n)) => {
                        let b = vis.visible_box.expect(&case);
                        assert_eq!(
                            [b.x0, b.y0, b.x1, b.y1],
                            [r.x0, r.y0, r.x1, r.y1].map(f64::from),
                            "{case}"
                        );
                        assert_eq!(vis.visible_pixels, n, "{case}");
                        assert!(label.is_kept(), "{case}");
                        assert_eq!(label.bbox, b, "{case}");
                    }
                    None => {
                        invisible += 1;
                        assert_eq!(vis.visible_box, None, "{case}");
                        assert_eq!(vis.visible_pixels, 0, "{case}");
                        assert!(!label.is_kept(), "{case}: an invisible drone is dropped");
                    }
                }
                if sigma_px < 10.0 && exposure == 0.3 {
                    assert!(truth.is_some(), "{case}: a visible drone");
                }
                // Blur spreads the drone: at a normal exposure its camera box holds the rendered one.
                if exposure != 0.3 {
                } else if let (Some((r, _)), Some(rb)) = (
                    truth,
                    plain.labels[0].visibility.and_then(|v| v.visible_box),
                ) {
                    assert!(
                        f64::from(r.x0) <= rb.x0 && f64::from(r.x1) >= rb.x1,
                        "{case}"
                    );
                }
                // The amodal box stays geometric.
                assert_eq!(label.amodal, plain.labels[0].amodal, "{case}");
                checked += 1;
            }
        }
    }
    assert!(checked >= 8);
    // Some draws hide the drone below one level (a dark exposure, a huge blur).
    assert!(
        invisible > 0 && invisible < checked,
        "{invisible} of {checked}"
    );
}

fn camera_preset() -> Preset {
    let mut p = common::tiny_preset();
    p.labels.box_method = BoxMethod::Visible;
    p.output.image_format = swarmshot::preset::ImageFormat::Jpeg { quality: 85 };
    p.camera_model = Some(CameraModel {
        exposure_ev: (-0.5, 0.5),
        white_balance_red: (0.9, 1.1),
        psf: Psf::Gaussian {
            sigma_px: (0.5, 1.5),
        },
        vignetting: (0.0, 0.3),
        ca_blue_scale: (0.998, 1.002),
        shot_noise_gain: (0.0, 0.05),
        read_noise_levels: (0.5, 2.0),
        sensor_scale: Some((0.6, 0.9)),
        jpeg_quality: Some((60, 95)),
        recompress_quality: Some((70, 90)),
        ..CameraModel::default()
    });
    p
}

#[test]
fn the_stage_gives_the_same_bytes_on_1_and_3_threads() {
    let p = camera_preset();
    let ctx = common::gpu();
    let pipeline = swarmshot::pipeline::FramePipeline::new(p.clone()).expect("pipeline");
    let mut renderer = pipeline.renderer(&ctx);
    let frame = pipeline.make(&mut renderer, 1).expect("frame");
    let mut plain = frame.scene.clone();
    plain.camera_model = None;
    let raw = pipeline.make_scene(&mut renderer, plain).expect("plain");
    let draw = frame.scene.camera_model.expect("drawn");
    let (w, h) = (frame.scene.camera.width, frame.scene.camera.height);
    let on = |n: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build()
            .expect("pool")
            .install(|| sensor::apply(&raw.rgba, w, h, &draw))
    };
    let one = on(1);
    assert_eq!(one, on(3));
    assert_ne!(one, raw.rgba, "the camera changed the picture");
}

#[test]
fn batches_with_the_camera_model_are_deterministic_and_frame_equals_batch() {
    use std::sync::atomic::AtomicBool;
    use swarmshot::pipeline::{BatchOptions, FramePipeline, run_batch};
    let p = camera_preset();
    let ctx = common::gpu();
    let pipeline = FramePipeline::new(p.clone()).expect("pipeline");
    let (a, b) = (
        tempfile::tempdir().expect("dir"),
        tempfile::tempdir().expect("dir"),
    );
    run_batch(
        &pipeline,
        &BatchOptions::new(a.path()),
        &ctx,
        &AtomicBool::new(false),
        |_| {},
    )
    .expect("batch");
    let mut options = BatchOptions::new(b.path());
    options.makers = 3;
    options.encoder_threads = 2;
    run_batch(&pipeline, &options, &ctx, &AtomicBool::new(false), |_| {}).expect("batch");
    let manifest = std::fs::read_to_string(a.path().join("manifest.jsonl")).expect("manifest");
    assert_eq!(
        manifest,
        std::fs::read_to_string(b.path().join("manifest.jsonl")).expect("manifest")
    );
    let mut renderer = pipeline.renderer(&ctx);
    let mut qualities = std::collections::BTreeSet::new();
    for index in 0..p.frame_count() {
        let frame = pipeline.make(&mut renderer, index).expect("frame");
        let format = pipeline.image_format(&frame.scene);
        let swarmshot::preset::ImageFormat::Jpeg { quality } = format else {
            panic!("JPEG")
        };
        qualities.insert(quality);
        let (w, h) = (frame.scene.camera.width, frame.scene.camera.height);
        let bytes = swarmshot::write::encode_image(&frame.rgba, w, h, format).expect("encode");
        let rel = swarmshot::write::image_rel_path(&frame.scene, format);
        let (x, y) = (
            std::fs::read(a.path().join(&rel)).expect("image"),
            std::fs::read(b.path().join(&rel)).expect("image"),
        );
        assert!(x == bytes, "frame {index}: `frame` differs from the batch");
        assert!(x == y, "frame {index}: differs between runs");
        // The manifest records the draws.
        let line = manifest.lines().nth(index as usize).expect("line");
        let record: serde_json::Value = serde_json::from_str(line).expect("json");
        assert_eq!(
            record["camera_model"]["jpeg_quality"].as_u64(),
            Some(u64::from(quality))
        );
    }
    assert!(
        qualities.len() > 1,
        "the quality is drawn per frame: {qualities:?}"
    );
}

#[test]
fn the_camera_model_leaves_the_scene_draws_alone() {
    let mut p = common::tiny_preset();
    let off: Vec<_> = (0..p.frame_count())
        .map(|i| swarmshot::scene::build_frame(&p, i).expect("frame"))
        .collect();
    p.camera_model = Some(CameraModel::default());
    for (i, a) in off.iter().enumerate() {
        let mut b = swarmshot::scene::build_frame(&p, i as u64).expect("frame");
        assert!(b.camera_model.is_some());
        b.camera_model = None;
        assert_eq!(a, &b);
    }
}

/// The exposure scales the light before anything clips: under −1 EV a drone
/// brighter than white (lit drones, emission 3× a white albedo) still reaches
/// white, while the sky (never above white) takes half its light. Were the
/// exposure applied after an 8-bit picture clipped at white, nothing could
/// pass sRGB 188 (half of white's light).
#[test]
fn a_negative_exposure_keeps_the_headroom_of_surfaces_brighter_than_white() {
    let ctx = common::gpu();
    // A gradient sky (drawn and exposed by the sky shader) and a procedural
    // one (upsampled on the CPU, then exposed by a table).
    for sky in [
        swarmshot::preset::Sky::default(),
        swarmshot::preset::Sky::procedural(swarmshot::preset::EnvironmentName::Daytime),
    ] {
        headroom_under(&ctx, sky);
    }
}

fn headroom_under(ctx: &swarmshot::render::GpuContext, sky: swarmshot::preset::Sky) {
    use swarmshot::preset::appearance::{Appearance, DroneColor};
    let mut p = common::tiny_preset();
    p.sky = sky;
    p.appearance = Some(Appearance {
        palette: vec![(DroneColor::White, 1.0)],
        emissive_share: 1.0,
        emissive_strength: (3.0, 3.0),
        ..Appearance::default()
    });
    let at = |ev: f64| {
        let mut p = p.clone();
        p.camera_model = Some(CameraModel {
            exposure_ev: (ev, ev),
            ..CameraModel::default()
        });
        let pipeline = swarmshot::pipeline::FramePipeline::new(p).expect("pipeline");
        let mut renderer = pipeline.renderer(ctx);
        pipeline.make(&mut renderer, 0).expect("frame")
    };
    let (bright, dark) = (at(0.0), at(-1.0));
    let w = bright.scene.camera.width as usize;
    // The drones' pixels: those the ids pass gave a drone, here the labelled boxes' insides.
    let brightest_in_boxes = |f: &swarmshot::pipeline::Frame| {
        let mut max = 0u8;
        for l in &f.labels {
            let b = l.visibility.and_then(|v| v.visible_box).expect("visible");
            for y in b.y0 as usize..b.y1 as usize {
                for x in b.x0 as usize..b.x1 as usize {
                    let px = &f.rgba[(y * w + x) * 4..][..3];
                    max = max.max(*px.iter().max().unwrap_or(&0));
                }
            }
        }
        max
    };
    assert_eq!(brightest_in_boxes(&bright), 255);
    assert_eq!(
        brightest_in_boxes(&dark),
        255,
        "a surface 3× brighter than white clips at white under −1 EV too"
    );
    // The sky, far from every box, takes half its light: sRGB 255 · srgb(0.5 · linear(c / 255)).
    let (x, y) = (2usize, 2usize);
    let inside = |f: &swarmshot::pipeline::Frame| {
        f.labels.iter().any(|l| {
            l.visibility.and_then(|v| v.visible_box).is_some_and(|b| {
                (b.x0 - 2.0..b.x1 + 2.0).contains(&(x as f64))
                    && (b.y0 - 2.0..b.y1 + 2.0).contains(&(y as f64))
            })
        })
    };
    assert!(!inside(&bright) && !inside(&dark));
    let (linear, srgb) = (common::srgb_decode, common::srgb_encode);
    for c in 0..3 {
        let (b, d) = (
            bright.rgba[(y * w + x) * 4 + c],
            dark.rgba[(y * w + x) * 4 + c],
        );
        let want = (srgb(0.5 * linear(b)) * 255.0).round();
        assert!(
            (f64::from(d) - want).abs() <= 1.0,
            "channel {c}: {d} under −1 EV, {b} at 0 EV (want {want})"
        );
    }
}

/// A sky that stays the same under an exposure drawn per frame is drawn once
/// and re-exposed for each frame, not drawn again; each frame's sky still
/// takes its own exposure.
#[test]
fn a_static_sky_under_an_exposure_range_is_drawn_once() {
    let ctx = common::gpu();
    let mut p = common::tiny_preset();
    p.camera_model = Some(CameraModel {
        exposure_ev: (-1.5, 0.0),
        ..CameraModel::default()
    });
    let pipeline = swarmshot::pipeline::FramePipeline::new(p.clone()).expect("pipeline");
    let mut renderer = pipeline.renderer(&ctx);
    let mut plain = p.clone();
    plain.camera_model = None;
    let plain_pipeline = swarmshot::pipeline::FramePipeline::new(plain).expect("pipeline");
    let mut plain_renderer = plain_pipeline.renderer(&ctx);
    let n = p.frame_count().min(4);
    assert!(n >= 3);
    let mut exposures = Vec::new();
    for index in 0..n {
        let frame = pipeline.make(&mut renderer, index).expect("frame");
        let clean = plain_pipeline
            .make(&mut plain_renderer, index)
            .expect("clean");
        let ev = frame.scene.camera_model.expect("drawn").exposure_ev;
        exposures.push(ev);
        // A sky pixel in the top-left corner, clear of the drones.
        let (b, d) = (clean.rgba[0], frame.rgba[0]);
        let want = (common::srgb_encode(2f64.powf(ev) * common::srgb_decode(b)) * 255.0).round();
        assert!(
            (f64::from(d) - want).abs() <= 1.0,
            "frame {index}: {d}, want {want}"
        );
    }
    assert!(exposures.windows(2).all(|w| w[0] != w[1]), "{exposures:?}");
    assert_eq!(
        renderer.background_draws(),
        1,
        "drawn once, re-exposed after"
    );
}

/// The mean luminance level (Rec. 601 on the sRGB bytes, as `swarmshot gap`
/// measures brightness) of an RGBA frame.
fn mean_level(rgba: &[u8]) -> f64 {
    let sum: f64 = rgba
        .chunks_exact(4)
        .map(|p| 0.299 * f64::from(p[0]) + 0.587 * f64::from(p[1]) + 0.114 * f64::from(p[2]))
        .sum();
    sum / (rgba.len() / 4) as f64
}

/// Auto-exposure meters each frame's background to its target: across the
/// seven environments, sun heights, cloud, haze and camera elevations from
/// the horizon in view to sky only, every frame's mean level lands within a
/// few levels of the target (the meter's sky is the renderer's), where the
/// fixed exposure spreads the same frames widely; the frame is drawn at the
/// metered EV the scene records.
#[test]
fn auto_exposure_brings_each_frame_to_its_target_level() {
    use swarmshot::pipeline::FramePipeline;
    use swarmshot::preset::atmosphere::Atmosphere;
    use swarmshot::preset::observer::ObserverCamera;
    use swarmshot::preset::{EnvironmentName, Placement, Sky, Volume};
    let ctx = common::gpu();
    let preset = |auto_exposure: Option<(f64, f64)>| {
        let mut p = common::tiny_preset();
        p.placement = Placement::Randomized {
            count: (1, 1),
            count_distribution: Default::default(),
            volume: Volume::Box {
                size_m: (1.0, 1.0, 1.0),
            },
            min_separation_m: 0.5,
        };
        p.repeats = 3;
        p.sky = Sky::Random {
            choices: EnvironmentName::ALL
                .iter()
                .map(|&e| Sky::procedural(e))
                .collect(),
            azimuth_offset_deg: (0.0, 360.0),
            sun_elevation_deg: Some((10.0, 60.0)),
            cloud_cover: Some((0.0, 0.4)),
            exposure_ev: None,
            sun_ev: None,
        };
        p.camera.observer = Some(ObserverCamera {
            elevation_deg: (0.0, 30.0),
            distance_m: (400.0, 400.0),
            ..ObserverCamera::default()
        });
        p.atmosphere = Some(Atmosphere {
            visibility_m: (4000.0, 40000.0),
        });
        p.camera_model = Some(CameraModel {
            auto_exposure,
            ..CameraModel::default()
        });
        p
    };
    let levels = |p: Preset| {
        let pipeline = FramePipeline::new(p).expect("pipeline");
        let mut renderer = pipeline.renderer(&ctx);
        (0..pipeline.frame_count())
            .map(|i| {
                let frame = pipeline.make(&mut renderer, i).expect("frame");
                (mean_level(&frame.rgba), frame.scene.camera_model)
            })
            .collect::<Vec<_>>()
    };
    let fixed = levels(preset(None));
    let metered = levels(preset(Some((120.0, 120.0))));
    assert_eq!(metered.len(), 12);
    let spread = |v: &[(f64, Option<CameraDraw>)]| {
        let (lo, hi) = v.iter().fold((f64::MAX, f64::MIN), |(lo, hi), (m, _)| {
            (lo.min(*m), hi.max(*m))
        });
        hi - lo
    };
    assert!(spread(&fixed) > 20.0, "fixed exposure: {fixed:?}");
    let mut evs = Vec::new();
    for (level, draw) in &metered {
        assert!(
            (level - 120.0).abs() < 3.0,
            "metered frame at {level:.1}: {metered:?}"
        );
        let auto = draw
            .and_then(|d| d.auto_exposure)
            .expect("auto-exposure drawn");
        assert_eq!(auto.target_level, 120.0);
        // On the 1/64-stop grid, and what the frame was drawn at.
        assert_eq!((auto.metered_ev * 64.0).fract(), 0.0, "{auto:?}");
        assert_eq!(draw.map(|d| d.total_ev()), Some(auto.metered_ev));
        evs.push(auto.metered_ev);
    }
    evs.sort_by(f64::total_cmp);
    assert!(
        evs[evs.len() - 1] - evs[0] > 0.5,
        "one EV for every frame: {evs:?}"
    );
}

/// Auto-exposure's target is an 8-bit level: outside [1, 254] the preset is
/// refused naming `camera_model.auto_exposure`; every kind of sky is metered.
#[test]
fn auto_exposure_refuses_a_level_outside_the_encoding() {
    use swarmshot::preset::{Sky, SkyImageSource};
    let mut p = common::tiny_preset();
    p.camera_model = Some(CameraModel {
        auto_exposure: Some((120.0, 120.0)),
        ..CameraModel::default()
    });
    p.validate().expect("a gradient sky is metered");
    let mut image = p.clone();
    image.sky = Sky::Image {
        source: SkyImageSource::Builtin("forest".into()),
        exposure_ev: 0.0,
        rotation_deg: 0.0,
        sun_elevation_deg: 40.0,
        sun_azimuth_deg: 0.0,
    };
    image.validate().expect("an image sky is metered");
    for level in [
        (0.0, 120.0),
        (120.0, 300.0),
        (130.0, 120.0),
        (f64::NAN, 1.0),
    ] {
        let mut bad = p.clone();
        if let Some(c) = &mut bad.camera_model {
            c.auto_exposure = Some(level);
        }
        let errors = bad.validate().expect_err("invalid");
        assert!(
            errors
                .iter()
                .any(|e| e.field == "camera_model.auto_exposure"),
            "{level:?}: {errors:?}"
        );
    }
}

/// The meter's picture is the renderer's: along the meter's grid of rays,
/// its samples of a drone-free frame's background (a procedural environment
/// with clouds and haze, a gradient sky, an HDR image sky turned and exposed,
/// a cube map with a split on every face) match the rendered pixels there,
/// all but a few rays within a few levels.
#[test]
fn the_meters_samples_are_the_rendered_background() {
    use swarmshot::pipeline::FramePipeline;
    use swarmshot::preset::atmosphere::Atmosphere;
    use swarmshot::preset::observer::ObserverCamera;
    use swarmshot::preset::{EnvironmentName, Sky, SkyImageSource};
    use swarmshot::sky::{FrameSky, meter};
    let ctx = common::gpu();
    let dir = tempfile::tempdir().expect("tempdir");
    // Cube faces split left/right into two colours, each face its own pair.
    let face = |name: &str, k: u8| {
        let path = dir.path().join(format!("{name}.png"));
        let img = image::RgbImage::from_fn(32, 32, |x, y| {
            let base = 40 * k;
            image::Rgb(if x < 16 {
                [base, 200 - base, 90]
            } else if y < 16 {
                [220, base, 250 - base]
            } else {
                [30, 30 + base, 120]
            })
        });
        img.save(&path).expect("face");
        path
    };
    let cube = SkyImageSource::Cubemap {
        px: face("px", 0),
        nx: face("nx", 1),
        py: face("py", 2),
        ny: face("ny", 3),
        pz: face("pz", 4),
        nz: face("nz", 5),
    };
    let image = |source: SkyImageSource, rotation_deg: f64, exposure_ev: f64| Sky::Image {
        source,
        exposure_ev,
        rotation_deg,
        sun_elevation_deg: 40.0,
        sun_azimuth_deg: 0.0,
    };
    let mut procedural = Sky::procedural(EnvironmentName::Tellsplatte);
    if let Sky::Procedural { cloud_cover, .. } = &mut procedural {
        *cloud_cover = Some(0.4);
    }
    let skies = [
        procedural,
        Sky::default(),
        image(SkyImageSource::Builtin("quarry_01".into()), 70.0, -0.5),
        image(cube, 30.0, 0.0),
    ];
    for sky in skies {
        let mut p = common::tiny_preset();
        p.sky = sky.clone();
        p.atmosphere = Some(Atmosphere {
            visibility_m: (8000.0, 8000.0),
        });
        p.camera.observer = Some(ObserverCamera {
            elevation_deg: (-10.0, 25.0),
            distance_m: (300.0, 300.0),
            ..ObserverCamera::default()
        });
        let pipeline = FramePipeline::new(p).expect("pipeline");
        let mut renderer = pipeline.renderer(&ctx);
        let mut diffs = Vec::new();
        for i in 0..4 {
            let mut scene = pipeline.scene(i).expect("scene");
            scene.drones.clear();
            let view = scene.camera.meter_view();
            let visibility = scene.atmosphere.map(|a| a.visibility_m);
            let samples = match scene.sky {
                FrameSky::Image {
                    image,
                    exposure,
                    rotation_deg,
                } => meter::image_samples(
                    &pipeline.assets().sky.images[image],
                    exposure,
                    rotation_deg,
                    &view,
                ),
                _ => meter::background_samples(&scene.sky, &scene.environment, &view, visibility)
                    .expect("metered"),
            };
            let (w, h) = (view.width, view.height);
            let frame = pipeline.make_scene(&mut renderer, scene).expect("frame");
            let (cols, rows) = meter::GRID;
            for (k, sample) in samples.iter().enumerate() {
                let (i, j) = (k as u32 % cols, k as u32 / cols);
                let x = (2 * i + 1) * w / (2 * cols);
                let y = (2 * j + 1) * h / (2 * rows);
                let px = ((y * w + x) * 4) as usize;
                for ch in 0..3 {
                    let want = linear_to_srgb(f64::from(sample[ch]).min(1.0));
                    diffs.push((want - f64::from(frame.rgba[px + ch])).abs());
                }
            }
        }
        diffs.sort_by(f64::total_cmp);
        let at = |q: f64| diffs[((diffs.len() - 1) as f64 * q) as usize];
        assert!(
            at(0.5) <= 1.0 && at(0.9) <= 4.0,
            "{sky:?}: median {} levels, 90th percentile {}",
            at(0.5),
            at(0.9)
        );
    }
}
