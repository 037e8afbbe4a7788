//! The app under hostile inputs and edits (an audit): a batch failure says each cause
//! once; Generate waits while a merge writes into the output folder; Save replaces the
//! preset file atomically, keeps its permissions, leaves a read-only file, a file edited
//! elsewhere and a file the preset reads, and never writes through a link; Save As into
//! another folder keeps the files the preset reads; the preview's boxes are the batch's
//! labels through a camera model; a preset over the render budget is a problem; a restored
//! session whose file broke says so; while a batch runs another preset is refused in
//! words; a repeated message is shown once; a folder typed as `~/…` is in the home folder,
//! and a chosen folder whose name is not UTF-8 is refused, not stored as another name.
//! Rendering through the wgpu renderer (lavapipe on CI).
#![cfg(feature = "app")]
#![allow(clippy::unwrap_used)]

use std::os::unix::fs::MetadataExt;
use std::path::Path;
use std::sync::Arc;

use egui::accesskit::Role;
use egui_kittest::Harness;
use egui_kittest::kittest::Queryable;
use swarmshot::app::preview::{PreviewKey, PreviewRenderer, PreviewRequest, PreviewView};
use swarmshot::app::runner::BatchError;
use swarmshot::app::{Command, StartOptions, SwarmshotApp};
use swarmshot::pipeline::FramePipeline;
use swarmshot::preset::{ModelSource, Preset, Resolution};

use crate::app_common;
use app_common::{GPU, MemoryStorage, harness, harness_with, wait_for};

/// 3 frames at 96×64.
const TINY: &str = r#"(
    name: "tiny",
    seed: 11,
    placement: Structured(x_count: 2, y_count: 1, z_count: 1, load_factor: 3.0),
    camera: (z: (start: 1.0, end: 2.0, step: 0.5)),
    render: (resolution: Custom(width: 96, height: 64), msaa: 1),
    output: (image_format: Png, label_formats: [Yolo], split: (train: 1.0, val: 0.0, test: 0.0)),
)"#;

/// The app on `preset` (written as `dir/tiny.ron`) once its first preview is on screen.
fn settled(dir: &Path, preset: &str) -> Harness<'static, SwarmshotApp> {
    let path = dir.join("tiny.ron");
    std::fs::write(&path, preset).unwrap();
    let mut h = harness(Some(path));
    wait_for(&mut h, "the first preview", |app| app.preview_is_current());
    h
}

fn command(h: &mut Harness<'static, SwarmshotApp>, command: Command) {
    let ctx = h.ctx.clone();
    h.state_mut().command(command, &ctx);
}

#[test]
fn a_batch_failure_names_each_cause_once() {
    // A missing model: the model error's message already quotes its source.
    let missing = swarmshot::model::ModelError::Io {
        file: "/x/nope.glb".into(),
        source: std::io::Error::from(std::io::ErrorKind::NotFound),
    };
    let shown = BatchError::Failed(anyhow::Error::from(missing)).to_string();
    assert_eq!(
        shown.matches("not found").count(),
        1,
        "the cause is said once: {shown}"
    );
    assert!(
        shown.starts_with("cannot read model /x/nope.glb"),
        "{shown}"
    );
}

#[test]
fn generate_waits_while_a_merge_writes_into_the_output_folder() {
    let _gpu = GPU.lock().unwrap_or_else(|e| e.into_inner());
    let dir = tempfile::tempdir().unwrap();
    let mut h = settled(dir.path(), TINY);
    let out = dir.path().join("merged");
    let session = h.state_mut().session_mut();
    session.out_dir = out.display().to_string();
    session.merge_shards = dir.path().join("shard-1").display().to_string();
    h.run_steps(2);
    // Merge, then Generate before the merge's thread has answered: two writers in one folder.
    command(&mut h, Command::Merge);
    command(&mut h, Command::Generate);
    assert!(!h.state().batch_running(), "no batch beside the merge");
    let notice = h.state().notices().last().cloned().unwrap_or_default();
    assert!(notice.contains("a merge is writing"), "{notice}");
    wait_for(&mut h, "the merge's answer", |app| {
        app.merge_outcome().is_some()
    });
    assert!(!out.exists(), "the refused merge wrote nothing");
}

