//! Base colour textures of the drone models: one bind group (texture +
//! sampler, `@group(1)` in `shaders/drone.wgsl`) per distinct texture, and a
//! 1×1 white one for untextured draw ranges. Mipmaps are built on the CPU at
//! upload (drones are small in the frame, so minification is the common case).

use wgpu::util::DeviceExt;

use super::gpu::{PipelineFactory, sampler_entry, texture_entry};
use crate::model::{CpuTexture, WrapMode};

/// The layout of `@group(1)` of the drone pipeline.
pub(super) fn bind_group_layout(factory: &PipelineFactory) -> wgpu::BindGroupLayout {
    factory.bind_group_layout(
        "material layout",
        &[
            texture_entry(0, true, wgpu::TextureViewDimension::D2, false),
            sampler_entry(1),
        ],
    )
}

fn address_mode(w: WrapMode) -> wgpu::AddressMode {
    match w {
        WrapMode::Repeat => wgpu::AddressMode::Repeat,
        WrapMode::MirroredRepeat => wgpu::AddressMode::MirrorRepeat,
        WrapMode::ClampToEdge => wgpu::AddressMode::ClampToEdge,
    }
}

/// The mip chain of an RGBA8 image, level 0 first (box-filtered halvings).
pub(crate) fn mip_chain(width: u32, height: u32, rgba: &[u8]) -> Vec<(u32, u32, Vec<u8>)> {
    let mut levels = vec![(width, height, rgba.to_vec())];
    while let Some((w, h, px)) = levels.last() {
        if *w == 1 && *h == 1 {
            break;
        }
        let (nw, nh) = ((w / 2).max(1), (h / 2).max(1));
        let mut out = vec![0u8; (nw * nh * 4) as usize];
        for y in 0..nh {
            for x in 0..nw {
                for c in 0..4 {
                    let mut sum = 0u32;
                    for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                        let sx = (x * 2 + dx).min(w - 1);
                        let sy = (y * 2 + dy).min(h - 1);
                        sum += u32::from(px[((sy * w + sx) * 4 + c) as usize]);
                    }
                    out[((y * nw + x) * 4 + c) as usize] = ((sum + 2) / 4) as u8;
                }
            }
        }
        levels.push((nw, nh, out));
    }
    levels
}

/// Upload a texture with its mip chain and make its bind group.
pub(super) fn upload(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    layout: &wgpu::BindGroupLayout,
    texture: &CpuTexture,
    label: &str,
) -> wgpu::BindGroup {
    let levels = mip_chain(texture.width, texture.height, &texture.rgba8);
    let data: Vec<u8> = levels
        .iter()
        .flat_map(|(_, _, px)| px.iter().copied())
        .collect();
    let gpu = device.create_texture_with_data(
        queue,
        &wgpu::TextureDescriptor {
            label: Some(label),
            size: wgpu::Extent3d {
                width: texture.width,
                height: texture.height,
                depth_or_array_layers: 1,
            },
            mip_level_count: levels.len() as u32,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            // glTF base colour textures are sRGB-encoded; sampling decodes them.
            format: wgpu::TextureFormat::Rgba8UnormSrgb,
            usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        },
        wgpu::util::TextureDataOrder::LayerMajor,
        &data,
    );
    let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
        label: Some(label),
        address_mode_u: address_mode(texture.wrap[0]),
        address_mode_v: address_mode(texture.wrap[1]),
        mag_filter: wgpu::FilterMode::Linear,
        min_filter: wgpu::FilterMode::Linear,
        mipmap_filter: wgpu::MipmapFilterMode::Linear,
        ..Default::default()
    });
    device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some(label),
        layout,
        entries: &[
            wgpu::BindGroupEntry {
                binding: 0,
                resource: wgpu::BindingResource::TextureView(&gpu.create_view(&Default::default())),
            },
            wgpu::BindGroupEntry {
                binding: 1,
                resource: wgpu::BindingResource::Sampler(&sampler),
            },
        ],
    })
}

/// The bind group of untextured draw ranges: 1×1 white.
pub(super) fn white(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    layout: &wgpu::BindGroupLayout,
) -> wgpu::BindGroup {
    let texture = CpuTexture {
        name: "white".into(),
        width: 1,
        height: 1,
        rgba8: vec![255; 4],
        wrap: [WrapMode::Repeat; 2],
    };
    upload(device, queue, layout, &texture, "white texture")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mip_chain_halves_down_to_one_pixel_and_averages() {
        // 4×2: left half black, right half white.
        let mut px = Vec::new();
        for _y in 0..2 {
            for x in 0..4 {
                let v = if x < 2 { 0 } else { 255 };
                px.extend([v, v, v, 255]);
            }
        }
        let levels = mip_chain(4, 2, &px);
        let sizes: Vec<(u32, u32)> = levels.iter().map(|(w, h, _)| (*w, *h)).collect();
        assert_eq!(sizes, vec![(4, 2), (2, 1), (1, 1)]);
        assert_eq!(&levels[1].2[..4], &[0, 0, 0, 255]);
        assert_eq!(&levels[1].2[4..8], &[255, 255, 255, 255]);
        assert_eq!(levels[2].2[0], 128);
    }
}
