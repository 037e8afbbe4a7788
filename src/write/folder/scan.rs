//! Reading the ledger back: the run, the last checkpoint whose frames' files
//! are all there, and what the folder owns.

use super::*;

/// What a ledger says, read from disk.
pub(super) struct LedgerScan {
    pub(super) run: RunId,
    /// The inputs the run recorded (the `^` lines after the header; none in
    /// a ledger written before the record).
    pub(super) inputs: Vec<InputRecord>,
    /// Bytes of the header and the input records.
    pub(super) head_len: usize,
    /// Valid bytes: everything up to the last complete line.
    pub(super) prefix_len: usize,
    /// Byte offset just after the last trusted checkpoint (or the header).
    pub(super) good_end: usize,
    pub(super) checkpoint: Option<Checkpoint>,
    pub(super) done: bool,
    pub(super) owned: HashSet<String>,
    /// Every frame file the ledger claims (`+` lines), checkpointed or not.
    pub(super) frame_files: HashSet<String>,
    /// Claim lines after `good_end` (kept when the ledger is cut back).
    pub(super) later_claims: Vec<String>,
}

impl Folder {
    /// Read the ledger: the run, the last checkpoint whose frames' files all
    /// exist and whose append-only files are long enough, and every claim.
    pub(super) fn scan(root: &Path) -> Result<LedgerScan, OutputError> {
        let path = root.join(LEDGER);
        let bytes = super::ledger::read_ledger(open_checked(root, LEDGER, false)?, &path)?;
        let prefix_len = bytes.iter().rposition(|&b| b == b'\n').map_or(0, |i| i + 1);
        if prefix_len == 0 && !bytes.is_empty() {
            return Err(OutputError::Ledger {
                path,
                reason: format!(
                    "it holds {} bytes and no whole line: its header is cut short",
                    bytes.len()
                ),
            });
        }
        let text = String::from_utf8_lossy(&bytes[..prefix_len]);
        // A finished run deleted its COCO parts: its checkpoints are not checked against files.
        let finished = text.trim_end().ends_with("\n!done");
        let scan = Self::scan_text(root, &text, prefix_len, finished)?;
        if finished && !scan.done {
            // Its done mark is not trusted (a checkpoint before it changed
            // after it was written): it is not a finished run, so its
            // checkpoints are checked against its files after all.
            return Self::scan_text(root, &text, prefix_len, false);
        }
        Ok(scan)
    }

    /// [`Folder::scan`] of the ledger's whole lines `text` (its first
    /// `prefix_len` bytes); `finished`: the ledger ends with the done mark,
    /// and checkpoints are not checked against files.
    fn scan_text(
        root: &Path,
        text: &str,
        prefix_len: usize,
        finished: bool,
    ) -> Result<LedgerScan, OutputError> {
        let path = root.join(LEDGER);
        let mut tree = Tree::open(root)?;
        let corrupt = |reason: &str| OutputError::Ledger {
            path: path.clone(),
            reason: reason.into(),
        };
        let mut lines = text.split_inclusive('\n');
        let header = lines.next().unwrap_or_default();
        let run = header_run(header).map_err(|reason| corrupt(&reason))?;
        // The inputs' records, written with the header, belong to it.
        let mut inputs = Vec::new();
        let mut offset = header.len();
        let mut lines = lines.peekable();
        while let Some(line) = lines.next_if(|l| l.starts_with('^')) {
            offset += line.len();
            let record = line.trim_end_matches('\n');
            inputs.push(InputRecord::parse(&record[1..]).ok_or_else(|| {
                corrupt(&format!("it holds a malformed input record {record:?}"))
            })?);
        }
        let mut scan = LedgerScan {
            run,
            inputs,
            head_len: offset,
            prefix_len,
            good_end: offset,
            checkpoint: None,
            done: false,
            owned: HashSet::new(),
            frame_files: HashSet::new(),
            later_claims: Vec::new(),
        };
        let mut frame_files: Vec<String> = Vec::new();
        let mut broken = false;
        for line in lines {
            offset += line.len();
            let line = line.trim_end_matches('\n');
            if let Some(rel) = line.strip_prefix('*') {
                scan.owned.insert(rel.to_owned());
                scan.later_claims.push(line.to_owned());
            } else if let Some(rel) = line.strip_prefix('+') {
                frame_files.push(rel.to_owned());
                scan.frame_files.insert(rel.to_owned());
                scan.later_claims.push(line.to_owned());
            } else if let Some(json) = line.strip_prefix('=') {
                if broken {
                    continue;
                }
                // A line changed after it was written (its hash differs) is
                // not trusted, nor any checkpoint after it.
                let Some(cp) = super::ledger::parse_checkpoint(json) else {
                    broken = true;
                    continue;
                };
                // A missing file means the run stopped before it: the
                // checkpoint is not trusted. A link where a listed file
                // should be (or in a folder above it) is refused now, before
                // the ledger is cut back or anything is written.
                let checked =
                    |tree: &mut Tree, rel: &str, min_len: Option<u64>| match tree.lstat(rel)? {
                        Some(e) if e.is_symlink() => Err(link_refused(root.join(rel))),
                        Some(e) if min_len.is_some() && e.is_file() && e.links != 1 => {
                            Err(hard_link_refused(root.join(rel), e.links))
                        }
                        Some(e) => Ok(e.is_file() && e.len >= min_len.unwrap_or(0)),
                        None => Ok(false),
                    };
                let mut good = true;
                if !finished {
                    for rel in &frame_files {
                        good &= checked(&mut tree, rel, None)?;
                    }
                    for (rel, &len) in &cp.files {
                        good &= checked(&mut tree, rel, Some(len))?;
                    }
                }
                if good {
                    // A checkpoint lists only what changed since the one before.
                    let mut merged = scan.checkpoint.take().unwrap_or_default();
                    merged.next = cp.next;
                    merged.files.extend(cp.files);
                    merged.counters.extend(cp.counters);
                    merged.stats = cp.stats;
                    scan.checkpoint = Some(merged);
                    scan.good_end = offset;
                    scan.later_claims.clear();
                    frame_files.clear();
                } else {
                    broken = true;
                }
            } else if line.starts_with('%') {
                // A finished shard's content records (see `mark_done`).
            } else if line == "!done" {
                if !broken
                    && scan
                        .checkpoint
                        .as_ref()
                        .map_or(scan.run.start(), |cp| cp.next)
                        >= scan.run.end()
                {
                    scan.done = true;
                    scan.good_end = offset;
                    scan.later_claims.clear();
                }
            } else {
                return Err(corrupt(&format!("it holds an unknown line {line:?}")));
            }
        }
        scan.owned.extend(frame_files);
        Ok(scan)
    }
}

/// The run a ledger's first line names, or why there is none. Without its
/// header a ledger tells nothing, not even which files are swarmshot's (what
/// `--overwrite` would delete), so the refusal says what to do.
fn header_run(header: &str) -> Result<RunId, String> {
    const WAY: &str = "which of the folder's files swarmshot wrote is not known, so nothing was written: choose another folder, or clear this one by hand";
    if header.is_empty() {
        return Err(format!("it is empty; {WAY}"));
    }
    RunId::parse(header.trim_end())
        .ok_or_else(|| format!("its first line is not a swarmshot-ledger 1 header; {WAY}"))
}
