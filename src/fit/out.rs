//! The output folder (`--out`), opened once: every file `fit` writes (the plates, the
//! rounds' presets and reports, `footage.json`, `fitted.ron`, `fit.json`) is written
//! relative to a held folder handle ([`crate::write::outdir::OutDir`]) under a temporary
//! name and renamed into place, and every folder below `--out` is made and opened one
//! level at a time without following a link ([`Tree`]). A folder swapped for a symbolic
//! link while a run goes on cannot send a file outside `--out`: the write lands in the
//! folder that was opened, or the link is refused by name.
//!
//! `--overwrite` deletes only what `fit` wrote: `fitted.ron`, `footage.json`, `fit.json`;
//! in `plates/` each plate (an image beside its `.plate.ron` sidecar) and sidecar; in
//! `frames/` the video's `frame_NNNNN.png`; in `rounds/NN/` the round's preset and report
//! files, and in `rounds/NN/dataset/` the files its `.swarmshot-ledger` lists. Anything
//! else in `plates/`, `frames/` or `rounds/` is refused by name before anything is
//! deleted (those folders are read back as plates and frames); other entries beside them
//! at the top of `--out` are left as they are.

use std::collections::HashSet;
use std::os::fd::OwnedFd;
use std::path::{Path, PathBuf};

use super::FitError;
use crate::write::folder::tree::{Entry, Tree};
use crate::write::outdir::OutDir;

/// How deep a dataset's folders may nest before `--overwrite` refuses to walk on.
const MAX_DEPTH: usize = 16;

/// The files `fit` writes at the top of `--out`.
const TOP_FILES: [&str; 3] = ["fitted.ron", "footage.json", "fit.json"];

/// The output folder opened once (module docs).
pub struct FitOut {
    tree: Tree,
}

impl std::fmt::Debug for FitOut {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("FitOut")
            .field("root", &self.tree.root())
            .finish()
    }
}

fn out_err(e: crate::write::OutputError) -> FitError {
    FitError::Other(e.to_string())
}

fn not_fits(path: PathBuf, why: &str) -> FitError {
    FitError::NotFits {
        path,
        why: why.to_string(),
    }
}

/// A temporary file [`OutDir::write`] makes: `.NAME.PID.tmp`.
fn is_temp(name: &str) -> bool {
    let Some(inner) = name.strip_prefix('.').and_then(|n| n.strip_suffix(".tmp")) else {
        return false;
    };
    inner.rsplit_once('.').is_some_and(|(n, pid)| {
        !n.is_empty() && !pid.is_empty() && pid.bytes().all(|b| b.is_ascii_digit())
    })
}

fn digits(s: &str) -> bool {
    !s.is_empty() && s.bytes().all(|b| b.is_ascii_digit())
}

/// Whether `name` in `plates/` (whose names are `names`) is a plate or a sidecar.
fn is_plate(name: &str, names: &HashSet<&str>) -> bool {
    if name.ends_with(".plate.ron") {
        return true;
    }
    [".png", ".jpg"].iter().any(|ext| {
        name.strip_suffix(ext)
            .is_some_and(|stem| names.contains(format!("{stem}.plate.ron").as_str()))
    })
}

/// Whether `name` in `rounds/NN/` is a round's file.
fn is_round_file(name: &str) -> bool {
    matches!(
        name,
        "preset.ron" | "report.json" | "report.txt" | "contact_sheet.png"
    ) || (name.starts_with("hist_") && name.ends_with(".png"))
}

/// What `--overwrite` deletes: files, then folders (deepest first).
#[derive(Default)]
struct Plan {
    files: Vec<String>,
    dirs: Vec<String>,
}

impl FitOut {
    /// Opens `out` (created when missing): it must be missing or empty, or an earlier
    /// fit's with `overwrite`, whose own files are then deleted (module docs). Anything
    /// refused is refused before anything is deleted.
    pub fn open(out: &Path, overwrite: bool) -> Result<Self, FitError> {
        let not_empty = || FitError::OutNotEmpty {
            path: out.to_path_buf(),
        };
        match std::fs::metadata(out) {
            Ok(m) if !m.is_dir() => return Err(not_empty()),
            Ok(_) => {}
            Err(_) => std::fs::create_dir_all(out).map_err(super::io_err(out))?,
        }
        let mut tree = Tree::open(out).map_err(out_err)?;
        let top = tree.entries("").map_err(out_err)?;
        if top.is_empty() {
            return Ok(Self { tree });
        }
        let earlier_fit = top
            .iter()
            .any(|(n, e)| e.is_file() && (n == "fitted.ron" || n == "footage.json"));
        if !(overwrite && earlier_fit) {
            return Err(not_empty());
        }
        let mut plan = Plan::default();
        for (name, entry) in &top {
            let path = out.join(name);
            match name.as_str() {
                "plates" | "frames" | "rounds" if entry.is_dir() => {
                    plan_dir(&mut tree, name, &mut plan)?;
                    plan.dirs.push(name.clone());
                }
                "plates" | "frames" | "rounds" => {
                    return Err(not_fits(
                        path,
                        "is not the folder fit writes there (a link or a file); move it away first",
                    ));
                }
                n if entry.is_file() && (TOP_FILES.contains(&n) || is_temp(n)) => {
                    plan.files.push(name.clone());
                }
                _ => {}
            }
        }
        for f in &plan.files {
            tree.remove_file(f).map_err(out_err)?;
        }
        for d in &plan.dirs {
            tree.remove_dir_if_empty(d).map_err(out_err)?;
        }
        Ok(Self { tree })
    }

