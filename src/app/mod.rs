//! The desktop authoring app (issue 3): eframe + egui with the wgpu renderer.
//!
//! Data flow: the [`Session`] (plain serde data, restored by eframe
//! persistence) holds the preset being edited. After each UI pass the app
//! notices a changed preset, bumps a generation number, validates it and asks
//! two latest-wins workers ([`worker::LatestWorker`]) for a new preview
//! ([`preview`]) and a new summary ([`summary`]). "Generate" snapshots the
//! preset and hands it to [`runner::BatchRun`], which runs the same
//! `run_batch` as `swarmshot batch` on a background thread. The UI thread
//! only polls channels, so it never waits on a render or a batch.
//!
//! Panels are `*_ui` functions in [`panels`]; actions that reach beyond the
//! preset (file dialogs, Generate) are [`Command`]s applied after the pass.
//! Typed values are committed on Enter, focus loss or a pause
//! ([`history::CommitGate`]); committed presets feed the undo history
//! ([`history::EditHistory`]). Replacing an edited preset asks first
//! ([`prompt`]); file dialogs are native where they work, in-app elsewhere
//! ([`files`]).

mod backplate_panel;
pub mod clutter_panel;
mod commands;
pub mod confuser_panel;
mod derived;
pub mod files;
pub mod fit_panel;
mod flat_paint;
pub mod gap_panel;
pub mod history;
pub mod job;
mod keys;
pub mod latency;
mod launch;
mod layout;
pub mod lens_panel;
mod mask_pane;
pub mod mask_view;
pub mod panels;
pub mod paths;
pub mod playback;
pub mod preset_text;
pub mod preview;
pub mod preview_pane;
pub mod problems;
pub mod prompt;
pub mod realism_panels;
pub mod rolling_panel;
pub mod runner;
pub mod summary;
#[cfg(any(test, feature = "test-hooks"))]
mod testing;
pub mod thermal_panel;
pub mod weather_panel;
pub mod worker;
#[cfg(all(unix, not(target_os = "macos")))]
mod x11_focus;

pub use launch::{
    OpenError, example_description, example_presets, quiet_vulkan_on_plain_x11, read_preset,
    read_preset_text, run, run_or_exit,
};
pub use layout::stage_status;

use std::path::PathBuf;
use std::sync::Arc;
use std::time::{Duration, Instant};

use eframe::egui_wgpu;
use egui::{Rect, Ui};
use serde::{Deserialize, Serialize};

use crate::preset::{FieldError, Preset};
use crate::render::GpuContext;
use crate::write::merge::MergeError;
use commands::BatchInputs;
use files::{DialogBackend, FileDialogs};
use history::{CommitGate, EditHistory};
use preview::{
    Orbit, PreviewError, PreviewFrame, PreviewKey, PreviewRenderer, PreviewRequest, PreviewResult,
};
use prompt::Replace;
use runner::{BatchOutcome, BatchRun};
use summary::{Summary, SummaryError, SummaryMaker, SummaryRequest};
use worker::LatestWorker;

/// Window title and persistence key.
pub const APP_NAME: &str = "swarmshot";
/// The longest a committed preset's summary waits for its preview (see `request_summary`).
const SUMMARY_DEFER: Duration = Duration::from_secs(1);

