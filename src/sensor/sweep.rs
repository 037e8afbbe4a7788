//! The camera chain's one implementation: a sweep over rows that runs
//! every stage the draw has, in the order the module docs give, for a
//! window of the frame.
//!
//! A band of output rows is made by one thread, top to bottom. Per row and
//! channel it decodes ([`super::exposure`]), applies the chromatic
//! aberration ([`super::aberration`]), filters horizontally into a ring of
//! the last 2r + 1 rows and vertically out of it ([`super::psf`]), runs the
//! registered per-pixel stages ([`super::pixel_stages`]: vignetting,
//! saturation, …), and then, on a sensor with the output's pixels, clips or
//! adds the noise ([`super::noise`]) and encodes ([`super::encode`]); on a
//! coarser sensor ([`super::grid`]) it averages those rows into sensor rows
//! (two held), clips or adds the noise there and interpolates each output
//! row from its two sensor rows before encoding. No full-frame intermediate:
//! the working set is a few rows in cache. Stages at identity are skipped,
//! and a neutral draw copies its input.
//!
//! Every read is clamped to the image (not to the band or window), so any
//! band, any window and any thread count give exactly the bytes of the
//! whole frame. The band is compiled for AVX-512 and AVX2 as well as for
//! the baseline ([`crate::simd`]); the unit tests compare the builds, and
//! the test reference ([`super::reference`], planes of f32, stage after
//! stage) with the sweep, byte for byte.

use rayon::prelude::*;

use super::aberration::{self, Source};
use super::encode::encode_line;
use super::exposure::Exposure;
use super::grid::{self, Down, Grid};
use super::noise::Sensor;
use super::psf::{Kernel, Ring};
use super::{CameraDraw, PixelRect, PixelStage, RowFn, Span};

/// Everything of a draw the sweep needs, computed once per call.
struct Chain<'a> {
    exposure: Exposure<'a>,
    /// The radial scale of each channel's chromatic aberration (`None`: 1).
    ca: [Option<f64>; 3],
    kernel: Kernel,
    /// The registered per-pixel stages the draw has, in order.
    pixel: Vec<Box<dyn PixelStage>>,
    /// The sensor grid when coarser than the output.
    grid: Option<Grid>,
    sensor: Sensor,
}

/// Output rows per band (at least; more when the PSF is wide): tall bands
/// decode and filter fewer of the 2r rows that neighbouring bands share
/// (256 against 64: 0.4 ms less for the typical 1080p draw on 2 threads).
const BAND_ROWS: i64 = 256;

/// The fewest rows a band gets so that a short window still spreads over
/// the threads.
const MIN_BAND_ROWS: i64 = 48;

/// Rows per band for `rows` output rows: about [`BAND_ROWS`] (at least 8
/// PSF radii), but at least as many bands as rayon's threads while each
/// keeps [`MIN_BAND_ROWS`]; the number of bands a multiple of the threads
/// so that they finish together (one band for a short window). Any split
/// gives the same bytes.
fn band_rows(rows: i64, radius: i64) -> i64 {
    let threads = rayon::current_num_threads().max(1) as i64;
    let target = BAND_ROWS.max(8 * radius);
    let fewest = (rows / MIN_BAND_ROWS.max(8 * radius)).min(threads);
    let bands = ((rows + target / 2) / target).max(fewest);
    let bands = if bands > 1 {
        (bands + threads - 1) / threads * threads
    } else {
        1
    };
    ((rows + bands - 1) / bands).max(1)
}

/// The RGBA8 bytes of window `out` (inside the image, non-empty) of the
/// `width`×`height` frame `rgba` through `draw`, with or without noise.
#[cfg(test)]
pub(super) fn develop(
    rgba: &[u8],
    width: u32,
    height: u32,
    draw: &CameraDraw,
    out: PixelRect,
    noisy: bool,
) -> Vec<u8> {
    let mut bytes = Vec::new();
    develop_into((rgba, width, height), draw, out, noisy, &mut bytes);
    bytes
}

/// [`develop`] into `bytes`, resized to the window: every byte is written,
/// so a recycled buffer's old contents never show.
pub(super) fn develop_into(
    (rgba, width, height): (&[u8], u32, u32),
    draw: &CameraDraw,
    out: PixelRect,
    noisy: bool,
    bytes: &mut Vec<u8>,
) {
    let chain = Chain::new(rgba, width, height, draw, noisy);
    let cols = Span {
        start: i64::from(out.x0),
        end: i64::from(out.x1),
    };
    let (y0, y1) = (i64::from(out.y0), i64::from(out.y1));
    let ow = cols.len();
    let len = ow * (y1 - y0) as usize * 4;
    bytes.resize(len, 0);
    if chain.is_identity() {
        for (r, line) in bytes.chunks_exact_mut(ow * 4).enumerate() {
            let start = ((y0 as usize + r) * width as usize + cols.start as usize) * 4;
            line.copy_from_slice(&rgba[start..start + ow * 4]);
        }
        return;
    }
    let band = band_rows(y1 - y0, chain.kernel.radius());
    bytes
        .par_chunks_mut(band as usize * ow * 4)
        .enumerate()
        .for_each(|(b, out)| {
            let start = y0 + b as i64 * band;
            let rows = Span {
                start,
                end: (start + band).min(y1),
            };
            crate::simd::widest(
                #[inline(always)]
                || chain.band(cols, rows, out),
            );
        });
}

