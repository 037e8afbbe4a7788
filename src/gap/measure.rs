//! The per-frame and per-drone statistics of the domain-gap report, on one decoded frame.
//!
//! Everything is measured on luminance `Y = 0.299 R + 0.587 G + 0.114 B` (JPEG's Rec. 601
//! weights) in 8-bit levels, as `f32`. See the module docs of [`crate::gap`] for what each
//! number means; the functions here are the definitions.

use image::{GrayImage, RgbImage};

/// A burnt-in overlay's pixels ([`super::overlay::Overlay::near`]), row-major at the
/// frame's size: the statistics leave them out.
pub type OverlayMask<'a> = &'a [bool];

/// A labelled box in pixels, `[x0, x1) × [y0, y1)` (continuous coordinates, as YOLO's).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PixelBox {
    pub x0: f32,
    pub y0: f32,
    pub x1: f32,
    pub y1: f32,
}

/// Side of the square tiles the flat-sky statistics are measured on.
pub const TILE_PX: usize = 16;
/// Height the gradient statistics scale the frame to.
pub const GRADIENT_HEIGHT_PX: u32 = 540;
/// Canny thresholds on imageproc's (unnormalised) Sobel magnitude at 540 px high:
/// 20 and 40 are gradients of 2.5 and 5 levels per pixel.
pub const CANNY_LOW: f32 = 20.0;
pub const CANNY_HIGH: f32 = 40.0;
/// A Gaussian profile's 90→10 % edge width (the small drones' edge width statistic) over
/// its σ: √(2 ln 10) − √(2 ln (10/9)). A blur of σ widens an edge w to √(w² + (this · σ)²).
pub const EDGE_PER_SIGMA: f64 = 1.687;
/// An edge profile must rise by at least this many levels to count for the blur estimate.
pub const BLUR_MIN_CONTRAST: f32 = 24.0;
/// Longest half-profile walked from an edge's steepest step (pixels).
const BLUR_MAX_HALF_PX: usize = 12;
/// A frame needs this many flat tiles for its noise figures, and this many edges for its blur.
const MIN_FLAT_TILES: usize = 4;
const MIN_EDGES: usize = 5;

/// Whether `rgb` is grey or a tinted grey (a thermal camera's palette): at
/// most one pixel in fifty has channels more than 16 levels apart, which a
/// coloured sky (30 levels and more) is not.
pub fn is_grey(rgb: &RgbImage) -> bool {
    let coloured = (rgb.pixels())
        .filter(|p| p[0].max(p[1]).max(p[2]) - p[0].min(p[1]).min(p[2]) > 16)
        .count();
    coloured * 50 <= rgb.pixels().len()
}

/// Mean luminance of the lower third of the rows minus the upper third's:
/// positive when the frame brightens downwards (a thermal sky warming
/// towards the horizon).
pub fn vertical_gradient(l: &Luma) -> f32 {
    let third = (l.height / 3).max(1) * l.width;
    let mean = |px: &[f32]| px.iter().sum::<f32>() / px.len().max(1) as f32;
    let n = l.y.len();
    if n < 3 * third {
        return 0.0;
    }
    mean(&l.y[n - third..]) - mean(&l.y[..third])
}

/// Luminance plane in 8-bit levels.
#[derive(Clone, Debug)]
pub struct Luma {
    pub width: usize,
    pub height: usize,
    pub y: Vec<f32>,
}

impl Luma {
    pub fn from_rgb(rgb: &RgbImage) -> Self {
        let y = rgb
            .pixels()
            .map(|p| 0.299 * f32::from(p[0]) + 0.587 * f32::from(p[1]) + 0.114 * f32::from(p[2]))
            .collect();
        Self {
            width: rgb.width() as usize,
            height: rgb.height() as usize,
            y,
        }
    }

    #[inline]
    pub(crate) fn at(&self, x: usize, y: usize) -> f32 {
        self.y[y * self.width + x]
    }

    /// Rounded to 8 bits, for imageproc's integer filters.
    pub fn to_gray(&self) -> GrayImage {
        let data = self
            .y
            .iter()
            .map(|&v| v.round().clamp(0.0, 255.0) as u8)
            .collect();
        // Length matches by construction.
        GrayImage::from_raw(self.width as u32, self.height as u32, data)
            .unwrap_or_else(|| GrayImage::new(self.width as u32, self.height as u32))
    }
}

