//! The thermal camera's chain on a composed radiance plane (docs/realism.md,
//! "Thermal camera"): the detail enhancement when the preset has one
//! (`thermal.detail`, [`super::detail`]), the optics' Gaussian blur of σ px,
//! then per pixel the fixed pattern and the temporal noise (NETD; the
//! deviates of [`crate::sensor::noise`] under the frame's key), then a
//! linear gain that maps the frame's low and high percentiles to levels 0
//! and 255, capped at `agc_max_gain` levels per kelvin, their middle at
//! `agc_mid_level`; out as
//! 8-bit grey RGBA or 16-bit grey (the same gain × 257). Over a backplate
//! the gain is the plate's own ([`Gain::Fixed`], `plate_gain`): its camera's
//! gain control set its levels, with the drone in view, when it was taken.
//!
//! Three passes over the frame, each in bands of rows on rayon's threads:
//! the blur (a band's rows and the kernel's halo through the row pass into
//! a small buffer, its taps summed over blocks of pixels held in
//! registers, then the column pass tap by tap along whole rows) fused with
//! the noise and the frame's extremes, written to a second plane that is
//! then swapped in; the gain control's percentiles (the values at their
//! ranks selected within brackets a sample of the frame sets, [`rank`]:
//! the histogram's bins without scattering a count per pixel; the
//! histogram itself where a bracket misses); the gain. A pixel's value is
//! the same sum in the same order as a plain loop gives, and extremes,
//! counts and selected values are exact, so the bytes do not depend on the
//! threads. Float to integer conversions go through the float unit's
//! rounding ([`floor`], [`level`]) so their loops vectorise. The planes
//! are kept in [`Scratch`] from frame to frame, each thread's halo buffer
//! in a thread local.

use rayon::prelude::*;

use crate::preset::thermal::Thermal;
use crate::sensor::noise::{Key, deviate};

use super::{Scratch, radiance_per_kelvin};

mod rank;

/// Where the developed frame goes (`w`×`h` pixels, row-major).
pub enum Developed<'a> {
    /// Levels 0–255 as RGBA8: R = G = B, A = 255.
    Rgba8(&'a mut [u8]),
    /// Levels 0–65535 (the 8-bit level × 257 before rounding).
    Grey16(&'a mut [u16]),
}

/// How the developed levels follow the radiance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Gain {
    /// The gain control: the frame's `agc_percentiles` to levels 0 and 255, at most
    /// `agc_max_gain` levels per kelvin, their middle at `agc_mid_level`.
    Automatic,
    /// level = radiance · `scale` + `offset`, whatever the frame holds.
    Fixed {
        /// Levels per radiance unit.
        scale: f32,
        /// The level of radiance 0.
        offset: f32,
    },
}

/// Rows per band handed to a thread (the blur's row pass also runs on the
/// kernel's halo of rows above and below each band: fewer, taller bands
/// repeat fewer rows).
const BAND_ROWS: usize = 32;

/// The chain on `plane` as RGBA8 grey (R = G = B, A = 255): blur, fixed
/// `pattern` and temporal noise (key from `noise_seed`), gain control.
pub fn develop(
    t: &Thermal,
    plane: &mut [f32],
    dims: (u32, u32),
    pattern: &[f32],
    noise_seed: u64,
) -> Vec<u8> {
    let mut out = vec![0u8; plane.len() * 4];
    let mut scratch = Scratch {
        plane: plane.to_vec(),
        ..Scratch::default()
    };
    let to = Developed::Rgba8(&mut out);
    develop_into(
        t,
        dims,
        (pattern, noise_seed),
        Gain::Automatic,
        &mut scratch,
        to,
    );
    plane.copy_from_slice(&scratch.plane);
    out
}

