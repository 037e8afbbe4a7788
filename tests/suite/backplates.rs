//! Photographic backgrounds (`backplate:`, issue 21 item 4): the plate is the
//! frame's background pixel for pixel where no drone is, the camera agrees
//! with the plate's field of view and horizon, the visible boxes are the
//! pixels the drones change against it, the draw is deterministic, and bad
//! folders or files are refused naming them before anything is written.

use crate::common;

use std::os::unix::ffi::OsStrExt;
use std::path::{Path, PathBuf};

use glam::DVec3;
use swarmshot::pipeline::FramePipeline;
use swarmshot::preset::backplate::{Backplate, PlateHorizon};
use swarmshot::preset::{Placement, Preset, Resolution, Volume};

/// The output size of the tests' frames, and the rows a plate loses above it.
const W: u32 = 640;
const H: u32 = 360;
const CROP: u32 = 76;

/// The four CC0 plates (640×512) of tests/data/plates.
fn plates_dir() -> PathBuf {
    common::testdata("plates")
}

/// A 640×360 preset over the test plates (a 640×512 plate covers it by
/// dropping 76 rows above and below: no resampling, so the expected
/// background is the decoded plate's rows 76..436).
fn plate_preset(folder: &Path, count: (u32, u32)) -> Preset {
    let mut p = common::tiny_preset();
    p.placement = Placement::Randomized {
        count,
        count_distribution: Default::default(),
        volume: Volume::Box {
            size_m: (6.0, 3.0, 6.0),
        },
        min_separation_m: 0.7,
    };
    p.render.resolution = Resolution::Custom {
        width: W,
        height: H,
    };
    p.camera.observer = Some(swarmshot::preset::observer::ObserverCamera {
        distance_m: (15.0, 30.0),
        ..Default::default()
    });
    p.repeats = 6;
    // Every drone keeps its label (the tests compare pixels with boxes).
    p.labels.min_box_px = 0.0;
    p.backplate = Some(Backplate {
        folder: folder.to_owned(),
        hfov_deg: 50.0,
        ..Default::default()
    });
    p
}

/// The plate as the frame must show it, decoded here independently: rows 76..436, mirrored if asked.
fn expected_background(file: &str, flip: bool) -> Vec<u8> {
    let img = image::open(plates_dir().join(file))
        .expect("plate decodes")
        .to_rgba8();
    assert_eq!(img.dimensions(), (640, 512));
    let mut out = Vec::with_capacity((W * H * 4) as usize);
    for y in CROP..CROP + H {
        for x in 0..W {
            let sx = if flip { W - 1 - x } else { x };
            out.extend_from_slice(&img.get_pixel(sx, y).0);
        }
    }
    out
}

#[test]
fn plate_frames_show_the_plate_where_no_drone_is_and_it_is_the_drone_free_background() {
    let ctx = common::gpu();
    for msaa in [1, 4] {
        let mut preset = plate_preset(&plates_dir(), (2, 4));
        preset.render.msaa = msaa;
        shows_the_plate(&ctx, preset);
    }
}

fn shows_the_plate(ctx: &swarmshot::render::GpuContext, preset: Preset) {
    let pipeline = FramePipeline::new(preset).expect("pipeline");
    let mut renderer = pipeline.renderer(ctx);
    let mut flips = [false; 2];
    for index in 0..6 {
        let frame = pipeline.make(&mut renderer, index).expect("frame");
        let plate = frame.scene.backplate.clone().expect("a plate frame");
        flips[usize::from(plate.flip)] = true;
        let want = expected_background(&plate.file, plate.flip);
        let background = renderer
            .background_pixels(&frame.painted)
            .expect("the background of a plate frame is known");
        assert!(
            background == want.as_slice(),
            "frame {index}: background ≠ plate"
        );
        // Every pixel outside the drones' (amodal) boxes, one pixel of margin, is the plate's.
        let boxes: Vec<_> = frame.labels.iter().map(|l| l.amodal).collect();
        let mut outside = 0;
        for y in 0..H as usize {
            for x in 0..W as usize {
                let near = boxes.iter().any(|b| {
                    x as f64 + 1.0 >= b.x0 - 1.0
                        && (x as f64) <= b.x1 + 1.0
                        && y as f64 + 1.0 >= b.y0 - 1.0
                        && (y as f64) <= b.y1 + 1.0
                });
                if !near {
                    let i = (y * W as usize + x) * 4;
                    assert_eq!(
                        frame.rgba[i..i + 4],
                        want[i..i + 4],
                        "frame {index}: pixel ({x}, {y}) outside every drone"
                    );
                    outside += 1;
                }
            }
        }
        assert!(
            outside > (W * H / 2) as usize,
            "frame {index}: {outside} pixels compared"
        );
        // And the drones did paint something.
        assert!(frame.rgba != want, "frame {index}: no drone drawn");
    }
    assert!(flips[0] || flips[1]);
}

