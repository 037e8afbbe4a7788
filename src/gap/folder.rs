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
pub(crate) fn label_for(root: &Path, image: &Path) -> Option<PathBuf> {
    let rel = image.strip_prefix(root).ok()?;
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
    candidates.into_iter().find(|p| p.is_file())
}

/// YOLO rows `class cx cy w h` (normalised) → pixel boxes. At most
/// [`MAX_LABEL_LINES`] lines and [`MAX_LABEL_BYTES`]; the class a whole number ≥ 0, the
/// four values finite and within [0, 1] (± [`YOLO_TOLERANCE`]); the boxes' summed area
/// at most [`MAX_BOX_COVERAGE`] frames.
pub(crate) fn read_labels(path: &Path, w: u32, h: u32) -> Result<Vec<PixelBox>, GapError> {
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
        let class_ok = f[0]
            .parse::<f64>()
            .is_ok_and(|c| c.is_finite() && c >= 0.0 && c.fract() == 0.0 && c <= 1e9);
        if !class_ok {
            return Err(bad(format!("class `{}` is not a whole number ≥ 0", f[0])));
        }
        let mut v = [0f32; 4];
        for (k, s) in f[1..].iter().enumerate() {
            v[k] = s
                .parse::<f32>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or_else(|| bad(format!("`{s}` is not a number")))?;
        }
        if v[2] < 0.0 || v[3] < 0.0 {
            return Err(bad("negative box width or height".into()));
        }
        for (name, x) in ["cx", "cy", "w", "h"].iter().zip(v) {
            if !(-YOLO_TOLERANCE..=1.0 + YOLO_TOLERANCE).contains(&x) {
                return Err(bad(format!(
                    "{name} {x} is outside [0, 1]: YOLO values are fractions of the frame"
                )));
            }
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