/// Median of a slice by the grouped-data rule: when the middle value is tied (values on a
/// grid, such as 8-bit levels), the median is interpolated within that value's bin
/// `[max(v − w/2, floor), v + w/2]` (w the grid step; `floor` bounds a folded bin, 0 for
/// absolute deviations), so that quantised data give the median of the underlying
/// continuous values rather than the nearest grid point.
pub fn grouped_median(values: &mut [f32], floor: f32) -> Option<f32> {
    let n = values.len();
    if n == 0 {
        return None;
    }
    values.sort_by(f32::total_cmp);
    let mid = n / 2;
    let v = values[mid];
    let lo = values.partition_point(|&a| a < v);
    let hi = values.partition_point(|&a| a <= v);
    let tied = hi - lo;
    if tied <= 1 {
        return Some(if n.is_multiple_of(2) {
            0.5 * (values[mid - 1] + values[mid])
        } else {
            v
        });
    }
    let below = if lo > 0 {
        Some(v - values[lo - 1])
    } else {
        None
    };
    let above = if hi < n { Some(values[hi] - v) } else { None };
    let w = match (below, above) {
        (Some(a), Some(b)) => a.min(b),
        (Some(a), None) => a,
        (None, Some(b)) => b,
        (None, None) => return Some(v),
    };
    let (lower, upper) = ((v - 0.5 * w).max(floor), v + 0.5 * w);
    Some(lower + (upper - lower) * ((n as f32 * 0.5 - lo as f32) / tied as f32))
}

/// 1.4826 × the median absolute deviation (grouped medians), the σ of Gaussian data.
pub fn robust_sigma(values: &[f32]) -> Option<f32> {
    let mut v = values.to_vec();
    let med = grouped_median(&mut v, f32::NEG_INFINITY)?;
    let mut dev: Vec<f32> = values.iter().map(|&a| (a - med).abs()).collect();
    Some(1.4826 * grouped_median(&mut dev, 0.0)?)
}

/// Φ(x), the standard normal CDF, through erf (Abramowitz–Stegun 7.1.26, |error| < 1.5e-7).
fn normal_cdf(x: f64) -> f64 {
    let z = x.abs() / std::f64::consts::SQRT_2;
    let t = 1.0 / (1.0 + 0.327_591_1 * z);
    let poly = t
        * (0.254_829_592
            + t * (-0.284_496_736
                + t * (1.421_413_741 + t * (-1.453_152_027 + t * 1.061_405_429))));
    let erf = 1.0 - poly * (-z * z).exp();
    0.5 * (1.0 + if x >= 0.0 { erf } else { -erf })
}

