//! `swarmshot fit` (issue 36): the camera estimate recovers the parameters of frames
//! swarmshot rendered with a known camera; drone removal leaves no labelled drone; the
//! fitted preset is byte-identical across runs; bad input is a named error with nothing
//! written.

use crate::common;

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::atomic::AtomicBool;

use image::{Rgb, RgbImage};
use rand::{Rng, SeedableRng};
use swarmshot::fit::{camera, input, plates};
use swarmshot::gap::PixelBox;
use swarmshot::gap::measure::{Luma, measure_drone};
use swarmshot::pipeline::{BatchOptions, FramePipeline, run_batch};
use swarmshot::preset::Preset;

fn swarmshot() -> Command {
    Command::new(env!("CARGO_BIN_EXE_swarmshot"))
}

fn tmp(name: &str) -> common::Scratch {
    common::Scratch::new(&format!("fit-{name}"))
}

/// A small scene with sky, buildings and a tree line (edges for the blur estimate)
/// under a known camera: read noise σ, Gaussian PSF σ, JPEG quality.
fn known_camera_preset(read: f64, psf: f64, q: u8) -> Preset {
    let text = format!(
        r#"(
    version: 1,
    name: "known_camera",
    seed: 5,
    models: [
        (source: Builtin("quad_x"), size_m: 0.35, class: "uav"),
        (source: Builtin("fixed_wing"), size_m: 2.0, class: "uav"),
    ],
    placement: Randomized(count: (2, 4), volume: Box(size_m: (12.0, 6.0, 30.0)), min_separation_m: 2.5),
    camera: (fov_y_deg: 50.0, observer: (elevation_deg: (4.0, 10.0), size_px: Some((16.0, 30.0)))),
    repeats: 100,
    sky: Procedural(environment: Daytime, turbidity: Some(1.9)),
    render: (resolution: Custom(width: 480, height: 360), msaa: 4),
    labels: (box_method: Visible, min_box_px: 2.0, min_visible_pixels: 2, min_labelled: 0),
    output: (image_format: Jpeg(quality: {q}), label_formats: [Yolo]),
    clutter: Some((
        tree_lines: (count: (1, 2), distance_m: (150.0, 400.0), height_m: (12.0, 25.0), width_deg: (30.0, 60.0)),
        trees: (count: (0, 0)),
        poles: (count: (0, 0)),
        buildings: (count: (2, 3), distance_m: (40.0, 120.0), height_m: (10.0, 25.0), width_m: (10.0, 30.0)),
    )),
    camera_model: Some((
        read_noise_levels: ({read}, {read}),
        psf: Gaussian(sigma_px: ({psf}, {psf})),
        jpeg_quality: Some(({q}, {q})),
    )),
)"#
    );
    Preset::from_ron(&text).expect("the test preset parses")
}

fn render(preset: Preset, frames: u64, out: &Path) {
    let ctx = common::gpu();
    let pipeline = FramePipeline::new(preset).expect("valid preset");
    let mut options = BatchOptions::new(out);
    options.limit = Some(frames);
    run_batch(&pipeline, &options, &ctx, &AtomicBool::new(false), |_| {}).expect("batch");
}

