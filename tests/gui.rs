//! The desktop app driven through its widgets with egui_kittest and the wgpu
//! renderer (Vulkan pinned: lavapipe on CI). A missing adapter makes the
//! harness panic ("Failed to create render state"): these tests never pass
//! without rendering.
#![allow(clippy::unwrap_used)]

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::time::{Duration, Instant};

use eframe::egui_wgpu;
use egui::accesskit::Role;
use egui_kittest::kittest::{NodeT as _, Queryable};
use egui_kittest::{Harness, SnapshotOptions};
use swarmshot::app::runner::BatchOutcome;
use swarmshot::app::{StartOptions, SwarmshotApp};

/// One harness at a time: each owns a lavapipe device and 2 cores are shared.
static GPU: Mutex<()> = Mutex::new(());

const WAIT: Duration = Duration::from_secs(300);

fn harness(preset: Option<PathBuf>) -> Harness<'static, SwarmshotApp> {
    let mut setup = egui_kittest::wgpu::default_wgpu_setup();
    if let egui_wgpu::WgpuSetup::CreateNew(create) = &mut setup {
        create.instance_descriptor.backends = wgpu::Backends::VULKAN;
    }
    Harness::builder()
        .with_size([1400.0, 880.0])
        .wgpu_setup(setup)
        .build_eframe(move |cc| {
            SwarmshotApp::new(
                cc,
                StartOptions {
                    preset,
                    restore_session: false,
                },
            )
        })
}

/// Step the UI until `done` holds (the workers answer asynchronously).
fn wait_for(h: &mut Harness<'_, SwarmshotApp>, what: &str, done: impl Fn(&SwarmshotApp) -> bool) {
    let start = Instant::now();
    loop {
        h.step();
        if done(h.state()) {
            h.step();
            h.step();
            return;
        }
        assert!(
            start.elapsed() < WAIT,
            "timed out after {WAIT:?} waiting for {what}"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
}

fn settled(app: &SwarmshotApp) -> bool {
    app.preview_is_current() && app.summary_is_current()
}

/// The preview pane's pixels in the last rendered window image.
fn preview_pixels(h: &mut Harness<'_, SwarmshotApp>) -> image::RgbaImage {
    let rect = h
        .state()
        .preview_rect()
        .expect("the preview pane was drawn");
    let ppp = h.ctx.pixels_per_point();
    let image = h.render().expect("render the window");
    let (x, y) = ((rect.min.x * ppp) as u32, (rect.min.y * ppp) as u32);
    let (w, h) = ((rect.width() * ppp) as u32, (rect.height() * ppp) as u32);
    image::imageops::crop_imm(&image, x, y, w, h).to_image()
}

fn differing_pixels(a: &image::RgbaImage, b: &image::RgbaImage) -> usize {
    assert_eq!(a.dimensions(), b.dimensions());
    a.pixels()
        .zip(b.pixels())
        .filter(|(p, q)| p.0.iter().zip(q.0).any(|(x, y)| x.abs_diff(y) > 8))
        .count()
}

fn write_preset(dir: &Path, name: &str, ron: &str) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, ron).unwrap();
    path
}

/// A small structured preset: 3×3×3 grid, one frame, 640×360.
const GRID: &str = r#"(
    name: "grid",
    seed: 7,
    placement: Structured(x_count: 3, y_count: 3, z_count: 3, load_factor: 4.0),
    camera: (z: (start: 1.0, end: 1.0, step: 0.0)),
    render: (resolution: Custom(width: 640, height: 360), msaa: 1),
)"#;

