//! MOTChallenge tracking ground truth in the layout of the MOTChallenge
//! devkit and TrackEval (sequence mode only), one folder per sequence:
//! `mot/{split}/seq-NNNNNNNN/` (NNNNNNNN the sequence number) holding
//! `img1/000001.ext` … (hard links to the dataset's images, no second copy;
//! none in a labels-only plan), `gt/gt.txt` and `seqinfo.ini` (the standard
//! keys only: name, imDir, frameRate, seqLength, imWidth, imHeight, imExt),
//! and per split a sequence map `mot/seqmaps/{split}.txt` (`name`, then the
//! split's sequences), written at the end from the sequence folders on disk.
//!
//! `gt.txt` has one line per labelled drone and frame:
//! `frame,id,bb_left,bb_top,bb_width,bb_height,conf,class,visibility` —
//! frame 1..=T+1 within the sequence, id the drone's track id (its index in
//! the frame + 1, the same in every frame of the sequence), the training box
//! in the devkit's 1-based pixel coordinates (the top-left pixel's corner is
//! (1, 1): the COCO box moved by one pixel, so the box is exactly the YOLO
//! label's), conf 1 (0 for a crowd region, which MOT evaluation ignores),
//! class the COCO category id, visibility the visible fraction (1 when
//! visibility was not measured). Lines are in frame order, then id order.
//! `gt.txt` is appended a frame at a time and cut back to the last
//! checkpoint on resume, like the manifest; `seqinfo.ini` is written whole
//! with the sequence's first frame.

use std::collections::BTreeMap;

use super::{DatasetInfo, FormatWriter, FrameRecord};
use crate::annotate::{DroneLabel, LabelStatus};
use crate::preset::{ImageFormat, Preset};
use crate::scene::{FrameScene, SequenceFrame, SplitName};
use crate::write::folder::AppendFile;
use crate::write::{Checkpoint, Folder, OutputError, stem};

/// The folder of a sequence relative to the dataset folder.
pub fn sequence_dir(scene: &FrameScene, sequence: &SequenceFrame) -> String {
    format!(
        "mot/{}/{}",
        scene.split.as_str(),
        sequence_name(sequence.id)
    )
}

/// The folder of the sequence maps, `{split}.txt` each.
pub const SEQMAPS: &str = "mot/seqmaps";

/// The sequence map of `split` relative to the dataset folder.
pub fn seqmap_rel_path(split: SplitName) -> String {
    format!("{SEQMAPS}/{}.txt", split.as_str())
}

/// The name of step `step` (0-based) of a sequence in its `img1` folder.
pub fn img1_name(step: u64, format: ImageFormat) -> String {
    format!("{:06}.{}", step + 1, format.extension())
}

/// The MOT name of sequence `id`.
pub fn sequence_name(id: u64) -> String {
    format!("seq-{}", stem(id))
}

/// The `gt.txt` lines of one frame.
pub fn gt_lines(scene: &FrameScene, labels: &[DroneLabel]) -> String {
    let mut text = Vec::new();
    let _ = write_gt_lines(scene, labels, |piece| {
        text.extend_from_slice(piece);
        Ok(())
    });
    // Only ASCII digits, signs, points, commas and newlines were written.
    String::from_utf8(text).unwrap_or_default()
}

/// Bytes of `gt.txt` handed on at once by [`write_gt_lines`].
const PIECE_BYTES: usize = 64 << 10;

/// [`gt_lines`] handed to `out` in pieces of about [`PIECE_BYTES`], so a
/// frame of a million drones is never one string in memory.
fn write_gt_lines(
    scene: &FrameScene,
    labels: &[DroneLabel],
    mut out: impl FnMut(&[u8]) -> Result<(), OutputError>,
) -> Result<(), OutputError> {
    use std::io::Write as _;
    let Some(seq) = scene.sequence else {
        return Ok(());
    };
    let mut kept: Vec<&DroneLabel> = labels.iter().filter(|l| l.is_detection_label()).collect();
    kept.sort_by_key(|l| l.drone);
    let mut piece = Vec::with_capacity(PIECE_BYTES + 256);
    for l in kept {
        let b = &l.bbox;
        let conf = u8::from(l.status != LabelStatus::Crowd);
        let visibility = l.visibility.map_or(1.0, |v| v.fraction());
        // Writing into a Vec cannot fail.
        let _ = writeln!(
            piece,
            "{},{},{:.6},{:.6},{:.6},{:.6},{conf},{},{:.6}",
            seq.step + 1,
            l.drone + 1,
            b.x0 + 1.0,
            b.y0 + 1.0,
            b.width(),
            b.height(),
            l.class_id + 1,
            visibility
        );
        if piece.len() >= PIECE_BYTES {
            out(&piece)?;
            piece.clear();
        }
    }
    if piece.is_empty() {
        Ok(())
    } else {
        out(&piece)
    }
}

