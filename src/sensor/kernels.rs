//! The row kernels of the fused sweep ([`super::fused`]): decoding a row
//! through the exposure's table, the chromatic aberration's taps in
//! contiguous runs, the PSF's sums in register blocks, and the encode of a
//! finished row; and which SIMD build of the sweep this CPU runs. Each
//! computes exactly the plane path's f32 operations in its order, so every
//! build gives the same bytes.

use super::rows::encode_row;

/// The widest build of the band this CPU runs: 2 AVX-512 (F, BW, DQ, VL),
/// 1 AVX2, 0 the baseline. `SWARMSHOT_CAMERA_SIMD=avx2` or `=base` caps it
/// (for comparing the builds; the bytes are the same).
#[cfg(target_arch = "x86_64")]
pub(super) fn simd_level() -> u8 {
    static LEVEL: std::sync::OnceLock<u8> = std::sync::OnceLock::new();
    *LEVEL.get_or_init(|| {
        let cap = match std::env::var("SWARMSHOT_CAMERA_SIMD").as_deref() {
            Ok("base") => 0,
            Ok("avx2") => 1,
            _ => 2,
        };
        cpu_simd_level().min(cap)
    })
}

/// The widest build the CPU itself can run (2 AVX-512, 1 AVX2, 0 the
/// baseline), whatever `SWARMSHOT_CAMERA_SIMD` says.
#[cfg(target_arch = "x86_64")]
pub(super) fn cpu_simd_level() -> u8 {
    let avx512 = std::arch::is_x86_feature_detected!("avx512f")
        && std::arch::is_x86_feature_detected!("avx512bw")
        && std::arch::is_x86_feature_detected!("avx512dq")
        && std::arch::is_x86_feature_detected!("avx512vl");
    let avx2 = std::arch::is_x86_feature_detected!("avx2");
    if avx512 { 2 } else { u8::from(avx2) }
}

/// [`decode_row_any`] in its AVX2 build where the CPU has AVX2, even
/// inside the AVX-512 band: AVX-512 gathers are slower than AVX2's
/// look-ups one lane at a time (measured: 0.28 against 0.19 ns a value on
/// the 2-core AMD EPYC build machine).
#[inline(always)]
pub(super) fn decode_row(lut: &[f32; 256], row: &[u8], c: usize, first: i64, out: &mut [f32]) {
    #[cfg(target_arch = "x86_64")]
    if simd_level() >= 1 {
        // SAFETY: the CPU has AVX2 (checked by `simd_level`).
        #[allow(unsafe_code)]
        unsafe {
            return decode_row_avx2(lut, row, c, first, out);
        }
    }
    decode_row_any(lut, row, c, first, out);
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline(never)]
fn decode_row_avx2(lut: &[f32; 256], row: &[u8], c: usize, first: i64, out: &mut [f32]) {
    decode_row_any(lut, row, c, first, out);
}

/// One row of RGBA8 from the three linear rows (see
/// [`super::rows::encode_row`]), in its AVX2 build where the CPU has it
/// (as [`decode_row`], for the same reason).
#[inline(always)]
pub(super) fn encode_line(vals: [&[f32]; 3], src: &[u8], line: &mut [u8]) {
    #[cfg(target_arch = "x86_64")]
    if simd_level() >= 1 {
        // SAFETY: the CPU has AVX2 (checked by `simd_level`).
        #[allow(unsafe_code)]
        unsafe {
            return encode_line_avx2(vals, src, line);
        }
    }
    encode_row(vals, src, line, false);
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline(never)]
fn encode_line_avx2(vals: [&[f32]; 3], src: &[u8], line: &mut [u8]) {
    encode_row(vals, src, line, true);
}

/// RGBA8 image row `row`'s channel `c` through `lut` at image columns
/// `first`, `first + 1`, … (as many as `out` is long), clamped to the row.
#[inline(always)]
fn decode_row_any(lut: &[f32; 256], row: &[u8], c: usize, first: i64, out: &mut [f32]) {
    let (w, n) = ((row.len() / 4) as i64, out.len() as i64);
    let lo = (-first).clamp(0, n) as usize;
    let hi = (w - first).clamp(lo as i64, n) as usize;
    let (left, rest) = out.split_at_mut(lo);
    let (inside, right) = rest.split_at_mut(hi - lo);
    left.fill(lut[usize::from(row[c])]);
    right.fill(lut[usize::from(row[(w as usize - 1) * 4 + c])]);
    if !inside.is_empty() {
        let start = (first + lo as i64) as usize * 4;
        for (o, px) in inside.iter_mut().zip(row[start..].chunks_exact(4)) {
            *o = lut[usize::from(px[c])];
        }
    }
}

