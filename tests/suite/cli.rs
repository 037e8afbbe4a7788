//! The `swarmshot` binary: check, frame and batch from a preset file.

use crate::common;

use std::process::Command;

fn swarmshot() -> Command {
    Command::new(env!("CARGO_BIN_EXE_swarmshot"))
}

#[test]
fn check_prints_counts_and_rejects_bad_presets() {
    let out = swarmshot()
        .args([
            "check",
            concat!(env!("CARGO_MANIFEST_DIR"), "/presets/quickstart.ron"),
        ])
        .output()
        .expect("runs");
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{text}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(text.contains("frames: 108"), "{text}");
    assert!(text.contains("drones") && text.contains("volume"), "{text}");

    let dir = tempfile::tempdir().expect("tempdir");
    let bad = dir.path().join("bad.ron");
    std::fs::write(&bad, "(camera: (z: (start: 1.0, end: 2.0, step: 0.0)))").expect("write");
    let out = swarmshot()
        .args(["check"])
        .arg(&bad)
        .output()
        .expect("runs");
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("camera.z.step") && err.contains("bad.ron"),
        "{err}"
    );
}

#[test]
fn frame_and_batch_write_files() {
    let dir = tempfile::tempdir().expect("tempdir");
    let preset = dir.path().join("tiny.ron");
    std::fs::write(&preset, common::tiny_preset().to_ron()).expect("write preset");

    let png = dir.path().join("f.png");
    let out = swarmshot()
        .args(["frame"])
        .arg(&preset)
        .args(["--index", "3", "--overlay", "--out"])
        .arg(&png)
        .output()
        .expect("runs");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let img = image::open(&png).expect("png").to_rgb8();
    assert_eq!(img.dimensions(), (320, 180));
    assert!(
        img.pixels().any(|p| p.0 == [255, 40, 40]),
        "overlay boxes are drawn"
    );

    let data = dir.path().join("data");
    let out = swarmshot()
        .args(["batch"])
        .arg(&preset)
        .args(["--limit", "3", "--out"])
        .arg(&data)
        .output()
        .expect("runs");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let manifest = std::fs::read_to_string(data.join("manifest.jsonl")).expect("manifest");
    assert_eq!(manifest.lines().count(), 3);
}

/// `frame` is a batch of one: frame K's image bytes, YOLO lines and manifest
/// record equal what `batch` writes for K (JPEG, so quality and chroma count).
#[test]
fn frame_writes_exactly_what_the_batch_writes() {
    let dir = tempfile::tempdir().expect("tempdir");
    let mut p = common::tiny_preset();
    p.output.image_format = swarmshot::preset::ImageFormat::Jpeg { quality: 85 };
    p.render.msaa = 4;
    let preset = dir.path().join("tiny.ron");
    std::fs::write(&preset, p.to_ron()).expect("write preset");
    let data = dir.path().join("data");
    let mut batch = swarmshot();
    batch
        .arg("batch")
        .arg(&preset)
        .args(["--limit", "6", "--out"])
        .arg(&data);
    assert!(batch.status().expect("batch runs").success());
    let manifest = std::fs::read_to_string(data.join("manifest.jsonl")).expect("manifest");
    for index in [2u64, 5] {
        let jpg = dir.path().join(format!("f{index}.jpg"));
        let mut frame = swarmshot();
        frame
            .arg("frame")
            .arg(&preset)
            .args(["--index", &index.to_string(), "--out"])
            .arg(&jpg);
        assert!(frame.status().expect("frame runs").success());
        let line: serde_json::Value =
            serde_json::from_str(manifest.lines().nth(index as usize).expect("line"))
                .expect("json");
        let image = line["image"].as_str().expect("image path");
        assert_eq!(
            std::fs::read(&jpg).expect("frame image"),
            std::fs::read(data.join(image)).expect("batch image"),
            "frame {index}: image bytes differ from the batch's"
        );
        let labels = data
            .join(image.replace("images/", "labels/"))
            .with_extension("txt");
        assert_eq!(
            std::fs::read_to_string(jpg.with_extension("txt")).expect("frame labels"),
            std::fs::read_to_string(labels).expect("batch labels")
        );
        assert_eq!(
            std::fs::read_to_string(jpg.with_extension("json")).expect("frame record"),
            format!("{}\n", manifest.lines().nth(index as usize).expect("line"))
        );
    }
    // An extension that does not match the preset's format is refused before anything is written.
    let png = dir.path().join("wrong.png");
    let out = swarmshot()
        .arg("frame")
        .arg(&preset)
        .args(["--out"])
        .arg(&png)
        .output()
        .expect("runs");
    assert!(!out.status.success());
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("image_format"),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(!png.exists());
}

/// Commands that open no window print nothing from the window system: with the
/// Vulkan backend and `XDG_RUNTIME_DIR` unset, Mesa's device-select layer made
/// libwayland print "error: XDG_RUNTIME_DIR is invalid or not set" twice.
#[test]
fn check_and_batch_print_nothing_on_stderr_without_xdg_runtime_dir() {
    let dir = tempfile::tempdir().expect("tempdir");
    let preset = dir.path().join("tiny.ron");
    // Every frame to train: two frames must not leave a split empty (that warns, rightly).
    let mut tiny = common::tiny_preset();
    tiny.output.split.train = 1.0;
    tiny.output.split.val = 0.0;
    tiny.output.split.test = 0.0;
    std::fs::write(&preset, tiny.to_ron()).expect("write preset");
    let quiet = |args: &[&std::ffi::OsStr]| {
        let out = swarmshot()
            .args(args)
            .env_remove("XDG_RUNTIME_DIR")
            .env_remove("NODEVICE_SELECT")
            .env_remove("MESA_VK_DEVICE_SELECT")
            .env_remove("DRI_PRIME")
            .env("WGPU_BACKEND", "vulkan")
            .output()
            .expect("runs");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{args:?}: {err}");
        assert!(err.is_empty(), "{args:?} printed on stderr: {err}");
    };
    quiet(&["check".as_ref(), preset.as_os_str()]);
    let out = dir.path().join("out");
    quiet(&[
        "batch".as_ref(),
        preset.as_os_str(),
        "--out".as_ref(),
        out.as_os_str(),
        "--limit".as_ref(),
        "2".as_ref(),
    ]);
}

/// `swarmshot check P | head -1`: the reader goes away after one line; the command ends
/// quietly (by SIGPIPE, as Unix tools do), not with a panic on its closed stdout.
#[cfg(unix)]
#[test]
fn a_closed_stdout_ends_the_command_quietly() {
    use std::io::Read;
    use std::os::unix::process::ExitStatusExt;
    let mut child = swarmshot()
        .args([
            "check",
            concat!(env!("CARGO_MANIFEST_DIR"), "/presets/realistic.ron"),
        ])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("runs");
    // Read nothing: close the pipe at once, before the command's first line.
    drop(child.stdout.take());
    let mut err = String::new();
    child
        .stderr
        .take()
        .expect("stderr")
        .read_to_string(&mut err)
        .expect("stderr reads");
    let status = child.wait().expect("waits");
    assert!(!err.contains("panicked"), "{err}");
    assert!(!err.contains("Broken pipe"), "{err}");
    assert!(
        status.success() || status.signal() == Some(libc::SIGPIPE),
        "{status:?}: {err}"
    );
}
