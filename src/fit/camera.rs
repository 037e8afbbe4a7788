//! The footage measured, and its camera estimated.
//!
//! **Measured**: every frame through the domain-gap report's own statistics
//! ([`crate::gap::measure_frame`]): noise σ and high-pass RMS of the flat sky, blur σ of
//! the sharpest edges, JPEG quality from the quantisation tables, sky saturation, mean
//! brightness, and per labelled drone its core size, peak and polarity. Summaries are
//! medians and quartiles over frames (drones).
//!
//! **Estimated**: the camera that made those final bytes, as the camera model's
//! parameters (`camera_model.read_noise_levels`, `psf`, `jpeg_quality`). The JPEG quality
//! is read from the files. Noise and blur are measured *after* the camera's processing
//! and compression, so they are inverted through the camera model's own forward path: a
//! test picture goes through [`crate::sensor::apply`] with a trial read noise or PSF, is
//! written as the batch writes a frame ([`crate::write::encode_image`] at the footage's
//! JPEG quality, PNG footage: none), is decoded and measured by the same statistic; the
//! trial value is bisected until the measurement equals the footage's median. So "σ 3
//! linear levels under JPEG 80" is what a preset must set to write frames whose sky
//! measures like the footage's.
//!
//! The noise's test picture is the footage's own sky ([`super::sky`]): flat tiles of its
//! upper half, each as its least-squares plane per channel, in a mosaic; the σ aimed at
//! is that of the same tiles as the footage has them, in the same mosaic. (What JPEG
//! leaves of a noise depends on the signal under it: one gently sloped sky colour kept
//! less of it than the footage's skies and read σ 3 at JPEG 80 as about 3.5.) The blur's
//! test picture is point-sampled steps of ±60 levels over the footage's median sky
//! colour.

use image::RgbImage;
use rayon::prelude::*;
use serde::Serialize;

use super::input::RealFrame;
use super::sky::{self, NoisePicture, SKY_TILES, SkyTile};
use crate::gap;
use crate::gap::measure::{self, Luma};
use crate::preset::ImageFormat;
use crate::preset::camera_model::{CameraModel, Psf};

/// Side of the blur's test picture.
const PATCH: u32 = 192;

/// Median and quartiles of `n` values.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Quartiles {
    pub n: usize,
    pub q25: f64,
    pub median: f64,
    pub q75: f64,
}

/// Quartiles by linear interpolation between order statistics (`None` when empty).
pub fn quartiles(values: &[f64]) -> Option<Quartiles> {
    let mut v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    let at = |q: f64| gap::percentile(&v, q);
    Some(Quartiles {
        n: v.len(),
        q25: at(0.25),
        median: at(0.5),
        q75: at(0.75),
    })
}

/// One frame's figures, as `footage.json` lists them.
#[derive(Clone, Debug, Serialize)]
pub struct FrameFigures {
    pub file: String,
    pub width: u32,
    pub height: u32,
    pub labelled: bool,
    pub drones: usize,
    pub noise_sigma: Option<f32>,
    pub blur_sigma_px: Option<f32>,
    pub jpeg_quality: Option<u8>,
    pub sky_saturation: Option<f32>,
    pub mean_brightness: f32,
    pub sky_rgb: Option<[f32; 3]>,
    /// The block steps of an earlier 8×8 compression (grey frames; levels).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub block_steps: Option<f32>,
    /// The border lines' level offsets (grey frames; [`crate::gap::capture::EdgeLines`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub edge_lines: Option<crate::gap::capture::EdgeLines>,
    /// The narcissus' depth (grey frames; [`crate::gap::capture::centre_depth`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub centre_depth: Option<f32>,
    /// The horizon (grey frames; [`crate::gap::horizon::horizon`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub horizon: Option<crate::gap::horizon::Horizon>,
    /// The gradient energy ([`crate::gap::measure::gradient_energy`]; levels a pixel at
    /// 540 px high).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gradient_energy: Option<f32>,
}

/// The footage's statistics, summarised over its frames and drones.
#[derive(Clone, Debug, Serialize)]
pub struct Measured {
    pub noise_sigma: Option<Quartiles>,
    /// The same on the upper half alone, where `sky_rgb` and the noise estimate's tiles
    /// are measured (the lower half's ground is darker, and the sRGB curve gives a read
    /// noise more levels there).
    pub sky_noise_sigma: Option<Quartiles>,
    pub highpass_rms: Option<Quartiles>,
    pub blur_sigma_px: Option<Quartiles>,
    pub jpeg_quality: Option<Quartiles>,
    pub sky_saturation: Option<Quartiles>,
    pub mean_brightness: Option<Quartiles>,
    /// Median sky colour (the flat tiles of the upper half), 8-bit sRGB.
    pub sky_rgb: Option<[f64; 3]>,
    /// Core size of the labelled drones, √(pixels over half the peak).
    pub drone_core_px: Option<Quartiles>,
    /// √(w·h) of the labelled boxes, pixels.
    pub drone_box_px: Option<Quartiles>,
    /// Share of drones darker than their ring.
    pub drone_darker_share: Option<f64>,
    /// Labelled drones per labelled frame.
    pub drones_per_frame: Option<Quartiles>,
}

