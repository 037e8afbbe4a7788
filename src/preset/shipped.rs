//! The presets shipped with swarmshot (`presets/` of its repository) and
//! where they are looked for: `presets/` in the working folder, then in the
//! repository this binary was built from. The app's Examples menu lists
//! them; `swarmshot fit` starts from `realistic.ron` unless given `--base`.

use std::path::{Path, PathBuf};

/// The folders looked in, in order.
pub fn dirs() -> [PathBuf; 2] {
    [
        PathBuf::from("presets"),
        Path::new(env!("CARGO_MANIFEST_DIR")).join("presets"),
    ]
}

/// The shipped preset file `name` (e.g. `realistic.ron`) from the first of
/// [`dirs`] that holds it.
pub fn find(name: &str) -> Option<PathBuf> {
    dirs()
        .into_iter()
        .map(|d| d.join(name))
        .find(|p| p.is_file())
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_repository_s_presets_are_found_from_any_folder() {
        // Tests run in the package's folder; the second place is that same
        // repository by its absolute path, so either finds it.
        let found = super::find("realistic.ron").expect("presets/realistic.ron is shipped");
        assert!(
            found.ends_with("presets/realistic.ron"),
            "{}",
            found.display()
        );
        assert!(super::find("no-such-preset.ron").is_none());
        assert!(super::dirs()[1].is_absolute());
    }
}