#[test]
fn save_replaces_the_preset_file_atomically_and_never_through_a_link() {
    let _gpu = GPU.lock().unwrap_or_else(|e| e.into_inner());
    let dir = tempfile::tempdir().unwrap();
    let mut h = settled(dir.path(), TINY);
    let path = dir.path().join("tiny.ron");
    let before = std::fs::metadata(&path).unwrap().ino();
    h.state_mut().session_mut().preset.seed = 12;
    h.run_steps(2);
    command(&mut h, Command::Save);
    h.run_steps(2);
    // A new file renamed over the old one (a failed or killed write leaves the old whole).
    assert_ne!(std::fs::metadata(&path).unwrap().ino(), before);
    assert!(std::fs::read_to_string(&path).unwrap().contains("seed: 12"));
    assert!(!h.state().session().is_dirty());
    let names: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names, ["tiny.ron"], "no temporary file is left");

    // Its permissions carry over; a read-only preset is not replaced.
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o600)).unwrap();
    h.state_mut().session_mut().preset.seed = 14;
    h.run_steps(2);
    command(&mut h, Command::Save);
    h.run_steps(2);
    let mode = std::fs::metadata(&path).unwrap().permissions().mode();
    assert_eq!(mode & 0o777, 0o600);
    std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o444)).unwrap();
    h.state_mut().session_mut().preset.seed = 15;
    h.run_steps(2);
    command(&mut h, Command::Save);
    h.run_steps(2);
    assert!(std::fs::read_to_string(&path).unwrap().contains("seed: 14"));
    let notice = h.state().notices().last().cloned().unwrap_or_default();
    assert!(
        notice.contains("tiny.ron") && notice.contains("read-only"),
        "{notice}"
    );
    let session = h.state_mut().session_mut();
    session.saved = Some(session.preset.clone()); // (Open without the unsaved-changes prompt)

    // A preset file that is a link to a file elsewhere is refused by name, not written through.
    let elsewhere = tempfile::tempdir().unwrap();
    let target = elsewhere.path().join("real.ron");
    std::fs::write(&target, TINY).unwrap();
    let link = dir.path().join("link.ron");
    std::os::unix::fs::symlink(&target, &link).unwrap();
    command(&mut h, Command::OpenPath(link.clone()));
    h.run_steps(2);
    h.state_mut().session_mut().preset.seed = 13;
    h.run_steps(2);
    command(&mut h, Command::Save);
    h.run_steps(2);
    assert_eq!(std::fs::read_to_string(&target).unwrap(), TINY);
    let notice = h.state().notices().last().cloned().unwrap_or_default();
    assert!(
        notice.contains("link.ron") && notice.contains("symbolic link"),
        "{notice}"
    );
    assert!(h.state().session().is_dirty(), "the edit is still unsaved");
}

/// Save As `name` through the in-app browser, replacing a file there when asked.
fn save_as(h: &mut Harness<'static, SwarmshotApp>, name: &str) {
    let ctx = h.ctx.clone();
    h.state_mut()
        .use_file_dialogs(swarmshot::app::files::DialogBackend::Builtin, &ctx);
    command(h, Command::SaveAs);
    h.run_steps(2);
    h.get_by_label("File name").focus();
    h.run_steps(1);
    h.key_combination_modifiers(egui::Modifiers::COMMAND, &[egui::Key::A]);
    h.get_by_label("File name").type_text(name);
    h.run_steps(2);
    for action in ["Save", "Replace"] {
        let button = h.query_all_by_role_and_label(Role::Button, action);
        if let Some(button) = button.max_by(|a, b| a.rect().top().total_cmp(&b.rect().top())) {
            button.click();
            h.run_steps(2);
        }
    }
}

