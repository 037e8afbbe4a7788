//! Frames drawn region by region: the cost of a frame grows with the pixels
//! its drones cover, not with the frame.
//!
//! A frame is composed from parts that own their things ([`RegionState`]):
//! the region passes (`passes.rs`: shaders, layouts, pipelines, rect
//! buffers, the uploads and encoding of a frame's passes), the background ([`super::background`]: the sky pipelines; per
//! size a [`super::background::BackgroundCache`], drawn only when what it
//! depends on changes and read back once into a CPU copy), the scenery
//! ([`super::scenery`]) and, per size and sample count, the full-size
//! targets allocated once and never cleared ([`super::targets`], with the
//! id layer).
//!
//! A frame then only touches its regions ([`super::regions`]): merged,
//! padded boxes of the drones' projected hulls. It is made in three steps:
//! its [`FramePlan`] (CPU only: passes, overlap layers, atlas places, reads),
//! the encoded passes ([`passes`]: in each region, a scissor rect, the
//! background drawn at far depth with id 0 (the region's "clear"), then the
//! drones, with the same full-frame projection as a full render, so
//! rasterisation is bit-identical to one; with MSAA the regions resolved by
//! a shader (the mean of the samples, and the id samples side by side) into
//! a compact atlas), and the collected readback: one reused buffer, pasted
//! into the frame's buffer (which already holds the background: [`Painted`])
//! and reduced to per-drone visibility on the CPU ([`IdCollect`]). With
//! visibility (and no scenery) the unoccluded counts come after the main
//! pass is read, in a submission of their own, for only the drones that
//! pass shows something in front of ([`ids::shows_front`]): one footprint
//! pass (`footprint.rs`), or, where fragment shaders cannot write storage,
//! the overlap layers' passes (`layers.rs`).

mod footprint;
mod layers;
mod passes;

use super::background::{BackgroundInputs, Backgrounds};
use super::gpu::PipelineFactory;
use super::id_layer::{self, IdCollect};
use super::ids;
use super::plan::{FramePlan, PassPlan, PlanRequest};
use super::readback;
use super::regions::{self, Rect};
use super::scenery::{self, SceneryGpu};
use super::targets::{FrameTargets, TargetLayouts};
use super::visibility::Visibility;
use super::{IdImage, RenderError, Renderer};
use crate::scene::FrameScene;
use layers::Layers;
use passes::{PassInputs, RegionPasses};

/// What [`Renderer::render_frame`] is asked for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RenderRequest {
    /// Samples per pixel: 1 or 4.
    pub msaa: u32,
    /// Produce the picture (false: visibility only, e.g. for a preview's labels).
    pub color: bool,
    /// Measure each drone's visibility from the same samples.
    pub visibility: bool,
}

/// A rendered frame.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RenderedFrame {
    /// Tightly packed RGBA8, sRGB-encoded; empty when colour was not asked for.
    pub rgba: Vec<u8>,
    /// Which background `rgba` holds and where this frame painted over it:
    /// hand both back with [`Renderer::recycle`] and a later frame over the
    /// same background restores only these rects instead of copying it whole.
    pub painted: Painted,
    /// Per drone (scene order), when asked for.
    pub visibility: Option<Vec<Visibility>>,
    /// Each visible pixel's drones, with visibility when
    /// [`Renderer::set_pixel_hits`] is on (row by row within each drawn rect).
    pub pixel_hits: Option<Vec<ids::PixelHit>>,
}

/// What a frame's pixel buffer holds: the cached background `background`
/// (a process-wide generation number; 0: none) with `rects` painted over it.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Painted {
    pub(super) background: u64,
    pub(super) rects: Vec<Rect>,
}

impl Painted {
    /// The background's key: unique in the process to one drawn background
    /// (0: the buffer holds none).
    pub fn background(&self) -> u64 {
        self.background
    }

    /// The rects this frame painted over its background; everywhere else
    /// its pixels are the background's.
    pub fn rects(&self) -> &[Rect] {
        &self.rects
    }
}

