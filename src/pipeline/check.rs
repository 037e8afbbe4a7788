//! The checks of a preset that need a later stage's knowledge: the
//! built-in model table (`model::builtin`) and how frames fall into split
//! groups (`scene::split`). `preset/` checks its own fields and imports
//! nothing above it; [`validate`] and [`warnings`] are its checks plus
//! these, with the same field paths and messages. Every caller that builds
//! or shows a preset's problems goes through them.

use crate::preset::{FieldError, ModelSource, Preset};

/// Every problem of `preset`: its own fields' ([`Preset::validate`]), then
/// the cross-stage ones. All at once, each with its field path.
pub fn validate(preset: &Preset) -> Result<(), Vec<FieldError>> {
    let mut errors = preset.validate().err().unwrap_or_default();
    errors.extend(builtin_models(preset));
    if errors.is_empty() {
        Ok(())
    } else {
        Err(errors)
    }
}

/// What `preset` may not want ([`Preset::warnings`]), then a split that no
/// group reaches.
pub fn warnings(preset: &Preset) -> Vec<FieldError> {
    let mut warnings = preset.warnings();
    warnings.extend(empty_split_groups(preset));
    warnings
}

/// `models[i].source`: a built-in name must be in the table.
fn builtin_models(preset: &Preset) -> Vec<FieldError> {
    let mut errors = Vec::new();
    for (i, m) in preset.models.iter().enumerate() {
        if let ModelSource::Builtin(name) = &m.source
            && crate::model::builtin::glb(name).is_none()
        {
            errors.push(FieldError {
                field: format!("models[{i}].source"),
                message: format!(
                    "no built-in model \"{name}\" (built-ins: {})",
                    crate::model::builtin::NAMES.join(", ")
                ),
            });
        }
    }
    errors
}

/// `output.split.by`: a split with a share that gets no group.
fn empty_split_groups(preset: &Preset) -> Option<FieldError> {
    let groups = crate::scene::split::groups(preset)?;
    let counts = crate::scene::split::group_counts(preset, groups);
    let s = &preset.output.split;
    let empty: Vec<&str> = ["train", "val", "test"]
        .into_iter()
        .zip(counts)
        .zip([s.train, s.val, s.test])
        .filter(|((_, n), share)| *n == 0 && *share > 0.0)
        .map(|((name, _), _)| name)
        .collect();
    (!empty.is_empty()).then(|| FieldError {
        field: "output.split.by".into(),
        message: format!(
            "{:?} makes {groups} group{} ({} train / {} val / {} test): {} gets no frame; sweep more values or split by something finer",
            s.by,
            if groups == 1 { "" } else { "s" },
            counts[0],
            counts[1],
            counts[2],
            empty.join(" and ")
        ),
    })
}
