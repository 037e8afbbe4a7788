//! The app's measuring tools driven with egui_kittest and the wgpu renderer (Vulkan
//! pinned: lavapipe on CI): the preview latency the status bar shows, and the
//! domain-gap report window. A missing adapter makes the harness panic ("Failed to
//! create render state"): these tests never pass without rendering.
#![cfg(feature = "app")]
#![allow(clippy::unwrap_used)]

use std::path::{Path, PathBuf};
use std::time::Instant;

use egui_kittest::Harness;
use egui_kittest::kittest::Queryable;
use swarmshot::app::SwarmshotApp;
use swarmshot::preset::Placement;

use crate::app_common;
use app_common::{GPU, harness, wait_for};

/// A small structured preset: 3×3×3 grid, 640×360, JPEG.
const GRID: &str = r#"(
    name: "grid",
    seed: 7,
    placement: Structured(x_count: 3, y_count: 3, z_count: 3, load_factor: 4.0),
    camera: (z: (start: 0.6, end: 1.2, step: 0.2)),
    render: (resolution: Custom(width: 640, height: 360), msaa: 1),
    output: (image_format: Jpeg(quality: 85)),
)"#;

/// The app on the grid preset (written into `dir`), once its first preview is on screen.
fn grid_app_showing_its_preview(dir: &Path) -> Harness<'static, SwarmshotApp> {
    let mut h = harness(Some(grid_preset(dir)));
    wait_for(
        &mut h,
        "the first preview",
        SwarmshotApp::preview_is_current,
    );
    h
}

fn grid_preset(dir: &Path) -> PathBuf {
    let path = dir.join("grid.ron");
    std::fs::write(&path, GRID).unwrap();
    path
}

#[test]
fn an_edit_is_timed_to_its_picture_on_screen_and_the_status_bar_shows_it() {
    let _gpu = GPU.lock().unwrap_or_else(|e| e.into_inner());
    let dir = tempfile::tempdir().unwrap();
    let mut h = grid_app_showing_its_preview(dir.path());
    let before = h.state().preview_latency().recent_ms().count();
    assert!(before >= 1, "the first picture is timed too");

    // An edit; the meter must time it from this pass to the pass after its picture.
    let sent = Instant::now();
    if let Placement::Structured { x_count, .. } = &mut h.state_mut().session_mut().preset.placement
    {
        *x_count = 5;
    }
    wait_for(&mut h, "the preview after XCount = 5", |app| {
        app.preview_is_current() && app.preview_key().is_some_and(|k| k.generation >= 2)
    });
    let elapsed_ms = sent.elapsed().as_secs_f64() * 1e3;
    let meter = h.state().preview_latency();
    assert_eq!(
        meter.recent_ms().count(),
        before + 1,
        "one figure per picture"
    );
    let last = meter.last_ms().unwrap();
    let render = h.state().preview_render_ms().unwrap();
    // At least the preview thread's own render, at most the time the test waited.
    assert!(
        last >= render && last <= elapsed_ms,
        "latency {last} ms outside [render {render} ms, waited {elapsed_ms} ms]"
    );
    let (median, n) = meter.median_ms().unwrap();
    let shown = format!("on screen {last:.0} ms (median {median:.0} ms of {n})");
    h.get_by_label(&shown);
}