#[test]
fn xcount_and_camera_z_change_the_summary_and_the_preview() {
    let _gpu = GPU.lock().unwrap_or_else(|e| e.into_inner());
    let dir = tempfile::tempdir().unwrap();
    let mut h = harness(Some(write_preset(dir.path(), "grid.ron", GRID)));
    wait_for(&mut h, "the first preview and summary", settled);
    assert!(h.state().errors().is_empty(), "{:?}", h.state().errors());
    h.get_by_label("Frames: 1");
    h.get_by_label("Drones per frame: 27");
    let before = preview_pixels(&mut h);

    h.get_by_label("XCount").set_value_accesskit(5.0);
    wait_for(&mut h, "the preview and summary after XCount = 5", |app| {
        settled(app) && app.summary().is_some_and(|s| s.drones_max == 45)
    });
    h.get_by_label("Drones per frame: 45");
    let after = preview_pixels(&mut h);
    let changed = differing_pixels(&before, &after);
    assert!(
        changed > 200,
        "the preview changed in only {changed} pixels after XCount 3 → 5"
    );
    assert!(
        h.state().session().is_dirty(),
        "an edit marks the preset unsaved"
    );
    h.get_by_label("• unsaved changes");

    // CameraZ 1..2 step 0.5 is three frames.
    h.get_by_label("CameraZ end").set_value_accesskit(2.0);
    h.get_by_label("CameraZ step").set_value_accesskit(0.5);
    wait_for(&mut h, "three frames", |app| {
        settled(app) && app.summary().is_some_and(|s| s.frames == 3)
    });
    h.get_by_label("Frames: 3");
    h.get_by_label("frame 1 of 3");
    // Scrub to the last frame: the camera moves back, the picture changes.
    let first = preview_pixels(&mut h);
    h.get_by_label("Frame").set_value_accesskit(2.0);
    wait_for(&mut h, "frame 3", |app| {
        settled(app) && app.preview_key().is_some_and(|k| k.frame == 2)
    });
    h.get_by_label("frame 3 of 3");
    h.get_by_label_contains("CameraZ 2 ·");
    let last = preview_pixels(&mut h);
    assert!(
        differing_pixels(&first, &last) > 200,
        "scrubbing to frame 3 did not change the preview"
    );
}

#[test]
fn an_invalid_step_shows_its_message_at_the_widget() {
    let _gpu = GPU.lock().unwrap_or_else(|e| e.into_inner());
    let quickstart = Path::new(env!("CARGO_MANIFEST_DIR")).join("presets/quickstart.ron");
    let mut h = harness(Some(quickstart));
    wait_for(&mut h, "the first preview", settled);
    assert!(h.state().errors().is_empty());

    // Type a step that points away from the end (CameraZ runs 0.6 → 1.4).
    h.get_by_label("CameraZ step").click();
    h.run_steps(2);
    h.key_combination_modifiers(egui::Modifiers::COMMAND, &[egui::Key::A]);
    h.get_by_label("CameraZ step").type_text("-0.4");
    h.key_press(egui::Key::Enter);
    h.run_steps(3);

    assert_eq!(
        h.state().session().preset.camera.z.step,
        -0.4,
        "the typed value reached the preset"
    );
    let errors = h.state().errors();
    assert_eq!(errors.len(), 1, "{errors:?}");
    assert_eq!(errors[0].field, "camera.z.step");
    let message = h.get_by_label_contains("points away from end");
    // Shown right under the CameraZ row, not somewhere else.
    let step = h.get_by_label("CameraZ step").rect();
    let at = message.rect();
    assert!(
        at.top() >= step.bottom() - 1.0 && at.top() - step.bottom() < 30.0,
        "message at {at:?}, CameraZ step at {step:?}"
    );
    assert!(
        h.get_by_role_and_label(Role::Button, "Generate")
            .accesskit_node()
            .is_disabled(),
        "Generate is disabled while the preset is invalid"
    );
    h.get_by_label_contains("Preview paused");

    // Fixing it removes the message.
    h.get_by_label("CameraZ step").set_value_accesskit(0.4);
    h.run_steps(3);
    assert!(h.state().errors().is_empty());
    assert!(h.query_by_label_contains("points away from end").is_none());
}

