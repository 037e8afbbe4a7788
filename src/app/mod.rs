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
mod batch_panel;
pub mod clutter_panel;
pub mod confuser_panel;
pub mod files;
pub mod gap_panel;
pub mod history;
mod keys;
pub mod latency;
pub mod panels;
pub mod playback;
pub mod preview;
pub mod problems;
pub mod prompt;
pub mod realism_panels;
pub mod runner;
pub mod summary;
pub mod worker;
#[cfg(all(unix, not(target_os = "macos")))]
mod x11_focus;

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, Instant};

use eframe::egui_wgpu;
use egui::{Color32, Pos2, Rect, RichText, Sense, Stroke, Ui, Vec2};
use glam::DVec3;
use serde::{Deserialize, Serialize};

use crate::pipeline::BatchOptions;
use crate::preset::{FieldError, ModelSource, ModelSpec, PRESET_VERSION, Preset};
use crate::render::GpuContext;
use files::{DialogBackend, FileChoice, FileDialogs, FilePurpose};
use history::{CommitGate, EditHistory, Gate};
use panels::{Form, error_label, format_to_step, group_digits};
use preview::{
    Orbit, PreviewError, PreviewFrame, PreviewKey, PreviewRenderer, PreviewRequest, PreviewResult,
    PreviewView,
};
use prompt::{Answer, Replace};
use runner::{BatchOutcome, BatchRun};
use summary::{Summary, SummaryMaker, SummaryRequest};
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
    /// Where Generate writes.
    pub out_dir: String,
    pub overwrite: bool,
    /// Generate makes only the first `trial_frames` frames (the CLI's `--limit`).
    pub trial: bool,
    pub trial_frames: u64,
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
    /// The preview shows the frame through the preset's camera model.
    pub through_camera: bool,
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
            out_dir: "swarmshot-dataset".into(),
            overwrite: false,
            trial: false,
            trial_frames: 10,
            shard: false,
            shard_index: 0,
            shard_count: 2,
            merge_shards: String::new(),
            frame: 0,
            show_boxes: true,
            inspect: false,
            through_camera: false,
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
}

/// Read a preset for editing: parsed, not validated (problems are shown at the widgets).
pub fn read_preset(path: &Path) -> Result<Preset, String> {
    let text = std::fs::read_to_string(path).map_err(|e| match e.kind() {
        std::io::ErrorKind::NotFound => format!("preset {} does not exist", path.display()),
        std::io::ErrorKind::PermissionDenied => {
            format!(
                "preset {}: permission denied (cannot read it)",
                path.display()
            )
        }
        std::io::ErrorKind::IsADirectory => {
            format!("preset {} is a folder, not a preset file", path.display())
        }
        _ => format!("cannot read preset {}: {e}", path.display()),
    })?;
    let preset = Preset::from_ron(&text).map_err(|e| format!("preset {}: {e}", path.display()))?;
    if preset.version > PRESET_VERSION {
        return Err(format!(
            "preset {}: version {} is newer than this swarmshot understands ({PRESET_VERSION})",
            path.display(),
            preset.version
        ));
    }
    Ok(preset)
}

/// The example presets shipped in the repository's presets/ folder.
pub fn example_presets() -> Vec<PathBuf> {
    let dirs = [
        PathBuf::from("presets"),
        Path::new(env!("CARGO_MANIFEST_DIR")).join("presets"),
    ];
    let Some(dir) = dirs.iter().find(|d| d.is_dir()) else {
        return Vec::new();
    };
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .map(|entries| {
            entries
                .filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|p| p.extension().is_some_and(|x| x == "ron"))
                .collect()
        })
        .unwrap_or_default();
    files.sort();
    files
}

/// `swarmshot` and `swarmshot gui`: open the window, or print one line saying
/// why not and exit with status 1 (no winit internals, no backtrace).
///
/// Without a display a bad preset path is reported first: it is the error the
/// user can fix from where they are.
pub fn run_or_exit(preset: Option<PathBuf>) {
    let fail = |message: String| -> ! {
        eprintln!("swarmshot: {message}");
        std::process::exit(1)
    };
    if let Some(why) = no_display() {
        if let Some(path) = &preset
            && let Err(e) = read_preset(path)
        {
            fail(e);
        }
        fail(why);
    }
    if let Err(e) = run(preset) {
        fail(format!("{e:#}"));
    }
}

/// Why no window can open here, when that is known without trying.
fn no_display() -> Option<String> {
    let set = |name: &str| std::env::var_os(name).is_some_and(|v| !v.is_empty());
    (cfg!(all(unix, not(target_os = "macos"))) && !set("DISPLAY") && !set("WAYLAND_DISPLAY"))
        .then(|| {
            "no display: the desktop app needs an X11 or Wayland session (DISPLAY and WAYLAND_DISPLAY are unset); \
             the command line works without one (swarmshot --help)"
                .to_string()
        })
}

/// winit's errors name its own source file ("os error at /…/winit-…/src/…rs:42: …"):
/// keep only what it says.
fn window_error(error: &eframe::Error) -> String {
    let text = error.to_string();
    let short = match text.find("os error at ") {
        Some(start) => {
            let rest = &text[start + "os error at ".len()..];
            // Skip "PATH:LINE: " to the message.
            let message = rest
                .split_once(".rs:")
                .and_then(|(_, after)| after.split_once(": "))
                .map_or(rest, |(_, message)| message);
            format!("{}{message}", &text[..start])
        }
        None => text,
    };
    let display = std::env::var("DISPLAY")
        .or_else(|_| std::env::var("WAYLAND_DISPLAY"))
        .unwrap_or_default();
    format!("cannot open the swarmshot window on display \"{display}\": {short}")
}

/// Open the app window (blocks until it is closed).
pub fn run(preset: Option<PathBuf>) -> anyhow::Result<()> {
    let options = eframe::NativeOptions {
        viewport: egui::ViewportBuilder::default()
            .with_title(APP_NAME)
            .with_inner_size([1400.0, 880.0])
            .with_min_inner_size([900.0, 560.0]),
        renderer: eframe::Renderer::Wgpu,
        ..Default::default()
    };
    eframe::run_native(
        APP_NAME,
        options,
        Box::new(move |cc| {
            Ok(Box::new(SwarmshotApp::new(
                cc,
                StartOptions {
                    preset,
                    restore_session: true,
                },
            )))
        }),
    )
    .map_err(|e| anyhow::anyhow!(window_error(&e)))
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
    preview_texture: Option<egui::TextureId>,
    preview_error: Option<PreviewError>,
    preview_sent: Option<PreviewKey>,
    preview_size_px: [u32; 2],
    /// Where the preview was drawn in the last pass (points).
    preview_rect: Option<Rect>,
    /// Change → picture on screen, measured here (see [`latency`]).
    latency: latency::LatencyMeter,
    /// A committed preset's summary is yet to be asked for (since then).
    summary_due: Option<Instant>,
    /// When this UI pass started.
    pass_start: Instant,
    summary_worker: Option<LatestWorker<SummaryRequest, Result<Summary, String>>>,
    summary: Option<Result<Summary, String>>,
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
    /// A merge of shard folders in flight: its one-line report or error.
    merge: Option<crossbeam_channel::Receiver<Result<String, String>>>,
    merge_outcome: Option<Result<String, String>>,
    /// The domain-gap report window.
    gap: gap_panel::GapPanel,
}

