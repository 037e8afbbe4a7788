//! Near-field scenery between the camera and the swarm (`clutter:` in a
//! preset, issue 22 item 2): tree lines along the horizon, single bare trees,
//! poles with power lines, buildings. Off unless a preset names it. The
//! frame's draw is `scene::clutter::FrameClutter`; the renderer draws it as
//! an occluder with no instance id (docs/realism.md, "Clutter").

use serde::{Deserialize, Serialize};

use super::Validator;

/// The most objects of one kind a frame may hold.
pub const MAX_CLUTTER_COUNT: u32 = 64;
/// The largest distance (metres) and height (metres) accepted.
pub const MAX_CLUTTER_DISTANCE_M: f64 = 20_000.0;
pub const MAX_CLUTTER_HEIGHT_M: f64 = 500.0;
/// The most branching levels of a tree (each level multiplies the branches by 2–3).
pub const MAX_BRANCH_LEVELS: u32 = 8;

/// The scenery of a frame. Every object stands on the ground (the camera's
/// height minus `eye_height_m`), at an azimuth inside the camera's view.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Clutter {
    /// true: drawn per frame (per sequence in sequence mode) from (seed,
    /// frame index); false: drawn once from the preset seed, the same
    /// scenery around every frame's camera (a fixed camera then keeps its
    /// background cached).
    pub per_frame: bool,
    /// Height of the camera above the ground, metres.
    pub eye_height_m: f64,
    pub tree_lines: TreeLines,
    pub trees: Trees,
    pub poles: Poles,
    pub buildings: Buildings,
}

impl Default for Clutter {
    fn default() -> Self {
        Self {
            per_frame: true,
            eye_height_m: 1.6,
            tree_lines: TreeLines::default(),
            trees: Trees::default(),
            poles: Poles::default(),
            buildings: Buildings::default(),
        }
    }
}

/// Bands of trees along the horizon: a canopy silhouette of crowns.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TreeLines {
    /// How many per frame, drawn uniformly in (min, max).
    pub count: (u32, u32),
    pub distance_m: (f64, f64),
    pub height_m: (f64, f64),
    /// Angular width of each band, degrees of azimuth.
    pub width_deg: (f64, f64),
}

impl Default for TreeLines {
    fn default() -> Self {
        Self {
            count: (1, 2),
            distance_m: (150.0, 600.0),
            height_m: (12.0, 25.0),
            width_deg: (30.0, 90.0),
        }
    }
}

/// Single bare trees: a trunk and `branch_levels` levels of thin branches.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Trees {
    pub count: (u32, u32),
    pub distance_m: (f64, f64),
    pub height_m: (f64, f64),
    pub branch_levels: u32,
}

impl Default for Trees {
    fn default() -> Self {
        Self {
            count: (0, 3),
            distance_m: (15.0, 60.0),
            height_m: (8.0, 20.0),
            branch_levels: 6,
        }
    }
}

/// Lines of poles across the view, each span hung with sagging wires.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Poles {
    /// Lines of poles per frame.
    pub count: (u32, u32),
    pub distance_m: (f64, f64),
    pub height_m: (f64, f64),
    /// Distance between neighbouring poles, metres.
    pub spacing_m: (f64, f64),
    /// Wires per span (0: bare poles).
    pub wires: (u32, u32),
}

impl Default for Poles {
    fn default() -> Self {
        Self {
            count: (0, 1),
            distance_m: (20.0, 80.0),
            height_m: (8.0, 12.0),
            spacing_m: (30.0, 50.0),
            wires: (2, 4),
        }
    }
}

/// Boxes with flat or gabled roofs.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Buildings {
    pub count: (u32, u32),
    pub distance_m: (f64, f64),
    pub height_m: (f64, f64),
    pub width_m: (f64, f64),
}

impl Default for Buildings {
    fn default() -> Self {
        Self {
            count: (0, 2),
            distance_m: (40.0, 200.0),
            height_m: (6.0, 20.0),
            width_m: (8.0, 30.0),
        }
    }
}

