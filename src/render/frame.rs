//! Frames drawn region by region: the cost of a frame grows with the pixels
//! its drones cover, not with the frame.
//!
//! Per size and sample count, full-size targets are allocated once and never
//! cleared: colour (multisampled with MSAA, else single-sample), the
//! instance ids ([`super::ids`]), depth and the background.
//! The background (sky, environment or backplate, with the scenery) is
//! cached per size by [`super::background::BackgroundCache`]: drawn only
//! when what it depends on changes, and read back once into a CPU copy.
//!
//! A frame then only touches its regions ([`super::regions`]): merged,
//! padded boxes of the drones' projected hulls. In each region (a scissor
//! rect) the background is drawn at far depth with id 0 (the region's
//! "clear"), then the drones, with the same full-frame projection as a
//! full render, so rasterisation is bit-identical to one; with MSAA the
//! regions are resolved by a shader (the mean of the samples, and the id
//! samples side by side) into a compact atlas ([`Atlas`]); they are read back
//! into one reused buffer, pasted into the frame's buffer (which already
//! holds the background: [`Painted`]) and reduced to per-drone visibility on
//! the CPU ([`ids::tally`]).

use std::borrow::Cow;

use super::background::{BackgroundCache, SkyPipelines};
use super::ids::{self, IdStats, Tally};
use super::regions::{self, PassDraws, Rect};
use super::visibility::{Visibility, overlap_layers};
use super::{
    COLOR_FORMAT, DEPTH_FORMAT, IdImage, InstanceRaw, Readback, RenderError, Renderer, read_mapped,
};
use crate::scene::FrameScene;
use crate::scene::projection::PixelBox;

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

/// Pipelines of the region passes for one sample count.
struct RegionPipelines {
    msaa: u32,
    background: wgpu::RenderPipeline,
    drone: super::DronePipelines,
    /// The same two for passes that write instance ids only (overlap layers,
    /// id images): no colour attachment, no lighting.
    ids_background: wgpu::RenderPipeline,
    ids_drone: super::DronePipelines,
    /// The colour resolve (MSAA only).
    resolve: Option<wgpu::RenderPipeline>,
    /// The id resolves (MSAA only), built on first use: presets that need no
    /// visibility never build them.
    id_resolve: Option<IdResolve>,
}

/// Resolves that write a pixel's id samples side by side (`resolve.wgsl`).
struct IdResolve {
    /// Ids only (overlap layers, frames without colour).
    ids: wgpu::RenderPipeline,
    /// Colour and ids in one pass (the main pass of a frame with both).
    color_ids: wgpu::RenderPipeline,
}

