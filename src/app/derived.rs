//! State derived from the committed preset after each UI pass: validation,
//! the resolved preset, preview and summary requests, playback, the title,
//! and what the worker threads finished.

use std::path::Path;
use std::sync::Arc;
use std::time::{Duration, Instant};

use super::history::Gate;
use super::preview::{PreviewKey, PreviewRequest, PreviewView};
use super::runner::BatchRun;
use super::summary::SummaryRequest;
use super::worker::LatestWorker;
use super::{APP_NAME, SUMMARY_DEFER, SwarmshotApp};

impl SwarmshotApp {
    /// Re-derive validation, the resolved preset and the summary after a preset edit.
    pub(super) fn sync(&mut self, ctx: &egui::Context) {
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
        // The app renders every frame it makes (it has no labels-only batch): a frame
        // over the render budget is a problem here, as `swarmshot batch` refuses it.
        self.errors
            .extend(self.session.preset.check_render_budget().err());
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
    pub(super) fn request_summary(&mut self, ctx: &egui::Context) {
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
    pub(super) fn play_tick(&mut self, ctx: &egui::Context) {
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
            .shown_key()
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
    pub(super) fn play_rate_hz(&self) -> Option<f64> {
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
    pub(super) fn request_preview(&mut self) {
        let Some(worker) = &self.preview_worker else {
            return;
        };
        if !self.errors.is_empty() || self.preview_size_px.contains(&0) {
            return;
        }
        let view = if self.session.inspect {
            PreviewView::Inspect(self.session.orbit)
        } else if !self.session.clean_preview && self.resolved.camera_model.is_some() {
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
    pub(super) fn poll(&mut self, ctx: &egui::Context) {
        self.poll_masks();
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

    /// Show a freshly rendered preview texture from this pass on.
    pub(super) fn show_texture(&mut self, view: &wgpu::TextureView) {
        if let Some(flat) = &mut self.flat {
            flat.set_picture(view);
        }
    }

    pub(super) fn update_title(&mut self, ctx: &egui::Context) {
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
}

impl SwarmshotApp {
    /// The Domain gap and Fit windows' requests: their folder dialogs, the preset a
    /// fit wrote (opened, asking first about unsaved changes), and a pause of
    /// playback when a report or a fit starts, so the preview's renders leave the
    /// CPU to it.
    pub(super) fn background_jobs(&mut self, commands: &mut Vec<super::Command>) {
        use super::Command;
        use super::files::FilePurpose;
        for (asked, purpose) in [
            (
                std::mem::take(&mut self.gap.browse_real),
                FilePurpose::RealFrames,
            ),
            (
                std::mem::take(&mut self.fit.browse_real),
                FilePurpose::FitRealFrames,
            ),
            (
                std::mem::take(&mut self.fit.browse_out),
                FilePurpose::FitOutput,
            ),
        ] {
            if asked {
                commands.push(Command::BrowseFolder(purpose));
            }
        }
        if let Some(fitted) = self.fit.take_fitted() {
            commands.push(Command::OpenPath(fitted));
        }
        if self.gap.take_started() | self.fit.take_started() {
            self.playback.pause();
        }
    }
}
