//! Opening a dataset folder for a run: refuse what is not swarmshot's, then
//! start afresh, continue the earlier run from its last trusted checkpoint
//! (`--resume`, or the same command again), or delete the earlier run's own
//! files first (`--overwrite`).

use super::files::write_new_then_rename;
use super::*;

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

/// Refuse a ledger whose last checkpoint lies past the end of the run its
/// header names (its frame count edited, or the checkpoint): continued, the
/// run would be marked done with the frames past that end, or a count of
/// frames it never wrote. A run's last frame's successor lies at most a
/// step (`--every`) past its end.
fn past_its_end(root: &Path, scan: &LedgerScan) -> Result<(), OutputError> {
    let Some(next) = scan.checkpoint.as_ref().map(|c| c.next) else {
        return Ok(());
    };
    let end = scan.run.end();
    if next < end.saturating_add(scan.run.every.max(1)) {
        return Ok(());
    }
    Err(OutputError::Ledger {
        path: root.join(LEDGER),
        reason: format!(
            "its last checkpoint is at frame {next}, past the end of its run ({}), so it was changed after swarmshot wrote it; nothing was written; pass --overwrite to make the run again (files swarmshot did not write are kept)",
            scan.run.describe()
        ),
    })
}

/// Refuse a file in one of the dataset's folders (`needed` entries ending in
/// `/`) named as a frame's files are (eight digits or more, then an
/// extension) that is not among the earlier run's frame files (`listed`, the
/// ledger's claims): a user's file there would stop the run at that frame
/// ([`Folder::check_earlier`]); found now, before anything is written. One
/// read of each folder.
fn frame_names_free(
    tree: &mut Tree,
    needed: &[String],
    listed: &HashSet<String>,
) -> Result<(), OutputError> {
    let frame_name = |name: &str| {
        name.split_once('.')
            .is_some_and(|(stem, _)| stem.len() >= 8 && stem.bytes().all(|b| b.is_ascii_digit()))
    };
    for dir in needed.iter().filter(|n| n.ends_with('/')) {
        for name in tree.names(dir.trim_end_matches('/'))? {
            let rel = format!("{dir}{name}");
            if frame_name(&name) && !listed.contains(&rel) {
                return Err(refused(
                    tree.root().join(&rel),
                    "exists and was not written by swarmshot (it is not in .swarmshot-ledger), at the name of a frame's file",
                ));
            }
        }
    }
    Ok(())
}

/// The most problems a refusal of a changed finished run names.
const MAX_PROBLEMS_NAMED: usize = 10;

/// A finished run's files as it left them, before it is called complete:
/// every file its ledger claims (working files aside: they are deleted when
/// the run ends) is still there as a regular file, and each append-only
/// file (the manifest) has the length its last checkpoint gives. Files are
/// looked at, not read.
fn finished_files_intact(tree: &mut Tree, scan: &LedgerScan) -> Result<(), OutputError> {
    let mut claimed: Vec<&String> = scan
        .owned
        .union(&scan.frame_files)
        .filter(|r| !r.ends_with('/') && !is_working_file(r) && r.as_str() != LEDGER)
        .collect();
    claimed.sort();
    let mut problems = Vec::new();
    for rel in claimed {
        match tree.lstat(rel)? {
            None => problems.push(format!("{rel} is missing")),
            Some(e) if !e.is_file() => problems.push(format!("{rel} is not a regular file")),
            Some(_) => {}
        }
    }
    let appended = scan.checkpoint.iter().flat_map(|cp| cp.files.iter());
    for (rel, &len) in appended.filter(|(r, _)| !is_working_file(r)) {
        if let Some(e) = tree.lstat(rel)?.filter(|e| e.is_file() && e.len != len) {
            problems.push(format!(
                "{rel} is {} bytes, {len} when the run ended",
                e.len
            ));
        }
    }
    if problems.is_empty() {
        return Ok(());
    }
    if problems.len() > MAX_PROBLEMS_NAMED {
        let more = problems.len() - MAX_PROBLEMS_NAMED;
        problems.truncate(MAX_PROBLEMS_NAMED);
        problems.push(format!("and {more} more"));
    }
    Err(OutputError::FinishedChanged {
        path: tree.root().to_owned(),
        problems,
    })
}

