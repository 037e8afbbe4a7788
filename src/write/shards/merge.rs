//! `swarmshot merge OUT SHARD…`: join the folders of `--shard K/N` runs into
//! the dataset one process would have written (docs/scale.md).
//!
//! The shards must be every shard 0..N-1 of one run (the same locked preset,
//! frame count and N), each finished (`!done` in its ledger). OUT is written
//! like a batch's folder (docs/reliability.md: claimed in its own ledger,
//! never through a link, atomic files) and ends as a finished run of the
//! preset, so `batch` on OUT with the same preset finds nothing to do.
//! Shards are appended in index order, one checkpoint each: images, label
//! and MOT files are hard-linked (copied when OUT is on another file
//! system), manifest lines and COCO records appended as they are, COCO
//! annotation ids numbered on, statistics added. A killed merge run again
//! continues after the last complete shard. Nothing is written into a shard:
//! an output folder inside a shard, or holding one, is refused.
//!
//! Before anything is written, every file of every shard is checked against
//! the content record (size and BLAKE3 hash) its ledger got when the shard
//! finished, reached without following a link (`super::tree`): a missing
//! file is named as missing, a changed one as changed, a link as a link.
//! `--copy` copies the files instead of hard-linking them, so later edits
//! to a shard cannot reach the merged dataset.

use std::path::{Path, PathBuf};

use serde_json::Value;

use std::collections::BTreeMap;

use crate::preset::Preset;
use crate::write::folder::tree::Tree;
use crate::write::folder::{
    ContentRecord, EarlierRun, Folder, InputRecord, LEDGER, changed_inputs, content_record,
    content_records, fnv1a64, is_working_file, read_run,
};
use crate::write::{DatasetStats, DatasetWriter, OutputError, ShardRun, WriterOptions};

/// What [`merge`] did.
#[derive(Clone, Debug)]
pub struct MergeReport {
    pub stats: DatasetStats,
    pub frames: u64,
    pub shards: u64,
    /// Shards an earlier, interrupted merge had already joined.
    pub shards_before: u64,
    pub linked: u64,
    pub copied: u64,
}

/// Why shards cannot be merged.
#[derive(Debug, thiserror::Error)]
pub enum MergeError {
    #[error("no shard folders given: swarmshot merge OUT SHARD_0 SHARD_1 …")]
    NoShards,
    #[error("{}: not a shard: {reason}", path.display())]
    NotAShard { path: PathBuf, reason: String },
    #[error(
        "{}: shard {shard} is incomplete (its ledger has no !done); finish it with the same `swarmshot batch … --shard {shard}` (it continues where it stopped), then merge",
        path.display()
    )]
    Incomplete { path: PathBuf, shard: String },
    #[error(
        "{} and {} are shards of different runs ({what}); merge only the shards of one `--shard K/N` run",
        a.display(),
        b.display()
    )]
    DifferentRuns {
        a: PathBuf,
        b: PathBuf,
        what: String,
    },
    #[error("{} and {} are both shard {shard}: shards overlap", a.display(), b.display())]
    Overlap {
        a: PathBuf,
        b: PathBuf,
        shard: String,
    },
    #[error(
        "{} missing: every shard 0/{count} … {}/{count} of the run is needed",
        missing_list(missing, *more),
        count - 1
    )]
    Missing {
        /// The first [`MISSING_SHOWN`] missing shards.
        missing: Vec<String>,
        /// How many more are missing.
        more: u64,
        count: u64,
    },
    #[error("{}: the shard ranges do not tile the frames ({reason})", path.display())]
    Ranges { path: PathBuf, reason: String },
    #[error("{}: {source}", path.display())]
    Lock { path: PathBuf, source: LockProblem },
    #[error("{}: the output folder is one of the shards; choose a new folder for the merged dataset", path.display())]
    OutIsShard { path: PathBuf },
    #[error(
        "{}: the output folder is inside shard {}; merge never writes into a shard: choose a folder outside every shard",
        path.display(),
        shard.display()
    )]
    OutInShard { path: PathBuf, shard: PathBuf },
    #[error(
        "{}: shard {} is inside the output folder, where merge would write the merged dataset's folders into it; choose an output folder that holds no shard",
        path.display(),
        shard.display()
    )]
    ShardInOut { path: PathBuf, shard: PathBuf },
    #[error(
        "{}: shard files differ from what its ledger recorded when the shard finished, so nothing was merged:\n  {}\nrun that shard again with `swarmshot batch … --shard K/N --overwrite`, or restore the files",
        path.display(),
        problems.join("\n  ")
    )]
    Tampered {
        path: PathBuf,
        problems: Vec<String>,
    },
    #[error(
        "{}: cannot be read to check it against its shard's ledger, so nothing was merged: {source}",
        path.display()
    )]
    Unreadable {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error(
        "{}: it holds a run stopped at frame {next}, which is not where a shard starts; choose another folder, or pass --overwrite",
        path.display()
    )]
    NotAtShard { path: PathBuf, next: u64 },
    #[error("{}: the statistics cannot be added: {source}", path.display())]
    Stats { path: PathBuf, source: StatsProblem },
    #[error(transparent)]
    Output(#[from] OutputError),
}

