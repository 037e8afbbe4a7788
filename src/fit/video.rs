//! Footage given as a video: decoded by the `ffmpeg` program on PATH after `ffprobe`
//! (beside it, or on PATH) has read the video's frame size and duration, so that frames
//! past fit's pixel budgets are refused before ffmpeg writes any of them.

use std::path::{Path, PathBuf};

use super::{FitError, FitOptions, io_err};

/// The most frames decoded when `--max-frames` is 0.
pub const MAX_VIDEO_FRAMES: usize = 10_000;
/// The most bytes read of ffprobe's answer (a few numbers).
const MAX_PROBE_OUTPUT: usize = 4096;

/// The decoder programs found for a video.
#[derive(Debug, Clone)]
pub struct Decoder {
    pub ffmpeg: PathBuf,
    pub ffprobe: PathBuf,
}

impl Decoder {
    /// ffmpeg on PATH and ffprobe beside it (else on PATH); `None` without both.
    pub fn find() -> Option<Self> {
        let ffmpeg = find_program("ffmpeg")?;
        let beside = ffmpeg.with_file_name("ffprobe");
        let ffprobe = if is_executable(&beside) {
            beside
        } else {
            find_program("ffprobe")?
        };
        Some(Self { ffmpeg, ffprobe })
    }
}

/// A video's first video stream as ffprobe reports it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Probe {
    pub width: u32,
    pub height: u32,
    /// Seconds, when the container states it.
    pub duration_s: Option<f64>,
}

