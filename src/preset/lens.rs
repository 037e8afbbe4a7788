//! The lens's geometric distortion (issue 41), `camera_model.lens`: the
//! Brown–Conrady radial and tangential model or the equidistant fisheye
//! (Kannala–Brandt, as OpenCV's `fisheye`), each coefficient a `(min, max)`
//! range drawn per frame by [`crate::sensor::draw`]. Plain serde data and its
//! own fields' checks; the mapping itself and the check that it never folds
//! the picture live in `sensor/lens.rs` and `pipeline/check.rs`.
//! docs/realism.md, "Lens distortion", describes every field.

use serde::{Deserialize, Serialize};

use super::Validator;

/// A lens's distortion model, its coefficients ranges (a fixed value is `(v, v)`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum Lens {
    /// Brown–Conrady, in normalised pinhole coordinates (x, y), r² = x² + y²:
    /// x_d = x·(1 + k1 r² + k2 r⁴ + k3 r⁶) + 2 p1 x y + p2 (r² + 2x²),
    /// y_d = y·(1 + k1 r² + k2 r⁴ + k3 r⁶) + p1 (r² + 2y²) + 2 p2 x y
    /// (OpenCV's order). k1 < 0: barrel; k1 > 0: pincushion.
    BrownConrady {
        #[serde(default)]
        k1: (f64, f64),
        #[serde(default)]
        k2: (f64, f64),
        #[serde(default)]
        k3: (f64, f64),
        #[serde(default)]
        p1: (f64, f64),
        #[serde(default)]
        p2: (f64, f64),
    },
    /// The equidistant fisheye (OpenCV's `fisheye` model): θ = atan r,
    /// θ_d = θ·(1 + k1 θ² + k2 θ⁴ + k3 θ⁶ + k4 θ⁸), (x_d, y_d) = (θ_d / r)·(x, y).
    Fisheye {
        #[serde(default)]
        k1: (f64, f64),
        #[serde(default)]
        k2: (f64, f64),
        #[serde(default)]
        k3: (f64, f64),
        #[serde(default)]
        k4: (f64, f64),
    },
}

/// The largest |k| accepted for a radial coefficient.
pub const MAX_RADIAL: f64 = 2.0;
/// The largest |p| accepted for a tangential coefficient.
pub const MAX_TANGENTIAL: f64 = 0.1;

impl Lens {
    /// Each coefficient's name, range and the bound on its magnitude.
    pub fn coefficients(&self) -> Vec<(&'static str, (f64, f64), f64)> {
        match *self {
            Self::BrownConrady { k1, k2, k3, p1, p2 } => vec![
                ("k1", k1, MAX_RADIAL),
                ("k2", k2, MAX_RADIAL),
                ("k3", k3, MAX_RADIAL),
                ("p1", p1, MAX_TANGENTIAL),
                ("p2", p2, MAX_TANGENTIAL),
            ],
            Self::Fisheye { k1, k2, k3, k4 } => vec![
                ("k1", k1, MAX_RADIAL),
                ("k2", k2, MAX_RADIAL),
                ("k3", k3, MAX_RADIAL),
                ("k4", k4, MAX_RADIAL),
            ],
        }
    }

    /// The model's name as the manifest and the app show it.
    pub fn kind(&self) -> &'static str {
        match self {
            Self::BrownConrady { .. } => "brown_conrady",
            Self::Fisheye { .. } => "fisheye",
        }
    }

    /// Each coefficient a finite range within its bound, named by its path.
    pub(super) fn validate(&self, v: &mut Validator) {
        for (name, (lo, hi), bound) in self.coefficients() {
            let field = format!("camera_model.lens.{name}");
            let ok = lo.is_finite() && hi.is_finite() && lo <= hi;
            v.check(ok, &field, || {
                format!("({lo}, {hi}) is not a range (min, max) of finite numbers with min ≤ max")
            });
            v.check(!ok || (lo >= -bound && hi <= bound), &field, || {
                format!("({lo}, {hi}) leaves [-{bound}, {bound}]")
            });
        }
    }
}
