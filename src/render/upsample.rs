//! Bilinear upsampling of an RGBA8 image on the CPU, in exact integer
//! arithmetic: the procedural environment is shaded at reduced resolution
//! (it is soft: haze, clouds, distant ground) and enlarged here, so the same
//! bytes come out on every machine and thread count, and the full-size
//! picture costs no full-frame GPU pass (issue 23: on lavapipe a full-frame
//! pass and its readback cost ≈ 13 ms at 1080p before any shading).
//!
//! Sample positions follow the GPU's convention: full-size pixel `x` has its
//! centre at `x + 0.5`, which lies at `(x + 0.5) / scale - 0.5` in source
//! texels; neighbours beyond the edge clamp to it. Weights are in 1/256.

/// One axis: for each output position, the two source indices and the
/// second one's weight (0..=255, of 256).
fn taps(out_len: u32, src_len: u32, scale: u32) -> Vec<(usize, usize, u32)> {
    let last = src_len.saturating_sub(1) as i64;
    let scale = i64::from(scale.max(1));
    (0..i64::from(out_len))
        .map(|x| {
            // (x + 0.5) / scale - 0.5, in 1/256 of a texel.
            let t = ((2 * x + 1 - scale) * 256).div_euclid(2 * scale);
            if t < 0 {
                return (0, 0, 0);
            }
            let i0 = (t >> 8).min(last);
            let i1 = (i0 + 1).min(last);
            (i0 as usize, i1 as usize, (t & 255) as u32)
        })
        .collect()
}

/// `src` (`src_w`×`src_h` RGBA8, tightly packed) enlarged by `scale` per
/// axis and cropped to `width`×`height`, into `out` (reusing its memory).
/// Alpha is written opaque.
pub fn upsample_rgba8(
    src: &[u8],
    (src_w, src_h): (u32, u32),
    scale: u32,
    (width, height): (u32, u32),
    out: &mut Vec<u8>,
) {
    out.clear();
    out.resize(width as usize * height as usize * 4, 0);
    if src_w == 0 || src_h == 0 || src.len() < src_w as usize * src_h as usize * 4 {
        out.chunks_exact_mut(4).for_each(|px| px[3] = 255);
        return;
    }
    let xs = taps(width, src_w, scale);
    let ys = taps(height, src_h, scale);
    let row_len = src_w as usize * 4;
    // One source row pair blended vertically (weights sum to 256).
    let mut blended = vec![0u32; src_w as usize * 3];
    let mut last_y: Option<(usize, usize, u32)> = None;
    for (y, &(r0, r1, wy)) in ys.iter().enumerate() {
        if last_y != Some((r0, r1, wy)) {
            let (a, b) = (
                &src[r0 * row_len..(r0 + 1) * row_len],
                &src[r1 * row_len..(r1 + 1) * row_len],
            );
            for (i, v) in blended.iter_mut().enumerate() {
                let k = i / 3 * 4 + i % 3;
                *v = u32::from(a[k]) * (256 - wy) + u32::from(b[k]) * wy;
            }
            last_y = Some((r0, r1, wy));
        }
        let row = &mut out[y * width as usize * 4..(y + 1) * width as usize * 4];
        for (px, &(c0, c1, wx)) in row.chunks_exact_mut(4).zip(&xs) {
            for c in 0..3 {
                let v = blended[c0 * 3 + c] * (256 - wx) + blended[c1 * 3 + c] * wx;
                px[c] = ((v + (1 << 15)) >> 16) as u8;
            }
            px[3] = 255;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn taps_follow_pixel_centres_and_clamp_at_the_edges() {
        // Scale 2: output centres fall a quarter texel either side of a source centre.
        assert_eq!(
            taps(6, 3, 2),
            vec![
                (0, 0, 0),
                (0, 1, 64),
                (0, 1, 192),
                (1, 2, 64),
                (1, 2, 192),
                (2, 2, 64)
            ]
        );
        // Scale 1 is the identity.
        assert_eq!(taps(3, 3, 1), vec![(0, 1, 0), (1, 2, 0), (2, 2, 0)]);
    }

    #[test]
    fn a_flat_image_stays_flat_and_a_ramp_is_interpolated() {
        let mut out = Vec::new();
        let flat: Vec<u8> = [10, 200, 77, 255].repeat(4 * 3);
        upsample_rgba8(&flat, (4, 3), 2, (7, 5), &mut out);
        assert_eq!(out, [10, 200, 77, 255].repeat(7 * 5));
        // A horizontal ramp 0, 100, 200: pixels between centres get the mix.
        let ramp: Vec<u8> = [0u8, 100, 200]
            .iter()
            .flat_map(|&v| [v, v, v, 255])
            .collect();
        upsample_rgba8(&ramp, (3, 1), 2, (6, 2), &mut out);
        let reds: Vec<u8> = out.chunks_exact(4).take(6).map(|p| p[0]).collect();
        assert_eq!(reds, vec![0, 25, 75, 125, 175, 200]);
        assert_eq!(&out[..24], &out[24..48], "rows from one source row agree");
    }

    #[test]
    fn scale_one_copies_and_short_input_gives_opaque_black() {
        let src: Vec<u8> = (0..5 * 4 * 4).map(|i| (i * 7 % 256) as u8).collect();
        let mut out = Vec::new();
        upsample_rgba8(&src, (5, 4), 1, (5, 4), &mut out);
        for (a, b) in out.chunks_exact(4).zip(src.chunks_exact(4)) {
            assert_eq!(&a[..3], &b[..3]);
            assert_eq!(a[3], 255);
        }
        upsample_rgba8(&src[..10], (5, 4), 1, (5, 4), &mut out);
        assert!(out.chunks_exact(4).all(|p| p == [0, 0, 0, 255]));
    }
}
