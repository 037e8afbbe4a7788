//! What a run's preset reads from disk, hashed for its ledger: one
//! [`InputRecord`] for each input the preset names ([`Preset::input_paths`]:
//! a sky image, the backplate folder, a model file), so a run continued,
//! finished again or merged from files that changed since it began is
//! refused before anything is written (docs/reliability.md).

use std::path::Path;

use super::PipelineError;
use crate::model::{self, UriPolicy};
use crate::preset::{FieldError, ModelSource, Preset};
use crate::write::folder::{InputRecord, MAX_INPUT_RECORDS};

/// The records of every input of `preset`, each file or folder once, in
/// [`Preset::input_paths`] order. Called after the pipeline loaded them, so
/// each exists and passed its loader's checks; each file is read again
/// within its loader's bound, in bounded memory.
pub fn input_records(preset: &Preset) -> Result<Vec<InputRecord>, PipelineError> {
    let mut inputs = preset.input_paths();
    let mut seen = std::collections::HashSet::new();
    inputs.retain(|input| seen.insert(*input));
    if inputs.len() > MAX_INPUT_RECORDS {
        return Err(PipelineError::Invalid(vec![FieldError {
            field: inputs[MAX_INPUT_RECORDS].0.to_owned(),
            message: format!(
                "the preset names {} model files, sky images and backplate folders, more than the {MAX_INPUT_RECORDS} a run records in its ledger",
                inputs.len()
            ),
        }]));
    }
    (inputs.into_iter())
        .map(|(field, path)| {
            let mut hasher = blake3::Hasher::new();
            match field {
                "models" => model::hash_sources(path, uri_policy(preset, path), &mut hasher)?,
                "backplate.folder" => crate::sky::plates::hash_folder(path, &mut hasher)?,
                _ => crate::sky::hash_sky_image(path, &mut hasher)?,
            }
            Ok(InputRecord::new(
                field,
                hasher.finalize().to_hex().to_string(),
                path,
            ))
        })
        .collect()
}

/// The URI policy the preset gives the model file at `path`.
fn uri_policy(preset: &Preset, path: &Path) -> UriPolicy {
    let spec =
        (preset.models.iter()).find(|m| matches!(&m.source, ModelSource::File(p) if p == path));
    UriPolicy {
        allow_outside_folder: spec.is_some_and(|m| m.allow_uris_outside_folder),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::preset::ModelSpec;

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
