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

/// What a dataset's description file given where a folder of frames belongs is, and
/// where the frames are, by its extension: an Ultralytics `data.yaml` is what a YOLO
/// user passes to everything else. `None` for any other file.
pub(crate) fn description_file(p: &Path) -> Option<String> {
    let ext = p.extension()?.to_str()?.to_ascii_lowercase();
    let kind = match ext.as_str() {
        "yaml" | "yml" => "a dataset description (Ultralytics' data.yaml)",
        "txt" => "a text file (a list of frames, or labels)",
        "json" => "a JSON file (COCO annotations)",
        "xml" => "an XML file (VOC or CVAT annotations)",
        _ => return None,
    };
    let folder = match p.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.display().to_string(),
        _ => ".".into(),
    };
    Some(format!(
        "{kind}, not footage: give the folder that holds the frames, e.g. the dataset's root {folder} (images/ and labels/ in it) or one split's images/train"
    ))
}

/// The refusal of a `--real` (or `--synthetic`) that is not a folder.
pub(crate) fn not_a_folder(p: &Path) -> GapError {
    let described = p.is_file().then(|| what_file(p)).flatten();
    input(p, described.unwrap_or_else(|| "not a folder".into()))
}

/// What a file given where a folder of frames belongs is, when its name says.
fn what_file(p: &Path) -> Option<String> {
    if is_image(p) {
        return Some("a single image, not a folder: give the folder that holds the frames".into());
    }
    if is_video(p) {
        return Some(
            "a video, not a folder: the report reads frames; take them out first (ffmpeg -i VIDEO -vf fps=2 FRAMES/%05d.png), or fit to the video with swarmshot fit".into(),
        );
    }
    description_file(p)
}

/// Whether a file's name is a video's.
fn is_video(p: &Path) -> bool {
    (p.extension().and_then(|e| e.to_str()))
        .is_some_and(|e| VIDEO_EXTENSIONS.contains(&e.to_ascii_lowercase().as_str()))
}

/// The extensions of the video files footage comes in.
const VIDEO_EXTENSIONS: [&str; 9] = [
    "mp4", "avi", "mov", "mkv", "m4v", "mpg", "mpeg", "ts", "webm",
];

/// Whether `dir` holds a gap report (`report.json` and `report.txt`): its
/// histogram PNGs are gap's own output, not frames.
fn is_report_folder(dir: &Path) -> bool {
    dir.join("report.json").is_file() && dir.join("report.txt").is_file()
}

/// The image formats real footage comes in that are not read, by extension, with the
/// name said when one is found: skipping them would measure a part of the footage only.
const UNREAD_FORMATS: [(&str, &str); 8] = [
    ("bmp", "a BMP"),
    ("webp", "a WebP"),
    ("tif", "a TIFF"),
    ("tiff", "a TIFF"),
    ("gif", "a GIF"),
    ("heic", "a HEIC"),
    ("avif", "an AVIF"),
    ("jp2", "a JPEG 2000"),
];

/// The kind of image a file name says that is not read (`None`: a JPEG or PNG, or no image).
fn unread_format(p: &Path) -> Option<&'static str> {
    let ext = p.extension()?.to_str()?.to_ascii_lowercase();
    UNREAD_FORMATS
        .iter()
        .find(|(e, _)| *e == ext)
        .map(|(_, kind)| *kind)
}