/// σ of the flat-tile high-pass values (on the 0.5-level grid of the 8-bit Y plane): the
/// grouped 1.4826·MAD, except when more than half the values are exactly 0 (noise well
/// under one level): then the MAD lies inside the zero bin and the σ of a Gaussian that
/// puts that share p₀ within ±0.25 is used, 0.25 / Φ⁻¹((1 + p₀)/2) (the two agree at
/// p₀ = ½), so a quieter sky always reads lower, down to 0 for a constant one.
pub fn quantised_sigma(hp: &[f32]) -> Option<f32> {
    if hp.is_empty() {
        return None;
    }
    let zeros = hp.iter().filter(|&&v| v == 0.0).count();
    let p0 = zeros as f64 / hp.len() as f64;
    if p0 <= 0.5 {
        // Deviations from the middle value itself, a grid point, stay on the grid, so
        // their grouped median interpolates; from the interpolated median (between grid
        // points) they would fall just beside it and the MAD would snap to k/2 levels.
        let mut v = hp.to_vec();
        let mid = v.len() / 2;
        let (_, &mut centre, _) = v.select_nth_unstable_by(mid, f32::total_cmp);
        let mut dev: Vec<f32> = hp.iter().map(|&a| (a - centre).abs()).collect();
        return grouped_median(&mut dev, 0.0).map(|m| 1.4826 * m);
    }
    if zeros == hp.len() {
        return Some(0.0);
    }
    // Φ⁻¹((1 + p₀)/2) by bisection on [0, 10].
    let target = 0.5 * (1.0 + p0);
    let (mut lo, mut hi) = (0.0f64, 10.0f64);
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if normal_cdf(mid) < target {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    Some((0.25 / (0.5 * (lo + hi))) as f32)
}

/// The flat-sky measurement of a frame.
#[derive(Clone, Debug, Default)]
pub struct FlatSky {
    /// σ of the high-pass over every flat tile ([`quantised_sigma`]).
    pub noise_sigma: Option<f32>,
    /// RMS of the same high-pass values.
    pub highpass_rms: Option<f32>,
    /// Mean colour (R, G, B) of the flat tiles in the upper half of the frame.
    pub sky_rgb: Option<[f32; 3]>,
    /// The top-left corners (x, y) of the tiles that passed the flatness test, row by row.
    pub origins: Vec<(u32, u32)>,
}

/// The 2×2 high-pass `(a − b − c + d)/2` over a tile of the 8-bit luminance plane (Y
/// rounded to whole levels, as a codec stores it, so the values lie on a 0.5 grid and the
/// grouped medians apply): it removes any plane (a smooth sky gradient) and has unit gain
/// on white noise, so its σ is the noise σ.
fn tile_highpass(l: &Luma, x0: usize, y0: usize, out: &mut Vec<f32>) {
    let q = |x: usize, y: usize| l.at(x, y).round();
    for y in y0..y0 + TILE_PX - 1 {
        for x in x0..x0 + TILE_PX - 1 {
            out.push(0.5 * (q(x, y) - q(x + 1, y) - q(x, y + 1) + q(x + 1, y + 1)));
        }
    }
}

/// Whether a tile is flat: the 16 means of its 4×4 sub-blocks lie within
/// `2 + σ_tile` levels of their least-squares plane (σ_tile: the tile's own robust noise),
/// so a smooth gradient passes and any edge, branch or cloud border fails.
fn tile_is_flat(l: &Luma, x0: usize, y0: usize, hp: &[f32]) -> bool {
    let mut means = [0f32; 16];
    for (k, m) in means.iter_mut().enumerate() {
        let (bx, by) = (x0 + (k % 4) * 4, y0 + (k / 4) * 4);
        let mut s = 0.0;
        for y in by..by + 4 {
            for x in bx..bx + 4 {
                s += l.at(x, y);
            }
        }
        *m = s / 16.0;
    }
    let mean = means.iter().sum::<f32>() / 16.0;
    if !(8.0..=247.0).contains(&mean) {
        return false; // clipped tiles carry no noise
    }
    // Plane fit on the centred 4×4 grid: coordinates −1.5..1.5, Σu² = 20 per row → 80.
    let (mut su, mut sv) = (0.0, 0.0);
    for (k, &m) in means.iter().enumerate() {
        let u = (k % 4) as f32 - 1.5;
        let v = (k / 4) as f32 - 1.5;
        su += u * (m - mean);
        sv += v * (m - mean);
    }
    let (a, b) = (su / 20.0, sv / 20.0);
    let worst = means
        .iter()
        .enumerate()
        .map(|(k, &m)| (m - mean - a * ((k % 4) as f32 - 1.5) - b * ((k / 4) as f32 - 1.5)).abs())
        .fold(0.0f32, f32::max);
    let sigma = robust_sigma(hp).unwrap_or(0.0);
    worst <= 2.0 + sigma
}

/// The tiles within 8 px of a box: tile `(tx, ty)` at `(x0, y0)` is near box `b` when
/// `x0 < b.x1 + 8`, `x0 + 16 > b.x0 − 8` and the same in y. Each box's tile rectangle is
/// found by binary search (exactly those comparisons, in `f32`) and added to a 2-D
/// difference array, so the cost is O(boxes · log tiles + tiles), not boxes × tiles (a
/// label file of 10⁵ boxes on a 1080p frame was 10⁹ comparisons).
fn tiles_near_boxes(tiles_x: usize, tiles_y: usize, boxes: &[PixelBox]) -> Vec<bool> {
    // The tiles t in 0..n with `t·16 < hi` and `t·16 + 16 > lo`: a range, both
    // conditions being monotone in t.
    let span = |n: usize, lo: f32, hi: f32| -> (usize, usize) {
        let first = partition(n, |t| lo.is_nan() || ((t + 1) * TILE_PX) as f32 <= lo);
        let end = partition(n, |t| ((t * TILE_PX) as f32) < hi);
        (first, end)
    };
    let mut diff = vec![0i64; (tiles_x + 1) * (tiles_y + 1)];
    for b in boxes {
        let (x_first, x_end) = span(tiles_x, b.x0 - 8.0, b.x1 + 8.0);
        let (y_first, y_end) = span(tiles_y, b.y0 - 8.0, b.y1 + 8.0);
        if x_first >= x_end || y_first >= y_end {
            continue;
        }
        let w = tiles_x + 1;
        diff[y_first * w + x_first] += 1;
        diff[y_first * w + x_end] -= 1;
        diff[y_end * w + x_first] -= 1;
        diff[y_end * w + x_end] += 1;
    }
    let mut near = vec![false; tiles_x * tiles_y];
    let w = tiles_x + 1;
    let mut acc = vec![0i64; w];
    for ty in 0..tiles_y {
        let mut run = 0i64;
        for tx in 0..tiles_x {
            run += diff[ty * w + tx];
            acc[tx] += run;
            near[ty * tiles_x + tx] = acc[tx] > 0;
        }
    }
    near
}

/// The first `t` in `0..n` for which `pred` is false (`pred` true on a prefix, then false).
fn partition(n: usize, pred: impl Fn(usize) -> bool) -> usize {
    let (mut lo, mut hi) = (0, n);
    while lo < hi {
        let mid = lo + (hi - lo) / 2;
        if pred(mid) {
            lo = mid + 1;
        } else {
            hi = mid;
        }
    }
    lo
}

/// Flat-sky noise, high-pass RMS and sky colour. Tiles touching a drone box (grown by 8 px)
/// are left out.
pub fn flat_sky(rgb: &RgbImage, l: &Luma, boxes: &[PixelBox]) -> FlatSky {
    flat_sky_clear(rgb, l, boxes, None)
}

/// Whether any pixel of the tile at (x0, y0) is `overlay`'s.
fn tile_has_overlay(overlay: Option<OverlayMask>, w: usize, x0: usize, y0: usize) -> bool {
    overlay.is_some_and(|o| {
        (y0..y0 + TILE_PX).any(|y| o[y * w + x0..y * w + x0 + TILE_PX].contains(&true))
    })
}

/// [`flat_sky`] leaving out, besides, the tiles with any pixel of `overlay`.
pub fn flat_sky_clear(
    rgb: &RgbImage,
    l: &Luma,
    boxes: &[PixelBox],
    overlay: Option<OverlayMask>,
) -> FlatSky {
    let mut all = Vec::new();
    let mut hp = Vec::with_capacity(TILE_PX * TILE_PX);
    let mut sky = [0f64; 3];
    let mut sky_n = 0u64;
    let mut origins = Vec::new();
    let (tiles_x, tiles_y) = (l.width / TILE_PX, l.height / TILE_PX);
    let near = tiles_near_boxes(tiles_x, tiles_y, boxes);
    for ty in 0..tiles_y {
        for tx in 0..tiles_x {
            let (x0, y0) = (tx * TILE_PX, ty * TILE_PX);
            if near[ty * tiles_x + tx] || tile_has_overlay(overlay, l.width, x0, y0) {
                continue;
            }
            hp.clear();
            tile_highpass(l, x0, y0, &mut hp);
            if !tile_is_flat(l, x0, y0, &hp) {
                continue;
            }
            origins.push((x0 as u32, y0 as u32));
            all.extend_from_slice(&hp);
            if y0 + TILE_PX / 2 < l.height / 2 {
                for y in y0..y0 + TILE_PX {
                    for x in x0..x0 + TILE_PX {
                        let p = rgb.get_pixel(x as u32, y as u32);
                        for c in 0..3 {
                            sky[c] += f64::from(p[c]);
                        }
                        sky_n += 1;
                    }
                }
            }
        }
    }
    let flat_tiles = origins.len();
    let mut out = FlatSky {
        origins,
        ..FlatSky::default()
    };
    if sky_n > 0 {
        let n = sky_n as f64;
        out.sky_rgb = Some([
            (sky[0] / n) as f32,
            (sky[1] / n) as f32,
            (sky[2] / n) as f32,
        ]);
    }
    if flat_tiles >= MIN_FLAT_TILES {
        out.noise_sigma = quantised_sigma(&all);
        let ss: f64 = all.iter().map(|&v| f64::from(v) * f64::from(v)).sum();
        out.highpass_rms = Some((ss / all.len() as f64).sqrt() as f32);
    }
    out
}

/// HSV saturation (0–1) and hue (degrees, 0–360) of a colour.
pub fn saturation_hue(rgb: [f32; 3]) -> (f32, f32) {
    let [r, g, b] = rgb;
    let max = r.max(g).max(b);
    let min = r.min(g).min(b);
    let delta = max - min;
    let s = if max > 0.0 { delta / max } else { 0.0 };
    if delta <= 0.0 {
        return (s, 0.0);
    }
    let h = if max == r {
        60.0 * ((g - b) / delta).rem_euclid(6.0)
    } else if max == g {
        60.0 * ((b - r) / delta + 2.0)
    } else {
        60.0 * ((r - g) / delta + 4.0)
    };
    (s, h)
}

/// The frame's luminance scaled to 540 px high (Triangle filter), as 8-bit grey.
pub fn scaled_gray(l: &Luma) -> GrayImage {
    gray_at_540(&l.to_gray())
}

/// A grey image scaled to 540 px high (Triangle filter), as the gradient statistics see it.
pub fn gray_at_540(g: &GrayImage) -> GrayImage {
    let h = GRADIENT_HEIGHT_PX;
    let w = ((f64::from(g.width()) * f64::from(h) / f64::from(g.height().max(1))).round() as u32)
        .max(1);
    image::imageops::resize(g, w, h, image::imageops::FilterType::Triangle)
}

/// The background's texture: the median, over the 16 px tiles of the frame scaled to
/// 540 px high ([`scaled_gray`]) that lie at least 8 px (at that scale) from every
/// labelled box, of each tile's luminance standard deviation (levels). `None` when no
/// tile is clear of the boxes.
pub fn background_texture(
    g540: &GrayImage,
    boxes: &[PixelBox],
    height: usize,
    overlay: Option<&[bool]>,
) -> Option<f32> {
    let scale = g540.height() as f32 / height.max(1) as f32;
    let scaled: Vec<PixelBox> = boxes
        .iter()
        .map(|b| PixelBox {
            x0: b.x0 * scale,
            y0: b.y0 * scale,
            x1: b.x1 * scale,
            y1: b.y1 * scale,
        })
        .collect();
    let (w, h) = (g540.width() as usize, g540.height() as usize);
    let (tiles_x, tiles_y) = (w / TILE_PX, h / TILE_PX);
    let near = tiles_near_boxes(tiles_x, tiles_y, &scaled);
    let px = g540.as_raw();
    let mut sigmas = Vec::new();
    for ty in 0..tiles_y {
        for tx in 0..tiles_x {
            if near[ty * tiles_x + tx]
                || overlay.is_some_and(|m| {
                    (ty * TILE_PX..(ty + 1) * TILE_PX).any(|y| {
                        m[y * w + tx * TILE_PX..y * w + (tx + 1) * TILE_PX].contains(&true)
                    })
                })
            {
                continue;
            }
            let (mut s, mut ss) = (0f64, 0f64);
            for y in ty * TILE_PX..(ty + 1) * TILE_PX {
                for &v in &px[y * w + tx * TILE_PX..y * w + (tx + 1) * TILE_PX] {
                    let v = f64::from(v);
                    s += v;
                    ss += v * v;
                }
            }
            let n = (TILE_PX * TILE_PX) as f64;
            let mean = s / n;
            sigmas.push(((ss / n - mean * mean).max(0.0).sqrt()) as f32);
        }
    }
    if sigmas.is_empty() {
        return None;
    }
    sigmas.sort_by(f32::total_cmp);
    Some(percentile_sorted(&sigmas, 0.5))
}

/// Mean Sobel magnitude (imageproc's Sobel divided by 8, so levels per pixel) at 540 px
/// high, over the pixels not set in `overlay` (its mask at that size; all without one).
pub fn gradient_energy(g540: &GrayImage, overlay: Option<&[bool]>) -> f32 {
    let gx = imageproc::gradients::horizontal_sobel(g540);
    let gy = imageproc::gradients::vertical_sobel(g540);
    let clear = |i: usize| overlay.is_none_or(|m| !m[i]);
    let n = (0..gx.as_raw().len()).filter(|&i| clear(i)).count().max(1);
    let s: f64 = gx
        .as_raw()
        .iter()
        .zip(gy.as_raw().iter())
        .enumerate()
        .filter(|&(i, _)| clear(i))
        .map(|(_, (&a, &b))| (f64::from(a).powi(2) + f64::from(b).powi(2)).sqrt())
        .sum();
    (s / n as f64 / 8.0) as f32
}

/// Share of pixels imageproc's Canny (σ 1.4 smoothing, thresholds [`CANNY_LOW`],
/// [`CANNY_HIGH`]) marks as edges, at 540 px high, among the pixels not set in `overlay`.
pub fn canny_share(g540: &GrayImage, overlay: Option<&[bool]>) -> f32 {
    let e = imageproc::edges::canny(g540, CANNY_LOW, CANNY_HIGH);
    let clear = |i: usize| overlay.is_none_or(|m| !m[i]);
    let n = (0..e.as_raw().len()).filter(|&i| clear(i)).count().max(1);
    let edges = e.as_raw().iter().enumerate();
    edges.filter(|&(i, &v)| v > 0 && clear(i)).count() as f32 / n as f32
}

/// One edge's PSF σ: the edge's discrete derivative profile, taken across the edge along a
/// row or column, is the PSF's line-spread function integrated over unit bins; its variance
/// is σ² + 1/12 (Sheppard's correction), divided by the profile's slant (cos θ of the
/// gradient to the scan axis).
fn profile_sigma(d: &[f32], peak: usize) -> Option<(f32, f32)> {
    let p = d[peak];
    if p == 0.0 {
        return None;
    }
    let sign = p.signum();
    let floor = 0.02 * p.abs();
    let walk = |step: isize| -> Option<usize> {
        let mut k = peak as isize;
        for _ in 0..BLUR_MAX_HALF_PX {
            let next = k + step;
            if next < 0 || next as usize >= d.len() {
                return None; // ran off the image before the edge ended
            }
            let v = d[next as usize] * sign;
            if v <= floor {
                return Some(k as usize);
            }
            k = next;
        }
        None // still rising after BLUR_MAX_HALF_PX: a ramp, not an edge
    };
    let lo = walk(-1)?;
    let hi = walk(1)?;
    let (mut c, mut m1) = (0f64, 0f64);
    for (k, &v) in d.iter().enumerate().take(hi + 1).skip(lo) {
        let w = f64::from(v * sign);
        c += w;
        m1 += w * (k as f64 + 0.5);
    }
    if c < f64::from(BLUR_MIN_CONTRAST) {
        return None;
    }
    let mu = m1 / c;
    let var: f64 = d[lo..=hi]
        .iter()
        .enumerate()
        .map(|(i, &v)| f64::from(v * sign) * ((lo + i) as f64 + 0.5 - mu).powi(2))
        .sum::<f64>()
        / c;
    Some((((var - 1.0 / 12.0).max(0.0)).sqrt() as f32, c as f32))
}

/// Per-edge PSF σ estimates (pixels) along every row and column: each local maximum of the
/// step between neighbours that is the steepest within ±2 px, on an edge within 30° of
/// the scan's normal (|g_along| ≥ 2 |g_across| by Sobel), rising by at least
/// [`BLUR_MIN_CONTRAST`] levels with both tails reaching 2 % of the peak step within 12 px.
pub fn edge_sigmas(l: &Luma, g: &GrayImage) -> Vec<f32> {
    edge_sigmas_clear(l, g, None)
}

/// Whether `overlay` has a pixel on the scan line within the longest profile of step `k`.
fn profile_has_overlay(
    overlay: Option<OverlayMask>,
    (w, h): (usize, usize),
    (axis, line, k): (usize, usize, usize),
) -> bool {
    overlay.is_some_and(|o| {
        let len = if axis == 0 { w } else { h };
        let (lo, hi) = (
            k.saturating_sub(BLUR_MAX_HALF_PX),
            (k + BLUR_MAX_HALF_PX + 2).min(len),
        );
        (lo..hi).any(|j| {
            if axis == 0 {
                o[line * w + j]
            } else {
                o[j * w + line]
            }
        })
    })
}

/// [`edge_sigmas`] leaving out the edges whose profile could reach `overlay`.
pub fn edge_sigmas_clear(l: &Luma, g: &GrayImage, overlay: Option<OverlayMask>) -> Vec<f32> {
    let gx = imageproc::gradients::horizontal_sobel(g);
    let gy = imageproc::gradients::vertical_sobel(g);
    let (w, h) = (l.width, l.height);
    let mut out = Vec::new();
    let mut d = Vec::new();
    // Rows (edges across x), then columns (edges across y).
    for axis in 0..2 {
        let (lines, len) = if axis == 0 { (h, w) } else { (w, h) };
        for line in 1..lines.saturating_sub(1) {
            d.clear();
            for k in 0..len.saturating_sub(1) {
                let (a, b) = if axis == 0 {
                    (l.at(k, line), l.at(k + 1, line))
                } else {
                    (l.at(line, k), l.at(line, k + 1))
                };
                d.push(b - a);
            }
            for k in 2..d.len().saturating_sub(2) {
                let v = d[k].abs();
                if v < 3.0 || (k - 2..=k + 2).any(|j| j != k && d[j].abs() > v) {
                    continue;
                }
                if d[k - 1].abs() == v {
                    continue; // a plateau of equal steps is counted once, at its right end
                }
                if profile_has_overlay(overlay, (w, h), (axis, line, k)) {
                    continue;
                }
                let (px, py) = if axis == 0 { (k, line) } else { (line, k) };
                let a = f32::from(gx.get_pixel(px as u32, py as u32)[0]);
                let b = f32::from(gy.get_pixel(px as u32, py as u32)[0]);
                let (along, across) = if axis == 0 { (a, b) } else { (b, a) };
                if along.abs() < 2.0 * across.abs() || along == 0.0 {
                    continue;
                }
                let cos = along.abs() / (along * along + across * across).sqrt();
                if let Some((s, _)) = profile_sigma(&d, k) {
                    out.push(s * cos);
                }
            }
        }
    }
    out
}

/// The frame's blur: the 25th percentile of its per-edge σ (the sharpest edges carry the
/// PSF; soft edges of clouds or defocused trees are wider), or `None` with fewer than 5 edges.
pub fn blur_sigma(mut sigmas: Vec<f32>) -> Option<f32> {
    if sigmas.len() < MIN_EDGES {
        return None;
    }
    sigmas.sort_by(f32::total_cmp);
    Some(percentile_sorted(&sigmas, 0.25))
}

/// Linear-interpolated percentile of sorted data (`q` in 0–1).
pub fn percentile_sorted(v: &[f32], q: f64) -> f32 {
    if v.is_empty() {
        return f32::NAN;
    }
    let pos = q * (v.len() - 1) as f64;
    let i = pos.floor() as usize;
    let f = (pos - i as f64) as f32;
    if i + 1 < v.len() {
        v[i] + f * (v[i + 1] - v[i])
    } else {
        v[i]
    }
}

/// What one labelled drone shows against its background.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct DroneMeasure {
    /// Median luminance of the ring around the box.
    pub background: f32,
    /// Signed deviation from the background of the box's most deviating pixel.
    pub peak: f32,
    /// √(pixels in the box deviating from the background by more than half the peak, on the
    /// peak's side).
    pub core_px: f32,
    /// True when the peak is darker than the background.
    pub darker: bool,
    /// Mean 90 %→10 % fall distance of the deviation from the peak pixel outwards (left,
    /// right, up, down; those that reach 10 %), pixels; `None` when no direction does.
    pub edge_width_px: Option<f32>,
    /// √(w·h) of the labelled box, pixels (as labelled, before clipping to the frame).
    pub box_px: f32,
    /// What lies behind the drone ([`super::behind::classify`]; `None` when its ring has
    /// no pixel to judge).
    pub behind: Option<Behind>,
}