/// An executable regular file named `name` in a folder of PATH.
fn find_program(name: &str) -> Option<PathBuf> {
    let path = std::env::var_os("PATH")?;
    std::env::split_paths(&path)
        .map(|d| d.join(name))
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

/// The frame size and duration of `video`'s first video stream, read by ffprobe.
pub fn probe(video: &Path, decoder: &Decoder) -> Result<Probe, FitError> {
    let output = std::process::Command::new(&decoder.ffprobe)
        .args(["-v", "error", "-select_streams", "v:0"])
        .args(["-show_entries", "stream=width,height:format=duration"])
        .args(["-of", "default=noprint_wrappers=1"])
        .arg(video)
        .stdin(std::process::Stdio::null())
        .output()
        .map_err(io_err(&decoder.ffprobe))?;
    let decode_err = |reason: String| FitError::VideoDecode {
        path: video.to_path_buf(),
        reason,
    };
    if !output.status.success() {
        return Err(decode_err(bounded_text(&output.stderr)));
    }
    parse_probe(&bounded_text(&output.stdout)).map_err(decode_err)
}

/// At most [`MAX_PROBE_OUTPUT`] bytes of a program's output, as text.
fn bounded_text(bytes: &[u8]) -> String {
    let n = bytes.len().min(MAX_PROBE_OUTPUT);
    String::from_utf8_lossy(&bytes[..n]).trim().to_string()
}

/// ffprobe's `key=value` lines: `width`, `height` (required, ≥ 1) and `duration`
/// (seconds; `N/A` or absent when the container does not say).
pub fn parse_probe(text: &str) -> Result<Probe, String> {
    let (mut width, mut height, mut duration_s) = (None, None, None);
    for line in text.lines() {
        let Some((key, value)) = line.trim().split_once('=') else {
            continue;
        };
        match key {
            "width" => width = value.parse::<u32>().ok().filter(|&w| w > 0),
            "height" => height = value.parse::<u32>().ok().filter(|&h| h > 0),
            "duration" => {
                duration_s = value
                    .parse::<f64>()
                    .ok()
                    .filter(|d| d.is_finite() && *d >= 0.0)
            }
            _ => {}
        }
    }
    match (width, height) {
        (Some(width), Some(height)) => Ok(Probe {
            width,
            height,
            duration_s,
        }),
        _ => Err("no video stream with a frame size".into()),
    }
}

/// The most frames taken from a video: `--max-frames` (0: [`MAX_VIDEO_FRAMES`]).
fn max_frames(options: &FitOptions) -> usize {
    match options.max_frames {
        0 => MAX_VIDEO_FRAMES,
        n => n,
    }
}

/// The frames a second decoded: `--video-fps`, or fewer when the video is longer than
/// its frames at that rate would cover (its duration known), so that the frames taken
/// are spread over the whole video, as a folder's frames are spread over its names.
pub fn sample_fps(probe: &Probe, options: &FitOptions) -> f64 {
    let max = max_frames(options) as f64;
    match probe.duration_s {
        Some(d) if d * options.video_fps > max => max / d,
        _ => options.video_fps,
    }
}

/// The most frames the decode can give: `--max-frames` (0: [`MAX_VIDEO_FRAMES`]), fewer
/// when the duration says so (`fps` a second, one more for the first frame's rounding).
pub fn frames_bound(probe: &Probe, options: &FitOptions) -> usize {
    let max = max_frames(options);
    match probe.duration_s {
        Some(d) => {
            let by_time = (d * options.video_fps).ceil() + 1.0;
            if by_time < max as f64 {
                by_time as usize
            } else {
                max
            }
        }
        None => max,
    }
}

/// Decodes [`sample_fps`] frames a second of the video's first video stream (the one
/// [`probe`] measured) into `OUT/frames/` with ffmpeg (PNG, lossless), at most
/// [`frames_bound`]. The folder is made below `out`'s handle
/// without following a link, and checked to be the same folder before and after ffmpeg
/// writes into it by path.
pub fn decode(
    video: &Path,
    decoder: &Decoder,
    probe: &Probe,
    out: &mut super::out::FitOut,
    options: &FitOptions,
) -> Result<PathBuf, FitError> {
    let (dir, held) = out.dir_for_path("frames")?;
    let frames = frames_bound(probe, options);
    // `--video-fps` was checked before anything was written (`check_numbers`).
    let fps = sample_fps(probe, options);
    let output = std::process::Command::new(&decoder.ffmpeg)
        .args(["-nostdin", "-hide_banner", "-loglevel", "error", "-i"])
        .arg(video)
        // The stream ffprobe measured (`v:0`): left to choose, ffmpeg takes the video
        // stream of the most pixels, which the budgets never saw.
        .args(["-map", "0:v:0"])
        .args([
            "-vf",
            &format!("fps={fps}"),
            "-frames:v",
            &frames.to_string(),
        ])
        .args(["-start_number", "0"])
        .arg(dir.join("frame_%05d.png"))
        .stdin(std::process::Stdio::null())
        .output()
        .map_err(io_err(&decoder.ffmpeg))?;
    if !output.status.success() {
        return Err(FitError::VideoDecode {
            path: video.to_path_buf(),
            reason: bounded_text(&output.stderr),
        });
    }
    out.check_same(&dir, &held)?;
    check_some_frame(video, &dir)?;
    Ok(dir)
}

/// Refuses, naming the video, a decode that gave no frame (a still image given as a
/// video, a stream without frames): the frames folder's own error would name `OUT`.
fn check_some_frame(video: &Path, dir: &Path) -> Result<(), FitError> {
    let mut entries = std::fs::read_dir(dir).map_err(io_err(dir))?;
    if entries.next().is_some() {
        return Ok(());
    }
    Err(FitError::VideoDecode {
        path: video.to_path_buf(),
        reason: "ffmpeg gave no frame (a still image, or a video stream without frames)".into(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn probe_lines_are_read_and_a_missing_size_is_named() {
        let p = parse_probe("width=1920\nheight=1080\nduration=12.5\n").expect("probe");
        assert_eq!((p.width, p.height, p.duration_s), (1920, 1080, Some(12.5)));
        let p = parse_probe("width=640\nheight=512\nduration=N/A").expect("probe");
        assert_eq!(p.duration_s, None);
        for bad in ["", "duration=3", "width=0\nheight=10", "width=x\nheight=10"] {
            let e = parse_probe(bad).expect_err(bad);
            assert!(e.contains("no video stream"), "{bad}: {e}");
        }
    }
}