/// Full-size targets of one size and sample count, and the cached background.
pub(super) struct FrameTargets {
    width: u32,
    height: u32,
    msaa: u32,
    msaa_color: Option<wgpu::TextureView>,
    /// The single-sample colour target MSAA 1 draws into.
    single: Option<(wgpu::Texture, wgpu::TextureView)>,
    ids: wgpu::Texture,
    ids_view: wgpu::TextureView,
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

/// The compact target the resolves write (MSAA only): a pass's rects packed
/// in shelves ([`regions::pack_shelves`]) as wide as the frame and as tall as
/// they need, the resolved colour and/or the id samples side by side, copied
/// from here into the readback buffer. Passes reuse it one after the other;
/// it grows as needed and never shrinks.
#[derive(Default)]
struct Atlas {
    rows: u32,
    color: Option<(wgpu::Texture, wgpu::TextureView)>,
    ids: Option<(wgpu::Texture, wgpu::TextureView)>,
}

impl Atlas {
    /// At least `rows` rows (of `width` pixels) of the parts asked for.
    fn ensure(&mut self, device: &wgpu::Device, width: u32, rows: u32, color: bool, ids: bool) {
        if rows == 0 && self.rows == 0 {
            return; // nothing to resolve yet (a frame without drones)
        }
        if rows > self.rows {
            self.rows = rows.next_multiple_of(64);
            // Reallocated at the new size below, as far as still wanted.
            let had = (self.color.take().is_some(), self.ids.take().is_some());
            return self.ensure(device, width, 0, color || had.0, ids || had.1);
        }
        let texture = |label: &str, format| {
            let texture = device.create_texture(&wgpu::TextureDescriptor {
                label: Some(label),
                size: wgpu::Extent3d {
                    width,
                    height: self.rows,
                    depth_or_array_layers: 1,
                },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format,
                usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
                view_formats: &[],
            });
            let view = texture.create_view(&Default::default());
            (texture, view)
        };
        if color && self.color.is_none() {
            self.color = Some(texture("resolve atlas (colour)", COLOR_FORMAT));
        }
        if ids && self.ids.is_none() {
            self.ids = Some(texture(
                "resolve atlas (id samples)",
                ids::ID_SAMPLES_FORMAT,
            ));
        }
    }
}

/// Per-instance layout of a resolve rect: its place in the atlas (x0, y0,
/// x1, y1 in the atlas's normalised device coordinates), then the whole-pixel
/// offset (dx, dy) from there to the rect in the frame.
const RESOLVE_ATTRS: [wgpu::VertexAttribute; 2] =
    wgpu::vertex_attr_array![0 => Float32x4, 1 => Float32x2];

fn resolve_buffer_layout() -> wgpu::VertexBufferLayout<'static> {
    wgpu::VertexBufferLayout {
        array_stride: 24,
        step_mode: wgpu::VertexStepMode::Instance,
        attributes: &RESOLVE_ATTRS,
    }
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

/// Per-instance layout of a rect: (x0, y0, x1, y1) in normalised device coordinates.
const RECT_ATTRS: [wgpu::VertexAttribute; 1] = wgpu::vertex_attr_array![0 => Float32x4];

pub(super) fn rect_buffer_layout() -> wgpu::VertexBufferLayout<'static> {
    wgpu::VertexBufferLayout {
        array_stride: 16,
        step_mode: wgpu::VertexStepMode::Instance,
        attributes: &RECT_ATTRS,
    }
}

/// A pixel rect in normalised device coordinates (y up), for `rect.wgsl`.
fn rect_ndc(r: &Rect, width: u32, height: u32) -> [f32; 4] {
    let x = |v: u32| (f64::from(v) / f64::from(width) * 2.0 - 1.0) as f32;
    let y = |v: u32| (1.0 - f64::from(v) / f64::from(height) * 2.0) as f32;
    [x(r.x0), y(r.y0), x(r.x1), y(r.y1)]
}

/// A colour target of `format`, written whole, without blending.
pub(super) fn color_target(format: wgpu::TextureFormat) -> Option<wgpu::ColorTargetState> {
    Some(wgpu::ColorTargetState {
        format,
        blend: None,
        write_mask: wgpu::ColorWrites::ALL,
    })
}

/// Target sets kept at once (e.g. a frame size and its id-pass size).
const MAX_TARGETS: usize = 2;

/// A layout of `bindings` unfilterable float textures (bindings 0, 1, …)
/// read by fragment shaders.
fn texture_layout(
    device: &wgpu::Device,
    label: &str,
    multisampled: bool,
    bindings: u32,
) -> wgpu::BindGroupLayout {
    let entries: Vec<wgpu::BindGroupLayoutEntry> = (0..bindings)
        .map(|binding| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::FRAGMENT,
            ty: wgpu::BindingType::Texture {
                sample_type: wgpu::TextureSampleType::Float { filterable: false },
                view_dimension: wgpu::TextureViewDimension::D2,
                multisampled,
            },
            count: None,
        })
        .collect();
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some(label),
        entries: &entries,
    })
}

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

