//! The region passes' GPU side ([`RegionPasses`]): their shaders, layouts
//! and pipelines per sample count, the rect buffers, and the encoding of a
//! planned frame ([`FramePlan`]): instances and rects uploaded, each pass
//! drawn into the frame's targets ([`FrameTargets`]), resolved (MSAA) and
//! its reads copied into the readback buffer, in the plan's order; and the
//! one-sample id pass of an id image. What they draw with from the renderer
//! (device, queue, pipeline maker, frame uniforms, drones) comes in as
//! [`PassInputs`].

use crate::render::gpu::{
    PassViews, PipelineDesc, PipelineFactory, color_target, depth_test, load_pass,
    rect_buffer_layout, resolve_buffer_layout, texture_layout,
};
use crate::render::id_layer::IdResolve;
use crate::render::mesh::{DronePipelines, Drones};
use crate::render::plan::{FramePlan, PassPlan, rect_ndc};
use crate::render::readback::{Read, encode_reads, ensure_buffer};
use crate::render::regions::PassDraws;
use crate::render::scenery::{SceneryDraw, SceneryGpu};
use crate::render::targets::FrameTargets;
use crate::render::{COLOR_FORMAT, DEPTH_FORMAT, InstanceRaw, ids};
use crate::scene::FrameScene;

/// The region passes' own things: their shaders and bind group layouts,
/// pipelines per sample count, and the buffers of a frame's rects.
pub(super) struct RegionPasses {
    background_layout: wgpu::BindGroupLayout,
    resolve_layout: wgpu::BindGroupLayout,
    regions_module: wgpu::ShaderModule,
    resolve_module: wgpu::ShaderModule,
    pipelines: Vec<RegionPipelines>,
    /// The frame's rects of every pass, one instance each (see `rect.wgsl`).
    rects: Option<wgpu::Buffer>,
    /// The frame's resolve rects of every pass (see `resolve.wgsl`).
    resolve_rects: Option<wgpu::Buffer>,
    /// Whether any frame has measured visibility (for tests).
    id_readback: bool,
}

impl RegionPasses {
    pub(super) fn new(factory: &PipelineFactory) -> Self {
        let [_, _, (_, regions_src), (_, resolve_src), ..] = crate::render::shader_sources();
        let (background_layout, resolve_layout) = target_layouts(factory);
        Self {
            background_layout,
            resolve_layout,
            regions_module: factory.shader("regions.wgsl", regions_src),
            resolve_module: factory.shader("resolve.wgsl", resolve_src),
            pipelines: Vec::new(),
            rects: None,
            resolve_rects: None,
            id_readback: false,
        }
    }

    /// How the targets' background is bound for the passes' "clear".
    pub(super) fn background_layout(&self) -> &wgpu::BindGroupLayout {
        &self.background_layout
    }

    /// How the targets' multisampled colour and ids are bound for the resolves.
    pub(super) fn resolve_layout(&self) -> &wgpu::BindGroupLayout {
        &self.resolve_layout
    }

    pub(super) fn has_id_readback(&self) -> bool {
        self.id_readback
    }
}

/// How the frame targets are bound: their background (the passes' "clear")
/// and the resolves' inputs, the multisampled colour and id targets. Bind
/// group layouts are the same whoever makes them (wgpu keeps one of each).
pub(super) fn target_layouts(
    factory: &PipelineFactory,
) -> (wgpu::BindGroupLayout, wgpu::BindGroupLayout) {
    (
        texture_layout(factory, "region background layout", false, 1),
        texture_layout(factory, "region resolve layout", true, 2),
    )
}

/// What the region passes draw with that the renderer owns: its device,
/// queue and pipeline maker, the frame uniforms' group, and the drones
/// (meshes, the instance buffer they upload, their draws).
pub(super) struct PassInputs<'a> {
    pub device: &'a wgpu::Device,
    pub queue: &'a wgpu::Queue,
    pub factory: &'a PipelineFactory,
    pub frame_group: &'a wgpu::BindGroup,
    pub drones: &'a mut Drones,
}

