//! The frames of a folder as `gap` (and `fit`) read them: the image files below it
//! (never a gap report's own histograms), each one's YOLO label file, and the labels
//! read with their limits (lines, bytes, values, classes, coverage), in linear time.

use std::path::{Path, PathBuf};

use super::error::GapError;
use super::measure::PixelBox;

/// Deepest folder level walked below a side's root.
pub(crate) const MAX_DEPTH: usize = 8;
/// The most lines a label file may have (a frame with 10⁵ labelled drones is not a
/// frame of a swarm but a broken file; reading stops at the limit).
pub const MAX_LABEL_LINES: usize = 100_000;
/// The largest label file read.
pub const MAX_LABEL_BYTES: u64 = 16 << 20;
/// How far outside [0, 1] a normalised YOLO value may lie (rounding by exporters).
pub const YOLO_TOLERANCE: f32 = 1e-3;
/// The most times over a frame's labelled boxes may cover it (their summed area over
/// the frame's): the per-drone measurements cost the boxes' area, so this bounds a
/// frame's work; no frame of drones comes near it.
pub const MAX_BOX_COVERAGE: f64 = 16.0;

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

/// A JPEG or PNG file name.
pub(crate) fn is_image(p: &Path) -> bool {
    p.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| matches!(e.to_ascii_lowercase().as_str(), "jpg" | "jpeg" | "png"))
}

/// Whether `dir` holds a gap report (`report.json` and `report.txt`): its
/// histogram PNGs are gap's own output, not frames.
fn is_report_folder(dir: &Path) -> bool {
    dir.join("report.json").is_file() && dir.join("report.txt").is_file()
}

pub(crate) fn walk(dir: &Path, depth: usize, out: &mut Vec<PathBuf>) -> Result<(), GapError> {
    if is_report_folder(dir) {
        return Ok(());
    }
    let rd = std::fs::read_dir(dir).map_err(|source| GapError::Io {
        path: dir.to_path_buf(),
        source,
    })?;
    for e in rd {
        let e = e.map_err(|source| GapError::Io {
            path: dir.to_path_buf(),
            source,
        })?;
        let p = e.path();
        if e.file_name().to_string_lossy().starts_with('.') {
            continue;
        }
        let ft = e.file_type().map_err(|source| GapError::Io {
            path: p.clone(),
            source,
        })?;
        if ft.is_dir() {
            if depth < MAX_DEPTH {
                walk(&p, depth + 1, out)?;
            }
        } else if ft.is_file() && is_image(&p) {
            out.push(p);
        }
    }
    Ok(())
}

/// The label file of an image: under a sibling `labels/` folder (the last `images`
/// component of its path below `root` replaced by `labels`), else beside it; `.txt`.
/// `None` when neither exists; something other than a file at the first name
/// that exists (a FIFO, a folder, a device) is refused by name, looked at
/// without being opened (opening a FIFO would block).
pub(crate) fn label_for(root: &Path, image: &Path) -> Result<Option<PathBuf>, GapError> {
    let Ok(rel) = image.strip_prefix(root) else {
        return Ok(None);
    };
    let comps: Vec<_> = rel.components().collect();
    let mut candidates = Vec::new();
    let root_is_images = root.file_name().is_some_and(|n| n == "images");
    if let Some(i) = comps.iter().rposition(|c| c.as_os_str() == "images") {
        let mut p = root.to_path_buf();
        for (j, c) in comps.iter().enumerate() {
            p.push(if j == i {
                "labels".as_ref()
            } else {
                c.as_os_str()
            });
        }
        candidates.push(p.with_extension("txt"));
    } else if root_is_images && let Some(parent) = root.parent() {
        candidates.push(parent.join("labels").join(rel).with_extension("txt"));
    }
    candidates.push(image.with_extension("txt"));
    for p in candidates {
        match std::fs::metadata(&p) {
            Ok(meta) if meta.is_file() => return Ok(Some(p)),
            Ok(meta) => {
                let kind = crate::input::file_kind(&meta);
                return Err(input(&p, format!("is {kind}, not a label file")));
            }
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
            Err(source) => return Err(GapError::Io { path: p, source }),
        }
    }
    Ok(None)
}

