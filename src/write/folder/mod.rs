//! The dataset folder as swarmshot owns it: every entry it creates is first
//! recorded in a ledger, it never writes through a symbolic link, and it
//! deletes only what the ledger lists.
//!
//! # The ledger (`.swarmshot-ledger`)
//!
//! A text file at the folder's top, one record per line, only ever appended
//! (whole lines; a torn last line is cut off when the folder is opened again):
//!
//! ```text
//! swarmshot-ledger 1 frames=120 preset=fnv1a64:0123456789abcdef   header: the run
//! *preset.lock.ron            a dataset file or folder (`/` at the end) this run made
//! +images/train/00000000.png  a file of the frame in flight
//! ={"next":1,...}             checkpoint: frames below `next` are complete
//! %1817 blake3:… preset.lock.ron  a shard's content record (written just before !done)
//! !done                       COCO, data.yaml and stats.json are written
//! ```
//!
//! A claim (`*`, `+`) is written and flushed to disk before its file is
//! created, so every file swarmshot made is listed, and `--overwrite` can
//! delete exactly those. A checkpoint is written after the frame's image,
//! labels and manifest line; it records the length of every append-only file
//! (manifest, COCO record parts) and the writers' counters, so a resumed run
//! cuts those files back to the last complete frame and carries on from there
//! exactly as an uninterrupted run would have.
//!
//! # One writer
//!
//! [`FolderLock`]: an exclusive `flock` on `.swarmshot-lock`, taken before
//! anything else in the folder is read or written; a second run is refused
//! naming the process that holds it.
//!
//! # What is checked
//!
//! Before any create, rename or delete, the entry is looked at without
//! following links: a symbolic link, or an entry that is not in the ledger,
//! is refused with its path. Reads, deletions and the ledger scan go through
//! [`tree::Tree`] (every component opened with `O_NOFOLLOW` relative
//! to its folder's handle), so a link at a folder above a listed entry is
//! refused too; a file opened to append or cut back must have one name (no
//! hard link). `--overwrite` and `--resume` check everything they will touch
//! before they delete, cut back or write anything. New files are made under a
//! temporary name with `create_new` (which never follows a link), flushed and
//! renamed over the final name (a rename replaces a link, never follows it).
//! Files opened again (to append or read) are checked to be the very file
//! that was looked at (same device and inode). Folders are made one level at
//! a time with `create_dir`, which refuses an existing link.

use std::collections::{BTreeMap, HashSet};
use std::fs::{self, File};
use std::io::{Read, Seek, SeekFrom, Write};
use std::os::unix::fs::{FileExt, MetadataExt};
use std::path::{Path, PathBuf};

use super::shards::shard::Shard;
use super::{DatasetStats, OutputError, io};
use stall::stall_if_asked;
use tree::{Tree, hard_link_refused, link_refused};

mod append;
mod content;
mod lock;
pub mod outdir;
mod run;
mod scan;
mod stall;
pub mod tree;

pub use append::AppendFile;
pub use content::{ContentRecord, content_record, content_records};
pub use lock::FolderLock;
pub use run::{RunId, ShardPlan, ShardRun, fnv1a64, read_run};
use scan::LedgerScan;

/// File name of the ledger in the dataset folder.
pub const LEDGER: &str = ".swarmshot-ledger";
/// File name of the lock file in the dataset folder (see [`FolderLock`]).
pub const LOCK: &str = ".swarmshot-lock";
const LEDGER_VERSION: u32 = 1;

/// The state after the last complete frame: enough to continue exactly.
#[derive(Clone, Debug, Default, serde::Serialize, serde::Deserialize)]
pub struct Checkpoint {
    /// Frames `0..next` are complete.
    pub next: u64,
    /// Length of the append-only files, by path relative to the folder (in
    /// the ledger: those that changed since the checkpoint before; a file
    /// never listed is empty).
    pub files: BTreeMap<String, u64>,
    /// Writers' counters (COCO ids; in the ledger, those that changed).
    pub counters: BTreeMap<String, u64>,
    pub stats: DatasetStats,
}

