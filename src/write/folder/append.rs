//! [`AppendFile`]: the append-only files (manifest, COCO record parts), cut back on resume.

use super::*;

/// An append-only file (the manifest, COCO record parts): whole records
/// appended, cut back to the last checkpoint on resume or failure.
pub struct AppendFile {
    pub(super) rel: String,
    pub(super) path: PathBuf,
    pub(super) file: File,
    /// Bytes appended so far (on disk and in `buffer`).
    pub(super) len: u64,
    pub(super) committed: u64,
    /// With [`AppendFile::buffered`]: appended bytes not yet written.
    pub(super) buffer: Option<Vec<u8>>,
}

/// A buffered [`AppendFile`] writes once this many bytes are pending.
pub(super) const APPEND_BUFFER: usize = 1 << 20;

impl AppendFile {
    /// Keep appended bytes in memory until [`AppendFile::flush`] (or a
    /// megabyte is pending): one write per batch of records instead of one
    /// per record. The owner flushes before [`AppendFile::save`].
    pub fn buffered(mut self) -> Self {
        self.buffer = Some(Vec::with_capacity(APPEND_BUFFER));
        self
    }

    /// Append `bytes` (one or more whole records, or part of one that the
    /// next calls finish before the file is saved).
    pub fn append(&mut self, bytes: &[u8]) -> Result<(), OutputError> {
        self.len += bytes.len() as u64;
        match &mut self.buffer {
            Some(buffer) => {
                buffer.extend_from_slice(bytes);
                if buffer.len() >= APPEND_BUFFER {
                    self.flush()?;
                }
                Ok(())
            }
            None => (&self.file).write_all(bytes).map_err(io(&self.path)),
        }
    }

    /// Write the buffered bytes (nothing when unbuffered).
    pub fn flush(&mut self) -> Result<(), OutputError> {
        if let Some(buffer) = &mut self.buffer
            && !buffer.is_empty()
        {
            let result = (&self.file).write_all(buffer);
            buffer.clear();
            result.map_err(io(&self.path))?;
        }
        Ok(())
    }

    /// Bytes written so far.
    pub fn len(&self) -> u64 {
        self.len
    }

    /// Whether nothing has been written.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Record this file's length in `checkpoint` (the frame is complete;
    /// a buffered file is flushed first).
    pub fn save(&mut self, checkpoint: &mut Checkpoint) {
        debug_assert!(
            self.buffer.as_ref().is_none_or(Vec::is_empty),
            "{} saved with unwritten bytes",
            self.rel
        );
        if self.len != self.committed {
            self.committed = self.len;
            checkpoint.files.insert(self.rel.clone(), self.len);
        }
    }

    /// Cut the file back to its last checkpoint (after a failed frame).
    pub fn rollback(&mut self) {
        if let Some(buffer) = &mut self.buffer {
            buffer.clear();
        }
        if self.file.set_len(self.committed).is_ok() {
            self.len = self.committed;
        }
    }

    /// Copy the whole file into `out`.
    pub fn copy_to(&mut self, out: &mut impl Write) -> std::io::Result<()> {
        if let Some(buffer) = &mut self.buffer
            && !buffer.is_empty()
        {
            (&self.file).write_all(buffer)?;
            buffer.clear();
        }
        self.file.seek(SeekFrom::Start(0))?;
        std::io::copy(&mut (&self.file).take(self.len), out)?;
        Ok(())
    }

    /// Flush the file to disk.
    pub fn sync(&mut self) -> Result<(), OutputError> {
        self.flush()?;
        self.file.sync_data().map_err(io(&self.path))
    }

    /// Path relative to the folder.
    pub fn rel(&self) -> &str {
        &self.rel
    }
}