/// "shard 2/3 is", "shards 1/9, 2/9 are", "shards 1/9, … 20/9 and 5 more are".
fn missing_list(missing: &[String], more: u64) -> String {
    let list = missing.join(", ");
    match (missing.len(), more) {
        (1, 0) => format!("shard {list} is"),
        (_, 0) => format!("shards {list} are"),
        _ => format!("shards {list} and {more} more are"),
    }
}

struct ShardDir {
    path: PathBuf,
    run: ShardRun,
    frames: u64,
    preset_hash: u64,
    /// What its run recorded of its inputs (none: made before the record).
    inputs: Vec<InputRecord>,
}

/// Merge the finished shards `shards` into `out` (created if missing;
/// `overwrite` deletes an earlier run's own files there first, as the batch's does).
///
/// `copy`: copy every file instead of hard-linking it.
pub fn merge(
    out: &Path,
    shards: &[PathBuf],
    overwrite: bool,
    copy: bool,
) -> Result<MergeReport, MergeError> {
    let mut dirs = read_shards(shards)?;
    let first = dirs.first().ok_or(MergeError::NoShards)?;
    // Shards made before the inputs' record hold none, and are not compared.
    let recorded = dirs.iter().find(|d| !d.inputs.is_empty()).unwrap_or(first);
    for d in &dirs[1..] {
        let what = if d.preset_hash != first.preset_hash {
            "their preset.lock.ron differ".to_owned()
        } else if d.frames != first.frames {
            format!("{} and {} frames: --limit differs", first.frames, d.frames)
        } else if d.run.shard.count != first.run.shard.count {
            format!(
                "cut in {} and {} shards",
                first.run.shard.count, d.run.shard.count
            )
        } else if let changed = changed_inputs(&recorded.inputs, &d.inputs)
            && !d.inputs.is_empty()
            && !changed.is_empty()
        {
            let (a, b) = (recorded.path.display(), d.path.display());
            format!(
                "made from other input files: {} (in {b}, against {a})",
                changed.join("; ")
            )
        } else {
            continue;
        };
        return Err(MergeError::DifferentRuns {
            a: first.path.clone(),
            b: d.path.clone(),
            what,
        });
    }
    let inputs = recorded.inputs.clone();
    dirs.sort_by_key(|d| d.run.shard.index);
    for w in dirs.windows(2) {
        if w[0].run.shard.index == w[1].run.shard.index {
            return Err(MergeError::Overlap {
                a: w[0].path.clone(),
                b: w[1].path.clone(),
                shard: w[0].run.shard.to_string(),
            });
        }
    }
    let count = dirs[0].run.shard.count;
    let (frames, preset_hash) = (dirs[0].frames, dirs[0].preset_hash);
    check_ranges(&dirs, count, frames)?;
    check_out_apart(out, &dirs)?;
    let preset = locked_preset(&dirs[0].path, preset_hash)?;
    // Every shard checked before anything is written.
    let checked: Vec<CheckedShard> = dirs
        .iter()
        .map(|d| check_shard(&d.path))
        .collect::<Result<_, _>>()?;
    let mut writer = DatasetWriter::open(
        out,
        &preset,
        Vec::new(),
        WriterOptions {
            frames: Some(frames),
            overwrite,
            resume: false,
            shard: None,
            every: Some(1),
            labels_only: false,
            merge: true,
            inputs,
        },
    )?;
    let resumed_at = writer.next_frame();
    if resumed_at < frames && !dirs.iter().any(|d| d.run.start == resumed_at) {
        return Err(MergeError::NotAtShard {
            path: out.into(),
            next: resumed_at,
        });
    }
    let mut report = MergeReport {
        stats: DatasetStats::default(),
        frames,
        shards: count,
        shards_before: 0,
        linked: 0,
        copied: 0,
    };
    for (d, checked) in dirs.iter().zip(&checked) {
        if d.run.start < resumed_at || resumed_at == frames {
            report.shards_before += 1;
            continue;
        }
        let stats = add_stats(writer.stats(), &d.path, checked)?;
        let (linked, copied) =
            writer.merge_shard(&d.path, d.run.start, d.run.end, &stats, checked, copy)?;
        report.linked += linked;
        report.copied += copied;
    }
    report.stats = writer.finish()?;
    Ok(report)
}

