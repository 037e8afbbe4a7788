//! The preview pane's mask views (issue 22, item 5): with `output.masks` the
//! pane shows the previewed frame's instance image and depth map, the same
//! masks the batch writes.
#![cfg(feature = "app")]
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::{Path, PathBuf};

use egui_kittest::kittest::Queryable;
use swarmshot::app::SwarmshotApp;
use swarmshot::app::mask_view::{PaneShows, drone_colour};
use swarmshot::pipeline::FramePipeline;
use swarmshot::preset::Preset;

use crate::app_common;
use crate::common;
use app_common::{GPU, harness, wait_for};

/// Two drones side by side at 96×64, instance images and depth maps asked for.
const MASKED: &str = r#"(
    name: "masked",
    seed: 11,
    placement: Structured(x_count: 2, y_count: 1, z_count: 1, load_factor: 3.0),
    camera: (z: (start: 1.0, end: 2.0, step: 0.5)),
    render: (resolution: Custom(width: 96, height: 64), msaa: 1),
    output: (image_format: Png, label_formats: [Yolo], masks: (instance_png: true, depth: true)),
)"#;

fn masked(dir: &Path) -> PathBuf {
    let path = dir.join("masked.ron");
    std::fs::write(&path, MASKED).unwrap();
    path
}

#[test]
fn the_pane_shows_the_frames_instance_image_and_depth_map() {
    let _gpu = GPU.lock().unwrap_or_else(|e| e.into_inner());
    let dir = tempfile::tempdir().unwrap();
    let path = masked(dir.path());
    let mut h = harness(Some(path.clone()));
    wait_for(&mut h, "the first preview", |app| app.preview_is_current());
    assert_eq!(h.state().pane_shows(), PaneShows::Picture);

    h.get_by_label("Instances").click();
    wait_for(&mut h, "the instance image", |app: &SwarmshotApp| {
        if let Some((_, e)) = app.mask_error() {
            panic!("the masks failed: {e}");
        }
        app.pane_shows() == PaneShows::Instances
            && app
                .mask_picture()
                .is_some_and(|p| p.key.generation == app.generation())
    });
    // The batch's own masks of frame 0: each pixel in the colour of its drone.
    let preset = Preset::open(&path).unwrap();
    let pipeline = FramePipeline::new(preset).unwrap();
    let mut renderer = pipeline.renderer(&common::gpu());
    let frame = pipeline.make(&mut renderer, 0).unwrap();
    let masks = frame.masks.expect("masks asked for");
    let picture = h.state().mask_picture().unwrap();
    assert_eq!(picture.instances.size, [96, 64]);
    assert_eq!(picture.pixels_shown, masks.instance.len());
    assert!(
        picture.pixels_shown > 0,
        "no drone pixel in the instance image"
    );
    assert_eq!(picture.drones_shown, 2);
    for &(pixel, drone) in &masks.instance {
        assert_eq!(
            picture.instances.pixels[pixel as usize],
            drone_colour(drone)
        );
    }

    h.get_by_label("Depth").click();
    wait_for(&mut h, "the depth view", |app| {
        app.pane_shows() == PaneShows::Depth
    });
    let picture = h.state().mask_picture().unwrap();
    let depth = picture.depth.as_ref().expect("depth asked for");
    let lit = depth.pixels.iter().filter(|p| p.r() > 0).count();
    assert_eq!(lit, masks.instance.len(), "depth shows where drones show");

    // Back to the picture.
    h.get_by_label("Picture").click();
    wait_for(&mut h, "the picture", |app| {
        app.pane_shows() == PaneShows::Picture
    });
}
