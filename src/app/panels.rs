//! The parameter panels, named as in the paper's "3D Model Shots Generator"
//! (section 3.3): Models, Placement (XCount, YCount, ZCount, LoadFactor or
//! randomized), Attitude, Camera (CameraX/Y/Z), Scene rotation
//! (PlaneRX/RY/RZ), Skybox and Output.
//!
//! Each panel edits the preset in place; actions that reach beyond the preset
//! (file dialogs) are returned as [`Command`]s. Validation messages come from
//! [`Preset::validate`] and are shown under the widget that owns their field
//! path ([`Form`]); any message no widget claimed is listed at the end.

use egui::{DragValue, Response, RichText, Ui};

use super::Command;
use crate::model::builtin::NAMES as BUILTIN_NAMES;
use crate::preset::sweep::SweepRange;
use crate::preset::{
    BoxMethod, FieldError, Formation, FormationShape, ImageFormat, LabelFormat, ModelSource,
    ModelSpec, Placement, Preset, Resolution, SequenceCamera, SequenceSpec, Sky, Volume,
};

/// The validation messages of the preset being edited, and which of them a widget has shown.
pub struct Form<'a> {
    errors: &'a [FieldError],
    shown: Vec<bool>,
    /// Scroll this field's message into view (a Problems link was clicked).
    scroll_to: Option<&'a str>,
    scrolled: bool,
}

impl<'a> Form<'a> {
    pub fn new(errors: &'a [FieldError], scroll_to: Option<&'a str>) -> Self {
        Self {
            errors,
            shown: vec![false; errors.len()],
            scroll_to,
            scrolled: false,
        }
    }

    /// Show the messages of these exact field paths, in the error colour.
    pub fn messages(&mut self, ui: &mut Ui, fields: &[&str]) {
        for (i, e) in self.errors.iter().enumerate() {
            if fields.contains(&e.field.as_str()) {
                self.shown[i] = true;
                let response = error_label(ui, &e.message);
                self.scroll_if_wanted(&e.field, &response);
            }
        }
    }

    /// Messages that no widget showed (e.g. limits on the whole preset).
    pub fn rest(&mut self, ui: &mut Ui) {
        for (i, e) in self.errors.iter().enumerate() {
            if !self.shown[i] {
                self.shown[i] = true;
                let response = error_label(ui, &e.to_string());
                self.scroll_if_wanted(&e.field, &response);
            }
        }
    }

    /// Whether the wanted message was scrolled to in this pass.
    pub fn scrolled(&self) -> bool {
        self.scrolled
    }

    fn scroll_if_wanted(&mut self, field: &str, response: &Response) {
        if !self.scrolled && self.scroll_to == Some(field) {
            response.scroll_to_me(Some(egui::Align::Center));
            response.clone().highlight();
            self.scrolled = true;
        }
    }
}

pub fn error_label(ui: &mut Ui, message: &str) -> Response {
    ui.label(RichText::new(message).color(ui.visuals().error_fg_color))
}

/// `label  [number]` on one line; the label names the field (for screen readers and tests).
fn number_row<N: egui::emath::Numeric>(
    ui: &mut Ui,
    value: &mut N,
    name: &str,
    tip: &str,
    speed: f64,
) -> Response {
    number_row_in(ui, value, name, tip, speed, "")
}

/// [`number_row`] for an angle: the number shows its unit, °.
fn angle_row(ui: &mut Ui, value: &mut f64, name: &str, tip: &str, speed: f64) -> Response {
    number_row_in(ui, value, name, tip, speed, "°")
}

/// [`number_row`] with a unit after the number (`"°"`, `" m"`; `""` for none).
pub(super) fn number_row_in<N: egui::emath::Numeric>(
    ui: &mut Ui,
    value: &mut N,
    name: &str,
    tip: &str,
    speed: f64,
    unit: &str,
) -> Response {
    ui.horizontal(|ui| {
        let label = ui.label(name).on_hover_text(tip);
        ui.add(DragValue::new(value).speed(speed).suffix(unit))
            .labelled_by(label.id)
            .on_hover_text(tip)
    })
    .inner
}

/// `label  min [..] max [..]` for an inclusive (min, max) pair of angles (°).
fn range_row(ui: &mut Ui, value: &mut (f64, f64), name: &str, tip: &str, speed: f64) {
    range_row_in(ui, value, name, tip, speed, "°");
}

