//! The preset: every parameter of a dataset, as plain serde data (RON on disk).
//!
//! Field names are snake_case; docs/conventions.md maps each to the paper's
//! "3D Model Shots Generator" name (XCount → `x_count`, CameraZ → `camera.z`, …).
//! Every struct is `#[serde(default)]`, so old presets keep loading when fields
//! are added. [`Preset::validate`] returns every problem at once, each naming
//! the field, the value and the allowed range.
//!
//! This file holds [`Preset`], its errors and its file: RON read and
//! written, loaded, validated, paths resolved. Each section of the preset
//! has its file with its types and defaults (`models.rs`, `placement.rs`,
//! `camera.rs`, `render.rs`, `labels.rs`, `output.rs`, `sky.rs`,
//! `formation.rs`, `camera_model.rs`, `appearance.rs`, …; most with their
//! `validate_into`); `validate.rs` checks the whole preset, `sweep.rs` maps
//! frame indices to sweep values, `budget.rs` estimates memory and disk,
//! `fields.rs` names the fields for the app.

use std::fmt;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

pub mod appearance;
pub mod atmosphere;
pub mod backplate;
pub mod budget;
mod camera;
pub mod camera_model;
pub mod clutter;
pub mod confusers;
pub mod fields;
pub mod formation;
mod labels;
pub mod lens;
pub mod masks;
mod models;
pub mod observer;
mod output;
mod placement;
mod render;
pub mod rolling_shutter;
mod ron_error;
pub mod shipped;
mod sky;
pub mod sweep;
pub mod thermal;
pub mod weather;
mod written;

pub use crate::text::{printable, short_number};
pub use camera::{CameraSweep, PlaneSweep};
pub use labels::{BoxMethod, FilteredDrones, LabelSettings};
pub use models::{ModelSource, ModelSpec};
pub use output::{ImageFormat, LabelFormat, OutputSettings, Split, SplitBy};
pub use placement::{AttitudeRanges, CountDistribution, Placement, Volume};
pub use render::{DEFAULT_LOD_ERROR_PX, RenderSettings, Resolution};
pub use ron_error::RonError;
pub use sky::{
    BUILTIN_SKIES, DEFAULT_HORIZON, DEFAULT_ZENITH, EnvironmentName, Sky, SkyImageSource,
};
mod validate;

pub use formation::{
    AbsoluteCamera, Formation, FormationShape, Motion, SequenceCamera, SequenceSpec,
};
use validate::Validator;
pub use validate::{DeviceLimits, MAX_COUNT_SPAN, MAX_FRAME_MEMORY_BYTES, QUEUED_FRAMES};
pub use written::WrittenPaths;

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
    /// The thermal camera (issue 41; docs/realism.md, "Thermal camera"): grey long-wave infrared frames. Off when absent.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub thermal: Option<thermal::Thermal>,
    /// Rain or snow in front of the camera (issue 41; docs/realism.md, "Weather"). Off when absent.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub weather: Option<weather::Weather>,
    /// The paths the preset reads as its file wrote them, kept when
    /// [`Preset::resolve_paths`] resolves them (for [`Preset::lock_text`]);
    /// never in RON, and not compared.
    #[serde(skip)]
    pub written_paths: WrittenPaths,
}

/// A file or folder a preset reads ([`Preset::inputs`]).
#[derive(Clone, Copy, Debug)]
pub enum Input<'a> {
    /// A sky image.
    Sky(&'a Path),
    /// The backplate folder.
    Backplate(&'a Path),
    /// A model file, with the entry that names it.
    Model(&'a ModelSpec, &'a Path),
}

impl<'a> Input<'a> {
    /// The preset field that names it.
    pub fn field(&self) -> &'static str {
        match self {
            Input::Sky(_) => "sky",
            Input::Backplate(_) => "backplate.folder",
            Input::Model(..) => "models",
        }
    }

    pub fn path(&self) -> &'a Path {
        match *self {
            Input::Sky(path) | Input::Backplate(path) | Input::Model(_, path) => path,
        }
    }
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
            thermal: None,
            weather: None,
            written_paths: WrittenPaths::default(),
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

    /// Every file and folder the preset reads: the sky's images, the
    /// backplate folder, the model files.
    pub fn inputs(&self) -> Vec<Input<'_>> {
        let sky = self.sky.image_sources().into_iter();
        let sky = sky.flat_map(|s| s.paths()).map(Input::Sky);
        let plates = (self.backplate.iter()).map(|b| Input::Backplate(&b.folder));
        let models = self.models.iter().filter_map(|m| match &m.source {
            ModelSource::File(path) => Some(Input::Model(m, path)),
            _ => None,
        });
        sky.chain(plates).chain(models).collect()
    }

    /// [`Preset::inputs`], each with the field that names it.
    pub fn input_paths(&self) -> Vec<(&'static str, &Path)> {
        (self.inputs().into_iter())
            .map(|input| (input.field(), input.path()))
            .collect()
    }

    fn input_paths_mut(&mut self) -> Vec<(&'static str, &mut PathBuf)> {
        let sky = self.sky.image_paths_mut().into_iter().map(|p| ("sky", p));
        let plates = self
            .backplate
            .iter_mut()
            .map(|b| ("backplate.folder", &mut b.folder));
        let models = self.models.iter_mut().filter_map(|m| match &mut m.source {
            ModelSource::File(path) => Some(("models", path)),
            _ => None,
        });
        sky.chain(plates).chain(models).collect()
    }

    /// Image size in pixels.
    pub fn image_size(&self) -> (u32, u32) {
        self.render.resolution.size()
    }
}
