//! The Batch panel: Generate (with the reason when it cannot run), progress
//! and Cancel while a batch runs, and its outcome with the output folder's
//! path, "Copy path" and "Open output folder".

use std::path::Path;

use egui::{RichText, Ui};

use std::time::Duration;

use super::{error_label, group_digits};
use crate::app::runner::{BatchOutcome, BatchRun};
use crate::app::{Command, SwarmshotApp, problems};
use crate::pipeline::{BatchOptions, BatchReport};

impl SwarmshotApp {
    pub(in crate::app) fn batch_ui(&mut self, ui: &mut Ui, commands: &mut Vec<Command>) {
        ui.heading("Batch");
        match &self.batch {
            None => {
                // The output folder and Overwrite beside Generate: the batch's settings in one place.
                super::output::folder_ui(
                    ui,
                    &mut self.session.out_dir,
                    &mut self.session.overwrite,
                    commands,
                );
                self.split_by_ui(ui);
                self.trial_ui(ui);
                self.shard_ui(ui);
                self.generate_ui(ui, commands);
            }
            Some(batch) => progress_ui(ui, batch, commands),
        }
        match &self.batch_outcome {
            None => {}
            Some(BatchOutcome::Failed(e)) => {
                error_label(ui, &format!("Batch failed: {}", gui_wording(e)));
            }
            Some(BatchOutcome::Done(report)) => outcome_ui(ui, report, commands),
        }
        if self.batch.is_none() {
            ui.separator();
            self.merge_ui(ui, commands);
        }
    }

    /// Why Generate cannot run now, if it cannot.
    fn generate_blocked(&self) -> Option<String> {
        if !self.errors.is_empty() {
            Some(format!(
                "Fix the {} listed under Problems first",
                problems::count_problems(self.errors.len())
            ))
        } else if self.merge.is_some() {
            Some("A merge is writing into the output folder; wait until it ends".into())
        } else if self.gpu.is_none() {
            Some("No wgpu device: the app started without the wgpu renderer".into())
        } else if self.session.out_dir.trim().is_empty() {
            Some("Choose an output folder (above Generate)".into())
        } else {
            None
        }
    }

    /// "Trial run: first N frames" (the CLI's `--limit`) and "one frame in K" (`--every`).
    fn trial_ui(&mut self, ui: &mut Ui) {
        let frames = self.resolved.frame_count().max(1);
        ui.horizontal_wrapped(|ui| {
            ui.checkbox(&mut self.session.trial, "Trial run: first")
                .on_hover_text(
                    "Make only the first frames, as `swarmshot batch --limit N` does; \
                     a later Generate without it continues the same folder only with Overwrite",
                );
            ui.add_enabled(
                self.session.trial,
                egui::DragValue::new(&mut self.session.trial_frames).range(1..=frames),
            )
            .accessible_name("Trial frames")
            .on_hover_text("How many frames the trial run makes, from frame 1");
            ui.label(if self.session.trial_frames == 1 {
                "frame"
            } else {
                "frames"
            });
        });
        ui.horizontal_wrapped(|ui| {
            ui.checkbox(&mut self.session.every, "Trial run: one frame in")
                .on_hover_text(
                    "Make only every Kth frame (frames 0, K, 2K, … across the whole sweep), as `swarmshot batch --every K` does",
                );
            ui.add_enabled(
                self.session.every,
                egui::DragValue::new(&mut self.session.every_k).range(1..=frames),
            )
            .accessible_name("Every Kth frame")
            .on_hover_text("K: the step between the frames made (1: every frame)");
        });
    }

    /// What each split keeps whole (`output.split.by`, a preset field).
    fn split_by_ui(&mut self, ui: &mut Ui) {
        use crate::preset::SplitBy;
        let by = &mut self.session.preset.output.split.by;
        let name = |b: SplitBy| match b {
            SplitBy::Frame => "each frame",
            SplitBy::CameraPose => "camera pose",
            SplitBy::Environment => "environment",
            SplitBy::SweepPoint => "sweep point",
        };
        ui.horizontal(|ui| {
            let tip = "What a split keeps whole: no val or test frame shares its group with a train frame (output.split.by)";
            ui.label("Split by").on_hover_text(tip);
            egui::ComboBox::from_id_salt("split by")
                .selected_text(name(*by))
                .show_ui(ui, |ui| {
                    for b in [
                        SplitBy::Frame,
                        SplitBy::CameraPose,
                        SplitBy::Environment,
                        SplitBy::SweepPoint,
                    ] {
                        ui.selectable_value(by, b, name(b));
                    }
                })
                .response
                .on_hover_text(tip);
        });
    }