/// [`range_row`] with a unit after each number (`" m"`, `" px"`; `""` for none).
pub(super) fn range_row_in<N: egui::emath::Numeric>(
    ui: &mut Ui,
    value: &mut (N, N),
    name: &str,
    tip: &str,
    speed: f64,
    unit: &str,
) {
    ui.horizontal(|ui| {
        ui.label(name).on_hover_text(tip);
        ui.add(
            DragValue::new(&mut value.0)
                .speed(speed)
                .prefix("min ")
                .suffix(unit),
        )
        .accessible_name(format!("{name} min"))
        .on_hover_text(tip);
        ui.add(
            DragValue::new(&mut value.1)
                .speed(speed)
                .prefix("max ")
                .suffix(unit),
        )
        .accessible_name(format!("{name} max"))
        .on_hover_text(tip);
    });
}

/// A paper start/end/step sweep row (CameraZ, PlaneRY, …) with its value count and messages.
fn sweep_row(
    ui: &mut Ui,
    form: &mut Form<'_>,
    range: &mut SweepRange,
    name: &str,
    field: &str,
    tip: &str,
    speed: f64,
) {
    ui.horizontal(|ui| {
        ui.label(name).on_hover_text(tip);
        for (part, value) in [
            ("start", &mut range.start),
            ("end", &mut range.end),
            ("step", &mut range.step),
        ] {
            // PlaneRX/RY/RZ sweep angles; CameraX/Y/Z are relative units.
            let unit = if field.starts_with("plane.") {
                "°"
            } else {
                ""
            };
            ui.add(
                DragValue::new(value)
                    .speed(speed)
                    .prefix(format!("{part} "))
                    .suffix(unit),
            )
            .accessible_name(format!("{name} {part}"))
            .on_hover_text(format!("{name} {part}: {tip}"));
        }
        if let Ok(n) = range.count() {
            ui.weak(if n == 1 {
                "1 value".to_string()
            } else {
                format!("{} values", group_digits(n))
            });
        }
    });
    form.messages(ui, &[field, &format!("{field}.step")]);
}

/// 4860 → "4 860" (the and SI's digit grouping).
pub fn group_digits(n: u64) -> String {
    let digits = n.to_string();
    let mut out = String::new();
    for (i, c) in digits.chars().enumerate() {
        if i > 0 && (digits.len() - i).is_multiple_of(3) {
            out.push(' ');
        }
        out.push(c);
    }
    out
}

/// `value` with as many decimals as `range`'s start and step have (at most 6),
/// so 0.6 + 3·0.2 reads "1.2", not "1.2000000000000002".
pub fn format_to_step(value: f64, range: &SweepRange) -> String {
    let decimals = |x: f64| {
        let text = format!("{:.6}", x.abs());
        let fraction = text.split('.').nth(1).unwrap_or("");
        fraction.trim_end_matches('0').len()
    };
    let places = decimals(range.start).max(decimals(range.step));
    let text = format!("{value:.places$}");
    // No "-0" for a value that rounds to zero.
    if text
        .trim_start_matches('-')
        .chars()
        .all(|c| c == '0' || c == '.')
    {
        text.trim_start_matches('-').to_string()
    } else {
        text
    }
}

/// The general fields above the panels: name, seed, repeats.
pub fn general_ui(ui: &mut Ui, preset: &mut Preset, form: &mut Form<'_>) {
    ui.horizontal(|ui| {
        let label = ui
            .label("Name")
            .on_hover_text("Preset name, written into the dataset's lock file");
        ui.text_edit_singleline(&mut preset.name)
            .labelled_by(label.id);
    });
    number_row(
        ui,
        &mut preset.seed,
        "Seed",
        "Master seed: every frame derives its own random draw from (seed, frame index)",
        1.0,
    );
    number_row(
        ui,
        &mut preset.repeats,
        "Repeats",
        "Frames made per sweep combination, each with its own random placement",
        0.1,
    );
    form.messages(ui, &["name", "seed", "repeats"]);
}