impl SwarmshotApp {
    pub fn new(cc: &eframe::CreationContext<'_>, options: StartOptions) -> Self {
        let mut notices = Vec::new();
        let mut session = if options.restore_session {
            cc.storage
                .and_then(|s| eframe::get_value::<Session>(s, eframe::APP_KEY))
                .unwrap_or_default()
        } else {
            Session::default()
        };
        if let Some(path) = &options.preset {
            match read_preset(path) {
                Ok(preset) => session.load(preset, path.clone()),
                Err(e) => notices.push(e),
            }
        }
        let gpu = cc.wgpu_render_state.as_ref().map(|rs| {
            let ctx = GpuContext {
                device: rs.device.clone(),
                queue: rs.queue.clone(),
                adapter_info: rs.adapter.get_info(),
                max_texture_side: rs.device.limits().max_texture_dimension_2d,
            };
            (ctx, rs.clone())
        });
        let egui_ctx = cc.egui_ctx.clone();
        let wake = move || egui_ctx.request_repaint();
        let dialogs = FileDialogs::new(DialogBackend::from_env(), wake.clone());
        let preview_worker = match &gpu {
            Some((ctx, _)) => {
                let mut renderer = PreviewRenderer::new(ctx.clone());
                LatestWorker::spawn(
                    "swarmshot preview",
                    wake.clone(),
                    move |request: PreviewRequest| renderer.render(&request),
                )
                .map_err(|e| notices.push(format!("cannot start the preview thread: {e}")))
                .ok()
            }
            None => {
                notices.push(
                    "eframe gave no wgpu device: the preview and Generate need the wgpu renderer"
                        .into(),
                );
                None
            }
        };
        let mut maker = SummaryMaker::default();
        let summary_worker =
            LatestWorker::spawn("swarmshot summary", wake, move |request: SummaryRequest| {
                maker.estimate(&request)
            })
            .map_err(|e| notices.push(format!("cannot start the summary thread: {e}")))
            .ok();
        Self {
            resolved: Arc::new(session.preset.clone()),
            session,
            gpu,
            seen: None,
            generation: 0,
            errors: Vec::new(),
            preview_worker,
            preview: None,
            preview_texture: None,
            preview_error: None,
            preview_sent: None,
            preview_size_px: [0, 0],
            preview_rect: None,
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
        }
    }

    /// Use this kind of file dialog from now on (tests pin the in-app browser).
    pub fn use_file_dialogs(&mut self, backend: DialogBackend, ctx: &egui::Context) {
        let ctx = ctx.clone();
        self.dialogs = FileDialogs::new(backend, move || ctx.request_repaint());
    }

    // ---- accessors for tests and the benchmark -------------------------------------------

    pub fn session(&self) -> &Session {
        &self.session
    }

    pub fn session_mut(&mut self) -> &mut Session {
        &mut self.session
    }

    /// Validation messages of the current preset.
    pub fn errors(&self) -> &[FieldError] {
        &self.errors
    }

    /// The key of the picture on screen, if any.
    pub fn preview_key(&self) -> Option<PreviewKey> {
        self.preview.as_ref().map(|p| p.key)
    }

    /// The measured time from a change to its picture on screen.
    pub fn preview_latency(&self) -> &latency::LatencyMeter {
        &self.latency
    }

    /// Last preview render time (build + encode + GPU), milliseconds.
    pub fn preview_render_ms(&self) -> Option<f64> {
        self.preview.as_ref().map(|p| p.render_ms)
    }

    /// The picture on screen answers the newest request (nothing in flight).
    pub fn preview_is_current(&self) -> bool {
        self.preview_sent.is_some()
            && (self.preview_key() == self.preview_sent
                || self.preview_error.as_ref().map(|e| e.key) == self.preview_sent)
    }

    /// Where the preview pane drew its picture in the last pass, in points.
    pub fn preview_rect(&self) -> Option<Rect> {
        self.preview_rect
    }

    pub fn preview_error(&self) -> Option<&str> {
        self.preview_error.as_ref().map(|e| e.message.as_str())
    }

    pub fn summary(&self) -> Option<&Summary> {
        self.summary.as_ref().and_then(|s| s.as_ref().ok())
    }

    pub fn summary_is_current(&self) -> bool {
        self.summary()
            .is_some_and(|s| s.generation == self.generation)
    }

    pub fn batch_running(&self) -> bool {
        self.batch.is_some()
    }

    pub fn batch_outcome(&self) -> Option<&BatchOutcome> {
        self.batch_outcome.as_ref()
    }

    pub fn notices(&self) -> &[String] {
        &self.notices
    }

    /// The window title.
    pub fn title(&self) -> &str {
        &self.title
    }

    /// Bumped once per committed preset edit: every preview and summary request carries it.
    pub fn generation(&self) -> u64 {
        self.generation
    }

    /// The in-app file browser, while it is open.
    pub fn file_browser(&self) -> Option<&files::FileBrowser> {
        self.dialogs.browser()
    }

    /// The domain-gap report window.
    pub fn gap_panel(&self) -> &gap_panel::GapPanel {
        &self.gap
    }

    pub fn gap_panel_mut(&mut self) -> &mut gap_panel::GapPanel {
        &mut self.gap
    }

    /// The unsaved-changes prompt, while it is open.
    pub fn prompt(&self) -> Option<&Replace> {
        self.prompt.as_ref()
    }

    // ---- derived state --------------------------------------------------------------------

    /// Re-derive validation, the resolved preset and the summary after a preset edit.
    fn sync(&mut self, ctx: &egui::Context) {
        if self.seen.as_ref() == Some(&self.session.preset) {
            return;
        }
        // Typing "55" on the way to "5" must not build a 495-drone grid first.
        let typing = ctx.text_edit_focused();
        let now = ctx.input(|i| i.time);
        if let Gate::Wait(seconds) = self.gate.check(typing, &self.session.preset, now) {
            ctx.request_repaint_after(Duration::from_secs_f64(seconds));
            return;
        }
        self.generation += 1;
        self.seen = Some(self.session.preset.clone());
        self.errors = crate::pipeline::check::validate(&self.session.preset)
            .err()
            .unwrap_or_default();
        let mut resolved = self.session.preset.clone();
        let base = self
            .session
            .preset_path
            .as_deref()
            .and_then(Path::parent)
            .unwrap_or(Path::new("."));
        resolved.resolve_paths(base);
        self.resolved = Arc::new(resolved);
        // While the preset is invalid the frame count means nothing: keep the
        // frame, so a value that is briefly invalid does not send it back to 1.
        let frames = self.resolved.frame_count();
        if self.errors.is_empty() && self.session.frame >= frames {
            self.session.frame = frames.saturating_sub(1);
        }
        // Asked for once this edit's picture is on screen (`request_summary`).
        self.summary_due = self.errors.is_empty().then(Instant::now);
        ctx.request_repaint();
    }

