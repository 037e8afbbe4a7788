//! One writer per folder: [`FolderLock`], an exclusive `flock` on `.swarmshot-lock`.

use super::*;

/// One writer per folder: an exclusive `flock` on `.swarmshot-lock` in the
/// folder, taken before anything else in it is read or written and held for
/// the whole run. The kernel releases it when the process ends, however it
/// ends, so a killed run never leaves the folder locked; the file holds the
/// holder's process id for the refusal's message. A run that ends deletes the
/// file while it still holds the lock (a run that opened the old file sees
/// it gone and tries again), so a finished folder holds no lock file; one
/// left by a killed run is taken over by the next.
///
/// On a file system without locks (`ENOLCK`, `EOPNOTSUPP`, `ENOSYS`: some
/// NFS and Lustre mounts) the run goes on with a warning, the rule then
/// being the user's, and the lock file is left in place.
pub struct FolderLock {
    pub(super) file: File,
    pub(super) tree: Tree,
    pub(super) held: bool,
}

impl FolderLock {
    /// Lock the folder `folder` opened (it exists), or say which process holds it.
    pub fn take(folder: &Tree) -> Result<Self, OutputError> {
        let root = folder.root();
        let path = root.join(LOCK);
        for _ in 0..8 {
            let mut tree = folder.try_clone()?;
            let fd = rustix::fs::openat(
                tree.fd(),
                LOCK,
                rustix::fs::OFlags::RDWR
                    | rustix::fs::OFlags::CREATE
                    | rustix::fs::OFlags::NOFOLLOW
                    | rustix::fs::OFlags::CLOEXEC
                    | rustix::fs::OFlags::NONBLOCK,
                rustix::fs::Mode::from_raw_mode(0o644),
            )
            .map_err(|e| match e {
                rustix::io::Errno::LOOP => link_refused(path.clone()),
                rustix::io::Errno::ISDIR => refused(path.clone(), "is not a regular file"),
                e => io(&path)(e.into()),
            })?;
            let file = File::from(fd);
            let seen = file.metadata().map_err(io(&path))?;
            if !seen.is_file() {
                return Err(refused(path, "is not a regular file"));
            }
            match file.try_lock() {
                Ok(()) => {}
                Err(fs::TryLockError::WouldBlock) => {
                    let mut text = String::new();
                    let _ = (&file).take(32).read_to_string(&mut text);
                    return Err(OutputError::InUse {
                        path: root.to_owned(),
                        lock: path,
                        pid: text.trim().parse().ok(),
                    });
                }
                Err(fs::TryLockError::Error(e)) if no_locks_here(&e) => {
                    eprintln!(
                        "warning: {}: this file system does not support locks ({e}); one writer per folder is not enforced here: run one swarmshot at a time into {}",
                        path.display(),
                        root.display()
                    );
                    return Ok(Self {
                        file,
                        tree,
                        held: false,
                    });
                }
                Err(fs::TryLockError::Error(e)) => return Err(io(&path)(e)),
            }
            // The file may have been deleted (or replaced) by the run that
            // held it between our open and our lock: then lock the new one.
            let now = tree.lstat(LOCK)?;
            if now.is_none_or(|e| (e.dev, e.ino) != (seen.dev(), seen.ino())) {
                continue;
            }
            if seen.nlink() != 1 {
                return Err(hard_link_refused(path, seen.nlink()));
            }
            if !holds_a_pid(&file) {
                return Err(refused(
                    path,
                    "is not swarmshot's lock file (a run's holds only its process id), so it is not taken over",
                ));
            }
            let pid = format!("{}\n", std::process::id());
            file.set_len(0)
                .and_then(|()| file.write_all_at(pid.as_bytes(), 0))
                .map_err(io(&path))?;
            return Ok(Self {
                file,
                tree,
                held: true,
            });
        }
        Err(refused(
            path,
            "keeps being replaced while swarmshot tries to lock it",
        ))
    }
}

impl Drop for FolderLock {
    fn drop(&mut self) {
        let ours = Tree::identity(&self.file);
        if self.held
            && self
                .tree
                .lstat(LOCK)
                .ok()
                .flatten()
                .is_some_and(|e| Some((e.dev, e.ino)) == ours)
        {
            let _ = self.tree.remove_file(LOCK);
        }
    }
}

/// Whether `file` is empty or holds what a run writes into its lock file,
/// a process id and a line end: what a killed run leaves is taken over, a
/// file of anyone else's at that name is not overwritten and deleted.
fn holds_a_pid(file: &File) -> bool {
    let mut text = Vec::new();
    if file.take(33).read_to_end(&mut text).is_err() || text.len() > 32 {
        return false;
    }
    let digits = text.strip_suffix(b"\n").unwrap_or(&text);
    digits.is_empty() == text.is_empty() && digits.iter().all(u8::is_ascii_digit)
}

/// The lock call failed because the file system has no locks, not because of a holder.
pub(super) fn no_locks_here(e: &std::io::Error) -> bool {
    use rustix::io::Errno;
    [Errno::NOLCK, Errno::OPNOTSUPP, Errno::NOSYS]
        .iter()
        .any(|n| e.raw_os_error() == Some(n.raw_os_error()))
}
