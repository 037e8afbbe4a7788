//! The user's footage: a folder of frames with optional YOLO labels, or a video decoded
//! by the `ffmpeg` program on PATH ([`super::video`]). Every problem is a named
//! [`FitError`], found before anything is written. The folder rules are the domain-gap
//! report's ([`crate::gap::folder`]): images searched 8 levels deep in name order, links
//! followed, labels found as Ultralytics finds them (the last `images` folder of the
//! frame's path replaced by `labels`) or beside the image as `NAME.txt`.

use std::path::{Path, PathBuf};

use image::RgbImage;

use super::{FitError, FitOptions, io_err};
use crate::gap::PixelBox;

/// The largest frame file read.
pub const MAX_FRAME_BYTES: u64 = 64 << 20;
/// The smallest frame side (one report tile, and a plate needs 64 px).
pub const MIN_SIDE: u32 = 64;
/// The most pixels of all the frames read together (each frame is held decoded until
/// the plates are written): 2 000 megapixels, 6 GB of RGB, e.g. 960 frames of
/// 1920 × 1080 or 240 of 3840 × 2160. Summed from the files' headers before any frame
/// is decoded. (The plates' own budget, [`super::plates::check_plate_budget`], is
/// tighter for large frames: 64 plates of 4K.)
pub const MAX_TOTAL_PIXELS: u64 = 2_000_000_000;
/// The most frames a second taken from a video (`--video-fps`).
pub const MAX_VIDEO_FPS: f64 = 1000.0;

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
    Video {
        path: PathBuf,
        decoder: super::video::Decoder,
    },
}

