//! `swarmshot gap`, the domain-gap report: its statistics recover known parameters on
//! synthetic frames (noise σ, PSF σ, blob polarity and core size, JPEG quality), and the
//! command runs end to end on the bundled real frames against a tiny rendered dataset,
//! deterministically.

use crate::common;

use std::path::Path;
use std::process::Command;
use std::time::Instant;

use image::{Rgb, RgbImage};
use rand::{Rng, SeedableRng};
use swarmshot::gap::{PixelBox, measure_frame};

fn swarmshot() -> Command {
    Command::new(env!("CARGO_BIN_EXE_swarmshot"))
}

/// Standard normal by Box–Muller.
fn normal(rng: &mut impl Rng) -> f64 {
    let u1: f64 = rng.random_range(1e-12..1.0);
    let u2: f64 = rng.random::<f64>();
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

/// Φ(x) through erf (Abramowitz–Stegun 7.1.26, |error| < 1.5e-7).
fn phi(x: f64) -> f64 {
    let z = x / std::f64::consts::SQRT_2;
    let t = 1.0 / (1.0 + 0.327_591_1 * z.abs());
    let poly = t
        * (0.254_829_592
            + t * (-0.284_496_736
                + t * (1.421_413_741 + t * (-1.453_152_027 + t * 1.061_405_429))));
    let erf = 1.0 - poly * (-z * z).exp();
    0.5 * (1.0 + if z >= 0.0 { erf } else { -erf })
}

fn grey(w: u32, h: u32, f: impl Fn(u32, u32) -> f64) -> RgbImage {
    RgbImage::from_fn(w, h, |x, y| {
        let v = f(x, y).round().clamp(0.0, 255.0) as u8;
        Rgb([v, v, v])
    })
}

#[test]
fn noise_sigma_on_a_smooth_sky_is_recovered_within_10_percent() {
    for (sigma, seed) in [(1.5f64, 1u64), (3.0, 2), (6.0, 3)] {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        // A smooth sky gradient (0.1 level/px across, 0.06 down) plus Gaussian noise.
        let noise: Vec<f64> = (0..640 * 480).map(|_| sigma * normal(&mut rng)).collect();
        let img = grey(640, 480, |x, y| {
            70.0 + 0.1 * f64::from(x) + 0.06 * f64::from(y) + noise[(y * 640 + x) as usize]
        });
        let s = measure_frame(&img, &[], None);
        let got = f64::from(s.noise_sigma.expect("flat tiles"));
        assert!(
            (got / sigma - 1.0).abs() < 0.10,
            "set σ {sigma}, measured {got} over {} flat tiles",
            s.flat_tiles
        );
        let rms = f64::from(s.highpass_rms.expect("rms"));
        assert!((rms / sigma - 1.0).abs() < 0.10, "σ {sigma}: RMS {rms}");
        assert!(s.flat_tiles > 1000, "every tile is flat: {}", s.flat_tiles);
    }
    // Under one level the 8-bit plane hides most of the noise; the estimate still orders
    // quieter skies lower, and a constant sky reads 0.
    let low: Vec<f32> = [0.15f64, 0.3, 0.45]
        .iter()
        .map(|&sigma| {
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
            let n: Vec<f64> = (0..320 * 240).map(|_| sigma * normal(&mut rng)).collect();
            let img = grey(320, 240, |x, y| 100.2 + n[(y * 320 + x) as usize]);
            measure_frame(&img, &[], None).noise_sigma.expect("flat")
        })
        .collect();
    assert!(low[0] < low[1] && low[1] < low[2], "{low:?}");
    let constant = measure_frame(&grey(320, 240, |_, _| 100.0), &[], None);
    assert_eq!(constant.noise_sigma, Some(0.0));
    // Clean: the same gradient without noise measures (nearly) nothing.
    let clean = measure_frame(
        &grey(640, 480, |x, y| {
            70.0 + 0.1 * f64::from(x) + 0.06 * f64::from(y)
        }),
        &[],
        None,
    );
    assert!(
        clean.noise_sigma.expect("flat") < 0.4,
        "{:?}",
        clean.noise_sigma
    );
}

#[test]
fn tiles_with_structure_are_not_flat() {
    // Left half flat, right half vertical stripes 8 px wide: only the left half's
    // 20 × 30 tiles count.
    let img = grey(640, 480, |x, _| {
        if x < 320 || (x / 8) % 2 == 0 {
            120.0
        } else {
            160.0
        }
    });
    let s = measure_frame(&img, &[], None);
    assert_eq!(s.flat_tiles, 20 * 30);
    // And a drone box keeps the tiles around it out.
    let b = PixelBox {
        x0: 100.0,
        y0: 100.0,
        x1: 110.0,
        y1: 110.0,
    };
    let s2 = measure_frame(&img, &[b], None);
    assert!(
        s2.flat_tiles < s.flat_tiles,
        "{} vs {}",
        s2.flat_tiles,
        s.flat_tiles
    );
}

/// An edge through (cx, cy) with normal at `angle_deg` from +x, blurred by a Gaussian PSF
/// of σ, point-sampled at pixel centres: a + C·Φ(s/σ), s the signed distance.
fn blurred_edge(sigma: f64, angle_deg: f64, noise: f64, seed: u64) -> RgbImage {
    let (c, s) = (angle_deg.to_radians().cos(), angle_deg.to_radians().sin());
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let n: Vec<f64> = (0..400 * 300).map(|_| noise * normal(&mut rng)).collect();
    grey(400, 300, |x, y| {
        let d = (f64::from(x) + 0.5 - 200.3) * c + (f64::from(y) + 0.5 - 150.0) * s;
        50.0 + 150.0 * phi(d / sigma) + n[(y * 400 + x) as usize]
    })
}

#[test]
fn blur_sigma_of_a_gaussian_edge_is_recovered_within_10_percent() {
    for sigma in [0.8, 1.2, 2.0, 3.0] {
        for angle in [0.0, 12.0, 90.0] {
            let s = measure_frame(&blurred_edge(sigma, angle, 0.0, 0), &[], None);
            let got = f64::from(s.blur_sigma_px.expect("edges"));
            assert!(
                (got / sigma - 1.0).abs() < 0.10,
                "σ {sigma} at {angle}°: measured {got} from {} edges",
                s.blur_edges
            );
        }
    }
    // With a little sensor noise (σ 0.7 levels) the estimate still holds.
    let s = measure_frame(&blurred_edge(1.5, 5.0, 0.7, 9), &[], None);
    let got = f64::from(s.blur_sigma_px.expect("edges"));
    assert!((got / 1.5 - 1.0).abs() < 0.10, "noisy edge: {got}");
    // A flat frame has no edge, hence no blur figure.
    assert_eq!(
        measure_frame(&grey(200, 200, |_, _| 90.0), &[], None).blur_sigma_px,
        None
    );
}

#[test]
fn blob_polarity_core_size_and_edge_width() {
    // Sharp discs: every disc pixel deviates fully, so the core is √(disc pixels).
    for (value, darker) in [(40.0, true), (235.0, false)] {
        let inside = |x: u32, y: u32| {
            let (dx, dy) = (f64::from(x) + 0.5 - 100.0, f64::from(y) + 0.5 - 80.0);
            dx * dx + dy * dy <= 16.0
        };
        let img = grey(200, 160, |x, y| if inside(x, y) { value } else { 150.0 });
        let count = (0..200)
            .flat_map(|x| (0..160).map(move |y| (x, y)))
            .filter(|&(x, y)| inside(x, y))
            .count();
        let b = PixelBox {
            x0: 92.0,
            y0: 72.0,
            x1: 108.0,
            y1: 88.0,
        };
        let s = measure_frame(&img, &[b], None);
        let d = s.drones[0];
        assert_eq!(d.darker, darker);
        assert_eq!(d.background, 150.0);
        assert!((d.peak.abs() - (value - 150.0).abs() as f32).abs() < 1e-3);
        assert!(
            (d.core_px - (count as f32).sqrt()).abs() < 1e-4,
            "{} vs √{count}",
            d.core_px
        );
    }
    // A Gaussian spot of σ 2 px: the half-peak core has area 2π·σ²·ln 2 (core √ = 4.17 px),
    // and the 90 %→10 % fall is (√(2 ln 10) − √(2 ln(1/0.9)))·σ = 1.687σ = 3.37 px.
    let spot = grey(200, 160, |x, y| {
        let (dx, dy) = (f64::from(x) - 100.0, f64::from(y) - 80.0);
        150.0 - 90.0 * (-(dx * dx + dy * dy) / 8.0).exp()
    });
    let b = PixelBox {
        x0: 92.0,
        y0: 72.0,
        x1: 109.0,
        y1: 89.0,
    };
    let d = measure_frame(&spot, &[b], None).drones[0];
    assert!(d.darker);
    let core = (2.0 * std::f32::consts::PI * 4.0 * std::f32::consts::LN_2).sqrt();
    assert!(
        (d.core_px / core - 1.0).abs() < 0.10,
        "core {} vs {core}",
        d.core_px
    );
    let width = d.edge_width_px.expect("edge width");
    assert!((width / 3.374 - 1.0).abs() < 0.10, "edge width {width}");
}

#[test]
fn jpeg_quality_is_read_from_the_quantisation_tables() {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(4);
    let rgba: Vec<u8> = (0..128 * 96 * 4).map(|_| rng.random()).collect();
    for q in [30u8, 50, 75, 85, 95] {
        let jpeg = swarmshot::write::encode::jpeg::compress(&rgba, 128, 96, q).expect("encode");
        let est = swarmshot::gap::jpeg_quality::estimate(&jpeg).expect("a JPEG");
        assert_eq!((est.quality, est.exact), (q, true), "libjpeg-turbo q{q}");
    }
    // The image crate's encoder uses the same IJG scaling.
    let img = RgbImage::from_fn(64, 64, |x, y| Rgb([(x * 4) as u8, (y * 4) as u8, 90]));
    let mut bytes = Vec::new();
    image::codecs::jpeg::JpegEncoder::new_with_quality(&mut bytes, 70)
        .encode_image(&img)
        .expect("encode");
    let est = swarmshot::gap::jpeg_quality::estimate(&bytes).expect("a JPEG");
    assert_eq!(est.quality, 70);
    // And measure_frame reports it.
    assert_eq!(
        measure_frame(&img, &[], Some(&bytes)).jpeg_quality,
        Some(70)
    );
}

/// A tiny JPEG dataset (4 frames of the tiny preset at quality 85).
fn render_tiny_dataset(dir: &Path) {
    let mut p = common::tiny_preset();
    p.output.image_format = swarmshot::preset::ImageFormat::Jpeg { quality: 85 };
    let preset = dir.join("tiny.ron");
    std::fs::write(&preset, p.to_ron()).expect("preset");
    let out = swarmshot()
        .args(["batch"])
        .arg(&preset)
        .arg("--out")
        .arg(dir.join("ds"))
        .args(["--limit", "4"])
        .output()
        .expect("run batch");
    assert!(
        out.status.success(),
        "batch failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
}

#[test]
fn gap_cli_end_to_end_on_the_bundled_real_frames() {
    let tmp = tempfile::tempdir().expect("tmp");
    render_tiny_dataset(tmp.path());
    let real = common::testdata("real");
    let run = |out: &Path| {
        let o = swarmshot()
            .args(["gap", "--real"])
            .arg(&real)
            .arg("--synthetic")
            .arg(tmp.path().join("ds"))
            .arg("--out")
            .arg(out)
            .output()
            .expect("run gap");
        assert!(
            o.status.success(),
            "gap failed: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        String::from_utf8_lossy(&o.stdout).into_owned()
    };
    let a = tmp.path().join("report-a");
    let table = run(&a);
    for row in [
        "flat-sky noise σ",
        "gradient energy",
        "Canny edges",
        "sky saturation",
        "mean brightness",
        "blur: PSF σ",
        "JPEG quality",
        "drone core size",
        "darker than their ring",
    ] {
        assert!(table.contains(row), "no `{row}` row in:\n{table}");
    }
    assert!(
        table.contains("(10 of 10 images, 10 labelled, 10 drones)"),
        "{table}"
    );
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(a.join("report.json")).expect("json"))
            .expect("parse");
    let stats = json["statistics"].as_array().expect("statistics");
    assert!(stats.len() >= 14);
    for s in stats {
        assert!(
            ["inside", "below", "above", "n/a"].contains(&s["verdict"].as_str().expect("verdict")),
            "{s}"
        );
    }
    let by_key = |k: &str| stats.iter().find(|s| s["key"] == k).expect(k).clone();
    // The real frames are PNGs from H.264 video: no JPEG quality; the dataset's is 85.
    let q = by_key("jpeg_quality");
    assert!(q["real"].is_null());
    assert_eq!(q["synthetic"]["median"], 85.0);
    // Every real frame is labelled with one drone, and each is measured.
    assert_eq!(by_key("drone_core_px")["real"]["n"], 10);
    assert_eq!(json["real"]["frames"].as_array().expect("frames").len(), 10);
    // Ten frames are few: the table says so, naming each statistic and its count.
    let few = table
        .lines()
        .find(|l| l.starts_with("few real values"))
        .unwrap_or_else(|| panic!("no `few real values` line in:\n{table}"));
    assert!(
        few.contains("drone core size √(pixels > half the peak) (n=10)"),
        "{few}"
    );
    let small = by_key("small_drone_peak_contrast")["real"]["n"].clone();
    assert!(
        few.contains(&format!("peak contrast of 3–6 px drones (n={small})")),
        "{few}"
    );
    // Histograms are PNGs.
    let pngs: Vec<_> = std::fs::read_dir(&a)
        .expect("out")
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "png"))
        .filter(|p| p.file_name().is_some_and(|n| n != "contact_sheet.png"))
        .collect();
    assert!(pngs.len() >= 8, "{pngs:?}");
    for p in &pngs {
        let img = image::open(p).expect("decodes");
        assert_eq!(img.width(), 900);
    }
    // The rows added for fitting are there, marked not counted; the counted ones
    // are the original fourteen.
    let counted: Vec<&str> = stats
        .iter()
        .filter(|s| s["counted"] == true)
        .map(|s| s["key"].as_str().expect("key"))
        .collect();
    assert_eq!(counted.len(), 14, "{counted:?}");
    for key in [
        "background_texture",
        "drone_box_px",
        "behind_sky",
        "behind_vegetation",
        "behind_ground",
        "behind_building",
    ] {
        assert_eq!(by_key(key)["counted"], false, "{key}");
    }
    assert!(
        table.contains("not counted (measured for fitting):"),
        "{table}"
    );
    assert!(table.contains("counted statistics inside: "), "{table}");
    // Each real drone's box size is √(w·h) of its label (V_DRONE_001: 0.101562 × 640
    // by 0.087891 × 512).
    let d0 = &json["real"]["frames"][0]["drones"][0];
    let want = ((0.101_562f64 * 640.0) * (0.087_891 * 512.0)).sqrt();
    let got = d0["box_px"].as_f64().expect("box_px");
    assert!((got - want).abs() < 1e-3, "{got} vs {want}");
    assert!(d0["behind"].is_string(), "{d0}");
    // The contact sheet: its fixed size, and its left half the real frames' thumbnails
    // (frames 0, 1, 2, 3, 5, 6, 7, 8 of the ten, in name order).
    use swarmshot::gap::sheet;
    let contact = image::open(a.join("contact_sheet.png"))
        .expect("sheet")
        .to_rgb8();
    assert_eq!(contact.dimensions(), sheet::sheet_size());
    let mut names: Vec<_> = std::fs::read_dir(real.join("images"))
        .expect("real")
        .filter_map(|e| e.ok().map(|e| e.path()))
        .collect();
    names.sort();
    assert_eq!(sheet::picks(10), [0, 1, 2, 3, 5, 6, 7, 8]);
    for (cell, &i) in sheet::picks(10).iter().enumerate() {
        let thumb = sheet::thumbnail(&image::open(&names[i]).expect("frame").to_rgb8());
        let (x0, y0) = sheet::cell_origin(false, cell);
        assert!(x0 + sheet::THUMB_W <= contact.width() / 2);
        for (x, y, p) in thumb.enumerate_pixels() {
            assert_eq!(
                contact.get_pixel(x0 + x, y0 + y),
                p,
                "cell {cell} at {x},{y}"
            );
        }
    }
    // Deterministic: the same JSON again.
    let b = tmp.path().join("report-b");
    let table_b = run(&b);
    assert_eq!(table, table_b);
    assert_eq!(
        std::fs::read(a.join("report.json")).expect("a"),
        std::fs::read(b.join("report.json")).expect("b")
    );
    assert_eq!(
        std::fs::read(a.join("contact_sheet.png")).expect("a"),
        std::fs::read(b.join("contact_sheet.png")).expect("b")
    );
}

