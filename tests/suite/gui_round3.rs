//! The app, round three (issue 40): Discard is honoured across a restart, Save keeps
//! the preset's comments, the preview goes through the camera by default, switching
//! presets clears the batch report, and the preview fits the window at any size.
#![cfg(feature = "app")]
#![allow(clippy::unwrap_used)]

use std::path::{Path, PathBuf};

use egui::accesskit::Role;
use egui_kittest::Harness;
use egui_kittest::kittest::{NodeT, Queryable};
use swarmshot::app::preview::PreviewView;
use swarmshot::app::runner::BatchOutcome;
use swarmshot::app::{Command, StartOptions, SwarmshotApp};

use crate::app_common;
use app_common::{GPU, MemoryStorage, harness, harness_with, wait_for};

fn settled(app: &SwarmshotApp) -> bool {
    app.preview_is_current() && app.summary_is_current()
}

fn write_preset(dir: &Path, name: &str, ron: &str) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, ron).unwrap();
    path
}

/// The lowest button of that name: the prompt's, over the window's own.
fn prompt_button<'a>(h: &'a Harness<'_, SwarmshotApp>, name: &'a str) -> egui_kittest::Node<'a> {
    h.get_all_by_role_and_label(Role::Button, name)
        .max_by(|a, b| a.rect().top().total_cmp(&b.rect().top()))
        .unwrap()
}

/// A small structured preset with a comment header: 3×3×3 grid, one frame, 640×360.
const GRID: &str = r#"// A grid for the tests.
// Its comments must survive a Save.
(
    name: "grid",
    seed: 7, // the seed
    placement: Structured(x_count: 3, y_count: 3, z_count: 3, load_factor: 4.0),
    // one camera distance
    camera: (z: (start: 1.0, end: 1.0, step: 0.0)),
    render: (resolution: Custom(width: 640, height: 360), msaa: 1),
)
"#;

#[test]
fn discard_then_a_restart_opens_the_files_state() {
    let _gpu = GPU.lock().unwrap_or_else(|e| e.into_inner());
    let dir = tempfile::tempdir().unwrap();
    let grid = write_preset(dir.path(), "grid.ron", GRID);
    let mut h = harness(Some(grid.clone()));
    wait_for(&mut h, "the first preview", settled);
    h.state_mut().session_mut().preset.seed = 12345;
    h.run_steps(2);
    assert!(h.state().session().is_dirty());

    // Ctrl+Q asks, and Discard closes.
    h.key_combination_modifiers(egui::Modifiers::COMMAND, &[egui::Key::Q]);
    h.run_steps(4);
    h.get_by_label("Unsaved changes");
    prompt_button(&h, "Discard").click();
    h.run_steps(2);
    assert!(h.state().prompt().is_none());
    // What eframe stores on exit.
    let mut storage = MemoryStorage::default();
    eframe::App::save(h.state_mut(), &mut storage);
    drop(h);

    // The next start restores that session: the file's state, nothing unsaved.
    let storage: &'static MemoryStorage = Box::leak(Box::new(storage));
    let mut h = harness_with(
        StartOptions {
            preset: None,
            restore_session: true,
        },
        Some(storage),
        [1400.0, 880.0],
    );
    h.run_steps(3);
    let session = h.state().session();
    assert_eq!(session.preset_path.as_deref(), Some(grid.as_path()));
    assert_eq!(session.preset.seed, 7, "the discarded seed came back");
    assert!(!session.is_dirty());
    assert!(
        !h.state().title().contains("unsaved"),
        "{}",
        h.state().title()
    );
    assert!(h.query_by_label("• unsaved changes").is_none());
}

#[test]
fn save_keeps_the_presets_comments_and_field_order() {
    let _gpu = GPU.lock().unwrap_or_else(|e| e.into_inner());
    let dir = tempfile::tempdir().unwrap();
    let grid = write_preset(dir.path(), "grid.ron", GRID);
    let mut h = harness(Some(grid.clone()));
    wait_for(&mut h, "the first preview", settled);
    h.get_by_label("XCount").set_value_accesskit(5.0);
    h.run_steps(2);
    assert!(h.state().session().is_dirty());
    h.key_combination_modifiers(egui::Modifiers::COMMAND, &[egui::Key::S]);
    h.run_steps(2);
    assert!(!h.state().session().is_dirty());
    let saved = std::fs::read_to_string(&grid).unwrap();
    let expected = GRID.replace("x_count: 3", "x_count: 5");
    assert_eq!(saved, expected, "only the edited value changed");
    assert_eq!(
        swarmshot::preset::Preset::from_ron(&saved).unwrap(),
        h.state().session().preset
    );
}