/// Output columns `start..end` whose aberration taps are (c0 + k, c0 + k + 1)
/// for k = 0, 1, … (`Some(c0)`, a run read as two contiguous slices), or one
/// column with other taps (`None`: at the image's edges).
#[derive(Clone, Copy, Debug)]
pub(super) struct TapRun {
    pub(super) start: usize,
    pub(super) end: usize,
    pub(super) c0: Option<usize>,
}

/// The taps split into [`TapRun`]s.
pub(super) fn tap_runs(taps: &[(usize, usize, f32)]) -> Vec<TapRun> {
    let mut runs = Vec::new();
    let mut j = 0;
    while j < taps.len() {
        let (c0, c1, _) = taps[j];
        let mut end = j + 1;
        if c1 == c0 + 1 {
            while end < taps.len()
                && taps[end].0 == c0 + (end - j)
                && taps[end].1 == taps[end].0 + 1
            {
                end += 1;
            }
        }
        let c0 = (c1 == c0 + 1).then_some(c0);
        runs.push(TapRun { start: j, end, c0 });
        j = end;
    }
    runs
}

/// `out[j]` = `src[c0]` + (`src[c1]` − `src[c0]`)·`fx` for the taps
/// (c0, c1, fx) of column j, as [`super::rows::taps_row`] computes it, a
/// run of contiguous taps at a time (a loop that vectorises).
#[inline(always)]
pub(super) fn taps_runs(
    src: &[f32],
    (taps, fx): (&[(usize, usize, f32)], &[f32]),
    runs: &[TapRun],
    out: &mut [f32],
) {
    for run in runs {
        let (out, taps) = (&mut out[run.start..run.end], &taps[run.start..run.end]);
        match run.c0 {
            Some(c0) => {
                let n = out.len();
                let (a, b) = (&src[c0..c0 + n], &src[c0 + 1..c0 + 1 + n]);
                let fx = &fx[run.start..run.end];
                for (((o, x), y), f) in out.iter_mut().zip(a).zip(b).zip(fx) {
                    *o = x + (y - x) * f;
                }
            }
            None => super::rows::taps_row(src, taps, out),
        }
    }
}

/// Outputs per block of the convolutions: sums held in registers, four
/// AVX-512 registers' worth, so that four independent chains of additions
/// hide the adder's latency.
const LANES: usize = 64;

/// `out[i]` = Σₖ `weights[k]`·`padded[i + k]`, summed from 0 in the order
/// k = 0, 1, … (the plane path's order, so its f32 results), a block of
/// [`LANES`] outputs at a time.
#[inline(always)]
pub(super) fn convolve_row(weights: &[f32], padded: &[f32], out: &mut [f32]) {
    let mut blocks = out.chunks_exact_mut(LANES);
    let mut i = 0;
    for block in &mut blocks {
        let mut acc = [0f32; LANES];
        for (k, &wk) in weights.iter().enumerate() {
            let src: &[f32; LANES] = padded[i + k..i + k + LANES].try_into().expect("block");
            for (a, s) in acc.iter_mut().zip(src) {
                *a += wk * s;
            }
        }
        block.copy_from_slice(&acc);
        i += LANES;
    }
    for (j, o) in blocks.into_remainder().iter_mut().enumerate() {
        let mut acc = 0f32;
        for (k, &wk) in weights.iter().enumerate() {
            acc += wk * padded[i + j + k];
        }
        *o = acc;
    }
}

/// `out[i]` = Σₖ `weights[k]`·`ring[starts[k] + i]`, summed from 0 in the
/// order k = 0, 1, …, a block of [`LANES`] outputs at a time.
#[inline(always)]
pub(super) fn sum_rows(weights: &[f32], ring: &[f32], starts: &[usize], out: &mut [f32]) {
    let mut blocks = out.chunks_exact_mut(LANES);
    let mut i = 0;
    for block in &mut blocks {
        let mut acc = [0f32; LANES];
        for (&wk, &s) in weights.iter().zip(starts) {
            let src: &[f32; LANES] = ring[s + i..s + i + LANES].try_into().expect("block");
            for (a, s) in acc.iter_mut().zip(src) {
                *a += wk * s;
            }
        }
        block.copy_from_slice(&acc);
        i += LANES;
    }
    for (j, o) in blocks.into_remainder().iter_mut().enumerate() {
        let mut acc = 0f32;
        for (&wk, &s) in weights.iter().zip(starts) {
            acc += wk * ring[s + i + j];
        }
        *o = acc;
    }
}
