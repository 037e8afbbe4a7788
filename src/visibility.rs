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

/// Measure every drone of `scene`, with the id passes rendered at `scale` ×
/// the output resolution (1 = pixel-exact at the output resolution; 2 or 4
/// supersample: boxes are divided by `scale`, pixel counts stay in id-pass
/// pixels, so fractions are unaffected).
pub fn measure(
    renderer: &mut Renderer,
    scene: &FrameScene,
    sky: &Sky,
    geometry: &[LabelGeometry],
    scale: u32,
) -> Result<Vec<Visibility>, RenderError> {
    let scale = scale.max(1);
    let scaled;
    let scene = if scale == 1 {
        scene
    } else {
        // Scaling W and H scales K with them: the same view, finer pixels.
        let mut s = scene.clone();
        s.camera.width *= scale;
        s.camera.height *= scale;
        scaled = s;
        &scaled
    };
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
    let k = f64::from(scale);
    Ok(seen
        .into_iter()
        .zip(unoccluded)
        .map(
            |((visible_box, visible_pixels), unoccluded_pixels)| Visibility {
                visible_box: visible_box.map(|b| PixelBox {
                    x0: b.x0 / k,
                    y0: b.y0 / k,
                    x1: b.x1 / k,
                    y1: b.y1 / k,
                }),
                visible_pixels,
                unoccluded_pixels,
            },
        )
        .collect())
}
