//! The pose manifest: one JSON line per frame with the frame's index, seed,
//! split, sweep values, camera (K, R, t) and every drone's model, pose and label.

use serde::Serialize;

use super::folder::AppendFile;
use super::{Checkpoint, Folder, FormatWriter, FrameRecord, OutputError, box_xyxy, r6};
use crate::annotate::DroneLabel;
use crate::scene::FrameScene;

/// File name of the manifest in the dataset folder.
pub const FILE: &str = "manifest.jsonl";

/// Appends `manifest.jsonl`, one whole line per frame; a resumed run cuts it
/// back to the last checkpoint's length, so it is never torn.
pub struct ManifestWriter {
    out: AppendFile,
}

impl ManifestWriter {
    /// Open the manifest, cut back to `checkpoint` (created when new).
    pub fn open(folder: &mut Folder, checkpoint: &Checkpoint) -> Result<Self, OutputError> {
        let len = checkpoint.files.get(FILE).copied().unwrap_or(0);
        Ok(Self {
            out: folder.open_append(FILE, len)?.buffered(),
        })
    }
}

impl FormatWriter for ManifestWriter {
    fn frame(&mut self, _folder: &mut Folder, record: &FrameRecord<'_>) -> Result<(), OutputError> {
        self.out.append(record.text.manifest.as_bytes())?;
        self.out.append(b"\n")
    }

    fn flush(&mut self) -> Result<(), OutputError> {
        self.out.flush()
    }

    fn save(&mut self, checkpoint: &mut Checkpoint) {
        self.out.save(checkpoint);
    }

    fn rollback(&mut self) {
        self.out.rollback();
    }

    fn finish(
        &mut self,
        _folder: &mut Folder,
        _dataset: &super::DatasetInfo,
    ) -> Result<(), OutputError> {
        self.out.sync()
    }

    /// The shard's lines follow, as they are (whatever fields they carry).
    fn merge_shard(
        &mut self,
        _folder: &mut Folder,
        shard: &std::path::Path,
    ) -> Result<(), OutputError> {
        let path = shard.join(FILE);
        let bytes = std::fs::read(&path).map_err(super::io(&path))?;
        if !bytes.is_empty() && !bytes.ends_with(b"\n") {
            return Err(OutputError::Shard {
                path,
                reason: "ends in a torn line; is the shard finished?".into(),
            });
        }
        self.out.append(&bytes)
    }
}

// The manifest's records as plain structs, fields in byte order of their
// names (the order a sorted JSON map writes them), serialised straight to
// text: no map is built per frame.

#[derive(Serialize)]
struct Line<'a> {
    camera: CameraRecord,
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
    model: Option<&'a str>,
    position_m: [f64; 3],
    quaternion_xyzw: [f64; 4],
    size_m: f64,
    #[serde(skip_serializing_if = "Option::is_none")]
    track_id: Option<u64>,
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
pub struct SweepRecord {
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
pub struct EnvironmentRecord<'a> {
    choice: usize,
    cloud_cover: f64,
    name: &'a str,
    pattern_seed: u32,
    sun_azimuth_deg: f64,
    sun_elevation_deg: f64,
    turbidity: f64,
}

fn r9(v: f64) -> f64 {
    (v * 1e9).round() / 1e9
}

fn r12(v: f64) -> f64 {
    (v * 1e12).round() / 1e12
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
            fov_y_deg: cam.fov_y_deg,
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
        drones,
        environment: environment_record(scene),
        image,
        index: scene.index,
        models_present: models_present(scene, model_names),
        placement_shortfall: scene.placement_shortfall,
        redraw: (scene.redraw > 0).then_some(scene.redraw),
        seed: scene.seed,
        sequence: scene.sequence.map(|seq| SequenceRecord {
            first_index: seq.first_index,
            frame: seq.step + 1,
            id: seq.id,
            name: super::mot::sequence_name(seq.id),
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
        name: &scene.environment_name,
        pattern_seed: e.pattern_seed,
        sun_azimuth_deg: r6(e.sun_azimuth_deg),
        sun_elevation_deg: r6(e.sun_elevation_deg),
        turbidity: r6(e.turbidity),
    }
}

/// Names of the models present in the frame, each once, in preset order.
pub fn models_present<'a>(scene: &FrameScene, model_names: &'a [String]) -> Vec<&'a str> {
    scene
        .models_present()
        .into_iter()
        .filter_map(|m| model_names.get(m).map(String::as_str))
        .collect()
}
