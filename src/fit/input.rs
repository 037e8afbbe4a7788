//! The user's footage: a folder of frames with optional YOLO labels, or a video decoded
//! by the `ffmpeg` program on PATH. Every problem is a named [`FitError`], found before
//! anything is written. The folder rules are the domain-gap report's (`swarmshot gap`):
//! images searched 8 levels deep in name order, labels in a sibling `labels/` (the last
//! `images` component replaced) or beside the image as `NAME.txt`.

use std::path::{Path, PathBuf};

use image::RgbImage;

use super::{FitError, FitOptions, io_err};
use crate::gap::PixelBox;

/// The largest frame file read.
pub const MAX_FRAME_BYTES: u64 = 64 << 20;
/// The smallest frame side (one report tile, and a plate needs 64 px).
pub const MIN_SIDE: u32 = 64;

/// One real frame, decoded.
#[derive(Debug)]
pub struct RealFrame {
    /// Path relative to the real folder, with `/`.
    pub rel: String,
    pub path: PathBuf,
    pub rgb: RgbImage,
    pub boxes: Vec<PixelBox>,
    /// Whether a label file was found (an empty one counts: "no drone here").
    pub labelled: bool,
    /// The file's bytes when it is a JPEG (for its quantisation tables).
    pub jpeg: Option<Vec<u8>>,
}

/// What `--real` names.
#[derive(Debug)]
pub enum Source {
    Folder(PathBuf),
    Video { path: PathBuf, ffmpeg: PathBuf },
}

/// The absolute form of `p` without requiring it to exist: its longest existing
/// ancestor canonicalised, the rest appended.
pub fn absolute(p: &Path) -> PathBuf {
    let p = if p.is_absolute() {
        p.to_path_buf()
    } else {
        std::env::current_dir().unwrap_or_default().join(p)
    };
    let mut rest = Vec::new();
    let mut cur = p.as_path();
    loop {
        if let Ok(c) = cur.canonicalize() {
            let mut out = c;
            for r in rest.iter().rev() {
                out.push(r);
            }
            return out;
        }
        match (cur.parent(), cur.file_name()) {
            (Some(parent), Some(name)) => {
                rest.push(name.to_os_string());
                cur = parent;
            }
            _ => return p,
        }
    }
}

/// `ffmpeg` on PATH, if any (an executable regular file).
pub fn find_ffmpeg() -> Option<PathBuf> {
    let path = std::env::var_os("PATH")?;
    std::env::split_paths(&path)
        .map(|d| d.join("ffmpeg"))
        .find(|p| is_executable(p))
}

fn is_executable(p: &Path) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        std::fs::metadata(p).is_ok_and(|m| m.is_file() && m.permissions().mode() & 0o111 != 0)
    }
    #[cfg(not(unix))]
    {
        p.is_file()
    }
}

/// What `--real` is, and `--out` not inside it; nothing is read or written yet.
pub fn check_source(options: &FitOptions) -> Result<Source, FitError> {
    let real = &options.real;
    if !real.exists() {
        return Err(FitError::Missing { path: real.clone() });
    }
    if real.is_dir() {
        let (r, o) = (absolute(real), absolute(&options.out));
        if o.starts_with(&r) {
            return Err(FitError::OutInsideReal {
                out: options.out.clone(),
                real: real.clone(),
            });
        }
        return Ok(Source::Folder(real.clone()));
    }
    if crate::gap::folder::is_image(real) {
        return Err(FitError::Other(format!(
            "--real {}: a single image; give the folder that holds the frames (or a video file)",
            real.display()
        )));
    }
    let meta = std::fs::metadata(real).map_err(io_err(real))?;
    if meta.len() == 0 {
        return Err(FitError::EmptyFile { path: real.clone() });
    }
    let ffmpeg = find_ffmpeg().ok_or_else(|| FitError::NoVideoDecoder { path: real.clone() })?;
    if !options.unlabelled_ok {
        return Err(FitError::Unlabelled {
            count: 1,
            total: 1,
            first: real.clone(),
        });
    }
    Ok(Source::Video {
        path: real.clone(),
        ffmpeg,
    })
}

/// The output folder: missing or empty, or an earlier fit's with `overwrite` (its own
/// files removed, others kept).
pub fn prepare_out(out: &Path, overwrite: bool) -> Result<(), FitError> {
    if !out.exists() {
        return Ok(());
    }
    if !out.is_dir() {
        return Err(FitError::OutNotEmpty {
            path: out.to_path_buf(),
        });
    }
    let empty = std::fs::read_dir(out)
        .map_err(io_err(out))?
        .next()
        .is_none();
    if empty {
        return Ok(());
    }
    let earlier_fit = out.join("fitted.ron").is_file() || out.join("footage.json").is_file();
    if !(overwrite && earlier_fit) {
        return Err(FitError::OutNotEmpty {
            path: out.to_path_buf(),
        });
    }
    for name in super::OUT_NAMES {
        let p = out.join(name);
        if p.is_dir() {
            std::fs::remove_dir_all(&p).map_err(io_err(&p))?;
        } else if p.exists() {
            std::fs::remove_file(&p).map_err(io_err(&p))?;
        }
    }
    Ok(())
}