/// Each drone's rect and whether drone `j` may hide drone `i` (`(j, i)`):
/// what telling the drones that need a layer pass takes.
type FrontCheck<'a> = (&'a [Option<Rect>], &'a dyn Fn(usize, usize) -> bool);

/// A collected main pass: the frame (without its visibility), the id
/// tallies, and the drones that need a layer pass (when asked).
type Collected = (RenderedFrame, IdCollect, Option<Vec<bool>>);

/// Long-lived state of region rendering, built on first use: the parts a
/// frame is made of, each owning its things.
pub(super) struct RegionState {
    /// The region passes: shaders, layouts, pipelines and rect buffers.
    passes: RegionPasses,
    /// The background part: its sky pipelines and how often it drew.
    backgrounds: Backgrounds,
    /// Most recently used last; at most [`MAX_TARGETS`].
    targets: Vec<FrameTargets>,
    /// The near-field scenery's layer and pipelines (frames with clutter only).
    scenery: Option<SceneryGpu>,
    /// The footprint pass (unoccluded counts in one pass; `None` where
    /// fragment shaders cannot write storage: layer passes instead).
    footprints: Option<footprint::Footprints>,
}

/// Target sets kept at once (e.g. a frame size and its id-pass size).
const MAX_TARGETS: usize = 2;

/// Frame targets of `size` and `msaa` samples with their first use
/// submitted ([`made_targets`]), made without a renderer.
pub(super) fn first_used_targets(
    (device, queue): (&wgpu::Device, &wgpu::Queue),
    size: (u32, u32),
    msaa: u32,
) -> FrameTargets {
    let factory = PipelineFactory::new(device);
    let (background, resolve) = passes::target_layouts(&factory);
    let layouts = TargetLayouts {
        background: &background,
        resolve: &resolve,
    };
    made_targets((device, queue), size, msaa, layouts)
}

/// New frame targets with their first use submitted at once: a pass that
/// loads and stores their colour, ids and depth and draws nothing, which
/// wgpu precedes by zeroing them (faulting in some 100 MB at 1080p with
/// MSAA 4). On a CPU device that work then runs on the driver's threads
/// while the caller goes on, not before the first frame's passes; frames
/// are the same either way.
fn made_targets(
    (device, queue): (&wgpu::Device, &wgpu::Queue),
    size: (u32, u32),
    msaa: u32,
    layouts: TargetLayouts<'_>,
) -> FrameTargets {
    let targets = FrameTargets::new(device, size, msaa, layouts);
    let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
        label: Some("targets' first use"),
    });
    let views = super::gpu::PassViews {
        color: targets.color_view(),
        ids: targets.ids.view(),
        depth: &targets.depth,
    };
    drop(super::gpu::load_pass(
        &mut encoder,
        "targets' first use",
        views,
    ));
    queue.submit([encoder.finish()]);
    targets
}

impl RegionState {
    /// The parts of `factory`'s device, on `backend`.
    pub(super) fn new(factory: &PipelineFactory, backend: wgpu::Backend) -> Self {
        let footprints = footprint::Footprints::supported(backend);
        Self {
            passes: RegionPasses::new(factory),
            backgrounds: Backgrounds::default(),
            targets: Vec::new(),
            scenery: None,
            footprints: footprints.then(|| footprint::Footprints::new(factory)),
        }
    }

    /// Whether any frame has measured visibility (for tests).
    pub(super) fn has_id_readback(&self) -> bool {
        self.passes.has_id_readback()
    }

    /// Drop every cached background (the sky images changed).
    pub(super) fn forget_backgrounds(&mut self) {
        for t in &mut self.targets {
            t.background.forget();
        }
    }
}