/// The footage's camera as camera-model parameters (see the module docs).
#[derive(Clone, Debug, Serialize)]
pub struct CameraEstimate {
    /// The flat-sky noise σ the read noise is inverted to: the noise test picture's tiles
    /// as the footage has them ([`sky::footage_sigma`]).
    pub sky_noise_sigma: Option<f64>,
    /// Read noise σ, linear 8-bit levels, that writes the footage's sky noise.
    pub read_noise_levels: Option<f64>,
    /// Gaussian PSF σ, pixels, that writes the footage's edge blur.
    pub psf_sigma_px: Option<f64>,
    /// The JPEG quality of the files (median), `None` for PNG footage.
    pub jpeg_quality: Option<u8>,
    /// The sky colour the forward model ran at.
    pub sky_rgb: [u8; 3],
}

/// Everything `fit` knows of the footage (`OUT/footage.json`).
#[derive(Clone, Debug, Serialize)]
pub struct Footage {
    pub frames: usize,
    pub labelled_frames: usize,
    pub drones: usize,
    pub jpeg_frames: usize,
    /// The frame size most frames have (ties: the larger area), the fitted resolution.
    pub size: (u32, u32),
    /// How many frames have that size (fewer than `frames`: the footage mixes sizes,
    /// perhaps cameras, and the fit is one camera's).
    pub size_frames: usize,
    pub measured: Measured,
    pub estimate: CameraEstimate,
    pub per_frame: Vec<FrameFigures>,
    /// The test picture the noise estimate ran on (not written).
    #[serde(skip)]
    pub noise_picture: NoisePicture,
}

/// Per-frame results of the measuring pass.
struct FramePass {
    stats: crate::gap::FrameStats,
    sky_rgb: Option<[f32; 3]>,
    /// The flat-sky noise σ of the upper half alone (the tiles `sky_rgb` is measured on).
    sky_noise: Option<f32>,
    /// At most `tile_cap` (evenly spaced) of the flat tiles of the upper half.
    sky_tiles: Vec<SkyTile>,
}

