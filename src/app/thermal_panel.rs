//! The thermal camera panel (issue 41 item 1): grey long-wave infrared
//! frames instead of visible ones (`thermal` in the preset; docs/realism.md,
//! "Thermal camera"). Off is the preset field `None`, so a preset without it
//! keeps its bytes. Validation messages are shown under the row that owns
//! their field path; labels, tooltips and units come from the table of
//! fields ([`crate::preset::fields`]).

use egui::{DragValue, Ui};

use super::panels::{Form, Words};
use super::realism_panels::section_checkbox;
use crate::preset::Preset;
use crate::preset::thermal::{Capture, Detail, Narcissus, Signature, Texture, Thermal};

/// Thermal camera: scene temperatures, objects' signatures, the camera's noise, blur and gain.
pub fn thermal_ui(ui: &mut Ui, preset: &mut Preset, form: &mut Form<'_>) {
    let mut on = preset.thermal.is_some();
    if section_checkbox(ui, &mut on, "thermal").changed() {
        preset.thermal = on.then(Thermal::default);
    }
    let Some(t) = &mut preset.thermal else {
        return;
    };
    for (path, value, speed) in [
        ("thermal.air_k", &mut t.air_k, 0.1),
        ("thermal.ground_k", &mut t.ground_k, 0.1),
        ("thermal.cloud_k", &mut t.cloud_k, 0.1),
        ("thermal.zenith_emissivity", &mut t.zenith_emissivity, 0.01),
        ("thermal.clear_saturation", &mut t.clear_saturation, 0.01),
        ("thermal.extinction_per_km", &mut t.extinction_per_km, 0.01),
        ("thermal.netd_mk", &mut t.netd_mk, 1.0),
        ("thermal.fixed_pattern_mk", &mut t.fixed_pattern_mk, 1.0),
        ("thermal.shading_k", &mut t.shading_k, 0.1),
        ("thermal.blur_px", &mut t.blur_px, 0.01),
        ("thermal.agc_max_gain", &mut t.agc_max_gain, 0.1),
        ("thermal.agc_mid_level", &mut t.agc_mid_level, 1.0),
    ] {
        Words::of(path).number(ui, form, value, speed);
    }
    Words::of("thermal.agc_percentiles").range(ui, form, &mut t.agc_percentiles, 0.1);
    bits_row(ui, form, &mut t.bits);
    texture_rows(ui, form, &mut t.texture);
    narcissus_rows(ui, form, &mut t.narcissus);
    detail_rows(ui, form, &mut t.detail);
    capture_rows(ui, form, &mut t.capture);
    signature_rows(ui, form, "thermal.drone", &mut t.drone);
    part_rows(ui, form, DRONE_PARTS, &mut t.drone);
    signature_rows(ui, form, "thermal.bird", &mut t.bird);
    signature_rows(ui, form, "thermal.aircraft", &mut t.aircraft);
    part_rows(ui, form, AIRCRAFT_PARTS, &mut t.aircraft);
    signature_rows(ui, form, "thermal.balloon", &mut t.balloon);
}

/// The fields of a kind's warm parts: motors, battery, rotors.
const DRONE_PARTS: [&str; 3] = [
    "thermal.drone.motor_k",
    "thermal.drone.battery_k",
    "thermal.drone.rotor_k",
];
const AIRCRAFT_PARTS: [&str; 3] = [
    "thermal.aircraft.motor_k",
    "thermal.aircraft.battery_k",
    "thermal.aircraft.rotor_k",
];

/// A kind's warm parts (the models' rotor hubs, the body's centre, the
/// rotor discs): each optional, unset by default (the one warm spot).
/// Ticking one sets it to a typical flight value in kelvin (motors 30 and
/// battery 10 above the skin, rotors at the air's temperature).
fn part_rows(ui: &mut Ui, form: &mut Form<'_>, paths: [&'static str; 3], s: &mut Signature) {
    let [motor, battery, rotor] = paths;
    for (path, value, typical) in [
        (motor, &mut s.motor_k, 30.0),
        (battery, &mut s.battery_k, 10.0),
        (rotor, &mut s.rotor_k, 0.0),
    ] {
        let words = Words::of(path);
        ui.horizontal(|ui| {
            let mut on = value.is_some();
            if words.checkbox(ui, &mut on).changed() {
                *value = on.then_some(typical);
            }
            if let Some(v) = value {
                ui.add(DragValue::new(v).speed(0.1).suffix(words.unit))
                    .on_hover_text(words.tooltip);
            }
        });
        form.messages(ui, &[&words.path]);
    }
}

