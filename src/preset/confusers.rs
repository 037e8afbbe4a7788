//! Confusers (issue 22, `confusers:` in a preset): birds, manned aircraft and
//! balloons placed around the swarm, each kind labelled as its own class or
//! kept as an unlabelled hard negative. Off (an empty list) unless a preset
//! asks; the scene places them (`scene::confusers`), docs/negatives.md
//! describes the fields.

use serde::{Deserialize, Serialize};

use super::Validator;

/// A bird species of the built-in models (`bird_SPECIES_*.glb`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum BirdSpecies {
    /// House sparrow, ~0.15 m wingspan, fast whirring beat.
    Sparrow,
    /// Gull, ~1 m wingspan, long pointed wings.
    #[default]
    Gull,
    /// Buzzard-like raptor, ~1.5 m wingspan, broad wings, often gliding.
    Raptor,
}

/// What a confuser is: one of the built-in models.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum ConfuserKind {
    Bird(BirdSpecies),
    /// A high-wing single-engine aircraft (~11 m span).
    LightAircraft,
    /// A narrow-body airliner (~38 m long).
    Airliner,
    /// A light helicopter (~11 m rotor).
    Helicopter,
    /// A hot-air balloon (~17 m tall).
    Balloon,
}

impl Default for ConfuserKind {
    fn default() -> Self {
        Self::Bird(BirdSpecies::Gull)
    }
}

impl ConfuserKind {
    /// Every kind, in the order the app offers them.
    pub const ALL: [Self; 7] = [
        Self::Bird(BirdSpecies::Sparrow),
        Self::Bird(BirdSpecies::Gull),
        Self::Bird(BirdSpecies::Raptor),
        Self::LightAircraft,
        Self::Airliner,
        Self::Helicopter,
        Self::Balloon,
    ];

    /// Its name in the manifest and the app.
    pub fn name(self) -> &'static str {
        match self {
            Self::Bird(BirdSpecies::Sparrow) => "sparrow",
            Self::Bird(BirdSpecies::Gull) => "gull",
            Self::Bird(BirdSpecies::Raptor) => "raptor",
            Self::LightAircraft => "light_aircraft",
            Self::Airliner => "airliner",
            Self::Helicopter => "helicopter",
            Self::Balloon => "balloon",
        }
    }

    pub fn is_bird(self) -> bool {
        matches!(self, Self::Bird(_))
    }

    /// Largest span drawn when `size_m` is not given (birds: wingspan), metres.
    pub fn typical_size_m(self) -> (f64, f64) {
        match self {
            Self::Bird(BirdSpecies::Sparrow) => (0.13, 0.17),
            Self::Bird(BirdSpecies::Gull) => (0.9, 1.2),
            Self::Bird(BirdSpecies::Raptor) => (1.2, 1.6),
            Self::LightAircraft => (10.0, 11.5),
            Self::Airliner => (34.0, 40.0),
            Self::Helicopter => (10.0, 12.0),
            Self::Balloon => (15.0, 20.0),
        }
    }

    /// Speed drawn when `speed_m_s` is not given, metres per second.
    pub fn typical_speed_m_s(self) -> (f64, f64) {
        match self {
            Self::Bird(BirdSpecies::Sparrow) => (7.0, 11.0),
            Self::Bird(BirdSpecies::Gull) => (8.0, 14.0),
            Self::Bird(BirdSpecies::Raptor) => (6.0, 12.0),
            Self::LightAircraft => (45.0, 65.0),
            Self::Airliner => (70.0, 130.0),
            Self::Helicopter => (30.0, 60.0),
            Self::Balloon => (0.5, 4.0),
        }
    }

    /// The largest climb (pitch) and bank (roll) of its attitude, degrees
    /// either way: birds turn and climb steeply, aircraft gently, a balloon
    /// hangs upright.
    pub fn attitude_limits_deg(self) -> (f64, f64) {
        match self {
            Self::Bird(_) => (15.0, 20.0),
            Self::Balloon => (0.0, 0.0),
            Self::LightAircraft | Self::Airliner | Self::Helicopter => (6.0, 15.0),
        }
    }

    /// Wing beats per second drawn when `flap_hz` is not given (birds).
    pub fn typical_flap_hz(self) -> (f64, f64) {
        match self {
            Self::Bird(BirdSpecies::Sparrow) => (12.0, 15.0),
            Self::Bird(BirdSpecies::Gull) => (2.5, 3.5),
            Self::Bird(BirdSpecies::Raptor) => (2.0, 3.0),
            _ => (0.0, 0.0),
        }
    }

    /// The built-in models of this kind: a bird's flap poses then its
    /// gliding pose ([`FLAP_POSES`] + 1 names), else one.
    pub fn model_names(self) -> Vec<String> {
        match self {
            Self::Bird(_) => (0..FLAP_POSES)
                .map(Some)
                .chain([None])
                .map(|pose| bird_model(self.name(), pose))
                .collect(),
            other => vec![other.name().to_string()],
        }
    }
}

