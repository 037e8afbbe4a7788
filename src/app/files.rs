//! File dialogs that always open.
//!
//! rfd's default Linux backend talks to the XDG desktop portal and falls back
//! to `zenity`; with neither (a plain X session, a remote desktop, WSL) it
//! returns "nothing chosen" at once, which looks exactly like a cancel. So
//! [`FileDialogs`] asks the session bus once, in the background, whether a
//! portal's FileChooser answers (or `zenity` is installed), and otherwise shows
//! [`FileBrowser`], a small in-app browser. `SWARMSHOT_FILE_DIALOG=builtin` or
//! `=native` overrides the choice.
//!
//! Native dialogs run on their own thread, so the window keeps redrawing while
//! one is open; either way the app receives a [`FileChoice`] from
//! [`FileDialogs::show`] after the UI pass that finished it.

use std::ffi::OsStr;
use std::path::{Path, PathBuf};
use std::sync::{Arc, OnceLock};
use std::time::Duration;

use crossbeam_channel::Receiver;
use egui::{Key, RichText, Ui};

/// Environment variable that picks the dialog: `builtin`, `native` or `auto` (default).
pub const DIALOG_ENV: &str = "SWARMSHOT_FILE_DIALOG";

/// How long the start-up probe waits for the portal to answer.
const PORTAL_TIMEOUT: Duration = Duration::from_secs(3);

/// Which file dialog the app uses.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum DialogBackend {
    /// The native dialog when a portal (or zenity) answers, else the in-app browser.
    #[default]
    Auto,
    /// Always the in-app browser.
    Builtin,
    /// Always rfd (which does nothing visible when no portal runs).
    Native,
}

impl DialogBackend {
    /// `SWARMSHOT_FILE_DIALOG`, or `Auto` when unset or unknown.
    pub fn from_env() -> Self {
        match std::env::var(DIALOG_ENV).as_deref() {
            Ok("builtin") => Self::Builtin,
            Ok("native") => Self::Native,
            _ => Self::Auto,
        }
    }
}

/// What a dialog is for; decides its title, kind and filter.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FilePurpose {
    OpenPreset,
    SavePreset,
    AddModel,
    OutputFolder,
    /// The backplate folder (Backplates section).
    BackplateFolder,
    /// The real frames the Domain gap window measures.
    RealFrames,
    /// The real frames the Fit window fits to.
    FitRealFrames,
    /// The Fit window's output folder.
    FitOutput,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    Open,
    Save,
    Folder,
}

impl FilePurpose {
    /// Whether the chosen path goes into the preset (not a window's own folder).
    pub fn edits_preset(self) -> bool {
        !matches!(
            self,
            Self::RealFrames | Self::FitRealFrames | Self::FitOutput
        )
    }

    pub fn title(self) -> &'static str {
        match self {
            Self::OpenPreset => "Open preset",
            Self::SavePreset => "Save preset as",
            Self::AddModel => "Add glTF model",
            Self::OutputFolder => "Output folder",
            Self::BackplateFolder => "Backplate folder",
            Self::RealFrames | Self::FitRealFrames => "Real frames folder",
            Self::FitOutput => "Fit output folder",
        }
    }

    fn kind(self) -> Kind {
        match self {
            Self::OpenPreset | Self::AddModel => Kind::Open,
            Self::SavePreset => Kind::Save,
            Self::OutputFolder
            | Self::BackplateFolder
            | Self::RealFrames
            | Self::FitRealFrames
            | Self::FitOutput => Kind::Folder,
        }
    }

    /// Filter name and file extensions (empty for folders).
    fn filter(self) -> (&'static str, &'static [&'static str]) {
        match self {
            Self::OpenPreset | Self::SavePreset => ("swarmshot preset", &["ron"]),
            Self::AddModel => ("glTF model", &["gltf", "glb"]),
            Self::OutputFolder
            | Self::BackplateFolder
            | Self::RealFrames
            | Self::FitRealFrames
            | Self::FitOutput => ("folder", &[]),
        }
    }
}

/// A path the user chose.
#[derive(Clone, Debug, PartialEq)]
pub struct FileChoice {
    pub purpose: FilePurpose,
    pub path: PathBuf,
}

