//! The real frames against themselves: on how many counted statistics one half of the
//! real frames has its median inside the other half's range, both ways, for two splits in
//! name order. It tells what to expect of a synthetic set on that footage: footage whose
//! halves disagree (scenes, weather, cameras that change along it) has ranges that one
//! part of it misses too.
//!
//! - **alternate** frames (even and odd places): neighbouring frames, often of one video
//!   or occasion, fall in both halves, so this is the agreement of like with like, high;
//! - **first against second** half: frames from the start of the name order against those
//!   from its end, which in footage named by time or by video are other occasions.

use serde::Serialize;

/// The fewest real frames the halves are made from (ten a half: with fewer, a half's
/// median and quartiles move with every frame, and halves of one footage read apart).
pub const MIN_FRAMES: usize = 20;

/// Counted statistics inside, of those with a value on both sides, for each direction:
/// `[(inside, of), (inside, of)]`, the first half as real, then the second.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct Agreement(pub [(usize, usize); 2]);

#[derive(Clone, Debug, Serialize)]
pub struct RealHalves {
    /// Frames at even places in name order against those at odd places.
    pub alternate: Agreement,
    /// The first half in name order against the second.
    pub first_second: Agreement,
}

/// Which half a frame's place in name order puts it in (true: the first).
pub type Split<'a> = &'a dyn Fn(usize) -> bool;

impl RealHalves {
    /// The halves of `n` real frames in name order, `agree` measuring the two halves a
    /// split makes against each other ([`super::report`] does); `None` under
    /// [`MIN_FRAMES`].
    pub fn of(n: usize, agree: impl Fn(Split) -> Agreement) -> Option<Self> {
        (n >= MIN_FRAMES).then(|| Self {
            alternate: agree(&|i| i % 2 == 0),
            first_second: agree(&|i| i < n / 2),
        })
    }

    /// The report's line.
    pub fn line(&self) -> String {
        let two = |Agreement([(a, n), (b, m)]): Agreement| format!("{a} of {n} and {b} of {m}");
        format!(
            "for reference, the real frames against themselves: one half's median inside the other half's range on {} (alternate frames in name order), {} (the first half against the second): a synthetic set as like the footage as the footage is like itself scores about so\n",
            two(self.alternate),
            two(self.first_second)
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The splits put alternate places, then the first and second halves, apart.
    #[test]
    fn the_splits_are_alternate_places_then_the_two_halves() {
        let firsts =
            |s: Split| Agreement([((0..30).filter(|&i| s(i)).count(), 30), (s(1) as usize, 1)]);
        let h = RealHalves::of(30, firsts).expect("enough frames");
        assert_eq!(h.alternate, Agreement([(15, 30), (0, 1)]));
        assert_eq!(h.first_second, Agreement([(15, 30), (1, 1)]));
        assert!(h.line().contains("15 of 30 and 0 of 1"));
        assert!(RealHalves::of(MIN_FRAMES - 1, firsts).is_none());
    }
}
