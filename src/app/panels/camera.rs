//! The Attitude, Camera and Scene rotation sections: per-drone angle ranges
//! and the paper's camera translation and plane rotation sweeps.

use egui::Ui;

use super::{Form, angle_row, range_row, sweep_row};
use crate::preset::Preset;

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
