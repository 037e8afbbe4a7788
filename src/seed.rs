//! Deterministic per-frame randomness: a frame is a pure function of
//! (preset, frame index), so any frame can be made alone on any machine.
//!
//! `frame_seed = mix64(preset_seed ⊕ mix64(index + φ64))` where `mix64` is
//! the SplitMix64 finaliser and φ64 = 0x9E3779B97F4A7C15. The frame's sampler
//! is ChaCha8 seeded with `frame_seed` (rand_chacha's `seed_from_u64`).

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

const GOLDEN_GAMMA: u64 = 0x9E37_79B9_7F4A_7C15;
/// Salt that keeps the split draw independent of the scene draws.
const SPLIT_SALT: u64 = 0x5350_4C49_545F_5341; // "SPLIT_SA"

/// SplitMix64's output function (Steele, Lea, Flood 2014): a bijective 64-bit mixer.
pub const fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The documented per-frame seed.
pub const fn frame_seed(preset_seed: u64, frame_index: u64) -> u64 {
    mix64(preset_seed ^ mix64(frame_index.wrapping_add(GOLDEN_GAMMA)))
}

/// Salt of the re-draw seeds (`labels.min_labelled`).
const REDRAW_SALT: u64 = 0x5245_4452_4157_5F5F; // "REDRAW__"

/// The seed of re-draw `attempt` (1, 2, …) of a frame that had too few
/// labelled drones: `mix64(frame_seed ⊕ mix64(attempt ⊕ salt))`. Attempt 0 is
/// the frame seed itself.
pub const fn redraw_seed(preset_seed: u64, frame_index: u64, attempt: u32) -> u64 {
    let base = frame_seed(preset_seed, frame_index);
    if attempt == 0 {
        base
    } else {
        mix64(base ^ mix64(attempt as u64 ^ REDRAW_SALT))
    }
}

/// Salt of the camera model's draws (issue 21).
const CAMERA_SALT: u64 = 0x4341_4D45_5241_5F4D; // "CAMERA_M"

/// The camera model's seed of frame `frame_index`:
/// `mix64(frame_seed ⊕ CAMERA_SALT)`. Its own stream, so turning the
/// camera model on changes none of the scene's draws.
pub const fn camera_seed(preset_seed: u64, frame_index: u64) -> u64 {
    mix64(frame_seed(preset_seed, frame_index) ^ CAMERA_SALT)
}

/// The sampler for one frame.
pub fn frame_rng(preset_seed: u64, frame_index: u64) -> ChaCha8Rng {
    ChaCha8Rng::seed_from_u64(frame_seed(preset_seed, frame_index))
}

/// Salts of the realism draws (issue 21): each its own stream, so turning one
/// on never shifts the placement, the sky or another's draws.
pub const ATMOSPHERE_SALT: u64 = 0x4154_4D4F_5350_4852; // "ATMOSPHR"
pub const APPEARANCE_SALT: u64 = 0x4150_5045_4152_4E43; // "APPEARNC"
/// The drones' rotor opacities (`appearance.rotor_opacity`).
pub const ROTOR_SALT: u64 = 0x524F_544F_5253_5F5F; // "ROTORS__"
pub const OBSERVER_SALT: u64 = 0x4F42_5345_5256_4552; // "OBSERVER"
/// Salt of the clutter draws (issue 22).
pub const CLUTTER_SALT: u64 = 0x434C_5554_5445_5253; // "CLUTTERS"
pub const BACKPLATE_SALT: u64 = 0x4241_434B_504C_4154; // "BACKPLAT"
/// The weather's particles (`scene::weather`).
pub const WEATHER_SALT: u64 = 0x5745_4154_4845_5253; // "WEATHERS"

/// A frame's sampler of one salted stream: ChaCha8 seeded with
/// `mix64(frame_seed ⊕ mix64(salt))`.
pub fn salted_rng(preset_seed: u64, frame_index: u64, salt: u64) -> ChaCha8Rng {
    ChaCha8Rng::seed_from_u64(mix64(frame_seed(preset_seed, frame_index) ^ mix64(salt)))
}

/// Frames are split in blocks of this many consecutive indices.
pub const SPLIT_BLOCK: u64 = 100;

