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
//! ^models blake3:… models/m.glb  an input the run read (written with the header)
//! *preset.lock.ron            a dataset file or folder (`/` at the end) this run made
//! +images/train/00000000.png  a file of the frame in flight
//! ={"next":1,...}<TAB>fnv1a64:…  checkpoint: frames below `next` are complete (with its JSON's hash)
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
//! exactly as an uninterrupted run would have. A checkpoint whose hash does
//! not match its JSON was changed after it was written: neither it nor any
//! checkpoint after it is trusted.
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
//!
//! # Where each part lives
//!
//! This file holds the types ([`Folder`], [`Checkpoint`], [`OpenMode`],
//! [`Start`]) and the small checks the parts share. `open.rs`: opening a
//! folder for a run (fresh, resumed, or an earlier run deleted); `scan.rs`:
//! reading the ledger back; `ledger.rs`: the records a run appends (claims,
//! checkpoints, the done mark); `files.rs`: files written atomically,
//! folders made, append-only files opened; `link.rs`: files put in place by
//! a hard link (merge's shard files, a frame's repeated file); `pending.rs`: a labels-only plan's frame
//! files, created together before their checkpoint; `lock.rs`,
//! `append.rs`, `content.rs`, `run.rs`: the lock, the append-only files, the
//! shards' content records, the run's header line; `tree.rs`: no-follow
//! access below a folder; `outdir.rs`: report folders.

use std::collections::{BTreeMap, HashSet};
use std::fs::{self, File};
use std::io::{Read, Seek, SeekFrom, Write};
use std::os::unix::fs::{FileExt, MetadataExt};
use std::path::{Path, PathBuf};

use super::shards::shard::Shard;
use super::{DatasetStats, OutputError, io};
pub(crate) use stall::stall_if_asked;
use tree::{Tree, hard_link_refused, link_refused};

mod append;
mod content;
mod files;
mod ledger;
mod link;
mod lock;
mod open;
pub mod outdir;
mod pending;
mod run;
mod scan;
mod stall;
pub mod tree;

pub use append::AppendFile;
pub use content::{ContentRecord, content_record, content_records};
pub use lock::FolderLock;
pub use run::{
    EarlierRun, InputRecord, MAX_INPUT_RECORDS, RunId, ShardPlan, ShardRun, changed_inputs,
    fnv1a64, read_run,
};
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
    /// The hash this preset's run has in the other mode (a labels-only plan
    /// for a rendered run, and the other way round), and what such a run is
    /// called: an earlier run of that hash is refused by that name, not as
    /// another preset (the two never continue each other).
    pub twin: Option<(u64, &'static str)>,
    /// This run is a labels-only plan.
    pub labels_only: bool,
    /// This run is a merge, which continues only with the same command: its
    /// refusal of another run names no batch flags.
    pub merge: bool,
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
    /// A labels-only plan's frame files, created just before their checkpoint.
    pending: pending::PendingFiles,
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

impl Folder {
    /// The folder's top.
    pub fn root(&self) -> &Path {
        &self.root
    }

    /// Whether the run reads its files back when it finishes (a shard's
    /// content records hash every file).
    pub fn reads_back(&self) -> bool {
        self.records
    }
}

/// A swarmshot working file (the ledger, the lock, temporary files, COCO
/// record parts): its name starts with `.`; never part of a finished dataset.
pub fn is_working_file(rel: &str) -> bool {
    rel.rsplit('/')
        .next()
        .is_some_and(|name| name.starts_with('.'))
}