fn check_count(v: &mut Validator, field: &str, (lo, hi): (u32, u32)) {
    v.check(lo <= hi && hi <= MAX_CLUTTER_COUNT, field, || {
        format!("({lo}, {hi}) must be counts with min ≤ max ≤ {MAX_CLUTTER_COUNT}")
    });
}

fn check_range(v: &mut Validator, field: &str, (lo, hi): (f64, f64), (min, max): (f64, f64)) {
    v.check(
        lo.is_finite() && hi.is_finite() && lo >= min && lo <= hi && hi <= max && hi > 0.0,
        field,
        || format!("({lo}, {hi}) must lie in [{min}, {max}] with min ≤ max and max > 0"),
    );
}

impl Clutter {
    pub(super) fn validate_into(&self, v: &mut Validator) {
        let (d, h) = ((0.5, MAX_CLUTTER_DISTANCE_M), (0.1, MAX_CLUTTER_HEIGHT_M));
        v.check(
            self.eye_height_m.is_finite() && (0.0..=1000.0).contains(&self.eye_height_m),
            "clutter.eye_height_m",
            || format!("{} must be metres in [0, 1000]", self.eye_height_m),
        );
        let t = &self.tree_lines;
        check_count(v, "clutter.tree_lines.count", t.count);
        check_range(v, "clutter.tree_lines.distance_m", t.distance_m, d);
        check_range(v, "clutter.tree_lines.height_m", t.height_m, h);
        check_range(v, "clutter.tree_lines.width_deg", t.width_deg, (0.1, 360.0));
        let t = &self.trees;
        check_count(v, "clutter.trees.count", t.count);
        check_range(v, "clutter.trees.distance_m", t.distance_m, d);
        check_range(v, "clutter.trees.height_m", t.height_m, h);
        v.check(
            t.branch_levels <= MAX_BRANCH_LEVELS,
            "clutter.trees.branch_levels",
            || format!("{} must be at most {MAX_BRANCH_LEVELS}", t.branch_levels),
        );
        let p = &self.poles;
        check_count(v, "clutter.poles.count", p.count);
        check_range(v, "clutter.poles.distance_m", p.distance_m, d);
        check_range(v, "clutter.poles.height_m", p.height_m, h);
        check_range(v, "clutter.poles.spacing_m", p.spacing_m, (1.0, 1000.0));
        v.check(
            p.wires.0 <= p.wires.1 && p.wires.1 <= 8,
            "clutter.poles.wires",
            || {
                format!(
                    "({}, {}) must be counts with min ≤ max ≤ 8",
                    p.wires.0, p.wires.1
                )
            },
        );
        let b = &self.buildings;
        check_count(v, "clutter.buildings.count", b.count);
        check_range(v, "clutter.buildings.distance_m", b.distance_m, d);
        check_range(v, "clutter.buildings.height_m", b.height_m, h);
        check_range(v, "clutter.buildings.width_m", b.width_m, (0.5, 1000.0));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::preset::Preset;

    #[test]
    fn bad_ranges_are_named_by_field() {
        let mut c = Clutter::default();
        c.trees.count = (5, 2);
        c.poles.distance_m = (f64::NAN, 3.0);
        c.trees.branch_levels = 30;
        let preset = Preset {
            clutter: Some(c),
            ..Preset::default()
        };
        let errors = preset.validate().expect_err("the bad ranges are refused");
        let fields: Vec<&str> = errors.iter().map(|e| e.field.as_str()).collect();
        for f in [
            "clutter.trees.count",
            "clutter.poles.distance_m",
            "clutter.trees.branch_levels",
        ] {
            assert!(fields.contains(&f), "{f} missing from {fields:?}");
        }
        let ok = Preset {
            clutter: Some(Clutter::default()),
            ..Preset::default()
        };
        assert_eq!(ok.validate(), Ok(()));
    }
}
