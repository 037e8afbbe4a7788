//! The split of a frame: a pure function of (preset, frame index), like the
//! rest of the frame, so any frame, shard or `--limit` peek agrees on it.
//!
//! `output.split.by` says what is kept whole (docs/conventions.md, "Splits"):
//!
//! - `Frame` (the default): each frame's split draw (`seed::split_uniform`;
//!   in sequence mode the draw of its sequence's number), exact shares in
//!   every block of 100 frames (sequences).
//! - `CameraPose`, `SweepPoint`, `Environment`: frames are grouped (by their
//!   CameraX/CameraY/CameraZ sweep values; by every swept value, only
//!   `repeat` differing; by the `Random` sky's choice) and whole groups are
//!   split. The G groups are ranked by a seeded permutation
//!   (`seed::permute`); ranks below round(G·train) go to train, those below
//!   round(G·(train + val)) to val, the rest to test. Camera-pose and
//!   sweep-point groups hold the same number of frames each, so the frame
//!   shares are exactly the group shares; environments are drawn with equal
//!   chances, so their frame shares match in expectation.
//!
//! A sequence (sequence mode) never changes its sweep values or environment,
//! so every mode keeps sequences whole.

use crate::preset::sweep::decode_mixed_radix;
use crate::preset::{Preset, Sky, SplitBy};
use crate::seed;
use crate::sky::FrameEnvironment;

use super::{SequenceFrame, SplitName};

/// Salt of the group ranking (apart from the per-frame split draw).
const GROUP_SALT: u64 = 0x4752_4f55_505f_5350; // "GROUP_SP"

/// The split of frame `index`.
pub fn split_of(
    preset: &Preset,
    index: u64,
    sequence: Option<SequenceFrame>,
    environment: &FrameEnvironment,
) -> SplitName {
    match group_of(preset, index, environment) {
        None => {
            let draw = sequence.map_or(index, |s| s.id);
            let u = seed::split_uniform(preset.seed, draw);
            let s = &preset.output.split;
            if u < s.train {
                SplitName::Train
            } else if u < s.train + s.val {
                SplitName::Val
            } else {
                SplitName::Test
            }
        }
        Some((group, groups)) => {
            let key = seed::mix64(preset.seed ^ GROUP_SALT) ^ preset.output.split.by as u64;
            let rank = seed::permute(key, group, groups);
            let [train, val, _] = group_counts(preset, groups);
            if rank < train {
                SplitName::Train
            } else if rank < train + val {
                SplitName::Val
            } else {
                SplitName::Test
            }
        }
    }
}

/// Frame `index`'s group and the number of groups (`None` for `Frame`).
pub fn group_of(preset: &Preset, index: u64, environment: &FrameEnvironment) -> Option<(u64, u64)> {
    let digits_group = |axes: usize| {
        let radices = preset.frame_radices().ok()?;
        let digits = decode_mixed_radix(index, &radices);
        let (mut group, mut groups) = (0u64, 1u64);
        for (d, r) in digits.iter().zip(radices).take(axes) {
            group = group * r + d;
            groups = groups.saturating_mul(r);
        }
        Some((group, groups))
    };
    match preset.output.split.by {
        SplitBy::Frame => None,
        SplitBy::CameraPose => digits_group(3),
        // The seven sweep axes (camera, plane, density), not `repeat` or the sequence step.
        SplitBy::SweepPoint => digits_group(7),
        SplitBy::Environment => Some((environment.choice as u64, environment_groups(preset))),
    }
}

/// The number of environments frames can get: the `Random` sky's choices, else 1.
fn environment_groups(preset: &Preset) -> u64 {
    match &preset.sky {
        Sky::Random { choices, .. } if !choices.is_empty() => choices.len() as u64,
        _ => 1,
    }
}

/// The number of groups: `None` for `Frame`.
pub fn groups(preset: &Preset) -> Option<u64> {
    let radices = preset.frame_radices().ok()?;
    let product = |n: usize| radices[..n].iter().fold(1u64, |a, &r| a.saturating_mul(r));
    match preset.output.split.by {
        SplitBy::Frame => None,
        SplitBy::CameraPose => Some(product(3)),
        SplitBy::SweepPoint => Some(product(7)),
        SplitBy::Environment => Some(environment_groups(preset)),
    }
}

/// Groups in train, val and test when `groups` groups are split:
/// round(G·train), round(G·(train + val)) − round(G·train), the rest.
pub fn group_counts(preset: &Preset, groups: u64) -> [u64; 3] {
    let s = &preset.output.split;
    let g = groups as f64;
    let train = ((g * s.train).round() as u64).min(groups);
    let train_val = ((g * (s.train + s.val)).round() as u64).clamp(train, groups);
    [train, train_val - train, groups - train_val]
}

/// Frames per split (train, val, test) of the first `frames` frames when
/// each frame (sequence) draws its own split (`SplitBy::Frame`); `None` for
/// the grouped modes (see [`group_counts`]) or when there are more than
/// `max_draws` draws. Exact and cheap: every full block of
/// [`seed::SPLIT_BLOCK`] draws holds each rank once, so only the last,
/// partial block is drawn one by one.
pub fn frame_split_counts(preset: &Preset, frames: u64, max_draws: u64) -> Option<[u64; 3]> {
    if preset.output.split.by != SplitBy::Frame {
        return None;
    }
    let len = if preset.sequence.is_some() {
        preset.sequence_len().max(1)
    } else {
        1
    };
    let draws = frames.div_ceil(len);
    if draws > max_draws {
        return None;
    }
    let s = &preset.output.split;
    let slot = |u: f64| {
        if u < s.train {
            0
        } else if u < s.train + s.val {
            1
        } else {
            2
        }
    };
    let block = seed::SPLIT_BLOCK;
    let mut per_block = [0u64; 3];
    for rank in 0..block {
        per_block[slot((rank as f64 + 0.5) / block as f64)] += 1;
    }
    let full = draws / block;
    let mut counts = per_block.map(|n| n * full * len);
    for draw in full * block..draws {
        counts[slot(seed::split_uniform(preset.seed, draw))] += len;
    }
    // The last sequence may be cut short by `frames`.
    if let Some(last) = draws.checked_sub(1) {
        let short = draws * len - frames;
        let i = slot(seed::split_uniform(preset.seed, last));
        counts[i] -= short;
    }
    Some(counts)
}
