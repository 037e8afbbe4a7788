//! The window's layout: the menu bar, the status bar, the parameter sections
//! on the left and the Summary, Problems and Batch panels on the right.

use egui::{RichText, Ui};

use super::panels::{self, Form, error_label, group_digits};
use super::{
    APP_NAME, Command, Session, SwarmshotApp, backplate_panel, clutter_panel, confuser_panel,
    example_description, example_presets, problems, realism_panels, thermal_panel, weather_panel,
};

/// The most messages the top bar shows (the newest).
const MAX_NOTICES: usize = 6;

impl SwarmshotApp {
    pub(super) fn menu_ui(&mut self, ui: &mut Ui, commands: &mut Vec<Command>) {
        let locked = self.batch.is_some();
        // Wrapped: a narrow window puts the rest of the bar on a second line.
        ui.horizontal_wrapped(|ui| {
            ui.strong(APP_NAME);
            ui.separator();
            ui.add_enabled_ui(!locked, |ui| {
                if ui
                    .button("New")
                    .on_hover_text("Start from the default preset (Ctrl+N)")
                    .clicked()
                {
                    commands.push(Command::New);
                }
                if ui
                    .button("Open…")
                    .on_hover_text("Open a .ron preset (Ctrl+O)")
                    .clicked()
                {
                    commands.push(Command::Open);
                }
                examples_menu(ui, commands);
            });
            if ui
                .button("Save")
                .on_hover_text("Save the preset to its file (Ctrl+S)")
                .clicked()
            {
                commands.push(Command::Save);
            }
            if ui
                .button("Save As…")
                .on_hover_text("Save the preset to a new file (Ctrl+Shift+S)")
                .clicked()
            {
                commands.push(Command::SaveAs);
            }
            ui.add_enabled_ui(!locked, |ui| {
                let preset = &self.session.preset;
                if ui
                    .add_enabled(self.history.can_undo(preset), egui::Button::new("Undo"))
                    .on_hover_text("Undo the last preset edit (Ctrl+Z)")
                    .clicked()
                {
                    commands.push(Command::Undo);
                }
                if ui
                    .add_enabled(self.history.can_redo(preset), egui::Button::new("Redo"))
                    .on_hover_text("Redo what Undo took back (Ctrl+Shift+Z)")
                    .clicked()
                {
                    commands.push(Command::Redo);
                }
            });
            ui.separator();
            ui.toggle_value(&mut self.session.show_parameters, "Parameters")
                .on_hover_text("Show or hide the parameter panel");
            ui.toggle_value(&mut self.session.show_summary, "Summary")
                .on_hover_text("Show or hide the Summary and Batch panel");
            ui.toggle_value(&mut self.gap.open, "Domain gap")
                .on_hover_text("Compare real frames with this preset's frames (swarmshot gap)");
            ui.toggle_value(&mut self.fit.open, "Fit to footage")
                .on_hover_text("Fit a preset to your own footage (swarmshot fit)");
            ui.separator();
            let (file, full) = match &self.session.preset_path {
                Some(p) => (
                    p.file_name().map_or_else(
                        || p.display().to_string(),
                        |f| f.to_string_lossy().into_owned(),
                    ),
                    p.display().to_string(),
                ),
                None => ("not saved".into(), "this preset has no file yet".into()),
            };
            ui.label(format!("{} ({file})", self.session.preset.name))
                .on_hover_text(full);
            if self.session.is_dirty() {
                ui.label(RichText::new("• unsaved changes").color(ui.visuals().warn_fg_color));
            }
        });
        // The same message again (a held Ctrl+S on a read-only file) is shown once, and
        // only the newest few: the top bar never grows past the window.
        self.notices.dedup();
        let old = self.notices.len().saturating_sub(MAX_NOTICES);
        self.notices.drain(..old);
        let mut dismiss = None;
        for (i, notice) in self.notices.iter().enumerate() {
            ui.horizontal(|ui| {
                error_label(ui, notice);
                if ui
                    .small_button("Dismiss")
                    .on_hover_text("Hide this message")
                    .clicked()
                {
                    dismiss = Some(i);
                }
            });
        }
        if let Some(i) = dismiss {
            self.notices.remove(i);
        }
    }

