//! The pose manifest: one JSON line per frame with the frame's index, seed,
//! split, sweep values, camera (K, R, t) and every drone's model, pose and label.

mod confusers;

use super::json::{Decimals, Json};
use super::{FormatWriter, FrameRecord};
use crate::annotate::DroneLabel;
use crate::scene::{DronePose, FrameScene};
use crate::write::folder::AppendFile;
use crate::write::{Checkpoint, Folder, OutputError};

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
        self.out.append(record.text.manifest)?;
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
        let bytes = std::fs::read(&path).map_err(crate::write::io(&path))?;
        if !bytes.is_empty() && !bytes.ends_with(b"\n") {
            return Err(OutputError::Shard {
                path,
                reason: "ends in a torn line; is the shard finished?".into(),
            });
        }
        self.out.append(&bytes)
    }
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
    let mut out = Vec::with_capacity(1024 + 640 * scene.drones.len());
    write_manifest_line(&mut out, scene, labels, image, model_names, classes);
    // Only JSON text was written: valid UTF-8.
    String::from_utf8(out).unwrap_or_default()
}

/// [`manifest_line`] appended to `out` (without its newline): compact JSON,
/// fields in byte order of their names (the order a sorted JSON map writes
/// them), the bytes serde_json writes for the same records (the tests
/// compare them), written straight into the buffer.
pub fn write_manifest_line(
    out: &mut Vec<u8>,
    scene: &FrameScene,
    labels: &[DroneLabel],
    image: &str,
    model_names: &[String],
    classes: &[String],
) {
    let mut j = Json { out };
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
    // The atmosphere adds its field only when the preset has one.
    j.raw(b"{");
    if let Some(a) = &scene.atmosphere {
        j.raw(b"\"atmosphere\":{\"visibility_m\":");
        j.rounded(a.visibility_m, Decimals::Nine);
        j.raw(b"},");
    }
    // A backplate adds its field only when the preset has one.
    if let Some(p) = &scene.backplate {
        j.raw(b"\"backplate\":{\"file\":");
        j.str(&p.file);
        j.raw(if p.flip {
            b",\"flip\":true},"
        } else {
            b",\"flip\":false},"
        });
    }
    j.raw(b"\"camera\":{\"K\":");
    matrix(&mut j, cam.k());
    j.raw(b",\"R\":");
    matrix(&mut j, cam.camera_from_world);
    j.raw(b",\"fov_y_deg\":");
    j.f64(cam.fov_y_deg);
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
    if let Some(c) = &scene.camera_model {
        j.raw(b",\"camera_model\":");
        write_camera_model(&mut j, c);
    }
    if !scene.confusers.is_empty() {
        j.raw(b",\"confusers\":[");
        confusers::write_confusers(&mut j, scene, labels, model_names, classes);
        j.raw(b"]");
    }
    j.raw(b",\"drones\":[");
    write_drones(&mut j, scene, labels, model_names, classes);
    j.raw(b"],\"environment\":");
    write_environment(&mut j, scene);
    j.raw(b",\"image\":");
    j.str(image);
    j.raw(b",\"index\":");
    j.u64(scene.index);
    j.raw(b",\"models_present\":");
    write_models_present(&mut j, scene, model_names);
    j.raw(b",\"placement_shortfall\":");
    j.u64(scene.placement_shortfall.into());
    if scene.redraw > 0 {
        j.raw(b",\"redraw\":");
        j.u64(scene.redraw.into());
    }
    j.raw(b",\"seed\":");
    j.u64(scene.seed);
    if let Some(seq) = scene.sequence {
        j.raw(b",\"sequence\":{\"first_index\":");
        j.u64(seq.first_index);
        j.raw(b",\"frame\":");
        j.u64(seq.step + 1);
        j.raw(b",\"id\":");
        j.u64(seq.id);
        j.raw(b",\"name\":");
        j.str(&super::mot::sequence_name(seq.id));
        j.raw(b",\"step\":");
        j.u64(seq.step);
        j.raw(b",\"steps\":");
        j.u64(seq.steps);
        j.raw(b"}");
    }
    j.raw(b",\"split\":\"");
    j.raw(scene.split.as_str().as_bytes());
    j.raw(b"\",\"sweep\":");
    write_sweep(&mut j, scene);
    j.raw(b",\"volume_radius_m\":");
    j.rounded(scene.volume_radius_m, Decimals::Nine);
    j.raw(b"}");
}

/// The drones' records: each drone's label is the first label naming it.
fn write_drones(
    j: &mut Json<'_>,
    scene: &FrameScene,
    labels: &[DroneLabel],
    model_names: &[String],
    classes: &[String],
) {
    // Labels come in drone order, so a cursor finds each drone's label
    // without a table; labels in any other order take the table.
    let ordered = labels.windows(2).all(|w| w[0].drone < w[1].drone);
    let table: Vec<Option<&DroneLabel>> = if ordered {
        Vec::new()
    } else {
        let mut label_of = vec![None; scene.drones.len()];
        for l in labels {
            if let Some(slot) = label_of.get_mut(l.drone)
                && slot.is_none()
            {
                *slot = Some(l);
            }
        }
        label_of
    };
    let mut cursor = 0;
    let with_tracks = scene.sequence.is_some();
    for (i, d) in scene.real_drones().iter().enumerate() {
        let label = if ordered {
            while cursor < labels.len() && labels[cursor].drone < i {
                cursor += 1;
            }
            labels.get(cursor).filter(|l| l.drone == i)
        } else {
            table.get(i).copied().flatten()
        };
        if i > 0 {
            j.raw(b",");
        }
        j.raw(b"{\"class\":");
        match label.and_then(|l| classes.get(l.class_id)) {
            Some(class) => j.str(class),
            None => j.raw(b"null"),
        }
        j.raw(b",\"euler_deg\":{\"pitch\":");
        j.rounded(d.euler_deg.pitch, Decimals::Six);
        j.raw(b",\"roll\":");
        j.rounded(d.euler_deg.roll, Decimals::Six);
        j.raw(b",\"yaw\":");
        j.rounded(d.euler_deg.yaw, Decimals::Six);
        j.raw(b"}");
        write_label_and_pose(j, label, scene.looks.get(i), model_names, d);
        if with_tracks {
            j.raw(b",\"track_id\":");
            j.u64(i as u64 + 1);
        }
        j.raw(b"}");
    }
}

