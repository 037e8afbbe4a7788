//! The renderer's low-level wgpu helpers: the one place pipelines and
//! layouts are made ([`PipelineFactory`], described by [`PipelineDesc`]), and
//! descriptors that several parts of the frame write alike (2D textures,
//! colour and depth targets, a cleared pass, bind group layout entries, the
//! atlas texture and the rect vertex layouts). A leaf: it imports nothing of
//! `render`, and every part (drones, sky and background, scenery, id layer,
//! region passes, and the desktop app's flat paint) builds on it.

use std::borrow::Cow;

/// Makes every shader module, bind group layout, pipeline layout and render
/// pipeline of the renderer (and of the desktop app's flat paint), so each
/// part describes only what differs ([`PipelineDesc`]), not a whole wgpu
/// descriptor.
#[derive(Clone)]
pub(crate) struct PipelineFactory {
    device: wgpu::Device,
}

/// What one render pipeline differs in. [`PipelineDesc::new`] gives the
/// common case (vertex `vs_main` without buffers, no override constants,
/// default primitive, no depth, one sample); struct update syntax changes
/// the rest.
pub(crate) struct PipelineDesc<'a> {
    pub label: &'a str,
    pub layout: &'a wgpu::PipelineLayout,
    pub module: &'a wgpu::ShaderModule,
    pub vertex_entry: &'a str,
    pub buffers: &'a [Option<wgpu::VertexBufferLayout<'a>>],
    /// Override constants of the vertex stage.
    pub vertex_constants: &'a [(&'a str, f64)],
    pub fragment_entry: &'a str,
    /// Override constants of the fragment stage.
    pub constants: &'a [(&'a str, f64)],
    pub targets: &'a [Option<wgpu::ColorTargetState>],
    pub primitive: wgpu::PrimitiveState,
    pub depth: Option<wgpu::DepthStencilState>,
    pub samples: u32,
}

impl<'a> PipelineDesc<'a> {
    /// Fragment `fragment_entry` of `module` writing `targets`, the rest the common case.
    pub(crate) fn new(
        label: &'a str,
        layout: &'a wgpu::PipelineLayout,
        module: &'a wgpu::ShaderModule,
        fragment_entry: &'a str,
        targets: &'a [Option<wgpu::ColorTargetState>],
    ) -> Self {
        Self {
            label,
            layout,
            module,
            vertex_entry: "vs_main",
            buffers: &[],
            vertex_constants: &[],
            fragment_entry,
            constants: &[],
            targets,
            primitive: wgpu::PrimitiveState::default(),
            depth: None,
            samples: 1,
        }
    }
}

/// A shader module and the pipeline layout its pipelines are made with.
pub(super) struct Program {
    pub module: wgpu::ShaderModule,
    pub layout: wgpu::PipelineLayout,
}

impl PipelineFactory {
    pub(crate) fn new(device: &wgpu::Device) -> Self {
        Self {
            device: device.clone(),
        }
    }

    /// The device everything is made on (for buffers, textures and bind groups).
    pub(crate) fn device(&self) -> &wgpu::Device {
        &self.device
    }

    /// A [`Program`]: `source` compiled, its pipelines laid out with `groups`.
    pub(super) fn program(
        &self,
        label: &str,
        source: String,
        groups: &[&wgpu::BindGroupLayout],
    ) -> Program {
        Program {
            module: self.shader(label, source),
            layout: self.layout(&format!("{label} pipeline layout"), groups),
        }
    }

