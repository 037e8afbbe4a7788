//! Backplates from the footage: each frame with its labelled drones removed, written as
//! a high-quality JPEG (a JPEG frame) or a PNG (a PNG frame: a lossy pass would add
//! quantisation noise and ringing the footage does not have) with the `.plate.ron`
//! sidecar the backplate feature reads (`crate::sky::plates`).
//!
//! **Removal** ([`remove_drones`]): every labelled box is grown by a margin (a quarter of
//! its larger side, 3–24 px: the blur's halo and loose boxes' slack), boxes whose rings
//! touch are filled together. The grown boxes are filled from the ring of pixels around
//! them (as wide as the margin, at least 4 px): first layer by layer from the outside in,
//! each pixel the mean of its already known 8-neighbours, then by 4-neighbour diffusion
//! (red–black over-relaxation, the ring held fixed), which continues the ring's gradient
//! smoothly across the hole. A smooth fill would read as a patch smoother than the sky
//! around it, so each filled pixel then gets the residual (pixel minus the mean of its
//! four neighbours, scaled by 1/√1.25 to unit gain on white noise) of a ring pixel drawn
//! at random: the ring's own noise, with its channel correlation. The draws come from a
//! ChaCha8 stream seeded by the frame's name, so a frame's plate is the same on every run.
//!
//! **Camera**: the plates' horizontal field of view comes from `--hfov`, else from the
//! base preset (its `backplate.hfov_deg`, else its `camera.fov_y_deg` at the footage's
//! aspect); the horizon row of each plate is estimated from its row-mean brightness: the
//! row with the strongest fall from the rows above (sky) to the rows below (ground), when
//! that fall is at least [`HORIZON_MIN_STEP`] levels and lies within the frame's middle
//! 90 %, else `Unknown` (the elevation is then drawn from the base observer's range).
//! Both are estimates: edit `fitted.ron` or a sidecar when you know the camera.
//!
//! **Views** (`--views N`, default 1): besides the whole frame, view k ≥ 1 is a crop of
//! [`VIEW_CROP`] of its width and height, shifted to one of eight places
//! ([`view_crop`]: left, right, top, bottom, then the corners), written as its own plate
//! `NAME__vK.jpg` (`.png`) whose sidecar keeps the camera consistent: the crop's field of view
//! ([`view_hfov`]: the same focal length in the frame's pixels) and the horizon row moved
//! into it ([`view_horizon`]; outside 0–1 when the crop leaves the horizon out). The
//! scene mirrors each plate in half the frames (`backplate.flip`), so N views give 2N.
//! The loader enlarges a crop back to the output size, which lowers its noise and widens
//! its blur a little: the default is the frame alone.

use image::RgbImage;
use rand::{Rng, SeedableRng};
use serde::Serialize;

use super::FitError;
use super::camera::Footage;
use super::input::RealFrame;
use crate::gap::PixelBox;
use crate::preset::{ImageFormat, Preset};
use crate::write::outdir::OutDir;

/// The most views `--views` may ask per frame.
pub const MAX_VIEWS: usize = 9;
/// The share of a frame's width and height a crop view keeps.
pub const VIEW_CROP: f64 = 0.8;
/// Where crop view k ≥ 1 lies within the frame's slack, as fractions (x, y).
const VIEW_PLACES: [(f64, f64); 8] = [
    (0.0, 0.5),
    (1.0, 0.5),
    (0.5, 0.0),
    (0.5, 1.0),
    (0.0, 0.0),
    (1.0, 0.0),
    (0.0, 1.0),
    (1.0, 1.0),
];

/// View `k`'s part of a `w` × `h` frame, `(x0, y0, width, height)`: view 0 is the whole
/// frame, view k ≥ 1 a [`VIEW_CROP`] crop at the k-th of eight places (module docs).
pub fn view_crop(w: u32, h: u32, k: usize) -> (u32, u32, u32, u32) {
    if k == 0 {
        return (0, 0, w, h);
    }
    let cw = ((f64::from(w) * VIEW_CROP).round() as u32).clamp(1, w.max(1));
    let ch = ((f64::from(h) * VIEW_CROP).round() as u32).clamp(1, h.max(1));
    let (fx, fy) = VIEW_PLACES[(k - 1) % VIEW_PLACES.len()];
    let x0 = (f64::from(w.saturating_sub(cw)) * fx).round() as u32;
    let y0 = (f64::from(h.saturating_sub(ch)) * fy).round() as u32;
    (x0, y0, cw, ch)
}