#[test]
fn visible_boxes_on_plates_are_exactly_the_pixels_the_drone_changes() {
    let ctx = common::gpu();
    let pipeline = FramePipeline::new(plate_preset(&plates_dir(), (1, 1))).expect("pipeline");
    let mut renderer = pipeline.renderer(&ctx);
    let mut checked = 0;
    for index in 0..8 {
        let frame = pipeline.make(&mut renderer, index).expect("frame");
        let background = renderer
            .background_pixels(&frame.painted)
            .expect("background");
        let (mut x0, mut y0, mut x1, mut y1) = (u32::MAX, u32::MAX, 0, 0);
        for (i, (a, b)) in frame
            .rgba
            .chunks_exact(4)
            .zip(background.chunks_exact(4))
            .enumerate()
        {
            if a != b {
                let (x, y) = (i as u32 % W, i as u32 / W);
                (x0, y0, x1, y1) = (x0.min(x), y0.min(y), x1.max(x + 1), y1.max(y + 1));
            }
        }
        let Some(label) = frame.labels.first() else {
            assert_eq!(x0, u32::MAX, "frame {index}: pixels changed but no label");
            continue;
        };
        let b = label.bbox;
        assert_eq!(
            (b.x0, b.y0, b.x1, b.y1),
            (x0.into(), y0.into(), x1.into(), y1.into()),
            "frame {index}: visible box vs changed pixels"
        );
        checked += 1;
    }
    assert!(checked >= 5, "only {checked} frames had a visible drone");
}

#[test]
fn the_camera_has_the_plates_field_of_view_and_sees_the_horizon_on_its_row() {
    let pipeline = FramePipeline::new(plate_preset(&plates_dir(), (2, 4))).expect("pipeline");
    for index in 0..12 {
        let scene = pipeline.scene(index).expect("scene");
        let plate = scene.backplate.clone().expect("plate");
        let cam = &scene.camera;
        // No columns are cropped (640 of 640): the horizontal field of view is the plate's.
        let hfov = 2.0 * (f64::from(W / 2) / cam.focal_px()).atan().to_degrees();
        assert!((hfov - 50.0).abs() < 1e-9, "frame {index}: hfov {hfov}");
        // The sidecar's row, minus the cropped rows.
        let row: f64 =
            std::fs::read_to_string(plates_dir().join(plate.file.replace(".jpg", ".plate.ron")))
                .expect("sidecar")
                .split("Row(")
                .nth(1)
                .and_then(|s| s.split(')').next())
                .and_then(|s| s.parse().ok())
                .expect("a Row(..) in the sidecar");
        let want_v = row * 512.0 - f64::from(CROP);
        assert!((plate.horizon_row_px.expect("row") - want_v).abs() < 1e-9);
        // A far point on the horizon straight ahead projects onto that row.
        let ahead = scene.look_at - cam.position;
        let flat = DVec3::new(ahead.x, 0.0, ahead.z).normalize();
        let far = DVec3::new(cam.position.x, 0.0, cam.position.z) + flat * 1e7;
        let p = cam
            .project_camera_point(cam.camera_from_world_point(far))
            .expect("ahead of the camera");
        assert!(
            (p.y - want_v).abs() < 0.01,
            "frame {index}: v {} vs {want_v}",
            p.y
        );
        assert!(
            (p.x - f64::from(W / 2)).abs() < 0.01,
            "frame {index}: u {}",
            p.x
        );
    }
}