impl Renderer {
    /// Make the targets that frames of `width`×`height` pixels and `msaa`
    /// samples draw into now (or take those the context made ahead,
    /// [`GpuContext::prepare_frame_targets`]), so that the device zeroes
    /// them while the caller goes on (uploading the sky, making the first
    /// scene): see [`made_targets`]. A size the device cannot draw is left
    /// to the frame to report.
    ///
    /// [`GpuContext::prepare_frame_targets`]: super::GpuContext::prepare_frame_targets
    pub fn prepare_targets(&mut self, (width, height): (u32, u32), msaa: u32) {
        if self.check_size(width, height).is_err() {
            return;
        }
        let mut state = match self.regions.take() {
            Some(s) => s,
            None => RegionState::new(&self.factory, self.backend),
        };
        self.frame_targets(&mut state, width, height, msaa.max(1));
        self.regions = Some(state);
    }

    /// Render `scene` region by region: the picture (equal to a full-frame
    /// render of the same meshes within one 8-bit level) and/or each drone's
    /// visibility, measured from the colour pass's own samples.
    pub fn render_frame(
        &mut self,
        scene: &FrameScene,
        request: &RenderRequest,
    ) -> Result<RenderedFrame, RenderError> {
        self.check_size(scene.camera.width, scene.camera.height)?;
        id_layer::check_drones(scene.drones.len())?;
        let mut state = match self.regions.take() {
            Some(s) => s,
            None => RegionState::new(&self.factory, self.backend),
        };
        let result = self.render_regions(&mut state, scene, request);
        self.regions = Some(state);
        result
    }

