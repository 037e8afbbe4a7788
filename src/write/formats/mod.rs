//! Label formats, one file each behind [`FormatWriter`]: YOLO ([`yolo`]),
//! COCO ([`coco`]), MOTChallenge ([`mot`], sequence mode), masks and maps
//! ([`masks`], `output.masks`) and the pose manifest ([`manifest`]), with
//! the compact JSON writer their records share (`json.rs`).
//!
//! A frame's records that depend on the frame alone are formatted as text
//! first ([`TextContext::push_frame`], on any thread); the writers append
//! them in index order. Which formats a dataset writes, and the fixed
//! entries each needs, is decided here alone: `open_writers` and
//! `needed_entries` hold one line per format.

pub mod coco;
pub(crate) mod json;
pub mod manifest;
pub mod masks;
pub mod mot;
pub mod yolo;

use super::{Checkpoint, Folder, OutputError};
use crate::annotate::DroneLabel;
use crate::preset::{ImageFormat, LabelFormat, Preset};
use crate::scene::FrameScene;
use crate::write::shards::merge::ShardReader;

pub use manifest::manifest_line;

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
    /// A labels-only plan: no images were rendered (see [`super::WriterOptions::labels_only`]).
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
    /// label files) are linked by [`super::DatasetWriter::merge_shard`]; a format
    /// with records in shared files (manifest, COCO) appends them here.
    fn merge_shard(
        &mut self,
        _folder: &mut Folder,
        _shard: &mut ShardReader<'_>,
    ) -> Result<(), OutputError> {
        Ok(())
    }
}

/// The formats a dataset of `preset` writes: a labels-only plan writes
/// no masks (they need pixels); MOT comes with sequence mode.
#[derive(Clone, Copy, Debug)]
struct Chosen {
    yolo: bool,
    coco: bool,
    masks: bool,
    mot: bool,
}

impl Chosen {
    fn of(preset: &Preset, labels_only: bool) -> Self {
        let formats = &preset.output.label_formats;
        let m = preset.output.masks;
        Self {
            yolo: formats.contains(&LabelFormat::Yolo),
            coco: formats.contains(&LabelFormat::Coco),
            masks: !labels_only && (m.yolo_seg || m.instance_png || m.depth || m.flow),
            mot: preset.sequence.is_some(),
        }
    }
}

/// The fixed entries of the formats `preset` asks for (files, and folders
/// ending in `/`), checked before anything is written.
pub(super) fn needed_entries(preset: &Preset, labels_only: bool) -> Vec<String> {
    let on = Chosen::of(preset, labels_only);
    let mut needed = vec![manifest::FILE.to_owned()];
    if on.yolo {
        needed.extend(yolo::needed_entries(labels_only));
    }
    if on.coco {
        needed.extend(coco::needed_entries(on.mot));
    }
    if on.masks {
        needed.extend(masks::needed_entries(&preset.output.masks));
    }
    if on.mot {
        needed.extend(mot::needed_entries());
    }
    needed
}

/// Open the writers of the formats `preset` asks for, continuing from
/// `checkpoint`. Whole files first, then the append-only records: a
/// manifest line never names a label file that is not there yet.
pub(super) fn open_writers(
    folder: &mut Folder,
    preset: &Preset,
    checkpoint: &Checkpoint,
    labels_only: bool,
) -> Result<Vec<Box<dyn FormatWriter>>, OutputError> {
    let on = Chosen::of(preset, labels_only);
    let mut formats: Vec<Box<dyn FormatWriter>> = Vec::new();
    if on.yolo {
        formats.push(Box::new(yolo::YoloWriter::create(folder)?));
    }
    if on.masks {
        let m = preset.output.masks;
        formats.push(Box::new(masks::MasksWriter::create(folder, m)?));
    }
    formats.push(Box::new(manifest::ManifestWriter::open(
        folder, checkpoint,
    )?));
    if on.coco {
        formats.push(Box::new(coco::CocoWriter::open(
            folder, checkpoint, on.mot,
        )?));
    }
    if on.mot {
        let mot = mot::MotWriter::open(folder, checkpoint, preset, labels_only)?;
        formats.push(Box::new(mot));
    }
    Ok(formats)
}
