//! The capture chain of a recorded thermal video (docs/realism.md, "The
//! capture chain"), on the camera's developed 8-bit grey frame, before the
//! file's own encoding: what happens between a thermal camera's analogue
//! or digital video out and the frames a dataset ships.
//!
//! - **An earlier lossy compression**: the recorder's 8×8 DCT quantisation
//!   (MPEG or JPEG), decoded back to levels. Each block's orthonormal DCT
//!   (JPEG's: the DC is 8 × the block's mean) is quantised with one step
//!   for the DC and one for the other 63 coefficients, then inverted and
//!   rounded to levels. A smooth sky's blocks lose their slope and keep
//!   their mean to the DC step, so neighbouring blocks differ by steps at
//!   their edges; noise coefficients larger than the AC step stay in. The
//!   blocks lie on the frame's 8-pixel grid; a partial block at the right
//!   or bottom edge is filled out by its last column or row (as a JPEG
//!   encoder does) and only its own pixels are written back.
//! - **Border lines** the digitiser adds (blanking): rows and columns at
//!   fixed offsets from the frame's edges, each moved by its own number of
//!   levels (clamped to 0–255), after the compression (the recorded lines
//!   are sharp).
//!
//! Both are arithmetic on the levels in a fixed order (f64, no fused
//! multiply-add), so the bytes are the same on every machine and any
//! number of threads. Off ([`Capture`]'s defaults) they cost nothing.
//!
//! The compression computes only what the quantiser keeps, with the plain
//! loops' bytes: most AC coefficients of a thermal frame round to 0. An f32
//! estimate of each block's DCT (its error bounded far inside
//! [`ESTIMATE_ERROR`]) names the rows that may hold an AC coefficient of
//! half the AC step or more; those rows and the DC are computed as the
//! plain loops do, the others are 0, as the quantiser would have made
//! them. The inverse runs over the nonzero rows and columns alone: a
//! skipped product is ±0, and adding ±0 changes no sum but the sign of a
//! zero, which gives the same level. A block left with its DC alone is one
//! level, the plain loops' `(s·DC)·s` (every entry of D's row 0 is `s`).

use std::sync::OnceLock;

use rayon::prelude::*;

use crate::preset::thermal::Capture;

/// A block's side, pixels.
const N: usize = 8;

/// `body` once for each row index `$i` in 0..8, written out: a loop over
/// the rows whose body works on a whole row would be vectorised across
/// the rows instead (gathers and scatters), not along each row.
macro_rules! each_row {
    (|$i:ident| $body:block) => {
        each_row!(@ $i $body 0 1 2 3 4 5 6 7)
    };
    (@ $i:ident $body:block $($n:literal)*) => {
        $({
            let $i: usize = $n;
            $body
        })*
    };
}

/// The chain on the RGBA8 grey frame `rgba` of `w`×`h` pixels (R = G = B):
/// the earlier compression, then the border lines.
pub fn apply(c: &Capture, (w, h): (u32, u32), rgba: &mut [u8]) {
    let (w, h) = (w as usize, h as usize);
    if w == 0 || h == 0 || rgba.len() < w * h * 4 {
        return;
    }
    if c.prior_dc_step > 0.0 || c.prior_ac_step > 0.0 {
        prior_compression(c.prior_dc_step, c.prior_ac_step, w, rgba);
    }
    border(c, w, h, rgba);
}

/// An 8×8 block of levels or coefficients, row by row.
type Block = [[f64; N]; N];

/// An 8×8 block in f32: levels − 128, or estimated coefficients.
type Block32 = [[f32; N]; N];

/// The orthonormal 8-point DCT-II matrix `D[u][x]`, its transpose, and
/// both rounded to f32 (for the estimate).
struct Dct {
    d: Block,
    dt: Block,
    d32: Block32,
    dt32: Block32,
}

fn dct() -> &'static Dct {
    static D: OnceLock<Dct> = OnceLock::new();
    D.get_or_init(|| {
        let mut d = [[0.0; N]; N];
        for (u, row) in d.iter_mut().enumerate() {
            let scale = if u == 0 {
                (1.0 / N as f64).sqrt()
            } else {
                (2.0 / N as f64).sqrt()
            };
            for (x, v) in row.iter_mut().enumerate() {
                let angle = std::f64::consts::PI * (2 * x + 1) as f64 * u as f64 / (2 * N) as f64;
                *v = scale * angle.cos();
            }
        }
        let dt = std::array::from_fn(|i| std::array::from_fn(|j| d[j][i]));
        let d32 = d.map(|row| row.map(|v| v as f32));
        let dt32 = dt.map(|row| row.map(|v| v as f32));
        Dct { d, dt, d32, dt32 }
    })
}

