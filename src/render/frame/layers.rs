//! The unoccluded counts of a frame whose main pass is already read: only
//! the drones that pass shows something in front of
//! ([`super::ids::shows_front`]) are drawn again, in a second submission, and
//! what they show alone is counted into the frame's tallies. The footprint
//! pass (`footprint.rs`) counts them all at once; without it (or when their
//! bitmasks outgrow a storage buffer) they are drawn in overlap layers, each
//! with drones apart from it, ids only.

use crate::render::RenderError;
use crate::render::id_layer::IdCollect;
use crate::render::plan::FramePlan;
use crate::render::readback;
use crate::render::regions::Rect;
use crate::scene::FrameScene;
use crate::scene::projection::PixelBox;

use super::RegionState;
use super::passes::PassInputs;

/// What the layer passes of a frame are drawn with and of: its pipelines
/// and targets (indices into the region state), each drone's amodal box
/// and rect, and which drones are measured alone.
pub(super) struct Layers<'a> {
    pub pipelines: usize,
    pub targets: usize,
    pub drones: (&'a [Option<PixelBox>], &'a [Option<Rect>]),
    pub alone: &'a [bool],
}

/// Draw and read the layer passes of the drones `layers.alone` names (after
/// `main`, the frame's main pass, is read), with what the renderer lends
/// (`with`), counting what each shows alone into `ids`; returns the passes
/// drawn (none when no drone is named).
pub(super) fn measure_alone(
    with: &mut PassInputs<'_>,
    state: &mut RegionState,
    scene: &FrameScene,
    main: &FramePlan,
    layers: &Layers<'_>,
    ids: &mut IdCollect,
) -> Result<u64, RenderError> {
    if !layers.alone.contains(&true) {
        return Ok(0);
    }
    let (boxes, rects) = layers.drones;
    if let Some(footprints) = state.footprints.as_mut() {
        let target = &state.targets[layers.targets];
        let named = (rects, layers.alone);
        if let Some(drawn) = footprints.measure(with, target, scene, named, ids)? {
            return Ok(drawn);
        }
    }
    let plan = FramePlan::layer_passes(main.request, boxes, rects, layers.alone)?;
    let (p, t) = (layers.pipelines, layers.targets);
    let target = &mut state.targets[t];
    let uploaded = (state.passes).upload(with, p, target, scene, &plan);
    let target = &state.targets[t];
    let encoder = (state.passes).encode(with, target, None, &plan, &uploaded);
    let submitted = with.queue.submit([encoder.finish()]);
    match &target.regions_readback {
        Some(buffer) if plan.readback_size > 0 => {
            let size = plan.readback_size;
            readback::read_mapped(with.device, submitted, buffer, size, |bytes| {
                ids.add_alone(bytes, &plan.id_reads);
            })?;
        }
        _ => readback::wait(with.device, submitted)?,
    }
    Ok(plan.passes.len() as u64)
}
