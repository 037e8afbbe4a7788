//! COCO: `annotations/instances_{split}.json`. Image and annotation records
//! are appended to part files (`annotations/.instances_{split}.*.part`) as
//! frames are written and assembled at the end, so memory stays flat at a
//! million frames and a resumed run assembles the same bytes. The parts are
//! deleted once the whole dataset is written.

use std::io::{BufRead, Write};

use serde_json::json;

use super::json::{Decimals, Json};
use super::{DatasetInfo, FormatWriter, FrameRecord};
use crate::annotate::LabelStatus;
use crate::scene::SplitName;
use crate::write::folder::AppendFile;
use crate::write::shards::merge::ShardReader;
use crate::write::{Checkpoint, Folder, OutputError};

struct Parts {
    images: AppendFile,
    annotations: AppendFile,
    /// Sequence mode: the `videos` records (one per sequence, at its first frame).
    videos: Option<AppendFile>,
    n_images: u64,
    n_annotations: u64,
    /// The counters as the last checkpoint holds them.
    saved: (u64, u64),
}

/// The fixed entries: each split's `annotations/instances_{split}.json`
/// and its record parts (with `sequences`, the video records' part too).
pub fn needed_entries(sequences: bool) -> Vec<String> {
    let mut needed = Vec::new();
    for split in SplitName::ALL.map(SplitName::as_str) {
        needed.push(format!("annotations/instances_{split}.json"));
        needed.push(format!("annotations/.instances_{split}.images.part"));
        needed.push(format!("annotations/.instances_{split}.annotations.part"));
        if sequences {
            needed.push(format!("annotations/.instances_{split}.videos.part"));
        }
    }
    needed
}

/// Writes the three COCO files.
pub struct CocoWriter {
    parts: Vec<Parts>,
}

/// Track ids of video v are v·10⁶ + 1 .. (a frame holds at most 10⁶ drones).
pub const TRACKS_PER_VIDEO: u64 = 1_000_000;

fn counter(split: SplitName, what: &str) -> String {
    format!("coco.{}.{what}", split.as_str())
}

impl CocoWriter {
    /// Open the part files, cut back to `checkpoint` (created when new).
    /// With `sequences`, images and annotations carry the video fields of
    /// TAO and COCO-VID and each split file lists its `videos`.
    pub fn open(
        folder: &mut Folder,
        checkpoint: &Checkpoint,
        sequences: bool,
    ) -> Result<Self, OutputError> {
        folder.ensure_dir("annotations")?;
        let mut parts = Vec::new();
        for split in SplitName::ALL {
            let mut open = |what: &str| {
                let rel = format!("annotations/.instances_{}.{what}.part", split.as_str());
                let len = checkpoint.files.get(&rel).copied().unwrap_or(0);
                Ok::<_, OutputError>(folder.open_append(&rel, len)?.buffered())
            };
            let (images, annotations) = (open("images")?, open("annotations")?);
            let videos = if sequences {
                Some(open("videos")?)
            } else {
                None
            };
            let count = |what| {
                checkpoint
                    .counters
                    .get(&counter(split, what))
                    .copied()
                    .unwrap_or(0)
            };
            let (n_images, n_annotations) = (count("images"), count("annotations"));
            parts.push(Parts {
                images,
                annotations,
                videos,
                n_images,
                n_annotations,
                saved: (n_images, n_annotations),
            });
        }
        Ok(Self { parts })
    }
}

/// A frame's COCO image record (appended to `image_out`) and its annotation
/// records (to `annotations_out`; filtered drones have none), as
/// [`super::FrameText`] holds them: each annotation without its `id` and
/// opening brace, since ids run on per split file, and ended by a newline
/// (compact JSON holds none). Image ids are frame index + 1. Fields in byte
/// order of their names, the bytes serde_json writes for the same records
/// (the tests compare them). Pure, so a plan formats on every core.
pub fn write_frame_records(
    image_out: &mut Vec<u8>,
    annotations_out: &mut Vec<u8>,
    scene: &crate::scene::FrameScene,
    labels: &[crate::annotate::DroneLabel],
    image: &str,
    model_names: &[String],
) {
    let frame = (scene, labels);
    write_frame_records_with(image_out, annotations_out, frame, image, model_names, None);
}