/// Each shard folder's run, refused unless it is a finished shard.
fn read_shards(shards: &[PathBuf]) -> Result<Vec<ShardDir>, MergeError> {
    let mut dirs = Vec::new();
    for path in shards {
        let not = |reason: &str| MergeError::NotAShard {
            path: path.clone(),
            reason: reason.into(),
        };
        match std::fs::metadata(path) {
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                return Err(not("it does not exist"));
            }
            Ok(m) if !m.is_dir() => return Err(not("it is not a folder")),
            _ => {}
        }
        let Some(EarlierRun { run, done, inputs }) = read_run(path)? else {
            return Err(not(&format!("it holds no swarmshot run (no {LEDGER})")));
        };
        let Some(shard) = run.shard else {
            return Err(not(
                "its run was made without --shard (a whole dataset needs no merge)",
            ));
        };
        if !done {
            return Err(MergeError::Incomplete {
                path: path.clone(),
                shard: shard.shard.to_string(),
            });
        }
        dirs.push(ShardDir {
            path: path.clone(),
            run: shard,
            frames: run.frames,
            preset_hash: run.preset_hash,
            inputs,
        });
    }
    Ok(dirs)
}

/// Most missing shards named in one refusal.
const MISSING_SHOWN: usize = 20;

/// Every shard `0..count` present, their ranges following one another up to `frames`.
fn check_ranges(dirs: &[ShardDir], count: u64, frames: u64) -> Result<(), MergeError> {
    // `dirs` are sorted by index and hold no index twice, so the missing ones
    // are counted, not listed: N comes from a ledger and may be 10^11.
    let given = dirs.iter().filter(|d| d.run.shard.index < count).count() as u64;
    if given < count {
        let missing: Vec<String> = (0..count)
            .filter(|k| !dirs.iter().any(|d| d.run.shard.index == *k))
            .take(MISSING_SHOWN)
            .map(|k| format!("{k}/{count}"))
            .collect();
        let more = count - given - missing.len() as u64;
        return Err(MergeError::Missing {
            missing,
            more,
            count,
        });
    }
    let mut next = 0;
    for d in dirs {
        if d.run.start != next || d.run.end < d.run.start {
            return Err(MergeError::Ranges {
                path: d.path.clone(),
                reason: format!(
                    "shard {} holds frames {}..{}, but the shards before it end at {next}",
                    d.run.shard, d.run.start, d.run.end
                ),
            });
        }
        next = d.run.end;
    }
    if next != frames {
        return Err(MergeError::Ranges {
            path: dirs[dirs.len() - 1].path.clone(),
            reason: format!("the last shard ends at frame {next}, the run has {frames}"),
        });
    }
    Ok(())
}