/// [`develop`] on `scratch.plane` into `out` (as long as the plane, × 4
/// for RGBA8) through `gain_by`, the row pass's plane kept in `scratch`.
pub fn develop_into(
    t: &Thermal,
    (w, h): (u32, u32),
    (pattern, noise_seed): (&[f32], u64),
    gain_by: Gain,
    scratch: &mut Scratch,
    out: Developed<'_>,
) {
    let per_kelvin = radiance_per_kelvin(t.air_k);
    let noise = Noise {
        key: Key::new(noise_seed),
        sigma: (t.netd_mk * 1e-3) as f32 * per_kelvin,
        pattern,
    };
    let dims = (w as usize, h as usize);
    let Scratch {
        plane,
        rows,
        detail,
        ..
    } = scratch;
    if let Some(d) = &t.detail {
        super::detail::enhance(d, plane, dims, detail);
    }
    let extremes = blur_and_noise(plane, dims, t.blur_px as f32, &noise, rows);
    let (scale, offset) = match gain_by {
        Gain::Fixed { scale, offset } => (scale, offset),
        Gain::Automatic => {
            let (lo, hi) = percentiles_within(plane, extremes, t.agc_percentiles);
            let cap = t.agc_max_gain as f32 / per_kelvin;
            let scale = (255.0 / (hi - lo).max(1e-6)).min(cap);
            (scale, t.agc_mid_level as f32 - (lo + hi) * 0.5 * scale)
        }
    };
    gain(plane, w as usize, (scale, offset), out);
}

/// The temporal noise's key and σ (radiance units) and the fixed pattern.
struct Noise<'a> {
    key: Key,
    sigma: f32,
    pattern: &'a [f32],
}

/// Pixels `first`, `first + 1`, … (`row`) with their fixed pattern and
/// noise added; their extremes folded into `(lo, hi)`.
#[inline(always)]
fn add_noise(noise: &Noise<'_>, row: &mut [f32], first: usize, lo_hi: (f32, f32)) -> (f32, f32) {
    let pattern = noise.pattern.get(first..).unwrap_or_default();
    let base = first as u32;
    for (x, (v, p)) in row.iter_mut().zip(pattern).enumerate() {
        *v += p + noise.sigma * deviate(noise.key.bits(base.wrapping_add(x as u32)));
    }
    extremes(row, lo_hi)
}

simd_fn! {
    /// [`add_noise`] on a band of pixels from `first`.
    fn noise_band(noise: &Noise<'_>, band: &mut [f32], first: usize) -> (f32, f32) {
        add_noise(noise, band, first, (f32::INFINITY, f32::NEG_INFINITY))
    }
}

simd_fn! {
    /// Band `b` of the blurred `src` (`w`×`h`) into `out`: the row pass on
    /// the band's rows and the kernel's halo above and below (into `halo`),
    /// then the column pass, each row then given its pattern and noise; the
    /// band's extremes.
    fn column_band(
        src: &[f32],
        wh: (usize, usize),
        b: usize,
        k: &[f32],
        noise: &Noise<'_>,
        halo: &mut Vec<f32>,
        out: &mut [f32],
    ) -> (f32, f32) {
        let (w, h) = wh;
        let (y0, r) = (b * BAND_ROWS, k.len() / 2);
        let first = y0.saturating_sub(r);
        let last = (y0 + out.len() / w + r).min(h);
        halo.resize((last - first) * w, 0.0);
        blur_rows(&src[first * w..last * w], halo, w, k);
        let mut lo_hi = (f32::INFINITY, f32::NEG_INFINITY);
        for (j, row) in out.chunks_exact_mut(w).enumerate() {
            let y = y0 + j;
            blur_column((halo, first), wh, y, k, row);
            lo_hi = add_noise(noise, row, y * w, lo_hi);
        }
        lo_hi
    }
}

