//! How the drones look (`appearance:` in a preset): a material drawn per
//! drone from a palette (colour, roughness, metalness) and an optional
//! emissive factor. Off unless a preset names it: the models' own glTF
//! materials are then drawn unchanged. The draws are `scene::DroneLook`.

use serde::{Deserialize, Serialize};

use super::Validator;

/// A palette colour of the drone's body.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum DroneColor {
    /// Linear albedo 0.80.
    White,
    /// Linear albedo 0.45.
    LightGrey,
    /// Linear albedo 0.12.
    DarkGrey,
    /// Linear albedo 0.03.
    Black,
    /// A saturated colour of random hue (red, orange, yellow, green, blue, …), linear albedo about 0.3.
    Coloured,
}

impl DroneColor {
    /// The name a preset spells it with.
    pub fn name(self) -> &'static str {
        match self {
            Self::White => "White",
            Self::LightGrey => "LightGrey",
            Self::DarkGrey => "DarkGrey",
            Self::Black => "Black",
            Self::Coloured => "Coloured",
        }
    }
}

/// Drone materials drawn per drone.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Appearance {
    /// Colours with their weights (a drone takes colour k with probability weight_k / Σ weights).
    pub palette: Vec<(DroneColor, f64)>,
    /// glTF roughness, drawn uniformly per drone within (min, max), in [0, 1].
    pub roughness: (f64, f64),
    /// glTF metalness, drawn uniformly per drone within (min, max), in [0, 1].
    pub metalness: (f64, f64),
    /// Share of drones that carry lights (0: none).
    pub emissive_share: f64,
    /// Emission of a drone with lights, as a multiple of its colour (linear), drawn within (min, max).
    pub emissive_strength: (f64, f64),
    /// Opacity of the rotor discs (the built-in models' spinning rotors, and any
    /// glTF `alphaMode: BLEND` material: a factor on its alpha), drawn uniformly
    /// per drone within (min, max), in [0, 1]. (1, 1): solid discs as before
    /// (and then not written to `preset.lock.ron`, which stays as it was).
    #[serde(skip_serializing_if = "solid_rotors")]
    pub rotor_opacity: (f64, f64),
}

fn solid_rotors(range: &(f64, f64)) -> bool {
    *range == (1.0, 1.0)
}

impl Default for Appearance {
    fn default() -> Self {
        Self {
            palette: vec![
                (DroneColor::White, 4.0),
                (DroneColor::LightGrey, 2.0),
                (DroneColor::DarkGrey, 1.0),
                (DroneColor::Black, 2.0),
                (DroneColor::Coloured, 1.0),
            ],
            roughness: (0.3, 0.8),
            metalness: (0.0, 0.2),
            emissive_share: 0.15,
            emissive_strength: (0.3, 1.5),
            rotor_opacity: (1.0, 1.0),
        }
    }
}

impl Appearance {
    pub(super) fn validate_into(&self, v: &mut Validator) {
        v.check(
            !self.palette.is_empty()
                && self.palette.len() <= 64
                && self.palette.iter().all(|(_, w)| w.is_finite() && *w >= 0.0)
                && self.palette.iter().any(|(_, w)| *w > 0.0),
            "appearance.palette",
            || {
                "needs 1 to 64 (colour, weight) entries, weights finite and ≥ 0, at least one > 0"
                    .into()
            },
        );
        for (name, (lo, hi), max) in [
            ("roughness", self.roughness, 1.0),
            ("metalness", self.metalness, 1.0),
            ("emissive_strength", self.emissive_strength, 100.0),
            ("rotor_opacity", self.rotor_opacity, 1.0),
        ] {
            v.check(
                lo.is_finite() && hi.is_finite() && lo >= 0.0 && lo <= hi && hi <= max,
                &format!("appearance.{name}"),
                || format!("({lo}, {hi}) must be finite with 0 ≤ min ≤ max ≤ {max}"),
            );
        }
        v.check(
            self.emissive_share.is_finite() && (0.0..=1.0).contains(&self.emissive_share),
            "appearance.emissive_share",
            || format!("{} must be within [0, 1]", self.emissive_share),
        );
    }
}
