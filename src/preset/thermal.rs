//! The thermal camera (`thermal:` in a preset; issue 41): a long-wave
//! infrared (8–14 µm) picture instead of the visible one. Off unless a preset
//! names it. The fields are temperatures, emissivities and the camera's
//! figures; `sensor::thermal` turns them into band radiance and 8-bit grey
//! pixels (docs/realism.md, "Thermal camera").

use serde::{Deserialize, Serialize};

use super::Validator;

/// The thermal look of one kind of object: its skin, and a warm spot
/// centred on its picture (a drone's battery and motors, a bird's body, an
/// aircraft's engine).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Signature {
    /// Skin temperature above the air's, kelvin.
    pub skin_k: f64,
    /// Skin emissivity in the band (0–1); the rest reflects what lies behind.
    pub emissivity: f64,
    /// Warm spot's peak temperature above the skin's, kelvin.
    pub spot_k: f64,
    /// Warm spot's Gaussian σ as a share of the object's half box size.
    pub spot_share: f64,
    /// Share of the objects (drawn per object and frame) seen colder than
    /// the air: skin `skin_k` below the air instead of above (a shell cooled
    /// by radiating to the cold sky) and no warm spot (battery and motors
    /// idle or shielded by the shell), so against a background at the air's
    /// temperature or warmer they read darker. 0 is not written to
    /// preset.lock.ron, so datasets made before it resume.
    #[serde(skip_serializing_if = "is_zero")]
    pub cold_share: f64,
    /// The motors' peak temperature above the skin, kelvin: with this or
    /// `battery_k` set, the warm spot is the object's parts instead (a
    /// Gaussian at each rotor hub of the model, the motor's size, and one
    /// at the body's centre, the battery's), projected by the frame's
    /// camera; `spot_k` and `spot_share` are then unused. Absent (the
    /// default): one warm spot, not written to preset.lock.ron.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub motor_k: Option<f64>,
    /// The battery's peak temperature above the skin, kelvin, at the
    /// body's centre (see `motor_k`; absent with `motor_k` set: 0).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub battery_k: Option<f64>,
    /// The spinning rotors' temperature above the air's, kelvin: the pixels
    /// whose ray crosses a rotor disc of the model between its motor and
    /// its rim take it instead of the skin's (blades at about the air's
    /// temperature, cooled by the air they move). Absent: the skin's.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub rotor_k: Option<f64>,
}

fn is_zero(x: &f64) -> bool {
    *x == 0.0
}

impl Default for Signature {
    fn default() -> Self {
        Self::DRONE
    }
}

impl Signature {
    /// A multirotor in flight: plastic/carbon shell a few kelvin over the
    /// air, battery and motors warm (≈ 15 K above the shell), as one spot.
    pub const DRONE: Self = Self {
        skin_k: 4.0,
        emissivity: 0.9,
        spot_k: 15.0,
        spot_share: 0.45,
        cold_share: 0.0,
        motor_k: None,
        battery_k: None,
        rotor_k: None,
    };
    /// A bird: feathers near the air's temperature, a warm body core.
    pub const BIRD: Self = Self {
        skin_k: 2.0,
        emissivity: 0.95,
        spot_k: 10.0,
        spot_share: 0.3,
        cold_share: 0.0,
        motor_k: None,
        battery_k: None,
        rotor_k: None,
    };
    /// An aircraft or helicopter: painted metal skin, a hot engine.
    pub const AIRCRAFT: Self = Self {
        skin_k: 3.0,
        emissivity: 0.8,
        spot_k: 60.0,
        spot_share: 0.15,
        cold_share: 0.0,
        motor_k: None,
        battery_k: None,
        rotor_k: None,
    };
    /// A balloon: fabric warmed by the burner.
    pub const BALLOON: Self = Self {
        skin_k: 20.0,
        emissivity: 0.9,
        spot_k: 10.0,
        spot_share: 0.6,
        cold_share: 0.0,
        motor_k: None,
        battery_k: None,
        rotor_k: None,
    };
}

