//! The frame files of a labels-only plan (one small label file a frame,
//! thousands a second): kept in memory from [`Folder::write_frame_file`] until
//! the chunk's checkpoint, then created together on several threads just
//! before it is committed ([`Folder::commit`]). Their claims are in the
//! ledger before any of them exists; a frame is complete only once its
//! checkpoint is written, which follows its files, so a kill costs what it
//! cost before: the frames after the last checkpoint.
//!
//! On ext4 creating a file (its inode, its directory entry, its first page)
//! is the writer's largest cost; the kernel serialises only the directory
//! entry, so creating a chunk's files on a few threads overlaps the rest.

use std::collections::HashMap;
use std::ops::Range;
use std::os::fd::OwnedFd;

use rustix::fs::{Mode, OFlags};
use rustix::io::Errno;

use super::*;

/// Threads that create one chunk's files, at most (the calling one included).
const CREATE_THREADS: usize = 4;
/// Files per creating thread, at least: fewer are not worth a thread.
const FILES_PER_THREAD: usize = 32;

/// Frame files waiting for their checkpoint: paths and their bytes, kept in one buffer.
#[derive(Default)]
pub(super) struct PendingFiles {
    files: Vec<(String, Range<usize>)>,
    bytes: Vec<u8>,
}

impl PendingFiles {
    pub(super) fn push(&mut self, rel: &str, bytes: &[u8]) {
        let start = self.bytes.len();
        self.bytes.extend_from_slice(bytes);
        self.files.push((rel.to_owned(), start..self.bytes.len()));
    }

    pub(super) fn clear(&mut self) {
        self.files.clear();
        self.bytes.clear();
    }
}

/// How a pending file's creation went.
enum Created {
    Done,
    /// Something is already there (a resumed plan's frame in flight, or a
    /// link): it goes the careful way of [`Folder::write_file`].
    Exists,
}

impl Folder {
    /// Create the pending frame files (see the module docs). A file whose name
    /// is taken is written the careful way; the first error is returned.
    pub(super) fn create_pending(&mut self) -> Result<(), OutputError> {
        if self.pending.files.is_empty() {
            return Ok(());
        }
        let pending = std::mem::take(&mut self.pending);
        let result = self.create_all(&pending);
        self.pending = pending;
        self.pending.clear();
        result
    }

    fn create_all(&mut self, pending: &PendingFiles) -> Result<(), OutputError> {
        // The folders, opened once without following links, by name.
        let mut dirs: HashMap<&str, OwnedFd> = HashMap::new();
        for (rel, _) in &pending.files {
            let dir = rel.rsplit_once('/').map_or("", |(d, _)| d);
            if !dirs.contains_key(dir) {
                let fd = self
                    .tree
                    .open_dir(dir)?
                    .ok_or_else(|| io(&self.root.join(dir))(std::io::ErrorKind::NotFound.into()))?;
                dirs.insert(dir, fd);
            }
        }
        let threads = (pending.files.len() / FILES_PER_THREAD).clamp(1, CREATE_THREADS);
        let per = pending.files.len().div_ceil(threads);
        let root = self.root.as_path();
        let create = |part: &[(String, Range<usize>)]| -> Result<Vec<usize>, OutputError> {
            let mut taken = Vec::new();
            for (i, (rel, range)) in part.iter().enumerate() {
                let path = || root.join(rel);
                let (dir, name) = rel.rsplit_once('/').unwrap_or(("", rel));
                let fd = dirs
                    .get(dir)
                    .ok_or_else(|| io(&path())(std::io::ErrorKind::NotFound.into()))?;
                let created = create_file(fd, name, &pending.bytes[range.clone()])
                    .map_err(|e| io(&path())(std::io::Error::from(e)))?;
                if let Created::Exists = created {
                    taken.push(i);
                }
            }
            Ok(taken)
        };
        let parts: Vec<&[(String, Range<usize>)]> = pending.files.chunks(per.max(1)).collect();
        let results: Vec<Result<Vec<usize>, OutputError>> = std::thread::scope(|s| {
            // A part whose thread the system refuses is created on this
            // thread, in its turn.
            let others: Vec<_> = parts[1..]
                .iter()
                .map(|part| crate::threads::spawn_or_defer(s, move || create(part)))
                .collect();
            let mut results = vec![create(parts[0])];
            for task in others {
                results.push(task.join().unwrap_or_else(|_| {
                    Err(io(root)(std::io::Error::other(
                        "a thread creating label files panicked",
                    )))
                }));
            }
            results
        });
        for (part, result) in parts.iter().zip(results) {
            for i in result? {
                let (rel, range) = &part[i];
                self.write_file(rel, &pending.bytes[range.clone()])?;
            }
        }
        Ok(())
    }
}

/// Create `name` in `dir` (never following a link, never replacing an
/// entry) holding `bytes`, not flushed.
fn create_file(dir: &OwnedFd, name: &str, bytes: &[u8]) -> Result<Created, Errno> {
    let flags = OFlags::WRONLY | OFlags::CREATE | OFlags::EXCL | OFlags::NOFOLLOW | OFlags::CLOEXEC;
    let fd = match rustix::fs::openat(dir, name, flags, Mode::from_raw_mode(0o644)) {
        Ok(fd) => fd,
        Err(Errno::EXIST) => return Ok(Created::Exists),
        Err(e) => return Err(e),
    };
    let mut rest = bytes;
    while !rest.is_empty() {
        match rustix::io::write(&fd, rest) {
            Ok(0) => return Err(Errno::IO),
            Ok(n) => rest = &rest[n..],
            Err(Errno::INTR) => {}
            Err(e) => return Err(e),
        }
    }
    Ok(Created::Done)
}
