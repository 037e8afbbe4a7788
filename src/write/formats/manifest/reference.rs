//! The manifest's records as serde writes them: the reference the tests
//! compare the hand-written records with, over varied frames (test builds only).

use serde::Serialize;

use crate::annotate::DroneLabel;
use crate::scene::FrameScene;
use crate::write::{box_xyxy, r6};

fn r9(v: f64) -> f64 {
    (v * 1e9).round() / 1e9
}

fn r12(v: f64) -> f64 {
    (v * 1e12).round() / 1e12
}

// The manifest's records as plain structs, fields in byte order of their
// names (the order a sorted JSON map writes them), serialised straight to
// text: no map is built per frame.

#[derive(Serialize)]
struct Line<'a> {
    camera: CameraRecord,
    #[serde(skip_serializing_if = "Option::is_none")]
    camera_model: Option<serde_json::Value>,
    drones: Vec<DroneRecord<'a>>,
    environment: EnvironmentRecord<'a>,
    image: &'a str,
    index: u64,
    models_present: Vec<&'a str>,
    placement_shortfall: u32,
    #[serde(skip_serializing_if = "Option::is_none")]
    redraw: Option<u32>,
    seed: u64,
    #[serde(skip_serializing_if = "Option::is_none")]
    sequence: Option<SequenceRecord>,
    split: crate::scene::SplitName,
    sweep: SweepRecord,
    volume_radius_m: f64,
}

#[derive(Serialize)]
#[allow(non_snake_case)]
struct CameraRecord {
    K: [[f64; 3]; 3],
    R: [[f64; 3]; 3],
    fov_y_deg: f64,
    height: u32,
    #[serde(skip_serializing_if = "Option::is_none")]
    look_at_m: Option<[f64; 3]>,
    #[serde(skip_serializing_if = "Option::is_none")]
    mode: Option<&'static str>,
    near_m: f64,
    position_m: [f64; 3],
    t: [f64; 3],
    width: u32,
}

#[derive(Serialize)]
struct DroneRecord<'a> {
    class: Option<&'a str>,
    euler_deg: EulerRecord,
    label: Option<LabelRecord>,
    #[serde(skip_serializing_if = "Option::is_none")]
    look: Option<LookRecord>,
    model: Option<&'a str>,
    position_m: [f64; 3],
    quaternion_xyzw: [f64; 4],
    size_m: f64,
    #[serde(skip_serializing_if = "Option::is_none")]
    track_id: Option<u64>,
}

#[derive(Serialize)]
struct LookRecord {
    albedo: [f64; 3],
    color: &'static str,
    emissive: f64,
    metalness: f64,
    rotor_opacity: f64,
    roughness: f64,
}

#[derive(Serialize)]
struct EulerRecord {
    pitch: f64,
    roll: f64,
    yaw: f64,
}

#[derive(Serialize)]
struct LabelRecord {
    amodal_xyxy: [f64; 4],
    bbox_xyxy: [f64; 4],
    distance_m: f64,
    paper_aabb_xyxy: [f64; 4],
    status: crate::annotate::LabelStatus,
    truncated: bool,
    unoccluded_pixels: Option<u64>,
    visible_fraction: Option<f64>,
    visible_pixels: Option<u64>,
    visible_xyxy: Option<[f64; 4]>,
}

#[derive(Serialize)]
struct SequenceRecord {
    first_index: u64,
    frame: u64,
    id: u64,
    name: String,
    step: u64,
    steps: u64,
}

/// The sweep values by the paper's names.
#[derive(Serialize)]
#[allow(non_snake_case)]
pub(crate) struct SweepRecord {
    CameraX: f64,
    CameraY: f64,
    CameraZ: f64,
    PlaneRX: f64,
    PlaneRY: f64,
    PlaneRZ: f64,
    #[serde(skip_serializing_if = "Option::is_none")]
    density_per_m3: Option<f64>,
    repeat: u64,
}

/// The environment a frame shows and its draws.
#[derive(Serialize)]
pub(crate) struct EnvironmentRecord<'a> {
    choice: usize,
    cloud_cover: f64,
    #[serde(skip_serializing_if = "Option::is_none")]
    exposure_offset_ev: Option<f64>,
    name: &'a str,
    pattern_seed: u32,
    sun_azimuth_deg: f64,
    sun_elevation_deg: f64,
    #[serde(skip_serializing_if = "Option::is_none")]
    sun_offset_ev: Option<f64>,
    turbidity: f64,
}

