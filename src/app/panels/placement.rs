//! The Placement section: one function per placement mode (structured grid,
//! randomized volume, formation), and sequence mode below them.

use egui::{DragValue, Ui};

use super::{Form, field_range_row, field_row, named_sweep_row};
use crate::preset::fields;
use crate::preset::sweep::SweepRange;
use crate::preset::{
    Formation, FormationShape, Placement, Preset, SequenceCamera, SequenceSpec, Volume,
};

/// The mode picker (structured, randomized, formation), the chosen mode's
/// fields, and sequence mode below them.
pub fn placement_ui(ui: &mut Ui, preset: &mut Preset, form: &mut Form<'_>) {
    mode_picker_ui(ui, &mut preset.placement);
    match &mut preset.placement {
        Placement::Structured {
            x_count,
            y_count,
            z_count,
            load_factor,
        } => structured_ui(ui, [x_count, y_count, z_count], load_factor, form),
        Placement::Formation(f) => formation_ui(ui, f, form),
        Placement::Randomized {
            count,
            volume,
            min_separation_m,
            ..
        } => randomized_ui(ui, count, volume, min_separation_m, form),
    }
    ui.separator();
    sequence_ui(ui, preset, form);
}

/// Structured / Randomized / Formation radio buttons; a new mode starts from its defaults.
fn mode_picker_ui(ui: &mut Ui, placement: &mut Placement) {
    let structured = matches!(placement, Placement::Structured { .. });
    let formation = matches!(placement, Placement::Formation(_));
    ui.horizontal(|ui| {
        if ui
            .radio(structured, "Structured")
            .on_hover_text("A regular XCount × YCount × ZCount grid")
            .clicked()
            && !structured
        {
            *placement = Placement::Structured {
                x_count: 3,
                y_count: 3,
                z_count: 3,
                load_factor: 4.0,
            };
        }
        let randomized = !structured && !formation;
        if ui
            .radio(randomized, "Randomized")
            .on_hover_text("Uniform random positions in the observation volume")
            .clicked()
            && !randomized
        {
            *placement = Placement::default();
        }
        if ui
            .radio(formation, "Formation")
            .on_hover_text("A named formation: line abreast, column, echelon, wedge, ring, sphere shell, clusters")
            .clicked()
            && !formation
        {
            *placement = Placement::Formation(Formation::default());
        }
    });
}

/// The paper's grid: XCount, YCount, ZCount and LoadFactor.
fn structured_ui(ui: &mut Ui, counts: [&mut u32; 3], load_factor: &mut f64, form: &mut Form<'_>) {
    let [x_count, y_count, z_count] = counts;
    field_row(ui, x_count, "placement.x_count", 0.1);
    form.messages(ui, &["placement.x_count"]);
    field_row(ui, y_count, "placement.y_count", 0.1);
    form.messages(ui, &["placement.y_count"]);
    field_row(ui, z_count, "placement.z_count", 0.1);
    form.messages(ui, &["placement.z_count"]);
    field_row(ui, load_factor, "placement.load_factor", 0.05);
    form.messages(ui, &["placement.load_factor", "placement"]);
}

/// Uniform random positions: the count range, the volume and the minimum separation.
fn randomized_ui(
    ui: &mut Ui,
    count: &mut (u32, u32),
    volume: &mut Volume,
    min_separation_m: &mut f64,
    form: &mut Form<'_>,
) {
    ui.horizontal(|ui| {
        let tip = fields::get("placement.count").tooltip;
        ui.label("Count").on_hover_text(tip);
        ui.add(DragValue::new(&mut count.0).prefix("min ").speed(0.1))
            .accessible_name("Count min")
            .on_hover_text(tip);
        ui.add(DragValue::new(&mut count.1).prefix("max ").speed(0.1))
            .accessible_name("Count max")
            .on_hover_text(tip);
    });
    form.messages(ui, &["placement.count"]);
    volume_picker_ui(ui, volume);
    match volume {
        Volume::Box { size_m } => {
            volume_size_ui(ui, size_m, fields::get("placement.volume.size_m").tooltip);
            form.messages(
                ui,
                &[
                    "placement.volume.size_m.x",
                    "placement.volume.size_m.y",
                    "placement.volume.size_m.z",
                ],
            );
        }
        Volume::Density { per_m3 } => {
            field_row(ui, per_m3, "placement.volume.per_m3", 0.001);
            form.messages(ui, &["placement.volume.per_m3"]);
        }
        Volume::DensitySweep { size_m, per_m3 } => {
            volume_size_ui(
                ui,
                size_m,
                "Size of the observation volume in metres (held fixed)",
            );
            named_sweep_row(
                ui,
                form,
                per_m3,
                [
                    "Density ρ",
                    "placement.volume.per_m3",
                    "Drones per cubic metre, swept like the camera parameters",
                    "",
                ],
                0.0005,
            );
        }
    }
    field_row(ui, min_separation_m, "placement.min_separation_m", 0.01);
    form.messages(ui, &["placement.min_separation_m"]);
}