/// The horizontal field of view of a crop `cw` wide out of a frame `w` wide whose field
/// of view is `hfov_deg`: the same focal length, `f = (w/2) / tan(hfov/2)`.
pub fn view_hfov(hfov_deg: f64, w: u32, cw: u32) -> f64 {
    let t = (hfov_deg.to_radians() * 0.5).tan() * f64::from(cw) / f64::from(w.max(1));
    let v = 2.0 * t.atan().to_degrees();
    (v * 1000.0).round() / 1000.0
}

/// The horizon row (a fraction of the height) of a frame `h` high, in its crop of rows
/// `y0 .. y0 + ch`.
pub fn view_horizon(row: Option<f64>, h: u32, y0: u32, ch: u32) -> Option<f64> {
    row.map(|r| {
        let v = (r * f64::from(h) - f64::from(y0)) / f64::from(ch.max(1));
        (v * 10_000.0).round() / 10_000.0
    })
}

/// JPEG quality of the plates of JPEG frames (those of PNG frames are PNG).
pub const PLATE_QUALITY: u8 = 95;
/// The smallest fall (levels) of the row-mean brightness taken for a horizon.
pub const HORIZON_MIN_STEP: f64 = 10.0;

/// The plates' camera as fitted.
#[derive(Clone, Debug, Serialize)]
pub struct PlateCamera {
    pub hfov_deg: f64,
    /// Where the field of view came from, in words.
    pub hfov_source: String,
    /// The line of sight's elevation range for plates without a horizon.
    pub elevation_deg: (f64, f64),
}

/// The plates' horizontal field of view and where it comes from: `--hfov`, else the
/// base preset's `backplate.hfov_deg`, else its `camera.fov_y_deg` at the frames' aspect.
fn plate_hfov(base: &Preset, (w, h): (u32, u32), hfov: Option<f64>) -> (f64, String) {
    match (hfov, &base.backplate) {
        (Some(v), _) => (v, "--hfov".to_string()),
        (None, Some(b)) => (b.hfov_deg, "the base preset's backplate.hfov_deg".into()),
        (None, None) => {
            let aspect = f64::from(w.max(1)) / f64::from(h.max(1));
            let fy = base.camera.fov_y_deg.to_radians();
            let hf = 2.0 * ((fy * 0.5).tan() * aspect).atan();
            (
                hf.to_degrees(),
                format!(
                    "the base preset's camera.fov_y_deg {} at the footage's {w}×{h} aspect (not measured: give --hfov when you know the lens)",
                    base.camera.fov_y_deg
                ),
            )
        }
    }
}

/// Refuses, before anything is written, frames of `size` whose plates would take a
/// horizontal field of view no plate can have (a panorama strip many times wider than
/// high, at the base preset's vertical field of view): the fitted preset would not load.
pub fn check_plate_hfov(
    base: &Preset,
    size: (u32, u32),
    hfov: Option<f64>,
) -> Result<(), FitError> {
    let (hfov_deg, source) = plate_hfov(base, size, hfov);
    if crate::preset::backplate::hfov_ok((hfov_deg * 1000.0).round() / 1000.0) {
        return Ok(());
    }
    Err(FitError::Other(format!(
        "the plates' horizontal field of view would be {hfov_deg:.1}° ({source}), past the {}° a plate may have: give --hfov (the lens's, within [1, {}]) or frames nearer 16:9",
        crate::preset::backplate::MAX_PLATE_HFOV_DEG,
        crate::preset::backplate::MAX_PLATE_HFOV_DEG
    )))
}

impl PlateCamera {
    pub fn from_base(base: &Preset, footage: &Footage, hfov: Option<f64>) -> Self {
        let (hfov_deg, hfov_source) = plate_hfov(base, footage.size, hfov);
        let elevation_deg = base
            .camera
            .observer
            .as_ref()
            .map_or((5.0, 30.0), |o| o.elevation_deg);
        Self {
            hfov_deg: (hfov_deg * 1000.0).round() / 1000.0,
            hfov_source,
            elevation_deg,
        }
    }
}

/// One written plate.
#[derive(Clone, Debug, Serialize)]
pub struct PlateRecord {
    pub plate: String,
    pub source: String,
    pub drones_removed: usize,
    pub labelled: bool,
    /// The estimated horizon row as a fraction of the height (`None`: unknown).
    pub horizon_row: Option<f64>,
}