#[test]
fn gap_cli_refuses_bad_input_before_writing() {
    let tmp = tempfile::tempdir().expect("tmp");
    let out = tmp.path().join("report");
    // A missing folder is named.
    let o = swarmshot()
        .args(["gap", "--real", "/nonexistent/real", "--synthetic"])
        .arg(tmp.path())
        .arg("--out")
        .arg(&out)
        .output()
        .expect("run");
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("/nonexistent/real"));
    // A malformed label line is named with its file and line; nothing is written.
    let real = tmp.path().join("real");
    std::fs::create_dir_all(real.join("images")).expect("dir");
    std::fs::create_dir_all(real.join("labels")).expect("dir");
    grey(64, 64, |_, _| 100.0)
        .save(real.join("images/a.png"))
        .expect("png");
    std::fs::write(
        real.join("labels/a.txt"),
        "0 0.5 0.5 0.1 0.1\n0 0.5 oops 0.1 0.1\n",
    )
    .expect("txt");
    let ds = tmp.path().join("ds");
    std::fs::create_dir_all(ds.join("images/train")).expect("dir");
    grey(64, 64, |_, _| 100.0)
        .save(ds.join("images/train/00000000.png"))
        .expect("png");
    let o = swarmshot()
        .args(["gap", "--real"])
        .arg(&real)
        .arg("--synthetic")
        .arg(&ds)
        .arg("--out")
        .arg(&out)
        .output()
        .expect("run");
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("a.txt") && err.contains("line 2") && err.contains("oops"),
        "{err}"
    );
    assert!(!out.exists(), "nothing may be written on bad input");
    // A folder that is not a dataset is refused as such.
    std::fs::write(real.join("labels/a.txt"), "0 0.5 0.5 0.1 0.1\n").expect("txt");
    let notes = tmp.path().join("notes");
    std::fs::create_dir(&notes).expect("dir");
    std::fs::write(notes.join("a.txt"), "0 0.5 0.5 0.1 0.1\n").expect("txt");
    let o = swarmshot()
        .args(["gap", "--real"])
        .arg(&real)
        .arg("--synthetic")
        .arg(&notes)
        .output()
        .expect("run");
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("no images/ folder"));
}

