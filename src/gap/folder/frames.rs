//! The image files below a side's root: JPEG and PNG frames, links followed, each
//! folder walked once; formats not read, videos and dataset files named.

use std::path::{Path, PathBuf};

use super::{input, label_for};
use crate::gap::error::GapError;

/// Deepest folder level walked below a side's root.
pub(crate) const MAX_DEPTH: usize = 8;

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
