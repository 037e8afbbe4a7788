//! Masks and maps on disk (`output.masks`, docs/conventions.md "Masks and
//! maps"): a frame's [`FrameMasks`] encoded on the encoder threads into
//! [`EncodedMasks`] (COCO RLE strings for the COCO writer, the YOLO
//! segmentation label file, the 16-bit instance and depth PNGs, the KITTI
//! flow PNG), and the [`MasksWriter`] that writes the per-frame files
//! through the [`Folder`].

use image::Luma;

use super::{DatasetInfo, FormatWriter, FrameRecord};
use crate::annotate::flow::FrameFlow;
use crate::annotate::masks::FrameMasks;
use crate::annotate::{DroneLabel, LabelStatus, rle};
use crate::preset::masks::{MAX_INSTANCE_ID, MaskOutputs};
use crate::scene::{FrameScene, SplitName};
use crate::write::{EncodeError, Folder, OutputError, stem};

/// One frame's masks, ready to write.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct EncodedMasks {
    /// Per drone (scene order): its COCO RLE string (pycocotools' compressed
    /// form), for the drones COCO annotates (`coco_rle` on; else empty).
    pub rle: Vec<Option<String>>,
    /// The YOLO segmentation label file (`yolo_seg` on).
    pub yolo_seg: Option<Vec<u8>>,
    /// The instance PNG (`instance_png` on).
    pub instance_png: Option<Vec<u8>>,
    /// The depth PNG (`depth` on).
    pub depth_png: Option<Vec<u8>>,
    /// The KITTI flow PNG (`flow` on and the frame has a next in its sequence).
    pub flow_png: Option<Vec<u8>>,
}

/// Encode what `outputs` asks for of one frame's masks.
pub fn encode(
    masks: &FrameMasks,
    labels: &[DroneLabel],
    outputs: &MaskOutputs,
) -> Result<EncodedMasks, OutputError> {
    let len = u64::from(masks.width) * u64::from(masks.height);
    let mut rle = Vec::new();
    if outputs.coco_rle {
        rle = vec![None; masks.pixels.len()];
        for l in labels.iter().filter(|l| l.status != LabelStatus::Filtered) {
            if let (Some(slot), Some(pixels)) = (rle.get_mut(l.drone), masks.pixels.get(l.drone)) {
                *slot = Some(rle::to_coco_string(&rle::counts(pixels, len)));
            }
        }
    }
    Ok(EncodedMasks {
        rle,
        yolo_seg: outputs.yolo_seg.then(|| yolo_seg_text(masks, labels)),
        instance_png: if outputs.instance_png {
            Some(instance_png(masks)?)
        } else {
            None
        },
        depth_png: outputs
            .depth
            .then(|| depth_png(masks, outputs.depth_unit_mm)),
        flow_png: match masks.flow.as_ref().filter(|_| outputs.flow) {
            Some(flow) => Some(flow_png(masks, flow)?),
            None => None,
        },
    })
}

/// One line per training box (the order of the YOLO detection file):
/// `class x1 y1 x2 y2 …`, the vertices of the largest outer contour of the
/// drone's visible pixels (imageproc's border following, the centres of
/// the boundary pixels), normalised to the image size. A mask whose
/// largest contour has fewer than three points (its largest piece is one or
/// two pixels) gets its whole box's corners.
pub fn yolo_seg_text(masks: &FrameMasks, labels: &[DroneLabel]) -> Vec<u8> {
    use super::json::{decimal, fixed6};
    let (w, h) = (f64::from(masks.width), f64::from(masks.height));
    let mut out = Vec::new();
    for l in labels.iter().filter(|l| l.is_kept()) {
        let polygon = outline(masks, l.drone).unwrap_or_else(|| {
            let b = &l.bbox;
            vec![(b.x0, b.y0), (b.x1, b.y0), (b.x1, b.y1), (b.x0, b.y1)]
        });
        decimal(&mut out, l.class_id as u64);
        for (x, y) in polygon {
            out.push(b' ');
            fixed6(&mut out, (x / w).clamp(0.0, 1.0));
            out.push(b' ');
            fixed6(&mut out, (y / h).clamp(0.0, 1.0));
        }
        out.push(b'\n');
    }
    out
}

/// The largest outer contour of drone `d`'s mask, as pixel-centre
/// coordinates; `None` when it has fewer than three points.
fn outline(masks: &FrameMasks, d: usize) -> Option<Vec<(f64, f64)>> {
    let b = masks.bbox(d)?;
    let (x0, y0) = (b.x0 as u32, b.y0 as u32);
    // One pixel of background around the mask, so its border is traced whole.
    let (cw, ch) = (b.width() as u32 + 2, b.height() as u32 + 2);
    let mut crop = image::GrayImage::new(cw, ch);
    let h = masks.height.max(1);
    for &i in masks.pixels.get(d)? {
        let (x, y) = (i / h, i % h);
        crop.put_pixel(x - x0 + 1, y - y0 + 1, Luma([255]));
    }
    let contours = imageproc::contours::find_contours::<i32>(&crop);
    let best = contours
        .iter()
        .filter(|c| c.border_type == imageproc::contours::BorderType::Outer)
        .max_by_key(|c| c.points.len())?;
    (best.points.len() >= 3).then(|| {
        best.points
            .iter()
            .map(|p| {
                (
                    f64::from(x0) + f64::from(p.x - 1) + 0.5,
                    f64::from(y0) + f64::from(p.y - 1) + 0.5,
                )
            })
            .collect()
    })
}

