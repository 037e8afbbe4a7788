//! The observer camera (`camera.observer:` in a preset): the camera as a
//! person on the ground points it, looking up at the swarm from below, so the
//! horizon sits low in the frame or out of it and the drones are against the
//! sky. Off unless a preset names it; the sweep's CameraX/Y/Z are then not used.

use serde::{Deserialize, Serialize};

use super::Validator;

/// The camera looks at the volume's centre from distance D along a line of
/// sight with elevation E above the horizon and azimuth A (from +Z towards
/// +X): it sits at `−D·(cos E·sin A, sin E, cos E·cos A)` with no roll.
/// E, A and D are drawn per frame; the horizon is then at
/// `v = cy + f·tan E` pixels (below the centre; out of frame when E > fov_y/2).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ObserverCamera {
    /// Elevation E of the line of sight, degrees above the horizon, drawn uniformly within (min, max).
    pub elevation_deg: (f64, f64),
    /// Azimuth A of the line of sight, degrees, drawn uniformly within (min, max).
    pub azimuth_deg: (f64, f64),
    /// Distance D from the camera to the volume's centre (its depth along the line of
    /// sight with `centre_at`), metres, drawn uniformly within (min, max).
    pub distance_m: (f64, f64),
    /// Instead of `distance_m`: the drawn apparent size s of the largest model
    /// at the volume's centre in pixels, and D = f·size_m / s (f the focal length in pixels).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub size_px: Option<(f64, f64)>,
    /// With `size_px`: the apparent size's distribution as (quantile, px) knots instead
    /// of a uniform draw within `size_px`; the draw's deviate u gives the px at u,
    /// geometric between the two knots around it (log-uniform within each segment).
    /// Quantiles rise from 0 to 1, px never fall, and the first and last px are
    /// `size_px`'s ends. Absent: uniform within `size_px`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub size_px_knots: Option<Vec<(f64, f64)>>,
    /// Where the volume's centre appears in the frame: (x, y) as shares of the width
    /// and height from the top-left corner, each within [0, 1]. The line of sight keeps
    /// its elevation and azimuth (and a backplate's horizon its row); the camera moves
    /// sideways so the centre lies at depth D on the ray through that point. Absent:
    /// the frame's centre.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub centre_at: Option<(f64, f64)>,
}

impl Default for ObserverCamera {
    fn default() -> Self {
        Self {
            elevation_deg: (15.0, 60.0),
            azimuth_deg: (-180.0, 180.0),
            distance_m: (300.0, 1500.0),
            size_px: None,
            size_px_knots: None,
            centre_at: None,
        }
    }
}

impl ObserverCamera {
    pub(super) fn validate_into(&self, v: &mut Validator) {
        let (lo, hi) = self.elevation_deg;
        v.check(
            lo.is_finite() && hi.is_finite() && lo <= hi && lo >= -80.0 && hi <= 80.0,
            "camera.observer.elevation_deg",
            || format!("({lo}, {hi}) must be finite degrees with min ≤ max within [-80, 80]"),
        );
        let (lo, hi) = self.azimuth_deg;
        v.check(
            lo.is_finite() && hi.is_finite() && lo <= hi && lo >= -360.0 && hi <= 360.0,
            "camera.observer.azimuth_deg",
            || format!("({lo}, {hi}) must be finite degrees with min ≤ max within [-360, 360]"),
        );
        let (lo, hi) = self.distance_m;
        v.check(
            lo.is_finite() && hi.is_finite() && lo > 0.0 && lo <= hi && hi <= 1e6,
            "camera.observer.distance_m",
            || format!("({lo}, {hi}) must be metres with 0 < min ≤ max ≤ 1e6"),
        );
        if let Some((lo, hi)) = self.size_px {
            v.check(
                lo.is_finite() && hi.is_finite() && lo >= 0.1 && lo <= hi && hi <= 1e5,
                "camera.observer.size_px",
                || format!("({lo}, {hi}) must be pixels with 0.1 ≤ min ≤ max ≤ 1e5"),
            );
        }
        if let Some((x, y)) = self.centre_at {
            v.check(
                (0.0..=1.0).contains(&x) && (0.0..=1.0).contains(&y),
                "camera.observer.centre_at",
                || format!("({x}, {y}) must be shares of the frame within [0, 1]"),
            );
        }
        if let Some(knots) = &self.size_px_knots {
            let problem = knots_problem(knots, self.size_px);
            v.check(problem.is_none(), "camera.observer.size_px_knots", || {
                problem.unwrap_or_default()
            });
        }
    }

    /// The apparent size in px at the draw's deviate `u` in [0, 1): uniform within
    /// `size_px` (`range`) or, with knots, their inverse distribution function.
    pub fn size_at(&self, range: (f64, f64), u: f64) -> f64 {
        match &self.size_px_knots {
            Some(knots) => knots_at(knots, u),
            None => range.0 + (range.1 - range.0) * u,
        }
    }
}

