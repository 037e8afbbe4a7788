//! Test hooks: what the GUI tests (`tests/gui*.rs`, egui_kittest) and the app's
//! benchmarks (`examples/app_bench.rs`, `examples/preview_bench.rs`) read and drive
//! the app with. Compiled only with the `test-hooks` feature, which `cargo test` and
//! the examples turn on through the crate's dev-dependency on itself (Cargo.toml), so
//! none of it is part of a shipped build's API: the app itself reads its own fields.

use egui::Rect;

use super::files::{self, DialogBackend, FileDialogs};
use super::mask_view::{MaskKey, MaskPicture};
use super::preview::PreviewKey;
use super::prompt::Replace;
use super::runner::BatchOutcome;
use super::summary::Summary;
use super::{Command, Session, SwarmshotApp, fit_panel, gap_panel, latency, preview_pane};
use crate::preset::FieldError;
use crate::write::merge::MergeError;

impl SwarmshotApp {
    /// Apply a [`Command`] as if a widget or a shortcut gave it (benchmarks drive
    /// the app in a real window with it).
    pub fn command(&mut self, command: Command, ctx: &egui::Context) {
        self.apply(command, ctx);
    }

    /// Take `path` as a dialog's answer for `purpose`, as if the user chose it.
    pub fn choose(
        &mut self,
        purpose: files::FilePurpose,
        path: std::path::PathBuf,
        ctx: &egui::Context,
    ) {
        self.chosen(files::FileChoice { purpose, path }, ctx);
    }

    /// Use this kind of file dialog from now on (tests pin the in-app browser).
    pub fn use_file_dialogs(&mut self, backend: DialogBackend, ctx: &egui::Context) {
        let ctx = ctx.clone();
        self.dialogs = FileDialogs::new(backend, move || ctx.request_repaint());
    }

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
        self.shown_key()
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
        self.picture_is_current()
    }

    /// Where the preview pane drew its picture in the last pass, in points.
    pub fn preview_rect(&self) -> Option<Rect> {
        self.preview_rect
    }

    /// Screen pixels per output pixel of the picture shown (1: a 1:1 view; it grows as
    /// the wheel zooms in).
    pub fn shown_pixel_scale(&self) -> Option<f32> {
        self.pixel_scale
    }

    /// The preview's zoom and the part of the frame it shows.
    pub fn pane_view(&self) -> preview_pane::PaneView {
        self.pane_view
    }

    /// The central panel (frame bar, toggles and preview) in the last pass, in points.
    pub fn central_rect(&self) -> Option<Rect> {
        self.central_rect
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

    /// The Fit window.
    pub fn fit_panel(&self) -> &fit_panel::FitPanel {
        &self.fit
    }

    pub fn fit_panel_mut(&mut self) -> &mut fit_panel::FitPanel {
        &mut self.fit
    }

    /// The unsaved-changes prompt, while it is open.
    pub fn prompt(&self) -> Option<&Replace> {
        self.prompt.as_ref()
    }

    /// The mask picture last made (it belongs to [`MaskPicture::key`]).
    pub fn mask_picture(&self) -> Option<&MaskPicture> {
        self.mask_pane.picture.as_ref()
    }

    /// Why the mask thread could not make the masks of this key, if it could not.
    pub fn mask_error(&self) -> Option<&(MaskKey, String)> {
        self.mask_pane.error.as_ref()
    }

    /// A merge has finished; its report line or error.
    pub fn merge_outcome(&self) -> Option<&Result<String, MergeError>> {
        self.merge_outcome.as_ref()
    }
}
