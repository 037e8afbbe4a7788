//! The pose manifest: one JSON line per frame with the frame's index, seed,
//! split, sweep values, camera (K, R, t) and every drone's model, pose and label.

use serde_json::json;

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
    model_names: Vec<String>,
    classes: Vec<String>,
}

impl ManifestWriter {
    /// Open the manifest, cut back to `checkpoint` (created when new).
    pub fn open(
        folder: &mut Folder,
        checkpoint: &Checkpoint,
        model_names: Vec<String>,
        classes: Vec<String>,
    ) -> Result<Self, OutputError> {
        let len = checkpoint.files.get(FILE).copied().unwrap_or(0);
        Ok(Self {
            out: folder.open_append(FILE, len)?,
            model_names,
            classes,
        })
    }
}

impl FormatWriter for ManifestWriter {
    fn frame(&mut self, _folder: &mut Folder, record: &FrameRecord<'_>) -> Result<(), OutputError> {
        let mut line = manifest_line(
            record.scene,
            record.labels,
            record.image,
            &self.model_names,
            &self.classes,
        );
        line.push('\n');
        self.out.append(line.as_bytes())
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

/// One manifest line: the frame's index, seed, split, sweep values, camera
/// (K, R, t) and every drone's model, pose and label.
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
        [t.x_axis, t.y_axis, t.z_axis].map(|r| r.to_array().map(|v| (v * 1e12).round() / 1e12))
    };
    let drones: Vec<_> = scene
        .drones
        .iter()
        .enumerate()
        .map(|(i, d)| {
            let label = labels.iter().find(|l| l.drone == i);
            let q = d.rotation;
            json!({
                "model": model_names.get(d.model),
                "class": label.map(|l| classes[l.class_id].clone()),
                "position_m": d.position.to_array().map(|v| (v * 1e9).round() / 1e9),
                "quaternion_xyzw": q.to_array().map(|v| (v * 1e12).round() / 1e12),
                "euler_deg": {"roll": r6(d.euler_deg.roll), "pitch": r6(d.euler_deg.pitch), "yaw": r6(d.euler_deg.yaw)},
                "size_m": d.size_m,
                "label": label.map(|l| json!({
                    "bbox_xyxy": box_xyxy(&l.bbox),
                    "amodal_xyxy": box_xyxy(&l.amodal),
                    "paper_aabb_xyxy": box_xyxy(&l.paper_aabb),
                    "truncated": l.truncated,
                    "status": l.status,
                    "distance_m": (l.distance_m * 1e6).round() / 1e6,
                    "visible_xyxy": l.visibility.and_then(|v| v.visible_box).as_ref().map(box_xyxy),
                    "visible_pixels": l.visibility.map(|v| v.visible_pixels),
                    "unoccluded_pixels": l.visibility.map(|v| v.unoccluded_pixels),
                    "visible_fraction": l.visibility.map(|v| r6(v.fraction())),
                })),
            })
        })
        .collect();
    let s = &scene.sweep;
    let mut line = json!({
        "index": scene.index,
        "seed": scene.seed,
        "split": scene.split,
        "image": image,
        "sweep": {"CameraX": s.CameraX, "CameraY": s.CameraY, "CameraZ": s.CameraZ, "PlaneRX": s.PlaneRX, "PlaneRY": s.PlaneRY, "PlaneRZ": s.PlaneRZ, "repeat": s.repeat},
        "camera": {
            "width": cam.width, "height": cam.height, "fov_y_deg": cam.fov_y_deg,
            "K": rows(cam.k()), "R": rows(cam.camera_from_world), "t": cam.t().to_array().map(|v| (v * 1e9).round() / 1e9),
            "position_m": cam.position.to_array().map(|v| (v * 1e9).round() / 1e9), "near_m": cam.near_m,
        },
        "volume_radius_m": (scene.volume_radius_m * 1e9).round() / 1e9,
        "placement_shortfall": scene.placement_shortfall,
        "drones": drones,
    });
    // Sequence mode and the absolute camera add fields; other frames keep their bytes.
    if let Some(seq) = scene.sequence {
        line["sequence"] = json!({"id": seq.id, "name": super::mot::sequence_name(seq.id), "frame": seq.step + 1, "step": seq.step, "steps": seq.steps, "first_index": seq.first_index});
        if let Some(list) = line["drones"].as_array_mut() {
            for (i, d) in list.iter_mut().enumerate() {
                d["track_id"] = (i as u64 + 1).into();
            }
        }
    }
    if let Some(rho) = s.density_per_m3 {
        line["sweep"]["density_per_m3"] = rho.into();
    }
    if scene.sequence.is_some() || scene.camera_absolute {
        line["camera"]["look_at_m"] = scene
            .look_at
            .to_array()
            .map(|v| (v * 1e9).round() / 1e9)
            .into();
        line["camera"]["mode"] = if scene.camera_absolute {
            "absolute"
        } else {
            "relative"
        }
        .into();
    }
    line.to_string()
}