/// How to treat an earlier run found in the folder.
#[derive(Clone, Copy, Debug, Default)]
pub struct OpenMode {
    /// Delete the earlier run's own files and start again.
    pub overwrite: bool,
    /// Require an earlier run of the same preset and continue it.
    pub resume: bool,
    /// Make only one shard's frames (`--shard K/N`).
    pub shard: Option<ShardPlan>,
    /// Make every Kth frame (`--every K`); `None` takes a resumed run's
    /// step (and 1 for a new run).
    pub every: Option<u64>,
    /// The frame count a new run makes when `frames` is `None` (a `--resume`
    /// that finds no earlier run: one killed before its ledger existed).
    pub fresh_frames: u64,
}

/// Where an opened folder starts.
#[derive(Debug)]
pub enum Start {
    /// Nothing written yet.
    Fresh,
    /// Frames below `checkpoint.next` are complete (`done`: the end files too).
    Resume {
        checkpoint: Box<Checkpoint>,
        done: bool,
    },
}

/// A dataset folder opened for one run. See the module docs.
pub struct Folder {
    root: PathBuf,
    /// Held for the whole run (dropped last: fields drop in order).
    ledger: File,
    /// The folder reached without following links (deletions, checks).
    tree: Tree,
    /// A shard run: its ledger gets content records when it finishes.
    records: bool,
    /// Entries listed in the ledger that may be replaced or deleted.
    owned: HashSet<String>,
    /// Files of the frame in flight (claimed, maybe partly written).
    frame_claims: Vec<String>,
    /// Folders already checked to be real folders.
    dirs_ok: HashSet<String>,
    /// Frame claims and frame files are flushed to disk one by one (a
    /// labels-only plan turns this off: see `set_durable_frames`).
    durable_frames: bool,
    /// One writer per folder; released (and its file deleted) when the folder is dropped.
    _lock: FolderLock,
}

fn refused(path: PathBuf, reason: &str) -> OutputError {
    OutputError::Refused {
        path,
        reason: reason.into(),
    }
}

/// Look at `path` without following a link: `None` if it does not exist.
fn lstat(path: &Path) -> Result<Option<fs::Metadata>, OutputError> {
    match fs::symlink_metadata(path) {
        Ok(m) => Ok(Some(m)),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
        Err(e) => Err(io(path)(e)),
    }
}

/// Open the existing regular file `rel` below `root` (read, and append if
/// `append`) without following a link anywhere below `root`; a file opened
/// to append must have a single name (no hard link to a file elsewhere).
fn open_checked(root: &Path, rel: &str, append: bool) -> Result<File, OutputError> {
    Tree::open(root)?.open_file(rel, append)
}

/// The temporary name a file is written under before it is renamed into place.
fn temp_rel(rel: &str) -> String {
    match rel.rsplit_once('/') {
        Some((dir, name)) => format!("{dir}/.{name}.tmp"),
        None => format!(".{rel}.tmp"),
    }
}

/// Refuse `root` if an entry the dataset needs is a link, is in the way, or
/// is a file swarmshot did not write (not in `owned`).
fn preflight(
    tree: &mut Tree,
    needed: &[String],
    owned: &HashSet<String>,
) -> Result<(), OutputError> {
    for rel in needed {
        let parts: Vec<&str> = rel.split('/').filter(|p| !p.is_empty()).collect();
        let mut prefix = String::new();
        for (i, part) in parts.iter().enumerate() {
            if !prefix.is_empty() {
                prefix.push('/');
            }
            prefix.push_str(part);
            let want_dir = i + 1 < parts.len() || rel.ends_with('/');
            let path = tree.root().join(&prefix);
            match tree.lstat(&prefix)? {
                None => break,
                Some(m) if m.is_symlink() => return Err(link_refused(path)),
                Some(m) if want_dir && !m.is_dir() => {
                    return Err(refused(path, "is in the way of a folder swarmshot needs"));
                }
                Some(m) if !want_dir && !m.is_file() => {
                    return Err(refused(path, "is not a regular file"));
                }
                Some(m) if !want_dir && m.links != 1 => {
                    return Err(hard_link_refused(path, m.links));
                }
                Some(_) if !want_dir && !owned.contains(rel) => {
                    return Err(refused(
                        path,
                        "exists and was not written by swarmshot (it is not in .swarmshot-ledger)",
                    ));
                }
                Some(_) => {}
            }
        }
    }
    Ok(())
}