fn view_is(view: PreviewView) -> impl Fn(&SwarmshotApp) -> bool {
    move |app| settled(app) && app.preview_key().is_some_and(|k| k.view == view)
}

#[test]
fn the_preview_goes_through_the_camera_when_the_preset_has_one() {
    let _gpu = GPU.lock().unwrap_or_else(|e| e.into_inner());
    let dir = tempfile::tempdir().unwrap();
    let grid = write_preset(dir.path(), "grid.ron", GRID);
    let camera = GRID.replace(
        "render:",
        "camera_model: (read_noise_levels: (20.0, 20.0)),\n    render:",
    );
    let camera = write_preset(dir.path(), "camera.ron", &camera);
    let mut h = harness(Some(camera));
    wait_for(
        &mut h,
        "the preview through the camera",
        view_is(PreviewView::ThroughCamera),
    );
    h.get_by_label("Through the camera");
    // Switched off, it stays off for this preset…
    h.get_by_label("Through the camera").click_accesskit();
    wait_for(&mut h, "the clean preview", view_is(PreviewView::Camera));

    // …and a preset without a camera model says there is none: no greyed box.
    let ctx = h.ctx.clone();
    h.state_mut().command(Command::OpenPath(grid), &ctx);
    wait_for(&mut h, "the grid's preview", view_is(PreviewView::Camera));
    assert!(h.query_by_label("Through the camera").is_none());
    h.get_by_label("clean render: no camera model");
}

/// 6 frames at 96×64.
const TINY: &str = r#"(
    name: "tiny",
    seed: 11,
    placement: Structured(x_count: 2, y_count: 1, z_count: 1, load_factor: 3.0),
    camera: (z: (start: 1.0, end: 2.0, step: 0.5)),
    plane: (ry: (start: 0.0, end: 90.0, step: 90.0)),
    render: (resolution: Custom(width: 96, height: 64), msaa: 1),
    output: (image_format: Png, label_formats: [Yolo], split: (train: 1.0, val: 0.0, test: 0.0)),
)"#;

#[test]
fn switching_presets_clears_the_batch_report_and_generate_says_what_it_makes() {
    let _gpu = GPU.lock().unwrap_or_else(|e| e.into_inner());
    let dir = tempfile::tempdir().unwrap();
    let tiny = write_preset(dir.path(), "tiny.ron", TINY);
    let grid = write_preset(dir.path(), "grid.ron", GRID);
    let mut h = harness(Some(tiny));
    wait_for(&mut h, "the first preview", settled);
    h.state_mut().session_mut().out_dir = dir.path().join("ds").display().to_string();
    h.state_mut().session_mut().trial = true;
    h.state_mut().session_mut().trial_frames = 2;
    h.run_steps(2);
    let tip = h.state().generate_tip();
    assert!(tip.contains("the first 2 of the 6 frames"), "{tip}");
    assert!(!tip.contains("every"), "{tip}");
    h.state_mut().session_mut().every = true;
    h.state_mut().session_mut().every_k = 4;
    h.run_steps(1);
    let tip = h.state().generate_tip();
    assert!(tip.contains("2 of the 6 frames, one in 4"), "{tip}");
    h.state_mut().session_mut().every = false;

    h.get_by_label("Generate").click();
    wait_for(&mut h, "the trial run", |app| {
        !app.batch_running() && app.batch_outcome().is_some()
    });
    assert!(
        matches!(h.state().batch_outcome(), Some(BatchOutcome::Done(_))),
        "{:?}",
        h.state().batch_outcome().map(|_| ())
    );
    h.get_by_label_contains("Finished");

    let ctx = h.ctx.clone();
    h.state_mut().command(Command::OpenPath(grid), &ctx);
    wait_for(&mut h, "the grid's preview", settled);
    assert!(h.state().batch_outcome().is_none());
    assert!(h.query_by_label_contains("Finished").is_none());
}

