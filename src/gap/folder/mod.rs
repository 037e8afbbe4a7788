//! The frames of a folder as `gap` (and `fit`) read them: the image files below it
//! ([`frames`]: never a gap report's own histograms), each one's YOLO label file and
//! its labels ([`labels`]: read with their limits — lines, bytes, values, classes,
//! coverage — in linear time), and which classes are drones (here).

mod frames;
mod labels;

pub(crate) use frames::{description_file, is_image, not_a_folder, walk};
pub use labels::{MAX_BOX_COVERAGE, MAX_LABEL_BYTES, MAX_LABEL_LINES, YOLO_TOLERANCE};
pub(crate) use labels::{label_for, read_labels};

use std::path::Path;

use super::error::GapError;

/// The YOLO classes whose rows a side's label files count as drones; rows of other
/// classes (birds, aircraft, …) are checked like any row and then left out.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub enum DroneClasses {
    /// Every row is a drone.
    #[default]
    All,
    /// Only rows of these classes (sorted, each once).
    Only(Vec<u64>),
}

/// The most class ids a `--classes` list may name.
pub const MAX_LISTED_CLASSES: usize = 1024;

impl DroneClasses {
    /// `all`, or class ids separated by commas (`0,2`): whole numbers ≥ 0, at most
    /// [`MAX_LISTED_CLASSES`]. The error says what is wrong, for the caller to name
    /// its option.
    pub fn parse(text: &str) -> Result<Self, String> {
        let text = text.trim();
        if text.eq_ignore_ascii_case("all") {
            return Ok(Self::All);
        }
        let mut ids = Vec::new();
        for part in text.split(',') {
            let part = part.trim();
            let id = part.parse::<u64>().map_err(|_| {
                format!("`{part}` is not a class id (a whole number ≥ 0; a list: 0,2; or all)")
            })?;
            ids.push(id);
            if ids.len() > MAX_LISTED_CLASSES {
                return Err(format!("more than {MAX_LISTED_CLASSES} class ids"));
            }
        }
        ids.sort_unstable();
        ids.dedup();
        Ok(Self::Only(ids))
    }

    /// Whether a row of `class` is a drone.
    pub fn contains(&self, class: u64) -> bool {
        match self {
            Self::All => true,
            Self::Only(ids) => ids.binary_search(&class).is_ok(),
        }
    }
}

impl std::fmt::Display for DroneClasses {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::All => f.write_str("all"),
            Self::Only(ids) => {
                let ids: Vec<String> = ids.iter().map(u64::to_string).collect();
                f.write_str(&ids.join(","))
            }
        }
    }
}

/// How many label rows of a side's files were of the drone classes and of others (the
/// first [`TALLY_CLASSES`] other classes kept, for the error that names them).
#[derive(Clone, Debug, Default)]
pub struct ClassTally {
    pub drone_rows: usize,
    pub other_rows: usize,
    pub other_classes: std::collections::BTreeSet<u64>,
    /// Rows of other classes than those kept were read.
    pub more_classes: bool,
}

/// The most other classes a [`ClassTally`] keeps.
const TALLY_CLASSES: usize = 8;

impl ClassTally {
    fn count(&mut self, class: u64, drone: bool) {
        if drone {
            self.drone_rows += 1;
            return;
        }
        self.other_rows += 1;
        if self.other_classes.len() < TALLY_CLASSES {
            self.other_classes.insert(class);
        } else if !self.other_classes.contains(&class) {
            self.more_classes = true;
        }
    }

    /// Refuses a class list that matched none of the rows read while rows of other
    /// classes were there (a list naming the wrong ids measures no drone at all). The
    /// reason is for the caller to name its option.
    pub fn check(&self, classes: &DroneClasses) -> Result<(), String> {
        if self.drone_rows > 0 || self.other_rows == 0 || *classes == DroneClasses::All {
            return Ok(());
        }
        let seen: Vec<String> = self.other_classes.iter().map(u64::to_string).collect();
        let more = if self.more_classes { ", …" } else { "" };
        Err(format!(
            "none of the {} label rows read is of these classes (the rows' classes: {}{more}): give the classes that are drones",
            self.other_rows,
            seen.join(", ")
        ))
    }
}

/// The classes of a swarmshot dataset's drones: the classes of its preset's models
/// (read from its `preset.lock.ron`), not those its labelled confusers (birds, aircraft)
/// add after them; every class when the folder has no lock (frames from elsewhere).
pub fn dataset_drone_classes(dir: &Path) -> Result<DroneClasses, GapError> {
    let lock = dir.join("preset.lock.ron");
    if lock_absent(&lock)? {
        return Ok(DroneClasses::All);
    }
    let bytes = crate::input::read_input_file(&lock, crate::preset::MAX_PRESET_BYTES).map_err(
        |source| GapError::Io {
            path: lock.clone(),
            source,
        },
    )?;
    let preset = std::str::from_utf8(&bytes)
        .map_err(|e| e.to_string())
        .and_then(|text| crate::preset::Preset::from_ron(text).map_err(|e| e.to_string()))
        .map_err(|e| {
            input(
                &lock,
                format!("not a preset swarmshot wrote ({e}); pass --synthetic-classes"),
            )
        })?;
    let (names, of_model) = preset.classes();
    let drones = of_model
        .iter()
        .take(preset.models.len())
        .max()
        .map_or(0, |m| m + 1);
    Ok(if drones >= names.len() {
        DroneClasses::All
    } else {
        DroneClasses::Only((0..drones as u64).collect())
    })
}

