//! A row of output pixels' bilinear taps from the lens map's grid (issue
//! 41): the row's grid nodes (each its source's displacement in 1/[`ONE`]
//! px, already mixed from the four grid rows around the row) mixed per
//! pixel in f32 from the four nodes around its column (cubic Lagrange
//! weights, the sum in one fixed order, no fused multiply-add), rounded to
//! a whole 1/[`ONE`] (ties to even), added to the pixel's own position and
//! split into the top-left source pixel and the weights by shifts and
//! masks. The scalar code and, where the CPU has it, AVX2 eight pixels at
//! a time, with the same bytes (tested).

use super::kernel::{ONE, Tap};

/// The grid's spacing, pixels: a cell's columns share its four nodes.
pub(super) const GRID: usize = 16;

/// log₂ [`ONE`]: a position in 1/ONE px shifted right by this is its pixel.
const SHIFT: i32 = 10;
const _: () = assert!(ONE == 1 << SHIFT);

/// The largest displacement a grid node stores and a mix gives, in 1/ONE
/// px (16384 px, the largest picture side): the sums stay inside i32.
pub(super) const LIM: f32 = 16_777_216.0;

/// An output row's grid nodes: each plane's displacements (u, then v) at
/// the nodes from the one before cell `first` on, and the cubic weights
/// of each column's place in its cell (`k[i][t]`: node i's at column t).
pub(super) struct Rows<'a> {
    pub u: &'a [f32],
    pub v: &'a [f32],
    pub first: u32,
    pub k: &'a [[f32; GRID]; 4],
}

/// The taps of the output pixels from column `x0` of row `y` (a `w`×`h`
/// picture) into `out` (columns past the nodes' cells left as they are):
/// the AVX2 code where the CPU has it, else the scalar (the same taps).
pub(super) fn row_taps(rows: &Rows, x0: u32, y: u32, (w, h): (u32, u32), out: &mut [Tap]) {
    let nodes = rows.u.len().min(rows.v.len());
    let cells = (nodes.saturating_sub(3) as u32 + rows.first) * GRID as u32;
    let n = (out.len() as u32).min(cells.saturating_sub(x0)) as usize;
    let out = &mut out[..n];
    if x0 < rows.first * GRID as u32 {
        return;
    }
    #[cfg(target_arch = "x86_64")]
    if super::super::simd::simd_level() >= 1 {
        // SAFETY: the CPU has AVX2 (checked by `simd_level`).
        #[allow(unsafe_code)]
        unsafe {
            return row_taps_avx2(rows, x0, y, (w, h), out);
        }
    }
    row_taps_scalar(rows, x0, y, (w, h), out);
}

/// Plane `p`'s four-node mix at column `x`, rounded to a whole 1/ONE.
#[inline(always)]
fn mixed(p: &[f32], rows: &Rows, x: u32) -> i32 {
    let (c, t) = ((x / GRID as u32 - rows.first) as usize, x as usize % GRID);
    let k = rows.k;
    let m = k[0][t] * p[c] + k[1][t] * p[c + 1] + k[2][t] * p[c + 2] + k[3][t] * p[c + 3];
    m.clamp(-LIM, LIM).round_ties_even() as i32
}

/// A position `s` (1/ONE px, index space) along a side of `n` pixels as
/// its first tap's pixel and the next one's weight: clamped to the side,
/// the last pixel taken as the second's full weight.
#[inline(always)]
fn axis(s: i32, n: u32) -> (u32, u32) {
    let s = s.clamp(0, ((n - 1) << SHIFT) as i32) as u32;
    let i = (s >> SHIFT).min(n - 2);
    (i, s - (i << SHIFT))
}

/// [`row_taps`] in scalar code (the reference the AVX2 code matches).
fn row_taps_scalar(rows: &Rows, x0: u32, y: u32, (w, h): (u32, u32), out: &mut [Tap]) {
    let sy = (y << SHIFT) as i32;
    for (tap, x) in out.iter_mut().zip(x0..) {
        let (ix, wx) = axis(((x << SHIFT) as i32) + mixed(rows.u, rows, x), w);
        let (iy, wy) = axis(sy + mixed(rows.v, rows, x), h);
        *tap = Tap::new(iy * w + ix, wx, wy);
    }
}

