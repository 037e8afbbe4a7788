//! [`DatasetWriter`]: one dataset folder written frame by frame in index
//! order. It opens the [`Folder`] (a new run, a resumed one, a shard, a
//! labels-only plan), writes the locked preset, feeds every frame to the
//! label formats' writers (`formats::open_writers`), checkpoints each
//! frame, appends finished shards (`swarmshot merge`) and writes the end
//! files (COCO assembled, `data.yaml`, `stats.json`).

use std::path::Path;

use super::folder::{InputRecord, fnv1a64, tree};
use super::formats::{
    self, DatasetInfo, FormatWriter, FrameRecord, FrameTexts, TextContext, masks,
};
use super::shards::{merge, shard};
use super::{
    Checkpoint, DatasetStats, Folder, OpenMode, OutputError, ShardPlan, Start, image_rel_path,
};
use crate::annotate::DroneLabel;
use crate::preset::{ImageFormat, Preset};
use crate::scene::{FrameScene, SplitName};

/// The locked preset's file in the dataset folder.
const LOCK_FILE: &str = "preset.lock.ron";

/// How [`DatasetWriter::open`] treats the folder.
#[derive(Clone, Debug, Default)]
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
    /// A `swarmshot merge`: a refusal names no batch flags.
    pub merge: bool,
    /// What the preset's input files hold (`pipeline::inputs`): recorded by
    /// a new run, compared by a continued one.
    pub inputs: Vec<InputRecord>,
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

/// Refuse a run whose output folder `root` holds a file or folder the
/// preset reads ([`Preset::input_paths`]: a sky image, the backplate
/// folder, a model) or lies inside a folder it reads: the run, or a later
/// one continuing it, would read what was written instead of what the
/// preset names. Compared as canonical paths (links resolved, `root` as far
/// as it exists); an input that does not exist is left to the stage that
/// reads it.
fn check_inputs_outside(root: &Path, preset: &Preset) -> Result<(), OutputError> {
    let out = crate::input::canonical_as_far_as_it_exists(root).map_err(super::io(root))?;
    for (field, path) in preset.input_paths() {
        let Ok(input) = path.canonicalize() else {
            continue;
        };
        let inside = input.starts_with(&out);
        if inside || (input.is_dir() && out.starts_with(&input)) {
            return Err(OutputError::InputInside {
                field,
                input: path.to_owned(),
                out: root.to_owned(),
                out_inside: !inside,
            });
        }
    }
    Ok(())
}

/// Refuse an output folder `root` that is, or lies inside, one of the
/// [`super::DATA_FOLDERS`] of another swarmshot dataset (a folder above it
/// holding a [`super::folder::LEDGER`]; compared canonically, `root` as far
/// as it exists): that dataset's readers (Ultralytics reads `images/`
/// recursively, `merge` and `--resume` check its frame folders) would take
/// this run's files for its frames.
pub(crate) fn check_outside_other_datasets(root: &Path) -> Result<(), OutputError> {
    let out = crate::input::canonical_as_far_as_it_exists(root).map_err(super::io(root))?;
    for above in out.ancestors().skip(1) {
        let Some(folder) = out.strip_prefix(above).ok().and_then(|r| r.iter().next()) else {
            continue;
        };
        let data = super::DATA_FOLDERS.iter().find(|f| folder == **f);
        if let Some(data) = data
            && std::fs::symlink_metadata(above.join(super::folder::LEDGER)).is_ok()
        {
            return Err(OutputError::Refused {
                path: root.to_owned(),
                reason: format!(
                    "is inside the {data}/ folder of the swarmshot dataset {}, whose readers would take this run's files for its frames",
                    above.display()
                ),
            });
        }
    }
    Ok(())
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
        check_inputs_outside(root, preset)?;
        check_outside_other_datasets(root)?;
        // The preset's paths as its file wrote them: the same lock wherever it was run from.
        let lock = preset.lock_text();
        let labels_only = options.labels_only;
        let needed = needed_entries(preset, labels_only);
        // Every entry is checked before anything is written or rendered: a
        // link or a file swarmshot did not write is refused now, not after hours.
        let plan_text = format!("{lock}{PLAN_MARK}");
        let (run_text, twin) = if labels_only {
            (plan_text, (fnv1a64(lock.as_bytes()), "a rendered run"))
        } else {
            let plan = fnv1a64(plan_text.as_bytes());
            (lock.clone(), (plan, "a labels-only plan"))
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
                twin: Some(twin),
                labels_only,
                merge: options.merge,
            },
            &needed,
            &options.inputs,
        )?;
        let (mut checkpoint, done) = match start {
            Start::Fresh => (Checkpoint::default(), false),
            Start::Resume { checkpoint, done } => (*checkpoint, done),
        };
        // A shard starts at its first frame.
        checkpoint.next = checkpoint.next.max(run.start());
        let (classes, _) = preset.classes();
        let text = TextContext::new(preset, model_names.clone());
        let mut writers: Vec<Box<dyn FormatWriter>> = Vec::new();
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
            writers = formats::open_writers(&mut folder, preset, &checkpoint, labels_only)?;
        }
        Ok(Self {
            folder,
            text,
            texts: FrameTexts::default(),
            image_format: preset.output.image_format,
            classes,
            formats: writers,
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
        let mut reader = merge::ShardReader {
            tree: &mut shard,
            checked,
        };
        for format in &mut self.formats {
            format.merge_shard(&mut self.folder, &mut reader)?;
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

/// The dataset's fixed entries (lock, stats, the plan's note, image
/// folders, then every format's: `formats::needed_entries`; folders end
/// in `/`) for `preset`, checked before anything is written.
fn needed_entries(preset: &Preset, labels_only: bool) -> Vec<String> {
    let mut needed = vec![LOCK_FILE.to_owned(), "stats.json".to_owned()];
    if labels_only {
        needed.push(PLAN_README.to_owned());
    } else {
        needed.extend(SplitName::ALL.map(|split| format!("images/{}/", split.as_str())));
    }
    needed.extend(formats::needed_entries(preset, labels_only));
    needed
}

/// `PLAN.txt`: what a labels-only plan folder is and is not.
fn plan_readme(preset: &Preset) -> String {
    let visible = if preset.labels.needs_id_pass() {
        "This preset asks for Visible boxes or visibility filters, which need pixels: here every\n\
         box is the AMODAL box within the image and no visibility filter ran, so these labels are\n\
         an ESTIMATE (stats.json: \"boxes_from\": \"Visible ESTIMATED by Amodal boxes …\"). A\n\
         rendered run's boxes are tighter on partly hidden drones, and filtered drones are missing\n\
         from it.\n"
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