impl Folder {
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
        inputs: &[InputRecord],
    ) -> Result<(Self, Start, RunId), OutputError> {
        if mode.overwrite && mode.resume {
            return Err(OutputError::Conflict);
        }
        match lstat(root)? {
            None => fs::create_dir_all(root).map_err(io(root))?,
            Some(_) => {
                // The folder the user named may itself be a link; what is inside may not.
                let m = fs::metadata(root).map_err(crate::write::io_following(root))?;
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
            frame_names_free(&mut tree, needed, &HashSet::new())?;
            return Ok((Self::fresh(tree, run, lock, inputs)?, Start::Fresh, run));
        };
        preflight(&mut tree, needed, &scan.owned)?;
        frame_names_free(&mut tree, needed, &scan.frame_files)?;
        let frames = frames.unwrap_or(scan.run.frames);
        let run = RunId {
            frames,
            preset_hash,
            shard: mode.shard.map(|p| p.run(frames)),
            every: mode.every.unwrap_or(scan.run.every).max(1),
        };
        if scan.run == run && !mode.overwrite {
            past_its_end(root, &scan)?;
            let changed = changed_inputs(&scan.inputs, inputs);
            if !changed.is_empty() {
                return Err(OutputError::InputsChanged {
                    path: root.to_owned(),
                    changed,
                    merge: mode.merge,
                });
            }
            if scan.done {
                finished_files_intact(&mut tree, &scan)?;
            }
            let folder = Self::continue_from(tree, &scan, lock, inputs)?;
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
            let what = other_run(&scan.run, &run, mode.twin);
            return Err(OutputError::OtherRun {
                path: root.to_owned(),
                what,
                resume_with: resume_flags(&scan.run, &run, &mode),
            });
        }
        Self::delete_run(&mut tree)?;
        Ok((Self::fresh(tree, run, lock, inputs)?, Start::Fresh, run))
    }

    /// A new ledger holding only the header and the run's inputs.
    fn fresh(
        mut tree: Tree,
        run: RunId,
        lock: FolderLock,
        inputs: &[InputRecord],
    ) -> Result<Self, OutputError> {
        if tree.lstat(LEDGER)?.is_some() {
            return Err(refused(
                tree.root().join(LEDGER),
                "exists although no earlier run was found; remove it by hand",
            ));
        }
        let mut head = run.header();
        head.extend(inputs.iter().map(InputRecord::line));
        write_new_then_rename(&mut tree, LEDGER, head.as_bytes(), false)?;
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
            pending: Default::default(),
            _lock: lock,
        })
    }

    /// Cut the ledger back to its last trusted checkpoint (keeping every
    /// claim after it) and open it to append. An unfinished run whose
    /// ledger records no inputs (written before the record, or left by an
    /// interrupted `--overwrite`) records `inputs` from here on, so the rest
    /// of it is continued only from them.
    fn continue_from(
        mut tree: Tree,
        scan: &LedgerScan,
        lock: FolderLock,
        inputs: &[InputRecord],
    ) -> Result<Self, OutputError> {
        let path = tree.root().join(LEDGER);
        let bytes = super::ledger::read_ledger(tree.open_file(LEDGER, false)?, &path)?;
        let record = scan.inputs.is_empty() && !scan.done && !inputs.is_empty();
        if record || scan.good_end != bytes.len() || scan.prefix_len != bytes.len() {
            let mut text = bytes[..scan.head_len].to_vec();
            if record {
                text.extend(inputs.iter().flat_map(|r| r.line().into_bytes()));
            }
            text.extend_from_slice(&bytes[scan.head_len..scan.good_end]);
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
            pending: Default::default(),
            _lock: lock,
        })
    }

    /// Delete every file and folder an earlier run's ledger lists (files
    /// first, then folders that are empty), then the ledger itself. Links and
    /// entries that are not regular files are left alone.
    ///
    /// Every listed entry is first looked at without following links: a
    /// link anywhere on a listed path (the entry itself or a folder above
    /// it) refuses the whole deletion before anything is deleted. Then the
    /// ledger forgets the run's progress ([`Folder::forget_progress`]), and
    /// each file is deleted relative to its folder's handle (`unlinkat`), so
    /// a folder swapped for a link in between is never walked through.
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
        Self::forget_progress(tree)?;
        let mut dirs = Vec::new();
        for rel in &claims {
            if let Some(dir) = rel.strip_suffix('/') {
                dirs.push(dir.to_owned());
                continue;
            }
            for r in [rel.clone(), temp_rel(rel)] {
                tree.remove_file(&r)?;
            }
            stall_if_asked("overwrite:deleting");
        }
        for dir in dirs.iter().rev() {
            // Not empty: it holds files swarmshot did not write; keep them.
            tree.remove_dir_if_empty(dir)?;
        }
        tree.remove_file(LEDGER)?;
        Ok(())
    }
}

