//! Dataset writers, apart from rendering: image encoding ([`image`]), one
//! writer per label format behind [`FormatWriter`] ([`yolo`], [`coco`],
//! [`manifest`]), statistics ([`stats`]), and the dataset folder with its
//! locked preset ([`DatasetWriter`]).
//!
//! Frames are written in index order by one sink, so label files, COCO ids and
//! the manifest are byte-identical run to run. Every file goes through the
//! [`Folder`] ([`folder`]): claimed in the folder's ledger before it exists,
//! never written through a symbolic link, written atomically or appended
//! whole records at a time, and checkpointed per frame so an interrupted run
//! continues byte for byte (docs/reliability.md). Adding a label format is
//! one new file with a [`FormatWriter`] and one line in [`DatasetWriter::open`].

pub mod coco;
pub mod folder;
pub mod image;
pub mod jpeg;
pub(crate) mod json;
pub mod manifest;
pub mod masks;
pub mod merge;
pub mod mot;
pub mod outdir;
pub mod shard;
pub mod single;
pub mod sparse_png;
pub mod stats;
pub mod tree;
pub mod yolo;

use std::fs;
use std::path::{Path, PathBuf};

use crate::annotate::{DroneLabel, PixelBox};
use crate::preset::{ImageFormat, LabelFormat, Preset};
use crate::scene::{FrameScene, SplitName};
use folder::fnv1a64;

pub use folder::{Checkpoint, Folder, OpenMode, RunId, ShardPlan, ShardRun, Start};
pub use image::{ImageEncoder, encode_image, jpeg_round_trip};
pub use jpeg::{Area, Unchanged};
pub use manifest::manifest_line;
pub use stats::{DatasetStats, StatsError};

/// One frame as the format writers see it.
pub struct FrameRecord<'a> {
    pub scene: &'a FrameScene,
    pub labels: &'a [DroneLabel],
    /// The image's path relative to the dataset folder (`images/{split}/NAME.ext`).
    pub image: &'a str,
    /// The frame's records as text, formatted by [`TextContext::push_frame`].
    pub text: FrameText<'a>,
    /// The frame's encoded masks, when the preset asks for masks and pixels were rendered.
    pub masks: Option<&'a masks::EncodedMasks>,
}

/// A frame's records as text: everything the writers write for it that
/// depends on the frame alone, held by a [`FrameTexts`]. Formatted by
/// [`TextContext::push_frame`], which needs no writer state, so a
/// labels-only plan formats frames on every core and its one writer
/// thread only appends bytes.
#[derive(Clone, Copy, Debug, Default)]
pub struct FrameText<'a> {
    /// The YOLO label file (empty when the preset writes no YOLO).
    pub yolo: &'a [u8],
    /// The manifest line, without its newline.
    pub manifest: &'a [u8],
    /// The COCO image record (empty when the preset writes no COCO).
    pub coco_image: &'a [u8],
    /// The COCO annotation records, each a JSON object without its `id`
    /// and its opening brace (the writer puts `{"id":N,` in front), each
    /// ended by a newline.
    pub coco_annotations: &'a [u8],
}

/// The records of consecutive frames as text, in buffers kept from chunk
/// to chunk ([`FrameTexts::clear`] keeps their memory): formatting a frame
/// allocates nothing once they have grown.
#[derive(Clone, Debug, Default)]
pub struct FrameTexts {
    yolo: Vec<u8>,
    manifest: Vec<u8>,
    coco_images: Vec<u8>,
    coco_annotations: Vec<u8>,
    /// Each frame's end in the four buffers.
    ends: Vec<[usize; 4]>,
    /// The image path of the frame being formatted.
    image: String,
}

impl FrameTexts {
    /// Forget the frames, keep the memory.
    pub fn clear(&mut self) {
        self.yolo.clear();
        self.manifest.clear();
        self.coco_images.clear();
        self.coco_annotations.clear();
        self.ends.clear();
    }

    /// Frames held.
    pub fn len(&self) -> usize {
        self.ends.len()
    }

    pub fn is_empty(&self) -> bool {
        self.ends.is_empty()
    }