    /// A WGSL module from `source`.
    pub(crate) fn shader(&self, label: &str, source: String) -> wgpu::ShaderModule {
        self.device
            .create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some(label),
                source: wgpu::ShaderSource::Wgsl(Cow::Owned(source)),
            })
    }

    /// A bind group layout of `entries`.
    pub(crate) fn bind_group_layout(
        &self,
        label: &str,
        entries: &[wgpu::BindGroupLayoutEntry],
    ) -> wgpu::BindGroupLayout {
        self.device
            .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some(label),
                entries,
            })
    }

    /// A pipeline layout of `groups` (`@group(0)`, `@group(1)`, …), no immediates.
    pub(crate) fn layout(
        &self,
        label: &str,
        groups: &[&wgpu::BindGroupLayout],
    ) -> wgpu::PipelineLayout {
        let groups: Vec<Option<&wgpu::BindGroupLayout>> =
            groups.iter().copied().map(Some).collect();
        self.device
            .create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some(label),
                bind_group_layouts: &groups,
                immediate_size: 0,
            })
    }

    /// The render pipeline `desc` describes.
    pub(crate) fn render(&self, desc: &PipelineDesc<'_>) -> wgpu::RenderPipeline {
        self.device
            .create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some(desc.label),
                layout: Some(desc.layout),
                vertex: wgpu::VertexState {
                    module: desc.module,
                    entry_point: Some(desc.vertex_entry),
                    compilation_options: wgpu::PipelineCompilationOptions {
                        constants: desc.vertex_constants,
                        ..Default::default()
                    },
                    buffers: desc.buffers,
                },
                primitive: desc.primitive,
                depth_stencil: desc.depth.clone(),
                multisample: wgpu::MultisampleState {
                    count: desc.samples,
                    ..Default::default()
                },
                fragment: Some(wgpu::FragmentState {
                    module: desc.module,
                    entry_point: Some(desc.fragment_entry),
                    compilation_options: wgpu::PipelineCompilationOptions {
                        constants: desc.constants,
                        ..Default::default()
                    },
                    targets: desc.targets,
                }),
                multiview_mask: None,
                cache: None,
            })
    }
}

/// A depth test of `format` against `compare`, writing depth when `write`.
pub(crate) fn depth_test(
    format: wgpu::TextureFormat,
    write: bool,
    compare: wgpu::CompareFunction,
) -> Option<wgpu::DepthStencilState> {
    Some(wgpu::DepthStencilState {
        format,
        depth_write_enabled: Some(write),
        depth_compare: Some(compare),
        stencil: Default::default(),
        bias: Default::default(),
    })
}

/// A uniform buffer at `binding`, seen by `visibility`.
pub(crate) fn uniform_entry(
    binding: u32,
    visibility: wgpu::ShaderStages,
) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Uniform,
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

/// A float texture at `binding` read by fragment shaders.
pub(crate) fn texture_entry(
    binding: u32,
    filterable: bool,
    view_dimension: wgpu::TextureViewDimension,
    multisampled: bool,
) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::FRAGMENT,
        ty: wgpu::BindingType::Texture {
            sample_type: wgpu::TextureSampleType::Float { filterable },
            view_dimension,
            multisampled,
        },
        count: None,
    }
}

/// A filtering sampler at `binding` read by fragment shaders.
pub(crate) fn sampler_entry(binding: u32) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::FRAGMENT,
        ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
        count: None,
    }
}

/// A 2D texture of `width`×`height` pixels, one mip level, `samples` samples a pixel.
pub(super) fn texture_2d(
    device: &wgpu::Device,
    label: &str,
    (width, height): (u32, u32),
    (format, samples): (wgpu::TextureFormat, u32),
    usage: wgpu::TextureUsages,
) -> wgpu::Texture {
    device.create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
        size: wgpu::Extent3d {
            width,
            height,
            depth_or_array_layers: 1,
        },
        mip_level_count: 1,
        sample_count: samples,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage,
        view_formats: &[],
    })
}

/// A single-sample target of `size` the resolves write and the reads copy from.
pub(super) fn atlas_texture(
    device: &wgpu::Device,
    label: &str,
    format: wgpu::TextureFormat,
    size: (u32, u32),
) -> (wgpu::Texture, wgpu::TextureView) {
    let usage = wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC;
    let texture = texture_2d(device, label, size, (format, 1), usage);
    let view = texture.create_view(&Default::default());
    (texture, view)
}

