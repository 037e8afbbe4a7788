//! What a run's preset reads from disk, hashed for its ledger: one
//! [`InputRecord`] for each input the preset names ([`Preset::input_paths`]:
//! a sky image, the backplate folder, a model file), so a run continued,
//! finished again or merged from files that changed since it began is
//! refused before anything is written (docs/reliability.md).

use std::path::Path;

use super::PipelineError;
use crate::model::{self, UriPolicy};
use crate::preset::{ModelSource, Preset};
use crate::write::folder::InputRecord;

/// The records of every input of `preset`, in [`Preset::input_paths`]
/// order. Called after the pipeline loaded them, so each exists and passed
/// its loader's checks; each file is read again within its loader's bound,
/// in bounded memory.
pub fn input_records(preset: &Preset) -> Result<Vec<InputRecord>, PipelineError> {
    (preset.input_paths().into_iter())
        .map(|(field, path)| {
            let mut hasher = blake3::Hasher::new();
            match field {
                "models" => model::hash_sources(path, uri_policy(preset, path), &mut hasher)?,
                "backplate.folder" => crate::sky::plates::hash_folder(path, &mut hasher)?,
                _ => crate::sky::hash_sky_image(path, &mut hasher)?,
            }
            Ok(InputRecord {
                field: field.to_owned(),
                blake3: hasher.finalize().to_hex().to_string(),
                path: path.display().to_string(),
            })
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
