//! The split of a frame: a pure function of (preset, frame index), like the
//! rest of the frame, so any frame, shard, `--every` trial or `--limit` peek
//! agrees on it.
//!
//! `output.split.by` says what is kept whole (docs/conventions.md, "Splits"):
//!
//! - `Frame` (the default): each frame's split draw (in sequence mode the
//!   draw of its sequence's number), [`draw_slot`]: blocks of 100 draws, each
//!   a seeded shuffle holding every share's rounded count (`seed::split_uniform`),
//!   except that the first block starts with one draw of each split whose
//!   share is above 0 (and holds at least one of each). So every run of at
//!   least 3 frames (sequences) from frame 0 has three non-empty splits, and
//!   every full block holds the shares exactly.
//! - `CameraPose`, `SweepPoint`, `Environment`: frames are grouped (by their
//!   CameraX/CameraY/CameraZ sweep values; by every swept value, only
//!   `repeat` differing; by the `Random` sky's choice) and whole groups are
//!   split, [`group_slot`]: [`group_counts`] groups per split (round(G·train),
//!   round(G·(train + val)) − round(G·train), the rest; at least one for
//!   every share above 0 when G allows), groups 0, 1, 2 one of each split (in
//!   a seeded order), the rest ranked by a seeded permutation
//!   (`seed::permute`). Camera-pose and sweep-point groups are numbered in
//!   frame order, so a `--limit` run that reaches three groups has three
//!   splits.
//!
//! A sequence (sequence mode) never changes its sweep values or environment,
//! so every mode keeps sequences whole. A run of at least 3 frames that keeps
//! groups (sequences) whole and holds too few of them is refused at its start
//! ([`run_splits`], `pipeline::check::run_split_error`).

use crate::preset::sweep::decode_mixed_radix;
use crate::preset::{Preset, Sky, SplitBy};
use crate::seed;
use crate::sky::FrameEnvironment;

use super::{SequenceFrame, SplitName};

/// Salt of the group ranking (apart from the per-frame split draw).
const GROUP_SALT: u64 = 0x4752_4f55_505f_5350; // "GROUP_SP"
/// Salt of the order of the first groups (one of each split).
const FIRST_GROUPS_SALT: u64 = 0x4649_5253_545f_4753; // "FIRST_GS"

const SPLITS: [SplitName; 3] = [SplitName::Train, SplitName::Val, SplitName::Test];

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
            SPLITS[draw_slot(preset.seed, shares(preset), draw)]
        }
        Some((group, groups)) => SPLITS[group_slot(preset, group, groups)],
    }
}

/// The preset's train, val and test shares.
fn shares(preset: &Preset) -> [f64; 3] {
    let s = &preset.output.split;
    [s.train, s.val, s.test]
}

/// The split (0 train, 1 val, 2 test) of a split draw `u` against the
/// cumulative shares: train if `u < train`, val if `u < train + val`, else test.
fn slot_of_uniform(shares: [f64; 3], u: f64) -> usize {
    if u < shares[0] {
        0
    } else if u < shares[0] + shares[1] {
        1
    } else {
        2
    }
}

/// The split (0 train, 1 val, 2 test) of split draw `draw` (a frame, or a
/// sequence in sequence mode). Draws from 100 on: the block's seeded rank
/// against the cumulative shares (`seed::split_uniform`). Draws 0..99:
/// [`first_block`].
pub fn draw_slot(preset_seed: u64, shares: [f64; 3], draw: u64) -> usize {
    if draw < seed::SPLIT_BLOCK {
        usize::from(first_block(preset_seed, shares)[draw as usize])
    } else {
        slot_of_uniform(shares, seed::split_uniform(preset_seed, draw))
    }
}

