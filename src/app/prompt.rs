//! The unsaved-changes prompt: New, Open, Examples and closing the window
//! ask Save / Discard / Cancel before an edited preset is replaced.

use std::path::{Path, PathBuf};

use egui::{Key, RichText};

/// What would replace the preset being edited.
#[derive(Clone, Debug, PartialEq)]
pub enum Replace {
    /// The default preset.
    New,
    /// A preset file.
    Path(PathBuf),
    /// An example from presets/, opened as an untitled copy.
    Example(PathBuf),
    /// Closing the window.
    Close,
}

impl Replace {
    /// "… before {doing}?"
    fn doing(&self) -> String {
        let file = |p: &Path| {
            p.file_name().map_or_else(
                || p.display().to_string(),
                |f| f.to_string_lossy().into_owned(),
            )
        };
        match self {
            Self::New => "starting a new preset".into(),
            Self::Path(p) => format!("opening {}", file(p)),
            Self::Example(p) => format!("opening the example {}", file(p)),
            Self::Close => "closing swarmshot".into(),
        }
    }
}

/// The user's answer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Answer {
    Save,
    Discard,
    Cancel,
}

/// Show the prompt for `replace`; `Some` once the user answered.
pub fn prompt_ui(ctx: &egui::Context, preset_name: &str, replace: &Replace) -> Option<Answer> {
    let mut answer = None;
    egui::Modal::new(egui::Id::unique("swarmshot unsaved prompt")).show(ctx, |ui| {
        ui.set_max_width(420.0);
        ui.heading("Unsaved changes");
        ui.label(format!(
            "The preset \"{preset_name}\" has changes that are not saved. Save them before {}?",
            replace.doing()
        ));
        ui.add_space(8.0);
        ui.horizontal(|ui| {
            if ui
                .button(RichText::new("Save").strong())
                .on_hover_text("Save the preset (asks for a file if it has none), then go on")
                .clicked()
            {
                answer = Some(Answer::Save);
            }
            if ui
                .button("Discard")
                .on_hover_text("Throw the changes away and go on")
                .clicked()
            {
                answer = Some(Answer::Discard);
            }
            if ui
                .button("Cancel")
                .on_hover_text("Keep editing this preset")
                .clicked()
            {
                answer = Some(Answer::Cancel);
            }
        });
    });
    if ctx.input_mut(|i| i.consume_key(egui::Modifiers::NONE, Key::Escape)) {
        answer = Some(Answer::Cancel);
    }
    answer
}