/// Flap poses per bird: pose `k` shows phase `k / FLAP_POSES` of the beat
/// (the built-in models `model::confusers` embeds, one per pose).
pub const FLAP_POSES: usize = 8;

/// The built-in model name of a bird species' pose (`None`: gliding).
pub fn bird_model(species: &str, pose: Option<usize>) -> String {
    match pose {
        Some(k) => format!("bird_{species}_{}", k % FLAP_POSES),
        None => format!("bird_{species}_glide"),
    }
}

/// How the birds of a flock are arranged about its leader.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum FlockShape {
    /// A V (skein) pointing along the heading, as geese and gulls fly.
    #[default]
    V,
    /// Side by side across the heading.
    Line,
    /// A loose ball, each bird drawn within a sphere (starlings, sparrows).
    Cloud,
}

/// One flock: every bird of the entry flies with the same heading and speed
/// in a formation about the flock's centre.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Flock {
    pub shape: FlockShape,
    /// Distance between neighbours in wingspans (`Cloud`: the ball's radius per bird).
    pub spacing_wingspans: f64,
    /// Each bird displaced by up to ± this many wingspans per axis.
    pub jitter_wingspans: f64,
}

impl Default for Flock {
    fn default() -> Self {
        Self {
            shape: FlockShape::V,
            spacing_wingspans: 1.5,
            jitter_wingspans: 0.3,
        }
    }
}

/// One kind of confuser in the frames (`confusers: [(kind: Bird(Gull), …)]`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Confuser {
    pub kind: ConfuserKind,
    /// How many per frame (inclusive range, drawn uniformly per frame or sequence).
    pub count: (u32, u32),
    /// Distance from the camera, metres, drawn per object (per flock: its centre).
    pub distance_m: (f64, f64),
    /// Largest span in metres (birds: wingspan), drawn per object; absent: the kind's typical.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub size_m: Option<(f64, f64)>,
    /// Speed along its heading, m/s, drawn per object (per flock); absent: the kind's typical.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub speed_m_s: Option<(f64, f64)>,
    /// The class it is labelled as; absent: an unlabelled hard negative
    /// (in the manifest with its boxes, never in YOLO/COCO/MOT).
    pub labelled_as: Option<String>,
    /// Birds: wing beats per second, drawn per bird; absent: the species' typical.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub flap_hz: Option<(f64, f64)>,
    /// Birds: the share that glide (wings held in the gliding pose), 0–1.
    pub glide_share: f64,
    /// Birds: fly as one flock; absent: each bird on its own.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub flock: Option<Flock>,
}

impl Default for Confuser {
    fn default() -> Self {
        Self {
            kind: ConfuserKind::default(),
            count: (1, 3),
            distance_m: (30.0, 300.0),
            size_m: None,
            speed_m_s: None,
            labelled_as: None,
            flap_hz: None,
            glide_share: 0.0,
            flock: None,
        }
    }
}

/// The most confusers of one entry in a frame.
pub const MAX_PER_ENTRY: u32 = 500;
/// The most entries in `confusers`.
pub const MAX_ENTRIES: usize = 32;

impl Confuser {
    /// The size range drawn from.
    pub fn size_range_m(&self) -> (f64, f64) {
        self.size_m.unwrap_or(self.kind.typical_size_m())
    }

    pub fn speed_range_m_s(&self) -> (f64, f64) {
        self.speed_m_s.unwrap_or(self.kind.typical_speed_m_s())
    }

    pub fn flap_range_hz(&self) -> (f64, f64) {
        self.flap_hz.unwrap_or(self.kind.typical_flap_hz())
    }

