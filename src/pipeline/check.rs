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

/// What `swarmshot check` says of a preset besides its problems, from the
/// stages that know it: the split groups and the placement.
pub struct Summary {
    /// With a grouped `output.split.by`: the groups and their train / val / test counts.
    pub split_groups: Option<(u64, [u64; 3])>,
    /// One line: what the placement makes per frame.
    pub placement: String,
}

/// The [`Summary`] of `preset`.
pub fn summary(preset: &Preset) -> Summary {
    Summary {
        split_groups: crate::scene::split::groups(preset)
            .map(|g| (g, crate::scene::split::group_counts(preset, g))),
        placement: crate::scene::placement::describe(preset),
    }
}

/// A warning for each split that gets no frame of the first `frames`
/// (counted for presets whose frames draw their split one by one; grouped
/// splits warn in [`warnings`]). Exact in O(100) whatever the count.
pub fn empty_splits(preset: &Preset, frames: u64) -> Vec<String> {
    let Some(counts) = crate::scene::split::frame_split_counts(preset, frames, u64::MAX) else {
        return Vec::new();
    };
    let s = &preset.output.split;
    let mut out = Vec::new();
    for ((name, n), share) in ["train", "val", "test"]
        .into_iter()
        .zip(counts)
        .zip([s.train, s.val, s.test])
    {
        if n == 0 && share > 0.0 && frames > 0 {
            out.push(format!(
                "output.split.{name}: {share} of the frames, but the split draw gives it none of these {frames} ({} train / {} val / {} test); {}",
                counts[0],
                counts[1],
                counts[2],
                if name == "val" {
                    "data.yaml then names the train images as val; change the seed or the shares, or make more frames"
                } else {
                    "change the seed or the shares, or make more frames"
                }
            ));
        }
    }
    out
}

/// The drones a frame holds on average, for disk estimates: the count
/// distribution's mean for randomized placement, else the most a frame holds.
pub fn mean_drones_per_frame(preset: &Preset) -> f64 {
    match &preset.placement {
        crate::preset::Placement::Randomized {
            count: (lo, hi),
            count_distribution,
            volume,
            ..
        } if !matches!(volume, crate::preset::Volume::DensitySweep { .. }) => {
            crate::scene::placement::count_mean(*lo, *hi, count_distribution)
        }
        _ => preset.max_drones_per_frame() as f64,
    }
}
