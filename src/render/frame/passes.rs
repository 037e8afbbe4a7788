//! The region passes' GPU side: pipelines per sample count, the atlas the
//! resolves write, and the encoding of a planned frame ([`FramePlan`]):
//! instances and rects uploaded, each pass drawn, resolved (MSAA) and its
//! reads copied into the readback buffer, in the plan's order.

use super::{FrameTargets, RegionState};
use crate::render::id_layer::{IdLayer, IdResolve};
use crate::render::plan::{FramePlan, PassPlan, rect_ndc};
use crate::render::readback::{Read, encode_reads, ensure_buffer};
use crate::render::regions::PassDraws;
use crate::render::{COLOR_FORMAT, DEPTH_FORMAT, InstanceRaw, MeshLevel, Renderer, ids};
use crate::scene::FrameScene;

/// Pipelines of the region passes for one sample count.
pub(super) struct RegionPipelines {
    msaa: u32,
    background: wgpu::RenderPipeline,
    drone: crate::render::DronePipelines,
    /// The same two for passes that write instance ids only (overlap layers,
    /// id images): no colour attachment, no lighting.
    ids_background: wgpu::RenderPipeline,
    ids_drone: crate::render::DronePipelines,
    /// The colour resolve (MSAA only).
    resolve: Option<wgpu::RenderPipeline>,
    /// The id resolves (MSAA only), built on first use: presets that need no
    /// visibility never build them.
    id_resolve: Option<IdResolve>,
}

/// The compact target the resolves write (MSAA only): a pass's rects packed
/// in shelves ([`crate::render::regions::pack_shelves`]) as wide as the
/// frame and as tall as they need, the resolved colour here and the id
/// samples side by side in the id layer's atlas of the same rows
/// ([`IdLayer::atlas_view`]), copied from there into the readback buffer.
/// Passes reuse it one after the other; it grows as needed and never shrinks.
#[derive(Default)]
pub(super) struct Atlas {
    rows: u32,
    color: Option<(wgpu::Texture, wgpu::TextureView)>,
}

impl Atlas {
    /// At least `rows` rows (of `width` pixels) of the colour when `color`
    /// and of the id layer's atlas when `with_ids`.
    fn ensure(
        &mut self,
        device: &wgpu::Device,
        (width, rows): (u32, u32),
        (color, with_ids): (bool, bool),
        ids: &mut IdLayer,
    ) {
        if rows == 0 && self.rows == 0 {
            return; // nothing to resolve yet (a frame without drones)
        }
        let (mut color, mut with_ids) = (color, with_ids);
        if rows > self.rows {
            self.rows = rows.next_multiple_of(64);
            // Reallocated at the new size below, as far as still wanted.
            color |= self.color.take().is_some();
            with_ids |= ids.drop_atlas();
        }
        if color && self.color.is_none() {
            self.color = Some(atlas_texture(
                device,
                "resolve atlas (colour)",
                COLOR_FORMAT,
                (width, self.rows),
            ));
        }
        if with_ids {
            ids.ensure_atlas(device, (width, self.rows));
        }
    }
}

