//! The preview pane: the frame slider with play controls, the sweep line,
//! the view toggles, the picture with its boxes or inspect overlay, and the
//! message shown over it when the preview is paused or failed.

use egui::{Color32, Pos2, Rect, RichText, Sense, Stroke, Ui, Vec2};
use glam::DVec3;

use super::panels::{format_to_step, group_digits};
use super::preview::{Orbit, PreviewFrame};
use super::{SwarmshotApp, problems};
use crate::preset::Preset;

impl SwarmshotApp {
    /// The frame bar, the sweep line, the view toggles, then the picture.
    pub(super) fn preview_ui(&mut self, ui: &mut Ui) {
        self.frame_bar_ui(ui);
        let sweep_line = self
            .preview
            .as_ref()
            .filter(|p| p.key.frame == self.session.frame && p.key.generation == self.generation)
            .map(|p| sweep_line(p, &self.resolved));
        ui.label(sweep_line.unwrap_or_else(|| " ".into()));
        self.view_toggles_ui(ui);
        if let Some(rect) = self.picture_ui(ui) {
            self.paused_message_ui(ui, rect);
        }
    }

    /// Play controls, "frame N of M", the sequence step and the frame slider.
    fn frame_bar_ui(&mut self, ui: &mut Ui) {
        let frames = self.resolved.frame_count();
        // Wrapped rows: in a narrow pane they take two lines, never run past its edge.
        ui.horizontal_wrapped(|ui| {
            if frames > 1 {
                self.play_controls_ui(ui, frames);
            }
            ui.label(format!(
                "frame {} of {}",
                group_digits(self.session.frame + 1),
                group_digits(frames)
            ));
            // Sequence mode: scrubbing moves the swarm; say where in its sequence the frame is.
            if let Some(seq) = crate::scene::SequenceFrame::of(&self.resolved, self.session.frame) {
                ui.label(format!(
                    "· sequence {} · step {} of {}",
                    group_digits(seq.id + 1),
                    group_digits(seq.step + 1),
                    group_digits(seq.steps + 1)
                ))
                .on_hover_text(format!(
                    "Counted from 1, as frames are. Each sweep point is a sequence of T + 1 = {} frames; the files number its steps t = 0..=T (this is t = {})",
                    seq.steps + 1,
                    seq.step
                ));
            }
            if frames > 1 {
                let max = frames - 1;
                // What is left of this row (`available_width` is a whole row's in a
                // wrapped layout); too little, and the slider takes a row of its own.
                if ui.available_size_before_wrap().x < 140.0 {
                    ui.end_row();
                }
                ui.spacing_mut().slider_width =
                    (ui.available_size_before_wrap().x - 24.0).max(40.0);
                let slider = ui
                    .add_enabled(
                        self.errors.is_empty(),
                        egui::Slider::new(&mut self.session.frame, 0..=max).show_value(false),
                    )
                    .accessible_name("Frame")
                    .on_hover_text(
                        "Scrub through the sweep: every frame the batch will make (Left and Right arrow keys, Home, End)",
                    );
                self.frame_slider = Some(slider.id);
            }
        });
    }

    /// Boxes (with their legend), Through the camera, Inspect and its Reset view.
    fn view_toggles_ui(&mut self, ui: &mut Ui) {
        ui.horizontal_wrapped(|ui| {
            // Each label whole, on the next row when it does not fit on this one.
            ui.style_mut().wrap_mode = Some(egui::TextWrapMode::Extend);
            ui.checkbox(&mut self.session.show_boxes, "Boxes")
                .on_hover_text("Draw the label boxes this frame gets");
            if self.session.show_boxes && !self.session.inspect {
                box_legend_ui(ui, &self.resolved.classes().0);
            }
            if !self.session.inspect {
                if self.resolved.camera_model.is_some() {
                    let mut through = !self.session.clean_preview;
                    if ui
                        .checkbox(&mut through, "Through the camera")
                        .on_hover_text(
                            "The frame through the camera model (exposure, noise, blur, JPEG, …) as the batch writes it, scaled to the pane; off: the clean render",
                        )
                        .changed()
                    {
                        self.session.clean_preview = !through;
                    }
                } else {
                    ui.weak("clean render: no camera model").on_hover_text(
                        "The preset has no camera model (Camera model section): its frames are written as rendered, as shown",
                    );
                }
            }
            if !self.session.inspect {
                self.zoom_buttons_ui(ui);
            }
            ui.checkbox(&mut self.session.inspect, "Inspect")
                .on_hover_text(
                    "Orbit around the scene: volume, drones and the sweep's camera positions",
                );
            if self.session.inspect {
                if ui
                    .button("Reset view")
                    .on_hover_text("Back to the default orbit")
                    .clicked()
                {
                    self.session.orbit = Orbit::default();
                }
                ui.weak("drag to orbit, scroll to zoom");
            }
        });
        self.masks_toggle_ui(ui);
    }

