//! Preview latency as the user sees it, measured in the app (issue 24): from the
//! UI pass that committed a change (a preset edit taken on Enter, focus loss or a
//! pause; another frame; a resized pane; a view toggle) to the start of the first
//! pass after the one that drew the new picture, i.e. once that pass has been
//! painted and presented. It therefore counts the preview thread's render, the
//! wait for the UI to take the picture, and the window's own paint of it; the
//! preview thread's render time alone is [`super::preview::PreviewFrame::render_ms`].
//!
//! What it cannot see: the time an input event waited for the UI pass that read it
//! (at most one window paint when the window was busy drawing). A picture that is
//! replaced before it is shown (a newer edit came first) is not counted: only the
//! newest request's picture is timed, so dragging gives one figure per picture drawn.

use std::collections::VecDeque;
use std::time::Instant;

use super::preview::PreviewKey;

/// How many recent latencies the median is taken over.
pub const RECENT: usize = 20;

/// Times the newest preview request from its UI pass to the picture on screen.
#[derive(Debug, Default)]
pub struct LatencyMeter {
    /// The newest key asked for, and the start of the UI pass that asked.
    asked: Option<(PreviewKey, Instant)>,
    /// The newest key's picture went into the texture in the last pass: timed at
    /// the start of the next one.
    drawn: bool,
    /// Recent latencies, milliseconds, oldest first.
    recent_ms: VecDeque<f64>,
}

impl LatencyMeter {
    /// A UI pass starts at `now`: a picture drawn by the previous pass is on
    /// screen now, so its latency is known.
    pub fn pass_started(&mut self, now: Instant) {
        if !std::mem::take(&mut self.drawn) {
            return;
        }
        if let Some((_, at)) = self.asked.take() {
            if self.recent_ms.len() == RECENT {
                self.recent_ms.pop_front();
            }
            self.recent_ms
                .push_back(now.saturating_duration_since(at).as_secs_f64() * 1e3);
        }
    }

    /// A new picture was asked for in the pass that started at `pass_start`.
    pub fn asked(&mut self, key: PreviewKey, pass_start: Instant) {
        self.asked = Some((key, pass_start));
        self.drawn = false;
    }

    /// The picture of `key` went into the preview texture in this pass. Returns
    /// whether it is the one being timed (then the caller asks for one more pass,
    /// whose start times it).
    pub fn picture_taken(&mut self, key: PreviewKey) -> bool {
        let timed = self.asked.is_some_and(|(k, _)| k == key);
        self.drawn |= timed;
        timed
    }

    /// No picture is being waited for: the newest one asked for is on screen.
    pub fn idle(&self) -> bool {
        self.asked.is_none()
    }

    /// The newest latency, milliseconds.
    pub fn last_ms(&self) -> Option<f64> {
        self.recent_ms.back().copied()
    }

    /// The median of the last [`RECENT`] latencies and how many there are.
    pub fn median_ms(&self) -> Option<(f64, usize)> {
        let mut v: Vec<f64> = self.recent_ms.iter().copied().collect();
        if v.is_empty() {
            return None;
        }
        v.sort_by(f64::total_cmp);
        let n = v.len();
        let median = if n % 2 == 1 {
            v[n / 2]
        } else {
            (v[n / 2 - 1] + v[n / 2]) / 2.0
        };
        Some((median, n))
    }

    /// Every recent latency, oldest first (the benchmark reads them).
    pub fn recent_ms(&self) -> impl Iterator<Item = f64> + '_ {
        self.recent_ms.iter().copied()
    }
}

#[cfg(test)]
mod tests {
    use std::time::Duration;

    use super::super::preview::PreviewView;
    use super::*;

    fn key(generation: u64) -> PreviewKey {
        PreviewKey {
            generation,
            frame: 0,
            size_px: [960, 540],
            view: PreviewView::Camera,
        }
    }

    #[test]
    fn times_the_newest_request_to_the_pass_after_its_picture() {
        let t0 = Instant::now();
        let ms = |n| t0 + Duration::from_millis(n);
        let mut m = LatencyMeter::default();
        m.pass_started(t0);
        m.asked(key(1), t0);
        m.pass_started(ms(30));
        // A newer edit before the first picture came: the old picture is not timed.
        m.asked(key(2), ms(30));
        assert!(!m.picture_taken(key(1)));
        m.pass_started(ms(60));
        assert_eq!(m.last_ms(), None);
        assert!(m.picture_taken(key(2)));
        // Not known until the pass that drew it has been presented.
        assert_eq!(m.last_ms(), None);
        m.pass_started(ms(150));
        assert_eq!(m.last_ms(), Some(120.0));
        // Counted once.
        m.pass_started(ms(400));
        assert_eq!(m.median_ms(), Some((120.0, 1)));
        m.asked(key(3), ms(500));
        assert!(m.picture_taken(key(3)));
        m.pass_started(ms(600));
        assert_eq!(m.median_ms(), Some((110.0, 2)));
    }

    #[test]
    fn keeps_only_the_recent_figures() {
        let t0 = Instant::now();
        let mut m = LatencyMeter::default();
        for i in 0..(RECENT as u64 + 5) {
            m.asked(key(i), t0);
            m.picture_taken(key(i));
            m.pass_started(t0 + Duration::from_millis(i));
        }
        assert_eq!(m.recent_ms().count(), RECENT);
        assert_eq!(m.recent_ms().next(), Some(5.0));
    }
}
