//! The Confusers panel (issue 22): birds, aircraft and balloons around the
//! swarm (`confusers` in the preset, docs/negatives.md). One block per entry:
//! its kind, count and distance, whether it is labelled as a class or kept as
//! an unlabelled hard negative, its size and speed (off: the kind's typical),
//! and for birds the wing-beat rate, the gliding share and the flock. An empty list is off, so a preset that does not use it keeps its
//! bytes. Validation messages appear under the row owning their field path;
//! labels, tooltips and units come from the table of fields
//! ([`crate::preset::fields`]), numbered by entry ("Confuser 2 count").

use egui::Ui;

use super::panels::{Form, Words};
use super::realism_panels::optional_range;
use crate::preset::confusers::{Confuser, ConfuserKind, Flock, FlockShape};
use crate::preset::{Preset, fields};

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
    let mut remove = false;
    ui.horizontal(|ui| {
        egui::ComboBox::from_id_salt("kind")
            .selected_text(c.kind.name())
            .show_ui(ui, |ui| {
                for kind in ConfuserKind::ALL {
                    ui.selectable_value(&mut c.kind, kind, kind.name());
                }
            })
            .response
            .on_hover_text(fields::get("confusers[]").tooltip);
        remove = ui.button("Remove").clicked();
    });
    if !c.kind.is_bird() {
        // Bird-only fields go when the kind is no longer a bird.
        c.flap_hz = None;
        c.glide_share = 0.0;
        c.flock = None;
    }
    Words::item("confusers[].count", i).range(ui, form, &mut c.count, 0.2);
    Words::item("confusers[].distance_m", i).range(ui, form, &mut c.distance_m, 1.0);
    let (size, speed) = (c.size_range_m(), c.speed_range_m_s());
    let words = Words::item("confusers[].size_m", i);
    optional_range(ui, form, &mut c.size_m, size, &words, 0.01);
    let words = Words::item("confusers[].speed_m_s", i);
    optional_range(ui, form, &mut c.speed_m_s, speed, &words, 0.1);
    let words = Words::item("confusers[].labelled_as", i);
    ui.horizontal(|ui| {
        let mut labelled = c.labelled_as.is_some();
        if words.checkbox(ui, &mut labelled).changed() {
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
    form.messages(ui, &[&words.path]);
    if c.kind.is_bird() {
        bird_ui(ui, i, c, form);
    }
    remove
}

/// Gliding share and flock of a bird entry.
fn bird_ui(ui: &mut Ui, i: usize, c: &mut Confuser, form: &mut Form<'_>) {
    Words::item("confusers[].glide_share", i).number(ui, form, &mut c.glide_share, 0.01);
    let flap = c.flap_range_hz();
    let words = Words::item("confusers[].flap_hz", i);
    optional_range(ui, form, &mut c.flap_hz, flap, &words, 0.1);
    let mut flock = c.flock.is_some();
    let words = Words::item("confusers[].flock", i);
    if words.checkbox(ui, &mut flock).changed() {
        c.flock = flock.then(Flock::default);
    }
    form.messages(ui, &[&words.path]);
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
    Words::item("confusers[].flock.spacing_wingspans", i).number(
        ui,
        form,
        &mut f.spacing_wingspans,
        0.05,
    );
    Words::item("confusers[].flock.jitter_wingspans", i).number(
        ui,
        form,
        &mut f.jitter_wingspans,
        0.05,
    );
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
