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
    /// Seconds: stated by the stream or the container (the shorter), else counted
    /// from its packets and frame rate; `None` when none of them says.
    pub duration_s: Option<f64>,
    /// ffmpeg read it as a picture (its `image2` or an `*_pipe` demuxer), not a video.
    pub still: bool,
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

/// The frame size and duration of `video`'s first video stream, read by ffprobe:
/// the shorter of the stream's and the container's durations where both are stated
/// (a container can claim far more than its stream holds), and where neither is, the
/// stream's packets counted (the file read once, nothing decoded) over its frame rate.
pub fn probe(video: &Path, decoder: &Decoder) -> Result<Probe, FitError> {
    let entries = "stream=width,height,duration:format=duration,format_name";
    let mut probe = parse_probe(&ffprobe(video, decoder, &[], entries)?)
        .map_err(|reason| decode_err(video, reason))?;
    if probe.duration_s.is_none() {
        let entries = "stream=nb_read_packets,avg_frame_rate,r_frame_rate";
        probe.duration_s = parse_counted(&ffprobe(video, decoder, &["-count_packets"], entries)?);
    }
    Ok(probe)
}

fn decode_err(video: &Path, reason: String) -> FitError {
    FitError::VideoDecode {
        path: video.to_path_buf(),
        reason,
    }
}

/// ffprobe's answer (`flat` lines, at most [`MAX_PROBE_OUTPUT`] bytes) for `entries`
/// of `video`'s first video stream.
fn ffprobe(
    video: &Path,
    decoder: &Decoder,
    extra: &[&str],
    entries: &str,
) -> Result<String, FitError> {
    let output = std::process::Command::new(&decoder.ffprobe)
        .args(["-v", "error", "-select_streams", "v:0"])
        .args(extra)
        .args(["-show_entries", entries, "-of", "flat"])
        .arg(video)
        .stdin(std::process::Stdio::null())
        .output()
        .map_err(io_err(&decoder.ffprobe))?;
    if !output.status.success() {
        return Err(decode_err(video, bounded_text(&output.stderr)));
    }
    Ok(bounded_text(&output.stdout))
}

/// At most [`MAX_PROBE_OUTPUT`] bytes of a program's output, as text.
fn bounded_text(bytes: &[u8]) -> String {
    let n = bytes.len().min(MAX_PROBE_OUTPUT);
    String::from_utf8_lossy(&bytes[..n]).trim().to_string()
}

/// ffprobe's `flat` lines as (key, value) pairs, quotes taken off the values; the
/// first stream's keys lose their `streams.stream.0.` prefix.
fn flat_entries(text: &str) -> impl Iterator<Item = (&str, &str)> {
    text.lines().filter_map(|line| {
        let (key, value) = line.trim().split_once('=')?;
        let key = key.strip_prefix("streams.stream.0.").unwrap_or(key);
        Some((key, value.trim_matches('"')))
    })
}

/// A non-negative, finite number of seconds (`N/A` and the like: `None`).
fn seconds(value: &str) -> Option<f64> {
    value
        .parse::<f64>()
        .ok()
        .filter(|d| d.is_finite() && *d >= 0.0)
}

/// ffprobe's `flat` answer: `width`, `height` (required, ≥ 1) and the stream's and the
/// container's `duration` (seconds; `N/A` or absent when not stated), the shorter kept;
/// the container's `format_name`, which tells a picture from a video.
pub fn parse_probe(text: &str) -> Result<Probe, String> {
    let (mut width, mut height, mut duration_s) = (None, None, None::<f64>);
    let mut still = false;
    for (key, value) in flat_entries(text) {
        match key {
            "format.format_name" => still = value == "image2" || value.ends_with("_pipe"),
            "width" => width = value.parse::<u32>().ok().filter(|&w| w > 0),
            "height" => height = value.parse::<u32>().ok().filter(|&h| h > 0),
            "duration" | "format.duration" => {
                if let Some(d) = seconds(value) {
                    duration_s = Some(duration_s.map_or(d, |known| known.min(d)));
                }
            }
            _ => {}
        }
    }
    match (width, height) {
        (Some(width), Some(height)) => Ok(Probe {
            width,
            height,
            duration_s,
            still,
        }),
        _ => Err("no video stream with a frame size".into()),
    }
}