/// TINY drawing the model `m.glb` beside it (a copy of a bundled one) in `dir`.
fn with_model(dir: &Path) -> String {
    let model = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/models/bird_sparrow_0.glb");
    std::fs::copy(&model, dir.join("m.glb")).unwrap();
    TINY.replace(
        "seed: 11,",
        "seed: 11, models: [(source: File(\"m.glb\"), size_m: 0.5, class: \"uav\")],",
    )
}

#[test]
fn save_as_over_a_file_the_preset_reads_is_refused() {
    let _gpu = GPU.lock().unwrap_or_else(|e| e.into_inner());
    let dir = tempfile::tempdir().unwrap();
    let preset = with_model(dir.path());
    let mut h = settled(dir.path(), &preset);
    let before = std::fs::read(dir.path().join("m.glb")).unwrap();
    save_as(&mut h, "m.glb");
    assert_eq!(std::fs::read(dir.path().join("m.glb")).unwrap(), before);
    let notice = h.state().notices().last().cloned().unwrap_or_default();
    assert!(
        notice.contains("the preset reads that file (models)"),
        "{notice}"
    );
    assert!(
        h.state()
            .session()
            .preset_path
            .as_deref()
            .is_some_and(|p| p.ends_with("tiny.ron"))
    );
}

#[test]
fn save_as_into_another_folder_keeps_the_model_the_preset_reads() {
    let _gpu = GPU.lock().unwrap_or_else(|e| e.into_inner());
    let dir = tempfile::tempdir().unwrap();
    let preset = with_model(dir.path());
    let mut h = settled(dir.path(), &preset);
    assert_eq!(h.state().preview_error(), None);
    let other = dir.path().join("other");
    std::fs::create_dir(&other).unwrap();
    let copy = other.join("copy.ron");
    save_as(&mut h, &copy.display().to_string());
    wait_for(&mut h, "the copy's preview", |app| {
        app.session().preset_path.as_deref() == Some(copy.as_path()) && app.preview_is_current()
    });
    assert_eq!(
        h.state().preview_error(),
        None,
        "the copy still finds m.glb"
    );
    // The file read on its own (as `swarmshot batch` reads it) names the same model.
    let mut saved = swarmshot::preset::Preset::load(&copy).unwrap();
    saved.resolve_paths(&other);
    let ModelSource::File(read) = &saved.models[0].source else {
        panic!("{:?}", saved.models[0].source)
    };
    assert!(read.is_file(), "{} exists", read.display());
    assert_eq!(
        read.canonicalize().unwrap(),
        dir.path().join("m.glb").canonicalize().unwrap()
    );
}

/// The shipped `preset` at 160×96.
fn small_shipped(name: &str) -> Preset {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("presets")
        .join(name);
    let mut preset = Preset::load(&path).unwrap();
    preset.resolve_paths(path.parent().unwrap());
    preset.render.resolution = Resolution::Custom {
        width: 160,
        height: 96,
    };
    preset
}

#[test]
fn the_preview_boxes_are_the_batch_labels_through_a_camera_model() {
    let _gpu = GPU.lock().unwrap_or_else(|e| e.into_inner());
    let ctx = crate::common::gpu();
    // Blur and noise; a lens; a rolling shutter: the batch measures visibility in the
    // finished picture (and a lens moves the boxes).
    for name in [
        "realistic.ron",
        "lens_distortion.ron",
        "rolling_shutter.ron",
    ] {
        let preset = small_shipped(name);
        let pipeline = FramePipeline::new(preset.clone()).unwrap();
        let mut batch = pipeline.renderer(&ctx);
        let mut preview = PreviewRenderer::new(ctx.clone());
        for frame in 0..2 {
            let made = pipeline.make(&mut batch, frame).unwrap();
            let views = [PreviewView::ThroughCamera, PreviewView::Camera];
            for (size_px, view) in [[160, 96], [80, 48]].into_iter().zip(views) {
                let key = PreviewKey {
                    generation: 0,
                    frame,
                    size_px,
                    view,
                };
                let preset = Arc::new(preset.clone());
                let shown = preview.picture(&PreviewRequest { key, preset }).unwrap();
                assert_eq!(shown.labels, made.labels, "{name} frame {frame} {view:?}");
                if size_px == [160, 96] {
                    assert!(shown.rgba == made.rgba, "{name} frame {frame}: pixels");
                }
            }
        }
    }
}

