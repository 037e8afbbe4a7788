//! Frames drawn region by region: the cost of a frame grows with the pixels
//! its drones cover, not with the frame.
//!
//! Per size and sample count, full-size targets are allocated once and never
//! cleared: colour (multisampled with MSAA, else single-sample), the
//! instance ids ([`IdLayer`]), depth and the background.
//! The background (sky, environment or backplate, with the scenery) is
//! cached per size by [`super::background::BackgroundCache`]: drawn only
//! when what it depends on changes, and read back once into a CPU copy.
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
//! and reduced to per-drone visibility on the CPU ([`IdCollect`]).

mod passes;

use std::borrow::Cow;

use super::background::{BackgroundCache, SkyPipelines};
use super::id_layer::{self, IdCollect, IdLayer};
use super::ids;
use super::plan::{FramePlan, PassPlan, PlanRequest};
use super::readback::{self, Readback};
use super::regions::{self, Rect};
use super::visibility::Visibility;
use super::{COLOR_FORMAT, DEPTH_FORMAT, IdImage, RenderError, Renderer};
use crate::scene::FrameScene;
use passes::{Atlas, RegionPipelines, texture_layout};
pub(super) use passes::{atlas_texture, clear_pass, color_target, rect_buffer_layout};

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

/// Full-size targets of one size and sample count, and the cached background.
pub(super) struct FrameTargets {
    width: u32,
    height: u32,
    msaa: u32,
    msaa_color: Option<wgpu::TextureView>,
    /// The single-sample colour target MSAA 1 draws into.
    single: Option<(wgpu::Texture, wgpu::TextureView)>,
    /// The instance ids the passes draw, resolve and read back.
    ids: IdLayer,
    depth: wgpu::TextureView,
    /// The cached background of this size.
    pub(super) background: BackgroundCache,
    resolve_group: Option<wgpu::BindGroup>,
    /// Where the resolves write (MSAA only).
    atlas: Atlas,
    /// Full-frame readback (id images).
    readback: Readback,
    /// Readback of the regions (colour and ids), grown as needed and reused.
    regions_readback: Option<wgpu::Buffer>,
}

/// Long-lived state of region rendering, built on first use.
pub(super) struct RegionState {
    background_layout: wgpu::BindGroupLayout,
    resolve_layout: wgpu::BindGroupLayout,
    regions_module: wgpu::ShaderModule,
    resolve_module: wgpu::ShaderModule,
    /// The background sky pipelines ([`super::background`]).
    pub(super) sky_pipelines: SkyPipelines,
    pipelines: Vec<RegionPipelines>,
    /// Most recently used last; at most [`MAX_TARGETS`].
    pub(super) targets: Vec<FrameTargets>,
    /// The frame's rects of every pass, one instance each (see `rect.wgsl`).
    rects: Option<wgpu::Buffer>,
    /// The frame's resolve rects of every pass (see `resolve.wgsl`).
    resolve_rects: Option<wgpu::Buffer>,
    pub(super) background_draws: u64,
    /// Whether any frame has measured visibility (for tests).
    id_readback: bool,
    /// The near-field scenery's layer and pipelines (frames with clutter only).
    pub(super) scenery: Option<super::scenery::SceneryGpu>,
}

/// Target sets kept at once (e.g. a frame size and its id-pass size).
const MAX_TARGETS: usize = 2;

impl RegionState {
    pub(super) fn new(device: &wgpu::Device) -> Self {
        let [_, _, (_, regions_src), (_, resolve_src), ..] = super::shader_sources();
        let module = |label: &str, src: String| {
            device.create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some(label),
                source: wgpu::ShaderSource::Wgsl(Cow::Owned(src)),
            })
        };
        Self {
            background_layout: texture_layout(device, "region background layout", false, 1),
            // The resolve's inputs: the multisampled colour and id targets.
            resolve_layout: texture_layout(device, "region resolve layout", true, 2),
            regions_module: module("regions.wgsl", regions_src),
            resolve_module: module("resolve.wgsl", resolve_src),
            sky_pipelines: SkyPipelines::default(),
            pipelines: Vec::new(),
            targets: Vec::new(),
            rects: None,
            resolve_rects: None,
            background_draws: 0,
            id_readback: false,
            scenery: None,
        }
    }

    pub(super) fn has_id_readback(&self) -> bool {
        self.id_readback
    }

    /// Drop every cached background (the sky images changed).
    pub(super) fn forget_backgrounds(&mut self) {
        for t in &mut self.targets {
            t.background.forget();
        }
    }
}