/// Round `n` up to the copy row alignment.
fn padded_row(bytes: u32) -> u32 {
    bytes.div_ceil(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT) * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT
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
        if scene.drones.len() >= ids::MAX_DRONES {
            return Err(RenderError::TooManyDrones {
                count: scene.drones.len(),
                limit: ids::MAX_DRONES - 1,
            });
        }
        let mut state = match self.regions.take() {
            Some(s) => s,
            None => RegionState::new(&self.device),
        };
        let result = self.render_regions(&mut state, scene, request);
        self.regions = Some(state);
        result
    }

    fn region_pipelines(&self, state: &mut RegionState, msaa: u32) -> usize {
        if let Some(i) = state.pipelines.iter().position(|p| p.msaa == msaa) {
            return i;
        }
        let device = &self.device;
        let multisample = wgpu::MultisampleState {
            count: msaa,
            ..Default::default()
        };
        let targets = [color_target(COLOR_FORMAT), color_target(ids::ID_FORMAT)];
        let depth = |compare| wgpu::DepthStencilState {
            format: DEPTH_FORMAT,
            depth_write_enabled: Some(true),
            depth_compare: Some(compare),
            stencil: Default::default(),
            bias: Default::default(),
        };
        let background_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("region background pipeline layout"),
            bind_group_layouts: &[Some(&state.background_layout)],
            immediate_size: 0,
        });
        let background_pipeline = |label: &str, entry: &str, targets: &[_]| {
            device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some(label),
                layout: Some(&background_layout),
                vertex: wgpu::VertexState {
                    module: &state.regions_module,
                    entry_point: Some("vs_main"),
                    compilation_options: Default::default(),
                    buffers: &[Some(rect_buffer_layout())],
                },
                primitive: wgpu::PrimitiveState::default(),
                depth_stencil: Some(depth(wgpu::CompareFunction::Always)),
                multisample,
                fragment: Some(wgpu::FragmentState {
                    module: &state.regions_module,
                    entry_point: Some(entry),
                    compilation_options: Default::default(),
                    targets,
                }),
                multiview_mask: None,
                cache: None,
            })
        };
        let background = background_pipeline("region background pipeline", "fs_main", &targets);
        let drone = self.drone_pipeline("drone + id pipeline", msaa, "fs_ids", &targets);
        let id_targets = [None, targets[1].clone()];
        let ids_background =
            background_pipeline("region id background pipeline", "fs_clear_ids", &id_targets);
        let ids_drone = self.drone_pipeline("drone id pipeline", msaa, "fs_layer", &id_targets);
        let resolve = (msaa > 1).then(|| {
            self.resolve_pipeline(state, "region resolve pipeline", "fs_main", &targets[..1])
        });
        state.pipelines.push(RegionPipelines {
            msaa,
            background,
            drone,
            ids_background,
            ids_drone,
            resolve,
            id_resolve: None,
        });
        state.pipelines.len() - 1
    }

    fn resolve_pipeline(
        &self,
        state: &RegionState,
        label: &str,
        entry: &str,
        targets: &[Option<wgpu::ColorTargetState>],
    ) -> wgpu::RenderPipeline {
        let device = &self.device;
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("region resolve pipeline layout"),
            bind_group_layouts: &[Some(&state.resolve_layout)],
            immediate_size: 0,
        });
        device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some(label),
            layout: Some(&layout),
            vertex: wgpu::VertexState {
                module: &state.resolve_module,
                entry_point: Some("vs_main"),
                compilation_options: Default::default(),
                buffers: &[Some(resolve_buffer_layout())],
            },
            primitive: wgpu::PrimitiveState::default(),
            depth_stencil: None,
            multisample: wgpu::MultisampleState::default(),
            fragment: Some(wgpu::FragmentState {
                module: &state.resolve_module,
                entry_point: Some(entry),
                compilation_options: Default::default(),
                targets,
            }),
            multiview_mask: None,
            cache: None,
        })
    }

    /// Set up what reading ids back needs: with MSAA, the id resolves.
    fn prepare_id_readback(&self, state: &mut RegionState, p: usize) {
        state.id_readback = true;
        if state.pipelines[p].msaa <= 1 {
            return;
        }
        if state.pipelines[p].id_resolve.is_none() {
            let color = color_target(COLOR_FORMAT);
            let id_samples = color_target(ids::ID_SAMPLES_FORMAT);
            let id_resolve = IdResolve {
                ids: self.resolve_pipeline(
                    state,
                    "region id resolve pipeline",
                    "fs_ids",
                    &[None, id_samples.clone()],
                ),
                color_ids: self.resolve_pipeline(
                    state,
                    "region colour + id resolve pipeline",
                    "fs_main_ids",
                    &[color, id_samples],
                ),
            };
            state.pipelines[p].id_resolve = Some(id_resolve);
        }
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
        let ids = texture(
            "instance ids",
            ids::ID_FORMAT,
            msaa,
            attachment | bind | copy,
        );
        let ids_view = ids.create_view(&Default::default());
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
                        resource: wgpu::BindingResource::TextureView(&ids_view),
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
            ids_view,
            depth,
            background,
            resolve_group,
            atlas: Atlas::default(),
            readback: Readback::new(device, "frame readback (full)", width, height),
            regions_readback: None,
        });
        state.targets.len() - 1
    }

    /// Write the rects of `passes` into the (reused, grown as needed) rect
    /// buffer, one after the other, and note where each pass's begin.
    fn upload_rects(
        &self,
        state: &mut RegionState,
        passes: &mut [&mut PassDraws],
        (width, height): (u32, u32),
    ) {
        let mut data: Vec<[f32; 4]> = Vec::new();
        for pass in passes.iter_mut() {
            pass.first_rect = data.len() as u32;
            data.extend(pass.rects.iter().map(|r| rect_ndc(r, width, height)));
        }
        super::write_vertices(
            (&self.device, &self.queue),
            &mut state.rects,
            "region rects",
            bytemuck::cast_slice(&data),
        );
    }

    /// Write each pass's resolve rects (its rects' `places` in an atlas of
    /// `atlas` = (width, rows) pixels, and the offsets back to the frame) into
    /// the (reused, grown as needed) resolve rect buffer; returns where each
    /// pass's begin.
    fn upload_resolve_rects(
        &self,
        state: &mut RegionState,
        passes: &[&PassDraws],
        places: &[Vec<(u32, u32)>],
        (width, rows): (u32, u32),
    ) -> Vec<u32> {
        let mut data: Vec<[f32; 6]> = Vec::new();
        let mut first = Vec::with_capacity(passes.len());
        for (pass, places) in passes.iter().zip(places) {
            first.push(data.len() as u32);
            for (r, &(x, y)) in pass.rects.iter().zip(places) {
                let place = Rect {
                    x0: x,
                    y0: y,
                    x1: x + r.width(),
                    y1: y + r.height(),
                };
                let [x0, y0, x1, y1] = rect_ndc(&place, width, rows);
                // Whole pixels, exact in f32 below 2^24.
                let dx = f64::from(r.x0) - f64::from(x);
                let dy = f64::from(r.y0) - f64::from(y);
                data.push([x0, y0, x1, y1, dx as f32, dy as f32]);
            }
        }
        super::write_vertices(
            (&self.device, &self.queue),
            &mut state.resolve_rects,
            "resolve rects",
            bytemuck::cast_slice(&data),
        );
        first
    }

    /// A pass over the disjoint `rects` drawing `drones`: their instances
    /// (drone index + 1 as id) appended to `data`, grouped by (model, level
    /// of detail).
    fn region_draws(
        &self,
        scene: &FrameScene,
        (rects, drones): (Vec<Rect>, Vec<usize>),
        data: &mut Vec<InstanceRaw>,
    ) -> PassDraws {
        let mut order: Vec<(super::MeshLevel, usize)> = drones
            .iter()
            .map(|&i| ((scene.drones[i].model, self.level_of(scene, i)), i))
            .collect();
        order.sort_unstable();
        let mut draws: Vec<(super::MeshLevel, std::ops::Range<u32>)> = Vec::new();
        for (key, i) in order {
            let idx = data.len() as u32;
            data.push(InstanceRaw::new(scene, i));
            match draws.last_mut() {
                Some((k, r)) if *k == key => r.end = idx + 1,
                _ => draws.push((key, idx..idx + 1)),
            }
        }
        PassDraws {
            rects,
            first_rect: 0,
            draws,
        }
    }

    /// One render pass over a pass's regions: each region's background (its
    /// "clear"), then the drones of all regions. Without `color` the pass
    /// writes instance ids (and depth) only: no colour target, no lighting.
    fn encode_region_pass(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        (pipes, target, rects): (&RegionPipelines, &FrameTargets, Option<&wgpu::Buffer>),
        draws: &PassDraws,
        (label, color): (&str, bool),
    ) {
        let load = wgpu::Operations {
            load: wgpu::LoadOp::Load,
            store: wgpu::StoreOp::Store,
        };
        let attachment = |view| {
            Some(wgpu::RenderPassColorAttachment {
                view,
                depth_slice: None,
                resolve_target: None,
                ops: load,
            })
        };
        let depth_ops = wgpu::Operations {
            load: wgpu::LoadOp::Load,
            store: wgpu::StoreOp::Store,
        };
        let Some(color_view) = target
            .msaa_color
            .as_ref()
            .or(target.single.as_ref().map(|(_, view)| view))
        else {
            return;
        };
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some(label),
            color_attachments: &[
                if color { attachment(color_view) } else { None },
                attachment(&target.ids_view),
            ],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: &target.depth,
                depth_ops: Some(depth_ops),
                stencil_ops: None,
            }),
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        let Some(rect_buffer) = rects else {
            return;
        };
        let (background, drone) = if color {
            (&pipes.background, &pipes.drone)
        } else {
            (&pipes.ids_background, &pipes.ids_drone)
        };
        pass.set_pipeline(background);
        pass.set_bind_group(0, &target.background.group, &[]);
        pass.set_vertex_buffer(0, rect_buffer.slice(..));
        pass.draw(0..6, draws.rect_instances());
        let (Some(instances), Some(bounds)) = (&self.instances, draws.bounds()) else {
            return;
        };
        if draws.draws.is_empty() {
            return;
        }
        // The scissor only bounds the work: each drone stays inside its region.
        pass.set_scissor_rect(bounds.x0, bounds.y0, bounds.width(), bounds.height());
        pass.set_bind_group(0, &self.frame_bind_group, &[]);
        pass.set_vertex_buffer(1, instances.slice(..));
        self.draw_drones(&mut pass, drone, &draws.draws);
    }

    fn render_regions(
        &mut self,
        state: &mut RegionState,
        scene: &FrameScene,
        request: &RenderRequest,
    ) -> Result<RenderedFrame, RenderError> {
        let (width, height) = (scene.camera.width, scene.camera.height);
        let msaa = request.msaa.max(1);
        let n = scene.drones.len();
        let uniforms = self.upload_uniforms(scene);
        let p = self.region_pipelines(state, msaa);
        let t = self.frame_targets(state, width, height, msaa);
        let scenery = self.prepare_scenery(&mut state.scenery, scene, &uniforms, msaa);
        if request.color {
            self.update_background(state, t, scene, &uniforms, scenery)?;
        }
        let (boxes, rects) = regions::drone_rects(scene, &self.geometry);
        // A pass's pixels (disjoint rects) and its drones.
        let pass_of = |members: Vec<usize>| -> (Vec<Rect>, Vec<usize>) {
            if self.use_regions {
                regions::cover(&rects, members)
            } else {
                let drones = members
                    .into_iter()
                    .filter(|&i| rects[i].is_some())
                    .collect();
                (vec![Rect::full(width, height)], drones)
            }
        };
        let main = pass_of((0..n).collect());
        // Unoccluded counts: layers of drones whose boxes are apart, each drawn alone.
        let (layers, overlapping) = if request.visibility {
            let clipped: Vec<Option<PixelBox>> = boxes
                .iter()
                .map(|b| {
                    b.map(|b| b.clip(f64::from(width), f64::from(height)))
                        .filter(|b| b.width() > 0.0 && b.height() > 0.0)
                })
                .collect();
            let (layers, mut overlapping) = overlap_layers(&clipped)?;
            // Scenery hides drones in the main pass only: every drone's
            // unoccluded count then comes from a layer pass.
            if scenery.is_some() {
                overlapping = clipped.iter().map(Option::is_some).collect();
            }
            let layers: Vec<(Vec<Rect>, Vec<usize>)> = layers
                .into_iter()
                .map(|l| {
                    l.into_iter()
                        .filter(|&i| overlapping[i])
                        .collect::<Vec<_>>()
                })
                .filter(|l| !l.is_empty())
                .map(pass_of)
                .collect();
            (layers, overlapping)
        } else {
            (Vec::new(), vec![false; n])
        };
        let mut data = Vec::new();
        let mut main_draws = self.region_draws(scene, main, &mut data);
        let mut layer_draws: Vec<PassDraws> = layers
            .into_iter()
            .map(|l| self.region_draws(scene, l, &mut data))
            .collect();
        self.write_instances(&data);
        let mut passes: Vec<&mut PassDraws> = vec![&mut main_draws];
        passes.extend(layer_draws.iter_mut());
        self.upload_rects(state, &mut passes, (width, height));
        if request.color {
            self.counts.color += 1;
        }
        if request.visibility {
            self.counts.ids += 1 + layer_draws.len() as u64;
            self.prepare_id_readback(state, p);
        }
        // With MSAA each pass is resolved into the atlas and read from there;
        // without, the passes draw straight into the targets read back.
        let resolved = msaa > 1;
        let all_passes: Vec<&PassDraws> =
            std::iter::once(&main_draws).chain(&layer_draws).collect();
        let packed: Vec<(Vec<(u32, u32)>, u32)> = all_passes
            .iter()
            .map(|pass| {
                let in_place = || (pass.rects.iter().map(|r| (r.x0, r.y0)).collect(), height);
                match resolved.then(|| regions::pack_shelves(&pass.rects, width)) {
                    // Never taller than the frame: rects that pack worse stay where they are.
                    Some((places, rows)) if rows <= height => (places, rows),
                    Some(_) => in_place(),
                    None => (in_place().0, 0),
                }
            })
            .collect();
        let rows = packed.iter().map(|(_, rows)| *rows).max().unwrap_or(0);
        let places: Vec<Vec<(u32, u32)>> = packed.into_iter().map(|(places, _)| places).collect();
        let first_resolve = if resolved {
            state.targets[t].atlas.ensure(
                &self.device,
                width,
                rows,
                request.color,
                request.visibility,
            );
            let rows = state.targets[t].atlas.rows;
            self.upload_resolve_rects(state, &all_passes, &places, (width, rows))
        } else {
            Vec::new()
        };
        // Where each read-back rect lands in the one readback buffer: the
        // main pass's colour, then the ids of the main pass and of each layer.
        let mut size = 0u64;
        let color_reads = if request.color {
            plan_reads(&main_draws.rects, &places[0], 4, &mut size)
        } else {
            Vec::new()
        };
        let id_reads: Vec<Vec<Read>> = if request.visibility {
            let bpp = ids::id_bytes_per_pixel(msaa);
            all_passes
                .iter()
                .zip(&places)
                .map(|(pass, places)| plan_reads(&pass.rects, places, bpp, &mut size))
                .collect()
        } else {
            Vec::new()
        };
        let target = &mut state.targets[t];
        if size > 0
            && target
                .regions_readback
                .as_ref()
                .is_none_or(|b| b.size() < size)
        {
            target.regions_readback = Some(self.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("region readback"),
                size: size.next_power_of_two(),
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }));
        }
        let mut encoder = self
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("frame (regions)"),
            });
        {
            let pipes = &state.pipelines[p];
            let target = &state.targets[t];
            let rects = state.rects.as_ref();
            let resolve_rects = state.resolve_rects.as_ref();
            let readback = target.regions_readback.as_ref();
            let (color_source, id_source) = if resolved {
                (
                    target.atlas.color.as_ref().map(|(t, _)| t),
                    target.atlas.ids.as_ref().map(|(t, _)| t),
                )
            } else {
                (target.single.as_ref().map(|(t, _)| t), Some(&target.ids))
            };
            let resolve = |encoder: &mut wgpu::CommandEncoder, k: usize, asked: (bool, bool)| {
                if let (Some(buffer), Some(&first)) = (resolve_rects, first_resolve.get(k)) {
                    let count = all_passes[k].rects.len() as u32;
                    encode_resolve(
                        encoder,
                        (pipes, target, buffer),
                        first..first + count,
                        asked,
                    );
                }
            };
            let read =
                |encoder: &mut wgpu::CommandEncoder, source: Option<&wgpu::Texture>, reads| {
                    if let (Some(buffer), Some(source)) = (readback, source) {
                        encode_reads(encoder, source, buffer, reads);
                    }
                };
            self.encode_region_pass(
                &mut encoder,
                (pipes, target, rects),
                &main_draws,
                ("region pass", request.color),
            );
            if let (Some(gpu), Some(rects), true) = (&state.scenery, rects, scenery.is_some()) {
                let color_view = (target.msaa_color.as_ref())
                    .or(target.single.as_ref().map(|(_, view)| view))
                    .filter(|_| request.color);
                let views = (color_view, &target.ids_view, &target.depth);
                self.encode_scenery(gpu, &mut encoder, views, (rects, &main_draws, msaa));
            }
            resolve(&mut encoder, 0, (request.color, request.visibility));
            read(&mut encoder, color_source, &color_reads);
            if let Some(reads) = id_reads.first() {
                read(&mut encoder, id_source, reads);
            }
            for (k, (layer, reads)) in layer_draws.iter().zip(id_reads.iter().skip(1)).enumerate() {
                self.encode_region_pass(
                    &mut encoder,
                    (pipes, target, rects),
                    layer,
                    ("layer pass", false),
                );
                resolve(&mut encoder, k + 1, (false, true));
                read(&mut encoder, id_source, reads);
            }
        }
        let submitted = self.queue.submit([encoder.finish()]);
        let target = &state.targets[t];
        let (mut rgba, painted) = if request.color {
            let painted = Painted {
                background: target.background.generation,
                rects: main_draws.rects.clone(),
            };
            (
                self.frame_buffer(&target.background.rgba, painted.background, width),
                painted,
            )
        } else {
            (Vec::new(), Painted::default())
        };
        // Per drone: what the frame shows of it, and what it shows alone
        // (drones that overlap no other are alone in the main pass).
        let mut seen = vec![Tally::default(); n];
        let mut alone = vec![Tally::default(); n];
        let mut hits = (request.visibility && self.keep_pixel_hits).then(Vec::new);
        match &target.regions_readback {
            Some(buffer) if size > 0 => {
                read_mapped(&self.device, submitted, buffer, size, |bytes| {
                    let stride = width as usize * 4;
                    for read in &color_reads {
                        let w = read.rect.width() as usize * 4;
                        for y in 0..read.rect.height() as usize {
                            let src = read.offset as usize + y * read.row as usize;
                            let dst =
                                (read.rect.y0 as usize + y) * stride + read.rect.x0 as usize * 4;
                            rgba[dst..dst + w].copy_from_slice(&bytes[src..src + w]);
                        }
                    }
                    for (k, reads) in id_reads.iter().enumerate() {
                        let tallies = if k == 0 { &mut seen } else { &mut alone };
                        for read in reads {
                            if let (0, Some(hits)) = (k, hits.as_mut()) {
                                let bytes = &bytes[read.offset as usize..];
                                ids::collect_hits(
                                    bytes,
                                    read.row as usize,
                                    &read.rect,
                                    msaa,
                                    n,
                                    hits,
                                );
                            }
                            ids::tally(
                                &bytes[read.offset as usize..],
                                read.row as usize,
                                &read.rect,
                                msaa,
                                tallies,
                            );
                        }
                    }
                })?;
            }
            _ => {
                // Nothing to read; still wait for the submission (the queue stays in step).
                self.device
                    .poll(wgpu::PollType::Wait {
                        submission_index: Some(submitted),
                        timeout: None,
                    })
                    .map_err(|e| RenderError::Readback(e.to_string()))?;
            }
        }
        let visibility = request.visibility.then(|| {
            (0..n)
                .map(|i| {
                    let seen = seen[i].stats();
                    visibility_of(
                        seen,
                        if overlapping[i] {
                            alone[i].stats()
                        } else {
                            seen
                        },
                    )
                })
                .collect()
        });
        Ok(RenderedFrame {
            rgba,
            painted,
            visibility,
            pixel_hits: hits,
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
        let drones = (0..scene.drones.len()).filter(|&i| include(i)).collect();
        let mut data = Vec::new();
        let mut draws =
            self.region_draws(scene, (vec![Rect::full(width, height)], drones), &mut data);
        self.write_instances(&data);
        self.upload_rects(state, &mut [&mut draws], (width, height));
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
            &draws,
            ("id pass", false),
        );
        target.readback.copy_from(&mut encoder, &target.ids);
        let submitted = self.queue.submit([encoder.finish()]);
        let bytes = target.readback.read(&self.device, submitted)?;
        let values: Vec<f32> = bytemuck::pod_collect_to_vec(&bytes);
        Ok(IdImage {
            width,
            height,
            ids: values.into_iter().map(|v| v as u32).collect(),
        })
    }
}