    /// Ask for the summary of the committed preset once the preview of it is on
    /// screen (or failed, or none is coming), or after [`SUMMARY_DEFER`]: on two
    /// cores its estimate would otherwise share the CPU with the preview render and
    /// the window's paint of the picture, which the user waits for.
    fn request_summary(&mut self, ctx: &egui::Context) {
        let Some(since) = self.summary_due else {
            return;
        };
        let preview_failed = self.preview_error.as_ref().map(|e| e.key) == self.preview_sent;
        let no_preview = self
            .preview_sent
            .is_none_or(|k| k.generation != self.generation);
        let waiting = !(self.latency.idle() || preview_failed || no_preview);
        let left = SUMMARY_DEFER.saturating_sub(since.elapsed());
        if waiting && !left.is_zero() {
            ctx.request_repaint_after(left);
            return;
        }
        self.summary_due = None;
        if let Some(worker) = &self.summary_worker {
            worker.submit(SummaryRequest {
                generation: self.generation,
                preset: Arc::clone(&self.resolved),
            });
        }
    }

    /// Playing: move to the frame that is due (see [`playback`]).
    fn play_tick(&mut self, ctx: &egui::Context) {
        if !self.playback.is_playing() {
            return;
        }
        if !self.errors.is_empty() {
            self.playback.pause();
            return;
        }
        let frames = self.resolved.frame_count();
        let rate_hz = self.play_rate_hz();
        let shown = self
            .preview_key()
            .is_some_and(|k| k.frame == self.session.frame && k.generation == self.generation);
        let now = ctx.input(|i| i.time);
        let (frame, wake_s) = self
            .playback
            .tick(now, self.session.frame, frames, rate_hz, shown);
        if let Some(frame) = frame {
            self.session.frame = frame;
            ctx.request_repaint();
        }
        if let Some(seconds) = wake_s {
            ctx.request_repaint_after(Duration::from_secs_f64(seconds));
        }
    }

    /// The sequence's frame rate; None (as fast as pictures come) without a sequence.
    fn play_rate_hz(&self) -> Option<f64> {
        self.resolved
            .sequence
            .as_ref()
            .map(|s| f64::from(s.frame_rate))
    }

    /// Playback is running.
    pub fn is_playing(&self) -> bool {
        self.playback.is_playing()
    }

    /// Ask for a preview when what it depends on changed (and the preset is valid).
    fn request_preview(&mut self) {
        let Some(worker) = &self.preview_worker else {
            return;
        };
        if !self.errors.is_empty() || self.preview_size_px.contains(&0) {
            return;
        }
        let view = if self.session.inspect {
            PreviewView::Inspect(self.session.orbit)
        } else if self.session.through_camera && self.resolved.camera_model.is_some() {
            PreviewView::ThroughCamera
        } else {
            PreviewView::Camera
        };
        let key = PreviewKey {
            generation: self.generation,
            frame: self.session.frame,
            size_px: self.preview_size_px,
            view,
        };
        if self.preview_sent != Some(key) {
            worker.submit(PreviewRequest {
                key,
                preset: Arc::clone(&self.resolved),
            });
            self.preview_sent = Some(key);
            self.latency.asked(key, self.pass_start);
        }
    }

    /// Take what the workers and the batch thread finished.
    fn poll(&mut self, ctx: &egui::Context) {
        if let Some(result) = self.preview_worker.as_ref().and_then(LatestWorker::latest) {
            match result {
                Ok(frame) => {
                    self.show_texture(&frame.texture);
                    if self.latency.picture_taken(frame.key) {
                        // The next pass starts once this one is on screen: it times it.
                        ctx.request_repaint();
                    }
                    self.preview_error = None;
                    self.preview = Some(frame);
                }
                Err(e) => self.preview_error = Some(e),
            }
        }
        if let Some(summary) = self.summary_worker.as_ref().and_then(LatestWorker::latest) {
            self.summary = Some(summary);
        }
        if let Some(outcome) = self.merge.as_ref().and_then(|rx| rx.try_recv().ok()) {
            self.merge = None;
            self.merge_outcome = Some(outcome);
        }
        if let Some(outcome) = self.batch.as_ref().and_then(BatchRun::finished) {
            self.batch = None;
            self.batch_outcome = Some(outcome);
        }
    }

    /// Point the preview's egui texture at a freshly rendered wgpu texture.
    fn show_texture(&mut self, view: &wgpu::TextureView) {
        let Some((ctx, render_state)) = &self.gpu else {
            return;
        };
        let mut renderer = render_state.renderer.write();
        match self.preview_texture {
            Some(id) => renderer.update_egui_texture_from_wgpu_texture(
                &ctx.device,
                view,
                wgpu::FilterMode::Linear,
                id,
            ),
            None => {
                self.preview_texture = Some(renderer.register_native_texture(
                    &ctx.device,
                    view,
                    wgpu::FilterMode::Linear,
                ))
            }
        }
    }

    fn update_title(&mut self, ctx: &egui::Context) {
        let file = self
            .session
            .preset_path
            .as_ref()
            .map_or_else(|| "not saved".to_string(), |p| p.display().to_string());
        let marker = if self.session.is_dirty() {
            " • unsaved changes"
        } else {
            ""
        };
        let title = format!("{}{marker} ({file}) — {APP_NAME}", self.session.preset.name);
        if title != self.title {
            ctx.send_viewport_cmd(egui::ViewportCommand::Title(title.clone()));
            self.title = title;
        }
    }

    // ---- commands -------------------------------------------------------------------------

    fn apply(&mut self, command: Command, ctx: &egui::Context) {
        let locked = self.batch.is_some();
        match command {
            Command::New if !locked => self.guard(Replace::New, ctx),
            Command::Open if !locked => self.open_dialog(FilePurpose::OpenPreset, ctx),
            Command::OpenPath(path) if !locked => self.guard(Replace::Path(path), ctx),
            Command::OpenExample(path) if !locked => self.guard(Replace::Example(path), ctx),
            Command::Save => match self.session.preset_path.clone() {
                Some(path) => {
                    self.save_to(&path);
                }
                None => self.apply(Command::SaveAs, ctx),
            },
            Command::SaveAs => self.open_dialog(FilePurpose::SavePreset, ctx),
            Command::AddGltf if !locked => self.open_dialog(FilePurpose::AddModel, ctx),
            Command::BrowseOutDir if !locked => self.open_dialog(FilePurpose::OutputFolder, ctx),
            Command::Generate if !locked => self.generate(ctx),
            Command::Merge if !locked && self.merge.is_none() => self.start_merge(ctx),
            Command::Cancel => {
                if let Some(batch) = &self.batch {
                    batch.cancel();
                }
            }
            Command::OpenOutputFolder(dir) => {
                if let Err(e) = open::that_detached(&dir) {
                    let why = if e.kind() == std::io::ErrorKind::NotFound {
                        "no program to open folders is installed (xdg-open is missing)"
                    } else {
                        "no file manager is set up to open folders here"
                    };
                    self.notices.push(format!(
                        "Cannot open {}: {why}. Use \"Copy path\" under Batch and open it yourself.",
                        dir.display()
                    ));
                }
            }
            Command::Undo if !locked => {
                if let Some(preset) = self.history.undo(&self.session.preset) {
                    self.session.preset = preset;
                }
            }
            Command::Redo if !locked => {
                if let Some(preset) = self.history.redo(&self.session.preset) {
                    self.session.preset = preset;
                }
            }
            Command::ShowProblem(field) => {
                self.session.show_parameters = true;
                self.scroll_to = Some(field);
            }
            Command::StepFrame(delta) => {
                let last = self.resolved.frame_count().saturating_sub(1);
                self.session.frame = self.session.frame.saturating_add_signed(delta).min(last);
            }
            Command::FirstFrame => self.session.frame = 0,
            Command::LastFrame => {
                self.session.frame = self.resolved.frame_count().saturating_sub(1)
            }
            // Preset edits while a batch runs are ignored: the widgets are disabled anyway.
            _ => {}
        }
    }

