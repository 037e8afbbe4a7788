//! The parameter panels, named as in the paper's "3D Model Shots Generator"
//! (section 3.3): Models, Placement (XCount, YCount, ZCount, LoadFactor or
//! randomized), Attitude, Camera (CameraX/Y/Z), Scene rotation
//! (PlaneRX/RY/RZ), Skybox and Output.
//!
//! Each panel edits the preset in place; actions that reach beyond the preset
//! (file dialogs) are returned as [`Command`]s. Validation messages come from
//! [`Preset::validate`] and are shown under the widget that owns their field
//! path ([`Form`]); any message no widget claimed is listed at the end.

mod batch;
mod camera;
mod models;
mod output;
mod placement;
mod skybox;

pub use camera::{attitude_ui, camera_ui, plane_ui};
pub use models::models_ui;
pub use output::output_ui;
pub use placement::{placement_ui, sequence_ui};
pub use skybox::skybox_ui;

use egui::{DragValue, Response, RichText, Ui};

use crate::preset::sweep::SweepRange;
use crate::preset::{FieldError, Preset, fields};

/// The validation messages of the preset being edited, and which of them a widget has shown.
pub struct Form<'a> {
    errors: &'a [FieldError],
    shown: Vec<bool>,
    /// Scroll this field's message into view (a Problems link was clicked).
    scroll_to: Option<&'a str>,
    scrolled: bool,
}

impl<'a> Form<'a> {
    pub fn new(errors: &'a [FieldError], scroll_to: Option<&'a str>) -> Self {
        Self {
            errors,
            shown: vec![false; errors.len()],
            scroll_to,
            scrolled: false,
        }
    }

    /// Show the messages of these exact field paths, in the error colour.
    pub fn messages(&mut self, ui: &mut Ui, fields: &[&str]) {
        for (i, e) in self.errors.iter().enumerate() {
            if fields.contains(&e.field.as_str()) {
                self.shown[i] = true;
                let response = error_label(ui, &e.message);
                self.scroll_if_wanted(&e.field, &response);
            }
        }
    }

    /// Messages that no widget showed (e.g. limits on the whole preset).
    pub fn rest(&mut self, ui: &mut Ui) {
        for (i, e) in self.errors.iter().enumerate() {
            if !self.shown[i] {
                self.shown[i] = true;
                let response = error_label(ui, &e.to_string());
                self.scroll_if_wanted(&e.field, &response);
            }
        }
    }

    /// Whether the wanted message was scrolled to in this pass.
    pub fn scrolled(&self) -> bool {
        self.scrolled
    }

    fn scroll_if_wanted(&mut self, field: &str, response: &Response) {
        if !self.scrolled && self.scroll_to == Some(field) {
            response.scroll_to_me(Some(egui::Align::Center));
            response.clone().highlight();
            self.scrolled = true;
        }
    }
}

pub fn error_label(ui: &mut Ui, message: &str) -> Response {
    ui.label(RichText::new(message).color(ui.visuals().error_fg_color))
}

/// `label  [number unit]` for a preset field: its label, tooltip and unit come
/// from the table of fields ([`fields`]); the label names the number (for
/// screen readers and tests).
pub(super) fn field_row<N: egui::emath::Numeric>(
    ui: &mut Ui,
    value: &mut N,
    path: &'static str,
    speed: f64,
) -> Response {
    let f = fields::get(path);
    number_row_in(ui, value, f.label, f.tooltip, speed, f.unit)
}

/// A field's words from the table of fields, with the path its messages name:
/// for an item of a list (`confusers[].count`, item 2) the label's `{n}` is the
/// item's number ("Confuser 3 count") and the path `confusers[2].count`.
pub(in crate::app) struct Words {
    pub label: String,
    pub tooltip: &'static str,
    pub unit: &'static str,
    pub path: String,
}

impl Words {
    pub fn of(path: &'static str) -> Self {
        let f = fields::get(path);
        Self {
            label: f.label.to_string(),
            tooltip: f.tooltip,
            unit: f.unit,
            path: path.to_string(),
        }
    }

    /// The words of item `i` (from 0) of a `[]` path.
    pub fn item(path: &'static str, i: usize) -> Self {
        let f = fields::get(path);
        Self {
            label: f.label.replace("{n}", &(i + 1).to_string()),
            tooltip: f.tooltip,
            unit: f.unit,
            path: path.replacen("[]", &format!("[{i}]"), 1),
        }
    }