impl Renderer {
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
            None => RegionState::new(&self.device),
        };
        let result = self.render_regions(&mut state, scene, request);
        self.regions = Some(state);
        result
    }

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
        let device = &self.device;
        let size = wgpu::Extent3d {
            width,
            height,
            depth_or_array_layers: 1,
        };
        let texture = |label: &str, format, samples, usage| {
            device.create_texture(&wgpu::TextureDescriptor {
                label: Some(label),
                size,
                mip_level_count: 1,
                sample_count: samples,
                dimension: wgpu::TextureDimension::D2,
                format,
                usage,
                view_formats: &[],
            })
        };
        let attachment = wgpu::TextureUsages::RENDER_ATTACHMENT;
        let copy = wgpu::TextureUsages::COPY_SRC;
        let bind = wgpu::TextureUsages::TEXTURE_BINDING;
        let single = (msaa <= 1).then(|| {
            let color = texture("region colour", COLOR_FORMAT, 1, attachment | copy);
            let view = color.create_view(&Default::default());
            (color, view)
        });
        let msaa_color = (msaa > 1).then(|| {
            texture(
                "region colour (msaa)",
                COLOR_FORMAT,
                msaa,
                attachment | bind,
            )
            .create_view(&Default::default())
        });
        let ids = IdLayer::new(device, (width, height), msaa);
        let depth = texture("region depth", DEPTH_FORMAT, msaa, attachment)
            .create_view(&Default::default());
        let background = BackgroundCache::new(device, &state.background_layout, width, height);
        let resolve_group = msaa_color.as_ref().map(|color| {
            device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("region resolve"),
                layout: &state.resolve_layout,
                entries: &[
                    wgpu::BindGroupEntry {
                        binding: 0,
                        resource: wgpu::BindingResource::TextureView(color),
                    },
                    wgpu::BindGroupEntry {
                        binding: 1,
                        resource: wgpu::BindingResource::TextureView(ids.view()),
                    },
                ],
            })
        });
        state.targets.push(FrameTargets {
            width,
            height,
            msaa,
            msaa_color,
            single,
            ids,
            depth,
            background,
            resolve_group,
            atlas: Atlas::default(),
            readback: Readback::new(device, "frame readback (full)", width, height),
            regions_readback: None,
        });
        state.targets.len() - 1
    }

    /// A frame in three steps: its plan (CPU only), the encoded passes,
    /// and what they read back collected into pixels and visibility. The
    /// background comes first, from the cache or drawn anew.
    fn render_regions(
        &mut self,
        state: &mut RegionState,
        scene: &FrameScene,
        request: &RenderRequest,
    ) -> Result<RenderedFrame, RenderError> {
        let (width, height) = (scene.camera.width, scene.camera.height);
        let msaa = request.msaa.max(1);
        let uniforms = self.upload_uniforms(scene);
        let p = self.region_pipelines(state, msaa);
        let t = self.frame_targets(state, width, height, msaa);
        let scenery = self.prepare_scenery(&mut state.scenery, scene, &uniforms, msaa);
        if request.color {
            self.update_background(state, t, scene, &uniforms, scenery)?;
        }
        let (boxes, rects) = regions::drone_rects(scene, &self.geometry);
        let request = PlanRequest {
            size_px: (width, height),
            msaa,
            color: request.color,
            visibility: request.visibility,
            regions: self.use_regions,
            scenery: scenery.is_some(),
        };
        let plan = FramePlan::new(request, &boxes, &rects)?;
        let under = || plan.passes.iter().flat_map(|p| &p.rects);
        if plan.request.color {
            self.upload_background_under(&mut state.targets[t].background, under());
        }
        if let Some(gpu) = state.scenery.as_mut() {
            self.upload_scenery_under(gpu, under());
        }
        let (draws, first_resolve) = self.upload_plan(state, (p, t), scene, &plan);
        let encoder = self.encode_frame(state, (p, t), &plan, (&draws, &first_resolve));
        let submitted = self.queue.submit([encoder.finish()]);
        self.collect(state, t, &plan, submitted)
    }

    /// A planned frame's pixels and visibility, once `submitted` is done: the
    /// frame's buffer (its background) with the read colour rects pasted in,
    /// and the read ids reduced to each drone's visibility.
    fn collect(
        &mut self,
        state: &RegionState,
        t: usize,
        plan: &FramePlan,
        submitted: wgpu::SubmissionIndex,
    ) -> Result<RenderedFrame, RenderError> {
        let request = &plan.request;
        let width = request.size_px.0;
        let target = &state.targets[t];
        let (mut rgba, painted) = if request.color {
            let painted = Painted {
                background: target.background.generation,
                rects: plan.passes[0].rects.clone(),
            };
            (
                self.frame_buffer(&target.background.rgba, painted.background, width),
                painted,
            )
        } else {
            (Vec::new(), Painted::default())
        };
        let hits = request.visibility && self.keep_pixel_hits;
        let mut ids = IdCollect::new(plan.overlapping.len(), request.msaa, hits);
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
                    },
                )?;
            }
            _ => readback::wait(&self.device, submitted)?,
        }
        let (visibility, pixel_hits) = ids.finish(&plan.overlapping);
        Ok(RenderedFrame {
            rgba,
            painted,
            visibility: request.visibility.then_some(visibility),
            pixel_hits,
        })
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
            None => RegionState::new(&self.device),
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
        let p = self.region_pipelines(state, 1);
        let t = self.frame_targets(state, width, height, 1);
        let pass = PassPlan {
            rects: vec![Rect::full(width, height)],
            drones: (0..scene.drones.len()).filter(|&i| include(i)).collect(),
        };
        let mut data = Vec::new();
        let mut draws = [self.region_draws(scene, &pass, &mut data)];
        self.write_instances(&data);
        self.upload_rects(state, &mut draws, (width, height));
        self.counts.ids += 1;
        let mut encoder = self
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("instance ids"),
            });
        let target = &state.targets[t];
        self.encode_region_pass(
            &mut encoder,
            (&state.pipelines[p], target, state.rects.as_ref()),
            &draws[0],
            ("id pass", false),
        );
        target
            .readback
            .copy_from(&mut encoder, target.ids.texture());
        let submitted = self.queue.submit([encoder.finish()]);
        let bytes = target.readback.read(&self.device, submitted)?;
        Ok(id_layer::id_image(&bytes, width, height))
    }
}