/// 2 drones, CameraZ 1..2 step 0.5 × PlaneRY 0, 90 = 6 frames at 96×64.
const TINY: &str = r#"(
    name: "tiny",
    seed: 11,
    placement: Structured(x_count: 2, y_count: 1, z_count: 1, load_factor: 3.0),
    camera: (z: (start: 1.0, end: 2.0, step: 0.5)),
    plane: (ry: (start: 0.0, end: 90.0, step: 90.0)),
    render: (resolution: Custom(width: 96, height: 64), msaa: 1),
    output: (image_format: Png, label_formats: [Yolo, Coco], split: (train: 0.5, val: 0.25, test: 0.25)),
)"#;

fn files_under(dir: &Path, ext: &str) -> BTreeSet<PathBuf> {
    let mut out = BTreeSet::new();
    for split in ["train", "val", "test"] {
        let d = dir.join(split);
        if let Ok(entries) = std::fs::read_dir(&d) {
            for e in entries {
                let p = e.unwrap().path();
                if p.extension().is_some_and(|x| x == ext) {
                    out.insert(p.strip_prefix(dir).unwrap().to_owned());
                }
            }
        }
    }
    out
}

fn stems(files: &BTreeSet<PathBuf>) -> BTreeSet<PathBuf> {
    files.iter().map(|p| p.with_extension("")).collect()
}

#[test]
fn generate_writes_the_same_dataset_as_the_cli() {
    let _gpu = GPU.lock().unwrap_or_else(|e| e.into_inner());
    let dir = tempfile::tempdir().unwrap();
    let preset = write_preset(dir.path(), "tiny.ron", TINY);
    let gui_out = dir.path().join("from-gui");
    let mut h = harness(Some(preset.clone()));
    wait_for(&mut h, "the first preview", settled);
    h.state_mut().session_mut().out_dir = gui_out.display().to_string();
    h.run_steps(2);
    h.get_by_role_and_label(Role::Button, "Generate").click();
    h.run_steps(2);
    wait_for(&mut h, "the batch to finish", |app| {
        !app.batch_running() && app.batch_outcome().is_some()
    });
    match h.state().batch_outcome() {
        Some(BatchOutcome::Done(report)) => {
            assert!(!report.cancelled);
            assert_eq!(report.stats.frames, 6);
        }
        Some(BatchOutcome::Failed(e)) => panic!("batch failed: {e}"),
        None => unreachable!(),
    }
    h.get_by_label_contains("Finished: 6 frames");
    h.get_by_role_and_label(Role::Button, "Open output folder");

    let images = files_under(&gui_out.join("images"), "png");
    let labels = files_under(&gui_out.join("labels"), "txt");
    assert_eq!(images.len(), 6, "{images:?}");
    assert_eq!(stems(&images), stems(&labels));

    // The CLI on the same preset file writes byte-identical labels.
    let cli_out = dir.path().join("from-cli");
    let status = std::process::Command::new(env!("CARGO_BIN_EXE_swarmshot"))
        .args([
            "batch",
            preset.to_str().unwrap(),
            "--out",
            cli_out.to_str().unwrap(),
        ])
        .status()
        .unwrap();
    assert!(status.success());
    assert_eq!(files_under(&cli_out.join("images"), "png"), images);
    for rel in labels.iter().map(|p| Path::new("labels").join(p)).chain(
        [
            "manifest.jsonl",
            "preset.lock.ron",
            "stats.json",
            "annotations/instances_train.json",
            "annotations/instances_val.json",
            "annotations/instances_test.json",
        ]
        .map(PathBuf::from),
    ) {
        let (a, b) = (
            std::fs::read(gui_out.join(&rel)).unwrap(),
            std::fs::read(cli_out.join(&rel)).unwrap(),
        );
        assert!(
            a == b,
            "{} differs between the app and the CLI",
            rel.display()
        );
    }
}