/// One rect read back: the frame rect, where it is in the texture copied
/// (the atlas, or the frame itself), where its rows start in the readback
/// buffer, and their (padded) length in bytes.
struct Read {
    rect: Rect,
    origin: (u32, u32),
    offset: u64,
    row: u32,
}

/// Lay `rects` (`bpp` bytes a pixel; in the texture at `places`) out one
/// after the other in the readback buffer from `*size`.
fn plan_reads(rects: &[Rect], places: &[(u32, u32)], bpp: u32, size: &mut u64) -> Vec<Read> {
    rects
        .iter()
        .zip(places)
        .map(|(&rect, &origin)| {
            let row = padded_row(rect.width() * bpp);
            let read = Read {
                rect,
                origin,
                offset: *size,
                row,
            };
            *size = (*size + u64::from(row) * u64::from(rect.height())).next_multiple_of(256);
            read
        })
        .collect()
}

/// Copy each of `reads` from `texture` into `buffer`.
fn encode_reads(
    encoder: &mut wgpu::CommandEncoder,
    texture: &wgpu::Texture,
    buffer: &wgpu::Buffer,
    reads: &[Read],
) {
    for read in reads {
        encoder.copy_texture_to_buffer(
            wgpu::TexelCopyTextureInfo {
                texture,
                mip_level: 0,
                origin: wgpu::Origin3d {
                    x: read.origin.0,
                    y: read.origin.1,
                    z: 0,
                },
                aspect: wgpu::TextureAspect::All,
            },
            wgpu::TexelCopyBufferInfo {
                buffer,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: read.offset,
                    bytes_per_row: Some(read.row),
                    rows_per_image: Some(read.rect.height()),
                },
            },
            wgpu::Extent3d {
                width: read.rect.width(),
                height: read.rect.height(),
                depth_or_array_layers: 1,
            },
        );
    }
}

