//! Ultralytics YOLO: `labels/{split}/NAME.txt` beside `images/{split}/NAME.ext`,
//! and `data.yaml` naming the splits and classes.

use super::{DatasetInfo, FormatWriter, FrameRecord};
use crate::annotate::DroneLabel;
use crate::scene::{FrameScene, SplitName};
use crate::write::{Folder, OutputError};

/// One line per training box: `class cx cy w h`, normalised to the image size.
/// YOLO has no ignore flag, so crowd regions stay out of its files.
pub fn label_text(scene: &FrameScene, labels: &[DroneLabel]) -> String {
    let mut text = Vec::with_capacity(48 * labels.len());
    write_label_text(&mut text, scene, labels);
    // Only ASCII digits, signs, points, spaces and newlines were written.
    String::from_utf8(text).unwrap_or_default()
}

/// [`label_text`] appended to `out`: the numbers as `{:.6}` formats them
/// (exact integer arithmetic, tested against `format!`), without the formatting machinery.
pub fn write_label_text(out: &mut Vec<u8>, scene: &FrameScene, labels: &[DroneLabel]) {
    use super::json::{decimal, fixed6};
    let (w, h) = (
        f64::from(scene.camera.width),
        f64::from(scene.camera.height),
    );
    for l in labels.iter().filter(|l| l.is_kept()) {
        let b = &l.bbox;
        let cx = (b.x0 + b.x1) * 0.5 / w;
        let cy = (b.y0 + b.y1) * 0.5 / h;
        decimal(out, l.class_id as u64);
        for v in [cx, cy, b.width() / w, b.height() / h] {
            out.push(b' ');
            fixed6(out, v);
        }
        out.push(b'\n');
    }
}

/// A frame's label file relative to the dataset folder.
pub fn label_rel_path(scene: &FrameScene) -> String {
    format!(
        "labels/{}/{}.txt",
        scene.split.as_str(),
        crate::write::stem(scene.index)
    )
}

/// The fixed entries: `labels/{split}/`, and `data.yaml` (not in a
/// labels-only plan, which is no training set).
pub fn needed_entries(labels_only: bool) -> Vec<String> {
    let mut needed: Vec<String> = (SplitName::ALL.map(SplitName::as_str))
        .iter()
        .map(|split| format!("labels/{split}/"))
        .collect();
    if !labels_only {
        needed.push("data.yaml".to_owned());
    }
    needed
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
        folder.write_frame_file(&label_rel_path(record.scene), record.text.yolo)
    }

    fn finish(&mut self, folder: &mut Folder, dataset: &DatasetInfo) -> Result<(), OutputError> {
        if dataset.labels_only {
            // No images: a data.yaml would point Ultralytics at empty folders.
            return Ok(());
        }
        folder.write_file(
            "data.yaml",
            data_yaml_for_splits(&dataset.classes, dataset.frames_per_split).as_bytes(),
        )
    }
}

/// `data.yaml` with no `path:` key, so the dataset stays valid wherever it
/// is copied or moved. Ultralytics' `check_det_dataset` (ultralytics/data/
/// utils.py) takes the dataset root from `path`, or when `path` is missing
/// from the folder that holds the YAML file (`Path(data["yaml_file"]).parent`),
/// and joins train/val/test to it. A relative `path` would be resolved
/// against the working directory (or `datasets_dir`), not the YAML's folder,
/// so none is written. docs/scale.md, README.
pub fn data_yaml(classes: &[String]) -> String {
    let mut yaml = String::from(
        "# Ultralytics YOLO dataset written by swarmshot. No `path`: Ultralytics then takes the folder\n# holding this file as the dataset root, so the folder can be copied or moved.\n",
    );
    yaml.push_str("train: images/train\nval: images/val\ntest: images/test\nnames:\n");
    for (i, name) in classes.iter().enumerate() {
        yaml.push_str(&format!(
            "  {i}: {}\n",
            serde_json::Value::from(name.clone())
        ));
    }
    yaml
}

/// [`data_yaml`] for a dataset whose splits hold `frames_per_split` frames
/// (train, val, test): an empty split is never named, since Ultralytics
/// refuses a `val` folder with no images. An empty `val` points at the train
/// images (Ultralytics then validates on training data: the batch warns);
/// an empty `test` is left out (it is optional); an empty `train` points at
/// the first split that has frames. With every split filled it is exactly
/// [`data_yaml`].
pub fn data_yaml_for_splits(classes: &[String], frames_per_split: [u64; 3]) -> String {
    let yaml = data_yaml(classes);
    let [train, val, test] = frames_per_split;
    if train > 0 && val > 0 && test > 0 {
        return yaml;
    }
    let nonempty = ["train", "val", "test"]
        .into_iter()
        .zip(frames_per_split)
        .find(|(_, n)| *n > 0)
        .map_or("train", |(name, _)| name);
    let train_to = if train > 0 { "train" } else { nonempty };
    let val_to = if val > 0 { "val" } else { train_to };
    let mut lines = format!("train: images/{train_to}\nval: images/{val_to}\n");
    if test > 0 {
        lines.push_str("test: images/test\n");
    }
    let note = format!(
        "# Splits: {train} train / {val} val / {test} test frames; an empty split is not named{}.\n",
        if val == 0 {
            " (val points at the train images: validation on training data)"
        } else {
            ""
        }
    );
    yaml.replace(
        "train: images/train\nval: images/val\ntest: images/test\n",
        &format!("{note}{lines}"),
    )
}

#[cfg(test)]
mod split_tests {
    use super::*;

    #[test]
    fn data_yaml_never_names_an_empty_split() {
        let classes = vec!["uav".to_string()];
        assert_eq!(
            data_yaml_for_splits(&classes, [7, 1, 2]),
            data_yaml(&classes)
        );
        let y = data_yaml_for_splits(&classes, [75, 0, 25]);
        assert!(
            y.contains("val: images/train\n") && y.contains("test: images/test\n"),
            "{y}"
        );
        assert!(!y.contains("images/val"), "{y}");
        let y = data_yaml_for_splits(&classes, [75, 5, 0]);
        assert!(
            !y.contains("test:") && y.contains("val: images/val\n"),
            "{y}"
        );
        let y = data_yaml_for_splits(&classes, [0, 0, 3]);
        assert!(y.contains("train: images/test\nval: images/test\n"), "{y}");
    }
}
