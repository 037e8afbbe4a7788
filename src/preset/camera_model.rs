//! The camera model's preset section (`camera_model: Some((...))`): plain
//! serde data, one `(min, max)` range per parameter, drawn per frame by
//! [`crate::sensor::draw`] (a fixed value is `(v, v)`). Validation names each
//! field by its path. The processing itself lives in [`crate::sensor`];
//! docs/realism.md, "The camera model", describes every field.

use serde::{Deserialize, Serialize};

use super::{ImageFormat, Preset, Validator};

/// The camera between the rendered scene and the written file: optics,
/// sensor and image processing. Every parameter is a range drawn per frame.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CameraModel {
    /// Exposure change in stops (EV): linear light × 2^EV before the sensor clips.
    /// With `auto_exposure`, the exposure compensation added to the metered EV.
    pub exposure_ev: (f64, f64),
    /// Auto-exposure: the mean 8-bit luminance level the frame's background
    /// (sky, clouds, silhouettes, ground; an image sky's or a backplate's pixels) is metered to,
    /// drawn per frame (`sky::meter`); `None`: the exposure is `exposure_ev` alone.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub auto_exposure: Option<(f64, f64)>,
    /// White balance gain of the red channel (relative to green).
    pub white_balance_red: (f64, f64),
    /// White balance gain of the blue channel (relative to green).
    pub white_balance_blue: (f64, f64),
    /// The optics' point spread function.
    pub psf: Psf,
    /// Light lost at the image corner (0: none, 0.3: corners at 70 %), falling off as r².
    pub vignetting: (f64, f64),
    /// Lateral chromatic aberration: the red image's radial scale relative to green (1: none).
    pub ca_red_scale: (f64, f64),
    /// The blue image's radial scale relative to green (1: none).
    pub ca_blue_scale: (f64, f64),
    /// Shot noise: variance in (linear 8-bit levels)² per linear 8-bit level of signal.
    pub shot_noise_gain: (f64, f64),
    /// Read noise σ in linear 8-bit levels.
    pub read_noise_levels: (f64, f64),
    /// Sensor side / output side, in [0.05, 1]: the picture is sampled by a
    /// coarser sensor and scaled back up (`None`: the sensor has the output's pixels).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sensor_scale: Option<(f64, f64)>,
    /// JPEG quality drawn per frame, in place of `output.image_format`'s (JPEG output only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub jpeg_quality: Option<(u8, u8)>,
    /// A first JPEG compression at this quality (encoded and decoded once) before the final write.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub recompress_quality: Option<(u8, u8)>,
    /// Motion blur (sequences only): how long the shutter is open, seconds,
    /// at most one frame interval (1 / `sequence.frame_rate`); 0: no blur.
    #[serde(skip_serializing_if = "is_zero_range")]
    pub exposure_time_s: (f64, f64),
    /// Colour saturation of the camera's processing, in linear light about
    /// each pixel's luminance (Rec. 709 weights): 1 leaves the colours, 0 is
    /// grey, above 1 more saturated (a camera's "vivid" look). Drawn per frame.
    #[serde(skip_serializing_if = "is_unit_range")]
    pub saturation: (f64, f64),
    /// The image processor's sharpening, an unsharp mask on luma after the
    /// sRGB encoding (0: none, 1: a step overshoots by a quarter of its
    /// height on each side; at most 4). Drawn per frame.
    #[serde(skip_serializing_if = "is_zero_range")]
    pub sharpen: (f64, f64),
    /// The lens's geometric distortion, drawn per frame (`None`: a pinhole).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub lens: Option<super::lens::Lens>,
    /// A rolling shutter: each row exposed at its own time, drawn per frame
    /// (`None`: a global shutter, every row at the frame's time).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub rolling_shutter: Option<super::rolling_shutter::RollingShutter>,
}

/// The largest sharpening amount (`sensor::sharpen` computes in i32 up to it).
pub const MAX_SHARPEN: f64 = 4.0;

fn is_unit_range(r: &(f64, f64)) -> bool {
    *r == (1.0, 1.0)
}

fn is_zero_range(r: &(f64, f64)) -> bool {
    *r == (0.0, 0.0)
}

