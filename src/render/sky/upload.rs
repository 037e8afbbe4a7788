//! The sky images' upload (RGB to RGBA half-float textures, equirect or cube
//! map) and the bind groups of `@group(1)` that sample them.

use half::slice::HalfFloatSliceExt;
use wgpu::util::DeviceExt;

use super::SkyGpu;
use crate::sky::{EnvironmentAssets, SkyImage, SkyImageKind};

/// RGB texels as RGBA half floats (alpha 1), rounded to nearest as
/// `f16::from_f32`; converted a row of texels at a time by the `half`
/// crate's slice conversion (F16C where the CPU has it: a 1k sky image is
/// two million values, on the first frame's path).
pub(super) fn f16_rgba(rgb: &[f32]) -> Vec<half::f16> {
    const CHUNK: usize = 1024;
    let mut out = vec![half::f16::ZERO; rgb.len() / 3 * 4];
    let mut rgba = [0f32; CHUNK * 4];
    for (src, dst) in rgb.chunks(CHUNK * 3).zip(out.chunks_mut(CHUNK * 4)) {
        let texels = src.len() / 3;
        for (p, q) in src.chunks_exact(3).zip(rgba.chunks_exact_mut(4)) {
            q.copy_from_slice(&[p[0], p[1], p[2], 1.0]);
        }
        dst.convert_from_f32_slice(&rgba[..texels * 4]);
    }
    out
}

/// The RGB values of `rgba` (half floats, alpha dropped) as `f32`: the
/// texels a half-float texture of `rgb` holds, for the CPU's image pass
/// (`equirect`) to sample the very values the GPU's sky pass samples.
fn rounded_rgb(rgba: &[half::f16]) -> Vec<f32> {
    const CHUNK: usize = 1024;
    let mut out = Vec::with_capacity(rgba.len() / 4 * 3);
    let mut values = [0f32; CHUNK * 4];
    for chunk in rgba.chunks(CHUNK * 4) {
        let values = &mut values[..chunk.len()];
        chunk.convert_to_f32_slice(values);
        for texel in values.chunks_exact(4) {
            out.extend_from_slice(&texel[..3]);
        }
    }
    out
}

impl SkyGpu {
    pub(super) fn texture(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        label: &str,
        width: u32,
        height: u32,
        layers: u32,
        rgb: &[f32],
    ) -> wgpu::Texture {
        Self::half_texture(
            device,
            queue,
            label,
            (width, height, layers),
            &f16_rgba(rgb),
        )
    }

    /// A `width`×`height`×`layers` RGBA16F texture of `rgba`.
    fn half_texture(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        label: &str,
        (width, height, layers): (u32, u32, u32),
        rgba: &[half::f16],
    ) -> wgpu::Texture {
        device.create_texture_with_data(
            queue,
            &wgpu::TextureDescriptor {
                label: Some(label),
                size: wgpu::Extent3d {
                    width,
                    height,
                    depth_or_array_layers: layers,
                },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format: wgpu::TextureFormat::Rgba16Float,
                usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
                view_formats: &[],
            },
            wgpu::util::TextureDataOrder::LayerMajor,
            bytemuck::cast_slice(rgba),
        )
    }

    fn bind_group(
        &self,
        device: &wgpu::Device,
        label: &str,
        equirect: &wgpu::TextureView,
        cube: &wgpu::TextureView,
    ) -> wgpu::BindGroup {
        make_bind_group(
            device,
            &self.layout,
            &self.uniforms,
            (&self.sampler, &self.half_sampler),
            label,
            [equirect, cube, &self.placeholder_2d],
        )
    }