/// The background's temperature texture: off (absent), or its RMS, slope, size,
/// sharpness and whether it lies on the ground alone (ticking it sets the default: 2 K,
/// slope 3, half the frame's height, sharpness 3, the whole background).
fn texture_rows(ui: &mut Ui, form: &mut Form<'_>, texture: &mut Option<Texture>) {
    let Some(x) = optional(ui, form, "thermal.texture", texture, Texture::default) else {
        return;
    };
    for (path, value, speed) in [
        ("thermal.texture.rms_k", &mut x.rms_k, 0.05),
        ("thermal.texture.slope", &mut x.slope, 0.05),
        ("thermal.texture.size", &mut x.size, 0.01),
        ("thermal.texture.sharpness", &mut x.sharpness, 0.05),
    ] {
        Words::of(path).number(ui, form, value, speed);
    }
    let ground = Words::of("thermal.texture.ground_only");
    ground.checkbox(ui, &mut x.ground_only);
    form.messages(ui, &[&ground.path]);
}

/// An optional part's checkbox (unticked: absent; ticking it sets `typical()`) and its
/// messages; the part while it is on.
fn optional<'a, T>(
    ui: &mut Ui,
    form: &mut Form<'_>,
    path: &'static str,
    part: &'a mut Option<T>,
    typical: impl FnOnce() -> T,
) -> Option<&'a mut T> {
    let words = Words::of(path);
    let mut on = part.is_some();
    if words.checkbox(ui, &mut on).changed() {
        *part = on.then(typical);
    }
    form.messages(ui, &[&words.path]);
    part.as_mut()
}

/// The optics' narcissus: off (absent), or its depth and radius (ticking it sets a 4 K
/// dark centre of the default radius).
fn narcissus_rows(ui: &mut Ui, form: &mut Form<'_>, narcissus: &mut Option<Narcissus>) {
    let typical = || Narcissus {
        depth_k: TYPICAL_NARCISSUS_K,
        ..Narcissus::default()
    };
    let Some(n) = optional(ui, form, "thermal.narcissus", narcissus, typical) else {
        return;
    };
    Words::of("thermal.narcissus.depth_k").number(ui, form, &mut n.depth_k, 0.1);
    Words::of("thermal.narcissus.radius").number(ui, form, &mut n.radius, 0.01);
}

/// The camera's detail enhancement: off (absent), or its gain and reach (ticking it sets
/// the defaults: gain 1, a reach of 0.15 of the height).
fn detail_rows(ui: &mut Ui, form: &mut Form<'_>, detail: &mut Option<Detail>) {
    let Some(d) = optional(ui, form, "thermal.detail", detail, Detail::default) else {
        return;
    };
    Words::of("thermal.detail.gain").number(ui, form, &mut d.gain, 0.05);
    Words::of("thermal.detail.size").number(ui, form, &mut d.size, 0.01);
}

/// The depth a ticked narcissus starts at, kelvin.
const TYPICAL_NARCISSUS_K: f64 = 4.0;
/// The DC step a ticked capture chain starts at: MPEG-2's 8-bit DC precision.
const TYPICAL_PRIOR_DC_STEP: f64 = 8.0;