// ---- inputs of gap (issue 35, "Trust, round four") --------------------------

/// A real folder (`images/a.png`, `labels/a.txt` holding `labels`) and a
/// dataset (`ds/images/train/00000000.png`) of 640×512 noisy grey frames.
fn small_sides(dir: &Path, labels: &str) -> (std::path::PathBuf, std::path::PathBuf) {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
    let noise: Vec<f64> = (0..640 * 512).map(|_| 2.0 * normal(&mut rng)).collect();
    let img = grey(640, 512, |x, y| 120.0 + noise[(y * 640 + x) as usize]);
    let real = dir.join("real");
    std::fs::create_dir_all(real.join("images")).expect("dir");
    std::fs::create_dir_all(real.join("labels")).expect("dir");
    img.save(real.join("images/a.png")).expect("png");
    std::fs::write(real.join("labels/a.txt"), labels).expect("txt");
    let ds = dir.join("ds");
    std::fs::create_dir_all(ds.join("images/train")).expect("dir");
    img.save(ds.join("images/train/00000000.png")).expect("png");
    (real, ds)
}

fn gap_run(real: &Path, ds: &Path, out: Option<&Path>) -> std::process::Output {
    let mut c = swarmshot();
    c.args(["gap", "--json", "--real"])
        .arg(real)
        .arg("--synthetic")
        .arg(ds);
    if let Some(out) = out {
        c.arg("--out").arg(out);
    }
    c.output().expect("run gap")
}