/// [`row_taps_scalar`]'s arithmetic on AVX2, eight pixels (half a cell) at
/// a time from the first column that is a multiple of 8 (the scalar code
/// for the columns before it and the last few): the f32 mix in the
/// scalar's order, the rounding `cvtps` (ties to even, the default
/// MXCSR), the rest in i32.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn row_taps_avx2(rows: &Rows, x0: u32, y: u32, (w, h): (u32, u32), out: &mut [Tap]) {
    use std::arch::x86_64::*;
    let head = ((8 - x0 % 8) % 8).min(out.len() as u32) as usize;
    let (before, out) = out.split_at_mut(head);
    row_taps_scalar(rows, x0, y, (w, h), before);
    let x0 = x0 + head as u32;
    let (lo, hi) = (_mm256_set1_ps(-LIM), _mm256_set1_ps(LIM));
    // A cell's four nodes, each in every lane (`row_taps` keeps `c + 4`
    // within the nodes: the zeros are never read).
    let nodes = |p: &[f32], c: usize| {
        let q: [f32; 4] = p
            .get(c..c + 4)
            .and_then(|q| q.try_into().ok())
            .unwrap_or_default();
        q.map(|v| _mm256_set1_ps(v))
    };
    let mix = |p: &[__m256; 4], k: &[__m256; 4]| {
        let m = _mm256_add_ps(
            _mm256_add_ps(
                _mm256_add_ps(_mm256_mul_ps(k[0], p[0]), _mm256_mul_ps(k[1], p[1])),
                _mm256_mul_ps(k[2], p[2]),
            ),
            _mm256_mul_ps(k[3], p[3]),
        );
        _mm256_cvtps_epi32(_mm256_min_ps(_mm256_max_ps(m, lo), hi))
    };
    let axis = |s: __m256i, n: u32| {
        let s = _mm256_min_epi32(
            _mm256_max_epi32(s, _mm256_setzero_si256()),
            _mm256_set1_epi32(((n - 1) << SHIFT) as i32),
        );
        let i = _mm256_min_epu32(
            _mm256_srli_epi32::<SHIFT>(s),
            _mm256_set1_epi32((n - 2) as i32),
        );
        (i, _mm256_sub_epi32(s, _mm256_slli_epi32::<SHIFT>(i)))
    };
    let step = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
    let sy = _mm256_set1_epi32((y << SHIFT) as i32);
    let width = _mm256_set1_epi32(w as i32);
    // SAFETY: each weight row holds GRID = 16 f32, read 8 from 0 or 8.
    #[allow(unsafe_code)]
    let weights = |t: usize| {
        rows.k
            .map(|k| unsafe { _mm256_loadu_ps(k[t..t + 8].as_ptr()) })
    };
    let halves = [weights(0), weights(8)];
    let n = out.len() / 8 * 8;
    // The nodes of the cell the last block was in (a cell is two blocks).
    let mut cell = (
        usize::MAX,
        [_mm256_setzero_ps(); 4],
        [_mm256_setzero_ps(); 4],
    );
    for (b, block) in out[..n].chunks_exact_mut(8).enumerate() {
        let x = x0 + 8 * b as u32;
        let (c, k) = (
            (x / GRID as u32 - rows.first) as usize,
            &halves[x as usize % GRID / 8],
        );
        if cell.0 != c {
            cell = (c, nodes(rows.u, c), nodes(rows.v, c));
        }
        let xs = _mm256_add_epi32(_mm256_set1_epi32(x as i32), step);
        let su = _mm256_add_epi32(_mm256_slli_epi32::<SHIFT>(xs), mix(&cell.1, k));
        let (ix, wx) = axis(su, w);
        let (iy, wy) = axis(_mm256_add_epi32(sy, mix(&cell.2, k)), h);
        let index = _mm256_add_epi32(_mm256_mullo_epi32(iy, width), ix);
        let weights = _mm256_or_si256(wx, _mm256_slli_epi32::<16>(wy));
        // Per lane [t0 t1 | t4 t5] and [t2 t3 | t6 t7], each tap a u64.
        let (a, c) = (
            _mm256_unpacklo_epi32(index, weights),
            _mm256_unpackhi_epi32(index, weights),
        );
        // SAFETY: `block` is 8 `Tap`s, 64 bytes (`Tap` is a transparent `u64`).
        #[allow(unsafe_code)]
        unsafe {
            let p = block.as_mut_ptr() as *mut __m256i;
            _mm256_storeu_si256(p, _mm256_permute2x128_si256::<0x20>(a, c));
            _mm256_storeu_si256(p.add(1), _mm256_permute2x128_si256::<0x31>(a, c));
        }
    }
    row_taps_scalar(rows, x0 + n as u32, y, (w, h), &mut out[n..]);
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Cubic-like weights at each column of a cell (any will do here).
    fn weights() -> [[f32; GRID]; 4] {
        std::array::from_fn(|i| std::array::from_fn(|t| (i as f32 - 1.3) * 0.17 + t as f32 / 41.0))
    }

    /// The AVX2 taps are the scalar ones for displacements of every size
    /// (ties, past either edge, the clamp), from a column that is not a
    /// multiple of 8, on a row that is not a multiple of 8 long.
    #[test]
    fn the_avx2_taps_are_the_scalar_taps() {
        let (w, h, n) = (203u32, 77u32, 187usize);
        let plane = |seed: f32| -> Vec<f32> {
            (0..20)
                .map(|i| match i % 7 {
                    0 => 0.5,
                    1 => -2.5,
                    2 => 3.0e7,
                    3 => -3.0e7,
                    _ => ((i as f32 + seed) * 0.731).sin() * 9000.0,
                })
                .collect()
        };
        let (u, v, k) = (plane(0.0), plane(17.0), weights());
        let rows = Rows {
            u: &u,
            v: &v,
            first: 0,
            k: &k,
        };
        for (x0, y) in [(9u32, 0u32), (0, 5), (16, 76), (3, 40)] {
            let mut scalar = vec![Tap(0); n];
            row_taps_scalar(&rows, x0, y, (w, h), &mut scalar);
            let mut fast = vec![Tap(1); n];
            row_taps(&rows, x0, y, (w, h), &mut fast);
            assert_eq!(scalar, fast, "from ({x0}, {y})");
            // The clamp reaches both edges.
            assert!(
                scalar
                    .iter()
                    .any(|t| t.index() % w == w - 2 && t.wx() == ONE)
            );
            assert!(scalar.iter().any(|t| t.index() % w == 0 && t.wx() == 0));
        }
    }

    /// A displacement that rounds to a whole pixel gives that pixel with
    /// weight 0; half a pixel further the weight is half; the nodes of
    /// later cells are read from `first`.
    #[test]
    fn a_displacement_lands_on_its_pixel_and_fraction() {
        let mut k = [[0.0f32; GRID]; 4];
        k[1] = [1.0; GRID];
        let d = |du: f32, dv: f32| {
            let (u, v) = ([0.0, du, 0.0, 0.0], [0.0, dv, 0.0, 0.0]);
            let rows = Rows {
                u: &u,
                v: &v,
                first: 1,
                k: &k,
            };
            let mut t = [Tap(0)];
            row_taps(&rows, 26, 20, (64, 48), &mut t);
            (t[0].index() % 64, t[0].index() / 64, t[0].wx(), t[0].wy())
        };
        assert_eq!(d(3.0 * 1024.0, -2.0 * 1024.0), (29, 18, 0, 0));
        assert_eq!(d(512.0, 256.0), (26, 20, 512, 256));
        assert_eq!(d(-0.6, 0.4), (25, 20, 1023, 0));
    }
}