/// `(lo, hi)` with the least and greatest of `row` (eight lanes, so it vectorises).
#[inline(always)]
fn extremes(row: &[f32], (mut lo, mut hi): (f32, f32)) -> (f32, f32) {
    let (mut l, mut h) = ([lo; 8], [hi; 8]);
    let chunks = row.chunks_exact(8);
    for &v in chunks.remainder() {
        (lo, hi) = (lo.min(v), hi.max(v));
    }
    for c in chunks {
        // Comparisons rather than f32::min/max (whose NaN rule does not
        // vectorise): the same extremes, a NaN pixel skipped alike.
        for k in 0..8 {
            l[k] = if c[k] < l[k] { c[k] } else { l[k] };
            h[k] = if c[k] > h[k] { c[k] } else { h[k] };
        }
    }
    (
        l.into_iter().fold(lo, f32::min),
        h.into_iter().fold(hi, f32::max),
    )
}

/// The normalised Gaussian of σ `sigma` truncated at ±⌈3σ⌉ (none for σ ≤ 0).
fn kernel(sigma: f32) -> Option<Vec<f32>> {
    if sigma <= 0.0 {
        return None;
    }
    let r = kernel_radius(sigma) as isize;
    let mut k: Vec<f32> = (-r..=r)
        .map(|d| (-(d * d) as f32 / (2.0 * sigma * sigma)).exp())
        .collect();
    let sum: f32 = k.iter().sum();
    k.iter_mut().for_each(|v| *v /= sum);
    Some(k)
}

/// The blur kernel's half width for σ `sigma` > 0: ⌈3σ⌉ px.
pub(super) fn kernel_radius(sigma: f32) -> usize {
    (3.0 * sigma).ceil() as usize
}

thread_local! {
    /// Each thread's row pass of a band and its halo, kept from frame to
    /// frame (a fresh one per band would be zeroed and faulted in anew).
    static HALO: std::cell::RefCell<Vec<f32>> = const { std::cell::RefCell::new(Vec::new()) };
}

/// The blur (when σ > 0), then the pattern and noise, into `plane` (the
/// blur writes `spare` and swaps it in); the frame's extremes.
fn blur_and_noise(
    plane: &mut Vec<f32>,
    (w, h): (usize, usize),
    sigma: f32,
    noise: &Noise<'_>,
    spare: &mut Vec<f32>,
) -> (f32, f32) {
    let start = (f32::INFINITY, f32::NEG_INFINITY);
    let fold = |a: (f32, f32), b: (f32, f32)| (a.0.min(b.0), a.1.max(b.1));
    let band = BAND_ROWS * w.max(1);
    let Some(k) = kernel(sigma).filter(|_| w > 0 && h > 0) else {
        return (plane.par_chunks_mut(band).enumerate())
            .map(|(b, rows)| noise_band(noise, rows, b * band))
            .reduce(|| start, fold);
    };
    spare.resize(plane.len(), 0.0);
    let src = &plane[..];
    let lo_hi = (spare.par_chunks_mut(band).enumerate())
        .map(|(b, out)| {
            HALO.with_borrow_mut(|halo| column_band(src, (w, h), b, &k, noise, halo, out))
        })
        .reduce(|| start, fold);
    std::mem::swap(plane, spare);
    lo_hi
}

simd_fn! {
    /// The row pass of the separable blur on whole rows (edges clamped).
    fn blur_rows(src: &[f32], dst: &mut [f32], w: usize, k: &[f32]) {
        let r = k.len() / 2;
        for (src, dst) in src.chunks_exact(w).zip(dst.chunks_exact_mut(w)) {
            // The inner pixels a block at a time, tap by tap.
            if w > 2 * r {
                let taps = k.iter().enumerate().map(|(j, kv)| (*kv, &src[j..j + w - 2 * r]));
                blur_taps(taps, &mut dst[r..w - r]);
            }
            let (left, right) = if w > 2 * r { (r, w - r) } else { (w, w) };
            for x in (0..left).chain(right..w) {
                let mut acc = 0.0;
                for (j, kv) in k.iter().enumerate() {
                    let sx = (x + j).saturating_sub(r).min(w - 1);
                    acc += kv * src[sx];
                }
                dst[x] = acc;
            }
        }
    }
}

