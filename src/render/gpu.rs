//! The renderer's low-level wgpu helpers: descriptors that several parts of
//! the frame write alike (2D textures, colour targets, a cleared pass, texture layouts,
//! the atlas texture and the rect vertex layouts). A leaf: it imports
//! nothing of `render`, and every part (background, sky, scenery, id layer,
//! region passes) builds on it.

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
/// stored (the background and reduced sky passes).
pub(super) fn clear_pass<'e>(
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
