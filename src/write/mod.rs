//! Dataset writers, apart from rendering, one concern a folder:
//!
//! - [`encode`]: image encoding (PNG, JPEG with reused tiles, sparse 16-bit PNG);
//! - [`formats`]: one file per label format (YOLO, COCO, MOT, masks, the
//!   manifest) behind [`FormatWriter`], registered in one place
//!   (`formats::open_writers`), and the frame records as text;
//! - [`folder`]: the dataset folder swarmshot owns (ledger, lock, atomic
//!   files, resume; no link followed), and report folders ([`folder::outdir`]);
//! - [`shards`]: `--shard K/N` and `swarmshot merge`;
//! - [`stats`]: `stats.json` and its plots;
//! - [`dataset`]: [`DatasetWriter`], which drives the formats over the folder;
//! - [`single`]: one frame alone (`swarmshot frame`).
//!
//! Frames are written in index order by one sink, so label files, COCO ids and
//! the manifest are byte-identical run to run. Every file goes through the
//! [`Folder`]: claimed in the folder's ledger before it exists, never written
//! through a symbolic link, written atomically or appended whole records at a
//! time, and checkpointed per frame so an interrupted run continues byte for
//! byte (docs/reliability.md). Adding a label format: docs/architecture.md,
//! "Adding a label format".

pub mod dataset;
pub mod encode;
pub mod folder;
pub mod formats;
pub mod shards;
pub mod single;
pub mod stats;

use std::path::{Path, PathBuf};

use crate::annotate::PixelBox;
use crate::preset::ImageFormat;
use crate::scene::FrameScene;

pub use dataset::{DatasetWriter, PLAN_README, WriterOptions};
pub use encode::{
    Area, EncodeError, ImageEncoder, Unchanged, encode_grey_image, encode_grey16_png, encode_image,
    jpeg_round_trip,
};
pub use folder::{Checkpoint, Folder, OpenMode, RunId, ShardPlan, ShardRun, Start};
pub use formats::{
    DatasetInfo, FormatWriter, FrameRecord, FrameText, FrameTexts, TextContext, manifest_line,
};
// The paths the app, `fit` and `gap` name (`write::merge`, `write::shard`,
// `write::outdir`), kept so those callers need no change.
pub use folder::outdir;
pub use shards::{merge, shard};
pub use stats::{DatasetStats, StatsError};

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

/// The top-level folders of a dataset that hold its frames' files and
/// annotations: what Ultralytics, pycocotools, MOT tools and `swarmshot gap`
/// walk, so nothing else may be written into them.
pub const DATA_FOLDERS: [&str; 8] = [
    "images",
    "labels",
    "annotations",
    "masks",
    "depth",
    "flow",
    "mot",
    "seg",
];

