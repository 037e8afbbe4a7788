//! The realism panels (issue 21): the camera model, the atmosphere, the
//! drones' appearance and the observer camera. Each section has an on/off
//! checkbox: off is the preset field `None`, so a preset that does not use a
//! stage keeps its bytes. Ranges are `(min, max)` pairs drawn per frame;
//! validation messages come from [`Preset::validate`] and are shown under the
//! row that owns their field path (docs/realism.md describes every field).

use egui::Ui;

use super::panels::{Form, number_row_in, range_row_in};
use crate::preset::Preset;
use crate::preset::appearance::{Appearance, DroneColor};
use crate::preset::atmosphere::Atmosphere;
use crate::preset::camera_model::{CameraModel, Psf};
use crate::preset::observer::ObserverCamera;

/// An optional `(min, max)` range: a checkbox, and the range row while it is on.
pub(super) fn optional_range<N: egui::emath::Numeric>(
    ui: &mut Ui,
    value: &mut Option<(N, N)>,
    default: (N, N),
    name: &str,
    tip: &str,
    speed: f64,
    unit: &str,
) {
    let mut on = value.is_some();
    if ui.checkbox(&mut on, name).on_hover_text(tip).changed() {
        *value = on.then_some(default);
    }
    if let Some(range) = value {
        range_row_in(ui, range, name, tip, speed, unit);
    }
}

/// Camera model: exposure, white balance, PSF, vignetting, chromatic
/// aberration, noise, sensor resolution and JPEG (`camera_model`).
pub fn camera_model_ui(ui: &mut Ui, preset: &mut Preset, form: &mut Form<'_>) {
    let mut on = preset.camera_model.is_some();
    if ui
        .checkbox(&mut on, "Camera model on")
        .on_hover_text(
            "Pass every frame through a camera: optics, sensor noise and image processing, drawn per frame (off: the clean render)",
        )
        .changed()
    {
        preset.camera_model = on.then(CameraModel::default);
    }
    let Some(c) = &mut preset.camera_model else {
        return;
    };
    let p = "camera_model";
    for (value, name, field, tip, speed, unit) in [
        (
            &mut c.exposure_ev,
            "Exposure",
            "exposure_ev",
            "Exposure change in stops: linear light × 2^EV before the sensor clips",
            0.05,
            " EV",
        ),
        (
            &mut c.white_balance_red,
            "White balance red",
            "white_balance_red",
            "Gain of the red channel relative to green (1: neutral)",
            0.01,
            "×",
        ),
        (
            &mut c.white_balance_blue,
            "White balance blue",
            "white_balance_blue",
            "Gain of the blue channel relative to green (1: neutral)",
            0.01,
            "×",
        ),
    ] {
        range_row_in(ui, value, name, tip, speed, unit);
        form.messages(ui, &[&format!("{p}.{field}")]);
    }
    psf_ui(ui, &mut c.psf, form);
    for (value, name, field, tip, speed, unit) in [
        (
            &mut c.vignetting,
            "Vignetting",
            "vignetting",
            "Light lost at the image corner, falling off as r² (0: none, 0.3: corners at 70 %)",
            0.01,
            "",
        ),
        (
            &mut c.saturation,
            "Saturation",
            "saturation",
            "Colour saturation of the camera's processing about each pixel's grey (1: unchanged, 0: grey, 1.2: a vivid look)",
            0.01,
            "×",
        ),
        (
            &mut c.exposure_time_s,
            "Exposure time",
            "exposure_time_s",
            "Motion blur in sequences: how long the shutter is open, at most one frame interval (0: none)",
            0.001,
            " s",
        ),
        (
            &mut c.ca_red_scale,
            "CA red scale",
            "ca_red_scale",
            "Lateral chromatic aberration: the red image's radial scale relative to green (1: none)",
            0.0005,
            "×",
        ),
        (
            &mut c.ca_blue_scale,
            "CA blue scale",
            "ca_blue_scale",
            "Lateral chromatic aberration: the blue image's radial scale relative to green (1: none)",
            0.0005,
            "×",
        ),
        (
            &mut c.shot_noise_gain,
            "Shot noise gain",
            "shot_noise_gain",
            "Shot (Poisson) noise: variance in levels² per linear 8-bit level of signal (0: none)",
            0.01,
            " levels",
        ),
        (
            &mut c.read_noise_levels,
            "Read noise",
            "read_noise_levels",
            "Read (Gaussian) noise σ in linear 8-bit levels (0: none)",
            0.01,
            " levels",
        ),
    ] {
        range_row_in(ui, value, name, tip, speed, unit);
        form.messages(ui, &[&format!("{p}.{field}")]);
    }
    sensor_and_jpeg_ui(ui, c, form);
}

/// The camera model's optional stages: a coarser sensor and the JPEG qualities.
fn sensor_and_jpeg_ui(ui: &mut Ui, c: &mut CameraModel, form: &mut Form<'_>) {
    optional_range(
        ui,
        &mut c.sensor_scale,
        (0.5, 0.5),
        "Sensor scale",
        "A coarser sensor: its side over the output's, in (0, 1]; the picture is sampled by it and scaled back up",
        0.01,
        "",
    );
    form.messages(ui, &["camera_model.sensor_scale"]);
    optional_range(
        ui,
        &mut c.jpeg_quality,
        (70, 95),
        "Camera JPEG quality",
        "JPEG quality drawn per frame (1–100), in place of Output's (JPEG output only)",
        0.2,
        "",
    );
    form.messages(ui, &["camera_model.jpeg_quality"]);
    optional_range(
        ui,
        &mut c.recompress_quality,
        (70, 95),
        "Recompress quality",
        "A first JPEG compression at this quality (1–100), decoded again before the final write",
        0.2,
        "",
    );
    form.messages(ui, &["camera_model.recompress_quality"]);
}

