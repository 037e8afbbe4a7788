//! The domain-gap report in the app (issue 21 item 8): a window where the user names a
//! folder of real frames and runs `swarmshot gap` ([`crate::gap::run_report`]) against
//! either the current preset's first frames, made now into a temporary folder by the
//! batch's own [`run_batch`], or a dataset folder already made. The work runs on its
//! own thread ([`Job`]: woken once a second at most, never by a spinner); the window
//! shows its progress, then the side-by-side table with each
//! statistic's verdict and the proposed camera-model ranges.
//!
//! The temporary dataset is a folder this module creates under the system's temporary
//! folder (a new name each run, never an existing folder) and removes once measured.

use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

use egui::{Color32, RichText, Ui};

use super::job::{Job, JobSlot, Stage};

use crate::gap::folder::DroneClasses;
use crate::gap::report::cell;
use crate::gap::{GapOptions, Report, run_report};
use crate::pipeline::{BatchOptions, FramePipeline, run_batch};
use crate::preset::Preset;
use crate::render::GpuContext;

/// Frames of the preset made for the report unless the user asks otherwise.
pub const DEFAULT_PRESET_FRAMES: u64 = 16;
/// The most frames of the preset the window makes for one report.
pub const MAX_PRESET_FRAMES: u64 = 500;

/// What the report compares the real frames against.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SyntheticSide {
    /// The current preset's first N frames, made now.
    PresetFrames,
    /// A dataset folder (`swarmshot batch --out`, or the app's output folder).
    Dataset,
}

/// The window's state.
pub struct GapPanel {
    pub open: bool,
    /// Browse… was clicked for the real frames: the app opens the folder dialog.
    pub browse_real: bool,
    /// Folder of real frames (YOLO labels in a sibling labels/ or beside them).
    pub real_dir: String,
    pub side: SyntheticSide,
    pub preset_frames: u64,
    /// The dataset folder for [`SyntheticSide::Dataset`].
    pub dataset_dir: String,
    /// At most this many frames per side (0: all).
    pub max_images: usize,
    /// The real labels' classes that are drones, as typed (`all`, or ids such as `0,2`).
    pub real_classes: String,
    job: JobSlot<Report>,
}

impl Default for GapPanel {
    fn default() -> Self {
        Self {
            open: false,
            browse_real: false,
            real_dir: String::new(),
            side: SyntheticSide::PresetFrames,
            preset_frames: DEFAULT_PRESET_FRAMES,
            dataset_dir: String::new(),
            max_images: 200,
            real_classes: "all".into(),
            job: JobSlot::default(),
        }
    }
}

/// What the window needs from the app to start a report.
pub struct GapInputs<'a> {
    pub gpu: Option<&'a GpuContext>,
    /// The preset with model paths resolved; None while it is invalid.
    pub preset: Option<Arc<Preset>>,
    /// The batch panel's output folder, proposed for the dataset side.
    pub out_dir: &'a str,
}

impl GapPanel {
    /// The finished report, if the last run succeeded.
    pub fn report(&self) -> Option<&Report> {
        self.job.done()
    }

    /// The last run's error, if it failed.
    pub fn error(&self) -> Option<String> {
        self.job.error().map(ToString::to_string)
    }

    /// A report is being made.
    pub fn is_running(&self) -> bool {
        self.job.is_running()
    }

    /// Whether a report started since the last call (the app then pauses playback,
    /// so the preview's renders leave the CPU to the report).
    pub fn take_started(&mut self) -> bool {
        self.job.take_started()
    }

    /// The window (when open).
    pub fn show(&mut self, ctx: &egui::Context, inputs: GapInputs<'_>) {
        self.job.poll();
        if !self.open {
            return;
        }
        if self.dataset_dir.is_empty() {
            self.dataset_dir = inputs.out_dir.to_owned();
        }
        let mut open = self.open;
        egui::Window::new("Domain gap")
            .open(&mut open)
            .default_size([900.0, 560.0])
            .vscroll(true)
            .show(ctx, |ui| self.contents(ui, &inputs));
        self.open = open;
    }

    fn contents(&mut self, ui: &mut Ui, inputs: &GapInputs<'_>) {
        ui.label(
            "Compares real frames with synthetic ones statistic by statistic (as `swarmshot gap`): noise, blur, edges, sky colour, JPEG quality, drone size and contrast. See docs/realism.md.",
        );
        let running = self.job.is_running();
        ui.add_enabled_ui(!running, |ui| self.inputs_ui(ui));
        ui.horizontal(|ui| {
            let why_not = self.why_not(inputs);
            let run = ui
                .add_enabled(
                    !running && why_not.is_none(),
                    egui::Button::new("Run report"),
                )
                .on_hover_text("Measure both sides and show the table (runs in the background)");
            if let Some(why) = &why_not
                && !running
            {
                ui.weak(why.as_str());
            }
            if run.clicked() {
                self.start(inputs, ui.ctx().clone());
            }
            if let Some(job) = self.job.running() {
                job.status_ui(ui, true);
            }
        });
        ui.separator();
        match self.job.outcome() {
            Some(Ok(report)) => report_ui(ui, report),
            Some(Err(e)) => {
                ui.label(
                    RichText::new(format!("Report failed: {e}")).color(ui.visuals().error_fg_color),
                );
            }
            None => {}
        }
    }