    /// The picture scaled to the pane with its overlay, and the inspect orbit's
    /// drag and zoom; where it was drawn (None: the pane is too small).
    fn picture_ui(&mut self, ui: &mut Ui) -> Option<Rect> {
        let (out_w, out_h) = self.resolved.image_size();
        let aspect = out_w.max(1) as f32 / out_h.max(1) as f32;
        let avail = ui.available_size();
        let mut size = Vec2::new(avail.x, avail.x / aspect);
        if size.y > avail.y {
            size = Vec2::new(avail.y * aspect, avail.y);
        }
        let ppp = ui.ctx().pixels_per_point();
        // Zoomed in, the picture is rendered larger (up to the output's own size), so
        // the pixels shown are the frame's, not the pane-sized picture's blown up.
        let view = if self.session.inspect {
            PaneView::default()
        } else {
            self.pane_view
        };
        let scale = ((size.x * ppp * view.zoom) / out_w.max(1) as f32).min(1.0);
        self.preview_size_px = [
            ((out_w as f32 * scale).round() as u32).max(1),
            ((out_h as f32 * scale).round() as u32).max(1),
        ];
        if size.x < 8.0 || size.y < 8.0 {
            self.preview_size_px = [0, 0];
            return None;
        }
        let (rect, response) = ui.allocate_exact_size(size, Sense::click_and_drag());
        self.preview_rect = Some(rect);
        if !self.session.inspect {
            self.zoom_and_pan(ui, &response, rect, out_w);
        }
        let view = if self.session.inspect {
            PaneView::default()
        } else {
            self.pane_view
        };
        self.pixel_scale = Some(rect.width() * ppp * view.zoom / out_w.max(1) as f32);
        let part = view.part();
        let painter = ui.painter_at(rect);
        let tint = if self.errors.is_empty() {
            Color32::WHITE
        } else {
            Color32::from_gray(90)
        };
        // The picture covers the pane: the dark fill only where it is not shown.
        let under = painter.add(egui::Shape::Noop);
        let masked = self.paint_masks(ui.ctx(), &painter, rect, part);
        let picture = (self.preview.as_ref().zip(self.flat.as_ref()))
            .and_then(|(_, flat)| flat.picture_part(rect, tint, part))
            .filter(|_| !masked);
        if picture.is_none() {
            painter.set(
                under,
                egui::Shape::rect_filled(rect, 0.0, Color32::from_gray(20)),
            );
        }
        if let Some(frame) = &self.preview {
            if let Some(picture) = picture {
                painter.add(picture);
            }
            match &frame.inspect {
                None if self.session.show_boxes => {
                    let classes = self.resolved.classes().0;
                    let (w, h) = (out_w as f32, out_h as f32);
                    let to_screen = |x: f64, y: f64| {
                        let n = Vec2::new(x as f32 / w, y as f32 / h);
                        rect.min + (n - part.min.to_vec2()) / part.size() * rect.size()
                    };
                    draw_boxes(&painter, frame, &classes, to_screen);
                }
                None => {}
                Some(_) => draw_inspect(&painter, rect, frame),
            }
        }
        if self.session.inspect {
            if response.dragged() {
                let d = response.drag_delta();
                let orbit = &mut self.session.orbit;
                orbit.yaw_deg -= f64::from(d.x) * 0.4;
                orbit.pitch_deg = (orbit.pitch_deg + f64::from(d.y) * 0.4).clamp(-89.0, 89.0);
            }
            if response.hovered() {
                let scroll = ui.input(|i| i.smooth_scroll_delta.y);
                if scroll != 0.0 {
                    self.session.orbit.zoom = (self.session.orbit.zoom
                        * (-f64::from(scroll) * 0.002).exp())
                    .clamp(0.02, 10.0);
                }
            }
        }
        Some(rect)
    }

