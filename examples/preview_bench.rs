//! Preview latency benchmark for docs/gui.md (a measurement, not a test).
//!
//! 1. Worker level: the quickstart preset at 960×540; each iteration edits a
//!    parameter (CameraZ start), re-validates and renders through
//!    [`PreviewRenderer`] — what the preview thread does after an edit.
//! 2. The same for a 10×10×10 structured grid (1000 drones): the frame time
//!    while scrubbing frames.
//! 3. End to end through the app with egui_kittest (wgpu renderer): from a
//!    changed XCount / CameraZ to the new picture on screen, including the egui
//!    passes and the window render.
//!
//! Run: `cargo run --release --example preview_bench` (add
//! `VK_ICD_FILENAMES=/usr/share/vulkan/icd.d/lvp_icd.x86_64.json WGPU_BACKEND=vulkan`
//! on a lavapipe-only machine).
#![allow(clippy::unwrap_used)]

use std::path::Path;
use std::sync::Arc;
use std::time::{Duration, Instant};

use swarmshot::app::preview::{PreviewKey, PreviewRenderer, PreviewRequest, PreviewView};
use swarmshot::app::{StartOptions, SwarmshotApp};
use swarmshot::preset::{Placement, Preset};
use swarmshot::render::GpuContext;

const ITERATIONS: usize = 20;

fn stats(name: &str, mut ms: Vec<f64>) {
    ms.sort_by(f64::total_cmp);
    let median = ms[ms.len() / 2];
    let p90 = ms[(ms.len() * 9 / 10).min(ms.len() - 1)];
    println!(
        "{name}: median {median:.1} ms, p90 {p90:.1} ms, min {:.1} ms, max {:.1} ms (n = {})",
        ms[0],
        ms[ms.len() - 1],
        ms.len()
    );
}

/// Edit → validate → render, as the app does it, `ITERATIONS` times.
fn worker_latency(
    name: &str,
    renderer: &mut PreviewRenderer,
    base: &Preset,
    edit: impl Fn(&mut Preset, usize),
    frame_of: impl Fn(usize) -> u64,
) {
    let mut preset = base.clone();
    let mut times = Vec::new();
    for i in 0..ITERATIONS + 3 {
        let start = Instant::now();
        edit(&mut preset, i);
        assert!(preset.validate().is_ok());
        let request = PreviewRequest {
            key: PreviewKey {
                generation: i as u64,
                frame: frame_of(i),
                size_px: [960, 540],
                view: PreviewView::Camera,
            },
            preset: Arc::new(preset.clone()),
        };
        let frame = renderer
            .render(&request)
            .unwrap_or_else(|e| panic!("{}", e.message));
        let ms = start.elapsed().as_secs_f64() * 1e3;
        if i >= 3 {
            times.push(ms);
        }
        if i == 3 {
            println!(
                "{name}: {} drones in the frame, {} boxes",
                frame.scene.drones.len(),
                frame.labels.len()
            );
        }
    }
    stats(name, times);
}

fn end_to_end(
    name: &str,
    preset_path: &Path,
    edit: impl Fn(&mut egui_kittest::Harness<'_, SwarmshotApp>, usize),
) {
    let mut h = egui_kittest::Harness::builder()
        .with_size([1700.0, 900.0])
        .wgpu()
        .build_eframe(|cc| {
            SwarmshotApp::new(
                cc,
                StartOptions {
                    preset: Some(preset_path.to_owned()),
                    restore_session: false,
                },
            )
        });
    // Steps the app until the new picture is in its egui texture, then draws the window.
    let wait = |h: &mut egui_kittest::Harness<'_, SwarmshotApp>| {
        let start = Instant::now();
        while !h.state().preview_is_current() {
            h.step();
            std::thread::sleep(Duration::from_millis(1));
            assert!(
                start.elapsed() < Duration::from_secs(60),
                "preview never arrived"
            );
        }
        h.step();
        let current = start.elapsed();
        h.render().unwrap();
        (current, start.elapsed() - current)
    };
    wait(&mut h);
    // Make the pane 960 px wide.
    for _ in 0..3 {
        let [w, _] = h.state().preview_key().unwrap().size_px;
        let size = h.ctx.content_rect().size();
        h.set_size(egui::vec2(size.x + 960.0 - w as f32, size.y));
        h.step();
        h.step();
        wait(&mut h);
    }
    let [w, hh] = h.state().preview_key().unwrap().size_px;
    let (mut shown, mut window) = (Vec::new(), Vec::new());
    for i in 0..ITERATIONS + 2 {
        let start = Instant::now();
        edit(&mut h, i);
        h.step();
        let (_, window_render) = wait(&mut h);
        if i >= 2 {
            shown.push((start.elapsed() - window_render).as_secs_f64() * 1e3);
            window.push(window_render.as_secs_f64() * 1e3);
        }
    }
    let render_ms = h.state().preview_render_ms().unwrap();
    println!("{name}: pane {w}×{hh}, last preview render {render_ms:.1} ms");
    stats(
        &format!("{name}: edit → new picture in the egui texture (UI passes included)"),
        shown,
    );
    stats(
        &format!(
            "{name}: kittest window render + readback ({:.0}×{:.0} points, test-harness cost)",
            h.ctx.content_rect().width(),
            h.ctx.content_rect().height()
        ),
        window,
    );
}

fn main() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let quickstart_path = root.join("presets/quickstart.ron");
    let quickstart = Preset::open(&quickstart_path).unwrap();
    let ctx = GpuContext::headless().unwrap();
    println!("adapter: {}", ctx.describe());
    let mut renderer = PreviewRenderer::new(ctx);

    worker_latency(
        "quickstart 960×540, CameraZ start edit",
        &mut renderer,
        &quickstart,
        |p, i| p.camera.z.start = if i % 2 == 0 { 0.6 } else { 0.2 },
        |_| 0,
    );
    let mut grid = quickstart.clone();
    grid.placement = Placement::Structured {
        x_count: 10,
        y_count: 10,
        z_count: 10,
        load_factor: 3.0,
    };
    worker_latency(
        "10×10×10 grid 960×540, scrubbing frames",
        &mut renderer,
        &grid,
        |_, _| {},
        |i| i as u64 % grid.frame_count(),
    );
    worker_latency(
        "10×10×10 grid 960×540, XCount edit",
        &mut renderer,
        &grid,
        |p, i| {
            if let Placement::Structured { x_count, .. } = &mut p.placement {
                *x_count = if i % 2 == 0 { 10 } else { 9 };
            }
        },
        |_| 0,
    );

    end_to_end("app, quickstart", &quickstart_path, |h, i| {
        h.state_mut().session_mut().preset.camera.z.start = if i % 2 == 0 { 0.2 } else { 0.6 };
    });
    let dir = std::env::temp_dir().join("swarmshot-bench");
    std::fs::create_dir_all(&dir).unwrap();
    let grid_path = dir.join("grid10.ron");
    std::fs::write(&grid_path, grid.to_ron()).unwrap();
    end_to_end("app, 10×10×10 grid", &grid_path, |h, i| {
        if let Placement::Structured { x_count, .. } =
            &mut h.state_mut().session_mut().preset.placement
        {
            *x_count = if i % 2 == 0 { 9 } else { 10 };
        }
    });
}