/// Whether a dataset has no `preset.lock.ron` at all; a link to nothing is refused (it
/// is no "frames from elsewhere": every class would silently count as a drone).
fn lock_absent(lock: &Path) -> Result<bool, GapError> {
    if std::fs::symlink_metadata(lock).is_err() {
        return Ok(true);
    }
    if lock.exists() {
        return Ok(false);
    }
    Err(input(
        lock,
        "a link to a file that does not exist; pass --synthetic-classes",
    ))
}

/// A named input error.
pub(super) fn input(path: &Path, reason: impl Into<String>) -> GapError {
    GapError::Input {
        path: path.to_path_buf(),
        reason: reason.into(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[cfg(unix)]
    #[test]
    fn a_dataset_lock_linked_to_nothing_is_refused_not_read_as_no_lock() {
        let dir = std::env::temp_dir().join(format!("swarmshot-lock-link-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("dir");
        assert_eq!(
            dataset_drone_classes(&dir).expect("no lock"),
            DroneClasses::All
        );
        std::os::unix::fs::symlink(dir.join("gone.ron"), dir.join("preset.lock.ron"))
            .expect("link");
        let e = dataset_drone_classes(&dir).expect_err("a link to nothing");
        assert!(e.to_string().contains("preset.lock.ron"), "{e}");
        assert!(
            e.to_string()
                .contains("a link to a file that does not exist"),
            "{e}"
        );
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn drone_classes_parse_and_pick_the_rows_of_their_classes() {
        assert_eq!(DroneClasses::parse(" all "), Ok(DroneClasses::All));
        let only = DroneClasses::parse("3, 0,3").expect("list");
        assert_eq!(only, DroneClasses::Only(vec![0, 3]));
        assert_eq!(only.to_string(), "0,3");
        for bad in ["", "0,", "-1", "1.5", "x", "0;1"] {
            let e = DroneClasses::parse(bad).expect_err(bad);
            assert!(e.contains("is not a class id"), "{bad}: {e}");
        }
        let many = vec!["1"; MAX_LISTED_CLASSES + 1].join(",");
        assert!(DroneClasses::parse(&many).is_err());
        let dir = tempfile::tempdir().expect("temp dir");
        let path = dir.path().join("a.txt");
        std::fs::write(
            &path,
            "0 0.5 0.5 0.5 0.5\n1 0.25 0.25 0.5 0.5\n3 0.75 0.75 0.5 0.5\n",
        )
        .expect("txt");
        let centres = |classes: &DroneClasses| -> Vec<f32> {
            let boxes =
                read_labels(&path, (64, 64), classes, &mut ClassTally::default()).expect("labels");
            boxes.iter().map(|b| (b.x0 + b.x1) * 0.5).collect()
        };
        assert_eq!(centres(&DroneClasses::All), [32.0, 16.0, 48.0]);
        assert_eq!(centres(&only), [32.0, 48.0]);
        assert!(centres(&DroneClasses::Only(vec![7])).is_empty());
        // A list matching none of the rows is refused, naming the rows' classes.
        let mut tally = ClassTally::default();
        read_labels(&path, (64, 64), &DroneClasses::Only(vec![7]), &mut tally).expect("labels");
        let e = tally
            .check(&DroneClasses::Only(vec![7]))
            .expect_err("no row of class 7");
        assert!(
            e.contains("none of the 3 label rows") && e.contains("classes: 0, 1, 3)"),
            "{e}"
        );
        let mut tally = ClassTally::default();
        read_labels(&path, (64, 64), &only, &mut tally).expect("labels");
        assert_eq!((tally.drone_rows, tally.other_rows), (2, 1));
        tally.check(&only).expect("rows of class 0 and 3 were read");
        ClassTally::default()
            .check(&only)
            .expect("no rows at all: nothing to say");
        // Eight other classes are listed; a ninth is said as "…".
        let mut tally = ClassTally::default();
        (10..18).for_each(|c| tally.count(c, false));
        let e = tally.check(&only).expect_err("eight classes");
        assert!(e.contains("14, 15, 16, 17)"), "{e}");
        tally.count(99, false);
        let e = tally.check(&only).expect_err("nine classes");
        assert!(e.contains("16, 17, …)"), "{e}");
        // A bad row of another class is still refused.
        std::fs::write(&path, "0 0.5 0.5 0.5 0.5\n1 0.25 0.25 0.5\n").expect("txt");
        let e =
            read_labels(&path, (64, 64), &only, &mut ClassTally::default()).expect_err("bad row");
        assert!(e.to_string().contains("line 2"), "{e}");
    }
}