    /// "Shard K of N", the CLI's `--shard K/N` (K shown from 1).
    fn shard_ui(&mut self, ui: &mut Ui) {
        let s = &mut self.session;
        ui.horizontal_wrapped(|ui| {
            ui.checkbox(&mut s.shard, "Shard").on_hover_text(
                "Make one part of the frames, as `swarmshot batch --shard K/N` does on a cluster; \
                     join the finished shard folders with Merge below",
            );
            s.shard_count = s.shard_count.max(1);
            let mut k = s.shard_index.min(s.shard_count - 1) + 1;
            ui.add_enabled(
                s.shard,
                egui::DragValue::new(&mut k).range(1..=s.shard_count),
            )
            .accessible_name("Shard number")
            .on_hover_text("Which shard this Generate makes (from 1)");
            ui.label("of");
            ui.add_enabled(
                s.shard,
                egui::DragValue::new(&mut s.shard_count).range(1..=10_000),
            )
            .accessible_name("Shard count")
            .on_hover_text("How many shards the frames are cut into");
            s.shard_index = (k - 1).min(s.shard_count - 1);
        });
    }

    /// The shard Generate makes, if any (`--shard K/N`, K from 0).
    pub(in crate::app) fn batch_shard(&self) -> Option<crate::write::shard::Shard> {
        let s = &self.session;
        s.shard.then(|| crate::write::shard::Shard {
            index: s.shard_index.min(s.shard_count.max(1) - 1),
            count: s.shard_count.max(1),
        })
    }

    /// Merge: finished shard folders joined into the output folder (`swarmshot merge`).
    pub(in crate::app) fn merge_ui(&mut self, ui: &mut Ui, commands: &mut Vec<Command>) {
        egui::CollapsingHeader::new("Merge shards")
            .default_open(false)
            .show(ui, |ui| {
                ui.label("Shard folders, one per line:");
                ui.add(
                    egui::TextEdit::multiline(&mut self.session.merge_shards)
                        .desired_rows(3)
                        .desired_width(f32::INFINITY),
                )
                .on_hover_text("The output folders of finished shards (relative paths are relative to the folder swarmshot was started in)");
                let shards = self.merge_shard_dirs();
                let blocked = if self.merge.is_some() {
                    Some("merging…".to_string())
                } else if shards.is_empty() {
                    Some("Name the shard folders first".to_string())
                } else if self.session.out_dir.trim().is_empty() {
                    Some("Choose an output folder (above Generate)".to_string())
                } else {
                    None
                };
                let response = ui
                    .add_enabled(blocked.is_none(), egui::Button::new("Merge into the output folder"))
                    .on_hover_text(format!(
                        "Join the shards into {} with the same code as `swarmshot merge` (files hard-linked where possible)",
                        self.session.out_dir.trim()
                    ));
                match &blocked {
                    Some(reason) => {
                        ui.weak(reason.as_str());
                    }
                    None if response.clicked() => commands.push(Command::Merge),
                    None => {}
                }
                match &self.merge_outcome {
                    Some(Ok(line)) => {
                        ui.label(line.as_str());
                    }
                    Some(Err(e)) => {
                        error_label(ui, &format!("Merge failed: {}", gui_wording(e)));
                    }
                    None => {}
                }
            });
    }

    /// The shard folders named in the merge field.
    pub(in crate::app) fn merge_shard_dirs(&self) -> Vec<std::path::PathBuf> {
        self.session
            .merge_shards
            .lines()
            .map(str::trim)
            .filter(|l| !l.is_empty())
            .map(std::path::PathBuf::from)
            .collect()
    }

    /// The frames Generate asks for: the trial's first N, or all.
    pub(in crate::app) fn batch_limit(&self) -> Option<u64> {
        self.session
            .trial
            .then_some(self.session.trial_frames.max(1))
    }

    /// Every Kth frame only, when the trial run asks for it.
    pub(in crate::app) fn batch_every(&self) -> Option<u64> {
        self.session.every.then_some(self.session.every_k.max(1))
    }

    /// What Generate hands to `run_batch`: the folder and the Batch panel's choices.
    pub fn batch_options(&self) -> BatchOptions {
        BatchOptions {
            limit: self.batch_limit(),
            overwrite: self.session.overwrite,
            shard: self.batch_shard(),
            every: self.batch_every(),
            ..BatchOptions::new(crate::app::paths::typed(&self.session.out_dir))
        }
    }