impl Folder {
    /// The folder's top.
    pub fn root(&self) -> &Path {
        &self.root
    }

    /// Open `root` for a run: refuse what is not ours, delete the earlier
    /// run's files when `mode.overwrite`, and say where to start.
    ///
    /// `run.frames == None` (only with `mode.resume`) takes the locked frame count.
    ///
    /// `needed` lists the dataset's fixed entries (folders end in `/`): each
    /// one that exists must be a real folder, or a regular file the earlier
    /// run wrote, or the folder is refused before anything is written.
    pub fn open(
        root: &Path,
        preset_hash: u64,
        frames: Option<u64>,
        mode: OpenMode,
        needed: &[String],
    ) -> Result<(Self, Start, RunId), OutputError> {
        if mode.overwrite && mode.resume {
            return Err(OutputError::Conflict);
        }
        match lstat(root)? {
            None => fs::create_dir_all(root).map_err(io(root))?,
            Some(_) => {
                // The folder the user named may itself be a link; what is inside may not.
                let m = fs::metadata(root).map_err(io(root))?;
                if !m.is_dir() {
                    return Err(refused(root.to_owned(), "is not a folder"));
                }
            }
        }
        // The folder is opened once: everything below is reached from this handle.
        let mut tree = Tree::open(root)?;
        // Before anything in the folder is read or written.
        let lock = FolderLock::take(&tree)?;
        let scan = match tree.lstat(LEDGER)? {
            None => None,
            Some(_) => Some(Self::scan(root)?),
        };
        let Some(scan) = scan else {
            // A lock file, or the first ledger's temporary file, left by a
            // run killed before its ledger existed is swarmshot's own: such a
            // folder starts afresh, with or without --resume.
            let ledger_tmp = temp_rel(LEDGER);
            let empty = !fs::read_dir(root).map_err(io(root))?.any(|e| {
                e.map_or(true, |e| {
                    e.file_name() != LOCK && e.file_name() != *ledger_tmp
                })
            });
            if !empty && mode.resume {
                return Err(OutputError::NothingToResume {
                    path: root.to_owned(),
                });
            }
            if !empty && !mode.overwrite {
                return Err(OutputError::NotEmpty {
                    path: root.to_owned(),
                });
            }
            let frames = frames.unwrap_or(mode.fresh_frames);
            let run = RunId {
                frames,
                preset_hash,
                shard: mode.shard.map(|p| p.run(frames)),
                every: mode.every.unwrap_or(1).max(1),
            };
            preflight(&mut tree, needed, &HashSet::new())?;
            return Ok((Self::fresh(tree, run, lock)?, Start::Fresh, run));
        };
        preflight(&mut tree, needed, &scan.owned)?;
        let frames = frames.unwrap_or(scan.run.frames);
        let run = RunId {
            frames,
            preset_hash,
            shard: mode.shard.map(|p| p.run(frames)),
            every: mode.every.unwrap_or(scan.run.every).max(1),
        };
        if scan.run == run && !mode.overwrite {
            let folder = Self::continue_from(tree, &scan, lock)?;
            let start = match scan.checkpoint {
                Some(checkpoint) => Start::Resume {
                    checkpoint: Box::new(checkpoint),
                    done: scan.done,
                },
                None => Start::Resume {
                    checkpoint: Box::default(),
                    done: false,
                },
            };
            return Ok((folder, start, run));
        }
        if !mode.overwrite {
            let what = if scan.run.preset_hash != preset_hash {
                "a run of a different preset (its preset.lock.ron differs)".to_owned()
            } else if scan.run.every != run.every {
                format!(
                    "a run of this preset with {}, and this run makes {} (--every differs; --resume without --every continues the earlier trial)",
                    scan.run.describe(),
                    run.describe()
                )
            } else if scan.run.shard != run.shard {
                format!(
                    "a run of this preset with {}, and this run makes {} (--shard differs)",
                    scan.run.describe(),
                    run.describe()
                )
            } else if run.every > 1 {
                format!(
                    "a run of this preset with {}, and this run makes {} (--limit differs)",
                    scan.run.describe(),
                    run.describe()
                )
            } else {
                format!(
                    "a run of this preset with {} frames, and this run makes {frames} (--limit differs)",
                    scan.run.frames
                )
            };
            return Err(OutputError::OtherRun {
                path: root.to_owned(),
                what,
            });
        }
        Self::delete_run(&mut tree)?;
        Ok((Self::fresh(tree, run, lock)?, Start::Fresh, run))
    }

