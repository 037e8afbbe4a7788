//! Preset types of swarm formations and motion (issue 12): the formation
//! shapes of `Placement::Formation`, the sequence mode (`Preset::sequence`)
//! and the absolute camera. Plain serde data; where the drones go is decided
//! in `scene/placement.rs`, how they move in `scene/motion.rs`.

use serde::{Deserialize, Serialize};

use super::{AttitudeRanges, Validator};

/// The most drones one formation may hold (its geometry is checked pairwise at validation).
pub const MAX_FORMATION_DRONES: u32 = 100_000;
/// The most steps T of one sequence.
pub const MAX_SEQUENCE_STEPS: u32 = 100_000;

/// The shape of a formation and its own parameters. Every shape lies in the
/// formation's frame: forward +Z (the heading), right +X, up +Y, centred on
/// the origin.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum FormationShape {
    /// Side by side along the formation's right axis.
    LineAbreast,
    /// One behind the other along the heading.
    Column,
    /// A diagonal line, each drone behind and to the right of the one ahead;
    /// `angle_deg` is measured from the heading (0 = column, 90 = line abreast).
    Echelon { angle_deg: f64 },
    /// A V with the leader at the apex, the others alternately left and right
    /// behind it; `half_angle_deg` between each arm and the heading.
    Wedge { half_angle_deg: f64 },
    /// A circle with neighbours `spacing` apart (chord), its axis the
    /// formation's up axis tilted forward by `tilt_deg`.
    Ring { tilt_deg: f64 },
    /// Points spread evenly on a sphere (Fibonacci lattice) whose radius puts
    /// the nearest two exactly `spacing` apart.
    SphereShell,
    /// `clusters` dense groups (drones `spacing` apart at least, at random in
    /// each group's ball) whose centres are at least `cluster_gap` model spans
    /// apart beyond the groups' own radii, laid out at random.
    Clustered { clusters: u32, cluster_gap: f64 },
}

/// A formation: its shape, size, heading and jitter (`Placement::Formation`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Formation {
    pub shape: FormationShape,
    /// Drones in the formation.
    pub count: u32,
    /// Distance between neighbours in units of the largest model span (a LoadFactor).
    pub spacing: f64,
    /// Heading: yaw of the formation's forward axis about +Y, degrees, an
    /// inclusive (min, max) drawn per frame (or per sequence).
    pub heading_deg: (f64, f64),
    /// Each drone is moved by up to ± this many model spans along each axis, uniformly.
    pub position_jitter: f64,
    /// Each drone's attitude: the heading, then these roll/pitch/yaw draws (degrees).
    pub attitude_jitter: AttitudeRanges,
    /// No two drone centres come closer than this many largest model spans.
    /// Validation refuses a shape whose spacing, less twice the largest jitter,
    /// could break it.
    pub min_separation: f64,
}

impl Default for Formation {
    fn default() -> Self {
        Self {
            shape: FormationShape::Wedge {
                half_angle_deg: 35.0,
            },
            count: 7,
            spacing: 4.0,
            heading_deg: (0.0, 0.0),
            position_jitter: 0.0,
            attitude_jitter: AttitudeRanges::zero(),
            min_separation: 1.0,
        }
    }
}

impl AttitudeRanges {
    /// All three ranges (0, 0).
    pub const fn zero() -> Self {
        Self {
            roll_deg: (0.0, 0.0),
            pitch_deg: (0.0, 0.0),
            yaw_deg: (0.0, 0.0),
        }
    }
}

impl FormationShape {
    /// Every shape with its default parameters, for pickers and tests.
    pub fn all() -> [Self; 7] {
        [
            Self::LineAbreast,
            Self::Column,
            Self::Echelon { angle_deg: 45.0 },
            Self::Wedge {
                half_angle_deg: 35.0,
            },
            Self::Ring { tilt_deg: 0.0 },
            Self::SphereShell,
            Self::Clustered {
                clusters: 3,
                cluster_gap: 4.0,
            },
        ]
    }