/// [`write_frame_records`] with each drone's mask as a COCO RLE string
/// (`rle[drone]`, `output.masks.coco_rle`): the annotation gets
/// `"segmentation": {"counts": …, "size": [height, width]}` and its `area`
/// is the mask's pixel count (the visible pixels) instead of the box's area.
pub fn write_frame_records_with(
    image_out: &mut Vec<u8>,
    annotations_out: &mut Vec<u8>,
    (scene, labels): (&crate::scene::FrameScene, &[crate::annotate::DroneLabel]),
    image: &str,
    model_names: &[String],
    rle: Option<&[Option<String>]>,
) {
    write_image_record(&mut Json { out: image_out }, scene, image, model_names);
    let j = &mut Json {
        out: annotations_out,
    };
    for l in labels.iter().filter(|l| l.is_detection_label()) {
        let segmentation = rle.and_then(|r| r.get(l.drone)).and_then(Option::as_ref);
        write_annotation(j, scene, l, segmentation.map(String::as_str));
    }
}

/// TAO / COCO-VID: the frame's video id, from 1 (its frames count from 0:
/// `frame_id` for mmtracking's CocoVID, `frame_index` for TAO).
fn video_id(scene: &crate::scene::FrameScene) -> Option<u64> {
    scene.sequence.map(|seq| seq.id + 1)
}

/// A box as COCO's `[x, y, width, height]`.
fn xywh(j: &mut Json<'_>, b: &crate::annotate::PixelBox) {
    j.rounded_all(&[b.x0, b.y0, b.width(), b.height()], Decimals::Six);
}

/// The frame's image record. What varies per frame rides along, so results
/// can be broken down per scene.
fn write_image_record(
    j: &mut Json<'_>,
    scene: &crate::scene::FrameScene,
    image: &str,
    model_names: &[String],
) {
    j.raw(b"{\"environment\":");
    j.str(&scene.environment_name);
    j.raw(b",\"file_name\":");
    j.str(image.trim_start_matches("images/"));
    if let Some(seq) = scene.sequence {
        j.raw(b",\"frame_id\":");
        j.u64(seq.step);
        j.raw(b",\"frame_index\":");
        j.u64(seq.step);
    }
    j.raw(b",\"height\":");
    j.u64(scene.camera.height.into());
    j.raw(b",\"id\":");
    j.u64(scene.index + 1);
    j.raw(b",\"models\":");
    super::manifest::write_models_present(j, scene, model_names);
    j.raw(b",\"sweep\":");
    super::manifest::write_sweep(j, scene);
    if let Some(id) = video_id(scene) {
        j.raw(b",\"video_id\":");
        j.u64(id);
    }
    j.raw(b",\"width\":");
    j.u64(scene.camera.width.into());
    j.raw(b"}");
}

