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

use crate::environment::EnvironmentName;
use crate::sweep::{SweepError, SweepRange};

/// The preset format version this build writes and reads.
pub const PRESET_VERSION: u32 = 1;
/// The most frames one preset may describe.
pub const MAX_FRAMES: u64 = 100_000_000;
/// The most drones one frame may hold.
pub const MAX_DRONES_PER_FRAME: u64 = 1_000_000;
/// The largest image side we accept before asking the adapter.
pub const MAX_IMAGE_SIDE: u32 = 16_384;
/// Randomized placement refuses presets whose spheres of minimum separation
/// would fill more than this share of the volume (random packing jams near 0.38).
pub const MAX_PACKING_FRACTION: f64 = 0.25;

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
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
        }
    }
}

/// Where a model comes from.
#[derive(Clone, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
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
#[serde(default)]
pub struct ModelSpec {
    pub source: ModelSource,
    /// The model is scaled so that its largest span is this many metres.
    pub size_m: f64,
    /// Class name written into the labels.
    pub class: String,
}

impl Default for ModelSpec {
    fn default() -> Self {
        Self {
            source: ModelSource::Builtin("quad_x".into()),
            size_m: 0.35,
            class: "uav".into(),
        }
    }
}

/// The paper's two placement modes.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
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
        volume: Volume,
        /// Centre-to-centre distance no two drones come closer than.
        min_separation_m: f64,
    },
}

impl Default for Placement {
    fn default() -> Self {
        Self::Randomized {
            count: (1, 15),
            volume: Volume::default(),
            min_separation_m: 0.7,
        }
    }
}

/// The observation volume W of randomized placement, centred at the origin.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum Volume {
    /// A box of the given size in metres (x, y, z).
    Box { size_m: (f64, f64, f64) },
    /// A cube whose volume gives the density ρ = N / V (drones per cubic metre).
    Density { per_m3: f64 },
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
#[serde(default)]
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
#[serde(default)]
pub struct CameraSweep {
    /// CameraX: sideways offset in units of the swarm radius R.
    pub x: SweepRange,
    /// CameraY: vertical offset in units of R.
    pub y: SweepRange,
    /// CameraZ: distance in units of the distance that just fits the swarm in view.
    pub z: SweepRange,
    /// Vertical field of view.
    pub fov_y_deg: f64,
}

impl Default for CameraSweep {
    fn default() -> Self {
        Self {
            x: SweepRange::fixed(0.0),
            y: SweepRange::fixed(0.0),
            z: SweepRange::fixed(1.0),
            fov_y_deg: 50.0,
        }
    }
}

/// PlaneRX/RY/RZ: rotation of the whole swarm about the volume's centre, degrees.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct PlaneSweep {
    pub rx: SweepRange,
    pub ry: SweepRange,
    pub rz: SweepRange,
}

/// The background environment.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum Sky {
    /// A procedural gradient sky with a sun disc; the sun also lights the drones.
    Gradient {
        sun_elevation_deg: f64,
        sun_azimuth_deg: f64,
        /// Linear RGB at the zenith and at the horizon.
        zenith: (f32, f32, f32),
        horizon: (f32, f32, f32),
    },
    /// One of the seven named procedural environments (`EnvironmentName`):
    /// a Preetham sky, clouds, ground and horizon. Unset fields take the
    /// environment's own values.
    Procedural {
        environment: EnvironmentName,
        #[serde(default)]
        sun_elevation_deg: Option<f64>,
        #[serde(default)]
        sun_azimuth_deg: Option<f64>,
        /// Atmospheric turbidity, [1.7, 10] (2 = very clear, 6+ = hazy).
        #[serde(default)]
        turbidity: Option<f64>,
        /// Fraction of the sky under cloud, [0, 1].
        #[serde(default)]
        cloud_cover: Option<f64>,
        /// Seed of the cloud/ground pattern; unset: a new pattern every frame.
        #[serde(default)]
        seed: Option<u32>,
        /// Exposure compensation in stops.
        #[serde(default)]
        exposure_ev: f64,
    },
    /// An equirectangular image (.hdr, .exr, .png, .jpg) or six cubemap faces.
    /// The sun that lights the drones is given in the image's frame (azimuth
    /// 0 = the image's centre column) and turns with `rotation_deg`.
    Image {
        source: SkyImageSource,
        /// Exposure in stops (HDR values are then tone mapped).
        #[serde(default)]
        exposure_ev: f64,
        /// Turns the image about the vertical axis (same sense as the sun azimuth).
        #[serde(default)]
        rotation_deg: f64,
        #[serde(default = "default_image_sun_elevation")]
        sun_elevation_deg: f64,
        #[serde(default)]
        sun_azimuth_deg: f64,
    },
    /// Per frame: pick one of `choices`, add a random azimuth offset, and
    /// replace the sun elevation and cloud cover by draws from the ranges given.
    Random {
        choices: Vec<Sky>,
        #[serde(default)]
        azimuth_offset_deg: (f64, f64),
        #[serde(default)]
        sun_elevation_deg: Option<(f64, f64)>,
        #[serde(default)]
        cloud_cover: Option<(f64, f64)>,
    },
}

