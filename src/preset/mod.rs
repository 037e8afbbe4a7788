//! The preset: every parameter of a dataset, as plain serde data (RON on disk).
//!
//! Field names are snake_case; docs/conventions.md maps each to the paper's
//! "3D Model Shots Generator" name (XCount → `x_count`, CameraZ → `camera.z`, …).
//! Every struct is `#[serde(default)]`, so old presets keep loading when fields
//! are added. [`Preset::validate`] returns every problem at once, each naming
//! the field, the value and the allowed range.

use std::fmt;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

pub mod appearance;
pub mod atmosphere;
pub mod backplate;
pub mod budget;
pub mod camera_model;
pub mod clutter;
pub mod confusers;
pub mod fields;
pub mod formation;
pub mod masks;
pub mod observer;
mod ron_error;
mod sky;
pub mod sweep;

pub use crate::text::{printable, short_number};
pub use ron_error::RonError;
pub use sky::{BUILTIN_SKIES, DEFAULT_HORIZON, DEFAULT_ZENITH, Sky, SkyImageSource};
mod validate;

pub use formation::{
    AbsoluteCamera, Formation, FormationShape, Motion, SequenceCamera, SequenceSpec,
};
pub use validate::{DeviceLimits, MAX_COUNT_SPAN, MAX_FRAME_MEMORY_BYTES, QUEUED_FRAMES};

use sweep::{SweepError, SweepRange};

/// The preset format version this build writes and reads.
pub const PRESET_VERSION: u32 = 1;
/// The most frames one preset may describe.
pub const MAX_FRAMES: u64 = 100_000_000;
/// The most drones one frame may hold.
pub const MAX_DRONES_PER_FRAME: u64 = 1_000_000;
/// The largest image side we accept before asking the adapter.
pub const MAX_IMAGE_SIDE: u32 = 16_384;
/// The largest preset file read.
pub const MAX_PRESET_BYTES: u64 = 16 << 20;
/// Randomized placement refuses presets whose spheres of minimum separation
/// would fill more than this share of the volume (random packing jams near 0.38).
pub const MAX_PACKING_FRACTION: f64 = 0.25;

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Preset {
    /// Preset format version ([`PRESET_VERSION`]).
    pub version: u32,
    pub name: String,
    /// Master seed; each frame derives its own from (seed, frame index).
    pub seed: u64,
    pub models: Vec<ModelSpec>,
    pub placement: Placement,
    pub attitude: AttitudeRanges,
    pub camera: CameraSweep,
    pub plane: PlaneSweep,
    /// Frames made per sweep combination (each with its own random draw).
    pub repeats: u32,
    pub sky: Sky,
    pub render: RenderSettings,
    pub labels: LabelSettings,
    pub output: OutputSettings,
    /// Sequence mode (issue 12): each sweep point becomes `steps + 1` frames of motion.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sequence: Option<SequenceSpec>,
    /// The camera model (issue 21): optics, sensor and image processing after rendering; off when `None`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub camera_model: Option<camera_model::CameraModel>,
    /// Haze with range on every drone (issue 21; docs/realism.md). Off when absent.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub atmosphere: Option<atmosphere::Atmosphere>,
    /// Drone materials drawn per drone (issue 21; docs/realism.md). Off when absent.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub appearance: Option<appearance::Appearance>,
    /// Near-field scenery that occludes drones (issue 22; docs/realism.md, "Clutter"). Off when absent.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub clutter: Option<clutter::Clutter>,
    /// Birds, aircraft and balloons around the swarm (issue 22; docs/negatives.md). Off when empty.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub confusers: Vec<confusers::Confuser>,
    /// Photographic backgrounds (issue 21; docs/realism.md). Off when absent.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub backplate: Option<backplate::Backplate>,
}

impl Default for Preset {
    fn default() -> Self {
        Self {
            version: PRESET_VERSION,
            name: "untitled".into(),
            seed: 1,
            models: vec![ModelSpec::default()],
            placement: Placement::default(),
            attitude: AttitudeRanges::default(),
            camera: CameraSweep::default(),
            plane: PlaneSweep::default(),
            repeats: 1,
            sky: Sky::default(),
            render: RenderSettings::default(),
            labels: LabelSettings::default(),
            output: OutputSettings::default(),
            sequence: None,
            camera_model: None,
            atmosphere: None,
            appearance: None,
            clutter: None,
            confusers: Vec::new(),
            backplate: None,
        }
    }
}

