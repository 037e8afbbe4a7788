//! Dataset writers, apart from rendering: image encoding ([`image`]), one
//! writer per label format behind [`FormatWriter`] ([`yolo`], [`coco`],
//! [`manifest`]), statistics ([`stats`]), and the dataset folder with its
//! locked preset ([`DatasetWriter`]).
//!
//! Frames are written in index order by one sink, so label files, COCO ids and
//! the manifest are byte-identical run to run. Adding a label format is one
//! new file with a [`FormatWriter`] and one line in [`DatasetWriter::create`].

pub mod coco;
pub mod image;
pub mod manifest;
pub mod stats;
pub mod yolo;

use std::fs;
use std::path::{Path, PathBuf};

use crate::annotate::{DroneLabel, PixelBox};
use crate::preset::{ImageFormat, LabelFormat, Preset};
use crate::scene::{FrameScene, SplitName};

pub use image::encode_image;
pub use manifest::manifest_line;
pub use stats::DatasetStats;

/// One frame as the format writers see it.
pub struct FrameRecord<'a> {
    pub scene: &'a FrameScene,
    pub labels: &'a [DroneLabel],
    /// The image's path relative to the dataset folder (`images/{split}/NAME.ext`).
    pub image: &'a str,
}

/// What the format writers need at the end.
pub struct DatasetInfo {
    pub classes: Vec<String>,
}

/// A writer of one label format: fed every frame in index order, then finished once.
pub trait FormatWriter: Send {
    fn frame(&mut self, record: &FrameRecord<'_>) -> Result<(), OutputError>;
    fn finish(self: Box<Self>, dataset: &DatasetInfo) -> Result<(), OutputError>;
}

/// Write `bytes` to `path` atomically: a temporary file in the same folder,
/// flushed to disk, then renamed over `path`. A crash leaves either the old
/// file or the new one, never a torn one.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), OutputError> {
    use std::io::Write;
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let name = path
        .file_name()
        .map_or_else(|| "swarmshot".into(), |n| n.to_string_lossy().into_owned());
    let tmp = dir.join(format!(".{name}.{}.tmp", std::process::id()));
    let result = (|| {
        let mut file = fs::File::create(&tmp)?;
        file.write_all(bytes)?;
        file.sync_all()?;
        fs::rename(&tmp, path)
    })();
    if result.is_err() {
        let _ = fs::remove_file(&tmp);
    }
    result.map_err(io(path))
}

/// File stem of a frame: its zero-padded index.
pub fn stem(index: u64) -> String {
    format!("{index:08}")
}

/// A frame's image path relative to the dataset folder.
pub fn image_rel_path(scene: &FrameScene, format: ImageFormat) -> String {
    format!(
        "images/{}/{}.{}",
        scene.split.as_str(),
        stem(scene.index),
        format.extension()
    )
}

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

pub(crate) fn io(path: &Path) -> impl FnOnce(std::io::Error) -> OutputError + '_ {
    move |source| OutputError::Io {
        path: path.to_owned(),
        source,
    }
}

/// Round to a fixed number of decimals so files do not depend on the last ulp.
pub(crate) fn r6(x: f64) -> f64 {
    (x * 1e6).round() / 1e6
}

pub(crate) fn box_xyxy(b: &PixelBox) -> [f64; 4] {
    [r6(b.x0), r6(b.y0), r6(b.x1), r6(b.y1)]
}

/// Writes one dataset folder. Call [`DatasetWriter::write_frame`] in index order, then [`DatasetWriter::finish`].
pub struct DatasetWriter {
    root: PathBuf,
    image_format: ImageFormat,
    classes: Vec<String>,
    formats: Vec<Box<dyn FormatWriter>>,
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
        for split in SplitName::ALL {
            let dir = root.join("images").join(split.as_str());
            fs::create_dir_all(&dir).map_err(io(&dir))?;
        }
        let lock_path = root.join(LOCK_FILE);
        fs::write(&lock_path, &lock).map_err(io(&lock_path))?;
        let (classes, _) = preset.classes();
        let mut formats: Vec<Box<dyn FormatWriter>> = vec![Box::new(
            manifest::ManifestWriter::create(root, model_names, classes.clone())?,
        )];
        for format in &preset.output.label_formats {
            formats.push(match format {
                LabelFormat::Yolo => Box::new(yolo::YoloWriter::create(root)?),
                LabelFormat::Coco => Box::new(coco::CocoWriter::create(root)?),
            });
        }
        Ok(Self {
            root: root.to_owned(),
            image_format: preset.output.image_format,
            classes,
            formats,
            stats: DatasetStats::default(),
        })
    }

    /// Relative path of a frame's image.
    pub fn image_rel_path(&self, scene: &FrameScene) -> String {
        image_rel_path(scene, self.image_format)
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
        let record = FrameRecord {
            scene,
            labels,
            image: &rel,
        };
        for format in &mut self.formats {
            format.frame(&record)?;
        }
        self.stats.add(scene, labels);
        Ok(())
    }

    /// Finish every format (COCO assembled, data.yaml written) and write stats.json.
    pub fn finish(self) -> Result<DatasetStats, OutputError> {
        let info = DatasetInfo {
            classes: self.classes,
        };
        for format in self.formats {
            format.finish(&info)?;
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

pub(crate) fn xywh(b: &PixelBox) -> [f64; 4] {
    [r6(b.x0), r6(b.y0), r6(b.width()), r6(b.height())]
}