#[test]
fn the_plate_draw_is_deterministic_and_a_frame_made_alone_equals_the_batchs() {
    let ctx = common::gpu();
    let preset = plate_preset(&plates_dir(), (2, 4));
    let a = FramePipeline::new(preset.clone()).expect("pipeline");
    let b = FramePipeline::new(preset.clone()).expect("pipeline");
    let mut files = std::collections::BTreeSet::new();
    let mut flips = std::collections::BTreeSet::new();
    for index in 0..preset.frame_count().min(40) {
        let (sa, sb) = (a.scene(index).expect("a"), b.scene(index).expect("b"));
        assert_eq!(sa, sb);
        let p = sa.backplate.expect("plate");
        files.insert(p.file);
        flips.insert(p.flip);
    }
    assert!(files.len() >= 3, "{files:?}");
    assert_eq!(flips.len(), 2);
    // Frames 0..4 in order on one renderer; frame 3 alone on a fresh one.
    let mut in_order = a.renderer(&ctx);
    let batch: Vec<_> = (0..4)
        .map(|i| a.make(&mut in_order, i).expect("frame").rgba)
        .collect();
    let mut fresh = b.renderer(&ctx);
    assert!(b.make(&mut fresh, 3).expect("frame").rgba == batch[3]);
    // Another seed draws other plates.
    let mut other = preset.clone();
    other.seed += 1;
    let c = FramePipeline::new(other).expect("pipeline");
    let differs = (0..8).any(|i| {
        c.scene(i).expect("c").backplate.map(|p| (p.file, p.flip))
            != a.scene(i).expect("a").backplate.map(|p| (p.file, p.flip))
    });
    assert!(differs);
}

fn error_of(preset: Preset) -> String {
    match FramePipeline::new(preset) {
        Ok(_) => panic!("the pipeline should refuse this preset"),
        Err(e) => e.to_string(),
    }
}

/// A PNG whose header says `w`×`h` (its pixel data is missing).
pub(crate) fn png_header(w: u32, h: u32) -> Vec<u8> {
    fn crc(bytes: &[u8]) -> u32 {
        let mut c = 0xFFFF_FFFFu32;
        for &b in bytes {
            c ^= u32::from(b);
            for _ in 0..8 {
                c = if c & 1 != 0 {
                    0xEDB8_8320 ^ (c >> 1)
                } else {
                    c >> 1
                };
            }
        }
        !c
    }
    let mut ihdr = b"IHDR".to_vec();
    ihdr.extend(w.to_be_bytes());
    ihdr.extend(h.to_be_bytes());
    ihdr.extend([8, 2, 0, 0, 0]);
    let mut out = b"\x89PNG\r\n\x1a\n".to_vec();
    out.extend(13u32.to_be_bytes());
    out.extend(&ihdr);
    out.extend(crc(&ihdr).to_be_bytes());
    out.extend(0u32.to_be_bytes());
    out.extend(b"IDAT");
    out.extend(crc(b"IDAT").to_be_bytes());
    out
}

