//! Ultralytics YOLO: `labels/{split}/NAME.txt` beside `images/{split}/NAME.ext`,
//! and `data.yaml` naming the splits and classes.

use std::fmt::Write as _;
use std::fs;

use super::{DatasetInfo, Folder, FormatWriter, FrameRecord, OutputError, io};
use crate::annotate::DroneLabel;
use crate::scene::FrameScene;

/// One line per training box: `class cx cy w h`, normalised to the image size.
/// YOLO has no ignore flag, so crowd regions stay out of its files.
pub fn label_text(scene: &FrameScene, labels: &[DroneLabel]) -> String {
    let (w, h) = (
        f64::from(scene.camera.width),
        f64::from(scene.camera.height),
    );
    let mut text = String::new();
    for l in labels.iter().filter(|l| l.is_kept()) {
        let b = &l.bbox;
        let cx = (b.x0 + b.x1) * 0.5 / w;
        let cy = (b.y0 + b.y1) * 0.5 / h;
        // Writing into a String cannot fail.
        let _ = writeln!(
            text,
            "{} {:.6} {:.6} {:.6} {:.6}",
            l.class_id,
            cx,
            cy,
            b.width() / w,
            b.height() / h
        );
    }
    text
}

/// A frame's label file relative to the dataset folder.
pub fn label_rel_path(scene: &FrameScene) -> String {
    format!(
        "labels/{}/{}.txt",
        scene.split.as_str(),
        super::stem(scene.index)
    )
}

/// Writes the YOLO label files and `data.yaml`.
pub struct YoloWriter;

impl YoloWriter {
    pub fn create(folder: &mut Folder) -> Result<Self, OutputError> {
        for split in crate::scene::SplitName::ALL {
            folder.ensure_dir(&format!("labels/{}", split.as_str()))?;
        }
        Ok(Self)
    }
}

impl FormatWriter for YoloWriter {
    fn frame_files(&self, scene: &FrameScene) -> Vec<String> {
        vec![label_rel_path(scene)]
    }

    fn frame(&mut self, folder: &mut Folder, record: &FrameRecord<'_>) -> Result<(), OutputError> {
        folder.write_frame_file(&label_rel_path(record.scene), record.text.yolo.as_bytes())
    }

    fn finish(&mut self, folder: &mut Folder, dataset: &DatasetInfo) -> Result<(), OutputError> {
        if dataset.labels_only {
            // No images: a data.yaml would point Ultralytics at empty folders.
            return Ok(());
        }
        let root = folder.root().to_owned();
        let abs = fs::canonicalize(&root).map_err(io(&root))?;
        let mut yaml = String::from(
            "# Ultralytics YOLO dataset written by swarmshot. `path` is absolute so any working directory resolves it.\n",
        );
        yaml.push_str(&format!(
            "path: {}\n",
            serde_json::Value::from(abs.to_string_lossy().into_owned())
        ));
        yaml.push_str("train: images/train\nval: images/val\ntest: images/test\nnames:\n");
        for (i, name) in dataset.classes.iter().enumerate() {
            yaml.push_str(&format!(
                "  {i}: {}\n",
                serde_json::Value::from(name.clone())
            ));
        }
        folder.write_file("data.yaml", yaml.as_bytes())
    }
}
