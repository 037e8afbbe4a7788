//! The thermal fit's drone sizes: `camera.observer.size_px_knots` fitted to the real
//! drone cores' deciles, so the apparent size can follow footage that holds two
//! populations (near large drones and far small ones) which one uniform `size_px` range
//! cannot (a 20 % share under 6 px with a 20 px median core).
//!
//! After a round with the drone core size or the share under 6 px outside (and at least
//! [`MIN_DRONES`] synthetic drones): knots at quantiles 0, 0.1, …, 0.9, 1 (from the
//! uniform `size_px` range the first time), each inner knot's px × the real cores'
//! decile ÷ the synthetic cores' decile at its quantile (within ×5 or ÷5; the core grows
//! with the apparent size, so the quantiles map onto each other), the ends × their
//! neighbour's ratio; then px made non-falling (a falling run pooled to its mean: [`non_falling`]), `size_px` set to the ends and the volume
//! scaled with the nearest distance as the visible fit does. Without `size_px` (a
//! distance range) the visible fit's [`adjust_size`] moves the distances.

use super::drones::{MIN_DRONES, adjust_size, scale_volume};
use crate::gap::report::{Report, Side};
use crate::preset::Preset;

/// The knots' quantiles: 0, the nine deciles, 1.
const QUANTILES: [f64; 11] = [0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0];

/// Ratio limits a round.
const MAX_RATIO: f64 = 5.0;

fn r3(v: f64) -> f64 {
    (v * 1000.0).round() / 1000.0
}

/// The drone cores of one side, sorted.
fn sorted_cores(side: &Side) -> Vec<f64> {
    let mut v: Vec<f64> = (side.frames.iter())
        .flat_map(|f| f.stats.drones.iter().map(|d| f64::from(d.core_px)))
        .filter(|c| c.is_finite())
        .collect();
    v.sort_by(f64::total_cmp);
    v
}

fn off(report: &Report, key: &str) -> bool {
    (report.statistics.iter().find(|r| r.key == key))
        .is_some_and(|r| r.verdict == "below" || r.verdict == "above")
}

/// Moves the apparent size's knots toward the real cores' deciles (module docs); the
/// change, in words, is appended to `changes`.
pub fn adjust(preset: &mut Preset, report: &Report, changes: &mut Vec<String>) {
    if !off(report, "drone_core_px") && !off(report, "drone_core_under_6px") {
        return;
    }
    let Some(obs) = preset.camera.observer.as_ref() else {
        return;
    };
    let Some(range) = obs.size_px else {
        adjust_size(preset, report, changes);
        return;
    };
    let (real, syn) = (sorted_cores(&report.real), sorted_cores(&report.synthetic));
    if real.is_empty() || syn.len() < MIN_DRONES {
        return;
    }
    let (w, h) = preset.render.resolution.size();
    let max_px = 2.0 * f64::from(w.max(h));
    let knots = moved_knots(|q| obs.size_at(range, q), &real, &syn, max_px);
    let (lo, hi) = (knots[0].1, knots[knots.len() - 1].1);
    changes.push(format!(
        "observer size_px {range:?} → ({lo}, {hi}), size_px_knots {:?} → {knots:?} (drone cores' deciles {:?} against the real {:?} px)",
        obs.size_px_knots,
        deciles(&syn),
        deciles(&real),
    ));
    if let Some(o) = &mut preset.camera.observer {
        o.size_px = Some((lo, hi));
        o.size_px_knots = Some(knots);
    }
    // The nearest distance is focal × span / the largest size.
    if hi > 0.0
        && let Some(note) = scale_volume(preset, range.1 / hi)
    {
        changes.push(note);
    }
}

/// The knots at [`QUANTILES`]: the px `now` gives at each quantile × the real ÷ the
/// synthetic cores' decile there (sorted `real` and `syn`, `syn` not empty), within
/// [0.5, `max_px`], made non-falling by pooling (module docs).
fn moved_knots(
    now: impl Fn(f64) -> f64,
    real: &[f64],
    syn: &[f64],
    max_px: f64,
) -> Vec<(f64, f64)> {
    let wanted: Vec<f64> = (QUANTILES.iter())
        .map(|&q| {
            let d = q.clamp(0.1, 0.9);
            let (r, s) = (
                crate::gap::percentile(real, d),
                crate::gap::percentile(syn, d),
            );
            let k = if s > 0.0 {
                (r / s).clamp(1.0 / MAX_RATIO, MAX_RATIO)
            } else {
                MAX_RATIO
            };
            (now(q) * k).clamp(0.5, max_px.max(0.5))
        })
        .collect();
    (QUANTILES.iter().zip(non_falling(&wanted)))
        .map(|(&q, px)| (q, r3(px)))
        .collect()
}