#[test]
fn bad_plate_folders_and_files_are_refused_naming_them() {
    let tmp = tempfile::tempdir().expect("tmp");
    let folder = |name: &str| {
        let d = tmp.path().join(name);
        std::fs::create_dir_all(&d).expect("mkdir");
        d
    };
    // Missing and empty folders name the folder.
    let missing = tmp.path().join("no-such-folder");
    let e = error_of(plate_preset(&missing, (1, 1)));
    assert!(
        e.contains("no-such-folder") && e.contains("backplate.folder"),
        "{e}"
    );
    let empty = folder("empty");
    std::fs::write(empty.join("README.txt"), "not a plate").expect("write");
    let e = error_of(plate_preset(&empty, (1, 1)));
    assert!(e.contains("empty") && e.contains("no .jpg"), "{e}");
    // A file that is not an image, a tiny image, a huge one: each named.
    let cases: [(&str, Vec<u8>, &str); 3] = [
        ("garbage.jpg", b"not a jpeg at all".to_vec(), "garbage.jpg"),
        ("tiny.png", Vec::new(), "smaller than the 64-pixel"),
        (
            "huge.png",
            png_header(20_000, 20_000),
            "larger than the 12000-pixel",
        ),
    ];
    for (name, bytes, reason) in cases {
        let d = folder(&format!("case-{name}"));
        let path = d.join(name);
        if name == "tiny.png" {
            image::RgbaImage::new(16, 16).save(&path).expect("png");
        } else {
            std::fs::write(&path, bytes).expect("write");
        }
        let e = error_of(plate_preset(&d, (1, 1)));
        assert!(e.contains(name) && e.contains(reason), "{name}: {e}");
    }
    // A bad sidecar names the sidecar.
    let d = folder("sidecar");
    std::fs::copy(plates_dir().join("V_DRONE_010.jpg"), d.join("a.jpg")).expect("copy");
    std::fs::write(d.join("a.plate.ron"), "(hfov_deg: 500.0)").expect("write");
    let e = error_of(plate_preset(&d, (1, 1)));
    assert!(e.contains("a.plate.ron") && e.contains("hfov_deg"), "{e}");
    // Validation names the field.
    let mut p = plate_preset(&plates_dir(), (1, 1));
    if let Some(b) = &mut p.backplate {
        b.hfov_deg = 0.0;
        b.horizon = PlateHorizon::Row(f64::NAN);
    }
    let e = error_of(p);
    assert!(
        e.contains("backplate.hfov_deg") && e.contains("backplate.horizon"),
        "{e}"
    );
}

#[test]
fn the_batch_refuses_a_bad_plate_before_writing_anything() {
    let tmp = tempfile::tempdir().expect("tmp");
    let plates = tmp.path().join("plates");
    std::fs::create_dir_all(&plates).expect("mkdir");
    std::fs::write(plates.join("broken.png"), b"\x89PNG\r\n\x1a\nbroken").expect("write");
    let preset = tmp.path().join("p.ron");
    std::fs::write(
        &preset,
        "(name: \"plates\", backplate: Some((folder: \"plates\")))",
    )
    .expect("write");
    let out = tmp.path().join("out");
    let run = std::process::Command::new(env!("CARGO_BIN_EXE_swarmshot"))
        .args(["batch", preset.to_str().expect("utf-8"), "--out"])
        .arg(&out)
        .output()
        .expect("run");
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(!run.status.success());
    assert!(stderr.contains("broken.png"), "{stderr}");
    assert!(!out.exists(), "the batch wrote {}", out.display());
}

fn builtin_sky(name: &str) -> swarmshot::preset::Sky {
    swarmshot::preset::Sky::Image {
        source: swarmshot::preset::SkyImageSource::Builtin(name.into()),
        exposure_ev: 0.0,
        rotation_deg: 0.0,
        sun_elevation_deg: 45.0,
        sun_azimuth_deg: 0.0,
    }
}

