use super::*;

/// [`Row::segment_avx2`] where the CPU has AVX2 (how many pixels it made;
/// 0 elsewhere).
fn segment_simd(row: &Row, start: (i32, i32), step: (i32, i32), out: &mut [u8]) -> usize {
    #[cfg(target_arch = "x86_64")]
    if crate::simd::simd_level() >= 1 {
        // SAFETY: the CPU has AVX2 (checked by `simd_level`).
        #[allow(unsafe_code)]
        unsafe {
            return row.segment_avx2(start, step, out);
        }
    }
    let _ = (row, start, step, out);
    0
}

/// The fixed-point rounding is `f64::round`'s, ties, negatives, the clamp
/// and NaN included.
#[test]
fn fixed_rounds_half_away_from_zero_as_round_does() {
    let old = |s: f64| ((s - 0.5).clamp(-4096.0, 20480.0) * 65536.0).round() as i32;
    let tie = 0.5 / 65536.0;
    for s in [
        0.0,
        0.5,
        1.0,
        -3.25,
        1e9,
        -1e9,
        f64::NAN,
        7.0 + tie,
        7.0 - tie,
        -7.0 + tie,
    ] {
        for s in [s, s + tie, s - tie, s + 3.0 * tie, s - 3.0 * tie] {
            assert_eq!(fixed(s), old(s), "{s}");
        }
    }
    for k in 0..100_000u32 {
        let s = f64::from(k) * 0.013_7 - 300.0 + f64::from(k % 7) * tie;
        assert_eq!(fixed(s), old(s), "{s}");
    }
}

#[test]
fn the_simd_segment_gives_the_scalar_bytes_and_the_bilinear_mix() {
    // A 40×30 image of mixed bytes; segments crossing every edge.
    let (w, h) = (40u32, 30u32);
    let src: Vec<u8> = (0..w * h * 4).map(|i| (i * 37 % 251) as u8).collect();
    let row = Row {
        src: &src,
        size: (w, h),
    };
    for (start, step) in [
        ((-3.3, -2.0), (0.37, 0.11)),
        ((5.71, 3.2), (1.003, -0.019)),
        ((30.2, 27.9), (0.9, 0.08)),
    ] {
        let (u0, v0) = (fixed(start.0), fixed(start.1));
        let d = (fixed(start.0 + step.0) - u0, fixed(start.1 + step.1) - v0);
        let mut out = vec![0u8; 32 * 4];
        let done = segment_simd(&row, (u0, v0), d, &mut out);
        for (j, px) in (0..).zip(out.chunks_exact(4)) {
            let want = row.pixel((u0, v0), d, j).to_le_bytes();
            if (j as usize) < done {
                assert_eq!(px, want, "pixel {j} of {start:?}");
            }
            // The integers are the bilinear mix within 2 levels: two
            // roundings and weights in 1/256 (≤ 1/512 px each way, here
            // between neighbours up to 250 levels apart).
            let (u, v) = (
                start.0 + step.0 * f64::from(j),
                start.1 + step.1 * f64::from(j),
            );
            let clamp = |s: f64, n: u32| (s - 0.5).clamp(0.0, f64::from(n - 1));
            let (x, y) = (clamp(u, w), clamp(v, h));
            let (x0, y0) = ((x.floor() as u32).min(w - 2), (y.floor() as u32).min(h - 2));
            let (fx, fy) = (x - f64::from(x0), y - f64::from(y0));
            for c in 0..4 {
                let at = |x: u32, y: u32| f64::from(src[((y * w + x) * 4) as usize + c]);
                let top = at(x0, y0) * (1.0 - fx) + at(x0 + 1, y0) * fx;
                let bottom = at(x0, y0 + 1) * (1.0 - fx) + at(x0 + 1, y0 + 1) * fx;
                let exact = top * (1.0 - fy) + bottom * fy;
                let got = f64::from(want[c]);
                assert!(
                    (got - exact).abs() <= 1.5,
                    "pixel {j} channel {c}: {got} vs {exact}"
                );
            }
        }
    }
}

