//! The gain control's percentiles without a histogram of every pixel: the
//! value at each wanted rank found by selection. A sample of the plane
//! (every [`STRIDE`]th pixel) brackets each rank's value; one pass over the
//! plane counts the pixels below each bracket and keeps those inside it
//! (compares and adds that vectorise, no scattered counts); the value is
//! then selected among the kept. The histogram's answer is the bin of that
//! value (its bins rise with the value), so the percentiles are the
//! histogram's to the bit; where a rank falls outside its bracket, or the
//! sample holds a NaN, the caller falls back to the histogram.

use rayon::prelude::*;

/// One pixel in this many is sampled (odd, so that the sample walks across
/// the columns of a wide frame rather than down a few of them).
const STRIDE: usize = 251;

/// Planes under this many pixels use the histogram (a small sample
/// brackets poorly, and the pass costs little anyway).
pub(super) const MIN_PIXELS: usize = 1 << 16;

/// Pixels per block of the counting pass (its "any kept?" test).
const BLOCK: usize = 64;

/// The values of `plane` at the 1-based `ranks` in the order NaN first,
/// then ascending (`None` where a bracket misses its rank, the sample holds
/// a NaN, or the plane is under [`MIN_PIXELS`]).
pub(super) fn values_at_ranks(plane: &[f32], ranks: [u64; 2]) -> Option<[f32; 2]> {
    if plane.len() < MIN_PIXELS {
        return None;
    }
    let brackets = brackets(plane, ranks)?;
    let chunk = plane
        .len()
        .div_ceil(2 * rayon::current_num_threads())
        .max(1 << 16);
    let (below, mut kept) = (plane.par_chunks(chunk))
        .map(|c| tally(c, brackets))
        .reduce(
            || ([0u64; 2], [Vec::new(), Vec::new()]),
            |(mut n, mut kept), (m, more)| {
                for k in 0..2 {
                    n[k] += m[k];
                    kept[k].extend_from_slice(&more[k]);
                }
                (n, kept)
            },
        );
    let mut out = [0f32; 2];
    for k in 0..2 {
        let at = usize::try_from(ranks[k].checked_sub(below[k] + 1)?).ok()?;
        let kept = &mut kept[k];
        if at >= kept.len() {
            return None;
        }
        out[k] = *kept.select_nth_unstable_by(at, f32::total_cmp).1;
    }
    Some(out)
}

/// Each rank's bracket `(a, b)` of values from the sample's order
/// statistics, four standard errors of a quantile (and three samples)
/// either side of the rank's place (−∞ or +∞ past the sample's ends).
fn brackets(plane: &[f32], ranks: [u64; 2]) -> Option<[(f32, f32); 2]> {
    let mut sample: Vec<f32> = plane.iter().step_by(STRIDE).copied().collect();
    if sample.iter().any(|v| v.is_nan()) {
        return None;
    }
    let (n, ns) = (plane.len() as f64, sample.len() as f64);
    let mut out = [(0f32, 0f32); 2];
    for (o, &rank) in out.iter_mut().zip(&ranks) {
        let p = (rank as f64 / n).clamp(0.0, 1.0);
        let place = p * ns - 1.0;
        let margin = 4.0 * (ns * p * (1.0 - p)).sqrt() + 3.0;
        let (i, j) = ((place - margin).floor(), (place + margin).ceil());
        let last = sample.len() - 1;
        let mut at = |i: f64| *sample.select_nth_unstable_by(i as usize, f32::total_cmp).1;
        let a = if i < 1.0 { f32::NEG_INFINITY } else { at(i) };
        let b = if j >= last as f64 {
            f32::INFINITY
        } else {
            at(j)
        };
        *o = (a, b);
    }
    Some(out)
}

