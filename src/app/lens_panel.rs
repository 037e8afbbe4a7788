//! The lens distortion panel (issue 41): `camera_model.lens`, its own
//! section of the table. On makes the field `Some` (and the camera model
//! with it, neutral, when it was off); off makes it `None`, so a preset
//! without a lens keeps its bytes. Each coefficient is a `(min, max)` range
//! drawn per frame; docs/realism.md, "Lens distortion", describes them.

use egui::Ui;

use super::panels::{Form, Words};
use super::realism_panels::section_checkbox;
use crate::preset::Preset;
use crate::preset::camera_model::CameraModel;
use crate::preset::lens::Lens;

/// A mild barrel lens, what the checkbox turns on.
fn barrel() -> Lens {
    Lens::BrownConrady {
        k1: (-0.15, -0.15),
        k2: (0.0, 0.0),
        k3: (0.0, 0.0),
        p1: (0.0, 0.0),
        p2: (0.0, 0.0),
    }
}

/// The equidistant fisheye with no extra terms.
fn fisheye() -> Lens {
    Lens::Fisheye {
        k1: (0.0, 0.0),
        k2: (0.0, 0.0),
        k3: (0.0, 0.0),
        k4: (0.0, 0.0),
    }
}

/// Lens distortion: on/off, the model, its coefficients' ranges.
pub fn lens_ui(ui: &mut Ui, preset: &mut Preset, form: &mut Form<'_>) {
    let lens = preset.camera_model.as_ref().and_then(|c| c.lens.as_ref());
    let mut on = lens.is_some();
    if section_checkbox(ui, &mut on, "camera_model.lens").changed() {
        let camera = preset.camera_model.get_or_insert_with(CameraModel::default);
        camera.lens = on.then(barrel);
    }
    form.messages(ui, &["camera_model.lens"]);
    let Some(lens) = preset.camera_model.as_mut().and_then(|c| c.lens.as_mut()) else {
        return;
    };
    ui.horizontal(|ui| {
        let brown = matches!(lens, Lens::BrownConrady { .. });
        if ui
            .radio(brown, "Brown–Conrady")
            .on_hover_text("Radial k1–k3 and tangential p1, p2 (OpenCV's model)")
            .clicked()
            && !brown
        {
            *lens = barrel();
        }
        if ui
            .radio(!brown, "Fisheye")
            .on_hover_text("The equidistant fisheye, θ_d = θ(1 + k1θ² + …) (OpenCV's fisheye)")
            .clicked()
            && brown
        {
            *lens = fisheye();
        }
    });
    let rows: Vec<(&'static str, &mut (f64, f64))> = match lens {
        Lens::BrownConrady { k1, k2, k3, p1, p2 } => vec![
            ("camera_model.lens.k1", k1),
            ("camera_model.lens.k2", k2),
            ("camera_model.lens.k3", k3),
            ("camera_model.lens.p1", p1),
            ("camera_model.lens.p2", p2),
        ],
        Lens::Fisheye { k1, k2, k3, k4 } => vec![
            ("camera_model.lens.k1", k1),
            ("camera_model.lens.k2", k2),
            ("camera_model.lens.k3", k3),
            ("camera_model.lens.k4", k4),
        ],
    };
    for (path, value) in rows {
        Words::of(path).range(ui, form, value, 0.001);
    }
}
