//! The written picture's focal length (issue 41): the smallest whose
//! border pixels' centres all come from inside the render's pixel centres
//! ([`LensGeometry::fill_focal`]), found by a bisection of 60 steps from
//! [focal / 64, 64 · focal] on a border of 260 points (65 along each side).
//! Each step asks whether every point's source is inside; the answer is
//! decided by the few points that bind there (the others are inside by a
//! margin at the bisection's end, so at each step), so the steps solve
//! those few, and the rest are solved once to confirm it: the same focal
//! length, bit for bit, as asking every point at every step (tested),
//! for about a tenth of the solves.

use super::LensGeometry;

/// The border's points along each side: this many + 1.
const SIDE: u32 = 64;

/// The bisection's steps.
const STEPS: usize = 60;

/// How far outside a pixel centre a source may lie and still count as
/// inside (pixels).
const EPS: f64 = 1e-9;

/// A point whose source is inside by this (pixels) at a focal length is
/// inside at every larger one: the source moves inwards as the focal
/// length grows (the bisection's premise), and a solve's error is far
/// under it (its Newton steps stop within 1e-14 of the normalised point).
const MARGIN: f64 = 1e-6;

/// Rounds of the binding points' bisection before every point is asked at
/// every step instead (each round adds the points found not inside by
/// [`MARGIN`] at its result).
const ROUNDS: usize = 4;

impl LensGeometry {
    /// The smallest written focal length whose border pixels' centres all
    /// come from inside the render's pixel centres (a bisection; the
    /// mapping is monotone in it), on one thread (a step solves a few
    /// points: waking another costs more than it saves).
    pub(super) fn fill_focal(&self) -> f64 {
        self.fill_focal_rounds().0
    }

    /// [`Self::fill_focal`] and the rounds of binding points it took
    /// ([`ROUNDS`] + 1: every point at every step).
    fn fill_focal_rounds(&self) -> (f64, usize) {
        let border = self.border();
        let (lo, hi) = (self.focal / 64.0, self.focal * 64.0);
        if !self.all_inside(&border, hi, 0.0) {
            return (self.focal, 0);
        }
        // The point least inside at the render's own focal length first.
        let mut binding = vec![self.least_inside(&border)];
        for round in 1..=ROUNDS {
            let points: Vec<(f64, f64)> = binding.iter().map(|&i| border[i]).collect();
            let fo = bisect(lo, hi, |fo| self.all_inside(&points, fo, 0.0));
            // Every other point inside by the margin at `fo` is inside at
            // each step that `points` found inside (those are ≥ `fo`).
            let solved = self.inverse_all_with(fo, &border);
            let asked = |i: usize| binding.iter().any(|&j| border[j] == border[i]);
            let loose: Vec<usize> = (0..border.len())
                .filter(|&i| !asked(i) && !self.inside(solved[i], MARGIN))
                .collect();
            if loose.is_empty() {
                return (fo, round);
            }
            binding.extend(loose);
        }
        let fo = bisect(lo, hi, |fo| self.all_inside(&border, fo, 0.0));
        (fo, ROUNDS + 1)
    }

    /// The border's pixel centres: 65 along each side, corners included.
    fn border(&self) -> Vec<(f64, f64)> {
        let (w, h) = (f64::from(self.width), f64::from(self.height));
        (0..=SIDE)
            .flat_map(|i| {
                let t = f64::from(i) / f64::from(SIDE);
                let (x, y) = (0.5 + t * (w - 1.0), 0.5 + t * (h - 1.0));
                [(x, 0.5), (x, h - 0.5), (0.5, y), (w - 0.5, y)]
            })
            .collect()
    }

    /// Whether the source `(u, v)` lies inside the render's pixel centres
    /// (within [`EPS`]) by `margin` pixels (NaN: never).
    fn inside(&self, (u, v): (f64, f64), margin: f64) -> bool {
        let (w, h) = (f64::from(self.width), f64::from(self.height));
        let (lo, hi) = (0.5 - EPS + margin, -0.5 + EPS - margin);
        (lo..=w + hi).contains(&u) && (lo..=h + hi).contains(&v)
    }

