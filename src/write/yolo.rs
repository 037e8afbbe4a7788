//! Ultralytics YOLO: `labels/{split}/NAME.txt` beside `images/{split}/NAME.ext`,
//! and `data.yaml` naming the splits and classes.

use std::fs;
use std::path::{Path, PathBuf};

use super::{DatasetInfo, FormatWriter, FrameRecord, OutputError, io};
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
        text.push_str(&format!(
            "{} {:.6} {:.6} {:.6} {:.6}\n",
            l.class_id,
            cx,
            cy,
            b.width() / w,
            b.height() / h
        ));
    }
    text
}

/// Writes the YOLO label files and `data.yaml`.
pub struct YoloWriter {
    root: PathBuf,
}

impl YoloWriter {
    pub fn create(root: &Path) -> Result<Self, OutputError> {
        for split in crate::scene::SplitName::ALL {
            let dir = root.join("labels").join(split.as_str());
            fs::create_dir_all(&dir).map_err(io(&dir))?;
        }
        Ok(Self {
            root: root.to_owned(),
        })
    }
}

impl FormatWriter for YoloWriter {
    fn frame(&mut self, record: &FrameRecord<'_>) -> Result<(), OutputError> {
        let scene = record.scene;
        let path = self
            .root
            .join("labels")
            .join(scene.split.as_str())
            .join(format!("{}.txt", super::stem(scene.index)));
        fs::write(&path, label_text(scene, record.labels)).map_err(io(&path))
    }

    fn finish(self: Box<Self>, dataset: &DatasetInfo) -> Result<(), OutputError> {
        let abs = fs::canonicalize(&self.root).map_err(io(&self.root))?;
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
        let path = self.root.join("data.yaml");
        fs::write(&path, yaml).map_err(io(&path))
    }
}