#[test]
fn the_preview_fits_the_central_panel_at_any_window_size() {
    let _gpu = GPU.lock().unwrap_or_else(|e| e.into_inner());
    let quickstart = Path::new(env!("CARGO_MANIFEST_DIR")).join("presets/quickstart.ron");
    for size in [[800.0, 600.0], [1100.0, 700.0], [1600.0, 1000.0]] {
        let mut h = harness_with(
            StartOptions {
                preset: Some(quickstart.clone()),
                restore_session: false,
            },
            None,
            size,
        );
        wait_for(&mut h, "the first preview", settled);
        let central = h.state().central_rect().unwrap();
        let preview = h.state().preview_rect().unwrap();
        let window = egui::Rect::from_min_size(egui::Pos2::ZERO, size.into());
        let inside = |r: egui::Rect| central.expand(0.5).contains_rect(r);
        assert!(
            window.contains_rect(central),
            "{size:?}: central panel {central:?} outside the window"
        );
        assert!(
            inside(preview),
            "{size:?}: preview {preview:?} outside the central panel {central:?}"
        );
        // The rows above the picture are not clipped.
        for (role, label) in [
            (Role::Slider, "Frame"),
            (Role::CheckBox, "Boxes"),
            (Role::CheckBox, "Inspect"),
        ] {
            let rect = h.get_by_role_and_label(role, label).rect();
            assert!(
                inside(rect),
                "{size:?}: {label} {rect:?} outside the central panel {central:?}"
            );
        }
        // The Batch panel's controls stay in view: the output folder's Browse… beside its
        // field (it sat past the window's edge in a panel of the default width).
        let batch = |rect: egui::Rect| rect.left() >= central.right() && rect.right() <= size[0];
        let mut controls: Vec<(&str, egui::Rect)> = h
            .query_all_by_role_and_label(Role::Button, "Browse…")
            .map(|n| ("Browse…", n.rect()))
            .collect();
        assert_eq!(
            controls.len(),
            1,
            "{size:?}: one Browse… (the output folder's)"
        );
        for (role, label) in [
            (Role::CheckBox, "Overwrite an existing dataset"),
            (Role::Button, "Generate"),
        ] {
            controls.push((label, h.get_by_role_and_label(role, label).rect()));
        }
        for (label, rect) in controls {
            assert!(
                batch(rect),
                "{size:?}: {label} {rect:?} not inside the Batch panel (central {central:?})"
            );
        }
        // The picture takes the space it has (one side fills the pane, less the rows).
        assert!(
            preview.width() > 0.9 * central.width() || preview.height() > 0.6 * central.height(),
            "{size:?}: preview {preview:?} small in {central:?}"
        );
        drop(h);
    }
}

#[test]
fn the_masks_checkboxes_reach_the_preset() {
    let _gpu = GPU.lock().unwrap_or_else(|e| e.into_inner());
    let dir = tempfile::tempdir().unwrap();
    let grid = write_preset(dir.path(), "grid.ron", GRID);
    let mut h = harness(Some(grid.clone()));
    wait_for(&mut h, "the first preview", settled);
    assert!(!h.state().session().preset.output.masks.any());
    assert!(h.query_by_label("Instances").is_none());

    for name in [
        "Instance map",
        "Depth map",
        "COCO masks",
        "YOLO segmentation",
    ] {
        h.get_by_role_and_label(Role::CheckBox, name)
            .click_accesskit();
        h.run_steps(3);
    }
    let masks = h.state().session().preset.output.masks;
    assert!(
        masks.instance_png && masks.depth && masks.coco_rle && masks.yolo_seg,
        "{masks:?}"
    );
    assert!(h.state().errors().is_empty(), "{:?}", h.state().errors());
    // The depth map's unit shows while depth maps are on, and the pane offers the views.
    assert!(h.query_by_label_contains("Depth unit").is_some());
    h.get_by_label("Instances");
    h.get_by_label("Depth");

    h.key_combination_modifiers(egui::Modifiers::COMMAND, &[egui::Key::S]);
    h.run_steps(2);
    let saved = std::fs::read_to_string(&grid).unwrap();
    let preset = swarmshot::preset::Preset::from_ron(&saved).unwrap();
    assert_eq!(preset.output.masks, masks, "{saved}");
    assert!(saved.contains("// the seed"), "{saved}");

    h.get_by_role_and_label(Role::CheckBox, "Depth map")
        .click_accesskit();
    h.run_steps(3);
    assert!(!h.state().session().preset.output.masks.depth);
    assert!(h.query_by_label_contains("Depth unit").is_none());
}

/// Steps until `done`, at most `n` passes (smooth scrolling spreads a wheel over passes).
fn step_until(h: &mut Harness<'_, SwarmshotApp>, n: usize, done: impl Fn(&SwarmshotApp) -> bool) {
    for _ in 0..n {
        h.step();
        if done(h.state()) {
            return;
        }
    }
}