    /// The records of the `i`th frame held (empty past the last).
    pub fn get(&self, i: usize) -> FrameText<'_> {
        let (Some(end), start) = (
            self.ends.get(i),
            i.checked_sub(1)
                .and_then(|p| self.ends.get(p))
                .copied()
                .unwrap_or_default(),
        ) else {
            return FrameText::default();
        };
        FrameText {
            yolo: &self.yolo[start[0]..end[0]],
            manifest: &self.manifest[start[1]..end[1]],
            coco_image: &self.coco_images[start[2]..end[2]],
            coco_annotations: &self.coco_annotations[start[3]..end[3]],
        }
    }
}

/// What formatting a frame's records needs besides the frame: the preset's
/// names and formats. Cheap to clone; shared by the threads of a plan.
#[derive(Clone, Debug)]
pub struct TextContext {
    pub model_names: Vec<String>,
    pub classes: Vec<String>,
    pub image_format: ImageFormat,
    pub yolo: bool,
    pub coco: bool,
}

impl TextContext {
    /// The context of `preset` with the models' names as the manifest writes them.
    pub fn new(preset: &Preset, model_names: Vec<String>) -> Self {
        Self {
            model_names,
            classes: preset.classes().0,
            image_format: preset.output.image_format,
            yolo: preset.output.label_formats.contains(&LabelFormat::Yolo),
            coco: preset.output.label_formats.contains(&LabelFormat::Coco),
        }
    }

    /// Append every record of one frame to `texts` (pure: the same bytes on any thread).
    pub fn push_frame(&self, texts: &mut FrameTexts, scene: &FrameScene, labels: &[DroneLabel]) {
        self.push_frame_with(texts, scene, labels, None);
    }

    /// [`TextContext::push_frame`], with the frame's masks: their RLE goes
    /// into the COCO annotations as `segmentation` (and `area`).
    pub fn push_frame_with(
        &self,
        texts: &mut FrameTexts,
        scene: &FrameScene,
        labels: &[DroneLabel],
        masks: Option<&masks::EncodedMasks>,
    ) {
        use std::fmt::Write as _;
        texts.image.clear();
        // Writing into a String cannot fail.
        let _ = write!(
            texts.image,
            "images/{}/{:08}.{}",
            scene.split.as_str(),
            scene.index,
            self.image_format.extension()
        );
        if self.coco {
            let rle = masks.map(|m| m.rle.as_slice()).filter(|r| !r.is_empty());
            coco::write_frame_records_with(
                &mut texts.coco_images,
                &mut texts.coco_annotations,
                (scene, labels),
                &texts.image,
                &self.model_names,
                rle,
            );
        }
        if self.yolo {
            yolo::write_label_text(&mut texts.yolo, scene, labels);
        }
        manifest::write_manifest_line(
            &mut texts.manifest,
            scene,
            labels,
            &texts.image,
            &self.model_names,
            &self.classes,
        );
        texts.ends.push([
            texts.yolo.len(),
            texts.manifest.len(),
            texts.coco_images.len(),
            texts.coco_annotations.len(),
        ]);
    }
}

/// What the format writers need at the end.
pub struct DatasetInfo {
    pub classes: Vec<String>,
    /// A labels-only plan: no images were rendered (see [`WriterOptions::labels_only`]).
    pub labels_only: bool,
    /// Frames written per split (train, val, test): data.yaml names no empty split.
    pub frames_per_split: [u64; 3],
}