#[test]
fn builtin_photographic_skies_load_render_and_take_the_drawn_turn_and_exposure() {
    use swarmshot::sky::FrameSky;
    let ctx = common::gpu();
    let mean = |rgba: &[u8]| rgba.iter().map(|&c| f64::from(c)).sum::<f64>() / rgba.len() as f64;
    for (name, _) in swarmshot::preset::BUILTIN_SKIES {
        let mut p = common::tiny_preset();
        p.sky = swarmshot::preset::Sky::Random {
            choices: vec![builtin_sky(name)],
            azimuth_offset_deg: (0.0, 360.0),
            sun_elevation_deg: None,
            cloud_cover: None,
            exposure_ev: Some((-1.5, 1.5)),
            sun_ev: None,
        };
        let pipeline = FramePipeline::new(p).expect("pipeline");
        assert_eq!(pipeline.assets().sky.images.len(), 1, "{name}");
        let mut renderer = pipeline.renderer(&ctx);
        let mut draws = Vec::new();
        for index in 0..4 {
            let scene = pipeline.scene(index).expect("scene");
            let FrameSky::Image {
                exposure,
                rotation_deg,
                ..
            } = scene.sky
            else {
                panic!(
                    "{name}: frame {index} is not the image sky: {:?}",
                    scene.sky
                );
            };
            let ev = scene.environment.exposure_offset_ev;
            assert!((-1.5..=1.5).contains(&ev), "{name}: {ev}");
            assert!((f64::from(exposure) - 2f64.powf(ev)).abs() < 1e-5);
            assert_eq!(rotation_deg, scene.environment.azimuth_offset_deg);
            draws.push((ev, rotation_deg));
            // Brighter with more exposure: the same frame a stop darker and a stop brighter.
            let at = |renderer: &mut swarmshot::render::Renderer, k: f32| {
                let mut s = scene.clone();
                s.drones.clear();
                if let FrameSky::Image { exposure, .. } = &mut s.sky {
                    *exposure *= k;
                }
                mean(&pipeline.make_scene(renderer, s).expect("frame").rgba)
            };
            let (dark, bright) = (at(&mut renderer, 0.5), at(&mut renderer, 2.0));
            assert!(bright > dark + 2.0, "{name}: {dark} vs {bright}");
        }
        assert!(draws.windows(2).all(|w| w[0] != w[1]), "{name}: {draws:?}");
    }
    // An unknown name is refused naming the field.
    let mut p = common::tiny_preset();
    p.sky = builtin_sky("no_such_sky");
    let e = error_of(p);
    assert!(e.contains("sky.source") && e.contains("quarry_01"), "{e}");
}

#[test]
fn drones_under_a_plate_take_its_ambient_light() {
    let ctx = common::gpu();
    // MSAA 1 (tiny_preset): a pixel a drone changes is all drone, no blend with the plate.
    let pipeline = FramePipeline::new(plate_preset(&plates_dir(), (1, 1))).expect("pipeline");
    let mut renderer = pipeline.renderer(&ctx);
    let plates = &pipeline.assets().plates;
    let light = |i: usize| {
        let p = &plates[i];
        p.mean_upper.iter().chain(&p.mean_lower).sum::<f32>()
    };
    let bright = (0..plates.len()).max_by(|&a, &b| light(a).total_cmp(&light(b)));
    let dark = (0..plates.len()).min_by(|&a, &b| light(a).total_cmp(&light(b)));
    let (bright, dark) = (bright.expect("plates"), dark.expect("plates"));
    assert_ne!(
        (plates[bright].mean_upper, plates[bright].mean_lower),
        (plates[dark].mean_upper, plates[dark].mean_lower)
    );
    let mut compared = 0;
    for index in 0..8 {
        let scene = pipeline.scene(index).expect("scene");
        let mut under = |plate: usize| {
            let mut s = scene.clone();
            if let Some(p) = &mut s.backplate {
                p.plate = plate;
            }
            let frame = pipeline.make_scene(&mut renderer, s).expect("frame");
            let background = renderer
                .background_pixels(&frame.painted)
                .expect("background")
                .to_vec();
            (frame.rgba, background)
        };
        let ((a, bg_a), (b, bg_b)) = (under(bright), under(dark));
        let (mut sum_a, mut sum_b, mut n) = (0u64, 0u64, 0u64);
        for i in (0..a.len()).step_by(4) {
            if a[i..i + 3] != bg_a[i..i + 3] && b[i..i + 3] != bg_b[i..i + 3] {
                sum_a += a[i..i + 3].iter().map(|&c| u64::from(c)).sum::<u64>();
                sum_b += b[i..i + 3].iter().map(|&c| u64::from(c)).sum::<u64>();
                n += 1;
            }
        }
        if n >= 20 {
            // The same drone, sun and sky: only the plate's ambient light differs.
            assert_ne!(sum_a, sum_b, "frame {index}: over {n} pixels");
            compared += 1;
        }
    }
    assert!(
        compared >= 3,
        "only {compared} frames had a drone to compare"
    );
}

