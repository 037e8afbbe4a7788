//! Presets that validation accepts but whose cost their limits did not
//! bound (the bounds audit): a PSF at its widest on the largest frame, a
//! kilometres-long band of tree lines, confusers outside `check`'s sample,
//! thousands of large drones in front of the camera, motion blur over the
//! whole frame. Each is now refused by name, or costs what its limit says.

use crate::common::cli::{err, ok};

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// A quickstart-like preset (1–15 quadcopters, 4 frames) at `resolution`,
/// with `replace` applied to its text and `extra` fields appended.
fn preset(resolution: &str, replace: &[(&str, &str)], extra: &str) -> String {
    let mut text = format!(
        r#"(
    version: 1,
    name: "bounds",
    seed: 2024,
    models: [(source: Builtin("quad_x"), size_m: 0.35, class: "uav")],
    placement: Randomized(
        count: (1, 15),
        volume: Box(size_m: (8.0, 4.0, 8.0)),
        min_separation_m: 0.7,
    ),
    camera: (
        y: (start: -0.3, end: 0.3, step: 0.6),
        z: (start: 0.8, end: 1.2, step: 0.4),
        fov_y_deg: 50.0,
    ),
    repeats: 1,
    render: (resolution: {resolution}, msaa: 1),
    output: (image_format: Png),
"#
    );
    for (from, to) in replace {
        assert!(text.contains(from), "{from}");
        text = text.replace(from, to);
    }
    text + extra + ")\n"
}

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, text).expect("write preset");
    path
}

/// `swarmshot ARGS` run to its end within `limit` (killed and failed past
/// it): whether it succeeded, and stderr then stdout.
fn within(args: &[&std::ffi::OsStr], limit: Duration) -> (bool, String) {
    let mut child = Command::new(env!("CARGO_BIN_EXE_swarmshot"))
        .args(args)
        .env("RUST_BACKTRACE", "0")
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn swarmshot");
    let start = Instant::now();
    while child.try_wait().expect("wait").is_none() {
        if start.elapsed() > limit {
            let _ = child.kill();
            let _ = child.wait();
            panic!("still running after {limit:?}: {args:?}");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    let out = child.wait_with_output().expect("output");
    let text =
        String::from_utf8_lossy(&out.stderr).into_owned() + &String::from_utf8_lossy(&out.stdout);
    (out.status.success(), text)
}

/// A Gaussian PSF of σ 64 px on a 16384 × 9000 frame convolved each pixel
/// with 770 taps: over two minutes a frame. Refused by `check` at once,
/// naming the field; the same σ on a 1920 × 1080 frame stays allowed.
#[test]
fn a_psf_past_its_work_budget_on_the_frame_is_refused_by_name() {
    let dir = tempfile::tempdir().expect("temp dir");
    let big = "Custom(width: 16384, height: 9000)";
    for (psf, field) in [
        (
            "Gaussian(sigma_px: (0.0, 64.0))",
            "camera_model.psf.sigma_px",
        ),
        (
            "Disc(radius_px: (64.0, 64.0))",
            "camera_model.psf.radius_px",
        ),
    ] {
        let extra = format!("    camera_model: Some((psf: {psf})),\n");
        let path = write(dir.path(), "wide.ron", &preset(big, &[], &extra));
        let e = err(&[Path::new("check"), path.as_path()]);
        assert!(e.contains(field) && e.contains("work budget"), "{e}");
        assert!(e.contains("16384×9000"), "{e}");
    }
    let extra = "    camera_model: Some((psf: Gaussian(sigma_px: (64.0, 64.0)))),\n";
    let path = write(dir.path(), "hd.ron", &preset("FullHd", &[], extra));
    ok(&[Path::new("check"), path.as_path()]);
}

/// `check` sampled frames by their drones alone: 15 drones and 16 000
/// confusers a frame had it estimate 200 frames (3.2 million objects, 30 s
/// in a release build). Confusers count now: a frame past the sample's
/// objects skips the estimate, as a frame of too many drones does.
#[test]
fn check_samples_frames_by_their_drones_and_confusers() {
    let dir = tempfile::tempdir().expect("temp dir");
    let entry = "        (kind: Bird(Gull), count: (500, 500), distance_m: (20.0, 200.0)),\n";
    let extra = format!("    confusers: [\n{}    ],\n", entry.repeat(32));
    let replace = [
        ("count: (1, 15)", "count: (190000, 190000)"),
        ("(8.0, 4.0, 8.0)", "(9000.0, 9000.0, 9000.0)"),
    ];
    let path = write(dir.path(), "flock.ron", &preset("FullHd", &replace, &extra));
    let (_, text) = within(
        &["check".as_ref(), path.as_os_str()],
        Duration::from_secs(60),
    );
    assert!(
        text.contains("estimate skipped: a frame holds up to 206000 drones and confusers"),
        "{text}"
    );
}

/// A tree line's crowns were each compared with every point of its band:
/// 64 bands 360° wide at up to 20 km took about a second a frame (2 minutes
/// for `check`'s sample, where one frame renders in 3 s). A point now looks
/// only at the crowns within reach, with the same result.
#[test]
fn kilometres_of_tree_lines_are_checked_in_seconds() {
    let dir = tempfile::tempdir().expect("temp dir");
    let extra = "    clutter: Some((
        tree_lines: (count: (64, 64), distance_m: (10000.0, 20000.0), height_m: (500.0, 500.0), width_deg: (360.0, 360.0)),
        trees: (count: (0, 0)), poles: (count: (0, 0)), buildings: (count: (0, 0)),
    )),
";
    let frames = [("repeats: 1", "repeats: 10")];
    let path = write(dir.path(), "forest.ron", &preset("FullHd", &frames, extra));
    // 40 frames: about 2.5 s; over 40 s (release build) before.
    let limit = Duration::from_secs(15);
    let (success, text) = within(&["check".as_ref(), path.as_os_str()], limit);
    assert!(success, "{text}");
    assert!(
        text.contains("estimated from the first 40 frames"),
        "{text}"
    );
}