    /// The wheel zooms about the pointer, a drag pans, a double click fits the frame.
    fn zoom_and_pan(&mut self, ui: &Ui, response: &egui::Response, rect: Rect, out_w: u32) {
        let ppp = ui.ctx().pixels_per_point();
        let max = self.max_zoom(rect, ppp, out_w);
        let view = &mut self.pane_view;
        if response.hovered() {
            let scroll = ui.input(|i| i.smooth_scroll_delta.y);
            if scroll != 0.0
                && let Some(at) = response.hover_pos()
            {
                view.zoom_at(rect, at, (scroll * 0.003).exp(), max);
            }
        }
        if response.dragged() && view.zoom > 1.0 {
            view.pan(rect, response.drag_delta());
        }
        if response.double_clicked() {
            *view = PaneView::default();
        }
        view.zoom = view.zoom.min(max);
        view.clamp();
    }

    /// The largest zoom: 8 screen pixels an output pixel (at least the whole frame).
    fn max_zoom(&self, rect: Rect, ppp: f32, out_w: u32) -> f32 {
        (8.0 * out_w as f32 / (rect.width() * ppp).max(1.0)).max(1.0)
    }

    /// Zoom, the 1:1 button and Fit, beside the view toggles (not in Inspect).
    fn zoom_buttons_ui(&mut self, ui: &mut Ui) {
        let (Some(rect), Some(scale)) = (self.preview_rect, self.pixel_scale) else {
            return;
        };
        let (out_w, _) = self.resolved.image_size();
        let ppp = ui.ctx().pixels_per_point();
        ui.label(format!("{:.0} %", scale * 100.0)).on_hover_text(
            "Screen pixels per pixel of the frame: wheel over the picture to zoom, drag to pan, double-click to fit",
        );
        if ui
            .button("1:1")
            .on_hover_text("One screen pixel for each pixel of the frame, about the centre")
            .clicked()
        {
            let centre = rect.center();
            let factor = (1.0 / scale).max(1.0 / self.pane_view.zoom);
            let max = self.max_zoom(rect, ppp, out_w);
            self.pane_view.zoom_at(rect, centre, factor, max);
        }
        if ui
            .add_enabled(self.pane_view.zoom > 1.0, egui::Button::new("Fit"))
            .on_hover_text("The whole frame in the pane (double-click the picture)")
            .clicked()
        {
            self.pane_view = PaneView::default();
        }
    }

    /// Why the picture is paused or failed, over the picture.
    fn paused_message_ui(&self, ui: &mut Ui, rect: Rect) {
        let message = if !self.errors.is_empty() {
            let first = &self.errors[0];
            Some(format!(
                "Preview paused: {}, first {} ({}). See Problems on the right.",
                problems::count_problems(self.errors.len()),
                crate::preset::fields::label_of(&first.field),
                first.message
            ))
        } else {
            self.preview_error
                .as_ref()
                .map(|e| format!("Preview failed: {}", e.message))
        };
        if let Some(message) = message {
            let colour = ui.visuals().error_fg_color;
            let area = Rect::from_center_size(rect.center(), Vec2::new(rect.width() * 0.9, 60.0));
            ui.put(
                area,
                egui::Label::new(
                    RichText::new(message)
                        .size(16.0)
                        .color(colour)
                        .background_color(Color32::from_black_alpha(160)),
                ),
            );
        }
    }
    /// Play / Pause and Loop, left of the frame counter.
    pub(super) fn play_controls_ui(&mut self, ui: &mut Ui, frames: u64) {
        let speed = match self.play_rate_hz() {
            Some(rate) => format!(
                "at the sequence's {rate} frames/s; frames are skipped when the preview is slower"
            ),
            None => "as fast as the preview renders them".into(),
        };
        let enabled = self.errors.is_empty();
        if self.playback.is_playing() {
            if ui
                .button("Pause")
                .on_hover_text("Stop playing at this frame")
                .clicked()
            {
                self.playback.pause();
            }
        } else if ui
            .add_enabled(enabled, egui::Button::new("Play"))
            .on_hover_text(format!("Play the frames {speed}"))
            .clicked()
        {
            self.session.frame = self.playback.play(self.session.frame, frames);
        }
        ui.checkbox(&mut self.playback.looping, "Loop")
            .on_hover_text("Start again from the first frame after the last");
    }
}