/// Refuse an output folder that is a shard, lies inside one or holds one
/// (compared with every link resolved): merge writes into no shard.
fn check_out_apart(out: &Path, dirs: &[ShardDir]) -> Result<(), MergeError> {
    let out_abs = resolved(out);
    for d in dirs {
        let shard_abs = std::fs::canonicalize(&d.path).map_err(crate::write::io(&d.path))?;
        if out_abs == shard_abs {
            return Err(MergeError::OutIsShard { path: out.into() });
        }
        let (path, shard) = (out.to_owned(), d.path.clone());
        if out_abs.starts_with(&shard_abs) {
            return Err(MergeError::OutInShard { path, shard });
        }
        if shard_abs.starts_with(&out_abs) {
            return Err(MergeError::ShardInOut { path, shard });
        }
    }
    Ok(())
}

/// `path` made absolute with every link resolved, for a folder that may not
/// exist yet: its nearest existing ancestor resolved, the rest appended.
fn resolved(path: &Path) -> PathBuf {
    let abs = std::path::absolute(path).unwrap_or_else(|_| path.to_owned());
    let mut rest = Vec::new();
    let mut at = abs.as_path();
    loop {
        if let Ok(real) = std::fs::canonicalize(at) {
            return rest.iter().rev().fold(real, |p, c| p.join(c));
        }
        match (at.parent(), at.file_name()) {
            (Some(parent), Some(name)) => {
                rest.push(name.to_owned());
                at = parent;
            }
            _ => return abs,
        }
    }
}

/// A shard whose files all match their content records: each file merge
/// takes, with the (device, inode) it had when it was checked.
pub struct CheckedShard {
    /// Path relative to the shard → (device, inode) when it was checked.
    pub files: BTreeMap<String, (u64, u64)>,
}

/// A checked shard's files opened to read their records (manifest lines,
/// COCO records): through the shard's folder handle, never through a link,
/// and only the file that was checked (the same device and inode).
pub struct ShardReader<'a> {
    pub tree: &'a mut Tree,
    pub checked: &'a CheckedShard,
}

impl ShardReader<'_> {
    /// The shard's path of `rel`, for messages.
    pub fn path(&self, rel: &str) -> PathBuf {
        self.tree.root().join(rel)
    }

    /// Open the shard's file `rel` to read, refused unless it is the file
    /// whose content was checked.
    pub fn open(&mut self, rel: &str) -> Result<std::fs::File, OutputError> {
        let file = self.tree.open_file(rel, false)?;
        match (Tree::identity(&file), self.checked.files.get(rel)) {
            (Some(now), Some(seen)) if now == *seen => Ok(file),
            _ => Err(OutputError::Shard {
                path: self.path(rel),
                reason: "was replaced after its content was checked".into(),
            }),
        }
    }
}

/// Most problems listed in one refusal.
const PROBLEMS_SHOWN: usize = 20;

/// Check every file the ledger of shard `root` lists against its content
/// record, without following a link: missing, changed, linked or unrecorded
/// files are all listed in one refusal.
fn check_shard(root: &Path) -> Result<CheckedShard, MergeError> {
    let records = content_records(root)?;
    if records.is_empty() {
        return Err(MergeError::NotAShard {
            path: root.to_owned(),
            reason: "its ledger holds no content records (it was finished by a swarmshot before they were written); run the shard again with --overwrite".into(),
        });
    }
    let mut tree = Tree::open(root)?;
    let mut files = BTreeMap::new();
    let mut problems = Vec::new();
    let listed: std::collections::BTreeSet<String> = Folder::listed_files(root)?
        .into_iter()
        .filter(|rel| !is_working_file(rel))
        .collect();
    for rel in listed.iter().chain(records.keys()) {
        if files.contains_key(rel) || problems.iter().any(|(r, _): &(String, _)| r == rel) {
            continue;
        }
        match check_file(&mut tree, rel, records.get(rel)) {
            Ok(Some(id)) => {
                files.insert(rel.clone(), id);
            }
            Ok(None) => {}
            // A file that could not be read was not checked: under `ulimit -n 8`
            // every file failed with EMFILE and a good shard was called changed,
            // "run that shard again". The read error is the cause, named alone.
            Err(FileProblem::Read(source)) => {
                return Err(MergeError::Unreadable {
                    path: root.join(rel),
                    source,
                });
            }
            Err(problem) => problems.push((rel.clone(), problem.to_string())),
        }
    }
    if problems.is_empty() {
        return Ok(CheckedShard { files });
    }
    let more = problems.len().saturating_sub(PROBLEMS_SHOWN);
    let mut lines: Vec<String> = (problems.iter().take(PROBLEMS_SHOWN))
        .map(|(rel, p)| format!("{rel}: {p}"))
        .collect();
    if more > 0 {
        lines.push(format!("… and {more} more"));
    }
    Err(MergeError::Tampered {
        path: root.to_owned(),
        problems: lines,
    })
}

