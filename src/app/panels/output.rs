//! The Output section: resolution and MSAA, image and label formats, the
//! split, box method and filters, and the output folder.

use egui::{DragValue, Ui};

use super::{Form, field_row};
use crate::app::Command;
use crate::preset::{BoxMethod, ImageFormat, LabelFormat, Preset, Resolution, fields};

/// Output: resolution, MSAA, image and label formats, split, boxes, folder.
pub fn output_ui(ui: &mut Ui, preset: &mut Preset, form: &mut Form<'_>) {
    resolution_ui(ui, preset, form);
    file_formats_ui(ui, preset, form);
    split_ui(ui, preset, form);
    boxes_ui(ui, preset, form);
    masks_ui(ui, preset, form);
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
        .on_hover_text(fields::get("render.resolution").tooltip);
    if let Resolution::Custom { width, height } = &mut r.resolution {
        ui.horizontal(|ui| {
            ui.label("Size")
                .on_hover_text("Custom image size in pixels");
            for (value, path) in [
                (width, "render.resolution.width"),
                (height, "render.resolution.height"),
            ] {
                let f = fields::get(path);
                ui.add(DragValue::new(value).suffix(f.unit))
                    .accessible_name(f.label)
                    .on_hover_text(f.tooltip);
            }
        });
    }
    form.messages(ui, &["render.resolution.width", "render.resolution.height"]);
    ui.horizontal(|ui| {
        let msaa = fields::get("render.msaa");
        ui.label(msaa.label).on_hover_text(msaa.tooltip);
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
        let images = fields::get("output.image_format");
        ui.label(images.label).on_hover_text(images.tooltip);
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
        let labels = fields::get("output.label_formats");
        ui.label(labels.label).on_hover_text(labels.tooltip);
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
        let split = fields::get("output.split");
        let tip = split.tooltip;
        ui.label(split.label).on_hover_text(tip);
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
        let boxes = fields::get("labels.box_method");
        ui.label(boxes.label).on_hover_text(boxes.tooltip);
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
    field_row(ui, &mut preset.labels.min_box_px, "labels.min_box_px", 0.1);
    form.messages(ui, &["labels.min_box_px"]);
    ui.horizontal(|ui| {
        let f = fields::get("labels.min_visible_pixels");
        let label = ui.label(f.label).on_hover_text(f.tooltip);
        ui.add(egui::DragValue::new(&mut preset.labels.min_visible_pixels).range(0..=1_000_000))
            .labelled_by(label.id)
            .on_hover_text(f.tooltip);
    });
    field_row(
        ui,
        &mut preset.labels.min_visible_fraction,
        "labels.min_visible_fraction",
        0.01,
    );
    form.messages(ui, &["labels.min_visible_fraction"]);
    ui.horizontal(|ui| {
        let filtered = fields::get("labels.filtered");
        ui.label(filtered.label).on_hover_text(filtered.tooltip);
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
        let id_scale = fields::get("labels.id_scale");
        ui.label(id_scale.label).on_hover_text(id_scale.tooltip);
        let l = &mut preset.labels;
        for k in [1, 2, 4] {
            ui.radio_value(&mut l.id_scale, k, format!("{k}×"))
                .on_hover_text("Resolution factor of the instance-id pass");
        }
    });
    form.messages(ui, &["labels.id_scale"]);
}

/// Masks and maps besides the boxes (`output.masks`): each one's checkbox, and the
/// depth map's unit while depth maps are on.
fn masks_ui(ui: &mut Ui, preset: &mut Preset, form: &mut Form<'_>) {
    let m = &mut preset.output.masks;
    let masks = fields::get("output.masks");
    ui.horizontal_wrapped(|ui| {
        ui.label(masks.label).on_hover_text(masks.tooltip);
        for (on, path) in [
            (&mut m.coco_rle, "output.masks.coco_rle"),
            (&mut m.yolo_seg, "output.masks.yolo_seg"),
            (&mut m.instance_png, "output.masks.instance_png"),
            (&mut m.flow, "output.masks.flow"),
        ] {
            let f = fields::get(path);
            ui.checkbox(on, f.label).on_hover_text(f.tooltip);
        }
        ui.checkbox(&mut m.depth, "Depth map").on_hover_text(
            "A 16-bit depth PNG per frame (depth/{split}/NAME.png): each drone pixel's camera depth",
        );
    });
    if m.depth {
        field_row(ui, &mut m.depth_unit_mm, "output.masks.depth_unit_mm", 1.0);
    }
    form.messages(
        ui,
        &[
            "output.masks",
            "output.masks.coco_rle",
            "output.masks.yolo_seg",
            "output.masks.instance_png",
            "output.masks.flow",
            "output.masks.depth_unit_mm",
        ],
    );
}

/// Where Generate writes, and whether it may replace another dataset there (the
/// Batch panel, beside Generate).
pub(in crate::app) fn folder_ui(
    ui: &mut Ui,
    out_dir: &mut String,
    overwrite: &mut bool,
    commands: &mut Vec<Command>,
) {
    // Generate opens the folder as typed, so a relative one is taken from the working directory.
    let tip = match std::env::current_dir() {
        Ok(cwd) => format!(
            "Where Generate writes the dataset. A relative path is relative to the folder swarmshot was started in: {}",
            cwd.display()
        ),
        Err(_) => "Where Generate writes the dataset. A relative path is relative to the folder swarmshot was started in".to_string(),
    };
    // The label above its field: the field and Browse… share the panel's width, so
    // Browse… stays in view in a panel of any width.
    let label = ui.label("Output folder").on_hover_text(&tip);
    ui.horizontal(|ui| {
        let browse = egui::Button::new("Browse…");
        let browse_width = 80.0;
        let width = (ui.available_width() - browse_width).max(60.0);
        ui.add(egui::TextEdit::singleline(out_dir).desired_width(width))
            .labelled_by(label.id)
            .on_hover_text(&tip);
        if ui
            .add(browse)
            .on_hover_text("Choose the output folder")
            .clicked()
        {
            commands.push(Command::BrowseOutDir);
        }
    });
    ui.checkbox(overwrite, "Overwrite an existing dataset")
        .on_hover_text("Replace a dataset of another preset in a non-empty output folder");
}