/// 200 000 drones a frame (twice the render budget), boxes from the geometry alone: a
/// labels-only batch may plan it, a rendered one refuses it.
const OVER_BUDGET: &str = r#"(
    name: "over",
    seed: 7,
    placement: Structured(x_count: 100, y_count: 100, z_count: 20, load_factor: 4.0),
    camera: (z: (start: 1.0, end: 1.0, step: 0.5)),
    render: (resolution: Custom(width: 96, height: 64), msaa: 1),
    labels: (box_method: Amodal),
)"#;

#[test]
fn a_preset_over_the_render_budget_is_a_problem_and_is_not_previewed() {
    let _gpu = GPU.lock().unwrap_or_else(|e| e.into_inner());
    let preset = Arc::new(Preset::from_ron(OVER_BUDGET).unwrap());
    let key = PreviewKey {
        generation: 0,
        frame: 0,
        size_px: [96, 64],
        view: PreviewView::Camera,
    };
    let mut preview = PreviewRenderer::new(crate::common::gpu());
    let refused = preview.picture(&PreviewRequest { key, preset }).err();
    let refused = refused.map(|e| e.to_string()).unwrap_or_default();
    assert!(refused.contains("work budget"), "{refused}");

    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("over.ron");
    std::fs::write(&path, OVER_BUDGET).unwrap();
    let mut h = harness(Some(path));
    h.run_steps(3);
    let errors = h.state().errors();
    assert!(
        errors
            .iter()
            .any(|e| e.field == "placement" && e.message.contains("work budget")),
        "{errors:?}"
    );
    command(&mut h, Command::Generate);
    assert!(!h.state().batch_running());
}

#[test]
fn a_restored_session_whose_file_is_now_broken_says_so_and_never_saves_over_it() {
    let _gpu = GPU.lock().unwrap_or_else(|e| e.into_inner());
    let dir = tempfile::tempdir().unwrap();
    let mut h = settled(dir.path(), TINY);
    let mut storage = MemoryStorage::default();
    eframe::App::save(h.state_mut(), &mut storage);
    drop(h);
    // Between sessions the file is edited by hand, with a typo.
    let path = dir.path().join("tiny.ron");
    let edited = TINY.replace("seed: 11,", "seed: 12,,");
    std::fs::write(&path, &edited).unwrap();
    let storage: &'static MemoryStorage = Box::leak(Box::new(storage));
    let options = StartOptions {
        preset: None,
        restore_session: true,
    };
    let mut h = harness_with(options, Some(storage), [1400.0, 880.0]);
    h.run_steps(3);
    let notice = h.state().notices().last().cloned().unwrap_or_default();
    assert!(notice.contains(&path.display().to_string()), "{notice}");
    // Shown unsaved and tied to no file: Save asks for one, the hand edit stays.
    assert!(h.state().session().is_dirty());
    assert_eq!(h.state().session().preset_path, None);
    command(&mut h, Command::Save);
    h.run_steps(2);
    assert_eq!(std::fs::read_to_string(&path).unwrap(), edited);
}

#[test]
fn while_a_batch_runs_another_preset_is_refused_in_words_and_the_fit_folders_browse() {
    let _gpu = GPU.lock().unwrap_or_else(|e| e.into_inner());
    let dir = tempfile::tempdir().unwrap();
    let mut h = settled(dir.path(), TINY);
    let ctx = h.ctx.clone();
    h.state_mut()
        .use_file_dialogs(swarmshot::app::files::DialogBackend::Builtin, &ctx);
    h.state_mut().session_mut().out_dir = dir.path().join("out").display().to_string();
    h.run_steps(2);
    command(&mut h, Command::Generate);
    assert!(h.state().batch_running());
    // A finished fit opens its preset this way: while the batch runs it is said, not dropped.
    command(&mut h, Command::OpenPath(dir.path().join("fitted.ron")));
    let notice = h.state().notices().last().cloned().unwrap_or_default();
    assert!(notice.contains("a batch is running"), "{notice}");
    // The Fit window's Browse… is its own folder's: it opens.
    let fit_real = Command::BrowseFolder(swarmshot::app::files::FilePurpose::FitRealFrames);
    command(&mut h, fit_real);
    assert!(
        h.state().file_browser().is_some(),
        "the folder dialog opened"
    );
    wait_for(&mut h, "the batch", |app| !app.batch_running());
}