#[test]
fn gap_refuses_an_out_inside_its_inputs_and_never_counts_its_own_report() {
    let tmp = tempfile::tempdir().expect("tmp");
    let (real, ds) = small_sides(tmp.path(), "0 0.5 0.5 0.02 0.02\n");
    std::os::unix::fs::symlink(&real, tmp.path().join("link")).expect("symlink");
    for (out, needle) in [
        (real.clone(), "the same folder as --real"),
        (real.join("report"), "inside --real"),
        (real.join("new/../deeper/report"), "inside --real"),
        (ds.join("images/new/report"), "inside --synthetic"),
        (ds.clone(), "the same folder as --synthetic"),
        // Through a link: compared canonically.
        (tmp.path().join("link/report"), "inside --real"),
    ] {
        let o = gap_run(&real, &ds, Some(&out));
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{}: accepted", out.display());
        assert!(
            err.contains(&format!("--out {}", out.display())) && err.contains(needle),
            "{}: {err}",
            out.display()
        );
        assert!(
            !real.join("report").exists() && !real.join("report.json").exists(),
            "{}: something was written",
            out.display()
        );
        assert!(!o.stdout.starts_with(b"{"), "refused before measuring");
    }
    assert!(!real.join("new").exists() && !real.join("deeper").exists());
    assert!(!ds.join("images/new").exists());
    // A report beside the inputs is fine; copied into the real folder (an old
    // run's, or moved there), its histograms are not counted as frames.
    let rep = tmp.path().join("rep");
    let o = gap_run(&real, &ds, Some(&rep));
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let hists = std::fs::read_dir(&rep)
        .expect("rep")
        .filter(|e| {
            e.as_ref()
                .is_ok_and(|e| e.path().extension().is_some_and(|x| x == "png"))
        })
        .count();
    assert!(hists > 0);
    let inside = real.join("images/old-report");
    std::fs::create_dir_all(&inside).expect("dir");
    for e in std::fs::read_dir(&rep).expect("rep") {
        let p = e.expect("entry").path();
        std::fs::copy(&p, inside.join(p.file_name().expect("name"))).expect("copy");
    }
    let o = gap_run(&real, &ds, None);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let json: serde_json::Value = serde_json::from_slice(&o.stdout).expect("json");
    assert_eq!(json["real"]["images_found"], 1, "{}", json["real"]);
}