/// The fixed entries: `mot/`, the seqmaps folder and its file per split.
pub fn needed_entries() -> Vec<String> {
    let mut needed = vec!["mot/".to_owned(), format!("{SEQMAPS}/")];
    needed.extend(SplitName::ALL.map(seqmap_rel_path));
    needed
}

/// Writes `gt.txt` and `seqinfo.ini` of every sequence.
pub struct MotWriter {
    /// The sequence being written and its `gt.txt`.
    current: Option<(u64, AppendFile)>,
    /// `gt.txt` lengths from the checkpoint a resumed run starts at.
    resume: BTreeMap<String, u64>,
    frame_rate: u32,
    image_format: ImageFormat,
    /// Images are written (not a labels-only plan): each gets its `img1` link.
    images: bool,
}

impl MotWriter {
    /// Remember where a resumed run's sequence files stand.
    pub fn open(
        folder: &mut Folder,
        checkpoint: &Checkpoint,
        preset: &Preset,
        labels_only: bool,
    ) -> Result<Self, OutputError> {
        folder.ensure_dir("mot")?;
        let resume = checkpoint
            .files
            .iter()
            .filter(|(rel, _)| rel.starts_with("mot/"))
            .map(|(rel, len)| (rel.clone(), *len))
            .collect();
        Ok(Self {
            current: None,
            resume,
            frame_rate: preset.sequence.as_ref().map_or(30, |s| s.frame_rate),
            image_format: preset.output.image_format,
            images: !labels_only,
        })
    }

    fn seqinfo(&self, scene: &FrameScene, seq: &SequenceFrame) -> String {
        format!(
            "[Sequence]\nname={}\nimDir=img1\nframeRate={}\nseqLength={}\nimWidth={}\nimHeight={}\nimExt=.{}\n",
            sequence_name(seq.id),
            self.frame_rate,
            seq.steps + 1,
            scene.camera.width,
            scene.camera.height,
            self.image_format.extension(),
        )
    }
}

/// A split's sequence map: `name`, then each sequence folder's name in
/// `mot/{split}`, sorted (TrackEval's `SEQMAP_FILE`).
fn seqmap(folder: &mut Folder, split: SplitName) -> Result<Option<String>, OutputError> {
    let names = folder.folders_in(&format!("mot/{}", split.as_str()))?;
    let names: Vec<String> = (names.into_iter())
        .filter(|n| n.strip_prefix("seq-").is_some_and(is_stem))
        .collect();
    if names.is_empty() {
        return Ok(None);
    }
    Ok(Some(format!("name\n{}\n", names.join("\n"))))
}

/// Whether `s` is a frame or sequence stem: eight or more ASCII digits.
fn is_stem(s: &str) -> bool {
    s.len() >= 8 && s.bytes().all(|b| b.is_ascii_digit())
}

impl FormatWriter for MotWriter {
    fn frame_files(&self, scene: &FrameScene) -> Vec<String> {
        match scene.sequence {
            Some(seq) if seq.step == 0 => {
                vec![format!("{}/seqinfo.ini", sequence_dir(scene, &seq))]
            }
            _ => Vec::new(),
        }
    }

    fn frame(&mut self, folder: &mut Folder, record: &FrameRecord<'_>) -> Result<(), OutputError> {
        let scene = record.scene;
        let Some(seq) = scene.sequence else {
            return Ok(());
        };
        let dir = sequence_dir(scene, &seq);
        if self.current.as_ref().is_none_or(|(id, _)| *id != seq.id) {
            if let Some((_, mut done)) = self.current.take() {
                done.sync()?;
            }
            let rel = format!("{dir}/gt/gt.txt");
            let len = self.resume.remove(&rel).unwrap_or(0);
            let gt = folder.open_append(&rel, len)?;
            self.current = Some((seq.id, gt));
        }
        if seq.step == 0 {
            folder.write_file(
                &format!("{dir}/seqinfo.ini"),
                self.seqinfo(scene, &seq).as_bytes(),
            )?;
        }
        if self.images {
            let link = format!("{dir}/img1/{}", img1_name(seq.step, self.image_format));
            folder.link_frame_file(record.image, &link)?;
        }
        match &mut self.current {
            Some((_, gt)) => write_gt_lines(scene, record.labels, |piece| gt.append(piece)),
            None => Ok(()),
        }
    }

    fn save(&mut self, checkpoint: &mut Checkpoint) {
        if let Some((_, gt)) = &mut self.current {
            gt.save(checkpoint);
        }
    }

    fn rollback(&mut self) {
        if let Some((_, gt)) = &mut self.current {
            gt.rollback();
        }
    }

    fn finish(&mut self, folder: &mut Folder, _dataset: &DatasetInfo) -> Result<(), OutputError> {
        if let Some((_, gt)) = &mut self.current {
            gt.sync()?;
        }
        folder.ensure_dir(SEQMAPS)?;
        for split in SplitName::ALL {
            if let Some(text) = seqmap(folder, split)? {
                folder.write_file(&seqmap_rel_path(split), text.as_bytes())?;
            }
        }
        Ok(())
    }
}