/// Drone label `l`'s annotation record, without its id and opening brace
/// (the writer opens the object with its id), ended by a newline;
/// `segmentation` is its mask's COCO RLE counts. One field after another,
/// in byte order of their names.
fn write_annotation(
    j: &mut Json<'_>,
    scene: &crate::scene::FrameScene,
    l: &crate::annotate::DroneLabel,
    segmentation: Option<&str>,
) {
    let b = &l.bbox;
    let video = video_id(scene);
    // Track ids unique over the dataset: video id × 1e6 + the drone's track id.
    let track_id = video.map(|id| id * TRACKS_PER_VIDEO + l.drone as u64 + 1);
    let v = l.visibility.as_ref();
    j.raw(b"\"amodal_bbox\":");
    xywh(j, &l.amodal);
    j.raw(b",\"area\":");
    match (segmentation, v) {
        (Some(_), Some(v)) => j.u64(v.visible_pixels),
        _ => j.rounded(b.area(), Decimals::Six),
    }
    j.raw(b",\"bbox\":");
    xywh(j, b);
    j.raw(b",\"category_id\":");
    j.u64(l.class_id as u64 + 1);
    j.raw(b",\"image_id\":");
    j.u64(scene.index + 1);
    if let Some(track) = track_id {
        j.raw(b",\"instance_id\":");
        j.u64(track);
    }
    j.raw(if l.status == LabelStatus::Crowd {
        b",\"iscrowd\":1"
    } else {
        b",\"iscrowd\":0"
    });
    j.raw(b",\"paper_aabb_bbox\":");
    xywh(j, &l.paper_aabb);
    if let Some(counts) = segmentation {
        j.raw(b",\"segmentation\":{\"counts\":");
        j.str(counts);
        j.raw(b",\"size\":[");
        j.u64(scene.camera.height.into());
        j.raw(b",");
        j.u64(scene.camera.width.into());
        j.raw(b"]}");
    }
    if let Some(track) = track_id {
        j.raw(b",\"track_id\":");
        j.u64(track);
    }
    j.raw(b",\"truncated\":");
    j.bool(l.truncated);
    if let Some(v) = v {
        j.raw(b",\"unoccluded_pixels\":");
        j.u64(v.unoccluded_pixels);
    }
    if let Some(id) = video {
        j.raw(b",\"video_id\":");
        j.u64(id);
    }
    if let Some(v) = v {
        j.raw(b",\"visible_bbox\":");
        match &v.visible_box {
            Some(vb) => xywh(j, vb),
            None => j.raw(b"null"),
        }
        j.raw(b",\"visible_fraction\":");
        j.rounded(v.fraction(), Decimals::Six);
        j.raw(b",\"visible_pixels\":");
        j.u64(v.visible_pixels);
    }
    j.raw(b"}\n");
}

/// `n` in decimal, as `{n}` formats it, in `buf`.
fn decimal(mut n: u64, buf: &mut [u8; 20]) -> &[u8] {
    let mut at = buf.len();
    loop {
        at -= 1;
        buf[at] = b'0' + (n % 10) as u8;
        n /= 10;
        if n == 0 {
            return &buf[at..];
        }
    }
}

impl FormatWriter for CocoWriter {
    fn frame(&mut self, _folder: &mut Folder, record: &FrameRecord<'_>) -> Result<(), OutputError> {
        let scene = record.scene;
        let part = &mut self.parts[scene.split as usize];
        if let (Some(videos), Some(seq)) = (&mut part.videos, scene.sequence)
            && seq.step == 0
        {
            let sep = if videos.is_empty() { "" } else { ",\n" };
            let name = super::mot::sequence_name(seq.id);
            let v = json!({"id": seq.id + 1, "name": name, "width": scene.camera.width, "height": scene.camera.height, "length": seq.steps + 1});
            videos.append(format!("{sep}{v}").as_bytes())?;
        }
        if part.n_images != 0 {
            part.images.append(b",\n")?;
        }
        part.images.append(record.text.coco_image)?;
        part.n_images += 1;
        let mut id = [0u8; 20];
        for rest in record
            .text
            .coco_annotations
            .split(|&b| b == b'\n')
            .filter(|r| !r.is_empty())
        {
            if part.n_annotations != 0 {
                part.annotations.append(b",\n")?;
            }
            part.n_annotations += 1;
            part.annotations.append(b"{\"id\":")?;
            part.annotations
                .append(decimal(part.n_annotations, &mut id))?;
            part.annotations.append(b",")?;
            part.annotations.append(rest)?;
        }
        Ok(())
    }