/// Measures every frame (in parallel, collected in order) and estimates the camera.
pub fn measure(frames: &[RealFrame]) -> Footage {
    // Enough tiles per frame for the noise's test picture, and no more held.
    let tile_cap = (SKY_TILES * SKY_TILES).div_ceil(frames.len().max(1));
    let passes: Vec<FramePass> = frames
        .par_iter()
        .map(|f| {
            let stats = crate::gap::measure_frame(&f.rgb, &f.boxes, f.jpeg.as_deref());
            let l = Luma::from_rgb(&f.rgb);
            let sky_rgb = measure::flat_sky(&f.rgb, &l, &f.boxes).sky_rgb;
            let (w, h) = f.rgb.dimensions();
            let top = image::imageops::crop_imm(&f.rgb, 0, 0, w, h / 2).to_image();
            let top_sky = measure::flat_sky(&top, &Luma::from_rgb(&top), &f.boxes);
            FramePass {
                stats,
                sky_rgb,
                sky_noise: top_sky.noise_sigma,
                sky_tiles: sky::sample(&top, &top_sky.origins, tile_cap),
            }
        })
        .collect();
    let col = |g: &dyn Fn(&FramePass) -> Option<f64>| -> Vec<f64> {
        passes.iter().filter_map(g).collect()
    };
    let drones: Vec<&measure::DroneMeasure> =
        passes.iter().flat_map(|p| p.stats.drones.iter()).collect();
    let boxes: Vec<f64> = frames
        .iter()
        .flat_map(|f| f.boxes.iter())
        .map(|b| f64::from(((b.x1 - b.x0).max(0.0) * (b.y1 - b.y0).max(0.0)).sqrt()))
        .collect();
    let sky: Vec<[f32; 3]> = passes.iter().filter_map(|p| p.sky_rgb).collect();
    let sky_rgb = (!sky.is_empty()).then(|| {
        [0, 1, 2].map(|c| {
            quartiles(&sky.iter().map(|s| f64::from(s[c])).collect::<Vec<_>>())
                .map_or(128.0, |q| q.median)
        })
    });
    let polar: Vec<bool> = drones
        .iter()
        .filter(|d| d.peak != 0.0)
        .map(|d| d.darker)
        .collect();
    let measured = Measured {
        noise_sigma: quartiles(&col(&|p| p.stats.noise_sigma.map(f64::from))),
        sky_noise_sigma: quartiles(&col(&|p| p.sky_noise.map(f64::from))),
        highpass_rms: quartiles(&col(&|p| p.stats.highpass_rms.map(f64::from))),
        blur_sigma_px: quartiles(&col(&|p| p.stats.blur_sigma_px.map(f64::from))),
        jpeg_quality: quartiles(&col(&|p| p.stats.jpeg_quality.map(f64::from))),
        sky_saturation: quartiles(&col(&|p| p.stats.sky_saturation.map(f64::from))),
        mean_brightness: quartiles(&col(&|p| Some(f64::from(p.stats.mean_brightness)))),
        sky_rgb,
        drone_core_px: quartiles(
            &drones
                .iter()
                .map(|d| f64::from(d.core_px))
                .collect::<Vec<_>>(),
        ),
        drone_box_px: quartiles(&boxes),
        drone_darker_share: (!polar.is_empty())
            .then(|| polar.iter().filter(|&&d| d).count() as f64 / polar.len() as f64),
        drones_per_frame: quartiles(
            &frames
                .iter()
                .filter(|f| f.labelled)
                .map(|f| f.boxes.len() as f64)
                .collect::<Vec<_>>(),
        ),
    };
    let tiles: Vec<SkyTile> = passes
        .iter()
        .flat_map(|p| p.sky_tiles.iter().cloned())
        .collect();
    let noise_picture = NoisePicture::of(&tiles)
        .unwrap_or_else(|| NoisePicture::gradient(measured.sky_rgb.map_or([128; 3], to_u8), PATCH));
    let estimate = estimate_camera(&measured, &noise_picture, sky::footage_sigma(&tiles));
    let per_frame = frames
        .iter()
        .zip(&passes)
        .map(|(f, p)| FrameFigures {
            file: f.rel.clone(),
            width: f.rgb.width(),
            height: f.rgb.height(),
            labelled: f.labelled,
            drones: f.boxes.len(),
            noise_sigma: p.stats.noise_sigma,
            blur_sigma_px: p.stats.blur_sigma_px,
            jpeg_quality: p.stats.jpeg_quality,
            sky_saturation: p.stats.sky_saturation,
            mean_brightness: p.stats.mean_brightness,
            sky_rgb: p.sky_rgb,
            block_steps: p.stats.block_steps,
            edge_lines: p.stats.edge_lines,
            centre_depth: p.stats.centre_depth,
            horizon: p.stats.horizon,
            gradient_energy: Some(p.stats.gradient_energy),
        })
        .collect();
    let (size, size_frames) = common_size(frames);
    Footage {
        frames: frames.len(),
        labelled_frames: frames.iter().filter(|f| f.labelled).count(),
        drones: frames.iter().map(|f| f.boxes.len()).sum(),
        jpeg_frames: frames.iter().filter(|f| f.jpeg.is_some()).count(),
        size,
        size_frames,
        measured,
        estimate,
        per_frame,
        noise_picture,
    }
}

/// An sRGB colour rounded to 8 bits.
fn to_u8(c: [f64; 3]) -> [u8; 3] {
    c.map(|v| v.round().clamp(0.0, 255.0) as u8)
}

/// The frame size most frames have (ties go to the larger area, then the wider) and
/// how many have it.
pub(super) fn common_size(frames: &[RealFrame]) -> ((u32, u32), usize) {
    let mut sizes: Vec<(u32, u32)> = frames.iter().map(|f| f.rgb.dimensions()).collect();
    sizes.sort_unstable();
    let mut best = ((0u32, 0u32), 0usize);
    let mut i = 0;
    while i < sizes.len() {
        let j = i + sizes[i..].iter().take_while(|&&s| s == sizes[i]).count();
        let (s, n) = (sizes[i], j - i);
        let area = |s: (u32, u32)| u64::from(s.0) * u64::from(s.1);
        if n > best.1 || (n == best.1 && area(s) > area(best.0)) {
            best = (s, n);
        }
        i = j;
    }
    best
}

/// The camera that writes the measured statistics (module docs): the read noise whose
/// `picture` measures `sky_noise` ([`sky::footage_sigma`]).
pub fn estimate_camera(
    m: &Measured,
    picture: &NoisePicture,
    sky_noise: Option<f64>,
) -> CameraEstimate {
    let sky = m.sky_rgb.map_or([128u8; 3], to_u8);
    let q = m
        .jpeg_quality
        .map(|j| j.median.round().clamp(1.0, 100.0) as u8);
    let read = sky_noise.and_then(|n| invert_noise(picture, q, n));
    let psf = m
        .blur_sigma_px
        .and_then(|b| invert_blur(sky, q, read.unwrap_or(0.0), b.median));
    CameraEstimate {
        sky_noise_sigma: sky_noise,
        read_noise_levels: read,
        psf_sigma_px: psf,
        jpeg_quality: q,
        sky_rgb: sky,
    }
}