/// `dir/wall.ron`: 3000 drones of 3 m around a camera 0.1 volume radii from
/// the centre, 320×180, two frames (CameraY −0.3 and 0.3).
fn wall_of_drones(dir: &Path) -> PathBuf {
    let replace = [
        ("count: (1, 15)", "count: (3000, 3000)"),
        ("size_m: 0.35", "size_m: 3.0"),
        ("min_separation_m: 0.7", "min_separation_m: 0.0"),
        (
            "z: (start: 0.8, end: 1.2, step: 0.4)",
            "z: (start: 0.1, end: 0.1, step: 0.0)",
        ),
    ];
    let res = "Custom(width: 320, height: 180)";
    write(dir, "wall.ron", &preset(res, &replace, ""))
}

/// 3000 drones of 3 m around a close camera cover the picture hundreds of
/// times over: 10 000 of them drew for two minutes before the visibility's
/// budget refused the frame. The fill budget refuses it from the scene's
/// geometry, before anything is drawn or written.
#[test]
fn drones_covering_the_picture_past_the_fill_budget_are_refused_before_drawing() {
    let dir = tempfile::tempdir().expect("temp dir");
    let path = wall_of_drones(dir.path());
    let text = frame_refused(dir.path(), &path, Duration::from_secs(30));
    assert!(
        text.contains("error: frame 0: placement:") && text.contains("work budget"),
        "{text}"
    );
}

/// `swarmshot frame PRESET --out DIR/f.png`, failed within `limit` with
/// nothing written: what it said.
fn frame_refused(dir: &Path, preset: &Path, limit: Duration) -> String {
    let out = dir.join("f.png");
    let args = [
        "frame".as_ref(),
        preset.as_os_str(),
        "--out".as_ref(),
        out.as_os_str(),
    ];
    let (success, text) = within(&args, limit);
    assert!(!success, "{text}");
    assert!(!out.exists(), "{text}");
    text
}

/// `check` tells the first sampled frame past the fill budget (from geometry,
/// as the batch does before drawing it), where a batch would stop hours in.
#[test]
fn check_names_the_first_frame_past_the_fill_budget() {
    let dir = tempfile::tempdir().expect("temp dir");
    let path = wall_of_drones(dir.path());
    // Both frames are over it: the first is named, once.
    let warned = budget_warnings(&path);
    assert_eq!(warned.len(), 1, "{warned:?}");
    assert!(
        warned[0].starts_with("warning: frame 0: placement:"),
        "{warned:?}"
    );
}