/// What is wrong with one shard file (listed after its name).
#[derive(Debug, thiserror::Error)]
enum FileProblem {
    #[error("{0}")]
    Output(#[from] OutputError),
    #[error("{0}")]
    Read(#[from] std::io::Error),
    #[error("is not in the content records written when the shard finished (added afterwards?)")]
    NotRecorded,
    #[error("is missing (the shard's ledger records {0} bytes)")]
    Missing(u64),
    #[error("is a symbolic link; merge never follows one in a shard")]
    Link,
    #[error("is not a regular file")]
    NotAFile,
    #[error("has changed since the shard finished ({len} bytes, {recorded} recorded)")]
    Length { len: u64, recorded: u64 },
    #[error("has changed since the shard finished (same size, different content hash)")]
    Hash,
    #[error("cannot be looked at")]
    NoIdentity,
}

/// One shard file against its record: its (device, inode) when it matches,
/// `None` when it is neither recorded nor there (a file of a dropped frame).
/// Its size is compared first, from its entry, so a file of another size is
/// refused without being read; only one of the recorded size is hashed.
fn check_file(
    tree: &mut Tree,
    rel: &str,
    record: Option<&ContentRecord>,
) -> Result<Option<(u64, u64)>, FileProblem> {
    let entry = tree.lstat(rel)?;
    let Some(record) = record else {
        return match entry {
            None => Ok(None),
            Some(_) => Err(FileProblem::NotRecorded),
        };
    };
    let Some(entry) = entry else {
        return Err(FileProblem::Missing(record.len));
    };
    if entry.is_symlink() {
        return Err(FileProblem::Link);
    }
    if !entry.is_file() {
        return Err(FileProblem::NotAFile);
    }
    // A size other than the record's is refused before the file is read:
    // hashing a huge (or sparse) file would take as long as reading it.
    if entry.len != record.len {
        return Err(FileProblem::Length {
            len: entry.len,
            recorded: record.len,
        });
    }
    let mut file = tree.open_file(rel, false)?;
    let (len, hash) = content_record(&mut file)?;
    if len != record.len {
        return Err(FileProblem::Length {
            len,
            recorded: record.len,
        });
    }
    if hash != record.blake3 {
        return Err(FileProblem::Hash);
    }
    Tree::identity(&file)
        .map(Some)
        .ok_or(FileProblem::NoIdentity)
}

/// Why a shard's locked preset is not the one its ledger names.
#[derive(Debug, thiserror::Error)]
pub enum LockProblem {
    #[error("{0}")]
    Read(#[from] std::io::Error),
    #[error("does not match the hash in the shard's ledger")]
    Hash,
    #[error("{0}")]
    Parse(#[from] crate::preset::RonError),
    #[error(
        "was locked by another swarmshot version (it does not read back to the same text); merge with the version that made the shards"
    )]
    Version,
}

/// The shard's locked preset, read within the preset size limit (it is read
/// before the shard's files are checked against their records), checked
/// against its ledger's hash and against the text a batch of it would lock
/// (so OUT's lock is the same bytes).
fn locked_preset(shard: &Path, hash: u64) -> Result<Preset, MergeError> {
    let path = shard.join("preset.lock.ron");
    let bad = |source: LockProblem| MergeError::Lock {
        path: path.clone(),
        source,
    };
    let bytes = crate::input::read_input_file(&path, crate::preset::MAX_PRESET_BYTES)
        .map_err(|e| bad(e.into()))?;
    let text = String::from_utf8(bytes).map_err(|e| {
        bad(std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            format!("not UTF-8 text ({e})"),
        )
        .into())
    })?;
    if fnv1a64(text.as_bytes()) != hash {
        return Err(bad(LockProblem::Hash));
    }
    let preset = Preset::from_ron(&text).map_err(|e| bad(e.into()))?;
    if preset.to_ron() != text {
        return Err(bad(LockProblem::Version));
    }
    Ok(preset)
}

/// `so_far` plus the shard's `stats.json` (the file that was `checked`):
/// every count added (numbers in arrays and maps alike), so fields added to
/// the statistics later are carried without a change here, as long as they
/// are counts.
fn add_stats(
    so_far: &DatasetStats,
    shard: &Path,
    checked: &CheckedShard,
) -> Result<DatasetStats, MergeError> {
    use std::io::Read;
    let path = shard.join("stats.json");
    let bad = |source: StatsProblem| MergeError::Stats {
        path: path.clone(),
        source,
    };
    let mut tree = Tree::open(shard)?;
    let mut file = ShardReader {
        tree: &mut tree,
        checked,
    }
    .open("stats.json")?;
    let mut text = String::new();
    (&mut file)
        .take(STATS_JSON_MAX_BYTES + 1)
        .read_to_string(&mut text)
        .map_err(|e| bad(e.into()))?;
    if text.len() as u64 > STATS_JSON_MAX_BYTES {
        return Err(bad(StatsProblem::TooLarge));
    }
    let theirs: Value = serde_json::from_str(&text).map_err(|e| bad(e.into()))?;
    let mut sum = serde_json::to_value(so_far).map_err(|e| bad(e.into()))?;
    add_counts(&mut sum, &theirs, "").map_err(bad)?;
    serde_json::from_value(sum).map_err(|e| bad(e.into()))
}

/// The largest shard `stats.json` a merge reads. A run's is a few KiB to a
/// few hundred (its histograms' bins and its breakdowns' names are bounded
/// by its preset); parsed into JSON values a file takes about twelve times
/// its size, so a larger one (its content record forged to match) is
/// refused before it is parsed.
const STATS_JSON_MAX_BYTES: u64 = 16 << 20;

/// Why a shard's `stats.json` cannot be added to the sum.
#[derive(Debug, thiserror::Error)]
pub enum StatsProblem {
    #[error("{0}")]
    Read(#[from] std::io::Error),
    #[error("{0}")]
    Json(#[from] serde_json::Error),
    #[error("it is larger than any stats.json a run writes ({} MiB)", STATS_JSON_MAX_BYTES >> 20)]
    TooLarge,
    #[error("{at} is not a count ({sum} + {add})")]
    NotACount { at: String, sum: Value, add: Value },
    #[error("{at} overflows")]
    Overflow { at: String },
    #[error("{at} differs in shape ({sum} and {add})")]
    Shape { at: String, sum: Value, add: Value },
    #[error("{at} differs between shards ({sum} and {add})")]
    Differs { at: String, sum: Value, add: Value },
}

fn add_counts(sum: &mut Value, add: &Value, at: &str) -> Result<(), StatsProblem> {
    match (sum, add) {
        (Value::Number(a), Value::Number(b)) => {
            let (Some(x), Some(y)) = (a.as_u64(), b.as_u64()) else {
                return Err(StatsProblem::NotACount {
                    at: at.to_owned(),
                    sum: Value::Number(a.clone()),
                    add: Value::Number(b.clone()),
                });
            };
            let total = x
                .checked_add(y)
                .ok_or_else(|| StatsProblem::Overflow { at: at.to_owned() })?;
            *a = total.into();
            Ok(())
        }
        // Histograms: bin by bin (a bin one side lacks counts 0).
        (Value::Array(a), Value::Array(b)) => {
            for (i, y) in b.iter().enumerate() {
                match a.get_mut(i) {
                    Some(x) => add_counts(x, y, &format!("{at}[{i}]"))?,
                    None => a.push(y.clone()),
                }
            }
            Ok(())
        }
        (Value::Object(a), Value::Object(b)) => {
            for (k, y) in b {
                match a.get_mut(k) {
                    Some(x) => add_counts(x, y, &format!("{at}.{k}"))?,
                    None => {
                        a.insert(k.clone(), y.clone());
                    }
                }
            }
            Ok(())
        }
        // Labels of the whole run (how boxes were made, …): the same in every
        // shard; the empty running sum takes the first shard's.
        (a @ (Value::String(_) | Value::Bool(_) | Value::Null), b) if a == b => Ok(()),
        (a, b) if *a == Value::String(String::new()) || *a == Value::Bool(false) || a.is_null() => {
            if b.is_string() || b.is_boolean() {
                *a = b.clone();
                Ok(())
            } else {
                Err(StatsProblem::Shape {
                    at: at.to_owned(),
                    sum: a.clone(),
                    add: b.clone(),
                })
            }
        }
        (a, b) => Err(StatsProblem::Differs {
            at: at.to_owned(),
            sum: a.clone(),
            add: b.clone(),
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_shard_lock_larger_than_a_preset_may_be_is_refused_unread() {
        let dir = tempfile::tempdir().expect("temp dir");
        let file = std::fs::File::create(dir.path().join("preset.lock.ron")).expect("create");
        file.set_len(crate::preset::MAX_PRESET_BYTES + 1)
            .expect("set_len");
        let err = locked_preset(dir.path(), 0)
            .expect_err("refused")
            .to_string();
        assert!(err.contains("preset.lock.ron"), "{err}");
        let limit = format!("{}-byte limit", crate::preset::MAX_PRESET_BYTES);
        assert!(err.contains(&limit), "{err}");
    }

    #[test]
    fn a_shard_file_of_another_size_is_refused_unread() {
        let dir = tempfile::tempdir().expect("temp dir");
        let len = 64u64 << 30;
        let file = std::fs::File::create(dir.path().join("manifest.jsonl")).expect("create");
        // A sparse file: no disk used, but hashing it would read 64 GiB.
        file.set_len(len).expect("set_len");
        let mut tree = Tree::open(dir.path()).expect("tree");
        let record = ContentRecord {
            len: 10,
            blake3: "0".repeat(64),
        };
        let start = std::time::Instant::now();
        let got = check_file(&mut tree, "manifest.jsonl", Some(&record));
        assert!(
            matches!(got, Err(FileProblem::Length { len: l, recorded: 10 }) if l == len),
            "{got:?}"
        );
        assert!(start.elapsed() < std::time::Duration::from_secs(2));
    }

    #[test]
    fn counts_add_in_arrays_and_maps_and_other_numbers_are_refused() {
        let mut a = serde_json::json!({"frames": 2, "per": [1, 2, 3], "by": {"x": 1}});
        let b = serde_json::json!({"frames": 3, "per": [1, 1, 1], "by": {"x": 1, "y": 4}});
        add_counts(&mut a, &b, "").expect("counts add");
        assert_eq!(
            a,
            serde_json::json!({"frames": 5, "per": [2, 3, 4], "by": {"x": 2, "y": 4}})
        );
        let mut c = serde_json::json!({"mean": 1.5});
        assert!(add_counts(&mut c, &serde_json::json!({"mean": 2.0}), "").is_err());
        // Histograms of different lengths add bin by bin.
        let mut d = serde_json::json!({"per": [1, 2]});
        add_counts(&mut d, &serde_json::json!({"per": [1, 0, 5]}), "").expect("bins add");
        assert_eq!(d, serde_json::json!({"per": [2, 2, 5]}));
        // Labels of the run: taken when empty, equal afterwards, else refused.
        let mut e = serde_json::json!({"from": "", "plan": false});
        let f = serde_json::json!({"from": "Visible", "plan": false});
        add_counts(&mut e, &f, "").expect("labels");
        add_counts(&mut e, &f, "").expect("labels again");
        assert_eq!(e, f);
        assert!(add_counts(&mut e, &serde_json::json!({"from": "Amodal"}), "").is_err());
    }
}