#[test]
fn label_files_are_read_in_linear_time_with_a_line_limit() {
    let tmp = tempfile::tempdir().expect("tmp");
    // 10⁶ lines (14 MB): refused at the limit, naming the file, in well under a second
    // (it ran for tens of minutes).
    let million = "0 .5 .5 .1 .1\n".repeat(1_000_000);
    assert_eq!(million.len(), 14_000_000);
    let (real, ds) = small_sides(tmp.path(), &million);
    let t = Instant::now();
    let o = gap_run(&real, &ds, None);
    let secs = t.elapsed().as_secs_f64();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert!(
        err.contains("a.txt") && err.contains("100000-line limit"),
        "{err}"
    );
    assert!(secs < 5.0, "{secs:.2} s");
    // 10⁵ small boxes, at the limit: read and measured in linear time.
    let at_limit: String = (0..100_000)
        .map(|i| {
            let (x, y) = (
                0.01 + 0.98 * f64::from(i % 317) / 317.0,
                0.01 + 0.98 * f64::from(i / 317) / 316.0,
            );
            format!("0 {x:.5} {y:.5} 0.005 0.005\n")
        })
        .collect();
    std::fs::write(real.join("labels/a.txt"), at_limit).expect("txt");
    let t = Instant::now();
    let o = gap_run(&real, &ds, None);
    let secs = t.elapsed().as_secs_f64();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let json: serde_json::Value = serde_json::from_slice(&o.stdout).expect("json");
    assert_eq!(
        json["real"]["frames"][0]["drones"]
            .as_array()
            .expect("drones")
            .len(),
        100_000
    );
    eprintln!("10^5 boxes: {secs:.2} s");
    assert!(secs < 60.0, "{secs:.2} s");
}

#[test]
fn yolo_values_out_of_range_and_bad_classes_are_named_with_file_and_line() {
    let tmp = tempfile::tempdir().expect("tmp");
    let (real, ds) = small_sides(tmp.path(), "");
    for (line, needle) in [
        ("0 1.5 0.5 0.1 0.1", "cx 1.5 is outside [0, 1]"),
        ("0 0.5 -0.2 0.1 0.1", "cy -0.2 is outside [0, 1]"),
        ("0 0.5 0.5 2 0.1", "w 2 is outside [0, 1]"),
        ("0 0.5 0.5 0.1 NaN", "`NaN` is not a number"),
        ("0 0.5 0.5 inf 0.1", "`inf` is not a number"),
        ("-1 0.5 0.5 0.1 0.1", "class `-1` is not a whole number"),
        ("1.5 0.5 0.5 0.1 0.1", "class `1.5` is not a whole number"),
        ("x 0.5 0.5 0.1 0.1", "class `x` is not a whole number"),
    ] {
        std::fs::write(
            real.join("labels/a.txt"),
            format!("0 0.5 0.5 0.1 0.1\n{line}\n"),
        )
        .expect("txt");
        let o = gap_run(&real, &ds, None);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{line}: accepted");
        assert!(
            err.contains("a.txt") && err.contains("line 2") && err.contains(needle),
            "{line}: {err}"
        );
    }
    // Within the tolerance, and whole classes written as decimals, are read.
    std::fs::write(
        real.join("labels/a.txt"),
        "3 1.0005 0.5 0.1 0.1\n2.0 0.5 -0.0005 0.1 0.1\n",
    )
    .expect("txt");
    let o = gap_run(&real, &ds, None);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    // Boxes past 16 frames' area are refused, not measured for minutes (each row a
    // little different: an exact repeat of a row is dropped, not measured).
    let rows: String = (0..17)
        .map(|i| format!("0 0.5 0.5 1 {}\n", 1.0 - f64::from(i) * 0.001))
        .collect();
    std::fs::write(real.join("labels/a.txt"), rows).expect("txt");
    let o = gap_run(&real, &ds, None);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success() && err.contains("line 17") && err.contains("16 times over"),
        "{err}"
    );
}