/// A camera model with only read noise `read` and a Gaussian PSF `psf` (fixed values).
fn trial_model(read: f64, psf: f64) -> CameraModel {
    CameraModel {
        read_noise_levels: (read, read),
        psf: if psf > 0.0 {
            Psf::Gaussian {
                sigma_px: (psf, psf),
            }
        } else {
            Psf::None
        },
        ..CameraModel::default()
    }
}

/// `rgba` (`side`²) through the camera model and the writer, decoded again.
fn through(rgba: &[u8], side: u32, model: &CameraModel, q: Option<u8>) -> RgbImage {
    let draw = crate::sensor::draw(model, 1, 0);
    let out = crate::sensor::apply(rgba, side, side, &draw);
    if let Some(quality) = q
        && let Ok(bytes) =
            crate::write::encode_image(&out, side, side, ImageFormat::Jpeg { quality })
        && let Ok(img) = image::load_from_memory(&bytes)
    {
        return img.to_rgb8();
    }
    let rgb: Vec<u8> = out
        .chunks_exact(4)
        .flat_map(|p| [p[0], p[1], p[2]])
        .collect();
    RgbImage::from_raw(side, side, rgb).unwrap_or_else(|| RgbImage::new(side, side))
}

/// Point-sampled squares of ±60 levels (darker on a bright sky) over the sky colour.
fn step_patch(sky: [u8; 3]) -> Vec<u8> {
    let lum = 0.299 * f64::from(sky[0]) + 0.587 * f64::from(sky[1]) + 0.114 * f64::from(sky[2]);
    let d: i32 = if lum > 128.0 { -60 } else { 60 };
    let fg = sky.map(|c| (i32::from(c) + d).clamp(0, 255) as u8);
    let mut v = Vec::with_capacity((PATCH * PATCH * 4) as usize);
    for y in 0..PATCH {
        for x in 0..PATCH {
            // 24 px squares every 48 px, offset so edges sit away from the 8 px JPEG grid.
            let inside = (x + 13) % 48 < 24 && (y + 11) % 48 < 24;
            let c = if inside { fg } else { sky };
            v.extend_from_slice(&[c[0], c[1], c[2], 255]);
        }
    }
    v
}

/// The flat-sky noise σ a read noise of `read` linear levels writes on `picture` under `q`.
pub fn noise_after(picture: &NoisePicture, q: Option<u8>, read: f64) -> f64 {
    let img = through(&picture.rgba, picture.side, &trial_model(read, 0.0), q);
    let l = Luma::from_rgb(&img);
    measure::flat_sky(&img, &l, &[])
        .noise_sigma
        .map_or(0.0, f64::from)
}

/// The blur σ a PSF of `psf` px writes (with read noise `read`) at `sky` under `q`.
pub fn blur_after(sky: [u8; 3], q: Option<u8>, read: f64, psf: f64) -> f64 {
    let img = through(&step_patch(sky), PATCH, &trial_model(read, psf), q);
    let l = Luma::from_rgb(&img);
    measure::blur_sigma(measure::edge_sigmas(&l, &l.to_gray())).map_or(0.0, f64::from)
}

/// The smallest x in [0, max] with f(x) ≥ target, for f rising with x (bisection to
/// 1/2¹⁴ of the bracket); 0 when f(0) already reaches it, `None` when f(max) does not.
pub fn bisect(f: impl Fn(f64) -> f64, target: f64, max: f64) -> Option<f64> {
    if !target.is_finite() || f(0.0) >= target {
        return Some(0.0);
    }
    let mut hi = 0.25;
    while f(hi) < target {
        hi *= 2.0;
        if hi > max {
            return None;
        }
    }
    let mut lo = 0.0;
    for _ in 0..14 {
        let mid = 0.5 * (lo + hi);
        if f(mid) >= target {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    Some(0.5 * (lo + hi))
}

/// Read noise (linear levels) whose written `picture` measures `sigma`.
pub fn invert_noise(picture: &NoisePicture, q: Option<u8>, sigma: f64) -> Option<f64> {
    bisect(|r| noise_after(picture, q, r), sigma, 64.0)
}

/// PSF σ (px) whose written edges measure `blur`, under read noise `read`.
pub fn invert_blur(sky: [u8; 3], q: Option<u8>, read: f64, blur: f64) -> Option<f64> {
    bisect(|s| blur_after(sky, q, read, s), blur, 16.0)
}