/// A long-wave infrared camera: the scene's temperatures, the atmosphere,
/// and the camera's noise, blur and gain control.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Thermal {
    /// Air temperature near the camera, kelvin.
    pub air_k: f64,
    /// Ground and scenery temperature, kelvin.
    pub ground_k: f64,
    /// Cloud base temperature, kelvin (clouds are the visible sky's grey pixels).
    pub cloud_k: f64,
    /// The clear sky's band emissivity at the zenith (0–1); towards the
    /// horizon it rises as `1 − (1 − ε_z)^(1/sin e)`, so the sky warms.
    pub zenith_emissivity: f64,
    /// Visible sky pixels with an HSV saturation at or above this are clear
    /// sky; greyer ones are cloud in proportion (0–1).
    pub clear_saturation: f64,
    /// Band extinction of the air, per kilometre: a drone at d km keeps
    /// `exp(−β·d)` of its own radiance and takes the air's for the rest.
    pub extinction_per_km: f64,
    /// The preset's drones.
    pub drone: Signature,
    /// Bird confusers.
    pub bird: Signature,
    /// Aircraft and helicopter confusers.
    pub aircraft: Signature,
    /// Balloon confusers.
    pub balloon: Signature,
    /// Noise-equivalent temperature difference, millikelvin (temporal noise σ).
    pub netd_mk: f64,
    /// Fixed-pattern noise σ, millikelvin: per-pixel and per-column offsets,
    /// the same in every frame of the preset (from the preset seed).
    pub fixed_pattern_mk: f64,
    /// Radial shading of the optics and housing, kelvin at the corners
    /// (negative: darker corners).
    pub shading_k: f64,
    /// The optics' blur, Gaussian σ in pixels (0: none).
    pub blur_px: f64,
    /// Automatic gain control: these percentiles of the frame span levels 0
    /// to 255, unless that takes more than `agc_max_gain`. Over a backplate
    /// the frame keeps the plate's own gain (its levels come back as they
    /// are, what is drawn over it at `agc_max_gain`): unused there.
    pub agc_percentiles: (f64, f64),
    /// The gain control's largest gain, 8-bit levels per kelvin (at the
    /// air's temperature): a low-contrast scene stays low in contrast.
    pub agc_max_gain: f64,
    /// The level the middle of the percentiles' span maps to (over a
    /// backplate, the plate level that stands for the air's temperature).
    pub agc_mid_level: f64,
    /// Bits per pixel of the written frames: 8, or 16 (grey PNG, the gain
    /// control's levels × 257; needs `output.image_format: Png`). 8 is not
    /// written to preset.lock.ron, so datasets made before it resume.
    #[serde(skip_serializing_if = "is_eight")]
    pub bits: u8,
    /// The capture chain after the camera (an earlier compression of the
    /// video, the digitiser's border lines; `sensor::thermal::capture`).
    /// Absent (the default): none, not written to preset.lock.ron.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub capture: Option<Capture>,
    /// The optics' narcissus: a dark spot at the frame's centre, the same in
    /// every frame (`sensor::thermal::narcissus`). Absent (the default):
    /// none, not written to preset.lock.ron.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub narcissus: Option<Narcissus>,
    /// The camera's detail enhancement: each pixel's difference from its
    /// neighbourhood's mean raised, the warm edges' dark halos it draws
    /// (`sensor::thermal::detail`). Absent (the default): none, not written
    /// to preset.lock.ron.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub detail: Option<Detail>,
    /// The scene's temperature texture: a fractal field over the background
    /// (cloud and air structure, scenery), the same wherever the camera
    /// looks (`sensor::thermal::texture`). Absent (the default): none, not
    /// written to preset.lock.ron.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub texture: Option<Texture>,
}

/// The background's temperature texture: Gaussian fractal noise whose
/// power falls as 1/f^`slope` with the spatial frequency f, from two pixels
/// to the frame's size, tied to the sky (a turned camera sees it moved).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Texture {
    /// The field's RMS over a frame, kelvin.
    pub rms_k: f64,
    /// The power spectrum's exponent: 2 puts the same power in every octave,
    /// more puts it in the large features, less in the fine.
    pub slope: f64,
    /// The largest features' size, a share of the frame's height (the
    /// coarsest octave's control points that far apart).
    pub size: f64,
    /// How abruptly the field steps between warmer and colder patches: 0 a
    /// Gaussian field; more soft-clips it (s·g through a tanh-like clip) into
    /// plateaus joined by fronts, as cloud and scenery are; its RMS stays `rms_k`.
    pub sharpness: f64,
    /// Only on the ground and the scenery, each pixel by its share of them (the
    /// background's own: all below the horizon, scenery by its colour), the sky
    /// left as smooth as the sky's gradient and clouds draw it. Needs a
    /// modelled scene (no backplate). False (the default): over the whole
    /// background; not written to preset.lock.ron.
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub ground_only: bool,
}

