//! Starting the app: reading a preset for editing, the example presets, and
//! opening the window (or saying in one line why it cannot open).

use std::path::{Path, PathBuf};

use super::{APP_NAME, StartOptions, SwarmshotApp};
use crate::preset::{PRESET_VERSION, Preset};

/// Why a preset file could not be opened for editing; its message names the file.
#[derive(Debug, thiserror::Error)]
pub enum OpenError {
    #[error("preset {} does not exist", .0.display())]
    NotFound(PathBuf),
    #[error("preset {}: permission denied (cannot read it)", .0.display())]
    PermissionDenied(PathBuf),
    #[error("preset {} is a folder, not a preset file", .0.display())]
    IsAFolder(PathBuf),
    #[error("cannot read preset {}: {source}", path.display())]
    Read {
        path: PathBuf,
        source: std::io::Error,
    },
    /// Not RON, or not a preset (the message names the field and its line).
    #[error("preset {}: {source}", path.display())]
    Parse {
        path: PathBuf,
        source: crate::preset::RonError,
    },
    #[error(
        "preset {}: version {version} is newer than this swarmshot understands ({known})",
        path.display(),
        known = PRESET_VERSION
    )]
    TooNew { path: PathBuf, version: u32 },
}

/// Read a preset for editing: parsed, not validated (problems are shown at the widgets).
pub fn read_preset(path: &Path) -> Result<Preset, OpenError> {
    read_preset_text(path).map(|(preset, _)| preset)
}

/// [`read_preset`], and the file's text (Save edits it, keeping its comments).
pub fn read_preset_text(path: &Path) -> Result<(Preset, String), OpenError> {
    let owned = || path.to_path_buf();
    if path.is_dir() {
        return Err(OpenError::IsAFolder(owned()));
    }
    // A regular file within the preset size limit, as every command reads one
    // (a FIFO is refused unopened, /dev/zero unread).
    let text = crate::input::read_input_file(path, crate::preset::MAX_PRESET_BYTES)
        .and_then(|bytes| {
            String::from_utf8(bytes).map_err(|e| {
                std::io::Error::new(
                    std::io::ErrorKind::InvalidData,
                    format!("not UTF-8 text ({e})"),
                )
            })
        })
        .map_err(|e| match e.kind() {
            std::io::ErrorKind::NotFound => OpenError::NotFound(owned()),
            std::io::ErrorKind::PermissionDenied => OpenError::PermissionDenied(owned()),
            _ => OpenError::Read {
                path: owned(),
                source: e,
            },
        })?;
    let preset = Preset::from_ron(&text).map_err(|source| OpenError::Parse {
        path: owned(),
        source,
    })?;
    if preset.version > PRESET_VERSION {
        return Err(OpenError::TooNew {
            path: owned(),
            version: preset.version,
        });
    }
    Ok((preset, text))
}

/// What an example preset is, from the comment it starts with (its first three lines
/// joined); None when it starts with none.
pub fn example_description(path: &Path) -> Option<String> {
    use std::io::Read;
    // Its start only, of a regular file.
    let (file, _) = crate::input::open_input_file(path, crate::preset::MAX_PRESET_BYTES).ok()?;
    let mut head = Vec::new();
    file.take(4096).read_to_end(&mut head).ok()?;
    let text = String::from_utf8_lossy(&head);
    let lines: Vec<&str> = text
        .lines()
        .map_while(|l| l.trim_start().strip_prefix("//"))
        .map(str::trim)
        .take_while(|l| !l.is_empty())
        .take(3)
        .collect();
    (!lines.is_empty()).then(|| lines.join(" "))
}

/// The example presets shipped in the repository's presets/ folder.
pub fn example_presets() -> Vec<PathBuf> {
    let dirs = crate::preset::shipped::dirs();
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
            fail(e.to_string());
        }
        fail(why);
    }
    if let Err(e) = run(preset) {
        fail(format!("{e:#}"));
    }
}