    /// The output folder's path.
    pub fn path(&self) -> &Path {
        self.tree.root()
    }

    /// Folder `rel` below `--out` (components separated by `/`), made when missing one
    /// level at a time without following a link, and opened: its files are then written
    /// relative to its handle.
    pub fn dir(&mut self, rel: &str) -> Result<OutDir, FitError> {
        let fd = self.dir_fd(rel)?;
        Ok(OutDir::from_tree(Tree::from_fd(
            self.tree.root().join(rel),
            fd,
        )))
    }

    fn dir_fd(&mut self, rel: &str) -> Result<OwnedFd, FitError> {
        let mut prefix = String::new();
        for part in rel.split('/').filter(|p| !p.is_empty()) {
            if !prefix.is_empty() {
                prefix.push('/');
            }
            prefix.push_str(part);
            self.tree.mkdir(&prefix).map_err(out_err)?;
        }
        self.tree
            .open_dir(rel)
            .map_err(out_err)?
            .ok_or_else(|| not_fits(self.tree.root().join(rel), "was removed while fit wrote"))
    }

    /// Writes `bytes` as the file `name` at the top of `--out`, atomically.
    pub fn write(&mut self, name: &str, bytes: &[u8]) -> Result<PathBuf, FitError> {
        OutDir::from_tree(self.tree.try_clone().map_err(out_err)?)
            .write(name, bytes)
            .map_err(out_err)
    }

    /// Folder `rel` made and opened as [`FitOut::dir`], for a writer that takes a path
    /// (the batch, ffmpeg): its path, checked to lead to the very folder opened, and its
    /// handle (for [`FitOut::check_same`] once the writer is done).
    pub fn dir_for_path(&mut self, rel: &str) -> Result<(PathBuf, OwnedFd), FitError> {
        let fd = self.dir_fd(rel)?;
        let path = self.tree.root().join(rel);
        self.check_same(&path, &fd)?;
        Ok((path, fd))
    }

    /// Refuses when `path` no longer leads to the folder `fd` holds, or when a folder
    /// opened below `--out` was replaced ([`Tree::verify`]): the run stops.
    pub fn check_same(&self, path: &Path, fd: &OwnedFd) -> Result<(), FitError> {
        self.tree.verify().map_err(out_err)?;
        let held = rustix::fs::fstat(fd).map(|st| (st.st_dev, st.st_ino));
        let named = rustix::fs::stat(path).map(|st| (st.st_dev, st.st_ino));
        match (held, named) {
            (Ok(a), Ok(b)) if a == b => Ok(()),
            _ => Err(not_fits(
                path.to_path_buf(),
                "was replaced while fit wrote into it (a link or another folder now stands there); the run stopped",
            )),
        }
    }

    /// Refuses when a folder opened below `--out` was replaced ([`Tree::verify`]).
    pub fn verify(&self) -> Result<(), FitError> {
        self.tree.verify().map_err(out_err)
    }

    /// Deletes the frames a video's decode wrote into `frames/` (ffmpeg's
    /// `frame_NNNNN.png` names only, any other entry left) and the folder when
    /// that empties it: a fit refused after the decode leaves `--out` as it found
    /// it (made empty, or emptied by `--overwrite`). Best effort: the refusal
    /// that called it is what the user sees.
    pub fn discard_frames(&mut self) {
        let Ok(entries) = self.tree.entries("frames") else {
            return;
        };
        for (name, entry) in &entries {
            let n = name
                .strip_prefix("frame_")
                .and_then(|n| n.strip_suffix(".png"));
            if entry.is_file() && n.is_some_and(|n| n.len() >= 5 && digits(n)) {
                let _ = self.tree.remove_file(&format!("frames/{name}"));
            }
        }
        let _ = self.tree.remove_dir_if_empty("frames");
    }
}