/// What a user saves between sessions (eframe persistence).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct Session {
    pub preset: Preset,
    /// The file the preset was opened from or saved to.
    pub preset_path: Option<PathBuf>,
    /// The preset as on disk, for the unsaved-changes marker.
    pub saved: Option<Preset>,
    /// The text of the file the preset came from: Save edits it ([`preset_text`]).
    pub saved_text: Option<String>,
    /// Where Generate writes.
    pub out_dir: String,
    pub overwrite: bool,
    /// Generate makes only the first `trial_frames` frames (the CLI's `--limit`).
    pub trial: bool,
    pub trial_frames: u64,
    /// Generate makes only every `every_k`th frame (the CLI's `--every`).
    pub every: bool,
    pub every_k: u64,
    /// Generate makes shard `shard_index` (from 0) of `shard_count` (`--shard K/N`).
    pub shard: bool,
    pub shard_index: u64,
    pub shard_count: u64,
    /// The shard folders Merge joins into `out_dir`, one per line.
    pub merge_shards: String,
    /// Selected frame index (0-based).
    pub frame: u64,
    pub show_boxes: bool,
    pub inspect: bool,
    /// "Through the camera" was switched off: the preview shows the clean render.
    /// Each preset opened starts through its camera model, when it has one.
    pub clean_preview: bool,
    /// The pane shows the picture, or the frame's instance image or depth map.
    pub pane_shows: mask_view::PaneShows,
    pub orbit: Orbit,
    /// The side panels are expanded.
    pub show_parameters: bool,
    pub show_summary: bool,
}

impl Default for Session {
    fn default() -> Self {
        Self {
            preset: Preset::default(),
            preset_path: None,
            // A fresh default preset has nothing unsaved until it is edited.
            saved: Some(Preset::default()),
            saved_text: None,
            out_dir: "swarmshot-dataset".into(),
            overwrite: false,
            trial: false,
            trial_frames: 10,
            every: false,
            every_k: 10,
            shard: false,
            shard_index: 0,
            shard_count: 2,
            merge_shards: String::new(),
            frame: 0,
            show_boxes: true,
            inspect: false,
            clean_preview: false,
            pane_shows: mask_view::PaneShows::Picture,
            orbit: Orbit::default(),
            show_parameters: true,
            show_summary: true,
        }
    }
}

impl Session {
    /// The preset differs from the file it came from (or was never saved).
    pub fn is_dirty(&self) -> bool {
        self.saved.as_ref() != Some(&self.preset)
    }
}

/// How the app starts.
#[derive(Clone, Debug, Default)]
pub struct StartOptions {
    /// Open this preset file instead of the last session's preset.
    pub preset: Option<PathBuf>,
    /// Restore the last session from eframe's storage.
    pub restore_session: bool,
}

/// Actions that reach beyond the panel that triggers them, applied after the UI pass.
#[must_use]
#[derive(Clone, Debug, PartialEq)]
pub enum Command {
    New,
    /// The Open dialog.
    Open,
    OpenPath(PathBuf),
    /// An example from presets/, opened as an untitled copy.
    OpenExample(PathBuf),
    Save,
    SaveAs,
    AddGltf,
    BrowseOutDir,
    /// The folder dialog for the backplate folder or the Domain gap window's real frames.
    BrowseFolder(files::FilePurpose),
    Generate,
    Cancel,
    OpenOutputFolder(PathBuf),
    Undo,
    Redo,
    /// Open the section holding this field and scroll its message into view.
    ShowProblem(String),
    /// Move the frame slider by this many frames (clamped).
    StepFrame(i64),
    FirstFrame,
    LastFrame,
    /// Join the shard folders named in the Batch panel into the output folder.
    Merge,
    /// Close the window (asks first when there are unsaved changes).
    Quit,
}

