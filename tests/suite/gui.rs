//! The desktop app driven through its widgets with egui_kittest and the wgpu
//! renderer (Vulkan pinned: lavapipe on CI). A missing adapter makes the
//! harness panic ("Failed to create render state"): these tests never pass
//! without rendering.
#![cfg(feature = "app")]
#![allow(clippy::unwrap_used)]

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use egui::accesskit::Role;
use egui_kittest::kittest::{NodeT as _, Queryable};
use egui_kittest::{Harness, SnapshotOptions};
use swarmshot::app::SwarmshotApp;
use swarmshot::app::runner::BatchOutcome;

use crate::app_common;
use app_common::{GPU, WAIT, harness, wait_for};

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
    h.get_by_label_contains("CameraZ 2.0 ·");
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
    // Shown right under the CameraZ row (the Problems list names it too).
    let step = h.get_by_label("CameraZ step").rect();
    let at: Vec<_> = h
        .get_all_by_label_contains("points away from end")
        .map(|m| m.rect())
        .collect();
    assert!(
        at.iter()
            .any(|at| at.top() >= step.bottom() - 1.0 && at.top() - step.bottom() < 30.0),
        "messages at {at:?}, CameraZ step at {step:?}"
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
    h.get_by_label_contains("Finished: made 6 frames in");
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

fn click_generate_and_wait(h: &mut Harness<'_, SwarmshotApp>) {
    h.get_by_role_and_label(Role::Button, "Generate").click();
    h.run_steps(2);
    wait_for(h, "the batch to end", |app| {
        !app.batch_running() && app.batch_outcome().is_some()
    });
}

fn report(h: &Harness<'_, SwarmshotApp>) -> swarmshot::pipeline::BatchReport {
    match h.state().batch_outcome() {
        Some(BatchOutcome::Done(report)) => (**report).clone(),
        Some(BatchOutcome::Failed(e)) => panic!("batch failed: {e}"),
        None => panic!("no batch outcome"),
    }
}

#[test]
fn a_trial_run_writes_its_frames_and_a_second_generate_has_nothing_to_do() {
    let _gpu = GPU.lock().unwrap_or_else(|e| e.into_inner());
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let mut h = harness(Some(write_preset(dir.path(), "tiny.ron", TINY)));
    wait_for(&mut h, "the first preview", settled);

    // A failure is shown, and goes once the preset changes.
    let file = dir.path().join("a-file");
    std::fs::write(&file, "not a folder").unwrap();
    h.state_mut().session_mut().out_dir = file.display().to_string();
    h.run_steps(2);
    click_generate_and_wait(&mut h);
    assert!(matches!(
        h.state().batch_outcome(),
        Some(BatchOutcome::Failed(_))
    ));
    h.get_by_label_contains("Batch failed");
    h.get_by_label("XCount").set_value_accesskit(3.0);
    h.run_steps(3);
    assert!(
        h.query_by_label_contains("Batch failed").is_none(),
        "the failure's message stayed after the preset changed"
    );
    assert!(h.state().batch_outcome().is_none());

    // Trial run: the first 2 of 6 frames.
    h.state_mut().session_mut().out_dir = out.display().to_string();
    // Let the layout settle (the new folder changes the batch panel) before clicking.
    wait_for(&mut h, "the preview after the edit", settled);
    h.get_by_label("Trial run: first").click();
    wait_for(&mut h, "the trial run switched on", |app| {
        app.session().trial
    });
    h.get_by_label("Trial frames").set_value_accesskit(2.0);
    wait_for(&mut h, "two trial frames", |app| {
        app.session().trial_frames == 2
    });
    click_generate_and_wait(&mut h);
    let first = report(&h);
    assert_eq!((first.made, first.stats.frames), (2, 2));
    assert_eq!(files_under(&out.join("images"), "png").len(), 2);
    h.get_by_label_contains("Finished: made 2 frames in");
    h.get_by_label_contains("images/s)");

    // Again on the finished folder: nothing to do, and no rate.
    click_generate_and_wait(&mut h);
    let again = report(&h);
    assert!(again.already_complete(), "{again:?}");
    assert_eq!(again.made, 0);
    h.get_by_label_contains("Already complete — nothing to do");
    assert!(
        h.query_by_label_contains("images/s").is_none(),
        "a run that made nothing shows a rate"
    );
    assert_eq!(files_under(&out.join("images"), "png").len(), 2);
}

#[test]
fn two_shards_made_in_the_app_merge_into_the_whole_dataset() {
    let _gpu = GPU.lock().unwrap_or_else(|e| e.into_inner());
    let dir = tempfile::tempdir().unwrap();
    let mut h = harness(Some(write_preset(dir.path(), "tiny.ron", TINY)));
    wait_for(&mut h, "the first preview", settled);
    h.get_by_label("Shard").click();
    h.run_steps(1);
    let mut made = 0;
    for k in 1..=2u64 {
        let out = dir.path().join(format!("shard{k}"));
        h.state_mut().session_mut().out_dir = out.display().to_string();
        h.get_by_label("Shard number").set_value_accesskit(k as f64);
        h.run_steps(2);
        click_generate_and_wait(&mut h);
        let r = report(&h);
        assert_eq!(r.made, 3, "shard {k} of 2 makes half the 6 frames");
        made += files_under(&out.join("images"), "png").len();
    }
    assert_eq!(made, 6);

    let merged = dir.path().join("merged");
    {
        let session = h.state_mut().session_mut();
        session.out_dir = merged.display().to_string();
        session.merge_shards = format!(
            "{}\n{}\n",
            dir.path().join("shard1").display(),
            dir.path().join("shard2").display()
        );
    }
    h.run_steps(1);
    // Below the batch report the Merge section may lie under the panel's fold: by accesskit.
    h.get_by_label("Merge shards").click_accesskit();
    h.run_steps(2);
    h.get_by_role_and_label(Role::Button, "Merge into the output folder")
        .click_accesskit();
    h.run_steps(1);
    wait_for(&mut h, "the merge", |app| app.merge_outcome().is_some());
    match h.state().merge_outcome() {
        Some(Ok(line)) => assert!(
            line.contains("Merged 2 shards") && line.contains("6 frames"),
            "{line}"
        ),
        other => panic!("merge failed: {other:?}"),
    }
    h.get_by_label_contains("Merged 2 shards");
    assert_eq!(files_under(&merged.join("images"), "png").len(), 6);
    assert_eq!(
        std::fs::read_to_string(merged.join("manifest.jsonl"))
            .unwrap()
            .lines()
            .count(),
        6
    );
}

#[test]
fn generate_after_cancel_says_where_it_resumed_and_rates_only_its_frames() {
    let _gpu = GPU.lock().unwrap_or_else(|e| e.into_inner());
    let dir = tempfile::tempdir().unwrap();
    // 51 × 2 = 102 frames.
    let preset = TINY.replace(
        "(start: 1.0, end: 2.0, step: 0.5)",
        "(start: 1.0, end: 2.0, step: 0.02)",
    );
    let out = dir.path().join("out");
    let mut h = harness(Some(write_preset(dir.path(), "resume.ron", &preset)));
    wait_for(&mut h, "the first preview", settled);
    h.state_mut().session_mut().out_dir = out.display().to_string();
    h.run_steps(2);
    h.get_by_role_and_label(Role::Button, "Generate").click();
    h.run_steps(2);
    wait_for(&mut h, "a few frames", |_| {
        std::fs::read_dir(out.join("images/train"))
            .map(|d| d.count())
            .unwrap_or(0)
            >= 2
    });
    h.get_by_role_and_label(Role::Button, "Cancel").click();
    h.run_steps(2);
    wait_for(&mut h, "the cancelled batch to end", |app| {
        !app.batch_running()
    });
    let cancelled = report(&h);
    assert!(cancelled.cancelled, "the batch finished before Cancel");
    let kept = cancelled.stats.frames;
    assert!((2..102).contains(&kept), "{kept}");

    click_generate_and_wait(&mut h);
    let resumed = report(&h);
    assert!(!resumed.cancelled);
    assert_eq!(resumed.resumed_at(), Some(kept));
    assert_eq!(resumed.made, 102 - kept);
    assert_eq!(resumed.stats.frames, 102);
    h.get_by_label_contains(&format!(
        "Finished: resumed at frame {}, made {} frames in",
        kept + 1,
        102 - kept
    ));
    let rate = resumed.made as f64 / resumed.elapsed.as_secs_f64();
    h.get_by_label_contains(&format!("({rate:.1} images/s)"));
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

fn quickstart() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("presets/quickstart.ron")
}

fn x_count(app: &SwarmshotApp) -> u32 {
    match app.session().preset.placement {
        swarmshot::preset::Placement::Structured { x_count, .. } => x_count,
        _ => panic!("the grid preset is structured"),
    }
}

#[test]
fn the_in_app_file_browser_opens_in_the_presets_folder_and_opens_a_preset() {
    let _gpu = GPU.lock().unwrap_or_else(|e| e.into_inner());
    let dir = tempfile::tempdir().unwrap();
    let grid = write_preset(dir.path(), "grid.ron", GRID);
    write_preset(
        dir.path(),
        "other.ron",
        &GRID.replace("name: \"grid\"", "name: \"other\""),
    );
    std::fs::write(dir.path().join("notes.txt"), "not a preset").unwrap();
    let mut h = harness(Some(grid));
    let ctx = h.ctx.clone();
    // What a plain X session without a portal gets (pinned: a developer's machine may have one).
    h.state_mut()
        .use_file_dialogs(swarmshot::app::files::DialogBackend::Builtin, &ctx);
    wait_for(&mut h, "the first preview", settled);

    h.key_combination_modifiers(egui::Modifiers::COMMAND, &[egui::Key::O]);
    h.run_steps(2);
    let browser = h
        .state()
        .file_browser()
        .expect("Ctrl+O opened the in-app browser");
    assert_eq!(browser.dir(), dir.path().canonicalize().unwrap());
    h.get_by_label("Open preset");
    assert!(
        h.query_by_label("notes.txt").is_none(),
        "only .ron files are listed"
    );
    h.get_by_label("other.ron").click();
    h.run_steps(2);
    h.get_by_role_and_label(Role::Button, "Open").click();
    wait_for(&mut h, "the other preset", |app| {
        app.session().preset.name == "other" && settled(app)
    });
    assert!(h.state().file_browser().is_none(), "the browser closed");
    assert_eq!(
        h.state().session().preset_path.as_deref(),
        Some(
            dir.path()
                .canonicalize()
                .unwrap()
                .join("other.ron")
                .as_path()
        )
    );
    assert!(!h.state().session().is_dirty());

    // Save As starts in the same folder with the file's name, and asks before replacing it.
    h.key_combination_modifiers(
        egui::Modifiers::COMMAND | egui::Modifiers::SHIFT,
        &[egui::Key::S],
    );
    h.run_steps(2);
    h.get_by_label("Save preset as");
    prompt_button(&h, "Save").click();
    h.run_steps(2);
    h.get_by_label_contains("exists. Replace it?");
    h.get_by_role_and_label(Role::Button, "Replace").click();
    h.run_steps(2);
    assert!(h.state().file_browser().is_none());
    let saved = std::fs::read_to_string(dir.path().join("other.ron")).unwrap();
    // Nothing was edited: the file keeps its own text.
    assert_eq!(saved, GRID.replace("name: \"grid\"", "name: \"other\""));
}

/// The prompt's button, not the top bar's button of the same name.
fn prompt_button<'a>(h: &'a Harness<'_, SwarmshotApp>, name: &'a str) -> egui_kittest::Node<'a> {
    h.get_all_by_role_and_label(Role::Button, name)
        .max_by(|a, b| a.rect().top().total_cmp(&b.rect().top()))
        .unwrap()
}