/// Row `y` of the column pass over the row-blurred `rows`, which hold the
/// frame's rows from `first` on (edges clamped).
#[inline(always)]
fn blur_column(
    (rows, first): (&[f32], usize),
    (w, h): (usize, usize),
    y: usize,
    k: &[f32],
    dst: &mut [f32],
) {
    // Tap by tap along whole rows: measured faster here than the row
    // pass's blocks in registers (each tap of a block is another row).
    let r = k.len() / 2;
    let source = |j: usize| {
        let sy = (y + j).saturating_sub(r).min(h - 1) - first;
        &rows[sy * w..(sy + 1) * w]
    };
    // The first tap written, not added to a zeroed row: 0 + k·s is the sum
    // from zero (−0 included), without a pass clearing the row first.
    let Some((&k0, rest)) = k.split_first() else {
        dst.fill(0.0);
        return;
    };
    for (o, s) in dst.iter_mut().zip(source(0)) {
        *o = 0.0 + k0 * s;
    }
    for (j, kv) in (1..).zip(rest) {
        for (o, s) in dst.iter_mut().zip(source(j)) {
            *o += kv * s;
        }
    }
}

/// Pixels per block of [`blur_taps`] (a few vector registers).
const BLOCK: usize = 32;

/// `dst` = Σ weight · source over the `taps` (each source as long as
/// `dst`), summed from 0 in the taps' order, a block of pixels at a time
/// in registers (the same sums as tap by tap over the whole row).
#[inline(always)]
fn blur_taps<'a>(taps: impl Iterator<Item = (f32, &'a [f32])> + Clone, dst: &mut [f32]) {
    let first = dst.len() - dst.len() % BLOCK;
    let mut blocks = dst.chunks_exact_mut(BLOCK);
    for (b, out) in (&mut blocks).enumerate() {
        let mut acc = [0f32; BLOCK];
        for (kv, src) in taps.clone() {
            let src = &src[b * BLOCK..(b + 1) * BLOCK];
            for (a, s) in acc.iter_mut().zip(src) {
                *a += kv * s;
            }
        }
        out.copy_from_slice(&acc);
    }
    let rest = blocks.into_remainder();
    rest.fill(0.0);
    for (kv, src) in taps {
        for (o, s) in rest.iter_mut().zip(&src[first..]) {
            *o += kv * s;
        }
    }
}

/// The development's blur alone (σ `sigma` px, edges clamped) in place on `plane`
/// (`w`×`h`): bands of rows on rayon's threads, `spare` taking the output and swapped in.
/// The same sums as [`blur`].
pub(super) fn blur_banded(
    plane: &mut Vec<f32>,
    dims: (usize, usize),
    sigma: f32,
    spare: &mut Vec<f32>,
) {
    let silent = Noise {
        key: Key::new(0),
        sigma: 0.0,
        pattern: &[],
    };
    blur_and_noise(plane, dims, sigma, &silent, spare);
}

/// A separable Gaussian blur of σ `sigma` px, truncated at ±⌈3σ⌉ (edges clamped).
pub fn blur(plane: &mut [f32], (w, h): (usize, usize), sigma: f32) {
    let Some(k) = kernel(sigma).filter(|_| w > 0 && h > 0) else {
        return;
    };
    let mut rows = vec![0.0; plane.len()];
    blur_rows(plane, &mut rows, w, &k);
    for (y, row) in plane.chunks_exact_mut(w).enumerate() {
        blur_column((&rows, 0), (w, h), y, &k, row);
    }
}

/// Histogram bins of the gain control's percentiles.
const AGC_BINS: usize = 4096;

/// The `(low, high)` percentiles of `plane` to within 1/4096 of its range.
pub fn percentiles(plane: &[f32], p: (f64, f64)) -> (f32, f32) {
    let start = (f32::INFINITY, f32::NEG_INFINITY);
    percentiles_within(plane, extremes(plane, start), p)
}