/// The recording's capture chain: off (absent), or the earlier compression's steps and
/// each edge's border lines as the preset has them (ticking it sets a DC step of 8, the
/// other coefficients kept, no border lines; the fit sets the lines from footage).
fn capture_rows(ui: &mut Ui, form: &mut Form<'_>, capture: &mut Option<Capture>) {
    let typical = || Capture {
        prior_dc_step: TYPICAL_PRIOR_DC_STEP,
        ..Capture::default()
    };
    let Some(c) = optional(ui, form, "thermal.capture", capture, typical) else {
        return;
    };
    Words::of("thermal.capture.prior_dc_step").number(ui, form, &mut c.prior_dc_step, 0.1);
    Words::of("thermal.capture.prior_ac_step").number(ui, form, &mut c.prior_ac_step, 0.1);
    for (path, lines) in [
        ("thermal.capture.top_rows", &mut c.top_rows),
        ("thermal.capture.bottom_rows", &mut c.bottom_rows),
        ("thermal.capture.left_columns", &mut c.left_columns),
        ("thermal.capture.right_columns", &mut c.right_columns),
    ] {
        if lines.is_empty() {
            continue;
        }
        let words = Words::of(path);
        ui.horizontal(|ui| {
            ui.label(&words.label).on_hover_text(words.tooltip);
            for v in lines.iter_mut() {
                ui.add(DragValue::new(v).speed(0.5).suffix(words.unit))
                    .on_hover_text(words.tooltip);
            }
        });
        form.messages(ui, &[&words.path]);
    }
}

/// Bits per written pixel: 8, or 16 (grey PNG; validation's message on
/// `thermal.bits`, that 16 needs PNG output, shows under the row).
fn bits_row(ui: &mut Ui, form: &mut Form<'_>, bits: &mut u8) {
    let words = Words::of("thermal.bits");
    ui.horizontal(|ui| {
        ui.label(&words.label).on_hover_text(words.tooltip);
        for (value, text) in [(8, "8 bits"), (16, "16 bits")] {
            ui.radio_value(bits, value, text)
                .on_hover_text(words.tooltip);
        }
    });
    form.messages(ui, &[&words.path]);
}

/// One kind's signature: its heading, then skin, emissivity, warm spot and cold share.
fn signature_rows(ui: &mut Ui, form: &mut Form<'_>, kind: &'static str, s: &mut Signature) {
    let f = crate::preset::fields::get(kind);
    ui.label(f.label).on_hover_text(f.tooltip);
    let rows: [(&'static str, &mut f64, f64); 5] = match kind {
        "thermal.drone" => [
            ("thermal.drone.skin_k", &mut s.skin_k, 0.1),
            ("thermal.drone.emissivity", &mut s.emissivity, 0.01),
            ("thermal.drone.spot_k", &mut s.spot_k, 0.1),
            ("thermal.drone.spot_share", &mut s.spot_share, 0.01),
            ("thermal.drone.cold_share", &mut s.cold_share, 0.01),
        ],
        "thermal.bird" => [
            ("thermal.bird.skin_k", &mut s.skin_k, 0.1),
            ("thermal.bird.emissivity", &mut s.emissivity, 0.01),
            ("thermal.bird.spot_k", &mut s.spot_k, 0.1),
            ("thermal.bird.spot_share", &mut s.spot_share, 0.01),
            ("thermal.bird.cold_share", &mut s.cold_share, 0.01),
        ],
        "thermal.aircraft" => [
            ("thermal.aircraft.skin_k", &mut s.skin_k, 0.1),
            ("thermal.aircraft.emissivity", &mut s.emissivity, 0.01),
            ("thermal.aircraft.spot_k", &mut s.spot_k, 0.1),
            ("thermal.aircraft.spot_share", &mut s.spot_share, 0.01),
            ("thermal.aircraft.cold_share", &mut s.cold_share, 0.01),
        ],
        _ => [
            ("thermal.balloon.skin_k", &mut s.skin_k, 0.1),
            ("thermal.balloon.emissivity", &mut s.emissivity, 0.01),
            ("thermal.balloon.spot_k", &mut s.spot_k, 0.1),
            ("thermal.balloon.spot_share", &mut s.spot_share, 0.01),
            ("thermal.balloon.cold_share", &mut s.cold_share, 0.01),
        ],
    };
    for (path, value, speed) in rows {
        Words::of(path).number(ui, form, value, speed);
    }
}