/// The app: session data plus everything derived from it.
pub struct SwarmshotApp {
    session: Session,
    gpu: Option<(GpuContext, egui_wgpu::RenderState)>,
    /// The preset the derived state below belongs to.
    seen: Option<Preset>,
    generation: u64,
    errors: Vec<FieldError>,
    /// `session.preset` with model paths resolved against the preset's folder.
    resolved: Arc<Preset>,
    preview_worker: Option<LatestWorker<PreviewRequest, PreviewResult>>,
    preview: Option<PreviewFrame>,
    /// Paints the window's background and the preview picture (see [`flat_paint`]).
    flat: Option<flat_paint::FlatPainter>,
    preview_error: Option<PreviewError>,
    preview_sent: Option<PreviewKey>,
    preview_size_px: [u32; 2],
    /// Where the preview was drawn in the last pass (points).
    preview_rect: Option<Rect>,
    /// The central panel (the preview pane's column) in the last pass.
    central_rect: Option<Rect>,
    /// The preview's zoom and pan (wheel and drag in the pane).
    pane_view: preview_pane::PaneView,
    /// Screen pixels per output pixel of the picture shown, in the last pass.
    pixel_scale: Option<f32>,
    /// The instance / depth views of the previewed frame.
    mask_pane: mask_pane::MaskPane,
    /// Change → picture on screen, measured here (see [`latency`]).
    latency: latency::LatencyMeter,
    /// A committed preset's summary is yet to be asked for (since then).
    summary_due: Option<Instant>,
    /// When this UI pass started.
    pass_start: Instant,
    summary_worker: Option<LatestWorker<SummaryRequest, Result<Summary, SummaryError>>>,
    summary: Option<Result<Summary, SummaryError>>,
    batch: Option<BatchRun>,
    batch_outcome: Option<BatchOutcome>,
    /// What the last Generate was asked for (preset generation, folder,
    /// overwrite, limit): a failure's message goes once any of them changes.
    batch_inputs: Option<BatchInputs>,
    /// Problems with files and dialogs, shown in a banner until dismissed.
    notices: Vec<String>,
    title: String,
    dialogs: FileDialogs,
    history: EditHistory,
    gate: CommitGate,
    /// The unsaved-changes prompt is open for this replacement.
    prompt: Option<Replace>,
    /// Run this once the preset was saved through Save As.
    after_save: Option<Replace>,
    /// The user answered the prompt for closing: let the window close.
    allow_close: bool,
    /// A Problems link was clicked: scroll to this field's message.
    scroll_to: Option<String>,
    /// The frame slider's id (arrow keys step frames while it or nothing has focus).
    frame_slider: Option<egui::Id>,
    /// Play / pause / loop through the frames.
    playback: playback::Playback,
    /// A merge of shard folders in flight: its one-line report or why it failed.
    merge: Option<crossbeam_channel::Receiver<Result<String, MergeError>>>,
    merge_outcome: Option<Result<String, MergeError>>,
    /// The domain-gap report window.
    gap: gap_panel::GapPanel,
    /// The Fit window.
    fit: fit_panel::FitPanel,
}

impl SwarmshotApp {
    pub fn new(cc: &eframe::CreationContext<'_>, options: StartOptions) -> Self {
        let mut notices = Vec::new();
        let session = start_session(cc, &options, &mut notices);
        let gpu = cc.wgpu_render_state.as_ref().map(|rs| {
            let ctx = GpuContext {
                device: rs.device.clone(),
                queue: rs.queue.clone(),
                adapter_info: rs.adapter.get_info(),
                max_texture_side: rs.device.limits().max_texture_dimension_2d,
                shared: Default::default(),
                prepared: Default::default(),
            };
            (ctx, rs.clone())
        });
        let flat = gpu.as_ref().map(|(_, rs)| flat_paint::FlatPainter::new(rs));
        let egui_ctx = cc.egui_ctx.clone();
        let wake = move || egui_ctx.request_repaint();
        let dialogs = FileDialogs::new(DialogBackend::from_env(), wake.clone());
        let gpu_ctx = gpu.as_ref().map(|(ctx, _)| ctx);
        let preview_worker = spawn_preview_worker(gpu_ctx, wake.clone(), &mut notices);
        let summary_worker = spawn_summary_worker(wake, &mut notices);
        Self {
            resolved: Arc::new(session.preset.clone()),
            session,
            gpu,
            seen: None,
            generation: 0,
            errors: Vec::new(),
            preview_worker,
            preview: None,
            flat,
            preview_error: None,
            preview_sent: None,
            preview_size_px: [0, 0],
            preview_rect: None,
            central_rect: None,
            pane_view: preview_pane::PaneView::default(),
            pixel_scale: None,
            mask_pane: mask_pane::MaskPane::default(),
            latency: latency::LatencyMeter::default(),
            summary_due: None,
            pass_start: Instant::now(),
            summary_worker,
            summary: None,
            batch: None,
            batch_outcome: None,
            batch_inputs: None,
            notices,
            title: String::new(),
            dialogs,
            history: EditHistory::default(),
            gate: CommitGate::default(),
            prompt: None,
            after_save: None,
            allow_close: false,
            scroll_to: None,
            frame_slider: None,
            playback: playback::Playback::default(),
            merge: None,
            merge_outcome: None,
            gap: gap_panel::GapPanel::default(),
            fit: fit_panel::FitPanel::default(),
        }
    }