    pub(super) fn parameters_ui(&mut self, ui: &mut Ui, commands: &mut Vec<Command>) {
        let errors = self.errors.clone();
        let scroll_to = self.scroll_to.clone();
        let open_section = scroll_to
            .as_deref()
            .and_then(crate::preset::fields::section_of);
        let mut form = Form::new(&errors, scroll_to.as_deref());
        let load_error = self
            .preview_error
            .as_ref()
            .filter(|e| e.models)
            .map(|e| e.message.clone());
        panels::general_ui(ui, &mut self.session.preset, &mut form);
        sections_ui(
            ui,
            &mut self.session,
            &mut form,
            open_section,
            load_error.as_deref(),
            commands,
        );
        form.rest(ui);
        let wanted = self.scroll_to.as_deref();
        if form.scrolled() || !errors.iter().any(|e| Some(e.field.as_str()) == wanted) {
            self.scroll_to = None;
        }
    }

    pub(super) fn summary_ui(&mut self, ui: &mut Ui) {
        ui.heading("Summary");
        let frames = self.resolved.frame_count();
        ui.label(format!("Frames: {}", group_digits(frames)));
        if !self.errors.is_empty() {
            ui.weak("paused until the problems below are fixed");
            return;
        }
        match &self.summary {
            None => {
                ui.weak("estimating…");
            }
            Some(Err(e)) => {
                error_label(ui, &e.to_string());
            }
            Some(Ok(s)) => {
                let drones = if s.drones_min == s.drones_max {
                    format!("{}", s.drones_min)
                } else {
                    format!(
                        "{}–{} (mean {:.1})",
                        s.drones_min,
                        s.drones_max,
                        s.drones_mean()
                    )
                };
                ui.label(format!("Drones per frame: {drones}"));
                let [small, medium, large] = s.size_shares().map(|x| x * 100.0);
                ui.label(format!(
                    "Boxes per frame: {:.1}",
                    s.stats.boxes as f64 / s.sampled_frames.max(1) as f64
                ));
                confuser_panel::summary_classes_ui(ui, &s.stats, s.sampled_frames);
                ui.label(format!(
                    "Small {small:.0}% · medium {medium:.0}% · large {large:.0}%"
                ))
                .on_hover_text("Share of boxes with √(w·h) < 32 px, 32–96 px and > 96 px");
                ui.weak(format!(
                    "estimated from the geometry of {} sampled frames",
                    s.sampled_frames
                ));
                if s.generation != self.generation {
                    ui.weak("updating…");
                }
            }
        }
    }

    pub(super) fn status_ui(&self, ui: &mut Ui) {
        ui.horizontal_wrapped(|ui| {
            match &self.preview {
                Some(p) => {
                    let [w, h] = p.key.size_px;
                    ui.label(format!("preview {:.1} ms at {w}×{h}", p.render_ms))
                        .on_hover_text("Last preview render: frame build + encode + GPU");
                    if let (Some(last), Some((median, n))) =
                        (self.latency.last_ms(), self.latency.median_ms())
                    {
                        ui.label(format!("on screen {last:.0} ms (median {median:.0} ms of {n})"))
                            .on_hover_text(
                                "From the change (an edit taken, another frame, a resize) to its picture on screen: render, hand-over and the window's own paint",
                            );
                    }
                }
                None => {
                    ui.label("no preview yet");
                }
            }
            if !self.picture_is_current() && self.errors.is_empty() {
                // Words, not a spinner: a spinner repaints the whole window every
                // pass, which on a CPU renderer slows the render it waits for.
                ui.weak("rendering…");
            }
            if let Some((ctx, _)) = &self.gpu {
                ui.weak(ctx.describe());
            }
            if !self.errors.is_empty() {
                ui.label(
                    RichText::new(problems::count_problems(self.errors.len()))
                        .color(ui.visuals().error_fg_color),
                );
            }
        });
    }