#[test]
fn oversized_and_truncated_frames_are_refused_naming_the_file() {
    let tmp = tempfile::tempdir().expect("tmp");
    let (real, ds) = small_sides(tmp.path(), "0 0.5 0.5 0.1 0.1\n");
    // 20000×20000 (400 megapixels) from a header of a few dozen bytes: refused
    // before any pixel buffer, on either side.
    std::fs::write(
        real.join("images/huge.png"),
        common::png_header(20_000, 20_000),
    )
    .expect("png");
    let o = gap_run(&real, &ds, None);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success()
            && err.contains("huge.png")
            && err.contains("20000×20000")
            && err.contains("64000000-pixel limit"),
        "{err}"
    );
    std::fs::remove_file(real.join("images/huge.png")).expect("rm");
    std::fs::write(
        ds.join("images/train/00000001.png"),
        common::png_header(9_000, 8_000),
    )
    .expect("png");
    let o = gap_run(&real, &ds, None);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success() && err.contains("00000001.png") && err.contains("64000000-pixel"),
        "{err}"
    );
    std::fs::remove_file(ds.join("images/train/00000001.png")).expect("rm");
    // A JPEG cut to half decodes (grey fill) but is refused as truncated.
    let jpeg = std::fs::read(common::testdata("plates/V_DRONE_010.jpg")).expect("plate");
    assert!(image::load_from_memory(&jpeg[..jpeg.len() / 2]).is_ok());
    std::fs::write(real.join("images/half.jpg"), &jpeg[..jpeg.len() / 2]).expect("jpg");
    let o = gap_run(&real, &ds, None);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success()
            && err.contains(&format!(
                "{}: truncated JPEG (",
                real.join("images/half.jpg").display()
            )),
        "{err}"
    );
    // The whole JPEG, and one with zero padding after its end, are read.
    let mut padded = jpeg.clone();
    padded.extend([0u8; 4096]);
    std::fs::write(real.join("images/half.jpg"), &padded).expect("jpg");
    let o = gap_run(&real, &ds, None);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

#[test]
fn iqr_distance_is_zero_inside_and_counts_iqr_widths_outside() {
    use swarmshot::gap::report::{distribution, iqr_distance, share};
    // Real 1..5: quartiles 2 and 4, an IQR of 2.
    let real = distribution(&[1.0, 2.0, 3.0, 4.0, 5.0]);
    let at = |m: f64| iqr_distance(real, distribution(&[m])).expect("both sides");
    assert_eq!(at(3.0), 0.0);
    assert_eq!(at(2.0), 0.0);
    assert_eq!(at(4.0), 0.0);
    assert_eq!(at(7.0), (7.0 - 4.0) / 2.0);
    assert_eq!(at(1.0), (2.0 - 1.0) / 2.0);
    assert_eq!(iqr_distance(real, None), None);
    assert_eq!(iqr_distance(None, distribution(&[1.0])), None);
    // An all-equal real side (every frame JPEG 85) counts as 0.1 % of the median wide.
    let q85 = distribution(&[85.0; 6]);
    let d = iqr_distance(q85, distribution(&[80.0])).expect("both");
    assert!((d - 5.0 / 0.08).abs() < 1e-9, "{d}");
    // Shares: against the real share's 50 % Wilson interval.
    let r = share(&[true, false, false, false]);
    let Some(swarmshot::gap::report::Summary::Share { high, low, .. }) = r else {
        panic!("share")
    };
    let d = iqr_distance(r, share(&[true; 4])).expect("both");
    assert!((d - (1.0 - high) / (high - low)).abs() < 1e-12, "{d}");
}

/// A 320×240 frame of `background` with a dark 12×12 drone at its centre.
fn drone_over(background: impl Fn(u32, u32) -> [u8; 3]) -> swarmshot::gap::FrameStats {
    let img = RgbImage::from_fn(320, 240, |x, y| {
        if (154..166).contains(&x) && (114..126).contains(&y) {
            Rgb([20, 20, 20])
        } else {
            Rgb(background(x, y))
        }
    });
    let b = PixelBox {
        x0: 153.0,
        y0: 113.0,
        x1: 167.0,
        y1: 127.0,
    };
    measure_frame(&img, &[b], None)
}