/// `swarmshot check PRESET` succeeded within 30 s: its lines that warn of
/// a frame past a work budget, each of which must say the batch stops there.
fn budget_warnings(preset: &Path) -> Vec<String> {
    let (success, text) = within(
        &["check".as_ref(), preset.as_os_str()],
        Duration::from_secs(30),
    );
    assert!(success, "{text}");
    let warned: Vec<String> = (text.lines())
        .filter(|l| l.contains("work budget"))
        .map(str::to_owned)
        .collect();
    assert!(
        (warned.iter()).all(|l| l.ends_with("a rendered batch stops at this frame")),
        "{text}"
    );
    warned
}

/// `dir/streak.ron`: eight 2 m drones crossing a 1920 × 1080 frame close to
/// the camera with a one-second shutter (a one-step sequence).
fn streaking_drones(dir: &Path) -> PathBuf {
    let replace = [
        ("count: (1, 15)", "count: (8, 8)"),
        ("size_m: 0.35", "size_m: 2.0"),
        ("min_separation_m: 0.7", "min_separation_m: 0.0"),
        (
            "z: (start: 0.8, end: 1.2, step: 0.4)",
            "z: (start: 0.15, end: 0.15, step: 0.0)",
        ),
        // Two sequences: all for training, so `check` finds no split empty.
        (
            "image_format: Png",
            "image_format: Png, split: (train: 1.0, val: 0.0, test: 0.0)",
        ),
    ];
    let extra = "    sequence: (
        steps: 1,
        motion: (translate_m: (40.0, 0.0, 0.0)),
        camera: Fixed,
        frame_rate: 1,
    ),
    camera_model: Some((exposure_time_s: (1.0, 1.0))),
";
    write(dir, "streak.ron", &preset("FullHd", &replace, extra))
}

/// The streaking drones: the blur sampled each swept pixel 512 times,
/// 2·10⁹ samples (69 s for 20 such drones, over 2 minutes at 4K). Now a
/// named error before the blur.
#[test]
fn motion_blur_past_its_work_budget_is_a_named_error() {
    let dir = tempfile::tempdir().expect("temp dir");
    let path = streaking_drones(dir.path());
    let text = frame_refused(dir.path(), &path, Duration::from_secs(60));
    assert!(
        text.contains("camera_model.exposure_time_s") && text.contains("work budget"),
        "{text}"
    );
}

/// `check` tells the first frame past the blur budget from the streaks'
/// geometry, as it does the fill budget.
#[test]
fn check_names_the_first_frame_past_the_blur_budget() {
    let dir = tempfile::tempdir().expect("temp dir");
    let warned = budget_warnings(&streaking_drones(dir.path()));
    assert!(!warned.is_empty(), "no frame named");
    assert!(
        warned[0].starts_with("warning: frame ")
            && warned[0].contains("camera_model.exposure_time_s"),
        "{warned:?}"
    );
}

/// `--makers` had no limit: each maker renders with its own renderer, and
/// 108 makers of the quickstart died with `wgpu error: Out of Memory` (a
/// panic). Past 64, or past what the memory holds for that many frames,
/// the batch is refused before the output folder is made.
#[test]
fn too_many_makers_are_refused_before_anything_is_written() {
    let dir = tempfile::tempdir().expect("temp dir");
    let out = dir.path().join("ds");
    let small = "Custom(width: 320, height: 180)";
    let path = write(dir.path(), "small.ron", &preset(small, &[], ""));
    let batch = |path: &Path, makers: &str| {
        let args = [Path::new("batch"), path, Path::new("--out"), out.as_path()];
        err(&[&args[..], &[Path::new("--makers"), Path::new(makers)]].concat())
    };
    let e = batch(&path, "1000");
    assert!(e.contains("--makers 1000: at most 64 makers"), "{e}");
    // 60 frames of 16384 × 9000 at once: about 7.7 GiB each.
    let big = "Custom(width: 16384, height: 9000)";
    let path = write(
        dir.path(),
        "big.ron",
        &preset(big, &[("repeats: 1", "repeats: 16")], ""),
    );
    let e = batch(&path, "60");
    assert!(
        e.contains("--makers 60: each maker renders its own frame"),
        "{e}"
    );
    assert!(!out.exists());
}