/// "CameraX 0 · … · CameraZ 1.2 · … · 14 drones, 14 boxes", values to their step's precision.
fn sweep_line(frame: &PreviewFrame, preset: &Preset) -> String {
    let s = &frame.scene.sweep;
    let (c, p) = (&preset.camera, &preset.plane);
    format!(
        "CameraX {} · CameraY {} · CameraZ {} · PlaneRX {}° · PlaneRY {}° · PlaneRZ {}° · repeat {} of {} · {} split · {} drones, {} boxes",
        format_to_step(s.CameraX, &c.x),
        format_to_step(s.CameraY, &c.y),
        format_to_step(s.CameraZ, &c.z),
        format_to_step(s.PlaneRX, &p.rx),
        format_to_step(s.PlaneRY, &p.ry),
        format_to_step(s.PlaneRZ, &p.rz),
        // Counted from 1 like frames (the manifest's `repeat` is 0-based).
        s.repeat + 1,
        preset.repeats,
        frame.scene.split.as_str(),
        frame.scene.drones.len(),
        frame.labels.iter().filter(|l| l.is_kept()).count()
    )
}

/// Training boxes take their class's colour (the first class red), COCO crowd regions
/// amber and unlabelled hard negatives cyan, as [`draw_boxes`] draws them.
const CLASS_COLOURS: [Color32; 6] = [
    Color32::from_rgb(255, 60, 60),
    Color32::from_rgb(90, 230, 90),
    Color32::from_rgb(235, 90, 235),
    Color32::from_rgb(240, 240, 70),
    Color32::from_rgb(120, 150, 255),
    Color32::from_rgb(240, 240, 240),
];
const BOX_CROWD: Color32 = Color32::from_rgb(255, 190, 40);
const BOX_NEGATIVE: Color32 = Color32::from_rgb(60, 200, 255);

fn class_colour(class: usize) -> Color32 {
    CLASS_COLOURS[class % CLASS_COLOURS.len()]
}

/// The preview's zoom and pan: the part of the frame the pane shows.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PaneView {
    /// 1: the whole frame fits the pane; 2: half its width and height fill it.
    pub zoom: f32,
    /// The top-left of the part shown, in 0..1 of the frame's width and height.
    pub origin: Vec2,
}

impl Default for PaneView {
    fn default() -> Self {
        Self {
            zoom: 1.0,
            origin: Vec2::ZERO,
        }
    }
}

impl PaneView {
    /// The part of the frame shown, in 0..1 of its width and height.
    pub fn part(&self) -> Rect {
        Rect::from_min_size(self.origin.to_pos2(), Vec2::splat(1.0 / self.zoom))
    }

    /// Zoom by `factor` keeping the frame's point under `at` (a screen point in `rect`) there.
    fn zoom_at(&mut self, rect: Rect, at: Pos2, factor: f32, max: f32) {
        let t = (at - rect.min) / rect.size();
        let under = self.origin + t / self.zoom;
        self.zoom = (self.zoom * factor).clamp(1.0, max.max(1.0));
        self.origin = under - t / self.zoom;
        self.clamp();
    }

    /// Move the picture with the pointer by `delta` screen points.
    fn pan(&mut self, rect: Rect, delta: Vec2) {
        self.origin -= delta / rect.size() / self.zoom;
        self.clamp();
    }

    /// Keep the part shown inside the frame.
    fn clamp(&mut self) {
        let max = 1.0 - 1.0 / self.zoom;
        self.origin = Vec2::new(self.origin.x.clamp(0.0, max), self.origin.y.clamp(0.0, max));
    }
}

fn box_legend_ui(ui: &mut Ui, classes: &[String]) {
    // Painted swatches: the default fonts have no "■". Each with its words, as one
    // piece that a narrow pane moves to the next row whole. The words take their
    // box's colour, as the class names over the boxes do: in the label colour they
    // read as greyed out beside the checkboxes.
    let entry = |ui: &mut Ui, colour: Color32, words: &str, tip: &str| {
        let galley = egui::WidgetText::from(RichText::new(words).color(colour)).into_galley(
            ui,
            Some(egui::TextWrapMode::Extend),
            f32::INFINITY,
            egui::TextStyle::Body,
        );
        let width = 10.0 + 2.0 * ui.spacing().item_spacing.x + galley.size().x;
        if ui.available_size_before_wrap().x < width {
            ui.end_row();
        }
        let (rect, response) = ui.allocate_exact_size(Vec2::splat(10.0), Sense::hover());
        ui.painter().rect_stroke(
            rect,
            0.0,
            Stroke::new(2.0, colour),
            egui::StrokeKind::Inside,
        );
        response.on_hover_text(tip);
        ui.label(galley).on_hover_text(tip);
    };
    for (i, class) in classes.iter().enumerate() {
        entry(
            ui,
            class_colour(i),
            class,
            &format!("A box of class \"{class}\" written to the labels"),
        );
    }
    entry(
        ui,
        BOX_CROWD,
        "crowd region (ignored)",
        "A filtered drone kept as a COCO iscrowd region (Output panel, Filtered drones: COCO crowd); trainers ignore it",
    );
    entry(
        ui,
        BOX_NEGATIVE,
        "hard negative",
        "An unlabelled hard negative (Confusers panel): in the manifest only, never in YOLO/COCO",
    );
}