/// The optics' point spread function: none, Gaussian σ or defocus disc radius.
fn psf_ui(ui: &mut Ui, psf: &mut Psf, form: &mut Form<'_>) {
    ui.horizontal(|ui| {
        ui.label("Optics blur")
            .on_hover_text("The lens's point spread function, its size drawn per frame");
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
            range_row_in(
                ui,
                sigma_px,
                "Blur σ",
                "Standard deviation of the Gaussian PSF in output pixels",
                0.01,
                " px",
            );
            form.messages(ui, &["camera_model.psf.sigma_px"]);
        }
        Psf::Disc { radius_px } => {
            range_row_in(
                ui,
                radius_px,
                "Disc radius",
                "Radius of the defocus disc in output pixels",
                0.01,
                " px",
            );
            form.messages(ui, &["camera_model.psf.radius_px"]);
        }
    }
}

/// Atmosphere: haze with range on every object (`atmosphere`).
pub fn atmosphere_ui(ui: &mut Ui, preset: &mut Preset, form: &mut Form<'_>) {
    let mut on = preset.atmosphere.is_some();
    if ui
        .checkbox(&mut on, "Atmosphere on")
        .on_hover_text(
            "Haze with range on drones, ground and horizon (Koschmieder: contrast × exp(−3.912·d/V))",
        )
        .changed()
    {
        preset.atmosphere = on.then(Atmosphere::default);
    }
    if let Some(a) = &mut preset.atmosphere {
        range_row_in(
            ui,
            &mut a.visibility_m,
            "Visibility",
            "Meteorological visibility V in metres, drawn per frame: 2 % of a drone's contrast remains at distance V",
            10.0,
            " m",
        );
        form.messages(ui, &["atmosphere.visibility_m"]);
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
    if ui
        .checkbox(&mut on, "Drone appearance on")
        .on_hover_text(
            "Draw each drone's material from a palette (off: the models' own glTF materials)",
        )
        .changed()
    {
        preset.appearance = on.then(Appearance::default);
    }
    let Some(a) = &mut preset.appearance else {
        return;
    };
    ui.label("Palette weights")
        .on_hover_text("A drone takes colour k with probability weight_k / Σ weights");
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
    for (value, name, field, tip, speed) in [
        (
            &mut a.roughness,
            "Roughness",
            "appearance.roughness",
            "glTF roughness drawn per drone, 0 (mirror) to 1 (matte)",
            0.01,
        ),
        (
            &mut a.metalness,
            "Metalness",
            "appearance.metalness",
            "glTF metalness drawn per drone, 0 to 1",
            0.01,
        ),
    ] {
        range_row_in(ui, value, name, tip, speed, "");
        form.messages(ui, &[field]);
    }
    number_row_in(
        ui,
        &mut a.emissive_share,
        "Lights share",
        "Share of drones that carry lights, 0 to 1 (0: none)",
        0.01,
        "",
    );
    form.messages(ui, &["appearance.emissive_share"]);
    range_row_in(
        ui,
        &mut a.emissive_strength,
        "Light strength",
        "Emission of a drone with lights, as a multiple of its colour (linear), drawn per drone",
        0.01,
        "×",
    );
    form.messages(ui, &["appearance.emissive_strength"]);
    range_row_in(
        ui,
        &mut a.rotor_opacity,
        "Rotor opacity",
        "Opacity of the spinning rotor discs (the models' glTF BLEND materials), drawn per drone: 1 solid, 0.3 a faint blur the sky shows through (MSAA 4 draws it in quarters)",
        0.01,
        "",
    );
    form.messages(ui, &["appearance.rotor_opacity"]);
}

/// The observer camera inside the Camera section (`camera.observer`).
pub fn observer_ui(ui: &mut Ui, preset: &mut Preset, form: &mut Form<'_>) {
    let mut on = preset.camera.observer.is_some();
    if ui
        .checkbox(&mut on, "Observer camera")
        .on_hover_text(
            "A person on the ground looking up at the swarm: horizon low or out of frame, drones against the sky (CameraX/Y/Z are then not used)",
        )
        .changed()
    {
        preset.camera.observer = on.then(ObserverCamera::default);
    }
    let Some(o) = &mut preset.camera.observer else {
        return;
    };
    for (value, name, field, tip, speed, unit) in [
        (
            &mut o.elevation_deg,
            "Elevation",
            "camera.observer.elevation_deg",
            "Line of sight, degrees above the horizon, drawn per frame",
            0.5,
            "°",
        ),
        (
            &mut o.azimuth_deg,
            "Azimuth",
            "camera.observer.azimuth_deg",
            "Line of sight's direction from +z towards +x, degrees, drawn per frame",
            1.0,
            "°",
        ),
        (
            &mut o.distance_m,
            "Distance",
            "camera.observer.distance_m",
            "Distance from the camera to the volume's centre in metres, drawn per frame",
            5.0,
            " m",
        ),
    ] {
        range_row_in(ui, value, name, tip, speed, unit);
        form.messages(ui, &[field]);
    }
    optional_range(
        ui,
        &mut o.size_px,
        (3.0, 6.0),
        "Apparent size",
        "Instead of Distance: the largest model's size at the volume's centre in pixels, drawn per frame",
        0.05,
        " px",
    );
    form.messages(ui, &["camera.observer.size_px"]);
}