/// Where a model comes from.
#[derive(Clone, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum ModelSource {
    /// A model that ships with swarmshot (`assets/models/NAME.glb`), e.g. `Builtin("quad_x")`.
    Builtin(String),
    /// A user .gltf/.glb file; relative paths are relative to the preset file.
    File(PathBuf),
}

impl fmt::Display for ModelSource {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Builtin(name) => write!(f, "builtin:{name}"),
            Self::File(path) => write!(f, "{}", path.display()),
        }
    }
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ModelSpec {
    pub source: ModelSource,
    /// The model is scaled so that its largest span is this many metres.
    pub size_m: f64,
    /// Class name written into the labels.
    pub class: String,
    /// Let a .gltf's buffer and image URIs name files outside the model's
    /// folder (absolute paths, `file:` URIs, `..`, links out). Off: only
    /// files inside the folder are read. Devices and FIFOs stay refused.
    #[serde(skip_serializing_if = "is_false")]
    pub allow_uris_outside_folder: bool,
}

fn is_false(b: &bool) -> bool {
    !*b
}

impl Default for ModelSpec {
    fn default() -> Self {
        Self {
            source: ModelSource::Builtin("quad_x".into()),
            size_m: 0.35,
            class: "uav".into(),
            allow_uris_outside_folder: false,
        }
    }
}

/// The paper's two placement modes.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum Placement {
    /// A regular grid of XCount × YCount × ZCount drones, spaced LoadFactor × model size apart.
    Structured {
        x_count: u32,
        y_count: u32,
        z_count: u32,
        load_factor: f64,
    },
    /// Uniform random positions in the observation volume, at least `min_separation_m` apart.
    Randomized {
        /// Inclusive range of drones per frame.
        count: (u32, u32),
        /// How the count is drawn within `count` (uniform unless given).
        #[serde(default, skip_serializing_if = "CountDistribution::is_uniform")]
        count_distribution: CountDistribution,
        volume: Volume,
        /// Centre-to-centre distance no two drones come closer than.
        min_separation_m: f64,
    },
    /// A named formation (line abreast, column, echelon, wedge, ring, sphere
    /// shell, clusters) with its heading and jitter.
    Formation(Formation),
}

impl Default for Placement {
    fn default() -> Self {
        Self::Randomized {
            count: (1, 15),
            count_distribution: CountDistribution::Uniform,
            volume: Volume::default(),
            min_separation_m: 0.7,
        }
    }
}

/// How randomized placement draws a frame's drone count within its
/// inclusive `count: (min, max)`. Every distribution other than `Uniform` is
/// truncated to (min, max): it is the distribution conditioned on
/// min ≤ n ≤ max (never piled onto the ends), drawn by inverting its CDF
/// with one uniform number from the frame's own sampler.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum CountDistribution {
    /// Every count in (min, max) equally likely (one `random_range` draw; the default).
    #[default]
    Uniform,
    /// Listed counts with relative weights, e.g. `Table([(1, 3.0), (2, 2.0), (5, 1.0)])`;
    /// counts not listed are never drawn.
    Table(Vec<(u32, f64)>),
    /// P(n) ∝ λⁿ / n!, with λ = `mean` (the mean before truncation).
    Poisson { mean: f64 },
    /// P(n) ∝ (1 − p)^(n − min): each further drone with probability 1 − p.
    Geometric { p: f64 },
}

impl CountDistribution {
    /// Whether this is the default uniform draw.
    pub fn is_uniform(&self) -> bool {
        *self == Self::Uniform
    }
}

/// The observation volume W of randomized placement, centred at the origin.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum Volume {
    /// A box of the given size in metres (x, y, z).
    Box { size_m: (f64, f64, f64) },
    /// A cube whose volume gives the density ρ = N / V (drones per cubic metre).
    Density { per_m3: f64 },
    /// A box of fixed size whose density ρ is swept like CameraX/Y/Z: each
    /// frame holds N = round(ρ·V) drones (at least 1) and `count` is not used,
    /// so density and apparent size vary independently.
    DensitySweep {
        size_m: (f64, f64, f64),
        per_m3: SweepRange,
    },
}

impl Default for Volume {
    fn default() -> Self {
        Self::Box {
            size_m: (20.0, 10.0, 20.0),
        }
    }
}

/// Per-drone attitude ranges in degrees, each an inclusive (min, max).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct AttitudeRanges {
    pub roll_deg: (f64, f64),
    pub pitch_deg: (f64, f64),
    pub yaw_deg: (f64, f64),
}

