//! The domain-gap report (`swarmshot gap`): the same image statistics measured on a folder
//! of real frames and on a swarmshot dataset, side by side, with a verdict per statistic and
//! camera-model ranges that would move the dataset inside the real inter-quartile range.
//!
//! CPU only; knows nothing of presets, rendering or the GPU. [`measure`] holds the
//! definitions, [`overlay`] finds a grey frame's burnt-in text and reticle (left out of
//! every statistic), [`behind`] classifies what lies behind each drone, [`jpeg_quality`] reads
//! quantisation tables, [`report`] walks the folders, aggregates, prints, and writes the
//! JSON, the histogram PNGs ([`histogram`]) and the contact sheet ([`sheet`]).
//!
//! What is measured, on luminance `Y = 0.299 R + 0.587 G + 0.114 B` in 8-bit levels
//! (docs/realism.md has the same list for users):
//!
//! - **flat-sky noise σ**: the frame is cut into 16 px tiles; a tile is *flat* when the
//!   means of its sixteen 4×4 sub-blocks lie within `2 + σ_tile` levels of their
//!   least-squares plane, its mean is within 8–247 (not clipped), and it is at least 8 px
//!   from every labelled box. Over the flat tiles, the high-pass `(a − b − c + d)/2` of each
//!   2×2 neighbourhood of the 8-bit luminance plane (Y rounded to whole levels, as a codec
//!   stores it) removes any smooth gradient and has unit gain on white noise; the noise σ
//!   is 1.4826 × its median absolute deviation, the medians interpolated within their
//!   0.5-level bins; when more than half the values are 0 (noise well under a level), the
//!   σ of a Gaussian with that share within ±0.25 ([`measure::quantised_sigma`]). At least 4
//!   flat tiles, else no value for that frame.
//! - **flat-sky high-pass RMS**: the RMS of the same values (noise plus fine texture).
//! - **gradient energy**: the mean Sobel magnitude (imageproc, divided by 8: levels per
//!   pixel) with the frame scaled to 540 px high.
//! - **Canny edge share**: the share of pixels imageproc's Canny (thresholds 20/40)
//!   marks, at 540 px high.
//! - **sky saturation and hue**: HSV of the mean colour of the flat tiles in the upper half.
//! - **mean brightness**: the mean of Y.
//! - **blur σ**: the Gaussian PSF σ (pixels) from the sharpest edges: every row and column
//!   is scanned for steps (the steepest within ±2 px, ≥ 3 levels, on an edge within 30° of
//!   the scan's normal), the step profile is walked out until it falls to 2 % of its peak
//!   (at most 12 px each way, rising ≥ 24 levels in all); its variance minus 1/12
//!   (Sheppard) is σ², scaled by the edge's slant. The frame's blur is the 25th percentile.
//! - **JPEG quality**: the IJG quality whose luminance table is nearest the file's.
//! - per labelled drone, against a ring around its box (the box grown by half its larger
//!   side, 3–32 px, minus the box): the **background** (ring median), the **peak** (the
//!   most deviating pixel in the box), the **core size** √(pixels deviating by more than half
//!   the peak on its side), **polarity** (darker than the ring or not), and for drones with
//!   a 3–6 px core their **peak contrast** and **edge width** (the 90 %→10 % fall of the
//!   deviation walking out from the peak pixel, averaged over four directions).
//!
//! Measured for fitting and shown, but not counted among the statistics "inside"
//! (`StatRow::counted`; docs/realism.md):
//!
//! - **background texture**: the median, over the 16 px tiles of the frame at 540 px high
//!   that lie 8 px or more from every box, of each tile's luminance standard deviation.
//! - on grey frames, the **horizon** ([`horizon`]): the row where the mean level steps
//!   across the whole width, and the step (frames that show one).
//! - per drone, the **box size** √(w·h) of its label, and **what lies behind it** (sky,
//!   vegetation, ground, building: [`behind`]'s rules on its ring).

pub mod behind;
pub mod capture;
mod error;
pub mod folder;
pub mod halves;
mod histogram;
pub mod horizon;
pub mod jpeg_quality;
pub mod measure;
pub mod overlay;
mod propose;
pub mod report;
pub mod sheet;
mod table;

pub use table::percentile;

use image::RgbImage;
use serde::Serialize;

pub use behind::Behind;
pub use measure::{DroneMeasure, PixelBox};
pub use report::{GapError, GapOptions, Report, run as run_report};