/// [`percentiles`] of a plane whose extremes are `(min, max)`: each the
/// histogram's bin (of [`AGC_BINS`] over the range) where the count reaches
/// its rank, found as the bin of the value at that rank
/// ([`rank::values_at_ranks`]) or, where that declines, from the histogram.
fn percentiles_within(
    plane: &[f32],
    (min, max): (f32, f32),
    (p_lo, p_hi): (f64, f64),
) -> (f32, f32) {
    if plane.is_empty() || max <= min {
        return (min.min(0.0), min.max(0.0) + 1e-6);
    }
    let scale = (AGC_BINS - 1) as f32 / (max - min);
    let rank = |p: f64| (p / 100.0 * plane.len() as f64).ceil().max(1.0) as u64;
    let ranks = [rank(p_lo), rank(p_hi)];
    let selected = (min.is_finite() && max.is_finite())
        .then(|| rank::values_at_ranks(plane, ranks))
        .flatten();
    let [lo, hi] = match selected {
        Some(values) => values.map(|v| {
            let k = floor(clamp_nan_low((v - min) * scale, (AGC_BINS - 1) as f32));
            min + k as f32 / scale
        }),
        None => histogram_percentiles(plane, (min, max), scale, ranks),
    };
    (lo, hi)
}

/// [`percentiles_within`] from the histogram of every pixel.
fn histogram_percentiles(
    plane: &[f32],
    (min, max): (f32, f32),
    scale: f32,
    ranks: [u64; 2],
) -> [f32; 2] {
    let chunk = plane
        .len()
        .div_ceil(2 * rayon::current_num_threads())
        .max(1 << 16);
    let hist = (plane.par_chunks(chunk))
        .map(|chunk| histogram(chunk, min, scale))
        .reduce(
            || vec![0u32; AGC_BINS],
            |mut a, b| {
                a.iter_mut().zip(b).for_each(|(a, b)| *a += b);
                a
            },
        );
    ranks.map(|rank| {
        let mut seen = 0u64;
        for (k, &n) in hist.iter().enumerate() {
            seen += u64::from(n);
            if seen >= rank {
                return min + k as f32 / scale;
            }
        }
        max
    })
}

simd_fn! {
    /// The histogram of `chunk` over [`AGC_BINS`] bins from `min` (`scale`
    /// bins per unit): the bins of 256 values at a time (a loop that
    /// vectorises), then the counts in four interleaved copies, so that runs
    /// of one bin do not wait on each other's counts.
    fn histogram(chunk: &[f32], min: f32, scale: f32) -> Vec<u32> {
        let mut hist = vec![[0u32; AGC_BINS]; 4];
        let mut bins = [0u32; 256];
        for run in chunk.chunks(256) {
            let bins = &mut bins[..run.len()];
            for (b, &v) in bins.iter_mut().zip(run) {
                // In 0..AGC_BINS for v in [min, max]; as `as i32` then the
                // clamp would give (NaN: 0), without a scalar conversion.
                let x = clamp_nan_low((v - min) * scale, (AGC_BINS - 1) as f32);
                *b = floor(x) as u32;
            }
            let quads = bins.chunks_exact(4);
            for &b in quads.remainder() {
                hist[0][b as usize] += 1;
            }
            for q in quads {
                for (h, &b) in hist.iter_mut().zip(q) {
                    h[b as usize] += 1;
                }
            }
        }
        let (first, rest) = hist.split_at_mut(1);
        for copy in rest {
            first[0].iter_mut().zip(copy.iter()).for_each(|(a, b)| *a += b);
        }
        first[0].to_vec()
    }
}

/// `x` clamped to [0, `top`] (NaN: 0) and rounded half away from zero
/// (`x − round(x)` is exact for 0 ≤ x < 2²²).
#[inline(always)]
fn level(x: f32, top: f32) -> u32 {
    let x = clamp_nan_low(x, top);
    let r = round_even(x);
    (r + i32::from(x - r as f32 >= 0.5)) as u32
}