/// Haze under a plate fades the drones into the plate's own sky around them
/// (`scene::plate_air`), not into the preset's procedural sky: in thick haze a
/// drone takes the mean colour of the plate about it, and nearly vanishes.
#[test]
fn haze_under_a_plate_takes_the_plates_sky_around_the_drone() {
    use swarmshot::preset::atmosphere::Atmosphere;
    let ctx = common::gpu();
    let decode = common::srgb_decode;
    let encode = |l: f64| common::srgb_encode(l) * 255.0;
    let mut checked = 0;
    for (visibility_m, thick) in [(0.5, true), (1.0e7, false)] {
        let mut p = plate_preset(&plates_dir(), (1, 1));
        p.atmosphere = Some(Atmosphere {
            visibility_m: (visibility_m, visibility_m),
        });
        let pipeline = FramePipeline::new(p).expect("pipeline");
        let mut renderer = pipeline.renderer(&ctx);
        for index in 0..6 {
            let frame = pipeline.make(&mut renderer, index).expect("frame");
            let bg = renderer
                .background_pixels(&frame.painted)
                .expect("background")
                .to_vec();
            let (a, w) = (&frame.rgba, W as usize);
            let changed: Vec<usize> = (0..a.len() / 4)
                .filter(|&i| a[i * 4..i * 4 + 3] != bg[i * 4..i * 4 + 3])
                .collect();
            if changed.len() < 12 {
                continue;
            }
            // The drone's mean colour and its mean difference from the plate under it.
            let mean = |img: &[u8], c: usize| {
                changed
                    .iter()
                    .map(|&i| f64::from(img[i * 4 + c]))
                    .sum::<f64>()
                    / changed.len() as f64
            };
            let diff: f64 = (0..3)
                .map(|c| (mean(a, c) - mean(&bg, c)).abs())
                .sum::<f64>()
                / 3.0;
            if !thick {
                assert!(
                    diff > 8.0,
                    "frame {index}: a clear-air drone stands out ({diff})"
                );
                checked += 1;
                continue;
            }
            // The plate's mean (linear) in a ±7 px window (2 % of 360) about the drone's centre.
            let (cx, cy) = (
                changed.iter().map(|&i| i % w).sum::<usize>() / changed.len(),
                changed.iter().map(|&i| i / w).sum::<usize>() / changed.len(),
            );
            for c in 0..3 {
                let mut sum = (0.0, 0.0);
                for y in cy.saturating_sub(7)..=(cy + 7).min(H as usize - 1) {
                    for x in cx.saturating_sub(7)..=(cx + 7).min(w - 1) {
                        sum.0 += decode(bg[(y * w + x) * 4 + c]);
                        sum.1 += 1.0;
                    }
                }
                let want = encode(sum.0 / sum.1);
                assert!(
                    (mean(a, c) - want).abs() < 3.0,
                    "frame {index}, channel {c}: the hazed drone {} against the plate's {want}",
                    mean(a, c)
                );
            }
            assert!(
                diff < 6.0,
                "frame {index}: the drone fades into the plate ({diff})"
            );
            checked += 1;
        }
    }
    assert!(checked >= 6, "{checked}");
}

