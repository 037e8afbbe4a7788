//! The manifest's records of the frame as a whole: the camera, the
//! sequence, the sweep values, the environment, the camera model's and the
//! weather's draws and the models present (COCO's image records write the sweep and the models
//! present with the same functions).

use crate::scene::FrameScene;
use crate::write::formats::json::{Decimals, Json};

/// `"camera":{…}`: K, R, the lens, the pose and the image size; with the
/// look-at point and the mode in sequence mode and for an absolute camera.
pub(super) fn write_camera(j: &mut Json<'_>, scene: &FrameScene) {
    let cam = &scene.camera;
    let matrix = |j: &mut Json<'_>, m: glam::DMat3| {
        let t = m.transpose();
        j.raw(b"[");
        for (i, row) in [t.x_axis, t.y_axis, t.z_axis].into_iter().enumerate() {
            if i > 0 {
                j.raw(b",");
            }
            j.rounded_all(&row.to_array(), Decimals::Twelve);
        }
        j.raw(b"]");
    };
    // Sequence mode and the absolute camera add fields; other frames keep their bytes.
    let look = scene.sequence.is_some() || scene.camera_absolute;
    j.raw(b"\"camera\":{\"K\":");
    matrix(j, cam.k());
    j.raw(b",\"R\":");
    matrix(j, cam.camera_from_world);
    // Rounded as the other measures: a backplate's field of view comes
    // from libm's `atan`, whose last bit may differ between machines.
    j.raw(b",\"fov_y_deg\":");
    j.rounded(cam.fov_y_deg, Decimals::Nine);
    j.raw(b",\"height\":");
    j.u64(cam.height.into());
    if look {
        j.raw(b",\"look_at_m\":");
        j.rounded_all(&scene.look_at.to_array(), Decimals::Nine);
        j.raw(if scene.camera_absolute {
            b",\"mode\":\"absolute\""
        } else {
            b",\"mode\":\"relative\""
        });
    }
    j.raw(b",\"near_m\":");
    j.f64(cam.near_m);
    j.raw(b",\"position_m\":");
    j.rounded_all(&cam.position.to_array(), Decimals::Nine);
    j.raw(b",\"t\":");
    j.rounded_all(&cam.t().to_array(), Decimals::Nine);
    j.raw(b",\"width\":");
    j.u64(cam.width.into());
    j.raw(b"}");
}

/// `,"sequence":{…}`: the frame's place in its sequence (sequence mode).
pub(super) fn write_sequence(j: &mut Json<'_>, seq: &crate::scene::SequenceFrame) {
    j.raw(b",\"sequence\":{\"first_index\":");
    j.u64(seq.first_index);
    j.raw(b",\"frame\":");
    j.u64(seq.step + 1);
    j.raw(b",\"id\":");
    j.u64(seq.id);
    j.raw(b",\"name\":");
    j.str(&crate::write::formats::mot::sequence_name(seq.id));
    j.raw(b",\"step\":");
    j.u64(seq.step);
    j.raw(b",\"steps\":");
    j.u64(seq.steps);
    j.raw(b"}");
}

/// The frame's sweep values by the paper's names (with the swept density
/// of a `DensitySweep` volume), as the manifest and COCO image records hold them.
pub(crate) fn write_sweep(j: &mut Json<'_>, scene: &FrameScene) {
    let s = &scene.sweep;
    j.raw(b"{\"CameraX\":");
    j.f64(s.CameraX);
    j.raw(b",\"CameraY\":");
    j.f64(s.CameraY);
    j.raw(b",\"CameraZ\":");
    j.f64(s.CameraZ);
    j.raw(b",\"PlaneRX\":");
    j.f64(s.PlaneRX);
    j.raw(b",\"PlaneRY\":");
    j.f64(s.PlaneRY);
    j.raw(b",\"PlaneRZ\":");
    j.f64(s.PlaneRZ);
    if let Some(density) = s.density_per_m3 {
        j.raw(b",\"density_per_m3\":");
        j.f64(density);
    }
    j.raw(b",\"repeat\":");
    j.u64(s.repeat);
    j.raw(b"}");
}

/// The camera model's draws of the frame (issue 21), keys in byte order.
/// A lens's record also holds `focal_px`: the written picture's focal
/// length (its principal point is `K`'s), which maps a point to the written
/// pixels with the coefficients.
pub(super) fn write_camera_model(
    j: &mut Json<'_>,
    scene: &FrameScene,
    c: &crate::sensor::CameraDraw,
) {
    let mut record = c.record();
    if c.lens.is_some() {
        let written = crate::scene::projection::frame_lens(scene);
        let focal = written.map_or(scene.camera.focal_px(), |g| g.focal_out);
        add_lens_focal(&mut record, focal);
    }
    write_draw_group(j, &record);
}

