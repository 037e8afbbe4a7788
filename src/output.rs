//! Dataset writers, apart from rendering: image encoding, the Ultralytics YOLO
//! layout, COCO annotations, the pose manifest and the locked preset.
//!
//! Frames are written in index order by one sink, so label files, COCO ids and
//! the manifest are byte-identical run to run. COCO files are streamed through
//! part files and assembled at the end, so memory stays flat at a million frames.

use std::fs::{self, File};
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use serde_json::json;

use crate::labels::{DroneLabel, LabelStatus, PixelBox};
use crate::preset::{ImageFormat, LabelFormat, Preset};
use crate::scene::{FrameScene, SplitName};

/// Files and folders a dataset consists of (what `--overwrite` replaces).
const OWNED: &[&str] = &[
    "images",
    "labels",
    "annotations",
    "manifest.jsonl",
    "data.yaml",
    "preset.lock.ron",
    "stats.json",
];
const LOCK_FILE: &str = "preset.lock.ron";

#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    #[error("{}: {source}", path.display())]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error(
        "output folder {} is not empty and is not an earlier output of this preset; choose another folder or pass --overwrite",
        path.display()
    )]
    NotEmpty { path: PathBuf },
    #[error("encoding {format} failed: {reason}")]
    Encode {
        format: &'static str,
        reason: String,
    },
}

fn io(path: &Path) -> impl FnOnce(std::io::Error) -> OutputError + '_ {
    move |source| OutputError::Io {
        path: path.to_owned(),
        source,
    }
}

/// Encode tightly packed RGBA8 pixels as JPEG or PNG (alpha dropped).
pub fn encode_image(
    rgba: &[u8],
    width: u32,
    height: u32,
    format: ImageFormat,
) -> Result<Vec<u8>, OutputError> {
    let rgb: Vec<u8> = rgba
        .chunks_exact(4)
        .flat_map(|p| [p[0], p[1], p[2]])
        .collect();
    match format {
        ImageFormat::Jpeg { quality } => {
            let mut out = Vec::with_capacity(rgb.len() / 8);
            let encoder = jpeg_encoder::Encoder::new(&mut out, quality);
            let (w, h) = (u16::try_from(width), u16::try_from(height));
            let (Ok(w), Ok(h)) = (w, h) else {
                return Err(OutputError::Encode {
                    format: "JPEG",
                    reason: format!("{width}×{height} exceeds JPEG's 65535 px side"),
                });
            };
            encoder
                .encode(&rgb, w, h, jpeg_encoder::ColorType::Rgb)
                .map_err(|e| OutputError::Encode {
                    format: "JPEG",
                    reason: e.to_string(),
                })?;
            Ok(out)
        }
        ImageFormat::Png => {
            let mut out = Vec::new();
            let encoder = image::codecs::png::PngEncoder::new_with_quality(
                &mut out,
                image::codecs::png::CompressionType::Fast,
                image::codecs::png::FilterType::Adaptive,
            );
            image::ImageEncoder::write_image(
                encoder,
                &rgb,
                width,
                height,
                image::ExtendedColorType::Rgb8,
            )
            .map_err(|e| OutputError::Encode {
                format: "PNG",
                reason: e.to_string(),
            })?;
            Ok(out)
        }
    }
}

/// Round to a fixed number of decimals so files do not depend on the last ulp.
fn r6(x: f64) -> f64 {
    (x * 1e6).round() / 1e6
}

fn box_xyxy(b: &PixelBox) -> [f64; 4] {
    [r6(b.x0), r6(b.y0), r6(b.x1), r6(b.y1)]
}

/// Counts gathered while writing.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct DatasetStats {
    pub frames: u64,
    pub frames_per_split: [u64; 3],
    pub boxes: u64,
    /// √(w·h) < 32, 32–96, > 96 px.
    pub small: u64,
    pub medium: u64,
    pub large: u64,
    pub truncated: u64,
    /// Filtered drones kept as COCO ignore regions.
    pub crowd: u64,
    /// Drones in front of the camera that got no training box.
    pub filtered: u64,
    pub drones_placed: u64,
}