/// The split draw of a frame: a number in (0, 1) whose values over each block
/// of [`SPLIT_BLOCK`] consecutive frames are exactly (r + ½)/100 for r = 0..99
/// in a seeded random order. Comparing it with the cumulative shares gives
/// every full block exactly the requested 70/10/20 (or other) split, while
/// each frame's split still depends only on (seed, index). Block 0 is then
/// reordered so that it starts with one frame of each split
/// (`scene::split::first_block`).
pub fn split_uniform(preset_seed: u64, frame_index: u64) -> f64 {
    let order = split_block_order(preset_seed, frame_index / SPLIT_BLOCK);
    let rank = order[(frame_index % SPLIT_BLOCK) as usize];
    (rank as f64 + 0.5) / SPLIT_BLOCK as f64
}

/// The ranks 0..99 of split block `block` in their seeded order (ChaCha8
/// seeded with `mix64(seed ⊕ SPLIT_SALT) ⊕ mix64(block)`, a Fisher–Yates
/// shuffle): position p holds the rank of frame `block · 100 + p`.
pub fn split_block_order(preset_seed: u64, block: u64) -> [u64; SPLIT_BLOCK as usize] {
    use rand::seq::SliceRandom;
    let mut order: [u64; SPLIT_BLOCK as usize] = std::array::from_fn(|i| i as u64);
    let mut rng = ChaCha8Rng::seed_from_u64(mix64(preset_seed ^ SPLIT_SALT) ^ mix64(block));
    order.shuffle(&mut rng);
    order
}

/// A seeded bijection of `0..n` (n ≥ 1; 0 when n ≤ 1): a four-round Feistel
/// network on the smallest even number of bits that holds n − 1, walked
/// until it lands below n ("cycle walking", under four steps on average).
/// O(1) per element, so a group's rank needs no table of all groups.
pub fn permute(key: u64, x: u64, n: u64) -> u64 {
    if n <= 1 {
        return 0;
    }
    let bits = (64 - (n - 1).leading_zeros()).next_multiple_of(2).max(2);
    let half = bits / 2;
    let mask = if half == 32 {
        u64::from(u32::MAX)
    } else {
        (1u64 << half) - 1
    };
    let mut y = x;
    loop {
        let (mut left, mut right) = (y >> half, y & mask);
        for round in 0..4u64 {
            let f = mix64(key ^ mix64(right ^ (round << 60) ^ GOLDEN_GAMMA)) & mask;
            (left, right) = (right, left ^ f);
        }
        y = (left << half) | right;
        if y < n {
            return y;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn seeds_are_stable_and_distinct() {
        // Pinned values: changing the hash silently would change every dataset.
        assert_eq!(mix64(0), 0);
        assert_eq!(mix64(1), 0x5692_161D_100B_05E5);
        let a: Vec<u64> = (0..1000).map(|i| frame_seed(42, i)).collect();
        let set: std::collections::BTreeSet<_> = a.iter().collect();
        assert_eq!(set.len(), a.len());
        assert_ne!(frame_seed(42, 0), frame_seed(43, 0));
    }

    #[test]
    fn permute_is_a_bijection_for_any_size() {
        for n in [1u64, 2, 3, 7, 10, 64, 100, 1000, 4097] {
            let mut seen: Vec<u64> = (0..n).map(|x| permute(42, x, n)).collect();
            seen.sort_unstable();
            assert_eq!(seen, (0..n).collect::<Vec<_>>(), "n = {n}");
        }
        let a: Vec<u64> = (0..100).map(|x| permute(1, x, 100)).collect();
        let b: Vec<u64> = (0..100).map(|x| permute(2, x, 100)).collect();
        assert_ne!(a, b);
        assert_ne!(a, (0..100).collect::<Vec<_>>());
        // Large domains stay in range.
        assert!(permute(3, u64::MAX - 1, u64::MAX) < u64::MAX);
    }

    #[test]
    fn every_block_of_100_frames_splits_exactly() {
        for block in 0..5 {
            let u: Vec<f64> = (block * 100..block * 100 + 100)
                .map(|i| split_uniform(7, i))
                .collect();
            assert_eq!(u.iter().filter(|&&x| x < 0.7).count(), 70);
            assert_eq!(u.iter().filter(|&&x| (0.7..0.8).contains(&x)).count(), 10);
            assert_eq!(u.iter().filter(|&&x| x >= 0.8).count(), 20);
        }
        // Not simply in index order, and different per seed.
        let a: Vec<f64> = (0..100).map(|i| split_uniform(7, i)).collect();
        let b: Vec<f64> = (0..100).map(|i| split_uniform(8, i)).collect();
        assert_ne!(a, b);
        assert!(a.windows(2).any(|w| w[0] > w[1]));
    }
}