/// YOLO rows `class cx cy w h` (normalised) → pixel boxes. At most
/// [`MAX_LABEL_LINES`] lines and [`MAX_LABEL_BYTES`]; the class a whole number ≥ 0, the
/// four values finite and within [0, 1] (± [`YOLO_TOLERANCE`]); the boxes' summed area
/// at most [`MAX_BOX_COVERAGE`] frames. Only rows of `classes` become boxes (every row
/// is checked), each row counted in `tally`.
pub(crate) fn read_labels(
    path: &Path,
    (w, h): (u32, u32),
    classes: &DroneClasses,
    tally: &mut ClassTally,
) -> Result<Vec<PixelBox>, GapError> {
    let bytes =
        crate::input::read_input_file(path, MAX_LABEL_BYTES).map_err(|source| GapError::Io {
            path: path.to_path_buf(),
            source,
        })?;
    let text = String::from_utf8(bytes).map_err(|e| {
        input(
            path,
            format!("is not UTF-8 text (byte {})", e.utf8_error().valid_up_to()),
        )
    })?;
    // Counted before any line is parsed, so the limit is the first thing said.
    if text.lines().nth(MAX_LABEL_LINES).is_some() {
        return Err(input(
            path,
            format!("more than the {MAX_LABEL_LINES}-line limit for a label file"),
        ));
    }
    let mut out = Vec::new();
    let mut coverage = 0f64;
    for (i, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let bad = |reason: String| GapError::Label {
            path: path.to_path_buf(),
            line: i + 1,
            reason,
        };
        let f: Vec<&str> = line.split_whitespace().collect();
        if f.len() != 5 {
            return Err(bad(format!(
                "expected 5 fields `class cx cy w h`, found {}",
                f.len()
            )));
        }
        let class = f[0]
            .parse::<f64>()
            .ok()
            .filter(|c| c.is_finite() && *c >= 0.0 && c.fract() == 0.0 && *c <= 1e9)
            .ok_or_else(|| bad(format!("class `{}` is not a whole number ≥ 0", f[0])))?;
        // Read as f64 and range-checked before the f32 they are kept as, so
        // a number beyond f32's range (`1e300`) is named as out of range.
        let mut wide = [0f64; 4];
        for (k, s) in f[1..].iter().enumerate() {
            wide[k] = s
                .parse::<f64>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or_else(|| bad(format!("`{s}` is not a number")))?;
        }
        if wide[2] < 0.0 || wide[3] < 0.0 {
            return Err(bad("negative box width or height".into()));
        }
        let range = f64::from(-YOLO_TOLERANCE)..=f64::from(1.0 + YOLO_TOLERANCE);
        for ((name, x), s) in ["cx", "cy", "w", "h"].iter().zip(wide).zip(&f[1..]) {
            if !range.contains(&x) {
                return Err(bad(format!(
                    "{name} {s} is outside [0, 1]: YOLO values are fractions of the frame"
                )));
            }
        }
        let v = wide.map(|x| x as f32);
        let drone = classes.contains(class as u64);
        tally.count(class as u64, drone);
        if !drone {
            continue;
        }
        coverage += f64::from(v[2].min(1.0)) * f64::from(v[3].min(1.0));
        if coverage > MAX_BOX_COVERAGE {
            return Err(bad(format!(
                "the boxes so far cover the frame more than {MAX_BOX_COVERAGE} times over (their summed area): duplicated or corrupt labels?"
            )));
        }
        let (wf, hf) = (w as f32, h as f32);
        out.push(PixelBox {
            x0: (v[0] - 0.5 * v[2]) * wf,
            x1: (v[0] + 0.5 * v[2]) * wf,
            y0: (v[1] - 0.5 * v[3]) * hf,
            y1: (v[1] + 0.5 * v[3]) * hf,
        });
    }
    Ok(out)
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

    #[test]
    fn a_value_beyond_f32_is_out_of_range_not_not_a_number() {
        let dir = tempfile::tempdir().expect("temp dir");
        let path = dir.path().join("a.txt");
        let refused = |row: &str| -> String {
            std::fs::write(&path, row).expect("txt");
            let mut tally = ClassTally::default();
            (read_labels(&path, (64, 64), &DroneClasses::All, &mut tally).expect_err(row))
                .to_string()
        };
        let err = refused("0 1e300 0.5 0.1 0.1\n");
        assert!(err.contains("cx 1e300 is outside [0, 1]"), "{err}");
        let err = refused("0 0.5 0.5 0.1 -1e300\n");
        assert!(err.contains("negative box width or height"), "{err}");
        let err = refused("0 0.5 0.5 0.1 NaN\n");
        assert!(err.contains("`NaN` is not a number"), "{err}");
    }

    #[test]
    fn a_fifo_or_folder_at_a_label_name_is_refused_by_name() {
        let dir = tempfile::tempdir().expect("temp dir");
        let root = dir.path();
        std::fs::create_dir_all(root.join("images")).expect("images");
        std::fs::create_dir_all(root.join("labels")).expect("labels");
        let image = root.join("images/a.png");
        assert!(label_for(root, &image).expect("none").is_none());
        // A folder at the label's name.
        std::fs::create_dir(root.join("labels/a.txt")).expect("dir");
        let err = label_for(root, &image).expect_err("folder").to_string();
        assert!(
            err.contains("labels/a.txt") && err.contains("a folder"),
            "{err}"
        );
        std::fs::remove_dir(root.join("labels/a.txt")).expect("rmdir");
        // A FIFO: named without being opened (an open would block).
        rustix::fs::mknodat(
            rustix::fs::CWD,
            root.join("labels/a.txt").as_path(),
            rustix::fs::FileType::Fifo,
            rustix::fs::Mode::from_raw_mode(0o644),
            0,
        )
        .expect("mkfifo");
        let err = label_for(root, &image).expect_err("fifo").to_string();
        assert!(
            err.contains("labels/a.txt") && err.contains("FIFO"),
            "{err}"
        );
        std::fs::remove_file(root.join("labels/a.txt")).expect("rm");
        std::fs::write(root.join("labels/a.txt"), "").expect("txt");
        assert_eq!(
            label_for(root, &image).expect("file"),
            Some(root.join("labels/a.txt"))
        );
    }
}