/// Opens dialogs: native where they work, the in-app browser elsewhere.
pub struct FileDialogs {
    backend: DialogBackend,
    /// Whether a native dialog can show; filled in by a background probe.
    native_works: Arc<OnceLock<bool>>,
    browser: Option<FileBrowser>,
    native: Option<(FilePurpose, Receiver<Option<PathBuf>>)>,
}

impl FileDialogs {
    /// Start probing for a portal in the background (only for `Auto`).
    pub fn new(backend: DialogBackend, wake: impl Fn() + Send + 'static) -> Self {
        let native_works = Arc::new(OnceLock::new());
        if backend == DialogBackend::Auto {
            let slot = Arc::clone(&native_works);
            let probe = std::thread::Builder::new()
                .name("swarmshot portal probe".into())
                .spawn(move || {
                    let bus = std::env::var("DBUS_SESSION_BUS_ADDRESS").ok();
                    let path = std::env::var_os("PATH");
                    let _ = slot.set(native_dialog_available(bus.as_deref(), path.as_deref()));
                    wake();
                });
            if probe.is_err() {
                let _ = native_works.set(false);
            }
        }
        Self {
            backend,
            native_works,
            browser: None,
            native: None,
        }
    }

    /// Whether native dialogs are used now.
    pub fn uses_native(&self) -> bool {
        match self.backend {
            DialogBackend::Native => true,
            DialogBackend::Builtin => false,
            // Until the probe answers, the in-app browser is the safe choice.
            DialogBackend::Auto => self.native_works.get().copied().unwrap_or(false),
        }
    }

    /// A dialog (native or in-app) is open.
    pub fn is_open(&self) -> bool {
        self.browser.is_some() || self.native.is_some()
    }

    /// Open a dialog starting in `start_dir` (and, for Save, proposing `file_name`).
    /// Ignored while another dialog is open.
    pub fn open(
        &mut self,
        purpose: FilePurpose,
        start_dir: &Path,
        file_name: Option<String>,
        wake: impl Fn() + Send + 'static,
    ) {
        if self.is_open() {
            return;
        }
        if self.uses_native() {
            let (tx, rx) = crossbeam_channel::bounded(1);
            let start = start_dir.to_owned();
            let spawned = std::thread::Builder::new()
                .name("swarmshot file dialog".into())
                .spawn(move || {
                    let _ = tx.send(native_dialog(purpose, &start, file_name));
                    wake();
                });
            match spawned {
                Ok(_) => self.native = Some((purpose, rx)),
                Err(_) => self.browser = Some(FileBrowser::new(purpose, start_dir, None)),
            }
        } else {
            self.browser = Some(FileBrowser::new(purpose, start_dir, file_name));
        }
    }

    /// The open in-app browser, if any (for tests).
    pub fn browser(&self) -> Option<&FileBrowser> {
        self.browser.as_ref()
    }

    /// Draw the in-app browser and collect what any dialog chose.
    pub fn show(&mut self, ctx: &egui::Context) -> Option<FileChoice> {
        if let Some((purpose, rx)) = &self.native {
            let purpose = *purpose;
            return match rx.try_recv() {
                Ok(path) => {
                    self.native = None;
                    path.map(|path| FileChoice { purpose, path })
                }
                Err(crossbeam_channel::TryRecvError::Empty) => None,
                Err(crossbeam_channel::TryRecvError::Disconnected) => {
                    self.native = None;
                    None
                }
            };
        }
        let browser = self.browser.as_mut()?;
        match browser.show(ctx) {
            BrowserState::Open => None,
            BrowserState::Cancelled => {
                self.browser = None;
                None
            }
            BrowserState::Chosen(path) => {
                let purpose = browser.purpose;
                self.browser = None;
                Some(FileChoice { purpose, path })
            }
        }
    }
}

/// rfd's blocking dialog (run on a dialog thread).
fn native_dialog(purpose: FilePurpose, start: &Path, file_name: Option<String>) -> Option<PathBuf> {
    let (filter, extensions) = purpose.filter();
    let mut dialog = rfd::FileDialog::new()
        .set_title(purpose.title())
        .set_directory(start);
    if !extensions.is_empty() {
        dialog = dialog.add_filter(filter, extensions);
    }
    if let Some(name) = file_name {
        dialog = dialog.set_file_name(name);
    }
    match purpose.kind() {
        Kind::Open => dialog.pick_file(),
        Kind::Save => dialog.save_file(),
        Kind::Folder => dialog.pick_folder(),
    }
}