/// A single-sample target of `size` the resolves write and the reads copy from.
pub(in crate::render) fn atlas_texture(
    device: &wgpu::Device,
    label: &str,
    format: wgpu::TextureFormat,
    (width, rows): (u32, u32),
) -> (wgpu::Texture, wgpu::TextureView) {
    let texture = device.create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
        size: wgpu::Extent3d {
            width,
            height: rows,
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

/// Per-instance layout of a rect: (x0, y0, x1, y1) in normalised device coordinates.
const RECT_ATTRS: [wgpu::VertexAttribute; 1] = wgpu::vertex_attr_array![0 => Float32x4];

pub(in crate::render) fn rect_buffer_layout() -> wgpu::VertexBufferLayout<'static> {
    wgpu::VertexBufferLayout {
        array_stride: 16,
        step_mode: wgpu::VertexStepMode::Instance,
        attributes: &RECT_ATTRS,
    }
}

/// A colour target of `format`, written whole, without blending.
pub(in crate::render) fn color_target(
    format: wgpu::TextureFormat,
) -> Option<wgpu::ColorTargetState> {
    Some(wgpu::ColorTargetState {
        format,
        blend: None,
        write_mask: wgpu::ColorWrites::ALL,
    })
}

/// A render pass drawing into `view` alone, cleared to black first and
/// stored (the background and reduced sky passes).
pub(in crate::render) fn clear_pass<'e>(
    encoder: &'e mut wgpu::CommandEncoder,
    label: &str,
    view: &wgpu::TextureView,
) -> wgpu::RenderPass<'e> {
    encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: Some(label),
        color_attachments: &[Some(wgpu::RenderPassColorAttachment {
            view,
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
    })
}