pub fn models_ui(
    ui: &mut Ui,
    preset: &mut Preset,
    form: &mut Form<'_>,
    load_error: Option<&str>,
    commands: &mut Vec<Command>,
) {
    let mut remove = None;
    for (i, model) in preset.models.iter_mut().enumerate() {
        ui.horizontal(|ui| {
            let name = match &model.source {
                ModelSource::Builtin(name) => format!("built-in {name}"),
                ModelSource::File(path) => path.file_name().map_or_else(
                    || path.display().to_string(),
                    |f| f.to_string_lossy().into_owned(),
                ),
            };
            ui.label(RichText::new(format!("{}. {name}", i + 1)).strong())
                .on_hover_text(model.source.to_string());
            if ui
                .small_button("Remove")
                .on_hover_text("Remove this model from the preset")
                .clicked()
            {
                remove = Some(i);
            }
        });
        ui.horizontal(|ui| {
            let tip = "Real size: the model is scaled so that its largest span is this many metres";
            ui.label("Size").on_hover_text(tip);
            ui.add(DragValue::new(&mut model.size_m).speed(0.01).suffix(" m"))
                .accessible_name(format!("Model {} size", i + 1))
                .on_hover_text(tip);
            let tip = "Class name written into the labels";
            ui.label("Class").on_hover_text(tip);
            ui.add(egui::TextEdit::singleline(&mut model.class).desired_width(80.0))
                .accessible_name(format!("Model {} class", i + 1))
                .on_hover_text(tip);
        });
        form.messages(
            ui,
            &[
                &format!("models[{i}].size_m"),
                &format!("models[{i}].class"),
                &format!("models[{i}].source"),
            ],
        );
    }
    if let Some(i) = remove {
        preset.models.remove(i);
    }
    ui.horizontal(|ui| {
        egui::ComboBox::from_id_salt("add built-in")
            .selected_text("Add built-in")
            .show_ui(ui, |ui| {
                for name in BUILTIN_NAMES {
                    if ui.selectable_label(false, *name).clicked() {
                        preset.models.push(ModelSpec {
                            source: ModelSource::Builtin((*name).to_string()),
                            ..ModelSpec::default()
                        });
                    }
                }
            })
            .response
            .accessible_name("Add built-in model")
            .on_hover_text("Add one of the models that ship with swarmshot");
        if ui
            .button("Add glTF…")
            .on_hover_text("Add a .gltf/.glb model file (any unit: it is scaled to its real size)")
            .clicked()
        {
            commands.push(Command::AddGltf);
        }
    });
    form.messages(ui, &["models"]);
    if let Some(message) = load_error {
        error_label(ui, message);
    }
}

