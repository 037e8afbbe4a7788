//! The weather panel (issue 41 item 4): rain or snow in front of the camera
//! (`weather` in the preset; docs/realism.md, "Weather"). Off is the preset
//! field `None`, so a preset without weather keeps its bytes. Switching the
//! kind loads that kind's defaults; every range is `(min, max)`, drawn per
//! frame. Labels, tooltips and units come from the table of fields
//! ([`crate::preset::fields`]).

use egui::Ui;

use super::panels::{Form, Words};
use super::realism_panels::section_checkbox;
use crate::preset::weather::{Weather, WeatherKind};
use crate::preset::{Preset, fields};

/// Weather: the kind, then its ranges (`weather`).
pub fn weather_ui(ui: &mut Ui, preset: &mut Preset, form: &mut Form<'_>) {
    let mut on = preset.weather.is_some();
    if section_checkbox(ui, &mut on, "weather").changed() {
        preset.weather = on.then(Weather::default);
    }
    let Some(w) = &mut preset.weather else {
        return;
    };
    let mut kind = w.kind;
    ui.horizontal(|ui| {
        let f = fields::get("weather.kind");
        ui.label(f.label).on_hover_text(f.tooltip);
        egui::ComboBox::from_id_salt("weather.kind")
            .selected_text(kind.name())
            .show_ui(ui, |ui| {
                for k in [WeatherKind::Rain, WeatherKind::Snow] {
                    ui.selectable_value(&mut kind, k, k.name());
                }
            });
    });
    if kind != w.kind {
        *w = Weather::of_kind(kind);
    }
    Words::of("weather.intensity_per_m3").range(ui, form, &mut w.intensity_per_m3, 0.05);
    Words::of("weather.wind_mps").range(ui, form, &mut w.wind_mps, 0.1);
    Words::of("weather.wind_dir_deg").range(ui, form, &mut w.wind_dir_deg, 1.0);
    Words::of("weather.fall_mps").range(ui, form, &mut w.fall_mps, 0.1);
    Words::of("weather.exposure_s").range(ui, form, &mut w.exposure_s, 0.001);
    Words::of("weather.diameter_mm").range(ui, form, &mut w.diameter_mm, 0.1);
    Words::of("weather.opacity").range(ui, form, &mut w.opacity, 0.01);
    Words::of("weather.depth_m").range(ui, form, &mut w.depth_m, 0.1);
}