/// Per-instance layout of a resolve rect: its place in the atlas (x0, y0,
/// x1, y1 in the atlas's normalised device coordinates), then the whole-pixel
/// offset (dx, dy) from there to the rect in the frame.
const RESOLVE_ATTRS: [wgpu::VertexAttribute; 2] =
    wgpu::vertex_attr_array![0 => Float32x4, 1 => Float32x2];

pub(super) fn resolve_buffer_layout() -> wgpu::VertexBufferLayout<'static> {
    wgpu::VertexBufferLayout {
        array_stride: 24,
        step_mode: wgpu::VertexStepMode::Instance,
        attributes: &RESOLVE_ATTRS,
    }
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

/// A colour target of `format`, written whole, without blending.
pub(super) fn color_target(format: wgpu::TextureFormat) -> Option<wgpu::ColorTargetState> {
    Some(wgpu::ColorTargetState {
        format,
        blend: None,
        write_mask: wgpu::ColorWrites::ALL,
    })
}

/// A render pass drawing into `view` alone, cleared to black first and
/// stored (the procedural environment's quarter-resolution pass, whose
/// polygons need not cover every texel the next pass samples).
pub(super) fn clear_pass<'e>(
    encoder: &'e mut wgpu::CommandEncoder,
    label: &str,
    view: &wgpu::TextureView,
) -> wgpu::RenderPass<'e> {
    single_pass(
        encoder,
        label,
        view,
        wgpu::LoadOp::Clear(wgpu::Color::BLACK),
    )
}

/// A render pass drawing into `view` alone, its contents loaded, not
/// cleared, and stored: for draws that write every pixel of it (a clear
/// would be a frame-sized fill for nothing; wgpu zeroes a texture before
/// its first load).
pub(super) fn covering_pass<'e>(
    encoder: &'e mut wgpu::CommandEncoder,
    label: &str,
    view: &wgpu::TextureView,
) -> wgpu::RenderPass<'e> {
    single_pass(encoder, label, view, wgpu::LoadOp::Load)
}

fn single_pass<'e>(
    encoder: &'e mut wgpu::CommandEncoder,
    label: &str,
    view: &wgpu::TextureView,
    load: wgpu::LoadOp<wgpu::Color>,
) -> wgpu::RenderPass<'e> {
    encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: Some(label),
        color_attachments: &[Some(wgpu::RenderPassColorAttachment {
            view,
            depth_slice: None,
            resolve_target: None,
            ops: wgpu::Operations {
                load,
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
    factory: &PipelineFactory,
    label: &str,
    multisampled: bool,
    bindings: u32,
) -> wgpu::BindGroupLayout {
    let entries: Vec<wgpu::BindGroupLayoutEntry> = (0..bindings)
        .map(|binding| texture_entry(binding, false, wgpu::TextureViewDimension::D2, multisampled))
        .collect();
    factory.bind_group_layout(label, &entries)
}

/// The views a region pass (and the scenery over it) draws into: colour
/// (`None`: ids only), instance ids and depth.
#[derive(Clone, Copy)]
pub(super) struct PassViews<'a> {
    pub color: Option<&'a wgpu::TextureView>,
    pub ids: &'a wgpu::TextureView,
    pub depth: &'a wgpu::TextureView,
}

/// A render pass into `views` that loads and stores them all (the targets
/// are never cleared: each pass draws only its regions).
pub(super) fn load_pass<'e>(
    encoder: &'e mut wgpu::CommandEncoder,
    label: &str,
    views: PassViews<'_>,
) -> wgpu::RenderPass<'e> {
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
    encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: Some(label),
        color_attachments: &[views.color.and_then(attachment), attachment(views.ids)],
        depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
            view: views.depth,
            depth_ops: Some(wgpu::Operations {
                load: wgpu::LoadOp::Load,
                store: wgpu::StoreOp::Store,
            }),
            stencil_ops: None,
        }),
        timestamp_writes: None,
        occlusion_query_set: None,
        multiview_mask: None,
    })
}
