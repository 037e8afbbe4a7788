//! The "Fit to footage" window (issue 36 item 8): `swarmshot fit` in the app. The user names a
//! folder of real frames and an output folder; the library's own entry points,
//! [`crate::fit::prepare`] then [`crate::fit::finish`] with a [`FitOptions`] (the
//! same calls `swarmshot fit` makes), run on a [`Job`] thread. The window shows the
//! stage, then the report before (the base preset) and after (the fitted preset),
//! and the app opens `fitted.ron` (through the unsaved-changes prompt).
//!
//! Only the public options, entry points and their results are used here, so the
//! fit's internals can change without this window changing. Cancel stops between
//! rounds (`finish` checks the flag); reading the footage and writing the plates
//! (`prepare`) runs to its end.

use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};

use egui::{RichText, Ui};

use super::job::{Job, JobSlot, Stage};
use crate::fit::FitOptions;
use crate::gap::folder::DroneClasses;
use crate::render::GpuContext;

/// What a finished fit shows.
#[derive(Debug)]
pub struct FitDone {
    /// The written preset, `OUT/fitted.ron`.
    pub fitted: PathBuf,
    /// The base preset's gap report (round 00), as a table.
    pub before: Option<String>,
    /// The fitted preset's gap report, as a table.
    pub after: Option<String>,
    /// The round whose preset is `fitted.ron` (`None`: no rounds, the first fit).
    pub best_round: Option<usize>,
    /// What `swarmshot fit` prints as warnings ([`crate::fit::Prepared::warnings`]).
    pub warnings: Vec<String>,
}

/// The window's state.
pub struct FitPanel {
    pub open: bool,
    /// Browse… was clicked for the real frames or the output folder.
    pub browse_real: bool,
    pub browse_out: bool,
    /// Folder of real frames (YOLO labels in a sibling labels/ or beside them).
    pub real_dir: String,
    /// The fit's output folder (empty or missing, or an earlier fit's with Overwrite).
    pub out_dir: String,
    /// The preset the fit starts from.
    pub base: String,
    /// Frames rendered per round.
    pub sample: u64,
    /// Rounds at most (0: plates and the first fit only).
    pub rounds: usize,
    /// At most this many real frames (0: all).
    pub max_frames: usize,
    /// The labels' classes that are drones, as typed (`all`, or ids such as `0,2`).
    pub classes: String,
    pub unlabelled_ok: bool,
    pub overwrite: bool,
    job: JobSlot<FitDone>,
    /// A fit ended with this preset: the app opens it ([`FitPanel::take_fitted`]).
    fitted: Option<PathBuf>,
}

impl Default for FitPanel {
    fn default() -> Self {
        let defaults = FitOptions::new("", "");
        Self {
            open: false,
            browse_real: false,
            browse_out: false,
            real_dir: String::new(),
            out_dir: String::new(),
            base: defaults.base.display().to_string(),
            sample: defaults.sample,
            rounds: defaults.rounds,
            max_frames: defaults.max_frames,
            classes: defaults.classes.to_string(),
            unlabelled_ok: defaults.unlabelled_ok,
            overwrite: defaults.overwrite,
            job: JobSlot::default(),
            fitted: None,
        }
    }
}

impl FitPanel {
    /// The finished fit, if the last run succeeded.
    pub fn done(&self) -> Option<&FitDone> {
        self.job.done()
    }

    /// The last run's error, if it failed.
    pub fn error(&self) -> Option<String> {
        self.job.error().map(ToString::to_string)
    }

    /// A fit is running.
    pub fn is_running(&self) -> bool {
        self.job.is_running()
    }

    /// Whether a fit started since the last call (the app then pauses playback).
    pub fn take_started(&mut self) -> bool {
        self.job.take_started()
    }

    /// The preset a fit just wrote, once: the app opens it.
    pub fn take_fitted(&mut self) -> Option<PathBuf> {
        self.fitted.take()
    }

    fn poll(&mut self) {
        if let Some(Ok(done)) = self.job.poll() {
            self.fitted = Some(done.fitted.clone());
        }
    }

