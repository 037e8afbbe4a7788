//! The realism panels (issue 21): the camera model, the atmosphere, the
//! drones' appearance and the observer camera. Each section has an on/off
//! checkbox: off is the preset field `None`, so a preset that does not use a
//! stage keeps its bytes. Ranges are `(min, max)` pairs drawn per frame;
//! validation messages come from [`Preset::validate`] and are shown under the
//! row that owns their field path (docs/realism.md describes every field).
//! Labels, tooltips and units come from the table of fields
//! ([`crate::preset::fields`]).

use egui::{Response, Ui};

use super::panels::{Form, Words, number_row_in};
use crate::preset::Preset;
use crate::preset::appearance::{Appearance, DroneColor};
use crate::preset::atmosphere::Atmosphere;
use crate::preset::camera_model::{CameraModel, Psf};
use crate::preset::fields;
use crate::preset::observer::ObserverCamera;

/// An optional `(min, max)` range: a checkbox, and the range row (with its
/// messages) while it is on.
pub(super) fn optional_range<N: egui::emath::Numeric>(
    ui: &mut Ui,
    form: &mut Form<'_>,
    value: &mut Option<(N, N)>,
    default: (N, N),
    words: &Words,
    speed: f64,
) {
    let mut on = value.is_some();
    if words.checkbox(ui, &mut on).changed() {
        *value = on.then_some(default);
    }
    if let Some(range) = value {
        words.range(ui, form, range, speed);
    } else {
        form.messages(ui, &[&words.path]);
    }
}

/// A section's on/off checkbox, "LABEL on", with the section field's tooltip.
pub(super) fn section_checkbox(ui: &mut Ui, on: &mut bool, path: &'static str) -> Response {
    let f = fields::get(path);
    ui.checkbox(on, format!("{} on", f.label))
        .on_hover_text(f.tooltip)
}

/// Camera model: exposure, white balance, PSF, vignetting, chromatic
/// aberration, noise, sensor resolution and JPEG (`camera_model`).
pub fn camera_model_ui(ui: &mut Ui, preset: &mut Preset, form: &mut Form<'_>) {
    let mut on = preset.camera_model.is_some();
    if section_checkbox(ui, &mut on, "camera_model").changed() {
        preset.camera_model = on.then(CameraModel::default);
    }
    let Some(c) = &mut preset.camera_model else {
        return;
    };
    for (value, path, speed) in [
        (&mut c.exposure_ev, "camera_model.exposure_ev", 0.05),
        (
            &mut c.white_balance_red,
            "camera_model.white_balance_red",
            0.01,
        ),
        (
            &mut c.white_balance_blue,
            "camera_model.white_balance_blue",
            0.01,
        ),
    ] {
        Words::of(path).range(ui, form, value, speed);
    }
    let auto = Words::of("camera_model.auto_exposure");
    optional_range(ui, form, &mut c.auto_exposure, (118.0, 124.0), &auto, 0.5);
    psf_ui(ui, &mut c.psf, form);
    for (value, path, speed) in [
        (&mut c.vignetting, "camera_model.vignetting", 0.01),
        (&mut c.saturation, "camera_model.saturation", 0.01),
        (&mut c.sharpen, "camera_model.sharpen", 0.01),
        (
            &mut c.exposure_time_s,
            "camera_model.exposure_time_s",
            0.001,
        ),
        (&mut c.ca_red_scale, "camera_model.ca_red_scale", 0.0005),
        (&mut c.ca_blue_scale, "camera_model.ca_blue_scale", 0.0005),
        (&mut c.shot_noise_gain, "camera_model.shot_noise_gain", 0.01),
        (
            &mut c.read_noise_levels,
            "camera_model.read_noise_levels",
            0.01,
        ),
    ] {
        Words::of(path).range(ui, form, value, speed);
    }
    sensor_and_jpeg_ui(ui, c, form);
    super::rolling_panel::rolling_shutter_ui(ui, c, form);
}

/// The camera model's optional stages: a coarser sensor and the JPEG qualities.
fn sensor_and_jpeg_ui(ui: &mut Ui, c: &mut CameraModel, form: &mut Form<'_>) {
    let sensor = Words::of("camera_model.sensor_scale");
    optional_range(ui, form, &mut c.sensor_scale, (0.5, 0.5), &sensor, 0.01);
    for (value, path) in [
        (&mut c.jpeg_quality, "camera_model.jpeg_quality"),
        (&mut c.recompress_quality, "camera_model.recompress_quality"),
    ] {
        optional_range(ui, form, value, (70, 95), &Words::of(path), 0.2);
    }
}

/// The optics' point spread function: none, Gaussian σ or defocus disc radius.
fn psf_ui(ui: &mut Ui, psf: &mut Psf, form: &mut Form<'_>) {
    ui.horizontal(|ui| {
        let f = fields::get("camera_model.psf");
        ui.label(f.label).on_hover_text(f.tooltip);
        if ui
            .radio(matches!(psf, Psf::None), "None")
            .on_hover_text("A perfect lens")
            .clicked()
        {
            *psf = Psf::None;
        }
        if ui
            .radio(matches!(psf, Psf::Gaussian { .. }), "Gaussian")
            .on_hover_text("A Gaussian blur of standard deviation σ pixels")
            .clicked()
            && !matches!(psf, Psf::Gaussian { .. })
        {
            *psf = Psf::Gaussian {
                sigma_px: (0.5, 1.0),
            };
        }
        if ui
            .radio(matches!(psf, Psf::Disc { .. }), "Defocus disc")
            .on_hover_text("Defocus: a uniform disc of the given radius in pixels")
            .clicked()
            && !matches!(psf, Psf::Disc { .. })
        {
            *psf = Psf::Disc {
                radius_px: (0.5, 1.5),
            };
        }
    });
    match psf {
        Psf::None => {}
        Psf::Gaussian { sigma_px } => {
            Words::of("camera_model.psf.sigma_px").range(ui, form, sigma_px, 0.01);
        }
        Psf::Disc { radius_px } => {
            Words::of("camera_model.psf.radius_px").range(ui, form, radius_px, 0.01);
        }
    }
}

