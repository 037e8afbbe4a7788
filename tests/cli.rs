//! The `swarmshot` binary: check, frame and batch from a preset file.

mod common;

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
