//! Access below a folder that never follows a link: every path component is
//! opened relative to the folder handle above it with `O_NOFOLLOW`
//! (`openat`), and entries are looked at, deleted and linked with
//! `AT_SYMLINK_NOFOLLOW` semantics (`statat`, `unlinkat`, `linkat`), so a
//! folder replaced by a symbolic link is refused by name instead of being
//! walked through. The dataset folder ([`super`]) and `swarmshot
//! merge`'s shards ([`crate::write::shards::merge`]) are read and cleared through it.

use std::collections::HashMap;
use std::fs::File;
use std::os::fd::{AsFd, OwnedFd};
use std::path::{Path, PathBuf};

use rustix::fs::{AtFlags, FileType, Mode, OFlags, Stat};
use rustix::io::Errno;

use crate::write::{OutputError, io};

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
///
/// Every folder below the root is opened once, one level at a time with
/// `O_NOFOLLOW` relative to the handle above it, and its handle is kept:
/// files are then created (`O_CREAT | O_EXCL | O_NOFOLLOW`), renamed
/// (`renameat`), linked (`linkat`) and deleted (`unlinkat`) relative to
/// that handle. A folder replaced by a symbolic link (or moved away) while a
/// run goes on cannot redirect a write: the write still lands in the folder
/// that was opened, and [`Tree::verify`] names the replaced folder so the run
/// stops.
pub struct Tree {
    root: PathBuf,
    fd: OwnedFd,
    /// Folders below the root opened so far, by path relative to it.
    dirs: HashMap<String, OwnedFd>,
}

/// At most this many folder handles are kept; past it the cache starts again
/// (each folder is then opened anew, still one level at a time without links).
const MAX_DIRS: usize = 256;

fn errno_io(path: &Path) -> impl Fn(Errno) -> OutputError + '_ {
    move |e| io(path)(std::io::Error::from(e))
}

/// Split `rel` into its folder (maybe "") and last component, refusing `..`, `.` and "".
fn split(root: &Path, rel: &str) -> Result<(String, String), OutputError> {
    let rel = rel.trim_end_matches('/');
    let (dir, name) = rel.rsplit_once('/').unwrap_or(("", rel));
    check_component(root, rel, name)?;
    Ok((dir.to_owned(), name.to_owned()))
}

fn check_component(root: &Path, rel: &str, part: &str) -> Result<(), OutputError> {
    if part.is_empty() || part == ".." || part == "." {
        return Err(OutputError::Refused {
            path: root.join(rel),
            reason: "is not a path inside the folder (an empty, . or .. component)".into(),
        });
    }
    Ok(())
}

/// The refusal for a component that is not a folder (a link, a file).
fn not_a_folder(parent: &OwnedFd, part: &str, at: PathBuf, e: Errno) -> OutputError {
    let seen =
        rustix::fs::statat(parent, part, AtFlags::SYMLINK_NOFOLLOW).map(|st| Entry::from_stat(&st));
    match seen {
        Ok(s) if s.is_symlink() => link_refused(at),
        Ok(_) => OutputError::Refused {
            path: at,
            reason: "is not a folder".into(),
        },
        Err(_) => io(&at)(std::io::Error::from(e)),
    }
}

