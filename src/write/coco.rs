//! COCO: `annotations/instances_{split}.json`. Image and annotation records
//! are appended to part files (`annotations/.instances_{split}.*.part`) as
//! frames are written and assembled at the end, so memory stays flat at a
//! million frames and a resumed run assembles the same bytes. The parts are
//! deleted once the whole dataset is written.

use std::io::{BufRead, Write};
use std::path::Path;

use serde_json::json;

use super::folder::AppendFile;
use super::{Checkpoint, DatasetInfo, Folder, FormatWriter, FrameRecord, OutputError, r6, xywh};
use crate::annotate::LabelStatus;
use crate::scene::SplitName;

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
                folder.open_append(&rel, len)
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

impl FormatWriter for CocoWriter {
    fn frame(&mut self, _folder: &mut Folder, record: &FrameRecord<'_>) -> Result<(), OutputError> {
        let scene = record.scene;
        let part = &mut self.parts[scene.split as usize];
        let image_id = scene.index + 1;
        let sep = if part.n_images == 0 { "" } else { ",\n" };
        let mut img = json!({"id": image_id, "file_name": record.image.trim_start_matches("images/"), "width": scene.camera.width, "height": scene.camera.height});
        // TAO / COCO-VID: video ids from 1, frames from 0 (`frame_id` for
        // mmtracking's CocoVID, `frame_index` for TAO).
        let video = scene.sequence.map(|seq| (seq.id + 1, seq));
        if let Some((video_id, seq)) = video {
            img["video_id"] = video_id.into();
            img["frame_id"] = seq.step.into();
            img["frame_index"] = seq.step.into();
        }
        let mut n_annotations = part.n_annotations;
        let mut anns = String::new();
        for l in record
            .labels
            .iter()
            .filter(|l| l.status != LabelStatus::Filtered)
        {
            let b = &l.bbox;
            let sep = if n_annotations == 0 { "" } else { ",\n" };
            n_annotations += 1;
            let mut ann = json!({
                "id": n_annotations,
                "image_id": image_id,
                "category_id": l.class_id + 1,
                "bbox": [r6(b.x0), r6(b.y0), r6(b.width()), r6(b.height())],
                "area": r6(b.area()),
                "iscrowd": u8::from(l.status == LabelStatus::Crowd),
                "truncated": l.truncated,
                "amodal_bbox": xywh(&l.amodal),
                "paper_aabb_bbox": xywh(&l.paper_aabb),
            });
            if let Some((video_id, _)) = video {
                // Track ids unique over the dataset: video id × 1e6 + the drone's track id.
                let track_id = video_id * TRACKS_PER_VIDEO + l.drone as u64 + 1;
                ann["video_id"] = video_id.into();
                ann["track_id"] = track_id.into();
                ann["instance_id"] = track_id.into();
            }
            if let Some(v) = &l.visibility {
                ann["visible_pixels"] = v.visible_pixels.into();
                ann["unoccluded_pixels"] = v.unoccluded_pixels.into();
                ann["visible_fraction"] = r6(v.fraction()).into();
                ann["visible_bbox"] = v.visible_box.as_ref().map(xywh).into();
            }
            anns.push_str(&format!("{sep}{ann}"));
        }
        if let (Some(videos), Some((video_id, seq))) = (&mut part.videos, video)
            && seq.step == 0
        {
            let sep = if videos.is_empty() { "" } else { ",\n" };
            let name = super::mot::sequence_name(seq.id);
            let v = json!({"id": video_id, "name": name, "width": scene.camera.width, "height": scene.camera.height, "length": seq.steps + 1});
            videos.append(format!("{sep}{v}").as_bytes())?;
        }
        part.images.append(format!("{sep}{img}").as_bytes())?;
        part.n_images += 1;
        if !anns.is_empty() {
            part.annotations.append(anns.as_bytes())?;
        }
        part.n_annotations = n_annotations;
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
        let head = json!({"description": "swarmshot synthetic UAV swarm dataset", "version": env!("CARGO_PKG_VERSION")});
        for (split, part) in SplitName::ALL.into_iter().zip(&mut self.parts) {
            let rel = format!("annotations/instances_{}.json", split.as_str());
            folder.write_file_with(&rel, |out| {
                write!(
                    out,
                    "{{\"info\": {head},\n\"licenses\": [],\n\"categories\": {},\n",
                    serde_json::Value::from(categories.clone())
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
            })?;
        }
        Ok(())
    }

    /// The shard's records follow, as they are, but for the annotation ids:
    /// numbered on from this split's last one, as a single run numbers them
    /// (image, video and track ids are global already).
    fn merge_shard(&mut self, _folder: &mut Folder, shard: &Path) -> Result<(), OutputError> {
        for (split, part) in SplitName::ALL.into_iter().zip(&mut self.parts) {
            let path = shard.join(format!("annotations/instances_{}.json", split.as_str()));
            let bad = |reason: String| OutputError::Shard {
                path: path.clone(),
                reason,
            };
            let file = std::fs::File::open(&path).map_err(super::io(&path))?;
            let mut section = "";
            for (n, line) in std::io::BufReader::new(file).lines().enumerate() {
                let line = line.map_err(super::io(&path))?;
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
                                value["id"] = part.n_annotations.into();
                                part.annotations
                                    .append(format!("{sep}{value}").as_bytes())?;
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