    /// What Generate will make, in words: the frames the trial run and the shard leave.
    pub fn generate_tip(&self) -> String {
        let frames = self.resolved.frame_count();
        let all = group_digits(frames);
        let mut what = match (self.batch_every().filter(|&k| k > 1), self.batch_limit()) {
            (None, None) => format!("all {all} frames"),
            (None, Some(n)) => format!(
                "the first {} of the {all} frames",
                group_digits(n.min(frames))
            ),
            (Some(k), limit) => {
                let picked = frames.div_ceil(k);
                let made = limit.map_or(picked, |n| n.min(picked));
                format!(
                    "{} of the {all} frames, one in {k} (frames 1, {}, {}, …)",
                    group_digits(made),
                    group_digits(k + 1),
                    group_digits(2 * k + 1)
                )
            }
        };
        if let Some(shard) = self.batch_shard() {
            what.push_str(&format!(
                ", shard {} of {} of them",
                shard.index + 1,
                shard.count
            ));
        }
        format!(
            "Render {what} with their labels into {}",
            self.session.out_dir.trim()
        )
    }

    fn generate_ui(&self, ui: &mut Ui, commands: &mut Vec<Command>) {
        let blocked = self.generate_blocked();
        let response = ui
            .add_enabled(blocked.is_none(), egui::Button::new("Generate"))
            .on_hover_text(self.generate_tip());
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
    ui.label(RichText::new(outcome_headline(report)).strong());
    ui.label(format!(
        "train {} · val {} · test {}",
        s.frames_per_split[0], s.frames_per_split[1], s.frames_per_split[2]
    ));
    ui.label(format!(
        "{} boxes: small {} · medium {} · large {}",
        s.boxes, s.small, s.medium, s.large
    ));
    if report.cancelled {
        ui.weak("every written image has its labels");
    }
    output_path_ui(ui, &report.out_dir, commands);
}

/// One honest line: what this run made, from where, how fast (over the frames it made).
fn outcome_headline(report: &BatchReport) -> String {
    if report.already_complete() {
        return format!(
            "Already complete — nothing to do: the folder holds all {} frames",
            group_digits(report.stats.frames)
        );
    }
    let made = format!(
        "made {} {} in {} ({:.1} images/s)",
        group_digits(report.made),
        if report.made == 1 { "frame" } else { "frames" },
        format_duration(report.elapsed),
        report.images_per_s()
    );
    let head = if report.cancelled {
        "Cancelled"
    } else {
        "Finished"
    };
    match report.resumed_at() {
        // Frames are numbered from 1 in the app, as under the preview.
        Some(first) => format!(
            "{head}: resumed at frame {}, {made}",
            group_digits(first + 1)
        ),
        None => format!("{head}: {made}"),
    }
}

/// Seconds "Copied" stays next to Copy path.
const COPIED_SHOWN_S: f64 = 2.0;

/// The output folder as selectable text, with Copy path and Open output folder.
fn output_path_ui(ui: &mut Ui, dir: &Path, commands: &mut Vec<Command>) {
    let shown = dir.canonicalize().unwrap_or_else(|_| dir.to_owned());
    let path = shown.display().to_string();
    ui.label("Written to:");
    ui.add(egui::Label::new(RichText::new(&path).monospace()).selectable(true))
        .on_hover_text("Select to copy, or use Copy path");
    ui.horizontal(|ui| {
        let copy = ui
            .button("Copy path")
            .on_hover_text("Put the output folder's path on the clipboard");
        // "Copied" shows for a moment after the click.
        let copied_at = copy.id.with("copied at");
        let now = ui.input(|i| i.time);
        if copy.clicked() {
            ui.ctx().copy_text(path.clone());
            ui.data_mut(|d| d.insert_temp(copied_at, now));
        }
        if let Some(at) = ui.data(|d| d.get_temp::<f64>(copied_at)) {
            let left = COPIED_SHOWN_S - (now - at);
            if left > 0.0 {
                ui.weak("Copied");
                ui.ctx()
                    .request_repaint_after(std::time::Duration::from_secs_f64(left));
            }
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
fn gui_wording(message: &impl std::fmt::Display) -> String {
    message.to_string().replace(
        "pass --overwrite",
        "tick \"Overwrite an existing dataset\" above Generate",
    )
}

/// 75 s → "1:15", 3 725 s → "1:02:05".
fn format_duration(d: Duration) -> String {
    let s = d.as_secs();
    if s >= 3600 {
        format!("{}:{:02}:{:02}", s / 3600, s / 60 % 60, s % 60)
    } else {
        format!("{}:{:02}", s / 60, s % 60)
    }
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