    /// A new ledger holding only the header.
    fn fresh(mut tree: Tree, run: RunId, lock: FolderLock) -> Result<Self, OutputError> {
        if tree.lstat(LEDGER)?.is_some() {
            return Err(refused(
                tree.root().join(LEDGER),
                "exists although no earlier run was found; remove it by hand",
            ));
        }
        write_new_then_rename(&mut tree, LEDGER, run.header().as_bytes(), false)?;
        let ledger = tree.open_file(LEDGER, true)?;
        Ok(Self {
            root: tree.root().to_owned(),
            ledger,
            tree,
            records: run.shard.is_some(),
            owned: HashSet::from([LEDGER.to_owned()]),
            frame_claims: Vec::new(),
            dirs_ok: HashSet::new(),
            durable_frames: true,
            _lock: lock,
        })
    }

    /// Cut the ledger back to its last trusted checkpoint (keeping every
    /// claim after it) and open it to append.
    fn continue_from(
        mut tree: Tree,
        scan: &LedgerScan,
        lock: FolderLock,
    ) -> Result<Self, OutputError> {
        let path = tree.root().join(LEDGER);
        let mut bytes = Vec::new();
        tree.open_file(LEDGER, false)?
            .read_to_end(&mut bytes)
            .map_err(io(&path))?;
        if scan.good_end != bytes.len() || scan.prefix_len != bytes.len() {
            let mut text = bytes[..scan.good_end].to_vec();
            for claim in &scan.later_claims {
                text.extend_from_slice(claim.as_bytes());
                text.push(b'\n');
            }
            write_new_then_rename(&mut tree, LEDGER, &text, true)?;
        }
        let ledger = tree.open_file(LEDGER, true)?;
        let mut owned = scan.owned.clone();
        owned.insert(LEDGER.to_owned());
        Ok(Self {
            root: tree.root().to_owned(),
            ledger,
            tree,
            records: scan.run.shard.is_some(),
            owned,
            frame_claims: Vec::new(),
            dirs_ok: HashSet::new(),
            durable_frames: true,
            _lock: lock,
        })
    }

    /// Delete every file and folder an earlier run's ledger lists (files
    /// first, then folders that are empty), then the ledger itself. Links and
    /// entries that are not regular files are left alone.
    ///
    /// Every listed entry is first looked at without following links: a
    /// link anywhere on a listed path (the entry itself or a folder above
    /// it) refuses the whole deletion before anything is deleted. Then each
    /// file is deleted relative to its folder's handle (`unlinkat`), so a
    /// folder swapped for a link in between is never walked through.
    fn delete_run(tree: &mut Tree) -> Result<(), OutputError> {
        let root = tree.root().to_owned();
        let claims = Self::claims(&root)?;
        for rel in &claims {
            let file = !rel.ends_with('/');
            let names = if file {
                vec![rel.clone(), temp_rel(rel)]
            } else {
                vec![rel.trim_end_matches('/').to_owned()]
            };
            for r in names {
                if tree.lstat(&r)?.is_some_and(|e| e.is_symlink()) {
                    return Err(link_refused(root.join(r)));
                }
            }
        }
        let mut dirs = Vec::new();
        for rel in &claims {
            if let Some(dir) = rel.strip_suffix('/') {
                dirs.push(dir.to_owned());
                continue;
            }
            for r in [rel.clone(), temp_rel(rel)] {
                tree.remove_file(&r)?;
            }
        }
        for dir in dirs.iter().rev() {
            // Not empty: it holds files swarmshot did not write; keep them.
            tree.remove_dir_if_empty(dir)?;
        }
        tree.remove_file(LEDGER)?;
        Ok(())
    }