    /// What the region passes draw with that this renderer owns.
    fn pass_inputs(&mut self) -> PassInputs<'_> {
        PassInputs {
            device: &self.device,
            queue: &self.queue,
            factory: &self.factory,
            frame_group: &self.frame_bind_group,
            drones: &mut self.drones,
        }
    }

    /// The index in `state.targets` of the targets of `width`×`height` and
    /// `msaa` samples, made (and the least recently used dropped) if needed.
    fn frame_targets(&self, state: &mut RegionState, width: u32, height: u32, msaa: u32) -> usize {
        if let Some(i) = state
            .targets
            .iter()
            .position(|t| t.width == width && t.height == height && t.msaa == msaa)
        {
            // Most recently used last.
            let t = state.targets.remove(i);
            state.targets.push(t);
            return state.targets.len() - 1;
        }
        if state.targets.len() >= MAX_TARGETS {
            state.targets.remove(0);
        }
        if let Some(targets) = self.prepared.take((width, height), msaa) {
            state.targets.push(targets);
            return state.targets.len() - 1;
        }
        let layouts = TargetLayouts {
            background: state.passes.background_layout(),
            resolve: state.passes.resolve_layout(),
        };
        let targets = made_targets((&self.device, &self.queue), (width, height), msaa, layouts);
        #[cfg(test)]
        if super::targets::GARBAGE.get() {
            targets.fill_with_garbage(&self.device, &self.queue);
        }
        state.targets.push(targets);
        state.targets.len() - 1
    }

    /// A frame in three steps: its plan (CPU only), the encoded passes,
    /// and what they read back collected into pixels and visibility. The
    /// background, from the cache or drawn anew, comes after the plan,
    /// whose regions tell where the passes read it.
    fn render_regions(
        &mut self,
        state: &mut RegionState,
        scene: &FrameScene,
        request: &RenderRequest,
    ) -> Result<RenderedFrame, RenderError> {
        let (width, height) = (scene.camera.width, scene.camera.height);
        let msaa = request.msaa.max(1);
        let uniforms = self.upload_uniforms(scene);
        let p = (state.passes).pipelines_for(&self.factory, &self.drones, msaa);
        let t = self.frame_targets(state, width, height, msaa);
        let scenery = scenery::prepare(&mut state.scenery, &self.factory, scene, &uniforms, msaa);
        let (boxes, rects) = regions::drone_rects(scene, self.drones.geometry());
        let depths = regions::drone_depths(scene, self.drones.geometry());
        let request = PlanRequest {
            size_px: (width, height),
            msaa,
            color: request.color,
            visibility: request.visibility,
            regions: self.use_regions,
            scenery: scenery.is_some(),
        };
        // Visibility without scenery: the main pass first, its ids then tell
        // which drones need a layer pass ([`ids::shows_front`]).
        let deferred = request.visibility && !request.scenery;
        let plan = if deferred {
            FramePlan::main_pass(request, &boxes, &rects, &depths)?
        } else {
            FramePlan::new(request, &boxes, &rects, &depths)?
        };
        let under = || plan.passes.iter().flat_map(|p| &p.rects);
        if request.color {
            let layer = (state.scenery.as_ref())
                .and_then(|g| g.layer())
                .map(|(_, l)| l);
            let mut with = BackgroundInputs {
                factory: &self.factory,
                queue: &self.queue,
                frame_group: &self.frame_bind_group,
                sky: &mut self.sky,
                plates: &self.plates,
            };
            let cache = &mut state.targets[t].background;
            let frame = (scene, &uniforms);
            (state.backgrounds).update(&mut with, cache, frame, (scenery, layer), under())?;
        }
        if let Some(gpu) = state.scenery.as_mut() {
            gpu.upload_under(&self.queue, under());
        }
        let mut with = self.pass_inputs();
        let target = &mut state.targets[t];
        let uploaded = (state.passes).upload(&mut with, p, target, scene, &plan);
        let (target, scenery) = (&state.targets[t], state.scenery.as_ref());
        let encoder = (state.passes).encode(&with, target, scenery, &plan, &uploaded);
        if plan.request.color {
            self.counts.color += 1;
        }
        if plan.request.visibility {
            self.counts.ids += plan.passes.len() as u64;
        }
        let submitted = self.queue.submit([encoder.finish()]);
        // The rest of a background drawn on the CPU, while the GPU draws.
        state.targets[t].background.finish();
        let may_hide = |j, i| regions::may_hide(&depths, j, i);
        let front: Option<FrontCheck<'_>> = deferred.then_some((&rects[..], &may_hide));
        let (mut frame, mut ids, alone) = self.collect(state, t, &plan, submitted, front)?;
        if let Some(alone) = &alone {
            let layers = Layers {
                pipelines: p,
                targets: t,
                drones: (&boxes, &rects),
                alone,
            };
            let mut with = self.pass_inputs();
            let drawn = layers::measure_alone(&mut with, state, scene, &plan, &layers, &mut ids)?;
            self.counts.ids += drawn;
        }
        let (visibility, pixel_hits) = ids.finish(alone.as_ref().unwrap_or(&plan.overlapping));
        frame.visibility = plan.request.visibility.then_some(visibility);
        frame.pixel_hits = pixel_hits;
        Ok(frame)
    }

    /// A planned frame's pixels and id tallies, once `submitted` is done:
    /// the frame's buffer (its background) with the read colour rects
    /// pasted in, and the read ids counted. With `front` (each drone's rect,
    /// and whether one drone may hide another) also the drones whose
    /// unoccluded counts need a layer pass ([`ids::shows_front`]).
    fn collect(
        &mut self,
        state: &mut RegionState,
        t: usize,
        plan: &FramePlan,
        submitted: wgpu::SubmissionIndex,
        front: Option<FrontCheck<'_>>,
    ) -> Result<Collected, RenderError> {
        let request = &plan.request;
        let width = request.size_px.0;
        let (mut rgba, painted) = if request.color {
            let cache = &mut state.targets[t].background;
            let painted = Painted {
                background: cache.generation,
                rects: plan.passes[0].rects.clone(),
            };
            (self.frame_pixels(cache, width), painted)
        } else {
            (Vec::new(), Painted::default())
        };
        let target = &state.targets[t];
        let hits = request.visibility && self.keep_pixel_hits;
        let mut ids = IdCollect::new(plan.overlapping.len(), request.msaa, hits);
        // Without reads (no drone in view) no drone needs a layer.
        let mut alone = front.map(|_| vec![false; plan.overlapping.len()]);
        match &target.regions_readback {
            Some(buffer) if plan.readback_size > 0 => {
                readback::read_mapped(
                    &self.device,
                    submitted,
                    buffer,
                    plan.readback_size,
                    |bytes| {
                        readback::paste(bytes, &plan.color_reads, &mut rgba, width);
                        ids.add(bytes, &plan.id_reads);
                        if let (Some((rects, may_hide)), Some(reads)) =
                            (front, plan.id_reads.first())
                        {
                            let drones = (rects, &plan.overlapping[..]);
                            alone = Some(ids::shows_front(
                                bytes,
                                reads,
                                request.msaa,
                                drones,
                                may_hide,
                            ));
                        }
                    },
                )?;
            }
            _ => readback::wait(&self.device, submitted)?,
        }
        let frame = RenderedFrame {
            rgba,
            painted,
            visibility: None,
            pixel_hits: None,
        };
        Ok((frame, ids, alone))
    }

    /// Render the instance ids of the drones `include` accepts (all others
    /// are left out, so they occlude nothing), one sample per pixel (the
    /// pixel centre), and read the whole id image back (tests, benchmarks).
    pub fn render_ids(
        &mut self,
        scene: &FrameScene,
        include: &dyn Fn(usize) -> bool,
    ) -> Result<IdImage, RenderError> {
        let (width, height) = (scene.camera.width, scene.camera.height);
        self.check_size(width, height)?;
        let mut state = match self.regions.take() {
            Some(s) => s,
            None => RegionState::new(&self.factory, self.backend),
        };
        let result = self.render_id_image(&mut state, scene, include);
        self.regions = Some(state);
        result
    }

    fn render_id_image(
        &mut self,
        state: &mut RegionState,
        scene: &FrameScene,
        include: &dyn Fn(usize) -> bool,
    ) -> Result<IdImage, RenderError> {
        let (width, height) = (scene.camera.width, scene.camera.height);
        self.upload_uniforms(scene);
        let p = (state.passes).pipelines_for(&self.factory, &self.drones, 1);
        let t = self.frame_targets(state, width, height, 1);
        let pass = PassPlan {
            rects: vec![Rect::full(width, height)],
            drones: (0..scene.drones.len()).filter(|&i| include(i)).collect(),
        };
        let target = &state.targets[t];
        let mut with = self.pass_inputs();
        let mut encoder = (state.passes).encode_ids(&mut with, p, target, scene, &pass);
        self.counts.ids += 1;
        target
            .readback
            .copy_from(&mut encoder, target.ids.texture());
        let submitted = self.queue.submit([encoder.finish()]);
        let bytes = target.readback.read(&self.device, submitted)?;
        Ok(id_layer::id_image(&bytes, width, height))
    }

    /// The drone-free pixels (RGBA8, the whole frame) of the background a
    /// frame's buffer holds (`painted`), while this renderer still caches
    /// it: outside `painted.rects()` they equal the frame's, inside them
    /// they are what the frame shows without its drones. `None` when the
    /// buffer holds no background or it was replaced since.
    pub fn background_pixels(&self, painted: &Painted) -> Option<&[u8]> {
        if painted.background == 0 {
            return None;
        }
        self.regions
            .as_ref()?
            .targets
            .iter()
            .map(|t| &t.background)
            .find(|b| b.generation == painted.background)
            .map(|b| b.pixels())
    }

    /// How many times the background was drawn (cache misses), for tests and benchmarks.
    pub fn background_draws(&self) -> u64 {
        self.regions.as_ref().map_or(0, |s| s.backgrounds.draws)
    }

    /// The frame targets held (width, height, samples), least recently used first.
    #[cfg(test)]
    pub(super) fn target_shapes(&self) -> Vec<(u32, u32, u32)> {
        let targets = self.regions.as_ref().map_or(&[][..], |s| &s.targets[..]);
        targets
            .iter()
            .map(|t| (t.width, t.height, t.msaa))
            .collect()
    }
}
