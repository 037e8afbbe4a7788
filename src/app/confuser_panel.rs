//! The Confusers panel (issue 22): birds, aircraft and balloons around the
//! swarm (`confusers` in the preset, docs/negatives.md). One block per entry:
//! its kind, count and distance, whether it is labelled as a class or kept as
//! an unlabelled hard negative, its size and speed (off: the kind's typical),
//! and for birds the wing-beat rate, the gliding share and the flock. An empty list is off, so a preset that does not use it keeps its
//! bytes. Validation messages appear under the row owning their field path.

use egui::Ui;

use super::panels::{Form, number_row_in, range_row_in};
use super::realism_panels::optional_range;
use crate::preset::Preset;
use crate::preset::confusers::{Confuser, ConfuserKind, Flock, FlockShape};

/// The list of confuser entries, with add and remove buttons.
pub fn confusers_ui(ui: &mut Ui, preset: &mut Preset, form: &mut Form<'_>) {
    if preset.confusers.is_empty() {
        ui.weak("None: the frames hold drones only.");
    }
    let mut remove = None;
    for (i, c) in preset.confusers.iter_mut().enumerate() {
        ui.push_id(("confuser", i), |ui| {
            if entry_ui(ui, i, c, form) {
                remove = Some(i);
            }
        });
        ui.separator();
    }
    if let Some(i) = remove {
        preset.confusers.remove(i);
    }
    if ui
        .button("Add confuser")
        .on_hover_text("Another kind of bird, aircraft or balloon in the frames")
        .clicked()
    {
        preset.confusers.push(Confuser::default());
    }
}

/// One entry; true when its Remove button was clicked.
fn entry_ui(ui: &mut Ui, i: usize, c: &mut Confuser, form: &mut Form<'_>) -> bool {
    let field = |name: &str| format!("confusers[{i}].{name}");
    let mut remove = false;
    ui.horizontal(|ui| {
        egui::ComboBox::from_id_salt("kind")
            .selected_text(c.kind.name())
            .show_ui(ui, |ui| {
                for kind in ConfuserKind::ALL {
                    ui.selectable_value(&mut c.kind, kind, kind.name());
                }
            });
        remove = ui.button("Remove").clicked();
    });
    if !c.kind.is_bird() {
        // Bird-only fields go when the kind is no longer a bird.
        c.flap_hz = None;
        c.glide_share = 0.0;
        c.flock = None;
    }
    range_row_in(
        ui,
        &mut c.count,
        "Count",
        "How many per frame (per sequence), inclusive",
        0.2,
        "",
    );
    form.messages(ui, &[&field("count")]);
    range_row_in(
        ui,
        &mut c.distance_m,
        "Distance",
        "Distance from the camera in metres, drawn per object (per flock)",
        1.0,
        " m",
    );
    form.messages(ui, &[&field("distance_m")]);
    let (size, speed) = (c.size_range_m(), c.speed_range_m_s());
    optional_range(
        ui,
        &mut c.size_m,
        size,
        "Size",
        "Largest span in metres (birds: wingspan), drawn per object; off: the kind's typical",
        0.01,
        " m",
    );
    form.messages(ui, &[&field("size_m")]);
    optional_range(
        ui,
        &mut c.speed_m_s,
        speed,
        "Speed",
        "Speed along the heading in m/s, drawn per object (per flock); off: the kind's typical",
        0.1,
        " m/s",
    );
    form.messages(ui, &[&field("speed_m_s")]);
    ui.horizontal(|ui| {
        let mut labelled = c.labelled_as.is_some();
        let tip = "Labelled: its own class in YOLO, COCO and MOT. Unlabelled: a hard negative, in the manifest only (cyan boxes in the preview)";
        if ui
            .checkbox(&mut labelled, "Labelled as")
            .on_hover_text(tip)
            .changed()
        {
            let default = if c.kind.is_bird() { "bird" } else { "aircraft" };
            c.labelled_as = labelled.then(|| default.to_string());
        }
        match &mut c.labelled_as {
            Some(name) => {
                ui.text_edit_singleline(name);
            }
            None => {
                ui.weak("hard negative");
            }
        }
    });
    form.messages(ui, &[&field("labelled_as")]);
    if c.kind.is_bird() {
        bird_ui(ui, c, &field, form);
    }
    remove
}

/// Gliding share and flock of a bird entry.
fn bird_ui(ui: &mut Ui, c: &mut Confuser, field: &dyn Fn(&str) -> String, form: &mut Form<'_>) {
    number_row_in(
        ui,
        &mut c.glide_share,
        "Gliding share",
        "Share of the birds holding their wings still (0: all flap)",
        0.01,
        "",
    );
    form.messages(ui, &[&field("glide_share")]);
    let flap = c.flap_range_hz();
    optional_range(
        ui,
        &mut c.flap_hz,
        flap,
        "Wing beats",
        "Wing beats per second, drawn per bird; off: the species' typical",
        0.1,
        " Hz",
    );
    form.messages(ui, &[&field("flap_hz")]);
    let mut flock = c.flock.is_some();
    if ui
        .checkbox(&mut flock, "Flock")
        .on_hover_text("The entry's birds fly together: one heading and speed, in a formation")
        .changed()
    {
        c.flock = flock.then(Flock::default);
    }
    let Some(f) = &mut c.flock else {
        return;
    };
    ui.horizontal(|ui| {
        ui.label("Shape");
        for (shape, name) in [
            (FlockShape::V, "V"),
            (FlockShape::Line, "Line"),
            (FlockShape::Cloud, "Cloud"),
        ] {
            ui.selectable_value(&mut f.shape, shape, name);
        }
    });
    number_row_in(
        ui,
        &mut f.spacing_wingspans,
        "Spacing",
        "Distance between neighbours in wingspans (Cloud: the ball's radius per ∛n)",
        0.05,
        " spans",
    );
    form.messages(ui, &[&field("flock.spacing_wingspans")]);
    number_row_in(
        ui,
        &mut f.jitter_wingspans,
        "Jitter",
        "Each bird displaced by up to ± this many wingspans per axis",
        0.05,
        " spans",
    );
    form.messages(ui, &[&field("flock.jitter_wingspans")]);
}

/// The summary's per-class lines (presets with confusers): training boxes
/// per frame by class, and the hard negatives per frame.
pub fn summary_classes_ui(ui: &mut Ui, stats: &crate::write::DatasetStats, frames: u64) {
    let per_frame = |n: u64| n as f64 / frames.max(1) as f64;
    for (class, b) in &stats.per_class {
        ui.label(format!("  {class}: {:.1} per frame", per_frame(b.boxes)));
    }
    if stats.negatives > 0 {
        ui.label(format!(
            "Hard negatives per frame: {:.1}",
            per_frame(stats.negatives)
        ))
        .on_hover_text("Unlabelled confusers: in the manifest only, never in YOLO/COCO");
    }
}