    /// Replace the preset, asking first when it has unsaved changes.
    fn guard(&mut self, replace: Replace, ctx: &egui::Context) {
        if self.session.is_dirty() {
            self.prompt = Some(replace);
        } else {
            self.replace(replace, ctx);
        }
    }

    fn replace(&mut self, replace: Replace, ctx: &egui::Context) {
        match replace {
            Replace::New => self.session.load_untitled(Preset::default()),
            Replace::Path(path) => match read_preset(&path) {
                Ok(preset) => self.session.load(preset, path),
                Err(e) => return self.notices.push(e),
            },
            Replace::Example(path) => match read_preset(&path) {
                Ok(mut preset) => {
                    // An untitled copy: Save asks for a new file, so the shipped
                    // example is never overwritten; its model and sky paths are
                    // made absolute so the copy still finds them.
                    preset.resolve_paths(path.parent().unwrap_or(Path::new(".")));
                    self.session.load_untitled(preset);
                }
                Err(e) => return self.notices.push(e),
            },
            Replace::Close => {
                self.allow_close = true;
                ctx.send_viewport_cmd(egui::ViewportCommand::Close);
                return;
            }
        }
        self.history.clear();
    }

    /// The user answered the unsaved-changes prompt.
    fn answer(&mut self, answer: Answer, ctx: &egui::Context) {
        let Some(replace) = self.prompt.take() else {
            return;
        };
        match answer {
            Answer::Save => match self.session.preset_path.clone() {
                Some(path) => {
                    if self.save_to(&path) {
                        self.replace(replace, ctx);
                    }
                }
                None => {
                    self.after_save = Some(replace);
                    self.open_dialog(FilePurpose::SavePreset, ctx);
                }
            },
            Answer::Discard => self.replace(replace, ctx),
            Answer::Cancel => {}
        }
    }

    /// The folder dialogs start in: the preset's, else the working directory.
    fn preset_dir(&self) -> PathBuf {
        self.session
            .preset_path
            .as_deref()
            .and_then(Path::parent)
            .filter(|d| !d.as_os_str().is_empty())
            .map_or_else(|| PathBuf::from("."), Path::to_owned)
    }

    fn open_dialog(&mut self, purpose: FilePurpose, ctx: &egui::Context) {
        let (start, name) = match purpose {
            FilePurpose::SavePreset => {
                let name = match &self.session.preset_path {
                    Some(p) => p.file_name().map(|f| f.to_string_lossy().into_owned()),
                    None => Some(format!("{}.ron", self.session.preset.name.trim())),
                };
                (self.preset_dir(), name)
            }
            FilePurpose::OutputFolder => {
                let out = PathBuf::from(self.session.out_dir.trim());
                let start = if out.is_dir() {
                    out
                } else {
                    out.parent()
                        .filter(|p| p.is_dir())
                        .map_or_else(|| self.preset_dir(), Path::to_owned)
                };
                (start, None)
            }
            FilePurpose::OpenPreset | FilePurpose::AddModel => (self.preset_dir(), None),
        };
        let ctx = ctx.clone();
        self.dialogs
            .open(purpose, &start, name, move || ctx.request_repaint());
    }

    /// A dialog returned a path.
    fn chosen(&mut self, choice: FileChoice, ctx: &egui::Context) {
        let FileChoice { purpose, path } = choice;
        match purpose {
            FilePurpose::OpenPreset => self.apply(Command::OpenPath(path), ctx),
            FilePurpose::SavePreset => {
                if self.save_to(&path)
                    && let Some(replace) = self.after_save.take()
                {
                    self.replace(replace, ctx);
                }
            }
            FilePurpose::AddModel if self.batch.is_none() => {
                self.session.preset.models.push(ModelSpec {
                    source: ModelSource::File(path),
                    ..ModelSpec::default()
                });
            }
            FilePurpose::OutputFolder if self.batch.is_none() => {
                self.session.out_dir = path.display().to_string();
            }
            _ => {}
        }
    }

    /// Write the preset; false (with a notice) when it could not be written.
    fn save_to(&mut self, path: &Path) -> bool {
        let text = format!(
            "// swarmshot preset (RON), written by the swarmshot app\n{}\n",
            self.session.preset.to_ron()
        );
        match std::fs::write(path, text) {
            Ok(()) => {
                self.session.preset_path = Some(path.to_owned());
                self.session.saved = Some(self.session.preset.clone());
                true
            }
            Err(e) => {
                self.notices
                    .push(format!("cannot save preset {}: {e}", path.display()));
                false
            }
        }
    }

    /// `swarmshot merge` on a background thread: shard folders into the output folder.
    fn start_merge(&mut self, ctx: &egui::Context) {
        let shards = self.merge_shard_dirs();
        let out = PathBuf::from(self.session.out_dir.trim());
        let overwrite = self.session.overwrite;
        let (tx, rx) = crossbeam_channel::bounded(1);
        let wake = ctx.clone();
        let spawned = std::thread::Builder::new()
            .name("swarmshot merge".into())
            .spawn(move || {
                let result = crate::write::merge::merge(&out, &shards, overwrite, false)
                    .map(|r| {
                        format!(
                            "Merged {} shards into {}: {} frames ({} train / {} val / {} test), {} boxes",
                            r.shards,
                            out.display(),
                            group_digits(r.frames),
                            r.stats.frames_per_split[0],
                            r.stats.frames_per_split[1],
                            r.stats.frames_per_split[2],
                            r.stats.boxes
                        )
                    })
                    .map_err(|e| format!("{e:#}"));
                let _ = tx.send(result);
                wake.request_repaint();
            });
        match spawned {
            Ok(_) => {
                self.merge = Some(rx);
                self.merge_outcome = None;
            }
            Err(e) => self
                .notices
                .push(format!("cannot start the merge thread: {e}")),
        }
    }

    /// A merge has finished; its report line or error.
    pub fn merge_outcome(&self) -> Option<&Result<String, String>> {
        self.merge_outcome.as_ref()
    }

