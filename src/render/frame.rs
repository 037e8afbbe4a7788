//! Frames drawn region by region: the cost of a frame grows with the pixels
//! its drones cover, not with the frame.
//!
//! Per size and sample count, full-size targets are allocated once and never
//! cleared: colour (multisampled with MSAA, else single-sample), the
//! instance ids ([`IdLayer`]), depth and the background.
//! The background (sky or environment) depends only on what the sky shader
//! reads: it is drawn once per distinct (frame uniforms, environment
//! uniforms, sky bind group, size) without MSAA — the sky shades once per
//! pixel at its centre, so an MSAA sky resolves to the very same value —
//! and read back once into a CPU copy.
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
use std::sync::atomic::{AtomicU64, Ordering};

use super::id_layer::{self, IdCollect, IdLayer};
use super::ids;
use super::plan::{FramePlan, PassPlan, PlanRequest};
use super::readback::{self, Readback};
use super::regions::{self, Rect};
use super::visibility::Visibility;
use super::{COLOR_FORMAT, DEPTH_FORMAT, FrameUniforms, IdImage, RenderError, Renderer};
use crate::scene::FrameScene;
use crate::sky::FrameSky;
use passes::{Atlas, RegionPipelines, texture_group, texture_layout};
pub(super) use passes::{atlas_texture, color_target, rect_buffer_layout};

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

/// Generation numbers of drawn backgrounds, unique in the process, so a
/// buffer recycled into another renderer never matches its background.
static BACKGROUNDS: AtomicU64 = AtomicU64::new(1);

/// Full-size targets of one size and sample count, and the cached background.
struct FrameTargets {
    width: u32,
    height: u32,
    msaa: u32,
    msaa_color: Option<wgpu::TextureView>,
    /// The single-sample colour target MSAA 1 draws into.
    single: Option<(wgpu::Texture, wgpu::TextureView)>,
    /// The instance ids the passes draw, resolve and read back.
    ids: IdLayer,
    depth: wgpu::TextureView,
    background: wgpu::Texture,
    background_view: wgpu::TextureView,
    background_group: wgpu::BindGroup,
    resolve_group: Option<wgpu::BindGroup>,
    /// Where the resolves write (MSAA only).
    atlas: Atlas,
    /// What the cached background was drawn from (see [`background_key`]).
    background_key: Option<Vec<u8>>,
    background_rgba: Vec<u8>,
    /// Generation of the cached background (see [`Painted`]).
    background_generation: u64,
    /// Full-frame readback (background, id images).
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
    /// The background sky pipeline per sky mode (see `SKY_MODE` in sky.wgsl).
    sky_background: Vec<(u32, wgpu::RenderPipeline)>,
    pipelines: Vec<RegionPipelines>,
    /// Most recently used last; at most [`MAX_TARGETS`].
    targets: Vec<FrameTargets>,
    /// The frame's rects of every pass, one instance each (see `rect.wgsl`).
    rects: Option<wgpu::Buffer>,
    /// The frame's resolve rects of every pass (see `resolve.wgsl`).
    resolve_rects: Option<wgpu::Buffer>,
    pub(super) background_draws: u64,
    /// Whether any frame has measured visibility (for tests).
    id_readback: bool,
    /// The near-field scenery's layer and pipelines (frames with clutter only).
    scenery: Option<super::scenery::SceneryGpu>,
}

/// Target sets kept at once (e.g. a frame size and its id-pass size).
const MAX_TARGETS: usize = 2;

impl RegionState {
    pub(super) fn new(device: &wgpu::Device) -> Self {
        let [_, _, (_, regions_src), (_, resolve_src), _] = super::shader_sources();
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
            sky_background: Vec::new(),
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
            t.background_key = None;
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
            .find(|t| t.background_generation == painted.background)
            .map(|t| t.background_rgba.as_slice())
    }