    /// Whether every one of `points`' sources lies inside by `margin` at
    /// the focal length `fo` (solved four at a time, stopping at the first
    /// four with one outside).
    fn all_inside(&self, points: &[(f64, f64)], fo: f64, margin: f64) -> bool {
        (points.chunks(4)).all(|four| {
            let solved = self.inverse_all_with(fo, four);
            solved.into_iter().all(|p| self.inside(p, margin))
        })
    }

    /// The index of the border point whose source lies least inside (or
    /// furthest outside) at the render's own focal length.
    fn least_inside(&self, border: &[(f64, f64)]) -> usize {
        let (w, h) = (f64::from(self.width), f64::from(self.height));
        let slack = |(u, v): (f64, f64)| match u.is_nan() || v.is_nan() {
            true => f64::NEG_INFINITY,
            false => (u - 0.5).min(w - 0.5 - u).min(v - 0.5).min(h - 0.5 - v),
        };
        let solved = self.inverse_all_with(self.focal, border);
        (0..solved.len())
            .min_by(|&i, &j| slack(solved[i]).total_cmp(&slack(solved[j])))
            .unwrap_or(0)
    }
}

/// The bisection of [`LensGeometry::fill_focal`]: `STEPS` halvings of
/// (`lo`, `hi`], keeping the upper end where `inside` holds.
fn bisect(mut lo: f64, mut hi: f64, mut inside: impl FnMut(f64) -> bool) -> f64 {
    for _ in 0..STEPS {
        let mid = 0.5 * (lo + hi);
        if inside(mid) {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    hi
}

#[cfg(test)]
mod tests {
    use super::super::LensDraw;
    use super::super::tests::bc;
    use super::*;

    /// The bisection on the binding points gives the focal length of the
    /// bisection asking every point at every step, bit for bit, within its
    /// rounds (no draw here falls back to asking every point): barrel,
    /// pincushion, a moustache lens (an edge's middle binds), tangential
    /// terms, symmetric ones (their corners tie), fisheyes, odd sizes.
    #[test]
    fn the_binding_points_give_every_points_focal_length() {
        let fisheye = |k1, k2| LensDraw::Fisheye {
            k1,
            k2,
            k3: 0.0,
            k4: 0.0,
        };
        let draws = [
            bc(-0.15, 0.02, 0.0005, -0.0005),
            bc(-0.3, 0.0, 0.0, 0.0),
            bc(0.25, 0.0, 0.0, 0.0),
            bc(-0.35, 0.2, 0.0, 0.0),
            bc(0.1, -0.08, 0.01, -0.02),
            bc(-0.05, 0.0, 0.0, 0.03),
            fisheye(0.0, 0.0),
            fisheye(0.05, -0.01),
        ];
        let mut rounds = Vec::new();
        for d in draws {
            for (w, h, f) in [(1920, 1080, 1158.0), (641, 359, 300.0), (200, 480, 510.0)] {
                let geo = LensGeometry::new(d, w, h, f).expect("a lens");
                let border = geo.border();
                let (lo, hi) = (f / 64.0, f * 64.0);
                assert!(geo.all_inside(&border, hi, 0.0));
                let every = bisect(lo, hi, |fo| geo.all_inside(&border, fo, 0.0));
                let (fo, round) = geo.fill_focal_rounds();
                assert_eq!(
                    fo.to_bits(),
                    every.to_bits(),
                    "{d:?} {w}×{h}: {fo} vs {every}"
                );
                assert!(round <= ROUNDS, "{d:?} {w}×{h}: every point asked");
                rounds.push(round);
            }
        }
        // A draw whose corners tie (no tangential terms) takes a second
        // round for the other corners; one with them, one round.
        assert!(rounds.contains(&1) && rounds.contains(&2), "{rounds:?}");
    }
}
