//! Keyboard shortcuts, read before the panels so they win over widgets:
//! Ctrl+N / Ctrl+O / Ctrl+S / Ctrl+Shift+S for the file actions, Ctrl+Q to quit, Ctrl+Z and
//! Ctrl+Shift+Z (or Ctrl+Y) for undo and redo, and ←/→/Home/End for the
//! frame slider.

use egui::{Key, KeyboardShortcut, Modifiers};

use super::Command;

fn key(modifiers: Modifiers, key: Key) -> KeyboardShortcut {
    KeyboardShortcut::new(modifiers, key)
}

/// Take this pass's shortcuts out of the input as commands.
///
/// `text_focused`: a text field has the keyboard, so undo belongs to it.
/// `frame_keys`: nothing (or the frame slider) has focus, so arrows move frames.
pub fn shortcuts(ctx: &egui::Context, text_focused: bool, frame_keys: bool) -> Vec<Command> {
    let mut commands = Vec::new();
    let shift_command = Modifiers::COMMAND | Modifiers::SHIFT;
    ctx.input_mut(|i| {
        // Shift variants first: Ctrl+Z also matches Ctrl+Shift+Z.
        let file_keys = [
            (key(shift_command, Key::S), Command::SaveAs),
            (key(Modifiers::COMMAND, Key::S), Command::Save),
            (key(Modifiers::COMMAND, Key::O), Command::Open),
            (key(Modifiers::COMMAND, Key::N), Command::New),
            (key(Modifiers::COMMAND, Key::Q), Command::Quit),
        ];
        for (shortcut, command) in file_keys {
            if i.consume_shortcut(&shortcut) {
                commands.push(command);
            }
        }
        if !text_focused {
            if i.consume_shortcut(&key(shift_command, Key::Z))
                || i.consume_shortcut(&key(Modifiers::COMMAND, Key::Y))
            {
                commands.push(Command::Redo);
            }
            if i.consume_shortcut(&key(Modifiers::COMMAND, Key::Z)) {
                commands.push(Command::Undo);
            }
        }
        if frame_keys {
            // Every press moves one frame: presses that arrive within one pass
            // (quick typing on a slow pass) are counted, not merged into one.
            for (k, direction) in [(Key::ArrowLeft, -1), (Key::ArrowRight, 1)] {
                let presses = i.count_and_consume_key(Modifiers::NONE, k);
                if presses > 0 {
                    let presses = i64::try_from(presses).unwrap_or(i64::MAX);
                    commands.push(Command::StepFrame(direction * presses));
                }
            }
            for (k, command) in [
                (Key::Home, Command::FirstFrame),
                (Key::End, Command::LastFrame),
            ] {
                if i.consume_key(Modifiers::NONE, k) {
                    commands.push(command);
                }
            }
        }
    });
    commands
}
