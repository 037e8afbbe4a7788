//! Access below a folder that never follows a link: every path component is
//! opened relative to the folder handle above it with `O_NOFOLLOW`
//! (`openat`), and entries are looked at, deleted and linked with
//! `AT_SYMLINK_NOFOLLOW` semantics (`statat`, `unlinkat`, `linkat`), so a
//! folder replaced by a symbolic link is refused by name instead of being
//! walked through. The dataset folder ([`super::folder`]) and `swarmshot
//! merge`'s shards ([`super::merge`]) are read and cleared through it.

use std::fs::File;
use std::os::fd::{AsFd, OwnedFd};
use std::path::{Path, PathBuf};

use rustix::fs::{AtFlags, CWD, FileType, Mode, OFlags, Stat};
use rustix::io::Errno;

use super::{OutputError, io};

/// What an entry is, seen without following it.
#[derive(Clone, Copy, Debug)]
pub struct Entry {
    /// File, folder, link, …
    pub kind: FileType,
    /// Size in bytes.
    pub len: u64,
    /// Number of names (hard links) of the file.
    pub links: u64,
    /// Device and inode: the file's identity.
    pub dev: u64,
    pub ino: u64,
}

impl Entry {
    fn from_stat(st: &Stat) -> Self {
        Self {
            kind: FileType::from_raw_mode(st.st_mode),
            len: u64::try_from(st.st_size).unwrap_or(0),
            #[allow(clippy::useless_conversion, clippy::unnecessary_cast)]
            links: st.st_nlink as u64,
            #[allow(clippy::useless_conversion, clippy::unnecessary_cast)]
            dev: st.st_dev as u64,
            #[allow(clippy::useless_conversion, clippy::unnecessary_cast)]
            ino: st.st_ino as u64,
        }
    }

    /// A regular file.
    pub fn is_file(&self) -> bool {
        self.kind == FileType::RegularFile
    }

    /// A folder.
    pub fn is_dir(&self) -> bool {
        self.kind == FileType::Directory
    }

    /// A symbolic link (never followed).
    pub fn is_symlink(&self) -> bool {
        self.kind == FileType::Symlink
    }
}

/// The refusal for a link met inside a folder swarmshot reads or writes.
pub fn link_refused(path: PathBuf) -> OutputError {
    OutputError::Refused {
        path,
        reason: "is a symbolic link; swarmshot never follows one in its output folder or a shard"
            .into(),
    }
}

/// The refusal for a file with more than one name.
pub fn hard_link_refused(path: PathBuf, links: u64) -> OutputError {
    OutputError::Refused {
        path,
        reason: format!(
            "is a hard link ({links} names share its contents, one of them maybe outside the folder); swarmshot never truncates or appends to one"
        ),
    }
}

/// A folder opened once; everything below it is reached without following links.
pub struct Tree {
    root: PathBuf,
    fd: OwnedFd,
    /// The last folder opened below the root (frame files come in runs of one folder).
    last: Option<(String, OwnedFd)>,
}

fn errno_io(path: &Path) -> impl Fn(Errno) -> OutputError + '_ {
    move |e| io(path)(std::io::Error::from(e))
}

impl Tree {
    /// Open `root` (the folder the user named may itself be a link; what is below it may not).
    pub fn open(root: &Path) -> Result<Self, OutputError> {
        let fd = rustix::fs::open(
            root,
            OFlags::RDONLY | OFlags::DIRECTORY | OFlags::CLOEXEC,
            Mode::empty(),
        )
        .map_err(errno_io(root))?;
        Ok(Self {
            root: root.to_owned(),
            fd,
            last: None,
        })
    }

    /// The folder's path.
    pub fn root(&self) -> &Path {
        &self.root
    }

    /// The root's handle.
    pub fn fd(&self) -> &OwnedFd {
        &self.fd
    }

    /// Open folder `rel` (components separated by `/`) one level at a time
    /// with `O_NOFOLLOW`: `None` if a component is missing; a component that
    /// is a link or not a folder is refused by name.
    pub fn open_dir(&self, rel: &str) -> Result<Option<OwnedFd>, OutputError> {
        let mut fd = rustix::io::dup(&self.fd).map_err(errno_io(&self.root))?;
        let mut at = self.root.clone();
        for part in rel.split('/').filter(|p| !p.is_empty()) {
            at.push(part);
            if part == ".." || part == "." {
                return Err(OutputError::Refused {
                    path: at,
                    reason: "names a folder above (..); the ledger lists only paths inside".into(),
                });
            }
            match rustix::fs::openat(
                &fd,
                part,
                OFlags::RDONLY | OFlags::DIRECTORY | OFlags::NOFOLLOW | OFlags::CLOEXEC,
                Mode::empty(),
            ) {
                Ok(next) => fd = next,
                Err(Errno::NOENT) => return Ok(None),
                Err(e @ (Errno::LOOP | Errno::NOTDIR)) => {
                    let seen = rustix::fs::statat(&fd, part, AtFlags::SYMLINK_NOFOLLOW)
                        .map(|st| Entry::from_stat(&st));
                    return Err(match seen {
                        Ok(s) if s.is_symlink() => link_refused(at),
                        Ok(_) => OutputError::Refused {
                            path: at,
                            reason: "is not a folder".into(),
                        },
                        Err(_) => io(&at)(std::io::Error::from(e)),
                    });
                }
                Err(e) => return Err(io(&at)(std::io::Error::from(e))),
            }
        }
        Ok(Some(fd))
    }

