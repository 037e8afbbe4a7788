//! JPEG/PNG encoding of rendered frames: the JPEG decodes to the same size and
//! nearly the same pixels, carries the preset's quality and chroma subsampling,
//! and is byte-identical run to run; bad input is a named error.

use swarmshot::preset::ImageFormat;
use swarmshot::write::{OutputError, encode_image};

/// A sky-like frame: a vertical blue gradient, mild deterministic noise, and a
/// few small dark "drones" with sharp edges. RGBA8, alpha 255.
fn frame(width: u32, height: u32) -> Vec<u8> {
    let mut state = 0x2545_f491_u32;
    let mut noise = move || {
        state ^= state << 13;
        state ^= state >> 17;
        state ^= state << 5;
        (state % 9) as i32 - 4
    };
    let mut rgba = Vec::with_capacity((width * height * 4) as usize);
    for y in 0..height {
        for x in 0..width {
            let t = y as f32 / height as f32;
            let mut rgb = [
                (90.0 + 120.0 * t) as i32,
                (140.0 + 80.0 * t) as i32,
                (230.0 - 10.0 * t) as i32,
            ];
            if (x / 8) % 23 == 5 && (y / 6) % 17 == 3 {
                rgb = [30, 30, 35];
            }
            for c in rgb {
                rgba.push((c + noise()).clamp(0, 255) as u8);
            }
            rgba.push(255);
        }
    }
    rgba
}

/// Mean absolute error over RGB (0–255) between an RGBA8 source and an RGB8 image.
fn mae(rgba: &[u8], rgb: &[u8]) -> f64 {
    let sum: u64 = rgba
        .chunks_exact(4)
        .zip(rgb.chunks_exact(3))
        .flat_map(|(a, b)| (0..3).map(move |c| u64::from(a[c].abs_diff(b[c]))))
        .sum();
    sum as f64 / rgb.len() as f64
}

/// The (horizontal, vertical) sampling factors of each component in the SOF0 segment.
fn sof0_sampling(jpeg: &[u8]) -> Vec<(u8, u8)> {
    let at = jpeg
        .windows(2)
        .position(|w| w == [0xFF, 0xC0])
        .expect("a baseline SOF0 marker");
    let seg = &jpeg[at + 4..];
    let components = seg[5] as usize;
    (0..components)
        .map(|i| (seg[7 + 3 * i] >> 4, seg[7 + 3 * i] & 0x0F))
        .collect()
}

/// The first (DC) entry of the luminance quantisation table.
fn luma_dc_quant(jpeg: &[u8]) -> u8 {
    let at = jpeg
        .windows(2)
        .position(|w| w == [0xFF, 0xDB])
        .expect("a DQT marker");
    assert_eq!(jpeg[at + 4], 0, "8-bit table 0 comes first");
    jpeg[at + 5]
}

/// The IJG scaling of the standard luminance DC quantiser (16) for a quality.
fn ijg_luma_dc(quality: u32) -> u8 {
    let scale = if quality < 50 {
        5000 / quality
    } else {
        200 - 2 * quality
    };
    ((16 * scale + 50) / 100).clamp(1, 255) as u8
}

#[test]
fn jpeg_decodes_to_the_source_with_the_presets_quality_and_420_chroma() {
    let (w, h) = (320, 180);
    let rgba = frame(w, h);
    let jpeg = encode_image(&rgba, w, h, ImageFormat::Jpeg { quality: 85 }).expect("encode");
    let decoded = image::load_from_memory_with_format(&jpeg, image::ImageFormat::Jpeg)
        .expect("decodes")
        .to_rgb8();
    assert_eq!(decoded.dimensions(), (w, h));
    let err = mae(&rgba, decoded.as_raw());
    assert!(err < 3.0, "mean absolute error {err}");
    // Y at 2×2, Cb and Cr at 1×1: 4:2:0.
    assert_eq!(sof0_sampling(&jpeg), [(2, 2), (1, 1), (1, 1)]);
    assert_eq!(luma_dc_quant(&jpeg), ijg_luma_dc(85));
    // Alpha is ignored: a transparent copy encodes to the same bytes.
    let mut clear = rgba.clone();
    clear.chunks_exact_mut(4).for_each(|p| p[3] = 0);
    assert_eq!(
        encode_image(&clear, w, h, ImageFormat::Jpeg { quality: 85 }).expect("encode"),
        jpeg
    );
}

