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

use std::sync::OnceLock;

use rayon::prelude::*;

use crate::preset::thermal::Capture;

/// A block's side, pixels.
const N: usize = 8;

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

/// The orthonormal 8-point DCT-II matrix `D[u][x]` and its transpose.
struct Dct {
    d: Block,
    dt: Block,
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
        Dct { d, dt }
    })
}

/// Each 8×8 block of the frame quantised in the DCT (DC step `dc`, the
/// others `ac`; 0: kept) and back, in bands of 8 rows on rayon's threads.
fn prior_compression(dc: f64, ac: f64, w: usize, rgba: &mut [u8]) {
    let d = dct();
    rgba.par_chunks_mut(N * w * 4)
        .for_each(|band| compress_band(band, w, dc, ac, d));
}

simd_fn! {
    /// One band of 8 rows (fewer at the bottom edge) of [`prior_compression`].
    fn compress_band(band: &mut [u8], w: usize, dc: f64, ac: f64, d: &Dct) {
        let rows = band.len() / (w * 4);
        for x0 in (0..w).step_by(N) {
            let mut block = [[0.0; N]; N];
            for (y, row) in block.iter_mut().enumerate() {
                let words = load_row(&band[y.min(rows - 1) * w * 4..], x0, w);
                for (v, p) in row.iter_mut().zip(words) {
                    *v = f64::from((p & 0xFF) as i32) - 128.0;
                }
            }
            let mut coeffs = transform((&d.d, &d.dt), &block);
            quantise(&mut coeffs, dc, ac);
            let back = transform((&d.dt, &d.d), &coeffs);
            for (y, row) in back.iter().enumerate().take(rows) {
                let line = &mut band[(y * w + x0) * 4..];
                let mut words = load_row(line, 0, w - x0);
                for (p, v) in words.iter_mut().zip(row) {
                    let g = level(round(v + 128.0));
                    *p = (*p & 0xFF00_0000) | (g * 0x0001_0101);
                }
                store_row(line, &words, w - x0);
            }
        }
    }
}

/// The first eight RGBA pixels of `line` from column `x0` as words, the
/// last of a `w`-pixel row repeated past its end.
#[inline(always)]
fn load_row(line: &[u8], x0: usize, w: usize) -> [u32; N] {
    let mut words = [0u32; N];
    let whole = line.get(x0 * 4..(x0 + N) * 4).filter(|_| x0 + N <= w);
    if let Some(bytes) = whole {
        for (p, b) in words.iter_mut().zip(bytes.as_chunks::<4>().0) {
            *p = u32::from_le_bytes(*b);
        }
        return words;
    }
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

/// `M·B·Mᵀ` for `(m, mt)` = (M, Mᵀ): the forward DCT with (D, Dᵀ), the
/// inverse with (Dᵀ, D). Each value the sum over k in ascending order from
/// 0, one product at a time (no fused multiply-add): the plain triple
/// loop's value, a row of eight at once.
#[inline(always)]
fn transform((m, mt): (&Block, &Block), b: &Block) -> Block {
    let mut t = [[0.0; N]; N];
    product(m, b, &mut t);
    let mut out = [[0.0; N]; N];
    product(&t, mt, &mut out);
    out
}

/// `out` += `a`·`b`, each value's products added in k's order; four rows
/// at a time, so that four rows' sums are in flight at once (no add waits
/// on the one before it for long) and stay in registers.
#[inline(always)]
fn product(a: &Block, b: &Block, out: &mut Block) {
    for (rows, ar) in out.chunks_exact_mut(4).zip(a.chunks_exact(4)) {
        for (k, bk) in b.iter().enumerate() {
            for (row, ai) in rows.iter_mut().zip(ar) {
                let s = ai[k];
                for (v, x) in row.iter_mut().zip(bk) {
                    *v += s * x;
                }
            }
        }
    }
}

/// Coefficients rounded to multiples of their step (DC `dc`, the rest `ac`; 0: kept).
#[inline(always)]
fn quantise(c: &mut Block, dc: f64, ac: f64) {
    let first = c[0][0];
    if ac > 0.0 {
        for row in c.iter_mut() {
            for x in row.iter_mut() {
                *x = round(*x / ac) * ac;
            }
        }
    }
    c[0][0] = if dc > 0.0 {
        round(first / dc) * dc
    } else {
        first
    };
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
    fn plain_compression(dc: f64, ac: f64, (w, h): (usize, usize), rgba: &mut [u8]) {
        let d = dct().d;
        let mul = |a: &Block, b: &Block, ta: bool, tb: bool| -> Block {
            let at = |i: usize, k: usize| if ta { a[k][i] } else { a[i][k] };
            let bt = |k: usize, j: usize| if tb { b[j][k] } else { b[k][j] };
            std::array::from_fn(|i| {
                std::array::from_fn(|j| (0..N).fold(0.0, |s, k| s + at(i, k) * bt(k, j)))
            })
        };
        for y0 in (0..h).step_by(N) {
            for x0 in (0..w).step_by(N) {
                let px = |x: usize, y: usize| ((y0 + y).min(h - 1) * w + (x0 + x).min(w - 1)) * 4;
                let b: Block = std::array::from_fn(|y| {
                    std::array::from_fn(|x| f64::from(rgba[px(x, y)]) - 128.0)
                });
                let mut c = mul(&mul(&d, &b, false, false), &d, false, true);
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
}
