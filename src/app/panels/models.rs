//! The Models section: built-in and glTF models with their real size and class.

use egui::{DragValue, RichText, Ui};

use super::{Form, error_label};
use crate::app::Command;
use crate::model::builtin::NAMES as BUILTIN_NAMES;
use crate::preset::{ModelSource, ModelSpec, Preset, fields};

pub fn models_ui(
    ui: &mut Ui,
    preset: &mut Preset,
    form: &mut Form<'_>,
    load_error: Option<&str>,
    commands: &mut Vec<Command>,
) {
    let mut remove = None;
    for (i, model) in preset.models.iter_mut().enumerate() {
        ui.horizontal(|ui| {
            let name = match &model.source {
                ModelSource::Builtin(name) => format!("built-in {name}"),
                ModelSource::File(path) => path.file_name().map_or_else(
                    || path.display().to_string(),
                    |f| f.to_string_lossy().into_owned(),
                ),
            };
            ui.label(RichText::new(format!("{}. {name}", i + 1)).strong())
                .on_hover_text(model.source.to_string());
            if ui
                .small_button("Remove")
                .on_hover_text("Remove this model from the preset")
                .clicked()
            {
                remove = Some(i);
            }
        });
        ui.horizontal(|ui| {
            let tip = fields::get("models[].size_m").tooltip;
            ui.label("Size").on_hover_text(tip);
            ui.add(DragValue::new(&mut model.size_m).speed(0.01).suffix(" m"))
                .accessible_name(format!("Model {} size", i + 1))
                .on_hover_text(tip);
            let tip = fields::get("models[].class").tooltip;
            ui.label("Class").on_hover_text(tip);
            ui.add(egui::TextEdit::singleline(&mut model.class).desired_width(80.0))
                .accessible_name(format!("Model {} class", i + 1))
                .on_hover_text(tip);
        });
        form.messages(
            ui,
            &[
                &format!("models[{i}].size_m"),
                &format!("models[{i}].class"),
                &format!("models[{i}].source"),
            ],
        );
    }
    if let Some(i) = remove {
        preset.models.remove(i);
    }
    ui.horizontal(|ui| {
        egui::ComboBox::from_id_salt("add built-in")
            .selected_text("Add built-in")
            .show_ui(ui, |ui| {
                for name in BUILTIN_NAMES {
                    if ui.selectable_label(false, *name).clicked() {
                        preset.models.push(ModelSpec {
                            source: ModelSource::Builtin((*name).to_string()),
                            ..ModelSpec::default()
                        });
                    }
                }
            })
            .response
            .accessible_name("Add built-in model")
            .on_hover_text("Add one of the models that ship with swarmshot");
        if ui
            .button("Add glTF…")
            .on_hover_text("Add a .gltf/.glb model file (any unit: it is scaled to its real size)")
            .clicked()
        {
            commands.push(Command::AddGltf);
        }
    });
    form.messages(ui, &["models"]);
    if let Some(message) = load_error {
        error_label(ui, message);
    }
}