fn identity(fd: &OwnedFd) -> Option<(u64, u64)> {
    rustix::fs::fstat(fd)
        .ok()
        .map(|st| Entry::from_stat(&st))
        .map(|e| (e.dev, e.ino))
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
            dirs: HashMap::new(),
        })
    }

    /// A folder already opened (`fd`, e.g. from [`Tree::open_dir`]), named `root` in messages.
    pub fn from_fd(root: PathBuf, fd: OwnedFd) -> Self {
        Self {
            root,
            fd,
            dirs: HashMap::new(),
        }
    }

    /// A second handle on the same root folder (not on whatever the path names now).
    pub fn try_clone(&self) -> Result<Self, OutputError> {
        Ok(Self {
            root: self.root.clone(),
            fd: rustix::io::dup(&self.fd).map_err(errno_io(&self.root))?,
            dirs: HashMap::new(),
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

    /// The handle of folder `rel` (components separated by `/`; "" is the
    /// root), opened once one level at a time with `O_NOFOLLOW`: `None` if a
    /// component is missing; a component that is a link or not a folder is
    /// refused by name.
    fn dir(&mut self, rel: &str) -> Result<Option<&OwnedFd>, OutputError> {
        let rel = rel.trim_matches('/');
        if rel.is_empty() {
            return Ok(Some(&self.fd));
        }
        if !self.dirs.contains_key(rel) {
            if self.dirs.len() >= MAX_DIRS {
                self.dirs.clear();
            }
            let mut prefix = String::new();
            for part in rel.split('/') {
                check_component(&self.root, rel, part)?;
                let parent_rel = prefix.clone();
                if !prefix.is_empty() {
                    prefix.push('/');
                }
                prefix.push_str(part);
                if self.dirs.contains_key(&prefix) {
                    continue;
                }
                let parent = match parent_rel.as_str() {
                    "" => &self.fd,
                    p => &self.dirs[p],
                };
                let flags = OFlags::RDONLY | OFlags::DIRECTORY | OFlags::NOFOLLOW | OFlags::CLOEXEC;
                match rustix::fs::openat(parent, part, flags, Mode::empty()) {
                    Ok(fd) => {
                        self.dirs.insert(prefix.clone(), fd);
                    }
                    Err(Errno::NOENT) => return Ok(None),
                    Err(e @ (Errno::LOOP | Errno::NOTDIR)) => {
                        return Err(not_a_folder(parent, part, self.root.join(&prefix), e));
                    }
                    Err(e) => return Err(errno_io(&self.root.join(&prefix))(e)),
                }
            }
        }
        Ok(self.dirs.get(rel))
    }

    /// Open folder `rel` (see [`Tree::dir`]) as a handle of its own.
    pub fn open_dir(&mut self, rel: &str) -> Result<Option<OwnedFd>, OutputError> {
        let root = self.root.join(rel);
        match self.dir(rel)? {
            Some(fd) => rustix::io::dup(fd).map(Some).map_err(errno_io(&root)),
            None => Ok(None),
        }
    }

    /// The folder holding `rel` (opened without following links) and `rel`'s last component.
    fn parent(&mut self, rel: &str) -> Result<Option<(&OwnedFd, String)>, OutputError> {
        let (dir, name) = split(&self.root, rel)?;
        Ok(self.dir(&dir)?.map(|fd| (fd, name)))
    }

    /// Look at `rel` without following a link (`None`: it, or a folder above it, is missing).
    pub fn lstat(&mut self, rel: &str) -> Result<Option<Entry>, OutputError> {
        let path = self.root.join(rel);
        let Some((dir, name)) = self.parent(rel)? else {
            return Ok(None);
        };
        match rustix::fs::statat(dir, name.as_str(), AtFlags::SYMLINK_NOFOLLOW) {
            Ok(st) => Ok(Some(Entry::from_stat(&st))),
            Err(Errno::NOENT) => Ok(None),
            Err(e) => Err(errno_io(&path)(e)),
        }
    }

    /// Make folder `rel` (its parent exists) unless it is already a real
    /// folder; returns whether it was made. A link or a file there is refused.
    pub fn mkdir(&mut self, rel: &str) -> Result<bool, OutputError> {
        let path = self.root.join(rel);
        let Some((dir, name)) = self.parent(rel)? else {
            return Err(io(&path)(std::io::ErrorKind::NotFound.into()));
        };
        let made = match rustix::fs::mkdirat(dir, name.as_str(), Mode::from_raw_mode(0o755)) {
            Ok(()) => true,
            Err(Errno::EXIST) => false,
            Err(e) => return Err(errno_io(&path)(e)),
        };
        // Opened (and kept) without following a link: a link put there is refused.
        match self.dir(rel)? {
            Some(_) => Ok(made),
            None => Err(OutputError::Refused {
                path,
                reason: "was removed while swarmshot made it".into(),
            }),
        }
    }

    /// Create the new regular file `rel` (it must not exist; never through a
    /// link), to write (`read`: to read and append as well).
    pub fn create_new(&mut self, rel: &str, read: bool) -> Result<File, OutputError> {
        let path = self.root.join(rel);
        let Some((dir, name)) = self.parent(rel)? else {
            return Err(io(&path)(std::io::ErrorKind::NotFound.into()));
        };
        let access = if read {
            OFlags::RDWR | OFlags::APPEND
        } else {
            OFlags::WRONLY
        };
        let flags = access | OFlags::CREATE | OFlags::EXCL | OFlags::NOFOLLOW | OFlags::CLOEXEC;
        match rustix::fs::openat(dir, name.as_str(), flags, Mode::from_raw_mode(0o644)) {
            Ok(fd) => Ok(File::from(fd)),
            Err(Errno::EXIST) if self.lstat(rel)?.is_some_and(|e| e.is_symlink()) => {
                Err(link_refused(path))
            }
            Err(e) => Err(errno_io(&path)(e)),
        }
    }

    /// Rename `from` over `to` (both below this folder; a rename replaces an
    /// entry, it never follows a link).
    pub fn rename(&mut self, from: &str, to: &str) -> Result<(), OutputError> {
        let path = self.root.join(to);
        let (from_dir, from_name) = split(&self.root, from)?;
        let (to_dir, to_name) = split(&self.root, to)?;
        let missing = || io(&path)(std::io::ErrorKind::NotFound.into());
        let src = match self.open_dir(&from_dir)? {
            Some(fd) => fd,
            None => return Err(missing()),
        };
        let dst = self.dir(&to_dir)?.ok_or_else(missing)?;
        rustix::fs::renameat(&src, from_name.as_str(), dst, to_name.as_str())
            .map_err(errno_io(&path))
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
            name.as_str(),
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
        match rustix::fs::statat(dir, name.as_str(), AtFlags::SYMLINK_NOFOLLOW) {
            Ok(st) if Entry::from_stat(&st).is_file() => {}
            Ok(_) | Err(Errno::NOENT) => return Ok(false),
            Err(e) => return Err(errno_io(&path)(e)),
        }
        match rustix::fs::unlinkat(dir, name.as_str(), AtFlags::empty()) {
            Ok(()) => Ok(true),
            Err(Errno::NOENT) => Ok(false),
            Err(e) => Err(errno_io(&path)(e)),
        }
    }

    /// Delete the folder `rel` if it is a real, empty folder (kept otherwise).
    pub fn remove_dir_if_empty(&mut self, rel: &str) -> Result<(), OutputError> {
        let rel = rel.trim_end_matches('/');
        let Some((dir, name)) = self.parent(rel)? else {
            return Ok(());
        };
        if rustix::fs::statat(dir, name.as_str(), AtFlags::SYMLINK_NOFOLLOW)
            .is_ok_and(|st| Entry::from_stat(&st).is_dir())
        {
            let _ = rustix::fs::unlinkat(dir, name.as_str(), AtFlags::REMOVEDIR);
        }
        // Its handle (and those below it) would name a folder no longer here.
        let below = format!("{rel}/");
        self.dirs.retain(|d, _| d != rel && !d.starts_with(&below));
        Ok(())
    }

    /// Hard-link the file `from` to the new name `to`, both below this
    /// folder, relative to their folders' handles, never following a link.
    pub fn link_within(&mut self, from: &str, to: &str) -> Result<(), OutputError> {
        let path = self.root.join(to);
        let missing = || io(&path)(std::io::ErrorKind::NotFound.into());
        let (from_dir, from_name) = split(&self.root, from)?;
        let src = self.dir(&from_dir)?.ok_or_else(missing)?;
        let src = rustix::io::dup(src).map_err(errno_io(&path))?;
        let (to_dir, to_name) = split(&self.root, to)?;
        let dst = self.dir(&to_dir)?.ok_or_else(missing)?;
        rustix::fs::linkat(
            &src,
            from_name.as_str(),
            dst,
            to_name.as_str(),
            AtFlags::empty(),
        )
        .map_err(errno_io(&path))
    }

    /// Folder `rel` below this one opened (`None` when it is missing), and
    /// the names of its entries but `.` and `..`, as read: one read of it.
    fn listing(
        &mut self,
        rel: &str,
    ) -> Result<Option<(OwnedFd, Vec<std::ffi::CString>)>, OutputError> {
        let path = self.root.join(rel);
        let Some(fd) = self.open_dir(rel)? else {
            return Ok(None);
        };
        let dir = rustix::fs::Dir::read_from(&fd).map_err(errno_io(&path))?;
        let mut names = Vec::new();
        for entry in dir {
            let entry = entry.map_err(errno_io(&path))?;
            let name = entry.file_name();
            if name != c"." && name != c".." {
                names.push(name.to_owned());
            }
        }
        Ok(Some((fd, names)))
    }

    /// The names of the real folders (not links) directly inside folder
    /// `rel`, sorted (none when `rel` is missing).
    pub fn folders_in(&mut self, rel: &str) -> Result<Vec<String>, OutputError> {
        let entries = self.entries(rel)?.into_iter();
        Ok(entries
            .filter(|(_, e)| e.is_dir())
            .map(|(n, _)| n)
            .collect())
    }

    /// The names in the folder `rel` below this one (none when it does not
    /// exist), unsorted and not looked at.
    pub fn names(&mut self, rel: &str) -> Result<Vec<String>, OutputError> {
        let names = self.listing(rel)?.map_or_else(Vec::new, |(_, names)| names);
        Ok(names
            .iter()
            .map(|n| n.to_string_lossy().into_owned())
            .collect())
    }

    /// Every entry directly inside folder `rel` (none when `rel` is missing), each seen
    /// without following it, sorted by name.
    pub fn entries(&mut self, rel: &str) -> Result<Vec<(String, Entry)>, OutputError> {
        let path = self.root.join(rel);
        let Some((fd, names)) = self.listing(rel)? else {
            return Ok(Vec::new());
        };
        let mut out = Vec::new();
        for name in names {
            let text = name.to_string_lossy().into_owned();
            match rustix::fs::statat(&fd, name.as_c_str(), AtFlags::SYMLINK_NOFOLLOW) {
                Ok(st) => out.push((text, Entry::from_stat(&st))),
                Err(Errno::NOENT) => {}
                Err(e) => return Err(errno_io(&path.join(&text))(e)),
            }
        }
        out.sort_by(|a, b| a.0.cmp(&b.0));
        Ok(out)
    }

    /// Hard-link the file `rel` below this folder to `to` below the folder
    /// `dest` (a name that does not exist yet), relative to both folders'
    /// handles, never following a link on either side.
    pub fn link_into(&mut self, rel: &str, dest: &mut Tree, to: &str) -> Result<(), OutputError> {
        let path = dest.root.join(to);
        let missing = || io(&path)(std::io::ErrorKind::NotFound.into());
        let (from_dir, from_name) = split(&self.root, rel)?;
        let src = self.dir(&from_dir)?.ok_or_else(missing)?;
        let (to_dir, to_name) = split(&dest.root, to)?;
        let dst = dest.dir(&to_dir)?.ok_or_else(missing)?;
        rustix::fs::linkat(
            src,
            from_name.as_str(),
            dst,
            to_name.as_str(),
            AtFlags::empty(),
        )
        .map_err(errno_io(&path))
    }

    /// Check that every folder opened so far is still where it was opened:
    /// a folder replaced (by a link or another folder) or moved away while a
    /// run goes on is named, so the run stops instead of writing on.
    pub fn verify(&self) -> Result<(), OutputError> {
        for (rel, fd) in &self.dirs {
            let (parent_rel, name) = rel.rsplit_once('/').unwrap_or(("", rel));
            let parent = match parent_rel {
                "" => &self.fd,
                p => match self.dirs.get(p) {
                    Some(fd) => fd,
                    None => continue,
                },
            };
            let now = rustix::fs::statat(parent, name, AtFlags::SYMLINK_NOFOLLOW)
                .ok()
                .map(|st| Entry::from_stat(&st));
            if now.is_none_or(|e| Some((e.dev, e.ino)) != identity(fd)) {
                let what = match now {
                    Some(e) if e.is_symlink() => "a symbolic link now stands there",
                    Some(_) => "another entry now stands there",
                    None => "it was moved away or deleted",
                };
                return Err(OutputError::Refused {
                    path: self.root.join(rel),
                    reason: format!(
                        "was replaced while swarmshot wrote into it ({what}); the run stopped, and everything it wrote is in the folder it opened"
                    ),
                });
            }
        }
        Ok(())
    }

    /// The device and inode of `file`.
    pub fn identity(file: &File) -> Option<(u64, u64)> {
        rustix::fs::fstat(file.as_fd())
            .ok()
            .map(|st| Entry::from_stat(&st))
            .map(|e| (e.dev, e.ino))
    }
}