    fn inputs_ui(&mut self, ui: &mut Ui) {
        egui::Grid::new("gap inputs").num_columns(2).show(ui, |ui| {
            ui.label("Real frames folder");
            ui.horizontal(|ui| {
                ui.add(egui::TextEdit::singleline(&mut self.real_dir).desired_width(360.0))
                    .accessible_name("Real frames folder")
                    .on_hover_text(
                        "A folder of real JPEG/PNG frames; YOLO labels in a sibling labels/ folder or beside the images give the drone statistics",
                    );
                if ui
                    .button("Browse…")
                    .on_hover_text("Choose the folder of real frames")
                    .clicked()
                {
                    self.browse_real = true;
                }
            });
            ui.end_row();
            ui.label("Synthetic frames");
            ui.vertical(|ui| {
                ui.horizontal(|ui| {
                    ui.radio_value(&mut self.side, SyntheticSide::PresetFrames, "This preset: first")
                        .on_hover_text("Make the preset's first frames now, as Generate makes them, into a temporary folder that is removed afterwards");
                    ui.add(
                        egui::DragValue::new(&mut self.preset_frames)
                            .range(1..=MAX_PRESET_FRAMES),
                    )
                    .accessible_name("Preset frames");
                    ui.label("frames");
                });
                ui.horizontal(|ui| {
                    ui.radio_value(&mut self.side, SyntheticSide::Dataset, "Dataset folder")
                        .on_hover_text("A folder made by Generate or `swarmshot batch --out`");
                    ui.add_enabled(
                        self.side == SyntheticSide::Dataset,
                        egui::TextEdit::singleline(&mut self.dataset_dir).desired_width(330.0),
                    )
                    .accessible_name("Dataset folder");
                });
            });
            ui.end_row();
            ui.label("At most");
            ui.horizontal(|ui| {
                ui.add(egui::DragValue::new(&mut self.max_images).range(0..=100_000))
                    .accessible_name("At most frames per side");
                ui.label("frames per side (0: all; evenly spaced in name order)");
            });
            ui.end_row();
            ui.label("Real drone classes");
            ui.add(egui::TextEdit::singleline(&mut self.real_classes).desired_width(120.0))
                .accessible_name("Real drone classes")
                .on_hover_text(
                    "The real labels' classes that are drones: all, or class ids such as 0,2 (rows of other classes, birds or aircraft, are not measured)",
                );
            ui.end_row();
        });
    }

    /// Why a report cannot start now, in words.
    fn why_not(&self, inputs: &GapInputs<'_>) -> Option<String> {
        if self.real_dir.trim().is_empty() {
            return Some("name the folder of real frames".into());
        }
        if let Err(e) = DroneClasses::parse(&self.real_classes) {
            return Some(format!("real drone classes: {e}"));
        }
        match self.side {
            SyntheticSide::PresetFrames if inputs.preset.is_none() => {
                Some("the preset has problems (see Problems)".into())
            }
            SyntheticSide::PresetFrames if inputs.gpu.is_none() => {
                Some("no wgpu device to make frames with".into())
            }
            SyntheticSide::Dataset if self.dataset_dir.trim().is_empty() => {
                Some("name the dataset folder".into())
            }
            _ => None,
        }
    }

    /// Start the report on its own thread.
    fn start(&mut self, inputs: &GapInputs<'_>, ctx: egui::Context) {
        let real = super::paths::typed(&self.real_dir);
        let max_images = self.max_images;
        let Ok(classes) = DroneClasses::parse(&self.real_classes) else {
            return;
        };
        let source = match self.side {
            SyntheticSide::PresetFrames => match (inputs.preset.clone(), inputs.gpu.cloned()) {
                (Some(preset), Some(gpu)) => Source::Preset {
                    preset,
                    gpu: Box::new(gpu),
                    frames: self.preset_frames.clamp(1, MAX_PRESET_FRAMES),
                },
                _ => return,
            },
            SyntheticSide::Dataset => Source::Dataset(super::paths::typed(&self.dataset_dir)),
        };
        self.job
            .start(Job::spawn("swarmshot gap", &ctx, move |stage, cancel| {
                make_report(real, source, max_images, classes, stage, cancel)
            }));
    }
}

/// The synthetic side of a report job.
enum Source {
    Preset {
        preset: Arc<Preset>,
        gpu: Box<GpuContext>,
        frames: u64,
    },
    Dataset(PathBuf),
}

/// A folder this run created under the system's temporary folder, removed on drop.
struct TempDataset(PathBuf);

