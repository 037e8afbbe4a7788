//! Files written into the dataset folder: folders made one level at a time,
//! each target checked (absent, or a regular file this run owns), whole files
//! written under a temporary name, flushed and renamed into place, and the
//! append-only files opened and cut back.

use super::*;

impl Folder {
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

    /// Refuse an entry at `rel` unless the earlier run's ledger lists it: a
    /// frame's files are claimed before they are written, so what stands at
    /// their names must be checked first (a user's file there is refused,
    /// not replaced and then listed as ours).
    pub(super) fn check_earlier(&mut self, rel: &str) -> Result<(), OutputError> {
        if self.owned.contains(rel) {
            return Ok(());
        }
        match self.tree.lstat(rel)? {
            None => Ok(()),
            Some(m) if m.is_symlink() => Err(link_refused(self.root.join(rel))),
            Some(_) => Err(refused(
                self.root.join(rel),
                "exists and was not written by swarmshot (it is not in .swarmshot-ledger)",
            )),
        }
    }

    /// Write a whole file atomically: claim it, write a temporary file in the
    /// same folder, flush it to disk, rename it over `rel`.
    pub fn write_file(&mut self, rel: &str, bytes: &[u8]) -> Result<(), OutputError> {
        let fill = |w: &mut std::io::BufWriter<&File>| w.write_all(bytes);
        self.write_files_with(vec![(rel.to_owned(), fill)])
    }

    /// A frame file of a labels-only plan (already claimed with
    /// [`Folder::claim_frame`], frames not durable): kept until the
    /// checkpoint, then created in place with the chunk's other files on a few
    /// threads (`pending.rs`), never following a link nor replacing an entry,
    /// and not flushed. Anything already at `rel` (a resumed plan's frame in
    /// flight) goes the careful way of [`Folder::write_file`].
    pub fn write_frame_file(&mut self, rel: &str, bytes: &[u8]) -> Result<(), OutputError> {
        if self.durable_frames {
            return self.write_file(rel, bytes);
        }
        if let Some((dir, _)) = rel.rsplit_once('/') {
            self.ensure_dir(dir)?;
        }
        self.pending.push(rel, bytes);
        Ok(())
    }

    /// Whole files written atomically, each streamed by its `fill`: their
    /// names claimed (one ledger flush) and their temporary files made here,
    /// each filled and flushed to disk on a thread of its own but the last,
    /// filled here (the disk writes them out together instead of one after
    /// another), then renamed over their names in order once every one is
    /// written. On an error, every temporary file not yet renamed is removed.
    pub fn write_files_with<F>(&mut self, files: Vec<(String, F)>) -> Result<(), OutputError>
    where
        F: FnOnce(&mut std::io::BufWriter<&File>) -> std::io::Result<()> + Send,
    {
        for (rel, _) in &files {
            if let Some((dir, _)) = rel.rsplit_once('/') {
                self.ensure_dir(dir)?;
            }
            self.check_target(rel)?;
        }
        let new: Vec<&str> = (files.iter().map(|(rel, _)| rel.as_str()))
            .filter(|rel| !self.is_ours(rel))
            .collect();
        self.claim(&new)?;
        let (mut names, mut slots) = (Vec::new(), Vec::new());
        for (rel, fill) in files {
            let made = (self.clear_temp(&rel))
                .and_then(|tmp| Ok((self.tree.create_new(&tmp, false)?, tmp)));
            let (file, tmp_rel) = match made {
                Ok(made) => made,
                Err(e) => return Err(self.remove_temps(names.iter().map(|(_, t)| t), e)),
            };
            names.push((rel, tmp_rel));
            slots.push(std::sync::Mutex::new(Some((file, fill))));
        }
        let written = fill_on_threads(&slots);
        let failed =
            (written.into_iter().zip(&names)).find_map(|(r, (rel, _))| r.err().map(|e| (rel, e)));
        if let Some((rel, e)) = failed {
            let e = io(&self.root.join(rel))(e);
            return Err(self.remove_temps(names.iter().map(|(_, t)| t), e));
        }
        for (k, (rel, tmp_rel)) in names.iter().enumerate() {
            stall_if_asked(rel);
            if let Err(e) = self.tree.rename(tmp_rel, rel) {
                return Err(self.remove_temps(names[k..].iter().map(|(_, t)| t), e));
            }
        }
        Ok(())
    }