impl Folder {
    /// Rewrite the ledger (atomically) as its header and its claims alone,
    /// before `--overwrite` deletes anything: a deletion cut short (a kill,
    /// a file that cannot be deleted) leaves a run with no checkpoint and no
    /// done mark, which the next run starts again from its first frame,
    /// never a run that looks finished while its files are gone.
    fn forget_progress(tree: &mut Tree) -> Result<(), OutputError> {
        let path = tree.root().join(LEDGER);
        let bytes = super::ledger::read_ledger(tree.open_file(LEDGER, false)?, &path)?;
        let whole = bytes.iter().rposition(|&b| b == b'\n').map_or(0, |i| i + 1);
        let mut text = Vec::with_capacity(whole);
        for (i, line) in bytes[..whole].split_inclusive(|&b| b == b'\n').enumerate() {
            if i == 0 || line.starts_with(b"*") || line.starts_with(b"+") {
                text.extend_from_slice(line);
            }
        }
        write_new_then_rename(tree, LEDGER, &text, true)
    }
}

/// The batch flags that continue `earlier` when it is a run of this preset
/// (as a plan or rendered) and only flags keep this run from it: `--resume`
/// keeps the earlier run's frame count (`--limit`) and step (`--every`), so
/// only the mode and the shard need naming. `None` for another preset and
/// for a merge. Without it a user who left out `--shard 1/2` or
/// `--labels-only` was told only to pass `--overwrite`, which deletes the
/// run they meant to continue.
fn resume_flags(earlier: &RunId, run: &RunId, mode: &OpenMode) -> Option<String> {
    let twin = mode
        .twin
        .is_some_and(|(hash, _)| hash == earlier.preset_hash);
    if mode.merge || !(twin || earlier.preset_hash == run.preset_hash) {
        return None;
    }
    // A twin is a run of the other mode.
    let plan = mode.labels_only != twin;
    let mut flags = "--resume".to_owned();
    if plan {
        flags.push_str(" --labels-only");
    }
    if let Some(s) = earlier.shard {
        flags.push_str(&format!(" --shard {}", s.shard));
    }
    let without: Vec<&str> = [
        (!plan && mode.labels_only, "--labels-only"),
        (earlier.shard.is_none() && mode.shard.is_some(), "--shard"),
        (true, "--limit"),
        (!plan, "--every"),
    ]
    .into_iter()
    .filter_map(|(left_out, flag)| left_out.then_some(flag))
    .collect();
    Some(format!("{flags} (no {})", without.join(", no ")))
}

/// What the earlier run in the folder is, against this run, for the
/// refusal's message: the first difference found, with the flag that makes it.
fn other_run(earlier: &RunId, run: &RunId, twin: Option<(u64, &str)>) -> String {
    if let Some((_, name)) = twin.filter(|(hash, _)| *hash == earlier.preset_hash) {
        format!(
            "{name} of this preset (a labels-only plan and a rendered run never continue each other)"
        )
    } else if earlier.preset_hash != run.preset_hash {
        "a run of a different preset (its preset.lock.ron differs)".to_owned()
    } else if earlier.every != run.every {
        format!(
            "a run of this preset with {}, and this run makes {} (--every differs)",
            earlier.describe(),
            run.describe()
        )
    } else if earlier.shard != run.shard {
        format!(
            "a run of this preset with {}, and this run makes {} (--shard differs)",
            earlier.describe(),
            run.describe()
        )
    } else if run.every > 1 {
        format!(
            "a run of this preset with {}, and this run makes {} (--limit differs)",
            earlier.describe(),
            run.describe()
        )
    } else {
        format!(
            "a run of this preset with {} frames, and this run makes {} (--limit differs)",
            earlier.frames, run.frames
        )
    }
}