/// A labelled box in whole pixels and the ring around it: the box grown by `margin`
/// (half its larger side, at least 3 px, at most 32) on each side, both within the image.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ring {
    /// The box, `[x0, x1) × [y0, y1)`.
    pub x0: i64,
    pub y0: i64,
    pub x1: i64,
    pub y1: i64,
    /// The grown box; the ring is it minus the box.
    pub rx0: i64,
    pub ry0: i64,
    pub rx1: i64,
    pub ry1: i64,
    pub margin: i64,
}

impl Ring {
    /// `None` for a box with no pixel inside a `width` × `height` image.
    pub fn around(b: PixelBox, width: usize, height: usize) -> Option<Self> {
        let (w, h) = (width as i64, height as i64);
        let x0 = (b.x0.floor() as i64).clamp(0, w);
        let y0 = (b.y0.floor() as i64).clamp(0, h);
        let x1 = (b.x1.ceil() as i64).clamp(0, w);
        let y1 = (b.y1.ceil() as i64).clamp(0, h);
        if x1 <= x0 || y1 <= y0 {
            return None;
        }
        let m = ((0.5 * (x1 - x0).max(y1 - y0) as f32).round() as i64).clamp(3, 32);
        Some(Self {
            x0,
            y0,
            x1,
            y1,
            rx0: (x0 - m).max(0),
            ry0: (y0 - m).max(0),
            rx1: (x1 + m).min(w),
            ry1: (y1 + m).min(h),
            margin: m,
        })
    }
}