pub fn placement_ui(ui: &mut Ui, preset: &mut Preset, form: &mut Form<'_>) {
    let structured = matches!(preset.placement, Placement::Structured { .. });
    let formation = matches!(preset.placement, Placement::Formation(_));
    ui.horizontal(|ui| {
        if ui
            .radio(structured, "Structured")
            .on_hover_text("A regular XCount × YCount × ZCount grid")
            .clicked()
            && !structured
        {
            preset.placement = Placement::Structured {
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
            preset.placement = Placement::default();
        }
        if ui
            .radio(formation, "Formation")
            .on_hover_text("A named formation: line abreast, column, echelon, wedge, ring, sphere shell, clusters")
            .clicked()
            && !formation
        {
            preset.placement = Placement::Formation(Formation::default());
        }
    });
    match &mut preset.placement {
        Placement::Structured {
            x_count,
            y_count,
            z_count,
            load_factor,
        } => {
            number_row(ui, x_count, "XCount", "Drones along the grid's x axis", 0.1);
            form.messages(ui, &["placement.x_count"]);
            number_row(
                ui,
                y_count,
                "YCount",
                "Drones along the grid's y (vertical) axis",
                0.1,
            );
            form.messages(ui, &["placement.y_count"]);
            number_row(
                ui,
                z_count,
                "ZCount",
                "Drones along the grid's z (depth) axis",
                0.1,
            );
            form.messages(ui, &["placement.z_count"]);
            number_row(
                ui,
                load_factor,
                "LoadFactor",
                "Grid spacing in multiples of the largest model size (≥ 1: no overlap)",
                0.05,
            );
            form.messages(ui, &["placement.load_factor", "placement"]);
        }
        Placement::Formation(f) => formation_ui(ui, f, form),
        Placement::Randomized {
            count,
            volume,
            min_separation_m,
            ..
        } => {
            ui.horizontal(|ui| {
                let tip = "Drones per frame: this inclusive range, drawn by the preset's count_distribution (uniform unless the preset names one)";
                ui.label("Count").on_hover_text(tip);
                ui.add(DragValue::new(&mut count.0).prefix("min ").speed(0.1))
                    .accessible_name("Count min")
                    .on_hover_text(tip);
                ui.add(DragValue::new(&mut count.1).prefix("max ").speed(0.1))
                    .accessible_name("Count max")
                    .on_hover_text(tip);
            });
            form.messages(ui, &["placement.count"]);
            let is_box = matches!(volume, Volume::Box { .. });
            ui.horizontal(|ui| {
                ui.label("Volume")
                    .on_hover_text("The observation volume W, centred at the origin");
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
                    .on_hover_text(
                        "A box of fixed size; ρ is swept and each frame holds round(ρ·V) drones",
                    )
                    .clicked()
                    && !is_sweep
                {
                    *volume = Volume::DensitySweep {
                        size_m: (20.0, 10.0, 20.0),
                        per_m3: SweepRange::new(0.001, 0.004, 0.001),
                    };
                }
            });
            match volume {
                Volume::Box { size_m } => {
                    ui.horizontal(|ui| {
                        let tip = "Size of the observation volume in metres";
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
                    number_row(
                        ui,
                        per_m3,
                        "Density",
                        "Global density factor ρ: drones per cubic metre",
                        0.001,
                    );
                    form.messages(ui, &["placement.volume.per_m3"]);
                }
                Volume::DensitySweep { size_m, per_m3 } => {
                    ui.horizontal(|ui| {
                        let tip = "Size of the observation volume in metres (held fixed)";
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
                    sweep_row(
                        ui,
                        form,
                        per_m3,
                        "Density ρ",
                        "placement.volume.per_m3",
                        "Drones per cubic metre, swept like the camera parameters",
                        0.0005,
                    );
                }
            }
            number_row(
                ui,
                min_separation_m,
                "Min separation",
                "No two drone centres come closer than this (metres)",
                0.01,
            );
            form.messages(ui, &["placement.min_separation_m"]);
        }
    }
    ui.separator();
    sequence_ui(ui, preset, form);
}

/// The formation's shape picker and its parameters.
fn formation_ui(ui: &mut Ui, f: &mut Formation, form: &mut Form<'_>) {
    ui.horizontal(|ui| {
        ui.label("Shape")
            .on_hover_text("The formation's pattern; each has its own few parameters");
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
            angle_row(
                ui,
                angle_deg,
                "Echelon angle",
                "Degrees from the heading (0 = column, 90 = line abreast)",
                0.5,
            );
        }
        FormationShape::Wedge { half_angle_deg } => {
            angle_row(
                ui,
                half_angle_deg,
                "Wedge half angle",
                "Degrees between each arm and the heading",
                0.5,
            );
        }
        FormationShape::Ring { tilt_deg } => {
            angle_row(
                ui,
                tilt_deg,
                "Ring tilt",
                "Degrees the ring's axis leans forward from vertical",
                0.5,
            );
        }
        FormationShape::Clustered {
            clusters,
            cluster_gap,
        } => {
            number_row(ui, clusters, "Clusters", "Number of dense groups", 0.1);
            number_row(
                ui,
                cluster_gap,
                "Cluster gap",
                "Gap between groups in model spans",
                0.1,
            );
        }
        FormationShape::LineAbreast | FormationShape::Column | FormationShape::SphereShell => {}
    }
    form.messages(ui, &["placement.shape"]);
    number_row(ui, &mut f.count, "Count", "Drones in the formation", 0.1);
    form.messages(ui, &["placement.count"]);
    number_row(
        ui,
        &mut f.spacing,
        "Spacing",
        "Distance between neighbours in multiples of the largest model size (a LoadFactor)",
        0.05,
    );
    form.messages(ui, &["placement.spacing"]);
    range_row(
        ui,
        &mut f.heading_deg,
        "Heading",
        "Yaw of the formation's forward axis, degrees, drawn per frame",
        1.0,
    );
    form.messages(ui, &["placement.heading_deg"]);
    number_row(
        ui,
        &mut f.position_jitter,
        "Jitter",
        "Each drone moves up to ± this many model sizes per axis",
        0.01,
    );
    form.messages(ui, &["placement.position_jitter"]);
    number_row(
        ui,
        &mut f.min_separation,
        "Min separation",
        "No two drone centres come closer than this many model sizes",
        0.05,
    );
    form.messages(ui, &["placement.min_separation"]);
}

/// Sequence mode: off, or T steps of motion per sweep point.
pub fn sequence_ui(ui: &mut Ui, preset: &mut Preset, form: &mut Form<'_>) {
    let mut on = preset.sequence.is_some();
    if ui
        .checkbox(&mut on, "Sequence")
        .on_hover_text("Each sweep point becomes T + 1 frames of motion (MOT ground truth)")
        .changed()
    {
        preset.sequence = on.then(SequenceSpec::default);
    }
    if let Some(seq) = &mut preset.sequence {
        number_row(
            ui,
            &mut seq.steps,
            "Steps T",
            "Interpolation steps; a sequence has T + 1 frames",
            0.2,
        );
        form.messages(ui, &["sequence.steps"]);
        ui.horizontal(|ui| {
            let tip = "Translation of the whole formation over the sequence (metres)";
            ui.label("Translate").on_hover_text(tip);
            let t = &mut seq.motion.translate_m;
            for (axis, v) in [("x", &mut t.0), ("y", &mut t.1), ("z", &mut t.2)] {
                ui.add(DragValue::new(v).prefix(format!("{axis} ")).speed(0.1))
                    .accessible_name(format!("Translate {axis}"))
                    .on_hover_text(tip);
            }
        });
        angle_row(
            ui,
            &mut seq.motion.turn_deg,
            "Turn",
            "Turn of the formation about the vertical, degrees",
            1.0,
        );
        angle_row(
            ui,
            &mut seq.motion.bank_deg,
            "Bank",
            "Each drone rolls by this many degrees",
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
                .on_hover_text("Fixed (a ground observer) or following the swarm");
            ui.radio_value(&mut seq.camera, SequenceCamera::Fixed, "Fixed");
            ui.radio_value(&mut seq.camera, SequenceCamera::Follow, "Follow");
        });
    }
}

pub fn attitude_ui(ui: &mut Ui, preset: &mut Preset, form: &mut Form<'_>) {
    let a = &mut preset.attitude;
    range_row(
        ui,
        &mut a.roll_deg,
        "Roll",
        "Per-drone roll range in degrees",
        1.0,
    );
    form.messages(ui, &["attitude.roll_deg"]);
    range_row(
        ui,
        &mut a.pitch_deg,
        "Pitch",
        "Per-drone pitch range in degrees",
        1.0,
    );
    form.messages(ui, &["attitude.pitch_deg"]);
    range_row(
        ui,
        &mut a.yaw_deg,
        "Yaw",
        "Per-drone yaw range in degrees",
        1.0,
    );
    form.messages(ui, &["attitude.yaw_deg"]);
}

pub fn camera_ui(ui: &mut Ui, preset: &mut Preset, form: &mut Form<'_>) {
    let c = &mut preset.camera;
    sweep_row(
        ui,
        form,
        &mut c.x,
        "CameraX",
        "camera.x",
        "sideways camera offset, in units of the swarm radius R",
        0.01,
    );
    sweep_row(
        ui,
        form,
        &mut c.y,
        "CameraY",
        "camera.y",
        "vertical camera offset, in units of the swarm radius R",
        0.01,
    );
    sweep_row(
        ui,
        form,
        &mut c.z,
        "CameraZ",
        "camera.z",
        "relative distance: 1 = the swarm just fills the view",
        0.01,
    );
    angle_row(
        ui,
        &mut c.fov_y_deg,
        "Field of view",
        "Vertical field of view of the camera, degrees",
        0.1,
    );
    form.messages(ui, &["camera.fov_y_deg"]);
}

pub fn plane_ui(ui: &mut Ui, preset: &mut Preset, form: &mut Form<'_>) {
    let p = &mut preset.plane;
    sweep_row(
        ui,
        form,
        &mut p.rx,
        "PlaneRX",
        "plane.rx",
        "rotation of the whole swarm about world x, degrees",
        1.0,
    );
    sweep_row(
        ui,
        form,
        &mut p.ry,
        "PlaneRY",
        "plane.ry",
        "rotation of the whole swarm about world y, degrees",
        1.0,
    );
    sweep_row(
        ui,
        form,
        &mut p.rz,
        "PlaneRZ",
        "plane.rz",
        "rotation of the whole swarm about world z, degrees",
        1.0,
    );
}

pub fn skybox_ui(ui: &mut Ui, preset: &mut Preset, form: &mut Form<'_>) {
    use crate::sky::EnvironmentName;
    // The paper's seven skyboxes (procedural), the gradient, and what only a preset file can say.
    let current = match &preset.sky {
        Sky::Gradient { .. } => "Gradient".to_string(),
        Sky::Procedural { environment, .. } => environment.as_str().to_string(),
        Sky::Image { .. } => "Image (preset file)".to_string(),
        Sky::Random { .. } => "Random (preset file)".to_string(),
    };
    ui.horizontal(|ui| {
        let tip = "The background environment; its sun also lights the drones";
        ui.label("Skybox").on_hover_text(tip);
        egui::ComboBox::from_id_salt("skybox")
            .selected_text(current)
            .show_ui(ui, |ui| {
                if ui
                    .selectable_label(matches!(preset.sky, Sky::Gradient { .. }), "Gradient")
                    .on_hover_text("Gradient sky with a sun disc")
                    .clicked()
                {
                    preset.sky = Sky::default();
                }
                for name in EnvironmentName::ALL {
                    let selected = matches!(&preset.sky, Sky::Procedural { environment, .. } if *environment == name);
                    if ui
                        .selectable_label(selected, name.as_str())
                        .on_hover_text("Procedural environment: physically based sky, clouds, ground and horizon")
                        .clicked()
                    {
                        preset.sky = Sky::procedural(name);
                    }
                }
            })
            .response
            .on_hover_text(tip);
    });
    match &mut preset.sky {
        Sky::Gradient {
            sun_elevation_deg,
            sun_azimuth_deg,
            zenith,
            horizon,
        } => {
            ui.label("Gradient sky with a sun disc; the sun also lights the drones");
            angle_row(
                ui,
                sun_elevation_deg,
                "Sun elevation",
                "Sun angle above the horizon, degrees",
                0.5,
            );
            form.messages(ui, &["sky.sun_elevation_deg"]);
            angle_row(
                ui,
                sun_azimuth_deg,
                "Sun azimuth",
                "Sun direction from +z towards +x, degrees",
                1.0,
            );
            form.messages(ui, &["sky.sun_azimuth_deg"]);
            for (name, colour, field) in [
                ("Zenith colour", zenith, "sky.zenith"),
                ("Horizon colour", horizon, "sky.horizon"),
            ] {
                ui.horizontal(|ui| {
                    let tip = "Linear RGB of the sky at this height";
                    ui.label(name).on_hover_text(tip);
                    let mut rgb = [colour.0, colour.1, colour.2];
                    if ui
                        .color_edit_button_rgb(&mut rgb)
                        .accessible_name(name)
                        .on_hover_text(tip)
                        .changed()
                    {
                        *colour = (rgb[0], rgb[1], rgb[2]);
                    }
                });
                form.messages(ui, &[field]);
            }
        }
        Sky::Procedural {
            environment,
            sun_elevation_deg,
            sun_azimuth_deg,
            cloud_cover,
            ..
        } => {
            let style = environment.style();
            let mut elevation = sun_elevation_deg.unwrap_or(style.sun_elevation_deg);
            if angle_row(
                ui,
                &mut elevation,
                "Sun elevation",
                "Sun angle above the horizon, degrees (the environment's own by default)",
                0.5,
            )
            .changed()
            {
                *sun_elevation_deg = Some(elevation);
            }
            form.messages(ui, &["sky.sun_elevation_deg"]);
            let mut azimuth = sun_azimuth_deg.unwrap_or(style.sun_azimuth_deg);
            if angle_row(
                ui,
                &mut azimuth,
                "Sun azimuth",
                "Sun direction from +z towards +x, degrees",
                1.0,
            )
            .changed()
            {
                *sun_azimuth_deg = Some(azimuth);
            }
            form.messages(ui, &["sky.sun_azimuth_deg"]);
            let mut cover = cloud_cover.unwrap_or(style.cloud_cover);
            if number_row(
                ui,
                &mut cover,
                "Cloud cover",
                "Fraction of the sky under cloud, 0 to 1",
                0.01,
            )
            .changed()
            {
                *cloud_cover = Some(cover);
            }
            form.messages(ui, &["sky.cloud_cover"]);
        }
        Sky::Image { .. } | Sky::Random { .. } => {
            ui.label("This sky is edited in the preset file (see docs/environments.md).");
        }
    }
}

/// Output: resolution, MSAA, image and label formats, split, boxes, folder.
pub fn output_ui(
    ui: &mut Ui,
    preset: &mut Preset,
    form: &mut Form<'_>,
    out_dir: &mut String,
    overwrite: &mut bool,
    commands: &mut Vec<Command>,
) {
    resolution_ui(ui, preset, form);
    file_formats_ui(ui, preset, form);
    split_ui(ui, preset, form);
    boxes_ui(ui, preset, form);
    folder_ui(ui, out_dir, overwrite, commands);
}

/// Resolution (named or custom) and MSAA.
fn resolution_ui(ui: &mut Ui, preset: &mut Preset, form: &mut Form<'_>) {
    let r = &mut preset.render;
    let name = |res: Resolution| match res {
        Resolution::FullHd => "Full HD 1920×1080".to_string(),
        Resolution::Qhd => "2K 2560×1440".to_string(),
        Resolution::Uhd4k => "4K 4096×2160".to_string(),
        Resolution::Custom { width, height } => format!("Custom {width}×{height}"),
    };
    egui::ComboBox::from_label("Resolution")
        .selected_text(name(r.resolution))
        .show_ui(ui, |ui| {
            for res in [Resolution::FullHd, Resolution::Qhd, Resolution::Uhd4k] {
                ui.selectable_value(&mut r.resolution, res, name(res));
            }
            let (w, h) = r.resolution.size();
            if ui
                .selectable_label(matches!(r.resolution, Resolution::Custom { .. }), "Custom")
                .clicked()
            {
                r.resolution = Resolution::Custom {
                    width: w,
                    height: h,
                };
            }
        })
        .response
        .on_hover_text("Image size of every frame");
    if let Resolution::Custom { width, height } = &mut r.resolution {
        ui.horizontal(|ui| {
            ui.label("Size")
                .on_hover_text("Custom image size in pixels");
            ui.add(DragValue::new(width).suffix(" px"))
                .accessible_name("Width")
                .on_hover_text("Image width in pixels");
            ui.add(DragValue::new(height).suffix(" px"))
                .accessible_name("Height")
                .on_hover_text("Image height in pixels");
        });
    }
    form.messages(ui, &["render.resolution.width", "render.resolution.height"]);
    ui.horizontal(|ui| {
        ui.label("MSAA")
            .on_hover_text("Multisample anti-aliasing: 1 (off) or 4 samples per pixel");
        ui.radio_value(&mut r.msaa, 1, "off")
            .on_hover_text("No anti-aliasing");
        ui.radio_value(&mut r.msaa, 4, "4×")
            .on_hover_text("4 samples per pixel");
    });
    form.messages(ui, &["render.msaa"]);
}

/// JPEG/PNG and the annotation formats.
fn file_formats_ui(ui: &mut Ui, preset: &mut Preset, form: &mut Form<'_>) {
    let o = &mut preset.output;
    ui.horizontal(|ui| {
        ui.label("Images").on_hover_text("Image file format");
        let jpeg = matches!(o.image_format, ImageFormat::Jpeg { .. });
        if ui
            .radio(jpeg, "JPEG")
            .on_hover_text("Lossy JPEG (the paper uses quality 85)")
            .clicked()
            && !jpeg
        {
            o.image_format = ImageFormat::Jpeg { quality: 85 };
        }
        if ui
            .radio(!jpeg, "PNG")
            .on_hover_text("Lossless PNG")
            .clicked()
        {
            o.image_format = ImageFormat::Png;
        }
        if let ImageFormat::Jpeg { quality } = &mut o.image_format {
            ui.add(DragValue::new(quality).prefix("quality ").range(1..=100))
                .accessible_name("JPEG quality")
                .on_hover_text("JPEG quality, 1–100");
        }
    });
    form.messages(ui, &["output.image_format.quality"]);
    ui.horizontal(|ui| {
        ui.label("Labels")
            .on_hover_text("Annotation formats written next to the images");
        for (format, name, tip) in [
            (
                LabelFormat::Yolo,
                "YOLO",
                "Ultralytics YOLO: labels/*.txt and data.yaml",
            ),
            (
                LabelFormat::Coco,
                "COCO",
                "COCO: annotations/instances_{split}.json",
            ),
        ] {
            let mut on = o.label_formats.contains(&format);
            if ui.checkbox(&mut on, name).on_hover_text(tip).changed() {
                if on {
                    o.label_formats.push(format);
                } else {
                    o.label_formats.retain(|f| *f != format);
                }
            }
        }
    });
}

/// The train/val/test shares.
fn split_ui(ui: &mut Ui, preset: &mut Preset, form: &mut Form<'_>) {
    let o = &mut preset.output;
    ui.horizontal(|ui| {
        let tip = "Share of frames in each split; the three must sum to 1";
        ui.label("Split").on_hover_text(tip);
        for (name, v) in [
            ("train", &mut o.split.train),
            ("val", &mut o.split.val),
            ("test", &mut o.split.test),
        ] {
            ui.add(DragValue::new(v).prefix(format!("{name} ")).speed(0.01))
                .accessible_name(format!("Split {name}"))
                .on_hover_text(tip);
        }
    });
    form.messages(
        ui,
        &[
            "output.split",
            "output.split.train",
            "output.split.val",
            "output.split.test",
        ],
    );
}

/// Box method, size and visibility filters, what happens to filtered drones, id pass scale.
fn boxes_ui(ui: &mut Ui, preset: &mut Preset, form: &mut Form<'_>) {
    ui.horizontal(|ui| {
        ui.label("Boxes")
            .on_hover_text("How each drone's 2D box is computed");
        let l = &mut preset.labels;
        ui.radio_value(&mut l.box_method, BoxMethod::Visible, "Visible")
            .on_hover_text(
                "Min/max of the drone's visible pixels (instance-id pass): occlusion-aware",
            );
        ui.radio_value(&mut l.box_method, BoxMethod::Amodal, "Amodal")
            .on_hover_text("Tight box of the projected convex hull");
        ui.radio_value(&mut l.box_method, BoxMethod::PaperAabb, "Paper AABB")
            .on_hover_text("The paper's box: projected corners of the world AABB");
    });
    number_row(
        ui,
        &mut preset.labels.min_box_px,
        "Min box",
        "Boxes narrower or shorter than this many pixels are dropped",
        0.1,
    );
    form.messages(ui, &["labels.min_box_px"]);
    ui.horizontal(|ui| {
        let label = ui
            .label("Min visible px")
            .on_hover_text("Drones with fewer visible pixels are filtered (0: off)");
        ui.add(egui::DragValue::new(&mut preset.labels.min_visible_pixels).range(0..=1_000_000))
            .labelled_by(label.id)
            .on_hover_text("Drones with fewer visible pixels are filtered (0: off)");
    });
    number_row(
        ui,
        &mut preset.labels.min_visible_fraction,
        "Min visible fraction",
        "Drones less visible than this (visible / unoccluded pixels) are filtered (0: off)",
        0.01,
    );
    form.messages(ui, &["labels.min_visible_fraction"]);
    ui.horizontal(|ui| {
        ui.label("Filtered drones")
            .on_hover_text("Drop them, or keep them in COCO as iscrowd ignore regions");
        let l = &mut preset.labels;
        ui.radio_value(&mut l.filtered, crate::preset::FilteredDrones::Drop, "Drop")
            .on_hover_text("Filtered drones are written nowhere (the manifest still lists them)");
        ui.radio_value(
            &mut l.filtered,
            crate::preset::FilteredDrones::Crowd,
            "COCO crowd",
        )
        .on_hover_text("Filtered drones become COCO iscrowd: 1 regions that trainers ignore");
    });
    ui.horizontal(|ui| {
        ui.label("Id pass scale")
            .on_hover_text("Resolution factor of the instance-id pass: 2 or 4 give sub-pixel visible boxes (cost × scale²)");
        let l = &mut preset.labels;
        for k in [1, 2, 4] {
            ui.radio_value(&mut l.id_scale, k, format!("{k}×"))
                .on_hover_text("Resolution factor of the instance-id pass");
        }
    });
    form.messages(ui, &["labels.id_scale"]);
}

/// Where Generate writes, and whether it may replace another dataset there.
fn folder_ui(ui: &mut Ui, out_dir: &mut String, overwrite: &mut bool, commands: &mut Vec<Command>) {
    // Generate opens the folder as typed, so a relative one is taken from the working directory.
    let tip = match std::env::current_dir() {
        Ok(cwd) => format!(
            "Where Generate writes the dataset. A relative path is relative to the folder swarmshot was started in: {}",
            cwd.display()
        ),
        Err(_) => "Where Generate writes the dataset. A relative path is relative to the folder swarmshot was started in".to_string(),
    };
    ui.horizontal(|ui| {
        let label = ui.label("Output folder").on_hover_text(&tip);
        ui.add(egui::TextEdit::singleline(out_dir).desired_width(180.0))
            .labelled_by(label.id)
            .on_hover_text(&tip);
        if ui
            .button("Browse…")
            .on_hover_text("Choose the output folder")
            .clicked()
        {
            commands.push(Command::BrowseOutDir);
        }
    });
    ui.checkbox(overwrite, "Overwrite an existing dataset")
        .on_hover_text("Replace a dataset of another preset in a non-empty output folder");
}
