//! The pose manifest: one JSON line per frame with the frame's index, seed,
//! split, sweep values, camera (K, R, t) and every drone's model, pose and label.
//!
//! This file holds the writer and the line's top level; `manifest/frame.rs`
//! the frame's records (camera, sequence, sweep, environment, camera-model
//! draws, models present; COCO's image records share the sweep and the
//! models), `manifest/drones.rs` the drones' records and labels,
//! `manifest/confusers.rs` the confusers' records, `manifest/reference.rs`
//! the serde reference the tests compare the bytes with.

mod confusers;
mod drones;
mod frame;
#[cfg(test)]
pub(crate) mod reference;

pub use frame::models_present;
pub(crate) use frame::{write_models_present, write_sweep};

use super::json::{Decimals, Json};
use super::{FormatWriter, FrameRecord};
use crate::annotate::DroneLabel;
use crate::scene::FrameScene;
use crate::write::folder::AppendFile;
use crate::write::shards::merge::ShardReader;
use crate::write::{Checkpoint, Folder, OutputError};

/// File name of the manifest in the dataset folder.
pub const FILE: &str = "manifest.jsonl";

/// Appends `manifest.jsonl`, one whole line per frame; a resumed run cuts it
/// back to the last checkpoint's length, so it is never torn.
pub struct ManifestWriter {
    out: AppendFile,
}

impl ManifestWriter {
    /// Open the manifest, cut back to `checkpoint` (created when new).
    pub fn open(folder: &mut Folder, checkpoint: &Checkpoint) -> Result<Self, OutputError> {
        let len = checkpoint.files.get(FILE).copied().unwrap_or(0);
        let out = folder.open_append(FILE, len)?.buffered();
        // Handed to the disk as it is written, unless the run hashes it at its end.
        let out = if folder.reads_back() {
            out
        } else {
            out.write_back()
        };
        Ok(Self { out })
    }
}

impl FormatWriter for ManifestWriter {
    fn frame(&mut self, _folder: &mut Folder, record: &FrameRecord<'_>) -> Result<(), OutputError> {
        self.out.append(record.text.manifest)?;
        self.out.append(b"\n")
    }

    fn flush(&mut self) -> Result<(), OutputError> {
        self.out.flush()
    }

    fn save(&mut self, checkpoint: &mut Checkpoint) {
        self.out.save(checkpoint);
    }

    fn rollback(&mut self) {
        self.out.rollback();
    }

    fn finish(
        &mut self,
        _folder: &mut Folder,
        _dataset: &super::DatasetInfo,
    ) -> Result<(), OutputError> {
        self.out.sync()
    }

    /// The shard's lines follow, as they are (whatever fields they carry).
    fn merge_shard(
        &mut self,
        _folder: &mut Folder,
        shard: &mut ShardReader<'_>,
    ) -> Result<(), OutputError> {
        use std::io::{Read, Seek, SeekFrom};
        let path = shard.path(FILE);
        let mut file = shard.open(FILE)?;
        // The last byte first: a torn line refuses the shard before any is appended.
        let mut last = [b'\n'];
        let end = file
            .seek(SeekFrom::End(0))
            .map_err(crate::write::io(&path))?;
        if end > 0 {
            file.seek(SeekFrom::End(-1))
                .and_then(|_| file.read_exact(&mut last))
                .and_then(|()| file.rewind())
                .map_err(crate::write::io(&path))?;
        }
        if last != [b'\n'] {
            return Err(OutputError::Shard {
                path,
                reason: "ends in a torn line; is the shard finished?".into(),
            });
        }
        // Copied in chunks: a shard's manifest may be gigabytes.
        let mut chunk = vec![0u8; MERGE_CHUNK];
        loop {
            let n = file.read(&mut chunk).map_err(crate::write::io(&path))?;
            if n == 0 {
                return Ok(());
            }
            self.out.append(&chunk[..n])?;
        }
    }
}

/// The bytes of a shard's manifest read at a time by [`ManifestWriter::merge_shard`].
const MERGE_CHUNK: usize = 4 << 20;

/// One manifest line: the frame's index, seed, split, sweep values,
/// environment, camera (K, R, t) and every drone's model, pose and label.
pub fn manifest_line(
    scene: &FrameScene,
    labels: &[DroneLabel],
    image: &str,
    model_names: &[String],
    classes: &[String],
) -> String {
    let mut out = Vec::with_capacity(1024 + 640 * scene.drones.len());
    write_manifest_line(&mut out, scene, labels, image, model_names, classes);
    // Only JSON text was written: valid UTF-8.
    String::from_utf8(out).unwrap_or_default()
}

/// [`manifest_line`] appended to `out` (without its newline): compact JSON,
/// fields in byte order of their names (the order a sorted JSON map writes
/// them), the bytes serde_json writes for the same records (the tests
/// compare them), written straight into the buffer.
pub fn write_manifest_line(
    out: &mut Vec<u8>,
    scene: &FrameScene,
    labels: &[DroneLabel],
    image: &str,
    model_names: &[String],
    classes: &[String],
) {
    let mut j = Json { out };
    // The atmosphere adds its field only when the preset has one.
    j.raw(b"{");
    if let Some(a) = &scene.atmosphere {
        j.raw(b"\"atmosphere\":{\"visibility_m\":");
        j.rounded(a.visibility_m, Decimals::Nine);
        j.raw(b"},");
    }
    // A backplate adds its field only when the preset has one.
    if let Some(p) = &scene.backplate {
        j.raw(b"\"backplate\":{\"file\":");
        j.str(&p.file);
        j.raw(if p.flip {
            b",\"flip\":true},"
        } else {
            b",\"flip\":false},"
        });
    }
    frame::write_camera(&mut j, scene);
    if let Some(c) = &scene.camera_model {
        j.raw(b",\"camera_model\":");
        frame::write_camera_model(&mut j, scene, c);
    }
    if !scene.confusers.is_empty() {
        j.raw(b",\"confusers\":[");
        confusers::write_confusers(&mut j, scene, labels, model_names, classes);
        j.raw(b"]");
    }
    j.raw(b",\"drones\":[");
    drones::write_drones(&mut j, scene, labels, model_names, classes);
    j.raw(b"],\"environment\":");
    frame::write_environment(&mut j, scene);
    j.raw(b",\"image\":");
    j.str(image);
    j.raw(b",\"index\":");
    j.u64(scene.index);
    j.raw(b",\"models_present\":");
    frame::write_models_present(&mut j, scene, model_names);
    j.raw(b",\"placement_shortfall\":");
    j.u64(scene.placement_shortfall.into());
    if scene.redraw > 0 {
        j.raw(b",\"redraw\":");
        j.u64(scene.redraw.into());
    }
    j.raw(b",\"seed\":");
    j.u64(scene.seed);
    if let Some(seq) = &scene.sequence {
        frame::write_sequence(&mut j, seq);
    }
    j.raw(b",\"split\":\"");
    j.raw(scene.split.as_str().as_bytes());
    j.raw(b"\",\"sweep\":");
    frame::write_sweep(&mut j, scene);
    j.raw(b",\"volume_radius_m\":");
    j.rounded(scene.volume_radius_m, Decimals::Nine);
    // Rain or snow adds its draws only when the preset has weather.
    if let Some(w) = &scene.weather {
        frame::write_weather(&mut j, w);
    }
    j.raw(b"}");
}