    fn generate(&mut self, ctx: &egui::Context) {
        if !self.errors.is_empty() {
            self.notices.push(format!(
                "cannot generate: the preset has {}, shown in the panels",
                problems::count_problems(self.errors.len())
            ));
            return;
        }
        let Some((gpu, _)) = &self.gpu else {
            self.notices.push("cannot generate: no wgpu device".into());
            return;
        };
        if self.session.out_dir.trim().is_empty() {
            self.notices
                .push("cannot generate: choose an output folder (Output panel)".into());
            return;
        }
        // The snapshot: later edits cannot reach the running batch.
        let preset = (*self.resolved).clone();
        let options = BatchOptions {
            out_dir: PathBuf::from(self.session.out_dir.trim()),
            limit: self.batch_limit(),
            overwrite: self.session.overwrite,
            resume: false,
            encoder_threads: 0,
            makers: 0,
            shard: self.batch_shard(),
            every: None,
        };
        let wake_ctx = ctx.clone();
        match BatchRun::start(preset, options, gpu.clone(), move || {
            wake_ctx.request_repaint()
        }) {
            Ok(run) => {
                self.batch = Some(run);
                self.batch_outcome = None;
                self.batch_inputs = Some(self.batch_inputs_now());
            }
            Err(e) => self
                .notices
                .push(format!("cannot start the batch thread: {e}")),
        }
    }

    // ---- panels ---------------------------------------------------------------------------

    fn menu_ui(&mut self, ui: &mut Ui, commands: &mut Vec<Command>) {
        let locked = self.batch.is_some();
        ui.horizontal(|ui| {
            ui.strong(APP_NAME);
            ui.separator();
            ui.add_enabled_ui(!locked, |ui| {
                if ui
                    .button("New")
                    .on_hover_text("Start from the default preset (Ctrl+N)")
                    .clicked()
                {
                    commands.push(Command::New);
                }
                if ui
                    .button("Open…")
                    .on_hover_text("Open a .ron preset (Ctrl+O)")
                    .clicked()
                {
                    commands.push(Command::Open);
                }
                ui.menu_button("Examples", |ui| {
                    let examples = example_presets();
                    if examples.is_empty() {
                        ui.label("no presets/ folder found");
                    }
                    for path in examples {
                        let name = path
                            .file_stem()
                            .map(|s| s.to_string_lossy().into_owned())
                            .unwrap_or_default();
                        if ui
                            .button(name)
                            .on_hover_text(format!(
                                "Open a copy of {}; Save asks where to keep it",
                                path.display()
                            ))
                            .clicked()
                        {
                            commands.push(Command::OpenExample(path));
                        }
                    }
                })
                .response
                .on_hover_text("Open a copy of one of the example presets in presets/");
            });
            if ui
                .button("Save")
                .on_hover_text("Save the preset to its file (Ctrl+S)")
                .clicked()
            {
                commands.push(Command::Save);
            }
            if ui
                .button("Save As…")
                .on_hover_text("Save the preset to a new file (Ctrl+Shift+S)")
                .clicked()
            {
                commands.push(Command::SaveAs);
            }
            ui.add_enabled_ui(!locked, |ui| {
                let preset = &self.session.preset;
                if ui
                    .add_enabled(self.history.can_undo(preset), egui::Button::new("Undo"))
                    .on_hover_text("Undo the last preset edit (Ctrl+Z)")
                    .clicked()
                {
                    commands.push(Command::Undo);
                }
                if ui
                    .add_enabled(self.history.can_redo(preset), egui::Button::new("Redo"))
                    .on_hover_text("Redo what Undo took back (Ctrl+Shift+Z)")
                    .clicked()
                {
                    commands.push(Command::Redo);
                }
            });
            ui.separator();
            ui.toggle_value(&mut self.session.show_parameters, "Parameters")
                .on_hover_text("Show or hide the parameter panel");
            ui.toggle_value(&mut self.session.show_summary, "Summary")
                .on_hover_text("Show or hide the Summary and Batch panel");
            ui.toggle_value(&mut self.gap.open, "Domain gap")
                .on_hover_text("Compare real frames with this preset's frames (swarmshot gap)");
            ui.separator();
            let (file, full) = match &self.session.preset_path {
                Some(p) => (
                    p.file_name().map_or_else(
                        || p.display().to_string(),
                        |f| f.to_string_lossy().into_owned(),
                    ),
                    p.display().to_string(),
                ),
                None => ("not saved".into(), "this preset has no file yet".into()),
            };
            ui.label(format!("{} ({file})", self.session.preset.name))
                .on_hover_text(full);
            if self.session.is_dirty() {
                ui.label(RichText::new("• unsaved changes").color(ui.visuals().warn_fg_color));
            }
        });
        let mut dismiss = None;
        for (i, notice) in self.notices.iter().enumerate() {
            ui.horizontal(|ui| {
                error_label(ui, notice);
                if ui
                    .small_button("Dismiss")
                    .on_hover_text("Hide this message")
                    .clicked()
                {
                    dismiss = Some(i);
                }
            });
        }
        if let Some(i) = dismiss {
            self.notices.remove(i);
        }
    }

    fn parameters_ui(&mut self, ui: &mut Ui, commands: &mut Vec<Command>) {
        let errors = self.errors.clone();
        let scroll_to = self.scroll_to.clone();
        let open_section = scroll_to.as_deref().and_then(problems::section_of);
        let mut form = Form::new(&errors, scroll_to.as_deref());
        let load_error = self
            .preview_error
            .as_ref()
            .filter(|e| e.models)
            .map(|e| e.message.clone());
        let s = &mut self.session;
        panels::general_ui(ui, &mut s.preset, &mut form);
        let section = |ui: &mut Ui, title: &str, tip: &str, add: &mut dyn FnMut(&mut Ui)| {
            // A Problems link opens the section that holds its field.
            let open = (open_section == Some(title)).then_some(true);
            // The realism sections start collapsed (most presets leave them off).
            let default_open = !problems::REALISM_SECTIONS.contains(&title);
            egui::CollapsingHeader::new(title)
                .default_open(default_open)
                .open(open)
                .show(ui, |ui| add(ui))
                .header_response
                .on_hover_text(tip);
        };
        section(
            ui,
            "Models",
            "The UAV models instantiated in every frame, with their real size",
            &mut |ui| {
                panels::models_ui(
                    ui,
                    &mut s.preset,
                    &mut form,
                    load_error.as_deref(),
                    commands,
                );
            },
        );
        section(
            ui,
            "Placement",
            "How drones are placed in the observation volume",
            &mut |ui| panels::placement_ui(ui, &mut s.preset, &mut form),
        );
        section(
            ui,
            "Attitude",
            "Random roll/pitch/yaw of each drone",
            &mut |ui| panels::attitude_ui(ui, &mut s.preset, &mut form),
        );
        section(
            ui,
            "Camera",
            "Camera translation sweeps; the camera always faces the volume's centre",
            &mut |ui| {
                panels::camera_ui(ui, &mut s.preset, &mut form);
                realism_panels::observer_ui(ui, &mut s.preset, &mut form);
            },
        );
        section(
            ui,
            "Scene rotation",
            "Rotation sweeps of the whole swarm",
            &mut |ui| panels::plane_ui(ui, &mut s.preset, &mut form),
        );
        section(ui, "Skybox", "The background environment", &mut |ui| {
            panels::skybox_ui(ui, &mut s.preset, &mut form)
        });
        section(
            ui,
            "Camera model",
            "Optics, sensor noise and image processing between the render and the file",
            &mut |ui| realism_panels::camera_model_ui(ui, &mut s.preset, &mut form),
        );
        section(
            ui,
            "Atmosphere",
            "Haze with range on every object",
            &mut |ui| realism_panels::atmosphere_ui(ui, &mut s.preset, &mut form),
        );
        section(
            ui,
            "Drone appearance",
            "Drone materials drawn per drone: colour, roughness, metalness, lights",
            &mut |ui| realism_panels::appearance_ui(ui, &mut s.preset, &mut form),
        );
        section(
            ui,
            "Clutter",
            "Tree lines, bare trees, poles and wires, buildings that hide the drones behind them",
            &mut |ui| clutter_panel::clutter_ui(ui, &mut s.preset, &mut form),
        );
        section(
            ui,
            "Confusers",
            "Birds, aircraft and balloons in the frames: labelled as a class or hard negatives",
            &mut |ui| confuser_panel::confusers_ui(ui, &mut s.preset, &mut form),
        );
        section(
            ui,
            "Backplates",
            "Photographic backgrounds: a folder of your own frames of sky and horizon",
            &mut |ui| backplate_panel::backplate_ui(ui, &mut s.preset, &mut form),
        );
        section(
            ui,
            "Output",
            "Resolution, file formats, split and folder",
            &mut |ui| {
                panels::output_ui(
                    ui,
                    &mut s.preset,
                    &mut form,
                    &mut s.out_dir,
                    &mut s.overwrite,
                    commands,
                );
            },
        );
        form.rest(ui);
        let wanted = self.scroll_to.as_deref();
        if form.scrolled() || !errors.iter().any(|e| Some(e.field.as_str()) == wanted) {
            self.scroll_to = None;
        }
    }