/// A writer of one label format: fed every frame in index order, then
/// finished. It writes only through the [`Folder`], and saves in each
/// [`Checkpoint`] what a resumed run needs to continue it byte for byte.
pub trait FormatWriter: Send {
    /// Whole files this format writes for the frame (claimed before its image).
    fn frame_files(&self, _scene: &FrameScene) -> Vec<String> {
        Vec::new()
    }
    fn frame(&mut self, folder: &mut Folder, record: &FrameRecord<'_>) -> Result<(), OutputError>;
    /// Write what [`FormatWriter::frame`] buffered (called before every [`FormatWriter::save`]).
    fn flush(&mut self) -> Result<(), OutputError> {
        Ok(())
    }
    /// The frame is complete: record file lengths and counters.
    fn save(&mut self, _checkpoint: &mut Checkpoint) {}
    /// A frame failed: cut append-only files back to the last checkpoint.
    fn rollback(&mut self) {}
    /// Write the end files (from what is on disk, so a resumed run gets the same bytes).
    fn finish(&mut self, folder: &mut Folder, dataset: &DatasetInfo) -> Result<(), OutputError>;
    /// The whole dataset is written: delete working files.
    fn cleanup(&mut self, _folder: &mut Folder) -> Result<(), OutputError> {
        Ok(())
    }
    /// `swarmshot merge`: append a finished shard's records (the shard's
    /// frames follow the frames written so far). Per-frame files (images,
    /// label files) are linked by [`DatasetWriter::merge_shard`]; a format
    /// with records in shared files (manifest, COCO) appends them here.
    fn merge_shard(&mut self, _folder: &mut Folder, _shard: &Path) -> Result<(), OutputError> {
        Ok(())
    }
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

const LOCK_FILE: &str = "preset.lock.ron";

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
        "output folder {} holds {what}; choose another folder, or pass --overwrite to delete that run's own files (files swarmshot did not write are kept) and start again",
        path.display()
    )]
    OtherRun { path: PathBuf, what: String },
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
    #[error("frame {got} came before frame {expected}: frames are written in index order")]
    OutOfOrder { expected: u64, got: u64 },
    #[error("{}: {reason}", path.display())]
    Shard { path: PathBuf, reason: String },
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

/// How [`DatasetWriter::open`] treats the folder.
#[derive(Clone, Copy, Debug, Default)]
pub struct WriterOptions {
    /// Frames this run makes; `None` (with `resume`) takes the locked run's count.
    pub frames: Option<u64>,
    /// Delete an earlier run's own files and start again.
    pub overwrite: bool,
    /// Require an earlier run of the same preset in the folder and continue it.
    pub resume: bool,
    /// Make only shard K of N of the frames (the unit: a sequence in sequence mode).
    pub shard: Option<shard::Shard>,
    /// Make frames `0, K, 2K, …` below `frames` (`--every K`); `None` takes
    /// a resumed run's step (1 for a new run).
    pub every: Option<u64>,
    /// A labels-only plan (`batch --labels-only`): labels, COCO, manifest
    /// and stats from geometry, no images and no data.yaml. Its ledger names
    /// it a plan, so a rendered run never continues it (nor it a rendered
    /// run); its frame files are not flushed to disk one by one (see
    /// [`DatasetWriter::write_plan_frames`]).
    pub labels_only: bool,
}

/// What a labels-only plan appends to the locked preset's text before
/// hashing it for the ledger: a plan and a rendered run of the same preset
/// are different runs.
const PLAN_MARK: &str = "\n// swarmshot labels-only plan\n";

/// The file at the top of a labels-only plan that says what the folder is.
pub const PLAN_README: &str = "PLAN.txt";

/// Writes one dataset folder: call [`DatasetWriter::write_frame`] for frames
/// [`DatasetWriter::next_frame`]`..`[`DatasetWriter::total`] in index order,
/// then [`DatasetWriter::finish`]. After a write error call
/// [`DatasetWriter::rollback`]: the folder then holds exactly the complete
/// frames, and a later run continues it.
pub struct DatasetWriter {
    folder: Folder,
    text: TextContext,
    /// The rendered frame's records (the buffers kept from frame to frame).
    texts: FrameTexts,
    image_format: ImageFormat,
    classes: Vec<String>,
    formats: Vec<Box<dyn FormatWriter>>,
    stats: DatasetStats,
    next: u64,
    /// One past the last frame of this run (of its shard, with `--shard`).
    total: u64,
    /// The step between the frames this run writes (`--every`; 1: all).
    every: u64,
    /// The first frame of this run (of its shard, with `--shard`).
    start: u64,
    /// An earlier run finished this dataset; nothing is left to write.
    done: bool,
    /// The dataset's fixed entries (lock, manifest, COCO files, …).
    needed: Vec<String>,
    labels_only: bool,
    /// `stats.json`'s `boxes_from`.
    boxes_from: String,
}