    /// Upload the preset's sky images (replacing any uploaded before).
    pub(in crate::render) fn set_images(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        assets: &EnvironmentAssets,
        max_side: u32,
    ) {
        self.images.clear();
        self.image_views.clear();
        self.upsampled = None;
        for (i, image) in assets.images.iter().enumerate() {
            let label = format!("sky image {i}");
            let mut equirect = None;
            let mut kept = None;
            let group = match &image.kind {
                SkyImageKind::Equirect { width, height, rgb }
                    if (*width).max(*height) <= max_side =>
                {
                    let rgba = f16_rgba(rgb);
                    let size = (*width, *height, 1);
                    let view = Self::half_texture(device, queue, &label, size, &rgba)
                        .create_view(&Default::default());
                    let group = self.bind_group(device, &label, &view, &self.placeholder_cube);
                    equirect = Some(view);
                    // Kept as the texture holds them, for the CPU's image pass.
                    kept = Some(SkyImageKind::Equirect {
                        width: *width,
                        height: *height,
                        rgb: rounded_rgb(&rgba),
                    });
                    group
                }
                SkyImageKind::Cubemap { side, faces } if *side <= max_side => {
                    let view =
                        Self::texture(device, queue, &label, *side, *side, 6, &faces.concat())
                            .create_view(&wgpu::TextureViewDescriptor {
                                dimension: Some(wgpu::TextureViewDimension::Cube),
                                ..Default::default()
                            });
                    self.bind_group(device, &label, &self.placeholder_2d, &view)
                }
                // Larger than the adapter allows (EnvironmentAssets already caps at 4096).
                _ => self.default_group.clone(),
            };
            let image = match kept {
                Some(kind) => SkyImage {
                    source: image.source.clone(),
                    kind,
                    hdr: image.hdr,
                    mean_upper: image.mean_upper,
                    mean_lower: image.mean_lower,
                    brightest: image.brightest,
                },
                None => image.clone(),
            };
            self.images.push((group, image));
            self.image_views.push(equirect);
        }
    }
}

pub(super) fn make_bind_group(
    device: &wgpu::Device,
    layout: &wgpu::BindGroupLayout,
    uniforms: &wgpu::Buffer,
    (sampler, half_sampler): (&wgpu::Sampler, &wgpu::Sampler),
    label: &str,
    [equirect, cube, half]: [&wgpu::TextureView; 3],
) -> wgpu::BindGroup {
    device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some(label),
        layout,
        entries: &[
            wgpu::BindGroupEntry {
                binding: 0,
                resource: uniforms.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 1,
                resource: wgpu::BindingResource::TextureView(equirect),
            },
            wgpu::BindGroupEntry {
                binding: 2,
                resource: wgpu::BindingResource::TextureView(cube),
            },
            wgpu::BindGroupEntry {
                binding: 3,
                resource: wgpu::BindingResource::Sampler(sampler),
            },
            wgpu::BindGroupEntry {
                binding: 4,
                resource: wgpu::BindingResource::TextureView(half),
            },
            wgpu::BindGroupEntry {
                binding: 5,
                resource: wgpu::BindingResource::Sampler(half_sampler),
            },
        ],
    })
}

/// `planes` (red, green and blue `f32` planes of `size` texels) written
/// into `texture` (RGBA16F) as half floats, alpha 1.
pub(super) fn write_half_floats(
    queue: &wgpu::Queue,
    texture: &wgpu::Texture,
    size: (u32, u32),
    [r, g, b]: &[Vec<f32>; 3],
) {
    let rgba = r.iter().zip(g).zip(b);
    let texels: Vec<f32> = rgba.flat_map(|((r, g), b)| [*r, *g, *b, 1.0]).collect();
    let mut half = vec![half::f16::ZERO; texels.len()];
    half.convert_from_f32_slice(&texels);
    queue.write_texture(
        texture.as_image_copy(),
        bytemuck::cast_slice(&half),
        wgpu::TexelCopyBufferLayout {
            offset: 0,
            bytes_per_row: Some(size.0 * 8),
            rows_per_image: Some(size.1),
        },
        wgpu::Extent3d {
            width: size.0,
            height: size.1,
            depth_or_array_layers: 1,
        },
    );
}