/// What [`RegionPasses::upload`] uploaded for a planned frame: the
/// pipelines it is drawn with, each pass's draws, and where each pass's
/// resolve rects begin (MSAA only).
pub(super) struct Uploaded {
    pipelines: usize,
    draws: Vec<PassDraws>,
    first_resolve: Vec<u32>,
}

/// Where a region pass (or its resolve) draws: the pipelines, the frame's
/// targets and the rect buffer (the resolve's: the resolve rects).
#[derive(Clone, Copy)]
struct PassTarget<'a> {
    pipes: &'a RegionPipelines,
    target: &'a FrameTargets,
    rects: Option<&'a wgpu::Buffer>,
}

/// A region pass's label and whether it draws colour (else instance ids only).
#[derive(Clone, Copy)]
struct PassKind<'a> {
    label: &'a str,
    color: bool,
}

/// What a pass is asked to produce: colour and/or instance ids.
#[derive(Clone, Copy)]
struct Asked {
    color: bool,
    ids: bool,
}

/// Pipelines of the region passes for one sample count.
struct RegionPipelines {
    msaa: u32,
    background: wgpu::RenderPipeline,
    drone: DronePipelines,
    /// The same two for passes that write instance ids only (overlap layers,
    /// id images): no colour attachment, no lighting.
    ids_background: wgpu::RenderPipeline,
    ids_drone: DronePipelines,
    /// The colour resolve (MSAA only).
    resolve: Option<wgpu::RenderPipeline>,
    /// The id resolves (MSAA only), built on first use: presets that need no
    /// visibility never build them.
    id_resolve: Option<IdResolve>,
}

impl RegionPasses {
    /// The index of the region pipelines for `msaa` samples (drawing
    /// `drones`), built on first use.
    pub(super) fn pipelines_for(
        &mut self,
        factory: &PipelineFactory,
        drones: &Drones,
        msaa: u32,
    ) -> usize {
        if let Some(i) = self.pipelines.iter().position(|p| p.msaa == msaa) {
            return i;
        }
        let targets = [color_target(COLOR_FORMAT), color_target(ids::ID_FORMAT)];
        let background_layout = factory.layout(
            "region background pipeline layout",
            &[&self.background_layout],
        );
        let buffers = [Some(rect_buffer_layout())];
        let background_pipeline = |label: &str, entry: &str, targets: &[_]| {
            factory.render(&PipelineDesc {
                buffers: &buffers,
                depth: depth_test(DEPTH_FORMAT, true, wgpu::CompareFunction::Always),
                samples: msaa,
                ..PipelineDesc::new(
                    label,
                    &background_layout,
                    &self.regions_module,
                    entry,
                    targets,
                )
            })
        };
        let background = background_pipeline("region background pipeline", "fs_main", &targets);
        let drone = drones.pipelines(factory, "drone + id pipeline", msaa, "fs_ids", &targets);
        let id_targets = [None, targets[1].clone()];
        let ids_background =
            background_pipeline("region id background pipeline", "fs_clear_ids", &id_targets);
        let ids_drone =
            drones.pipelines(factory, "drone id pipeline", msaa, "fs_layer", &id_targets);
        let resolve = (msaa > 1).then(|| {
            self.resolve_pipeline(factory, "region resolve pipeline", "fs_main", &targets[..1])
        });
        self.pipelines.push(RegionPipelines {
            msaa,
            background,
            drone,
            ids_background,
            ids_drone,
            resolve,
            id_resolve: None,
        });
        self.pipelines.len() - 1
    }

    fn resolve_pipeline(
        &self,
        factory: &PipelineFactory,
        label: &str,
        entry: &str,
        targets: &[Option<wgpu::ColorTargetState>],
    ) -> wgpu::RenderPipeline {
        let layout = factory.layout("region resolve pipeline layout", &[&self.resolve_layout]);
        factory.render(&PipelineDesc {
            buffers: &[Some(resolve_buffer_layout())],
            ..PipelineDesc::new(label, &layout, &self.resolve_module, entry, targets)
        })
    }