/// The most an estimated coefficient ([`estimate`]) may be from the plain
/// loops' f64 value, with room to spare. It is below 2·10⁻³: the levels −
/// 128 are at most 128, so the first pass's f32 sums are at most √2 × 256
/// (the even and odd sums, whole, times half a row of D) and the second's
/// at most 1024 (the block's norm), each of at most 16 products and sums
/// with a rounding error of 2⁻²⁴ of its size, and D's f32 entries are
/// within 2⁻²⁴ of its own (lib test: the largest seen is below a quarter
/// of this).
const ESTIMATE_ERROR: f64 = 1.0 / 64.0;

/// The quantiser's steps, and the magnitude below which an estimated AC
/// coefficient surely rounds to 0 (0: none does, every row computed).
#[derive(Clone, Copy)]
struct Steps {
    dc: f64,
    ac: f64,
    zero_below: f32,
}

impl Steps {
    /// An estimate below `ac / 2 − ESTIMATE_ERROR` (in f32, rounded down)
    /// is of a coefficient below `ac / 2 − 0.0136`, whose quotient by `ac`
    /// (at most 255) is below ½ − 5·10⁻⁵ and rounds to ±0.
    fn new(dc: f64, ac: f64) -> Steps {
        let bound = 0.5 * ac - ESTIMATE_ERROR;
        let mut zero_below = bound as f32;
        if f64::from(zero_below) > bound {
            zero_below = zero_below.next_down();
        }
        Steps {
            dc,
            ac,
            zero_below: zero_below.max(0.0),
        }
    }
}

/// Each 8×8 block of the frame quantised in the DCT (DC step `dc`, the
/// others `ac`; 0: kept) and back, in bands of 8 rows on rayon's threads.
fn prior_compression(dc: f64, ac: f64, w: usize, rgba: &mut [u8]) {
    let d = dct();
    let steps = Steps::new(dc, ac);
    rgba.par_chunks_mut(N * w * 4)
        .for_each(|band| compress_band(band, w, steps, d));
}

simd_fn! {
    /// One band of 8 rows (fewer at the bottom edge) of [`prior_compression`].
    fn compress_band(band: &mut [u8], w: usize, steps: Steps, d: &Dct) {
        let rows = band.len() / (w * 4);
        for x0 in (0..w).step_by(N) {
            if rows == N && x0 + N <= w {
                let b = load_whole(band, w, x0);
                let levels = compress_block(&b, steps, d);
                store_whole(band, w, x0, &levels);
            } else {
                let b = load_edge(band, w, rows, x0);
                let levels = compress_block(&b, steps, d);
                store_edge(band, w, rows, x0, &levels);
            }
        }
    }
}

/// The block at column `x0` of a band of 8 whole rows of `w` pixels, as
/// levels − 128.
#[inline(always)]
fn load_whole(band: &[u8], w: usize, x0: usize) -> Block32 {
    let mut b = [[0.0; N]; N];
    for (y, row) in b.iter_mut().enumerate() {
        let at = (y * w + x0) * 4;
        if let Some(px) = band.get(at..at + N * 4) {
            for (v, p) in row.iter_mut().zip(px.as_chunks::<4>().0) {
                *v = (u32::from_le_bytes(*p) & 0xFF) as i32 as f32 - 128.0;
            }
        }
    }
    b
}

/// [`load_whole`] for a block at the right or bottom edge: its last column
/// and row repeated.
#[inline(always)]
fn load_edge(band: &[u8], w: usize, rows: usize, x0: usize) -> Block32 {
    let mut b = [[0.0; N]; N];
    for (y, row) in b.iter_mut().enumerate() {
        let words = load_row(&band[y.min(rows - 1) * w * 4..], x0, w);
        for (v, p) in row.iter_mut().zip(words) {
            *v = f32::from(p as u8) - 128.0;
        }
    }
    b
}

/// `levels` as the grey of the block at column `x0` of a band of 8 whole
/// rows (alpha kept).
#[inline(always)]
fn store_whole(band: &mut [u8], w: usize, x0: usize, levels: &[[u32; N]; N]) {
    for (y, row) in levels.iter().enumerate() {
        let at = (y * w + x0) * 4;
        if let Some(px) = band.get_mut(at..at + N * 4) {
            for (p, g) in px.as_chunks_mut::<4>().0.iter_mut().zip(row) {
                let word = u32::from_le_bytes(*p);
                *p = ((word & 0xFF00_0000) | (g << 16) | (g << 8) | g).to_le_bytes();
            }
        }
    }
}