    /// The shape's name as the preset spells it.
    pub fn name(&self) -> &'static str {
        match self {
            Self::LineAbreast => "LineAbreast",
            Self::Column => "Column",
            Self::Echelon { .. } => "Echelon",
            Self::Wedge { .. } => "Wedge",
            Self::Ring { .. } => "Ring",
            Self::SphereShell => "SphereShell",
            Self::Clustered { .. } => "Clustered",
        }
    }
}

/// The sequence mode: each sweep point (and repeat) becomes a sequence of
/// `steps + 1` frames t = 0..=T in which every drone moves from its initial
/// to its terminal state by the paper's equations 4–5.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SequenceSpec {
    /// T, the number of interpolation steps; a sequence has T + 1 frames.
    pub steps: u32,
    /// How the terminal state is made from the initial one.
    pub motion: Motion,
    /// Where the camera is during the sequence.
    pub camera: SequenceCamera,
    /// Frames per second written into MOT's `seqinfo.ini`.
    pub frame_rate: u32,
}

impl Default for SequenceSpec {
    fn default() -> Self {
        Self {
            steps: 24,
            motion: Motion::default(),
            camera: SequenceCamera::Fixed,
            frame_rate: 30,
        }
    }
}

/// The terminal state of each drone: its initial state moved by the
/// whole-formation manoeuvre (turn and bank about the formation's centre,
/// then translate), then by its own displacement and attitude change drawn
/// within the ranges given.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Motion {
    /// Translation of the whole formation over the sequence, metres (world x, y, z).
    pub translate_m: (f64, f64, f64),
    /// Turn of the whole formation about the vertical through its centre, degrees.
    pub turn_deg: f64,
    /// Bank: every drone rolls about its own forward axis by this many degrees.
    pub bank_deg: f64,
    /// Per-drone displacement drawn uniformly within ± these metres per axis.
    pub displacement_m: (f64, f64, f64),
    /// Per-drone attitude change (body roll/pitch/yaw, degrees) drawn within these ranges.
    pub attitude_change: AttitudeRanges,
}

impl Default for Motion {
    fn default() -> Self {
        Self {
            translate_m: (0.0, 0.0, 10.0),
            turn_deg: 0.0,
            bank_deg: 0.0,
            displacement_m: (0.0, 0.0, 0.0),
            attitude_change: AttitudeRanges::zero(),
        }
    }
}

/// The camera of a sequence.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum SequenceCamera {
    /// The same pose in every frame (the paper's ground observer), placed to
    /// see the swarm's initial and terminal states.
    #[default]
    Fixed,
    /// The camera keeps its offset from the swarm's centroid and looks at it.
    Follow,
}

/// An absolute camera pose in metres (world frame), instead of the paper's
/// relative CameraX/Y/Z sweep.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct AbsoluteCamera {
    /// Camera centre, metres.
    pub position_m: (f64, f64, f64),
    /// The point the camera looks at, metres.
    pub look_at_m: (f64, f64, f64),
}

impl Default for AbsoluteCamera {
    fn default() -> Self {
        Self {
            position_m: (0.0, 3.0, 40.0),
            look_at_m: (0.0, 0.0, 0.0),
        }
    }
}

fn finite_pair(v: &mut Validator, field: &str, (lo, hi): (f64, f64), limit: f64) {
    v.check(
        lo.is_finite() && hi.is_finite() && lo <= hi && lo >= -limit && hi <= limit,
        field,
        || format!("({lo}, {hi}) must be finite with min ≤ max within [-{limit}, {limit}]"),
    );
}

fn attitude_ranges(v: &mut Validator, field: &str, a: &AttitudeRanges) {
    for (name, pair) in [
        ("roll_deg", a.roll_deg),
        ("pitch_deg", a.pitch_deg),
        ("yaw_deg", a.yaw_deg),
    ] {
        finite_pair(v, &format!("{field}.{name}"), pair, 360.0);
    }
}