/// Adds fit's own files below folder `rel` (`plates`, `frames` or `rounds`) to `plan`,
/// refusing any other entry by name.
fn plan_dir(tree: &mut Tree, rel: &str, plan: &mut Plan) -> Result<(), FitError> {
    let entries = tree.entries(rel).map_err(out_err)?;
    let names: HashSet<&str> = entries.iter().map(|(n, _)| n.as_str()).collect();
    for (name, entry) in &entries {
        let sub = format!("{rel}/{name}");
        let path = tree.root().join(&sub);
        let ours = match rel {
            "plates" => entry.is_file() && (is_plate(name, &names) || is_temp(name)),
            "frames" => {
                let n = name
                    .strip_prefix("frame_")
                    .and_then(|n| n.strip_suffix(".png"));
                entry.is_file() && n.is_some_and(|n| n.len() >= 5 && digits(n))
            }
            _ if entry.is_dir() && rel == "rounds" && digits(name) => {
                plan_round(tree, &sub, plan)?;
                plan.dirs.push(sub);
                continue;
            }
            _ => false,
        };
        if !ours {
            return Err(refuse_entry(path, entry));
        }
        plan.files.push(sub);
    }
    Ok(())
}

fn refuse_entry(path: PathBuf, entry: &Entry) -> FitError {
    let why = if entry.is_symlink() {
        "is a symbolic link fit did not make; move it away first (--overwrite deletes only fit's own files and never follows a link)"
    } else {
        "was not written by fit; move it away first (--overwrite deletes only fit's own files, and fit reads this folder back)"
    };
    not_fits(path, why)
}

/// A round's folder `rel` (`rounds/NN`): its preset and report files, and its dataset.
fn plan_round(tree: &mut Tree, rel: &str, plan: &mut Plan) -> Result<(), FitError> {
    for (name, entry) in tree.entries(rel).map_err(out_err)? {
        let sub = format!("{rel}/{name}");
        let path = tree.root().join(&sub);
        if name == "dataset" && entry.is_dir() {
            let listed = crate::write::Folder::listed_files(&path).unwrap_or_default();
            plan_dataset(tree, &sub, "", &listed, 0, plan)?;
            plan.dirs.push(sub);
        } else if entry.is_file() && (is_round_file(&name) || is_temp(&name)) {
            plan.files.push(sub);
        } else {
            return Err(refuse_entry(path, &entry));
        }
    }
    Ok(())
}

/// The files below a round's dataset (`root`, at `rel` inside it) that its ledger lists,
/// with the ledger and the lock; anything else refused.
fn plan_dataset(
    tree: &mut Tree,
    root: &str,
    rel: &str,
    listed: &std::collections::BTreeSet<String>,
    depth: usize,
    plan: &mut Plan,
) -> Result<(), FitError> {
    let here = if rel.is_empty() {
        root.to_string()
    } else {
        format!("{root}/{rel}")
    };
    for (name, entry) in tree.entries(&here).map_err(out_err)? {
        let inner = if rel.is_empty() {
            name.clone()
        } else {
            format!("{rel}/{name}")
        };
        let sub = format!("{root}/{inner}");
        let path = tree.root().join(&sub);
        if entry.is_dir() && depth < MAX_DEPTH {
            plan_dataset(tree, root, &inner, listed, depth + 1, plan)?;
            plan.dirs.push(sub);
            continue;
        }
        let own = listed.contains(&inner)
            || (rel.is_empty()
                && [crate::write::folder::LEDGER, crate::write::folder::LOCK]
                    .contains(&name.as_str()));
        if !(entry.is_file() && own) {
            return Err(refuse_entry(path, &entry));
        }
        plan.files.push(sub);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_fits_own_names_are_its_own() {
        assert!(is_temp(".fitted.ron.1234.tmp"));
        assert!(!is_temp(".fitted.ron.tmp") && !is_temp("notes.1.tmp") && !is_temp("..1.tmp"));
        let names: HashSet<&str> = [
            "a.png",
            "a.plate.ron",
            "b.jpg",
            "c__v1.jpg",
            "c__v1.plate.ron",
        ]
        .into_iter()
        .collect();
        assert!(is_plate("a.png", &names) && is_plate("a.plate.ron", &names));
        assert!(is_plate("c__v1.jpg", &names));
        assert!(
            !is_plate("b.jpg", &names),
            "an image without its sidecar is not a plate"
        );
        assert!(is_round_file("hist_noise_sigma.png") && !is_round_file("notes.txt"));
    }
}