#[test]
fn jpeg_quality_follows_the_preset_and_90_up_keeps_full_chroma() {
    let (w, h) = (96, 64);
    let rgba = frame(w, h);
    let mut sizes = Vec::new();
    for q in [30u8, 75, 89, 90, 100] {
        let jpeg = encode_image(&rgba, w, h, ImageFormat::Jpeg { quality: q }).expect("encode");
        assert_eq!(luma_dc_quant(&jpeg), ijg_luma_dc(u32::from(q)), "q{q}");
        let expected = if q < 90 {
            [(2, 2), (1, 1), (1, 1)]
        } else {
            [(1, 1), (1, 1), (1, 1)]
        };
        assert_eq!(sof0_sampling(&jpeg), expected, "q{q}");
        sizes.push(jpeg.len());
    }
    assert!(sizes[0] < sizes[1] && sizes[3] < sizes[4], "{sizes:?}");
}

#[test]
fn jpeg_output_is_byte_identical_run_to_run_and_across_threads() {
    let (w, h) = (640, 360);
    let rgba = frame(w, h);
    let format = ImageFormat::Jpeg { quality: 85 };
    let first = encode_image(&rgba, w, h, format).expect("encode");
    let second = encode_image(&rgba, w, h, format).expect("encode");
    assert_eq!(first, second);
    let other_thread = std::thread::scope(|s| {
        s.spawn(|| encode_image(&rgba, w, h, format).expect("encode"))
            .join()
            .expect("thread")
    });
    assert_eq!(first, other_thread);
}

#[test]
fn odd_sizes_encode_and_bad_input_is_a_named_error() {
    for (w, h) in [(1, 1), (3, 5), (17, 9)] {
        let rgba = frame(w, h);
        let jpeg = encode_image(&rgba, w, h, ImageFormat::Jpeg { quality: 85 }).expect("encode");
        let decoded = image::load_from_memory(&jpeg).expect("decodes");
        assert_eq!((decoded.width(), decoded.height()), (w, h));
    }
    let rgba = frame(8, 8);
    for (bytes, w, h, format) in [
        (&rgba[..], 8, 9, ImageFormat::Jpeg { quality: 85 }),
        (
            &rgba[..rgba.len() - 1],
            8,
            8,
            ImageFormat::Jpeg { quality: 85 },
        ),
        (&rgba[..], 8, 9, ImageFormat::Png),
        (&[][..], 0, 0, ImageFormat::Jpeg { quality: 85 }),
        (&rgba[..], 8, 8, ImageFormat::Jpeg { quality: 0 }),
        (&rgba[..], 8, 8, ImageFormat::Jpeg { quality: 101 }),
    ] {
        match encode_image(bytes, w, h, format) {
            Err(e @ OutputError::Encode { .. }) => assert!(!e.to_string().is_empty()),
            other => panic!("{w}×{h} {format:?}: expected an Encode error, got {other:?}"),
        }
    }
    let too_wide = vec![0u8; 70_000 * 4];
    assert!(matches!(
        encode_image(&too_wide, 70_000, 1, ImageFormat::Jpeg { quality: 85 }),
        Err(OutputError::Encode { .. })
    ));
}

#[test]
fn png_stays_lossless() {
    let (w, h) = (64, 48);
    let rgba = frame(w, h);
    let png = encode_image(&rgba, w, h, ImageFormat::Png).expect("encode");
    let decoded = image::load_from_memory_with_format(&png, image::ImageFormat::Png)
        .expect("decodes")
        .to_rgb8();
    assert_eq!(mae(&rgba, decoded.as_raw()), 0.0);
}