impl Formation {
    /// The smallest centre distance between two drones of the unjittered
    /// shape, in model spans (`scene/placement.rs` builds each shape so; its
    /// tests check it). `None` when no two drones are placed by a fixed rule
    /// (one drone, or the random groups of `Clustered`, which are drawn at the
    /// separation).
    pub fn nominal_min_spacing(&self) -> Option<f64> {
        if self.count < 2 {
            return None;
        }
        match &self.shape {
            FormationShape::Wedge { half_angle_deg } if self.count >= 3 => {
                let across = 2.0 * half_angle_deg.to_radians().sin();
                Some(self.spacing * across.min(1.0))
            }
            FormationShape::Clustered { .. } => None,
            _ => Some(self.spacing),
        }
    }

    /// The worst case of the jittered shape: the nominal spacing less twice
    /// the longest jitter (each drone moves up to `position_jitter·√3` spans).
    pub fn worst_min_spacing(&self) -> Option<f64> {
        self.nominal_min_spacing()
            .map(|d| d - 2.0 * 3f64.sqrt() * self.position_jitter)
    }

    /// Push every invalid value, fields named under `field`; a shape whose
    /// spacing and jitter could bring two drones closer than `min_separation`
    /// is refused.
    pub(crate) fn validate_into(&self, v: &mut Validator, field: &str) {
        v.check(
            (1..=MAX_FORMATION_DRONES).contains(&self.count),
            &format!("{field}.count"),
            || {
                format!(
                    "{} drones is out of range [1, {MAX_FORMATION_DRONES}]",
                    self.count
                )
            },
        );
        for (name, x, lo, hi) in [
            ("spacing", self.spacing, 1e-6, 1e6),
            ("position_jitter", self.position_jitter, 0.0, 1e6),
            ("min_separation", self.min_separation, 0.0, 1e6),
        ] {
            v.check(
                x.is_finite() && x >= lo && x <= hi,
                &format!("{field}.{name}"),
                || format!("{x} is out of range [{lo}, {hi}] model spans"),
            );
        }
        finite_pair(v, &format!("{field}.heading_deg"), self.heading_deg, 3600.0);
        attitude_ranges(
            v,
            &format!("{field}.attitude_jitter"),
            &self.attitude_jitter,
        );
        let shape = format!("{field}.shape");
        match &self.shape {
            FormationShape::Echelon { angle_deg } => v.check(
                angle_deg.is_finite() && (0.0..=90.0).contains(angle_deg),
                &format!("{shape}.angle_deg"),
                || format!("{angle_deg} is out of range [0, 90] degrees"),
            ),
            FormationShape::Wedge { half_angle_deg } => v.check(
                half_angle_deg.is_finite() && *half_angle_deg > 0.0 && *half_angle_deg <= 90.0,
                &format!("{shape}.half_angle_deg"),
                || format!("{half_angle_deg} is out of range (0, 90] degrees"),
            ),
            FormationShape::Ring { tilt_deg } => v.check(
                tilt_deg.is_finite() && tilt_deg.abs() <= 360.0,
                &format!("{shape}.tilt_deg"),
                || format!("{tilt_deg} is out of range [-360, 360] degrees"),
            ),
            FormationShape::Clustered {
                clusters,
                cluster_gap,
            } => {
                v.check(
                    *clusters >= 1 && *clusters <= self.count.max(1),
                    &format!("{shape}.clusters"),
                    || format!("{clusters} must be in [1, count = {}]", self.count),
                );
                v.check(
                    cluster_gap.is_finite() && (0.0..=1e6).contains(cluster_gap),
                    &format!("{shape}.cluster_gap"),
                    || format!("{cluster_gap} is out of range [0, 1e6] model spans"),
                );
            }
            FormationShape::LineAbreast | FormationShape::Column | FormationShape::SphereShell => {}
        }
        if v.errors.is_empty()
            && let Some(worst) = self.worst_min_spacing()
        {
            v.check(
                worst + 1e-9 >= self.min_separation,
                &format!("{field}.min_separation"),
                || {
                    format!(
                        "the {} at spacing {} with jitter ±{} can bring two drones {worst:.3} model spans apart, closer than min_separation {} (raise spacing or lower the jitter)",
                        self.shape.name(),
                        self.spacing,
                        self.position_jitter,
                        self.min_separation
                    )
                },
            );
        }
    }
}