    /// Append whole lines to the ledger; `sync` flushes them to disk first.
    fn ledger_append(&mut self, text: &str, sync: bool) -> Result<(), OutputError> {
        let path = self.root.join(LEDGER);
        self.ledger.write_all(text.as_bytes()).map_err(io(&path))?;
        if sync {
            self.ledger.sync_data().map_err(io(&path))?;
        }
        Ok(())
    }

    /// Record `rels` as dataset files (`*`) before they are created.
    pub fn claim(&mut self, rels: &[&str]) -> Result<(), OutputError> {
        let new: Vec<&str> = rels
            .iter()
            .copied()
            .filter(|r| !self.owned.contains(*r))
            .collect();
        if new.is_empty() {
            return Ok(());
        }
        let text: String = new.iter().map(|r| format!("*{r}\n")).collect();
        self.ledger_append(&text, true)?;
        self.owned.extend(new.into_iter().map(str::to_owned));
        Ok(())
    }

    /// Frame claims and frame files written without a flush to disk each
    /// (`false`: a labels-only plan, thousands of small files a second).
    /// A claim still reaches the ledger before its file is created, so a
    /// killed process leaves every file it made listed; the end files
    /// (COCO, stats, the done mark) are still flushed.
    pub fn set_durable_frames(&mut self, durable: bool) {
        self.durable_frames = durable;
    }

    /// Record the files of the frame in flight (`+`) before they are created.
    pub fn claim_frame(&mut self, rels: &[String]) -> Result<(), OutputError> {
        let mut text = String::with_capacity(rels.iter().map(|r| r.len() + 2).sum());
        for r in rels {
            text.push('+');
            text.push_str(r);
            text.push('\n');
        }
        self.ledger_append(&text, self.durable_frames)?;
        self.frame_claims.extend(rels.iter().cloned());
        Ok(())
    }

    fn is_ours(&self, rel: &str) -> bool {
        self.owned.contains(rel) || self.frame_claims.iter().any(|c| c == rel)
    }

    /// Make sure folder `rel` (and each folder above it) is a real folder,
    /// creating and claiming the missing ones.
    pub fn ensure_dir(&mut self, rel: &str) -> Result<(), OutputError> {
        let mut prefix = String::new();
        for part in rel.split('/').filter(|p| !p.is_empty()) {
            if !prefix.is_empty() {
                prefix.push('/');
            }
            prefix.push_str(part);
            if self.dirs_ok.contains(&prefix) {
                continue;
            }
            let path = self.root.join(&prefix);
            match self.tree.lstat(&prefix)? {
                Some(m) if m.is_dir() => {}
                Some(m) if m.is_symlink() => return Err(link_refused(path)),
                Some(_) => return Err(refused(path, "is in the way of a folder swarmshot needs")),
                None => self.claim(&[&format!("{prefix}/")])?,
            }
            // Made (if missing) and opened once, relative to the folder above.
            self.tree.mkdir(&prefix)?;
            self.dirs_ok.insert(prefix.clone());
        }
        Ok(())
    }

    /// Check that `rel` may be (re)written: absent, or a regular file this run owns.
    pub fn check_target(&mut self, rel: &str) -> Result<(), OutputError> {
        let path = self.root.join(rel);
        match self.tree.lstat(rel)? {
            None => Ok(()),
            Some(m) if m.is_symlink() => Err(link_refused(path)),
            Some(m) if !m.is_file() => Err(refused(path, "is not a regular file")),
            Some(_) if !self.is_ours(rel) => Err(refused(
                path,
                "exists and was not written by swarmshot (it is not in .swarmshot-ledger)",
            )),
            Some(_) => Ok(()),
        }
    }

