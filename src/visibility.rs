//! Visibility from instance-id passes: each drone's visible box, visible
//! pixel count and unoccluded pixel count.
//!
//! One id pass over the whole swarm gives every drone's visible pixels. A
//! drone whose (padded) amodal box overlaps no other drone's cannot be
//! occluded, so its unoccluded count is its visible count. The others are
//! split into layers of mutually non-overlapping drones (`labels::overlap_layers`);
//! rendering each layer alone gives their unoccluded counts exactly. A sparse
//! swarm costs one pass; a dense one a pass per layer.

use crate::labels::{LabelGeometry, PixelBox, Visibility, amodal_box, overlap_layers, pixel_stats};
use crate::preset::Sky;
use crate::render::{RenderError, Renderer};
use crate::scene::FrameScene;

/// Measure every drone of `scene`.
pub fn measure(
    renderer: &mut Renderer,
    scene: &FrameScene,
    sky: &Sky,
    geometry: &[LabelGeometry],
) -> Result<Vec<Visibility>, RenderError> {
    let n = scene.drones.len();
    let ids = renderer.render_ids(scene, sky, &|_| true)?;
    let seen = pixel_stats(&ids, n);
    let (w, h) = (
        f64::from(scene.camera.width),
        f64::from(scene.camera.height),
    );
    let boxes: Vec<Option<PixelBox>> = scene
        .drones
        .iter()
        .map(|d| {
            amodal_box(&scene.camera, d, &geometry[d.model])
                .map(|b| b.clip(w, h))
                .filter(|b| b.width() > 0.0 && b.height() > 0.0)
        })
        .collect();
    let (layers, overlapping) = overlap_layers(&boxes);
    let mut unoccluded: Vec<u64> = seen.iter().map(|(_, count)| *count).collect();
    for layer in layers {
        let members: Vec<usize> = layer.into_iter().filter(|&i| overlapping[i]).collect();
        if members.is_empty() {
            continue;
        }
        let mut include = vec![false; n];
        for &m in &members {
            include[m] = true;
        }
        let alone = renderer.render_ids(scene, sky, &|i| include[i])?;
        let stats = pixel_stats(&alone, n);
        for m in members {
            unoccluded[m] = stats[m].1;
        }
    }
    Ok(seen
        .into_iter()
        .zip(unoccluded)
        .map(
            |((visible_box, visible_pixels), unoccluded_pixels)| Visibility {
                visible_box,
                visible_pixels,
                unoccluded_pixels,
            },
        )
        .collect())
}