#[test]
fn the_gap_window_shows_the_report_table_for_the_bundled_real_frames() {
    let _gpu = GPU.lock().unwrap_or_else(|e| e.into_inner());
    let dir = tempfile::tempdir().unwrap();
    let mut h = grid_app_showing_its_preview(dir.path());
    let temp_before = gap_temp_folders();

    h.get_by_label("Domain gap").click();
    h.step();
    h.step();
    // Not startable before the real folder is named, and it says why.
    h.get_by_label("name the folder of real frames");
    let real = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/real");
    {
        let gap = h.state_mut().gap_panel_mut();
        gap.real_dir = real.display().to_string();
        gap.preset_frames = 3;
    }
    h.step();
    h.get_by_label("Run report").click();
    wait_for(&mut h, "the gap report", |app| {
        !app.gap_panel().is_running()
            && (app.gap_panel().report().is_some() || app.gap_panel().error().is_some())
    });
    let gap = h.state().gap_panel();
    assert_eq!(gap.error(), None);
    let report = gap.report().unwrap();
    assert_eq!(report.real.images_found, 10);
    assert_eq!(
        report.synthetic.images_found, 3,
        "the first 3 of the preset's 4 frames"
    );
    // The table: its header, every statistic's row and verdict, the sides' lines.
    for head in [
        "statistic",
        "real median [IQR]",
        "synthetic median [IQR]",
        "verdict",
    ] {
        h.get_by_label(head);
    }
    for row in &report.statistics {
        h.get_by_label(&swarmshot::app::gap_panel::plain(row.name));
        assert!(["inside", "below", "above", "n/a"].contains(&row.verdict));
    }
    let verdicts = ["inside", "below", "above"]
        .iter()
        .map(|v| h.query_all_by_label(v).count())
        .sum::<usize>();
    let decided = report
        .statistics
        .iter()
        .filter(|r| r.verdict != "n/a")
        .count();
    assert!(decided >= 5, "most statistics have both sides: {decided}");
    assert_eq!(verdicts, decided, "each decided verdict is shown");
    h.get_by_label_contains(&format!("Real: {}", real.display()));
    // The frames made for it are gone again.
    assert_eq!(gap_temp_folders(), temp_before);
}

/// This process's temporary folders of the gap window.
fn gap_temp_folders() -> Vec<PathBuf> {
    let prefix = format!("swarmshot-gap-{}-", std::process::id());
    let mut v: Vec<PathBuf> = std::fs::read_dir(std::env::temp_dir())
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().starts_with(&prefix))
        .map(|e| e.path())
        .collect();
    v.sort();
    v
}

/// What egui's mesh shader fills, in square points (the triangles' areas summed), and
/// the rects of the paint callbacks, in the last pass's output.
fn painted(h: &egui_kittest::Harness<'_, SwarmshotApp>) -> (f32, Vec<egui::Rect>) {
    let shapes = h.output().shapes.clone();
    let mut mesh_area = 0.0;
    let mut callbacks = Vec::new();
    for clipped in h.ctx.tessellate(shapes, h.ctx.pixels_per_point()) {
        match clipped.primitive {
            egui::epaint::Primitive::Mesh(mesh) => {
                for t in mesh.indices.chunks_exact(3) {
                    let [a, b, c] = [t[0], t[1], t[2]].map(|i| mesh.vertices[i as usize].pos);
                    let (u, v) = (b - a, c - a);
                    mesh_area += (u.x * v.y - u.y * v.x).abs() / 2.0;
                }
            }
            egui::epaint::Primitive::Callback(callback) => callbacks.push(callback.rect),
        }
    }
    (mesh_area, callbacks)
}

/// On a CPU rasteriser every pixel egui's mesh shader fills costs about 50 ns of CPU
/// (docs/gui.md, "Preview latency"): the window's background and the preview picture
/// are flat paints (paint callbacks), and egui fills only the widgets and the text.
#[test]
fn the_window_background_and_the_picture_are_not_egui_meshes() {
    let _gpu = GPU.lock().unwrap_or_else(|e| e.into_inner());
    let dir = tempfile::tempdir().unwrap();
    let h = grid_app_showing_its_preview(dir.path());
    let window = h.ctx.content_rect();
    let picture = h
        .state()
        .preview_rect()
        .expect("the preview pane was drawn");
    let (mesh_area, callbacks) = painted(&h);
    assert!(
        callbacks.contains(&window),
        "the background is one flat paint over the window: {callbacks:?}"
    );
    assert!(
        callbacks.contains(&picture),
        "the picture is a flat paint over the pane {picture:?}: {callbacks:?}"
    );
    // The panels' fills alone would be the whole window, the picture another 30 %.
    let share = mesh_area / window.area();
    assert!(
        share < 0.5,
        "egui meshes fill {:.0} % of the window's area",
        share * 100.0
    );
}