/// Segments along a pan (about a pixel a pixel, a slight slope, stretched
/// or shrunk by up to 15 %) and off every edge: where [`Row::run`] says
/// run, every pixel's taps are the run's; where [`Row::window`] says
/// window, every pixel's taps lie in its 16 pixels; segments that are
/// neither have blocks that are (the block-by-block path); and the SIMD
/// kernels give the scalar bytes in every case.
#[test]
fn runs_and_windows_are_their_taps_and_their_kernels_give_the_scalar_bytes() {
    let (w, h) = (70u32, 40u32);
    let src: Vec<u8> = (0..w * h * 4).map(|i| (i * 53 % 253) as u8).collect();
    let row = Row {
        src: &src,
        size: (w, h),
    };
    let (mut runs, mut run_blocks, mut windows) = (0, 0, 0);
    for k in 0..600 {
        let k = f64::from(k);
        let start = ((k * 7.31) % 90.0 - 10.0, (k * 3.17) % 48.0 - 4.0);
        let stretch = [0.01, 0.3][k as usize % 2];
        let step = (
            1.0 + ((k * 0.37) % 1.0 - 0.5) * stretch,
            ((k * 0.61) % 1.0 - 0.5) * 0.02,
        );
        let (u0, v0) = (fixed(start.0), fixed(start.1));
        let d = (fixed(start.0 + step.0) - u0, fixed(start.1 + step.1) - v0);
        let len = [32, 37, 9][k as usize % 3];
        let taps = |j: i32| (row.axis(u0 + d.0 * j, 0), row.axis(v0 + d.1 * j, 1));
        if let Some(at) = row.run((u0, v0), d, len) {
            runs += 1;
            for j in 0..len as i32 {
                let (x, y) = taps(j);
                assert_eq!((y.0 * w + x.0) as usize, at + j as usize, "segment {k}");
            }
        }
        for b in 0..len as i32 / 8 {
            let at = (u0 + d.0 * 8 * b, v0 + d.1 * 8 * b);
            run_blocks += usize::from(row.run(at, d, 8).is_some());
            if let Some(first) = row.window(at, d) {
                windows += 1;
                for j in 8 * b..8 * b + 8 {
                    let (x, y) = taps(j);
                    let i = (y.0 * w + x.0) as usize;
                    assert!((first..first + 9).contains(&i), "segment {k} pixel {j}");
                    assert_eq!(i / w as usize, first / w as usize);
                }
            }
        }
        let mut out = vec![0u8; len * 4];
        let done = segment_simd(&row, (u0, v0), d, &mut out);
        for (j, px) in (0..done as i32).zip(out.chunks_exact(4)) {
            let want = row.pixel((u0, v0), d, j).to_le_bytes();
            assert_eq!(px, want, "pixel {j} of segment {k}");
        }
    }
    assert!(runs > 100, "{runs} runs");
    assert!(run_blocks > 200, "{run_blocks} run blocks");
    assert!(windows > 300, "{windows} window blocks");
}

/// A whole segment's run test in `i32` ([`Row::run32`], a whole
/// segment's in [`Row::segment_avx2`]) is [`Row::run`]'s in `i64`, for
/// knots KNOT_PX apart anywhere on and off the image, steps from a pan's
/// to a stretched one's, and steps past i32.
#[test]
fn a_whole_segments_run_in_i32_is_the_run() {
    let (w, h) = (90u32, 50u32);
    let src = vec![0u8; (w * h * 4) as usize];
    let row = Row {
        src: &src,
        size: (w, h),
    };
    let mut runs = 0;
    for k in 0..20_000 {
        let k = f64::from(k);
        let a = ((k * 7.31) % 130.0 - 20.0, (k * 3.17) % 70.0 - 10.0);
        let b = (
            a.0 + 32.0 * (1.0 + ((k * 0.37) % 1.0 - 0.5) * 0.1),
            a.1 + ((k * 0.61) % 1.0 - 0.5) * [0.05, 3.0][k as usize % 2],
        );
        let (a, b) = ((fixed(a.0), fixed(a.1)), (fixed(b.0), fixed(b.1)));
        let step = (div_knot(b.0 - a.0), div_knot(b.1 - a.1));
        let want = row.run(a, step, KNOT_PX as usize);
        assert_eq!(row.run32(a, step), want, "segment {k}");
        runs += usize::from(want.is_some());
    }
    assert!((1000..19_000).contains(&runs), "{runs} runs");
    // Steps whose last position leaves i32: no run either way.
    for (a, step) in [
        ((0, 0), (i32::MAX / 8, 0)),
        ((1 << 20, 1 << 20), (0, i32::MIN / 16)),
    ] {
        assert_eq!(row.run32(a, step), row.run(a, step, KNOT_PX as usize));
        assert_eq!(row.run32(a, step), None);
    }
}