    fn flush(&mut self) -> Result<(), OutputError> {
        for part in &mut self.parts {
            part.images.flush()?;
            part.annotations.flush()?;
            if let Some(videos) = &mut part.videos {
                videos.flush()?;
            }
        }
        Ok(())
    }

    fn save(&mut self, checkpoint: &mut Checkpoint) {
        for (split, part) in SplitName::ALL.into_iter().zip(&mut self.parts) {
            part.images.save(checkpoint);
            part.annotations.save(checkpoint);
            if let Some(videos) = &mut part.videos {
                videos.save(checkpoint);
            }
            // Only what changed: this frame's split.
            if part.saved != (part.n_images, part.n_annotations) {
                part.saved = (part.n_images, part.n_annotations);
                checkpoint
                    .counters
                    .insert(counter(split, "images"), part.n_images);
                checkpoint
                    .counters
                    .insert(counter(split, "annotations"), part.n_annotations);
            }
        }
    }

    fn rollback(&mut self) {
        for part in &mut self.parts {
            part.images.rollback();
            part.annotations.rollback();
            if let Some(videos) = &mut part.videos {
                videos.rollback();
            }
        }
    }

    fn finish(&mut self, folder: &mut Folder, dataset: &DatasetInfo) -> Result<(), OutputError> {
        let categories: Vec<_> = dataset
            .classes
            .iter()
            .enumerate()
            .map(|(i, n)| json!({"id": i + 1, "name": n, "supercategory": "uav"}))
            .collect();
        let head = if dataset.labels_only {
            json!({"description": "swarmshot labels-only plan: NO IMAGES were rendered (file_name is the image a rendered run writes); boxes from geometry, Visible boxes estimated by amodal ones", "version": env!("CARGO_PKG_VERSION"), "labels_only": true})
        } else {
            json!({"description": "swarmshot synthetic UAV swarm dataset", "version": env!("CARGO_PKG_VERSION")})
        };
        let categories = serde_json::Value::from(categories);
        let (head, categories) = (&head, &categories);
        // The three splits' files assembled and flushed side by side.
        let files = (SplitName::ALL.into_iter().zip(&mut self.parts))
            .map(|(split, part)| {
                let rel = format!("annotations/instances_{}.json", split.as_str());
                let fill = move |out: &mut std::io::BufWriter<&std::fs::File>| {
                    write!(
                        out,
                        "{{\"info\": {head},\n\"licenses\": [],\n\"categories\": {categories},\n",
                    )?;
                    if let Some(videos) = &mut part.videos {
                        writeln!(out, "\"videos\": [")?;
                        videos.copy_to(out)?;
                        write!(out, "\n],\n")?;
                    }
                    writeln!(out, "\"images\": [")?;
                    part.images.copy_to(out)?;
                    write!(out, "\n],\n\"annotations\": [\n")?;
                    part.annotations.copy_to(out)?;
                    writeln!(out, "\n]}}")
                };
                (rel, fill)
            })
            .collect();
        folder.write_files_with(files)
    }