/// The splits of draws 0..99: block 0's seeded ranks against the shares,
/// then (1) a split whose share is above 0 but which no rank reaches (a
/// share under ½ %) takes the last draw of the split holding the most, and
/// (2) the first draw of each split moves to the front, in the order they
/// came. So draws 0, 1, 2 are one of each split (when all three shares are
/// above 0), and the draws after the last moved one keep their places.
pub fn first_block(preset_seed: u64, shares: [f64; 3]) -> [u8; seed::SPLIT_BLOCK as usize] {
    const N: usize = seed::SPLIT_BLOCK as usize;
    let order = seed::split_block_order(preset_seed, 0);
    let mut slots: [u8; N] =
        order.map(|r| slot_of_uniform(shares, (r as f64 + 0.5) / N as f64) as u8);
    for s in 0..3u8 {
        if shares[usize::from(s)] > 0.0 && !slots.contains(&s) {
            let mut counts = [0usize; 3];
            for &x in &slots {
                counts[usize::from(x)] += 1;
            }
            // The largest (the lower split on a tie).
            let big = (0..3u8)
                .rev()
                .max_by_key(|&t| counts[usize::from(t)])
                .unwrap_or(0);
            if let Some(j) = slots.iter().rposition(|&x| x == big) {
                slots[j] = s;
            }
        }
    }
    let mut firsts: Vec<usize> = (0..3u8)
        .filter_map(|s| slots.iter().position(|&x| x == s))
        .collect();
    firsts.sort_unstable();
    let mut out = [0u8; N];
    let rest = (0..N).filter(|p| !firsts.contains(p));
    for (o, p) in out.iter_mut().zip(firsts.iter().copied().chain(rest)) {
        *o = slots[p];
    }
    out
}