impl Default for Texture {
    fn default() -> Self {
        Self {
            rms_k: 2.0,
            slope: 3.0,
            size: 0.5,
            sharpness: 3.0,
            ground_only: false,
        }
    }
}

/// The largest texture RMS, kelvin.
pub const MAX_TEXTURE_K: f64 = 50.0;
/// The largest texture sharpness (past it the clip is a step at every zero).
pub const MAX_SHARPNESS: f64 = 20.0;

impl Texture {
    fn validate_into(&self, v: &mut Validator) {
        let (k, s) = (self.rms_k, self.slope);
        v.check(
            k.is_finite() && (0.0..=MAX_TEXTURE_K).contains(&k),
            "thermal.texture.rms_k",
            || format!("{k} must be kelvin in [0, {MAX_TEXTURE_K}]"),
        );
        v.check(
            s.is_finite() && (0.0..=6.0).contains(&s),
            "thermal.texture.slope",
            || format!("{s} must be a spectral exponent in [0, 6]"),
        );
        let z = self.size;
        v.check(
            z.is_finite() && (0.001..=4.0).contains(&z),
            "thermal.texture.size",
            || format!("{z} must be a share of the frame's height in [0.001, 4]"),
        );
        let c = self.sharpness;
        v.check(
            c.is_finite() && (0.0..=MAX_SHARPNESS).contains(&c),
            "thermal.texture.sharpness",
            || format!("{c} must be in [0, {MAX_SHARPNESS}] (0: a Gaussian field)"),
        );
    }
}

/// The narcissus of a cooled thermal camera: the detector sees its own cold
/// reflection in the lens surfaces, strongest on the optical axis, so the
/// frame's centre reads colder than the scene by a spot of Gaussian profile.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Narcissus {
    /// How much colder the centre reads, kelvin (negative: warmer).
    pub depth_k: f64,
    /// The spot's Gaussian σ, a share of half the frame's height.
    pub radius: f64,
}

impl Default for Narcissus {
    fn default() -> Self {
        Self {
            depth_k: 0.0,
            radius: 0.45,
        }
    }
}

/// The largest narcissus depth, kelvin either way.
pub const MAX_NARCISSUS_K: f64 = 100.0;

impl Narcissus {
    fn validate_into(&self, v: &mut Validator) {
        let (d, r) = (self.depth_k, self.radius);
        v.check(
            d.is_finite() && d.abs() <= MAX_NARCISSUS_K,
            "thermal.narcissus.depth_k",
            || format!("{d} must be a depth in kelvin within ±{MAX_NARCISSUS_K}"),
        );
        v.check(
            r.is_finite() && (0.01..=4.0).contains(&r),
            "thermal.narcissus.radius",
            || format!("{r} must be a share of half the frame's height in [0.01, 4]"),
        );
    }
}

/// A thermal camera's detail enhancement (a large-kernel unsharp mask, as
/// the digital detail enhancement of thermal cores): the radiance `v`
/// becomes `v + gain · (v − base)`, `base` the mean of `v` under a tent of
/// half-width `size` × the frame's height. Below a warm tree line the
/// sky's band reads darker, a warm drone's surroundings too.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Detail {
    /// How much the difference from the neighbourhood is raised (0: not).
    pub gain: f64,
    /// The neighbourhood's reach: the tent's half-width, a share of the frame's height.
    pub size: f64,
}

impl Default for Detail {
    fn default() -> Self {
        Self {
            gain: 1.0,
            size: 0.15,
        }
    }
}

/// The largest detail gain.
pub const MAX_DETAIL_GAIN: f64 = 20.0;

impl Detail {
    fn validate_into(&self, v: &mut Validator) {
        let (g, s) = (self.gain, self.size);
        v.check(
            g.is_finite() && (0.0..=MAX_DETAIL_GAIN).contains(&g),
            "thermal.detail.gain",
            || format!("{g} must be in [0, {MAX_DETAIL_GAIN}]"),
        );
        v.check(
            s.is_finite() && (0.01..=1.0).contains(&s),
            "thermal.detail.size",
            || format!("{s} must be a share of the frame's height in [0.01, 1]"),
        );
    }
}

