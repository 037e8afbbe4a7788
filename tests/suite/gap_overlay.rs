//! Burnt-in overlays (src/gap/overlay.rs): on-screen text and a reticle drawn into a grey
//! frame are found and left out of every statistic, so the frame measures as it did
//! without them; a colour frame is measured as before (no overlay rule).

use image::{Rgb, RgbImage};
use rand::{Rng, SeedableRng};
use swarmshot::gap::{FrameStats, PixelBox, measure_frame};

/// A grey thermal-like frame: a sky warming downwards with Gaussian noise σ 2, a darker
/// ground below a blurred horizon at row 400, and a warm blob (the drone) in `drone`.
fn frame(drone: PixelBox) -> RgbImage {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(41);
    let (cx, cy) = (0.5 * (drone.x0 + drone.x1), 0.5 * (drone.y0 + drone.y1));
    RgbImage::from_fn(640, 512, |x, y| {
        let (xf, yf) = (f64::from(x), f64::from(y));
        let horizon = 1.0 / (1.0 + (-(yf - 400.0) / 0.8).exp());
        let sky = 80.0 + 0.08 * yf + 0.01 * xf;
        let blob =
            90.0 * (-((xf - f64::from(cx)).powi(2) + (yf - f64::from(cy)).powi(2)) / 18.0).exp();
        let u1: f64 = rng.random_range(1e-12..1.0);
        let u2: f64 = rng.random::<f64>();
        let n = (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos();
        let v = (sky * (1.0 - horizon) + 60.0 * horizon + blob + 2.0 * n)
            .round()
            .clamp(0.0, 255.0) as u8;
        Rgb([v, v, v])
    })
}

fn rect(img: &mut RgbImage, x0: u32, y0: u32, w: u32, h: u32, v: u8) {
    for y in y0..y0 + h {
        for x in x0..x0 + w {
            img.put_pixel(x, y, Rgb([v, v, v]));
        }
    }
}

/// On-screen text (rows of 2 px glyph strokes, white, top left and top right; a line of
/// dense glyphs) and a
/// reticle (2 px corner brackets, white over the sky, black over the ground; a cross).
fn draw_overlay(img: &mut RgbImage) {
    for (x0, y0) in [(10u32, 10u32), (440, 10), (10, 50)] {
        for g in 0..9 {
            let x = x0 + g * 20;
            rect(img, x, y0, 2, 16, 255); // |
            rect(img, x, y0, 12, 2, 255); // top
            rect(img, x, y0 + 7, 10, 2, 255); // middle
            rect(
                img,
                x + 10 * (g % 2),
                y0 + 14,
                2 + 10 * ((g + 1) % 2),
                2,
                255,
            );
        }
    }
    for (x, y) in [(120u32, 120u32), (500, 120)] {
        rect(img, x, y, 60, 2, 255);
        rect(img, x + 29, y, 2, 60, 255);
    }
    for (x, y) in [(120u32, 430u32), (500, 430)] {
        rect(img, x, y, 60, 2, 0);
        rect(img, x + 29, y - 20, 2, 60, 0);
    }
    rect(img, 318, 20, 2, 70, 255); // the cross's upper arm
    rect(img, 20, 255, 80, 2, 255); // its left arm
    // A line of text as CJK characters are burnt in: a plain glyph, then dense glyphs
    // (1 px strokes 3 px apart, a mid-grey anti-aliased row under each, 4 px apart)
    // whose strokes do not stand out one by one.
    let (x0, y0) = (340u32, 40u32);
    rect(img, x0, y0, 2, 16, 255);
    rect(img, x0, y0, 12, 2, 255);
    rect(img, x0, y0 + 14, 12, 2, 255);
    for g in 0..5 {
        let x = x0 + 16 + g * 18;
        rect(img, x, y0, 1, 16, 255);
        for k in 0..6 {
            rect(img, x, y0 + 3 * k, 14, 1, 255);
            rect(img, x + 1, y0 + 3 * k + 1, 13, 1, 190);
        }
    }
}

fn close(name: &str, clean: f32, with: f32, tol: f32) {
    assert!(
        (clean - with).abs() <= tol,
        "{name}: {clean} without the overlay, {with} with it (tolerance {tol})"
    );
}

fn compare(clean: &FrameStats, with: &FrameStats) {
    let opt = |v: Option<f32>| v.expect("a value");
    close(
        "noise σ",
        opt(clean.noise_sigma),
        opt(with.noise_sigma),
        0.03 * opt(clean.noise_sigma),
    );
    close(
        "high-pass RMS",
        opt(clean.highpass_rms),
        opt(with.highpass_rms),
        0.03 * opt(clean.highpass_rms),
    );
    close(
        "gradient energy",
        clean.gradient_energy,
        with.gradient_energy,
        0.05 * clean.gradient_energy,
    );
    close(
        "Canny share",
        clean.canny_edge_share,
        with.canny_edge_share,
        0.002,
    );
    close(
        "mean brightness",
        clean.mean_brightness,
        with.mean_brightness,
        0.5,
    );
    close(
        "vertical gradient",
        clean.vertical_gradient,
        with.vertical_gradient,
        1.0,
    );
    close(
        "blur σ",
        opt(clean.blur_sigma_px),
        opt(with.blur_sigma_px),
        0.05,
    );
    close(
        "background texture",
        opt(clean.background_texture),
        opt(with.background_texture),
        0.05,
    );
    let (a, b) = (clean.drones[0], with.drones[0]);
    close("drone peak", a.peak, b.peak, 1.0);
    close("drone core", a.core_px, b.core_px, 0.5);
}

#[test]
fn a_burnt_in_overlay_leaves_every_statistic_where_it_was() {
    let drone = PixelBox {
        x0: 300.0,
        y0: 200.0,
        x1: 316.0,
        y1: 216.0,
    };
    let clean_img = frame(drone);
    let mut with_img = clean_img.clone();
    draw_overlay(&mut with_img);
    let clean = measure_frame(&clean_img, &[drone], None);
    let with = measure_frame(&with_img, &[drone], None);
    assert!(clean.grey && with.grey);
    assert_eq!(clean.overlay_px, None, "the clean frame has no overlay");
    let found = with.overlay_px.expect("the overlay is found");
    assert!(found > 1500, "{found} overlay pixels found");
    compare(&clean, &with);
    // The overlay matters: measured as a colour frame (no overlay rule: a tinted copy),
    // its strokes' sharp edges move the gradient energy and the Canny share.
    let tinted = RgbImage::from_fn(640, 512, |x, y| {
        let v = with_img.get_pixel(x, y)[0];
        Rgb([v, v.saturating_sub(40), v / 2])
    });
    let colour = measure_frame(&tinted, &[drone], None);
    assert!(!colour.grey && colour.overlay_px.is_none());
    assert!(
        colour.canny_edge_share > clean.canny_edge_share + 0.005,
        "without the rule the overlay's edges count: Canny {} against {}",
        colour.canny_edge_share,
        clean.canny_edge_share
    );
}

#[test]
fn thin_strokes_inside_a_labelled_box_are_not_overlay() {
    // A hot drone drawn as thin saturated arms, labelled: never taken for overlay.
    let drone = PixelBox {
        x0: 280.0,
        y0: 180.0,
        x1: 340.0,
        y1: 240.0,
    };
    let mut img = frame(PixelBox {
        x0: 0.0,
        y0: 0.0,
        x1: 1.0,
        y1: 1.0,
    });
    rect(&mut img, 282, 209, 56, 2, 255);
    rect(&mut img, 309, 182, 2, 56, 255);
    let s = measure_frame(&img, &[drone], None);
    assert_eq!(s.overlay_px, None);
    assert!(s.drones[0].peak > 100.0);
}