/// Resolve a pass's rects (MSAA only) into the atlas: the colour samples'
/// mean and/or the id samples side by side, in one pass. `instances` are the
/// pass's rects in the resolve rect buffer.
fn encode_resolve(
    encoder: &mut wgpu::CommandEncoder,
    (pipes, target, resolve_rects): (&RegionPipelines, &FrameTargets, &wgpu::Buffer),
    instances: std::ops::Range<u32>,
    (color, ids): (bool, bool),
) {
    let Some(group) = &target.resolve_group else {
        return;
    };
    if instances.is_empty() {
        return;
    }
    let id_resolve = pipes.id_resolve.as_ref();
    let color_view = target.atlas.color.as_ref().map(|(_, view)| view);
    let id_view = target.atlas.ids.as_ref().map(|(_, view)| view);
    let pipeline = match (color, ids) {
        (true, false) => pipes.resolve.as_ref(),
        (true, true) => id_resolve.map(|r| &r.color_ids),
        (false, true) => id_resolve.map(|r| &r.ids),
        (false, false) => return,
    };
    let (Some(pipeline), true, true) = (
        pipeline,
        !color || color_view.is_some(),
        !ids || id_view.is_some(),
    ) else {
        return;
    };
    let attachment = |view| {
        Some(wgpu::RenderPassColorAttachment {
            view,
            depth_slice: None,
            resolve_target: None,
            ops: wgpu::Operations {
                load: wgpu::LoadOp::Load,
                store: wgpu::StoreOp::Store,
            },
        })
    };
    // As many attachments as the pipeline has targets.
    let attachments = [
        color_view.filter(|_| color).and_then(attachment),
        id_view.filter(|_| ids).and_then(attachment),
    ];
    let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: Some("region resolve pass"),
        color_attachments: &attachments[..if ids { 2 } else { 1 }],
        depth_stencil_attachment: None,
        timestamp_writes: None,
        occlusion_query_set: None,
        multiview_mask: None,
    });
    pass.set_pipeline(pipeline);
    pass.set_bind_group(0, group, &[]);
    pass.set_vertex_buffer(0, resolve_rects.slice(..));
    pass.draw(0..6, instances);
}

fn visibility_of(seen: IdStats, alone: IdStats) -> Visibility {
    Visibility {
        visible_box: seen.rect.map(|r| PixelBox {
            x0: f64::from(r.x0),
            y0: f64::from(r.y0),
            x1: f64::from(r.x1),
            y1: f64::from(r.y1),
        }),
        visible_pixels: seen.pixels,
        unoccluded_pixels: alone.pixels,
    }
}