simd_fn! {
    /// For each bracket `(a, b)`: how many pixels of `chunk` lie below `a`
    /// (NaN counted below), and the values in [a, b].
    fn tally(chunk: &[f32], brackets: [(f32, f32); 2]) -> ([u64; 2], [Vec<f32>; 2]) {
        let [(a0, b0), (a1, b1)] = brackets;
        let mut below = [0u64; 2];
        let mut kept = [Vec::new(), Vec::new()];
        for block in chunk.chunks(BLOCK) {
            let (mut n0, mut n1, mut any) = (0u32, 0u32, false);
            for &v in block {
                // Not at or above a: below it, or NaN.
                let (at0, at1) = (v >= a0, v >= a1);
                n0 += u32::from(!at0);
                n1 += u32::from(!at1);
                any |= at0 & (v <= b0) | at1 & (v <= b1);
            }
            below[0] += u64::from(n0);
            below[1] += u64::from(n1);
            if any {
                for &v in block {
                    if v >= a0 && v <= b0 {
                        kept[0].push(v);
                    }
                    if v >= a1 && v <= b1 {
                        kept[1].push(v);
                    }
                }
            }
        }
        (below, kept)
    }
}

#[cfg(test)]
mod tests {
    use super::super::{histogram_percentiles, percentiles_within};
    use super::*;

    /// A 320×256 plane: a sky's gradient with hashed noise, a few hot
    /// pixels, and `f` applied to each value with its index.
    fn plane(f: impl Fn(usize, f32) -> f32) -> Vec<f32> {
        (0..320 * 256)
            .map(|i| {
                let hash = (i as u32).wrapping_mul(2_654_435_761) >> 20;
                let v = 30.0 + (i / 320) as f32 * 0.02 + hash as f32 * 1e-4;
                f(i, if i % 4099 == 5 { v + 40.0 } else { v })
            })
            .collect()
    }

    /// The selected values are a full sort's (NaN first) at those ranks, and
    /// the percentiles the histogram's, bit for bit, over awkward planes.
    #[test]
    fn selection_gives_the_histograms_percentiles() {
        let nan_off_sample = |i: usize, v: f32| {
            if i % 1000 == 3 && !i.is_multiple_of(STRIDE) {
                f32::NAN
            } else {
                v
            }
        };
        let planes = [
            ("sky", plane(|_, v| v)),
            ("ties", plane(|i, _| (i * 7 % 13) as f32)),
            ("NaN", plane(nan_off_sample)),
            ("negative", plane(|_, v| -v)),
        ];
        let percentiles = [(0.5, 99.9), (0.0, 100.0), (2.0, 98.0), (50.0, 50.001)];
        for (name, plane) in &planes {
            let extremes = super::super::extremes(plane, (f32::INFINITY, f32::NEG_INFINITY));
            let mut sorted = plane.clone();
            sorted.sort_by(|a, b| match (a.is_nan(), b.is_nan()) {
                (false, false) => a.total_cmp(b),
                (x, y) => y.cmp(&x),
            });
            for p in percentiles {
                let rank = |p: f64| (p / 100.0 * plane.len() as f64).ceil().max(1.0) as u64;
                let ranks = [rank(p.0), rank(p.1)];
                let values = values_at_ranks(plane, ranks);
                // The NaN plane's low rank lands among the NaNs for p = 0.
                if *name != "NaN" || p.0 > 0.0 {
                    let values = values.unwrap_or_else(|| panic!("{name} {p:?}: no selection"));
                    let want = ranks.map(|r| sorted[r as usize - 1]);
                    assert_eq!(
                        values.map(f32::to_bits),
                        want.map(f32::to_bits),
                        "{name} {p:?}"
                    );
                }
                let scale = (super::super::AGC_BINS - 1) as f32 / (extremes.1 - extremes.0);
                let hist = histogram_percentiles(plane, extremes, scale, ranks);
                assert_eq!(
                    percentiles_within(plane, extremes, p),
                    (hist[0], hist[1]),
                    "{name} {p:?}"
                );
            }
        }
    }

    /// A NaN in the sample, or a plane too small, declines (the histogram runs).
    #[test]
    fn selection_declines_what_it_cannot_bracket() {
        let nan = plane(|i, v| if i == 7 * STRIDE { f32::NAN } else { v });
        assert_eq!(values_at_ranks(&nan, [10, 70_000]), None);
        let small = vec![1.0f32; MIN_PIXELS - 1];
        assert_eq!(values_at_ranks(&small, [1, 2]), None);
        // A rank outside the plane has no value.
        assert_eq!(values_at_ranks(&plane(|_, v| v), [0, 5]), None);
    }
}