    fn summary_ui(&mut self, ui: &mut Ui) {
        ui.heading("Summary");
        let frames = self.resolved.frame_count();
        ui.label(format!("Frames: {}", group_digits(frames)));
        if !self.errors.is_empty() {
            ui.weak("paused until the problems below are fixed");
            return;
        }
        match &self.summary {
            None => {
                ui.weak("estimating…");
            }
            Some(Err(e)) => {
                error_label(ui, e);
            }
            Some(Ok(s)) => {
                let drones = if s.drones_min == s.drones_max {
                    format!("{}", s.drones_min)
                } else {
                    format!(
                        "{}–{} (mean {:.1})",
                        s.drones_min,
                        s.drones_max,
                        s.drones_mean()
                    )
                };
                ui.label(format!("Drones per frame: {drones}"));
                let [small, medium, large] = s.size_shares().map(|x| x * 100.0);
                ui.label(format!(
                    "Boxes per frame: {:.1}",
                    s.stats.boxes as f64 / s.sampled_frames.max(1) as f64
                ));
                confuser_panel::summary_classes_ui(ui, &s.stats, s.sampled_frames);
                ui.label(format!(
                    "Small {small:.0}% · medium {medium:.0}% · large {large:.0}%"
                ))
                .on_hover_text("Share of boxes with √(w·h) < 32 px, 32–96 px and > 96 px");
                ui.weak(format!(
                    "estimated from the geometry of {} sampled frames",
                    s.sampled_frames
                ));
                if s.generation != self.generation {
                    ui.weak("updating…");
                }
            }
        }
    }

    fn status_ui(&self, ui: &mut Ui) {
        ui.horizontal(|ui| {
            match &self.preview {
                Some(p) => {
                    let [w, h] = p.key.size_px;
                    ui.label(format!("preview {:.1} ms at {w}×{h}", p.render_ms))
                        .on_hover_text("Last preview render: frame build + encode + GPU");
                    if let (Some(last), Some((median, n))) =
                        (self.latency.last_ms(), self.latency.median_ms())
                    {
                        ui.label(format!("on screen {last:.0} ms (median {median:.0} ms of {n})"))
                            .on_hover_text(
                                "From the change (an edit taken, another frame, a resize) to its picture on screen: render, hand-over and the window's own paint",
                            );
                    }
                }
                None => {
                    ui.label("no preview yet");
                }
            }
            if !self.preview_is_current() && self.errors.is_empty() {
                // Words, not a spinner: a spinner repaints the whole window every
                // pass, which on a CPU renderer slows the render it waits for.
                ui.weak("rendering…");
            }
            if let Some((ctx, _)) = &self.gpu {
                ui.weak(ctx.describe());
            }
            if !self.errors.is_empty() {
                ui.label(
                    RichText::new(problems::count_problems(self.errors.len()))
                        .color(ui.visuals().error_fg_color),
                );
            }
        });
    }

