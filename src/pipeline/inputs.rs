//! What a run's preset reads from disk, hashed for its ledger: one
//! [`InputRecord`] for each input the preset names ([`Preset::input_paths`]:
//! a sky image, the backplate folder, a model file), so a run continued,
//! finished again or merged from files that changed since it began is
//! refused before anything is written (docs/reliability.md).

use super::PipelineError;
use crate::model::{self, UriPolicy};
use crate::preset::{FieldError, Input, Preset};
use crate::write::folder::{InputRecord, MAX_INPUT_RECORDS};

/// The records of every input of `preset`, each file or folder once, in
/// [`Preset::inputs`] order. Called after the pipeline loaded them, so
/// each exists and passed its loader's checks; each file is read again
/// within its loader's bound, in bounded memory.
pub fn input_records(preset: &Preset) -> Result<Vec<InputRecord>, PipelineError> {
    let mut inputs = preset.inputs();
    let mut seen = std::collections::HashSet::new();
    inputs.retain(|input| seen.insert((input.field(), input.path())));
    if inputs.len() > MAX_INPUT_RECORDS {
        return Err(PipelineError::Invalid(vec![FieldError {
            field: inputs[MAX_INPUT_RECORDS].field().to_owned(),
            message: format!(
                "the preset names {} model files, sky images and backplate folders, more than the {MAX_INPUT_RECORDS} a run records in its ledger",
                inputs.len()
            ),
        }]));
    }
    (inputs.into_iter())
        .map(|input| {
            let mut hasher = blake3::Hasher::new();
            match input {
                Input::Model(spec, path) => {
                    let policy = UriPolicy {
                        allow_outside_folder: spec.allow_uris_outside_folder,
                    };
                    model::hash_sources(path, policy, &mut hasher)?;
                }
                Input::Backplate(path) => crate::sky::plates::hash_folder(path, &mut hasher)?,
                Input::Sky(path) => crate::sky::hash_sky_image(path, &mut hasher)?,
            }
            let hash = hasher.finalize().to_hex().to_string();
            Ok(InputRecord::new(input.field(), hash, input.path()))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::preset::{ModelSource, ModelSpec};

    #[test]
    fn each_input_is_recorded_once_and_too_many_are_refused_before_any_is_read() {
        let mut preset = Preset::default();
        let spec = preset.models[0].clone();
        let file = |i: usize| ModelSpec {
            source: ModelSource::File(format!("missing/m{i}.glb").into()),
            ..spec.clone()
        };
        preset.models = (0..=MAX_INPUT_RECORDS).map(file).collect();
        let err = input_records(&preset).expect_err("refused").to_string();
        assert!(
            err.contains("models: the preset names 4097 model files") && err.contains("4096"),
            "{err}"
        );
        // The same file named again is one input (here read, and missing).
        preset.models = vec![file(0); MAX_INPUT_RECORDS + 1];
        let err = input_records(&preset).expect_err("missing").to_string();
        assert!(err.contains("missing/m0.glb"), "{err}");
    }
}