fn default_image_sun_elevation() -> f64 {
    45.0
}

/// Where an image sky's pixels come from; relative paths are relative to the preset file.
#[derive(Clone, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum SkyImageSource {
    /// One equirectangular (2:1 latitude/longitude) image, top row = zenith.
    Equirect(PathBuf),
    /// Six square faces in the OpenGL cubemap convention (+X, −X, +Y up, −Y, +Z, −Z).
    Cubemap {
        px: PathBuf,
        nx: PathBuf,
        py: PathBuf,
        ny: PathBuf,
        pz: PathBuf,
        nz: PathBuf,
    },
}

impl SkyImageSource {
    fn paths_mut(&mut self) -> Vec<&mut PathBuf> {
        match self {
            Self::Equirect(p) => vec![p],
            Self::Cubemap {
                px,
                nx,
                py,
                ny,
                pz,
                nz,
            } => vec![px, nx, py, ny, pz, nz],
        }
    }
}

impl Sky {
    /// A named procedural environment with all its defaults.
    pub fn procedural(environment: EnvironmentName) -> Self {
        Self::Procedural {
            environment,
            sun_elevation_deg: None,
            sun_azimuth_deg: None,
            turbidity: None,
            cloud_cover: None,
            seed: None,
            exposure_ev: 0.0,
        }
    }

    /// Every image this sky references, each once, in order of first appearance.
    pub fn image_sources(&self) -> Vec<&SkyImageSource> {
        let mut out: Vec<&SkyImageSource> = Vec::new();
        let mut visit = vec![self];
        while let Some(sky) = visit.pop() {
            match sky {
                Sky::Image { source, .. } if !out.contains(&source) => out.push(source),
                Sky::Random { choices, .. } => visit.extend(choices.iter().rev()),
                _ => {}
            }
        }
        out
    }

    fn resolve_paths(&mut self, base_dir: &Path) {
        match self {
            Sky::Image { source, .. } => {
                for path in source.paths_mut() {
                    if path.is_relative() {
                        *path = base_dir.join(&*path);
                    }
                }
            }
            Sky::Random { choices, .. } => {
                choices.iter_mut().for_each(|c| c.resolve_paths(base_dir))
            }
            _ => {}
        }
    }