/// One manifest line: the frame's index, seed, split, sweep values,
/// environment, camera (K, R, t) and every drone's model, pose and label.
pub fn manifest_line(
    scene: &FrameScene,
    labels: &[DroneLabel],
    image: &str,
    model_names: &[String],
    classes: &[String],
) -> String {
    let cam = &scene.camera;
    let rows = |m: glam::DMat3| {
        let t = m.transpose();
        [t.x_axis, t.y_axis, t.z_axis].map(|r| r.to_array().map(r12))
    };
    // Each drone's label, by drone index (labels come in drone order, some drones have none).
    let mut label_of: Vec<Option<&DroneLabel>> = vec![None; scene.drones.len()];
    for l in labels {
        if let Some(slot) = label_of.get_mut(l.drone)
            && slot.is_none()
        {
            *slot = Some(l);
        }
    }
    let with_tracks = scene.sequence.is_some();
    let drones = scene
        .drones
        .iter()
        .zip(&label_of)
        .enumerate()
        .map(|(i, (d, label))| DroneRecord {
            class: label.map(|l| classes[l.class_id].as_str()),
            euler_deg: EulerRecord {
                pitch: r6(d.euler_deg.pitch),
                roll: r6(d.euler_deg.roll),
                yaw: r6(d.euler_deg.yaw),
            },
            label: label.map(|l| LabelRecord {
                amodal_xyxy: box_xyxy(&l.amodal),
                bbox_xyxy: box_xyxy(&l.bbox),
                distance_m: r6(l.distance_m),
                paper_aabb_xyxy: box_xyxy(&l.paper_aabb),
                status: l.status,
                truncated: l.truncated,
                unoccluded_pixels: l.visibility.map(|v| v.unoccluded_pixels),
                visible_fraction: l.visibility.map(|v| r6(v.fraction())),
                visible_pixels: l.visibility.map(|v| v.visible_pixels),
                visible_xyxy: l
                    .visibility
                    .and_then(|v| v.visible_box)
                    .as_ref()
                    .map(box_xyxy),
            }),
            look: scene.looks.get(i).map(|l| LookRecord {
                albedo: l.albedo.map(|c| r6(f64::from(c))),
                color: l.color.name(),
                emissive: r6(f64::from(l.emissive)),
                metalness: r6(f64::from(l.metalness)),
                rotor_opacity: r6(f64::from(l.rotor_opacity)),
                roughness: r6(f64::from(l.roughness)),
            }),
            model: model_names.get(d.model).map(String::as_str),
            position_m: d.position.to_array().map(r9),
            quaternion_xyzw: d.rotation.to_array().map(r12),
            size_m: d.size_m,
            track_id: with_tracks.then_some(i as u64 + 1),
        })
        .collect();
    // Sequence mode and the absolute camera add fields; other frames keep their bytes.
    let look = scene.sequence.is_some() || scene.camera_absolute;
    let line = Line {
        camera: CameraRecord {
            K: rows(cam.k()),
            R: rows(cam.camera_from_world),
            fov_y_deg: r9(cam.fov_y_deg),
            height: cam.height,
            look_at_m: look.then(|| scene.look_at.to_array().map(r9)),
            mode: look.then_some(if scene.camera_absolute {
                "absolute"
            } else {
                "relative"
            }),
            near_m: cam.near_m,
            position_m: cam.position.to_array().map(r9),
            t: cam.t().to_array().map(r9),
            width: cam.width,
        },
        camera_model: scene.camera_model.as_ref().map(camera_model_record),
        drones,
        environment: environment_record(scene),
        image,
        index: scene.index,
        models_present: super::models_present(scene, model_names),
        placement_shortfall: scene.placement_shortfall,
        redraw: (scene.redraw > 0).then_some(scene.redraw),
        seed: scene.seed,
        sequence: scene.sequence.map(|seq| SequenceRecord {
            first_index: seq.first_index,
            frame: seq.step + 1,
            id: seq.id,
            name: crate::write::formats::mot::sequence_name(seq.id),
            step: seq.step,
            steps: seq.steps,
        }),
        split: scene.split,
        sweep: sweep_record(scene),
        volume_radius_m: r9(scene.volume_radius_m),
    };
    // Plain data into a buffer sized for it: serde_json cannot fail here
    // (non-finite numbers become null) and writes UTF-8.
    let mut out = Vec::with_capacity(1024 + 640 * scene.drones.len());
    if serde_json::to_writer(&mut out, &line).is_err() {
        return String::new();
    }
    String::from_utf8(out).unwrap_or_default()
}

