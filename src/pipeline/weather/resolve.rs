//! The weather's last step: a pixel under particles that each blend it
//! towards the same level L by their alpha × coverage aₖ ends at
//! L − (L − v)·T, T = Π(1 − aₖ) its transmittance, whatever their order.
//! Each channel of an RGBA8 row is rounded once from that (`floor(x + ½)`
//! in f32), its fourth byte kept; a radiance plane takes it as it is.

/// Row `t.len()` pixels of RGBA8 `dst` from `src` (or from `dst` itself)
/// under transmittances `t` towards `level`: eight pixels at once in AVX2
/// where the CPU runs it (`simd::simd_level`, which
/// `SWARMSHOT_SIMD=base` caps), the rest by [`resolve_scalar`]:
/// the same IEEE operations lane by lane, so the same bytes.
pub(super) fn resolve(dst: &mut [u8], src: Option<&[u8]>, t: &[f32], level: f32) {
    let n = t.len();
    #[cfg(target_arch = "x86_64")]
    let done = if crate::simd::simd_level() >= 1 {
        let wide = n / 8 * 8;
        // SAFETY: the CPU has AVX2 (checked by `simd_level`).
        #[allow(unsafe_code)]
        unsafe {
            resolve_avx2(
                &mut dst[..wide * 4],
                src.map(|s| &s[..wide * 4]),
                &t[..wide],
                level,
            )
        };
        wide
    } else {
        0
    };
    #[cfg(not(target_arch = "x86_64"))]
    let done = 0;
    let src = src.map(|s| &s[done * 4..n * 4]);
    resolve_scalar(&mut dst[done * 4..n * 4], src, &t[done..], level);
}

/// Row `dst` (the frame, RGBA8) under transmittances `t` towards `level`,
/// given the drone-free row before and after its blends (`background`,
/// `cleared`: [`resolve`] of it under the transmittances of the pixels no
/// drone shows). Eight pixels whose bytes equal the background's take the
/// cleared bytes: no drone shows there, so `t` there is the drone-free
/// row's, and the result the same function of the same bytes. The rest as
/// [`resolve`] in place.
pub(super) fn resolve_over(
    dst: &mut [u8],
    (background, cleared): (&[u8], &[u8]),
    t: &[f32],
    level: f32,
) {
    let n = t.len();
    let (bg, cl) = (background.as_chunks::<32>().0, cleared.as_chunks::<32>().0);
    // Whole groups of eight the three rows hold; the rest in place.
    let m = (n / 8).min(bg.len()).min(cl.len());
    let (groups, rest) = dst[..n * 4].split_at_mut(m * 32);
    for (k, ((px, b), c)) in (groups.as_chunks_mut::<32>().0.iter_mut())
        .zip(bg)
        .zip(cl)
        .enumerate()
    {
        if px == b {
            *px = *c;
        } else {
            resolve(px, None, &t[k * 8..k * 8 + 8], level);
        }
    }
    resolve(rest, None, &t[m * 8..], level);
}

/// [`resolve`] a pixel at a time.
pub(super) fn resolve_scalar(dst: &mut [u8], src: Option<&[u8]>, t: &[f32], level: f32) {
    for (i, &ti) in t.iter().enumerate() {
        for c in 0..3 {
            let v = f32::from(src.map_or(dst[i * 4 + c], |s| s[i * 4 + c]));
            let x = level - (level - v) * ti;
            // x lies between v and the level (t in 0–1): 0–255.
            dst[i * 4 + c] = (x + 0.5) as u8;
        }
        if let Some(s) = src {
            dst[i * 4 + 3] = s[i * 4 + 3];
        }
    }
}

/// [`resolve`] of `t.len()` (a multiple of 8) pixels in AVX2's two 128-bit
/// halves (pixels 0–3 and 4–7): the fourth channel's transmittance 1 leaves
/// its byte as it was, and eight pixels at transmittance 1 are copied as
/// they are (what the lanes give).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn resolve_avx2(dst: &mut [u8], src: Option<&[u8]>, t: &[f32], level: f32) {
    use std::arch::x86_64::*;
    let zero = _mm256_setzero_si256();
    let l = _mm256_set1_ps(level);
    let half = _mm256_set1_ps(0.5);
    let rgb = _mm256_castsi256_ps(_mm256_set_epi32(0, -1, -1, -1, 0, -1, -1, -1));
    let one_a = _mm256_set_ps(1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0);
    let one = _mm256_set1_ps(1.0);
    let lane = |v: __m256i, ti: __m256| {
        let x = _mm256_sub_ps(
            l,
            _mm256_mul_ps(_mm256_sub_ps(l, _mm256_cvtepi32_ps(v)), ti),
        );
        _mm256_cvttps_epi32(_mm256_add_ps(x, half))
    };
    let per_channel = |tv: __m256| _mm256_or_ps(_mm256_and_ps(tv, rgb), one_a);
    for (i, tq) in t.chunks_exact(8).enumerate() {
        let at = i * 32;
        let from = match src {
            Some(s) => &s[at..at + 32],
            None => &dst[at..at + 32],
        };
        // SAFETY: `from` and `dst[at..at + 32]` hold 32 bytes, `tq` 8 floats.
        #[allow(unsafe_code)]
        let (px, tv) = unsafe {
            (
                _mm256_loadu_si256(from.as_ptr().cast()),
                _mm256_loadu_ps(tq.as_ptr()),
            )
        };
        if _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_EQ_OQ>(tv, one)) == 0xFF {
            if src.is_some() {
                // SAFETY: as the loads.
                #[allow(unsafe_code)]
                unsafe {
                    _mm256_storeu_si256(dst[at..at + 32].as_mut_ptr().cast(), px)
                };
            }
            continue;
        }
        // Within each half: pixels 0, 1 (lo) and 2, 3 (hi) widened.
        let (lo, hi) = (
            _mm256_unpacklo_epi8(px, zero),
            _mm256_unpackhi_epi8(px, zero),
        );
        let p0 = lane(
            _mm256_unpacklo_epi16(lo, zero),
            per_channel(_mm256_shuffle_ps::<0x00>(tv, tv)),
        );
        let p1 = lane(
            _mm256_unpackhi_epi16(lo, zero),
            per_channel(_mm256_shuffle_ps::<0x55>(tv, tv)),
        );
        let p2 = lane(
            _mm256_unpacklo_epi16(hi, zero),
            per_channel(_mm256_shuffle_ps::<0xAA>(tv, tv)),
        );
        let p3 = lane(
            _mm256_unpackhi_epi16(hi, zero),
            per_channel(_mm256_shuffle_ps::<0xFF>(tv, tv)),
        );
        let out = _mm256_packus_epi16(_mm256_packs_epi32(p0, p1), _mm256_packs_epi32(p2, p3));
        // SAFETY: as the loads.
        #[allow(unsafe_code)]
        unsafe {
            _mm256_storeu_si256(dst[at..at + 32].as_mut_ptr().cast(), out)
        };
    }
}