/// [`store_whole`] for a block at the right or bottom edge: its own pixels
/// only.
#[inline(always)]
fn store_edge(band: &mut [u8], w: usize, rows: usize, x0: usize, levels: &[[u32; N]; N]) {
    for (y, row) in levels.iter().enumerate().take(rows) {
        let line = &mut band[(y * w + x0) * 4..];
        let mut words = load_row(line, 0, w - x0);
        for (p, g) in words.iter_mut().zip(row) {
            *p = (*p & 0xFF00_0000) | (g << 16) | (g << 8) | g;
        }
        store_row(line, &words, w - x0);
    }
}

/// The first eight RGBA pixels of `line` from column `x0` as words, the
/// last of a `w`-pixel row repeated past its end.
#[inline(always)]
fn load_row(line: &[u8], x0: usize, w: usize) -> [u32; N] {
    let mut words = [0u32; N];
    let pixels = line.as_chunks::<4>().0;
    for (x, p) in words.iter_mut().enumerate() {
        if let Some(b) = pixels.get((x0 + x).min(w.saturating_sub(1))) {
            *p = u32::from_le_bytes(*b);
        }
    }
    words
}

/// `words` into the first pixels of `line`, at most `w` of them.
#[inline(always)]
fn store_row(line: &mut [u8], words: &[u32; N], w: usize) {
    let n = w.min(N);
    let Some(bytes) = line.get_mut(..n * 4) else {
        return;
    };
    for (b, p) in bytes.as_chunks_mut::<4>().0.iter_mut().zip(words) {
        *b = p.to_le_bytes();
    }
}

/// One block (levels − 128) quantised in the DCT and back, as levels.
#[inline(always)]
fn compress_block(b: &Block32, steps: Steps, d: &Dct) -> [[u32; N]; N] {
    let exact = if steps.zero_below > 0.0 {
        candidate_rows(estimate(b, d), steps.zero_below)
    } else {
        0xFF
    };
    let mut c = [[0.0; N]; N];
    forward(b, exact, steps, d, &mut c);
    let (rows, cols) = nonzero(&c, exact | 1);
    let mut levels = [[0u32; N]; N];
    if rows <= 1 && cols <= 1 {
        let s = d.d[0][0];
        let g = level(round(s * c[0][0] * s + 128.0));
        for row in levels.iter_mut() {
            row.fill(g);
        }
    } else {
        let back = inverse(&c, (rows, cols), d);
        // Flat: the 64 levels as one loop of lanes.
        for (g, v) in levels
            .as_flattened_mut()
            .iter_mut()
            .zip(back.as_flattened())
        {
            *g = level(round(v + 128.0));
        }
    }
    levels
}

/// The block's DCT `D·B·Dᵀ` in f32 (`[u][v]` holds coefficient (u, v)):
/// `D·B` by the even/odd split on the block's columns, then each of its
/// rows times `Dᵀ` (the sum over k in ascending order, no transpose).
#[inline(always)]
fn estimate(b: &Block32, d: &Dct) -> Block32 {
    let t = columns_dct(b, d);
    let mut x = [[0.0; N]; N];
    each_row!(|u| {
        for (s, dtk) in t[u].iter().zip(&d.dt32) {
            add_product(&mut x[u], *s, dtk);
        }
    });
    x
}

/// The rows u of the DCT with an estimated AC coefficient of magnitude
/// `zero_below` or more, as bits, from [`estimate`]'s block.
#[inline(always)]
fn candidate_rows(mut x: Block32, zero_below: f32) -> u8 {
    x[0][0] = 0.0; // the DC
    let mut rows = 0;
    each_row!(|u| {
        let over = x[u].iter().fold(false, |o, v| o | (v.abs() >= zero_below));
        rows |= u8::from(over) << u;
    });
    rows
}

/// `D·B` in f32 by the even/odd split of B's rows (D's even rows are
/// symmetric, its odd rows antisymmetric: rows k and 7 − k summed for
/// the even u, differenced for the odd).
#[inline(always)]
fn columns_dct(b: &Block32, d: &Dct) -> Block32 {
    let even = [
        sum(&b[0], &b[7]),
        sum(&b[1], &b[6]),
        sum(&b[2], &b[5]),
        sum(&b[3], &b[4]),
    ];
    let odd = [
        difference(&b[0], &b[7]),
        difference(&b[1], &b[6]),
        difference(&b[2], &b[5]),
        difference(&b[3], &b[4]),
    ];
    let mut t = [[0.0; N]; N];
    for u in [0, 2, 4, 6] {
        for (k, e) in even.iter().enumerate() {
            add_product(&mut t[u], d.d32[u][k], e);
        }
    }
    for u in [1, 3, 5, 7] {
        for (k, o) in odd.iter().enumerate() {
            add_product(&mut t[u], d.d32[u][k], o);
        }
    }
    t
}