    fn preview_ui(&mut self, ui: &mut Ui) {
        let frames = self.resolved.frame_count();
        ui.horizontal(|ui| {
            if frames > 1 {
                self.play_controls_ui(ui, frames);
            }
            ui.label(format!(
                "frame {} of {}",
                group_digits(self.session.frame + 1),
                group_digits(frames)
            ));
            // Sequence mode: scrubbing moves the swarm; say where in its sequence the frame is.
            if let Some(seq) = crate::scene::SequenceFrame::of(&self.resolved, self.session.frame) {
                ui.label(format!(
                    "· sequence {} · step {} of {}",
                    group_digits(seq.id + 1),
                    seq.step,
                    seq.steps
                ))
                .on_hover_text("Each sweep point is a sequence of T + 1 frames; t = 0..=T");
            }
            if frames > 1 {
                let max = frames - 1;
                ui.spacing_mut().slider_width = (ui.available_width() - 40.0).max(100.0);
                let slider = ui
                    .add_enabled(
                        self.errors.is_empty(),
                        egui::Slider::new(&mut self.session.frame, 0..=max).show_value(false),
                    )
                    .accessible_name("Frame")
                    .on_hover_text(
                        "Scrub through the sweep: every frame the batch will make (Left and Right arrow keys, Home, End)",
                    );
                self.frame_slider = Some(slider.id);
            }
        });
        let sweep_line = self
            .preview
            .as_ref()
            .filter(|p| p.key.frame == self.session.frame && p.key.generation == self.generation)
            .map(|p| sweep_line(p, &self.resolved));
        ui.label(sweep_line.unwrap_or_else(|| " ".into()));
        ui.horizontal(|ui| {
            ui.checkbox(&mut self.session.show_boxes, "Boxes")
                .on_hover_text("Draw the label boxes this frame gets");
            if self.session.show_boxes && !self.session.inspect {
                box_legend_ui(ui);
            }
            if !self.session.inspect {
                ui.add_enabled(
                    self.resolved.camera_model.is_some(),
                    egui::Checkbox::new(&mut self.session.through_camera, "Through the camera"),
                )
                .on_hover_text(
                    "Show the frame through the camera model (noise, blur, JPEG, …) as the batch writes it, scaled to the pane; off: the clean render",
                )
                .on_disabled_hover_text("The preset has no camera model (Camera model section)");
            }
            ui.checkbox(&mut self.session.inspect, "Inspect")
                .on_hover_text(
                    "Orbit around the scene: volume, drones and the sweep's camera positions",
                );
            if self.session.inspect {
                if ui
                    .button("Reset view")
                    .on_hover_text("Back to the default orbit")
                    .clicked()
                {
                    self.session.orbit = Orbit::default();
                }
                ui.weak("drag to orbit, scroll to zoom");
            }
        });

        let (out_w, out_h) = self.resolved.image_size();
        let aspect = out_w.max(1) as f32 / out_h.max(1) as f32;
        let avail = ui.available_size();
        let mut size = Vec2::new(avail.x, avail.x / aspect);
        if size.y > avail.y {
            size = Vec2::new(avail.y * aspect, avail.y);
        }
        let ppp = ui.ctx().pixels_per_point();
        let scale = ((size.x * ppp) / out_w.max(1) as f32).min(1.0);
        self.preview_size_px = [
            ((out_w as f32 * scale).round() as u32).max(1),
            ((out_h as f32 * scale).round() as u32).max(1),
        ];
        if size.x < 8.0 || size.y < 8.0 {
            self.preview_size_px = [0, 0];
            return;
        }
        let (rect, response) = ui.allocate_exact_size(size, Sense::click_and_drag());
        self.preview_rect = Some(rect);
        let painter = ui.painter_at(rect);
        painter.rect_filled(rect, 0.0, Color32::from_gray(20));
        if let (Some(frame), Some(texture)) = (&self.preview, self.preview_texture) {
            let tint = if self.errors.is_empty() {
                Color32::WHITE
            } else {
                Color32::from_gray(90)
            };
            painter.image(
                texture,
                rect,
                Rect::from_min_max(Pos2::ZERO, Pos2::new(1.0, 1.0)),
                tint,
            );
            match &frame.inspect {
                None if self.session.show_boxes => draw_boxes(&painter, rect, frame, out_w),
                None => {}
                Some(_) => draw_inspect(&painter, rect, frame),
            }
        }
        if self.session.inspect {
            if response.dragged() {
                let d = response.drag_delta();
                let orbit = &mut self.session.orbit;
                orbit.yaw_deg -= f64::from(d.x) * 0.4;
                orbit.pitch_deg = (orbit.pitch_deg + f64::from(d.y) * 0.4).clamp(-89.0, 89.0);
            }
            if response.hovered() {
                let scroll = ui.input(|i| i.smooth_scroll_delta.y);
                if scroll != 0.0 {
                    self.session.orbit.zoom = (self.session.orbit.zoom
                        * (-f64::from(scroll) * 0.002).exp())
                    .clamp(0.02, 10.0);
                }
            }
        }
        let message = if !self.errors.is_empty() {
            let first = &self.errors[0];
            Some(format!(
                "Preview paused: {}, first {} ({}). See Problems on the right.",
                problems::count_problems(self.errors.len()),
                problems::field_label(&first.field),
                first.message
            ))
        } else {
            self.preview_error
                .as_ref()
                .map(|e| format!("Preview failed: {}", e.message))
        };
        if let Some(message) = message {
            let colour = ui.visuals().error_fg_color;
            let area = Rect::from_center_size(rect.center(), Vec2::new(rect.width() * 0.9, 60.0));
            ui.put(
                area,
                egui::Label::new(
                    RichText::new(message)
                        .size(16.0)
                        .color(colour)
                        .background_color(Color32::from_black_alpha(160)),
                ),
            );
        }
    }
}

impl Session {
    fn load(&mut self, preset: Preset, path: PathBuf) {
        self.saved = Some(preset.clone());
        self.preset = preset;
        self.preset_path = Some(path);
        self.frame = 0;
    }

    /// A preset with no file yet (New, an example's copy); nothing is unsaved until it is edited.
    fn load_untitled(&mut self, preset: Preset) {
        self.saved = Some(preset.clone());
        self.preset = preset;
        self.preset_path = None;
        self.frame = 0;
    }
}

impl SwarmshotApp {
    /// Play / Pause and Loop, left of the frame counter.
    fn play_controls_ui(&mut self, ui: &mut Ui, frames: u64) {
        let speed = match self.play_rate_hz() {
            Some(rate) => format!(
                "at the sequence's {rate} frames/s; frames are skipped when the preview is slower"
            ),
            None => "as fast as the preview renders them".into(),
        };
        let enabled = self.errors.is_empty();
        if self.playback.is_playing() {
            if ui
                .button("Pause")
                .on_hover_text("Stop playing at this frame")
                .clicked()
            {
                self.playback.pause();
            }
        } else if ui
            .add_enabled(enabled, egui::Button::new("Play"))
            .on_hover_text(format!("Play the frames {speed}"))
            .clicked()
        {
            self.session.frame = self.playback.play(self.session.frame, frames);
        }
        ui.checkbox(&mut self.playback.looping, "Loop")
            .on_hover_text("Start again from the first frame after the last");
    }
}

/// "CameraX 0 · … · CameraZ 1.2 · … · 14 drones, 14 boxes", values to their step's precision.
fn sweep_line(frame: &PreviewFrame, preset: &Preset) -> String {
    let s = &frame.scene.sweep;
    let (c, p) = (&preset.camera, &preset.plane);
    format!(
        "CameraX {} · CameraY {} · CameraZ {} · PlaneRX {}° · PlaneRY {}° · PlaneRZ {}° · repeat {} · {} split · {} drones, {} boxes",
        format_to_step(s.CameraX, &c.x),
        format_to_step(s.CameraY, &c.y),
        format_to_step(s.CameraZ, &c.z),
        format_to_step(s.PlaneRX, &p.rx),
        format_to_step(s.PlaneRY, &p.ry),
        format_to_step(s.PlaneRZ, &p.rz),
        s.repeat,
        frame.scene.split.as_str(),
        frame.scene.drones.len(),
        frame.labels.iter().filter(|l| l.is_kept()).count()
    )
}

/// Training boxes are red and COCO crowd regions amber, as [`draw_boxes`] draws them.
const BOX_KEPT: Color32 = Color32::from_rgb(255, 60, 60);
const BOX_CROWD: Color32 = Color32::from_rgb(255, 190, 40);
/// Unlabelled hard negatives (confusers without a class): their own colour.
const BOX_NEGATIVE: Color32 = Color32::from_rgb(60, 200, 255);

fn box_legend_ui(ui: &mut Ui) {
    // Painted swatches: the default fonts have no "■".
    let swatch = |ui: &mut Ui, colour: Color32, tip: &str| {
        let (rect, response) = ui.allocate_exact_size(Vec2::splat(10.0), Sense::hover());
        ui.painter().rect_stroke(
            rect,
            0.0,
            Stroke::new(2.0, colour),
            egui::StrokeKind::Inside,
        );
        response.on_hover_text(tip);
    };
    swatch(ui, BOX_KEPT, "A box written to the labels");
    ui.weak("label box");
    swatch(
        ui,
        BOX_CROWD,
        "A filtered drone kept as a COCO iscrowd region (Output panel, Filtered drones: COCO crowd); trainers ignore it",
    );
    ui.weak("crowd region (ignored)");
    swatch(
        ui,
        BOX_NEGATIVE,
        "An unlabelled hard negative (Confusers panel): in the manifest only, never in YOLO/COCO",
    );
    ui.weak("hard negative");
}

fn format_duration(d: Duration) -> String {
    let s = d.as_secs();
    if s >= 3600 {
        format!("{}:{:02}:{:02}", s / 3600, s / 60 % 60, s % 60)
    } else {
        format!("{}:{:02}", s / 60, s % 60)
    }
}