    /// Write a whole file atomically: claim it, write a temporary file in the
    /// same folder, flush it to disk, rename it over `rel`.
    pub fn write_file(&mut self, rel: &str, bytes: &[u8]) -> Result<(), OutputError> {
        self.write_file_with(rel, |w| w.write_all(bytes))
    }

    /// A frame file of a labels-only plan (already claimed with
    /// [`Folder::claim_frame`], frames not durable): created in place with
    /// `create_new`, which never follows a link nor replaces an entry, and not
    /// flushed. Anything already at `rel` (a resumed plan's frame in flight)
    /// goes the careful way of [`Folder::write_file`].
    pub fn write_frame_file(&mut self, rel: &str, bytes: &[u8]) -> Result<(), OutputError> {
        if self.durable_frames {
            return self.write_file(rel, bytes);
        }
        if let Some((dir, _)) = rel.rsplit_once('/') {
            self.ensure_dir(dir)?;
        }
        let path = self.root.join(rel);
        if self.tree.lstat(rel)?.is_some() {
            return self.write_file(rel, bytes);
        }
        let mut file = self.tree.create_new(rel, false)?;
        file.write_all(bytes).map_err(io(&path))
    }

    /// [`Folder::write_file`] with the contents streamed by `fill`.
    pub fn write_file_with(
        &mut self,
        rel: &str,
        fill: impl FnOnce(&mut std::io::BufWriter<&File>) -> std::io::Result<()>,
    ) -> Result<(), OutputError> {
        if let Some((dir, _)) = rel.rsplit_once('/') {
            self.ensure_dir(dir)?;
        }
        self.check_target(rel)?;
        if !self.is_ours(rel) {
            self.claim(&[rel])?;
        }
        let path = self.root.join(rel);
        let tmp_rel = self.clear_temp(rel)?;
        let file = self.tree.create_new(&tmp_rel, false)?;
        let written = (|| {
            let mut w = std::io::BufWriter::new(&file);
            fill(&mut w)?;
            w.flush()?;
            drop(w);
            file.sync_all()
        })();
        stall_if_asked(rel);
        let result = written
            .map_err(io(&path))
            .and_then(|()| self.tree.rename(&tmp_rel, rel));
        if result.is_err() {
            let _ = self.tree.remove_file(&tmp_rel);
        }
        result
    }

    /// The temporary name `rel` is written under, cleared of a temporary file
    /// of ours that a killed run left.
    fn clear_temp(&mut self, rel: &str) -> Result<String, OutputError> {
        let tmp_rel = temp_rel(rel);
        if let Some(m) = self.tree.lstat(&tmp_rel)? {
            if !m.is_file() {
                return Err(refused(
                    self.root.join(&tmp_rel),
                    "is in the way of swarmshot's temporary file",
                ));
            }
            self.tree.remove_file(&tmp_rel)?;
        }
        Ok(tmp_rel)
    }