/// Every statistic of one frame (`None` where the frame gives no value).
#[derive(Clone, Debug, Default, Serialize)]
pub struct FrameStats {
    pub width: u32,
    pub height: u32,
    pub flat_tiles: usize,
    pub noise_sigma: Option<f32>,
    pub highpass_rms: Option<f32>,
    pub gradient_energy: f32,
    pub canny_edge_share: f32,
    /// `None` on grey frames ([`FrameStats::grey`]): colour does not apply.
    pub sky_saturation: Option<f32>,
    pub sky_hue_deg: Option<f32>,
    /// Grey or tinted grey ([`measure::is_grey`]): thermal or monochrome footage.
    pub grey: bool,
    /// Mean luminance of the frame's lower third minus its upper third (levels).
    pub vertical_gradient: f32,
    pub mean_brightness: f32,
    /// Median luminance standard deviation of the 16 px tiles at 540 px high clear of the
    /// boxes (`None` when no tile is).
    pub background_texture: Option<f32>,
    pub blur_sigma_px: Option<f32>,
    /// Number of edges the blur estimate used.
    pub blur_edges: usize,
    pub jpeg_quality: Option<u8>,
    pub drones: Vec<DroneMeasure>,
    /// The block steps of an earlier 8×8 compression: the mean neighbour difference
    /// across the 8-pixel grid's edges less that inside the blocks, levels
    /// ([`crate::sensor::thermal::capture::block_steps`]; grey frames only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub block_steps: Option<f32>,
    /// The capture's border lines on a grey frame ([`capture::edge_lines`]): each edge's
    /// four outermost lines' level offsets from the line 8 further in.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub edge_lines: Option<capture::EdgeLines>,
    /// The narcissus' depth of a grey frame ([`capture::centre_depth`]): the centre
    /// disc's median level less the ring's, levels.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub centre_depth: Option<f32>,
    /// The horizon of a grey frame ([`horizon::horizon`]; absent when it shows none).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub horizon: Option<horizon::Horizon>,
    /// Stroke pixels of a burnt-in overlay ([`overlay`]) left out of every statistic
    /// (absent when the frame has none).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub overlay_px: Option<usize>,
}

/// Measures one decoded frame; `jpeg_bytes` are the file's bytes when it is a JPEG
/// (for the quality estimate), `boxes` its labelled drones in pixels.
pub fn measure_frame(rgb: &RgbImage, boxes: &[PixelBox], jpeg_bytes: Option<&[u8]>) -> FrameStats {
    let l = measure::Luma::from_rgb(rgb);
    let grey = measure::is_grey(rgb);
    let overlay = overlay::detect(&l, boxes, grey);
    let ov = overlay.as_ref();
    let mask = ov.map(overlay::Overlay::near);
    let flat = measure::flat_sky_clear(rgb, &l, boxes, mask);
    let (sky_saturation, sky_hue_deg) = match flat.sky_rgb {
        Some(_) if grey => (None, None),
        Some(c) => {
            let (s, h) = measure::saturation_hue(c);
            (Some(s), Some(h))
        }
        None => (None, None),
    };
    let g540 = measure::scaled_gray(&l);
    let m540 = ov.map(|o| o.wide_mask(g540.width() as usize, g540.height() as usize));
    let gray = l.to_gray();
    let edges = measure::edge_sigmas_clear(&l, &gray, mask);
    let blur_edges = edges.len();
    let n = l.y.len().max(1);
    let (mean_brightness, vertical_gradient) = match ov {
        None => (
            (l.y.iter().map(|&v| f64::from(v)).sum::<f64>() / n as f64) as f32,
            measure::vertical_gradient(&l),
        ),
        Some(o) => {
            let third = (l.height / 3).max(1);
            let top = overlay::mean_rows(&l, 0..third, o);
            let bottom = overlay::mean_rows(&l, l.height - third..l.height, o);
            (
                overlay::mean_rows(&l, 0..l.height, o) as f32,
                (bottom - top) as f32,
            )
        }
    };
    FrameStats {
        width: rgb.width(),
        height: rgb.height(),
        flat_tiles: flat.origins.len(),
        noise_sigma: flat.noise_sigma,
        highpass_rms: flat.highpass_rms,
        gradient_energy: measure::gradient_energy(&g540, m540.as_deref()),
        canny_edge_share: measure::canny_share(&g540, m540.as_deref()),
        sky_saturation,
        grey,
        vertical_gradient,
        sky_hue_deg,
        mean_brightness,
        background_texture: measure::background_texture(&g540, boxes, l.height, m540.as_deref()),
        blur_sigma_px: measure::blur_sigma(edges),
        blur_edges,
        jpeg_quality: jpeg_bytes
            .and_then(jpeg_quality::estimate)
            .map(|q| q.quality),
        drones: boxes
            .iter()
            .filter_map(|&b| {
                let mut d = measure::measure_drone_clear(&l, b, mask)?;
                d.behind = behind::classify(rgb, &l, b);
                Some(d)
            })
            .collect(),
        overlay_px: overlay.as_ref().map(|o| o.strokes),
        block_steps: grey.then(|| capture::block_steps(&gray, mask)).flatten(),
        edge_lines: grey.then(|| capture::edge_lines(&l)).flatten(),
        centre_depth: grey
            .then(|| capture::centre_depth(&l, boxes, mask))
            .flatten(),
        horizon: grey.then(|| horizon::horizon(&l, mask)).flatten(),
    }
}