/// The non-falling sequence nearest `v` (least squares): each run of values that
/// falls is replaced by its mean (pool adjacent violators). Raising a knot to its
/// lower neighbour instead kept the small end from shrinking whenever one decile
/// asked for it and the decile below did not: at one apparent size the cores spread
/// with the drone's attitude, so neighbouring deciles can ask for opposite moves.
fn non_falling(v: &[f64]) -> Vec<f64> {
    // (mean, count) of each pooled block.
    let mut blocks: Vec<(f64, usize)> = Vec::with_capacity(v.len());
    for &x in v {
        let mut block = (x, 1);
        while let Some(&(mean, n)) = blocks.last() {
            if mean <= block.0 {
                break;
            }
            blocks.pop();
            let total = n + block.1;
            block = (
                (mean * n as f64 + block.0 * block.1 as f64) / total as f64,
                total,
            );
        }
        blocks.push(block);
    }
    (blocks.into_iter())
        .flat_map(|(mean, n)| std::iter::repeat_n(mean, n))
        .collect()
}

/// The nine deciles of sorted `v`, to 0.01 px, for the notes.
fn deciles(v: &[f64]) -> Vec<f64> {
    (QUANTILES[1..10].iter())
        .map(|&q| (crate::gap::percentile(v, q) * 100.0).round() / 100.0)
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::preset::observer::knots_at;
    use rand::{Rng, SeedableRng};

    /// Cores of `n` drones drawn from `size` (the px at a deviate): a core grows with the
    /// apparent size but not in proportion (0.3 px a px plus 1 px of blur), each drone
    /// × 0.8–1.2 for its attitude.
    fn cores(size: impl Fn(f64) -> f64, n: usize, seed: u64) -> Vec<f64> {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let mut v: Vec<f64> = (0..n)
            .map(|_| (0.3 * size(rng.random()) + 1.0) * rng.random_range(0.8..1.2))
            .collect();
        v.sort_by(f64::total_cmp);
        v
    }

    fn share_under(v: &[f64], px: f64) -> f64 {
        v.iter().filter(|&&c| c < px).count() as f64 / v.len() as f64
    }

    /// Footage of two populations (a fifth far and small, 6–20 px; three quarters near,
    /// 40–90 px; log-uniform within each): from a uniform 16–70 px range, four rounds of the decile rule bring the
    /// synthetic cores' share under 6 px within 4 points and their median within 5 % of
    /// the real ones (simulated cores; rendering frames would take minutes).
    #[test]
    fn falling_runs_are_pooled_to_their_mean() {
        assert_eq!(non_falling(&[1.0, 3.0, 2.0, 4.0]), [1.0, 2.5, 2.5, 4.0]);
        assert_eq!(non_falling(&[5.0, 1.0, 0.0]), [2.0, 2.0, 2.0]);
        assert_eq!(non_falling(&[1.0, 2.0, 2.0]), [1.0, 2.0, 2.0]);
    }

    #[test]
    fn the_deciles_recover_a_two_population_mix() {
        let truth = [(0.0, 6.0), (0.2, 20.0), (0.25, 40.0), (1.0, 90.0)];
        let real = cores(|u| knots_at(&truth, u), 4000, 1);
        let (real_small, real_median) =
            (share_under(&real, 6.0), crate::gap::percentile(&real, 0.5));
        let mut knots = vec![(0.0, 16.0), (1.0, 70.0)];
        for round in 0..4 {
            let syn = cores(|u| knots_at(&knots, u), 4000, 10 + round);
            knots = moved_knots(|q| knots_at(&knots, q), &real, &syn, 1280.0);
        }
        let syn = cores(|u| knots_at(&knots, u), 4000, 99);
        let (small, median) = (share_under(&syn, 6.0), crate::gap::percentile(&syn, 0.5));
        assert!((real_small - 0.2).abs() < 0.05, "real share {real_small}");
        assert!(
            (small - real_small).abs() < 0.04,
            "share under 6 px {small} against {real_small}; {knots:?}"
        );
        assert!(
            (median / real_median - 1.0).abs() < 0.05,
            "median {median} against {real_median}"
        );
        assert!(
            knots
                .windows(2)
                .all(|w| w[0].0 < w[1].0 && w[0].1 <= w[1].1),
            "{knots:?}"
        );
    }
}