/// Whether rfd can show a dialog: a portal FileChooser answers on the session
/// bus at `bus_address`, or `zenity` (rfd's fallback) is on `path_var`.
pub fn native_dialog_available(bus_address: Option<&str>, path_var: Option<&OsStr>) -> bool {
    executable_on_path("zenity", path_var)
        || bus_address.is_some_and(|address| portal_answers(address, PORTAL_TIMEOUT))
}

fn executable_on_path(name: &str, path_var: Option<&OsStr>) -> bool {
    path_var.is_some_and(|paths| std::env::split_paths(paths).any(|dir| dir.join(name).is_file()))
}

/// Ask the portal for its FileChooser version; a missing portal, a portal
/// without a file chooser backend, or no answer within `timeout` is `false`.
fn portal_answers(address: &str, timeout: Duration) -> bool {
    let (tx, rx) = crossbeam_channel::bounded(1);
    let address = address.to_owned();
    let spawned = std::thread::Builder::new()
        .name("swarmshot portal query".into())
        .spawn(move || {
            let answer = pollster::block_on(async {
                let connection = zbus::connection::Builder::address(address.as_str())?
                    .method_timeout(timeout)
                    .build()
                    .await?;
                connection
                    .call_method(
                        Some("org.freedesktop.portal.Desktop"),
                        "/org/freedesktop/portal/desktop",
                        Some("org.freedesktop.DBus.Properties"),
                        "Get",
                        &("org.freedesktop.portal.FileChooser", "version"),
                    )
                    .await?;
                Ok::<(), zbus::Error>(())
            });
            let _ = tx.send(answer.is_ok());
        });
    spawned.is_ok() && rx.recv_timeout(timeout).unwrap_or(false)
}

/// One line of the browser's listing.
#[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord)]
struct Entry {
    /// Folders sort first.
    is_file: bool,
    name: String,
}

enum BrowserState {
    Open,
    Cancelled,
    Chosen(PathBuf),
}

/// The in-app file browser: a folder listing with Up, a path field, a file
/// name field for Save, and an overwrite question.
pub struct FileBrowser {
    purpose: FilePurpose,
    dir: PathBuf,
    dir_edit: String,
    entries: Result<Vec<Entry>, ListError>,
    file_name: String,
    /// A Save onto this existing file waits for "Replace".
    confirm_replace: Option<PathBuf>,
}

impl FileBrowser {
    fn new(purpose: FilePurpose, start_dir: &Path, file_name: Option<String>) -> Self {
        let dir = if start_dir.is_dir() {
            start_dir.to_owned()
        } else {
            std::env::current_dir().unwrap_or_else(|_| PathBuf::from("/"))
        };
        let mut browser = Self {
            purpose,
            dir_edit: String::new(),
            dir: PathBuf::new(),
            entries: Ok(Vec::new()),
            file_name: file_name.unwrap_or_default(),
            confirm_replace: None,
        };
        browser.go_to(dir);
        browser
    }