#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    #[error("{}: {source}", path.display())]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error(
        "output folder {} is not empty and holds no swarmshot run; choose another folder, or pass --overwrite to write into it (files swarmshot did not write are kept, and a name it needs that is taken is refused)",
        path.display()
    )]
    NotEmpty { path: PathBuf },
    #[error(
        "output folder {} holds {what}; {}choose another folder, or pass --overwrite to delete that run's own files (files swarmshot did not write are kept) and start again",
        path.display(),
        resume_with.as_ref().map_or_else(String::new, |flags| format!("to continue it, run the batch with {flags}; or "))
    )]
    OtherRun {
        path: PathBuf,
        what: String,
        /// The flags that continue the earlier run, when only flags keep
        /// this run from it (a batch of the same preset; never a merge).
        resume_with: Option<String>,
    },
    #[error(
        "nothing to resume in {}: it holds no swarmshot run (no .swarmshot-ledger); run without --resume",
        path.display()
    )]
    NothingToResume { path: PathBuf },
    #[error(
        "--resume and --overwrite exclude each other: --resume continues the earlier run, --overwrite deletes it"
    )]
    Conflict,
    #[error(
        "{}: {reason}; swarmshot writes only inside its output folder and only entries it created: move it away or choose another folder",
        path.display()
    )]
    Refused { path: PathBuf, reason: String },
    #[error(
        "{field} {} is {}: a run never reads from the folder it writes (it, or a later run continuing it, would read what was written, not what the preset names); move the input elsewhere or choose another output folder",
        input.display(),
        if *.out_inside { format!("a folder that holds the output folder {}", out.display()) } else { format!("inside the output folder {}", out.display()) }
    )]
    InputInside {
        field: &'static str,
        input: PathBuf,
        out: PathBuf,
        /// The output folder lies inside the input (a folder), not the input inside it.
        out_inside: bool,
    },
    #[error(
        "output folder {} is in use by {}: one run at a time writes a folder (it holds the lock on {}); wait for that run to end or stop it, then run again",
        path.display(),
        pid.map_or_else(|| "another swarmshot process".to_owned(), |p| format!("process {p}")),
        lock.display()
    )]
    InUse {
        path: PathBuf,
        lock: PathBuf,
        pid: Option<u32>,
    },
    #[error("{}: the ledger cannot be read: {reason}", path.display())]
    Ledger { path: PathBuf, reason: String },
    #[error(
        "output folder {} holds a finished run whose files changed after it ended ({}), so it is not complete; nothing was written; pass --overwrite to make the run again (files swarmshot did not write are kept)",
        path.display(),
        problems.join("; ")
    )]
    FinishedChanged {
        path: PathBuf,
        problems: Vec<String>,
    },
    #[error(
        "output folder {} holds a run made from other input files{}: {} (a model with the buffers and images it names, a backplate folder with every plate and sidecar){}; nothing was written; {}",
        path.display(),
        if *merge { " than the shards" } else { "" },
        changed.join("; "),
        if *merge { " differ" } else { " changed since it began, and continuing it would mix frames of both" },
        if *merge { "merge into another folder, or pass --overwrite to replace that run with the shards" } else { "restore them, or pass --overwrite to make the run again from the files as they are now" }
    )]
    InputsChanged {
        path: PathBuf,
        /// Each input whose content differs, as [`folder::changed_inputs`] names it.
        changed: Vec<String>,
        /// A `swarmshot merge` found it.
        merge: bool,
    },
    #[error("frame {got} came before frame {expected}: frames are written in index order")]
    OutOfOrder { expected: u64, got: u64 },
    #[error("{}: {reason}", path.display())]
    Shard { path: PathBuf, reason: String },
    #[error("encoding {format} failed: {source}")]
    Encode {
        format: &'static str,
        source: encode::EncodeError,
    },
}

pub(crate) fn io(path: &Path) -> impl FnOnce(std::io::Error) -> OutputError + '_ {
    move |source| OutputError::Io {
        path: path.to_owned(),
        source,
    }
}

/// As [`io`], for a path looked at through a link: a link to nothing is named as such
/// (the system says "No such file or directory" of a name that is there).
pub(crate) fn io_following(path: &Path) -> impl FnOnce(std::io::Error) -> OutputError + '_ {
    move |source| match std::fs::read_link(path) {
        Ok(target) if source.kind() == std::io::ErrorKind::NotFound => OutputError::Refused {
            path: path.to_owned(),
            reason: format!("is a link to {}, which does not exist", target.display()),
        },
        _ => io(path)(source),
    }
}

/// Round to a fixed number of decimals so files do not depend on the last ulp.
pub(crate) fn r6(x: f64) -> f64 {
    (x * 1e6).round() / 1e6
}

pub(crate) fn box_xyxy(b: &PixelBox) -> [f64; 4] {
    [r6(b.x0), r6(b.y0), r6(b.x1), r6(b.y1)]
}

#[cfg(test)]
pub(crate) fn xywh(b: &PixelBox) -> [f64; 4] {
    [r6(b.x0), r6(b.y0), r6(b.width()), r6(b.height())]
}