/// The keys a drone's and a confuser's records share, in byte order:
/// `,"label":…,"model":…,"position_m":…,"quaternion_xyzw":…,"size_m":…`,
/// with `,"look":…` after the label for a drone with a drawn look.
fn write_label_and_pose(
    j: &mut Json<'_>,
    label: Option<&DroneLabel>,
    look: Option<&crate::scene::realism::DroneLook>,
    model_names: &[String],
    d: &DronePose,
) {
    j.raw(b",\"label\":");
    match label {
        Some(l) => write_label(j, l),
        None => j.raw(b"null"),
    }
    if let Some(look) = look {
        write_look(j, look);
    }
    j.raw(b",\"model\":");
    match model_names.get(d.model) {
        Some(name) => j.str(name),
        None => j.raw(b"null"),
    }
    j.raw(b",\"position_m\":");
    j.rounded_all(&d.position.to_array(), Decimals::Nine);
    j.raw(b",\"quaternion_xyzw\":");
    j.rounded_all(&d.rotation.to_array(), Decimals::Twelve);
    j.raw(b",\"size_m\":");
    j.f64(d.size_m);
}

/// `,"look":{…}`: the drone's drawn material (`appearance` in the preset).
fn write_look(j: &mut Json<'_>, look: &crate::scene::realism::DroneLook) {
    j.raw(b",\"look\":{\"albedo\":");
    j.rounded_all(&look.albedo.map(f64::from), Decimals::Six);
    j.raw(b",\"color\":");
    j.str(look.color.name());
    j.raw(b",\"emissive\":");
    j.rounded(f64::from(look.emissive), Decimals::Six);
    j.raw(b",\"metalness\":");
    j.rounded(f64::from(look.metalness), Decimals::Six);
    j.raw(b",\"rotor_opacity\":");
    j.rounded(f64::from(look.rotor_opacity), Decimals::Six);
    j.raw(b",\"roughness\":");
    j.rounded(f64::from(look.roughness), Decimals::Six);
    j.raw(b"}");
}

pub(crate) fn write_label(j: &mut Json<'_>, l: &DroneLabel) {
    j.raw(b"{\"amodal_xyxy\":");
    write_xyxy(j, &l.amodal);
    j.raw(b",\"bbox_xyxy\":");
    write_xyxy(j, &l.bbox);
    j.raw(b",\"distance_m\":");
    j.rounded(l.distance_m, Decimals::Six);
    j.raw(b",\"paper_aabb_xyxy\":");
    write_xyxy(j, &l.paper_aabb);
    j.raw(b",\"status\":");
    j.raw(status_json(l.status));
    j.raw(b",\"truncated\":");
    j.bool(l.truncated);
    let v = l.visibility;
    j.raw(b",\"unoccluded_pixels\":");
    match v {
        Some(v) => j.u64(v.unoccluded_pixels),
        None => j.raw(b"null"),
    }
    j.raw(b",\"visible_fraction\":");
    match v {
        Some(v) => j.rounded(v.fraction(), Decimals::Six),
        None => j.raw(b"null"),
    }
    j.raw(b",\"visible_pixels\":");
    match v {
        Some(v) => j.u64(v.visible_pixels),
        None => j.raw(b"null"),
    }
    j.raw(b",\"visible_xyxy\":");
    match v.and_then(|v| v.visible_box) {
        Some(b) => write_xyxy(j, &b),
        None => j.raw(b"null"),
    }
    j.raw(b"}");
}

/// A box's corners `[x0,y0,x1,y1]`, each rounded to 1e-6 px (`box_xyxy`).
fn write_xyxy(j: &mut Json<'_>, b: &crate::annotate::PixelBox) {
    j.rounded_all(&[b.x0, b.y0, b.x1, b.y1], Decimals::Six);
}

/// A label status as serde writes it (`rename_all = "lowercase"`).
pub(crate) fn status_json(status: crate::annotate::LabelStatus) -> &'static [u8] {
    use crate::annotate::LabelStatus;
    match status {
        LabelStatus::Kept => b"\"kept\"",
        LabelStatus::Crowd => b"\"crowd\"",
        LabelStatus::Filtered => b"\"filtered\"",
        LabelStatus::Negative => b"\"negative\"",
    }
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
fn write_camera_model(j: &mut Json<'_>, c: &crate::sensor::CameraDraw) {
    write_draw_group(j, &c.record());
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
fn write_environment(j: &mut Json<'_>, scene: &FrameScene) {
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

/// The records as serde writes them: the reference the tests compare the
/// hand-written records with, over varied frames.
#[cfg(test)]
pub(crate) mod reference {
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
}
