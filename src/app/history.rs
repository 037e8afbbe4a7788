//! Undo/redo of preset edits, and the gate that decides when an edit counts.
//!
//! [`EditHistory`] wraps egui's [`Undoer`]: it is fed the committed preset
//! every pass and makes an undo point once the preset stayed unchanged for a
//! moment, so a drag is one step, not a hundred (the app does not feed it
//! while the pointer is held, so a slow drag with pauses is one step too). [`CommitGate`] holds edits
//! back while the user is typing in a field: the preset is committed (and
//! validated, previewed, summarised) on Enter, on focus loss, or after a short
//! pause, never at every keystroke.

use egui::util::undoer::{Settings, Undoer};

use crate::preset::Preset;

/// Seconds without a keystroke after which a typed value is committed.
pub const COMMIT_PAUSE_S: f64 = 0.8;

/// Undo and redo of the preset.
pub struct EditHistory {
    undoer: Undoer<Preset>,
}

impl Default for EditHistory {
    fn default() -> Self {
        Self {
            undoer: Undoer::with_settings(Settings {
                max_undos: 200,
                stable_time: 0.5,
                auto_save_interval: 10.0,
            }),
        }
    }
}

impl EditHistory {
    /// Forget every step (a new or opened preset starts a fresh history).
    pub fn clear(&mut self) {
        *self = Self::default();
    }

    /// Record `preset` at `time_s` (call every pass with the committed preset).
    pub fn feed(&mut self, time_s: f64, preset: &Preset) {
        self.undoer.feed_state(time_s, preset);
    }

    pub fn can_undo(&self, current: &Preset) -> bool {
        self.undoer.has_undo(current)
    }

    pub fn can_redo(&self, current: &Preset) -> bool {
        self.undoer.has_redo(current)
    }

    /// The preset before the latest step, if any.
    pub fn undo(&mut self, current: &Preset) -> Option<Preset> {
        self.undoer.undo(current).cloned()
    }

    /// The preset the latest undo left, if any.
    pub fn redo(&mut self, current: &Preset) -> Option<Preset> {
        self.undoer.redo(current).cloned()
    }
}

/// Whether an edit made in a text field may be committed now.
#[derive(Default)]
pub struct CommitGate {
    /// The preset as last typed, and when it last changed.
    typing: Option<(Preset, f64)>,
}

/// The gate's answer.
#[derive(Debug, PartialEq)]
pub enum Gate {
    Commit,
    /// Still typing: ask again after this many seconds.
    Wait(f64),
}

impl CommitGate {
    /// `typing` is true while a text field (or a number being typed) has the
    /// keyboard; `preset` is the edited preset, `time_s` egui's clock.
    pub fn check(&mut self, typing: bool, preset: &Preset, time_s: f64) -> Gate {
        if !typing {
            self.typing = None;
            return Gate::Commit;
        }
        match &self.typing {
            Some((typed, since)) if typed == preset => {
                let quiet = time_s - since;
                if quiet >= COMMIT_PAUSE_S {
                    Gate::Commit
                } else {
                    Gate::Wait(COMMIT_PAUSE_S - quiet)
                }
            }
            _ => {
                self.typing = Some((preset.clone(), time_s));
                Gate::Wait(COMMIT_PAUSE_S)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn typing_commits_after_a_pause_or_when_the_field_lets_go() {
        let mut gate = CommitGate::default();
        let mut preset = Preset::default();
        assert_eq!(gate.check(false, &preset, 0.0), Gate::Commit);
        preset.seed = 5;
        assert!(matches!(gate.check(true, &preset, 1.0), Gate::Wait(_)));
        preset.seed = 55;
        assert!(matches!(gate.check(true, &preset, 1.5), Gate::Wait(_)));
        // 0.8 s after the last keystroke, not after the first.
        assert!(matches!(gate.check(true, &preset, 2.2), Gate::Wait(_)));
        assert_eq!(gate.check(true, &preset, 2.4), Gate::Commit);
        preset.seed = 5;
        assert!(matches!(gate.check(true, &preset, 2.5), Gate::Wait(_)));
        // Enter or focus loss: commit at once.
        assert_eq!(gate.check(false, &preset, 2.6), Gate::Commit);
    }

    #[test]
    fn undo_and_redo_step_through_committed_presets() {
        let mut history = EditHistory::default();
        let first = Preset::default();
        history.feed(0.0, &first);
        let mut second = first.clone();
        second.seed = 99;
        history.feed(1.0, &second);
        history.feed(2.0, &second);
        assert!(history.can_undo(&second));
        let undone = history.undo(&second);
        assert_eq!(undone.as_ref(), Some(&first));
        assert!(history.can_redo(&first));
        assert_eq!(history.redo(&first), Some(second));
    }
}