/// `x` clamped to [0, `top`], NaN to 0: as `x.clamp(0.0, top)` then
/// `as i32` treat it, in two comparisons that vectorise.
#[inline(always)]
pub(super) fn clamp_nan_low(x: f32, top: f32) -> f32 {
    let x = if x > 0.0 { x } else { 0.0 };
    if x < top { x } else { top }
}

/// `x` (0 ≤ x < 2²²) rounded to the nearest integer, ties to even, by
/// float operations alone: x + 2²³ has no fraction bits left, so its
/// mantissa is the integer. A loop of these vectorises, where `as i32`
/// (saturating, NaN to 0) is converted one value at a time.
#[inline(always)]
fn round_even(x: f32) -> i32 {
    const MAGIC: f32 = 8_388_608.0;
    (x + MAGIC).to_bits() as i32 - MAGIC.to_bits() as i32
}

/// ⌊x⌋ of 0 ≤ x < 2²² (what `x as i32` gives), vectorisable as [`round_even`].
#[inline(always)]
pub(super) fn floor(x: f32) -> i32 {
    let r = round_even(x);
    r - i32::from(r as f32 > x)
}

/// Each pixel's level `v·scale + offset` into `out`.
fn gain(plane: &[f32], w: usize, (scale, offset): (f32, f32), out: Developed<'_>) {
    let band = BAND_ROWS * w.max(1);
    match out {
        Developed::Rgba8(out) => (out.par_chunks_mut(band * 4).zip(plane.par_chunks(band)))
            .for_each(|(out, plane)| gain8(plane, scale, offset, out)),
        Developed::Grey16(out) => (out.par_chunks_mut(band).zip(plane.par_chunks(band)))
            .for_each(|(out, plane)| gain16(plane, scale, offset, out)),
    }
}

simd_fn! {
    /// [`gain`] to 8-bit RGBA.
    fn gain8(plane: &[f32], scale: f32, offset: f32, out: &mut [u8]) {
        for (px, v) in out.chunks_exact_mut(4).zip(plane) {
            let g = level(v * scale + offset, 255.0);
            px.copy_from_slice(&((g * 0x0001_0101) | 0xFF00_0000).to_le_bytes());
        }
    }
}

simd_fn! {
    /// [`gain`] to 16-bit grey.
    fn gain16(plane: &[f32], scale: f32, offset: f32, out: &mut [u16]) {
        for (o, v) in out.iter_mut().zip(plane) {
            *o = level((v * scale + offset) * 257.0, 65535.0) as u16;
        }
    }
}

/// 16-bit grey levels as RGBA8 grey (each ÷ 257, rounded; A = 255).
pub fn grey16_to_rgba(grey: &[u16], rgba: &mut [u8]) {
    for (px, &g) in rgba.chunks_exact_mut(4).zip(grey) {
        let g = (u32::from(g) + 128) / 257;
        px.copy_from_slice(&((g * 0x0001_0101) | 0xFF00_0000).to_le_bytes());
    }
}

#[cfg(test)]
mod tests {
    use super::super::radiance;
    use super::*;

    /// The camera without noise, pattern, shading or blur, its gain control spanning the
    /// frame's extremes.
    fn noiseless() -> Thermal {
        Thermal {
            netd_mk: 0.0,
            fixed_pattern_mk: 0.0,
            shading_k: 0.0,
            blur_px: 0.0,
            agc_percentiles: (0.0, 100.0),
            ..Thermal::default()
        }
    }

    #[test]
    fn gain_control_maps_the_percentiles_to_the_full_range() {
        let t = Thermal {
            agc_max_gain: 1e4,
            agc_mid_level: 127.5,
            ..noiseless()
        };
        let mut plane: Vec<f32> = (0..1000).map(|i| 5.0 + i as f32 * 0.001).collect();
        let pattern = vec![0.0; plane.len()];
        let out = develop(&t, &mut plane, (1000, 1), &pattern, 7);
        let grey: Vec<u8> = out.chunks_exact(4).map(|p| p[0]).collect();
        assert_eq!((grey[0], grey[999]), (0, 255));
        assert!(
            out.chunks_exact(4)
                .all(|p| p[0] == p[1] && p[1] == p[2] && p[3] == 255)
        );
        assert!(grey.windows(2).all(|g| g[0] <= g[1]));
    }