impl Default for AttitudeRanges {
    fn default() -> Self {
        Self {
            roll_deg: (-15.0, 15.0),
            pitch_deg: (-15.0, 15.0),
            yaw_deg: (-180.0, 180.0),
        }
    }
}

/// CameraX/Y/Z sweeps (relative units, see docs/conventions.md) and the lens.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CameraSweep {
    /// CameraX: sideways offset in units of the swarm radius R.
    pub x: SweepRange,
    /// CameraY: vertical offset in units of R.
    pub y: SweepRange,
    /// CameraZ: distance in units of the distance that just fits the swarm in view.
    pub z: SweepRange,
    /// Vertical field of view.
    pub fov_y_deg: f64,
    /// An absolute pose in metres; when set, CameraX/Y/Z are not used.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub absolute: Option<AbsoluteCamera>,
    /// A ground observer's camera looking up at the swarm (docs/realism.md); when set, CameraX/Y/Z are not used.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub observer: Option<observer::ObserverCamera>,
}

impl Default for CameraSweep {
    fn default() -> Self {
        Self {
            x: SweepRange::fixed(0.0),
            y: SweepRange::fixed(0.0),
            z: SweepRange::fixed(1.0),
            fov_y_deg: 50.0,
            absolute: None,
            observer: None,
        }
    }
}

/// PlaneRX/RY/RZ: rotation of the whole swarm about the volume's centre, degrees.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PlaneSweep {
    pub rx: SweepRange,
    pub ry: SweepRange,
    pub rz: SweepRange,
}

/// The paper's seven Unity skyboxes, as procedural environments.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum EnvironmentName {
    Daytime,
    Sunset,
    BeautifulPasture,
    SnowyBridge,
    SmallHarbour,
    Tellsplatte,
    CountryRoad,
}

impl EnvironmentName {
    pub const ALL: [Self; 7] = [
        Self::Daytime,
        Self::Sunset,
        Self::BeautifulPasture,
        Self::SnowyBridge,
        Self::SmallHarbour,
        Self::Tellsplatte,
        Self::CountryRoad,
    ];