    pub(super) fn validate_into(&self, i: usize, v: &mut Validator) {
        let field = |name: &str| format!("confusers[{i}].{name}");
        let (lo, hi) = self.count;
        v.check(lo <= hi && hi <= MAX_PER_ENTRY, &field("count"), || {
            format!("({lo}, {hi}) must be an inclusive range with min ≤ max ≤ {MAX_PER_ENTRY}")
        });
        range(v, &field("distance_m"), self.distance_m, 0.0, 1e6, "metres");
        if let Some(s) = self.size_m {
            range(v, &field("size_m"), s, 0.0, 1e3, "metres");
        }
        if let Some(s) = self.speed_m_s {
            let ok = s.0.is_finite() && s.1.is_finite() && 0.0 <= s.0 && s.0 <= s.1 && s.1 <= 400.0;
            v.check(ok, &field("speed_m_s"), || {
                format!("({}, {}) must be m/s with 0 ≤ min ≤ max ≤ 400", s.0, s.1)
            });
        }
        if let Some(name) = &self.labelled_as {
            v.check(!name.trim().is_empty(), &field("labelled_as"), || {
                "class name is empty (leave it out for an unlabelled hard negative)".into()
            });
            if let Some(problem) = crate::text::name_problem(name) {
                v.push(&field("labelled_as"), problem);
            }
        }
        let bird_only = |v: &mut Validator, set: bool, name: &str| {
            v.check(!set || self.kind.is_bird(), &field(name), || {
                format!("only birds have {name}; {} does not", self.kind.name())
            });
        };
        bird_only(v, self.flap_hz.is_some(), "flap_hz");
        bird_only(v, self.glide_share != 0.0, "glide_share");
        bird_only(v, self.flock.is_some(), "flock");
        if let Some(f) = self.flap_hz {
            range(v, &field("flap_hz"), f, 0.0, 50.0, "beats per second");
        }
        v.check(
            (0.0..=1.0).contains(&self.glide_share),
            &field("glide_share"),
            || format!("{} must be a share within 0–1", self.glide_share),
        );
        if let Some(f) = &self.flock {
            v.check(
                f.spacing_wingspans.is_finite()
                    && f.spacing_wingspans > 0.0
                    && f.spacing_wingspans <= 1e3,
                &field("flock.spacing_wingspans"),
                || format!("{} must be > 0 and ≤ 1000 wingspans", f.spacing_wingspans),
            );
            v.check(
                f.jitter_wingspans.is_finite() && (0.0..=1e3).contains(&f.jitter_wingspans),
                &field("flock.jitter_wingspans"),
                || format!("{} must be within 0–1000 wingspans", f.jitter_wingspans),
            );
        }
    }
}

/// A (min, max) range with lower < min ≤ max ≤ upper, all finite.
fn range(v: &mut Validator, field: &str, r: (f64, f64), lower: f64, upper: f64, unit: &str) {
    let (lo, hi) = r;
    v.check(
        lo.is_finite() && hi.is_finite() && lo > lower && lo <= hi && hi <= upper,
        field,
        || format!("({lo}, {hi}) must be {unit} with {lower} < min ≤ max ≤ {upper}"),
    );
}

/// Check the whole list (called by `Preset::validate`).
pub(super) fn validate(confusers: &[Confuser], v: &mut Validator) {
    v.check(confusers.len() <= MAX_ENTRIES, "confusers", || {
        format!(
            "{} entries, more than the limit of {MAX_ENTRIES}",
            confusers.len()
        )
    });
    for (i, c) in confusers.iter().enumerate() {
        c.validate_into(i, v);
    }
}

/// The models the confusers need, in order: each entry's kind's
/// [`ConfuserKind::model_names`]. Slot `k` of this list is model
/// `preset.models.len() + k` of the pipeline's assets and a scene's poses.
pub fn model_slots(confusers: &[Confuser]) -> Vec<String> {
    confusers
        .iter()
        .flat_map(|c| c.kind.model_names())
        .collect()
}

/// The first slot of each entry in [`model_slots`].
pub fn first_slots(confusers: &[Confuser]) -> Vec<usize> {
    let mut next = 0;
    confusers
        .iter()
        .map(|c| {
            let first = next;
            next += c.kind.model_names().len();
            first
        })
        .collect()
}