    /// Set up what reading ids back needs: with MSAA, the id resolves.
    fn prepare_id_readback(&mut self, factory: &PipelineFactory, p: usize) {
        self.id_readback = true;
        if self.pipelines[p].msaa <= 1 || self.pipelines[p].id_resolve.is_some() {
            return;
        }
        let id_resolve = IdResolve::new(|label, entry, targets| {
            self.resolve_pipeline(factory, label, entry, targets)
        });
        self.pipelines[p].id_resolve = Some(id_resolve);
    }

    /// Write the rects of `passes` into the (reused, grown as needed) rect
    /// buffer, one after the other, and note where each pass's begin.
    pub(super) fn upload_rects(
        &mut self,
        (device, queue): (&wgpu::Device, &wgpu::Queue),
        passes: &mut [PassDraws],
        (width, height): (u32, u32),
    ) {
        let mut data: Vec<[f32; 4]> = Vec::new();
        for pass in passes.iter_mut() {
            pass.first_rect = data.len() as u32;
            data.extend(pass.rects.iter().map(|r| rect_ndc(r, width, height)));
        }
        crate::render::write_vertices(
            (device, queue),
            &mut self.rects,
            "region rects",
            bytemuck::cast_slice(&data),
        );
    }
}

impl RegionPasses {
    /// Upload what a planned frame draws with pipelines `p`: its instances
    /// (every pass's, one after the other), rects and resolve rects, and make
    /// room in `target` for what it resolves and reads.
    pub(super) fn upload(
        &mut self,
        with: &mut PassInputs<'_>,
        p: usize,
        target: &mut FrameTargets,
        scene: &FrameScene,
        plan: &FramePlan,
    ) -> Uploaded {
        let request = &plan.request;
        let mut data = Vec::new();
        let drones = &*with.drones;
        let mut draws: Vec<PassDraws> = (plan.passes.iter())
            .map(|pass| pass_draws(drones, scene, pass, &mut data))
            .collect();
        let (device, queue) = (with.device, with.queue);
        with.drones.upload_instances((device, queue), &data);
        self.upload_rects((device, queue), &mut draws, request.size_px);
        if request.visibility {
            self.prepare_id_readback(with.factory, p);
        }
        let first_resolve = if plan.resolved() {
            let size = (request.size_px.0, plan.atlas_rows);
            target.ensure_atlas(device, size, (request.color, request.visibility));
            let (data, first) = plan.resolve_instances(target.atlas.rows);
            crate::render::write_vertices(
                (device, queue),
                &mut self.resolve_rects,
                "resolve rects",
                bytemuck::cast_slice(&data),
            );
            first
        } else {
            Vec::new()
        };
        let label = "region readback";
        let buffer = &mut target.regions_readback;
        ensure_buffer(device, buffer, label, plan.readback_size);
        Uploaded {
            pipelines: p,
            draws,
            first_resolve,
        }
    }