/// What [`write_plates`] wrote.
#[derive(Clone, Debug, Default, Serialize)]
pub struct PlateSummary {
    pub plates: Vec<PlateRecord>,
    pub unlabelled: usize,
    /// Plates per frame (`--views`).
    #[serde(skip)]
    pub views: usize,
}

/// A filled region: the union of grown boxes filled together.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Filled {
    /// Bounding box of the filled pixels, `[x0, x1) × [y0, y1)`.
    pub x0: u32,
    pub y0: u32,
    pub x1: u32,
    pub y1: u32,
    /// How many pixels were filled.
    pub pixels: usize,
}

/// Margin a labelled box is grown by before it is filled (pixels).
pub fn margin_px(b: &PixelBox) -> i64 {
    let side = (b.x1 - b.x0).max(b.y1 - b.y0).max(0.0);
    ((0.25 * side).round() as i64).clamp(3, 24)
}

#[derive(Clone, Copy, Debug)]
struct Rect {
    x0: i64,
    y0: i64,
    x1: i64,
    y1: i64,
}

impl Rect {
    fn grow(self, d: i64) -> Self {
        Rect {
            x0: self.x0 - d,
            y0: self.y0 - d,
            x1: self.x1 + d,
            y1: self.y1 + d,
        }
    }
    fn clamp(self, w: i64, h: i64) -> Self {
        Rect {
            x0: self.x0.clamp(0, w),
            y0: self.y0.clamp(0, h),
            x1: self.x1.clamp(0, w),
            y1: self.y1.clamp(0, h),
        }
    }
    fn meets(&self, o: &Rect) -> bool {
        self.x0 < o.x1 && o.x0 < self.x1 && self.y0 < o.y1 && o.y0 < self.y1
    }
    fn union(self, o: Rect) -> Rect {
        Rect {
            x0: self.x0.min(o.x0),
            y0: self.y0.min(o.y0),
            x1: self.x1.max(o.x1),
            y1: self.y1.max(o.y1),
        }
    }
    fn empty(&self) -> bool {
        self.x1 <= self.x0 || self.y1 <= self.y0
    }
}

/// Removes the drones in `boxes` from `rgb` (module docs); returns the filled regions.
/// `seed` picks the ring residuals (the same seed, the same pixels).
pub fn remove_drones(rgb: &mut RgbImage, boxes: &[PixelBox], seed: u64) -> Vec<Filled> {
    let (w, h) = (i64::from(rgb.width()), i64::from(rgb.height()));
    // Each box grown by its margin (the hole) and by twice that (hole and ring).
    let mut groups: Vec<(Vec<Rect>, Rect, i64)> = Vec::new();
    for b in boxes {
        let m = margin_px(b);
        let hole = Rect {
            x0: b.x0.floor() as i64,
            y0: b.y0.floor() as i64,
            x1: b.x1.ceil() as i64,
            y1: b.y1.ceil() as i64,
        }
        .grow(m)
        .clamp(w, h);
        if hole.empty() {
            continue;
        }
        groups.push((vec![hole], hole.grow(m.max(4)).clamp(w, h), m.max(4)));
    }
    // Merge groups whose windows meet, until none do.
    loop {
        let mut merged = false;
        'outer: for i in 0..groups.len() {
            for j in i + 1..groups.len() {
                if groups[i].1.meets(&groups[j].1) {
                    let (holes, win, ring) = groups.remove(j);
                    groups[i].0.extend(holes);
                    groups[i].1 = groups[i].1.union(win);
                    groups[i].2 = groups[i].2.max(ring);
                    merged = true;
                    break 'outer;
                }
            }
        }
        if !merged {
            break;
        }
    }
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let all: Vec<Rect> = groups.iter().flat_map(|g| g.0.iter().copied()).collect();
    let source = rgb.clone();
    groups
        .iter()
        .filter_map(|(holes, win, ring)| {
            fill_group(rgb, &source, holes, &all, *win, *ring, &mut rng)
        })
        .collect()
}

/// Luminance of an RGB triple.
fn luma(c: [f32; 3]) -> f32 {
    0.299 * c[0] + 0.587 * c[1] + 0.114 * c[2]
}

