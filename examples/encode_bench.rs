//! JPEG encode benchmark (a measurement, not a test): the encoder the batch used
//! before (jpeg-encoder 0.7, RGBA→RGB copy first) against [`encode_image`]
//! (libjpeg-turbo via `turbojpeg`, straight from RGBA), on one 1920×1080 frame.
//!
//! Run: `cargo run --release --example encode_bench -- [FRAME.png] [N] [QUALITY]`.
//! FRAME.png is a rendered frame (e.g. `swarmshot frame presets/quickstart.ron
//! --index 13 --out /tmp/f.png`); without it a sky gradient with noise and small
//! dark blobs is synthesised. N defaults to 50, QUALITY to 85.
#![allow(clippy::unwrap_used)]

use std::time::Instant;

use swarmshot::preset::ImageFormat;
use swarmshot::write::encode_image;

fn synthetic(width: u32, height: u32) -> Vec<u8> {
    let mut state = 0x9e37_79b9_u32;
    let mut rgba = Vec::with_capacity((width * height * 4) as usize);
    for y in 0..height {
        for x in 0..width {
            state ^= state << 13;
            state ^= state >> 17;
            state ^= state << 5;
            let n = (state % 9) as f32 - 4.0;
            let t = y as f32 / height as f32;
            let mut rgb = [90.0 + 120.0 * t, 140.0 + 80.0 * t, 230.0 - 10.0 * t];
            if (x / 12) % 41 == 7 && (y / 8) % 29 == 11 {
                rgb = [30.0, 30.0, 35.0];
            }
            rgba.extend(rgb.map(|c| (c + n).clamp(0.0, 255.0) as u8));
            rgba.push(255);
        }
    }
    rgba
}

/// What `encode_image` did before: drop alpha into a new buffer, then jpeg-encoder.
fn old_encoder(rgba: &[u8], width: u32, height: u32, quality: u8) -> Vec<u8> {
    let rgb: Vec<u8> = rgba
        .chunks_exact(4)
        .flat_map(|p| [p[0], p[1], p[2]])
        .collect();
    let mut out = Vec::with_capacity(rgb.len() / 8);
    jpeg_encoder::Encoder::new(&mut out, quality)
        .encode(
            &rgb,
            width as u16,
            height as u16,
            jpeg_encoder::ColorType::Rgb,
        )
        .unwrap();
    out
}

/// Milliseconds of one call, and the size of what it returned.
fn time(f: impl FnOnce() -> Vec<u8>) -> (f64, usize) {
    let t = Instant::now();
    let size = std::hint::black_box(f()).len();
    (t.elapsed().as_secs_f64() * 1e3, size)
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (rgba, w, h, source) = match args.first().filter(|a| a.ends_with(".png")) {
        Some(path) => {
            let img = image::open(path).unwrap().to_rgba8();
            let (w, h) = img.dimensions();
            (img.into_raw(), w, h, path.clone())
        }
        None => (synthetic(1920, 1080), 1920, 1080, "synthetic sky".into()),
    };
    let rest: Vec<&String> = args.iter().filter(|a| !a.ends_with(".png")).collect();
    let n: usize = rest.first().map_or(50, |s| s.parse().unwrap());
    let quality: u8 = rest.get(1).map_or(85, |s| s.parse().unwrap());
    println!("{source}: {w}×{h}, q{quality}, {n} runs each (median, min, max)");
    // Warm up both (page faults, SIMD dispatch, libjpeg-turbo's tables).
    old_encoder(&rgba, w, h, quality);
    encode_image(&rgba, w, h, ImageFormat::Jpeg { quality }).unwrap();
    // Interleave the two so load changes hit both alike.
    let (mut old, mut new) = (Vec::new(), Vec::new());
    let (mut old_size, mut new_size) = (0, 0);
    for _ in 0..n {
        let (ms, size) = time(|| old_encoder(&rgba, w, h, quality));
        old.push(ms);
        old_size = size;
        let (ms, size) = time(|| encode_image(&rgba, w, h, ImageFormat::Jpeg { quality }).unwrap());
        new.push(ms);
        new_size = size;
    }
    for (name, mut ms, size) in [
        ("jpeg-encoder 0.7 (old)", old, old_size),
        ("turbojpeg / libjpeg-turbo (new)", new, new_size),
    ] {
        ms.sort_by(f64::total_cmp);
        println!(
            "{name:32} median {:6.2} ms  min {:6.2}  max {:6.2}  {:4} KiB",
            ms[n / 2],
            ms[0],
            ms[n - 1],
            size / 1024
        );
    }
}
