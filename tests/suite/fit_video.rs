//! `swarmshot fit --real VIDEO`: ffprobe reads the video's frame size and duration first,
//! so frames past fit's pixel budgets are refused before anything is written; ffmpeg then
//! decodes the frames, which fit reads as a folder's. The tests make their videos with
//! ffmpeg (lossless FFV1, so the decoded frames can be compared with their sources) and
//! need it on PATH: `scripts/test.sh` installs it and sets SWARMSHOT_REQUIRE_FFMPEG=1,
//! which makes a missing ffmpeg a failure; elsewhere the tests say they skipped.

use crate::common;

use std::path::{Path, PathBuf};
use std::process::Command;

fn swarmshot() -> Command {
    Command::new(env!("CARGO_BIN_EXE_swarmshot"))
}

fn tmp(name: &str) -> common::Scratch {
    let d = common::Scratch::new(&format!("fitvideo-{name}"));
    std::fs::create_dir(&*d).expect("tmp dir");
    d
}

/// Whether ffmpeg and ffprobe run; a failure instead of a skip under
/// SWARMSHOT_REQUIRE_FFMPEG=1.
fn have_ffmpeg() -> bool {
    let runs = |p: &str| {
        Command::new(p)
            .arg("-version")
            .output()
            .is_ok_and(|o| o.status.success())
    };
    let found = runs("ffmpeg") && runs("ffprobe");
    if !found {
        assert!(
            std::env::var("SWARMSHOT_REQUIRE_FFMPEG").as_deref() != Ok("1"),
            "SWARMSHOT_REQUIRE_FFMPEG=1 but ffmpeg/ffprobe do not run (scripts/setup.sh ffmpeg installs them)"
        );
        eprintln!("\n*** SKIPPED a fit-from-video test: ffmpeg/ffprobe not on PATH.\n");
    }
    found
}

/// Runs ffmpeg with `args`, writing `out`.
fn ffmpeg(args: &[&str], out: &Path) {
    let o = Command::new("ffmpeg")
        .args(["-nostdin", "-hide_banner", "-loglevel", "error", "-y"])
        .args(args)
        .arg(out)
        .output()
        .expect("run ffmpeg");
    assert!(
        o.status.success(),
        "ffmpeg: {}",
        String::from_utf8_lossy(&o.stderr)
    );
}

/// A lossless FFV1 clip at `out` of ffmpeg's generated `source` (a lavfi filter graph).
fn lavfi_ffv1(source: &str, out: &Path) {
    ffmpeg(&["-f", "lavfi", "-i", source, "-c:v", "ffv1"], out);
}

fn fit(video: &Path, out: &Path, extra: &[&str]) -> std::process::Output {
    swarmshot()
        .args(["fit", "--real"])
        .arg(video)
        .arg("--out")
        .arg(out)
        .args(["--rounds", "0", "--unlabelled-ok"])
        .args(extra)
        .output()
        .expect("run swarmshot fit")
}

/// The bundled real frames (PNG), in name order.
fn real_pngs() -> Vec<PathBuf> {
    let real = common::testdata("real/images");
    let mut sources = frame_files(&real);
    sources.retain(|p| p.extension().is_some_and(|e| e == "png"));
    sources
}

/// The bundled real frames as a lossless 2 fps FFV1 clip in `dir`.
fn lossless_clip(dir: &Path) -> PathBuf {
    let video = dir.join("clip.mkv");
    let pattern = format!("{}/*.png", common::testdata("real/images").display());
    let input = ["-framerate", "2", "-pattern_type", "glob", "-i", &pattern];
    ffmpeg(
        &[&input[..], &["-c:v", "ffv1", "-pix_fmt", "bgr0"]].concat(),
        &video,
    );
    video
}

fn rgb(path: &Path) -> image::RgbImage {
    image::open(path).expect("decode").to_rgb8()
}

#[test]
fn a_video_is_fitted_from_exactly_its_frames() {
    if !have_ffmpeg() {
        return;
    }
    let dir = tmp("lossless");
    let sources = real_pngs();
    // 2 frames a second, lossless: `--video-fps 2` takes every frame once.
    let video = lossless_clip(&dir);
    let out = dir.join("fit");
    let o = fit(&video, &out, &[]);
    assert!(
        o.status.success(),
        "fit: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    let decoded = frame_files(&out.join("frames"));
    assert_eq!(decoded.len(), sources.len(), "one frame each: {decoded:?}");
    for (s, d) in sources.iter().zip(&decoded) {
        assert!(
            rgb(s) == rgb(d),
            "{} decoded unlike {}",
            d.display(),
            s.display()
        );
    }
    let plates = std::fs::read_dir(out.join("plates"))
        .expect("plates/")
        .count();
    assert!(plates >= sources.len(), "{plates} plate files");
    let footage: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("footage.json")).expect("footage.json"))
            .expect("json");
    assert_eq!(
        footage["frames"].as_u64(),
        Some(sources.len() as u64),
        "{footage}"
    );
    assert!(out.join("fitted.ron").is_file());
}

