//! MOTChallenge tracking ground truth, one folder per sequence (sequence
//! mode only): `mot/{split}/seq-NNNNNNNN/gt/gt.txt` and
//! `mot/{split}/seq-NNNNNNNN/seqinfo.ini`, NNNNNNNN the sequence number.
//!
//! `gt.txt` has one line per labelled drone and frame:
//! `frame,id,x,y,w,h,conf,class,visibility` — frame 1..=T+1 within the
//! sequence, id the drone's track id (its index in the frame + 1, the same in
//! every frame of the sequence), the training box in pixels (top-left corner
//! and size, in the same continuous pixel coordinates as COCO, so the box is
//! exactly the YOLO label's), conf 1 (0 for a crowd region, which MOT
//! evaluation ignores), class the COCO category id, visibility the visible
//! fraction (1 when visibility was not measured). Lines are in frame order,
//! then id order. `gt.txt` is appended a frame at a time and cut back to the
//! last checkpoint on resume, like the manifest; `seqinfo.ini` is written
//! whole with the sequence's first frame.

use std::collections::BTreeMap;

use super::folder::AppendFile;
use super::{Checkpoint, DatasetInfo, Folder, FormatWriter, FrameRecord, OutputError, stem};
use crate::annotate::{DroneLabel, LabelStatus};
use crate::preset::{ImageFormat, Preset};
use crate::scene::{FrameScene, SequenceFrame};

/// The folder of a sequence relative to the dataset folder.
pub fn sequence_dir(scene: &FrameScene, sequence: &SequenceFrame) -> String {
    format!(
        "mot/{}/{}",
        scene.split.as_str(),
        sequence_name(sequence.id)
    )
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
            b.x0,
            b.y0,
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

/// Writes `gt.txt` and `seqinfo.ini` of every sequence.
pub struct MotWriter {
    /// The sequence being written and its `gt.txt`.
    current: Option<(u64, AppendFile)>,
    /// `gt.txt` lengths from the checkpoint a resumed run starts at.
    resume: BTreeMap<String, u64>,
    frame_rate: u32,
    image_format: ImageFormat,
}

impl MotWriter {
    /// Remember where a resumed run's sequence files stand.
    pub fn open(
        folder: &mut Folder,
        checkpoint: &Checkpoint,
        preset: &Preset,
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
        })
    }

    fn seqinfo(&self, scene: &FrameScene, seq: &SequenceFrame) -> String {
        format!(
            "[Sequence]\nname={}\nimDir=../../../images/{}\nframeRate={}\nseqLength={}\nimWidth={}\nimHeight={}\nimExt=.{}\n; swarmshot: frame f of this sequence is image {{firstIndex + f - 1}} (8 digits) in imDir\nfirstIndex={}\n",
            sequence_name(seq.id),
            scene.split.as_str(),
            self.frame_rate,
            seq.steps + 1,
            scene.camera.width,
            scene.camera.height,
            self.image_format.extension(),
            seq.first_index,
        )
    }
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

    fn finish(&mut self, _folder: &mut Folder, _dataset: &DatasetInfo) -> Result<(), OutputError> {
        match &mut self.current {
            Some((_, gt)) => gt.sync(),
            None => Ok(()),
        }
    }
}
