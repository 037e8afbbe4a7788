//! The camera model (issue 21): what a real camera does to the rendered
//! scene between the light arriving and the file being written — optics,
//! sensor and image processing — as a CPU stage between rendering and
//! encoding. Off unless the preset has `camera_model: Some(...)`; a preset
//! without it never reaches this module.
//!
//! It owns the per-frame draw of the preset's ranges ([`draw`] →
//! [`CameraDraw`], plain data recorded in the manifest), the processing of
//! a frame ([`apply`]), and the labels' view of it ([`changed_pixels`]:
//! which pixels a drone changes in the noise-free camera image). It knows
//! presets (for the ranges) and seeds, nothing of the GPU, scenes or files.
//!
//! The chain, in linear light (sRGB decoded with a 256-entry table), each
//! stage skipped when its draw is neutral:
//!
//! 1. exposure and white balance: × 2^EV × (R, 1, B) gains (folded into the
//!    decode table). In frames the pipeline makes, the renderer has already
//!    applied the exposure before its 8-bit encode (so highlights above white
//!    keep their headroom) and the stage gets the draw with EV 0
//!    ([`CameraDraw::after_render`]);
//! 2. lateral chromatic aberration: the red and blue images scaled radially
//!    about the image centre by their drawn scale relative to green
//!    (bilinear resampling);
//! 3. the optics' PSF: a Gaussian of σ px truncated at ±⌈3σ⌉ px (weights
//!    renormalised; separable), or a defocus disc of radius r px (the
//!    pixels whose centres lie within r of the pixel's, equal weights);
//! 4. vignetting: × (1 − v·ρ²), ρ the distance to the centre over the
//!    half-diagonal;
//! 5. the sensor grid, when `sensor_scale` < 1: the output is averaged
//!    into sensor pixels (a box filter over each sensor pixel's footprint:
//!    output columns ⌊jW/w⌋ … ⌊(j+1)W/w⌋ − 1, rows likewise), and the
//!    sensor picture is scaled back to the output size bilinearly
//!    (pixel centres aligned, edges clamped) after step 7;
//! 6. the sensor clips the signal at its full well (linear 1.0) and below 0;
//! 7. noise, per sensor pixel and channel: Poisson–Gaussian in linear
//!    8-bit-equivalent levels, variance = gain·signal + read², the normal
//!    deviate from a counter-based hash of (frame noise seed, pixel index)
//!    ([`noise`]); then clipped to [0, 1] again;
//! 8. sRGB encoding (a 65 536-entry table on the linear value);
//! 9. the image processor's sharpening, when drawn: an unsharp mask on the
//!    8-bit picture's luma ([`sharpen`]).
//!
//! Every stage reads its input at absolute pixel coordinates clamped to the
//! image, so running the chain on a window of the frame gives, inside the
//! window shrunk by [`CameraDraw::reach_px`], exactly the bytes the whole
//! frame gets there: the labels use that to compare a drone's neighbourhood
//! with and without the drone. Rows are split over rayon's threads; every
//! pixel's value depends only on the input and the draw, never on the split.

mod aberration;
mod encode;
mod exposure;
mod grid;
pub mod lens;
pub mod motion;
mod noise;
pub mod pool;
mod psf;
#[cfg(test)]
mod reference;
pub mod rolling;
mod saturation;
mod sharpen;
mod sweep;
pub mod thermal;
mod vignette;

use rand::{Rng, SeedableRng};
use serde::Serialize;

use crate::preset::camera_model::{CameraModel, Psf};

/// A camera stage that works pixel by pixel on linear light, after the
/// optics' PSF and before the sensor grid (vignetting, saturation, …): one
/// file under `sensor/` with a type that implements it, registered in
/// [`pixel_stages`]. The sweep ([`sweep`]) runs the registered stages row
/// by row in their order, and the test reference on its planes.
trait PixelStage: Sync {
    /// The stage over image columns `x0 .. x0 + width` of one band of rows
    /// (its per-band tables and working memory): a function of the image
    /// row and the three channels' linear values there, called row by row.
    fn band(&self, x0: i64, width: usize) -> RowFn<'_>;
}

/// A stage's function of one band ([`PixelStage::band`]).
type RowFn<'a> = Box<dyn FnMut(i64, [&mut [f32]; 3]) + 'a>;