    /// The key of the picture on screen, if any.
    fn shown_key(&self) -> Option<PreviewKey> {
        self.preview.as_ref().map(|p| p.key)
    }

    /// The picture on screen answers the newest request (nothing in flight).
    fn picture_is_current(&self) -> bool {
        self.preview_sent.is_some()
            && (self.shown_key() == self.preview_sent
                || self.preview_error.as_ref().map(|e| e.key) == self.preview_sent)
    }
}

/// The session the app starts with: the stored one (its file re-read when
/// nothing is unsaved) when `options` restore it, else a new one; then the
/// preset file `options` name, if any. A file that cannot be read is a notice.
fn start_session(
    cc: &eframe::CreationContext<'_>,
    options: &StartOptions,
    notices: &mut Vec<String>,
) -> Session {
    let mut session = if options.restore_session {
        cc.storage
            .and_then(|s| eframe::get_value::<Session>(s, eframe::APP_KEY))
            .unwrap_or_default()
    } else {
        Session::default()
    };
    // A restored session with nothing unsaved shows its file as it is now.
    if options.restore_session
        && options.preset.is_none()
        && !session.is_dirty()
        && let Some(path) = session.preset_path.clone()
    {
        reread_session_file(&mut session, path, notices);
    }
    if let Some(path) = &options.preset {
        match read_preset_text(path) {
            Ok((preset, text)) => session.load(preset, path.clone(), text),
            Err(e) => notices.push(e.to_string()),
        }
    }
    session
}

/// The restored session's preset read again from its file. A file that cannot be read
/// now (gone, or edited into something that is not a preset) is named in a notice, and
/// the session's preset is shown unsaved and untied from it: Save asks for a file (and
/// before replacing one), so the file's new text is never overwritten unseen.
fn reread_session_file(session: &mut Session, path: PathBuf, notices: &mut Vec<String>) {
    match read_preset_text(&path) {
        Ok((preset, text)) => {
            let frame = session.frame;
            session.load(preset, path, text);
            session.frame = frame;
        }
        Err(e) => {
            notices.push(format!(
                "{e}; showing the preset of the last session, not saved to any file"
            ));
            session.preset_path = None;
            session.saved = None;
        }
    }
}

/// The preview thread on the window's wgpu device (`gpu`), or a notice why
/// there is none.
fn spawn_preview_worker(
    gpu: Option<&GpuContext>,
    wake: impl Fn() + Send + 'static,
    notices: &mut Vec<String>,
) -> Option<LatestWorker<PreviewRequest, PreviewResult>> {
    let Some(ctx) = gpu else {
        notices.push(
            "eframe gave no wgpu device: the preview and Generate need the wgpu renderer".into(),
        );
        return None;
    };
    let mut renderer = PreviewRenderer::new(ctx.clone());
    LatestWorker::spawn("swarmshot preview", wake, move |request: PreviewRequest| {
        renderer.render(&request)
    })
    .map_err(|e| notices.push(format!("cannot start the preview thread: {e}")))
    .ok()
}

/// The summary thread, or a notice why it did not start.
fn spawn_summary_worker(
    wake: impl Fn() + Send + 'static,
    notices: &mut Vec<String>,
) -> Option<LatestWorker<SummaryRequest, Result<Summary, SummaryError>>> {
    let mut maker = SummaryMaker::default();
    LatestWorker::spawn("swarmshot summary", wake, move |request: SummaryRequest| {
        maker.estimate(&request)
    })
    .map_err(|e| notices.push(format!("cannot start the summary thread: {e}")))
    .ok()
}