/// The camera model's draws as a sorted JSON map.
fn camera_model_record(c: &crate::sensor::CameraDraw) -> serde_json::Value {
    use crate::sensor::PsfDraw;
    let psf = match c.psf {
        PsfDraw::None => serde_json::json!({"kind": "none"}),
        PsfDraw::Gaussian { sigma_px } => {
            serde_json::json!({"kind": "gaussian", "sigma_px": r6(sigma_px)})
        }
        PsfDraw::Disc { radius_px } => {
            serde_json::json!({"kind": "disc", "radius_px": r6(radius_px)})
        }
    };
    let mut v = serde_json::json!({
        "ca_blue_scale": r6(c.ca_blue_scale),
        "ca_red_scale": r6(c.ca_red_scale),
        "exposure_ev": r6(c.exposure_ev),
        "noise_seed": c.noise_seed,
        "psf": psf,
        "read_noise_levels": r6(c.read_noise_levels),
        "shot_noise_gain": r6(c.shot_noise_gain),
        "vignetting": r6(c.vignetting),
        "white_balance_blue": r6(c.white_balance_blue),
        "white_balance_red": r6(c.white_balance_red),
    });
    if let Some(map) = v.as_object_mut() {
        if let Some(q) = c.jpeg_quality {
            map.insert("jpeg_quality".into(), q.into());
        }
        if let Some(q) = c.recompress_quality {
            map.insert("recompress_quality".into(), q.into());
        }
        if let Some(s) = c.sensor_scale {
            map.insert("sensor_scale".into(), r6(s).into());
        }
        if c.exposure_time_s > 0.0 {
            map.insert("exposure_time_s".into(), r6(c.exposure_time_s).into());
        }
        if c.saturation != 1.0 {
            map.insert("saturation".into(), r6(c.saturation).into());
        }
        if c.sharpen != 0.0 {
            map.insert("sharpen".into(), r6(c.sharpen).into());
        }
        if let Some(a) = c.auto_exposure {
            map.insert(
                "auto_exposure".into(),
                serde_json::json!({
                    "metered_ev": r6(a.metered_ev),
                    "target_level": r6(a.target_level),
                }),
            );
        }
    }
    v
}

/// The frame's sweep values by the paper's names (with the swept density
/// of a `DensitySweep` volume), as the manifest and COCO image records hold them.
pub fn sweep_record(scene: &FrameScene) -> SweepRecord {
    let s = &scene.sweep;
    SweepRecord {
        CameraX: s.CameraX,
        CameraY: s.CameraY,
        CameraZ: s.CameraZ,
        PlaneRX: s.PlaneRX,
        PlaneRY: s.PlaneRY,
        PlaneRZ: s.PlaneRZ,
        density_per_m3: s.density_per_m3,
        repeat: s.repeat,
    }
}

/// The environment the frame shows (a `Random` sky's choice by name) and its draws.
pub fn environment_record(scene: &FrameScene) -> EnvironmentRecord<'_> {
    let e = &scene.environment;
    EnvironmentRecord {
        choice: e.choice,
        cloud_cover: r6(e.cloud_cover),
        exposure_offset_ev: (e.exposure_offset_ev != 0.0).then(|| r6(e.exposure_offset_ev)),
        name: &scene.environment_name,
        pattern_seed: e.pattern_seed,
        sun_azimuth_deg: r6(e.sun_azimuth_deg),
        sun_elevation_deg: r6(e.sun_elevation_deg),
        sun_offset_ev: (e.sun_offset_ev != 0.0).then(|| r6(e.sun_offset_ev)),
        turbidity: r6(e.turbidity),
    }
}