impl DatasetWriter {
    /// Open `root` for `preset` (see [`Folder::open`]): a new run, the
    /// continuation of an earlier run of the same preset and frame count, or
    /// a refusal that says how to proceed.
    pub fn open(
        root: &Path,
        preset: &Preset,
        model_names: Vec<String>,
        options: WriterOptions,
    ) -> Result<Self, OutputError> {
        let lock = preset.to_ron();
        let (yolo, coco) = (
            preset.output.label_formats.contains(&LabelFormat::Yolo),
            preset.output.label_formats.contains(&LabelFormat::Coco),
        );
        let labels_only = options.labels_only;
        let needed = needed_entries(preset, labels_only);
        let mask_files = !labels_only && preset.output.masks.any();
        let sequences = preset.sequence.is_some();
        // Every entry is checked before anything is written or rendered: a
        // link or a file swarmshot did not write is refused now, not after hours.
        let run_text = if labels_only {
            format!("{lock}{PLAN_MARK}")
        } else {
            lock.clone()
        };
        let (mut folder, start, run) = Folder::open(
            root,
            fnv1a64(run_text.as_bytes()),
            options.frames,
            OpenMode {
                overwrite: options.overwrite,
                resume: options.resume,
                shard: options.shard.map(|shard| ShardPlan {
                    shard,
                    unit: preset.sequence_len(),
                }),
                every: options.every,
                fresh_frames: preset.frame_count(),
            },
            &needed,
        )?;
        let (mut checkpoint, done) = match start {
            Start::Fresh => (Checkpoint::default(), false),
            Start::Resume { checkpoint, done } => (*checkpoint, done),
        };
        // A shard starts at its first frame.
        checkpoint.next = checkpoint.next.max(run.start());
        let (classes, _) = preset.classes();
        let text = TextContext::new(preset, model_names.clone());
        let mut formats: Vec<Box<dyn FormatWriter>> = Vec::new();
        if done {
            // A run killed after its "done" mark may have left its COCO parts.
            for rel in needed.iter().filter(|r| r.ends_with(".part")) {
                folder.remove(rel)?;
            }
        } else {
            // A killed run may have lost the lock: it is rewritten, the same bytes.
            folder.write_file(LOCK_FILE, lock.as_bytes())?;
            if labels_only {
                folder.set_durable_frames(false);
                folder.write_file(PLAN_README, plan_readme(preset).as_bytes())?;
            } else {
                for split in SplitName::ALL {
                    folder.ensure_dir(&format!("images/{}", split.as_str()))?;
                }
            }
            // Whole files first, then the append-only records: a manifest
            // line never names a label file that is not there yet.
            if yolo {
                formats.push(Box::new(yolo::YoloWriter::create(&mut folder)?));
            }
            let m = preset.output.masks;
            if mask_files && (m.yolo_seg || m.instance_png || m.depth) {
                formats.push(Box::new(masks::MasksWriter::create(&mut folder, m)?));
            }
            formats.push(Box::new(manifest::ManifestWriter::open(
                &mut folder,
                &checkpoint,
            )?));
            if coco {
                formats.push(Box::new(coco::CocoWriter::open(
                    &mut folder,
                    &checkpoint,
                    sequences,
                )?));
            }
            if sequences {
                formats.push(Box::new(mot::MotWriter::open(
                    &mut folder,
                    &checkpoint,
                    preset,
                    labels_only,
                )?));
            }
        }
        Ok(Self {
            folder,
            text,
            texts: FrameTexts::default(),
            image_format: preset.output.image_format,
            classes,
            formats,
            stats: checkpoint.stats,
            next: checkpoint.next,
            total: run.end(),
            every: run.every,
            start: run.start(),
            done,
            needed,
            labels_only,
            boxes_from: boxes_from(preset, labels_only),
        })
    }