/// Quiet Mesa's Vulkan device-select layer on an X11 session without Wayland.
///
/// wgpu enables `VK_KHR_wayland_surface` on every instance; with it, Mesa's implicit
/// `VK_LAYER_MESA_device_select` (up to Mesa 23.1, e.g. Debian 12's 22.3) calls
/// `wl_display_connect` each time the GPUs are listed, to find a compositor's GPU, and
/// when `XDG_RUNTIME_DIR` is unset libwayland prints `error: XDG_RUNTIME_DIR is invalid
/// or not set in the environment.` (four times while eframe starts). On a plain X
/// server (Xvfb, `startx` without a login session) there is no compositor to find, so
/// the layer's documented off switch `NODEVICE_SELECT=1` is set there, and only there:
/// [`device_select_would_print`] says when. eframe asks wgpu for a high-performance
/// adapter, which orders the GPUs by their kind whatever the layer's order.
///
/// # Safety
/// Changes the process environment: call it while the process has one thread
/// (`main`, before the window opens), as [`std::env::set_var`] requires.
#[allow(unsafe_code)]
pub unsafe fn quiet_vulkan_on_plain_x11() {
    if device_select_would_print(|name| std::env::var_os(name)) {
        // SAFETY: the caller guarantees no other thread reads or writes the environment.
        unsafe { std::env::set_var("NODEVICE_SELECT", "1") };
    }
}

/// The device-select layer would try Wayland and libwayland would complain: an X11
/// display and no Wayland one (`WAYLAND_DISPLAY`, `WAYLAND_SOCKET`), `XDG_RUNTIME_DIR`
/// unset or not an absolute path (libwayland's test), and the user has not spoken to
/// the layer (`NODEVICE_SELECT`, `MESA_VK_DEVICE_SELECT`, `DRI_PRIME`).
fn device_select_would_print(var: impl Fn(&str) -> Option<std::ffi::OsString>) -> bool {
    let set = |name: &str| var(name).is_some_and(|v| !v.is_empty());
    let runtime_dir_ok = var("XDG_RUNTIME_DIR").is_some_and(|v| Path::new(&v).is_absolute());
    cfg!(all(unix, not(target_os = "macos")))
        && set("DISPLAY")
        && !set("WAYLAND_DISPLAY")
        && !set("WAYLAND_SOCKET")
        && !runtime_dir_ok
        && ["NODEVICE_SELECT", "MESA_VK_DEVICE_SELECT", "DRI_PRIME"]
            .iter()
            .all(|name| var(name).is_none())
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
            .with_min_inner_size([800.0, 560.0]),
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

#[cfg(test)]
mod tests {
    use std::ffi::OsString;

    use super::device_select_would_print;

    #[test]
    fn a_preset_that_is_a_fifo_or_a_device_is_refused_unread() {
        // The app's Open: a FIFO would block the read, /dev/zero never end.
        let dir = tempfile::tempdir().expect("temp dir");
        let fifo = dir.path().join("p.ron");
        let made = std::process::Command::new("mkfifo").arg(&fifo).status();
        assert!(made.expect("mkfifo runs").success());
        let start = std::time::Instant::now();
        for path in [fifo.as_path(), std::path::Path::new("/dev/zero")] {
            let e = super::read_preset_text(path).expect_err("refused");
            assert!(e.to_string().contains(&path.display().to_string()), "{e}");
            assert!(super::example_description(path).is_none());
        }
        assert!(start.elapsed().as_secs() < 5, "{:?}", start.elapsed());
    }

    fn env(pairs: &[(&str, &str)]) -> impl Fn(&str) -> Option<OsString> {
        let pairs: Vec<(String, OsString)> = pairs
            .iter()
            .map(|(k, v)| (k.to_string(), OsString::from(v)))
            .collect();
        move |name| {
            pairs
                .iter()
                .find(|(k, _)| k == name)
                .map(|(_, v)| v.clone())
        }
    }

    #[test]
    fn plain_x11_without_a_runtime_dir_turns_the_layer_off() {
        assert!(device_select_would_print(env(&[("DISPLAY", ":1")])));
        assert!(device_select_would_print(env(&[
            ("DISPLAY", ":1"),
            ("XDG_RUNTIME_DIR", "relative/dir")
        ])));
    }

    #[test]
    fn the_layer_stays_wherever_it_can_work_or_the_user_asked() {
        for keep in [
            &[("DISPLAY", ":1"), ("XDG_RUNTIME_DIR", "/run/user/1000")][..],
            &[("DISPLAY", ":1"), ("WAYLAND_DISPLAY", "wayland-0")],
            &[("DISPLAY", ":1"), ("WAYLAND_SOCKET", "5")],
            &[("DISPLAY", ":1"), ("DRI_PRIME", "1")],
            &[("DISPLAY", ":1"), ("MESA_VK_DEVICE_SELECT", "1002:6780")],
            &[("DISPLAY", ":1"), ("NODEVICE_SELECT", "0")],
            &[("WAYLAND_DISPLAY", "wayland-0")],
            &[],
        ] {
            assert!(!device_select_would_print(env(keep)), "{keep:?}");
        }
    }
}