    /// The folder shown.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    pub fn purpose(&self) -> FilePurpose {
        self.purpose
    }

    fn go_to(&mut self, dir: PathBuf) {
        let dir = dir.canonicalize().unwrap_or(dir);
        self.entries = list_dir(&dir, self.purpose.filter().1);
        self.dir_edit = dir.display().to_string();
        self.dir = dir;
        self.confirm_replace = None;
    }

    fn show(&mut self, ctx: &egui::Context) -> BrowserState {
        let mut state = BrowserState::Open;
        let modal = egui::Modal::new(egui::Id::unique("swarmshot file browser")).show(ctx, |ui| {
            ui.set_width(560.0);
            ui.heading(self.purpose.title());
            self.path_ui(ui);
            ui.separator();
            self.listing_ui(ui, &mut state);
            ui.separator();
            self.buttons_ui(ui, &mut state);
        });
        if matches!(state, BrowserState::Open)
            && modal.backdrop_response.clicked()
            && self.confirm_replace.is_none()
        {
            state = BrowserState::Cancelled;
        }
        if ctx.input_mut(|i| i.consume_key(egui::Modifiers::NONE, Key::Escape)) {
            state = BrowserState::Cancelled;
        }
        state
    }

    fn path_ui(&mut self, ui: &mut Ui) {
        ui.horizontal(|ui| {
            let up = self.dir.parent().map(Path::to_owned);
            if ui
                .add_enabled(up.is_some(), egui::Button::new("Up"))
                .on_hover_text("The parent folder")
                .clicked()
                && let Some(up) = up
            {
                self.go_to(up);
            }
            let field = ui.add(
                egui::TextEdit::singleline(&mut self.dir_edit)
                    .desired_width(f32::INFINITY)
                    .hint_text("folder"),
            );
            let field = field
                .on_hover_text("Type a folder and press Enter")
                .accessible_name("Folder");
            if field.lost_focus() && ui.input(|i| i.key_pressed(Key::Enter)) {
                let typed = PathBuf::from(self.dir_edit.trim());
                if typed.is_dir() {
                    self.go_to(typed);
                } else {
                    self.entries = Err(ListError::NotAFolder(typed));
                }
            }
        });
    }

    fn listing_ui(&mut self, ui: &mut Ui, state: &mut BrowserState) {
        let mut enter = None;
        egui::ScrollArea::vertical()
            .max_height(300.0)
            .auto_shrink([false, false])
            .show(ui, |ui| match &self.entries {
                Err(e) => {
                    ui.label(RichText::new(e.to_string()).color(ui.visuals().error_fg_color));
                }
                Ok(entries) if entries.is_empty() => {
                    ui.weak("(nothing to show here)");
                }
                Ok(entries) => {
                    for entry in entries {
                        let text = if entry.is_file {
                            entry.name.clone()
                        } else {
                            format!("{}/", entry.name)
                        };
                        let selected = entry.is_file && entry.name == self.file_name;
                        let response = ui.selectable_label(selected, text);
                        if response.clicked() && entry.is_file {
                            self.file_name.clone_from(&entry.name);
                            self.confirm_replace = None;
                        }
                        if response.double_clicked() || (response.clicked() && !entry.is_file) {
                            enter = Some(entry.clone());
                        }
                    }
                }
            });
        match enter {
            Some(Entry {
                is_file: false,
                name,
            }) => self.go_to(self.dir.join(name)),
            Some(Entry {
                is_file: true,
                name,
            }) if self.purpose.kind() == Kind::Open => {
                *state = BrowserState::Chosen(self.dir.join(name));
            }
            _ => {}
        }
    }

    fn buttons_ui(&mut self, ui: &mut Ui, state: &mut BrowserState) {
        let kind = self.purpose.kind();
        if kind != Kind::Folder {
            ui.horizontal(|ui| {
                let label = ui.label("File name");
                let field = ui
                    .add(egui::TextEdit::singleline(&mut self.file_name).desired_width(320.0))
                    .labelled_by(label.id);
                if field.changed() {
                    self.confirm_replace = None;
                }
                if field.lost_focus() && ui.input(|i| i.key_pressed(Key::Enter)) {
                    self.confirm(state);
                }
            });
        }
        if let Some(path) = self.confirm_replace.clone() {
            ui.label(
                RichText::new(format!("{} exists. Replace it?", path.display()))
                    .color(ui.visuals().warn_fg_color),
            );
        }
        ui.horizontal(|ui| {
            let action = match (kind, &self.confirm_replace) {
                (Kind::Open, _) => "Open",
                (Kind::Save, None) => "Save",
                (Kind::Save, Some(_)) => "Replace",
                (Kind::Folder, _) => "Choose this folder",
            };
            let ready = kind == Kind::Folder || !self.file_name.trim().is_empty();
            if ui.add_enabled(ready, egui::Button::new(action)).clicked() {
                self.confirm(state);
            }
            if ui.button("Cancel").clicked() {
                *state = BrowserState::Cancelled;
            }
            let (filter, extensions) = self.purpose.filter();
            if !extensions.is_empty() {
                ui.weak(format!("{filter} (.{})", extensions.join(", .")));
            }
        });
    }

    /// The primary button (or Enter in the file name field).
    fn confirm(&mut self, state: &mut BrowserState) {
        let kind = self.purpose.kind();
        if kind == Kind::Folder {
            *state = BrowserState::Chosen(self.dir.clone());
            return;
        }
        let name = self.file_name.trim();
        if name.is_empty() {
            return;
        }
        let mut path = self.dir.join(name);
        if kind == Kind::Save && path.extension().is_none() {
            path.set_extension(self.purpose.filter().1.first().copied().unwrap_or("ron"));
        }
        if path.is_dir() {
            self.file_name.clear();
            self.go_to(path);
            return;
        }
        match kind {
            Kind::Open if !path.is_file() => {
                self.entries = Err(ListError::Missing(path));
            }
            Kind::Save if path.exists() && self.confirm_replace.as_ref() != Some(&path) => {
                self.confirm_replace = Some(path);
            }
            _ => *state = BrowserState::Chosen(path),
        }
    }
}