#[test]
fn the_wheel_zooms_the_preview_and_a_drag_pans_it() {
    let _gpu = GPU.lock().unwrap_or_else(|e| e.into_inner());
    let dir = tempfile::tempdir().unwrap();
    // 1280×720: larger than the pane, so the whole frame is shown scaled down.
    let big = GRID.replace("width: 640, height: 360", "width: 1280, height: 720");
    let mut h = harness(Some(write_preset(dir.path(), "grid.ron", &big)));
    wait_for(&mut h, "the first preview", settled);
    let fit = h.state().shown_pixel_scale().unwrap();
    assert!(fit < 0.8, "{fit}");
    assert_eq!(h.state().pane_view().zoom, 1.0);
    let rect = h.state().preview_rect().unwrap();
    let size_fit = h.state().preview_key().unwrap().size_px;

    // The wheel over the picture zooms in about the pointer.
    h.event(egui::Event::PointerMoved(rect.center()));
    h.step();
    h.event(egui::Event::MouseWheel {
        unit: egui::MouseWheelUnit::Point,
        delta: egui::vec2(0.0, 200.0),
        phase: egui::TouchPhase::Move,
        source: egui::MouseWheelSource::Unknown,
        modifiers: egui::Modifiers::NONE,
    });
    step_until(&mut h, 60, |app| {
        app.shown_pixel_scale().is_some_and(|s| s > 1.5 * fit)
    });
    let zoomed = h.state().shown_pixel_scale().unwrap();
    assert!(
        zoomed > 1.5 * fit,
        "the wheel zoomed from {fit} to {zoomed}"
    );
    let view = h.state().pane_view();
    assert!(view.part().width() < 0.7, "{view:?}");
    // Zoomed in, the picture is rendered larger (up to the output's 1280×720).
    wait_for(&mut h, "the larger picture", |app| {
        settled(app)
            && app
                .preview_key()
                .is_some_and(|k| k.size_px[0] > size_fit[0])
    });

    // A drag pans.
    let origin = h.state().pane_view().origin;
    h.event(egui::Event::PointerButton {
        pos: rect.center(),
        button: egui::PointerButton::Primary,
        pressed: true,
        modifiers: egui::Modifiers::NONE,
    });
    h.step();
    for i in 1..=5 {
        h.event(egui::Event::PointerMoved(
            rect.center() + egui::vec2(-20.0 * i as f32, -10.0 * i as f32),
        ));
        h.step();
    }
    h.event(egui::Event::PointerButton {
        pos: rect.center() + egui::vec2(-100.0, -50.0),
        button: egui::PointerButton::Primary,
        pressed: false,
        modifiers: egui::Modifiers::NONE,
    });
    h.run_steps(2);
    let moved = h.state().pane_view().origin;
    assert!(
        moved.x > origin.x && moved.y > origin.y,
        "{origin:?} -> {moved:?}"
    );

    // 1:1 shows one screen pixel per pixel of the frame; Fit the whole frame.
    h.get_by_role_and_label(Role::Button, "1:1").click();
    h.run_steps(3);
    let one = h.state().shown_pixel_scale().unwrap();
    assert!((one - 1.0).abs() < 0.01, "1:1 gave {one}");
    h.get_by_role_and_label(Role::Button, "Fit").click();
    h.run_steps(3);
    assert_eq!(h.state().pane_view().zoom, 1.0);
    assert!((h.state().shown_pixel_scale().unwrap() - fit).abs() < 1e-3);

    // Another preset opens whole, whatever the zoom the last one was left at.
    h.get_by_role_and_label(Role::Button, "1:1").click();
    h.run_steps(3);
    assert!(h.state().pane_view().zoom > 1.0);
    let ctx = h.ctx.clone();
    let other = write_preset(dir.path(), "other.ron", GRID);
    h.state_mut().command(Command::OpenPath(other), &ctx);
    h.run_steps(3);
    assert_eq!(h.state().pane_view(), Default::default());
}