#[test]
fn new_asks_before_dropping_edits() {
    let _gpu = GPU.lock().unwrap_or_else(|e| e.into_inner());
    let dir = tempfile::tempdir().unwrap();
    let grid = write_preset(dir.path(), "grid.ron", GRID);
    let mut h = harness(Some(grid.clone()));
    wait_for(&mut h, "the first preview", settled);
    h.get_by_label("XCount").set_value_accesskit(5.0);
    h.run_steps(2);
    assert!(h.state().session().is_dirty());
    assert!(
        h.state().title().contains("unsaved"),
        "{}",
        h.state().title()
    );

    h.get_by_role_and_label(Role::Button, "New").click();
    h.run_steps(2);
    assert_eq!(
        h.state().prompt(),
        Some(&swarmshot::app::prompt::Replace::New)
    );
    h.run_steps(2);
    h.get_by_label("Unsaved changes");
    prompt_button(&h, "Cancel").click();
    h.run_steps(2);
    assert!(h.state().prompt().is_none());
    assert_eq!(x_count(h.state()), 5, "Cancel keeps the edit");

    h.get_by_role_and_label(Role::Button, "New").click();
    h.run_steps(4);
    prompt_button(&h, "Save").click();
    h.run_steps(2);
    assert!(
        std::fs::read_to_string(&grid)
            .unwrap()
            .contains("x_count: 5"),
        "Save wrote the edit before New"
    );
    assert_eq!(
        h.state().session().preset,
        swarmshot::preset::Preset::default()
    );

    // Discard throws an edit away.
    h.state_mut().session_mut().preset.seed = 12345;
    h.run_steps(2);
    h.key_combination_modifiers(egui::Modifiers::COMMAND, &[egui::Key::N]);
    h.run_steps(4);
    h.get_by_label("Unsaved changes");
    prompt_button(&h, "Discard").click();
    h.run_steps(2);
    assert_eq!(
        h.state().session().preset,
        swarmshot::preset::Preset::default()
    );
    assert!(!h.state().session().is_dirty());
    // Nothing to lose: New goes ahead without asking.
    h.get_by_role_and_label(Role::Button, "New").click();
    h.run_steps(2);
    assert!(h.state().prompt().is_none());
}

