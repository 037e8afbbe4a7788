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
    /// With [`AppendFile::write_back`]: where the bytes start that were
    /// written but not yet handed to the disk.
    pub(super) write_back_from: Option<u64>,
}

/// A buffered [`AppendFile`] writes once this many bytes are pending.
pub(super) const APPEND_BUFFER: usize = 1 << 20;
/// [`AppendFile::write_back`] hands written bytes to the disk in runs of this many at least.
const WRITE_BACK_RUN: u64 = 8 << 20;

impl AppendFile {
    /// Keep appended bytes in memory until [`AppendFile::flush`] (or a
    /// megabyte is pending): one write per batch of records instead of one
    /// per record. The owner flushes before [`AppendFile::save`].
    pub fn buffered(mut self) -> Self {
        self.buffer = Some(Vec::with_capacity(APPEND_BUFFER));
        self
    }

    /// Hand each megabytes-long run of written bytes to the disk as it is
    /// written (Linux: `posix_fadvise(DONTNEED)`, which starts their
    /// write-out without waiting for it and lets the kernel drop them from
    /// its cache once written), so that the flush at the end ([`AppendFile::sync`])
    /// waits for the last run only, not for the whole file. For a large file
    /// written once and not read back (the manifest); nothing is flushed or
    /// promised by it, and the bytes are the same.
    pub fn write_back(mut self) -> Self {
        self.write_back_from = Some(self.len);
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
            self.start_write_back();
        }
        Ok(())
    }

    /// With [`AppendFile::write_back`], once [`WRITE_BACK_RUN`] bytes are
    /// written and not yet handed over: start their write-out (a hint: an
    /// error is ignored, the end's flush writes them anyway).
    fn start_write_back(&mut self) {
        let Some(from) = self.write_back_from else {
            return;
        };
        let written = self.len - self.buffer.as_ref().map_or(0, |b| b.len() as u64);
        let Some(run) = std::num::NonZeroU64::new(written.saturating_sub(from)) else {
            return;
        };
        if run.get() < WRITE_BACK_RUN {
            return;
        }
        #[cfg(any(target_os = "linux", target_os = "android"))]
        let _ = rustix::fs::fadvise(&self.file, from, Some(run), rustix::fs::Advice::DontNeed);
        self.write_back_from = Some(written);
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
        if let Some(from) = &mut self.write_back_from {
            *from = (*from).min(self.len);
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