impl Default for CameraModel {
    /// A camera that changes nothing but the noise-free rounding: every
    /// range at its neutral value.
    fn default() -> Self {
        Self {
            exposure_ev: (0.0, 0.0),
            auto_exposure: None,
            white_balance_red: (1.0, 1.0),
            white_balance_blue: (1.0, 1.0),
            psf: Psf::None,
            vignetting: (0.0, 0.0),
            ca_red_scale: (1.0, 1.0),
            ca_blue_scale: (1.0, 1.0),
            shot_noise_gain: (0.0, 0.0),
            read_noise_levels: (0.0, 0.0),
            sensor_scale: None,
            jpeg_quality: None,
            recompress_quality: None,
            exposure_time_s: (0.0, 0.0),
            saturation: (1.0, 1.0),
            sharpen: (0.0, 0.0),
            lens: None,
            rolling_shutter: None,
        }
    }
}

/// The optics' point spread function, its size drawn per frame.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum Psf {
    /// A perfect lens.
    #[default]
    None,
    /// A Gaussian of standard deviation `sigma_px` output pixels (support ±⌈3σ⌉).
    Gaussian { sigma_px: (f64, f64) },
    /// Defocus: a uniform disc of radius `radius_px` output pixels.
    Disc { radius_px: (f64, f64) },
}

/// The largest PSF size accepted (pixels): beyond it a frame is a flat smear.
pub const MAX_PSF_PX: f64 = 64.0;
/// The most PSF taps a frame may sum: the kernel's taps per pixel (a
/// Gaussian's 2·(2⌈3σ⌉ + 1), separable; a disc's 2⌊r⌋ + 1 rows of prefix
/// sums) times the output's pixels, at the range's widest. About 10 to 25 s
/// on two cores; σ 64 px fits up to 13 megapixels, a 16384 × 9000 frame
/// takes σ up to 5 px.
pub const MAX_PSF_WORK: f64 = 1e10;
/// The smallest `sensor_scale` accepted: below it (1e-300 made a 1 × 1 sensor) the
/// frame is a flat grey with no drone left to label.
pub const MIN_SENSOR_SCALE: f64 = 0.05;