/// The instance image as a 16-bit grey PNG: 0 where no drone shows, else
/// the drone's index + 1 (the manifest's `drone` + 1), written in time
/// proportional to the pixels drones cover ([`crate::write::encode::sparse_png`]).
pub fn instance_png(masks: &FrameMasks) -> Result<Vec<u8>, OutputError> {
    let pixels = (masks.instance.iter())
        .map(|&(i, d)| {
            u16::try_from(d as usize + 1)
                .ok()
                .filter(|&id| usize::from(id) <= MAX_INSTANCE_ID)
                .map(|id| (i, id))
                .ok_or(OutputError::Encode {
                    format: "instance PNG",
                    source: EncodeError::InstanceId(d),
                })
        })
        .collect::<Result<Vec<_>, _>>()?;
    Ok(crate::write::encode::sparse_png::grey16(
        masks.width,
        masks.height,
        &pixels,
    ))
}

/// The depth map as a 16-bit grey PNG: at each pixel of the instance
/// image, its depth in units of `unit_mm` millimetres, rounded, at least 1
/// and at most 65535 (that far or farther); 0 where no drone shows.
pub fn depth_png(masks: &FrameMasks, unit_mm: u32) -> Vec<u8> {
    let unit_m = f64::from(unit_mm.max(1)) / 1000.0;
    // In the CPU's widest build, where `round` is inline instructions, not
    // a call into libm per pixel (the same values in every build).
    let pixels: Vec<(u32, u16)> = crate::simd::widest(
        #[inline(always)]
        || {
            (masks.instance.iter().zip(&masks.depth_m))
                .map(|(&(i, _), &z)| (i, (z / unit_m).round().clamp(1.0, 65_535.0) as u16))
                .collect()
        },
    );
    crate::write::encode::sparse_png::grey16(masks.width, masks.height, &pixels)
}

/// The flow to the next frame as KITTI's 16-bit RGB PNG
/// ([`crate::annotate::flow::kitti_rgb16`]), rows filtered `Up` (a still
/// background's rows are then all zero) and compressed fast.
pub fn flow_png(masks: &FrameMasks, flow: &FrameFlow) -> Result<Vec<u8>, OutputError> {
    use image::ImageEncoder as _;
    use image::codecs::png::{CompressionType, FilterType, PngEncoder};
    let samples = crate::annotate::flow::kitti_rgb16(flow, &masks.instance);
    let bytes: Vec<u8> = samples.iter().flat_map(|v| v.to_ne_bytes()).collect();
    let mut png = Vec::new();
    PngEncoder::new_with_quality(&mut png, CompressionType::Fast, FilterType::Up)
        .write_image(
            &bytes,
            masks.width,
            masks.height,
            image::ExtendedColorType::Rgb16,
        )
        .map_err(|e| OutputError::Encode {
            format: "flow PNG",
            source: EncodeError::Png(e),
        })?;
    Ok(png)
}

/// Whether frame `scene` gets a flow PNG: it has a next frame in its sequence.
pub fn has_flow(scene: &FrameScene) -> bool {
    scene.sequence.is_some_and(|s| s.step < s.steps)
}

/// A frame's flow PNG relative to the dataset folder.
pub fn flow_rel_path(scene: &FrameScene) -> String {
    format!("flow/{}/{}.png", scene.split.as_str(), stem(scene.index))
}

/// A frame's depth PNG relative to the dataset folder.
pub fn depth_rel_path(scene: &FrameScene) -> String {
    format!("depth/{}/{}.png", scene.split.as_str(), stem(scene.index))
}

/// The root of the segmentation layout Ultralytics reads as written:
/// `seg/images/{split}/NAME.ext` (hard links to the dataset's images, no
/// second copy) beside `seg/labels/{split}/NAME.txt` (the polygons), named by
/// `data-seg.yaml`. Ultralytics finds a label by replacing the last
/// `/images/` of the image's path with `/labels/` (`img2label_paths`), so the
/// polygons must sit beside an `images` folder of their own (docs/conventions.md).
pub const SEG_ROOT: &str = "seg";

/// A frame's YOLO segmentation label file relative to the dataset folder.
pub fn yolo_seg_rel_path(scene: &FrameScene) -> String {
    format!(
        "{SEG_ROOT}/labels/{}/{}.txt",
        scene.split.as_str(),
        stem(scene.index)
    )
}

/// The segmentation layout's link to a frame's image (`image` relative to
/// the dataset folder: `images/{split}/NAME.ext`).
pub fn seg_image_rel_path(image: &str) -> String {
    format!("{SEG_ROOT}/{image}")
}

