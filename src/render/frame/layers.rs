//! The overlap layers of a frame whose main pass is already read: only the
//! drones that pass shows something in front of ([`super::ids::shows_front`])
//! are drawn again, each with drones apart from it, ids only, in a second
//! submission; what they show alone is counted into the frame's tallies.

use crate::render::id_layer::IdCollect;
use crate::render::plan::FramePlan;
use crate::render::readback;
use crate::render::regions::Rect;
use crate::render::{RenderError, Renderer};
use crate::scene::FrameScene;
use crate::scene::projection::PixelBox;

use super::RegionState;

/// What the layer passes of a frame are drawn with and of: its pipelines
/// and targets (indices into the region state), each drone's amodal box
/// and rect, and which drones are measured alone.
pub(super) struct Layers<'a> {
    pub pipelines: usize,
    pub targets: usize,
    pub drones: (&'a [Option<PixelBox>], &'a [Option<Rect>]),
    pub alone: &'a [bool],
}

impl Renderer {
    /// Draw and read the layer passes of the drones `layers.alone` names
    /// (after `main`, the frame's main pass, is read), counting what each
    /// shows alone into `ids`. Nothing to do when no drone is named.
    pub(super) fn measure_alone(
        &mut self,
        state: &mut RegionState,
        scene: &FrameScene,
        main: &FramePlan,
        layers: &Layers<'_>,
        ids: &mut IdCollect,
    ) -> Result<(), RenderError> {
        if !layers.alone.contains(&true) {
            return Ok(());
        }
        let (boxes, rects) = layers.drones;
        let plan = FramePlan::layer_passes(main.request, boxes, rects, layers.alone)?;
        let (p, t) = (layers.pipelines, layers.targets);
        let target = &mut state.targets[t];
        let uploaded = self.upload_plan(&mut state.passes, p, target, scene, &plan);
        let target = &state.targets[t];
        let encoder = self.encode_frame(&state.passes, target, None, &plan, &uploaded);
        let submitted = self.queue.submit([encoder.finish()]);
        match &target.regions_readback {
            Some(buffer) if plan.readback_size > 0 => {
                let size = plan.readback_size;
                readback::read_mapped(&self.device, submitted, buffer, size, |bytes| {
                    ids.add_alone(bytes, &plan.id_reads);
                })?;
            }
            _ => readback::wait(&self.device, submitted)?,
        }
        Ok(())
    }
}