/// The window `win` of `img` shifted by `(dx, dy)`, as floats; `None` when it leaves the image.
fn window_at(img: &RgbImage, win: Rect, dx: i64, dy: i64) -> Option<Vec<[f32; 3]>> {
    let (w, h) = (i64::from(img.width()), i64::from(img.height()));
    if win.x0 + dx < 0 || win.y0 + dy < 0 || win.x1 + dx > w || win.y1 + dy > h {
        return None;
    }
    let ww = (win.x1 - win.x0) as usize;
    let n = ww * (win.y1 - win.y0) as usize;
    Some(
        (0..n)
            .map(|i| {
                let p = img.get_pixel(
                    (win.x0 + dx + (i % ww) as i64) as u32,
                    (win.y0 + dy + (i / ww) as i64) as u32,
                );
                [f32::from(p[0]), f32::from(p[1]), f32::from(p[2])]
            })
            .collect(),
    )
}

/// Solves Laplace's equation for `v` on the `mask`ed pixels of a `ww`-wide window, the
/// others held fixed, the window's edge reflecting: an onion-peel start (each layer the
/// mean of its known 8-neighbours, from the outside in), then red–black over-relaxation.
fn harmonic(v: &mut [[f32; 3]], mask: &[bool], ww: usize, span: usize) {
    let wh = v.len() / ww;
    let idx = |x: usize, y: usize| y * ww + x;
    let mut known: Vec<bool> = mask.iter().map(|&m| !m).collect();
    loop {
        let mut layer = Vec::new();
        for y in 0..wh {
            for x in 0..ww {
                if known[idx(x, y)] {
                    continue;
                }
                let mut sum = [0f32; 3];
                let mut n = 0;
                for (nx, ny) in (-1i64..=1)
                    .flat_map(|dy| (-1i64..=1).map(move |dx| (x as i64 + dx, y as i64 + dy)))
                {
                    if nx < 0 || ny < 0 || nx >= ww as i64 || ny >= wh as i64 {
                        continue;
                    }
                    let k = idx(nx as usize, ny as usize);
                    if k == idx(x, y) || !known[k] {
                        continue;
                    }
                    for c in 0..3 {
                        sum[c] += v[k][c];
                    }
                    n += 1;
                }
                if n > 0 {
                    layer.push((idx(x, y), sum.map(|s| s / n as f32)));
                }
            }
        }
        if layer.is_empty() {
            break;
        }
        for (i, c) in layer {
            v[i] = c;
            known[i] = true;
        }
    }
    let iterations = (2 * span + 20).min(400);
    let omega = 1.8f32;
    for _ in 0..iterations {
        for parity in 0..2 {
            for y in 0..wh {
                for x in 0..ww {
                    if (x + y) % 2 != parity || !mask[idx(x, y)] {
                        continue;
                    }
                    let mut sum = [0f32; 3];
                    let mut n = 0f32;
                    for (nx, ny) in [
                        (x.wrapping_sub(1), y),
                        (x + 1, y),
                        (x, y.wrapping_sub(1)),
                        (x, y + 1),
                    ] {
                        if nx < ww && ny < wh {
                            let q = v[idx(nx, ny)];
                            for c in 0..3 {
                                sum[c] += q[c];
                            }
                            n += 1.0;
                        }
                    }
                    let i = idx(x, y);
                    for c in 0..3 {
                        v[i][c] += omega * (sum[c] / n - v[i][c]);
                    }
                }
            }
        }
    }
}

/// Fills the union of `holes` inside `win` (module docs): cloned from the most alike
/// place beside it, else diffused from the ring with the ring's residuals.
fn fill_group(
    rgb: &mut RgbImage,
    source: &RgbImage,
    holes: &[Rect],
    all: &[Rect],
    win: Rect,
    ring: i64,
    rng: &mut rand_chacha::ChaCha8Rng,
) -> Option<Filled> {
    let (ww, wh) = ((win.x1 - win.x0) as usize, (win.y1 - win.y0) as usize);
    let idx = |x: usize, y: usize| y * ww + x;
    let mut mask = vec![false; ww * wh];
    let mut bbox: Option<Rect> = None;
    for hole in holes {
        for y in hole.y0..hole.y1 {
            for x in hole.x0..hole.x1 {
                mask[idx((x - win.x0) as usize, (y - win.y0) as usize)] = true;
            }
        }
        bbox = Some(bbox.map_or(*hole, |b| b.union(*hole)));
    }
    let bbox = bbox?;
    let pixels = mask.iter().filter(|&&m| m).count();
    if pixels == ww * wh {
        return None; // nothing around it to fill from
    }
    let span = (bbox.x1 - bbox.x0).max(bbox.y1 - bbox.y0) as usize;
    let target = window_at(source, win, 0, 0)?;
    let place = Window { win, ww, wh };
    let filled = match clone_source(source, &target, &mask, place, (bbox, ring), all) {
        Some(s) => {
            // Seamless clone: the source plus the harmonic correction that meets the ring.
            let mut d: Vec<[f32; 3]> = (0..ww * wh)
                .map(|i| {
                    if mask[i] {
                        [0.0; 3]
                    } else {
                        [0, 1, 2].map(|c| target[i][c] - s[i][c])
                    }
                })
                .collect();
            harmonic(&mut d, &mask, ww, span);
            (0..ww * wh)
                .map(|i| [0, 1, 2].map(|c| s[i][c] + d[i][c]))
                .collect()
        }
        None => diffuse_with_residuals(target, &mask, (ww, wh), span, rng),
    };
    for y in 0..wh {
        for x in 0..ww {
            let i = idx(x, y);
            if mask[i] {
                let p = filled[i].map(|c| c.round().clamp(0.0, 255.0) as u8);
                rgb.put_pixel(
                    (win.x0 + x as i64) as u32,
                    (win.y0 + y as i64) as u32,
                    image::Rgb(p),
                );
            }
        }
    }
    Some(Filled {
        x0: bbox.x0 as u32,
        y0: bbox.y0 as u32,
        x1: bbox.x1 as u32,
        y1: bbox.y1 as u32,
        pixels,
    })
}