    /// The panels: menu, status, the collapsible parameters and summary, the preview.
    pub(super) fn panels_ui(&mut self, ui: &mut Ui, commands: &mut Vec<Command>) {
        let locked = self.batch.is_some();
        // With the window's background painted flat (see `flat_paint`), the
        // panels are drawn without a fill of their own.
        let (side, central) = match &self.flat {
            Some(flat) => {
                let fill = ui.visuals().panel_fill;
                ui.painter()
                    .add(flat.background(ui.ctx().content_rect(), fill));
                let clear = |f: egui::Frame| f.fill(egui::Color32::TRANSPARENT);
                (
                    clear(egui::Frame::side_top_panel(ui.style())),
                    clear(egui::Frame::central_panel(ui.style())),
                )
            }
            None => (
                egui::Frame::side_top_panel(ui.style()),
                egui::Frame::central_panel(ui.style()),
            ),
        };
        egui::Panel::top("menu")
            .frame(side)
            .show(ui, |ui| self.menu_ui(ui, commands));
        egui::Panel::bottom("status")
            .frame(side)
            .show(ui, |ui| self.status_ui(ui));
        // The side panels take at most their share of the window's width, so the
        // preview keeps room at 800 points; what does not fit in them scrolls.
        let width = ui.ctx().content_rect().width();
        let mut show_parameters = self.session.show_parameters;
        egui::Panel::left("parameters")
            .frame(side)
            .resizable(true)
            .default_size(430.0)
            .max_size((width * 0.33).max(200.0))
            .show_collapsible(ui, &mut show_parameters, |ui| {
                egui::ScrollArea::both().show(ui, |ui| {
                    ui.add_enabled_ui(!locked, |ui| self.parameters_ui(ui, commands));
                });
            });
        self.session.show_parameters = show_parameters;
        let mut show_summary = self.session.show_summary;
        egui::Panel::right("summary")
            .frame(side)
            .resizable(true)
            .default_size(250.0)
            .max_size((width * 0.24).max(160.0))
            .show_collapsible(ui, &mut show_summary, |ui| {
                egui::ScrollArea::both().show(ui, |ui| {
                    self.summary_ui(ui);
                    ui.separator();
                    if let Some(field) = problems::problems_ui(ui, &self.errors) {
                        commands.push(Command::ShowProblem(field));
                    }
                    if !self.errors.is_empty() {
                        ui.separator();
                    }
                    self.batch_ui(ui, commands);
                });
            });
        self.session.show_summary = show_summary;
        let central = egui::CentralPanel::default()
            .frame(central)
            .show(ui, |ui| self.preview_ui(ui));
        self.central_rect = Some(central.response.rect);
    }
}

/// Whether each optional stage is on, for its section's header: "on", "off", or a count.
pub fn stage_status(p: &crate::preset::Preset) -> Vec<(&'static str, String)> {
    let on = |b: bool| if b { "on" } else { "off" }.to_string();
    vec![
        ("Camera model", on(p.camera_model.is_some())),
        (
            "Lens distortion",
            on(p.camera_model.as_ref().is_some_and(|c| c.lens.is_some())),
        ),
        ("Thermal camera", on(p.thermal.is_some())),
        ("Atmosphere", on(p.atmosphere.is_some())),
        ("Drone appearance", on(p.appearance.is_some())),
        ("Clutter", on(p.clutter.is_some())),
        (
            "Confusers",
            match p.confusers.len() {
                0 => "off".into(),
                1 => "1 kind".into(),
                n => format!("{n} kinds"),
            },
        ),
        ("Backplates", on(p.backplate.is_some())),
        ("Weather", on(p.weather.is_some())),
    ]
}

/// What a section's panel edits, and what it may report or ask for.
struct PanelCtx<'a, 'f> {
    preset: &'a mut crate::preset::Preset,
    form: &'a mut Form<'f>,
    load_error: Option<&'a str>,
    commands: &'a mut Vec<Command>,
}

/// One collapsible parameter section: its title, hover tip and panel.
struct Section {
    title: &'static str,
    tip: &'static str,
    panel: fn(&mut Ui, &mut PanelCtx<'_, '_>),
}