#[test]
fn what_lies_behind_a_drone_is_read_from_its_ring() {
    use swarmshot::gap::Behind;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
    let mut noise =
        |amp: f64| -> Vec<f64> { (0..320 * 240).map(|_| amp * normal(&mut rng)).collect() };
    let n1 = noise(1.0);
    let n30 = noise(30.0);
    let at = |n: &Vec<f64>, x: u32, y: u32, base: f64| {
        (base + n[(y * 320 + x) as usize]).round().clamp(0.0, 255.0) as u8
    };
    type Background<'a> = Box<dyn Fn(u32, u32) -> [u8; 3] + 'a>;
    let cases: Vec<(&str, Behind, Background)> = vec![
        // A clear blue sky with a little noise.
        (
            "blue sky",
            Behind::Sky,
            Box::new(|x, y| {
                [
                    at(&n1, x, y, 90.0),
                    at(&n1, x, y, 140.0),
                    at(&n1, x, y, 210.0),
                ]
            }),
        ),
        // An overcast, colourless pale sky.
        (
            "overcast",
            Behind::Sky,
            Box::new(|x, y| {
                [
                    at(&n1, x, y, 200.0),
                    at(&n1, x, y, 200.0),
                    at(&n1, x, y, 206.0),
                ]
            }),
        ),
        // Foliage: green and strongly textured.
        (
            "foliage",
            Behind::Vegetation,
            Box::new(|x, y| {
                [
                    at(&n30, x, y, 50.0),
                    at(&n30, x, y, 110.0),
                    at(&n30, x, y, 40.0),
                ]
            }),
        ),
        // Bare branches: grey-brown, textured every which way.
        (
            "branches",
            Behind::Vegetation,
            Box::new(|x, y| {
                let v = at(&n30, x, y, 90.0);
                [v, v.saturating_sub(8), v.saturating_sub(16)]
            }),
        ),
        // A flat brown field.
        (
            "field",
            Behind::Ground,
            Box::new(|x, y| {
                [
                    at(&n1, x, y, 110.0),
                    at(&n1, x, y, 90.0),
                    at(&n1, x, y, 60.0),
                ]
            }),
        ),
        // A grey facade with a grid of dark windows: axis-aligned edges both ways.
        (
            "facade",
            Behind::Building,
            Box::new(|x, y| {
                if x % 10 < 5 && y % 10 < 5 {
                    [40, 40, 45]
                } else {
                    [150, 145, 140]
                }
            }),
        ),
    ];
    for (what, want, bg) in cases {
        let s = drone_over(bg);
        assert_eq!(s.drones.len(), 1, "{what}");
        let d = s.drones[0];
        assert_eq!(d.behind, Some(want), "{what}");
        assert_eq!(d.box_px, 14.0, "{what}");
    }
}

#[test]
fn background_texture_is_the_median_tile_sigma_away_from_drones() {
    // 960×540 (already 540 high, so not rescaled): the left two thirds in 8 px bands
    // of 100 and 140 levels (every 16 px tile: σ 20), the rest flat.
    let img = grey(960, 540, |x, _| {
        if x < 640 && (x / 8) % 2 == 1 {
            140.0
        } else {
            100.0
        }
    });
    let s = measure_frame(&img, &[], None);
    assert_eq!(s.background_texture, Some(20.0));
    let flat = measure_frame(&grey(960, 540, |_, _| 100.0), &[], None);
    assert_eq!(flat.background_texture, Some(0.0));
    // A box over the banded part leaves only flat tiles: median 0.
    let b = PixelBox {
        x0: 0.0,
        y0: 0.0,
        x1: 640.0,
        y1: 540.0,
    };
    let boxed = measure_frame(&img, &[b], None);
    assert_eq!(boxed.background_texture, Some(0.0));
    // A 1080-high frame is measured at 540: bands twice as wide give the same σ.
    let big = grey(1920, 1080, |x, _| {
        if x < 1280 && (x / 16) % 2 == 1 {
            140.0
        } else {
            100.0
        }
    });
    let t = measure_frame(&big, &[], None)
        .background_texture
        .expect("tiles");
    // (the 2:1 Triangle filter softens each band's edge: within 10 %).
    assert!((t - 20.0).abs() < 2.0, "{t}");
}

#[test]
fn the_contact_sheet_puts_real_left_and_synthetic_right() {
    use swarmshot::gap::sheet;
    let solid = |c: [u8; 3], w: u32, h: u32| RgbImage::from_pixel(w, h, Rgb(c));
    // A 4:3 frame fills its cell; a 2:1 one is letterboxed, centred.
    let t = sheet::thumbnail(&solid([200, 0, 0], 640, 480));
    assert_eq!(t.dimensions(), (sheet::THUMB_W, sheet::THUMB_H));
    assert!(t.pixels().all(|p| p.0 == [200, 0, 0]));
    let wide = sheet::thumbnail(&solid([0, 200, 0], 800, 400));
    assert_eq!(wide.get_pixel(120, 90).0, [0, 200, 0]);
    assert_eq!(wide.get_pixel(120, 0).0, [32, 32, 32]);
    let real = vec![t.clone(); 3];
    let synthetic = vec![wide.clone(); 8];
    let s = sheet::contact_sheet(&real, &synthetic, ["real", "synthetic"]).expect("sheet");
    assert_eq!(s.dimensions(), sheet::sheet_size());
    assert_eq!(
        s.dimensions(),
        (4 * sheet::THUMB_W, sheet::HEADER_PX + 4 * sheet::THUMB_H)
    );
    for i in 0..sheet::SHEET_FRAMES {
        let (x, y) = sheet::cell_origin(false, i);
        let want = if i < 3 { [200, 0, 0] } else { [32, 32, 32] };
        assert_eq!(s.get_pixel(x + 5, y + 5).0, want, "real cell {i}");
        let (x, y) = sheet::cell_origin(true, i);
        assert!(x >= s.width() / 2);
        assert_eq!(
            s.get_pixel(x + 120, y + 90).0,
            [0, 200, 0],
            "synthetic cell {i}"
        );
    }
    // Evenly spaced, deterministic picks.
    assert_eq!(sheet::picks(3), [0, 1, 2]);
    assert_eq!(sheet::picks(16), [0, 2, 4, 6, 8, 10, 12, 14]);
    assert!(sheet::picks(0).is_empty());
}