    /// Encode a planned frame's passes in order: the main pass (with the
    /// scenery over it), its resolve and reads, then each overlap layer's.
    pub(super) fn encode(
        &self,
        with: &PassInputs<'_>,
        target: &FrameTargets,
        scenery: Option<&SceneryGpu>,
        plan: &FramePlan,
        uploaded: &Uploaded,
    ) -> wgpu::CommandEncoder {
        let mut encoder = with
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("frame (regions)"),
            });
        let request = &plan.request;
        let pipes = &self.pipelines[uploaded.pipelines];
        let rects = self.rects.as_ref();
        let at = PassTarget {
            pipes,
            target,
            rects,
        };
        let (draws, first_resolve) = (&uploaded.draws, &uploaded.first_resolve);
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
                let asked = Asked {
                    color: request.color,
                    ids: request.visibility,
                };
                ("region pass", asked)
            } else {
                (
                    "layer pass",
                    Asked {
                        color: false,
                        ids: true,
                    },
                )
            };
            let kind = PassKind {
                label,
                color: asked.color,
            };
            encode_region_pass(&mut encoder, with, &at, pass, kind);
            if let (true, true, Some(gpu), Some(rects)) = (main, request.scenery, scenery, rects) {
                let views = PassViews {
                    color: target.color_view().filter(|_| request.color),
                    ids: target.ids.view(),
                    depth: &target.depth,
                };
                let samples = request.msaa;
                let draw = SceneryDraw {
                    rects,
                    draws: pass,
                    samples,
                };
                gpu.encode(&mut encoder, views, &draw);
            }
            if let (Some(buffer), Some(&first)) = (&self.resolve_rects, first_resolve.get(k)) {
                let instances = first..first + pass.rects.len() as u32;
                let at = PassTarget {
                    rects: Some(buffer),
                    ..at
                };
                encode_resolve(&mut encoder, &at, instances, asked);
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

    /// Encode one id pass with pipelines `p` (one sample per pixel) over
    /// `pass`'s rects drawing its drones, after uploading their instances
    /// and rects; the ids are left in `target`'s id layer.
    pub(super) fn encode_ids(
        &mut self,
        with: &mut PassInputs<'_>,
        p: usize,
        target: &FrameTargets,
        scene: &FrameScene,
        pass: &PassPlan,
    ) -> wgpu::CommandEncoder {
        let size = (scene.camera.width, scene.camera.height);
        let mut data = Vec::new();
        let mut draws = [pass_draws(with.drones, scene, pass, &mut data)];
        let (device, queue) = (with.device, with.queue);
        with.drones.upload_instances((device, queue), &data);
        self.upload_rects((device, queue), &mut draws, size);
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("instance ids"),
        });
        let at = PassTarget {
            pipes: &self.pipelines[p],
            target,
            rects: self.rects.as_ref(),
        };
        let kind = PassKind {
            label: "id pass",
            color: false,
        };
        encode_region_pass(&mut encoder, with, &at, &draws[0], kind);
        encoder
    }
}

/// A pass over its disjoint rects drawing its drones: their instances
/// (drone index + 1 as id) appended to `data`, grouped by (model, level
/// of detail).
fn pass_draws(
    drones: &Drones,
    scene: &FrameScene,
    pass: &PassPlan,
    data: &mut Vec<InstanceRaw>,
) -> PassDraws {
    PassDraws {
        rects: pass.rects.clone(),
        first_rect: 0,
        draws: drones.instances(scene, pass.drones.iter().copied(), data),
    }
}

/// One render pass over a pass's regions: each region's background (its
/// "clear"), then the drones of all regions. Without `color` the pass
/// writes instance ids (and depth) only: no colour target, no lighting.
fn encode_region_pass(
    encoder: &mut wgpu::CommandEncoder,
    with: &PassInputs<'_>,
    at: &PassTarget<'_>,
    draws: &PassDraws,
    kind: PassKind<'_>,
) {
    let PassTarget {
        pipes,
        target,
        rects,
    } = *at;
    let Some(color_view) = target.color_view() else {
        return;
    };
    let views = PassViews {
        color: kind.color.then_some(color_view),
        ids: target.ids.view(),
        depth: &target.depth,
    };
    let mut pass = load_pass(encoder, kind.label, views);
    let Some(rect_buffer) = rects else {
        return;
    };
    let (background, drone) = if kind.color {
        (&pipes.background, &pipes.drone)
    } else {
        (&pipes.ids_background, &pipes.ids_drone)
    };
    pass.set_pipeline(background);
    pass.set_bind_group(0, &target.background.group, &[]);
    pass.set_vertex_buffer(0, rect_buffer.slice(..));
    pass.draw(0..6, draws.rect_instances());
    let Some(bounds) = draws.bounds() else {
        return;
    };
    if draws.draws.is_empty() {
        return;
    }
    // The scissor only bounds the work: each drone stays inside its region.
    pass.set_scissor_rect(bounds.x0, bounds.y0, bounds.width(), bounds.height());
    pass.set_bind_group(0, with.frame_group, &[]);
    with.drones.draw(&mut pass, drone, &draws.draws);
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
    at: &PassTarget<'_>,
    instances: std::ops::Range<u32>,
    Asked { color, ids }: Asked,
) {
    let PassTarget {
        pipes,
        target,
        rects,
    } = *at;
    let Some(resolve_rects) = rects else {
        return;
    };
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