/// `a + b`, lane by lane.
#[inline(always)]
fn sum(a: &[f32; N], b: &[f32; N]) -> [f32; N] {
    let mut r = *a;
    for (r, b) in r.iter_mut().zip(b) {
        *r += b;
    }
    r
}

/// `a − b`, lane by lane.
#[inline(always)]
fn difference(a: &[f32; N], b: &[f32; N]) -> [f32; N] {
    let mut r = *a;
    for (r, b) in r.iter_mut().zip(b) {
        *r -= b;
    }
    r
}

/// `acc += s·x`, lane by lane (one product, then the sum: no fused
/// multiply-add), in f32 (the estimate) or f64 (the plain loops' sums).
#[inline(always)]
fn add_product<T>(acc: &mut [T; N], s: T, x: &[T; N])
where
    T: Copy + std::ops::Mul<Output = T> + std::ops::AddAssign,
{
    for (v, x) in acc.iter_mut().zip(x) {
        *v += s * *x;
    }
}

/// The quantised DCT `D·B·Dᵀ` of the block, rows `rows` whole and row 0's
/// DC, each value the plain loops' (the sum over k in ascending order from
/// 0, one product at a time: no fused multiply-add); the rest left 0.
#[inline(always)]
fn forward(b: &Block32, rows: u8, steps: Steps, d: &Dct, c: &mut Block) {
    let mut b64 = [[0.0; N]; N];
    for (r, s) in b64.iter_mut().zip(b) {
        for (v, x) in r.iter_mut().zip(s) {
            *v = f64::from(*x);
        }
    }
    let mut todo = rows | 1;
    while todo != 0 {
        let u = todo.trailing_zeros() as usize;
        todo &= todo - 1;
        let mut t = [0.0; N];
        for (&s, bk) in d.d[u].iter().zip(&b64) {
            for (v, x) in t.iter_mut().zip(bk) {
                *v += s * x;
            }
        }
        let row = &mut c[u];
        if rows & 1 << u == 0 {
            // Row 0 for its DC alone: Σₖ t[k]·Dᵀ[k][0].
            let mut p = [0.0; N];
            for ((p, t), s) in p.iter_mut().zip(&t).zip(&d.d[0]) {
                *p = t * s;
            }
            row[0] = p.iter().fold(0.0, |dc, p| dc + p);
        } else {
            for (&s, dk) in t.iter().zip(&d.dt) {
                for (v, x) in row.iter_mut().zip(dk) {
                    *v += s * x;
                }
            }
            if steps.ac > 0.0 {
                let first = row[0];
                for x in row.iter_mut() {
                    *x = round(*x / steps.ac) * steps.ac;
                }
                if u == 0 {
                    row[0] = first;
                }
            }
        }
        if u == 0 && steps.dc > 0.0 {
            row[0] = round(row[0] / steps.dc) * steps.dc;
        }
    }
}

/// The rows and columns of `c` with a value other than ±0, as bits, of the
/// rows `computed` (the others are 0).
#[inline(always)]
fn nonzero(c: &Block, computed: u8) -> (u8, u8) {
    let (mut rows, mut cols) = (0u8, 0u8);
    let mut todo = computed;
    while todo != 0 {
        let u = todo.trailing_zeros() as usize;
        todo &= todo - 1;
        let m = c[u]
            .iter()
            .enumerate()
            .fold(0u8, |m, (v, x)| m | (u8::from(*x != 0.0) << v));
        cols |= m;
        rows |= u8::from(m != 0) << u;
    }
    (rows, cols)
}

/// `Dᵀ·C·D` over the rows `rows` and columns `cols` of `c` alone (the
/// others ±0), each value the plain loops' but for the sign of a zero.
#[inline(always)]
fn inverse(c: &Block, (rows, cols): (u8, u8), d: &Dct) -> Block {
    let mut t = [[0.0; N]; N];
    let mut todo = rows;
    while todo != 0 {
        let k = todo.trailing_zeros() as usize;
        todo &= todo - 1;
        each_row!(|i| {
            add_product(&mut t[i], d.d[k][i], &c[k]);
        });
    }
    let mut out = [[0.0; N]; N];
    let mut todo = cols;
    while todo != 0 {
        let k = todo.trailing_zeros() as usize;
        todo &= todo - 1;
        each_row!(|i| {
            add_product(&mut out[i], t[i][k], &d.d[k]);
        });
    }
    out
}