    /// The first frame not yet written.
    pub fn next_frame(&self) -> u64 {
        self.next
    }

    /// One past the last frame of this run: its frame count, or with
    /// `--shard` the end of its shard's range.
    pub fn total(&self) -> u64 {
        self.total
    }

    /// The first frame of this run (0, or with `--shard` its range's start).
    pub fn start(&self) -> u64 {
        self.start
    }

    /// The step between the frames this run writes: `K` for `--every K`
    /// (frames `0, K, 2K, …` below [`DatasetWriter::total`]), else 1.
    pub fn every(&self) -> u64 {
        self.every
    }

    /// How this dataset formats a frame's records ([`TextContext::push_frame`]).
    pub fn text_context(&self) -> &TextContext {
        &self.text
    }

    /// Relative path of a frame's image.
    pub fn image_rel_path(&self, scene: &FrameScene) -> String {
        image_rel_path(scene, self.image_format)
    }

    /// Write one frame: claim its files, write its image, then its label
    /// files, manifest line and COCO records, then its checkpoint.
    pub fn write_frame(
        &mut self,
        scene: &FrameScene,
        labels: &[DroneLabel],
        image: &[u8],
    ) -> Result<(), OutputError> {
        self.write_frame_with(scene, labels, image, None)
    }

    /// [`DatasetWriter::write_frame`] with the frame's encoded masks (the
    /// preset's `output.masks`; required when it asks for mask files).
    pub fn write_frame_with(
        &mut self,
        scene: &FrameScene,
        labels: &[DroneLabel],
        image: &[u8],
        masks: Option<&masks::EncodedMasks>,
    ) -> Result<(), OutputError> {
        if scene.index != self.next || self.done {
            return Err(OutputError::OutOfOrder {
                expected: self.next,
                got: scene.index,
            });
        }
        let rel = self.image_rel_path(scene);
        let mut files = vec![rel.clone()];
        for format in &self.formats {
            files.extend(format.frame_files(scene));
        }
        self.folder.claim_frame(&files)?;
        self.folder.write_file(&rel, image)?;
        self.texts.clear();
        self.text
            .push_frame_with(&mut self.texts, scene, labels, masks);
        let record = FrameRecord {
            scene,
            labels,
            image: &rel,
            text: self.texts.get(0),
            masks,
        };
        for format in &mut self.formats {
            format.frame(&mut self.folder, &record)?;
        }
        let mut stats = self.stats.clone();
        stats.add(scene, labels, &self.text.model_names, &self.text.classes);
        self.checkpoint(self.next + self.every, stats)
    }

    /// Write consecutive frames of a labels-only plan (no images): their
    /// records formatted in `texts` (frame by frame, [`TextContext::push_frame`])
    /// and `stats` their statistics ([`DatasetStats::add`] over them). Their
    /// files are claimed in one ledger record, written without a flush to
    /// disk each, and one checkpoint follows the last. A plan killed midway
    /// continues from its last checkpoint like a rendered run; only a power
    /// loss can cost it more than the frames in flight (it is remade in
    /// seconds). Formats and stats are the rendered batch's, frame by frame.
    pub fn write_plan_frames(
        &mut self,
        frames: &[(FrameScene, Vec<DroneLabel>)],
        texts: &FrameTexts,
        stats: &DatasetStats,
    ) -> Result<(), OutputError> {
        let mut files = Vec::new();
        for (i, (scene, _)) in frames.iter().enumerate() {
            let trial = self.every != 1;
            if scene.index != self.next + i as u64 || self.done || !self.labels_only || trial {
                return Err(OutputError::OutOfOrder {
                    expected: self.next + i as u64,
                    got: scene.index,
                });
            }
            for format in &self.formats {
                files.extend(format.frame_files(scene));
            }
        }
        if texts.len() != frames.len() {
            return Err(OutputError::OutOfOrder {
                expected: self.next + texts.len() as u64,
                got: self.next + frames.len() as u64,
            });
        }
        self.folder.claim_frame(&files)?;
        for (i, (scene, labels)) in frames.iter().enumerate() {
            let rel = self.image_rel_path(scene);
            let record = FrameRecord {
                scene,
                labels,
                image: &rel,
                text: texts.get(i),
                masks: None,
            };
            for format in &mut self.formats {
                format.frame(&mut self.folder, &record)?;
            }
        }
        let mut sum = self.stats.clone();
        sum.merge(stats);
        self.checkpoint(self.next + frames.len() as u64, sum)
    }