impl<'a> Chain<'a> {
    fn new(rgba: &'a [u8], width: u32, height: u32, draw: &CameraDraw, noisy: bool) -> Self {
        Self {
            exposure: Exposure::new(rgba, width, height, draw),
            ca: aberration::scales(draw),
            kernel: Kernel::of(draw),
            pixel: super::pixel_stages(draw, width, height),
            grid: Grid::of(draw, width, height),
            sensor: Sensor::of(draw, noisy),
        }
    }

    /// True when the chain returns its input: unit gains, nothing else on
    /// (the encode table inverts the decode table on all 256 levels).
    fn is_identity(&self) -> bool {
        self.exposure.is_identity()
            && self.ca == [None; 3]
            && matches!(self.kernel, Kernel::None)
            && self.pixel.is_empty()
            && self.grid.is_none()
            && !self.sensor.is_noisy()
    }

    /// Output rows `rows`, columns `cols` into `out` (RGBA8).
    #[inline(always)]
    fn band(&self, cols: Span, rows: Span, out: &mut [u8]) {
        match &self.grid {
            None => self.band_direct(cols, rows, out),
            Some(grid) => self.band_gridded(grid, cols, rows, out),
        }
    }

    /// [`Self::band`] on a sensor with the output's pixels.
    #[inline(always)]
    fn band_direct(&self, cols: Span, rows: Span, out: &mut [u8]) {
        let mut linear = Linear::new(self, cols, rows.start);
        let ow = cols.len();
        let mut scratch = noise_scratch(&self.sensor, ow);
        let width = self.exposure.width;
        for (i, line) in out.chunks_exact_mut(ow * 4).enumerate() {
            let y = rows.start + i as i64;
            debug_assert!(y < rows.end);
            linear.row(y);
            let [r, g, b] = &mut linear.vals;
            let first = (y * width + cols.start) as u64;
            self.sensor.row(first, [r, g, b], &mut scratch);
            self.encode(y, cols, &linear.vals, line);
        }
    }

    /// [`Self::band`] on a sensor coarser than the output.
    #[inline(always)]
    fn band_gridded(&self, grid: &Grid, cols: Span, rows: Span, out: &mut [u8]) {
        let (scols, srows) = (grid.sensor_cols(cols), grid.sensor_rows(rows));
        let lcols = grid.footprint_cols(scols);
        let mut linear = Linear::new(self, lcols, grid.footprint_rows(srows).start);
        let mut down = Down::new(grid, scols, lcols.start);
        let up = grid::up_cols(grid, cols, scols.start);
        let mut scratch = noise_scratch(&self.sensor, scols.len());
        // The two sensor rows held: their indices (−1 none) and values.
        let mut held: [(i64, [Vec<f32>; 3]); 2] =
            std::array::from_fn(|_| (-1, std::array::from_fn(|_| vec![0.0; scols.len()])));
        let ow = cols.len();
        let mut vals: [Vec<f32>; 3] = std::array::from_fn(|_| vec![0.0; ow]);
        for (i, line) in out.chunks_exact_mut(ow * 4).enumerate() {
            let y = rows.start + i as i64;
            let (k0, k1, fy) = grid.up_rows(y);
            for k in [k0, k1] {
                if held.iter().any(|h| h.0 == k) {
                    continue;
                }
                // Rows come in order: the slot not holding k0 is free (when
                // neither does, the one holding the earlier row).
                let s = if held[0].0 == k0 {
                    1
                } else if held[1].0 == k0 {
                    0
                } else {
                    usize::from(held[0].0 > held[1].0)
                };
                down.clear();
                let span = grid::footprint(k, grid.h, grid.sh);
                for ly in span.start..span.end {
                    linear.row(ly);
                    down.add(&linear.vals);
                }
                down.finish(span.len() as i64);
                let [r, g, b] = &mut down.sums;
                let first = (k * grid.sw + scols.start) as u64;
                self.sensor.row(first, [r, g, b], &mut scratch);
                held[s].0 = k;
                for (h, v) in held[s].1.iter_mut().zip(&down.sums) {
                    h.copy_from_slice(v);
                }
            }
            let at = |k: i64| usize::from(held[1].0 == k);
            let (a, b) = (&held[at(k0)].1, &held[at(k1)].1);
            for c in 0..3 {
                grid::up_row(&a[c], &b[c], fy, &up, &mut vals[c]);
            }
            self.encode(y, cols, &vals, line);
        }
    }