#[test]
fn undo_restores_a_value_and_redo_brings_it_back() {
    let _gpu = GPU.lock().unwrap_or_else(|e| e.into_inner());
    let dir = tempfile::tempdir().unwrap();
    let mut h = harness(Some(write_preset(dir.path(), "grid.ron", GRID)));
    wait_for(&mut h, "the first preview", settled);
    h.get_by_label("XCount").set_value_accesskit(5.0);
    wait_for(&mut h, "XCount = 5 in the summary", |app| {
        settled(app) && app.summary().is_some_and(|s| s.drones_max == 45)
    });
    h.key_combination_modifiers(egui::Modifiers::COMMAND, &[egui::Key::Z]);
    wait_for(&mut h, "the undone grid", |app| {
        settled(app) && app.summary().is_some_and(|s| s.drones_max == 27)
    });
    assert_eq!(x_count(h.state()), 3);
    assert!(!h.state().session().is_dirty(), "back to the file's preset");
    h.key_combination_modifiers(
        egui::Modifiers::COMMAND | egui::Modifiers::SHIFT,
        &[egui::Key::Z],
    );
    h.run_steps(2);
    assert_eq!(x_count(h.state()), 5);
    // The Undo button does the same.
    h.get_by_role_and_label(Role::Button, "Undo").click();
    h.run_steps(2);
    assert_eq!(x_count(h.state()), 3);
}

#[test]
fn a_slow_drag_is_one_undo_step() {
    let _gpu = GPU.lock().unwrap_or_else(|e| e.into_inner());
    let dir = tempfile::tempdir().unwrap();
    let mut h = harness(Some(write_preset(dir.path(), "grid.ron", GRID)));
    wait_for(&mut h, "the first preview", settled);
    assert_eq!(x_count(h.state()), 3);
    let mut at = h.get_by_label("XCount").rect().center();
    h.hover_at(at);
    h.run_steps(1);
    h.drag_at(at);
    h.run_steps(1);
    // Four moves, each followed by a pause longer than the history's 0.5 s
    // (each harness step is 0.25 s of egui time).
    let mut seen = vec![3];
    for _ in 0..4 {
        at.x += 20.0;
        h.hover_at(at);
        h.run_steps(4);
        seen.push(x_count(h.state()));
    }
    h.drop_at(at);
    h.run_steps(4);
    let dragged = x_count(h.state());
    assert!(dragged > 3, "the drag did not change XCount: {seen:?}");
    assert!(
        seen.windows(2).filter(|w| w[0] != w[1]).count() >= 3,
        "the drag paused on at least three values: {seen:?}"
    );
    h.key_combination_modifiers(egui::Modifiers::COMMAND, &[egui::Key::Z]);
    h.run_steps(2);
    assert_eq!(
        x_count(h.state()),
        3,
        "one undo after a slow drag ({seen:?}) goes back to before it"
    );
    assert!(!h.state().session().is_dirty());
}