/// The image files below `dir` (at most [`MAX_DEPTH`] levels; hidden names, such as
/// macOS's `._NAME.jpg` and `.DS_Store`, and gap reports skipped). Links are followed,
/// to files and to folders (a dataset linked in from another disk), each folder walked
/// once (a link back up the tree adds nothing); a link to nothing named as an image is
/// refused. An image in a format not read ([`UNREAD_FORMATS`]) is refused by name when
/// it is footage: labelled, beside JPEG or PNG frames, or the only images there are
/// (skipping it would measure a part of the footage); elsewhere (a dataset's
/// `assets/demo.gif`) it is skipped.
pub(crate) fn walk(dir: &Path, depth: usize, out: &mut Vec<PathBuf>) -> Result<(), GapError> {
    let mut state = Walk {
        root: dir,
        walked: std::collections::HashSet::new(),
        unread: None,
        video: None,
    };
    walk_once(dir, depth, out, &mut state)?;
    if !out.is_empty() {
        return Ok(());
    }
    match (state.unread, state.video) {
        (Some(p), _) => Err(unread(&p)),
        (None, Some(v)) => Err(input(
            &v,
            "a video in a folder without frames: give the video itself as --real to swarmshot fit, or take its frames out first (ffmpeg -i VIDEO -vf fps=2 FRAMES/%05d.png)",
        )),
        (None, None) => Ok(()),
    }
}

/// What a [`walk`] keeps across folders.
struct Walk<'a> {
    root: &'a Path,
    /// The folders walked, canonical.
    walked: std::collections::HashSet<PathBuf>,
    /// The first image in a format not read that was skipped.
    unread: Option<PathBuf>,
    /// The first video file seen (named when the folder has no frame at all).
    video: Option<PathBuf>,
}

fn walk_once(
    dir: &Path,
    depth: usize,
    out: &mut Vec<PathBuf>,
    state: &mut Walk,
) -> Result<(), GapError> {
    let io = |path: &Path| {
        let path = path.to_path_buf();
        move |source| GapError::Io { path, source }
    };
    if is_report_folder(dir) || !state.walked.insert(dir.canonicalize().map_err(io(dir))?) {
        return Ok(());
    }
    let (mut frames_here, mut unread_here) = (false, None);
    for e in std::fs::read_dir(dir).map_err(io(dir))? {
        let p = e.map_err(io(dir))?.path();
        if p.file_name()
            .is_some_and(|n| n.to_string_lossy().starts_with('.'))
        {
            continue;
        }
        let Some(meta) = followed_metadata(&p)? else {
            continue;
        };
        if meta.is_dir() {
            if depth < MAX_DEPTH {
                walk_once(&p, depth + 1, out, state)?;
            }
        } else if meta.is_file() && is_image(&p) {
            out.push(p);
            frames_here = true;
        } else if meta.is_file() && unread_format(&p).is_some() {
            if label_for(state.root, &p)?.is_some() {
                return Err(unread(&p));
            }
            unread_here.get_or_insert(p);
        } else if meta.is_file() && is_video(&p) {
            state.video.get_or_insert(p);
        }
    }
    match unread_here {
        Some(p) if frames_here => Err(unread(&p)),
        Some(p) => {
            state.unread.get_or_insert(p);
            Ok(())
        }
        None => Ok(()),
    }
}

/// The refusal of an image in a format not read.
fn unread(p: &Path) -> GapError {
    let kind = unread_format(p).unwrap_or("an");
    input(
        p,
        format!(
            "{kind} image; frames are read as JPEG or PNG: convert them (ffmpeg -i NAME NAME.png; their labels stay valid) or move them out of the folder"
        ),
    )
}

/// `p`'s metadata, a link followed; `None` for a link to nothing unless its name is an
/// image's (then refused: a frame the footage lost).
fn followed_metadata(p: &Path) -> Result<Option<std::fs::Metadata>, GapError> {
    match std::fs::metadata(p) {
        Ok(meta) => Ok(Some(meta)),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            if is_image(p) {
                return Err(input(p, "a link to a file that does not exist"));
            }
            Ok(None)
        }
        Err(source) => Err(GapError::Io {
            path: p.to_path_buf(),
            source,
        }),
    }
}