#[test]
fn a_video_longer_than_its_frames_cover_is_sampled_over_its_whole_length() {
    if !have_ffmpeg() {
        return;
    }
    let dir = tmp("spread");
    let sources = real_pngs();
    let video = lossless_clip(&dir);
    // 10 frames at 2 a second (5 s); 5 frames at `--video-fps 2` would cover the first
    // 2.5 s: they are taken 1 s apart instead, frames 0, 2, 4, 6 and 8.
    let out = dir.join("fit");
    fits_every_other_frame(&video, &out, &["--max-frames", "5"], &sources);
}

/// Fits `video` into `out` with `extra` options and asserts its decoded frames are
/// `sources` 0, 2, 4, 6 and 8.
fn fits_every_other_frame(video: &Path, out: &Path, extra: &[&str], sources: &[PathBuf]) {
    let o = fit(video, out, extra);
    assert!(
        o.status.success(),
        "fit: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    let decoded = frame_files(&out.join("frames"));
    assert_eq!(decoded.len(), 5, "{decoded:?}");
    for (k, d) in decoded.iter().enumerate() {
        let s = &sources[2 * k];
        assert!(rgb(s) == rgb(d), "{} is not {}", d.display(), s.display());
    }
}

/// A raw MJPEG stream states no duration (neither stream nor container): it is counted
/// from the stream's packets (10) over its frame rate (25 a second), so the frames are
/// still spread over the whole stream.
#[test]
fn a_stream_without_a_stated_duration_is_sampled_over_its_counted_length() {
    if !have_ffmpeg() {
        return;
    }
    let dir = tmp("counted");
    let pattern = format!("{}/*.png", common::testdata("real/images").display());
    let video = dir.join("clip.mjpeg");
    let input = ["-framerate", "25", "-pattern_type", "glob", "-i", &pattern];
    ffmpeg(
        &[&input[..], &["-c:v", "mjpeg", "-f", "mjpeg"]].concat(),
        &video,
    );
    // Every frame of the stream, as the same decoder gives it.
    let every = dir.join("every");
    std::fs::create_dir_all(&every).expect("every/");
    ffmpeg(
        &["-i", video.to_str().expect("utf-8"), "-start_number", "0"],
        &every.join("f_%03d.png"),
    );
    let sources = frame_files(&every);
    assert_eq!(sources.len(), 10, "{sources:?}");
    // 5 frames at `--video-fps 25` would be the first five; over the counted 0.4 s
    // they are frames 0, 2, 4, 6 and 8.
    let out = dir.join("fit");
    let extra = ["--max-frames", "5", "--video-fps", "25"];
    fits_every_other_frame(&video, &out, &extra, &sources);
}

#[test]
fn a_video_past_the_pixel_budgets_is_refused_before_anything_is_written() {
    if !have_ffmpeg() {
        return;
    }
    let dir = tmp("budget");
    // One frame of 8 200 × 8 200 (67 Mpx, past the 64 Mpx an image may have).
    let huge = dir.join("huge.mkv");
    lavfi_ffv1("color=c=gray:s=8200x8200:r=1:d=1", &huge);
    // 100 s of 4 000 × 4 000 (one frame, but the container says 100 s: at 2 frames a
    // second the decode may give 200 frames, 3 200 Mpx, past fit's 2 000).
    let long = dir.join("long.mkv");
    lavfi_ffv1("color=c=gray:s=4000x4000:r=0.01:d=100", &long);
    for (video, what) in [
        (&huge, "8200×8200 is 67240000 pixels"),
        (&long, "pass --max-frames 125 or fewer"),
    ] {
        let out = dir.join("out");
        let o = fit(video, &out, &[]);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{what}: succeeded");
        assert!(err.contains(what), "expected `{what}` in: {err}");
        assert!(!out.exists(), "{what}: {} was written", out.display());
    }
}

#[test]
fn a_file_that_is_no_video_is_a_named_error_and_nothing_is_written() {
    if !have_ffmpeg() {
        return;
    }
    let dir = tmp("garbage");
    let video = dir.join("clip.mp4");
    std::fs::write(&video, b"\x00\x00\x00\x18ftypmp42 not a real video").expect("write");
    let out = dir.join("out");
    let o = fit(&video, &out, &[]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert!(
        err.contains("clip.mp4: ffmpeg could not decode the video"),
        "{err}"
    );
    assert!(!out.exists());
}

#[test]
fn a_clip_shorter_than_a_sampling_interval_gives_its_last_frame() {
    if !have_ffmpeg() {
        return;
    }
    let dir = tmp("short");
    // Three frames of 30 fps (0.1 s), red, green, blue: at 2 frames a second ffmpeg's
    // `fps` filter alone rounds them all away.
    let video = dir.join("short.mkv");
    let colour = |c: &str| format!("color=c={c}:s=96x96:r=30:d=0.0334");
    let graph = format!(
        "{}[a];{}[b];{}[c];[a][b][c]concat=n=3",
        colour("red"),
        colour("green"),
        colour("blue")
    );
    lavfi_ffv1(&graph, &video);
    let out = dir.join("out");
    let o = fit(&video, &out, &[]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let frames = frame_files(&out.join("frames"));
    assert_eq!(frames.len(), 1, "{frames:?}");
    let px = *rgb(&frames[0]).get_pixel(48, 48);
    assert!(px[2] > 240 && px[0] < 16 && px[1] < 16, "{px:?}");
}

/// The frames of `dir`, sorted.
fn frame_files(dir: &Path) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
        .expect("frames")
        .map(|e| e.expect("entry").path())
        .collect();
    v.sort();
    v
}

#[test]
fn ffmpeg_decodes_the_stream_ffprobe_measured_not_a_larger_one() {
    if !have_ffmpeg() {
        return;
    }
    let dir = tmp("streams");
    // Stream 0 is 128², stream 1 is 3 000²: ffmpeg alone picks the larger one (its
    // pixels outweigh the first stream's default flag), which the pixel budgets (read
    // from stream 0) never saw.
    let video = dir.join("two.mkv");
    ffmpeg(
        &[
            "-f",
            "lavfi",
            "-i",
            "color=c=gray:s=128x128:r=2:d=1",
            "-f",
            "lavfi",
            "-i",
            "color=c=gray:s=3000x3000:r=2:d=1",
            "-map",
            "0",
            "-map",
            "1",
            "-c:v",
            "ffv1",
        ],
        &video,
    );
    let out = dir.join("out");
    let o = fit(&video, &out, &[]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let frames = frame_files(&out.join("frames"));
    assert!(!frames.is_empty());
    for f in frames {
        assert_eq!(rgb(&f).dimensions(), (128, 128), "{}", f.display());
    }
}

#[test]
fn a_video_of_frames_too_small_is_refused_naming_it_before_anything_is_written() {
    if !have_ffmpeg() {
        return;
    }
    let dir = tmp("tiny");
    let video = dir.join("tiny.mkv");
    lavfi_ffv1("color=c=gray:s=32x48:r=2:d=1", &video);
    let out = dir.join("out");
    let o = fit(&video, &out, &[]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert!(
        err.contains("tiny.mkv: 32×48 is smaller than the 64 px a frame needs"),
        "{err}"
    );
    assert!(!out.exists(), "{} was written", out.display());
}

#[test]
fn plates_the_fitted_preset_could_not_load_are_refused_before_anything_is_written() {
    if !have_ffmpeg() {
        return;
    }
    let dir = tmp("plates");
    // 100 s of 640 × 512: at 2 frames a second 200 frames, × 9 views 1 800 plates
    // of 1.3 MB resampled, past the 2 GiB the plate loader takes (182 frames fit).
    let video = dir.join("long.mkv");
    lavfi_ffv1("color=c=gray:s=640x512:r=0.01:d=100", &video);
    let out = dir.join("out");
    let o = fit(&video, &out, &["--views", "9"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert!(err.contains("pass --max-frames 182 or fewer"), "{err}");
    assert!(!out.exists(), "{} was written", out.display());
}

#[test]
fn an_image_given_as_a_video_is_named_as_giving_no_frame() {
    if !have_ffmpeg() {
        return;
    }
    let dir = tmp("still");
    let video = dir.join("clip.mp4");
    // A PNG under a video's name: ffmpeg reads it, and its fps filter gives no frame.
    image::RgbImage::from_pixel(256, 256, image::Rgb([90, 120, 200]))
        .save_with_format(&video, image::ImageFormat::Png)
        .expect("write png");
    let out = dir.join("out");
    let o = fit(&video, &out, &[]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert!(
        err.contains("--real ")
            && err.contains("clip.mp4: ffmpeg could not decode the video: ffmpeg gave no frame"),
        "{err}"
    );
    // The decode's folder is taken away again: `--out` is left empty, so the next run
    // into it is not refused as "not empty and not an earlier fit".
    assert!(!out.join("frames").exists(), "OUT/frames/ left behind");
    let left: Vec<_> = std::fs::read_dir(&out).expect("out").collect();
    assert!(left.is_empty(), "{left:?}");
}