#[test]
fn a_missing_preset_is_named_and_leaves_nothing_unsaved() {
    let _gpu = GPU.lock().unwrap_or_else(|e| e.into_inner());
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("no-such-preset.ron");
    let mut h = harness(Some(missing.clone()));
    h.run_steps(2);
    let notices = h.state().notices().join("\n");
    assert!(
        notices.contains(&format!("preset {} does not exist", missing.display())),
        "{notices}"
    );
    assert!(!notices.contains("os error"), "{notices}");
    h.get_by_label_contains("no-such-preset.ron does not exist");
    assert!(!h.state().session().is_dirty());
    assert!(
        !h.state().title().contains("unsaved"),
        "{}",
        h.state().title()
    );
}

/// Step until `done` holds, recording the selected frame at each step.
fn play_until(
    h: &mut Harness<'_, SwarmshotApp>,
    what: &str,
    done: impl Fn(&SwarmshotApp, &[u64]) -> bool,
) -> Vec<u64> {
    let start = Instant::now();
    let mut frames = vec![h.state().session().frame];
    loop {
        h.step();
        let frame = h.state().session().frame;
        if frames.last() != Some(&frame) {
            frames.push(frame);
        }
        if done(h.state(), &frames) {
            return frames;
        }
        assert!(
            start.elapsed() < WAIT,
            "timed out waiting for {what}: {frames:?}"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
}

#[test]
fn play_advances_frames_and_stops_at_the_end_unless_looping() {
    let _gpu = GPU.lock().unwrap_or_else(|e| e.into_inner());
    let dir = tempfile::tempdir().unwrap();
    let mut h = harness(Some(write_preset(dir.path(), "tiny.ron", TINY)));
    wait_for(&mut h, "the first preview", settled);
    assert_eq!(h.state().session().frame, 0);

    h.get_by_role_and_label(Role::Button, "Play").click();
    let played = play_until(&mut h, "the end of the frames", |app, _| !app.is_playing());
    assert_eq!(played, vec![0, 1, 2, 3, 4, 5], "one frame after another");
    wait_for(&mut h, "the last frame's picture", |app| {
        settled(app) && app.preview_key().is_some_and(|k| k.frame == 5)
    });
    assert!(!h.state().is_playing(), "stopped at the end");
    h.get_by_label("frame 6 of 6");
    h.get_by_role_and_label(Role::Button, "Play");

    // Looping: from the last frame it starts again and goes round.
    h.get_by_label("Loop").click();
    h.run_steps(1);
    h.get_by_role_and_label(Role::Button, "Play").click();
    let looped = play_until(&mut h, "a second round", |_, frames| {
        frames.iter().filter(|&&f| f == 0).count() >= 2
    });
    assert!(h.state().is_playing(), "looping keeps playing: {looped:?}");
    assert!(looped.contains(&5), "{looped:?}");
    h.get_by_role_and_label(Role::Button, "Pause").click();
    h.run_steps(2);
    assert!(!h.state().is_playing());
    let paused_at = h.state().session().frame;
    h.run_steps(4);
    assert_eq!(h.state().session().frame, paused_at, "Pause stops");
}

#[test]
fn a_problem_link_scrolls_to_its_field() {
    let _gpu = GPU.lock().unwrap_or_else(|e| e.into_inner());
    let mut h = harness(Some(quickstart()));
    wait_for(&mut h, "the first preview", settled);
    h.get_by_label("Split train").set_value_accesskit(0.9);
    h.run_steps(3);
    let errors = h.state().errors().to_vec();
    assert_eq!(errors.len(), 1, "{errors:?}");
    assert_eq!(errors[0].field, "output.split");
    let visible_bottom = h.get_by_label_contains("preview ").rect().top();
    let below = h.get_by_label(&errors[0].message).rect();
    assert!(
        below.top() > visible_bottom,
        "the message should start out of view (at {below:?}, view ends at {visible_bottom})"
    );
    // The disabled Generate says why.
    let generate = h.get_by_role_and_label(Role::Button, "Generate");
    assert!(generate.accesskit_node().is_disabled());
    h.get_by_label_contains("Fix the 1 problem listed");
    h.get_by_label_contains("Preview paused: 1 problem, first Split");

    h.get_by_label(&format!("Split: {}", errors[0].message))
        .click();
    h.run_steps(4);
    let shown = h.get_by_label(&errors[0].message).rect();
    let top = h.get_by_role_and_label(Role::Button, "New").rect().bottom();
    assert!(
        shown.top() > top && shown.bottom() < visible_bottom,
        "after the click the message is in view: {shown:?} between {top} and {visible_bottom}"
    );
}

#[test]
fn a_typed_number_is_committed_on_enter_not_at_each_keystroke() {
    let _gpu = GPU.lock().unwrap_or_else(|e| e.into_inner());
    let dir = tempfile::tempdir().unwrap();
    let mut h = harness(Some(write_preset(dir.path(), "grid.ron", GRID)));
    wait_for(&mut h, "the first preview", settled);
    let before = h.state().generation();

    h.get_by_label("XCount").click();
    h.run_steps(1);
    h.key_combination_modifiers(egui::Modifiers::COMMAND, &[egui::Key::A]);
    h.get_by_label("XCount").type_text("55");
    h.step();
    assert_eq!(
        h.state().generation(),
        before,
        "\"55\" on the way to \"5\" reached the preview"
    );
    h.key_press(egui::Key::Backspace);
    h.key_press(egui::Key::Enter);
    wait_for(&mut h, "XCount = 5", |app| {
        settled(app) && app.summary().is_some_and(|s| s.drones_max == 45)
    });
    assert_eq!(x_count(h.state()), 5);
    assert_eq!(
        h.state().generation(),
        before + 1,
        "one committed edit: only XCount 5 was previewed and summarised"
    );
    assert_eq!(h.state().preview_key().unwrap().generation, before + 1);
}

#[test]
fn frame_keys_and_the_frame_survives_a_briefly_invalid_preset() {
    let _gpu = GPU.lock().unwrap_or_else(|e| e.into_inner());
    let mut h = harness(Some(quickstart()));
    wait_for(&mut h, "the first preview", settled);
    h.get_by_label("Frame").set_value_accesskit(50.0);
    h.run_steps(2);
    assert_eq!(h.state().session().frame, 50);
    h.key_press(egui::Key::ArrowRight);
    h.run_steps(1);
    assert_eq!(h.state().session().frame, 51);
    h.key_press(egui::Key::End);
    h.run_steps(1);
    assert_eq!(h.state().session().frame, 107);
    h.key_press(egui::Key::Home);
    h.run_steps(1);
    assert_eq!(h.state().session().frame, 0);
    h.get_by_label("Frame").set_value_accesskit(50.0);
    h.run_steps(2);

    // CameraZ step 0 with start ≠ end is invalid; then back to 0.4.
    h.get_by_label("CameraZ step").set_value_accesskit(0.0);
    h.run_steps(3);
    assert!(!h.state().errors().is_empty());
    h.get_by_label("CameraZ step").set_value_accesskit(0.4);
    wait_for(&mut h, "the preview of frame 51", |app| {
        settled(app) && app.preview_key().is_some_and(|k| k.frame == 50)
    });
    assert_eq!(h.state().session().frame, 50, "the frame was kept");
    h.get_by_label("frame 51 of 108");
    // Sweep values to their step's precision.
    h.get_by_label_contains("CameraY 0.0 · CameraZ 0.8 ·");
}

/// `docs/screenshot.png` comes from here:
/// `SWARMSHOT_UPDATE_SCREENSHOT=1 cargo test --test suite gui::docs_screenshot`.
/// Without the variable the test still renders it, so the command cannot rot.
#[test]
fn docs_screenshot_of_the_quickstart() {
    let _gpu = GPU.lock().unwrap_or_else(|e| e.into_inner());
    let mut h = harness(Some(quickstart()));
    wait_for(&mut h, "the quickstart preview", settled);
    h.get_by_label("Frame").set_value_accesskit(13.0);
    wait_for(&mut h, "frame 14", |app| {
        settled(app) && app.preview_key().is_some_and(|k| k.frame == 13)
    });
    h.get_by_label("frame 14 of 108");
    let image = h.render().expect("render the window");
    assert_eq!(image.dimensions(), (1400, 880));
    if std::env::var_os("SWARMSHOT_UPDATE_SCREENSHOT").is_some() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/screenshot.png");
        image.save(&path).unwrap();
        eprintln!("wrote {}", path.display());
    }
}

/// `swarmshot` with no display (env cleared of DISPLAY and WAYLAND_DISPLAY).
fn without_display(args: &[&str]) -> (bool, String) {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_swarmshot"))
        .args(args)
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .env("RUST_BACKTRACE", "1")
        .output()
        .unwrap();
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn without_a_display_the_app_says_so_in_one_line() {
    for args in [&[][..], &["gui"][..]] {
        let (ok, stderr) = without_display(args);
        assert!(!ok);
        assert_eq!(stderr.lines().count(), 1, "{stderr}");
        assert!(stderr.contains("no display"), "{stderr}");
        assert!(
            !stderr.contains("backtrace") && !stderr.contains(".rs:"),
            "{stderr}"
        );
    }
    // A preset path that cannot be read is the error to fix first.
    let (ok, stderr) = without_display(&["gui", "no/such/preset.ron"]);
    assert!(!ok);
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
    assert!(stderr.contains("no/such/preset.ron"), "{stderr}");
}

#[test]
fn realism_sections_switch_their_preset_fields_on_and_off() {
    let _gpu = GPU.lock().unwrap_or_else(|e| e.into_inner());
    let dir = tempfile::tempdir().unwrap();
    let mut h = harness(Some(write_preset(dir.path(), "grid.ron", GRID)));
    wait_for(&mut h, "the first preview", settled);
    assert!(h.state().session().preset.camera_model.is_none());
    // The realism sections start collapsed: their checkboxes are hidden.
    assert!(h.query_by_label("Camera model on").is_none());

    h.get_by_label("Camera model").click_accesskit();
    h.run_steps(3);
    h.get_by_label("Camera model on").click_accesskit();
    h.run_steps(3);
    assert_eq!(
        h.state().session().preset.camera_model,
        Some(swarmshot::preset::camera_model::CameraModel::default()),
        "ticking the box sets camera_model"
    );
    h.get_by_label("Exposure min").set_value_accesskit(-0.5);
    h.run_steps(3);
    let model = h.state().session().preset.camera_model.clone().unwrap();
    assert_eq!(model.exposure_ev, (-0.5, 0.0));
    h.get_by_label("Camera model on").click_accesskit();
    h.run_steps(3);
    assert!(
        h.state().session().preset.camera_model.is_none(),
        "unticking removes camera_model"
    );
    assert!(
        !h.state().session().is_dirty(),
        "on then off gives back the saved preset"
    );

    // The observer camera lives in the (open) Camera section.
    h.get_by_label("Observer camera").click_accesskit();
    h.run_steps(3);
    let observer = h.state().session().preset.camera.observer.clone();
    assert_eq!(
        observer,
        Some(swarmshot::preset::observer::ObserverCamera::default())
    );
    h.get_by_label("Observer distance max")
        .set_value_accesskit(900.0);
    h.run_steps(3);
    let observer = h.state().session().preset.camera.observer.clone().unwrap();
    assert_eq!(observer.distance_m.1, 900.0);

    // Drone appearance: a palette weight edits its entry.
    h.get_by_label("Drone appearance").click_accesskit();
    h.run_steps(3);
    h.get_by_label("Drone appearance on").click_accesskit();
    h.run_steps(3);
    h.get_by_label("Black").set_value_accesskit(0.0);
    h.run_steps(3);
    let appearance = h.state().session().preset.appearance.clone().unwrap();
    let black = appearance
        .palette
        .iter()
        .find(|(c, _)| *c == swarmshot::preset::appearance::DroneColor::Black);
    assert_eq!(black.map(|(_, w)| *w), Some(0.0));
    assert!(h.state().errors().is_empty(), "{:?}", h.state().errors());
}

#[test]
fn visibility_edits_reach_the_preset_and_a_bad_one_is_a_problem() {
    let _gpu = GPU.lock().unwrap_or_else(|e| e.into_inner());
    let dir = tempfile::tempdir().unwrap();
    let mut h = harness(Some(write_preset(dir.path(), "grid.ron", GRID)));
    wait_for(&mut h, "the first preview", settled);
    h.get_by_label("Atmosphere").click_accesskit();
    h.run_steps(3);
    h.get_by_label("Atmosphere on").click_accesskit();
    h.run_steps(3);
    h.get_by_label("Visibility max")
        .set_value_accesskit(20_000.0);
    h.run_steps(3);
    let atmosphere = h.state().session().preset.atmosphere.clone().unwrap();
    assert_eq!(atmosphere.visibility_m, (5_000.0, 20_000.0));
    assert!(h.state().errors().is_empty(), "{:?}", h.state().errors());

    // min > max is refused by validation and listed under Problems.
    h.get_by_label("Visibility min")
        .set_value_accesskit(30_000.0);
    h.run_steps(3);
    let errors = h.state().errors().to_vec();
    assert_eq!(errors.len(), 1, "{errors:?}");
    assert_eq!(errors[0].field, "atmosphere.visibility_m");
    h.get_by_label("Problems (1)");
    h.get_by_label(&format!("Visibility: {}", errors[0].message));
    // And under its row.
    let row = h.get_by_label("Visibility min").rect();
    let message = h.get_by_label(&errors[0].message).rect();
    assert!(
        message.top() >= row.bottom() - 1.0 && message.top() - row.bottom() < 30.0,
        "message at {message:?}, row at {row:?}"
    );
    // Its Problems link opens the collapsed Atmosphere section again.
    h.get_by_label("Atmosphere").click_accesskit();
    h.run_steps(3);
    assert!(h.query_by_label("Visibility min").is_none());
    h.get_by_label(&format!("Visibility: {}", errors[0].message))
        .click();
    h.run_steps(4);
    h.get_by_label("Visibility min")
        .set_value_accesskit(10_000.0);
    h.run_steps(3);
    assert!(h.state().errors().is_empty(), "{:?}", h.state().errors());
}

#[test]
fn the_preview_shows_the_frame_through_the_camera_model() {
    let _gpu = GPU.lock().unwrap_or_else(|e| e.into_inner());
    let dir = tempfile::tempdir().unwrap();
    let noisy = GRID.replace(
        "render:",
        "camera_model: Some((read_noise_levels: (20.0, 20.0), psf: Gaussian(sigma_px: (1.5, 1.5)))),\n    render:",
    );
    let mut h = harness(Some(write_preset(dir.path(), "noisy.ron", &noisy)));
    let view_is = |view: swarmshot::app::preview::PreviewView| {
        move |app: &SwarmshotApp| settled(app) && app.preview_key().is_some_and(|k| k.view == view)
    };
    // Through the camera from the start: the preset has a camera model.
    wait_for(
        &mut h,
        "the preview through the camera",
        view_is(swarmshot::app::preview::PreviewView::ThroughCamera),
    );
    assert!(h.state().errors().is_empty(), "{:?}", h.state().errors());
    let through = preview_pixels(&mut h);

    h.get_by_label("Through the camera").click_accesskit();
    wait_for(
        &mut h,
        "the clean preview",
        view_is(swarmshot::app::preview::PreviewView::Camera),
    );
    let clean = preview_pixels(&mut h);
    let changed = differing_pixels(&clean, &through);
    let total = (clean.width() * clean.height()) as usize;
    // Read noise σ = 20 levels moves most pixels by more than 8 levels.
    assert!(
        changed > total / 4,
        "only {changed} of {total} pixels changed through the camera"
    );

    h.get_by_label("Through the camera").click_accesskit();
    wait_for(
        &mut h,
        "the preview through the camera again",
        view_is(swarmshot::app::preview::PreviewView::ThroughCamera),
    );
    h.get_by_label("Through the camera").click_accesskit();
    wait_for(
        &mut h,
        "the clean preview again",
        view_is(swarmshot::app::preview::PreviewView::Camera),
    );
    let again = preview_pixels(&mut h);
    assert_eq!(
        differing_pixels(&clean, &again),
        0,
        "back to the clean render"
    );
}

#[test]
fn undo_turns_a_realism_stage_back_off() {
    let _gpu = GPU.lock().unwrap_or_else(|e| e.into_inner());
    let dir = tempfile::tempdir().unwrap();
    let mut h = harness(Some(write_preset(dir.path(), "grid.ron", GRID)));
    wait_for(&mut h, "the first preview", settled);
    h.get_by_label("Atmosphere").click_accesskit();
    h.run_steps(2);
    h.get_by_label("Atmosphere on").click_accesskit();
    // An edit becomes an undo step once it has held for half a second.
    let start = Instant::now();
    while start.elapsed() < Duration::from_millis(800) {
        h.step();
        std::thread::sleep(Duration::from_millis(20));
    }
    assert!(h.state().session().preset.atmosphere.is_some());
    h.get_by_role_and_label(Role::Button, "Undo").click();
    h.run_steps(2);
    assert!(
        h.state().session().preset.atmosphere.is_none(),
        "Undo removes the atmosphere again"
    );
    assert!(!h.state().session().is_dirty());
    h.get_by_role_and_label(Role::Button, "Redo").click();
    h.run_steps(2);
    assert_eq!(
        h.state().session().preset.atmosphere,
        Some(swarmshot::preset::atmosphere::Atmosphere::default())
    );
}

#[test]
fn the_backplate_panel_edits_the_preset_and_a_bad_value_is_a_problem() {
    let _gpu = GPU.lock().unwrap_or_else(|e| e.into_inner());
    let dir = tempfile::tempdir().unwrap();
    let mut h = harness(Some(write_preset(dir.path(), "grid.ron", GRID)));
    wait_for(&mut h, "the first preview", settled);
    // Room for the section: the open Camera section folds away.
    h.get_by_label("Camera").click_accesskit();
    h.run_steps(3);
    // A realism section: collapsed until opened.
    assert!(h.query_by_label("Backplates on").is_none());
    h.get_by_label("Backplates").click_accesskit();
    h.run_steps(3);
    h.get_by_label("Backplates on").click_accesskit();
    h.run_steps(3);
    assert_eq!(
        h.state().session().preset.backplate,
        Some(swarmshot::preset::backplate::Backplate::default())
    );
    h.get_by_label("Horizontal field of view")
        .set_value_accesskit(0.0);
    h.run_steps(3);
    let errors = h.state().errors().to_vec();
    assert!(
        errors.iter().any(|e| e.field == "backplate.hfov_deg"),
        "{errors:?}"
    );
    h.get_by_label("Horizontal field of view")
        .set_value_accesskit(55.0);
    h.run_steps(3);
    h.get_by_label("unknown").click_accesskit();
    h.run_steps(3);
    let b = h.state().session().preset.backplate.clone().unwrap();
    assert_eq!(b.hfov_deg, 55.0);
    assert_eq!(
        b.horizon,
        swarmshot::preset::backplate::PlateHorizon::Unknown
    );
    assert!(h.query_by_label("Elevation min").is_some());
}

#[test]
fn thermal_bits_and_parts_reach_the_preset_and_16_without_png_is_a_problem() {
    let _gpu = GPU.lock().unwrap_or_else(|e| e.into_inner());
    let dir = tempfile::tempdir().unwrap();
    let mut h = harness(Some(write_preset(dir.path(), "grid.ron", GRID)));
    wait_for(&mut h, "the first preview", settled);
    // Room for the section: the open Camera section folds away.
    h.get_by_label("Camera").click_accesskit();
    h.run_steps(3);
    h.get_by_label("Thermal camera").click_accesskit();
    h.run_steps(3);
    h.get_by_label("Thermal camera on").click_accesskit();
    h.run_steps(3);
    assert!(h.state().errors().is_empty(), "{:?}", h.state().errors());
    h.get_by_label("16 bits").click_accesskit();
    h.run_steps(3);
    let thermal = h.state().session().preset.thermal.clone().unwrap();
    assert_eq!(thermal.bits, 16);
    // The grid writes JPEG: 16 bits is refused, named as validation names it.
    let errors = h.state().errors().to_vec();
    assert_eq!(errors.len(), 1, "{errors:?}");
    assert_eq!(errors[0].field, "thermal.bits");
    h.get_by_label(&format!("Bits: {}", errors[0].message));
    h.get_by_label("8 bits").click_accesskit();
    h.run_steps(3);
    assert_eq!(h.state().session().preset.thermal.clone().unwrap().bits, 8);
    assert!(h.state().errors().is_empty(), "{:?}", h.state().errors());
    // The drone's warm parts: unset by default, ticking sets a typical value.
    assert_eq!(
        h.state()
            .session()
            .preset
            .thermal
            .clone()
            .unwrap()
            .drone
            .motor_k,
        None
    );
    h.get_by_label("Drone motors").click_accesskit();
    h.run_steps(3);
    let drone = h.state().session().preset.thermal.clone().unwrap().drone;
    assert_eq!((drone.motor_k, drone.battery_k), (Some(30.0), None));
    assert!(h.state().errors().is_empty(), "{:?}", h.state().errors());
    // The narcissus, the detail enhancement and the capture chain (what a fitted preset
    // carries): off by default, ticking sets a typical value, and their rows edit the preset.
    let t = h.state().session().preset.thermal.clone().unwrap();
    assert!(t.narcissus.is_none() && t.capture.is_none() && t.detail.is_none());
    h.get_by_label("Narcissus").click_accesskit();
    h.run_steps(3);
    h.get_by_label("Detail enhancement").click_accesskit();
    h.run_steps(3);
    h.get_by_label("Detail gain").set_value_accesskit(2.5);
    h.run_steps(3);
    h.get_by_label("Capture chain").click_accesskit();
    h.run_steps(3);
    h.get_by_label("Prior compression AC step")
        .set_value_accesskit(9.5);
    h.run_steps(3);
    let t = h.state().session().preset.thermal.clone().unwrap();
    assert_eq!(t.narcissus.map(|n| n.depth_k), Some(4.0));
    let d = t.detail.expect("a detail enhancement");
    assert_eq!((d.gain, d.size), (2.5, 0.15));
    let c = t.capture.expect("a capture chain");
    assert_eq!((c.prior_dc_step, c.prior_ac_step), (8.0, 9.5));
    assert!(h.state().errors().is_empty(), "{:?}", h.state().errors());
}

#[test]
fn the_clutter_panel_switches_the_scenery_on_and_edits_it() {
    let _gpu = GPU.lock().unwrap_or_else(|e| e.into_inner());
    let dir = tempfile::tempdir().unwrap();
    let mut h = harness(Some(write_preset(dir.path(), "grid.ron", GRID)));
    wait_for(&mut h, "the first preview", settled);
    assert!(h.state().session().preset.clutter.is_none());
    assert!(h.query_by_label("Clutter on").is_none(), "starts collapsed");
    h.get_by_label("Clutter").click_accesskit();
    h.run_steps(3);
    h.get_by_label("Clutter on").click_accesskit();
    h.run_steps(3);
    assert_eq!(
        h.state().session().preset.clutter,
        Some(swarmshot::preset::clutter::Clutter::default()),
        "ticking the box sets clutter"
    );
    h.get_by_label("Branch levels").set_value_accesskit(4.0);
    h.run_steps(3);
    let clutter = h.state().session().preset.clutter.clone().unwrap();
    assert_eq!(clutter.trees.branch_levels, 4);
    assert!(h.state().errors().is_empty(), "{:?}", h.state().errors());
    // A row's words come from the table of fields, so its message is listed
    // under Problems with the widget's own label.
    h.get_by_label("Poles height min").set_value_accesskit(50.0);
    h.run_steps(3);
    let errors = h.state().errors().to_vec();
    assert_eq!(errors.len(), 1, "{errors:?}");
    assert_eq!(errors[0].field, "clutter.poles.height_m");
    h.get_by_label(&format!("Poles height: {}", errors[0].message));
    h.get_by_label("Poles height min").set_value_accesskit(8.0);
    h.run_steps(3);
    assert!(h.state().errors().is_empty(), "{:?}", h.state().errors());
    h.get_by_label("Clutter on").click_accesskit();
    h.run_steps(3);
    assert!(
        h.state().session().preset.clutter.is_none(),
        "unticking removes clutter"
    );
}

/// A random sky's per-frame ranges are edited in the Skybox section (its
/// choices stay in the preset file): switching the sunlight range on sets it,
/// its bounds reach the preset, and switching it off removes it.
#[test]
fn a_random_skys_ranges_are_edited_in_the_skybox_section() {
    let _gpu = GPU.lock().unwrap_or_else(|e| e.into_inner());
    let dir = tempfile::tempdir().unwrap();
    let random = r#"(
    name: "random",
    seed: 7,
    placement: Structured(x_count: 2, y_count: 2, z_count: 2, load_factor: 4.0),
    camera: (z: (start: 1.0, end: 1.0, step: 0.0)),
    render: (resolution: Custom(width: 320, height: 180), msaa: 1),
    sky: Random(
        choices: [Procedural(environment: Daytime), Procedural(environment: Sunset)],
        azimuth_offset_deg: (0.0, 360.0),
        cloud_cover: Some((0.0, 0.3)),
    ),
)"#;
    let mut h = harness(Some(write_preset(dir.path(), "random.ron", random)));
    wait_for(&mut h, "the first preview", settled);
    let sun_ev = |h: &Harness<'_, SwarmshotApp>| match &h.state().session().preset.sky {
        swarmshot::preset::Sky::Random { sun_ev, .. } => *sun_ev,
        other => panic!("{other:?}"),
    };
    assert_eq!(sun_ev(&h), None);
    if h.query_by_label("Sunlight").is_none() {
        h.get_by_label("Skybox").click_accesskit();
        h.run_steps(3);
    }
    h.get_by_label("Sunlight").click_accesskit();
    h.run_steps(3);
    assert_eq!(
        sun_ev(&h),
        Some((-0.5, 0.5)),
        "ticking the box sets the range"
    );
    h.get_by_label("Sunlight min").set_value_accesskit(-0.25);
    h.run_steps(3);
    assert_eq!(sun_ev(&h), Some((-0.25, 0.5)));
    h.get_by_label("Cloud cover max").set_value_accesskit(0.6);
    h.run_steps(3);
    match &h.state().session().preset.sky {
        swarmshot::preset::Sky::Random { cloud_cover, .. } => {
            assert_eq!(*cloud_cover, Some((0.0, 0.6)));
        }
        other => panic!("{other:?}"),
    }
    assert!(h.state().errors().is_empty(), "{:?}", h.state().errors());
    // The range row under the checkbox has the same label.
    h.get_by_role_and_label(Role::CheckBox, "Sunlight")
        .click_accesskit();
    h.run_steps(3);
    assert_eq!(sun_ev(&h), None, "unticking removes the range");
}