    /// `label  [number unit]` and the field's messages.
    pub fn number<N: egui::emath::Numeric>(
        &self,
        ui: &mut Ui,
        form: &mut Form<'_>,
        value: &mut N,
        speed: f64,
    ) -> Response {
        let response = number_row_in(ui, value, &self.label, self.tooltip, speed, self.unit);
        form.messages(ui, &[&self.path]);
        response
    }

    /// `label  min [..] max [..]` and the field's messages.
    pub fn range<N: egui::emath::Numeric>(
        &self,
        ui: &mut Ui,
        form: &mut Form<'_>,
        value: &mut (N, N),
        speed: f64,
    ) {
        range_row_in(ui, value, &self.label, self.tooltip, speed, self.unit);
        form.messages(ui, &[&self.path]);
    }

    /// A checkbox with the field's label and tooltip.
    pub fn checkbox(&self, ui: &mut Ui, on: &mut bool) -> Response {
        ui.checkbox(on, self.label.as_str())
            .on_hover_text(self.tooltip)
    }
}

/// `label  [number]` with a unit after the number (`"°"`, `" m"`; `""` for none).
pub(in crate::app) fn number_row_in<N: egui::emath::Numeric>(
    ui: &mut Ui,
    value: &mut N,
    name: &str,
    tip: &str,
    speed: f64,
    unit: &str,
) -> Response {
    ui.horizontal(|ui| {
        let label = ui.label(name).on_hover_text(tip);
        ui.add(DragValue::new(value).speed(speed).suffix(unit))
            .labelled_by(label.id)
            .on_hover_text(tip)
    })
    .inner
}

/// `label  min [..] max [..]` for an inclusive (min, max) preset field, its
/// words and unit from the table of fields.
pub(super) fn field_range_row<N: egui::emath::Numeric>(
    ui: &mut Ui,
    value: &mut (N, N),
    path: &'static str,
    speed: f64,
) {
    let f = fields::get(path);
    range_row_in(ui, value, f.label, f.tooltip, speed, f.unit);
}

/// `label  min [..] max [..]` with a unit after each number (`" m"`, `" px"`; `""` for none).
pub(in crate::app) fn range_row_in<N: egui::emath::Numeric>(
    ui: &mut Ui,
    value: &mut (N, N),
    name: &str,
    tip: &str,
    speed: f64,
    unit: &str,
) {
    ui.horizontal(|ui| {
        ui.label(name).on_hover_text(tip);
        ui.add(
            DragValue::new(&mut value.0)
                .speed(speed)
                .prefix("min ")
                .suffix(unit),
        )
        .accessible_name(format!("{name} min"))
        .on_hover_text(tip);
        ui.add(
            DragValue::new(&mut value.1)
                .speed(speed)
                .prefix("max ")
                .suffix(unit),
        )
        .accessible_name(format!("{name} max"))
        .on_hover_text(tip);
    });
}

/// A paper start/end/step sweep row (CameraZ, PlaneRY, …) for a sweep field of
/// the table of fields, with its value count and messages.
pub(super) fn sweep_row(
    ui: &mut Ui,
    form: &mut Form<'_>,
    range: &mut SweepRange,
    path: &'static str,
    speed: f64,
) {
    let f = fields::get(path);
    named_sweep_row(ui, form, range, [f.label, path, f.tooltip, f.unit], speed);
}

/// [`sweep_row`] with its own label and tooltip (`[label, path, tooltip, unit]`).
pub(super) fn named_sweep_row(
    ui: &mut Ui,
    form: &mut Form<'_>,
    range: &mut SweepRange,
    words: [&str; 4],
    speed: f64,
) {
    let [name, field, tip, unit] = words;
    ui.horizontal(|ui| {
        ui.label(name).on_hover_text(tip);
        for (part, value) in [
            ("start", &mut range.start),
            ("end", &mut range.end),
            ("step", &mut range.step),
        ] {
            ui.add(
                DragValue::new(value)
                    .speed(speed)
                    .prefix(format!("{part} "))
                    .suffix(unit),
            )
            .accessible_name(format!("{name} {part}"))
            .on_hover_text(format!("{name} {part}: {tip}"));
        }
        if let Ok(n) = range.count() {
            ui.weak(if n == 1 {
                "1 value".to_string()
            } else {
                format!("{} values", group_digits(n))
            });
        }
    });
    form.messages(ui, &[field, &format!("{field}.step")]);
}