/// A hole group's window in the frame and its size.
#[derive(Clone, Copy)]
struct Window {
    win: Rect,
    ww: usize,
    wh: usize,
}

/// The window shifted left, right, up or down past the hole (`bbox` plus the
/// `ring`), inside the frame, its hole clear of every labelled box in `all`:
/// the one whose known pixels look most like `target`'s, `None` when none fits.
fn clone_source(
    source: &RgbImage,
    target: &[[f32; 3]],
    mask: &[bool],
    Window { win, ww, wh }: Window,
    (bbox, ring): (Rect, i64),
    all: &[Rect],
) -> Option<Vec<[f32; 3]>> {
    let (sw, sh) = (bbox.x1 - bbox.x0 + ring, bbox.y1 - bbox.y0 + ring);
    let mut best: Option<(f32, Vec<[f32; 3]>)> = None;
    for (dx, dy) in [(-sw, 0), (sw, 0), (0, -sh), (0, sh)] {
        let moved = Rect {
            x0: bbox.x0 + dx,
            y0: bbox.y0 + dy,
            x1: bbox.x1 + dx,
            y1: bbox.y1 + dy,
        }
        .grow(2);
        if all.iter().any(|h| h.meets(&moved)) {
            continue;
        }
        let Some(s) = window_at(source, win, dx, dy) else {
            continue;
        };
        let (mut diff, mut n) = (0f32, 0f32);
        for i in 0..ww * wh {
            if !mask[i] {
                diff += (luma(target[i]) - luma(s[i])).abs();
                n += 1.0;
            }
        }
        let score = diff / n.max(1.0);
        if best.as_ref().is_none_or(|b| score < b.0) {
            best = Some((score, s));
        }
    }
    best.map(|(_, s)| s)
}

/// The hole diffused from the ring (harmonic), each pixel given one of the
/// ring's residuals (pixel minus the mean of its four known neighbours, unit
/// gain on white noise; the edges' outliers beyond 3 robust σ left out), drawn from `rng`.
fn diffuse_with_residuals(
    mut v: Vec<[f32; 3]>,
    mask: &[bool],
    (ww, wh): (usize, usize),
    span: usize,
    rng: &mut rand_chacha::ChaCha8Rng,
) -> Vec<[f32; 3]> {
    let target = v.clone();
    let idx = |x: usize, y: usize| y * ww + x;
    harmonic(&mut v, mask, ww, span);
    let scale = 1.0 / 1.25f32.sqrt();
    let mut residuals: Vec<[f32; 3]> = Vec::new();
    for y in 1..wh.saturating_sub(1) {
        for x in 1..ww.saturating_sub(1) {
            let n = [idx(x - 1, y), idx(x + 1, y), idx(x, y - 1), idx(x, y + 1)];
            if mask[idx(x, y)] || n.iter().any(|&k| mask[k]) {
                continue;
            }
            let c = target[idx(x, y)];
            residuals.push(
                [0, 1, 2].map(|ch| {
                    scale * (c[ch] - 0.25 * n.iter().map(|&k| target[k][ch]).sum::<f32>())
                }),
            );
        }
    }
    let mut mags: Vec<f32> = residuals.iter().map(|r| luma(*r).abs()).collect();
    mags.sort_by(f32::total_cmp);
    let limit = 3.0 * 1.4826 * mags.get(mags.len() / 2).copied().unwrap_or(0.0);
    residuals.retain(|r| luma(*r).abs() <= limit);
    for i in 0..ww * wh {
        if mask[i] && !residuals.is_empty() {
            let r = residuals[rng.random_range(0..residuals.len())];
            for c in 0..3 {
                v[i][c] += r[c];
            }
        }
    }
    v
}