/// `focal_px` added to the `lens` group of a camera model's `record`.
fn add_lens_focal(record: &mut [(&'static str, crate::sensor::DrawValue)], focal_px: f64) {
    use crate::sensor::DrawValue::{Group, Real};
    for (key, value) in record.iter_mut() {
        if *key == "lens"
            && let Group(g) = value
        {
            g.push(("focal_px", Real(focal_px)));
            g.sort_by_key(|(k, _)| *k);
        }
    }
}

/// `,"weather":{…}`: the frame's weather draws, keys in byte order.
pub(super) fn write_weather(j: &mut Json<'_>, w: &crate::scene::weather::FrameWeather) {
    j.raw(b",\"weather\":{\"exposure_s\":");
    j.rounded(w.exposure_s, Decimals::Nine);
    j.raw(b",\"fall_mps\":");
    j.rounded(w.fall_mps, Decimals::Six);
    j.raw(b",\"intensity_per_m3\":");
    j.rounded(w.intensity_per_m3, Decimals::Six);
    j.raw(b",\"kind\":");
    j.str(w.kind.name());
    j.raw(b",\"opacity\":");
    j.rounded(w.opacity, Decimals::Six);
    j.raw(b",\"particle_seed\":");
    j.u64(w.particle_seed);
    j.raw(b",\"wind_dir_deg\":");
    j.rounded(w.wind_dir_deg, Decimals::Six);
    j.raw(b",\"wind_mps\":");
    j.rounded(w.wind_mps, Decimals::Six);
    j.raw(b"}");
}

/// `{"key":value,…}` of drawn values, in the order given (key order).
fn write_draw_group(j: &mut Json<'_>, values: &[(&'static str, crate::sensor::DrawValue)]) {
    use crate::sensor::DrawValue;
    j.raw(b"{");
    for (i, (key, value)) in values.iter().enumerate() {
        if i > 0 {
            j.raw(b",");
        }
        j.str(key);
        j.raw(b":");
        match value {
            DrawValue::Real(v) => j.rounded(*v, Decimals::Six),
            DrawValue::Count(n) => j.u64(*n),
            DrawValue::Name(name) => j.str(name),
            DrawValue::Group(inner) => write_draw_group(j, inner),
        }
    }
    j.raw(b"}");
}

/// The environment the frame shows (a `Random` sky's choice by name) and its draws.
pub(super) fn write_environment(j: &mut Json<'_>, scene: &FrameScene) {
    let e = &scene.environment;
    j.raw(b"{\"choice\":");
    j.u64(e.choice as u64);
    j.raw(b",\"cloud_cover\":");
    j.rounded(e.cloud_cover, Decimals::Six);
    if e.exposure_offset_ev != 0.0 {
        j.raw(b",\"exposure_offset_ev\":");
        j.rounded(e.exposure_offset_ev, Decimals::Six);
    }
    j.raw(b",\"name\":");
    j.str(&scene.environment_name);
    j.raw(b",\"pattern_seed\":");
    j.u64(e.pattern_seed.into());
    j.raw(b",\"sun_azimuth_deg\":");
    j.rounded(e.sun_azimuth_deg, Decimals::Six);
    j.raw(b",\"sun_elevation_deg\":");
    j.rounded(e.sun_elevation_deg, Decimals::Six);
    if e.sun_offset_ev != 0.0 {
        j.raw(b",\"sun_offset_ev\":");
        j.rounded(e.sun_offset_ev, Decimals::Six);
    }
    j.raw(b",\"turbidity\":");
    j.rounded(e.turbidity, Decimals::Six);
    j.raw(b"}");
}

/// `[names…]` of the models present in the frame, each once, in preset order.
pub(crate) fn write_models_present(j: &mut Json<'_>, scene: &FrameScene, model_names: &[String]) {
    j.raw(b"[");
    let mut first = true;
    let mut name = |j: &mut Json<'_>, m: usize| {
        if let Some(n) = model_names.get(m) {
            if !first {
                j.raw(b",");
            }
            first = false;
            j.str(n);
        }
    };
    // Up to 64 models: a bit set, no allocation.
    let mut bits = 0u64;
    if scene.real_drones().iter().all(|d| {
        bits |= 1u64.checked_shl(d.model as u32).unwrap_or(0);
        d.model < 64
    }) {
        while bits != 0 {
            let m = bits.trailing_zeros() as usize;
            bits &= bits - 1;
            name(j, m);
        }
    } else {
        for m in scene.models_present() {
            name(j, m);
        }
    }
    j.raw(b"]");
}

/// Names of the models present in the frame, each once, in preset order.
pub fn models_present<'a>(scene: &FrameScene, model_names: &'a [String]) -> Vec<&'a str> {
    scene
        .models_present()
        .into_iter()
        .filter_map(|m| model_names.get(m).map(String::as_str))
        .collect()
}