/// The label file of an image, as Ultralytics finds it: the last `images` folder of
/// the image's path replaced by `labels` (so a dataset's root, its `images/` or one
/// split's `images/train/` finds `labels/train/NAME.txt`), else beside the image;
/// `.txt`. `None` when neither exists; something other than a file at the first name
/// that exists (a FIFO, a folder, a device) is refused by name, looked at
/// without being opened (opening a FIFO would block).
pub(crate) fn label_for(root: &Path, image: &Path) -> Result<Option<PathBuf>, GapError> {
    let mut candidates: Vec<PathBuf> = labels_twin(image)
        .or_else(|| labels_twin(&canonical_twin(root, image)?))
        .into_iter()
        .collect();
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

/// `image` with the last `images` folder of its path replaced by `labels`, `.txt`.
fn labels_twin(image: &Path) -> Option<PathBuf> {
    let folders: Vec<_> = image.parent()?.components().collect();
    let i = folders.iter().rposition(|c| c.as_os_str() == "images")?;
    let mut p = PathBuf::new();
    for (j, c) in folders.iter().enumerate() {
        p.push(if j == i {
            "labels".as_ref()
        } else {
            c.as_os_str()
        });
    }
    Some(p.join(image.file_name()?).with_extension("txt"))
}

/// `image` under `root` resolved to its full path, for a root given as `.` or by a
/// name that does not show its `images` folder.
fn canonical_twin(root: &Path, image: &Path) -> Option<PathBuf> {
    let rel = image.strip_prefix(root).ok()?;
    Some(root.canonicalize().ok()?.join(rel))
}

/// YOLO label rows → pixel boxes. A row is `class cx cy w h` (a box), the same with a
/// sixth confidence column (a YOLO prediction file), or `class x1 y1 x2 y2 …` with three
/// points or more (a segmentation polygon or an oriented box's four corners, optionally
/// followed by a confidence), whose axis-aligned bounding box is taken. Values are
/// normalised; the class a whole number ≥ 0 (`0.0` too). A UTF-8 byte-order mark,
/// CRLF or CR line ends, blank lines and `#` comments are allowed. At most
/// [`MAX_LABEL_LINES`] lines and [`MAX_LABEL_BYTES`]; every value finite and within
/// [0, 1] (± [`YOLO_TOLERANCE`]); the boxes' summed area at most [`MAX_BOX_COVERAGE`]
/// frames. As Ultralytics loads them, boxes are clipped to the frame, and those of no
/// area and exact repeats of a row are dropped. Only rows of `classes` become boxes
/// (every row is checked), each row counted in `tally`.
pub(crate) fn read_labels(
    path: &Path,
    (w, h): (u32, u32),
    classes: &DroneClasses,
    tally: &mut ClassTally,
) -> Result<Vec<PixelBox>, GapError> {
    let text = read_label_text(path)?;
    let mut out = Vec::new();
    let mut seen = std::collections::HashSet::new();
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
        let fields: Vec<&str> = line.split_whitespace().collect();
        let (class, b) = parse_row(&fields).map_err(bad)?;
        // A row repeated exactly is one drone labelled twice (Ultralytics drops it too).
        if !seen.insert((class, b.map(f64::to_bits))) {
            continue;
        }
        let drone = classes.contains(class);
        tally.count(class, drone);
        if !drone {
            continue;
        }
        let Some(pixels) = clipped(b, (w, h)) else {
            continue;
        };
        coverage += (b[2] - b[0]).min(1.0) * (b[3] - b[1]).min(1.0);
        if coverage > MAX_BOX_COVERAGE {
            return Err(bad(format!(
                "the boxes so far cover the frame more than {MAX_BOX_COVERAGE} times over (their summed area): duplicated or corrupt labels?"
            )));
        }
        out.push(pixels);
    }
    Ok(out)
}