/// A duration from ffprobe's `-count_packets` answer: `nb_read_packets` over the
/// stream's `avg_frame_rate` (else `r_frame_rate`), a `num/den` fraction; `None`
/// when the count or both rates are missing or zero.
pub fn parse_counted(text: &str) -> Option<f64> {
    let (mut packets, mut avg, mut r) = (None, None, None);
    let rate = |value: &str| {
        let (num, den) = value.split_once('/')?;
        let (num, den) = (num.parse::<f64>().ok()?, den.parse::<f64>().ok()?);
        Some(num / den).filter(|f| f.is_finite() && *f > 0.0)
    };
    for (key, value) in flat_entries(text) {
        match key {
            "nb_read_packets" => packets = value.parse::<u64>().ok().filter(|&n| n > 0),
            "avg_frame_rate" => avg = rate(value),
            "r_frame_rate" => r = rate(value),
            _ => {}
        }
    }
    Some(packets? as f64 / avg.or(r)?).filter(|d| d.is_finite())
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
/// writes into it by path. A clip shorter than about half a sampling interval (ffmpeg
/// 5.1 at 2 a second: 0.2 s of 30 fps) gets no frame from ffmpeg's `fps` filter, which
/// rounds its frames away; then the decode runs again with `eof_action=pass`, which
/// passes the clip's last frame through. Only then, and not for a picture given as a
/// video (refused as giving no frame): on longer clips that option can add a frame at
/// the end (1.1 s of 30 fps gives 3 frames, not 2).
pub fn decode(
    video: &Path,
    decoder: &Decoder,
    probe: &Probe,
    out: &mut super::out::FitOut,
    options: &FitOptions,
) -> Result<PathBuf, FitError> {
    let (dir, held) = out.dir_for_path("frames")?;
    // `--video-fps` was checked before anything was written (`check_numbers`).
    let fps = sample_fps(probe, options);
    let frames = frames_bound(probe, options);
    run_ffmpeg(video, decoder, (&format!("fps={fps}"), frames), &dir)?;
    out.check_same(&dir, &held)?;
    if is_empty(&dir)? && !probe.still {
        let filter = format!("fps={fps}:eof_action=pass");
        run_ffmpeg(video, decoder, (&filter, frames), &dir)?;
        out.check_same(&dir, &held)?;
    }
    check_some_frame(video, &dir)?;
    Ok(dir)
}

/// ffmpeg decoding `video`'s first video stream through the `-vf` `filter` into
/// `dir`'s numbered PNGs, at most `frames`; its failure names the video with
/// ffmpeg's own (bounded) words.
fn run_ffmpeg(
    video: &Path,
    decoder: &Decoder,
    (filter, frames): (&str, usize),
    dir: &Path,
) -> Result<(), FitError> {
    let output = std::process::Command::new(&decoder.ffmpeg)
        .args(["-nostdin", "-hide_banner", "-loglevel", "error", "-i"])
        .arg(video)
        // The stream ffprobe measured (`v:0`): left to choose, ffmpeg takes the video
        // stream of the most pixels, which the budgets never saw.
        .args(["-map", "0:v:0"])
        .args(["-vf", filter, "-frames:v", &frames.to_string()])
        .args(["-start_number", "0"])
        .arg(dir.join("frame_%05d.png"))
        .stdin(std::process::Stdio::null())
        .output()
        .map_err(io_err(&decoder.ffmpeg))?;
    if !output.status.success() {
        return Err(decode_err(video, bounded_text(&output.stderr)));
    }
    Ok(())
}

fn is_empty(dir: &Path) -> Result<bool, FitError> {
    let mut entries = std::fs::read_dir(dir).map_err(io_err(dir))?;
    Ok(entries.next().is_none())
}

/// Refuses, naming the video, a decode that gave no frame (a still image given as a
/// video, a stream without frames): the frames folder's own error would name `OUT`.
fn check_some_frame(video: &Path, dir: &Path) -> Result<(), FitError> {
    if !is_empty(dir)? {
        return Ok(());
    }
    Err(decode_err(
        video,
        "ffmpeg gave no frame (a still image, or a video stream without frames)".into(),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn probe_lines_are_read_and_a_missing_size_is_named() {
        let text = "streams.stream.0.width=1920\nstreams.stream.0.height=1080\n\
                    streams.stream.0.duration=\"12.5\"\nformat.duration=\"12.5\"\n";
        let p = parse_probe(text).expect("probe");
        assert_eq!((p.width, p.height, p.duration_s), (1920, 1080, Some(12.5)));
        let text = "streams.stream.0.width=640\nstreams.stream.0.height=512\n\
                    streams.stream.0.duration=\"N/A\"\nformat.duration=\"N/A\"";
        assert_eq!(parse_probe(text).expect("probe").duration_s, None);
        let still = |format: &str| {
            let text = format!("{text}\nformat.format_name=\"{format}\"");
            parse_probe(&text).expect("probe").still
        };
        assert!(still("png_pipe") && still("jpeg_pipe") && still("image2"));
        assert!(!still("mov,mp4,m4a,3gp,3g2,mj2") && !still("matroska,webm"));
        for bad in [
            "",
            "format.duration=\"3\"",
            "streams.stream.0.width=0\nstreams.stream.0.height=10",
            "streams.stream.0.width=x\nstreams.stream.0.height=10",
        ] {
            let e = parse_probe(bad).expect_err(bad);
            assert!(e.contains("no video stream"), "{bad}: {e}");
        }
    }

    /// A container that claims more than its stream holds: the stream's duration;
    /// only one of them stated: that one.
    #[test]
    fn the_shorter_of_the_streams_and_the_containers_durations_is_kept() {
        let size = "streams.stream.0.width=64\nstreams.stream.0.height=48\n";
        let both = format!("{size}streams.stream.0.duration=\"3.0\"\nformat.duration=\"3600\"");
        assert_eq!(parse_probe(&both).expect("probe").duration_s, Some(3.0));
        let stream = format!("{size}streams.stream.0.duration=\"4.5\"\nformat.duration=\"N/A\"");
        assert_eq!(parse_probe(&stream).expect("probe").duration_s, Some(4.5));
        let format = format!("{size}streams.stream.0.duration=\"N/A\"\nformat.duration=\"7\"");
        assert_eq!(parse_probe(&format).expect("probe").duration_s, Some(7.0));
    }

    /// Counted packets over the average frame rate, else the base rate; nothing
    /// when either is missing or zero.
    #[test]
    fn a_duration_is_counted_from_packets_and_frame_rate() {
        let line = |k: &str, v: &str| format!("streams.stream.0.{k}=\"{v}\"\n");
        let text = line("r_frame_rate", "25/1") + &line("avg_frame_rate", "10/1");
        let counted =
            |t: &str| parse_counted(&(t.to_string() + "streams.stream.0.nb_read_packets=\"30\""));
        assert_eq!(counted(&text), Some(3.0));
        let text = line("r_frame_rate", "30000/1001") + &line("avg_frame_rate", "0/0");
        assert!((counted(&text).expect("counted") - 1.001).abs() < 1e-9);
        assert_eq!(
            counted(&(line("r_frame_rate", "0/0") + &line("avg_frame_rate", "0/0"))),
            None
        );
        assert_eq!(parse_counted(&line("avg_frame_rate", "10/1")), None);
    }
}