/// The capture chain of a recorded thermal video between the camera's 8-bit
/// frame and the written file: an earlier lossy compression (8×8 DCT
/// quantisation, as an MPEG or JPEG recorder's), then the border lines the
/// digitiser adds at the frame's edges (blanking lines). Each part is off
/// at its default (0 or empty).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Capture {
    /// The earlier compression's quantiser step for each 8×8 block's DC
    /// coefficient, in JPEG's units (the DC is 8 × the block's mean: 8
    /// keeps the mean in whole levels, MPEG-2's 8-bit DC precision); 0: no
    /// earlier compression.
    pub prior_dc_step: f64,
    /// Its step for the other 63 coefficients (JPEG's units, the same for
    /// all); 0: they are kept.
    pub prior_ac_step: f64,
    /// Level offsets of the rows from the top edge, row 0 first.
    pub top_rows: Vec<f64>,
    /// Level offsets of the rows from the bottom edge, the last row first.
    pub bottom_rows: Vec<f64>,
    /// Level offsets of the columns from the left edge, column 0 first.
    pub left_columns: Vec<f64>,
    /// Level offsets of the columns from the right edge, the last first.
    pub right_columns: Vec<f64>,
}

/// The most border lines at each edge.
pub const MAX_BORDER_LINES: usize = 16;

impl Capture {
    fn validate_into(&self, v: &mut Validator) {
        for (field, x) in [
            ("thermal.capture.prior_dc_step", self.prior_dc_step),
            ("thermal.capture.prior_ac_step", self.prior_ac_step),
        ] {
            v.check(x.is_finite() && (0.0..=255.0).contains(&x), field, || {
                format!("{x} must be a quantiser step in [0, 255]")
            });
        }
        for (field, lines) in [
            ("thermal.capture.top_rows", &self.top_rows),
            ("thermal.capture.bottom_rows", &self.bottom_rows),
            ("thermal.capture.left_columns", &self.left_columns),
            ("thermal.capture.right_columns", &self.right_columns),
        ] {
            v.check(lines.len() <= MAX_BORDER_LINES, field, || {
                format!("{} lines: at most {MAX_BORDER_LINES}", lines.len())
            });
            if let Some(x) = lines.iter().find(|x| !(x.is_finite() && x.abs() <= 255.0)) {
                v.check(false, field, || {
                    format!("{x} must be a level offset in [−255, 255]")
                });
            }
        }
    }
}

fn is_eight(bits: &u8) -> bool {
    *bits == 8
}

impl Default for Thermal {
    fn default() -> Self {
        Self {
            air_k: 288.0,
            ground_k: 292.0,
            cloud_k: 275.0,
            zenith_emissivity: 0.25,
            clear_saturation: 0.2,
            extinction_per_km: 0.2,
            drone: Signature::DRONE,
            bird: Signature::BIRD,
            aircraft: Signature::AIRCRAFT,
            balloon: Signature::BALLOON,
            netd_mk: 50.0,
            fixed_pattern_mk: 40.0,
            shading_k: 1.5,
            blur_px: 0.7,
            agc_percentiles: (0.5, 99.9),
            agc_max_gain: 4.0,
            agc_mid_level: 110.0,
            bits: 8,
            capture: None,
            narcissus: None,
            detail: None,
            texture: None,
        }
    }
}

/// The largest temperature accepted anywhere (kelvin).
pub const MAX_TEMPERATURE_K: f64 = 2000.0;

