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

/// The orthonormal 8-point DCT-II matrix, `D[u][x]`.
fn dct_matrix() -> &'static [[f64; N]; N] {
    static D: OnceLock<[[f64; N]; N]> = OnceLock::new();
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
        d
    })
}

/// Each 8×8 block of the frame quantised in the DCT (DC step `dc`, the
/// others `ac`; 0: kept) and back, in bands of 8 rows on rayon's threads.
fn prior_compression(dc: f64, ac: f64, w: usize, rgba: &mut [u8]) {
    let d = dct_matrix();
    rgba.par_chunks_mut(N * w * 4).for_each(|band| {
        let rows = band.len() / (w * 4);
        for x0 in (0..w).step_by(N) {
            let mut block = [[0.0f64; N]; N];
            for (y, row) in block.iter_mut().enumerate() {
                let yy = y.min(rows - 1);
                for (x, v) in row.iter_mut().enumerate() {
                    let xx = (x0 + x).min(w - 1);
                    *v = f64::from(band[(yy * w + xx) * 4]) - 128.0;
                }
            }
            let coeffs = quantise(transform(d, &block, false), dc, ac);
            let back = transform(d, &coeffs, true);
            for (y, row) in back.iter().enumerate().take(rows) {
                for (x, v) in row.iter().enumerate().take(w - x0) {
                    let g = (v + 128.0).round().clamp(0.0, 255.0) as u8;
                    let i = (y * w + x0 + x) * 4;
                    band[i..i + 3].fill(g);
                }
            }
        }
    });
}

/// `D·B·Dᵀ` (forward) or `Dᵀ·B·D` (`inverse`).
fn transform(d: &[[f64; N]; N], b: &[[f64; N]; N], inverse: bool) -> [[f64; N]; N] {
    let m = |i: usize, k: usize| if inverse { d[k][i] } else { d[i][k] };
    let mut t = [[0.0; N]; N];
    for (i, row) in t.iter_mut().enumerate() {
        for (j, v) in row.iter_mut().enumerate() {
            let mut s = 0.0;
            for (k, bk) in b.iter().enumerate() {
                s += m(i, k) * bk[j];
            }
            *v = s;
        }
    }
    let mut out = [[0.0; N]; N];
    for (i, row) in out.iter_mut().enumerate() {
        for (j, v) in row.iter_mut().enumerate() {
            let mut s = 0.0;
            for (k, tk) in t[i].iter().enumerate() {
                s += tk * m(j, k);
            }
            *v = s;
        }
    }
    out
}

/// Coefficients rounded to multiples of their step (DC `dc`, the rest `ac`; 0: kept).
fn quantise(mut c: [[f64; N]; N], dc: f64, ac: f64) -> [[f64; N]; N] {
    for (u, row) in c.iter_mut().enumerate() {
        for (v, x) in row.iter_mut().enumerate() {
            let step = if u == 0 && v == 0 { dc } else { ac };
            if step > 0.0 {
                *x = (*x / step).round() * step;
            }
        }
    }
    c
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
