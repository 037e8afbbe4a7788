//! A frame's YOLO label file, found as Ultralytics finds it, and its rows read as
//! boxes: plain rows, predictions, polygons and oriented boxes, within their limits.

use std::path::{Path, PathBuf};

use super::{ClassTally, DroneClasses, input};
use crate::gap::error::GapError;
use crate::gap::measure::PixelBox;

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

#[cfg(test)]
mod tests {
    use super::*;

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
