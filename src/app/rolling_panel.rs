//! The rolling shutter's rows in the camera model's section (issue 41):
//! `camera_model.rolling_shutter`. On makes the field `Some` with a 30 ms
//! readout and a still camera; off makes it `None`, so a preset without a
//! rolling shutter keeps its bytes. Both fields are `(min, max)` ranges
//! drawn per frame; docs/realism.md, "Rolling shutter", describes them.

use egui::Ui;

use super::panels::{Form, Words};
use crate::preset::camera_model::CameraModel;
use crate::preset::rolling_shutter::RollingShutter;

/// Rolling shutter: on/off, the readout time and the camera's yaw rate.
pub fn rolling_shutter_ui(ui: &mut Ui, c: &mut CameraModel, form: &mut Form<'_>) {
    let path = "camera_model.rolling_shutter";
    let mut on = c.rolling_shutter.is_some();
    if Words::of(path).checkbox(ui, &mut on).changed() {
        c.rolling_shutter = on.then_some(RollingShutter {
            readout_s: (0.03, 0.03),
            yaw_rate_deg_s: (0.0, 0.0),
        });
    }
    form.messages(ui, &[path]);
    let Some(r) = c.rolling_shutter.as_mut() else {
        return;
    };
    Words::of("camera_model.rolling_shutter.readout_s").range(ui, form, &mut r.readout_s, 0.001);
    let yaw = Words::of("camera_model.rolling_shutter.yaw_rate_deg_s");
    yaw.range(ui, form, &mut r.yaw_rate_deg_s, 0.5);
}