impl Session {
    fn load(&mut self, preset: Preset, path: PathBuf, text: String) {
        self.saved = Some(preset.clone());
        self.saved_text = Some(text);
        self.preset = preset;
        self.preset_path = Some(path);
        self.frame = 0;
        self.clean_preview = false;
    }

    /// A preset with no file yet (New, an example's copy); nothing is unsaved until it is edited.
    fn load_untitled(&mut self, preset: Preset, text: Option<String>) {
        self.saved = Some(preset.clone());
        self.saved_text = text;
        self.preset = preset;
        self.preset_path = None;
        self.frame = 0;
        self.clean_preview = false;
    }
}

impl eframe::App for SwarmshotApp {
    fn ui(&mut self, ui: &mut Ui, frame: &mut eframe::Frame) {
        let ctx = ui.ctx().clone();
        self.pass_start = Instant::now();
        self.latency.pass_started(self.pass_start);
        take_focus_on_click(&ctx, frame);
        self.poll(&ctx);
        self.close_requested(&ctx);
        let mut commands = self.shortcut_commands(&ctx);
        self.sync(&ctx);
        self.play_tick(&ctx);
        self.panels_ui(ui, &mut commands);
        self.gap.show(
            &ctx,
            gap_panel::GapInputs {
                gpu: self.gpu.as_ref().map(|(g, _)| g),
                preset: self.errors.is_empty().then(|| Arc::clone(&self.resolved)),
                out_dir: &self.session.out_dir,
            },
        );
        self.fit.show(&ctx, self.gpu.as_ref().map(|(g, _)| g));
        self.background_jobs(&mut commands);
        if let Some(choice) = self.dialogs.show(&ctx) {
            self.chosen(choice, &ctx);
        } else if !self.dialogs.is_open() {
            // A Save As for the prompt was cancelled: nothing more to do.
            self.after_save = None;
        }
        if let Some(replace) = &self.prompt
            && let Some(answer) = prompt::prompt_ui(&ctx, &self.session.preset.name, replace)
        {
            self.answer(answer, &ctx);
        }
        for command in commands {
            self.apply(command, &ctx);
        }
        self.sync(&ctx);
        // A drag is one undo step however slow: the history sees its value
        // once the pointer lets go, not at each pause along the way.
        let dragging = ctx.dragged_id().is_some() || ctx.input(|i| i.pointer.any_down());
        if let Some(committed) = &self.seen
            && !dragging
        {
            self.history.feed(ctx.input(|i| i.time), committed);
        }
        self.forget_stale_failure();
        self.request_preview();
        self.request_masks(&ctx);
        self.request_summary(&ctx);
        self.update_title(&ctx);
    }

    fn save(&mut self, storage: &mut dyn eframe::Storage) {
        eframe::set_value(storage, eframe::APP_KEY, &self.session);
    }
}

/// A click into a window without the keyboard gives it the keyboard, with or
/// without a window manager (see `x11_focus`).
fn take_focus_on_click(ctx: &egui::Context, frame: &eframe::Frame) {
    let (pressed, focused) = ctx.input(|i| (i.pointer.any_pressed(), i.viewport().focused));
    if pressed && focused != Some(true) {
        ctx.send_viewport_cmd(egui::ViewportCommand::Focus);
        #[cfg(all(unix, not(target_os = "macos")))]
        x11_focus::take(frame);
    }
    #[cfg(not(all(unix, not(target_os = "macos"))))]
    let _ = frame;
}

impl Drop for SwarmshotApp {
    /// Closing the window mid-batch cancels it and waits for the frames in
    /// flight, so the dataset on disk stays consistent (`BatchRun`'s drop);
    /// the batch goes first, then the workers (their own drops join them).
    fn drop(&mut self) {
        drop(self.batch.take());
    }
}