    /// Make the frames before `next` durable: every format writes its buffered
    /// bytes and records its length, and one checkpoint with `stats` is committed.
    fn checkpoint(&mut self, next: u64, stats: DatasetStats) -> Result<(), OutputError> {
        for format in &mut self.formats {
            format.flush()?;
        }
        let mut checkpoint = Checkpoint {
            next,
            stats,
            ..Checkpoint::default()
        };
        for format in &mut self.formats {
            format.save(&mut checkpoint);
        }
        self.folder.commit(&checkpoint)?;
        self.stats = checkpoint.stats;
        self.next = next;
        Ok(())
    }

    /// `swarmshot merge`: append the finished shard in `dir`, whose frames
    /// `start..end` follow the frames written so far. Its per-frame files
    /// (every file its ledger lists but the dataset's fixed entries: images,
    /// label files, MOT files) are hard-linked or copied in, each format
    /// appends its records, the statistics are added, and one checkpoint
    /// marks the shard complete (a killed merge continues from the shard
    /// after the last complete one). Returns the files linked and copied.
    pub fn merge_shard(
        &mut self,
        dir: &Path,
        start: u64,
        end: u64,
        stats: &DatasetStats,
        checked: &merge::CheckedShard,
        copy: bool,
    ) -> Result<(u64, u64), OutputError> {
        if start != self.next || self.done || end > self.total {
            return Err(OutputError::OutOfOrder {
                expected: self.next,
                got: start,
            });
        }
        let files: Vec<String> = (checked.files.keys())
            .filter(|rel| !self.needed.contains(*rel))
            .cloned()
            .collect();
        self.folder.claim_frame(&files)?;
        let mut shard = tree::Tree::open(dir)?;
        let (mut linked, mut copied) = (0, 0);
        for rel in &files {
            if self
                .folder
                .link_file(rel, &mut shard, checked.files[rel], copy)?
            {
                linked += 1;
            } else {
                copied += 1;
            }
        }
        for format in &mut self.formats {
            format.merge_shard(&mut self.folder, dir)?;
        }
        self.checkpoint(end, stats.clone())?;
        Ok((linked, copied))
    }

    /// The statistics of the frames written so far.
    pub fn stats(&self) -> &DatasetStats {
        &self.stats
    }

    /// After a failed [`DatasetWriter::write_frame`]: delete the frame's
    /// files and cut the manifest and COCO records back, so the folder holds
    /// exactly the frames before it.
    pub fn rollback(&mut self) {
        self.folder.drop_frame();
        for format in &mut self.formats {
            format.rollback();
        }
    }

    /// Write the end files (COCO assembled, data.yaml, stats.json). When every
    /// frame is written, mark the run done and delete the working files.
    pub fn finish(mut self) -> Result<DatasetStats, OutputError> {
        if self.done {
            return Ok(self.stats);
        }
        let info = DatasetInfo {
            classes: std::mem::take(&mut self.classes),
            labels_only: self.labels_only,
            frames_per_split: self.stats.frames_per_split,
        };
        for format in &mut self.formats {
            format.finish(&mut self.folder, &info)?;
        }
        self.stats.labels_only = self.labels_only;
        self.stats.boxes_from = self.boxes_from.clone();
        let stats = serde_json::to_string_pretty(&self.stats).unwrap_or_default();
        self.folder.write_file("stats.json", stats.as_bytes())?;
        // With `--every K` the last frame's successor may lie past the end.
        if self.next >= self.total {
            self.folder.mark_done()?;
            for format in &mut self.formats {
                format.cleanup(&mut self.folder)?;
            }
        }
        Ok(self.stats)
    }
}

