//! The Skybox section: the gradient sky, the paper's procedural environments,
//! and a note for skies only a preset file can describe.

use egui::Ui;

use super::{Form, Words, field_row};
use crate::preset::{Preset, Sky, fields};
use crate::sky::EnvironmentStyle;

pub fn skybox_ui(ui: &mut Ui, preset: &mut Preset, form: &mut Form<'_>) {
    sky_picker_ui(ui, &mut preset.sky);
    match &mut preset.sky {
        Sky::Gradient {
            sun_elevation_deg,
            sun_azimuth_deg,
            zenith,
            horizon,
        } => gradient_ui(
            ui,
            [sun_elevation_deg, sun_azimuth_deg],
            [zenith, horizon],
            form,
        ),
        Sky::Procedural {
            environment,
            sun_elevation_deg,
            sun_azimuth_deg,
            cloud_cover,
            sun_ev,
            ..
        } => {
            let style = environment.style();
            procedural_ui(
                ui,
                &style,
                [sun_elevation_deg, sun_azimuth_deg],
                cloud_cover,
                form,
            );
            field_row(ui, sun_ev, "sky.sun_ev", 0.05);
            form.messages(ui, &["sky.sun_ev"]);
        }
        Sky::Random {
            choices,
            azimuth_offset_deg,
            sun_elevation_deg,
            cloud_cover,
            exposure_ev,
            sun_ev,
        } => random_ui(
            ui,
            choices.len(),
            azimuth_offset_deg,
            [sun_elevation_deg, cloud_cover, exposure_ev, sun_ev],
            form,
        ),
        Sky::Image { .. } => {
            ui.label("This sky is edited in the preset file (see docs/environments.md).");
        }
    }
}

/// A random sky: its choices stay in the preset file; the ranges drawn per
/// frame are edited here (each optional one switched on with its checkbox).
fn random_ui(
    ui: &mut Ui,
    choices: usize,
    azimuth_offset_deg: &mut (f64, f64),
    [sun_elevation_deg, cloud_cover, exposure_ev, sun_ev]: [&mut Option<(f64, f64)>; 4],
    form: &mut Form<'_>,
) {
    use crate::app::realism_panels::optional_range;
    ui.label(format!(
        "Each frame picks one of {choices} skies (listed in the preset file, see docs/environments.md) and draws:"
    ));
    Words::of("sky.azimuth_offset_deg").range(ui, form, azimuth_offset_deg, 1.0);
    for (value, path, default, speed) in [
        (
            sun_elevation_deg,
            "sky.sun_elevation_deg",
            (10.0, 60.0),
            0.5,
        ),
        (cloud_cover, "sky.cloud_cover", (0.0, 0.5), 0.01),
        (exposure_ev, "sky.exposure_ev", (-1.0, 1.0), 0.05),
        (sun_ev, "sky.sun_ev", (-0.5, 0.5), 0.05),
    ] {
        optional_range(ui, form, value, default, &Words::of(path), speed);
    }
}

/// The Skybox combo box: Gradient or one of the procedural environments.
fn sky_picker_ui(ui: &mut Ui, sky: &mut Sky) {
    use crate::sky::EnvironmentName;
    // The paper's seven skyboxes (procedural), the gradient, and what only a preset file can say.
    let current = match &*sky {
        Sky::Gradient { .. } => "Gradient".to_string(),
        Sky::Procedural { environment, .. } => environment.as_str().to_string(),
        Sky::Image { .. } => "Image (preset file)".to_string(),
        Sky::Random { .. } => "Random (preset file)".to_string(),
    };
    ui.horizontal(|ui| {
        let tip = fields::get("sky").tooltip;
        ui.label("Skybox").on_hover_text(tip);
        egui::ComboBox::from_id_salt("skybox")
            .selected_text(current)
            .show_ui(ui, |ui| {
                if ui
                    .selectable_label(matches!(sky, Sky::Gradient { .. }), "Gradient")
                    .on_hover_text("Gradient sky with a sun disc")
                    .clicked()
                {
                    *sky = Sky::default();
                }
                for name in EnvironmentName::ALL {
                    let selected = matches!(&*sky, Sky::Procedural { environment, .. } if *environment == name);
                    if ui
                        .selectable_label(selected, name.as_str())
                        .on_hover_text("Procedural environment: physically based sky, clouds, ground and horizon")
                        .clicked()
                    {
                        *sky = Sky::procedural(name);
                    }
                }
            })
            .response
            .on_hover_text(tip);
    });
}

/// The gradient sky: sun direction and the zenith and horizon colours.
fn gradient_ui(
    ui: &mut Ui,
    sun_deg: [&mut f64; 2],
    colours: [&mut (f32, f32, f32); 2],
    form: &mut Form<'_>,
) {
    let [sun_elevation_deg, sun_azimuth_deg] = sun_deg;
    let [zenith, horizon] = colours;
    ui.label("Gradient sky with a sun disc; the sun also lights the drones");
    field_row(ui, sun_elevation_deg, "sky.sun_elevation_deg", 0.5);
    form.messages(ui, &["sky.sun_elevation_deg"]);
    field_row(ui, sun_azimuth_deg, "sky.sun_azimuth_deg", 1.0);
    form.messages(ui, &["sky.sun_azimuth_deg"]);
    for (name, colour, field) in [
        ("Zenith colour", zenith, "sky.zenith"),
        ("Horizon colour", horizon, "sky.horizon"),
    ] {
        ui.horizontal(|ui| {
            let tip = "Linear RGB of the sky at this height";
            ui.label(name).on_hover_text(tip);
            let mut rgb = [colour.0, colour.1, colour.2];
            if ui
                .color_edit_button_rgb(&mut rgb)
                .accessible_name(name)
                .on_hover_text(tip)
                .changed()
            {
                *colour = (rgb[0], rgb[1], rgb[2]);
            }
        });
        form.messages(ui, &[field]);
    }
}

/// A procedural environment: sun and cloud cover, the environment's own until edited.
fn procedural_ui(
    ui: &mut Ui,
    style: &EnvironmentStyle,
    sun_deg: [&mut Option<f64>; 2],
    cloud_cover: &mut Option<f64>,
    form: &mut Form<'_>,
) {
    let [sun_elevation_deg, sun_azimuth_deg] = sun_deg;
    let mut elevation = sun_elevation_deg.unwrap_or(style.sun_elevation_deg);
    if field_row(ui, &mut elevation, "sky.sun_elevation_deg", 0.5).changed() {
        *sun_elevation_deg = Some(elevation);
    }
    form.messages(ui, &["sky.sun_elevation_deg"]);
    let mut azimuth = sun_azimuth_deg.unwrap_or(style.sun_azimuth_deg);
    if field_row(ui, &mut azimuth, "sky.sun_azimuth_deg", 1.0).changed() {
        *sun_azimuth_deg = Some(azimuth);
    }
    form.messages(ui, &["sky.sun_azimuth_deg"]);
    let mut cover = cloud_cover.unwrap_or(style.cloud_cover);
    if field_row(ui, &mut cover, "sky.cloud_cover", 0.01).changed() {
        *cloud_cover = Some(cover);
    }
    form.messages(ui, &["sky.cloud_cover"]);
}