/// The split (0 train, 1 val, 2 test) of group `group` of `groups`: the
/// first k groups (k = the splits [`group_counts`] gives a group) one of
/// each split in a seeded order, the other G − k ranked by a seeded
/// permutation against the counts left.
pub fn group_slot(preset: &Preset, group: u64, groups: u64) -> usize {
    let counts = group_counts(preset, groups);
    let present: Vec<usize> = (0..3).filter(|&s| counts[s] > 0).collect();
    let k = present.len() as u64;
    let key = seed::mix64(preset.seed ^ GROUP_SALT) ^ preset.output.split.by as u64;
    if group < k {
        let first = seed::mix64(preset.seed ^ FIRST_GROUPS_SALT) ^ preset.output.split.by as u64;
        return present[seed::permute(first, group, k) as usize];
    }
    let left = counts.map(|n| n.saturating_sub(1));
    let rank = seed::permute(key, group - k, groups - k);
    if rank < left[0] {
        0
    } else if rank < left[0] + left[1] {
        1
    } else {
        2
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
/// round(G·train), round(G·(train + val)) − round(G·train), the rest; then,
/// when G is at least the number of shares above 0, a split whose share is
/// above 0 and got no group takes one from the split holding the most (the
/// lower split on a tie).
pub fn group_counts(preset: &Preset, groups: u64) -> [u64; 3] {
    let s = &preset.output.split;
    let g = groups as f64;
    let train = ((g * s.train).round() as u64).min(groups);
    let train_val = ((g * (s.train + s.val)).round() as u64).clamp(train, groups);
    let mut counts = [train, train_val - train, groups - train_val];
    let wanted = [s.train, s.val, s.test];
    let positive = wanted.iter().filter(|&&x| x > 0.0).count() as u64;
    if groups >= positive {
        for i in 0..3 {
            if wanted[i] > 0.0 && counts[i] == 0 {
                let big = (0..3).rev().max_by_key(|&t| counts[t]).unwrap_or(0);
                counts[big] -= 1;
                counts[i] = 1;
            }
        }
    }
    counts
}

/// Frames per split (train, val, test) of the first `frames` frames when
/// each frame (sequence) draws its own split (`SplitBy::Frame`); `None` for
/// the grouped modes (see [`group_counts`]) or when there are more than
/// `max_draws` draws. Exact and cheap: every full block of
/// [`seed::SPLIT_BLOCK`] draws after the first holds each rank once, so only
/// the first block and the last, partial one are drawn one by one.
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
    let shares = shares(preset);
    let block = seed::SPLIT_BLOCK;
    let mut counts = [0u64; 3];
    for &s in first_block(preset.seed, shares)
        .iter()
        .take(draws.min(block) as usize)
    {
        counts[usize::from(s)] += len;
    }
    let mut per_block = [0u64; 3];
    for rank in 0..block {
        per_block[slot_of_uniform(shares, (rank as f64 + 0.5) / block as f64)] += 1;
    }
    let full = (draws / block).saturating_sub(1);
    for (c, n) in counts.iter_mut().zip(per_block) {
        *c += n * full * len;
    }
    for draw in (full + 1) * block..draws {
        counts[draw_slot(preset.seed, shares, draw)] += len;
    }
    // The last sequence may be cut short by `frames`.
    if let Some(last) = draws.checked_sub(1) {
        let short = draws * len - frames;
        counts[draw_slot(preset.seed, shares, last)] -= short;
    }
    Some(counts)
}

/// What the splits of a run's frames hold, for the check at its start.
#[derive(Clone, Debug, PartialEq)]
pub struct RunSplits {
    /// The run's frames.
    pub frames: u64,
    /// What keeps a split's frames together: "sequence", "camera pose",
    /// "sweep point", "environment"; `None` when each frame draws its own.
    pub unit: Option<&'static str>,
    /// Per split: the first four groups (sequences) of the run in it, each
    /// as (group, its first frame in the run, its last frame in the run).
    pub groups: [Vec<(u64, u64, u64)>; 3],
    /// Per split: the run's groups (sequences) in it.
    pub group_counts: [u64; 3],
    /// Per split: the run's frames in it.
    pub frame_counts: [u64; 3],
    /// Frames per group when groups are runs of consecutive frames of the
    /// same size (sequences, camera poses, sweep points), else `None`.
    pub group_size: Option<u64>,
}

/// The splits of the frames `0, every, 2·every, …` below `end`, walked one by
/// one (each frame's group from its index, an environment from its sky draw),
/// at most `max_frames` of them (`None` past that).
pub fn run_splits(preset: &Preset, end: u64, every: u64, max_frames: u64) -> Option<RunSplits> {
    let every = every.max(1);
    let frames = end.div_ceil(every);
    if frames > max_frames {
        return None;
    }
    let len = if preset.sequence.is_some() {
        preset.sequence_len().max(1)
    } else {
        1
    };
    let radices = preset.frame_radices().ok()?;
    let product = |from: usize| {
        radices[from..]
            .iter()
            .fold(1u64, |a, &r| a.saturating_mul(r))
    };
    let (unit, group_size) = match preset.output.split.by {
        SplitBy::Frame if len > 1 => (Some("sequence"), Some(len)),
        SplitBy::Frame => (None, Some(1)),
        SplitBy::CameraPose => (Some("camera pose"), Some(product(3))),
        SplitBy::SweepPoint => (Some("sweep point"), Some(product(7))),
        SplitBy::Environment => (Some("environment"), None),
    };
    let shares = shares(preset);
    let mut out = RunSplits {
        frames,
        unit,
        groups: Default::default(),
        group_counts: [0; 3],
        frame_counts: [0; 3],
        group_size,
    };
    let mut seen: std::collections::BTreeMap<u64, usize> = Default::default();
    for index in (0..end).step_by(every as usize) {
        let (group, slot) = match preset.output.split.by {
            SplitBy::Frame => {
                let draw = index / len;
                (draw, draw_slot(preset.seed, shares, draw))
            }
            _ => {
                // The sky draws of the frame's sequence's first frame (as `build_frame`).
                let draw_index = index - index % len;
                let env = crate::sky::frame_environment(&preset.sky, preset.seed, draw_index);
                let (group, groups) = group_of(preset, index, &env)?;
                (group, group_slot(preset, group, groups))
            }
        };
        out.frame_counts[slot] += 1;
        match seen.get(&group) {
            Some(&i) => {
                if let Some(g) = out.groups[slot].get_mut(i) {
                    g.2 = index;
                }
            }
            None => {
                out.group_counts[slot] += 1;
                let list = &mut out.groups[slot];
                seen.insert(group, list.len());
                if list.len() < 4 {
                    list.push((group, index, index));
                }
            }
        }
    }
    Some(out)
}
