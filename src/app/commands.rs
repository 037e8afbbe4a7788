//! [`Command`]s applied after the UI pass: New/Open/Save with the
//! unsaved-changes prompt, file dialogs, Generate, Merge, undo and frame steps.

use std::path::{Path, PathBuf};

use super::files::{FileChoice, FilePurpose};
use super::panels::group_digits;
use super::prompt::{Answer, Replace};
use super::runner::{BatchOutcome, BatchRun};
use super::{Command, SwarmshotApp, keys, preset_text, problems, read_preset_text};
use crate::preset::{ModelSource, ModelSpec, Preset};
use crate::write::folder::outdir::OutDir;

impl SwarmshotApp {
    pub(super) fn apply(&mut self, command: Command, ctx: &egui::Context) {
        let locked = self.batch.is_some();
        match command {
            Command::New if !locked => self.guard(Replace::New, ctx),
            Command::Open if !locked => self.open_dialog(FilePurpose::OpenPreset, ctx),
            Command::OpenPath(path) if !locked => self.guard(Replace::Path(path), ctx),
            Command::OpenExample(path) if !locked => self.guard(Replace::Example(path), ctx),
            Command::Save => match self.session.preset_path.clone() {
                Some(path) => {
                    self.save_in_place(&path);
                }
                None => self.apply(Command::SaveAs, ctx),
            },
            Command::SaveAs => self.open_dialog(FilePurpose::SavePreset, ctx),
            Command::AddGltf if !locked => self.open_dialog(FilePurpose::AddModel, ctx),
            Command::BrowseOutDir if !locked => self.open_dialog(FilePurpose::OutputFolder, ctx),
            // The Domain gap and Fit windows' folders are theirs, not the batch's.
            Command::BrowseFolder(purpose) if !locked || !purpose.edits_preset() => {
                self.open_dialog(purpose, ctx)
            }
            Command::Generate if !locked => self.generate(ctx),
            Command::Merge if !locked && self.merge.is_none() => self.start_merge(ctx),
            Command::Quit => self.guard(Replace::Close, ctx),
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
            // Another preset (a shortcut, or a finished fit's) waits for the batch: said so.
            Command::New | Command::Open | Command::OpenPath(_) | Command::OpenExample(_) => {
                self.notices.push(BATCH_RUNNING.into())
            }
            // Preset edits while a batch runs are ignored: the widgets are disabled anyway.
            _ => {}
        }
    }

    /// Replace the preset, asking first when it has unsaved changes.
    pub(super) fn guard(&mut self, replace: Replace, ctx: &egui::Context) {
        if self.session.is_dirty() {
            self.prompt = Some(replace);
        } else {
            self.replace(replace, ctx);
        }
    }

    pub(super) fn replace(&mut self, replace: Replace, ctx: &egui::Context) {
        match replace {
            Replace::New => self.session.load_untitled(Preset::default(), None),
            Replace::Path(path) => match read_preset_text(&path) {
                Ok((preset, text)) => self.session.load(preset, path, text),
                Err(e) => return self.notices.push(e.to_string()),
            },
            Replace::Example(path) => match read_preset_text(&path) {
                Ok((mut preset, text)) => {
                    // An untitled copy: Save asks for a new file, so the shipped
                    // example is never overwritten; its model and sky paths are
                    // made absolute so the copy still finds them.
                    preset.resolve_paths(path.parent().unwrap_or(Path::new(".")));
                    // Its text goes with it: Save As keeps the example's comments.
                    self.session.load_untitled(preset, Some(text));
                }
                Err(e) => return self.notices.push(e.to_string()),
            },
            Replace::Close => {
                // Discard means it: the session stored on exit (and restored at the
                // next start) holds the preset as in its file, not the dropped edits.
                if let Some(saved) = self.session.saved.clone() {
                    self.session.preset = saved;
                }
                self.allow_close = true;
                ctx.send_viewport_cmd(egui::ViewportCommand::Close);
                return;
            }
        }
        // Another preset's frames have another size: its picture opens whole (Fit).
        self.pane_view = super::preview_pane::PaneView::default();
        // The Batch panel's report and a merge's line speak of the preset that went.
        self.batch_outcome = None;
        self.batch_inputs = None;
        self.merge_outcome = None;
        self.history.clear();
    }