/// Box / Density / Density sweep radio buttons for the randomized volume.
fn volume_picker_ui(ui: &mut Ui, volume: &mut Volume) {
    let is_box = matches!(volume, Volume::Box { .. });
    ui.horizontal(|ui| {
        ui.label("Volume")
            .on_hover_text(fields::get("placement.volume").tooltip);
        if ui
            .radio(is_box, "Box")
            .on_hover_text("A box of fixed size")
            .clicked()
            && !is_box
        {
            *volume = Volume::default();
        }
        let is_density = matches!(volume, Volume::Density { .. });
        if ui
            .radio(is_density, "Density")
            .on_hover_text("A cube sized so that drones per m³ stays constant")
            .clicked()
            && !is_density
        {
            *volume = Volume::Density { per_m3: 0.01 };
        }
        let is_sweep = matches!(volume, Volume::DensitySweep { .. });
        if ui
            .radio(is_sweep, "Density sweep")
            .on_hover_text("A box of fixed size; ρ is swept and each frame holds round(ρ·V) drones")
            .clicked()
            && !is_sweep
        {
            *volume = Volume::DensitySweep {
                size_m: (20.0, 10.0, 20.0),
                per_m3: SweepRange::new(0.001, 0.004, 0.001),
            };
        }
    });
}

/// `Size  x [..] m  y [..] m  z [..] m`.
fn volume_size_ui(ui: &mut Ui, size_m: &mut (f64, f64, f64), tip: &str) {
    ui.horizontal(|ui| {
        ui.label("Size").on_hover_text(tip);
        for (axis, v) in [
            ("x", &mut size_m.0),
            ("y", &mut size_m.1),
            ("z", &mut size_m.2),
        ] {
            ui.add(
                DragValue::new(v)
                    .prefix(format!("{axis} "))
                    .suffix(" m")
                    .speed(0.1),
            )
            .accessible_name(format!("Volume size {axis}"))
            .on_hover_text(tip);
        }
    });
}

/// The formation's shape picker and its parameters.
fn formation_ui(ui: &mut Ui, f: &mut Formation, form: &mut Form<'_>) {
    ui.horizontal(|ui| {
        ui.label("Shape")
            .on_hover_text(fields::get("placement.shape").tooltip);
        egui::ComboBox::from_id_salt("formation_shape")
            .selected_text(f.shape.name())
            .show_ui(ui, |ui| {
                for shape in FormationShape::all() {
                    let selected = f.shape.name() == shape.name();
                    let name = shape.name();
                    if ui.selectable_label(selected, name).clicked() && !selected {
                        f.shape = shape;
                    }
                }
            });
    });
    match &mut f.shape {
        FormationShape::Echelon { angle_deg } => {
            field_row(ui, angle_deg, "placement.shape.angle_deg", 0.5);
        }
        FormationShape::Wedge { half_angle_deg } => {
            field_row(ui, half_angle_deg, "placement.shape.half_angle_deg", 0.5);
        }
        FormationShape::Ring { tilt_deg } => {
            field_row(ui, tilt_deg, "placement.shape.tilt_deg", 0.5);
        }
        FormationShape::Clustered {
            clusters,
            cluster_gap,
        } => {
            field_row(ui, clusters, "placement.shape.clusters", 0.1);
            field_row(ui, cluster_gap, "placement.shape.cluster_gap", 0.1);
        }
        FormationShape::LineAbreast | FormationShape::Column | FormationShape::SphereShell => {}
    }
    form.messages(ui, &["placement.shape"]);
    field_row(ui, &mut f.count, "placement.count", 0.1);
    form.messages(ui, &["placement.count"]);
    field_row(ui, &mut f.spacing, "placement.spacing", 0.05);
    form.messages(ui, &["placement.spacing"]);
    field_range_row(ui, &mut f.heading_deg, "placement.heading_deg", 1.0);
    form.messages(ui, &["placement.heading_deg"]);
    field_row(
        ui,
        &mut f.position_jitter,
        "placement.position_jitter",
        0.01,
    );
    form.messages(ui, &["placement.position_jitter"]);
    field_row(ui, &mut f.min_separation, "placement.min_separation", 0.05);
    form.messages(ui, &["placement.min_separation"]);
}

/// Sequence mode: off, or T steps of motion per sweep point.
pub fn sequence_ui(ui: &mut Ui, preset: &mut Preset, form: &mut Form<'_>) {
    let mut on = preset.sequence.is_some();
    if ui
        .checkbox(&mut on, "Sequence")
        .on_hover_text(fields::get("sequence").tooltip)
        .changed()
    {
        preset.sequence = on.then(SequenceSpec::default);
    }
    if let Some(seq) = &mut preset.sequence {
        field_row(ui, &mut seq.steps, "sequence.steps", 0.2);
        form.messages(ui, &["sequence.steps"]);
        ui.horizontal(|ui| {
            let tip = fields::get("sequence.motion.translate_m").tooltip;
            ui.label("Translate").on_hover_text(tip);
            let t = &mut seq.motion.translate_m;
            for (axis, v) in [("x", &mut t.0), ("y", &mut t.1), ("z", &mut t.2)] {
                ui.add(DragValue::new(v).prefix(format!("{axis} ")).speed(0.1))
                    .accessible_name(format!("Translate {axis}"))
                    .on_hover_text(tip);
            }
        });
        field_row(
            ui,
            &mut seq.motion.turn_deg,
            "sequence.motion.turn_deg",
            1.0,
        );
        field_row(
            ui,
            &mut seq.motion.bank_deg,
            "sequence.motion.bank_deg",
            1.0,
        );
        form.messages(
            ui,
            &[
                "sequence.motion.translate_m",
                "sequence.motion.turn_deg",
                "sequence.motion.bank_deg",
            ],
        );
        ui.horizontal(|ui| {
            ui.label("Camera")
                .on_hover_text(fields::get("sequence.camera").tooltip);
            ui.radio_value(&mut seq.camera, SequenceCamera::Fixed, "Fixed");
            ui.radio_value(&mut seq.camera, SequenceCamera::Follow, "Follow");
        });
    }
}