/// Radiances `plane` (in place) towards `air` under transmittances `t`.
pub(super) fn resolve_radiance(plane: &mut [f32], t: &[f32], air: f32) {
    for (v, &ti) in plane.iter_mut().zip(t) {
        *v = air - (air - *v) * ti;
    }
}

#[cfg(test)]
mod tests {
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    use super::*;

    #[test]
    fn resolve_gives_the_scalar_bytes() {
        // 4099 pixels (a tail past the lanes), every value, transmittances
        // at 0, 1 (whole lanes of them too) and between, each level the weather uses and the ends.
        let mut rng = ChaCha8Rng::seed_from_u64(42);
        let n = 4099;
        let src: Vec<u8> = (0..n * 4).map(|i| (i * 7 % 256) as u8).collect();
        let mut t: Vec<f32> = (0..n).map(|_| rng.random::<f32>()).collect();
        t[..6].copy_from_slice(&[0.0, 1.0, 0.5, 1.0 / 255.0, 0.999_999_9, 1e-8]);
        // A whole lane of eight at 1 and one 1 short of it.
        t[8..16].fill(1.0);
        t[16..23].fill(1.0);
        for level in [0.0, 1.0, 127.0, 228.0, 242.0, 255.0] {
            let (mut simd, mut scalar) = (vec![9u8; n * 4], vec![9u8; n * 4]);
            resolve(&mut simd, Some(&src), &t, level);
            resolve_scalar(&mut scalar, Some(&src), &t, level);
            assert_eq!(simd, scalar, "level {level}");
            let mut in_place = src.clone();
            resolve(&mut in_place, None, &t, level);
            assert_eq!(in_place, scalar, "level {level} in place");
        }
    }

    #[test]
    fn resolve_over_is_resolve_of_the_frame() {
        // A drone-free row, its blends, and the frame: the background with
        // a few pixels changed (drones: their own transmittances), over a
        // tail past the lanes. The frame's pixels as `resolve` makes them.
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let n = 1003;
        let background: Vec<u8> = (0..n * 4).map(|_| rng.random()).collect();
        let t: Vec<f32> = (0..n).map(|_| rng.random::<f32>()).collect();
        let mut cleared = vec![0u8; n * 4];
        resolve(&mut cleared, Some(&background), &t, 228.0);
        let (mut frame, mut t_frame) = (background.clone(), t.clone());
        for i in [0, 9, 17, 18, 500, 1002] {
            frame[i * 4..i * 4 + 4].copy_from_slice(&[1, 2, 3, 4]);
            t_frame[i] = 0.25;
        }
        let mut want = frame.clone();
        resolve(&mut want, None, &t_frame, 228.0);
        resolve_over(&mut frame, (&background, &cleared), &t_frame, 228.0);
        assert_eq!(frame, want);
    }

    #[test]
    fn resolve_is_the_blends_product() {
        // Two blends towards the level, one after the other (in reals):
        // the same as one by their transmittances' product, rounded once;
        // transmittance 1 leaves a pixel as it was, 0 sets the level.
        let (level, v, a, b) = (228.0f32, 40u8, 0.3f32, 0.45f32);
        let once = f32::from(v) + (level - f32::from(v)) * a;
        let twice = once + (level - once) * b;
        let mut px = [v, v, v, 77];
        resolve(&mut px, None, &[(1.0 - a) * (1.0 - b)], level);
        let want = (twice + 0.5) as u8;
        assert_eq!(px, [want, want, want, 77], "{twice}");
        let mut px = [v, 200, 3, 77];
        resolve(&mut px, None, &[1.0], level);
        assert_eq!(px, [v, 200, 3, 77]);
        resolve(&mut px, None, &[0.0], level);
        assert_eq!(px, [228, 228, 228, 77]);
    }
}