/// Auto-exposure meters the plate itself: frames over plates of different
/// brightness all come out near the target level, well under the plates'
/// own, each at its own metered EV, where without it they keep the plates'
/// spread.
#[test]
fn auto_exposure_meters_the_plate() {
    use swarmshot::preset::camera_model::CameraModel;
    let ctx = common::gpu();
    let mean_level = |rgba: &[u8]| {
        let sum: f64 = rgba
            .chunks_exact(4)
            .map(|p| 0.299 * f64::from(p[0]) + 0.587 * f64::from(p[1]) + 0.114 * f64::from(p[2]))
            .sum();
        sum / (rgba.len() / 4) as f64
    };
    let frames = |auto_exposure: Option<(f64, f64)>| {
        let mut p = plate_preset(&plates_dir(), (1, 1));
        p.camera_model = Some(CameraModel {
            auto_exposure,
            ..CameraModel::default()
        });
        let pipeline = FramePipeline::new(p).expect("pipeline");
        let mut renderer = pipeline.renderer(&ctx);
        (0..8)
            .map(|i| {
                let f = pipeline.make(&mut renderer, i).expect("frame");
                let plate = f.scene.backplate.as_ref().map(|b| b.plate);
                let ev = (f.scene.camera_model).and_then(|d| d.auto_exposure.map(|a| a.metered_ev));
                (mean_level(&f.rgba), plate, ev)
            })
            .collect::<Vec<_>>()
    };
    let spread = |v: &[(f64, Option<usize>, Option<f64>)]| {
        let levels = v.iter().map(|f| f.0);
        levels.clone().fold(f64::MIN, f64::max) - levels.fold(f64::MAX, f64::min)
    };
    let fixed = frames(None);
    let metered = frames(Some((100.0, 100.0)));
    let plates: std::collections::BTreeSet<_> = metered.iter().map(|f| f.1).collect();
    assert!(plates.len() >= 2, "{metered:?}");
    // The test plates are bright skies (126-135 levels) that differ by a few levels.
    assert!(fixed.iter().all(|f| f.0 > 120.0), "{fixed:?}");
    assert!(spread(&fixed) > 5.0, "the plates differ: {fixed:?}");
    for (level, _, ev) in &metered {
        assert!((level - 100.0).abs() < 3.0, "{level:.1}: {metered:?}");
        assert!(ev.is_some_and(|e| e != 0.0), "{metered:?}");
    }
    assert!(spread(&metered) < spread(&fixed) / 2.0, "{metered:?}");
}

// ---- plates and sidecars under the rules models follow (issue 35) -----------

/// `load_plates` on `folder` (no GPU): the error, or `None` when it loads.
fn plate_error(folder: &Path) -> Option<String> {
    let b = Backplate {
        folder: folder.to_owned(),
        hfov_deg: 50.0,
        ..Default::default()
    };
    swarmshot::sky::plates::load_plates(&b, (W, H))
        .err()
        .map(|e| e.to_string())
}

fn mkfifo(path: &Path) {
    let ok = std::process::Command::new("mkfifo")
        .arg(path)
        .status()
        .expect("mkfifo runs")
        .success();
    assert!(ok, "mkfifo {}", path.display());
}

#[test]
fn truncated_and_oversized_plates_are_refused_naming_them() {
    let tmp = tempfile::tempdir().expect("tmp");
    let jpeg = std::fs::read(plates_dir().join("V_DRONE_010.jpg")).expect("plate");
    // Cut to half: the decoder fills the rest with grey and says nothing.
    assert!(image::load_from_memory(&jpeg[..jpeg.len() / 2]).is_ok());
    let d = tmp.path().join("half");
    std::fs::create_dir_all(&d).expect("mkdir");
    std::fs::write(d.join("half.jpg"), &jpeg[..jpeg.len() / 2]).expect("write");
    let e = plate_error(&d).expect("refused");
    assert!(
        e.contains(&format!(
            "{}: truncated JPEG (",
            d.join("half.jpg").display()
        )),
        "{e}"
    );
    // Cut anywhere (in a header segment, in the data, just before its end).
    for cut in [100, 1000, jpeg.len() / 3, jpeg.len() - 2] {
        std::fs::write(d.join("half.jpg"), &jpeg[..cut]).expect("write");
        let e = plate_error(&d).expect("refused");
        assert!(e.contains("truncated JPEG"), "cut at {cut}: {e}");
    }
    // Whole, or with zero padding after its end: read.
    let mut padded = jpeg.clone();
    padded.extend([0u8; 512]);
    std::fs::write(d.join("half.jpg"), &padded).expect("write");
    assert_eq!(plate_error(&d), None);
    // 9000×8000 is within the side limit but over the pixel budget, read from the header.
    let d = tmp.path().join("big");
    std::fs::create_dir_all(&d).expect("mkdir");
    std::fs::write(d.join("big.png"), png_header(9_000, 8_000)).expect("write");
    let e = plate_error(&d).expect("refused");
    assert!(
        e.contains("big.png") && e.contains("9000×8000") && e.contains("64000000-pixel limit"),
        "{e}"
    );
}

