//! Output pixels' bilinear taps from the lens map's grid (issue 41): a
//! row's grid nodes (each its source's displacement in 1/[`ONE`] px,
//! already mixed from the four grid rows around the row) mixed per pixel
//! in f32 from the four nodes around its column (cubic Lagrange weights,
//! the sum in one fixed order, no fused multiply-add), rounded to a whole
//! 1/[`ONE`] px (ties to even), added to the pixel's own position and split
//! into the top-left source pixel and the weights by shifts. The scalar
//! code ([`row_taps`], a [`Tap`] per pixel) and, where the CPU has it, AVX2
//! eight pixels at a time ([`Block`], kept in registers for the kernel),
//! with the same taps (tested).

/// The taps' scale: positions and weights in 1/ONE px (64 = the whole pixel).
pub(super) const ONE: u32 = 64;

/// log₂ [`ONE`]: a position in 1/ONE px shifted right by this is its pixel.
const SHIFT: i32 = 6;
const _: () = assert!(ONE == 1 << SHIFT);

/// The grid's spacing, pixels: a cell's columns share its four nodes.
pub(super) const GRID: usize = 16;

/// The largest displacement a row's node holds, in 1/ONE px (16384 px,
/// the largest picture side): a pixel's mix (cubic weights, their
/// magnitudes summing to at most 1.25) and its position stay inside i32.
pub(super) const LIM: f32 = 1_048_576.0;

/// One output pixel's bilinear taps, packed in a `u64`: the top-left
/// source pixel's index (bits 0–31) and the weights of the right column
/// (bits 32–47) and lower row (bits 48–63), in 1/[`ONE`].
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(transparent)]
pub(super) struct Tap(pub(super) u64);

impl Tap {
    #[inline(always)]
    pub(super) fn new(index: u32, wx: u32, wy: u32) -> Self {
        Self(u64::from(index) | u64::from(wx) << 32 | u64::from(wy) << 48)
    }
    #[inline(always)]
    pub(super) fn index(self) -> u32 {
        self.0 as u32
    }
    #[inline(always)]
    pub(super) fn wx(self) -> u32 {
        (self.0 >> 32) as u32 & 0xffff
    }
    #[inline(always)]
    pub(super) fn wy(self) -> u32 {
        (self.0 >> 48) as u32
    }
}

/// An output row's grid nodes: each plane's displacements (u, then v,
/// within ±[`LIM`]) at the nodes from the one before cell `first` on, and
/// the cubic weights of each column's place in its cell (`k[i][t]`: node
/// i's at column t).
pub(super) struct Rows<'a> {
    pub u: &'a [f32],
    pub v: &'a [f32],
    pub first: u32,
    pub k: &'a [[f32; GRID]; 4],
}

impl Rows<'_> {
    /// How many of the `n` columns from `x0` the nodes' cells cover (none
    /// when `x0` is before the first cell).
    pub(super) fn covered(&self, x0: u32, n: usize) -> usize {
        let nodes = self.u.len().min(self.v.len());
        let cells = (nodes.saturating_sub(3) as u32 + self.first) * GRID as u32;
        if x0 < self.first * GRID as u32 {
            return 0;
        }
        (n as u32).min(cells.saturating_sub(x0)) as usize
    }
}

