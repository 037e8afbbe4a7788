//! COCO: `annotations/instances_{split}.json`. Image and annotation records
//! are streamed through part files and assembled at the end, so memory stays
//! flat at a million frames.

use std::fs::{self, File};
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use serde_json::json;

use super::{DatasetInfo, FormatWriter, FrameRecord, OutputError, io, r6, xywh};
use crate::annotate::LabelStatus;
use crate::scene::SplitName;

struct Parts {
    images: BufWriter<File>,
    annotations: BufWriter<File>,
    images_path: PathBuf,
    annotations_path: PathBuf,
    n_images: u64,
    n_annotations: u64,
}

/// Writes the three COCO files.
pub struct CocoWriter {
    dir: PathBuf,
    parts: Vec<Parts>,
}

impl CocoWriter {
    pub fn create(root: &Path) -> Result<Self, OutputError> {
        let dir = root.join("annotations");
        fs::create_dir_all(&dir).map_err(io(&dir))?;
        let mut parts = Vec::new();
        for split in SplitName::ALL {
            let images_path = dir.join(format!(".instances_{}.images.part", split.as_str()));
            let annotations_path =
                dir.join(format!(".instances_{}.annotations.part", split.as_str()));
            parts.push(Parts {
                images: BufWriter::new(File::create(&images_path).map_err(io(&images_path))?),
                annotations: BufWriter::new(
                    File::create(&annotations_path).map_err(io(&annotations_path))?,
                ),
                images_path,
                annotations_path,
                n_images: 0,
                n_annotations: 0,
            });
        }
        Ok(Self { dir, parts })
    }
}

impl FormatWriter for CocoWriter {
    fn frame(&mut self, record: &FrameRecord<'_>) -> Result<(), OutputError> {
        let scene = record.scene;
        let part = &mut self.parts[scene.split as usize];
        let image_id = scene.index + 1;
        let sep = if part.n_images == 0 { "" } else { ",\n" };
        let img = json!({"id": image_id, "file_name": record.image.trim_start_matches("images/"), "width": scene.camera.width, "height": scene.camera.height});
        write!(part.images, "{sep}{img}").map_err(io(&part.images_path))?;
        part.n_images += 1;
        for l in record
            .labels
            .iter()
            .filter(|l| l.status != LabelStatus::Filtered)
        {
            let b = &l.bbox;
            let sep = if part.n_annotations == 0 { "" } else { ",\n" };
            part.n_annotations += 1;
            let mut ann = json!({
                "id": part.n_annotations,
                "image_id": image_id,
                "category_id": l.class_id + 1,
                "bbox": [r6(b.x0), r6(b.y0), r6(b.width()), r6(b.height())],
                "area": r6(b.area()),
                "iscrowd": u8::from(l.status == LabelStatus::Crowd),
                "truncated": l.truncated,
                "amodal_bbox": xywh(&l.amodal),
                "paper_aabb_bbox": xywh(&l.paper_aabb),
            });
            if let Some(v) = &l.visibility {
                ann["visible_pixels"] = v.visible_pixels.into();
                ann["unoccluded_pixels"] = v.unoccluded_pixels.into();
                ann["visible_fraction"] = r6(v.fraction()).into();
                ann["visible_bbox"] = v.visible_box.as_ref().map(xywh).into();
            }
            write!(part.annotations, "{sep}{ann}").map_err(io(&part.annotations_path))?;
        }
        Ok(())
    }

    fn finish(self: Box<Self>, dataset: &DatasetInfo) -> Result<(), OutputError> {
        let categories: Vec<_> = dataset
            .classes
            .iter()
            .enumerate()
            .map(|(i, n)| json!({"id": i + 1, "name": n, "supercategory": "uav"}))
            .collect();
        for (split, mut part) in SplitName::ALL.into_iter().zip(self.parts) {
            part.images.flush().map_err(io(&part.images_path))?;
            part.annotations
                .flush()
                .map_err(io(&part.annotations_path))?;
            drop((part.images, part.annotations));
            let path = self.dir.join(format!("instances_{}.json", split.as_str()));
            let mut out = BufWriter::new(File::create(&path).map_err(io(&path))?);
            let head = json!({"description": "swarmshot synthetic UAV swarm dataset", "version": env!("CARGO_PKG_VERSION")});
            let write_all = |out: &mut BufWriter<File>| -> std::io::Result<()> {
                write!(
                    out,
                    "{{\"info\": {head},\n\"licenses\": [],\n\"categories\": {},\n\"images\": [\n",
                    serde_json::Value::from(categories.clone())
                )?;
                std::io::copy(&mut File::open(&part.images_path)?, out)?;
                write!(out, "\n],\n\"annotations\": [\n")?;
                std::io::copy(&mut File::open(&part.annotations_path)?, out)?;
                writeln!(out, "\n]}}")?;
                out.flush()
            };
            write_all(&mut out).map_err(io(&path))?;
            for p in [&part.images_path, &part.annotations_path] {
                fs::remove_file(p).map_err(io(p))?;
            }
        }
        Ok(())
    }
}