    /// The shard's records follow, as they are, but for the annotation ids:
    /// numbered on from this split's last one, as a single run numbers them
    /// (image, video and track ids are global already).
    fn merge_shard(
        &mut self,
        _folder: &mut Folder,
        shard: &mut ShardReader<'_>,
    ) -> Result<(), OutputError> {
        for (split, part) in SplitName::ALL.into_iter().zip(&mut self.parts) {
            let rel = format!("annotations/instances_{}.json", split.as_str());
            let path = shard.path(&rel);
            let bad = |reason: String| OutputError::Shard {
                path: path.clone(),
                reason,
            };
            let file = shard.open(&rel)?;
            let mut section = "";
            for (n, line) in std::io::BufReader::new(file).lines().enumerate() {
                let line = line.map_err(crate::write::io(&path))?;
                match line.as_str() {
                    "\"videos\": [" => section = "videos",
                    "\"images\": [" => section = "images",
                    "\"annotations\": [" => section = "annotations",
                    "]," | "]}" => section = "",
                    "" => {}
                    _ if section.is_empty() => {}
                    record => {
                        let record = record.strip_suffix(',').unwrap_or(record);
                        let mut value: serde_json::Value = serde_json::from_str(record)
                            .map_err(|e| bad(format!("line {}: {e}", n + 1)))?;
                        if !value.is_object() {
                            return Err(bad(format!("line {}: not a record", n + 1)));
                        }
                        match section {
                            "videos" => {
                                let Some(videos) = &mut part.videos else {
                                    return Err(bad(
                                        "holds videos, but this dataset has no sequences".into(),
                                    ));
                                };
                                let sep = if videos.is_empty() { "" } else { ",\n" };
                                videos.append(format!("{sep}{record}").as_bytes())?;
                            }
                            "images" => {
                                let sep = if part.n_images == 0 { "" } else { ",\n" };
                                part.images.append(format!("{sep}{record}").as_bytes())?;
                                part.n_images += 1;
                            }
                            _ => {
                                let sep = if part.n_annotations == 0 { "" } else { ",\n" };
                                part.n_annotations += 1;
                                let n = part.n_annotations;
                                // The writer puts `"id"` first; the rest stays as it is.
                                let renumbered = match record
                                    .strip_prefix("{\"id\":")
                                    .and_then(|r| r.split_once(','))
                                {
                                    Some((digits, rest))
                                        if !digits.is_empty()
                                            && digits.bytes().all(|b| b.is_ascii_digit()) =>
                                    {
                                        format!("{{\"id\":{n},{rest}")
                                    }
                                    _ => {
                                        value["id"] = n.into();
                                        value.to_string()
                                    }
                                };
                                part.annotations
                                    .append(format!("{sep}{renumbered}").as_bytes())?;
                            }
                        }
                    }
                }
            }
        }
        Ok(())
    }

    fn cleanup(&mut self, folder: &mut Folder) -> Result<(), OutputError> {
        for part in &self.parts {
            folder.remove(part.images.rel())?;
            folder.remove(part.annotations.rel())?;
            if let Some(videos) = &part.videos {
                folder.remove(videos.rel())?;
            }
        }
        Ok(())
    }
}

/// The records as serde writes them: the reference the tests compare the
/// hand-written records with, over varied frames.
#[cfg(test)]
pub(crate) mod reference {
    use super::TRACKS_PER_VIDEO;
    use crate::annotate::LabelStatus;
    use crate::write::{r6, xywh};

    // COCO records as plain structs, fields in byte order of their names (the
    // order a sorted JSON map writes them), serialised straight to text.

