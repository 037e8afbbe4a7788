//! Impostors on the GPU ([`GpuImpostor`]): a model's baked quads and atlas
//! ([`crate::model::impostor`]) uploaded once, and the instanced draw of
//! the drones shown through one of its directions. The drone pipelines draw
//! them (textured, alpha as MSAA coverage: `shaders/drone.wgsl`,
//! `coverage_mask`), so colour, ids and depth come as a mesh's do.

use std::ops::Range;

use glam::DVec3;
use wgpu::util::DeviceExt;

use super::material;
use crate::model::impostor::Impostor;

/// One model's impostor on the GPU.
pub(super) struct GpuImpostor {
    vertices: wgpu::Buffer,
    indices: wgpu::Buffer,
    atlas: wgpu::BindGroup,
    /// Model-space directions towards the viewer, one per quad.
    directions: Vec<DVec3>,
}

impl GpuImpostor {
    /// Upload `impostor`'s quads and atlas (its material bound by `layout`).
    pub(super) fn new(
        (device, queue): (&wgpu::Device, &wgpu::Queue),
        layout: &wgpu::BindGroupLayout,
        impostor: &Impostor,
    ) -> Self {
        let label = &impostor.atlas.name;
        Self {
            vertices: device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents: bytemuck::cast_slice(&impostor.vertices),
                usage: wgpu::BufferUsages::VERTEX,
            }),
            indices: device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents: bytemuck::cast_slice(&impostor.indices),
                usage: wgpu::BufferUsages::INDEX,
            }),
            atlas: material::upload(device, queue, layout, &impostor.atlas, label),
            directions: impostor.directions.clone(),
        }
    }

    /// The direction whose quad shows a drone seen from `towards_viewer`
    /// (model space): the nearest baked one.
    pub(super) fn nearest(&self, towards_viewer: DVec3) -> usize {
        crate::model::impostor::nearest(&self.directions, towards_viewer)
    }

    /// Draw `instances` (uploaded, bound at slot 1) as direction `k`'s quad,
    /// with the impostor pipeline already set.
    pub(super) fn draw(&self, pass: &mut wgpu::RenderPass<'_>, k: usize, instances: Range<u32>) {
        let first = k as u32 * 6;
        pass.set_vertex_buffer(0, self.vertices.slice(..));
        pass.set_index_buffer(self.indices.slice(..), wgpu::IndexFormat::Uint32);
        pass.set_bind_group(1, &self.atlas, &[]);
        pass.draw_indexed(first..first + 6, 0, instances);
    }
}