/// A label file's text within [`MAX_LABEL_BYTES`] and [`MAX_LABEL_LINES`], its
/// byte-order mark taken off and CR line ends (old Mac editors) made LF.
fn read_label_text(path: &Path) -> Result<String, GapError> {
    let bytes =
        crate::input::read_input_file(path, MAX_LABEL_BYTES).map_err(|source| GapError::Io {
            path: path.to_path_buf(),
            source,
        })?;
    // Windows Notepad's "Unicode" is UTF-16, which starts with its byte-order mark.
    if bytes.starts_with(&[0xFF, 0xFE]) || bytes.starts_with(&[0xFE, 0xFF]) {
        return Err(input(path, "is UTF-16 text: save it as UTF-8"));
    }
    let text = String::from_utf8(bytes).map_err(|e| {
        input(
            path,
            format!("is not UTF-8 text (byte {})", e.utf8_error().valid_up_to()),
        )
    })?;
    // Windows editors write a byte-order mark, which would stick to the first class.
    let text = text.strip_prefix('\u{feff}').unwrap_or(&text);
    let text = if text.contains('\r') {
        text.replace("\r\n", "\n").replace('\r', "\n")
    } else {
        text.to_string()
    };
    // Counted before any line is parsed, so the limit is the first thing said.
    if text.lines().nth(MAX_LABEL_LINES).is_some() {
        return Err(input(
            path,
            format!("more than the {MAX_LABEL_LINES}-line limit for a label file"),
        ));
    }
    Ok(text)
}

/// One row's class and its box `[x0, y0, x1, y1]` in fractions of the frame (see
/// [`read_labels`] for the row kinds), or why the row is none of them.
fn parse_row(fields: &[&str]) -> Result<(u64, [f64; 4]), String> {
    let class = fields[0]
        .parse::<f64>()
        .ok()
        .filter(|c| c.is_finite() && *c >= 0.0 && c.fract() == 0.0 && *c <= 1e9)
        .ok_or_else(|| format!("class `{}` is not a whole number ≥ 0", fields[0]))?;
    let values = &fields[1..];
    check_no_track_id(values)?;
    let b = match values.len() {
        4 => yolo_box(values)?,
        5 => {
            confidence(values[4])?;
            yolo_box(&values[..4])?
        }
        n if n >= 6 && n % 2 == 0 => polygon_box(values)?,
        n if n >= 7 => {
            confidence(values[n - 1])?;
            polygon_box(&values[..n - 1])?
        }
        n => {
            return Err(format!(
                "expected `class cx cy w h` (a YOLO box, a confidence after it in a prediction file) or `class x1 y1 x2 y2 x3 y3 …` (a polygon or an oriented box), found {} fields",
                n + 1
            ));
        }
    };
    Ok((class as u64, b))
}

/// Refuses a tracker's row (`class cx cy w h [confidence] id`, as Ultralytics' `track`
/// saves it) by its id: a whole number past 1 where a box ends in a confidence or a
/// polygon in a y (read as either, it would be out of range for a confusing reason).
fn check_no_track_id(values: &[&str]) -> Result<(), String> {
    let (5 | 6) = values.len() else {
        return Ok(());
    };
    let last = values[values.len() - 1];
    match last.parse::<f64>() {
        Ok(id) if id > 1.0 && id.fract() == 0.0 => Err(format!(
            "the last value `{last}` is a whole number past 1: a tracker's id column? A label row is `class cx cy w h` (a prediction's: a confidence after it); drop the id"
        )),
        _ => Ok(()),
    }
}

/// A finite number (read as f64 and range-checked before any narrowing, so a number
/// beyond f32's range, `1e300`, is named as out of range).
fn number(s: &str) -> Result<f64, String> {
    (s.parse::<f64>().ok())
        .filter(|x| x.is_finite())
        .ok_or_else(|| format!("`{s}` is not a number"))
}

/// Refuses a value outside [0, 1] ± [`YOLO_TOLERANCE`], naming it.
fn in_unit(name: &str, s: &str, x: f64) -> Result<f64, String> {
    let range = f64::from(-YOLO_TOLERANCE)..=f64::from(1.0 + YOLO_TOLERANCE);
    if range.contains(&x) {
        return Ok(x);
    }
    Err(format!(
        "{name} {s} is outside [0, 1]: YOLO values are fractions of the frame"
    ))
}