impl Thermal {
    pub(super) fn validate_into(&self, v: &mut Validator) {
        for (field, t) in [
            ("thermal.air_k", self.air_k),
            ("thermal.ground_k", self.ground_k),
            ("thermal.cloud_k", self.cloud_k),
        ] {
            v.check(t.is_finite() && t > 150.0 && t < 400.0, field, || {
                format!("{t} must be kelvin in (150, 400)")
            });
        }
        for (field, x) in [
            ("thermal.zenith_emissivity", self.zenith_emissivity),
            ("thermal.clear_saturation", self.clear_saturation),
        ] {
            v.check(x.is_finite() && x > 0.0 && x <= 1.0, field, || {
                format!("{x} must be in (0, 1]")
            });
        }
        let nonneg = [
            ("thermal.extinction_per_km", self.extinction_per_km, 100.0),
            ("thermal.netd_mk", self.netd_mk, 10_000.0),
            ("thermal.fixed_pattern_mk", self.fixed_pattern_mk, 10_000.0),
            ("thermal.blur_px", self.blur_px, 8.0),
        ];
        for (field, x, max) in nonneg {
            v.check(x.is_finite() && (0.0..=max).contains(&x), field, || {
                format!("{x} must be in [0, {max}]")
            });
        }
        v.check(
            self.shading_k.is_finite() && self.shading_k.abs() <= 50.0,
            "thermal.shading_k",
            || format!("{} must be kelvin in [−50, 50]", self.shading_k),
        );
        v.check(
            self.agc_max_gain.is_finite() && self.agc_max_gain > 0.0 && self.agc_max_gain <= 1e4,
            "thermal.agc_max_gain",
            || {
                format!(
                    "{} must be levels per kelvin in (0, 10000]",
                    self.agc_max_gain
                )
            },
        );
        v.check(
            self.agc_mid_level.is_finite() && (0.0..=255.0).contains(&self.agc_mid_level),
            "thermal.agc_mid_level",
            || format!("{} must be a level in [0, 255]", self.agc_mid_level),
        );
        v.check(self.bits == 8 || self.bits == 16, "thermal.bits", || {
            format!("{} must be 8 or 16", self.bits)
        });
        if let Some(c) = &self.capture {
            c.validate_into(v);
            v.check(self.bits == 8, "thermal.capture", || {
                "works on 8-bit frames: set thermal.bits to 8".into()
            });
        }
        if let Some(n) = &self.narcissus {
            n.validate_into(v);
        }
        if let Some(d) = &self.detail {
            d.validate_into(v);
        }
        if let Some(x) = &self.texture {
            x.validate_into(v);
        }
        let (lo, hi) = self.agc_percentiles;
        v.check(
            lo.is_finite() && hi.is_finite() && 0.0 <= lo && lo < hi && hi <= 100.0,
            "thermal.agc_percentiles",
            || format!("({lo}, {hi}) must be percentiles with 0 ≤ low < high ≤ 100"),
        );
        for (name, s) in [
            ("drone", self.drone),
            ("bird", self.bird),
            ("aircraft", self.aircraft),
            ("balloon", self.balloon),
        ] {
            s.validate_into(v, name, self.air_k);
        }
    }
}

impl Signature {
    /// Whether the warm spot is the object's parts (`motor_k` or `battery_k` set).
    pub fn has_parts(&self) -> bool {
        self.motor_k.is_some() || self.battery_k.is_some()
    }

    fn validate_into(&self, v: &mut Validator, name: &str, air_k: f64) {
        if let Some(k) = self.rotor_k {
            let t = air_k + k;
            v.check(
                t.is_finite() && t > 150.0 && t <= MAX_TEMPERATURE_K,
                &format!("thermal.{name}.rotor_k"),
                || format!("air + {k} = {t} K must be in (150, {MAX_TEMPERATURE_K}]"),
            );
        }
        for (part, k) in [("motor_k", self.motor_k), ("battery_k", self.battery_k)] {
            let Some(k) = k else { continue };
            let hottest = air_k + self.skin_k + k;
            v.check(
                k.is_finite() && k >= 0.0 && hottest <= MAX_TEMPERATURE_K,
                &format!("thermal.{name}.{part}"),
                || format!("{k} must be kelvin ≥ 0 with air + skin + {k} ≤ {MAX_TEMPERATURE_K}"),
            );
        }
        let hottest = air_k + self.skin_k + self.spot_k;
        v.check(
            self.skin_k.is_finite() && self.spot_k.is_finite() && self.spot_k >= 0.0,
            &format!("thermal.{name}.spot_k"),
            || format!("{} must be kelvin ≥ 0", self.spot_k),
        );
        v.check(
            !hottest.is_finite() || (hottest > 150.0 && hottest <= MAX_TEMPERATURE_K),
            &format!("thermal.{name}.skin_k"),
            || format!("air + skin + spot = {hottest} K must be in (150, {MAX_TEMPERATURE_K}]"),
        );
        v.check(
            self.emissivity.is_finite() && self.emissivity > 0.0 && self.emissivity <= 1.0,
            &format!("thermal.{name}.emissivity"),
            || format!("{} must be in (0, 1]", self.emissivity),
        );
        v.check(
            self.spot_share.is_finite() && self.spot_share > 0.0 && self.spot_share <= 10.0,
            &format!("thermal.{name}.spot_share"),
            || format!("{} must be in (0, 10]", self.spot_share),
        );
        let coldest = air_k - self.skin_k;
        v.check(
            self.cold_share.is_finite()
                && (0.0..=1.0).contains(&self.cold_share)
                && (self.cold_share == 0.0 || !coldest.is_finite() || coldest > 150.0),
            &format!("thermal.{name}.cold_share"),
            || {
                format!(
                    "{} must be a share in [0, 1] (and air − skin = {coldest} K above 150 when over 0)",
                    self.cold_share
                )
            },
        );
    }
}
