//! A folder a report is written into (`swarmshot stats` plots, `swarmshot gap --out`,
//! `swarmshot fit --out`): opened once, every file written relative to that handle
//! under a temporary name (`O_CREAT | O_EXCL | O_NOFOLLOW`), flushed, and renamed into
//! place. An entry already at a file's name that is a symbolic link, not a regular
//! file, or a file with a second name (a hard link) is refused by name: a report never
//! writes through a link to a file elsewhere.

use std::io::Write;
use std::path::{Path, PathBuf};

use super::tree::{Tree, hard_link_refused, link_refused};
use crate::write::{OutputError, io};

/// A report folder opened once (see the module docs).
pub struct OutDir {
    tree: Tree,
}

impl OutDir {
    /// Create `path` (and the folders above it) when missing, and open it.
    pub fn create(path: &Path) -> Result<Self, OutputError> {
        match std::fs::metadata(path) {
            Ok(m) if !m.is_dir() => {
                return Err(OutputError::Refused {
                    path: path.to_owned(),
                    reason: "exists and is not a folder".into(),
                });
            }
            Ok(_) => {}
            Err(e)
                if e.kind() == std::io::ErrorKind::NotFound
                    && std::fs::symlink_metadata(path).is_err() =>
            {
                std::fs::create_dir_all(path).map_err(io(path))?
            }
            // A link to nothing, a link loop, a folder that cannot be searched: said as it is.
            Err(e) => return Err(crate::write::io_following(path)(e)),
        }
        Ok(Self {
            tree: Tree::open(path)?,
        })
    }

    /// A folder already opened as a [`Tree`] (e.g. one opened below another's handle).
    pub fn from_tree(tree: Tree) -> Self {
        Self { tree }
    }

    /// A second handle on the same folder (not on whatever its path names now).
    pub fn try_clone(&self) -> Result<Self, OutputError> {
        Ok(Self {
            tree: self.tree.try_clone()?,
        })
    }

    /// The folder's path.
    pub fn path(&self) -> &Path {
        self.tree.root()
    }

    /// Write `bytes` as the file `name` (one component) atomically; returns its path.
    pub fn write(&mut self, name: &str, bytes: &[u8]) -> Result<PathBuf, OutputError> {
        let path = self.tree.root().join(name);
        if name.contains('/') {
            return Err(OutputError::Refused {
                path,
                reason: "is not a file name directly in the report folder".into(),
            });
        }
        match self.tree.lstat(name)? {
            Some(e) if e.is_symlink() => return Err(link_refused(path)),
            Some(e) if !e.is_file() => {
                return Err(OutputError::Refused {
                    path,
                    reason: "is not a regular file".into(),
                });
            }
            Some(e) if e.links != 1 => return Err(hard_link_refused(path, e.links)),
            _ => {}
        }
        let tmp = format!(".{name}.{}.tmp", std::process::id());
        self.tree.remove_file(&tmp)?;
        let result = self.tree.create_new(&tmp, false).and_then(|mut file| {
            file.write_all(bytes)
                .and_then(|()| file.sync_all())
                .map_err(io(&path))
        });
        let result = result.and_then(|()| self.tree.rename(&tmp, name));
        if result.is_err() {
            let _ = self.tree.remove_file(&tmp);
        }
        result.map(|()| path)
    }
}
