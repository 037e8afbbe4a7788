//! The Batch panel's "one frame in K" trial run (issue 24): the field reaches
//! the batch's options, and (with `run_batch`'s `every`) limits the frames written.
#![cfg(feature = "app")]
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::{Path, PathBuf};

use egui_kittest::kittest::Queryable;
use swarmshot::app::SwarmshotApp;
use swarmshot::app::runner::BatchOutcome;

use crate::app_common;
use app_common::{GPU, harness, wait_for};

/// 2 camera distances × 2 rotations × … = 6 frames at 96×64.
const TINY: &str = r#"(
    name: "tiny",
    seed: 11,
    placement: Structured(x_count: 2, y_count: 1, z_count: 1, load_factor: 3.0),
    camera: (z: (start: 1.0, end: 2.0, step: 0.5)),
    plane: (ry: (start: 0.0, end: 90.0, step: 90.0)),
    render: (resolution: Custom(width: 96, height: 64), msaa: 1),
    output: (image_format: Png, label_formats: [Yolo], split: (train: 1.0, val: 0.0, test: 0.0)),
)"#;

fn tiny(dir: &Path) -> PathBuf {
    let path = dir.join("tiny.ron");
    std::fs::write(&path, TINY).unwrap();
    path
}

fn settled(app: &SwarmshotApp) -> bool {
    app.preview_is_current() && app.summary_is_current()
}

/// Switch "one frame in K" on with K = `k` through the widgets.
fn ask_for_every(h: &mut egui_kittest::Harness<'_, SwarmshotApp>, k: u64) {
    h.get_by_label("Trial run: one frame in").click();
    wait_for(h, "one frame in K switched on", |app| app.session().every);
    h.get_by_label("Every Kth frame")
        .set_value_accesskit(k as f64);
    wait_for(h, "K taken", move |app| app.session().every_k == k);
}

#[test]
fn one_frame_in_k_reaches_the_batch_options() {
    let _gpu = GPU.lock().unwrap_or_else(|e| e.into_inner());
    let dir = tempfile::tempdir().unwrap();
    let mut h = harness(Some(tiny(dir.path())));
    wait_for(&mut h, "the first preview", settled);
    assert_eq!(h.state().batch_options().every, None, "off by default");

    ask_for_every(&mut h, 3);
    let options = h.state().batch_options();
    assert_eq!(options.every, Some(3));
    assert_eq!(options.limit, None, "one frame in K is not a first-N limit");

    h.get_by_label("Trial run: one frame in").click();
    wait_for(&mut h, "one frame in K switched off", |app| {
        !app.session().every
    });
    assert_eq!(h.state().batch_options().every, None);
}

#[test]
fn one_frame_in_k_limits_the_frames_written() {
    let _gpu = GPU.lock().unwrap_or_else(|e| e.into_inner());
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let mut h = harness(Some(tiny(dir.path())));
    wait_for(&mut h, "the first preview", settled);
    h.state_mut().session_mut().out_dir = out.display().to_string();
    wait_for(&mut h, "the preview after the folder", settled);
    ask_for_every(&mut h, 2);
    h.get_by_role_and_label(egui::accesskit::Role::Button, "Generate")
        .click();
    h.run_steps(2);
    wait_for(&mut h, "the batch to end", |app| {
        !app.batch_running() && app.batch_outcome().is_some()
    });
    let report = match h.state().batch_outcome() {
        Some(BatchOutcome::Done(report)) => (**report).clone(),
        Some(BatchOutcome::Failed(e)) => panic!("batch failed: {e}"),
        None => panic!("no batch outcome"),
    };
    // Frames 0, 2 and 4 of 6.
    assert_eq!(report.made, 3, "{report:?}");
    let images = std::fs::read_dir(out.join("images/train")).unwrap().count();
    assert_eq!(images, 3);
}