impl SequenceSpec {
    /// Push every invalid value, fields named under `field`.
    pub(crate) fn validate_into(&self, v: &mut Validator, field: &str) {
        v.check(
            (1..=MAX_SEQUENCE_STEPS).contains(&self.steps),
            &format!("{field}.steps"),
            || {
                format!(
                    "{} is out of range [1, {MAX_SEQUENCE_STEPS}] (a sequence has steps + 1 frames)",
                    self.steps
                )
            },
        );
        v.check(
            (1..=1000).contains(&self.frame_rate),
            &format!("{field}.frame_rate"),
            || {
                format!(
                    "{} is out of range [1, 1000] frames per second",
                    self.frame_rate
                )
            },
        );
        let m = &self.motion;
        let (tx, ty, tz) = m.translate_m;
        let (dx, dy, dz) = m.displacement_m;
        v.check(
            [tx, ty, tz].iter().all(|x| x.is_finite() && x.abs() <= 1e6),
            &format!("{field}.motion.translate_m"),
            || format!("({tx}, {ty}, {tz}) must be finite metres within ±1e6"),
        );
        v.check(
            [dx, dy, dz]
                .iter()
                .all(|x| x.is_finite() && (0.0..=1e6).contains(x)),
            &format!("{field}.motion.displacement_m"),
            || format!("({dx}, {dy}, {dz}) must be finite metres in [0, 1e6]"),
        );
        for (name, x) in [("turn_deg", m.turn_deg), ("bank_deg", m.bank_deg)] {
            v.check(
                x.is_finite() && x.abs() <= 3600.0,
                &format!("{field}.motion.{name}"),
                || format!("{x} is out of range [-3600, 3600] degrees"),
            );
        }
        attitude_ranges(
            v,
            &format!("{field}.motion.attitude_change"),
            &m.attitude_change,
        );
    }
}

impl AbsoluteCamera {
    /// Push every invalid value, fields named under `field`.
    pub(crate) fn validate_into(&self, v: &mut Validator, field: &str) {
        let (p, l) = (self.position_m, self.look_at_m);
        for (name, (x, y, z)) in [("position_m", p), ("look_at_m", l)] {
            v.check(
                [x, y, z].iter().all(|c| c.is_finite() && c.abs() <= 1e7),
                &format!("{field}.{name}"),
                || format!("({x}, {y}, {z}) must be finite metres within ±1e7"),
            );
        }
        v.check(p != l, &format!("{field}.look_at_m"), || {
            "the camera cannot look at its own position".into()
        });
    }
}

impl super::Preset {
    /// The sequence and the absolute camera (issue 12).
    pub(crate) fn validate_motion(&self, v: &mut Validator) {
        if let Some(s) = &self.sequence {
            s.validate_into(v, "sequence");
        }
        if let Some(a) = &self.camera.absolute {
            a.validate_into(v, "camera.absolute");
        }
    }
}

/// A `DensitySweep` volume: a box of positive size and densities > 0 whose
/// largest drone count stays within the limit.
pub(crate) fn validate_density_sweep(
    v: &mut Validator,
    (x, y, z): (f64, f64, f64),
    per_m3: super::sweep::SweepRange,
) {
    for (axis, s) in [("x", x), ("y", y), ("z", z)] {
        v.check(
            s.is_finite() && s > 0.0 && s <= 1e6,
            &format!("placement.volume.size_m.{axis}"),
            || format!("{s} is out of range (0, 1e6] metres"),
        );
    }
    let (lo, hi) = (per_m3.start.min(per_m3.end), per_m3.start.max(per_m3.end));
    v.check(
        lo.is_finite() && lo > 0.0,
        "placement.volume.per_m3",
        || format!("densities from {lo} must be > 0 drones per m³"),
    );
    let most = (hi * x * y * z).round();
    v.check(
        most.is_finite() && most <= super::MAX_DRONES_PER_FRAME as f64,
        "placement.volume.per_m3",
        || {
            format!(
                "{hi} drones per m³ in {x} × {y} × {z} m is {most} drones, more than the limit of {}",
                super::MAX_DRONES_PER_FRAME
            )
        },
    );
}