/// A whole row through [`Row::resample`] (AVX2 where the CPU has it) is
/// pixel by pixel [`Row::pixel`] of each segment, for a pan's knots, a
/// stretched row and one that leaves the image.
#[test]
fn a_resampled_row_is_its_segments_scalar_pixels() {
    let (w, h) = (203u32, 31u32);
    let src: Vec<u8> = (0..w * h * 4).map(|i| (i * 97 % 241) as u8).collect();
    let row = Row {
        src: &src,
        size: (w, h),
    };
    // The knots every KNOT_PX columns, and with one moved a column (its
    // segments and those after taken as `segments` takes them).
    let xs = super::super::knot_columns(w);
    let mut moved = xs.clone();
    moved[2] += 1;
    let cases = [(1.002, 0.004, 3.3), (1.13, -0.02, -20.0), (0.87, 0.0, 9.9)];
    for ((scale, slope, shift), xs) in cases.into_iter().flat_map(|c| [(c, &xs), (c, &moved)]) {
        let knots: Vec<(f64, f64)> = (xs.iter())
            .map(|&x| {
                let x = f64::from(x) + 0.5;
                (x * scale + shift, 12.7 + x * slope)
            })
            .collect();
        let mut out = vec![0u8; w as usize * 4];
        row.resample(xs, &knots, &mut Vec::new(), &mut out);
        let fixed_knots: Vec<(i32, i32)> =
            knots.iter().map(|&(u, v)| (fixed(u), fixed(v))).collect();
        let mut want = vec![1u8; w as usize * 4];
        segments(xs, &fixed_knots, &mut want, |start, step, pixels| {
            for (j, px) in (0..).zip(pixels.chunks_exact_mut(4)) {
                px.copy_from_slice(&row.pixel(start, step, j).to_le_bytes());
            }
        });
        assert_eq!(out, want, "scale {scale}");
    }
}

/// The shift is `/` for every sign and size.
#[test]
fn dividing_by_the_knot_spacing_by_a_shift_is_the_quotient() {
    for d in (-100_000..100_000).chain([i32::MIN + 31, i32::MAX, -1_600_000_000, 1_600_000_000]) {
        assert_eq!(div_knot(d), d / KNOT_PX as i32, "{d}");
    }
}

/// The streamed copy is the bytes at every alignment of either end and
/// any length (its aligned body, its head and tail copied plainly).
#[test]
fn a_streamed_copy_is_the_bytes_at_any_alignment() {
    let src: Vec<u8> = (0..200u32).map(|i| (i * 37 % 251) as u8).collect();
    for from in 0..17 {
        for at in 0..17 {
            for len in [0, 1, 15, 16, 17, 33, 100, 150] {
                let mut dst = [0xeeu8; 200];
                copy_streamed(&mut dst[at..at + len], &src[from..from + len]);
                assert_eq!(
                    dst[at..at + len],
                    src[from..from + len],
                    "{from} {at} {len}"
                );
                assert!(dst[..at].iter().chain(&dst[at + len..]).all(|&b| b == 0xee));
            }
        }
    }
}
