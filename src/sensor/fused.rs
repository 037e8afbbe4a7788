//! The camera model's fast path: the whole chain in one sweep over rows,
//! for a sensor with the output's own pixels (no `sensor_scale` < 1, which
//! takes the plane path of [`super::stages`]).
//!
//! A band of output rows is made by one thread, top to bottom. Per row and
//! channel it decodes (exposure and white balance folded into the table),
//! applies the chromatic aberration's bilinear taps to the decoded rows
//! (two cached per channel), convolves horizontally into a ring of the
//! last 2r + 1 rows (r the PSF's support), then vertically out of the ring,
//! multiplies the vignetting, adds the noise (deviates made first, the
//! arithmetic in a loop that vectorises), clips and encodes: no full-frame
//! intermediate, the working set a few rows in cache. Stages at identity
//! are skipped, and a neutral draw copies its input.
//!
//! Every value is computed with the plane path's f32/f64 operations in the
//! same order, and every read is clamped to the image (not to the band or
//! window), so any band, any window and any thread count give exactly the
//! bytes of the whole frame, and exactly the plane path's bytes (the unit
//! tests compare the two).

use rayon::prelude::*;

#[cfg(target_arch = "x86_64")]
use super::kernels::simd_level;
use super::kernels::{
    TapRun, convolve_row, decode_row, encode_line, sum_rows, tap_runs, taps_runs,
};
use super::rows::{decode_table, disc_spans, gaussian_weights};
use super::{CameraDraw, PsfDraw, noise};

/// The PSF as the sweep applies it.
enum Kernel {
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
    fn radius(&self) -> i64 {
        match self {
            Self::None => 0,
            Self::Gaussian(w) => (w.len() / 2) as i64,
            Self::Disc { spans, .. } => (spans.len() / 2) as i64,
        }
    }
}

/// Everything of a draw the sweep needs, computed once per call.
struct Chain<'a> {
    rgba: &'a [u8],
    width: i64,
    height: i64,
    luts: [[f32; 256]; 3],
    /// The radial scale of each channel's chromatic aberration (`None`: 1).
    ca: [Option<f64>; 3],
    kernel: Kernel,
    /// Vignetting strength, image centre and squared half-diagonal.
    vignette: Option<(f64, (f64, f64), f64)>,
    /// Saturation about the linear luminance (`None`: 1, unchanged).
    saturation: Option<f32>,
    /// Shot gain, read noise², noise key (when the output is noisy).
    noise: Option<(f32, f32, noise::Key)>,
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

/// Whether the fused sweep makes this draw (the sensor has the output's pixels).
pub(super) fn handles(draw: &CameraDraw, width: u32, height: u32) -> bool {
    draw.sensor_size(width, height) == (width, height)
}

/// The RGBA8 bytes of window `[x0, x1) × [y0, y1)` (already clamped to the
/// image, non-empty) of the frame through `draw`.
pub(super) fn develop(
    rgba: &[u8],
    (width, height): (u32, u32),
    draw: &CameraDraw,
    (x0, y0, x1, y1): (i64, i64, i64, i64),
    noisy: bool,
) -> Vec<u8> {
    let chain = Chain::new(rgba, (width, height), draw, noisy);
    let ow = (x1 - x0) as usize;
    let mut bytes = vec![0u8; ow * (y1 - y0) as usize * 4];
    if chain.is_identity() {
        for (r, line) in bytes.chunks_exact_mut(ow * 4).enumerate() {
            let start = ((y0 as usize + r) * width as usize + x0 as usize) * 4;
            line.copy_from_slice(&rgba[start..start + ow * 4]);
        }
        return bytes;
    }
    let band = band_rows(y1 - y0, chain.kernel.radius());
    bytes
        .par_chunks_mut(band as usize * ow * 4)
        .enumerate()
        .for_each(|(b, out)| {
            let ya = y0 + b as i64 * band;
            let yb = (ya + band).min(y1);
            run_band(&chain, (x0, x1), (ya, yb), out);
        });
    bytes
}