/// A whole `x` clamped to 0–255, as an integer: the low bits of
/// `x + 2⁵²`, which holds a whole number below 2⁵² exactly in its mantissa
/// (`x as u8` in operations that vectorise).
#[inline(always)]
fn level(x: f64) -> u32 {
    const WHOLE: f64 = 4_503_599_627_370_496.0; // 2⁵²
    ((x.clamp(0.0, 255.0) + WHOLE).to_bits() & 0xFF) as u32
}

/// `x.round()` (halves away from 0) in operations that vectorise: the
/// truncation and the fraction left (exact), a unit added or taken away at
/// a half or more, the sign kept (−0 for −½ < x ≤ −0). An infinity's
/// fraction is NaN: nothing added.
#[inline(always)]
fn round(x: f64) -> f64 {
    let t = x.trunc();
    let f = x - t;
    let up = if f >= 0.5 { 1.0 } else { 0.0 };
    let down = if f <= -0.5 { 1.0 } else { 0.0 };
    (t + up - down).copysign(x)
}

/// The border lines: each named row or column moved by its offset.
fn border(c: &Capture, w: usize, h: usize, rgba: &mut [u8]) {
    let mut shift = |i: usize, off: f64| {
        let g = (f64::from(rgba[i * 4]) + off).round().clamp(0.0, 255.0) as u8;
        rgba[i * 4..i * 4 + 3].fill(g);
    };
    let lines = [
        (&c.top_rows, true, false),
        (&c.bottom_rows, true, true),
        (&c.left_columns, false, false),
        (&c.right_columns, false, true),
    ];
    for (offsets, is_row, from_end) in lines {
        let count = if is_row { h } else { w };
        for (k, &off) in offsets.iter().enumerate().filter(|&(k, _)| k < count) {
            let line = if from_end { count - 1 - k } else { k };
            if is_row {
                (line * w..(line + 1) * w).for_each(|i| shift(i, off));
            } else {
                (0..h).for_each(|y| shift(y * w + line, off));
            }
        }
    }
}

