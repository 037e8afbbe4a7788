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
    errors.extend(lens(preset));
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

/// `camera_model.lens`: no draw of the ranges folds the picture (the
/// radial mapping's slope stays over [`MIN_SLOPE`] out to the render's
/// corner; the slope is linear in the coefficients, so the ranges' corners
/// bound every draw), and the stages it cannot follow are off.
fn lens(preset: &Preset) -> Vec<FieldError> {
    use crate::sensor::lens::{MIN_SLOPE, draw};
    let Some(lens) = preset.camera_model.as_ref().and_then(|c| c.lens.as_ref()) else {
        return Vec::new();
    };
    let mut errors = Vec::new();
    let field = |name: &str, message: String| FieldError {
        field: format!("camera_model.lens{name}"),
        message,
    };
    let (w, h) = preset.image_size();
    let focal = f64::from(h) * 0.5 / (preset.camera.fov_y_deg.to_radians() * 0.5).tan();
    let corner = f64::from(w).hypot(f64::from(h)) / 2.0 / focal;
    let n = lens.coefficients().len();
    let ok = lens
        .coefficients()
        .iter()
        .all(|(_, (lo, hi), _)| lo.is_finite() && hi.is_finite());
    for mask in (0..1u32 << n).filter(|_| ok && corner.is_finite()) {
        let mut i = 0;
        let d = draw(lens, |(lo, hi)| {
            i += 1;
            if mask & (1 << (i - 1)) == 0 { lo } else { hi }
        });
        if let Some(r) = d.fold_radius(corner) {
            let (kind, k) = d.named();
            let values: Vec<String> = k.iter().map(|(k, v)| format!("{k} = {v}")).collect();
            errors.push(field(
                "",
                format!(
                    "{kind} with {} folds the picture: its distorted radius grows by under {MIN_SLOPE} per unit from normalised radius {r:.3}, inside the picture's corner at {corner:.3} (a smaller |k| keeps the lens monotone)",
                    values.join(", ")
                ),
            ));
            break;
        }
    }
    if preset.labels.needs_id_pass() && preset.labels.id_scale > 1 {
        errors.push(field(
            "",
            "a lens moves the id layer pixel by pixel: it needs labels.id_scale 1".into(),
        ));
    }
    // Both maps are of the rendered (pinhole) picture's pixels, not the written one's.
    let maps = [
        (preset.output.masks.depth, "depth maps (output.masks.depth)"),
        (preset.output.masks.flow, "optical flow (output.masks.flow)"),
    ];
    for (_, map) in maps.iter().filter(|(asked, _)| *asked) {
        errors.push(field(
            "",
            format!("{map}: not made through a lens (it would be of the rendered picture's pixels, not the written one's); turn one of them off"),
        ));
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
/// splits warn in [`warnings`]). Exact in O(100) whatever the count. None
/// where those frames are refused by [`run_split_error`], which says it.
pub fn empty_splits(preset: &Preset, frames: u64) -> Vec<String> {
    let Some(counts) = crate::scene::split::frame_split_counts(preset, frames, u64::MAX) else {
        return Vec::new();
    };
    if run_split_error(preset, frames, 1).is_some() {
        return Vec::new();
    }
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

/// Frames a run's split check walks one by one at most; a longer run's
/// groups are not checked (every such run reaches three groups long before).
const RUN_SPLIT_WALK: u64 = 4_000_000;

/// The error of a run (the frames `0, every, 2·every, …` below `end`, all
/// shards together) that holds at least 3 frames, keeps groups (sequences)
/// whole and leaves a split whose share is above 0 without a frame because
/// it holds too few groups: it names the groups and the fix. `None` when
/// every split with a share gets frames, when each frame draws its own split
/// (a `--every` trial may still leave one empty: [`empty_splits`]'s warning),
/// or for runs of 1 or 2 frames.
pub fn run_split_error(preset: &Preset, end: u64, every: u64) -> Option<String> {
    let run = crate::scene::split::run_splits(preset, end, every, RUN_SPLIT_WALK)?;
    let unit = run.unit?;
    let s = &preset.output.split;
    let names = ["train", "val", "test"];
    let empty: Vec<&str> = names
        .into_iter()
        .zip([s.train, s.val, s.test])
        .zip(run.frame_counts)
        .filter(|((_, share), n)| *share > 0.0 && *n == 0)
        .map(|((name, _), _)| name)
        .collect();
    if run.frames < 3 || empty.is_empty() {
        return None;
    }
    let held: u64 = run.group_counts.iter().sum();
    let plural = |n: u64, what: &str| {
        let many = if what.ends_with('s') { "es" } else { "s" };
        crate::text::plural(n, what, &format!("{what}{many}"))
    };
    let mut listed = Vec::new();
    for (name, groups) in names.iter().zip(&run.groups) {
        for &(group, first, last) in groups {
            let what = if unit == "environment" {
                format!("{unit} {group} ({})", environment_name_of(preset, first))
            } else {
                format!("{unit} {group}")
            };
            let frames = if first == last {
                format!("frame {first}")
            } else {
                format!("frames {first}–{last}")
            };
            listed.push(format!("{what}: {frames}, {name}"));
        }
    }
    if held as usize > listed.len() {
        listed.push("…".into());
    }
    let wanted = [s.train, s.val, s.test]
        .iter()
        .filter(|&&x| x > 0.0)
        .count() as u64;
    let more = match run.group_size {
        Some(size) if every == 1 => format!(
            "make frames of at least {} (--limit {} or more{})",
            plural(wanted, unit),
            (wanted - 1) * size + 1,
            if preset.frame_count() < (wanted - 1) * size + 1 {
                "; the preset has fewer: sweep more values or raise repeats"
            } else {
                ""
            }
        ),
        _ => format!("make frames of more {unit}s (a longer run, or more sweep values)"),
    };
    let by = match preset.output.split.by {
        crate::preset::SplitBy::Frame => {
            "in sequence mode a sequence's frames share one split".to_string()
        }
        by => format!("output.split.by: {by:?} keeps each {unit}'s frames in one split"),
    };
    Some(format!(
        "output.split: {by}, and this run's {} frames hold {} ({}), so {} get{} no frame; {more}, or set output.split.{} to 0",
        run.frames,
        plural(held, unit),
        listed.join("; "),
        empty.join(" and "),
        if empty.len() == 1 { "s" } else { "" },
        empty.join(" and output.split."),
    ))
}

/// The environment frame `index` draws (that of its sequence's first frame).
fn environment_name_of(preset: &Preset, index: u64) -> String {
    let draw_index = index - index % preset.sequence_len().max(1);
    let env = crate::sky::frame_environment(&preset.sky, preset.seed, draw_index);
    crate::sky::environment_name(&preset.sky, &env)
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