    /// Output row `y`'s columns `cols` encoded into `line`, alpha from the input.
    #[inline(always)]
    fn encode(&self, y: i64, cols: Span, vals: &[Vec<f32>; 3], line: &mut [u8]) {
        let first = (y * self.exposure.width + cols.start) as usize * 4;
        let [r, g, b] = vals;
        encode_line(
            [r, g, b],
            &self.exposure.rgba[first..first + line.len()],
            line,
        );
    }
}

/// Working rows for the sensor's noise deviates (empty without noise).
fn noise_scratch(sensor: &Sensor, width: usize) -> [Vec<f32>; 3] {
    let n = if sensor.is_noisy() { width } else { 0 };
    std::array::from_fn(|_| vec![0.0; n])
}

/// The chain's rows on the output grid up to the sensor: exposure,
/// chromatic aberration, PSF and the per-pixel stages, over columns `cols`,
/// asked for row by row (in increasing order where a PSF reads neighbours).
struct Linear<'c, 'a> {
    chain: &'c Chain<'a>,
    cols: Span,
    /// The first padded column the PSF reads.
    pad0: i64,
    source: Source<'c, 'a>,
    ring: Ring,
    /// The next source row the ring takes.
    next: i64,
    stages: Vec<RowFn<'c>>,
    vals: [Vec<f32>; 3],
}

impl<'c, 'a> Linear<'c, 'a> {
    fn new(chain: &'c Chain<'a>, cols: Span, first_row: i64) -> Self {
        let r = chain.kernel.radius();
        let ow = cols.len();
        // The columns the PSF reads: a disc's prefix sums start at −r, so a
        // window sums exactly as the whole frame does.
        let pad0 = match chain.kernel {
            Kernel::Disc { .. } => -r,
            _ => cols.start - r,
        };
        let pw = (cols.end + r - pad0) as usize;
        Self {
            chain,
            cols,
            pad0,
            source: Source::new(&chain.exposure, chain.ca, pad0, pw),
            ring: Ring::new(&chain.kernel, ow, pw),
            next: (first_row - r).max(0),
            stages: chain.pixel.iter().map(|s| s.band(cols.start, ow)).collect(),
            vals: std::array::from_fn(|_| vec![0.0; ow]),
        }
    }

    /// Row `y` into `self.vals`.
    #[inline(always)]
    fn row(&mut self, y: i64) {
        let chain = self.chain;
        let kernel = &chain.kernel;
        let (r, last) = (kernel.radius(), chain.exposure.height - 1);
        let offset = self.cols.start - self.pad0;
        match kernel {
            Kernel::None => {
                let ow = self.cols.len();
                for c in 0..3 {
                    let row = self.source.row(c, y);
                    self.vals[c].copy_from_slice(&row[..ow]);
                }
            }
            kernel => {
                while self.next <= (y + r).min(last) {
                    for c in 0..3 {
                        let row = self.source.row(c, self.next);
                        self.ring.push(kernel, c, self.next, row, offset);
                    }
                    self.next += 1;
                }
                for c in 0..3 {
                    let out = &mut self.vals[c];
                    self.ring.vertical(kernel, c, y, last, offset - r, out);
                }
            }
        }
        for stage in &mut self.stages {
            let [a, b, c] = &mut self.vals;
            stage(y, [a, b, c]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::reference::tests::draws;
    use super::{Chain, Span};
    #[cfg(target_arch = "x86_64")]
    use crate::simd;

    /// Every SIMD build of the band this CPU can run gives the baseline
    /// build's bytes, so a frame is the same on machines with and without
    /// AVX2 or AVX-512 (the same preset, byte-identical everywhere). The
    /// registered per-pixel stages run their own widest build inside each.
    #[test]
    fn every_simd_build_of_the_band_gives_the_same_bytes() {
        let (w, h) = (97u32, 71u32);
        let rgba: Vec<u8> = (0..w * h * 4)
            .map(|i| ((i * 37 + i / 11 + (i / 401) * 3) % 256) as u8)
            .collect();
        let mut builds = 0;
        for (n, d) in draws().iter().enumerate() {
            for noisy in [false, true] {
                let chain = Chain::new(&rgba, w, h, d, noisy);
                let cols = Span {
                    start: 3,
                    end: i64::from(w) - 2,
                };
                let rows = Span {
                    start: 5,
                    end: i64::from(h) - 1,
                };
                let len = cols.len() * rows.len() * 4;
                let mut base = vec![0u8; len];
                chain.band(cols, rows, &mut base);
                #[cfg(target_arch = "x86_64")]
                for level in 1..=simd::cpu_simd_level() {
                    let mut out = vec![0u8; len];
                    simd::in_build(
                        level,
                        #[inline(always)]
                        || chain.band(cols, rows, &mut out),
                    );
                    assert!(out == base, "SIMD level {level}, draw {n}, noisy {noisy}");
                    builds += 1;
                }
            }
        }
        eprintln!("{builds} wider builds compared with the baseline");
    }
}