    /// At the gain control's largest gain the enhancement leaves the levels far from an
    /// edge as they were (its overshoots widen the span evenly about the middle); next
    /// to the edge each side moves by half the step times its gain.
    #[test]
    fn the_detail_enhancement_keeps_the_gain_controls_levels() {
        let t = Thermal {
            agc_max_gain: 8.0,
            agc_mid_level: 128.0,
            ..noiseless()
        };
        let (w, h, edge) = (64, 256, 160);
        let (sky, ground) = (radiance(t.air_k - 10.0), radiance(t.air_k));
        let plane: Vec<f32> = (0..w * h)
            .map(|i| if i / w < edge { sky } else { ground })
            .collect();
        let grey = |t: &Thermal| -> Vec<u8> {
            let out = develop(
                t,
                &mut plane.clone(),
                (w as u32, h as u32),
                &vec![0.0; w * h],
                7,
            );
            out.chunks_exact(4).map(|p| p[0]).collect()
        };
        let plain = grey(&t);
        let sharp = grey(&Thermal {
            detail: Some(crate::preset::thermal::Detail {
                gain: 1.0,
                size: 0.1,
            }),
            ..t.clone()
        });
        let at = |g: &[u8], y: usize| i32::from(g[y * w + w / 2]);
        let step = at(&plain, edge) - at(&plain, edge - 1);
        assert!(
            (75..=85).contains(&step),
            "{step} levels for 10 K at 8 levels/K"
        );
        for y in (0..edge - 40).chain(edge + 40..h) {
            assert!((at(&sharp, y) - at(&plain, y)).abs() <= 1, "row {y}");
        }
        let (above, below) = (
            at(&sharp, edge - 1) - at(&plain, edge - 1),
            at(&sharp, edge) - at(&plain, edge),
        );
        assert!(
            (above + step / 2).abs() <= 3 && (below - step / 2).abs() <= 3,
            "{above} {below}"
        );
    }

    #[test]
    fn gain_control_keeps_a_low_contrast_scene_low() {
        let t = noiseless();
        // A scene spanning one kelvin around the air's temperature.
        let (a, b) = (radiance(t.air_k - 0.5), radiance(t.air_k + 0.5));
        let mut plane: Vec<f32> = (0..100).map(|i| a + (b - a) * i as f32 / 99.0).collect();
        let out = develop(&t, &mut plane, (100, 1), &[0.0; 100], 7);
        let span = i32::from(out[99 * 4]) - i32::from(out[0]);
        assert!(
            (3..=5).contains(&span),
            "{span} levels for 1 K at 4 levels/K"
        );
        assert!(
            (108..=112).contains(&out[50 * 4]),
            "middle at {}",
            out[50 * 4]
        );
    }

    #[test]
    fn blur_keeps_the_mean_and_spreads_a_point() {
        let mut p = vec![0.0f32; 81];
        p[40] = 1.0;
        blur(&mut p, (9, 9), 1.0);
        assert!((p.iter().sum::<f32>() - 1.0).abs() < 1e-4);
        assert!(p[40] < 0.2 && p[41] > 0.05 && p[31] > 0.05);
    }

