//! The paths a preset reads, as its file wrote them: what a run's
//! `preset.lock.ron` holds, so the lock (and the hash that names the run) is
//! the same bytes wherever the preset was named from.

use std::path::{Path, PathBuf};

use super::Preset;

/// Each path [`Preset::resolve_paths`] joined to the preset file's folder,
/// beside the path as the file wrote it. Not part of the preset's value:
/// presets equal in every field are equal wherever their files were read from.
#[derive(Clone, Debug, Default)]
pub struct WrittenPaths(Vec<(PathBuf, PathBuf)>);

impl PartialEq for WrittenPaths {
    fn eq(&self, _: &Self) -> bool {
        true
    }
}

impl WrittenPaths {
    /// The path as the preset's file wrote it, for a path `resolve_paths` made.
    fn original(&self, resolved: &Path) -> Option<&Path> {
        self.0
            .iter()
            .find(|(r, _)| r == resolved)
            .map(|(_, written)| written.as_path())
    }
}

impl Preset {
    /// The files and folders the preset reads ([`Preset::input_paths`])
    /// resolved against the directory of the preset file; each relative one
    /// is remembered as written, for [`Preset::lock_text`].
    pub fn resolve_paths(&mut self, base_dir: &Path) {
        let mut written = std::mem::take(&mut self.written_paths);
        for (_, path) in self.input_paths_mut() {
            if path.is_relative() {
                let resolved = base_dir.join(&*path);
                let original = written
                    .original(path)
                    .map_or_else(|| path.clone(), Path::to_path_buf);
                written.0.push((resolved.clone(), original));
                *path = resolved;
            }
        }
        self.written_paths = written;
    }

    /// Each relative path the preset reads replaced with `rebase` of it (the app's Save
    /// As into another folder: the same files, read from the new file's folder).
    pub fn rebase_relative_paths(&mut self, mut rebase: impl FnMut(&Path) -> PathBuf) {
        for (_, path) in self.input_paths_mut() {
            if path.is_relative() {
                *path = rebase(path);
            }
        }
    }

    /// The text of a run's `preset.lock.ron`, whose hash names the run:
    /// [`Preset::to_ron`] with each path the preset reads as the preset's
    /// file wrote it, so the lock is the same bytes whether the preset was
    /// run as `p.ron`, `presets/p.ron` or by its absolute path, from any
    /// folder. A path changed since it was resolved (in the app) is written
    /// as it is now.
    pub fn lock_text(&self) -> String {
        if self.written_paths.0.is_empty() {
            return self.to_ron();
        }
        let mut locked = self.clone();
        for (_, path) in locked.input_paths_mut() {
            if let Some(original) = self.written_paths.original(path) {
                *path = original.to_path_buf();
            }
        }
        locked.to_ron()
    }
}
