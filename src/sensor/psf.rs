//! The optics' PSF: a Gaussian of σ px truncated at ±⌈3σ⌉ px (weights
//! renormalised; separable: each row convolved horizontally into a ring of
//! the last 2r + 1 rows, then summed vertically out of it), or a defocus
//! disc of radius r px (the pixels whose centres lie within r, equal
//! weights; summed from each row's prefix sums, in f64). The sums run in
//! register blocks in a fixed order, so every SIMD build gives the same
//! bytes.

use super::{CameraDraw, PsfDraw};

/// The PSF as the sweep applies it.
pub(super) enum Kernel {
    None,
    /// Normalised weights for offsets −r … r.
    Gaussian(Vec<f32>),
    /// Half-widths of the disc's rows (−1: empty row) and 1 / pixel count.
    Disc {
        spans: Vec<i64>,
        norm: f64,
    },
}

impl Kernel {
    /// The draw's PSF (`None` when it reaches no neighbour).
    pub(super) fn of(draw: &CameraDraw) -> Self {
        match draw.psf {
            PsfDraw::Gaussian { sigma_px } if draw.psf.support_px() > 0 && sigma_px > 0.0 => {
                Self::Gaussian(gaussian_weights(sigma_px))
            }
            PsfDraw::Disc { radius_px } if draw.psf.support_px() > 0 => {
                let (spans, norm) = disc_spans(radius_px);
                Self::Disc { spans, norm }
            }
            _ => Self::None,
        }
    }

    pub(super) fn radius(&self) -> i64 {
        match self {
            Self::None => 0,
            Self::Gaussian(w) => (w.len() / 2) as i64,
            Self::Disc { spans, .. } => (spans.len() / 2) as i64,
        }
    }
}

/// The ring of the last 2r + 1 horizontally filtered rows per channel
/// (Gaussian: the convolved row; disc: the row's prefix sums in f64).
pub(super) struct Ring {
    len: usize,
    ring: [Vec<f32>; 3],
    prefix: [Vec<f64>; 3],
    sums: Vec<f64>,
    /// Where each of the vertical taps' rows starts in the ring (working memory).
    starts: Vec<usize>,
}

impl Ring {
    pub(super) fn new(kernel: &Kernel, ow: usize, pw: usize) -> Self {
        let n = 2 * kernel.radius() as usize + 1;
        let (len, ring, prefix) = match kernel {
            Kernel::None => (0, 0, 0),
            Kernel::Gaussian(_) => (ow, n * ow, 0),
            Kernel::Disc { .. } => (pw + 1, 0, n * (pw + 1)),
        };
        Self {
            len,
            ring: std::array::from_fn(|_| vec![0.0; ring]),
            prefix: std::array::from_fn(|_| vec![0.0; prefix]),
            sums: vec![0.0; if prefix > 0 { ow } else { 0 }],
            starts: Vec::new(),
        }
    }

    fn slot(&self, kernel: &Kernel, y: i64) -> std::ops::Range<usize> {
        let n = 2 * kernel.radius() + 1;
        let s = y.rem_euclid(n) as usize * self.len;
        s..s + self.len
    }

    /// Filter channel `c`'s padded row of image row `y` into the ring;
    /// `offset` = the window's first column − the padding's.
    #[inline(always)]
    pub(super) fn push(&mut self, kernel: &Kernel, c: usize, y: i64, padded: &[f32], offset: i64) {
        let slot = self.slot(kernel, y);
        match kernel {
            Kernel::None => {}
            Kernel::Gaussian(weights) => {
                debug_assert_eq!(offset as usize, weights.len() / 2);
                convolve_row(weights, padded, &mut self.ring[c][slot]);
            }
            Kernel::Disc { .. } => {
                let pre = &mut self.prefix[c][slot];
                let mut acc = 0.0;
                pre[0] = 0.0;
                for (p, &v) in pre[1..].iter_mut().zip(padded) {
                    acc += f64::from(v);
                    *p = acc;
                }
            }
        }
    }

    /// Channel `c`'s output row `y` from the ring.
    #[inline(always)]
    pub(super) fn vertical(
        &mut self,
        kernel: &Kernel,
        c: usize,
        y: i64,
        last: i64,
        start: i64,
        out: &mut [f32],
    ) {
        let r = kernel.radius();
        match kernel {
            Kernel::None => {}
            Kernel::Gaussian(weights) => {
                let mut starts = std::mem::take(&mut self.starts);
                starts.clear();
                starts.extend(
                    (0..weights.len() as i64)
                        .map(|k| self.slot(kernel, (y + k - r).clamp(0, last)).start),
                );
                sum_rows(weights, &self.ring[c], &starts, out);
                self.starts = starts;
            }
            Kernel::Disc { spans, norm } => {
                // `start`: the window's first column (prefix sums start at −r).
                let start = start as usize;
                self.sums.fill(0.0);
                for (k, &hw) in spans.iter().enumerate() {
                    if hw < 0 {
                        continue;
                    }
                    let range = self.slot(kernel, (y + k as i64 - r).clamp(0, last));
                    let pre = &self.prefix[c][range];
                    let (lo, hi) = (start + (r - hw) as usize, start + (r + hw + 1) as usize);
                    for (i, s) in self.sums.iter_mut().enumerate() {
                        *s += pre[i + hi] - pre[i + lo];
                    }
                }
                for (o, s) in out.iter_mut().zip(&self.sums) {
                    *o = (s * norm) as f32;
                }
            }
        }
    }
}

/// Normalised Gaussian weights for offsets −⌈3σ⌉ … ⌈3σ⌉.
pub(super) fn gaussian_weights(sigma_px: f64) -> Vec<f32> {
    let r = (3.0 * sigma_px).ceil() as i64;
    let raw: Vec<f64> = (-r..=r)
        .map(|k| (-(k * k) as f64 / (2.0 * sigma_px * sigma_px)).exp())
        .collect();
    let sum: f64 = raw.iter().sum();
    raw.iter().map(|w| (w / sum) as f32).collect()
}

/// The half-widths of a disc's rows −⌊r⌋ … ⌊r⌋ (−1: an empty row) and
/// 1 / its pixel count.
pub(super) fn disc_spans(radius_px: f64) -> (Vec<i64>, f64) {
    let r = radius_px.floor() as i64;
    let spans: Vec<i64> = (-r..=r)
        .map(|dy| {
            let rest = radius_px * radius_px - (dy * dy) as f64;
            if rest >= 0.0 {
                rest.sqrt().floor() as i64
            } else {
                -1
            }
        })
        .collect();
    let count: i64 = spans.iter().map(|h| 2 * h + 1).sum();
    (spans, 1.0 / count as f64)
}

/// Outputs per block of the convolutions: sums held in registers, four
/// AVX-512 registers' worth, so that four independent chains of additions
/// hide the adder's latency.
const LANES: usize = 64;

/// `out[i]` = Σₖ `weights[k]`·`padded[i + k]`, summed from 0 in the order
/// k = 0, 1, … (the test reference's order, so its f32 results), a block of
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