    pub fn as_str(self) -> &'static str {
        match self {
            Self::Daytime => "Daytime",
            Self::Sunset => "Sunset",
            Self::BeautifulPasture => "BeautifulPasture",
            Self::SnowyBridge => "SnowyBridge",
            Self::SmallHarbour => "SmallHarbour",
            Self::Tellsplatte => "Tellsplatte",
            Self::CountryRoad => "CountryRoad",
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum Resolution {
    /// 1920 × 1080
    FullHd,
    /// 2560 × 1440
    Qhd,
    /// 4096 × 2160
    Uhd4k,
    Custom {
        width: u32,
        height: u32,
    },
}

impl Resolution {
    pub fn size(self) -> (u32, u32) {
        match self {
            Self::FullHd => (1920, 1080),
            Self::Qhd => (2560, 1440),
            Self::Uhd4k => (4096, 2160),
            Self::Custom { width, height } => (width, height),
        }
    }
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RenderSettings {
    pub resolution: Resolution,
    /// Multisample anti-aliasing: 1 (off) or 4.
    pub msaa: u32,
    /// Level of detail: a drone is drawn with the coarsest simplified mesh
    /// whose silhouette lies within this many pixels of the full mesh's
    /// (0: every drone at full detail). Labels' amodal boxes always come
    /// from the full mesh; visible boxes follow the pixels drawn.
    pub lod_error_px: f64,
}

/// The silhouette error a level of detail may add, by default (pixels).
pub const DEFAULT_LOD_ERROR_PX: f64 = 0.5;

impl Default for RenderSettings {
    fn default() -> Self {
        Self {
            resolution: Resolution::FullHd,
            msaa: 4,
            lod_error_px: DEFAULT_LOD_ERROR_PX,
        }
    }
}

/// How a drone's 2D box is computed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum BoxMethod {
    /// Min/max of the drone's visible pixels in an instance-id pass: pixel-exact,
    /// occlusion-aware. The default for training.
    #[default]
    Visible,
    /// Min/max of the projected convex hull: the tight amodal box (occluded parts included).
    Amodal,
    /// The paper's method: project the 8 corners of the world axis-aligned box.
    PaperAabb,
}

/// What happens to a drone that fails a filter (too small, too occluded, or
/// not visible at all although it projects into the image).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum FilteredDrones {
    /// Written nowhere.
    #[default]
    Drop,
    /// Kept in COCO as `iscrowd: 1` (trainers ignore the region); left out of YOLO files.
    Crowd,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LabelSettings {
    pub box_method: BoxMethod,
    /// Boxes narrower or shorter than this (after clipping to the image) are filtered.
    pub min_box_px: f64,
    /// Drones with fewer visible pixels are filtered (0: off).
    pub min_visible_pixels: u64,
    /// Drones with a smaller visible fraction (visible / unoccluded pixels) are filtered (0: off).
    pub min_visible_fraction: f64,
    pub filtered: FilteredDrones,
    /// Resolution factor of the instance-id passes: 1 (pixel-exact at the
    /// output size), 2 or 4 (supersampled, sub-pixel visible boxes; costs scale²).
    pub id_scale: u32,
    /// A frame whose geometry gives fewer kept boxes than this is drawn again
    /// (its placement re-seeded from (seed, index, attempt); 0: off). See
    /// docs/conventions.md, "Randomness".
    #[serde(skip_serializing_if = "is_zero")]
    pub min_labelled: u32,
}

fn is_zero(n: &u32) -> bool {
    *n == 0
}

impl Default for LabelSettings {
    fn default() -> Self {
        Self {
            box_method: BoxMethod::Visible,
            min_box_px: 2.0,
            min_visible_pixels: 0,
            min_visible_fraction: 0.0,
            filtered: FilteredDrones::Drop,
            id_scale: 1,
            min_labelled: 0,
        }
    }
}

impl LabelSettings {
    /// Whether labelling needs the instance-id pass (visible boxes or visibility filters).
    pub fn needs_id_pass(&self) -> bool {
        self.box_method == BoxMethod::Visible
            || self.min_visible_pixels > 0
            || self.min_visible_fraction > 0.0
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum ImageFormat {
    Jpeg { quality: u8 },
    Png,
}

impl ImageFormat {
    pub fn extension(self) -> &'static str {
        match self {
            Self::Jpeg { .. } => "jpg",
            Self::Png => "png",
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum LabelFormat {
    /// Ultralytics YOLO: images/, labels/, data.yaml.
    Yolo,
    /// COCO: annotations/instances_{split}.json.
    Coco,
}

/// Shares of frames that go to each split; they must sum to 1.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Split {
    pub train: f64,
    pub val: f64,
    pub test: f64,
    /// What is kept together in one split (see `scene::split`); `Frame`
    /// (the default) is left out of the locked preset, so it keeps its bytes.
    #[serde(skip_serializing_if = "SplitBy::is_frame")]
    pub by: SplitBy,
}

impl Default for Split {
    fn default() -> Self {
        Self {
            train: 0.7,
            val: 0.1,
            test: 0.2,
            by: SplitBy::Frame,
        }
    }
}

/// The groups a split keeps whole, so that no val or test frame shares its
/// group with a train frame (docs/conventions.md, "Splits").
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum SplitBy {
    /// Each frame (each sequence, in sequence mode) on its own: exact shares per 100.
    #[default]
    Frame,
    /// Frames with the same camera sweep values (CameraX, CameraY, CameraZ).
    CameraPose,
    /// Frames with the same environment (the `Random` sky's choice).
    Environment,
    /// Frames with the same sweep point: every swept value alike, only `repeat` differs.
    SweepPoint,
}

impl SplitBy {
    /// The default, per-frame split (left out of the locked preset).
    pub fn is_frame(&self) -> bool {
        *self == Self::Frame
    }
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct OutputSettings {
    pub image_format: ImageFormat,
    pub label_formats: Vec<LabelFormat>,
    pub split: Split,
    /// Masks and maps besides the boxes (all off: left out of the lock).
    #[serde(skip_serializing_if = "masks::MaskOutputs::is_off")]
    pub masks: masks::MaskOutputs,
}

impl Default for OutputSettings {
    fn default() -> Self {
        Self {
            image_format: ImageFormat::Jpeg { quality: 85 },
            label_formats: vec![LabelFormat::Yolo, LabelFormat::Coco],
            split: Split::default(),
            masks: masks::MaskOutputs::default(),
        }
    }
}

/// One invalid value: the field's path in the preset and what is wrong with it.
#[derive(Clone, Debug, PartialEq)]
pub struct FieldError {
    /// Dotted path, e.g. `camera.z.step`.
    pub field: String,
    pub message: String,
}

impl fmt::Display for FieldError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.field, self.message)
    }
}

#[derive(Debug, thiserror::Error)]
pub enum PresetError {
    #[error("cannot read preset {}: {source}", path.display())]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("preset {}: {source}", path.display())]
    Parse { path: PathBuf, source: RonError },
    #[error("preset {} is invalid:\n{}", path.display(), list(errors))]
    Invalid {
        path: PathBuf,
        errors: Vec<FieldError>,
    },
    #[error("preset {}: version {found} is newer than this swarmshot understands ({PRESET_VERSION})", path.display())]
    Version { path: PathBuf, found: u32 },
}

fn list(errors: &[FieldError]) -> String {
    errors
        .iter()
        .map(|e| format!("  - {e}"))
        .collect::<Vec<_>>()
        .join("\n")
}

impl Preset {
    /// Parse RON text (no validation).
    ///
    /// Unknown fields and variants are refused, named with their path and the
    /// nearest known name ("unknown field `fovy_deg` in `camera`; did you mean
    /// `fov_y_deg`?").
    pub fn from_ron(text: &str) -> Result<Self, RonError> {
        // A byte-order mark (editors on Windows write one) is not RON.
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        let options = ron::Options::default()
            .with_default_extension(ron::extensions::Extensions::IMPLICIT_SOME);
        ron_error::from_str(text, &options)
    }

    /// Pretty RON text of this preset.
    pub fn to_ron(&self) -> String {
        let config = ron::ser::PrettyConfig::new()
            .depth_limit(4)
            .struct_names(false);
        // Serialising plain data to a String cannot fail; fall back to compact form if it did.
        ron::ser::to_string_pretty(self, config)
            .unwrap_or_else(|e| format!("// serialisation failed: {e}"))
    }

    /// Read, parse and validate a preset file.
    pub fn load(path: &Path) -> Result<Self, PresetError> {
        let io = |source| PresetError::Io {
            path: path.to_owned(),
            source,
        };
        let bytes = crate::input::read_input_file(path, MAX_PRESET_BYTES).map_err(io)?;
        let text = String::from_utf8(bytes).map_err(|e| {
            io(std::io::Error::new(
                std::io::ErrorKind::InvalidData,
                format!("not UTF-8 text ({e})"),
            ))
        })?;
        let preset = Self::from_ron(&text).map_err(|source| PresetError::Parse {
            path: path.to_owned(),
            source,
        })?;
        if preset.version > PRESET_VERSION {
            return Err(PresetError::Version {
                path: path.to_owned(),
                found: preset.version,
            });
        }
        preset.validate().map_err(|errors| PresetError::Invalid {
            path: path.to_owned(),
            errors,
        })?;
        Ok(preset)
    }

    /// Read, parse and validate a preset file, with its model and sky paths
    /// resolved against the file's folder: what every command runs.
    pub fn open(path: &Path) -> Result<Self, PresetError> {
        let mut preset = Self::load(path)?;
        preset.resolve_paths(path.parent().unwrap_or(Path::new(".")));
        Ok(preset)
    }

    /// Model files resolved against the directory of the preset file.
    pub fn resolve_paths(&mut self, base_dir: &Path) {
        self.sky.resolve_paths(base_dir);
        if let Some(b) = &mut self.backplate
            && b.folder.is_relative()
        {
            b.folder = base_dir.join(&b.folder);
        }
        for model in &mut self.models {
            if let ModelSource::File(path) = &mut model.source
                && path.is_relative()
            {
                *path = base_dir.join(&*path);
            }
        }
    }

    /// Image size in pixels.
    pub fn image_size(&self) -> (u32, u32) {
        self.render.resolution.size()
    }

    /// The sweep axes in nesting order (outermost first): CameraX, CameraY,
    /// CameraZ, PlaneRX, PlaneRY, PlaneRZ, then the density ρ of a
    /// `DensitySweep` volume (one value, unused, otherwise).
    pub fn sweep_axes(&self) -> [(&'static str, SweepRange); 7] {
        [
            ("camera.x", self.camera.x),
            ("camera.y", self.camera.y),
            ("camera.z", self.camera.z),
            ("plane.rx", self.plane.rx),
            ("plane.ry", self.plane.ry),
            ("plane.rz", self.plane.rz),
            (
                "placement.volume.per_m3",
                self.density_sweep().unwrap_or(SweepRange::fixed(0.0)),
            ),
        ]
    }

    /// The density sweep of a `DensitySweep` volume.
    pub fn density_sweep(&self) -> Option<SweepRange> {
        match &self.placement {
            Placement::Randomized {
                volume: Volume::DensitySweep { per_m3, .. },
                ..
            } => Some(*per_m3),
            _ => None,
        }
    }

    /// Radices of the frame index: the seven sweep axes, the repeat count,
    /// then the step t of a sequence (T + 1 frames; 1 without sequences).
    pub fn frame_radices(&self) -> Result<[u64; 9], SweepError> {
        let mut r = [1u64; 9];
        for (slot, (_, range)) in r.iter_mut().zip(self.sweep_axes()) {
            *slot = range.count()?;
        }
        r[7] = u64::from(self.repeats.max(1));
        r[8] = self.sequence_len();
        Ok(r)
    }

    /// Frames per sequence: T + 1 in sequence mode, else 1.
    pub fn sequence_len(&self) -> u64 {
        self.sequence
            .as_ref()
            .map_or(1, |s| u64::from(s.steps.max(1)) + 1)
    }

    /// Total number of frames (0 if a sweep is invalid).
    pub fn frame_count(&self) -> u64 {
        self.frame_radices()
            .map(|r| r.iter().fold(1u64, |acc, &n| acc.saturating_mul(n)))
            .unwrap_or(0)
    }

    /// The largest real size among the models, metres.
    pub fn max_model_size_m(&self) -> f64 {
        self.models.iter().map(|m| m.size_m).fold(0.0, f64::max)
    }

    /// Share of the volume taken by `n` balls of diameter `separation`, for the
    /// largest count the preset asks for.
    fn packing_fraction(n: u32, volume: &Volume, separation: f64) -> f64 {
        let ball = std::f64::consts::PI / 6.0 * separation.powi(3);
        match volume {
            Volume::Box { size_m: (x, y, z) } => {
                let v = x * y * z;
                if n <= 1 {
                    0.0
                } else if v <= 0.0 {
                    if separation > 0.0 { f64::INFINITY } else { 0.0 }
                } else {
                    f64::from(n) * ball / v
                }
            }
            Volume::Density { per_m3 } => per_m3 * ball,
            Volume::DensitySweep { per_m3, .. } => per_m3.start.max(per_m3.end) * ball,
        }
    }
}

#[derive(Default)]
pub(crate) struct Validator {
    errors: Vec<FieldError>,
}

impl Validator {
    fn push(&mut self, field: &str, message: String) {
        self.errors.push(FieldError {
            field: field.to_string(),
            message,
        });
    }

    fn check(&mut self, ok: bool, field: &str, message: impl FnOnce() -> String) {
        if !ok {
            self.push(field, message());
        }
    }

    fn positive(&mut self, field: &str, value: f64, unit: &str) {
        self.check(value.is_finite() && value > 0.0, field, || {
            format!("{value} must be a finite number > 0 ({unit})")
        });
    }
}

impl Preset {
    /// Class names in order of first appearance among the models, and each model's class index.
    pub fn classes(&self) -> (Vec<String>, Vec<usize>) {
        let mut names: Vec<String> = Vec::new();
        let of_model = self
            .models
            .iter()
            .map(|m| match names.iter().position(|n| *n == m.class) {
                Some(i) => i,
                None => {
                    names.push(m.class.clone());
                    names.len() - 1
                }
            })
            .collect();
        if self.confusers.is_empty() {
            return (names, of_model);
        }
        self.with_confuser_classes(names, of_model)
    }

    /// [`Preset::classes`] with the labelled confusers' classes appended
    /// (in entry order, each name once) and each confuser model slot's class;
    /// a hard negative's slot gets the out-of-range index `names.len()`.
    fn with_confuser_classes(
        &self,
        mut names: Vec<String>,
        mut of_model: Vec<usize>,
    ) -> (Vec<String>, Vec<usize>) {
        let mut of_entry = Vec::with_capacity(self.confusers.len());
        for c in &self.confusers {
            of_entry.push(c.labelled_as.as_ref().map(|class| {
                names.iter().position(|n| n == class).unwrap_or_else(|| {
                    names.push(class.clone());
                    names.len() - 1
                })
            }));
        }
        for (c, class) in self.confusers.iter().zip(of_entry) {
            let slots = c.kind.model_names().len();
            of_model.extend(std::iter::repeat_n(class.unwrap_or(names.len()), slots));
        }
        (names, of_model)
    }
}