#[test]
fn a_repeated_failure_is_shown_once_and_the_messages_stay_few() {
    let _gpu = GPU.lock().unwrap_or_else(|e| e.into_inner());
    let dir = tempfile::tempdir().unwrap();
    let mut h = settled(dir.path(), TINY);
    // Ctrl+S held on a preset that cannot be saved: one message, not one per key repeat.
    use std::os::unix::fs::PermissionsExt;
    let path = dir.path().join("tiny.ron");
    std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o444)).unwrap();
    h.state_mut().session_mut().preset.seed = 12;
    h.run_steps(2);
    for _ in 0..20 {
        command(&mut h, Command::Save);
        h.step();
    }
    assert_eq!(h.state().notices().len(), 1, "{:?}", h.state().notices());
    // Twenty different failures: the newest few are shown.
    let session = h.state_mut().session_mut();
    session.saved = Some(session.preset.clone()); // (Open without the unsaved-changes prompt)
    for i in 0..20 {
        command(
            &mut h,
            Command::OpenPath(dir.path().join(format!("gone-{i}.ron"))),
        );
        h.step();
    }
    let notices = h.state().notices();
    assert!(notices.len() <= 6, "{notices:?}");
    assert!(notices.last().unwrap().contains("gone-19.ron"));
}

#[test]
fn save_does_not_overwrite_an_edit_made_elsewhere() {
    let _gpu = GPU.lock().unwrap_or_else(|e| e.into_inner());
    let dir = tempfile::tempdir().unwrap();
    let mut h = settled(dir.path(), TINY);
    let path = dir.path().join("tiny.ron");
    // Another editor changes the file while the app has it open.
    let elsewhere = TINY.replace("seed: 11,", "seed: 99, // set by hand");
    std::fs::write(&path, &elsewhere).unwrap();
    h.state_mut().session_mut().preset.seed = 12;
    h.run_steps(2);
    command(&mut h, Command::Save);
    h.run_steps(2);
    assert_eq!(std::fs::read_to_string(&path).unwrap(), elsewhere);
    let notice = h.state().notices().last().cloned().unwrap_or_default();
    assert!(notice.contains("changed on disk"), "{notice}");
    assert!(h.state().session().is_dirty());
}

/// A typed `~/…` output folder is the home folder's (a shell's reading), not a folder named
/// `~` in the working folder; a folder a dialog answers whose name is not UTF-8 is refused
/// in words, and the field keeps what it had (its text would name another folder).
#[test]
fn a_typed_tilde_is_home_and_a_non_utf8_folder_is_refused() {
    use std::os::unix::ffi::OsStrExt;
    use swarmshot::app::files::FilePurpose;
    let _gpu = GPU.lock().unwrap_or_else(|e| e.into_inner());
    let dir = tempfile::tempdir().unwrap();
    let mut h = settled(dir.path(), TINY);
    h.state_mut().session_mut().out_dir = " ~/swarmshot-data ".into();
    let home = dirs::home_dir().unwrap();
    assert_eq!(
        h.state().batch_options().out_dir,
        home.join("swarmshot-data")
    );
    let odd = dir.path().join(std::ffi::OsStr::from_bytes(b"caf\xe9"));
    std::fs::create_dir(&odd).unwrap();
    let ctx = h.ctx.clone();
    h.state_mut().choose(FilePurpose::OutputFolder, odd, &ctx);
    assert_eq!(h.state().session().out_dir, " ~/swarmshot-data ");
    let notices = h.state().notices().join("\n");
    assert!(notices.contains("is not UTF-8 text"), "{notices}");
}