/// Atmosphere: haze with range on every object (`atmosphere`).
pub fn atmosphere_ui(ui: &mut Ui, preset: &mut Preset, form: &mut Form<'_>) {
    let mut on = preset.atmosphere.is_some();
    if section_checkbox(ui, &mut on, "atmosphere").changed() {
        preset.atmosphere = on.then(Atmosphere::default);
    }
    if let Some(a) = &mut preset.atmosphere {
        Words::of("atmosphere.visibility_m").range(ui, form, &mut a.visibility_m, 10.0);
    }
}

/// The palette's colours, as named in the preset.
const COLOURS: [(DroneColor, &str, &str); 5] = [
    (DroneColor::White, "White", "linear albedo 0.80"),
    (DroneColor::LightGrey, "Light grey", "linear albedo 0.45"),
    (DroneColor::DarkGrey, "Dark grey", "linear albedo 0.12"),
    (DroneColor::Black, "Black", "linear albedo 0.03"),
    (
        DroneColor::Coloured,
        "Coloured",
        "a saturated colour of random hue, linear albedo about 0.3",
    ),
];

/// Drone appearance: palette weights, roughness, metalness, lights (`appearance`).
pub fn appearance_ui(ui: &mut Ui, preset: &mut Preset, form: &mut Form<'_>) {
    let mut on = preset.appearance.is_some();
    if section_checkbox(ui, &mut on, "appearance").changed() {
        preset.appearance = on.then(Appearance::default);
    }
    let Some(a) = &mut preset.appearance else {
        return;
    };
    let palette = fields::get("appearance.palette");
    ui.label(palette.label).on_hover_text(palette.tooltip);
    for (colour, name, what) in COLOURS {
        let index = a.palette.iter().position(|(c, _)| *c == colour);
        let mut weight = index.map_or(0.0, |i| a.palette[i].1);
        let tip = format!("Weight of {name} ({what}); 0: never drawn");
        if number_row_in(ui, &mut weight, name, &tip, 0.05, "").changed() {
            match index {
                Some(i) => a.palette[i].1 = weight,
                None => a.palette.push((colour, weight)),
            }
        }
    }
    form.messages(ui, &["appearance.palette"]);
    Words::of("appearance.roughness").range(ui, form, &mut a.roughness, 0.01);
    Words::of("appearance.metalness").range(ui, form, &mut a.metalness, 0.01);
    Words::of("appearance.emissive_share").number(ui, form, &mut a.emissive_share, 0.01);
    Words::of("appearance.emissive_strength").range(ui, form, &mut a.emissive_strength, 0.01);
    Words::of("appearance.rotor_opacity").range(ui, form, &mut a.rotor_opacity, 0.01);
}

/// The observer camera inside the Camera section (`camera.observer`).
pub fn observer_ui(ui: &mut Ui, preset: &mut Preset, form: &mut Form<'_>) {
    let mut on = preset.camera.observer.is_some();
    if Words::of("camera.observer").checkbox(ui, &mut on).changed() {
        preset.camera.observer = on.then(ObserverCamera::default);
    }
    let Some(o) = &mut preset.camera.observer else {
        return;
    };
    for (value, path, speed) in [
        (&mut o.elevation_deg, "camera.observer.elevation_deg", 0.5),
        (&mut o.azimuth_deg, "camera.observer.azimuth_deg", 1.0),
        (&mut o.distance_m, "camera.observer.distance_m", 5.0),
    ] {
        Words::of(path).range(ui, form, value, speed);
    }
    let size = Words::of("camera.observer.size_px");
    optional_range(ui, form, &mut o.size_px, (3.0, 6.0), &size, 0.05);
    centre_at_ui(ui, form, &mut o.centre_at);
}

/// `camera.observer.centre_at`: on/off, then its x and y as shares of the frame.
fn centre_at_ui(ui: &mut Ui, form: &mut Form<'_>, at: &mut Option<(f64, f64)>) {
    let words = Words::of("camera.observer.centre_at");
    let mut on = at.is_some();
    if words.checkbox(ui, &mut on).changed() {
        *at = on.then_some((0.5, 0.5));
    }
    if let Some((x, y)) = at {
        ui.horizontal(|ui| {
            for (value, axis) in [(x, "x"), (y, "y")] {
                ui.add(
                    egui::DragValue::new(value)
                        .speed(0.005)
                        .range(0.0..=1.0)
                        .prefix(format!("{axis} ")),
                )
                .accessible_name(format!("{} {axis}", words.label))
                .on_hover_text(words.tooltip);
            }
        });
    }
    form.messages(ui, &[&words.path]);
}