/// A layout of `bindings` unfilterable float textures (bindings 0, 1, …)
/// read by fragment shaders.
pub(super) fn texture_layout(
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

impl Renderer {
    pub(super) fn region_pipelines(&self, state: &mut RegionState, msaa: u32) -> usize {
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
            let id_resolve = IdResolve::new(|label, entry, targets| {
                self.resolve_pipeline(state, label, entry, targets)
            });
            state.pipelines[p].id_resolve = Some(id_resolve);
        }
    }

    /// Write the rects of `passes` into the (reused, grown as needed) rect
    /// buffer, one after the other, and note where each pass's begin.
    pub(super) fn upload_rects(
        &self,
        state: &mut RegionState,
        passes: &mut [PassDraws],
        (width, height): (u32, u32),
    ) {
        let mut data: Vec<[f32; 4]> = Vec::new();
        for pass in passes.iter_mut() {
            pass.first_rect = data.len() as u32;
            data.extend(pass.rects.iter().map(|r| rect_ndc(r, width, height)));
        }
        crate::render::write_vertices(
            (&self.device, &self.queue),
            &mut state.rects,
            "region rects",
            bytemuck::cast_slice(&data),
        );
    }

    /// Upload what a planned frame draws: its instances (every pass's, one
    /// after the other), rects and resolve rects, and make room for what it
    /// resolves and reads. Returns each pass's draws and where its resolve
    /// rects begin (MSAA only).
    pub(super) fn upload_plan(
        &mut self,
        state: &mut RegionState,
        (p, t): (usize, usize),
        scene: &FrameScene,
        plan: &FramePlan,
    ) -> (Vec<PassDraws>, Vec<u32>) {
        let request = &plan.request;
        let mut data = Vec::new();
        let mut draws: Vec<PassDraws> = (plan.passes.iter())
            .map(|pass| self.region_draws(scene, pass, &mut data))
            .collect();
        self.write_instances(&data);
        self.upload_rects(state, &mut draws, request.size_px);
        if request.color {
            self.counts.color += 1;
        }
        if request.visibility {
            self.counts.ids += plan.passes.len() as u64;
            self.prepare_id_readback(state, p);
        }
        let first_resolve = if plan.resolved() {
            let target = &mut state.targets[t];
            let size = (request.size_px.0, plan.atlas_rows);
            let asked = (request.color, request.visibility);
            (target.atlas).ensure(&self.device, size, asked, &mut target.ids);
            let (data, first) = plan.resolve_instances(target.atlas.rows);
            crate::render::write_vertices(
                (&self.device, &self.queue),
                &mut state.resolve_rects,
                "resolve rects",
                bytemuck::cast_slice(&data),
            );
            first
        } else {
            Vec::new()
        };
        let target = &mut state.targets[t];
        let label = "region readback";
        ensure_buffer(
            &self.device,
            &mut target.regions_readback,
            label,
            plan.readback_size,
        );
        (draws, first_resolve)
    }

    /// A pass over its disjoint rects drawing its drones: their instances
    /// (drone index + 1 as id) appended to `data`, grouped by (model, level
    /// of detail).
    pub(super) fn region_draws(
        &self,
        scene: &FrameScene,
        pass: &PassPlan,
        data: &mut Vec<InstanceRaw>,
    ) -> PassDraws {
        let mut order: Vec<(MeshLevel, usize)> = (pass.drones.iter())
            .map(|&i| ((scene.drones[i].model, self.level_of(scene, i)), i))
            .collect();
        order.sort_unstable();
        let mut draws: Vec<(MeshLevel, std::ops::Range<u32>)> = Vec::new();
        for (key, i) in order {
            let idx = data.len() as u32;
            data.push(InstanceRaw::new(scene, i));
            match draws.last_mut() {
                Some((k, r)) if *k == key => r.end = idx + 1,
                _ => draws.push((key, idx..idx + 1)),
            }
        }
        PassDraws {
            rects: pass.rects.clone(),
            first_rect: 0,
            draws,
        }
    }

    /// One render pass over a pass's regions: each region's background (its
    /// "clear"), then the drones of all regions. Without `color` the pass
    /// writes instance ids (and depth) only: no colour target, no lighting.
    pub(super) fn encode_region_pass(
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
                attachment(target.ids.view()),
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

    /// Encode a planned frame's passes in order: the main pass (with the
    /// scenery over it), its resolve and reads, then each overlap layer's.
    pub(super) fn encode_frame(
        &self,
        state: &RegionState,
        (p, t): (usize, usize),
        plan: &FramePlan,
        (draws, first_resolve): (&[PassDraws], &[u32]),
    ) -> wgpu::CommandEncoder {
        let mut encoder = self
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("frame (regions)"),
            });
        let request = &plan.request;
        let pipes = &state.pipelines[p];
        let target = &state.targets[t];
        let rects = state.rects.as_ref();
        // With MSAA each pass is resolved into the atlas and read from there;
        // without, the passes draw straight into the targets read back.
        let color_source = if plan.resolved() {
            texture(&target.atlas.color)
        } else {
            texture(&target.single)
        };
        let id_source = target.ids.read_source(plan.resolved());
        let read =
            |encoder: &mut wgpu::CommandEncoder, source: Option<&wgpu::Texture>, reads: &[Read]| {
                if let (Some(buffer), Some(source)) = (&target.regions_readback, source) {
                    encode_reads(encoder, source, buffer, reads);
                }
            };
        for (k, pass) in draws.iter().enumerate() {
            let main = k == 0;
            let (label, asked) = if main {
                ("region pass", (request.color, request.visibility))
            } else {
                ("layer pass", (false, true))
            };
            self.encode_region_pass(&mut encoder, (pipes, target, rects), pass, (label, asked.0));
            if let (true, true, Some(gpu), Some(rects)) =
                (main, request.scenery, &state.scenery, rects)
            {
                let color_view = (target.msaa_color.as_ref())
                    .or(target.single.as_ref().map(|(_, view)| view))
                    .filter(|_| request.color);
                let views = (color_view, target.ids.view(), &target.depth);
                self.encode_scenery(gpu, &mut encoder, views, (rects, pass, request.msaa));
            }
            if let (Some(buffer), Some(&first)) = (&state.resolve_rects, first_resolve.get(k)) {
                let instances = first..first + pass.rects.len() as u32;
                encode_resolve(&mut encoder, (pipes, target, buffer), instances, asked);
            }
            if main {
                read(&mut encoder, color_source, &plan.color_reads);
            }
            if let Some(reads) = plan.id_reads.get(k) {
                read(&mut encoder, id_source, reads);
            }
        }
        encoder
    }
}

/// The texture of an optional (texture, view) pair.
fn texture(pair: &Option<(wgpu::Texture, wgpu::TextureView)>) -> Option<&wgpu::Texture> {
    pair.as_ref().map(|(texture, _)| texture)
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
    let id_view = target.ids.atlas_view();
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