/// The absolute form of `p` without requiring it to exist, links resolved as far as
/// it exists ([`crate::input::canonical_as_far_as_it_exists`]; `p` itself when even
/// the working folder cannot be read).
pub fn absolute(p: &Path) -> PathBuf {
    crate::input::canonical_as_far_as_it_exists(p).unwrap_or_else(|_| p.to_path_buf())
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
    if let Some(reason) = crate::gap::folder::description_file(real) {
        return Err(FitError::Other(format!(
            "--real {}: {reason}",
            real.display()
        )));
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
    let decoder = super::video::Decoder::find()
        .ok_or_else(|| FitError::NoVideoDecoder { path: real.clone() })?;
    if !options.unlabelled_ok {
        return Err(FitError::Unlabelled {
            count: 1,
            total: 1,
            first: real.clone(),
        });
    }
    Ok(Source::Video {
        path: real.clone(),
        decoder,
    })
}

/// Decodes one frame file as `gap` does ([`crate::input::decode_image`]: a JPEG or
/// PNG within [`crate::input::MAX_IMAGE_PIXELS`], read from its header before any
/// pixel is allocated; a truncated JPEG refused), naming the file and the reason.
/// Returns the frame and, for a JPEG, its header up to the first scan (the
/// quantisation tables the quality estimate reads).
pub fn decode(path: &Path) -> Result<(RgbImage, Option<Vec<u8>>), FitError> {
    use crate::input::ImageError;
    let bytes = crate::input::read_input_file(path, MAX_FRAME_BYTES).map_err(io_err(path))?;
    let img = crate::input::decode_image(&bytes, crate::input::MAX_IMAGE_PIXELS, u32::MAX)
        .map_err(|e| match e {
            ImageError::Truncated(_) | ImageError::Header(_) | ImageError::Decode(_) => {
                FitError::CorruptImage {
                    path: path.to_path_buf(),
                    reason: e.to_string(),
                }
            }
            _ => FitError::Image {
                path: path.to_path_buf(),
                reason: e.to_string(),
            },
        })?
        .to_rgb8();
    check_min_side(path, img.dimensions())?;
    let jpeg = bytes
        .starts_with(&[0xFF, 0xD8])
        .then(|| bytes[..jpeg_header_len(&bytes)].to_vec());
    Ok((img, jpeg))
}

/// The length of a JPEG's bytes before its first scan (start-of-scan marker FF DA), its
/// markers followed by their segment lengths; all of it when there is none.
fn jpeg_header_len(bytes: &[u8]) -> usize {
    let n = bytes.len();
    let mut i = 2;
    while i + 4 <= n {
        if bytes[i] != 0xFF {
            return n;
        }
        match bytes[i + 1] {
            0xFF => i += 1,
            0xDA | 0xD9 => return i,
            0x01 | 0xD0..=0xD7 => i += 2,
            _ => i += 2 + (usize::from(bytes[i + 2]) << 8 | usize::from(bytes[i + 3])),
        }
    }
    n
}

/// The width and height of a frame file read from its header alone (`None` when it
/// cannot be read: decoding it then names the reason).
fn header_size(path: &Path) -> Option<(u32, u32)> {
    let (file, _) = crate::input::open_input_file(path, MAX_FRAME_BYTES).ok()?;
    image::ImageReader::new(std::io::BufReader::new(file))
        .with_guessed_format()
        .ok()?
        .into_dimensions()
        .ok()
}

/// A frame's pixels, or its refusal by `path` past [`crate::input::MAX_IMAGE_PIXELS`].
pub(super) fn frame_pixels(path: &Path, (width, height): (u32, u32)) -> Result<u64, FitError> {
    let n = u64::from(width) * u64::from(height);
    let max_pixels = crate::input::MAX_IMAGE_PIXELS;
    if n <= max_pixels {
        return Ok(n);
    }
    let e = crate::input::ImageError::Pixels {
        width,
        height,
        max_pixels,
    };
    Err(FitError::Image {
        path: path.to_path_buf(),
        reason: e.to_string(),
    })
}

/// Refuses, from the files' headers before any frame is decoded, a frame over
/// [`crate::input::MAX_IMAGE_PIXELS`] (by name) and frames that together hold more than
/// [`MAX_TOTAL_PIXELS`] (naming how many frames fit).
fn check_pixels(paths: &[PathBuf]) -> Result<(), FitError> {
    let mut pixels = 0u64;
    for path in paths {
        let Some(size) = header_size(path) else {
            continue;
        };
        pixels += frame_pixels(path, size)?;
    }
    if pixels <= MAX_TOTAL_PIXELS {
        return Ok(());
    }
    let mean = (pixels / paths.len().max(1) as u64).max(1);
    Err(FitError::TooManyPixels {
        frames: paths.len(),
        pixels,
        fit: (MAX_TOTAL_PIXELS / mean) as usize,
    })
}

/// A frame's refusal by `path` when a side is under [`MIN_SIDE`].
fn check_min_side(path: &Path, (w, h): (u32, u32)) -> Result<(), FitError> {
    if w.min(h) >= MIN_SIDE {
        return Ok(());
    }
    Err(FitError::Image {
        path: path.to_path_buf(),
        reason: format!("{w}×{h} is smaller than the {MIN_SIDE} px a frame needs"),
    })
}

/// Refuses, before anything is written, a video whose frames would pass fit's budgets:
/// a frame under [`MIN_SIDE`] a side or over [`crate::input::MAX_IMAGE_PIXELS`], or the
/// frames the decode can give over [`MAX_TOTAL_PIXELS`] together (naming how many fit).
pub fn check_video_pixels(
    video: &Path,
    probe: &super::video::Probe,
    options: &FitOptions,
) -> Result<(), FitError> {
    check_min_side(video, (probe.width, probe.height))?;
    let each = frame_pixels(video, (probe.width, probe.height))?;
    let frames = super::video::frames_bound(probe, options);
    let pixels = each.saturating_mul(frames as u64);
    if pixels <= MAX_TOTAL_PIXELS {
        return Ok(());
    }
    Err(FitError::TooManyPixels {
        frames,
        pixels,
        fit: (MAX_TOTAL_PIXELS / each.max(1)) as usize,
    })
}

/// Every frame under `dir` in name order (at most `max`, evenly spaced; 0: all), decoded,
/// with its labels (the rows of `classes`); refuses unlabelled frames unless `unlabelled_ok`.
pub fn read_folder(
    dir: &Path,
    max: usize,
    unlabelled_ok: bool,
    classes: &crate::gap::folder::DroneClasses,
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
    check_pixels(&picked)?;
    let mut frames = Vec::with_capacity(picked.len());
    let mut rows = crate::gap::folder::ClassTally::default();
    for (path, label) in picked.into_iter().zip(labels) {
        let (rgb, jpeg) = decode(&path)?;
        let boxes = match &label {
            Some(l) => crate::gap::folder::read_labels(l, rgb.dimensions(), classes, &mut rows)?,
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
    rows.check(classes)
        .map_err(|reason| FitError::Other(format!("--classes {classes}: {reason}")))?;
    Ok(frames)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn options(max_frames: usize, video_fps: f64) -> FitOptions {
        FitOptions {
            max_frames,
            video_fps,
            ..FitOptions::new("real", "out")
        }
    }

    #[test]
    fn the_frame_bound_takes_the_duration_when_it_is_shorter() {
        let probe = |d| crate::fit::video::Probe {
            width: 10,
            height: 10,
            duration_s: d,
            still: false,
        };
        assert_eq!(
            crate::fit::video::frames_bound(&probe(Some(3.0)), &options(200, 2.0)),
            7
        );
        assert_eq!(
            crate::fit::video::frames_bound(&probe(Some(1e9)), &options(200, 2.0)),
            200
        );
        assert_eq!(
            crate::fit::video::frames_bound(&probe(None), &options(0, 2.0)),
            crate::fit::video::MAX_VIDEO_FRAMES
        );
    }

    #[test]
    fn a_long_video_is_sampled_slower_so_its_frames_span_it() {
        use crate::fit::video::sample_fps;
        let probe = |d| crate::fit::video::Probe {
            width: 10,
            height: 10,
            duration_s: d,
            still: false,
        };
        // 200 frames at 2 a second cover 100 s: a 1 000 s video is taken at 0.2 a second.
        assert_eq!(sample_fps(&probe(Some(1000.0)), &options(200, 2.0)), 0.2);
        assert_eq!(sample_fps(&probe(Some(100.0)), &options(200, 2.0)), 2.0);
        assert_eq!(sample_fps(&probe(Some(30.0)), &options(200, 2.0)), 2.0);
        assert_eq!(sample_fps(&probe(None), &options(200, 2.0)), 2.0);
        assert_eq!(sample_fps(&probe(Some(50_000.0)), &options(0, 2.0)), 0.2);
    }

    #[test]
    fn frames_past_the_budgets_are_refused_naming_how_many_fit() {
        let v = Path::new("clip.mp4");
        let eight_k = crate::fit::video::Probe {
            width: 7680,
            height: 4320,
            duration_s: None,
            still: false,
        };
        let e = check_video_pixels(v, &eight_k, &options(200, 2.0)).expect_err("8K × 200");
        assert!(matches!(e, FitError::TooManyPixels { fit: 60, .. }), "{e}");
        assert!(e.to_string().contains("--max-frames 60"), "{e}");
        check_video_pixels(v, &eight_k, &options(60, 2.0)).expect("8K × 60 fits");
        let huge = crate::fit::video::Probe {
            width: 20_000,
            height: 20_000,
            duration_s: Some(1.0),
            still: false,
        };
        let e = check_video_pixels(v, &huge, &options(1, 2.0)).expect_err("400 Mpx");
        assert!(e.to_string().starts_with("clip.mp4: "), "{e}");
    }
}