/// The mean absolute difference between neighbouring pixels across the
/// 8-pixel grid's block edges, less that inside the blocks (levels), over
/// the differences of at most `MAX_STEP_LEVELS` (smooth areas) between
/// pixels at least 8 from the frame's edges: the block steps an earlier
/// 8×8 compression leaves. `None` without such pairs on either side.
/// `grey` is `w`×`h` levels, row-major; `skip(i)` leaves pixel `i` out
/// (a burnt-in overlay).
pub fn block_steps(
    grey: &[u8],
    (w, h): (usize, usize),
    skip: impl Fn(usize) -> bool,
) -> Option<f32> {
    const MAX_STEP_LEVELS: u8 = 6;
    let (mut edge, mut inner) = ((0u64, 0u64), (0u64, 0u64));
    let mut add = |a: usize, b: usize, at_edge: bool| {
        if skip(a) || skip(b) {
            return;
        }
        let dv = grey[a].abs_diff(grey[b]);
        if dv <= MAX_STEP_LEVELS {
            let s = if at_edge { &mut edge } else { &mut inner };
            *s = (s.0 + u64::from(dv), s.1 + 1);
        }
    };
    for y in N..h.saturating_sub(N) {
        for x in N..w.saturating_sub(N) {
            let i = y * w + x;
            if x + 1 < w - N {
                add(i, i + 1, x % N == N - 1);
            }
            if y + 1 < h - N {
                add(i, i + w, y % N == N - 1);
            }
        }
    }
    let mean = |(s, n): (u64, u64)| (n > 0).then(|| s as f64 / n as f64);
    Some((mean(edge)? - mean(inner)?) as f32)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A `w`×`h` RGBA grey frame: a gentle slope plus a little hash noise.
    fn frame(w: usize, h: usize) -> Vec<u8> {
        let mut out = Vec::with_capacity(w * h * 4);
        for y in 0..h {
            for x in 0..w {
                let n = crate::seed::mix64((y * w + x) as u64) % 3;
                let g = (60.0 + 0.15 * x as f64 + 0.1 * y as f64) as u8 + n as u8;
                out.extend_from_slice(&[g, g, g, 255]);
            }
        }
        out
    }

    fn grey(rgba: &[u8]) -> Vec<u8> {
        rgba.chunks_exact(4).map(|p| p[0]).collect()
    }

    #[test]
    fn off_leaves_the_frame_alone_and_on_changes_it() {
        let (w, h) = (67, 45);
        let base = frame(w, h);
        let mut off = base.clone();
        apply(&Capture::default(), (w as u32, h as u32), &mut off);
        assert_eq!(off, base);
        let c = Capture {
            prior_dc_step: 16.0,
            prior_ac_step: 8.0,
            ..Capture::default()
        };
        let mut on = base.clone();
        apply(&c, (w as u32, h as u32), &mut on);
        assert_ne!(on, base);
        // Still grey, still opaque.
        assert!(
            on.chunks_exact(4)
                .all(|p| p[0] == p[1] && p[1] == p[2] && p[3] == 255)
        );
    }

    #[test]
    fn the_border_lines_move_their_rows_and_columns_only() {
        let (w, h) = (40, 24);
        let base = frame(w, h);
        let c = Capture {
            top_rows: vec![-50.0, -20.0],
            right_columns: vec![30.0],
            ..Capture::default()
        };
        let mut on = base.clone();
        apply(&c, (w as u32, h as u32), &mut on);
        let (a, b) = (grey(&base), grey(&on));
        for y in 0..h {
            for x in 0..w {
                let i = y * w + x;
                let mut want = f64::from(a[i]);
                want += [-50.0, -20.0].get(y).copied().unwrap_or(0.0);
                want += if x == w - 1 { 30.0 } else { 0.0 };
                assert_eq!(b[i], want.round().clamp(0.0, 255.0) as u8, "({x}, {y})");
            }
        }
    }

    #[test]
    fn the_block_steps_rise_with_the_prior_compression() {
        let (w, h) = (160, 120);
        let base = frame(w, h);
        let measure = |dc: f64| {
            let c = Capture {
                prior_dc_step: dc,
                prior_ac_step: 4.0,
                ..Capture::default()
            };
            let mut f = base.clone();
            apply(&c, (w as u32, h as u32), &mut f);
            block_steps(&grey(&f), (w, h), |_| false).expect("pairs")
        };
        let plain = block_steps(&grey(&base), (w, h), |_| false).expect("pairs");
        let (fine, coarse) = (measure(8.0), measure(24.0));
        assert!(plain.abs() < 0.1, "no compression: {plain}");
        assert!(fine > plain + 0.2, "{fine} vs {plain}");
        assert!(coarse > fine + 0.2, "{coarse} vs {fine}");
    }

    /// The compression as the plain triple loops and the library's
    /// `round` compute it, block by block.
    /// `A·B` (`Aᵀ` for `ta`, `Bᵀ` for `tb`) as the plain triple loop.
    fn plain_mul(a: &Block, b: &Block, ta: bool, tb: bool) -> Block {
        let at = |i: usize, k: usize| if ta { a[k][i] } else { a[i][k] };
        let bt = |k: usize, j: usize| if tb { b[j][k] } else { b[k][j] };
        std::array::from_fn(|i| {
            std::array::from_fn(|j| (0..N).fold(0.0, |s, k| s + at(i, k) * bt(k, j)))
        })
    }

    /// The block's DCT `D·B·Dᵀ` as the plain loops compute it.
    fn plain_dct(b: &Block) -> Block {
        let d = dct().d;
        plain_mul(&plain_mul(&d, b, false, false), &d, false, true)
    }

    fn plain_compression(dc: f64, ac: f64, (w, h): (usize, usize), rgba: &mut [u8]) {
        let d = dct().d;
        let mul = plain_mul;
        for y0 in (0..h).step_by(N) {
            for x0 in (0..w).step_by(N) {
                let px = |x: usize, y: usize| ((y0 + y).min(h - 1) * w + (x0 + x).min(w - 1)) * 4;
                let b: Block = std::array::from_fn(|y| {
                    std::array::from_fn(|x| f64::from(rgba[px(x, y)]) - 128.0)
                });
                let mut c = plain_dct(&b);
                for (u, row) in c.iter_mut().enumerate() {
                    for (v, x) in row.iter_mut().enumerate() {
                        let step = if u == 0 && v == 0 { dc } else { ac };
                        if step > 0.0 {
                            *x = (*x / step).round() * step;
                        }
                    }
                }
                let back = mul(&mul(&d, &c, true, false), &d, false, false);
                for (y, row) in back.iter().enumerate().take(h - y0) {
                    for (x, v) in row.iter().enumerate().take(w - x0) {
                        let g = (v + 128.0).round().clamp(0.0, 255.0) as u8;
                        rgba[px(x, y)..px(x, y) + 3].fill(g);
                    }
                }
            }
        }
    }

    #[test]
    fn the_compression_gives_the_plain_loops_bytes() {
        // Noisy frames of whole and partial blocks; steps that round often,
        // a step of 0 (kept) and tiny ones (every coefficient far above 2⁵²
        // would pass through whole).
        for (k, (w, h, dc, ac)) in [
            (64, 48, 8.0, 4.0),
            (67, 45, 16.0, 0.0),
            (19, 13, 0.0, 3.0),
            (33, 9, 1e-9, 1e-9),
            (24, 24, 255.0, 255.0),
            (9, 30, 1e-300, 5.0),
        ]
        .into_iter()
        .enumerate()
        {
            let mut base = frame(w, h);
            for (i, p) in base.chunks_exact_mut(4).enumerate() {
                let g = (crate::seed::mix64((i + 1000 * k) as u64) % 256) as u8;
                let g = if i % 3 == 0 { g } else { p[0] };
                p[..3].fill(g);
            }
            let c = Capture {
                prior_dc_step: dc,
                prior_ac_step: ac,
                ..Capture::default()
            };
            let mut fast = base.clone();
            apply(&c, (w as u32, h as u32), &mut fast);
            let mut plain = base.clone();
            plain_compression(dc, ac, (w, h), &mut plain);
            assert_eq!(fast, plain, "{w}×{h}, steps {dc} / {ac}");
            if dc.max(ac) >= 1.0 {
                assert_ne!(fast, base, "{w}×{h}, steps {dc} / {ac}: the frame changed");
            }
        }
    }

    /// A `w`×`h` RGBA grey frame of a low-rate codec's sparse noise: a
    /// slope with a level of noise and, at one pixel in 16, a spike of up
    /// to ±40 levels (a block keeps an AC row or two, rarely more).
    fn sparse_noise(w: usize, h: usize) -> Vec<u8> {
        let mut out = frame(w, h);
        for (i, p) in out.chunks_exact_mut(4).enumerate() {
            let bits = crate::seed::mix64(i as u64 ^ 0x5EED);
            let spike = if bits.is_multiple_of(16) {
                (bits >> 8) % 81
            } else {
                40
            };
            let g = (i64::from(p[0]) + spike as i64 - 40).clamp(0, 255) as u8;
            p[..3].fill(g);
        }
        out
    }

    #[test]
    fn sparse_noise_gives_the_plain_loops_bytes_on_any_threads() {
        let (w, h) = (203, 117);
        let base = sparse_noise(w, h);
        for (dc, ac) in [(0.0, 9.7), (16.0, 4.0), (8.0, 20.0)] {
            let c = Capture {
                prior_dc_step: dc,
                prior_ac_step: ac,
                ..Capture::default()
            };
            let mut plain = base.clone();
            plain_compression(dc, ac, (w, h), &mut plain);
            assert_ne!(plain, base, "steps {dc} / {ac}: the frame changed");
            for threads in [1, 3] {
                let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build();
                let mut f = base.clone();
                pool.expect("a thread pool")
                    .install(|| apply(&c, (w as u32, h as u32), &mut f));
                assert_eq!(f, plain, "steps {dc} / {ac}, {threads} threads");
            }
        }
    }

    #[test]
    fn level_is_the_clamped_cast() {
        for x in (-300..600).map(f64::from) {
            assert_eq!(level(x), u32::from(x.clamp(0.0, 255.0) as u8), "{x}");
        }
        assert_eq!((level(f64::INFINITY), level(f64::NEG_INFINITY)), (255, 0));
    }

    #[test]
    fn round_is_the_librarys() {
        let mut cases = vec![
            0.5,
            -0.5,
            1.5,
            -2.5,
            0.49999999999999994,
            -0.3,
            2.0f64.powi(52) - 0.5,
        ];
        cases.extend([f64::INFINITY, f64::NEG_INFINITY, 1e300, -1e300, 0.0, -0.0]);
        cases.extend((0..10_000).map(|i| (crate::seed::mix64(i) as i64) as f64 * 1e-15));
        for x in cases {
            assert_eq!(round(x).to_bits(), x.round().to_bits(), "{x}");
        }
        assert!(round(f64::NAN).is_nan());
    }

    #[test]
    fn a_round_trip_without_quantising_gives_the_frame_back() {
        // Steps of 1e-9: the DCT and its inverse alone, rounded to levels.
        let (w, h) = (19, 13);
        let base = frame(w, h);
        let c = Capture {
            prior_dc_step: 1e-9,
            prior_ac_step: 1e-9,
            ..Capture::default()
        };
        let mut f = base.clone();
        apply(&c, (w as u32, h as u32), &mut f);
        assert_eq!(f, base);
    }

    /// Test block `k` as levels − 128: uniform noise, the extremes −128 and
    /// 127 at random (the largest coefficients), a checkerboard of them, or
    /// a gentle slope with a little noise.
    fn test_block(k: u64) -> Block32 {
        let bits = |i: usize| crate::seed::mix64(k * 64 + i as u64);
        std::array::from_fn(|y| {
            std::array::from_fn(|x| {
                let i = y * N + x;
                let g = match k % 4 {
                    0 => (bits(i) % 256) as f32,
                    1 => [0.0, 255.0][(bits(i) % 2) as usize],
                    2 => [0.0, 255.0][(x + y + (k as usize / 4)) % 2],
                    _ => (60.0 + 0.4 * x as f32 + 0.3 * y as f32 + (bits(i) % 2) as f32).floor(),
                };
                g - 128.0
            })
        })
    }

    #[test]
    fn the_estimate_is_within_its_error_bound() {
        let mut worst = 0.0f64;
        for k in 0..4000 {
            let b = test_block(k);
            let exact = plain_dct(&b.map(|row| row.map(f64::from)));
            let estimated = estimate(&b, dct());
            for (row, est) in exact.iter().zip(&estimated) {
                for (x, e) in row.iter().zip(est) {
                    worst = worst.max((f64::from(*e) - x).abs());
                }
            }
        }
        assert!(worst < ESTIMATE_ERROR / 4.0, "{worst}");
    }

    #[test]
    fn the_estimate_names_every_row_the_quantiser_keeps_and_few_others() {
        let (ac, mut named, mut kept_rows) = (4.0, 0, 0);
        let steps = Steps::new(16.0, ac);
        for k in 0..4000 {
            let b = test_block(k);
            let exact = plain_dct(&b.map(|row| row.map(f64::from)));
            let rows = candidate_rows(estimate(&b, dct()), steps.zero_below);
            for (u, row) in exact.iter().enumerate() {
                let kept = row
                    .iter()
                    .enumerate()
                    .any(|(v, x)| u + v > 0 && (x / ac).round() != 0.0);
                assert!(!kept || rows & 1 << u != 0, "block {k}, row {u}");
                kept_rows += u32::from(kept);
            }
            named += rows.count_ones();
        }
        // Hardly a row more than the quantiser keeps, and not all of them.
        assert!(
            named <= kept_rows + kept_rows / 50 && kept_rows < 8 * 4000 * 7 / 8,
            "{named} rows named, {kept_rows} kept"
        );
    }

    #[test]
    fn steps_at_a_coefficients_rounding_edge_give_the_plain_bytes() {
        // For each row of the first block's DCT, AC steps of twice its
        // largest AC coefficient (the quotient ½, which rounds up: the only
        // one the row keeps) and a hair either side: the estimate must name
        // the row, or the coefficient is lost.
        let (w, h) = (16, 8);
        let base = frame(w, h);
        let b: Block = std::array::from_fn(|y| {
            std::array::from_fn(|x| f64::from(base[(y * w + x) * 4]) - 128.0)
        });
        let x = plain_dct(&b);
        for (u, row) in x.iter().enumerate() {
            let top = row
                .iter()
                .skip(usize::from(u == 0))
                .fold(0.0f64, |m, v| m.max(v.abs()));
            let edge = 2.0 * top;
            for ac in [edge.next_down(), edge, edge.next_up()] {
                let c = Capture {
                    prior_dc_step: 8.0,
                    prior_ac_step: ac,
                    ..Capture::default()
                };
                let mut fast = base.clone();
                apply(&c, (w as u32, h as u32), &mut fast);
                let mut plain = base.clone();
                plain_compression(8.0, ac, (w, h), &mut plain);
                assert_eq!(fast, plain, "row {u}, step {ac}");
            }
        }
    }

    #[test]
    fn the_dc_basis_is_one_value() {
        // A block left with its DC alone is one level, (s·DC)·s: every
        // entry of D's row 0 is the same s.
        let d = dct();
        assert!(d.d[0].iter().all(|s| s.to_bits() == d.d[0][0].to_bits()));
        let mut f = frame(16, 16);
        let c = Capture {
            prior_dc_step: 8.0,
            prior_ac_step: 255.0,
            ..Capture::default()
        };
        let mut plain = f.clone();
        apply(&c, (16, 16), &mut f);
        plain_compression(8.0, 255.0, (16, 16), &mut plain);
        assert_eq!(f, plain);
        assert!(f.chunks_exact(4 * 8).all(|run| run[..4] == run[28..]));
    }
}
