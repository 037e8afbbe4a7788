//! Keyboard focus on a bare X server.
//!
//! Without a window manager nobody gives the window X's input focus: egui
//! highlights a clicked field, but winit delivers key presses only to a
//! window that received `FocusIn`, so typing did nothing. On the first click
//! into an unfocused window the app asks for focus the usual way
//! (`ViewportCommand::Focus`, which a window manager honours) and, on X11,
//! also sets it with `XSetInputFocus`, as a window manager would. The call
//! goes through libX11, loaded at run time like winit loads it.
#![allow(unsafe_code)]

use wgpu::rwh::{HasDisplayHandle, HasWindowHandle, RawDisplayHandle, RawWindowHandle};

/// Give the app's X11 window the keyboard; false when it is no X11 window
/// (Wayland, the test harness) or libX11 cannot be loaded.
pub fn take(frame: &eframe::Frame) -> bool {
    let (Ok(window), Ok(display)) = (frame.window_handle(), frame.display_handle()) else {
        return false;
    };
    let (RawWindowHandle::Xlib(window), RawDisplayHandle::Xlib(display)) =
        (window.as_raw(), display.as_raw())
    else {
        return false;
    };
    let Some(display) = display.display else {
        return false;
    };
    let Ok(xlib) = x11_dl::xlib::Xlib::open() else {
        return false;
    };
    // SAFETY: `display` is winit's open Xlib connection and `window` its
    // window, both alive while the frame is; Xlib calls are made from the UI
    // thread that owns them.
    unsafe {
        (xlib.XSetInputFocus)(
            display.as_ptr().cast(),
            window.window,
            x11_dl::xlib::RevertToParent,
            x11_dl::xlib::CurrentTime,
        );
        (xlib.XFlush)(display.as_ptr().cast());
    }
    true
}