/// The horizon row as a fraction of the height (module docs), `None` when unclear.
pub fn estimate_horizon(rgb: &RgbImage) -> Option<f64> {
    let (w, h) = (rgb.width() as usize, rgb.height() as usize);
    if h < 32 {
        return None;
    }
    let rows: Vec<f64> = (0..h)
        .map(|y| {
            let s: f64 = (0..w)
                .map(|x| {
                    let p = rgb.get_pixel(x as u32, y as u32);
                    0.299 * f64::from(p[0]) + 0.587 * f64::from(p[1]) + 0.114 * f64::from(p[2])
                })
                .sum();
            s / w as f64
        })
        .collect();
    let k = (h / 32).max(4);
    let mut prefix = vec![0.0; h + 1];
    for (i, r) in rows.iter().enumerate() {
        prefix[i + 1] = prefix[i] + r;
    }
    let mean = |a: usize, b: usize| (prefix[b] - prefix[a]) / (b - a) as f64;
    let (lo, hi) = ((h / 20).max(k), (h - (h / 20).max(k)).min(h - k));
    let mut best: Option<(usize, f64)> = None;
    for y in lo..hi {
        let fall = mean(y - k, y) - mean(y, y + k);
        if best.is_none_or(|(_, f)| fall > f) {
            best = Some((y, fall));
        }
    }
    let (y, fall) = best?;
    (fall >= HORIZON_MIN_STEP).then(|| (y as f64 / h as f64 * 1000.0).round() / 1000.0)
}