#[test]
fn cancel_leaves_a_consistent_dataset_and_parameters_are_locked_meanwhile() {
    let _gpu = GPU.lock().unwrap_or_else(|e| e.into_inner());
    let dir = tempfile::tempdir().unwrap();
    // 10 001 frames: far more than can finish before Cancel.
    let long = TINY.replace(
        "(start: 1.0, end: 2.0, step: 0.5)",
        "(start: 1.0, end: 101.0, step: 0.01)",
    );
    let preset = write_preset(dir.path(), "long.ron", &long);
    let out = dir.path().join("out");
    let mut h = harness(Some(preset));
    wait_for(&mut h, "the first preview", settled);
    h.state_mut().session_mut().out_dir = out.display().to_string();
    h.run_steps(2);
    h.get_by_role_and_label(Role::Button, "Generate").click();
    h.run_steps(2);
    assert!(h.state().batch_running());
    assert!(
        h.get_by_label("XCount").accesskit_node().is_disabled(),
        "parameter widgets are locked during a batch"
    );
    assert!(
        h.get_by_label("CameraZ step")
            .accesskit_node()
            .is_disabled()
    );
    h.get_by_label_contains("images/s");
    wait_for(&mut h, "a few frames", |_| {
        std::fs::read_dir(out.join("images/train"))
            .map(|d| d.count())
            .unwrap_or(0)
            >= 3
    });
    h.get_by_role_and_label(Role::Button, "Cancel").click();
    h.run_steps(2);
    wait_for(&mut h, "the cancelled batch to end", |app| {
        !app.batch_running()
    });
    let frames = match h.state().batch_outcome() {
        Some(BatchOutcome::Done(report)) => {
            assert!(report.cancelled);
            report.stats.frames
        }
        Some(BatchOutcome::Failed(e)) => panic!("batch failed: {e}"),
        None => unreachable!(),
    };
    assert!((3..10_001).contains(&frames), "{frames} frames");
    h.get_by_label_contains("Cancelled:");
    assert!(
        !h.get_by_label("XCount").accesskit_node().is_disabled(),
        "parameters unlock after the batch"
    );

    let images = files_under(&out.join("images"), "png");
    let labels = files_under(&out.join("labels"), "txt");
    assert_eq!(images.len() as u64, frames);
    assert_eq!(
        stems(&images),
        stems(&labels),
        "every written image has its label file"
    );
    let manifest = std::fs::read_to_string(out.join("manifest.jsonl")).unwrap();
    assert_eq!(manifest.lines().count() as u64, frames);
    let coco_images: u64 = ["train", "val", "test"]
        .iter()
        .map(|s| {
            let text = std::fs::read_to_string(out.join(format!("annotations/instances_{s}.json")))
                .unwrap();
            serde_json::from_str::<serde_json::Value>(&text).unwrap()["images"]
                .as_array()
                .unwrap()
                .len() as u64
        })
        .sum();
    assert_eq!(coco_images, frames);
}

fn snapshot_options() -> SnapshotOptions {
    // lavapipe is deterministic run to run; the slack covers font/rasteriser
    // differences between Mesa builds.
    SnapshotOptions::new()
        .threshold(2.0)
        .max_failed_pixels(2000)
}

/// Hide what changes run to run: the status bar (render time, adapter name).
fn mask_status_bar(h: &mut Harness<'_, SwarmshotApp>) {
    let status = h.get_by_label_contains("preview ").rect();
    let width = h.ctx.content_rect().width();
    let bottom = h.ctx.content_rect().bottom();
    h.mask(egui::Rect::from_min_max(
        egui::pos2(0.0, status.top() - 4.0),
        egui::pos2(width, bottom),
    ));
}

#[test]
fn main_window_snapshots() {
    let _gpu = GPU.lock().unwrap_or_else(|e| e.into_inner());
    let quickstart = Path::new(env!("CARGO_MANIFEST_DIR")).join("presets/quickstart.ron");
    let mut h = harness(Some(quickstart));
    wait_for(&mut h, "the quickstart preview", settled);
    h.get_by_label("Frames: 108");
    mask_status_bar(&mut h);
    h.snapshot_options("main_window", &snapshot_options());

    h.get_by_label("Inspect").click();
    wait_for(&mut h, "the inspect view", |app| {
        settled(app)
            && app
                .preview_key()
                .is_some_and(|k| matches!(k.view, swarmshot::app::preview::PreviewView::Inspect(_)))
    });
    mask_status_bar(&mut h);
    h.snapshot_options("inspect_view", &snapshot_options());
}