    #[derive(serde::Serialize)]
    struct ImageRecord<'a> {
        environment: &'a str,
        file_name: &'a str,
        #[serde(skip_serializing_if = "Option::is_none")]
        frame_id: Option<u64>,
        #[serde(skip_serializing_if = "Option::is_none")]
        frame_index: Option<u64>,
        height: u32,
        id: u64,
        models: Vec<&'a str>,
        sweep: crate::write::formats::manifest::reference::SweepRecord,
        #[serde(skip_serializing_if = "Option::is_none")]
        video_id: Option<u64>,
        width: u32,
    }

    /// An annotation without its `id` (the writer numbers them per split file).
    #[derive(serde::Serialize)]
    struct AnnotationRecord {
        amodal_bbox: [f64; 4],
        area: f64,
        bbox: [f64; 4],
        category_id: usize,
        image_id: u64,
        #[serde(skip_serializing_if = "Option::is_none")]
        instance_id: Option<u64>,
        iscrowd: u8,
        paper_aabb_bbox: [f64; 4],
        #[serde(skip_serializing_if = "Option::is_none")]
        track_id: Option<u64>,
        truncated: bool,
        #[serde(skip_serializing_if = "Option::is_none")]
        unoccluded_pixels: Option<u64>,
        #[serde(skip_serializing_if = "Option::is_none")]
        video_id: Option<u64>,
        /// `Some(None)` writes `null`: measured, nothing visible.
        #[serde(skip_serializing_if = "Option::is_none")]
        visible_bbox: Option<Option<[f64; 4]>>,
        #[serde(skip_serializing_if = "Option::is_none")]
        visible_fraction: Option<f64>,
        #[serde(skip_serializing_if = "Option::is_none")]
        visible_pixels: Option<u64>,
    }

    /// A frame's COCO image record and its annotation records (filtered
    /// drones have none), as [`super::FrameText`] holds them: each annotation
    /// without its `id` and opening brace, since ids run on per split file,
    /// and ended by a newline (compact JSON holds none). Image ids are frame
    /// index + 1. Pure, so a plan formats on every core.
    pub fn frame_records(
        scene: &crate::scene::FrameScene,
        labels: &[crate::annotate::DroneLabel],
        image: &str,
        model_names: &[String],
    ) -> (String, String) {
        let image_id = scene.index + 1;
        // TAO / COCO-VID: video ids from 1, frames from 0 (`frame_id` for
        // mmtracking's CocoVID, `frame_index` for TAO).
        let video = scene.sequence.map(|seq| (seq.id + 1, seq));
        // What varies per frame rides along, so results can be broken down per scene.
        let img = ImageRecord {
            environment: &scene.environment_name,
            file_name: image.trim_start_matches("images/"),
            frame_id: video.map(|(_, seq)| seq.step),
            frame_index: video.map(|(_, seq)| seq.step),
            height: scene.camera.height,
            id: image_id,
            models: crate::write::formats::manifest::models_present(scene, model_names),
            sweep: crate::write::formats::manifest::reference::sweep_record(scene),
            video_id: video.map(|(id, _)| id),
            width: scene.camera.width,
        };
        let mut annotations = Vec::with_capacity(320 * labels.len());
        let mut one = Vec::with_capacity(512);
        for l in labels.iter().filter(|l| l.is_detection_label()) {
            {
                let b = &l.bbox;
                // Track ids unique over the dataset: video id × 1e6 + the drone's track id.
                let track_id = video.map(|(id, _)| id * TRACKS_PER_VIDEO + l.drone as u64 + 1);
                let v = l.visibility.as_ref();
                let ann = AnnotationRecord {
                    amodal_bbox: xywh(&l.amodal),
                    area: r6(b.area()),
                    bbox: [r6(b.x0), r6(b.y0), r6(b.width()), r6(b.height())],
                    category_id: l.class_id + 1,
                    image_id,
                    instance_id: track_id,
                    iscrowd: u8::from(l.status == LabelStatus::Crowd),
                    paper_aabb_bbox: xywh(&l.paper_aabb),
                    track_id,
                    truncated: l.truncated,
                    unoccluded_pixels: v.map(|v| v.unoccluded_pixels),
                    video_id: video.map(|(id, _)| id),
                    visible_bbox: v.map(|v| v.visible_box.as_ref().map(xywh)),
                    visible_fraction: v.map(|v| r6(v.fraction())),
                    visible_pixels: v.map(|v| v.visible_pixels),
                };
                // The writer opens the object with its id. Plain data: serde_json
                // cannot fail here (non-finite numbers become null).
                one.clear();
                if serde_json::to_writer(&mut one, &ann).is_ok() {
                    annotations.extend_from_slice(one.strip_prefix(b"{").unwrap_or(&one));
                    annotations.push(b'\n');
                }
            }
        }
        (
            serde_json::to_string(&img).unwrap_or_default(),
            String::from_utf8(annotations).unwrap_or_default(),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::decimal;

    #[test]
    fn decimal_is_display() {
        let mut buf = [0u8; 20];
        for n in [0, 1, 9, 10, 99, 100, 12_345, 1_000_000, u64::MAX] {
            assert_eq!(decimal(n, &mut buf), n.to_string().as_bytes());
        }
    }
}