#[test]
fn the_output_folder_sits_beside_generate_and_examples_say_what_they_are() {
    let _gpu = GPU.lock().unwrap_or_else(|e| e.into_inner());
    let dir = tempfile::tempdir().unwrap();
    let camera = GRID.replace(
        "render:",
        "camera_model: (read_noise_levels: (2.0, 2.0)),\n    render:",
    );
    let mut h = harness(Some(write_preset(dir.path(), "camera.ron", &camera)));
    wait_for(&mut h, "the first preview", settled);
    // The batch's settings in one place: the folder and Overwrite above Generate, on the right.
    let central = h.state().central_rect().unwrap();
    let generate = h.get_by_role_and_label(Role::Button, "Generate").rect();
    for label in ["Output folder", "Overwrite an existing dataset"] {
        let rect = h.get_by_label(label).rect();
        assert!(
            rect.left() > central.right() && rect.bottom() < generate.top(),
            "{label} at {rect:?}, Generate at {generate:?}"
        );
    }
    // The optional stages' headers say whether they are on.
    let status = swarmshot::app::stage_status(&h.state().session().preset);
    assert!(
        status.contains(&("Camera model", "on".to_string())),
        "{status:?}"
    );
    assert!(
        status.contains(&("Atmosphere", "off".to_string())),
        "{status:?}"
    );

    h.get_by_role_and_label(Role::Button, "Examples").click();
    h.run_steps(3);
    h.get_by_label_contains("swarmshot quickstart: a paper-like randomized swarm");
}

#[test]
fn browse_chooses_the_backplate_folder_and_the_real_frames_folder() {
    let _gpu = GPU.lock().unwrap_or_else(|e| e.into_inner());
    let dir = tempfile::tempdir().unwrap();
    let plates = dir.path().join("plates");
    std::fs::create_dir(&plates).unwrap();
    let other = dir.path().join("other");
    std::fs::create_dir(&other).unwrap();
    let mut h = harness(Some(write_preset(dir.path(), "grid.ron", GRID)));
    let ctx = h.ctx.clone();
    h.state_mut()
        .use_file_dialogs(swarmshot::app::files::DialogBackend::Builtin, &ctx);
    wait_for(&mut h, "the first preview", settled);
    h.state_mut().session_mut().preset.backplate = Some(Default::default());
    h.run_steps(2);
    h.get_by_label("Backplates").click_accesskit();
    h.run_steps(2);
    // The left panel's Browse… (the Batch panel on the right has the output folder's).
    h.get_all_by_role_and_label(Role::Button, "Browse…")
        .min_by(|a, b| a.rect().left().total_cmp(&b.rect().left()))
        .unwrap()
        .click_accesskit();
    h.run_steps(2);
    let browser = h.state().file_browser().expect("the folder dialog");
    assert_eq!(
        browser.purpose(),
        swarmshot::app::files::FilePurpose::BackplateFolder
    );
    // It starts at the folder the preset names (`plates`, beside the preset).
    assert_eq!(browser.dir(), plates.canonicalize().unwrap());
    h.run_steps(2);
    h.get_by_label("Backplate folder");
    h.get_by_role_and_label(Role::Button, "Up").click();
    h.run_steps(2);
    h.get_by_label("other/").click();
    h.run_steps(2);
    h.get_by_role_and_label(Role::Button, "Choose this folder")
        .click();
    h.run_steps(2);
    let folder = h
        .state()
        .session()
        .preset
        .backplate
        .as_ref()
        .unwrap()
        .folder
        .clone();
    // Stored as preset paths are read: from the preset's folder.
    assert_eq!(folder, Path::new("other"));

    // A stored `name/..` step is shown without it, and kept until edited.
    h.state_mut()
        .session_mut()
        .preset
        .backplate
        .as_mut()
        .unwrap()
        .folder = PathBuf::from("./sub/../plates");
    h.run_steps(2);
    assert!(
        h.get_all_by_value("plates")
            .any(|n| n.accesskit_node().role() == Role::TextInput),
        "the Folder field shows `plates`"
    );
    assert_eq!(
        h.state()
            .session()
            .preset
            .backplate
            .as_ref()
            .unwrap()
            .folder,
        Path::new("./sub/../plates")
    );

    // The Domain gap window's real frames: the Browse… on the row of its
    // "Real frames folder" field (opening the window may move the other panels).
    h.state_mut().gap_panel_mut().open = true;
    h.run_steps(2);
    let field = h
        .get_by_role_and_label(Role::TextInput, "Real frames folder")
        .rect();
    h.get_all_by_role_and_label(Role::Button, "Browse…")
        .filter(|b| b.rect().left() >= field.right())
        .min_by(|a, b| {
            let dy = |r: egui::Rect| (r.center().y - field.center().y).abs();
            dy(a.rect()).total_cmp(&dy(b.rect()))
        })
        .unwrap()
        .click_accesskit();
    h.run_steps(2);
    assert_eq!(
        h.state().file_browser().map(|b| b.purpose()),
        Some(swarmshot::app::files::FilePurpose::RealFrames)
    );
    h.get_by_role_and_label(Role::Button, "Choose this folder")
        .click();
    h.run_steps(2);
    assert!(!h.state().gap_panel().real_dir.is_empty());
}