/// `cx cy w h` → `[x0, y0, x1, y1]`.
fn yolo_box(values: &[&str]) -> Result<[f64; 4], String> {
    let mut v = [0f64; 4];
    for (k, s) in values.iter().enumerate() {
        v[k] = number(s)?;
    }
    if v[2] < 0.0 || v[3] < 0.0 {
        return Err("negative box width or height".into());
    }
    for ((name, x), s) in ["cx", "cy", "w", "h"].iter().zip(v).zip(values) {
        in_unit(name, s, x)?;
    }
    let [cx, cy, bw, bh] = v;
    Ok([cx - 0.5 * bw, cy - 0.5 * bh, cx + 0.5 * bw, cy + 0.5 * bh])
}

/// The bounding box of a polygon's `x y` pairs.
fn polygon_box(values: &[&str]) -> Result<[f64; 4], String> {
    let mut b = [
        f64::INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::NEG_INFINITY,
    ];
    for (k, s) in values.iter().enumerate() {
        let name = if k % 2 == 0 { "x" } else { "y" };
        let v = in_unit(name, s, number(s)?)?;
        b[k % 2] = b[k % 2].min(v);
        b[2 + k % 2] = b[2 + k % 2].max(v);
    }
    Ok(b)
}

/// Refuses a prediction's confidence outside [0, 1].
fn confidence(s: &str) -> Result<(), String> {
    let c = number(s)?;
    if (0.0..=1.0).contains(&c) {
        return Ok(());
    }
    Err(format!("confidence {s} is outside [0, 1]"))
}