/// The collapsible parameter sections, in the order of the paper's panels
/// and then the realism stages.
const SECTIONS: [Section; 16] = [
    Section {
        title: "Models",
        tip: "The UAV models instantiated in every frame, with their real size",
        panel: |ui, c| panels::models_ui(ui, c.preset, c.form, c.load_error, c.commands),
    },
    Section {
        title: "Placement",
        tip: "How drones are placed in the observation volume",
        panel: |ui, c| panels::placement_ui(ui, c.preset, c.form),
    },
    Section {
        title: "Attitude",
        tip: "Random roll/pitch/yaw of each drone",
        panel: |ui, c| panels::attitude_ui(ui, c.preset, c.form),
    },
    Section {
        title: "Camera",
        tip: "Camera translation sweeps; the camera always faces the volume's centre",
        panel: |ui, c| {
            panels::camera_ui(ui, c.preset, c.form);
            realism_panels::observer_ui(ui, c.preset, c.form);
        },
    },
    Section {
        title: "Scene rotation",
        tip: "Rotation sweeps of the whole swarm",
        panel: |ui, c| panels::plane_ui(ui, c.preset, c.form),
    },
    Section {
        title: "Skybox",
        tip: "The background environment",
        panel: |ui, c| panels::skybox_ui(ui, c.preset, c.form),
    },
    Section {
        title: "Camera model",
        tip: "Optics, sensor noise and image processing between the render and the file",
        panel: |ui, c| realism_panels::camera_model_ui(ui, c.preset, c.form),
    },
    Section {
        title: "Lens distortion",
        tip: "Brown–Conrady or fisheye distortion of the picture and its labels",
        panel: |ui, c| super::lens_panel::lens_ui(ui, c.preset, c.form),
    },
    Section {
        title: "Thermal camera",
        tip: "Grey long-wave infrared frames: temperatures, sky, air, noise, blur, gain control",
        panel: |ui, c| thermal_panel::thermal_ui(ui, c.preset, c.form),
    },
    Section {
        title: "Atmosphere",
        tip: "Haze with range on every object",
        panel: |ui, c| realism_panels::atmosphere_ui(ui, c.preset, c.form),
    },
    Section {
        title: "Drone appearance",
        tip: "Drone materials drawn per drone: colour, roughness, metalness, lights",
        panel: |ui, c| realism_panels::appearance_ui(ui, c.preset, c.form),
    },
    Section {
        title: "Clutter",
        tip: "Tree lines, bare trees, poles and wires, buildings that hide the drones behind them",
        panel: |ui, c| clutter_panel::clutter_ui(ui, c.preset, c.form),
    },
    Section {
        title: "Confusers",
        tip: "Birds, aircraft and balloons in the frames: labelled as a class or hard negatives",
        panel: |ui, c| confuser_panel::confusers_ui(ui, c.preset, c.form),
    },
    Section {
        title: "Weather",
        tip: "Rain streaks or snow flakes in front of the camera that veil or hide the drones behind them",
        panel: |ui, c| weather_panel::weather_ui(ui, c.preset, c.form),
    },
    Section {
        title: "Backplates",
        tip: "Photographic backgrounds: a folder of your own frames of sky and horizon",
        panel: |ui, c| backplate_panel::backplate_ui(ui, c.preset, c.form, c.commands),
    },
    Section {
        title: "Output",
        tip: "Resolution, file formats, split, boxes and masks",
        panel: |ui, c| panels::output_ui(ui, c.preset, c.form),
    },
];

/// Every section of [`SECTIONS`]; `open_section` is opened (a Problems link).
fn sections_ui(
    ui: &mut Ui,
    s: &mut Session,
    form: &mut Form<'_>,
    open_section: Option<&str>,
    load_error: Option<&str>,
    commands: &mut Vec<Command>,
) {
    let status = stage_status(&s.preset);
    let mut ctx = PanelCtx {
        preset: &mut s.preset,
        form,
        load_error,
        commands,
    };
    for section in &SECTIONS {
        // A Problems link opens the section that holds its field.
        let open = (open_section == Some(section.title)).then_some(true);
        // The realism sections start collapsed (most presets leave them off).
        let default_open = !problems::COLLAPSED_SECTIONS.contains(&section.title);
        let header = egui::CollapsingHeader::new(section.title)
            .default_open(default_open)
            .open(open)
            .show(ui, |ui| (section.panel)(ui, &mut ctx))
            .header_response;
        if let Some((_, on)) = status.iter().find(|(t, _)| *t == section.title) {
            stage_badge(ui, &header, on);
        }
        header.on_hover_text(section.tip);
    }
}

/// An optional stage's state (`on`: "off", "on", a count) beside its
/// section's header, weak when off.
fn stage_badge(ui: &Ui, header: &egui::Response, on: &str) {
    let colour = if on == "off" {
        ui.visuals().weak_text_color()
    } else {
        ui.visuals().text_color()
    };
    ui.painter().text(
        header.rect.right_center() + egui::vec2(8.0, 0.0),
        egui::Align2::LEFT_CENTER,
        on,
        egui::TextStyle::Body.resolve(ui.style()),
        colour,
    );
}

/// The Examples menu: each preset in presets/ with the start of its comment.
fn examples_menu(ui: &mut Ui, commands: &mut Vec<Command>) {
    ui.menu_button("Examples", |ui| {
        let examples = example_presets();
        if examples.is_empty() {
            ui.label("no presets/ folder found");
        }
        for path in examples {
            let name = path
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_default();
            // Each with the start of its own comment, and all of it on hover.
            let about = example_description(&path);
            let tip = format!(
                "{}\n\nOpen a copy of {}; Save asks where to keep it",
                about.as_deref().unwrap_or(""),
                path.display()
            );
            ui.horizontal(|ui| {
                if ui.button(name).on_hover_text(&tip).clicked() {
                    commands.push(Command::OpenExample(path.clone()));
                }
                if let Some(about) = &about {
                    let short: String = about.chars().take(70).collect();
                    let more = if about.chars().count() > 70 {
                        "…"
                    } else {
                        ""
                    };
                    ui.weak(format!("{short}{more}")).on_hover_text(&tip);
                }
            });
        }
    })
    .response
    .on_hover_text("Open a copy of one of the example presets in presets/");
}
