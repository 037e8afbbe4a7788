//! The clutter panel (issue 22 item 2): near-field scenery that hides drones
//! (`clutter` in the preset; docs/realism.md, "Clutter"). Off is the preset
//! field `None`, so a preset without scenery keeps its bytes. Every range is
//! `(min, max)`, drawn per frame; validation messages are shown under the
//! row that owns their field path. Labels, tooltips and units come from the
//! table of fields ([`crate::preset::fields`]).

use egui::Ui;

use super::panels::{Form, Words};
use super::realism_panels::section_checkbox;
use crate::preset::clutter::Clutter;
use crate::preset::{Preset, fields};

/// One kind's rows: its heading (`kind`), its count, then its metre (or degree) ranges.
fn kind_rows(
    ui: &mut Ui,
    form: &mut Form<'_>,
    kind: &'static str,
    (count_path, count): (&'static str, &mut (u32, u32)),
    ranges: Vec<(&'static str, &mut (f64, f64))>,
) {
    let f = fields::get(kind);
    ui.label(f.label).on_hover_text(f.tooltip);
    Words::of(count_path).range(ui, form, count, 0.1);
    for (path, value) in ranges {
        Words::of(path).range(ui, form, value, 0.5);
    }
}

/// Clutter: tree lines, bare trees, poles and wires, buildings (`clutter`).
pub fn clutter_ui(ui: &mut Ui, preset: &mut Preset, form: &mut Form<'_>) {
    let mut on = preset.clutter.is_some();
    if section_checkbox(ui, &mut on, "clutter").changed() {
        preset.clutter = on.then(Clutter::default);
    }
    let Some(c) = &mut preset.clutter else {
        return;
    };
    Words::of("clutter.per_frame").checkbox(ui, &mut c.per_frame);
    Words::of("clutter.eye_height_m").number(ui, form, &mut c.eye_height_m, 0.05);
    let t = &mut c.tree_lines;
    kind_rows(
        ui,
        form,
        "clutter.tree_lines",
        ("clutter.tree_lines.count", &mut t.count),
        vec![
            ("clutter.tree_lines.distance_m", &mut t.distance_m),
            ("clutter.tree_lines.height_m", &mut t.height_m),
            ("clutter.tree_lines.width_deg", &mut t.width_deg),
        ],
    );
    let t = &mut c.trees;
    kind_rows(
        ui,
        form,
        "clutter.trees",
        ("clutter.trees.count", &mut t.count),
        vec![
            ("clutter.trees.distance_m", &mut t.distance_m),
            ("clutter.trees.height_m", &mut t.height_m),
        ],
    );
    Words::of("clutter.trees.branch_levels").number(ui, form, &mut t.branch_levels, 0.05);
    let p = &mut c.poles;
    kind_rows(
        ui,
        form,
        "clutter.poles",
        ("clutter.poles.count", &mut p.count),
        vec![
            ("clutter.poles.distance_m", &mut p.distance_m),
            ("clutter.poles.height_m", &mut p.height_m),
            ("clutter.poles.spacing_m", &mut p.spacing_m),
        ],
    );
    Words::of("clutter.poles.wires").range(ui, form, &mut p.wires, 0.05);
    let b = &mut c.buildings;
    kind_rows(
        ui,
        form,
        "clutter.buildings",
        ("clutter.buildings.count", &mut b.count),
        vec![
            ("clutter.buildings.distance_m", &mut b.distance_m),
            ("clutter.buildings.height_m", &mut b.height_m),
            ("clutter.buildings.width_m", &mut b.width_m),
        ],
    );
}