/// The per-pixel stages `draw` has on a `width`×`height` frame, in chain
/// order: the registration list (a stage returns `None` when its draw is
/// neutral, and is skipped).
fn pixel_stages(draw: &CameraDraw, width: u32, height: u32) -> Vec<Box<dyn PixelStage>> {
    [
        vignette::Vignette::of(draw, width, height),
        saturation::Saturation::of(draw),
    ]
    .into_iter()
    .flatten()
    .collect()
}

/// Image columns or rows `start .. end`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Span {
    start: i64,
    end: i64,
}

impl Span {
    fn len(self) -> usize {
        (self.end - self.start).max(0) as usize
    }
}

/// The whole frame through the camera, noise included: RGBA8 of the same
/// size, alpha kept (rows in bands on rayon's threads; the noise keyed on
/// absolute pixel indices).
pub fn apply(rgba: &[u8], width: u32, height: u32, draw: &CameraDraw) -> Vec<u8> {
    let mut out = Vec::new();
    apply_into((rgba, width, height), draw, &mut out);
    out
}

/// [`apply`] into `out`, resized to the frame: every byte is written, so a
/// recycled buffer (the renderer's spare) gives the same bytes as a new one
/// without a new one's fresh pages.
pub fn apply_into((rgba, width, height): (&[u8], u32, u32), draw: &CameraDraw, out: &mut Vec<u8>) {
    let whole = PixelRect {
        x0: 0,
        y0: 0,
        x1: width,
        y1: height,
    };
    develop_into((rgba, width, height), draw, whole, true, out);
}

/// The pixels of `out` (RGBA8, row by row) of the `width`×`height` frame
/// `rgba` through the camera `draw`, with or without noise: the bytes the
/// whole frame gets there (empty when `out` misses the frame or `rgba` is
/// short).
pub fn develop(
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

/// [`develop`] into `bytes` (resized; every byte written).
fn develop_into(
    (rgba, width, height): (&[u8], u32, u32),
    draw: &CameraDraw,
    out: PixelRect,
    noisy: bool,
    bytes: &mut Vec<u8>,
) {
    let clamped = PixelRect {
        x0: out.x0.min(width),
        y0: out.y0.min(height),
        x1: out.x1.min(width),
        y1: out.y1.min(height),
    };
    let empty = clamped.x0 >= clamped.x1 || clamped.y0 >= clamped.y1;
    if empty || rgba.len() < (width as usize) * (height as usize) * 4 {
        bytes.clear();
        return;
    }
    if draw.sharpen > 0.0 {
        // The image processor's last step reads one pixel around each.
        let grown = PixelRect {
            x0: clamped.x0.saturating_sub(1),
            y0: clamped.y0.saturating_sub(1),
            x1: (clamped.x1 + 1).min(width),
            y1: (clamped.y1 + 1).min(height),
        };
        let mut px = Vec::new();
        sweep::develop_into((rgba, width, height), draw, grown, noisy, &mut px);
        *bytes = sharpen::sharpen(&px, grown, clamped, draw.sharpen);
        return;
    }
    sweep::develop_into((rgba, width, height), draw, clamped, noisy, bytes);
}

/// The camera parameters of one frame, drawn from the preset's ranges.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct CameraDraw {
    pub exposure_ev: f64,
    pub white_balance_red: f64,
    pub white_balance_blue: f64,
    pub psf: PsfDraw,
    pub vignetting: f64,
    pub ca_red_scale: f64,
    pub ca_blue_scale: f64,
    /// Variance (linear 8-bit levels²) per linear 8-bit level of signal.
    pub shot_noise_gain: f64,
    /// Read noise σ, linear 8-bit levels.
    pub read_noise_levels: f64,
    /// Sensor side / output side (`None`: the output's own pixels).
    pub sensor_scale: Option<f64>,
    /// The quality the frame is written with (`None`: `output.image_format`'s).
    pub jpeg_quality: Option<u8>,
    /// The quality of the first compression (`None`: none).
    pub recompress_quality: Option<u8>,
    /// Seed of the per-pixel noise.
    pub noise_seed: u64,
    /// How long the shutter is open, seconds (0: no motion blur; sequences only).
    pub exposure_time_s: f64,
    /// Saturation about each pixel's linear luminance (1: unchanged).
    pub saturation: f64,
    /// The image processor's sharpening amount (0: none; [`sharpen`]).
    #[serde(skip_serializing_if = "is_zero")]
    pub sharpen: f64,
    /// Auto-exposure, when the preset asks for it: the drawn target level and
    /// the metered EV (set when the frame's scene is built, from its sky).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub auto_exposure: Option<AutoExposureDraw>,
    /// The lens's distortion, when the preset has one ([`lens`]; applied by
    /// the pipeline before this chain, as the lens comes before the sensor).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub lens: Option<lens::LensDraw>,
    /// The rolling shutter, when the preset has one (applied by the
    /// pipeline to the rendered frame, before this chain).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub rolling_shutter: Option<RollingShutterDraw>,
}