    /// Put the file `rel` of the shard `shard` (outside the folder, for
    /// `swarmshot merge`) at `rel`: a hard link (`linkat` relative to the
    /// shard folder's handle, never following a link) unless `copy` or the
    /// file system refuses one, else a copy flushed to disk; made under the
    /// temporary name and renamed into place like every other file. `seen`
    /// is the (device, inode) the shard's file had when its content was
    /// checked: a file replaced since is refused. Returns whether it was linked.
    pub fn link_file(
        &mut self,
        rel: &str,
        shard: &mut Tree,
        seen: (u64, u64),
        copy: bool,
    ) -> Result<bool, OutputError> {
        if let Some((dir, _)) = rel.rsplit_once('/') {
            self.ensure_dir(dir)?;
        }
        self.check_target(rel)?;
        if !self.is_ours(rel) {
            self.claim(&[rel])?;
        }
        let src = shard.root().join(rel);
        let replaced = || refused(src.clone(), "was replaced after its content was checked");
        match shard.lstat(rel)? {
            Some(e) if e.is_file() && (e.dev, e.ino) == seen => {}
            Some(e) if e.is_symlink() => return Err(link_refused(src)),
            Some(_) => return Err(replaced()),
            None => return Err(refused(src, "is missing (the shard's ledger records it)")),
        }
        let path = self.root.join(rel);
        // Linked by an interrupted merge already (a rename onto another link
        // of the same file would do nothing and leave the temporary name).
        if !copy
            && self
                .tree
                .lstat(rel)?
                .is_some_and(|m| (m.dev, m.ino) == seen)
        {
            return Ok(true);
        }
        let tmp_rel = self.clear_temp(rel)?;
        let linked = !copy && shard.link_into(rel, &mut self.tree, &tmp_rel).is_ok();
        if linked
            && self
                .tree
                .lstat(&tmp_rel)?
                .is_none_or(|m| (m.dev, m.ino) != seen)
        {
            let _ = self.tree.remove_file(&tmp_rel);
            return Err(replaced());
        }
        let mut from = if linked {
            None
        } else {
            let from = shard.open_file(rel, false)?;
            if Tree::identity(&from) != Some(seen) {
                return Err(replaced());
            }
            Some(from)
        };
        let copied = match &mut from {
            Some(from) => self.tree.create_new(&tmp_rel, false).and_then(|mut to| {
                std::io::copy(from, &mut to)
                    .and_then(|_| to.sync_all())
                    .map_err(io(&path))
            }),
            None => Ok(()),
        };
        stall_if_asked(rel);
        let result = copied.and_then(|()| self.tree.rename(&tmp_rel, rel));
        if result.is_err() {
            let _ = self.tree.remove_file(&tmp_rel);
        }
        result?;
        Ok(linked)
    }

    /// Every file (not folder) the ledger of `root` lists (`*` and `+`
    /// claims), sorted: what `swarmshot merge` takes from a finished shard.
    pub fn listed_files(root: &Path) -> Result<std::collections::BTreeSet<String>, OutputError> {
        Ok(Self::claims(root)?
            .into_iter()
            .filter(|rel| !rel.ends_with('/') && rel != LEDGER)
            .collect())
    }

    /// The paths the ledger of `root` claims (`*` and `+` lines; folders end
    /// in `/`), in ledger order, leaving out any that could reach outside
    /// `root` (absolute, or with a `..` component).
    fn claims(root: &Path) -> Result<Vec<String>, OutputError> {
        let path = root.join(LEDGER);
        let mut bytes = Vec::new();
        open_checked(root, LEDGER, false)?
            .read_to_end(&mut bytes)
            .map_err(io(&path))?;
        Ok(String::from_utf8_lossy(&bytes)
            .lines()
            .filter_map(|line| line.strip_prefix('*').or_else(|| line.strip_prefix('+')))
            .filter(|rel| !rel.is_empty() && !rel.starts_with('/'))
            .filter(|rel| !rel.split('/').any(|c| c == ".."))
            .map(str::to_owned)
            .collect())
    }

    /// Open an append-only file at `rel`, cut back to `len` bytes (created
    /// and claimed when missing and `len` is 0).
    pub fn open_append(&mut self, rel: &str, len: u64) -> Result<AppendFile, OutputError> {
        if let Some((dir, _)) = rel.rsplit_once('/') {
            self.ensure_dir(dir)?;
        }
        self.check_target(rel)?;
        let path = self.root.join(rel);
        let file = if self.tree.lstat(rel)?.is_none() {
            if len != 0 {
                return Err(OutputError::Ledger {
                    path: path.clone(),
                    reason: format!("is missing but the ledger says it held {len} bytes"),
                });
            }
            self.claim(&[rel])?;
            self.tree.create_new(rel, true)?
        } else {
            let file = self.tree.open_file(rel, true)?;
            file.set_len(len).map_err(io(&path))?;
            file
        };
        Ok(AppendFile {
            rel: rel.to_owned(),
            path,
            file,
            len,
            committed: len,
            buffer: None,
        })
    }

    /// Delete a file this run owns (nothing if it is missing or not a regular file).
    pub fn remove(&mut self, rel: &str) -> Result<(), OutputError> {
        if !self.is_ours(rel) {
            return Ok(());
        }
        self.tree.remove_file(rel)?;
        Ok(())
    }