/// [`Chain::band`], compiled for AVX-512 and AVX2 as well as for the
/// baseline and run the widest way the CPU has: the same operations on
/// wider registers (Rust never fuses a multiply and an add on its own), so
/// the same bytes. The decode and encode rows take their AVX2 builds inside
/// the AVX-512 band ([`super::kernels::decode_row`]).
fn run_band(chain: &Chain<'_>, cols: (i64, i64), rows: (i64, i64), out: &mut [u8]) {
    #[cfg(target_arch = "x86_64")]
    {
        if simd_level() >= 2 {
            // SAFETY: the CPU has these features (checked by `simd_level`).
            #[allow(unsafe_code)]
            unsafe {
                return band_avx512(chain, cols, rows, out);
            }
        }
        if simd_level() >= 1 {
            // SAFETY: the CPU has AVX2 (checked by `simd_level`).
            #[allow(unsafe_code)]
            unsafe {
                return band_avx2(chain, cols, rows, out);
            }
        }
    }
    chain.band(cols, rows, out);
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512bw,avx512dq,avx512vl")]
fn band_avx512(chain: &Chain<'_>, cols: (i64, i64), rows: (i64, i64), out: &mut [u8]) {
    chain.band(cols, rows, out);
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn band_avx2(chain: &Chain<'_>, cols: (i64, i64), rows: (i64, i64), out: &mut [u8]) {
    chain.band(cols, rows, out);
}

impl<'a> Chain<'a> {
    fn new(rgba: &'a [u8], (width, height): (u32, u32), draw: &CameraDraw, noisy: bool) -> Self {
        let exposure = draw.exposure_gain();
        let gains = [
            exposure * draw.white_balance_red,
            exposure,
            exposure * draw.white_balance_blue,
        ];
        let table = decode_table();
        let luts = gains.map(|g| std::array::from_fn(|i| (f64::from(table[i]) * g) as f32));
        let ca_of = |s: f64| (s != 1.0 && s.is_finite() && s > 0.0).then_some(s);
        let kernel = match draw.psf {
            PsfDraw::Gaussian { sigma_px } if draw.psf.support_px() > 0 && sigma_px > 0.0 => {
                Kernel::Gaussian(gaussian_weights(sigma_px))
            }
            PsfDraw::Disc { radius_px } if draw.psf.support_px() > 0 => {
                let (spans, norm) = disc_spans(radius_px);
                Kernel::Disc { spans, norm }
            }
            _ => Kernel::None,
        };
        let centre = (f64::from(width) / 2.0, f64::from(height) / 2.0);
        let noise_on = noisy && (draw.shot_noise_gain > 0.0 || draw.read_noise_levels > 0.0);
        Self {
            rgba,
            width: i64::from(width),
            height: i64::from(height),
            luts,
            ca: [ca_of(draw.ca_red_scale), None, ca_of(draw.ca_blue_scale)],
            kernel,
            vignette: (draw.vignetting > 0.0).then_some((
                draw.vignetting,
                centre,
                centre.0 * centre.0 + centre.1 * centre.1,
            )),
            saturation: (draw.saturation != 1.0).then_some(draw.saturation as f32),
            noise: noise_on.then_some((
                draw.shot_noise_gain as f32,
                (draw.read_noise_levels * draw.read_noise_levels) as f32,
                noise::Key::new(draw.noise_seed),
            )),
        }
    }

    /// True when the chain returns its input: unit gains, nothing else on
    /// (the encode table inverts the decode table on all 256 levels).
    fn is_identity(&self) -> bool {
        let unit = decode_table();
        self.luts.iter().all(|l| l == unit)
            && self.ca == [None; 3]
            && matches!(self.kernel, Kernel::None)
            && self.vignette.is_none()
            && self.saturation.is_none()
            && self.noise.is_none()
    }

    /// Output rows `[ya, yb)`, columns `[x0, x1)` into `out` (RGBA8).
    #[inline(always)]
    fn band(&self, (x0, x1): (i64, i64), (ya, yb): (i64, i64), out: &mut [u8]) {
        let r = self.kernel.radius();
        let ow = (x1 - x0) as usize;
        // The columns the PSF reads: a disc's prefix sums start at −r, so a
        // window sums exactly as the whole frame does.
        let pad0 = match self.kernel {
            Kernel::Disc { .. } => -r,
            _ => x0 - r,
        };
        let pw = (x1 + r - pad0) as usize;
        let mut pre = PreRows::new(self, pad0, pw);
        let mut rows = Rows::new(&self.kernel, ow, pw);
        let mut finish = Finish::new(self, x0, ow);
        let last = self.height - 1;
        let mut next = (ya - r).max(0);
        for (i, line) in out.chunks_exact_mut(ow * 4).enumerate() {
            let y = ya + i as i64;
            debug_assert!(y < yb);
            match &self.kernel {
                Kernel::None => {
                    for c in 0..3 {
                        let row = pre.row(c, y);
                        finish.vals[c].copy_from_slice(&row[..ow]);
                    }
                }
                kernel => {
                    while next <= (y + r).min(last) {
                        for c in 0..3 {
                            let row = pre.row(c, next);
                            rows.push(kernel, c, next, row, x0 - pad0);
                        }
                        next += 1;
                    }
                    for c in 0..3 {
                        rows.vertical(kernel, c, y, last, x0 - pad0 - r, &mut finish.vals[c]);
                    }
                }
            }
            finish.row(self, y, line);
        }
    }
}

/// Rows of one channel after decoding and chromatic aberration, over the
/// padded columns `pad0 … pad0 + pw − 1` (each clamped to the image).
struct PreRows<'c, 'a> {
    chain: &'c Chain<'a>,
    /// The first padded column (image columns are clamped to the image).
    pad0: i64,
    /// Per channel with aberration: its column taps and decoded-row cache.
    ca: [Option<Aberration>; 3],
    out: Vec<f32>,
}

/// One channel's chromatic aberration over a band's padded columns.
struct Aberration {
    inv: f64,
    centre_y: f64,
    /// First decoded column, and per padded column (c0 − first, c1 − first, fx).
    first: usize,
    taps: Vec<(usize, usize, f32)>,
    /// The taps in runs ([`tap_runs`]), and each column's fx alone.
    runs: Vec<TapRun>,
    fx: Vec<f32>,
    /// Two decoded rows (`keys`: their image rows, −1 none), `first …` wide.
    keys: [i64; 2],
    decoded: [Vec<f32>; 2],
    /// The two rows interpolated vertically.
    mid: Vec<f32>,
}

impl<'c, 'a> PreRows<'c, 'a> {
    fn new(chain: &'c Chain<'a>, pad0: i64, pw: usize) -> Self {
        let (w, h) = (chain.width, chain.height);
        let cols: Vec<usize> = (0..pw as i64)
            .map(|j| (pad0 + j).clamp(0, w - 1) as usize)
            .collect();
        let (cx, cy) = (w as f64 / 2.0, h as f64 / 2.0);
        let ca = chain.ca.map(|scale| {
            let inv = 1.0 / scale?;
            let tap = |x: i64| {
                let u = cx + (x as f64 + 0.5 - cx) * inv - 0.5;
                (u.floor() as i64, (u - u.floor()) as f32)
            };
            let raw: Vec<(usize, usize, f32)> = cols
                .iter()
                .map(|&x| {
                    let (i, f) = tap(x as i64);
                    (
                        i.clamp(0, w - 1) as usize,
                        (i + 1).clamp(0, w - 1) as usize,
                        f,
                    )
                })
                .collect();
            let first = raw.iter().map(|t| t.0.min(t.1)).min().unwrap_or(0);
            let end = raw.iter().map(|t| t.0.max(t.1) + 1).max().unwrap_or(1);
            let taps: Vec<(usize, usize, f32)> = raw
                .into_iter()
                .map(|(a, b, f)| (a - first, b - first, f))
                .collect();
            Some(Aberration {
                inv,
                centre_y: cy,
                first,
                runs: tap_runs(&taps),
                fx: taps.iter().map(|t| t.2).collect(),
                taps,
                keys: [-1, -1],
                decoded: [vec![0.0; end - first], vec![0.0; end - first]],
                mid: vec![0.0; end - first],
            })
        });
        Self {
            chain,
            pad0,
            ca,
            out: vec![0.0; pw],
        }
    }

    /// Channel `c`'s row at image row `y` (clamped).
    #[inline(always)]
    fn row(&mut self, c: usize, y: i64) -> &[f32] {
        let chain = self.chain;
        let (w, last) = (chain.width as usize, chain.height - 1);
        let lut = &chain.luts[c];
        let image_row = |y: i64| &chain.rgba[y as usize * w * 4..(y as usize + 1) * w * 4];
        let decode = |y: i64, first: usize, out: &mut [f32]| {
            decode_row(lut, image_row(y), c, first as i64, out);
        };
        match &mut self.ca[c] {
            None => decode_row(
                lut,
                image_row(y.clamp(0, last)),
                c,
                self.pad0,
                &mut self.out,
            ),
            Some(a) => {
                let y = y.clamp(0, last);
                let u = a.centre_y + (y as f64 + 0.5 - a.centre_y) * a.inv - 0.5;
                let (yi, fy) = (u.floor() as i64, (u - u.floor()) as f32);
                let (k0, k1) = (yi.clamp(0, last), (yi + 1).clamp(0, last));
                let first = a.first;
                let s0 = a.slot(k0, k1, |k, out| decode(k, first, out));
                let s1 = a.slot(k1, k0, |k, out| decode(k, first, out));
                let (r0, r1) = (&a.decoded[s0], &a.decoded[s1]);
                super::rows::lerp_rows(r0, r1, fy, &mut a.mid);
                taps_runs(&a.mid, (&a.taps, &a.fx), &a.runs, &mut self.out);
            }
        }
        &self.out
    }
}

impl Aberration {
    /// The cache slot holding decoded row `k`, filling one that does not
    /// hold `keep` when `k` is missing.
    #[inline(always)]
    fn slot(&mut self, k: i64, keep: i64, fill: impl Fn(i64, &mut [f32])) -> usize {
        if let Some(s) = self.keys.iter().position(|&key| key == k) {
            return s;
        }
        let s = usize::from(self.keys[0] == keep && keep != k);
        fill(k, &mut self.decoded[s]);
        self.keys[s] = k;
        s
    }
}

/// The ring of the last 2r + 1 horizontally filtered rows per channel
/// (Gaussian: the convolved row; disc: the row's prefix sums in f64).
struct Rows {
    len: usize,
    ring: [Vec<f32>; 3],
    prefix: [Vec<f64>; 3],
    sums: Vec<f64>,
    /// Where each of the vertical taps' rows starts in the ring (working memory).
    starts: Vec<usize>,
}

impl Rows {
    fn new(kernel: &Kernel, ow: usize, pw: usize) -> Self {
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
    fn push(&mut self, kernel: &Kernel, c: usize, y: i64, padded: &[f32], offset: i64) {
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
    fn vertical(
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

/// The per-pixel end of the chain: vignetting, clipping, noise, encoding.
struct Finish {
    x0: i64,
    vals: [Vec<f32>; 3],
    /// Squared horizontal distance of each column's centre to the image
    /// centre, over the squared half-diagonal.
    dx2: Vec<f32>,
    factor: Vec<f32>,
    deviates: [Vec<f32>; 3],
}

impl Finish {
    fn new(chain: &Chain<'_>, x0: i64, ow: usize) -> Self {
        let dx2 = match chain.vignette {
            Some((_, centre, corner2)) => (0..ow as i64)
                .map(|i| super::rows::radius2(x0 + i, centre.0, corner2))
                .collect(),
            None => Vec::new(),
        };
        let noisy = if chain.noise.is_some() { ow } else { 0 };
        Self {
            x0,
            vals: std::array::from_fn(|_| vec![0.0; ow]),
            factor: vec![0.0; dx2.len()],
            dx2,
            deviates: std::array::from_fn(|_| vec![0.0; noisy]),
        }
    }

    #[inline(always)]
    fn row(&mut self, chain: &Chain<'_>, y: i64, line: &mut [u8]) {
        if let Some((strength, centre, corner2)) = chain.vignette {
            let dy2 = super::rows::radius2(y, centre.1, corner2);
            super::rows::vignette_factors(strength as f32, dy2, &self.dx2, &mut self.factor);
            for v in &mut self.vals {
                for (v, f) in v.iter_mut().zip(&self.factor) {
                    *v *= f;
                }
            }
        }
        if let Some(s) = chain.saturation {
            let [r, g, b] = &mut self.vals;
            for ((r, g), b) in r.iter_mut().zip(g.iter_mut()).zip(b.iter_mut()) {
                super::rows::saturate(s, r, g, b);
            }
        }
        if let Some((gain, read2, key)) = chain.noise {
            let first = (y * chain.width + self.x0) as u64;
            let [d0, d1, d2] = &mut self.deviates;
            noise::deviates(key, first, [d0, d1, d2]);
            for (vals, devs) in self.vals.iter_mut().zip(&self.deviates) {
                noise::add(vals, devs, gain, read2);
            }
        } else {
            for v in &mut self.vals {
                for v in v.iter_mut() {
                    *v = v.clamp(0.0, 1.0);
                }
            }
        }
        let first = (y as usize * chain.width as usize + self.x0 as usize) * 4;
        let [r, g, b] = &self.vals;
        encode_line([r, g, b], &chain.rgba[first..first + line.len()], line);
    }
}

#[cfg(test)]
mod tests {
    use super::super::stages::develop_planes;
    use super::super::{CameraDraw, PixelRect, PsfDraw, draw};

    fn neutral() -> CameraDraw {
        draw(&crate::preset::camera_model::CameraModel::default(), 1, 0)
    }

    fn draws() -> Vec<CameraDraw> {
        let n = neutral();
        let typical = CameraDraw {
            exposure_ev: 0.4,
            white_balance_red: 1.1,
            white_balance_blue: 0.9,
            psf: PsfDraw::Gaussian { sigma_px: 1.3 },
            vignetting: 0.4,
            ca_red_scale: 1.004,
            ca_blue_scale: 0.993,
            shot_noise_gain: 0.3,
            read_noise_levels: 2.0,
            ..n
        };
        vec![
            n,
            CameraDraw {
                exposure_ev: -0.7,
                ..n
            },
            CameraDraw {
                read_noise_levels: 3.0,
                ..n
            },
            typical,
            CameraDraw {
                psf: PsfDraw::Disc { radius_px: 3.6 },
                ..typical
            },
            CameraDraw {
                psf: PsfDraw::Disc { radius_px: 40.0 },
                ca_red_scale: 1.09,
                ..typical
            },
            CameraDraw {
                psf: PsfDraw::Gaussian { sigma_px: 30.0 },
                ca_blue_scale: 0.9,
                ..typical
            },
            CameraDraw {
                psf: PsfDraw::None,
                ..typical
            },
            CameraDraw {
                exposure_ev: 6.0,
                psf: PsfDraw::Gaussian { sigma_px: 0.2 },
                ..typical
            },
            CameraDraw {
                saturation: 1.4,
                ..typical
            },
            CameraDraw {
                saturation: 0.0,
                ..n
            },
        ]
    }

    /// Saturation moves each pixel away from (or towards) its grey, leaves
    /// greys alone, and 1 changes nothing.
    #[test]
    fn saturation_scales_the_distance_from_grey() {
        let (w, h) = (16u32, 8u32);
        let sky = [90u8, 140, 210, 255];
        let grey = [128u8, 128, 128, 255];
        let rgba: Vec<u8> = (0..w * h)
            .flat_map(|i| if i % 2 == 0 { sky } else { grey })
            .collect();
        let whole = (0, 0, i64::from(w), i64::from(h));
        let spread = |px: &[u8]| {
            i32::from(*px.iter().take(3).max().unwrap_or(&0))
                - i32::from(*px.iter().take(3).min().unwrap_or(&0))
        };
        let at = |s: f64| {
            let d = CameraDraw {
                saturation: s,
                ..neutral()
            };
            super::develop(&rgba, (w, h), &d, whole, false)
        };
        assert_eq!(at(1.0), rgba, "saturation 1 is the identity");
        let (more, none) = (at(1.3), at(0.0));
        assert!(spread(&more[0..4]) > spread(&sky) + 10, "{:?}", &more[0..4]);
        assert!(
            spread(&none[0..4]) <= 1,
            "saturation 0 is grey: {:?}",
            &none[0..4]
        );
        assert_eq!(&more[4..8], &grey, "a grey pixel stays grey");
    }

    type Band = unsafe fn(&super::Chain<'_>, (i64, i64), (i64, i64), &mut [u8]);

    /// The band's builds wider than the baseline that this CPU can run.
    fn wider_builds() -> Vec<(&'static str, Band)> {
        #[cfg(target_arch = "x86_64")]
        {
            let level = super::super::kernels::cpu_simd_level();
            let all: [(&str, Band); 2] =
                [("AVX2", super::band_avx2), ("AVX-512", super::band_avx512)];
            all.into_iter().take(usize::from(level)).collect()
        }
        #[cfg(not(target_arch = "x86_64"))]
        Vec::new()
    }

    /// Every SIMD build of the band this CPU can run gives the baseline
    /// build's bytes, so a frame is the same on machines with and without
    /// AVX2 or AVX-512 (the same preset, byte-identical everywhere).
    #[test]
    fn every_simd_build_of_the_band_gives_the_same_bytes() {
        let (w, h) = (97u32, 71u32);
        let rgba: Vec<u8> = (0..w * h * 4)
            .map(|i| ((i * 37 + i / 11 + (i / 401) * 3) % 256) as u8)
            .collect();
        let mut builds = 0;
        for (n, d) in draws().iter().enumerate() {
            for noisy in [false, true] {
                let chain = super::Chain::new(&rgba, (w, h), d, noisy);
                let (cols, rows) = ((3, i64::from(w) - 2), (5, i64::from(h) - 1));
                let len = (cols.1 - cols.0) as usize * (rows.1 - rows.0) as usize * 4;
                let mut base = vec![0u8; len];
                chain.band(cols, rows, &mut base);
                for (name, build) in wider_builds() {
                    let mut out = vec![0u8; len];
                    // SAFETY: `wider_builds` lists only builds this CPU runs.
                    #[allow(unsafe_code)]
                    unsafe {
                        build(&chain, cols, rows, &mut out)
                    };
                    assert!(out == base, "{name}, draw {n}, noisy {noisy}");
                    builds += 1;
                }
            }
        }
        eprintln!("{builds} wider builds compared with the baseline");
    }

    /// The fused sweep gives the plane path's bytes, noise included, on the
    /// whole frame and on windows (also ones touching the edges).
    #[test]
    fn the_sweep_equals_the_planes() {
        let (w, h) = (83u32, 157u32);
        let rgba: Vec<u8> = (0..w * h * 4)
            .map(|i| ((i * 31 + i / 7 + (i / 333) * 5) % 256) as u8)
            .collect();
        let rects = [
            PixelRect {
                x0: 0,
                y0: 0,
                x1: w,
                y1: h,
            },
            PixelRect {
                x0: 20,
                y0: 9,
                x1: 33,
                y1: 30,
            },
            PixelRect {
                x0: 70,
                y0: 140,
                x1: w,
                y1: h,
            },
            PixelRect {
                x0: 0,
                y0: 60,
                x1: 5,
                y1: 140,
            },
        ];
        for (n, d) in draws().iter().enumerate() {
            for r in rects {
                for noisy in [false, true] {
                    let clamped = (
                        i64::from(r.x0),
                        i64::from(r.y0),
                        i64::from(r.x1),
                        i64::from(r.y1),
                    );
                    let fast = super::develop(&rgba, (w, h), d, clamped, noisy);
                    let planes = develop_planes(&rgba, w, h, d, r, noisy);
                    assert!(fast == planes, "draw {n}, {r:?}, noisy {noisy}");
                }
            }
        }
    }
}