/// The px at quantile `u` of (quantile, px) `knots` (validated: quantiles rising from 0
/// to 1, px positive and never falling): geometric between the knots around `u`.
pub fn knots_at(knots: &[(f64, f64)], u: f64) -> f64 {
    if knots.len() < 2 {
        return knots.first().map_or(1.0, |k| k.1);
    }
    let upper = knots
        .iter()
        .position(|k| k.0 > u)
        .unwrap_or(knots.len() - 1);
    let (q1, p1) = knots[upper.max(1)];
    let (q0, p0) = knots[upper.max(1) - 1];
    let t = ((u - q0) / (q1 - q0)).clamp(0.0, 1.0);
    p0 * (p1 / p0).powf(t)
}

/// Why `knots` cannot be `size_px_knots` with this `size_px`, in words; `None` when they can.
fn knots_problem(knots: &[(f64, f64)], size_px: Option<(f64, f64)>) -> Option<String> {
    let Some((lo, hi)) = size_px else {
        return Some("needs camera.observer.size_px (the knots' first and last px)".into());
    };
    let (Some(first), Some(last)) = (knots.first(), knots.last()) else {
        return Some("needs at least two (quantile, px) knots".into());
    };
    if knots.len() < 2 || knots.len() > 64 {
        return Some(format!("has {} knots; 2 to 64 are allowed", knots.len()));
    }
    if first.0 != 0.0 || last.0 != 1.0 {
        return Some(format!(
            "quantiles must run from 0 to 1 (they run from {} to {})",
            first.0, last.0
        ));
    }
    if let Some(w) = knots
        .windows(2)
        .find(|w| !(w[0].0 < w[1].0 && w[0].1 <= w[1].1))
    {
        return Some(format!(
            "({}, {}) then ({}, {}): quantiles must rise and px never fall",
            w[0].0, w[0].1, w[1].0, w[1].1
        ));
    }
    if first.1 != lo || last.1 != hi {
        return Some(format!(
            "first and last px ({}, {}) must be camera.observer.size_px's ends ({lo}, {hi})",
            first.1, last.1
        ));
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::preset::Preset;
    use rand::{Rng, SeedableRng};

    const KNOTS: [(f64, f64); 4] = [(0.0, 2.0), (0.2, 6.0), (0.5, 20.0), (1.0, 120.0)];

    fn observer(knots: Vec<(f64, f64)>, size_px: (f64, f64)) -> ObserverCamera {
        ObserverCamera {
            size_px: Some(size_px),
            size_px_knots: Some(knots),
            ..ObserverCamera::default()
        }
    }

    /// 20 000 draws' quantiles land on the knots (within 2 %) and, between them, on the
    /// geometric mean of the two knots around the middle quantile.
    #[test]
    fn drawn_sizes_have_the_knots_quantiles() {
        let o = observer(KNOTS.to_vec(), (2.0, 120.0));
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(41);
        let mut v: Vec<f64> = (0..20_000)
            .map(|_| o.size_at((2.0, 120.0), rng.random()))
            .collect();
        v.sort_by(f64::total_cmp);
        let at = |q: f64| v[((v.len() - 1) as f64 * q).round() as usize];
        let mid = |a: (f64, f64), b: (f64, f64)| ((a.0 + b.0) / 2.0, (a.1 * b.1).sqrt());
        let expect = [
            KNOTS[1],
            KNOTS[2],
            mid(KNOTS[0], KNOTS[1]),
            mid(KNOTS[2], KNOTS[3]),
        ];
        for (q, px) in expect {
            let got = at(q);
            assert!(
                (got / px - 1.0).abs() < 0.02,
                "quantile {q}: {got} px, knots give {px}"
            );
        }
        assert!(v[0] >= 2.0 && v[v.len() - 1] <= 120.0);
        // Without knots: the uniform draw of before, the same deviate.
        let plain = ObserverCamera::default();
        assert_eq!(plain.size_at((16.0, 70.0), 0.25), 16.0 + 54.0 * 0.25);
    }

    #[test]
    fn bad_knots_are_refused_naming_the_field() {
        let bad = [
            (KNOTS.to_vec(), (3.0, 120.0)),
            (
                vec![(0.0, 2.0), (0.6, 6.0), (0.5, 20.0), (1.0, 120.0)],
                (2.0, 120.0),
            ),
            (
                vec![(0.0, 2.0), (0.5, 30.0), (0.7, 20.0), (1.0, 120.0)],
                (2.0, 120.0),
            ),
            (vec![(0.0, 2.0), (0.9, 120.0)], (2.0, 120.0)),
            (
                vec![(0.0, 2.0), (f64::NAN, 9.0), (1.0, 120.0)],
                (2.0, 120.0),
            ),
            (vec![(0.0, 2.0)], (2.0, 2.0)),
        ];
        for (knots, range) in bad {
            let mut p = Preset::default();
            p.camera.observer = Some(observer(knots.clone(), range));
            let errors = p.validate().expect_err("refused");
            assert!(
                errors
                    .iter()
                    .any(|e| e.field == "camera.observer.size_px_knots"),
                "{knots:?}: {errors:?}"
            );
        }
        let mut p = Preset::default();
        p.camera.observer = Some(observer(KNOTS.to_vec(), (2.0, 120.0)));
        assert!(p.validate().is_ok(), "{:?}", p.validate());
        p.camera.observer = Some(ObserverCamera {
            size_px: None,
            ..observer(KNOTS.to_vec(), (2.0, 120.0))
        });
        assert!(p.validate().is_err());
    }
}