#[test]
fn the_camera_estimate_recovers_a_known_camera() {
    // FIT_READ, FIT_PSF and FIT_Q set other values (docs/realism.md lists some).
    let env = |k: &str, d: f64| {
        std::env::var(k)
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(d)
    };
    let (read, psf, q) = (
        env("FIT_READ", 3.0),
        env("FIT_PSF", 1.2),
        env("FIT_Q", 80.0) as u8,
    );
    let dir = tmp("known");
    render(known_camera_preset(read, psf, q), 6, &dir);
    let frames = input::read_folder(&dir.join("images"), 0, false, &Default::default())
        .expect("frames and labels");
    assert_eq!(frames.len(), 6);
    assert!(frames.iter().all(|f| f.labelled));
    let footage = camera::measure(&frames);
    let e = &footage.estimate;
    eprintln!(
        "measured sky noise {:?} blur {:?}; estimated {e:?}",
        footage.measured.sky_noise_sigma, footage.measured.blur_sigma_px
    );
    assert_eq!(e.jpeg_quality, Some(q), "JPEG quality from the tables");
    let r = e.read_noise_levels.expect("a noise estimate");
    assert!(
        (r / read - 1.0).abs() < 0.10,
        "read noise {r} against {read}"
    );
    let s = e.psf_sigma_px.expect("a blur estimate");
    assert!((s / psf - 1.0).abs() < 0.10, "PSF σ {s} against {psf}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Standard normal by Box–Muller.
fn normal(rng: &mut impl Rng) -> f64 {
    let u1: f64 = rng.random_range(1e-12..1.0);
    let u2: f64 = rng.random::<f64>();
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

/// Mean and high-pass σ of the fill (the grown box) against its ring (the grown box grown
/// by `g` px more, the fill left out), on luminance.
fn fill_and_ring(rgb: &RgbImage, f: &plates::Filled, g: u32) -> ((f64, f64, f64), (f64, f64, f64)) {
    let hole = (f.x0, f.y0, f.x1, f.y1);
    let ring = (
        f.x0.saturating_sub(g),
        f.y0.saturating_sub(g),
        (f.x1 + g).min(rgb.width()),
        (f.y1 + g).min(rgb.height()),
    );
    (
        plates::region_stats(rgb, hole, None),
        plates::region_stats(rgb, ring, Some(hole)),
    )
}

#[test]
fn drone_removal_fills_from_the_ring_and_leaves_no_drone() {
    // A sky gradient with σ 2 noise and three dark drones of 40–90 levels.
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
    let (w, h) = (320u32, 240u32);
    let mut rgb = RgbImage::from_fn(w, h, |x, y| {
        let base = 150.0 + 0.08 * f64::from(x) - 0.1 * f64::from(y);
        let n = 2.0 * normal(&mut rng);
        let v = |c: f64| (c + n).round().clamp(0.0, 255.0) as u8;
        Rgb([v(base - 30.0), v(base), v(base + 40.0)])
    });
    let boxes = [
        (60.0f32, 50.0f32, 10.0f32, 90.0f32),
        (200.0, 120.0, 16.0, 40.0),
        (140.0, 180.0, 6.0, 70.0),
    ];
    let mut labelled = Vec::new();
    for (cx, cy, r, depth) in boxes {
        for y in (cy - r) as u32..(cy + r) as u32 {
            for x in (cx - r) as u32..(cx + r) as u32 {
                let d = ((x as f32 + 0.5 - cx).powi(2) + (y as f32 + 0.5 - cy).powi(2)).sqrt();
                if d < r * 0.8 {
                    let p = rgb.get_pixel_mut(x, y);
                    for c in 0..3 {
                        p[c] = (f32::from(p[c]) - depth).max(0.0) as u8;
                    }
                }
            }
        }
        labelled.push(PixelBox {
            x0: cx - r,
            y0: cy - r,
            x1: cx + r,
            y1: cy + r,
        });
    }
    let before: Vec<f32> = labelled
        .iter()
        .map(|b| {
            measure_drone(&Luma::from_rgb(&rgb), *b)
                .expect("a ring")
                .peak
        })
        .collect();
    assert!(before.iter().all(|p| *p < -25.0), "{before:?}");
    let original = rgb.clone();
    let filled = plates::remove_drones(&mut rgb, &labelled, 9);
    assert_eq!(filled.len(), 3);
    let l = Luma::from_rgb(&rgb);
    for (b, f) in labelled.iter().zip(&filled) {
        let after = measure_drone(&l, *b).expect("a ring").peak;
        // What the noise (σ 2) and the gradient give over a box, against 40–90 before.
        assert!(after.abs() < 12.0, "peak {after} after removal of {b:?}");
        let ((fm, _, fs), (rm, _, rs)) = fill_and_ring(&rgb, f, 8);
        eprintln!("fill {fm:.2}/{fs:.3} ring {rm:.2}/{rs:.3}");
        assert!((fm - rm).abs() < 1.5, "mean {fm} against the ring's {rm}");
        assert!(
            (fs / rs - 1.0).abs() < 0.15,
            "noise {fs} against the ring's {rs}"
        );
    }
    // The same seed, the same pixels.
    let mut again = original.clone();
    let _ = plates::remove_drones(&mut again, &labelled, 9);
    assert!(again == rgb, "the same seed gave other pixels");
}

#[test]
fn drone_removal_on_the_bundled_real_frames() {
    let real = common::testdata("real");
    let frames =
        input::read_folder(&real, 0, false, &Default::default()).expect("the bundled frames");
    let mut checked = 0;
    let mut bad = Vec::new();
    for f in &frames {
        let mut rgb = f.rgb.clone();
        let l0 = Luma::from_rgb(&rgb);
        let filled = plates::remove_drones(&mut rgb, &f.boxes, plates::name_seed(&f.rel));
        let l1 = Luma::from_rgb(&rgb);
        for b in &f.boxes {
            let (Some(d0), Some(d1)) = (measure_drone(&l0, *b), measure_drone(&l1, *b)) else {
                continue;
            };
            // The drone's own pixels (deviating by more than half its peak) are replaced:
            // on average they moved by at least a quarter of the peak (the box holds sky and
            // trees alike in some frames, so not every pixel over half the peak is drone),
            // and what is left deviates less than the drone did.
            let (x0, y0) = (b.x0.max(0.0) as u32, b.y0.max(0.0) as u32);
            let (x1, y1) = (
                (b.x1.ceil() as u32).min(rgb.width()),
                (b.y1.ceil() as u32).min(rgb.height()),
            );
            let (mut moved, mut n) = (0.0f32, 0);
            for y in y0..y1 {
                for x in x0..x1 {
                    let i = (y * rgb.width() + x) as usize;
                    let dev = l0.y[i] - d0.background;
                    if dev * d0.peak.signum() > 0.5 * d0.peak.abs() {
                        moved += (l1.y[i] - l0.y[i]).abs();
                        n += 1;
                    }
                }
            }
            let moved = moved / n.max(1) as f32;
            eprintln!(
                "{}: peak {} → {}, its core pixels moved {moved:.1} levels",
                f.rel, d0.peak, d1.peak
            );
            if !(moved >= 0.25 * d0.peak.abs() && d1.peak.abs() < d0.peak.abs()) {
                bad.push(format!(
                    "{}: the drone's pixels moved {moved} levels, its peak {} → {}",
                    f.rel, d0.peak, d1.peak
                ));
            }
            checked += 1;
        }
        for r in &filled {
            let ((fm, _, fs), (rm, rsd, rs)) = fill_and_ring(&rgb, r, 24);
            eprintln!(
                "{}: fill {fm:.1}/{fs:.2} ring {rm:.1}±{rsd:.1}/{rs:.2}",
                f.rel
            );
            if (fm - rm).abs() > rsd.max(6.0) {
                bad.push(format!("{}: mean {fm} against {rm} ± {rsd}", f.rel));
            }
            // Not smoother than a uniform ring (a ring over sky and trees alike, sd over
            // 10 levels, may surround a fill of sky alone), nor noisier than any ring.
            if fs > 2.0 * rs + 0.3 || (rsd < 10.0 && fs < 0.5 * rs - 0.3) {
                bad.push(format!("{}: high-pass {fs} against {rs}", f.rel));
            }
        }
    }
    assert!(bad.is_empty(), "{bad:#?}");
    assert!(checked >= 8, "{checked} drones checked");
}

/// A small base preset (fast in a debug build) for the command-line tests.
fn write_base(dir: &Path) -> PathBuf {
    std::fs::create_dir_all(dir).expect("dir");
    let mut p = known_camera_preset(0.5, 0.3, 85);
    p.render.resolution = swarmshot::preset::Resolution::Custom {
        width: 320,
        height: 256,
    };
    p.render.msaa = 1;
    p.clutter = None;
    let path = dir.join("base.ron");
    std::fs::write(&path, p.to_ron()).expect("write base");
    path
}

fn fit(real: &Path, out: &Path, extra: &[&str]) -> std::process::Output {
    swarmshot()
        .args(["fit", "--real"])
        .arg(real)
        .arg("--out")
        .arg(out)
        .args(extra)
        .output()
        .expect("run swarmshot")
}

#[test]
fn the_fitted_preset_is_byte_identical_across_runs() {
    let dir = tmp("twice");
    let base = write_base(&dir);
    let real = common::testdata("real");
    let mut outs = Vec::new();
    for k in 0..2 {
        let out = dir.join(format!("out{k}"));
        let o = fit(
            &real,
            &out,
            &[
                "--base",
                base.to_str().expect("utf-8"),
                "--rounds",
                "1",
                "--sample",
                "3",
            ],
        );
        let text = String::from_utf8_lossy(&o.stdout);
        assert!(
            o.status.success(),
            "{text}\n{}",
            String::from_utf8_lossy(&o.stderr)
        );
        assert!(
            text.contains("== before") && text.contains("== after"),
            "{text}"
        );
        for f in [
            "fitted.ron",
            "footage.json",
            "fit.json",
            "rounds/00/report.json",
            "rounds/01/report.txt",
        ] {
            assert!(out.join(f).is_file(), "{f} missing");
        }
        outs.push(out);
    }
    let read = |p: PathBuf| std::fs::read(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
    assert_eq!(
        read(outs[0].join("fitted.ron")),
        read(outs[1].join("fitted.ron"))
    );
    assert_eq!(
        read(outs[0].join("fit.json")),
        read(outs[1].join("fit.json"))
    );
    let names: Vec<_> = std::fs::read_dir(outs[0].join("plates"))
        .expect("plates")
        .map(|e| e.expect("entry").file_name())
        .collect();
    assert_eq!(names.len(), 20, "10 plates and 10 sidecars: {names:?}");
    for n in names {
        assert_eq!(
            read(outs[0].join("plates").join(&n)),
            read(outs[1].join("plates").join(&n)),
            "{n:?}"
        );
    }
    // The written preset is a valid preset that swarmshot check accepts.
    let check = swarmshot()
        .arg("check")
        .arg(outs[0].join("fitted.ron"))
        .output()
        .expect("check");
    assert!(
        check.status.success(),
        "{}",
        String::from_utf8_lossy(&check.stderr)
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// `fit` on `real` fails naming `what`, and writes nothing.
fn refuses(real: &Path, extra: &[&str], path_env: Option<&Path>, what: &str) {
    let out = real
        .parent()
        .unwrap_or(Path::new("/tmp"))
        .join(format!("out-{}", what.len()));
    let _ = std::fs::remove_dir_all(&out);
    let mut cmd = swarmshot();
    cmd.args(["fit", "--real"])
        .arg(real)
        .arg("--out")
        .arg(&out)
        .args(["--rounds", "0"])
        .args(extra);
    if let Some(p) = path_env {
        cmd.env("PATH", p);
    }
    let o = cmd.output().expect("run");
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success(), "{what}: succeeded");
    assert!(err.contains(what), "expected `{what}` in: {err}");
    assert!(!out.exists(), "{what}: {} was written", out.display());
}

#[test]
fn bad_input_is_a_named_error_and_nothing_is_written() {
    let dir = tmp("bad");
    let real = common::testdata("real/images");
    // An empty folder.
    let empty = dir.join("empty");
    std::fs::create_dir_all(&empty).expect("dir");
    refuses(&empty, &[], None, "empty folder");
    // A missing folder.
    refuses(&dir.join("nowhere"), &[], None, "no such file or folder");
    // A corrupt image among good ones (labels beside them).
    let corrupt = dir.join("corrupt");
    std::fs::create_dir_all(&corrupt).expect("dir");
    std::fs::copy(real.join("V_DRONE_001_f150.png"), corrupt.join("a.png")).expect("copy");
    std::fs::write(corrupt.join("a.txt"), "").expect("label");
    std::fs::write(corrupt.join("b.png"), b"\x89PNG\r\n\x1a\nnot really").expect("write");
    std::fs::write(corrupt.join("b.txt"), "").expect("label");
    refuses(&corrupt, &[], None, "corrupt image");
    // A 0-byte file.
    let zero = dir.join("zero");
    std::fs::create_dir_all(&zero).expect("dir");
    std::fs::write(zero.join("z.jpg"), b"").expect("write");
    std::fs::write(zero.join("z.txt"), "").expect("label");
    refuses(&zero, &[], None, "0-byte file");
    // Frames without labels where labels are needed.
    let unlabelled = dir.join("unlabelled");
    std::fs::create_dir_all(&unlabelled).expect("dir");
    std::fs::copy(real.join("V_DRONE_010_f150.png"), unlabelled.join("c.png")).expect("copy");
    refuses(
        &unlabelled,
        &[],
        None,
        "frames without labels where labels are needed",
    );
    // A video without a decoder on PATH.
    let video = dir.join("clip.mp4");
    std::fs::write(&video, b"\x00\x00\x00\x18ftypmp42 not a real video").expect("write");
    let no_path = dir.join("empty-path");
    std::fs::create_dir_all(&no_path).expect("dir");
    refuses(
        &video,
        &["--unlabelled-ok"],
        Some(&no_path),
        "no video decoder: install ffmpeg",
    );
    // Frames whose plates would share a name: b.jpg and b.jpeg; with two views,
    // view 1 of e.png and e__v1.png.
    let same = dir.join("same-name");
    std::fs::create_dir_all(&same).expect("dir");
    for (from, to) in [
        ("V_DRONE_001_f150.png", "e.png"),
        ("V_DRONE_010_f150.png", "e__v1.png"),
    ] {
        std::fs::copy(real.join(from), same.join(to)).expect("copy");
    }
    refuses(
        &same,
        &["--unlabelled-ok", "--views", "2"],
        None,
        "would give plates of the same name (e__v1.png)",
    );
    // Views out of range.
    refuses(&zero, &["--views", "0"], None, "--views 0: must be 1");
    refuses(&zero, &["--views", "10"], None, "--views 10: must be 1");
    // --out inside the real folder.
    let inside = dir.join("labelled");
    std::fs::create_dir_all(&inside).expect("dir");
    std::fs::copy(real.join("V_DRONE_010_f150.png"), inside.join("c.png")).expect("copy");
    std::fs::write(inside.join("c.txt"), "").expect("label");
    let o = fit(&inside, &inside.join("fit"), &["--rounds", "0"]);
    assert!(!o.status.success());
    assert!(
        String::from_utf8_lossy(&o.stderr).contains("is inside the real folder"),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(!inside.join("fit").exists());
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn frames_are_decoded_within_budgets_as_gap_decodes_them() {
    let dir = tmp("budgets");
    let folder = |name: &str, files: &[(&str, &[u8])]| {
        let d = dir.join(name);
        std::fs::create_dir_all(&d).expect("dir");
        for (n, bytes) in files {
            std::fs::write(d.join(n), bytes).expect("write");
        }
        d
    };
    let ok = ["--unlabelled-ok"];
    // A PNG whose header claims 22000×22000: refused by name, nothing allocated.
    let huge = common::png_header(22_000, 22_000);
    let d = folder("huge", &[("f1.png", &huge), ("f2.png", &huge)]);
    refuses(&d, &ok, None, "f1.png: 22000×22000 is 484000000 pixels");
    // Frames each within the budget that together are not: refused before decoding,
    // naming how many fit.
    let big = common::png_header(8_000, 8_000);
    let names: Vec<String> = (0..32).map(|i| format!("f{i:02}.png")).collect();
    let files: Vec<(&str, &[u8])> = names.iter().map(|n| (n.as_str(), &big[..])).collect();
    let d = folder("many", &files);
    refuses(&d, &ok, None, "32 frames of 2048 megapixels");
    refuses(&d, &ok, None, "pass --max-frames 31 or fewer");
    // A JPEG cut short: refused as gap refuses it.
    let mut jpeg = Vec::new();
    RgbImage::from_fn(128, 96, |x, y| Rgb([(x * 2) as u8, (y * 2) as u8, 90]))
        .write_to(
            &mut std::io::Cursor::new(&mut jpeg),
            image::ImageFormat::Jpeg,
        )
        .expect("jpeg");
    let d = folder("cut", &[("b.jpg", &jpeg[..jpeg.len() / 2])]);
    refuses(&d, &ok, None, "b.jpg: corrupt image: truncated JPEG (");
    // A 0-byte file and a frame too small are named without calling them undecodable.
    let d = folder("zero", &[("z.png", b"")]);
    refuses(
        &d,
        &ok,
        None,
        "z.png: is a 0-byte file, not a JPEG or PNG image",
    );
    let mut small = Vec::new();
    RgbImage::new(200, 40)
        .write_to(
            &mut std::io::Cursor::new(&mut small),
            image::ImageFormat::Png,
        )
        .expect("png");
    let d = folder("small", &[("s.png", &small)]);
    refuses(&d, &ok, None, "s.png: 200×40 is smaller than the 64 px");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn numeric_options_are_checked_before_anything_is_written() {
    let dir = tmp("numbers");
    let real = dir.join("real");
    std::fs::create_dir_all(&real).expect("dir");
    let frames = common::testdata("real/images");
    std::fs::copy(frames.join("V_DRONE_010_f150.png"), real.join("c.png")).expect("copy");
    std::fs::write(real.join("c.txt"), "").expect("label");
    for v in ["nan", "inf", "1e9", "0.0001", "-30", "151"] {
        let shown = v.parse::<f64>().expect("number");
        refuses(
            &real,
            &[&format!("--hfov={v}")],
            None,
            &format!("--hfov {shown}: must be degrees within [1, 150]"),
        );
    }
    for v in ["nan", "0", "-2", "1e9"] {
        let shown = v.parse::<f64>().expect("number");
        refuses(
            &real,
            &[&format!("--video-fps={v}")],
            None,
            &format!("--video-fps {shown}: must be frames a second within (0, 1000]"),
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// A copy of the bundled real frames (images/ and labels/), `times` over.
fn copy_real(to: &Path, times: usize) {
    let real = common::testdata("real");
    for sub in ["images", "labels"] {
        std::fs::create_dir_all(to.join(sub)).expect("dir");
        for e in std::fs::read_dir(real.join(sub)).expect("read") {
            let p = e.expect("entry").path();
            let name = p.file_name().expect("name").to_string_lossy().into_owned();
            for k in 0..times {
                std::fs::copy(&p, to.join(sub).join(format!("c{k}_{name}"))).expect("copy");
            }
        }
    }
}

fn files_in(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .map(|r| {
            r.map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
                .collect()
        })
        .unwrap_or_default();
    names.sort();
    names
}

/// Without `--base` the fit starts from the shipped `presets/realistic.ron`
/// wherever it is run from, not only in the repository's folder: from a
/// folder that holds no `presets/`, the base is the repository's copy.
#[test]
fn without_base_the_shipped_realistic_preset_is_found_from_any_folder() {
    let dir = tmp("default-base");
    let elsewhere = dir.join("work");
    std::fs::create_dir_all(&elsewhere).expect("dir");
    let o = swarmshot()
        .current_dir(&elsewhere)
        .args(["fit", "--rounds", "0", "--real"])
        .arg(common::testdata("real"))
        .arg("--out")
        .arg("fit")
        .output()
        .expect("run swarmshot");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let fitted = std::fs::read_to_string(elsewhere.join("fit/fitted.ron")).expect("fitted.ron");
    let notes = std::fs::read_to_string(elsewhere.join("fit/fit.json")).expect("fit.json");
    assert!(notes.contains("presets/realistic.ron"), "{notes}");
    assert!(fitted.contains("backplate"), "{fitted}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn overwrite_deletes_only_what_fit_wrote() {
    let dir = tmp("overwrite");
    let base = write_base(&dir);
    let base = base.to_str().expect("utf-8");
    let real = common::testdata("real");
    let out = dir.join("out");
    let args = ["--base", base, "--rounds", "0", "--overwrite"];
    let o = fit(&real, &out, &args[..4]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let plates = files_in(&out.join("plates"));
    assert_eq!(plates.len(), 20, "{plates:?}");
    // A plate of an earlier run whose frame is gone is fit's own: deleted.
    std::fs::copy(
        out.join("plates").join(&plates[0]),
        out.join("plates/old.png"),
    )
    .expect("copy");
    std::fs::write(out.join("plates/old.plate.ron"), "(hfov_deg: 60.0)").expect("write");
    // The user's files: refused by name and kept, nothing deleted.
    let outside = dir.join("outside");
    std::fs::create_dir_all(&outside).expect("dir");
    std::fs::write(outside.join("keep.txt"), "outside").expect("write");
    for (rel, what) in [
        ("rounds/NOTES.txt", "file"),
        ("frames/frame_0001_mine.png", "file"),
        ("plates/mine.png", "file"),
        ("rounds/07", "link"),
    ] {
        let p = out.join(rel);
        std::fs::create_dir_all(p.parent().expect("parent")).expect("dir");
        match what {
            "file" => std::fs::write(&p, "mine").expect("write"),
            _ => std::os::unix::fs::symlink(&outside, &p).expect("symlink"),
        }
        let o = fit(&real, &out, &args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{rel}: {err}");
        assert!(
            err.contains(&format!("{}", p.display())) && err.contains("move it away first"),
            "{rel}: {err}"
        );
        assert!(out.join("fitted.ron").is_file() && out.join("plates/old.png").is_file());
        assert_eq!(files_in(&outside), ["keep.txt"]);
        match what {
            "file" => std::fs::remove_file(&p).expect("rm"),
            _ => std::fs::remove_file(&p).expect("unlink"),
        }
    }
    // The rest of the user's files beside fit's: kept.
    std::fs::write(out.join("notes.txt"), "mine").expect("write");
    let o = fit(&real, &out, &args);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(std::fs::read(out.join("notes.txt")).expect("kept"), b"mine");
    assert_eq!(
        files_in(&out.join("plates")),
        plates,
        "the stale plate deleted"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_folder_swapped_for_a_link_while_fit_writes_gets_nothing() {
    let dir = tmp("swap");
    let base = write_base(&dir);
    let real = dir.join("real");
    copy_real(&real, 3);
    let evil = dir.join("evil");
    std::fs::create_dir_all(&evil).expect("dir");
    let out = dir.join("out");
    let child = swarmshot()
        .args(["fit", "--rounds", "0", "--views", "4", "--base"])
        .arg(&base)
        .arg("--real")
        .arg(&real)
        .arg("--out")
        .arg(&out)
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("spawn");
    // As soon as the plates' folder appears, it is swapped for a link to `evil`.
    let plates = out.join("plates");
    let start = std::time::Instant::now();
    while !plates.is_dir() && start.elapsed().as_secs() < 120 {
        std::thread::sleep(std::time::Duration::from_millis(1));
    }
    std::fs::rename(&plates, out.join("plates.orig")).expect("move the plates away");
    std::os::unix::fs::symlink(&evil, &plates).expect("symlink");
    let o = child.wait_with_output().expect("wait");
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(files_in(&evil), Vec::<String>::new(), "{err}");
    // The swap was seen (the plates were still being written) and named: the
    // folder held found replaced, or the link met where a folder is reached.
    if !o.status.success() {
        assert!(
            err.contains("was replaced") || err.contains("is a symbolic link"),
            "{err}"
        );
    }
    // A link already standing where fit makes a folder is refused, not followed.
    let out2 = dir.join("out2");
    std::fs::create_dir_all(&out2).expect("dir");
    std::fs::write(out2.join("footage.json"), "{}").expect("write");
    std::os::unix::fs::symlink(&evil, out2.join("plates")).expect("symlink");
    let o = fit(
        &real,
        &out2,
        &[
            "--rounds",
            "0",
            "--overwrite",
            "--base",
            base.to_str().expect("utf-8"),
        ],
    );
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("plates"), "{err}");
    assert_eq!(files_in(&evil), Vec::<String>::new(), "{err}");
    assert!(out2.join("plates").is_symlink());
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn crop_views_keep_the_focal_length_and_the_horizon() {
    // Eight distinct crops besides the whole frame, each 80 % of it.
    let (w, h) = (640u32, 480u32);
    assert_eq!(plates::view_crop(w, h, 0), (0, 0, w, h));
    let crops: Vec<_> = (1..=8).map(|k| plates::view_crop(w, h, k)).collect();
    for (i, c) in crops.iter().enumerate() {
        assert_eq!((c.2, c.3), (512, 384), "view {}", i + 1);
        assert!(c.0 + c.2 <= w && c.1 + c.3 <= h);
        assert!(!crops[..i].contains(c), "view {} repeats", i + 1);
    }
    // The same focal length in the frame's pixels: (w/2)/tan(hfov/2).
    let f = |hfov: f64, width: u32| f64::from(width) * 0.5 / (hfov.to_radians() * 0.5).tan();
    let hfov = plates::view_hfov(60.0, w, 512);
    assert!((f(hfov, 512) / f(60.0, w) - 1.0).abs() < 1e-4, "{hfov}");
    // A bright sky over dark ground, the horizon at row 288 (0.6 of the height): in
    // each crop the estimate finds it where view_horizon puts it.
    let frame = RgbImage::from_fn(w, h, |x, y| {
        let v = if y < 288 { 200 } else { 70 } + ((x * 7 + y * 13) % 5) as u8;
        Rgb([v, v, v])
    });
    assert_eq!(plates::estimate_horizon(&frame), Some(0.6));
    for k in [3usize, 4, 1] {
        let (x0, y0, cw, ch) = plates::view_crop(w, h, k);
        let crop = image::imageops::crop_imm(&frame, x0, y0, cw, ch).to_image();
        let want = plates::view_horizon(Some(0.6), h, y0, ch).expect("row");
        let got = plates::estimate_horizon(&crop).expect("horizon");
        assert!(
            (got - want).abs() <= 1.0 / f64::from(ch) + 1e-3,
            "view {k}: {got} vs {want}"
        );
    }
    assert_eq!(plates::view_horizon(Some(0.6), h, 0, 384), Some(0.75));
    assert_eq!(plates::view_horizon(Some(0.6), h, 96, 384), Some(0.5));
    assert_eq!(plates::view_horizon(None, h, 96, 384), None);
}

#[test]
fn views_write_a_plate_and_a_sidecar_per_crop() {
    let dir = tmp("views");
    let out = dir.join("fit");
    let real = common::testdata("real");
    let o = fit(&real, &out, &["--rounds", "0", "--views", "3"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let plates_dir = out.join("plates");
    let mut names: Vec<String> = std::fs::read_dir(&plates_dir)
        .expect("plates")
        .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(
        names.len(),
        60,
        "3 views × 10 frames, plate and sidecar: {names:?}"
    );
    let whole = image::open(plates_dir.join("images__V_DRONE_001_f150.png")).expect("plate");
    assert_eq!((whole.width(), whole.height()), (640, 512));
    let v1 = image::open(plates_dir.join("images__V_DRONE_001_f150__v1.png")).expect("view 1");
    let (_, _, cw, ch) = plates::view_crop(640, 512, 1);
    assert_eq!((v1.width(), v1.height()), (cw, ch));
    let side = std::fs::read_to_string(plates_dir.join("images__V_DRONE_001_f150__v2.plate.ron"))
        .expect("sidecar");
    let base = std::fs::read_to_string(plates_dir.join("images__V_DRONE_001_f150.plate.ron"))
        .expect("sidecar");
    let hfov = |t: &str| -> f64 {
        let i = t.find("(hfov_deg: ").expect("hfov") + "(hfov_deg: ".len();
        t[i..]
            .split(',')
            .next()
            .expect("value")
            .parse()
            .expect("number")
    };
    assert!(
        (hfov(&side) - plates::view_hfov(hfov(&base), 640, cw)).abs() < 1e-9,
        "{side}"
    );
    assert!(hfov(&side) < hfov(&base));
    // The written preset loads with every view as a plate.
    let check = swarmshot()
        .arg("check")
        .arg(out.join("fitted.ron"))
        .output()
        .expect("check");
    assert!(
        check.status.success(),
        "{}",
        String::from_utf8_lossy(&check.stderr)
    );
    let fitted = std::fs::read_to_string(out.join("fitted.ron")).expect("fitted");
    assert!(fitted.contains("as 30 plates, 3 views of each"), "{fitted}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn rows_of_other_classes_stay_in_the_plates_and_are_not_measured() {
    let dir = tmp("classes");
    let real = dir.join("real");
    // The bundled frames, each label file with a second row of class 2 (a "bird").
    let bird = (0.3f32, 0.3f32, 0.2f32, 0.2f32);
    let row = format!("2 {} {} {} {}", bird.0, bird.1, bird.2, bird.3);
    common::real_frames_with_row(&real, &row);
    let fit = |out: &Path, extra: &[&str]| -> serde_json::Value {
        let o = swarmshot()
            .args(["fit", "--rounds", "0", "--real"])
            .arg(real.join("images"))
            .arg("--out")
            .arg(out)
            .args(extra)
            .output()
            .expect("run fit");
        assert!(
            o.status.success(),
            "fit: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        serde_json::from_slice(&std::fs::read(out.join("footage.json")).expect("footage"))
            .expect("json")
    };
    let (every, drones) = (dir.join("every"), dir.join("drones"));
    assert_eq!(fit(&every, &[])["drones"], 20);
    assert_eq!(fit(&drones, &["--classes", "0"])["drones"], 10);
    let record: serde_json::Value =
        serde_json::from_slice(&std::fs::read(drones.join("fit.json")).expect("fit.json"))
            .expect("json");
    assert_eq!(record["drone_classes"], "0");
    // The bird's box: as in the frame with --classes 0, painted over without it.
    let frame = "V_DRONE_001_f150.png";
    let source = image::open(real.join("images").join(frame))
        .expect("frame")
        .to_rgb8();
    let (w, h) = (source.width() as f32, source.height() as f32);
    let x = ((bird.0 - bird.2 / 2.0) * w) as u32..((bird.0 + bird.2 / 2.0) * w) as u32;
    let y = ((bird.1 - bird.3 / 2.0) * h) as u32..((bird.1 + bird.3 / 2.0) * h) as u32;
    let same_in_box = |plate: &Path| {
        let plate = image::open(plate.join("plates").join(frame))
            .expect("plate")
            .to_rgb8();
        let differ = |(px, py): (u32, u32)| source.get_pixel(px, py) != plate.get_pixel(px, py);
        !x.clone()
            .flat_map(|px| y.clone().map(move |py| (px, py)))
            .any(differ)
    };
    assert!(same_in_box(&drones), "--classes 0 painted over the bird");
    assert!(
        !same_in_box(&every),
        "without --classes the bird's box was kept"
    );
    // A bad list is named with its option, nothing written; so is a list that matches
    // none of the rows.
    refuses(&real.join("images"), &["--classes", "x"], None, "--classes");
    refuses(
        &real.join("images"),
        &["--classes", "5,7"],
        None,
        "--classes 5,7: none of the 20 label rows read is of these classes (the rows' classes: 0, 2)",
    );
}

#[test]
fn footage_of_mixed_frame_sizes_is_fitted_to_the_common_one_and_says_so() {
    let dir = tmp("mixed");
    let real = dir.join("real");
    std::fs::create_dir_all(&real).expect("dir");
    let bundled = common::testdata("real/images");
    let mut names: Vec<_> = std::fs::read_dir(&bundled)
        .expect("read")
        .map(|e| e.expect("entry").file_name())
        .collect();
    names.sort();
    // Three frames at 640×512, two halved to 320×256; every label file empty but the
    // last frame's, which is missing.
    for (i, name) in names.iter().take(5).enumerate() {
        let img = image::open(bundled.join(name)).expect("frame").to_rgb8();
        let img = if i < 3 {
            img
        } else {
            image::imageops::resize(&img, 320, 256, image::imageops::FilterType::Triangle)
        };
        img.save(real.join(name)).expect("save");
        let label = Path::new(name).with_extension("txt");
        if i < 4 {
            std::fs::write(real.join(label), "").expect("label");
        }
    }
    let out = dir.join("out");
    let o = swarmshot()
        .args([
            "fit",
            "--rounds",
            "0",
            "--unlabelled-ok",
            "--views",
            "2",
            "--real",
        ])
        .arg(&real)
        .arg("--out")
        .arg(&out)
        .output()
        .expect("run fit");
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "fit: {err}");
    assert!(err.contains("warning: 3 of 5 frames are 640×512"), "{err}");
    // Frames, not plates (two a frame).
    assert!(
        err.contains("warning: 1 of 5 frames have no labels"),
        "{err}"
    );
    let fitted = std::fs::read_to_string(out.join("fitted.ron")).expect("fitted");
    assert!(
        fitted.contains("width: 640") && fitted.contains("height: 512"),
        "{fitted}"
    );
    assert!(
        fitted.contains("most common frame size (3 of 5 frames"),
        "{fitted}"
    );
}