/// Decodes `fps` frames a second of the video into `OUT/frames/` with ffmpeg (PNG,
/// lossless), at most `max_frames` (0: 10 000).
pub fn decode_video(
    video: &Path,
    ffmpeg: &Path,
    out: &Path,
    options: &FitOptions,
) -> Result<PathBuf, FitError> {
    let dir = out.join("frames");
    std::fs::create_dir_all(&dir).map_err(io_err(&dir))?;
    let max = if options.max_frames == 0 {
        10_000
    } else {
        options.max_frames
    };
    let fps = if options.video_fps.is_finite() && options.video_fps > 0.0 {
        options.video_fps
    } else {
        2.0
    };
    let output = std::process::Command::new(ffmpeg)
        .args(["-nostdin", "-hide_banner", "-loglevel", "error", "-i"])
        .arg(video)
        .args(["-vf", &format!("fps={fps}"), "-frames:v", &max.to_string()])
        .args(["-start_number", "0"])
        .arg(dir.join("frame_%05d.png"))
        .output()
        .map_err(io_err(ffmpeg))?;
    if !output.status.success() {
        return Err(FitError::VideoDecode {
            path: video.to_path_buf(),
            reason: String::from_utf8_lossy(&output.stderr).trim().to_string(),
        });
    }
    Ok(dir)
}

/// Decodes one frame file, naming a 0-byte or corrupt file.
pub fn decode(path: &Path) -> Result<(RgbImage, Option<Vec<u8>>), FitError> {
    let bytes = crate::input::read_input_file(path, MAX_FRAME_BYTES).map_err(io_err(path))?;
    if bytes.is_empty() {
        return Err(FitError::EmptyFile {
            path: path.to_path_buf(),
        });
    }
    let corrupt = |reason: String| FitError::CorruptImage {
        path: path.to_path_buf(),
        reason,
    };
    let reader = image::ImageReader::new(std::io::Cursor::new(bytes.as_slice()))
        .with_guessed_format()
        .map_err(|e| corrupt(e.to_string()))?;
    if !matches!(
        reader.format(),
        Some(image::ImageFormat::Jpeg | image::ImageFormat::Png)
    ) {
        return Err(corrupt("not a JPEG or PNG image".into()));
    }
    let img = reader
        .decode()
        .map_err(|e| corrupt(e.to_string()))?
        .to_rgb8();
    let (w, h) = img.dimensions();
    if w.min(h) < MIN_SIDE {
        return Err(corrupt(format!(
            "{w}×{h} is smaller than the {MIN_SIDE} px a frame needs"
        )));
    }
    let jpeg = bytes.starts_with(&[0xFF, 0xD8]).then_some(bytes);
    Ok((img, jpeg))
}

/// Every frame under `dir` in name order (at most `max`, evenly spaced; 0: all), decoded,
/// with its labels; refuses unlabelled frames unless `unlabelled_ok`.
pub fn read_folder(
    dir: &Path,
    max: usize,
    unlabelled_ok: bool,
) -> Result<Vec<RealFrame>, FitError> {
    let mut images = Vec::new();
    crate::gap::folder::walk(dir, 0, &mut images)?;
    images.sort();
    if images.is_empty() {
        return Err(FitError::EmptyFolder {
            path: dir.to_path_buf(),
        });
    }
    let found = images.len();
    let picked: Vec<PathBuf> = if max > 0 && found > max {
        (0..max).map(|i| images[i * found / max].clone()).collect()
    } else {
        images
    };
    let labels: Vec<Option<PathBuf>> = picked
        .iter()
        .map(|p| crate::gap::folder::label_for(dir, p))
        .collect::<Result<_, _>>()?;
    let missing = labels.iter().filter(|l| l.is_none()).count();
    if missing > 0 && !unlabelled_ok {
        let first = picked[labels.iter().position(Option::is_none).unwrap_or(0)].clone();
        return Err(FitError::Unlabelled {
            count: missing,
            total: picked.len(),
            first,
        });
    }
    let mut frames = Vec::with_capacity(picked.len());
    for (path, label) in picked.into_iter().zip(labels) {
        let (rgb, jpeg) = decode(&path)?;
        let boxes = match &label {
            Some(l) => crate::gap::folder::read_labels(l, rgb.width(), rgb.height())?,
            None => Vec::new(),
        };
        let rel = path
            .strip_prefix(dir)
            .unwrap_or(&path)
            .to_string_lossy()
            .replace('\\', "/");
        frames.push(RealFrame {
            rel,
            path,
            rgb,
            boxes,
            labelled: label.is_some(),
            jpeg,
        });
    }
    Ok(frames)
}