/// A box in fractions → pixels of a `w` × `h` frame, clipped to it; `None` when
/// nothing of it is left (a box of no area marks no pixel of a drone).
fn clipped(b: [f64; 4], (w, h): (u32, u32)) -> Option<PixelBox> {
    let (wf, hf) = (f64::from(w), f64::from(h));
    let px = PixelBox {
        x0: (b[0].clamp(0.0, 1.0) * wf) as f32,
        y0: (b[1].clamp(0.0, 1.0) * hf) as f32,
        x1: (b[2].clamp(0.0, 1.0) * wf) as f32,
        y1: (b[3].clamp(0.0, 1.0) * hf) as f32,
    };
    (px.x1 > px.x0 && px.y1 > px.y0).then_some(px)
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

    /// The boxes of `text` read as a label file of a 100 × 100 frame, as
    /// `[x0, y0, x1, y1]` pixels, or the error's text.
    fn boxes_of(text: &[u8]) -> Result<Vec<[f32; 4]>, String> {
        let dir = tempfile::tempdir().expect("temp dir");
        let path = dir.path().join("a.txt");
        std::fs::write(&path, text).expect("txt");
        let boxes = read_labels(
            &path,
            (100, 100),
            &DroneClasses::All,
            &mut ClassTally::default(),
        )
        .map_err(|e| e.to_string())?;
        Ok(boxes.iter().map(|b| [b.x0, b.y0, b.x1, b.y1]).collect())
    }

    fn assert_boxes(got: Vec<[f32; 4]>, want: &[[f32; 4]]) {
        assert_eq!(got.len(), want.len(), "{got:?}");
        for (g, w) in got.iter().zip(want) {
            assert!(
                g.iter().zip(w).all(|(a, b)| (a - b).abs() < 1e-3),
                "{got:?}"
            );
        }
    }

    /// Windows and old Mac editors: a byte-order mark, CRLF and lone CR line ends are
    /// read; UTF-16 is named.
    #[test]
    fn a_byte_order_mark_and_cr_line_ends_are_read() {
        let want = [[40.0, 40.0, 60.0, 60.0], [0.0, 0.0, 10.0, 10.0]];
        for text in [
            &b"\xef\xbb\xbf0 0.5 0.5 0.2 0.2\r\n0 0.05 0.05 0.1 0.1\r\n"[..],
            b"0 0.5 0.5 0.2 0.2\r0 0.05 0.05 0.1 0.1\r",
            b"\xef\xbb\xbf0.0 5e-1 0.5 2E-1 0.2 \t\n\n0 0.05 0.05 0.1 0.1",
        ] {
            assert_boxes(boxes_of(text).expect("read"), &want);
        }
        let e = boxes_of(b"\xff\xfe0\x00 \x000\x00").expect_err("UTF-16");
        assert!(e.contains("is UTF-16 text: save it as UTF-8"), "{e}");
        // A lone CR counts lines as the editor shows them.
        let e = boxes_of(b"0 0.5 0.5 0.2 0.2\r0 0.5 0.5 0.2\r").expect_err("short row");
        assert!(e.contains("line 2"), "{e}");
    }

    /// Ultralytics' other label files: a prediction's confidence column, a
    /// segmentation polygon, an oriented box's corners (with a confidence too).
    #[test]
    fn predictions_polygons_and_oriented_boxes_give_their_bounding_box() {
        let want = [[40.0, 30.0, 60.0, 70.0]];
        for row in [
            "0 0.5 0.5 0.2 0.4 0.87",
            "0 0.4 0.3 0.6 0.5 0.5 0.7",
            "0 0.5 0.3 0.6 0.5 0.5 0.7 0.4 0.5",
            "0 0.5 0.3 0.6 0.5 0.5 0.7 0.4 0.5 0.91",
            "0 0.4 0.3 0.6 0.5 0.5 0.7 0.45 0.6 0.4 0.31",
        ] {
            assert_boxes(boxes_of(row.as_bytes()).expect(row), &want);
        }
        for (row, says) in [
            ("0 0.5 0.5", "found 3 fields"),
            ("0 0.5 0.5 0.2 0.4 17", "a tracker's id column?"),
            ("0 0.5 0.5 0.2 0.4 0.9 3", "a tracker's id column?"),
            ("0 0.5 0.5 0.2 0.4 1.5", "confidence 1.5 is outside [0, 1]"),
            ("0 0.4 0.3 0.6 1.5 0.5 0.7", "y 1.5 is outside [0, 1]"),
            ("0 0.4 0.3 0.6 x 0.5 0.7", "`x` is not a number"),
        ] {
            let e = boxes_of(row.as_bytes()).expect_err(row);
            assert!(e.contains("line 1") && e.contains(says), "{row}: {e}");
        }
    }

    /// As Ultralytics loads labels: boxes clipped to the frame, boxes of no area and
    /// exact repeats of a row dropped (they would count as drones of no size, or twice).
    #[test]
    fn boxes_are_clipped_and_empty_or_repeated_rows_dropped() {
        let text = b"0 0.98 0.5 0.1 0.1\n0 0.5 0.5 0 0.1\n0 0.3 0.3 0.1 0.1\n0 0.3 0.3 0.1 0.1\n";
        let want = [[93.0, 45.0, 100.0, 55.0], [25.0, 25.0, 35.0, 35.0]];
        assert_boxes(boxes_of(text).expect("read"), &want);
        let dir = tempfile::tempdir().expect("temp dir");
        let path = dir.path().join("a.txt");
        std::fs::write(&path, text).expect("txt");
        let mut tally = ClassTally::default();
        read_labels(&path, (100, 100), &DroneClasses::All, &mut tally).expect("read");
        assert_eq!(tally.drone_rows, 3, "the repeated row is one drone");
    }

    /// A root given as an Ultralytics dataset, its `images/` or one split's
    /// `images/train/` finds the labels of `labels/train`.
    #[test]
    fn labels_are_found_from_any_folder_of_an_ultralytics_dataset() {
        let dir = tempfile::tempdir().expect("temp dir");
        let root = dir.path();
        std::fs::create_dir_all(root.join("images/train")).expect("images");
        std::fs::create_dir_all(root.join("labels/train")).expect("labels");
        std::fs::write(root.join("labels/train/a.txt"), "").expect("txt");
        let want = Some(root.join("labels/train/a.txt"));
        for top in ["", "images", "images/train"] {
            let top = root.join(top);
            let image = root.join("images/train/a.JPG");
            assert_eq!(label_for(&top, &image).expect(""), want, "{top:?}");
        }
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