impl DatasetStats {
    pub fn add(&mut self, scene: &FrameScene, labels: &[DroneLabel]) {
        self.frames += 1;
        self.frames_per_split[scene.split as usize] += 1;
        self.drones_placed += scene.drones.len() as u64;
        for l in labels {
            match l.status {
                LabelStatus::Kept => {}
                LabelStatus::Crowd => {
                    self.crowd += 1;
                    continue;
                }
                LabelStatus::Filtered => {
                    self.filtered += 1;
                    continue;
                }
            }
            self.boxes += 1;
            let s = l.bbox.area().sqrt();
            if s < 32.0 {
                self.small += 1;
            } else if s <= 96.0 {
                self.medium += 1;
            } else {
                self.large += 1;
            }
            self.truncated += u64::from(l.truncated);
        }
    }
}

struct CocoParts {
    images: BufWriter<File>,
    annotations: BufWriter<File>,
    images_path: PathBuf,
    annotations_path: PathBuf,
    n_images: u64,
    n_annotations: u64,
}

/// Writes one dataset folder. Call [`DatasetWriter::write_frame`] in index order, then [`DatasetWriter::finish`].
pub struct DatasetWriter {
    root: PathBuf,
    image_format: ImageFormat,
    yolo: bool,
    classes: Vec<String>,
    model_names: Vec<String>,
    manifest: BufWriter<File>,
    coco: Option<Vec<CocoParts>>,
    stats: DatasetStats,
}

