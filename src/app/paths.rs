//! Paths as the user reads them (issue 40): `presets/../tests/data/plates` is shown as
//! `tests/data/plates`, and a folder chosen with Browse… is stored relative to the
//! preset's folder, as preset paths are read ([`crate::preset::Preset::resolve_paths`]).
//!
//! [`lexical`] and [`relative_to`] touch no file system (links not followed); they
//! work on [`Path::components`], which already drops `.` and repeated separators.

use std::path::{Component, Path, PathBuf};

/// `path` with each `name/..` pair removed; a leading `..` (or one after the root,
/// which stays at the root) is kept as written.
pub fn lexical(path: &Path) -> PathBuf {
    let mut out: Vec<Component<'_>> = Vec::new();
    for c in path.components() {
        match c {
            Component::CurDir => {}
            Component::ParentDir => match out.last() {
                Some(Component::Normal(_)) => {
                    out.pop();
                }
                Some(Component::RootDir | Component::Prefix(_)) => {}
                _ => out.push(c),
            },
            _ => out.push(c),
        }
    }
    if out.is_empty() {
        return PathBuf::from(".");
    }
    out.iter().collect()
}

/// How `path` reads from the folder `base`: relative when both are relative or both
/// absolute (`..` steps where it lies outside), else `path` itself; both made lexical.
pub fn relative_to(path: &Path, base: &Path) -> PathBuf {
    let (path, base) = (lexical(path), lexical(base));
    if path.is_absolute() != base.is_absolute() {
        return path;
    }
    let base_parts: Vec<Component<'_>> = base
        .components()
        .filter(|c| *c != Component::CurDir)
        .collect();
    let path_parts: Vec<Component<'_>> = path.components().collect();
    if base_parts.contains(&Component::ParentDir) {
        // A base above the working folder: its names are unknown here.
        return path;
    }
    let common = base_parts
        .iter()
        .zip(&path_parts)
        .take_while(|(a, b)| a == b)
        .count();
    let mut out = PathBuf::new();
    for _ in common..base_parts.len() {
        out.push("..");
    }
    for c in &path_parts[common..] {
        out.push(c);
    }
    if out.as_os_str().is_empty() {
        PathBuf::from(".")
    } else {
        out
    }
}

/// A chosen folder as a preset stores it: relative to the preset's folder `base`
/// (the working folder when the preset has no file). Both are compared as the file
/// system names them (links resolved) where they exist, so a dialog's canonical answer and a preset opened by another name agree.
pub fn for_preset(chosen: &Path, base: &Path) -> PathBuf {
    let cwd = std::env::current_dir().unwrap_or_default();
    let absolute = |p: &Path| {
        std::fs::canonicalize(p).unwrap_or_else(|_| {
            if p.is_absolute() {
                p.to_owned()
            } else {
                cwd.join(p)
            }
        })
    };
    relative_to(&absolute(chosen), &absolute(base))
}

/// A folder typed into one of the app's fields, as a shell would read it: trimmed, and
/// a leading `~` (alone or before `/`) standing for the home folder, so `~/data` is not a
/// folder named `~` in the working folder.
pub fn typed(text: &str) -> PathBuf {
    let text = text.trim();
    let rest = match text.strip_prefix('~') {
        Some("") => Some(""),
        Some(rest) => rest.strip_prefix('/'),
        None => None,
    };
    match (rest, dirs::home_dir()) {
        (Some(rest), Some(home)) => home.join(rest),
        _ => PathBuf::from(text),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_typed_tilde_is_the_home_folder() {
        let home = dirs::home_dir().expect("a home folder");
        assert_eq!(typed(" ~/data "), home.join("data"));
        assert_eq!(typed("~"), home);
        assert_eq!(typed("~user/data"), Path::new("~user/data"));
        assert_eq!(typed("a/~/b"), Path::new("a/~/b"));
        assert_eq!(typed(" out "), Path::new("out"));
    }

    #[test]
    fn lexical_removes_dots_and_name_parent_pairs() {
        assert_eq!(
            lexical(Path::new("presets/../tests/data/plates")),
            Path::new("tests/data/plates")
        );
        assert_eq!(lexical(Path::new("./a/./b/")), Path::new("a/b"));
        assert_eq!(lexical(Path::new("../a/../../b")), Path::new("../../b"));
        assert_eq!(lexical(Path::new("/../a")), Path::new("/a"));
        assert_eq!(lexical(Path::new("a/..")), Path::new("."));
    }

    #[test]
    fn relative_to_walks_up_and_down() {
        assert_eq!(
            relative_to(Path::new("/w/tests/data/plates"), Path::new("/w/presets")),
            Path::new("../tests/data/plates")
        );
        assert_eq!(
            relative_to(Path::new("presets/plates"), Path::new("presets")),
            Path::new("plates")
        );
        assert_eq!(
            relative_to(Path::new("/a/b"), Path::new("rel")),
            Path::new("/a/b")
        );
        assert_eq!(
            relative_to(Path::new("/a"), Path::new("/a")),
            Path::new(".")
        );
    }

    #[test]
    fn a_chosen_folder_reads_from_the_presets_folder() {
        let cwd = std::env::current_dir().unwrap_or_default();
        assert_eq!(
            for_preset(&cwd.join("tests/data/plates"), Path::new("presets")),
            Path::new("../tests/data/plates")
        );
        assert_eq!(
            for_preset(
                Path::new("presets/../tests/data/plates"),
                Path::new("presets")
            ),
            Path::new("../tests/data/plates")
        );
    }
}
