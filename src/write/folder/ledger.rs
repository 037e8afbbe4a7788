//! The records a run appends to the ledger: claims (`*` dataset files, `+`
//! files of the frame in flight) written before their files, checkpoints
//! after each complete frame, a shard's content records and the done mark;
//! and the claims read back (what `--overwrite` deletes and `merge` takes).

use super::*;

/// The most bytes a ledger's header line takes (a run's frame count, preset
/// hash, shard and `--every`: under 200).
const LEDGER_HEADER_BYTES: u64 = 4 << 10;

/// The most bytes a ledger holds for each frame its run makes: the frame's
/// claims (its files' paths), its checkpoint (the append-only files'
/// lengths, the counters and the statistics so far: a few KiB, more with
/// many models, environments, resolutions or box counts), the same again
/// for each time an interrupted frame was made again, and the run's share of
/// the folder's claims and content records. 1 MiB a frame is far above
/// what any run writes, so a larger file was not written by swarmshot.
pub(super) const LEDGER_BYTES_PER_FRAME: u64 = 1 << 20;

/// The most bytes a ledger's input records take (`^` lines after the header).
const LEDGER_INPUTS_BYTES: u64 = run::MAX_INPUT_RECORDS as u64 * run::INPUT_RECORD_BYTES;

/// The whole ledger `file` (at `path`), read within the bound of its run: at
/// most [`LEDGER_HEADER_BYTES`] and [`LEDGER_INPUTS_BYTES`] plus
/// [`LEDGER_BYTES_PER_FRAME`] for each frame the header's run makes, and one
/// more (for a ledger whose header names no run, refused by its reader). A larger ledger is refused by name and size
/// before it is read, so no ledger makes a read grow without end.
pub(super) fn read_ledger(file: File, path: &Path) -> Result<Vec<u8>, OutputError> {
    use std::io::BufRead;
    let len = file.metadata().map_err(io(path))?.len();
    let mut reader = std::io::BufReader::new(file);
    let mut bytes = Vec::new();
    (&mut reader)
        .take(LEDGER_HEADER_BYTES)
        .read_until(b'\n', &mut bytes)
        .map_err(io(path))?;
    let run = std::str::from_utf8(&bytes)
        .ok()
        .and_then(|line| RunId::parse(line.trim_end()));
    let frames = run.as_ref().map_or(0, |run| {
        run.end()
            .saturating_sub(run.start())
            .div_ceil(run.every.max(1))
    });
    let cap = (LEDGER_HEADER_BYTES + LEDGER_INPUTS_BYTES).saturating_add(
        frames
            .saturating_add(1)
            .saturating_mul(LEDGER_BYTES_PER_FRAME),
    );
    let too_large = |len: u64| OutputError::Ledger {
        path: path.to_owned(),
        reason: match run {
            Some(_) => format!(
                "it is {len} bytes, more than the {cap}-byte limit for the ledger of a {frames}-frame run ({LEDGER_BYTES_PER_FRAME} bytes a frame), so swarmshot did not write it"
            ),
            None => format!(
                "its first line is not a header swarmshot writes (`swarmshot-ledger 1 frames=N preset=…`, with a frame count no preset exceeds and a shard range inside it), and it is {len} bytes, more than a ledger without one may hold ({cap} bytes)"
            ),
        },
    };
    if len > cap {
        return Err(too_large(len));
    }
    let rest = cap.saturating_sub(bytes.len() as u64).saturating_add(1);
    reader
        .take(rest)
        .read_to_end(&mut bytes)
        .map_err(io(path))?;
    if bytes.len() as u64 > cap {
        return Err(too_large(bytes.len() as u64));
    }
    Ok(bytes)
}

/// A checkpoint's ledger line: `=`, its JSON, a tab and the FNV-1a 64 hash
/// of the JSON (serde_json writes no raw tab), so a line changed after it was
/// written (a flipped bit, an edit) is told from one swarmshot wrote.
fn checkpoint_line(json: &str) -> String {
    format!("={json}\tfnv1a64:{:016x}\n", fnv1a64(json.as_bytes()))
}

/// The checkpoint a ledger line holds after its `=`: `None` when its hash
/// does not match its JSON or the JSON is not a checkpoint. A line without
/// a hash (written by a swarmshot before the hash) is read as it was.
pub(super) fn parse_checkpoint(text: &str) -> Option<Checkpoint> {
    let json = match text.rsplit_once('\t') {
        Some((json, sum)) => {
            let hex = sum.strip_prefix("fnv1a64:")?;
            let hash = u64::from_str_radix(hex, 16).ok()?;
            (hex.len() == 16 && hash == fnv1a64(json.as_bytes())).then_some(json)?
        }
        None => text,
    };
    serde_json::from_str(json).ok()
}