    /// The chain as plain loops, one pass per step (what the fused,
    /// banded passes must equal bit for bit).
    fn plain_develop(
        t: &Thermal,
        plane: &mut [f32],
        (w, h): (usize, usize),
        pattern: &[f32],
        seed: u64,
    ) -> Vec<u8> {
        let k = kernel(t.blur_px as f32).unwrap_or_else(|| vec![1.0]);
        let r = (k.len() / 2) as isize;
        let src = plane.to_vec();
        let tap = |x: isize, y: isize| {
            src[y.clamp(0, h as isize - 1) as usize * w + x.clamp(0, w as isize - 1) as usize]
        };
        let rows: Vec<f32> = (0..w * h)
            .map(|i| {
                (0..k.len()).fold(0.0, |acc, j| {
                    acc + k[j] * tap((i % w) as isize + j as isize - r, (i / w) as isize)
                })
            })
            .collect();
        for (i, v) in plane.iter_mut().enumerate() {
            let (x, y) = (i % w, (i / w) as isize);
            *v = (0..k.len()).fold(0.0, |acc, j| {
                acc + k[j] * rows[(y + j as isize - r).clamp(0, h as isize - 1) as usize * w + x]
            });
        }
        let per_k = radiance_per_kelvin(t.air_k);
        let (sigma, key) = ((t.netd_mk * 1e-3) as f32 * per_k, Key::new(seed));
        for (i, (v, p)) in plane.iter_mut().zip(pattern).enumerate() {
            *v += p + sigma * deviate(key.bits(i as u32));
        }
        let (lo, hi) = percentiles(plane, t.agc_percentiles);
        let scale = (255.0 / (hi - lo).max(1e-6)).min(t.agc_max_gain as f32 / per_k);
        let offset = t.agc_mid_level as f32 - (lo + hi) * 0.5 * scale;
        (plane.iter())
            .flat_map(|v| {
                let g = (v * scale + offset).clamp(0.0, 255.0).round() as u8;
                [g, g, g, 255]
            })
            .collect()
    }

    #[test]
    fn the_fused_passes_give_the_plain_loops_bytes() {
        let (w, h) = (67, 41);
        for blur_px in [0.0, 0.5, 1.3] {
            let t = Thermal {
                blur_px,
                ..Thermal::default()
            };
            let pattern = super::super::fixed_pattern(&t, 9, w as u32, h as u32);
            let plane: Vec<f32> = (0..w * h)
                .map(|i| {
                    radiance(280.0 + ((i * 7919) % 101) as f64 * 0.2)
                        + if i % 97 == 0 { 20.0 } else { 0.0 }
                })
                .collect();
            let (mut a, mut b) = (plane.clone(), plane.clone());
            let fused = develop(&t, &mut a, (w as u32, h as u32), &pattern, 77);
            assert_eq!(
                fused,
                plain_develop(&t, &mut b, (w, h), &pattern, 77),
                "blur {blur_px}"
            );
            // 16 bits: the same levels × 257, to within rounding.
            let mut scratch = Scratch {
                plane,
                ..Scratch::default()
            };
            let mut grey = vec![0u16; w * h];
            let to = Developed::Grey16(&mut grey);
            let gain = Gain::Automatic;
            develop_into(
                &t,
                (w as u32, h as u32),
                (&pattern, 77),
                gain,
                &mut scratch,
                to,
            );
            for (g, px) in grey.iter().zip(fused.chunks_exact(4)) {
                assert!(
                    (f32::from(*g) / 257.0 - f32::from(px[0])).abs() <= 0.5,
                    "{g} vs {}",
                    px[0]
                );
            }
        }
    }

    #[test]
    fn levels_round_half_away_from_zero_as_round_does() {
        for x in [
            -3.0f32, 0.0, 0.25, 0.49999997, 0.5, 1.5, 2.5, 254.49998, 254.5, 300.0,
        ] {
            assert_eq!(level(x, 255.0), x.clamp(0.0, 255.0).round() as u32, "{x}");
        }
        assert_eq!(level(f32::NAN, 255.0), 0);
        assert_eq!(level(65534.5, 65535.0), 65535);
        for x in [
            0.0f32, 0.49999997, 0.5, 1.0, 1.5, 2.5, 4094.9998, 4095.0, 70000.25,
        ] {
            let c = clamp_nan_low(x, 4095.0);
            assert_eq!(floor(c), (x as i32).clamp(0, 4095), "{x}");
        }
        assert_eq!(floor(clamp_nan_low(f32::NAN, 4095.0)), 0);
        assert_eq!(floor(clamp_nan_low(-3.5, 4095.0)), 0);
    }
}