#[test]
fn plates_and_sidecars_stay_in_their_folder_and_are_regular_files() {
    use std::os::unix::fs::symlink;
    let tmp = tempfile::tempdir().expect("tmp");
    let jpeg = plates_dir().join("V_DRONE_010.jpg");
    let fresh = |name: &str| {
        let d = tmp.path().join(name);
        std::fs::create_dir_all(&d).expect("mkdir");
        std::fs::copy(&jpeg, d.join("a.jpg")).expect("copy");
        d
    };
    // A sidecar linked to a file elsewhere is refused, not parsed: nothing of
    // the foreign file reaches the message.
    let secret = tmp.path().join("secret.txt");
    std::fs::write(&secret, "SECRET_TOKEN_1234 (not ron)").expect("write");
    let d = fresh("sidecar-link");
    symlink(&secret, d.join("a.plate.ron")).expect("symlink");
    let e = plate_error(&d).expect("refused");
    assert!(
        e.contains("a.plate.ron") && e.contains("leads out of the plate folder"),
        "{e}"
    );
    assert!(!e.contains("SECRET_TOKEN"), "{e}");
    // A link to nothing is named too.
    let d = fresh("sidecar-dangling");
    symlink(tmp.path().join("nothing.ron"), d.join("a.plate.ron")).expect("symlink");
    let e = plate_error(&d).expect("refused");
    assert!(
        e.contains("a.plate.ron") && e.contains("leads nowhere"),
        "{e}"
    );
    // A sidecar that is a FIFO is refused without blocking.
    let d = fresh("sidecar-fifo");
    mkfifo(&d.join("a.plate.ron"));
    let e = plate_error(&d).expect("refused");
    assert!(e.contains("a.plate.ron") && e.contains("FIFO"), "{e}");
    // A plate linked from outside the folder is refused; a link inside it is read,
    // and so is its sidecar linked inside.
    let d = fresh("plate-link");
    let outside = tmp.path().join("outside.jpg");
    std::fs::copy(&jpeg, &outside).expect("copy");
    symlink(&outside, d.join("b.jpg")).expect("symlink");
    let e = plate_error(&d).expect("refused");
    assert!(
        e.contains("b.jpg") && e.contains("leads out of the plate folder"),
        "{e}"
    );
    let d = fresh("inside-link");
    symlink(d.join("a.jpg"), d.join("b.jpg")).expect("symlink");
    std::fs::write(d.join("cam.ron"), "(hfov_deg: 70.0)").expect("write");
    symlink("cam.ron", d.join("b.plate.ron")).expect("symlink");
    assert_eq!(plate_error(&d), None);
    // A device reached through a link and a FIFO with a plate's name: refused.
    let d = fresh("device");
    symlink("/dev/zero", d.join("z.jpg")).expect("symlink");
    let e = plate_error(&d).expect("refused");
    assert!(e.contains("z.jpg") && e.contains("leads out"), "{e}");
    let d = fresh("fifo");
    mkfifo(&d.join("f.jpg"));
    let e = plate_error(&d).expect("refused");
    assert!(e.contains("f.jpg") && e.contains("FIFO"), "{e}");
    // A plate whose name is not UTF-8 is refused (it would be recorded lossily).
    let d = fresh("latin1");
    let name = std::ffi::OsStr::from_bytes(b"caf\xe9.jpg");
    std::fs::copy(&jpeg, d.join(name)).expect("copy");
    let e = plate_error(&d).expect("refused");
    assert!(e.contains("is not UTF-8"), "{e}");
}