/// The taps of the output pixels from column `x0` of row `y` (a `w`×`h`
/// picture) into `out` (columns past the nodes' cells left as they are):
/// the AVX2 code where the CPU has it, else the scalar (the same taps).
pub(super) fn row_taps(rows: &Rows, x0: u32, y: u32, (w, h): (u32, u32), out: &mut [Tap]) {
    let n = rows.covered(x0, out.len());
    let out = &mut out[..n];
    #[cfg(target_arch = "x86_64")]
    if crate::simd::simd_level() >= 1 {
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
    m.round_ties_even() as i32
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
pub(super) fn row_taps_scalar(rows: &Rows, x0: u32, y: u32, (w, h): (u32, u32), out: &mut [Tap]) {
    let sy = (y << SHIFT) as i32;
    for (tap, x) in out.iter_mut().zip(x0..) {
        let (ix, wx) = axis(((x << SHIFT) as i32) + mixed(rows.u, rows, x), w);
        let (iy, wy) = axis(sy + mixed(rows.v, rows, x), h);
        *tap = Tap::new(iy * w + ix, wx, wy);
    }
}

/// [`row_taps_scalar`]'s arithmetic on AVX2 for eight pixels at a time
/// (half a cell, from a column that is a multiple of 8): the f32 mix in the
/// scalar's order, the rounding `cvtps` (ties to even, the default MXCSR),
/// the rest in i32. [`Block::at`] gives a block's source indices and
/// weights in registers.
#[cfg(target_arch = "x86_64")]
pub(super) struct Block {
    /// The cubic weights of a cell's first 8 columns, then its last 8.
    halves: [[std::arch::x86_64::__m256; 4]; 2],
    /// The cell whose nodes `u` and `v` hold (each node in every lane).
    cell: usize,
    u: [std::arch::x86_64::__m256; 4],
    v: [std::arch::x86_64::__m256; 4],
    /// The row's position (1/ONE px), the picture's width and height.
    sy: std::arch::x86_64::__m256i,
    size: (u32, u32),
}

#[cfg(target_arch = "x86_64")]
impl Block {
    /// The blocks of row `y` of a `w`×`h` picture with `rows`' nodes.
    #[target_feature(enable = "avx2")]
    #[inline]
    pub(super) fn new(rows: &Rows, y: u32, (w, h): (u32, u32)) -> Self {
        use std::arch::x86_64::*;
        // SAFETY: each weight row holds GRID = 16 f32, read 8 from 0 or 8.
        #[allow(unsafe_code)]
        let weights = |t: usize| {
            rows.k
                .map(|k| unsafe { _mm256_loadu_ps(k[t..t + 8].as_ptr()) })
        };
        Self {
            halves: [weights(0), weights(8)],
            cell: usize::MAX,
            u: [_mm256_setzero_ps(); 4],
            v: [_mm256_setzero_ps(); 4],
            sy: _mm256_set1_epi32((y << SHIFT) as i32),
            size: (w, h),
        }
    }

    /// The block of the 8 columns from `x` (a multiple of 8 inside the
    /// nodes' cells): each pixel's top-left source index, and its weights
    /// as ONE − wx (bits 0–7), wx (8–15) and wy · 256 (16–31). Inlined
    /// whole into the AVX2 callers, with no closures (a call would pass
    /// the registers through memory; a closure is a baseline function).
    ///
    /// # Safety
    /// The CPU has AVX2.
    #[inline(always)]
    #[allow(unsafe_code)]
    pub(super) unsafe fn at(
        &mut self,
        rows: &Rows,
        x: u32,
    ) -> (std::arch::x86_64::__m256i, std::arch::x86_64::__m256i) {
        use std::arch::x86_64::*;
        let c = (x / GRID as u32 - rows.first) as usize;
        // SAFETY (each block): the caller's CPU has AVX2.
        if self.cell != c {
            // A cell's four nodes, each in every lane (`Rows::covered`
            // keeps `c + 4` within the nodes: the zeros are never read).
            let (u, v) = (rows.u.get(c..c + 4), rows.v.get(c..c + 4));
            let (u, v) = (u.unwrap_or(&[0.0; 4]), v.unwrap_or(&[0.0; 4]));
            for i in 0..4 {
                self.u[i] = unsafe { _mm256_set1_ps(u[i]) };
                self.v[i] = unsafe { _mm256_set1_ps(v[i]) };
            }
            self.cell = c;
        }
        let k = &self.halves[x as usize % GRID / 8];
        let (w, h) = self.size;
        unsafe {
            let step = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
            let xs =
                _mm256_slli_epi32::<SHIFT>(_mm256_add_epi32(_mm256_set1_epi32(x as i32), step));
            let (ix, wx) = axis8(_mm256_add_epi32(xs, mix8(k, &self.u)), w);
            let (iy, wy) = axis8(_mm256_add_epi32(self.sy, mix8(k, &self.v)), h);
            let index = _mm256_add_epi32(_mm256_mullo_epi32(iy, _mm256_set1_epi32(w as i32)), ix);
            (index, packed_weights(wx, wy))
        }
    }
}

/// Eight pixels' weights (`wx`, `wy` in 0–[`ONE`], a lane each) as the
/// kernel takes them: ONE − wx (bits 0–7), wx (8–15) and wy · 256 (16–31).
///
/// # Safety
/// The CPU has AVX2.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
#[allow(unsafe_code)]
pub(super) unsafe fn packed_weights(
    wx: std::arch::x86_64::__m256i,
    wy: std::arch::x86_64::__m256i,
) -> std::arch::x86_64::__m256i {
    use std::arch::x86_64::*;
    // SAFETY: the caller's CPU has AVX2.
    unsafe {
        let pair = _mm256_or_si256(
            _mm256_sub_epi32(_mm256_set1_epi32(ONE as i32), wx),
            _mm256_slli_epi32::<8>(wx),
        );
        _mm256_or_si256(pair, _mm256_slli_epi32::<24>(wy))
    }
}

/// [`mixed`] of eight columns: the cell's nodes `p` by the columns'
/// weights `k`, in the scalar's order, rounded (`cvtps`, ties to even).
///
/// # Safety
/// The CPU has AVX2.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
#[allow(unsafe_code)]
unsafe fn mix8(
    k: &[std::arch::x86_64::__m256; 4],
    p: &[std::arch::x86_64::__m256; 4],
) -> std::arch::x86_64::__m256i {
    use std::arch::x86_64::*;
    // SAFETY: the caller's CPU has AVX2.
    unsafe {
        let m = _mm256_add_ps(
            _mm256_add_ps(
                _mm256_add_ps(_mm256_mul_ps(k[0], p[0]), _mm256_mul_ps(k[1], p[1])),
                _mm256_mul_ps(k[2], p[2]),
            ),
            _mm256_mul_ps(k[3], p[3]),
        );
        _mm256_cvtps_epi32(m)
    }
}

/// [`axis`] of eight positions.
///
/// # Safety
/// The CPU has AVX2.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
#[allow(unsafe_code)]
unsafe fn axis8(
    s: std::arch::x86_64::__m256i,
    n: u32,
) -> (std::arch::x86_64::__m256i, std::arch::x86_64::__m256i) {
    use std::arch::x86_64::*;
    // SAFETY: the caller's CPU has AVX2.
    unsafe {
        let s = _mm256_min_epi32(
            _mm256_max_epi32(s, _mm256_setzero_si256()),
            _mm256_set1_epi32(((n - 1) << SHIFT) as i32),
        );
        let i = _mm256_min_epu32(
            _mm256_srli_epi32::<SHIFT>(s),
            _mm256_set1_epi32((n - 2) as i32),
        );
        (i, _mm256_sub_epi32(s, _mm256_slli_epi32::<SHIFT>(i)))
    }
}

/// [`row_taps_scalar`]'s taps by [`Block`], eight pixels at a time from
/// the first column that is a multiple of 8 (the scalar code for the
/// columns before it and the last few).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn row_taps_avx2(rows: &Rows, x0: u32, y: u32, (w, h): (u32, u32), out: &mut [Tap]) {
    use std::arch::x86_64::*;
    let head = ((8 - x0 % 8) % 8).min(out.len() as u32) as usize;
    let (before, out) = out.split_at_mut(head);
    row_taps_scalar(rows, x0, y, (w, h), before);
    let x0 = x0 + head as u32;
    let mut block = Block::new(rows, y, (w, h));
    let n = out.len() / 8 * 8;
    for (b, taps) in out[..n].chunks_exact_mut(8).enumerate() {
        // SAFETY: the CPU has AVX2 (this function's caller checks).
        #[allow(unsafe_code)]
        let (index, wts) = unsafe { block.at(rows, x0 + 8 * b as u32) };
        // Each tap's weights as the `Tap` keeps them: wx | wy << 16.
        let weights = _mm256_or_si256(
            _mm256_srli_epi32::<8>(_mm256_and_si256(wts, _mm256_set1_epi32(0xff00))),
            _mm256_slli_epi32::<16>(_mm256_srli_epi32::<24>(wts)),
        );
        // Per lane [t0 t1 | t4 t5] and [t2 t3 | t6 t7], each tap a u64.
        let (a, c) = (
            _mm256_unpacklo_epi32(index, weights),
            _mm256_unpackhi_epi32(index, weights),
        );
        // SAFETY: `taps` is 8 `Tap`s, 64 bytes (`Tap` is a transparent `u64`).
        #[allow(unsafe_code)]
        unsafe {
            let p = taps.as_mut_ptr() as *mut __m256i;
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
    /// (ties, past either edge, the limit), from a column that is not a
    /// multiple of 8, on a row that is not a multiple of 8 long.
    #[test]
    fn the_avx2_taps_are_the_scalar_taps() {
        let (w, h, n) = (203u32, 77u32, 187usize);
        let plane = |seed: f32| -> Vec<f32> {
            (0..20)
                .map(|i| match i % 7 {
                    0 => 0.5,
                    1 => -2.5,
                    2 => LIM,
                    3 => -LIM,
                    _ => ((i as f32 + seed) * 0.731).sin() * 600.0,
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
            // The clamp reaches both edges; some taps fall between pixels.
            assert!(
                scalar
                    .iter()
                    .any(|t| t.index() % w == w - 2 && t.wx() == ONE)
            );
            assert!(scalar.iter().any(|t| t.index() % w == 0 && t.wx() == 0));
            assert!(
                scalar
                    .iter()
                    .any(|t| t.wx() % ONE != 0 && t.wy() % ONE != 0)
            );
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
        assert_eq!(d(3.0 * 64.0, -2.0 * 64.0), (29, 18, 0, 0));
        assert_eq!(d(32.0, 16.0), (26, 20, 32, 16));
        assert_eq!(d(-0.6, 0.4), (25, 20, 63, 0));
    }
}