    /// The user answered the unsaved-changes prompt.
    pub(super) fn answer(&mut self, answer: Answer, ctx: &egui::Context) {
        let Some(replace) = self.prompt.take() else {
            return;
        };
        match answer {
            Answer::Save => match self.session.preset_path.clone() {
                Some(path) => {
                    if self.save_in_place(&path) {
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
    pub(super) fn preset_dir(&self) -> PathBuf {
        self.session
            .preset_path
            .as_deref()
            .and_then(Path::parent)
            .filter(|d| !d.as_os_str().is_empty())
            .map_or_else(|| PathBuf::from("."), Path::to_owned)
    }

    pub(super) fn open_dialog(&mut self, purpose: FilePurpose, ctx: &egui::Context) {
        let (start, name) = match purpose {
            FilePurpose::SavePreset => {
                let name = match &self.session.preset_path {
                    Some(p) => p.file_name().map(|f| f.to_string_lossy().into_owned()),
                    None => Some(format!("{}.ron", self.session.preset.name.trim())),
                };
                (self.preset_dir(), name)
            }
            FilePurpose::OutputFolder => {
                let out = super::paths::typed(&self.session.out_dir);
                let start = if out.is_dir() {
                    out
                } else {
                    out.parent()
                        .filter(|p| p.is_dir())
                        .map_or_else(|| self.preset_dir(), Path::to_owned)
                };
                (start, None)
            }
            FilePurpose::BackplateFolder => {
                let folder =
                    (self.resolved.backplate.as_ref()).map(|b| super::paths::lexical(&b.folder));
                let start = folder.filter(|f| f.is_dir());
                (start.unwrap_or_else(|| self.preset_dir()), None)
            }
            FilePurpose::RealFrames | FilePurpose::FitRealFrames | FilePurpose::FitOutput => {
                let named = match purpose {
                    FilePurpose::RealFrames => &self.gap.real_dir,
                    FilePurpose::FitRealFrames => &self.fit.real_dir,
                    _ => &self.fit.out_dir,
                };
                let named = super::paths::typed(named);
                let start = [Some(named.as_path()), named.parent()]
                    .into_iter()
                    .flatten()
                    .find(|p| p.is_dir())
                    .map_or_else(|| self.preset_dir(), Path::to_owned);
                (start, None)
            }
            FilePurpose::OpenPreset | FilePurpose::AddModel => (self.preset_dir(), None),
        };
        let ctx = ctx.clone();
        self.dialogs
            .open(purpose, &start, name, move || ctx.request_repaint());
    }

    /// A dialog returned a path.
    pub(super) fn chosen(&mut self, choice: FileChoice, ctx: &egui::Context) {
        let FileChoice { purpose, path } = choice;
        // Paths the app keeps as text or writes into a preset must read back as the same
        // file: a name that is not UTF-8 would be stored as another one.
        if purpose != FilePurpose::OpenPreset && path.to_str().is_none() {
            self.notices.push(format!(
                "cannot use {}: its name is not UTF-8 text; rename it or choose another",
                path.display()
            ));
            return;
        }
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
            FilePurpose::BackplateFolder if self.batch.is_none() => {
                // Stored as preset paths are read: from the preset's folder.
                let folder = super::paths::for_preset(&path, &self.preset_dir());
                if let Some(b) = &mut self.session.preset.backplate {
                    b.folder = folder;
                }
            }
            FilePurpose::RealFrames => self.gap.real_dir = path.display().to_string(),
            FilePurpose::FitRealFrames => self.fit.real_dir = path.display().to_string(),
            FilePurpose::FitOutput => self.fit.out_dir = path.display().to_string(),
            _ => {}
        }
    }

    /// Save over the preset's own file, unless the file changed on disk since it was read
    /// or saved here (an edit made elsewhere is not overwritten unseen: Save As… asks).
    fn save_in_place(&mut self, path: &Path) -> bool {
        let on_disk = crate::input::read_input_file(path, crate::preset::MAX_PRESET_BYTES);
        let known = self.session.saved_text.as_deref().map(str::as_bytes);
        if let (Ok(bytes), Some(known)) = (on_disk, known)
            && bytes != known
        {
            self.notices.push(format!(
                "cannot save preset {}: it changed on disk since it was opened or saved here; \
                 Save As… replaces it (after asking), or open it again to see the change",
                path.display()
            ));
            return false;
        }
        self.save_to(path)
    }

    /// Write the preset; false (with a notice) when it could not be written.
    pub(super) fn save_to(&mut self, path: &Path) -> bool {
        if let Some(field) = self.reads(path) {
            self.notices.push(format!(
                "cannot save preset {}: the preset reads that file ({field}); choose another name",
                path.display()
            ));
            return false;
        }
        let preset = self.preset_for(path);
        // The file's own text with the changed fields rewritten: comments and order kept.
        let text = preset_text::save_text(self.session.saved_text.as_deref(), &preset);
        match write_preset_file(path, &text) {
            Ok(()) => {
                if preset != self.session.preset {
                    // Its paths read from the new folder: undo cannot bring back the old ones.
                    self.session.preset = preset;
                    self.history.clear();
                }
                self.session.preset_path = Some(path.to_owned());
                self.session.saved = Some(self.session.preset.clone());
                self.session.saved_text = Some(text);
                true
            }
            Err(e) => {
                self.notices
                    .push(format!("cannot save preset {}: {e}", path.display()));
                false
            }
        }
    }

    /// The field naming `path` among the files the preset reads (a model, a sky image),
    /// if it is one of them.
    fn reads(&self, path: &Path) -> Option<&'static str> {
        let path = std::fs::canonicalize(path).ok()?;
        (self.resolved.input_paths().into_iter())
            .find(|(_, read)| std::fs::canonicalize(read).is_ok_and(|r| r == path))
            .map(|(field, _)| field)
    }

    /// The preset as written to `path`: saved into another folder, each relative path
    /// it reads (models, sky images, backplates) rewritten to name the same file from there.
    fn preset_for(&self, path: &Path) -> Preset {
        let mut preset = self.session.preset.clone();
        let (from, to) = (self.preset_dir(), folder_of(path));
        let canonical = |d: &Path| std::fs::canonicalize(d).unwrap_or_else(|_| d.to_owned());
        if canonical(&from) != canonical(&to) {
            preset.rebase_relative_paths(|p| super::paths::for_preset(&from.join(p), &to));
        }
        preset
    }

    /// `swarmshot merge` on a background thread: shard folders into the output folder.
    pub(super) fn start_merge(&mut self, ctx: &egui::Context) {
        let shards = self.merge_shard_dirs();
        let out = super::paths::typed(&self.session.out_dir);
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
                    });
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

    pub(super) fn generate(&mut self, ctx: &egui::Context) {
        if !self.errors.is_empty() {
            self.notices.push(format!(
                "cannot generate: the preset has {}, shown in the panels",
                problems::count_problems(self.errors.len())
            ));
            return;
        }
        if self.merge.is_some() {
            // One writer at a time: a batch beside a merge would share its folder.
            self.notices.push(MERGING.into());
            return;
        }
        let Some((gpu, _)) = &self.gpu else {
            self.notices.push("cannot generate: no wgpu device".into());
            return;
        };
        if self.session.out_dir.trim().is_empty() {
            self.notices
                .push("cannot generate: choose an output folder (Batch panel)".into());
            return;
        }
        // The snapshot: later edits cannot reach the running batch.
        let preset = (*self.resolved).clone();
        let options = self.batch_options();
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
}

/// Why another preset does not open while a batch runs.
pub(super) const BATCH_RUNNING: &str = "a batch is running: another preset opens once it ends \
     (or is cancelled); a finished fit's preset stays under Open fitted preset";

/// Why Generate waits while Merge runs.
pub(super) const MERGING: &str =
    "cannot generate: a merge is writing into the output folder; wait until it ends";

/// What a Generate was asked to do; see [`SwarmshotApp::forget_stale_failure`].
pub(super) type BatchInputs = (
    u64,
    String,
    bool,
    Option<u64>,
    Option<crate::write::shard::Shard>,
    Option<u64>,
);

impl SwarmshotApp {
    pub(super) fn batch_inputs_now(&self) -> BatchInputs {
        (
            self.generation,
            self.session.out_dir.trim().to_owned(),
            self.session.overwrite,
            self.batch_limit(),
            self.batch_shard(),
            self.batch_every(),
        )
    }

    /// A "Batch failed" message speaks of the inputs it failed on: once the
    /// preset, the folder, Overwrite or the trial run changed it is gone.
    pub(super) fn forget_stale_failure(&mut self) {
        if matches!(self.batch_outcome, Some(BatchOutcome::Failed(_)))
            && self.batch_inputs.as_ref() != Some(&self.batch_inputs_now())
        {
            self.batch_outcome = None;
        }
    }

    /// Closing the window with unsaved changes asks first.
    pub(super) fn close_requested(&mut self, ctx: &egui::Context) {
        if ctx.input(|i| i.viewport().close_requested())
            && !self.allow_close
            && self.session.is_dirty()
        {
            ctx.send_viewport_cmd(egui::ViewportCommand::CancelClose);
            self.prompt = Some(Replace::Close);
        }
    }

    /// Shortcuts, unless a dialog or the prompt has the keyboard.
    pub(super) fn shortcut_commands(&self, ctx: &egui::Context) -> Vec<Command> {
        if self.prompt.is_some() || self.dialogs.is_open() {
            return Vec::new();
        }
        let focused = ctx.memory(|m| m.focused());
        let frame_keys = focused.is_none() || focused == self.frame_slider;
        keys::shortcuts(ctx, ctx.text_edit_focused(), frame_keys)
    }
}

/// The folder a file is in ("." for a bare name).
fn folder_of(path: &Path) -> PathBuf {
    path.parent()
        .filter(|d| !d.as_os_str().is_empty())
        .map_or_else(|| PathBuf::from("."), Path::to_owned)
}

/// `text` written as the preset file `path` atomically, as the command line writes its
/// reports ([`OutDir::write`]): a temporary file in the same folder, flushed, renamed over
/// the old file, so a failure or a kill leaves the old file whole; never through a link.
fn write_preset_file(path: &Path, text: &str) -> Result<(), String> {
    let dir = folder_of(path);
    if !dir.is_dir() {
        return Err(format!("{} is not a folder", dir.display()));
    }
    let name = (path.file_name().and_then(|n| n.to_str())).ok_or("not a UTF-8 file name")?;
    // The old file's permissions carry over; a read-only one stays as it is.
    let old = std::fs::symlink_metadata(path).ok().filter(|m| m.is_file());
    let permissions = old.map(|m| m.permissions());
    if permissions
        .as_ref()
        .is_some_and(std::fs::Permissions::readonly)
    {
        return Err("the file is read-only".into());
    }
    let mut out = OutDir::create(&dir).map_err(|e| e.to_string())?;
    let written = out
        .write(name, text.as_bytes())
        .map_err(|e| e.to_string())?;
    match permissions {
        Some(p) => std::fs::set_permissions(written, p).map_err(|e| e.to_string()),
        None => Ok(()),
    }
}