/// A frame's rolling shutter: row y is exposed `readout_s · y / height`
/// after the first, while the camera turns at `yaw_rate_deg_s`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct RollingShutterDraw {
    pub readout_s: f64,
    pub yaw_rate_deg_s: f64,
}

/// A frame's auto-exposure: the level its background is metered to and the
/// EV that brings it there (the exposure is 2^(`exposure_ev` + `metered_ev`)).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct AutoExposureDraw {
    pub target_level: f64,
    pub metered_ev: f64,
}

fn is_zero(v: &f64) -> bool {
    *v == 0.0
}

/// One drawn value as the manifest records it.
#[derive(Clone, Debug, PartialEq)]
pub enum DrawValue {
    /// A real number (the manifest keeps six decimals).
    Real(f64),
    /// A whole number (qualities, seeds).
    Count(u64),
    /// A name.
    Name(&'static str),
    /// A group of values by key, in key order.
    Group(Vec<(&'static str, DrawValue)>),
}

impl CameraDraw {
    /// Every drawn value by its key, in key order, as each frame's manifest
    /// record lists them; values a preset leaves neutral and that earlier
    /// manifests did not list are left out. A new stage adds its key here.
    pub fn record(&self) -> Vec<(&'static str, DrawValue)> {
        use DrawValue::{Count, Group, Name, Real};
        let mut r = Vec::with_capacity(20);
        if let Some(a) = self.auto_exposure {
            let v = vec![
                ("metered_ev", Real(a.metered_ev)),
                ("target_level", Real(a.target_level)),
            ];
            r.push(("auto_exposure", Group(v)));
        }
        r.push(("ca_blue_scale", Real(self.ca_blue_scale)));
        r.push(("ca_red_scale", Real(self.ca_red_scale)));
        r.push(("exposure_ev", Real(self.exposure_ev)));
        if self.exposure_time_s > 0.0 {
            r.push(("exposure_time_s", Real(self.exposure_time_s)));
        }
        if let Some(q) = self.jpeg_quality {
            r.push(("jpeg_quality", Count(q.into())));
        }
        if let Some(l) = self.lens {
            let (kind, coefficients) = l.named();
            let mut g: Vec<(&'static str, DrawValue)> = coefficients
                .into_iter()
                .map(|(k, v)| (k, Real(v)))
                .collect();
            g.push(("kind", Name(kind)));
            g.sort_by_key(|(k, _)| *k);
            r.push(("lens", Group(g)));
        }
        r.push(("noise_seed", Count(self.noise_seed)));
        let psf = match self.psf {
            PsfDraw::None => vec![("kind", Name("none"))],
            PsfDraw::Gaussian { sigma_px } => {
                vec![("kind", Name("gaussian")), ("sigma_px", Real(sigma_px))]
            }
            PsfDraw::Disc { radius_px } => {
                vec![("kind", Name("disc")), ("radius_px", Real(radius_px))]
            }
        };
        r.push(("psf", Group(psf)));
        r.push(("read_noise_levels", Real(self.read_noise_levels)));
        if let Some(q) = self.recompress_quality {
            r.push(("recompress_quality", Count(q.into())));
        }
        if let Some(s) = self.rolling_shutter {
            let g = vec![
                ("readout_s", Real(s.readout_s)),
                ("yaw_rate_deg_s", Real(s.yaw_rate_deg_s)),
            ];
            r.push(("rolling_shutter", Group(g)));
        }
        if self.saturation != 1.0 {
            r.push(("saturation", Real(self.saturation)));
        }
        if let Some(s) = self.sensor_scale {
            r.push(("sensor_scale", Real(s)));
        }
        if self.sharpen != 0.0 {
            r.push(("sharpen", Real(self.sharpen)));
        }
        r.push(("shot_noise_gain", Real(self.shot_noise_gain)));
        r.push(("vignetting", Real(self.vignetting)));
        r.push(("white_balance_blue", Real(self.white_balance_blue)));
        r.push(("white_balance_red", Real(self.white_balance_red)));
        r
    }
}

/// The drawn point spread function.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub enum PsfDraw {
    None,
    Gaussian { sigma_px: f64 },
    Disc { radius_px: f64 },
}

impl PsfDraw {
    /// The kernel's half-width in pixels: ⌈3σ⌉ for a Gaussian, ⌊r⌋ for a disc.
    pub fn support_px(self) -> u32 {
        match self {
            Self::None => 0,
            Self::Gaussian { sigma_px } => (3.0 * sigma_px).ceil().max(0.0) as u32,
            Self::Disc { radius_px } => radius_px.floor().max(0.0) as u32,
        }
    }
}

/// Draw frame `frame_index`'s camera from `model`, with the camera model's
/// own seed ([`crate::seed::camera_seed`]): the scene's draws do not move.
/// Fields are drawn in declaration order, each uniform on its range.
pub fn draw(model: &CameraModel, preset_seed: u64, frame_index: u64) -> CameraDraw {
    let seed = crate::seed::camera_seed(preset_seed, frame_index);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let mut pick = |(lo, hi): (f64, f64)| {
        if hi > lo {
            rng.random_range(lo..=hi)
        } else {
            lo
        }
    };
    let exposure_ev = pick(model.exposure_ev);
    let white_balance_red = pick(model.white_balance_red);
    let white_balance_blue = pick(model.white_balance_blue);
    let psf = match model.psf {
        Psf::None => PsfDraw::None,
        Psf::Gaussian { sigma_px } => PsfDraw::Gaussian {
            sigma_px: pick(sigma_px),
        },
        Psf::Disc { radius_px } => PsfDraw::Disc {
            radius_px: pick(radius_px),
        },
    };
    let vignetting = pick(model.vignetting);
    let ca_red_scale = pick(model.ca_red_scale);
    let ca_blue_scale = pick(model.ca_blue_scale);
    let shot_noise_gain = pick(model.shot_noise_gain);
    let read_noise_levels = pick(model.read_noise_levels);
    let sensor_scale = model.sensor_scale.map(&mut pick);
    let mut pick_q = |q: Option<(u8, u8)>| {
        q.map(|(lo, hi)| {
            if hi > lo {
                rng.random_range(lo..=hi)
            } else {
                lo
            }
        })
    };
    let jpeg_quality = pick_q(model.jpeg_quality);
    let recompress_quality = pick_q(model.recompress_quality);
    // Drawn last, and only when it is a range: the earlier draws stay put.
    let exposure_time_s = match model.exposure_time_s {
        (lo, hi) if hi > lo => rng.random_range(lo..=hi),
        (lo, _) => lo,
    };
    // After it, and also only when a range: presets without it draw as before.
    let saturation = match model.saturation {
        (lo, hi) if hi > lo => rng.random_range(lo..=hi),
        (lo, _) => lo,
    };
    // Then the sharpening, again only when a range.
    let sharpen = match model.sharpen {
        (lo, hi) if hi > lo => rng.random_range(lo..=hi),
        (lo, _) => lo,
    };
    // Then the auto-exposure's target level, again only when a range.
    let auto_exposure = model.auto_exposure.map(|r| AutoExposureDraw {
        target_level: match r {
            (lo, hi) if hi > lo => rng.random_range(lo..=hi),
            (lo, _) => lo,
        },
        metered_ev: 0.0,
    });
    // Then the lens's coefficients, each only when a range.
    let lens = model.lens.as_ref().map(|l| {
        lens::draw(l, |(lo, hi)| {
            if hi > lo {
                rng.random_range(lo..=hi)
            } else {
                lo
            }
        })
    });
    // Then the rolling shutter's readout and yaw rate, each only when a range.
    let rolling_shutter = model.rolling_shutter.as_ref().map(|r| {
        let mut pick = |(lo, hi): (f64, f64)| {
            if hi > lo {
                rng.random_range(lo..=hi)
            } else {
                lo
            }
        };
        RollingShutterDraw {
            readout_s: pick(r.readout_s),
            yaw_rate_deg_s: pick(r.yaw_rate_deg_s),
        }
    });
    CameraDraw {
        exposure_ev,
        auto_exposure,
        white_balance_red,
        white_balance_blue,
        psf,
        vignetting,
        ca_red_scale,
        ca_blue_scale,
        shot_noise_gain,
        read_noise_levels,
        sensor_scale,
        jpeg_quality,
        recompress_quality,
        noise_seed: crate::seed::mix64(seed ^ 0x4E4F_4953_455F_5345), // "NOISE_SE"
        exposure_time_s,
        saturation,
        sharpen,
        lens,
        rolling_shutter,
    }
}

impl CameraDraw {
    /// The exposure in stops: the drawn EV plus the metered one (auto-exposure).
    pub fn total_ev(&self) -> f64 {
        self.exposure_ev + self.auto_exposure.map_or(0.0, |a| a.metered_ev)
    }

    /// The exposure as a gain on linear light, 2^EV ([`Self::total_ev`]).
    pub fn exposure_gain(&self) -> f64 {
        2f64.powf(self.total_ev())
    }

    /// The draw the camera stage applies to a frame the renderer already drew
    /// at this exposure ([`Self::exposure_gain`]): the same draw with EV 0.
    /// A camera's exposure scales the light before the sensor clips it, so
    /// the renderer applies it before it encodes its 8-bit picture: a sunlit
    /// white surface brighter than the encoding's white keeps its headroom
    /// under a negative EV instead of being clipped first and darkened after.
    pub fn after_render(&self) -> Self {
        Self {
            exposure_ev: 0.0,
            auto_exposure: None,
            ..*self
        }
    }

    /// The sensor's size for a `width`×`height` output (each side ≥ 1).
    pub fn sensor_size(&self, width: u32, height: u32) -> (u32, u32) {
        match self.sensor_scale {
            Some(s) if s < 1.0 => {
                let side = |n: u32| ((f64::from(n) * s).round() as u32).clamp(1, n);
                (side(width), side(height))
            }
            _ => (width, height),
        }
    }

    /// How far (pixels) a change of one input pixel can move in the output:
    /// the PSF's support, the largest chromatic-aberration shift plus the
    /// bilinear tap, two sensor pixels' footprints for the resampling, and
    /// one pixel for the sharpening.
    pub fn reach_px(&self, width: u32, height: u32) -> u32 {
        let half_diagonal = (f64::from(width).hypot(f64::from(height))) / 2.0;
        let shift = [self.ca_red_scale, self.ca_blue_scale]
            .iter()
            .map(|s| (1.0 - 1.0 / s).abs() * half_diagonal)
            .fold(0.0, f64::max);
        let ca = if shift > 0.0 {
            shift.ceil() as u32 + 2
        } else {
            0
        };
        let (sw, sh) = self.sensor_size(width, height);
        let resample = if (sw, sh) == (width, height) {
            0
        } else {
            2 * width.div_ceil(sw).max(height.div_ceil(sh)) + 2
        };
        self.psf.support_px() + ca + resample + u32::from(self.sharpen > 0.0)
    }
}

/// A pixel rectangle `[x0, x1) × [y0, y1)`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PixelRect {
    pub x0: u32,
    pub y0: u32,
    pub x1: u32,
    pub y1: u32,
}

impl PixelRect {
    /// The smallest rect holding `self` and `o`.
    pub fn union(self, o: Self) -> Self {
        Self {
            x0: self.x0.min(o.x0),
            y0: self.y0.min(o.y0),
            x1: self.x1.max(o.x1),
            y1: self.y1.max(o.y1),
        }
    }

    /// The pixels both `self` and `o` hold; `None` when none.
    pub fn meet(self, o: Self) -> Option<Self> {
        let r = Self {
            x0: self.x0.max(o.x0),
            y0: self.y0.max(o.y0),
            x1: self.x1.min(o.x1),
            y1: self.y1.min(o.y1),
        };
        (r.x0 < r.x1 && r.y0 < r.y1).then_some(r)
    }
}

/// What a drone shows through the camera: the box and number of pixels
/// where the noise-free camera image of `frame` differs by at least one
/// 8-bit level (any channel) from that of `background` (the same frame
/// without drones) under the same draw, searched within `near` (the
/// drone's rendered visible box) grown by [`CameraDraw::reach_px`].
/// A changed pixel that lies nearer to one of `others` (the other drones'
/// rendered visible boxes; distance from the pixel's centre to the box)
/// than to `near` belongs to that drone, not this one; at equal distance
/// it counts for both. `None` when no pixel changes. Both images are
/// `width`×`height` RGBA8.
pub fn changed_pixels(
    frame: &[u8],
    background: &[u8],
    size: (u32, u32),
    draw: &CameraDraw,
    near: PixelRect,
    others: &[PixelRect],
) -> Option<(PixelRect, u64)> {
    changed_pixels_each(
        frame,
        background,
        size,
        draw,
        (near, near, others),
        &mut |_, _| {},
    )
}

/// [`changed_pixels`], calling `each(x, y)` for every pixel it counts (row
/// by row): the drone's visible pixel set through the camera (for masks).
/// The pixels are searched within `search` (grown by the reach), which holds
/// `near` (a rolling shutter's drone reaches further than its visible box:
/// `search` is where its drawn rect's rows go, `near` where its visible box's do).
pub fn changed_pixels_each(
    frame: &[u8],
    background: &[u8],
    (width, height): (u32, u32),
    draw: &CameraDraw,
    (near, search, others): (PixelRect, PixelRect, &[PixelRect]),
    each: &mut dyn FnMut(u32, u32),
) -> Option<(PixelRect, u64)> {
    let reach = draw.reach_px(width, height);
    let grow = |r: PixelRect, by: u32| PixelRect {
        x0: r.x0.saturating_sub(by),
        y0: r.y0.saturating_sub(by),
        x1: r.x1.saturating_add(by).min(width),
        y1: r.y1.saturating_add(by).min(height),
    };
    let area = grow(search, reach);
    if area.x0 >= area.x1 || area.y0 >= area.y1 {
        return None;
    }
    // Only drones whose reach meets this area can claim its pixels.
    let rivals: Vec<PixelRect> = others
        .iter()
        .filter(|o| {
            let g = grow(**o, reach);
            g.x0 < area.x1 && area.x0 < g.x1 && g.y0 < area.y1 && area.y0 < g.y1
        })
        .copied()
        .collect();
    let a = develop(frame, width, height, draw, area, false);
    let b = develop(background, width, height, draw, area, false);
    let w = (area.x1 - area.x0) as usize;
    let mut found: Option<PixelRect> = None;
    let mut count = 0u64;
    for (i, (pa, pb)) in a.chunks_exact(4).zip(b.chunks_exact(4)).enumerate() {
        if pa[..3] == pb[..3] {
            continue;
        }
        let (x, y) = (area.x0 + (i % w) as u32, area.y0 + (i / w) as u32);
        let own = distance2(near, x, y);
        if rivals.iter().any(|o| distance2(*o, x, y) < own) {
            continue;
        }
        count += 1;
        each(x, y);
        let r = found.get_or_insert(PixelRect {
            x0: x,
            y0: y,
            x1: x + 1,
            y1: y + 1,
        });
        r.x0 = r.x0.min(x);
        r.y0 = r.y0.min(y);
        r.x1 = r.x1.max(x + 1);
        r.y1 = r.y1.max(y + 1);
    }
    found.map(|r| (r, count))
}

/// Squared distance from the centre of pixel (x, y) to the rect (0 inside).
fn distance2(r: PixelRect, x: u32, y: u32) -> f64 {
    let (px, py) = (f64::from(x) + 0.5, f64::from(y) + 0.5);
    let dx = (f64::from(r.x0) - px).max(px - f64::from(r.x1)).max(0.0);
    let dy = (f64::from(r.y0) - py).max(py - f64::from(r.y1)).max(0.0);
    dx * dx + dy * dy
}