/// Measures a drone in its box against a ring around it ([`Ring`]: the box grown by
/// half its larger side, at least 3 px, at most 32, on each side, minus the box, within
/// the image). `None` for a box with no pixel or a ring under 8 pixels.
pub fn measure_drone(l: &Luma, b: PixelBox) -> Option<DroneMeasure> {
    measure_drone_clear(l, b, None)
}

/// [`measure_drone`] with `overlay`'s pixels left out of the ring.
pub fn measure_drone_clear(
    l: &Luma,
    b: PixelBox,
    overlay: Option<OverlayMask>,
) -> Option<DroneMeasure> {
    let Ring {
        x0,
        y0,
        x1,
        y1,
        rx0,
        ry0,
        rx1,
        ry1,
        ..
    } = Ring::around(b, l.width, l.height)?;
    // The ring row by row: whole rows above and below the box, the two side
    // strips beside it (its cost is the ring's size, not the grown box's).
    let mut ring = Vec::new();
    let row = |y: i64, xs: std::ops::Range<i64>| {
        let base = y as usize * l.width;
        l.y[base + xs.start as usize..base + xs.end as usize].iter()
    };
    for y in ry0..ry1 {
        if y >= y0 && y < y1 {
            ring.extend(row(y, rx0..x0));
            ring.extend(row(y, x1..rx1));
        } else {
            ring.extend(row(y, rx0..rx1));
        }
    }
    if let Some(o) = overlay {
        ring_clear_of(
            &mut ring,
            (o, l.width),
            (rx0, ry0, rx1, ry1),
            (x0, y0, x1, y1),
        );
    }
    if ring.len() < 8 {
        return None;
    }
    let background = grouped_median(&mut ring, f32::NEG_INFINITY)?;
    let mut peak = 0f32;
    let mut at = (x0, y0);
    for y in y0..y1 {
        for x in x0..x1 {
            let dv = l.at(x as usize, y as usize) - background;
            if dv.abs() > peak.abs() {
                peak = dv;
                at = (x, y);
            }
        }
    }
    let half = 0.5 * peak.abs();
    let mut core = 0usize;
    for y in y0..y1 {
        for x in x0..x1 {
            let dv = (l.at(x as usize, y as usize) - background) * peak.signum();
            if peak != 0.0 && dv > half {
                core += 1;
            }
        }
    }
    // Edge width: walk out from the peak until the deviation falls under 10 % of it.
    let dev = |x: i64, y: i64| (l.at(x as usize, y as usize) - background) * peak.signum();
    let p = peak.abs();
    let mut widths = Vec::new();
    if p > 0.0 {
        for (sx, sy) in [(-1i64, 0i64), (1, 0), (0, -1), (0, 1)] {
            let (mut x, mut y) = at;
            let mut prev = p;
            let mut t = 0f32;
            let mut t90 = None;
            loop {
                let (nx, ny) = (x + sx, y + sy);
                if nx < rx0 || nx >= rx1 || ny < ry0 || ny >= ry1 {
                    break;
                }
                let v = dev(nx, ny);
                // Position of a crossing of `level` between t (value prev) and t+1 (value v).
                let cross = |level: f32| t + (prev - level) / (prev - v).max(1e-6);
                if t90.is_none() && v < 0.9 * p {
                    t90 = Some(cross(0.9 * p).max(t));
                }
                if v < 0.1 * p {
                    if let Some(a) = t90 {
                        widths.push(cross(0.1 * p) - a);
                    }
                    break;
                }
                prev = v;
                t += 1.0;
                x = nx;
                y = ny;
            }
        }
    }
    let edge_width_px = if widths.is_empty() {
        None
    } else {
        Some(widths.iter().sum::<f32>() / widths.len() as f32)
    };
    Some(DroneMeasure {
        background,
        peak,
        core_px: (core as f32).sqrt(),
        darker: peak < 0.0,
        edge_width_px,
        box_px: ((b.x1 - b.x0).max(0.0) * (b.y1 - b.y0).max(0.0)).sqrt(),
        behind: None,
    })
}