/// The label boxes, output pixels taken to the pane by `to_screen`; training boxes
/// with their class name.
fn draw_boxes(
    painter: &egui::Painter,
    frame: &PreviewFrame,
    classes: &[String],
    to_screen: impl Fn(f64, f64) -> Pos2,
) {
    let font = egui::FontId::proportional(11.0);
    for label in &frame.labels {
        let (colour, width, name) = match label.status {
            crate::annotate::LabelStatus::Kept => (
                class_colour(label.class_id),
                1.5,
                classes.get(label.class_id).map(String::as_str),
            ),
            crate::annotate::LabelStatus::Crowd => (BOX_CROWD, 1.0, None),
            crate::annotate::LabelStatus::Filtered => continue,
            crate::annotate::LabelStatus::Negative => (BOX_NEGATIVE, 1.0, None),
        };
        let b = &label.bbox;
        let r = Rect::from_min_max(to_screen(b.x0, b.y0), to_screen(b.x1, b.y1));
        painter.rect_stroke(
            r.expand(1.0),
            0.0,
            Stroke::new(width, colour),
            egui::StrokeKind::Outside,
        );
        if let Some(name) = name {
            painter.text(
                r.left_top() + Vec2::new(-1.0, -3.0),
                egui::Align2::LEFT_BOTTOM,
                name,
                font.clone(),
                colour,
            );
        }
    }
}

/// The inspect view's overlay: volume box, sweep camera positions, this frame's camera.
fn draw_inspect(painter: &egui::Painter, rect: Rect, frame: &PreviewFrame) {
    let Some(geometry) = &frame.inspect else {
        return;
    };
    let camera = &frame.camera;
    let scale = rect.width() / camera.width.max(1) as f32;
    let to_screen = |p: DVec3| -> Option<Pos2> {
        let pc = camera.camera_from_world_point(p);
        if pc.z < camera.near_m {
            return None;
        }
        let uv = camera.project_camera_point(pc)?;
        Some(rect.min + Vec2::new(uv.x as f32, uv.y as f32) * scale)
    };
    let volume = Stroke::new(1.0, Color32::from_rgb(230, 230, 230));
    let corners = &geometry.volume_corners;
    for i in 0..8 {
        for bit in [1, 2, 4] {
            let j = i | bit;
            if j != i
                && let (Some(a), Some(b)) = (to_screen(corners[i]), to_screen(corners[j]))
            {
                painter.line_segment([a, b], volume);
            }
        }
    }
    for p in &geometry.sweep_cameras {
        if let Some(s) = to_screen(*p) {
            painter.circle_filled(s, 2.5, Color32::from_rgb(255, 210, 60));
        }
    }
    if let (Some(cam), Some(centre)) = (to_screen(geometry.frame_camera), to_screen(DVec3::ZERO)) {
        painter.line_segment(
            [cam, centre],
            Stroke::new(1.0, Color32::from_rgb(255, 80, 80)),
        );
        painter.circle_filled(cam, 5.0, Color32::from_rgb(255, 80, 80));
    }
    let legend = format!(
        "white: observation volume · yellow: {} {} · red: this frame's camera",
        group_digits(geometry.sweep_cameras_total),
        if geometry.sweep_cameras_total == 1 {
            "sweep camera position"
        } else {
            "sweep camera positions"
        }
    );
    painter.text(
        rect.left_bottom() + Vec2::new(6.0, -6.0),
        egui::Align2::LEFT_BOTTOM,
        legend,
        egui::FontId::proportional(12.0),
        Color32::WHITE,
    );
}