/// 4860 → "4 860" (the and SI's digit grouping).
pub fn group_digits(n: u64) -> String {
    let digits = n.to_string();
    let mut out = String::new();
    for (i, c) in digits.chars().enumerate() {
        if i > 0 && (digits.len() - i).is_multiple_of(3) {
            out.push(' ');
        }
        out.push(c);
    }
    out
}

/// `value` with as many decimals as `range`'s start and step have (at most 6),
/// so 0.6 + 3·0.2 reads "1.2", not "1.2000000000000002".
pub fn format_to_step(value: f64, range: &SweepRange) -> String {
    let decimals = |x: f64| {
        let text = format!("{:.6}", x.abs());
        let fraction = text.split('.').nth(1).unwrap_or("");
        fraction.trim_end_matches('0').len()
    };
    let places = decimals(range.start).max(decimals(range.step));
    let text = format!("{value:.places$}");
    // No "-0" for a value that rounds to zero.
    if text
        .trim_start_matches('-')
        .chars()
        .all(|c| c == '0' || c == '.')
    {
        text.trim_start_matches('-').to_string()
    } else {
        text
    }
}

/// The general fields above the panels: name, seed, repeats.
pub fn general_ui(ui: &mut Ui, preset: &mut Preset, form: &mut Form<'_>) {
    ui.horizontal(|ui| {
        let name = fields::get("name");
        let label = ui.label(name.label).on_hover_text(name.tooltip);
        ui.text_edit_singleline(&mut preset.name)
            .labelled_by(label.id);
    });
    field_row(ui, &mut preset.seed, "seed", 1.0);
    field_row(ui, &mut preset.repeats, "repeats", 0.1);
    form.messages(ui, &["name", "seed", "repeats"]);
}

#[cfg(test)]
mod tests {
    use crate::preset::fields;

    /// The sources of every panel that edits preset fields.
    const SOURCES: [&str; 11] = [
        include_str!("mod.rs"),
        include_str!("models.rs"),
        include_str!("placement.rs"),
        include_str!("camera.rs"),
        include_str!("skybox.rs"),
        include_str!("output.rs"),
        include_str!("../realism_panels.rs"),
        include_str!("../backplate_panel.rs"),
        include_str!("../clutter_panel.rs"),
        include_str!("../confuser_panel.rs"),
        include_str!("../weather_panel.rs"),
    ];

    /// Every dotted field path these panels name (for a row's words or its
    /// messages) resolves in the table of fields to a label, not to itself.
    #[test]
    fn the_panels_field_paths_are_in_the_table() {
        let mut checked = 0;
        for source in SOURCES {
            for literal in source.split('"').skip(1).step_by(2) {
                let is_path = literal.contains('.')
                    && literal.starts_with(|c: char| c.is_ascii_lowercase())
                    && literal.chars().all(|c| {
                        c.is_ascii_lowercase() || c.is_ascii_digit() || "._[]{}".contains(c)
                    })
                    && !literal.contains("{field}")
                    && !literal.ends_with(".rs");
                if is_path {
                    let path = literal.replace("{i}", "0");
                    assert_ne!(
                        fields::label_of(&path),
                        path,
                        "{literal} is not in the table"
                    );
                    checked += 1;
                }
            }
        }
        assert!(
            checked > 100,
            "only {checked} paths found: the scan is broken"
        );
    }

    /// A path whose words a widget takes from the table is an entry of its
    /// own, not a parent's label with the path's last part added (which
    /// `get` would show as the raw path).
    #[test]
    fn the_panels_words_come_from_entries_of_the_table() {
        let mut checked = 0;
        for source in SOURCES {
            for call in [
                "fields::get(\"",
                "Words::of(\"",
                "Words::item(\"",
                "section_checkbox(ui, &mut on, \"",
            ] {
                for rest in source.split(call).skip(1) {
                    let path = rest.split('"').next().unwrap_or_default();
                    if path.is_empty() {
                        continue; // the calls' own text in this list
                    }
                    assert!(fields::field(path).is_some(), "{path} is not in the table");
                    checked += 1;
                }
            }
        }
        assert!(
            checked > 50,
            "only {checked} calls found: the scan is broken"
        );
    }
}