/// Why the browser shows no listing (in place of it).
#[derive(Debug, thiserror::Error)]
enum ListError {
    #[error("cannot list {}: {source}", dir.display())]
    Read {
        dir: PathBuf,
        source: std::io::Error,
    },
    #[error("{} is not a folder", .0.display())]
    NotAFolder(PathBuf),
    #[error("{} does not exist", .0.display())]
    Missing(PathBuf),
}

/// Folders and the files with one of `extensions` (all files when empty for
/// a file dialog; none for a folder dialog), hidden ones left out, sorted.
fn list_dir(dir: &Path, extensions: &[&str]) -> Result<Vec<Entry>, ListError> {
    let read = std::fs::read_dir(dir).map_err(|source| ListError::Read {
        dir: dir.to_owned(),
        source,
    })?;
    let mut entries: Vec<Entry> = read
        .filter_map(Result::ok)
        .filter_map(|e| {
            let name = e.file_name().to_string_lossy().into_owned();
            if name.starts_with('.') {
                return None;
            }
            // Follow symlinks: a linked folder is a folder.
            let is_dir = e.path().is_dir();
            let wanted = is_dir
                || (!extensions.is_empty()
                    && Path::new(&name)
                        .extension()
                        .and_then(OsStr::to_str)
                        .is_some_and(|x| extensions.iter().any(|w| w.eq_ignore_ascii_case(x))));
            wanted.then_some(Entry {
                is_file: !is_dir,
                name,
            })
        })
        .collect();
    entries.sort();
    Ok(entries)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn no_bus_and_no_zenity_means_no_native_dialog() {
        let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
        let path = std::env::join_paths([dir.path()]).unwrap_or_else(|e| panic!("{e}"));
        assert!(!native_dialog_available(None, Some(&path)));
        // A bus address where nothing listens: refused at once, not a hang.
        let socket = dir.path().join("no-bus");
        let address = format!("unix:path={}", socket.display());
        assert!(!native_dialog_available(Some(&address), Some(&path)));
        // zenity on PATH is enough: rfd falls back to it.
        std::fs::write(dir.path().join("zenity"), "").unwrap_or_else(|e| panic!("{e}"));
        assert!(native_dialog_available(None, Some(&path)));
    }

    #[test]
    fn the_listing_holds_folders_and_matching_files_only() {
        let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
        for name in ["b.ron", "a.RON", "c.txt", ".hidden.ron"] {
            std::fs::write(dir.path().join(name), "").unwrap_or_else(|e| panic!("{e}"));
        }
        std::fs::create_dir(dir.path().join("sub")).unwrap_or_else(|e| panic!("{e}"));
        let names: Vec<(bool, String)> = list_dir(dir.path(), &["ron"])
            .unwrap_or_else(|e| panic!("{e}"))
            .into_iter()
            .map(|e| (e.is_file, e.name))
            .collect();
        assert_eq!(
            names,
            [
                (false, "sub".to_string()),
                (true, "a.RON".to_string()),
                (true, "b.ron".to_string())
            ]
        );
        let folders = list_dir(dir.path(), &[]).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(folders.len(), 1);
        assert!(list_dir(&dir.path().join("missing"), &["ron"]).is_err());
    }
}