    /// How many times the background was drawn (cache misses), for tests and benchmarks.
    pub fn background_draws(&self) -> u64 {
        self.regions.as_ref().map_or(0, |s| s.background_draws)
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
        // COPY_DST: a backplate's pixels are written, not drawn.
        let upload = wgpu::TextureUsages::COPY_DST;
        let background = texture(
            "background",
            COLOR_FORMAT,
            1,
            attachment | bind | copy | upload,
        );
        let background_view = background.create_view(&Default::default());
        let background_group = texture_group(
            device,
            "region background",
            &state.background_layout,
            &background_view,
        );
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
            background_view,
            background_group,
            resolve_group,
            atlas: Atlas::default(),
            background_key: None,
            background_rgba: Vec::new(),
            background_generation: 0,
            readback: Readback::new(device, "frame readback (full)", width, height),
            regions_readback: None,
        });
        state.targets.len() - 1
    }

    /// The bytes the sky shader reads, plus what its bind group and size are.
    fn background_key(
        &self,
        uniforms: &FrameUniforms,
        sky: &FrameSky,
        size: (u32, u32),
    ) -> Vec<u8> {
        let group: u64 = match sky {
            FrameSky::Gradient { .. } => 0,
            FrameSky::Procedural { .. } => 1,
            FrameSky::Image { image, .. } => 2 + *image as u64,
        };
        // The sky shaders never read the atmosphere's slot (a procedural
        // environment's fog is in its own uniforms): a new visibility alone
        // keeps the background.
        let sky_uniforms = FrameUniforms {
            atmosphere: [0.0; 4],
            ..*uniforms
        };
        let mut key = bytemuck::bytes_of(&sky_uniforms).to_vec();
        key.extend_from_slice(self.sky.uniform_bytes());
        key.extend_from_slice(&group.to_le_bytes());
        key.extend_from_slice(&size.0.to_le_bytes());
        key.extend_from_slice(&size.1.to_le_bytes());
        key
    }

    /// Draw the sky into the background texture (no MSAA) and read it back.
    fn draw_background(
        &mut self,
        state: &mut RegionState,
        t: usize,
        scene: &FrameScene,
    ) -> Result<(), RenderError> {
        if let Some(plate) = &scene.backplate {
            return self.draw_plate_background(state, t, plate);
        }
        let mode = self.sky.mode();
        if !state
            .sky_background
            .iter()
            .any(|(m, _)| *m == mode.to_bits())
        {
            let constants = [("SKY_MODE", f64::from(mode))];
            let pipeline = self
                .device
                .create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                    label: Some("background sky pipeline"),
                    layout: Some(&self.sky_layout),
                    vertex: wgpu::VertexState {
                        module: &self.shaders.0,
                        entry_point: Some("vs_main"),
                        compilation_options: Default::default(),
                        buffers: &[],
                    },
                    primitive: wgpu::PrimitiveState::default(),
                    depth_stencil: None,
                    multisample: wgpu::MultisampleState::default(),
                    fragment: Some(wgpu::FragmentState {
                        module: &self.shaders.0,
                        entry_point: Some("fs_main"),
                        compilation_options: wgpu::PipelineCompilationOptions {
                            constants: &constants,
                            ..Default::default()
                        },
                        targets: &[color_target(COLOR_FORMAT)],
                    }),
                    multiview_mask: None,
                    cache: None,
                });
            state.sky_background.push((mode.to_bits(), pipeline));
        }
        let mut encoder = self
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("background"),
            });
        let target = &state.targets[t];
        if super::sky::SkyGpu::is_procedural(&scene.sky) {
            self.sky.encode_environment(
                &self.device,
                &mut encoder,
                (&self.shaders.0, &self.sky_layout),
                &self.frame_bind_group,
                (target.width, target.height),
            );
        }
        if let Some((_, pipeline)) = state
            .sky_background
            .iter()
            .find(|(m, _)| *m == mode.to_bits())
        {
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("background pass"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: &target.background_view,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(wgpu::Color::BLACK),
                        store: wgpu::StoreOp::Store,
                    },
                })],
                depth_stencil_attachment: None,
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            pass.set_pipeline(pipeline);
            pass.set_bind_group(0, &self.frame_bind_group, &[]);
            pass.set_bind_group(1, self.sky.bind_group_for(&scene.sky), &[]);
            pass.draw(0..3, 0..1);
        }
        target.readback.copy_from(&mut encoder, &target.background);
        let submitted = self.queue.submit([encoder.finish()]);
        // Into the previous background's memory: frame buffers copy from it,
        // and the new generation below tells them it changed.
        let mut rgba = std::mem::take(&mut state.targets[t].background_rgba);
        let read = state.targets[t]
            .readback
            .read_into(&self.device, submitted, &mut rgba);
        state.targets[t].background_rgba = rgba;
        read?;
        state.targets[t].background_generation = BACKGROUNDS.fetch_add(1, Ordering::Relaxed);
        state.background_draws += 1;
        Ok(())
    }

    /// A backplate as the background: its pixels written into the texture
    /// and kept as the CPU copy (no sky pass, no readback).
    fn draw_plate_background(
        &mut self,
        state: &mut RegionState,
        t: usize,
        plate: &crate::scene::backplate::FramePlate,
    ) -> Result<(), RenderError> {
        let target = &mut state.targets[t];
        let size = (target.width, target.height);
        let mut rgba = std::mem::take(&mut target.background_rgba);
        let made = self.plate_pixels(plate, size, &mut rgba);
        if made.is_ok() {
            self.upload_background(&target.background, &rgba, size);
        }
        target.background_rgba = rgba;
        // A new generation even on failure: no buffer may match what was overwritten.
        target.background_generation = BACKGROUNDS.fetch_add(1, Ordering::Relaxed);
        made?;
        state.background_draws += 1;
        Ok(())
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
            let mut key = match &scene.backplate {
                Some(plate) => Self::plate_key(plate, (width, height)),
                None => self.background_key(&uniforms, &scene.sky, (width, height)),
            };
            key.extend(scenery.iter().flat_map(|k| k.to_le_bytes()));
            if state.targets[t].background_key.as_ref() != Some(&key) {
                self.draw_background(state, t, scene)?;
                if let Some((_, layer)) = state.scenery.as_ref().and_then(|g| g.layer()) {
                    super::scenery::composite(layer, &mut state.targets[t].background_rgba);
                }
                state.targets[t].background_key = Some(key);
            }
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
                background: target.background_generation,
                rects: plan.passes[0].rects.clone(),
            };
            (
                self.frame_buffer(&target.background_rgba, painted.background, width),
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
