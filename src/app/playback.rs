//! Play, pause and loop through the frames under the preview.
//!
//! Playback moves the selected frame; the preview follows through its
//! latest-wins worker, so a slow render skips frames instead of queueing
//! stale ones. Sequences play at their preset's frame rate (the frame shown is
//! the one due at this moment: frames whose time passed while the preview was
//! rendering are skipped); everything else plays as fast as pictures come (the
//! next frame once the current one is on screen).

/// The play state (not saved between sessions).
#[derive(Debug, Default)]
pub struct Playback {
    playing: bool,
    /// Start again from the first frame after the last.
    pub looping: bool,
    /// When playing at a frame rate: the time and frame playing (re)started from.
    anchor: Option<(f64, u64)>,
    /// The frame playback last selected: anything else means the user moved it.
    selected: Option<u64>,
}

impl Playback {
    pub fn is_playing(&self) -> bool {
        self.playing
    }

    /// Start playing from `frame` (from the first frame when at the last and not looping).
    pub fn play(&mut self, frame: u64, frames: u64) -> u64 {
        self.playing = frames > 1;
        let from = if frame + 1 >= frames { 0 } else { frame };
        self.anchor = None;
        self.selected = None;
        from
    }

    pub fn pause(&mut self) {
        self.playing = false;
        self.anchor = None;
    }

    /// The frame to select at `now_s` (egui time), or None to stay. `rate_hz`
    /// is the sequence's frame rate (None: as fast as pictures come);
    /// `shown` says the current frame's picture is on screen. Returns the
    /// next wake-up in seconds for the frame-rate mode.
    pub fn tick(
        &mut self,
        now_s: f64,
        frame: u64,
        frames: u64,
        rate_hz: Option<f64>,
        shown: bool,
    ) -> (Option<u64>, Option<f64>) {
        if !self.playing || frames < 2 {
            self.pause();
            return (None, None);
        }
        if self.selected.is_some_and(|s| s != frame) {
            // The slider or a key moved the frame: carry on from there.
            self.anchor = None;
        }
        let (target, wake) = match rate_hz.filter(|r| *r > 0.0) {
            Some(rate) => {
                let (t0, f0) = *self.anchor.get_or_insert((now_s, frame));
                let elapsed = ((now_s - t0) * rate).max(0.0);
                let due = f0.saturating_add(elapsed.floor() as u64);
                let next_s = t0 + (elapsed.floor() + 1.0) / rate - now_s;
                (due, Some(next_s.max(0.001)))
            }
            None if shown => (frame + 1, None),
            None => (frame, None),
        };
        let target = if target >= frames {
            if self.looping {
                if rate_hz.is_some() {
                    // Keep the clock: wrap the anchor with the frame.
                    self.anchor = Some((now_s, target % frames));
                }
                target % frames
            } else {
                self.pause();
                let last = frames - 1;
                return ((frame != last).then_some(last), None);
            }
        } else {
            target
        };
        self.selected = Some(target);
        ((target != frame).then_some(target), wake)
    }
}