    /// The window (when open); `gpu` renders the rounds.
    pub fn show(&mut self, ctx: &egui::Context, gpu: Option<&GpuContext>) {
        self.poll();
        if !self.open {
            return;
        }
        let mut open = self.open;
        egui::Window::new("Fit to footage")
            .open(&mut open)
            .default_size([900.0, 560.0])
            .vscroll(true)
            .show(ctx, |ui| self.contents(ui, gpu));
        self.open = open;
    }

    fn contents(&mut self, ui: &mut Ui, gpu: Option<&GpuContext>) {
        ui.label(
            "Fits a preset to your own footage (as `swarmshot fit`): the frames become backplates with their labelled drones removed, the camera and the drones' size are fitted, then rounds of render, gap report and adjust. See docs/realism.md.",
        );
        let running = self.job.is_running();
        ui.add_enabled_ui(!running, |ui| self.inputs_ui(ui));
        ui.horizontal(|ui| {
            let why_not = self.why_not(gpu);
            let run = ui
                .add_enabled(!running && why_not.is_none(), egui::Button::new("Run fit"))
                .on_hover_text(
                    "Fit the preset in the background; fitted.ron opens when it is done",
                );
            if let Some(why) = &why_not
                && !running
            {
                ui.weak(why.as_str());
            }
            if run.clicked() {
                self.start(gpu, ui.ctx());
            }
            if let Some(job) = self.job.running() {
                job.status_ui(ui, true);
            }
        });
        ui.separator();
        match self.job.outcome() {
            Some(Ok(done)) => done_ui(ui, done, &mut self.fitted),
            Some(Err(e)) => {
                ui.label(
                    RichText::new(format!("Fit failed: {e}")).color(ui.visuals().error_fg_color),
                );
            }
            None => {}
        }
    }

    fn inputs_ui(&mut self, ui: &mut Ui) {
        egui::Grid::new("fit inputs").num_columns(2).show(ui, |ui| {
            ui.label("Real frames folder");
            ui.horizontal(|ui| {
                ui.add(egui::TextEdit::singleline(&mut self.real_dir).desired_width(360.0))
                    .accessible_name("Real frames folder")
                    .on_hover_text("JPEG/PNG frames; YOLO labels in a sibling labels/ folder or beside them");
                self.browse_real |= ui.button("Browse…").on_hover_text("Choose the folder of real frames").clicked();
            });
            ui.end_row();
            ui.label("Output folder");
            ui.horizontal(|ui| {
                ui.add(egui::TextEdit::singleline(&mut self.out_dir).desired_width(360.0))
                    .accessible_name("Output folder")
                    .on_hover_text("plates/, fitted.ron, footage.json, fit.json and rounds/NN/ are written here; it must be empty or missing");
                self.browse_out |= ui.button("Browse…").on_hover_text("Choose the fit's output folder").clicked();
                ui.checkbox(&mut self.overwrite, "Overwrite")
                    .on_hover_text("Replace an earlier fit's files in this folder");
            });
            ui.end_row();
            ui.label("Base preset");
            ui.add(egui::TextEdit::singleline(&mut self.base).desired_width(360.0))
                .accessible_name("Base preset")
                .on_hover_text("The preset the fit starts from");
            ui.end_row();
            ui.label("Rounds");
            ui.horizontal(|ui| {
                ui.add(egui::DragValue::new(&mut self.rounds).range(0..=20))
                    .accessible_name("Rounds");
                ui.label("at most, of");
                ui.add(egui::DragValue::new(&mut self.sample).range(1..=10_000))
                    .accessible_name("Frames per round");
                ui.label("frames each (0 rounds: plates and the first fit, no rendering)");
            });
            ui.end_row();
            ui.label("Real frames");
            ui.horizontal(|ui| {
                ui.add(egui::DragValue::new(&mut self.max_frames).range(0..=100_000))
                    .accessible_name("At most real frames");
                ui.label("at most (0: all)");
                ui.checkbox(&mut self.unlabelled_ok, "Frames without labels are fine")
                    .on_hover_text("Drones in unlabelled frames stay in the plates, unlabelled");
            });
            ui.end_row();
            ui.label("Drone classes");
            ui.add(egui::TextEdit::singleline(&mut self.classes).desired_width(120.0))
                .accessible_name("Drone classes")
                .on_hover_text(
                    "The labels' classes that are drones: all, or class ids such as 0,2 (rows of other classes, birds or aircraft, stay in the plates and are not measured)",
                );
            ui.end_row();
        });
    }