/// A frame's instance PNG relative to the dataset folder.
pub fn instance_rel_path(scene: &FrameScene) -> String {
    format!("masks/{}/{}.png", scene.split.as_str(), stem(scene.index))
}

/// The folders (and `data-seg.yaml`) a dataset with `outputs` holds besides the others (the ledger's fixed entries).
pub fn needed_entries(outputs: &MaskOutputs) -> Vec<String> {
    let mut needed = Vec::new();
    for split in SplitName::ALL.map(SplitName::as_str) {
        if outputs.yolo_seg {
            needed.push(format!("{SEG_ROOT}/labels/{split}/"));
            needed.push(format!("{SEG_ROOT}/images/{split}/"));
        }
        if outputs.instance_png {
            needed.push(format!("masks/{split}/"));
        }
        if outputs.depth {
            needed.push(format!("depth/{split}/"));
        }
        if outputs.flow {
            needed.push(format!("flow/{split}/"));
        }
    }
    if outputs.yolo_seg {
        needed.push("data-seg.yaml".to_owned());
    }
    needed
}

/// Writes the per-frame mask files (the COCO RLE rides in the COCO records).
pub struct MasksWriter {
    outputs: MaskOutputs,
}

impl MasksWriter {
    /// The writer of `outputs`' files, with their folders made.
    pub fn create(folder: &mut Folder, outputs: MaskOutputs) -> Result<Self, OutputError> {
        for dir in needed_entries(&outputs) {
            if let Some(dir) = dir.strip_suffix('/') {
                folder.ensure_dir(dir)?;
            }
        }
        Ok(Self { outputs })
    }
}

impl FormatWriter for MasksWriter {
    fn frame_files(&self, scene: &FrameScene) -> Vec<String> {
        let mut files = Vec::new();
        if self.outputs.yolo_seg {
            files.push(yolo_seg_rel_path(scene));
        }
        if self.outputs.instance_png {
            files.push(instance_rel_path(scene));
        }
        if self.outputs.depth {
            files.push(depth_rel_path(scene));
        }
        if self.outputs.flow && has_flow(scene) {
            files.push(flow_rel_path(scene));
        }
        files
    }

    fn frame(&mut self, folder: &mut Folder, record: &FrameRecord<'_>) -> Result<(), OutputError> {
        let missing = || OutputError::Encode {
            format: "masks",
            source: EncodeError::NoMasks(record.scene.index),
        };
        let masks = record.masks.ok_or_else(missing)?;
        if self.outputs.yolo_seg {
            let text = masks.yolo_seg.as_deref().ok_or_else(missing)?;
            folder.write_frame_file(&yolo_seg_rel_path(record.scene), text)?;
            // The image's second name: a hard link in the segmentation layout.
            folder.link_frame_file(record.image, &seg_image_rel_path(record.image))?;
        }
        if self.outputs.instance_png {
            let png = masks.instance_png.as_deref().ok_or_else(missing)?;
            folder.write_frame_file(&instance_rel_path(record.scene), png)?;
        }
        if self.outputs.depth {
            let png = masks.depth_png.as_deref().ok_or_else(missing)?;
            folder.write_frame_file(&depth_rel_path(record.scene), png)?;
        }
        if self.outputs.flow && has_flow(record.scene) {
            let png = masks.flow_png.as_deref().ok_or_else(missing)?;
            folder.write_frame_file(&flow_rel_path(record.scene), png)?;
        }
        Ok(())
    }

    fn finish(&mut self, folder: &mut Folder, dataset: &DatasetInfo) -> Result<(), OutputError> {
        if !self.outputs.yolo_seg || dataset.labels_only {
            return Ok(());
        }
        folder.write_file(
            "data-seg.yaml",
            data_seg_yaml(&dataset.classes, dataset.frames_per_split).as_bytes(),
        )
    }
}

/// `data-seg.yaml`: `data.yaml` (the same classes, the same rules for empty
/// splits, no `path:`) with every split's images taken from
/// `seg/images/{split}`, whose `seg/labels/{split}` holds the polygons, for
/// `yolo segment train data=OUT/data-seg.yaml`.
pub fn data_seg_yaml(classes: &[String], frames_per_split: [u64; 3]) -> String {
    let yaml = super::yolo::data_yaml_for_splits(classes, frames_per_split);
    let mut out = String::from(
        "# Ultralytics YOLO segmentation dataset written by swarmshot: the images are hard links in\n# seg/images/, the polygons in seg/labels/ (Ultralytics reads labels beside images/).\n# No `path`: the folder holding this file is the root, so the folder can be copied or moved.\n",
    );
    for line in yaml
        .lines()
        .filter(|l| !l.starts_with("# Ultralytics") && !l.starts_with("# holding"))
    {
        for key in ["train: ", "val: ", "test: "] {
            if let Some(rest) = line.strip_prefix(key) {
                out.push_str(&format!("{key}{SEG_ROOT}/{rest}\n"));
                break;
            }
        }
        if !["train: ", "val: ", "test: "]
            .iter()
            .any(|k| line.starts_with(k))
        {
            out.push_str(line);
            out.push('\n');
        }
    }
    out
}