/// A tiny dataset whose gulls are labelled as their own class ("bird", class 1).
fn render_dataset_with_labelled_birds(dir: &Path) -> std::path::PathBuf {
    let mut p = common::tiny_preset();
    p.confusers = vec![
        ron::from_str(
            r#"(kind: Bird(Gull), count: (4, 4), distance_m: (6.0, 9.0), labelled_as: Some("bird"))"#,
        )
        .expect("confuser"),
    ];
    let preset = dir.join("birds.ron");
    std::fs::write(&preset, p.to_ron()).expect("preset");
    let ds = dir.join("ds-birds");
    let o = swarmshot()
        .arg("batch")
        .arg(&preset)
        .arg("--out")
        .arg(&ds)
        .args(["--limit", "4"])
        .output()
        .expect("run batch");
    assert!(
        o.status.success(),
        "batch: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    ds
}

/// `gap --json` with `extra`; the report.
fn gap_json(real: &Path, ds: &Path, extra: &[&str]) -> serde_json::Value {
    let o = swarmshot()
        .args(["gap", "--json", "--real"])
        .arg(real)
        .arg("--synthetic")
        .arg(ds)
        .args(extra)
        .output()
        .expect("run gap");
    assert!(
        o.status.success(),
        "gap: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    serde_json::from_slice(&o.stdout).expect("json")
}

/// A statistic's side of a report.
fn side_stat(report: &serde_json::Value, key: &str, side: &str) -> serde_json::Value {
    let stats = report["statistics"].as_array().expect("statistics");
    stats.iter().find(|s| s["key"] == key).expect(key)[side].clone()
}

#[test]
fn only_the_drone_classes_are_measured_on_each_side() {
    let tmp = tempfile::tempdir().expect("tmp");
    let real = tmp.path().join("real-birds");
    common::real_frames_with_row(&real, "2 0.3 0.3 0.2 0.2");
    let ds = render_dataset_with_labelled_birds(tmp.path());
    let rows = |class: &str| -> usize {
        let labels = walkdir(&ds.join("labels"));
        let lines = labels.iter().flat_map(|p| {
            let text = std::fs::read_to_string(p).expect("label");
            text.lines().map(str::to_owned).collect::<Vec<_>>()
        });
        lines.filter(|l| l.split(' ').next() == Some(class)).count()
    };
    assert!(
        rows("1") > 0,
        "no bird was labelled: the test shows nothing"
    );
    let plain = gap_json(&common::testdata("real"), &ds, &[]);
    let all = gap_json(&real, &ds, &["--synthetic-classes", "all"]);
    let picked = gap_json(&real, &ds, &["--real-classes", "0"]);
    // Real side: the bird rows are drones by default, left out with --real-classes 0,
    // which then measures exactly what the labels without them measure.
    let n = |r: &serde_json::Value, side| side_stat(r, "drone_core_px", side)["n"].clone();
    assert_eq!(n(&all, "real"), 20);
    assert_eq!(n(&picked, "real"), 10);
    for key in [
        "drone_core_px",
        "drone_darker",
        "noise_sigma",
        "gradient_energy",
    ] {
        assert_eq!(
            side_stat(&picked, key, "real"),
            side_stat(&plain, key, "real"),
            "{key}"
        );
    }
    assert_eq!(picked["real"]["drone_classes"], "0");
    // Synthetic side: by default the dataset's models' class (0) only, from its lock.
    assert_eq!(picked["synthetic"]["drone_classes"], "0");
    assert_eq!(all["synthetic"]["drone_classes"], "all");
    let (drones, with_birds) = (n(&picked, "synthetic"), n(&all, "synthetic"));
    let (drones, with_birds) = (drones.as_u64().expect("n"), with_birds.as_u64().expect("n"));
    assert!(
        drones > 0 && drones < with_birds,
        "{drones} against {with_birds}"
    );
    assert!(with_birds as usize <= rows("0") + rows("1"));
    // A bad list is named with its option.
    let o = swarmshot()
        .args(["gap", "--real"])
        .arg(&real)
        .arg("--synthetic")
        .arg(&ds)
        .args(["--real-classes", "0,bird"])
        .output()
        .expect("run gap");
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert!(
        err.contains("--real-classes") && err.contains("`bird` is not a class id"),
        "{err}"
    );
    // A list that matches none of a side's rows is refused, naming the rows' classes.
    let refused = |flag: &str, list: &str| -> String {
        let o = swarmshot()
            .args(["gap", "--real"])
            .arg(&real)
            .arg("--synthetic")
            .arg(&ds)
            .args([flag, list])
            .output()
            .expect("run gap");
        assert!(!o.status.success(), "{flag} {list}: accepted");
        String::from_utf8_lossy(&o.stderr).into_owned()
    };
    let err = refused("--real-classes", "7");
    assert!(
        err.contains("--real-classes 7: none of the 20 label rows read is of these classes (the rows' classes: 0, 2)"),
        "{err}"
    );
    let err = refused("--synthetic-classes", "5,9");
    assert!(
        err.contains("--synthetic-classes 5,9: none of the")
            && err.contains("(the rows' classes: 0, 1)"),
        "{err}"
    );
}

/// Every file below `dir`.
fn walkdir(dir: &Path) -> Vec<std::path::PathBuf> {
    let mut out = Vec::new();
    for e in std::fs::read_dir(dir).expect("read") {
        let p = e.expect("entry").path();
        if p.is_dir() {
            out.extend(walkdir(&p));
        } else {
            out.push(p);
        }
    }
    out
}