    /// Why a fit cannot start now, in words.
    fn why_not(&self, gpu: Option<&GpuContext>) -> Option<String> {
        if self.real_dir.trim().is_empty() {
            Some("name the folder of real frames".into())
        } else if self.out_dir.trim().is_empty() {
            Some("name the output folder".into())
        } else if let Err(e) = DroneClasses::parse(&self.classes) {
            Some(format!("drone classes: {e}"))
        } else if self.rounds > 0 && gpu.is_none() {
            Some("no wgpu device to render the rounds with (0 rounds work without)".into())
        } else {
            None
        }
    }

    /// The options the window's fields name.
    pub fn options(&self) -> FitOptions {
        let typed = super::paths::typed;
        let mut options = FitOptions::new(typed(&self.real_dir), typed(&self.out_dir));
        options.base = typed(&self.base);
        options.sample = self.sample.max(1);
        options.rounds = self.rounds;
        options.max_frames = self.max_frames;
        options.unlabelled_ok = self.unlabelled_ok;
        options.overwrite = self.overwrite;
        // A list that does not parse keeps the run from starting (`why_not`).
        options.classes = DroneClasses::parse(&self.classes).unwrap_or_default();
        options
    }

    fn start(&mut self, gpu: Option<&GpuContext>, ctx: &egui::Context) {
        let options = self.options();
        let gpu = gpu.cloned();
        self.job
            .start(Job::spawn("swarmshot fit", ctx, move |stage, cancel| {
                run_fit(&options, gpu.as_ref(), stage, cancel)
            }));
    }
}

/// The fit job: the library's two entry points, as `swarmshot fit` calls them.
fn run_fit(
    options: &FitOptions,
    gpu: Option<&GpuContext>,
    stage: &Stage,
    cancel: &AtomicBool,
) -> anyhow::Result<FitDone> {
    stage.set("reading the footage and writing the plates…");
    let prep = crate::fit::prepare(options)?;
    if cancel.load(Ordering::Relaxed) {
        anyhow::bail!("cancelled");
    }
    stage.set("fitting…");
    let done = crate::fit::finish(&prep, gpu, cancel, &mut |line| stage.set(line))?;
    Ok(FitDone {
        fitted: done.fitted,
        before: done.before,
        after: done.after,
        best_round: done.record.best_round,
        warnings: prep.warnings(),
    })
}

/// The result: where the preset is, the report before and after, and its Open button.
fn done_ui(ui: &mut Ui, done: &FitDone, open: &mut Option<PathBuf>) {
    ui.horizontal(|ui| {
        ui.label(format!("Wrote {}", done.fitted.display()));
        if ui
            .button("Open fitted preset")
            .on_hover_text(
                "Open fitted.ron in the app (asks first if this preset has unsaved changes)",
            )
            .clicked()
        {
            *open = Some(done.fitted.clone());
        }
    });
    for warning in &done.warnings {
        ui.colored_label(ui.visuals().warn_fg_color, format!("warning: {warning}"));
    }
    let after = match done.best_round {
        Some(round) => format!("After: the fitted preset (round {round:02})"),
        None => "After: no rounds were rendered (the first fit, unmeasured)".into(),
    };
    for (title, table) in [
        (
            "Before: the base preset (round 00)".to_owned(),
            &done.before,
        ),
        (after, &done.after),
    ] {
        ui.add_space(4.0);
        ui.strong(title);
        if let Some(table) = table {
            ui.label(RichText::new(super::gap_panel::plain(table)).monospace());
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_drone_classes_field_is_read_and_a_bad_list_keeps_the_fit_from_starting() {
        let mut panel = FitPanel {
            real_dir: "real".into(),
            out_dir: "out".into(),
            rounds: 0,
            ..FitPanel::default()
        };
        assert_eq!(panel.options().classes, DroneClasses::All);
        panel.classes = "2, 0".into();
        assert_eq!(panel.why_not(None), None);
        assert_eq!(panel.options().classes, DroneClasses::Only(vec![0, 2]));
        panel.classes = "bird".into();
        let why = panel.why_not(None).expect("refused");
        assert!(
            why.contains("drone classes: `bird` is not a class id"),
            "{why}"
        );
    }
}
