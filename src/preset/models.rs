//! The preset's models (`models`): where each comes from, its real size and
//! class, and the classes the dataset's labels name (the models' classes,
//! then the labelled confusers').

use std::fmt;
use std::path::PathBuf;

use serde::{Deserialize, Serialize};

use super::Preset;

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

impl Preset {
    /// The largest real size among the models, metres.
    pub fn max_model_size_m(&self) -> f64 {
        self.models.iter().map(|m| m.size_m).fold(0.0, f64::max)
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