impl CameraModel {
    pub(super) fn validate(&self, preset: &Preset, v: &mut Validator) {
        let p = "camera_model";
        let range = |v: &mut Validator, name: &str, r: (f64, f64), lo: f64, hi: f64| {
            let field = format!("{p}.{name}");
            let ok = r.0.is_finite() && r.1.is_finite();
            v.check(ok && r.0 <= r.1, &field, || {
                format!(
                    "({}, {}) is not a range (min, max) of finite numbers with min ≤ max",
                    r.0, r.1
                )
            });
            v.check(!ok || (r.0 >= lo && r.1 <= hi), &field, || {
                format!("({}, {}) leaves [{lo}, {hi}]", r.0, r.1)
            });
        };
        range(v, "exposure_ev", self.exposure_ev, -10.0, 10.0);
        if let Some(level) = self.auto_exposure {
            range(v, "auto_exposure", level, 1.0, 254.0);
        }
        range(v, "white_balance_red", self.white_balance_red, 0.05, 20.0);
        range(v, "white_balance_blue", self.white_balance_blue, 0.05, 20.0);
        match &self.psf {
            Psf::None => {}
            Psf::Gaussian { sigma_px } => {
                range(v, "psf.sigma_px", *sigma_px, 0.0, MAX_PSF_PX);
            }
            Psf::Disc { radius_px } => {
                range(v, "psf.radius_px", *radius_px, 0.0, MAX_PSF_PX);
            }
        }
        self.psf.check_work(preset.image_size(), v);
        range(v, "vignetting", self.vignetting, 0.0, 1.0);
        range(v, "ca_red_scale", self.ca_red_scale, 0.9, 1.1);
        range(v, "ca_blue_scale", self.ca_blue_scale, 0.9, 1.1);
        range(v, "shot_noise_gain", self.shot_noise_gain, 0.0, 1000.0);
        range(v, "read_noise_levels", self.read_noise_levels, 0.0, 255.0);
        if let Some(s) = self.sensor_scale {
            range(v, "sensor_scale", s, 0.0, 1.0);
            v.check(
                s.0.is_nan() || s.0 > 0.0,
                &format!("{p}.sensor_scale"),
                || format!("{} must be > 0 (the sensor's side over the output's)", s.0),
            );
            v.check(
                s.0.is_nan() || s.0 <= 0.0 || s.0 >= MIN_SENSOR_SCALE,
                &format!("{p}.sensor_scale"),
                || {
                    format!(
                        "{} is under {MIN_SENSOR_SCALE}: a sensor under 1/20 of the output's side (96 × 54 pixels for 1920 × 1080) averages every drone away into a grey frame",
                        s.0
                    )
                },
            );
        }
        for (name, q) in [
            ("jpeg_quality", self.jpeg_quality),
            ("recompress_quality", self.recompress_quality),
        ] {
            if let Some((lo, hi)) = q {
                v.check(
                    (1..=100).contains(&lo) && (1..=100).contains(&hi) && lo <= hi,
                    &format!("{p}.{name}"),
                    || format!("({lo}, {hi}) is not a range (min, max) within [1, 100]"),
                );
            }
        }
        range(v, "exposure_time_s", self.exposure_time_s, 0.0, 1.0);
        range(v, "saturation", self.saturation, 0.0, 4.0);
        range(v, "sharpen", self.sharpen, 0.0, MAX_SHARPEN);
        if let Some(lens) = &self.lens {
            lens.validate(v);
        }
        if let Some(r) = &self.rolling_shutter {
            r.validate(v);
            self.check_rolling_with(preset, v);
        }
        if self.exposure_time_s.1 > 0.0 {
            let field = format!("{p}.exposure_time_s");
            match &preset.sequence {
                None => v.check(false, &field, || {
                    "motion blur needs `sequence` (a still frame has no motion)".into()
                }),
                Some(seq) => v.check(
                    self.exposure_time_s.1 * f64::from(seq.frame_rate) <= 1.0,
                    &field,
                    || {
                        format!(
                            "{} s is longer than a frame interval (1/{} s, sequence.frame_rate)",
                            self.exposure_time_s.1, seq.frame_rate
                        )
                    },
                ),
            }
        }
        if self.jpeg_quality.is_some() {
            v.check(
                matches!(preset.output.image_format, ImageFormat::Jpeg { .. }),
                &format!("{p}.jpeg_quality"),
                || "needs output.image_format Jpeg (the preset writes PNG)".into(),
            );
        }
    }
}

impl Psf {
    /// Taps summed per output pixel at the range's widest (0: no PSF).
    fn taps_per_pixel(&self) -> f64 {
        match *self {
            Self::None => 0.0,
            Self::Gaussian { sigma_px } => 2.0 * (2.0 * (3.0 * sigma_px.1).ceil() + 1.0),
            Self::Disc { radius_px } => 2.0 * radius_px.1.floor() + 1.0,
        }
    }

    /// The PSF's work on a `w`×`h` frame within [`MAX_PSF_WORK`].
    fn check_work(&self, (w, h): (u32, u32), v: &mut Validator) {
        let taps = self.taps_per_pixel();
        let pixels = f64::from(w) * f64::from(h);
        let work = taps * pixels;
        if !work.is_finite() || work <= MAX_PSF_WORK {
            return;
        }
        let (field, value) = match self {
            Self::Gaussian { sigma_px } => ("camera_model.psf.sigma_px", sigma_px.1),
            Self::Disc { radius_px } => ("camera_model.psf.radius_px", radius_px.1),
            Self::None => return,
        };
        v.push(
            field,
            format!(
                "{value} px on {w}×{h} sums {taps} taps for each of {pixels} pixels, {work:.2e} in all, more than the {MAX_PSF_WORK:.0e} a frame may (the camera model's work budget); lower it or the resolution"
            ),
        );
    }
}

impl CameraModel {
    /// What a rolling shutter cannot be combined with yet, named by field.
    fn check_rolling_with(&self, preset: &Preset, v: &mut Validator) {
        let field = "camera_model.rolling_shutter";
        v.check(self.lens.is_none(), field, || {
            "cannot be combined with camera_model.lens yet: the rows are read for a pinhole camera"
                .into()
        });
        v.check(preset.labels.id_scale <= 1, field, || {
            "needs labels.id_scale 1: the drones' pixels are measured in the shuttered picture"
                .into()
        });
    }
}