impl DatasetWriter {
    /// Prepare `root`: refuse a non-empty folder that is not an earlier output
    /// of the same preset (unless `overwrite`), create the layout and write the lock.
    pub fn create(
        root: &Path,
        preset: &Preset,
        model_names: Vec<String>,
        overwrite: bool,
    ) -> Result<Self, OutputError> {
        let lock = preset.to_ron();
        if root.exists() {
            let non_empty = fs::read_dir(root).map_err(io(root))?.next().is_some();
            let same_preset = fs::read_to_string(root.join(LOCK_FILE)).is_ok_and(|old| old == lock);
            if non_empty && !same_preset && !overwrite {
                return Err(OutputError::NotEmpty {
                    path: root.to_owned(),
                });
            }
            if non_empty {
                for name in OWNED {
                    let p = root.join(name);
                    if p.is_dir() {
                        fs::remove_dir_all(&p).map_err(io(&p))?;
                    } else if p.exists() {
                        fs::remove_file(&p).map_err(io(&p))?;
                    }
                }
            }
        }
        let yolo = preset.output.label_formats.contains(&LabelFormat::Yolo);
        let coco = preset.output.label_formats.contains(&LabelFormat::Coco);
        for split in SplitName::ALL {
            let dir = root.join("images").join(split.as_str());
            fs::create_dir_all(&dir).map_err(io(&dir))?;
            if yolo {
                let dir = root.join("labels").join(split.as_str());
                fs::create_dir_all(&dir).map_err(io(&dir))?;
            }
        }
        let lock_path = root.join(LOCK_FILE);
        fs::write(&lock_path, &lock).map_err(io(&lock_path))?;
        let manifest_path = root.join("manifest.jsonl");
        let manifest = BufWriter::new(File::create(&manifest_path).map_err(io(&manifest_path))?);
        let coco = if coco {
            let dir = root.join("annotations");
            fs::create_dir_all(&dir).map_err(io(&dir))?;
            let mut parts = Vec::new();
            for split in SplitName::ALL {
                let images_path = dir.join(format!(".instances_{}.images.part", split.as_str()));
                let annotations_path =
                    dir.join(format!(".instances_{}.annotations.part", split.as_str()));
                parts.push(CocoParts {
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
            Some(parts)
        } else {
            None
        };
        let (classes, _) = preset.classes();
        Ok(Self {
            root: root.to_owned(),
            image_format: preset.output.image_format,
            yolo,
            classes,
            model_names,
            manifest,
            coco,
            stats: DatasetStats::default(),
        })
    }

    /// File stem of a frame: its zero-padded index.
    pub fn stem(index: u64) -> String {
        format!("{index:08}")
    }

    /// Relative path of a frame's image.
    pub fn image_rel_path(&self, scene: &FrameScene) -> String {
        format!(
            "images/{}/{}.{}",
            scene.split.as_str(),
            Self::stem(scene.index),
            self.image_format.extension()
        )
    }

    /// Write one frame's image bytes and all of its labels.
    pub fn write_frame(
        &mut self,
        scene: &FrameScene,
        labels: &[DroneLabel],
        image: &[u8],
    ) -> Result<(), OutputError> {
        let rel = self.image_rel_path(scene);
        let image_path = self.root.join(&rel);
        fs::write(&image_path, image).map_err(io(&image_path))?;
        let (w, h) = (
            f64::from(scene.camera.width),
            f64::from(scene.camera.height),
        );
        if self.yolo {
            let mut text = String::new();
            // YOLO has no ignore flag: crowd regions stay out of its files.
            for l in labels.iter().filter(|l| l.is_kept()) {
                let b = &l.bbox;
                let cx = (b.x0 + b.x1) * 0.5 / w;
                let cy = (b.y0 + b.y1) * 0.5 / h;
                text.push_str(&format!(
                    "{} {:.6} {:.6} {:.6} {:.6}\n",
                    l.class_id,
                    cx,
                    cy,
                    b.width() / w,
                    b.height() / h
                ));
            }
            let path = self
                .root
                .join("labels")
                .join(scene.split.as_str())
                .join(format!("{}.txt", Self::stem(scene.index)));
            fs::write(&path, text).map_err(io(&path))?;
        }
        if let Some(parts) = &mut self.coco {
            let part = &mut parts[scene.split as usize];
            let image_id = scene.index + 1;
            let sep = if part.n_images == 0 { "" } else { ",\n" };
            let img = json!({"id": image_id, "file_name": rel.trim_start_matches("images/"), "width": scene.camera.width, "height": scene.camera.height});
            write!(part.images, "{sep}{img}").map_err(io(&part.images_path))?;
            part.n_images += 1;
            for l in labels.iter().filter(|l| l.status != LabelStatus::Filtered) {
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
        }
        let line = manifest_line(scene, labels, &rel, &self.model_names, &self.classes);
        writeln!(self.manifest, "{line}").map_err(io(&self.root.join("manifest.jsonl")))?;
        self.stats.add(scene, labels);
        Ok(())
    }

    /// Close the manifest, assemble COCO files, write data.yaml and stats.json.
    pub fn finish(mut self) -> Result<DatasetStats, OutputError> {
        let manifest_path = self.root.join("manifest.jsonl");
        self.manifest.flush().map_err(io(&manifest_path))?;
        if let Some(parts) = self.coco.take() {
            let categories: Vec<_> = self
                .classes
                .iter()
                .enumerate()
                .map(|(i, n)| json!({"id": i + 1, "name": n, "supercategory": "uav"}))
                .collect();
            for (split, mut part) in SplitName::ALL.into_iter().zip(parts) {
                part.images.flush().map_err(io(&part.images_path))?;
                part.annotations
                    .flush()
                    .map_err(io(&part.annotations_path))?;
                drop((part.images, part.annotations));
                let path = self
                    .root
                    .join("annotations")
                    .join(format!("instances_{}.json", split.as_str()));
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
        }
        if self.yolo {
            let abs = fs::canonicalize(&self.root).map_err(io(&self.root))?;
            let mut yaml = String::from(
                "# Ultralytics YOLO dataset written by swarmshot. `path` is absolute so any working directory resolves it.\n",
            );
            yaml.push_str(&format!(
                "path: {}\n",
                serde_json::Value::from(abs.to_string_lossy().into_owned())
            ));
            yaml.push_str("train: images/train\nval: images/val\ntest: images/test\nnames:\n");
            for (i, name) in self.classes.iter().enumerate() {
                yaml.push_str(&format!(
                    "  {i}: {}\n",
                    serde_json::Value::from(name.clone())
                ));
            }
            let path = self.root.join("data.yaml");
            fs::write(&path, yaml).map_err(io(&path))?;
        }
        let path = self.root.join("stats.json");
        fs::write(
            &path,
            serde_json::to_string_pretty(&self.stats).unwrap_or_default(),
        )
        .map_err(io(&path))?;
        Ok(self.stats)
    }
}

fn xywh(b: &PixelBox) -> [f64; 4] {
    [r6(b.x0), r6(b.y0), r6(b.width()), r6(b.height())]
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
    json!({
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
    })
    .to_string()
}