    /// Remove the temporary files `temps` after `error`, which is returned.
    fn remove_temps<'a>(
        &mut self,
        temps: impl Iterator<Item = &'a String>,
        error: OutputError,
    ) -> OutputError {
        for tmp in temps {
            let _ = self.tree.remove_file(tmp);
        }
        error
    }

    /// The temporary name `rel` is written under, cleared of a temporary file
    /// of ours that a killed run left.
    pub(super) fn clear_temp(&mut self, rel: &str) -> Result<String, OutputError> {
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
            write_back_from: None,
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
}

/// `file` filled by `fill` through a buffer, then flushed to disk.
fn fill_and_flush(
    file: &File,
    fill: impl FnOnce(&mut std::io::BufWriter<&File>) -> std::io::Result<()>,
) -> std::io::Result<()> {
    let mut w = std::io::BufWriter::new(file);
    fill(&mut w)?;
    w.flush()?;
    drop(w);
    file.sync_all()
}

/// Each slot's file filled and flushed ([`fill_and_flush`]): the last here,
/// the others each on a thread of its own where the system grants one
/// ([`crate::threads::spawn_or_defer`]); the results in order.
fn fill_on_threads<F>(slots: &[std::sync::Mutex<Option<(File, F)>>]) -> Vec<std::io::Result<()>>
where
    F: FnOnce(&mut std::io::BufWriter<&File>) -> std::io::Result<()> + Send,
{
    let run = |slot: &std::sync::Mutex<Option<(File, F)>>| {
        let taken = slot.lock().ok().and_then(|mut s| s.take());
        taken.map_or(Ok(()), |(file, fill)| fill_and_flush(&file, fill))
    };
    let Some((last, others)) = slots.split_last() else {
        return Vec::new();
    };
    std::thread::scope(|s| {
        let jobs: Vec<_> = (others.iter())
            .map(|slot| crate::threads::spawn_or_defer(s, move || run(slot)))
            .collect();
        let last = run(last);
        (jobs.into_iter())
            .map(|job| job.join().unwrap_or_else(|p| std::panic::resume_unwind(p)))
            .chain([last])
            .collect()
    })
}

/// Write `rel` (a new name, or one this run owns) through a temporary file and a rename.
pub(super) fn write_new_then_rename(
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

#[cfg(test)]
mod tests {
    use super::*;

    fn folder(root: &Path) -> Folder {
        let mode = OpenMode {
            fresh_frames: 1,
            ..OpenMode::default()
        };
        Folder::open(root, 1, Some(1), mode, &[], &[])
            .expect("open")
            .0
    }

    type Fill = Box<dyn FnOnce(&mut std::io::BufWriter<&File>) -> std::io::Result<()> + Send>;

    fn files(fail: Option<usize>) -> Vec<(String, Fill)> {
        (0..3)
            .map(|k| {
                let fill: Fill = Box::new(move |out: &mut std::io::BufWriter<&File>| {
                    if fail == Some(k) {
                        return Err(std::io::Error::other("refused"));
                    }
                    write!(out, "file {k}")
                });
                (format!("end/f{k}.json"), fill)
            })
            .collect()
    }

    #[test]
    fn several_files_are_written_side_by_side_or_none_is() {
        let dir = tempfile::tempdir().expect("temp dir");
        let mut f = folder(dir.path());
        f.write_files_with(files(None)).expect("written");
        for k in 0..3 {
            let text = fs::read_to_string(dir.path().join(format!("end/f{k}.json")));
            assert_eq!(text.expect("read"), format!("file {k}"));
        }
        let other = tempfile::tempdir().expect("temp dir");
        let mut f = folder(other.path());
        let err = f.write_files_with(files(Some(1))).expect_err("refused");
        assert!(err.to_string().contains("f1.json"), "{err}");
        let left: Vec<_> = fs::read_dir(other.path().join("end"))
            .expect("end")
            .collect();
        assert!(left.is_empty(), "{left:?}");
    }
}
