//! The clutter panel (issue 22 item 2): near-field scenery that hides drones
//! (`clutter` in the preset; docs/realism.md, "Clutter"). Off is the preset
//! field `None`, so a preset without scenery keeps its bytes. Every range is
//! `(min, max)`, drawn per frame; validation messages are shown under the
//! row that owns their field path.

use egui::Ui;

use super::panels::{Form, number_row_in, range_row_in};
use crate::preset::Preset;
use crate::preset::clutter::Clutter;

/// One kind's rows: its count, then its metre ranges (name, value, tip).
fn kind_rows(
    ui: &mut Ui,
    form: &mut Form<'_>,
    (kind, title): (&str, &str),
    count: &mut (u32, u32),
    ranges: Vec<(&str, &mut (f64, f64), &str, &str)>,
) {
    ui.label(title);
    range_row_in(
        ui,
        count,
        "Count",
        "How many per frame, drawn uniformly in (min, max)",
        0.1,
        "",
    );
    form.messages(ui, &[&format!("clutter.{kind}.count")]);
    for (field, value, tip, unit) in ranges {
        let name = match field {
            "distance_m" => "Distance",
            "height_m" => "Height",
            "width_m" => "Width",
            "width_deg" => "Angular width",
            _ => "Spacing",
        };
        range_row_in(ui, value, name, tip, 0.5, unit);
        form.messages(ui, &[&format!("clutter.{kind}.{field}")]);
    }
}

/// Clutter: tree lines, bare trees, poles and wires, buildings (`clutter`).
pub fn clutter_ui(ui: &mut Ui, preset: &mut Preset, form: &mut Form<'_>) {
    let mut on = preset.clutter.is_some();
    if ui
        .checkbox(&mut on, "Clutter on")
        .on_hover_text(
            "Scenery between the camera and the swarm that hides the drones behind it; labels follow the picture",
        )
        .changed()
    {
        preset.clutter = on.then(Clutter::default);
    }
    let Some(c) = &mut preset.clutter else {
        return;
    };
    ui.checkbox(&mut c.per_frame, "New scenery every frame")
        .on_hover_text("Off: one scenery from the preset seed around every frame's camera");
    number_row_in(
        ui,
        &mut c.eye_height_m,
        "Eye height",
        "Height of the camera above the ground the scenery stands on",
        0.05,
        " m",
    );
    form.messages(ui, &["clutter.eye_height_m"]);
    let distance = "Distance from the camera, metres";
    let height = "Height above the ground, metres";
    let t = &mut c.tree_lines;
    kind_rows(
        ui,
        form,
        ("tree_lines", "Tree lines along the horizon"),
        &mut t.count,
        vec![
            ("distance_m", &mut t.distance_m, distance, " m"),
            ("height_m", &mut t.height_m, height, " m"),
            (
                "width_deg",
                &mut t.width_deg,
                "Angular width of each band",
                "°",
            ),
        ],
    );
    let t = &mut c.trees;
    kind_rows(
        ui,
        form,
        ("trees", "Bare trees"),
        &mut t.count,
        vec![
            ("distance_m", &mut t.distance_m, distance, " m"),
            ("height_m", &mut t.height_m, height, " m"),
        ],
    );
    number_row_in(
        ui,
        &mut t.branch_levels,
        "Branch levels",
        "Levels of branching above the trunk (each splits into 2–3 thinner branches)",
        0.05,
        "",
    );
    form.messages(ui, &["clutter.trees.branch_levels"]);
    let p = &mut c.poles;
    kind_rows(
        ui,
        form,
        ("poles", "Lines of poles with wires"),
        &mut p.count,
        vec![
            ("distance_m", &mut p.distance_m, distance, " m"),
            ("height_m", &mut p.height_m, height, " m"),
            (
                "spacing_m",
                &mut p.spacing_m,
                "Distance between neighbouring poles",
                " m",
            ),
        ],
    );
    range_row_in(
        ui,
        &mut p.wires,
        "Wires",
        "Wires per span between two poles",
        0.05,
        "",
    );
    form.messages(ui, &["clutter.poles.wires"]);
    let b = &mut c.buildings;
    kind_rows(
        ui,
        form,
        ("buildings", "Buildings"),
        &mut b.count,
        vec![
            ("distance_m", &mut b.distance_m, distance, " m"),
            ("height_m", &mut b.height_m, height, " m"),
            ("width_m", &mut b.width_m, "Width of the front wall", " m"),
        ],
    );
}
