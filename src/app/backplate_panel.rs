//! The backplate panel (issue 21 item 4): photographic backgrounds from a
//! folder of the user's still frames (`backplate` in the preset; off is
//! `None`, so a preset without plates keeps its bytes). Validation messages
//! come from [`Preset::validate`]; a folder that cannot be read is reported
//! when the pipeline loads it (docs/realism.md, "Photographic backgrounds").

use std::path::PathBuf;

use egui::Ui;

use super::panels::{Form, Words, number_row_in};
use super::realism_panels::section_checkbox;
use crate::preset::backplate::{Backplate, PlateHorizon};
use crate::preset::{Preset, fields};

/// Backplates: folder, the plates' camera, the sun, mirroring.
pub fn backplate_ui(
    ui: &mut Ui,
    preset: &mut Preset,
    form: &mut Form<'_>,
    commands: &mut Vec<crate::app::Command>,
) {
    let mut on = preset.backplate.is_some();
    if section_checkbox(ui, &mut on, "backplate").changed() {
        preset.backplate = on.then(Backplate::default);
    }
    form.messages(ui, &["backplate"]);
    let Some(b) = &mut preset.backplate else {
        return;
    };
    ui.horizontal(|ui| {
        let f = fields::get("backplate.folder");
        let label = ui.label(f.label).on_hover_text(f.tooltip);
        // Shown without `./` or `name/..` steps, except while typed in; stored as
        // written until edited.
        let id = ui.make_persistent_id("backplate.folder");
        let mut text = if ui.memory(|m| m.has_focus(id)) {
            b.folder.display().to_string()
        } else {
            super::paths::lexical(&b.folder).display().to_string()
        };
        if ui
            .add(egui::TextEdit::singleline(&mut text).id(id))
            .labelled_by(label.id)
            .on_hover_text(f.tooltip)
            .changed()
        {
            b.folder = PathBuf::from(text);
        }
        if ui
            .button("Browse…")
            .on_hover_text("Choose the backplate folder")
            .clicked()
        {
            commands.push(crate::app::Command::BrowseFolder(
                crate::app::files::FilePurpose::BackplateFolder,
            ));
        }
    });
    form.messages(ui, &["backplate.folder"]);
    Words::of("backplate.hfov_deg").number(ui, form, &mut b.hfov_deg, 0.2);
    horizon_ui(ui, b);
    form.messages(ui, &["backplate.horizon", "backplate.elevation_deg"]);
    for (value, path) in [
        (&mut b.sun_elevation_deg, "backplate.sun_elevation_deg"),
        (&mut b.sun_azimuth_deg, "backplate.sun_azimuth_deg"),
    ] {
        Words::of(path).range(ui, form, value, 1.0);
    }
    Words::of("backplate.flip").checkbox(ui, &mut b.flip);
}

/// The plates' horizon: a row (fraction of the height from the top) or unknown.
fn horizon_ui(ui: &mut Ui, b: &mut Backplate) {
    let mut known = matches!(b.horizon, PlateHorizon::Row(_));
    ui.horizontal(|ui| {
        let f = fields::get("backplate.horizon");
        ui.label(f.label).on_hover_text(f.tooltip);
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
        PlateHorizon::Unknown => {
            let f = fields::get("backplate.elevation_deg");
            super::panels::range_row_in(ui, &mut b.elevation_deg, f.label, f.tooltip, 0.5, f.unit);
        }
    }
}