/// The label boxes, from output pixels to the pane.
fn draw_boxes(painter: &egui::Painter, rect: Rect, frame: &PreviewFrame, out_w: u32) {
    let scale = rect.width() / out_w.max(1) as f32;
    let kept = Stroke::new(1.5, BOX_KEPT);
    let crowd = Stroke::new(1.0, BOX_CROWD);
    let negative = Stroke::new(1.0, BOX_NEGATIVE);
    for label in &frame.labels {
        // Training boxes in red, COCO crowd (ignore) regions in amber; filtered drones get none.
        let stroke = match label.status {
            crate::annotate::LabelStatus::Kept => kept,
            crate::annotate::LabelStatus::Crowd => crowd,
            crate::annotate::LabelStatus::Filtered => continue,
            crate::annotate::LabelStatus::Negative => negative,
        };
        let b = &label.bbox;
        let r = Rect::from_min_max(
            rect.min + Vec2::new(b.x0 as f32, b.y0 as f32) * scale,
            rect.min + Vec2::new(b.x1 as f32, b.y1 as f32) * scale,
        );
        painter.rect_stroke(r.expand(1.0), 0.0, stroke, egui::StrokeKind::Outside);
    }
}

/// The inspect view's overlay: volume box, sweep camera positions, this frame's camera.
fn draw_inspect(painter: &egui::Painter, rect: Rect, frame: &PreviewFrame) {
    let Some(geometry) = &frame.inspect else {
        return;
    };
    let camera = &frame.camera;
    let scale = rect.width() / camera.width.max(1) as f32;
    let to_screen = |p: DVec3| -> Option<Pos2> {
        let pc = camera.camera_from_world_point(p);
        if pc.z < camera.near_m {
            return None;
        }
        let uv = camera.project_camera_point(pc)?;
        Some(rect.min + Vec2::new(uv.x as f32, uv.y as f32) * scale)
    };
    let volume = Stroke::new(1.0, Color32::from_rgb(230, 230, 230));
    let corners = &geometry.volume_corners;
    for i in 0..8 {
        for bit in [1, 2, 4] {
            let j = i | bit;
            if j != i
                && let (Some(a), Some(b)) = (to_screen(corners[i]), to_screen(corners[j]))
            {
                painter.line_segment([a, b], volume);
            }
        }
    }
    for p in &geometry.sweep_cameras {
        if let Some(s) = to_screen(*p) {
            painter.circle_filled(s, 2.5, Color32::from_rgb(255, 210, 60));
        }
    }
    if let (Some(cam), Some(centre)) = (to_screen(geometry.frame_camera), to_screen(DVec3::ZERO)) {
        painter.line_segment(
            [cam, centre],
            Stroke::new(1.0, Color32::from_rgb(255, 80, 80)),
        );
        painter.circle_filled(cam, 5.0, Color32::from_rgb(255, 80, 80));
    }
    let legend = format!(
        "white: observation volume · yellow: {} {} · red: this frame's camera",
        group_digits(geometry.sweep_cameras_total),
        if geometry.sweep_cameras_total == 1 {
            "sweep camera position"
        } else {
            "sweep camera positions"
        }
    );
    painter.text(
        rect.left_bottom() + Vec2::new(6.0, -6.0),
        egui::Align2::LEFT_BOTTOM,
        legend,
        egui::FontId::proportional(12.0),
        Color32::WHITE,
    );
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

/// What a Generate was asked to do; see [`SwarmshotApp::forget_stale_failure`].
type BatchInputs = (
    u64,
    String,
    bool,
    Option<u64>,
    Option<crate::write::shard::Shard>,
);

impl SwarmshotApp {
    fn batch_inputs_now(&self) -> BatchInputs {
        (
            self.generation,
            self.session.out_dir.trim().to_owned(),
            self.session.overwrite,
            self.batch_limit(),
            self.batch_shard(),
        )
    }

    /// A "Batch failed" message speaks of the inputs it failed on: once the
    /// preset, the folder, Overwrite or the trial run changed it is gone.
    fn forget_stale_failure(&mut self) {
        if matches!(self.batch_outcome, Some(BatchOutcome::Failed(_)))
            && self.batch_inputs.as_ref() != Some(&self.batch_inputs_now())
        {
            self.batch_outcome = None;
        }
    }

    /// Closing the window with unsaved changes asks first.
    fn close_requested(&mut self, ctx: &egui::Context) {
        if ctx.input(|i| i.viewport().close_requested())
            && !self.allow_close
            && self.session.is_dirty()
        {
            ctx.send_viewport_cmd(egui::ViewportCommand::CancelClose);
            self.prompt = Some(Replace::Close);
        }
    }

    /// Shortcuts, unless a dialog or the prompt has the keyboard.
    fn shortcut_commands(&self, ctx: &egui::Context) -> Vec<Command> {
        if self.prompt.is_some() || self.dialogs.is_open() {
            return Vec::new();
        }
        let focused = ctx.memory(|m| m.focused());
        let frame_keys = focused.is_none() || focused == self.frame_slider;
        keys::shortcuts(ctx, ctx.text_edit_focused(), frame_keys)
    }

    /// The panels: menu, status, the collapsible parameters and summary, the preview.
    fn panels_ui(&mut self, ui: &mut Ui, commands: &mut Vec<Command>) {
        let locked = self.batch.is_some();
        egui::Panel::top("menu").show(ui, |ui| self.menu_ui(ui, commands));
        egui::Panel::bottom("status").show(ui, |ui| self.status_ui(ui));
        let mut show_parameters = self.session.show_parameters;
        egui::Panel::left("parameters")
            .resizable(true)
            .default_size(430.0)
            .show_collapsible(ui, &mut show_parameters, |ui| {
                egui::ScrollArea::vertical().show(ui, |ui| {
                    ui.add_enabled_ui(!locked, |ui| self.parameters_ui(ui, commands));
                });
            });
        self.session.show_parameters = show_parameters;
        let mut show_summary = self.session.show_summary;
        egui::Panel::right("summary")
            .resizable(true)
            .default_size(250.0)
            .show_collapsible(ui, &mut show_summary, |ui| {
                egui::ScrollArea::vertical().show(ui, |ui| {
                    self.summary_ui(ui);
                    ui.separator();
                    if let Some(field) = problems::problems_ui(ui, &self.errors) {
                        commands.push(Command::ShowProblem(field));
                    }
                    if !self.errors.is_empty() {
                        ui.separator();
                    }
                    self.batch_ui(ui, commands);
                });
            });
        self.session.show_summary = show_summary;
        egui::CentralPanel::default().show(ui, |ui| self.preview_ui(ui));
    }
}

impl Drop for SwarmshotApp {
    /// Closing the window mid-batch cancels it and waits for the frames in
    /// flight, so the dataset on disk stays consistent.
    fn drop(&mut self) {
        if let Some(batch) = self.batch.take() {
            batch.cancel();
            for _ in 0..600 {
                if batch.finished().is_some() {
                    break;
                }
                std::thread::sleep(Duration::from_millis(50));
            }
        }
    }
}