    /// The real folders directly inside folder `rel`, sorted (never through a link).
    pub fn folders_in(&mut self, rel: &str) -> Result<Vec<String>, OutputError> {
        self.tree.folders_in(rel)
    }

    /// Hard-link the dataset's file `from` to `to` (both inside the folder),
    /// claimed with the frame's files before it is made (a frame remade by
    /// `--resume` drops it with them), never following a link.
    pub fn link_frame_file(&mut self, from: &str, to: &str) -> Result<(), OutputError> {
        if let Some((dir, _)) = to.rsplit_once('/') {
            self.ensure_dir(dir)?;
        }
        self.claim_frame(&[to.to_owned()])?;
        self.remove(to)?;
        self.tree.link_within(from, to)
    }

    /// Frame complete: write its checkpoint.
    pub fn commit(&mut self, checkpoint: &Checkpoint) -> Result<(), OutputError> {
        let json = serde_json::to_string(checkpoint).map_err(|e| OutputError::Ledger {
            path: self.root.join(LEDGER),
            reason: e.to_string(),
        })?;
        stall_if_asked(&format!("checkpoint:{}", checkpoint.next.saturating_sub(1)));
        // A folder swapped for a link (or moved) since it was opened stops the
        // run here: the frame's files went into the folder that was opened.
        self.tree.verify()?;
        self.ledger_append(&format!("={json}\n"), false)?;
        self.frame_claims.clear();
        Ok(())
    }

    /// The end files are written.
    ///
    /// A shard run first records each of its files (`%SIZE blake3:HASH
    /// PATH`, working files whose names start with `.` left out): `swarmshot
    /// merge` checks every file it takes against these records.
    pub fn mark_done(&mut self) -> Result<(), OutputError> {
        if self.records {
            let mut text = String::new();
            let mut seen = HashSet::new();
            for rel in Self::claims(&self.root)? {
                if rel.ends_with('/') || is_working_file(&rel) || !seen.insert(rel.clone()) {
                    continue;
                }
                let Some(entry) = self.tree.lstat(&rel)? else {
                    continue;
                };
                if !entry.is_file() {
                    continue;
                }
                let mut file = self.tree.open_file(&rel, false)?;
                let (len, hash) = content_record(&mut file).map_err(io(&self.root.join(&rel)))?;
                text.push_str(&format!("%{len} blake3:{hash} {rel}\n"));
            }
            self.ledger_append(&text, false)?;
        }
        self.ledger_append("!done\n", true)
    }

    /// After a failed frame: delete the files of the frame in flight (the
    /// checkpoint before it still describes the folder).
    pub fn drop_frame(&mut self) {
        for rel in std::mem::take(&mut self.frame_claims) {
            for r in [temp_rel(&rel), rel] {
                let _ = self.tree.remove_file(&r);
            }
        }
    }
}

/// A swarmshot working file (the ledger, the lock, temporary files, COCO
/// record parts): its name starts with `.`; never part of a finished dataset.
pub fn is_working_file(rel: &str) -> bool {
    rel.rsplit('/')
        .next()
        .is_some_and(|name| name.starts_with('.'))
}

/// Write `rel` (a new name, or one this run owns) through a temporary file and a rename.
fn write_new_then_rename(
    tree: &mut Tree,
    rel: &str,
    bytes: &[u8],
    replace: bool,
) -> Result<(), OutputError> {
    let path = tree.root().join(rel);
    let tmp = temp_rel(rel);
    if replace {
        tree.open_file(rel, false)?;
    }
    if tree.lstat(&tmp)?.is_some_and(|m| m.is_file()) {
        tree.remove_file(&tmp)?;
    }
    let result = tree.create_new(&tmp, false).and_then(|mut file| {
        file.write_all(bytes)
            .and_then(|()| file.sync_all())
            .map_err(io(&path))
    });
    let result = result.and_then(|()| tree.rename(&tmp, rel));
    if result.is_err() {
        let _ = tree.remove_file(&tmp);
    }
    result
}
