//! The Batch panel: Generate (with the reason when it cannot run), progress
//! and Cancel while a batch runs, and its outcome with the output folder's
//! path, "Copy path" and "Open output folder".

use std::path::Path;

use egui::{RichText, Ui};

use super::panels::{error_label, group_digits};
use super::runner::{BatchOutcome, BatchRun};
use super::{Command, SwarmshotApp, format_duration};
use crate::pipeline::BatchReport;

impl SwarmshotApp {
    pub(super) fn batch_ui(&mut self, ui: &mut Ui, commands: &mut Vec<Command>) {
        ui.heading("Batch");
        match &self.batch {
            None => self.generate_ui(ui, commands),
            Some(batch) => progress_ui(ui, batch, commands),
        }
        match &self.batch_outcome {
            None => {}
            Some(BatchOutcome::Failed(message)) => {
                error_label(ui, &format!("Batch failed: {}", gui_wording(message)));
            }
            Some(BatchOutcome::Done(report)) => outcome_ui(ui, report, commands),
        }
    }

    /// Why Generate cannot run now, if it cannot.
    fn generate_blocked(&self) -> Option<String> {
        if !self.errors.is_empty() {
            Some(format!(
                "Fix the {} problem(s) listed under Problems first",
                self.errors.len()
            ))
        } else if self.gpu.is_none() {
            Some("No wgpu device: the app started without the wgpu renderer".into())
        } else if self.session.out_dir.trim().is_empty() {
            Some("Choose an output folder in the Output panel".into())
        } else {
            None
        }
    }

    fn generate_ui(&self, ui: &mut Ui, commands: &mut Vec<Command>) {
        let blocked = self.generate_blocked();
        let response = ui
            .add_enabled(blocked.is_none(), egui::Button::new("Generate"))
            .on_hover_text("Render every frame with its labels into the output folder");
        if let Some(reason) = &blocked {
            response.on_disabled_hover_text(reason.as_str());
            ui.weak(reason.as_str());
        } else if response.clicked() {
            commands.push(Command::Generate);
        }
    }
}

/// Progress bar, rate, ETA and Cancel of a running batch.
fn progress_ui(ui: &mut Ui, batch: &BatchRun, commands: &mut Vec<Command>) {
    let status = batch.status();
    let fraction = status.done as f32 / status.total.max(1) as f32;
    ui.add(egui::ProgressBar::new(fraction).text(format!(
        "{} / {} frames",
        group_digits(status.done),
        group_digits(status.total)
    )));
    let eta = status.eta.map_or_else(|| "–".to_string(), format_duration);
    ui.label(format!("{:.1} images/s · ETA {eta}", status.images_per_s));
    if status.cancelling {
        ui.weak("cancelling: finishing the frames in flight…");
    } else if ui
        .button("Cancel")
        .on_hover_text("Stop after the frames in flight; every written image keeps its labels")
        .clicked()
    {
        commands.push(Command::Cancel);
    }
    ui.weak(format!(
        "writing to {} ({})",
        batch.out_dir.display(),
        format_duration(batch.elapsed())
    ));
}

/// What a finished (or cancelled) batch wrote, and where.
fn outcome_ui(ui: &mut Ui, report: &BatchReport, commands: &mut Vec<Command>) {
    let s = &report.stats;
    let head = if report.cancelled {
        "Cancelled"
    } else {
        "Finished"
    };
    ui.label(
        RichText::new(format!(
            "{head}: {} frames in {}",
            group_digits(s.frames),
            format_duration(report.elapsed)
        ))
        .strong(),
    );
    ui.label(format!(
        "train {} · val {} · test {}",
        s.frames_per_split[0], s.frames_per_split[1], s.frames_per_split[2]
    ));
    ui.label(format!(
        "{} boxes: small {} · medium {} · large {}",
        s.boxes, s.small, s.medium, s.large
    ));
    ui.label(format!(
        "{:.2} images/s",
        s.frames as f64 / report.elapsed.as_secs_f64().max(1e-9)
    ));
    if report.cancelled {
        ui.weak("every written image has its labels");
    }
    output_path_ui(ui, &report.out_dir, commands);
}

/// The output folder as selectable text, with Copy path and Open output folder.
fn output_path_ui(ui: &mut Ui, dir: &Path, commands: &mut Vec<Command>) {
    let shown = dir.canonicalize().unwrap_or_else(|_| dir.to_owned());
    let path = shown.display().to_string();
    ui.label("Written to:");
    ui.add(egui::Label::new(RichText::new(&path).monospace()).selectable(true))
        .on_hover_text("Select to copy, or use Copy path");
    ui.horizontal(|ui| {
        if ui
            .button("Copy path")
            .on_hover_text("Put the output folder's path on the clipboard")
            .clicked()
        {
            ui.ctx().copy_text(path.clone());
        }
        if ui
            .button("Open output folder")
            .on_hover_text("Open the folder in the file manager")
            .clicked()
        {
            commands.push(Command::OpenOutputFolder(shown.clone()));
        }
    });
}

/// Batch errors are worded for the command line; say what to do in the app instead.
fn gui_wording(message: &str) -> String {
    message.replace(
        "pass --overwrite",
        "tick \"Overwrite an existing dataset\" in the Output panel",
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_overwrite_advice_names_the_checkbox() {
        let cli = crate::write::OutputError::NotEmpty {
            path: "/tmp/x".into(),
        }
        .to_string();
        let gui = gui_wording(&cli);
        assert!(!gui.contains("--overwrite"), "{gui}");
        assert!(gui.contains("\"Overwrite an existing dataset\""), "{gui}");
    }
}