    /// Push every invalid value of this sky, fields named under `field`.
    fn validate_into(&self, v: &mut Validator, field: &str, nested: bool) {
        let range = |v: &mut Validator, name: &str, value: f64, lo: f64, hi: f64| {
            v.check(
                value.is_finite() && (lo..=hi).contains(&value),
                &format!("{field}.{name}"),
                || format!("{value} is out of range [{lo}, {hi}]"),
            );
        };
        match self {
            Sky::Gradient {
                sun_elevation_deg,
                sun_azimuth_deg,
                zenith,
                horizon,
            } => {
                range(v, "sun_elevation_deg", *sun_elevation_deg, -90.0, 90.0);
                v.check(
                    sun_azimuth_deg.is_finite(),
                    &format!("{field}.sun_azimuth_deg"),
                    || format!("{sun_azimuth_deg} must be finite"),
                );
                for (name, (r, g, b)) in [("zenith", zenith), ("horizon", horizon)] {
                    v.check(
                        [r, g, b]
                            .iter()
                            .all(|c| c.is_finite() && **c >= 0.0 && **c <= 100.0),
                        &format!("{field}.{name}"),
                        || format!("({r}, {g}, {b}) must be linear RGB in [0, 100]"),
                    );
                }
            }
            Sky::Procedural {
                sun_elevation_deg,
                sun_azimuth_deg,
                turbidity,
                cloud_cover,
                exposure_ev,
                ..
            } => {
                if let Some(e) = sun_elevation_deg {
                    range(v, "sun_elevation_deg", *e, -10.0, 90.0);
                }
                if let Some(a) = sun_azimuth_deg {
                    range(v, "sun_azimuth_deg", *a, -3600.0, 3600.0);
                }
                if let Some(t) = turbidity {
                    range(v, "turbidity", *t, 1.7, 10.0);
                }
                if let Some(c) = cloud_cover {
                    range(v, "cloud_cover", *c, 0.0, 1.0);
                }
                range(v, "exposure_ev", *exposure_ev, -10.0, 10.0);
            }
            Sky::Image {
                source,
                exposure_ev,
                rotation_deg,
                sun_elevation_deg,
                sun_azimuth_deg,
            } => {
                range(v, "exposure_ev", *exposure_ev, -20.0, 20.0);
                range(v, "rotation_deg", *rotation_deg, -3600.0, 3600.0);
                range(v, "sun_elevation_deg", *sun_elevation_deg, -90.0, 90.0);
                range(v, "sun_azimuth_deg", *sun_azimuth_deg, -3600.0, 3600.0);
                let mut source = source.clone();
                for path in source.paths_mut() {
                    v.check(
                        !path.as_os_str().is_empty(),
                        &format!("{field}.source"),
                        || "image path is empty".into(),
                    );
                }
            }
            Sky::Random {
                choices,
                azimuth_offset_deg,
                sun_elevation_deg,
                cloud_cover,
            } => {
                if nested {
                    v.push(
                        field,
                        "a Random sky cannot be one of another Random sky's choices".into(),
                    );
                }
                if choices.is_empty() {
                    v.push(
                        &format!("{field}.choices"),
                        "at least one choice is needed".into(),
                    );
                }
                let pair = |v: &mut Validator, name: &str, (a, b): (f64, f64), lo: f64, hi: f64| {
                    v.check(
                        a.is_finite() && b.is_finite() && lo <= a && a <= b && b <= hi,
                        &format!("{field}.{name}"),
                        || format!("({a}, {b}) must be an ordered (min, max) within [{lo}, {hi}]"),
                    );
                };
                pair(
                    v,
                    "azimuth_offset_deg",
                    *azimuth_offset_deg,
                    -3600.0,
                    3600.0,
                );
                if let Some(r) = sun_elevation_deg {
                    pair(v, "sun_elevation_deg", *r, -10.0, 90.0);
                }
                if let Some(r) = cloud_cover {
                    pair(v, "cloud_cover", *r, 0.0, 1.0);
                }
                for (i, c) in choices.iter().enumerate() {
                    c.validate_into(v, &format!("{field}.choices[{i}]"), true);
                }
            }
        }
    }
}