impl TempDataset {
    fn create() -> anyhow::Result<Self> {
        static RUN: AtomicU64 = AtomicU64::new(0);
        let base = std::env::temp_dir();
        for _ in 0..100 {
            let n = RUN.fetch_add(1, Ordering::Relaxed);
            let dir = base.join(format!("swarmshot-gap-{}-{n}", std::process::id()));
            match std::fs::create_dir(&dir) {
                Ok(()) => return Ok(Self(dir)),
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => continue,
                Err(e) => {
                    anyhow::bail!("cannot make a temporary folder in {}: {e}", base.display())
                }
            }
        }
        anyhow::bail!("no free temporary folder name in {}", base.display())
    }
}

impl Drop for TempDataset {
    fn drop(&mut self) {
        // Only this run's own folder, which holds only the batch's files.
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// The report job: make the preset's frames if asked, then measure both sides.
fn make_report(
    real: PathBuf,
    source: Source,
    max_images: usize,
    real_classes: DroneClasses,
    stage: &Stage,
    cancel: &AtomicBool,
) -> anyhow::Result<Report> {
    let (synthetic, _temp) = match source {
        Source::Dataset(dir) => (dir, None),
        Source::Preset {
            preset,
            gpu,
            frames,
        } => {
            if !real.is_dir() {
                // Found before any frame is made.
                anyhow::bail!("{}: not a folder", real.display());
            }
            let temp = TempDataset::create()?;
            stage.set(format!("making {frames} frames of the preset…"));
            let pipeline =
                FramePipeline::new((*preset).clone()).map_err(|e| anyhow::anyhow!("{e:#}"))?;
            let mut options = BatchOptions::new(&temp.0);
            options.limit = Some(frames);
            run_batch(&pipeline, &options, &gpu, cancel, |p| {
                stage.set(format!(
                    "making frames of the preset: {} of {}…",
                    p.done, p.total
                ));
            })
            .map_err(|e| anyhow::anyhow!("making the preset's frames: {e:#}"))?;
            if cancel.load(Ordering::Relaxed) {
                anyhow::bail!("cancelled");
            }
            (temp.0.clone(), Some(temp))
        }
    };
    stage.set("measuring the real and the synthetic frames…");
    Ok(run_report(&GapOptions {
        max_images,
        real_classes,
        ..GapOptions::new(real, synthetic)
    })?)
}

/// The report's words with "→" spelled out: egui's default font has no arrows.
pub fn plain(text: &str) -> String {
    text.replace('→', " to ")
}

/// The side-by-side table, its verdicts and the proposed ranges.
fn report_ui(ui: &mut Ui, report: &Report) {
    for (name, side) in [("Real", &report.real), ("Synthetic", &report.synthetic)] {
        let drones: usize = side.frames.iter().map(|f| f.stats.drones.len()).sum();
        ui.label(format!(
            "{name}: {} ({} of {} images measured, {} labelled, {drones} drones)",
            side.dir,
            side.frames.len(),
            side.images_found,
            side.labelled_frames
        ));
    }
    ui.add_space(4.0);
    egui::Grid::new("gap table")
        .num_columns(5)
        .striped(true)
        .show(ui, |ui| {
            for head in ["statistic", "unit", "real median [IQR]", "synthetic median [IQR]", "verdict"] {
                ui.strong(head);
            }
            ui.end_row();
            for row in &report.statistics {
                ui.label(plain(row.name));
                ui.label(plain(row.unit));
                ui.label(cell(row.real));
                ui.label(cell(row.synthetic));
                let colour = match row.verdict {
                    "inside" => Color32::from_rgb(80, 170, 80),
                    "below" | "above" => Color32::from_rgb(220, 150, 40),
                    _ => ui.visuals().weak_text_color(),
                };
                ui.label(RichText::new(row.verdict).color(colour))
                    .on_hover_text("The synthetic median (or share) against the real inter-quartile range (or 50 % interval)");
                ui.end_row();
            }
        });
    ui.weak("Shares: the interval is the 50 % Wilson interval. Verdict: the synthetic median or share against the real range.");
    if let Some(note) = report.few_real_values() {
        ui.label(RichText::new(plain(&note)).color(Color32::from_rgb(220, 150, 40)));
    }
    if let Some(halves) = &report.real_halves {
        ui.weak(plain(halves.line().trim_end()));
    }
    if !report.proposals.is_empty() {
        ui.add_space(4.0);
        ui.strong("Proposed ranges");
        for p in &report.proposals {
            ui.label(format!("• {}", plain(&p.text)));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_bad_real_classes_list_keeps_the_report_from_starting() {
        let inputs = GapInputs {
            gpu: None,
            preset: None,
            out_dir: "",
        };
        let mut panel = GapPanel {
            real_dir: "real".into(),
            side: SyntheticSide::Dataset,
            dataset_dir: "ds".into(),
            ..GapPanel::default()
        };
        assert_eq!(panel.why_not(&inputs), None);
        panel.real_classes = "0,x".into();
        let why = panel.why_not(&inputs).expect("refused");
        assert!(
            why.contains("real drone classes: `x` is not a class id"),
            "{why}"
        );
    }
}
