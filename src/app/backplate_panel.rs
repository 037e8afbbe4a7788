//! The backplate panel (issue 21 item 4): photographic backgrounds from a
//! folder of the user's still frames (`backplate` in the preset; off is
//! `None`, so a preset without plates keeps its bytes). Validation messages
//! come from [`Preset::validate`]; a folder that cannot be read is reported
//! when the pipeline loads it (docs/realism.md, "Photographic backgrounds").

use std::path::PathBuf;

use egui::Ui;

use super::panels::{Form, number_row_in, range_row_in};
use crate::preset::Preset;
use crate::preset::backplate::{Backplate, PlateHorizon};

/// Backplates: folder, the plates' camera, the sun, mirroring.
pub fn backplate_ui(ui: &mut Ui, preset: &mut Preset, form: &mut Form<'_>) {
    let mut on = preset.backplate.is_some();
    if ui
        .checkbox(&mut on, "Backplates on")
        .on_hover_text(
            "Your own still frames of empty sky and horizon as the backgrounds, one drawn per frame; the camera takes their field of view and horizon",
        )
        .changed()
    {
        preset.backplate = on.then(Backplate::default);
    }
    let Some(b) = &mut preset.backplate else {
        return;
    };
    ui.horizontal(|ui| {
        let tip = "Folder of .jpg/.jpeg/.png plates (a plate's NAME.plate.ron may set its own hfov_deg and horizon)";
        let label = ui.label("Folder").on_hover_text(tip);
        let mut text = b.folder.display().to_string();
        if ui
            .text_edit_singleline(&mut text)
            .labelled_by(label.id)
            .on_hover_text(tip)
            .changed()
        {
            b.folder = PathBuf::from(text);
        }
    });
    form.messages(ui, &["backplate.folder"]);
    number_row_in(
        ui,
        &mut b.hfov_deg,
        "Horizontal field of view",
        "Of the camera that took the plates, degrees (the frames are rendered with it)",
        0.2,
        "°",
    );
    form.messages(ui, &["backplate.hfov_deg"]);
    horizon_ui(ui, b);
    form.messages(ui, &["backplate.horizon", "backplate.elevation_deg"]);
    for (value, name, field, tip) in [
        (
            &mut b.sun_elevation_deg,
            "Sun elevation",
            "backplate.sun_elevation_deg",
            "The sun that lights the drones: degrees above the horizon, drawn per frame",
        ),
        (
            &mut b.sun_azimuth_deg,
            "Sun azimuth",
            "backplate.sun_azimuth_deg",
            "Relative to the line of sight (0: ahead, the drones backlit; 180: behind the camera), drawn per frame",
        ),
    ] {
        range_row_in(ui, value, name, tip, 1.0, "°");
        form.messages(ui, &[field]);
    }
    ui.checkbox(&mut b.flip, "Mirror half of the frames")
        .on_hover_text("Flip the plate left-right in a random half of the frames");
}

/// The plates' horizon: a row (fraction of the height from the top) or unknown.
fn horizon_ui(ui: &mut Ui, b: &mut Backplate) {
    let mut known = matches!(b.horizon, PlateHorizon::Row(_));
    ui.horizontal(|ui| {
        ui.label("Horizon")
            .on_hover_text("Where the horizon line is in the plates");
        let row = ui.radio_value(&mut known, true, "at a row").changed();
        let unknown = ui.radio_value(&mut known, false, "unknown").changed();
        if row || unknown {
            b.horizon = if known {
                PlateHorizon::Row(0.85)
            } else {
                PlateHorizon::Unknown
            };
        }
    });
    match &mut b.horizon {
        PlateHorizon::Row(row) => {
            number_row_in(
                ui,
                row,
                "Horizon row",
                "Fraction of the plate's height from its top (0: top, 1: bottom); the camera's pitch follows",
                0.005,
                "",
            );
        }
        PlateHorizon::Unknown => range_row_in(
            ui,
            &mut b.elevation_deg,
            "Elevation",
            "The line of sight's elevation, degrees above the horizon, drawn per frame",
            0.5,
            "°",
        ),
    }
}