/// Drops from `ring` (its values in [`measure_drone`]'s order: the grown box `g` row by
/// row, less the box `b`) those on `overlay`'s pixels.
fn ring_clear_of(
    ring: &mut Vec<f32>,
    (overlay, w): (OverlayMask, usize),
    g: (i64, i64, i64, i64),
    b: (i64, i64, i64, i64),
) {
    let (rx0, ry0, rx1, ry1) = g;
    let (x0, y0, x1, y1) = b;
    let mut at = Vec::with_capacity(ring.len());
    for y in ry0..ry1 {
        for x in rx0..rx1 {
            if !(y >= y0 && y < y1 && x >= x0 && x < x1) {
                at.push(overlay[y as usize * w + x as usize]);
            }
        }
    }
    let mut k = 0;
    ring.retain(|_| {
        k += 1;
        !at[k - 1]
    });
}

/// What lies behind a drone (classified by [`super::behind::classify`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Behind {
    Sky,
    Vegetation,
    Ground,
    Building,
}

impl Behind {
    pub const ALL: [Behind; 4] = [
        Behind::Sky,
        Behind::Vegetation,
        Behind::Ground,
        Behind::Building,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Behind::Sky => "sky",
            Behind::Vegetation => "vegetation",
            Behind::Ground => "ground",
            Behind::Building => "building",
        }
    }
}