impl Folder {
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
        // What stands at the names first ([`Folder::check_earlier`]): a claim
        // makes a file ours, for a failed frame's clean-up and a later --overwrite.
        for rel in rels {
            self.check_earlier(rel)?;
        }
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

    pub(super) fn is_ours(&self, rel: &str) -> bool {
        self.owned.contains(rel) || self.frame_claims.iter().any(|c| c == rel)
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
    pub(super) fn claims(root: &Path) -> Result<Vec<String>, OutputError> {
        let path = root.join(LEDGER);
        let bytes = read_ledger(open_checked(root, LEDGER, false)?, &path)?;
        Ok(String::from_utf8_lossy(&bytes)
            .lines()
            .filter_map(|line| line.strip_prefix('*').or_else(|| line.strip_prefix('+')))
            .filter(|rel| !rel.is_empty() && !rel.starts_with('/'))
            .filter(|rel| !rel.split('/').any(|c| c == ".."))
            .map(str::to_owned)
            .collect())
    }

    /// Frame complete: write its checkpoint.
    pub fn commit(&mut self, checkpoint: &Checkpoint) -> Result<(), OutputError> {
        let json = serde_json::to_string(checkpoint).map_err(|e| OutputError::Ledger {
            path: self.root.join(LEDGER),
            reason: e.to_string(),
        })?;
        self.create_pending()?;
        stall_if_asked(&format!("checkpoint:{}", checkpoint.next.saturating_sub(1)));
        // A folder swapped for a link (or moved) since it was opened stops the
        // run here: the frame's files went into the folder that was opened.
        self.tree.verify()?;
        self.ledger_append(&checkpoint_line(&json), false)?;
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
        self.pending.clear();
        for rel in std::mem::take(&mut self.frame_claims) {
            for r in [temp_rel(&rel), rel] {
                let _ = self.tree.remove_file(&r);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A folder whose ledger names a 2-frame run and is then made `len`
    /// bytes long (a sparse file: no disk used).
    fn ledger_of(len: u64) -> tempfile::TempDir {
        let dir = tempfile::tempdir().expect("temp dir");
        let header =
            "swarmshot-ledger 1 frames=2 preset=fnv1a64:0123456789abcdef\n*manifest.jsonl\n";
        fs::write(dir.path().join(LEDGER), header).expect("ledger");
        let file = fs::OpenOptions::new()
            .write(true)
            .open(dir.path().join(LEDGER))
            .expect("open");
        file.set_len(len.max(header.len() as u64)).expect("set_len");
        dir
    }

    #[test]
    fn a_checkpoint_line_changed_after_it_was_written_is_not_read() {
        let checkpoint = Checkpoint {
            next: 12,
            ..Checkpoint::default()
        };
        let json = serde_json::to_string(&checkpoint).expect("json");
        let line = checkpoint_line(&json);
        let text = line
            .trim_end()
            .strip_prefix('=')
            .expect("a checkpoint line");
        assert_eq!(parse_checkpoint(text).map(|c| c.next), Some(12));
        let changed = text.replace("\"next\":12", "\"next\":13");
        assert!(parse_checkpoint(&changed).is_none(), "{changed}");
        // Written by a swarmshot before the hash: read as it was.
        assert_eq!(parse_checkpoint(&json).map(|c| c.next), Some(12));
        let cut = &text[..text.len() - 1];
        assert!(parse_checkpoint(cut).is_none(), "{cut}");
    }

    #[test]
    fn a_ledger_cut_inside_its_header_says_so() {
        let dir = tempfile::tempdir().expect("temp dir");
        fs::write(dir.path().join(LEDGER), "swarmshot-ledger 1 fr").expect("ledger");
        let err = read_run(dir.path()).expect_err("refused").to_string();
        assert!(err.contains("21 bytes and no whole line"), "{err}");
        fs::write(dir.path().join(LEDGER), "").expect("ledger");
        let err = read_run(dir.path()).expect_err("refused").to_string();
        assert!(err.contains("it is empty"), "{err}");
        assert!(
            err.contains("choose another folder, or clear this one by hand"),
            "{err}"
        );
    }

    #[test]
    fn a_ledger_larger_than_its_run_can_write_is_refused_unread() {
        let cap = LEDGER_HEADER_BYTES + LEDGER_INPUTS_BYTES + 3 * LEDGER_BYTES_PER_FRAME;
        // Within the bound: read (no content records, one claim).
        let dir = ledger_of(0);
        assert!(content_records(dir.path()).expect("records").is_empty());
        let claims = Folder::listed_files(dir.path()).expect("claims");
        assert_eq!(claims.into_iter().collect::<Vec<_>>(), ["manifest.jsonl"]);
        // 64 MiB for a 2-frame run: refused by every reader, naming the file.
        let dir = ledger_of(64 << 20);
        let errors = [
            content_records(dir.path()).map(|_| ()),
            Folder::listed_files(dir.path()).map(|_| ()),
            read_run(dir.path()).map(|_| ()),
        ];
        for err in errors {
            let err = err.expect_err("refused").to_string();
            assert!(err.contains(".swarmshot-ledger"), "{err}");
            assert!(
                err.contains(&format!(
                    "{} bytes, more than the {cap}-byte limit",
                    64 << 20
                )),
                "{err}"
            );
        }
    }

    #[test]
    fn a_forged_header_does_not_lift_the_bound() {
        // A header naming 2^64 − 1 frames (or a shard past its run's end)
        // set the bound the rest was read within: a sparse 1 GiB ledger
        // was read whole (a 9 GiB one until memory ran out). Such a header
        // is no run's, so the ledger is refused unread, saying why.
        for header in [
            "swarmshot-ledger 1 frames=18446744073709551615 preset=fnv1a64:0123456789abcdef\n",
            "swarmshot-ledger 1 frames=200000000 preset=fnv1a64:0123456789abcdef\n",
            "swarmshot-ledger 1 frames=6 preset=fnv1a64:0123456789abcdef shard=0/2 range=0..18446744073709551615\n",
            "swarmshot-ledger 1 frames=6 preset=fnv1a64:0123456789abcdef shard=2/2 range=3..6\n",
        ] {
            assert!(RunId::parse(header.trim_end()).is_none(), "{header}");
            let dir = tempfile::tempdir().expect("temp dir");
            let path = dir.path().join(LEDGER);
            fs::write(&path, header).expect("ledger");
            let file = fs::OpenOptions::new()
                .write(true)
                .open(&path)
                .expect("open");
            file.set_len(1 << 30).expect("set_len");
            let err = Folder::listed_files(dir.path())
                .expect_err("refused")
                .to_string();
            assert!(err.contains("not a header swarmshot writes"), "{err}");
        }
        // The headers runs write still parse.
        for header in [
            "swarmshot-ledger 1 frames=100000000 preset=fnv1a64:0123456789abcdef",
            "swarmshot-ledger 1 frames=6 preset=fnv1a64:0123456789abcdef shard=1/2 range=3..6",
            "swarmshot-ledger 1 frames=15 preset=fnv1a64:0123456789abcdef every=3",
        ] {
            assert!(RunId::parse(header).is_some(), "{header}");
        }
    }

    #[test]
    fn inputs_are_read_back_as_written_and_compared_by_content() {
        let record = |field: &str, byte: char, path: &str| InputRecord {
            field: field.into(),
            blake3: byte.to_string().repeat(64),
            path: path.into(),
        };
        let dir = tempfile::tempdir().expect("temp dir");
        let run = RunId {
            frames: 4,
            preset_hash: 1,
            shard: None,
            every: 1,
        };
        let written = [
            record("models", 'a', "m dir/m.glb"),
            record("sky", 'b', "s.hdr"),
        ];
        let text: String = std::iter::once(run.header())
            .chain(written.iter().map(InputRecord::line))
            .collect();
        fs::write(dir.path().join(LEDGER), text).expect("ledger");
        let read = read_run(dir.path()).expect("read").expect("a run").inputs;
        assert_eq!(read, written);
        // The same content at other paths (a shard made elsewhere) matches.
        let moved = [
            record("models", 'a', "/x/m.glb"),
            record("sky", 'b', "/x/s.hdr"),
        ];
        assert!(changed_inputs(&read, &moved).is_empty());
        let changed = [
            record("models", 'a', "m dir/m.glb"),
            record("sky", 'c', "s.hdr"),
        ];
        assert_eq!(changed_inputs(&read, &changed), ["sky s.hdr"]);
        assert_eq!(changed_inputs(&read, &changed[..1]).len(), 1);
        // A ledger written before the record holds none: nothing to compare.
        assert!(changed_inputs(&[], &changed).is_empty());
        // A record's path is cut for its line's bound (a newline escaped).
        let long = InputRecord::new("models", "a".repeat(64), Path::new(&"\n".repeat(900)));
        assert!(long.line().len() as u64 <= run::INPUT_RECORD_BYTES);
        assert_eq!(long.line().matches('\n').count(), 1, "{}", long.line());
        // A malformed record is named.
        fs::write(
            dir.path().join(LEDGER),
            run.header() + "^sky blake3:zz s.hdr\n",
        )
        .expect("ledger");
        let err = read_run(dir.path()).expect_err("refused").to_string();
        assert!(err.contains("malformed input record"), "{err}");
    }
}
