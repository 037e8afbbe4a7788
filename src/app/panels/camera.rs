//! The Attitude, Camera and Scene rotation sections: per-drone angle ranges
//! and the paper's camera translation and plane rotation sweeps.

use egui::Ui;

use super::{Form, field_range_row, field_row, sweep_row};
use crate::preset::Preset;

pub fn attitude_ui(ui: &mut Ui, preset: &mut Preset, form: &mut Form<'_>) {
    let a = &mut preset.attitude;
    field_range_row(ui, &mut a.roll_deg, "attitude.roll_deg", 1.0);
    form.messages(ui, &["attitude.roll_deg"]);
    field_range_row(ui, &mut a.pitch_deg, "attitude.pitch_deg", 1.0);
    form.messages(ui, &["attitude.pitch_deg"]);
    field_range_row(ui, &mut a.yaw_deg, "attitude.yaw_deg", 1.0);
    form.messages(ui, &["attitude.yaw_deg"]);
}

pub fn camera_ui(ui: &mut Ui, preset: &mut Preset, form: &mut Form<'_>) {
    let c = &mut preset.camera;
    sweep_row(ui, form, &mut c.x, "camera.x", 0.01);
    sweep_row(ui, form, &mut c.y, "camera.y", 0.01);
    sweep_row(ui, form, &mut c.z, "camera.z", 0.01);
    field_row(ui, &mut c.fov_y_deg, "camera.fov_y_deg", 0.1);
    form.messages(ui, &["camera.fov_y_deg"]);
}

pub fn plane_ui(ui: &mut Ui, preset: &mut Preset, form: &mut Form<'_>) {
    let p = &mut preset.plane;
    sweep_row(ui, form, &mut p.rx, "plane.rx", 1.0);
    sweep_row(ui, form, &mut p.ry, "plane.ry", 1.0);
    sweep_row(ui, form, &mut p.rz, "plane.rz", 1.0);
}