    /// The folder holding `rel` (opened without following links) and `rel`'s last component.
    fn parent<'a>(&mut self, rel: &'a str) -> Result<Option<(&OwnedFd, &'a str)>, OutputError> {
        let rel = rel.trim_end_matches('/');
        let (dir, name) = rel.rsplit_once('/').unwrap_or(("", rel));
        if name.is_empty() || name == ".." || name == "." {
            return Err(OutputError::Refused {
                path: self.root.join(rel),
                reason: "is not a path inside the folder".into(),
            });
        }
        if dir.is_empty() {
            return Ok(Some((&self.fd, name)));
        }
        if self.last.as_ref().is_none_or(|(d, _)| d != dir) {
            match self.open_dir(dir)? {
                Some(fd) => self.last = Some((dir.to_owned(), fd)),
                None => return Ok(None),
            }
        }
        Ok(self.last.as_ref().map(|(_, fd)| (fd, name)))
    }

    /// Look at `rel` without following a link (`None`: it, or a folder above it, is missing).
    pub fn lstat(&mut self, rel: &str) -> Result<Option<Entry>, OutputError> {
        let path = self.root.join(rel);
        let Some((dir, name)) = self.parent(rel)? else {
            return Ok(None);
        };
        match rustix::fs::statat(dir, name, AtFlags::SYMLINK_NOFOLLOW) {
            Ok(st) => Ok(Some(Entry::from_stat(&st))),
            Err(Errno::NOENT) => Ok(None),
            Err(e) => Err(errno_io(&path)(e)),
        }
    }

    /// Open the regular file `rel` without following a link: to read, or to
    /// read and append (`append`: then it must have one name only, so
    /// cutting it back or appending cannot reach a file elsewhere).
    pub fn open_file(&mut self, rel: &str, append: bool) -> Result<File, OutputError> {
        let path = self.root.join(rel);
        let Some((dir, name)) = self.parent(rel)? else {
            return Err(io(&path)(std::io::ErrorKind::NotFound.into()));
        };
        let flags = if append {
            OFlags::RDWR | OFlags::APPEND
        } else {
            OFlags::RDONLY
        };
        let fd = match rustix::fs::openat(
            dir,
            name,
            flags | OFlags::NOFOLLOW | OFlags::CLOEXEC | OFlags::NOCTTY | OFlags::NONBLOCK,
            Mode::empty(),
        ) {
            Ok(fd) => fd,
            Err(Errno::LOOP) => return Err(link_refused(path)),
            Err(e) => return Err(errno_io(&path)(e)),
        };
        let seen = Entry::from_stat(&rustix::fs::fstat(&fd).map_err(errno_io(&path))?);
        if !seen.is_file() {
            return Err(OutputError::Refused {
                path,
                reason: "is not a regular file".into(),
            });
        }
        if append && seen.links != 1 {
            return Err(hard_link_refused(path, seen.links));
        }
        // Reads and writes block as usual (O_NONBLOCK only kept a FIFO's open from waiting).
        let flags = rustix::fs::fcntl_getfl(&fd).map_err(errno_io(&path))?;
        rustix::fs::fcntl_setfl(&fd, flags - OFlags::NONBLOCK).map_err(errno_io(&path))?;
        Ok(File::from(fd))
    }

    /// Delete the regular file `rel` (nothing if it is missing or not a regular file).
    pub fn remove_file(&mut self, rel: &str) -> Result<bool, OutputError> {
        let path = self.root.join(rel);
        let Some((dir, name)) = self.parent(rel)? else {
            return Ok(false);
        };
        match rustix::fs::statat(dir, name, AtFlags::SYMLINK_NOFOLLOW) {
            Ok(st) if Entry::from_stat(&st).is_file() => {}
            Ok(_) | Err(Errno::NOENT) => return Ok(false),
            Err(e) => return Err(errno_io(&path)(e)),
        }
        match rustix::fs::unlinkat(dir, name, AtFlags::empty()) {
            Ok(()) => Ok(true),
            Err(Errno::NOENT) => Ok(false),
            Err(e) => Err(errno_io(&path)(e)),
        }
    }

    /// Delete the folder `rel` if it is a real, empty folder (kept otherwise).
    pub fn remove_dir_if_empty(&mut self, rel: &str) -> Result<(), OutputError> {
        let Some((dir, name)) = self.parent(rel)? else {
            return Ok(());
        };
        if rustix::fs::statat(dir, name, AtFlags::SYMLINK_NOFOLLOW)
            .is_ok_and(|st| Entry::from_stat(&st).is_dir())
        {
            let _ = rustix::fs::unlinkat(dir, name, AtFlags::REMOVEDIR);
        }
        // The folder itself may have been the cached one.
        if self.last.as_ref().is_some_and(|(d, _)| d == rel) {
            self.last = None;
        }
        Ok(())
    }

    /// Hard-link the file `rel` below this folder to `to` (a path that does
    /// not exist yet), without following a link on either side.
    pub fn link_to(&mut self, rel: &str, to: &Path) -> Result<(), OutputError> {
        let path = self.root.join(rel);
        let Some((dir, name)) = self.parent(rel)? else {
            return Err(io(&path)(std::io::ErrorKind::NotFound.into()));
        };
        rustix::fs::linkat(dir, name, CWD, to, AtFlags::empty()).map_err(errno_io(to))
    }

    /// The device and inode of `file`.
    pub fn identity(file: &File) -> Option<(u64, u64)> {
        rustix::fs::fstat(file.as_fd())
            .ok()
            .map(|st| Entry::from_stat(&st))
            .map(|e| (e.dev, e.ino))
    }
}