/// The dataset's fixed entries (lock, manifest, COCO files, folders ending
/// in `/`) for `preset`, checked before anything is written.
fn needed_entries(preset: &Preset, labels_only: bool) -> Vec<String> {
    let (yolo, coco) = (
        preset.output.label_formats.contains(&LabelFormat::Yolo),
        preset.output.label_formats.contains(&LabelFormat::Coco),
    );
    let mut needed = vec![
        LOCK_FILE.to_owned(),
        manifest::FILE.to_owned(),
        "stats.json".to_owned(),
    ];
    if labels_only {
        needed.push(PLAN_README.to_owned());
    }
    for split in SplitName::ALL.map(SplitName::as_str) {
        if !labels_only {
            needed.push(format!("images/{split}/"));
        }
        if yolo {
            needed.push(format!("labels/{split}/"));
        }
        if coco {
            needed.push(format!("annotations/instances_{split}.json"));
            needed.push(format!("annotations/.instances_{split}.images.part"));
            needed.push(format!("annotations/.instances_{split}.annotations.part"));
        }
    }
    if yolo && !labels_only {
        needed.push("data.yaml".to_owned());
    }
    // Masks need pixels: a labels-only plan writes none.
    let mask_files = !labels_only && preset.output.masks.any();
    if mask_files {
        needed.extend(masks::needed_entries(&preset.output.masks));
    }
    let sequences = preset.sequence.is_some();
    if sequences {
        needed.push("mot/".to_owned());
        needed.push(format!("{}/", mot::SEQMAPS));
        for split in SplitName::ALL {
            needed.push(mot::seqmap_rel_path(split));
        }
        if coco {
            for split in SplitName::ALL.map(SplitName::as_str) {
                needed.push(format!("annotations/.instances_{split}.videos.part"));
            }
        }
    }
    needed
}

#[cfg(test)]
pub(crate) fn xywh(b: &PixelBox) -> [f64; 4] {
    [r6(b.x0), r6(b.y0), r6(b.width()), r6(b.height())]
}

/// `PLAN.txt`: what a labels-only plan folder is and is not.
fn plan_readme(preset: &Preset) -> String {
    let visible = if preset.labels.needs_id_pass() {
        "This preset asks for Visible boxes or visibility filters, which need pixels: here every\n\
         box is the AMODAL box within the image and no visibility filter ran, so these labels are\n\
         an ESTIMATE (stats.json: \"visible_boxes\": \"estimated\"). A rendered run's boxes are\n\
         tighter on partly hidden drones, and filtered drones are missing from it.\n"
    } else {
        "The preset's boxes (Amodal or PaperAabb) come from geometry alone: every label line,\n\
         COCO box and manifest box here is exactly what the rendered batch writes.\n"
    };
    format!(
        "swarmshot labels-only plan of preset \"{}\" (swarmshot batch --labels-only).\n\n\
         NO IMAGES were rendered: there is no images/ folder and no data.yaml, so this folder\n\
         is not a training set. The COCO files' image records name the images a rendered run\n\
         would write (their \"info\" says labels_only). Use it to look at the distribution\n\
         before rendering: swarmshot stats DIR.\n\n{visible}\n\
         Render the dataset with swarmshot batch PRESET --out OTHER_DIR (a plan folder is\n\
         never continued by a rendered run, nor the other way round).\n",
        preset.name
    )
}

/// Where a dataset's training boxes come from, for `stats.json`.
pub(crate) fn boxes_from(preset: &Preset, labels_only: bool) -> String {
    use crate::preset::BoxMethod;
    match (preset.labels.box_method, labels_only) {
        (BoxMethod::Visible, false) => "Visible (measured from the id pass)".into(),
        (BoxMethod::Visible, true) => {
            "Visible ESTIMATED by Amodal boxes within the image (labels-only plan: no pixels, no visibility filter)".into()
        }
        (method, true) if preset.labels.needs_id_pass() => format!(
            "{method:?} (labels-only plan: the visibility filters did not run)"
        ),
        (method, _) => format!("{method:?} (geometry: exact)"),
    }
}