impl Default for Sky {
    fn default() -> Self {
        Self::Gradient {
            sun_elevation_deg: 40.0,
            sun_azimuth_deg: 135.0,
            zenith: (0.10, 0.25, 0.60),
            horizon: (0.62, 0.74, 0.88),
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
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
#[serde(default)]
pub struct RenderSettings {
    pub resolution: Resolution,
    /// Multisample anti-aliasing: 1 (off) or 4.
    pub msaa: u32,
}

impl Default for RenderSettings {
    fn default() -> Self {
        Self {
            resolution: Resolution::FullHd,
            msaa: 4,
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
#[serde(default)]
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
#[serde(default)]
pub struct Split {
    pub train: f64,
    pub val: f64,
    pub test: f64,
}

impl Default for Split {
    fn default() -> Self {
        Self {
            train: 0.7,
            val: 0.1,
            test: 0.2,
        }
    }
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct OutputSettings {
    pub image_format: ImageFormat,
    pub label_formats: Vec<LabelFormat>,
    pub split: Split,
}

impl Default for OutputSettings {
    fn default() -> Self {
        Self {
            image_format: ImageFormat::Jpeg { quality: 85 },
            label_formats: vec![LabelFormat::Yolo, LabelFormat::Coco],
            split: Split::default(),
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
    #[error("preset {}: {message}", path.display())]
    Parse { path: PathBuf, message: String },
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
    pub fn from_ron(text: &str) -> Result<Self, String> {
        ron::Options::default()
            .with_default_extension(ron::extensions::Extensions::IMPLICIT_SOME)
            .from_str(text)
            .map_err(|e| e.to_string())
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
        let text = std::fs::read_to_string(path).map_err(|source| PresetError::Io {
            path: path.to_owned(),
            source,
        })?;
        let preset = Self::from_ron(&text).map_err(|message| PresetError::Parse {
            path: path.to_owned(),
            message,
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

    /// Model files resolved against the directory of the preset file.
    pub fn resolve_paths(&mut self, base_dir: &Path) {
        self.sky.resolve_paths(base_dir);
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
    /// CameraZ, PlaneRX, PlaneRY, PlaneRZ.
    pub fn sweep_axes(&self) -> [(&'static str, SweepRange); 6] {
        [
            ("camera.x", self.camera.x),
            ("camera.y", self.camera.y),
            ("camera.z", self.camera.z),
            ("plane.rx", self.plane.rx),
            ("plane.ry", self.plane.ry),
            ("plane.rz", self.plane.rz),
        ]
    }

    /// Radices of the frame index: the six sweep axes, then the repeat count.
    pub fn frame_radices(&self) -> Result<[u64; 7], SweepError> {
        let mut r = [1u64; 7];
        for (slot, (_, range)) in r.iter_mut().zip(self.sweep_axes()) {
            *slot = range.count()?;
        }
        r[6] = u64::from(self.repeats.max(1));
        Ok(r)
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

    /// Every invalid value, each naming its field.
    pub fn validate(&self) -> Result<(), Vec<FieldError>> {
        let mut v = Validator::default();
        v.check(self.version >= 1, "version", || {
            format!(
                "{} is not a preset version (use {PRESET_VERSION})",
                self.version
            )
        });
        if self.models.is_empty() {
            v.push("models", "at least one model is needed".into());
        }
        for (i, m) in self.models.iter().enumerate() {
            v.positive(&format!("models[{i}].size_m"), m.size_m, "metres");
            v.check(m.size_m <= 1000.0, &format!("models[{i}].size_m"), || {
                format!("{} m is larger than the 1000 m limit", m.size_m)
            });
            v.check(
                !m.class.trim().is_empty(),
                &format!("models[{i}].class"),
                || "class name is empty".into(),
            );
            if let ModelSource::Builtin(name) = &m.source {
                v.check(
                    crate::assets::builtin_glb(name).is_some(),
                    &format!("models[{i}].source"),
                    || {
                        format!(
                            "no built-in model \"{name}\" (built-ins: {})",
                            crate::assets::BUILTIN_NAMES.join(", ")
                        )
                    },
                );
            }
        }
        match &self.placement {
            Placement::Structured {
                x_count,
                y_count,
                z_count,
                load_factor,
            } => {
                for (name, c) in [
                    ("x_count", x_count),
                    ("y_count", y_count),
                    ("z_count", z_count),
                ] {
                    v.check(*c >= 1, &format!("placement.{name}"), || {
                        format!("{c} drones along an axis; must be at least 1")
                    });
                }
                let total = u64::from(*x_count) * u64::from(*y_count) * u64::from(*z_count);
                v.check(total <= MAX_DRONES_PER_FRAME, "placement", || {
                    format!("{x_count}×{y_count}×{z_count} = {total} drones per frame, more than the limit of {MAX_DRONES_PER_FRAME}")
                });
                v.check(load_factor.is_finite() && *load_factor >= 1.0 && *load_factor <= 1e6, "placement.load_factor", || {
                    format!("{load_factor} is out of range [1, 1e6]: below 1 the grid spacing is smaller than a drone and drones overlap")
                });
            }
            Placement::Randomized {
                count: (lo, hi),
                volume,
                min_separation_m,
            } => {
                v.check(*lo >= 1, "placement.count", || {
                    format!("minimum count {lo} must be at least 1")
                });
                v.check(hi >= lo, "placement.count", || {
                    format!("({lo}, {hi}): maximum must be ≥ minimum")
                });
                v.check(
                    u64::from(*hi) <= MAX_DRONES_PER_FRAME,
                    "placement.count",
                    || format!("{hi} drones is more than the limit of {MAX_DRONES_PER_FRAME}"),
                );
                v.check(
                    min_separation_m.is_finite() && *min_separation_m >= 0.0,
                    "placement.min_separation_m",
                    || format!("{min_separation_m} must be a finite distance ≥ 0 m"),
                );
                match volume {
                    Volume::Box { size_m: (x, y, z) } => {
                        for (axis, s) in [("x", x), ("y", y), ("z", z)] {
                            v.check(
                                s.is_finite() && *s >= 0.0 && *s <= 1e6,
                                &format!("placement.volume.size_m.{axis}"),
                                || format!("{s} is out of range [0, 1e6] metres"),
                            );
                        }
                    }
                    Volume::Density { per_m3 } => {
                        v.positive("placement.volume.per_m3", *per_m3, "drones per m³")
                    }
                }
                if v.errors.is_empty() {
                    let fraction = Self::packing_fraction(*hi, volume, *min_separation_m);
                    v.check(fraction <= MAX_PACKING_FRACTION, "placement.min_separation_m", || {
                        format!(
                            "{hi} drones {min_separation_m} m apart fill {:.0}% of the volume; at most {:.0}% can be placed at random (enlarge the volume or lower the count or separation)",
                            fraction * 100.0,
                            MAX_PACKING_FRACTION * 100.0
                        )
                    });
                }
            }
        }
        for (name, (lo, hi)) in [
            ("roll_deg", self.attitude.roll_deg),
            ("pitch_deg", self.attitude.pitch_deg),
            ("yaw_deg", self.attitude.yaw_deg),
        ] {
            v.check(
                lo.is_finite() && hi.is_finite() && lo <= hi && lo >= -360.0 && hi <= 360.0,
                &format!("attitude.{name}"),
                || format!("({lo}, {hi}) must be finite degrees with min ≤ max within [-360, 360]"),
            );
        }
        for (name, range) in self.sweep_axes() {
            if let Err(e) = range.count() {
                let field = match e {
                    SweepError::NotFinite { .. } | SweepError::TooMany { .. } => name.to_string(),
                    SweepError::ZeroStep { .. } | SweepError::WrongSign { .. } => {
                        format!("{name}.step")
                    }
                };
                v.push(&field, e.to_string());
            }
        }
        let has_zero = |r: SweepRange| {
            let Ok(n) = r.count() else { return false };
            if r.start == r.end || r.step == 0.0 {
                return r.start == 0.0;
            }
            let i = (-r.start / r.step).round();
            i >= 0.0 && (i as u64) < n && r.value(i as u64) == 0.0
        };
        if has_zero(self.camera.x) && has_zero(self.camera.y) && has_zero(self.camera.z) {
            v.push(
                "camera.z",
                "CameraX, CameraY and CameraZ are all 0 in some frame: the camera would sit at the centre it looks at".into(),
            );
        }
        v.check(
            self.camera.fov_y_deg.is_finite()
                && self.camera.fov_y_deg > 0.5
                && self.camera.fov_y_deg < 170.0,
            "camera.fov_y_deg",
            || {
                format!(
                    "{} is out of range (0.5, 170) degrees",
                    self.camera.fov_y_deg
                )
            },
        );
        v.check(self.repeats >= 1, "repeats", || {
            format!("{} must be at least 1", self.repeats)
        });
        let frames = self.frame_count();
        v.check(frames <= MAX_FRAMES, "frames", || format!("camera sweeps × plane sweeps × repeats = {frames} frames, more than the limit of {MAX_FRAMES}"));
        self.sky.validate_into(&mut v, "sky", false);
        let (w, h) = self.image_size();
        for (name, side) in [("width", w), ("height", h)] {
            v.check(
                (1..=MAX_IMAGE_SIDE).contains(&side),
                &format!("render.resolution.{name}"),
                || format!("{side} px is out of range [1, {MAX_IMAGE_SIDE}]"),
            );
        }
        v.check(matches!(self.render.msaa, 1 | 4), "render.msaa", || {
            format!("{} is not supported; use 1 or 4", self.render.msaa)
        });
        v.check(
            self.labels.min_box_px.is_finite() && self.labels.min_box_px >= 0.0,
            "labels.min_box_px",
            || {
                format!(
                    "{} must be a finite number of pixels ≥ 0",
                    self.labels.min_box_px
                )
            },
        );
        v.check(
            self.labels.min_visible_fraction.is_finite()
                && (0.0..=1.0).contains(&self.labels.min_visible_fraction),
            "labels.min_visible_fraction",
            || {
                format!(
                    "{} is out of range [0, 1]",
                    self.labels.min_visible_fraction
                )
            },
        );
        v.check(
            matches!(self.labels.id_scale, 1 | 2 | 4),
            "labels.id_scale",
            || format!("{} is not supported; use 1, 2 or 4", self.labels.id_scale),
        );
        if let ImageFormat::Jpeg { quality } = self.output.image_format {
            v.check(
                (1..=100).contains(&quality),
                "output.image_format.quality",
                || format!("{quality} is out of range [1, 100]"),
            );
        }
        let s = &self.output.split;
        let parts = [("train", s.train), ("val", s.val), ("test", s.test)];
        for (name, share) in parts {
            v.check(
                share.is_finite() && (0.0..=1.0).contains(&share),
                &format!("output.split.{name}"),
                || format!("{share} is out of range [0, 1]"),
            );
        }
        let sum = s.train + s.val + s.test;
        v.check((sum - 1.0).abs() < 1e-6, "output.split", || {
            format!("shares sum to {sum}; they must sum to 1")
        });
        if v.errors.is_empty() {
            Ok(())
        } else {
            Err(v.errors)
        }
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
        }
    }
}

#[derive(Default)]
struct Validator {
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
        (names, of_model)
    }
}