/// A seed from a frame's name (FNV-1a), so the plate does not depend on the frame's order.
pub fn name_seed(name: &str) -> u64 {
    name.bytes().fold(0xcbf2_9ce4_8422_2325u64, |h, b| {
        (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

/// The plate file name for a frame: its relative path with `/` → `__`, as `.{ext}`.
fn plate_name(rel: &str, ext: &str) -> String {
    let stem = match rel.rfind('.') {
        Some(i) => &rel[..i],
        None => rel,
    };
    format!("{}.{ext}", stem.replace('/', "__"))
}

/// A frame's plate format: a lossless frame stays lossless (its noise and fine
/// texture are the footage's), a JPEG's plates are JPEGs.
fn plate_format(f: &RealFrame) -> ImageFormat {
    match f.jpeg {
        Some(_) => ImageFormat::Jpeg {
            quality: PLATE_QUALITY,
        },
        None => ImageFormat::Png,
    }
}

/// The file name of view `k` of frame `f`'s plate: [`plate_name`], and
/// `__vK` before the extension for k ≥ 1.
fn view_name(f: &RealFrame, k: usize) -> String {
    let ext = plate_format(f).extension();
    let whole = plate_name(&f.rel, ext);
    match k {
        0 => whole,
        k => format!("{}__v{k}.{ext}", whole.trim_end_matches(&format!(".{ext}"))),
    }
}

/// Refuses, before any plate is written, plates the fitted preset could not load
/// ([`crate::sky::plates`]): `frames` × `views` plates past [`crate::sky::plates::MAX_PLATES`],
/// or past [`crate::sky::plates::MAX_PLATE_MEMORY_BYTES`] resampled to `size` (the fitted
/// resolution, RGBA), naming how many `--max-frames` fit.
pub fn check_plate_budget(frames: usize, views: usize, size: (u32, u32)) -> Result<(), FitError> {
    use crate::sky::plates::{MAX_PLATE_MEMORY_BYTES, MAX_PLATES};
    let views = views.max(1);
    let per_plate = (u64::from(size.0) * u64::from(size.1) * 4).max(1);
    let by_memory = MAX_PLATE_MEMORY_BYTES / (per_plate * views as u64);
    let fit = (MAX_PLATES / views).min(usize::try_from(by_memory).unwrap_or(usize::MAX));
    if frames <= fit {
        return Ok(());
    }
    Err(FitError::TooManyPlates {
        frames,
        views,
        width: size.0,
        height: size.1,
        fit,
    })
}

/// Two frames whose plates would take the same name (`b.jpg` and `b.jpeg`,
/// `cam/a.png` and `cam__a.png`, a view of `e.png` and `e__v1.png`), named
/// before anything is written: one would silently replace the other.
pub fn check_names_apart(frames: &[RealFrame], views: usize) -> Result<(), FitError> {
    let mut taken: std::collections::HashMap<String, &str> = std::collections::HashMap::new();
    for f in frames {
        for k in 0..views.max(1) {
            if let Some(other) = taken.insert(view_name(f, k), &f.rel) {
                return Err(FitError::Other(format!(
                    "frames {} and {} would give plates of the same name ({}): rename one of them",
                    crate::text::printable(other),
                    crate::text::printable(&f.rel),
                    crate::text::printable(&view_name(f, k)),
                )));
            }
        }
    }
    Ok(())
}

/// Writes every frame's plates (`views` of each, at least 1: module docs) and their
/// sidecars into the folder `dir` (opened once: each thread writes through its own
/// handle on it, never through a link).
pub fn write_plates(
    frames: &[RealFrame],
    footage: &Footage,
    camera: &PlateCamera,
    dir: &OutDir,
    views: usize,
) -> Result<PlateSummary, FitError> {
    use rayon::prelude::*;
    let _ = footage;
    let records: Vec<Result<Vec<PlateRecord>, FitError>> = frames
        .par_iter()
        .map_init(
            || dir.try_clone(),
            |dir, f| {
                let dir = dir.as_mut().map_err(|e| FitError::Other(e.to_string()))?;
                let mut rgb = f.rgb.clone();
                remove_drones(&mut rgb, &f.boxes, name_seed(&f.rel));
                let horizon = estimate_horizon(&rgb);
                (0..views.max(1))
                    .map(|k| write_view(dir, f, &rgb, horizon, camera, k))
                    .collect()
            },
        )
        .collect();
    let mut plates = Vec::new();
    for r in records {
        plates.extend(r?);
    }
    let unlabelled = plates.iter().filter(|p| !p.labelled).count();
    Ok(PlateSummary {
        plates,
        unlabelled,
        views: views.max(1),
    })
}

/// Writes view `k` of a frame's plate `rgb` (drones removed) and its sidecar.
fn write_view(
    dir: &mut OutDir,
    f: &RealFrame,
    rgb: &RgbImage,
    horizon: Option<f64>,
    camera: &PlateCamera,
    k: usize,
) -> Result<PlateRecord, FitError> {
    let (w, h) = rgb.dimensions();
    let (x0, y0, cw, ch) = view_crop(w, h, k);
    let view = image::imageops::crop_imm(rgb, x0, y0, cw, ch).to_image();
    let (hfov_deg, horizon) = match k {
        0 => (camera.hfov_deg, horizon),
        _ => (
            view_hfov(camera.hfov_deg, w, cw),
            view_horizon(horizon, h, y0, ch),
        ),
    };
    let format = plate_format(f);
    let ext = format.extension();
    let name = view_name(f, k);
    let rgba: Vec<u8> = view
        .pixels()
        .flat_map(|p| [p[0], p[1], p[2], 255])
        .collect();
    let bytes = crate::write::encode_image(&rgba, cw, ch, format)
        .map_err(|e| FitError::Other(format!("encoding plate {name}: {e}")))?;
    let save = |dir: &mut OutDir, name: &str, bytes: &[u8]| {
        dir.write(name, bytes)
            .map_err(|e| FitError::Other(e.to_string()))
    };
    save(dir, &name, &bytes)?;
    let horizon_text = match horizon {
        Some(r) => format!("Row({r})"),
        None => "Unknown".into(),
    };
    let view_text = match k {
        0 => String::new(),
        k => format!(
            "\n// view {k}: the {cw}×{ch} crop at ({x0}, {y0}) of the {w}×{h} plate; its hfov_deg and horizon follow from the plate's"
        ),
    };
    let sidecar = format!(
        "// swarmshot fit: {} with its {} labelled drone(s) removed{}.\n// hfov_deg: {}; horizon: {}{view_text}\n(hfov_deg: {hfov_deg}, horizon: {horizon_text})\n",
        // One line of comment whatever the frame's name holds (a new line would end it).
        crate::text::printable(&f.rel),
        f.boxes.len(),
        if f.labelled {
            ""
        } else {
            " (NO LABEL FILE: drones in it, if any, were not removed)"
        },
        camera.hfov_source,
        if horizon.is_some() {
            "estimated from the row-mean brightness step (sky above, ground below)"
        } else {
            "no clear brightness step: unknown, the elevation is drawn from backplate.elevation_deg"
        },
    );
    let stem = name.trim_end_matches(&format!(".{ext}"));
    save(dir, &format!("{stem}.plate.ron"), sidecar.as_bytes())?;
    Ok(PlateRecord {
        plate: name,
        source: f.rel.clone(),
        drones_removed: f.boxes.len(),
        labelled: f.labelled,
        horizon_row: horizon,
    })
}

/// Mean, standard deviation and 2×2 high-pass RMS of the luminance of `rgb` inside `r`
/// (`(x0, y0, x1, y1)`, leaving out `hole` when given): what the removal tests compare
/// between a fill and its ring.
pub fn region_stats(
    rgb: &RgbImage,
    r: (u32, u32, u32, u32),
    hole: Option<(u32, u32, u32, u32)>,
) -> (f64, f64, f64) {
    let inside =
        |x: u32, y: u32, q: (u32, u32, u32, u32)| x >= q.0 && x < q.2 && y >= q.1 && y < q.3;
    let fits = |x: u32, y: u32| inside(x, y, r) && !hole.is_some_and(|q| inside(x, y, q));
    let lum = |x: u32, y: u32| {
        let p = rgb.get_pixel(x, y);
        0.299 * f64::from(p[0]) + 0.587 * f64::from(p[1]) + 0.114 * f64::from(p[2])
    };
    let (mut sum, mut sq, mut n) = (0.0, 0.0, 0usize);
    let (mut hp, mut m) = (0.0, 0usize);
    for y in r.1..r.3 {
        for x in r.0..r.2 {
            if !fits(x, y) {
                continue;
            }
            let v = lum(x, y);
            sum += v;
            sq += v * v;
            n += 1;
            if fits(x + 1, y) && fits(x, y + 1) && fits(x + 1, y + 1) {
                let h = 0.5 * (v - lum(x + 1, y) - lum(x, y + 1) + lum(x + 1, y + 1));
                hp += h * h;
                m += 1;
            }
        }
    }
    let n = n.max(1) as f64;
    let mean = sum / n;
    (
        mean,
        (sq / n - mean * mean).max(0.0).sqrt(),
        (hp / m.max(1) as f64).sqrt(),
    )
}

#[cfg(test)]
mod budget_tests {
    use super::*;

    /// A panorama strip at the base's vertical field of view would need a plate wider
    /// than 150°: refused, unless `--hfov` says the lens's.
    #[test]
    fn frames_too_wide_for_a_plate_are_refused_unless_hfov_is_given() {
        let mut base = Preset::default();
        base.backplate = None;
        base.camera.fov_y_deg = 50.0;
        check_plate_hfov(&base, (1920, 1080), None).expect("16:9");
        let e = check_plate_hfov(&base, (2000, 64), None).expect_err("31:1");
        let e = e.to_string();
        assert!(
            e.contains("would be 172.1°") && e.contains("2000×64") && e.contains("give --hfov"),
            "{e}"
        );
        check_plate_hfov(&base, (2000, 64), Some(120.0)).expect("--hfov");
    }

    #[test]
    fn plates_the_fitted_preset_could_not_load_are_refused_naming_how_many_fit() {
        // 4K: 33 MB a plate resampled, 64 fit in the loader's 2 GiB.
        check_plate_budget(64, 1, (3840, 2160)).expect("64 fit");
        let e = check_plate_budget(200, 1, (3840, 2160)).expect_err("200 4K plates");
        assert!(matches!(e, FitError::TooManyPlates { fit: 64, .. }), "{e}");
        assert!(e.to_string().contains("--max-frames 64 or fewer"), "{e}");
        // Small frames: the loader's plate count (4096) bounds frames × views.
        check_plate_budget(4096, 1, (64, 64)).expect("4096 fit");
        let e = check_plate_budget(10_000, 1, (64, 64)).expect_err("10 000 plates");
        assert!(
            matches!(e, FitError::TooManyPlates { fit: 4096, .. }),
            "{e}"
        );
        let e = check_plate_budget(500, 9, (64, 64)).expect_err("4 500 plates");
        assert!(matches!(e, FitError::TooManyPlates { fit: 455, .. }), "{e}");
    }
}
