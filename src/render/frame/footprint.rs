//! Unoccluded pixel counts in one pass ([`Footprints`]): the drones whose
//! counts the main pass cannot give are drawn again all at once, with no
//! depth test and no attachment written, and each fragment that keeps a
//! sample sets its pixel's bit in its drone's own bitmask (one bit per
//! pixel of the drone's rect, in a storage buffer; `drone.wgsl`,
//! `fs_footprint`). A drone's count is its bits' popcount: the pixels of
//! its rect where any sample shows it when nothing is in front, with the
//! same rasterisation, coverage masks and alpha discards as an overlap
//! layer drawn alone (`layers.rs`), for every overlap layer at once. Meshes
//! stay inside their rects, so their counts are the layers' to the byte; an
//! impostor's filtered edge can reach a pixel past its rect, which a layer
//! counted where the layer's merged rects reached it (15 000 impostors, 3
//! frames: 3 of 45 000 counts one pixel lower, no status changed).
//!
//! Adapters whose fragment shaders cannot write storage (the GL backend)
//! keep the layer passes ([`Footprints::supported`]).

use crate::render::RenderError;
use crate::render::gpu::{PipelineFactory, depth_test};
use crate::render::id_layer::IdCollect;
use crate::render::mesh::DronePipelines;
use crate::render::readback;
use crate::render::regions::Rect;
use crate::render::targets::FrameTargets;
use crate::render::{DEPTH_FORMAT, InstanceRaw};
use crate::scene::FrameScene;

use super::passes::PassInputs;

/// One drone's entry in the footprint table (`drone.wgsl`, `Footprint`):
/// its rect (x0, y0, x1, y1; empty for drones not counted) and where its
/// bits begin, in 32-bit words (`offset[0]`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
struct Entry {
    rect: [u32; 4],
    offset: [u32; 4],
}

/// The footprint pass's bind group layout (`@group(2)`), pipelines per
/// sample count, and buffers (reused, grown as needed).
pub(super) struct Footprints {
    layout: wgpu::BindGroupLayout,
    pipelines: Vec<(u32, DronePipelines)>,
    table: Option<wgpu::Buffer>,
    bits: Option<wgpu::Buffer>,
    readback: Option<wgpu::Buffer>,
}

impl Footprints {
    /// Whether `backend`'s fragment shaders write storage buffers (every
    /// backend but GL).
    pub(super) fn supported(backend: wgpu::Backend) -> bool {
        backend != wgpu::Backend::Gl
    }

    pub(super) fn new(factory: &PipelineFactory) -> Self {
        let entry = |binding, read_only| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::FRAGMENT,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Storage { read_only },
                has_dynamic_offset: false,
                min_binding_size: None,
            },
            count: None,
        };
        Self {
            layout: factory
                .bind_group_layout("footprint layout", &[entry(0, true), entry(1, false)]),
            pipelines: Vec::new(),
            table: None,
            bits: None,
            readback: None,
        }
    }

    /// Count the pixels each drone `alone` names covers by itself (its
    /// rect in `rects`) into `ids`, drawn into `target`'s sample count;
    /// returns the passes drawn (0 when no drone is named), or `None`
    /// (nothing counted) when the bitmasks outgrow a storage buffer.
    pub(super) fn measure(
        &mut self,
        with: &mut PassInputs<'_>,
        target: &FrameTargets,
        scene: &FrameScene,
        (rects, alone): (&[Option<Rect>], &[bool]),
        ids: &mut IdCollect,
    ) -> Result<Option<u64>, RenderError> {
        let (entries, words) = table(rects, alone);
        if words == 0 {
            return Ok(Some(0));
        }
        let limit = with.device.limits().max_storage_buffer_binding_size;
        let table_size = std::mem::size_of_val(&entries[..]) as u64;
        if words > u64::from(u32::MAX) || words * 4 > limit || table_size > limit {
            return Ok(None);
        }
        let named = (0..alone.len()).filter(|&i| alone[i] && rects[i].is_some());
        let mut data: Vec<InstanceRaw> = Vec::new();
        let ranges = with.drones.instances(scene, named, &mut data);
        let (device, queue) = (with.device, with.queue);
        with.drones.upload_instances((device, queue), &data);
        let p = self.pipelines_for(with, target.msaa);
        let size = words * 4;
        let table_bytes: &[u8] = bytemuck::cast_slice(&entries);
        let usage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST;
        let table = grown(
            device,
            &mut self.table,
            "footprint table",
            table_size,
            usage,
        );
        queue.write_buffer(&table, 0, table_bytes);
        let usage = usage | wgpu::BufferUsages::COPY_SRC;
        let bits = grown(device, &mut self.bits, "footprint bits", size, usage);
        readback::ensure_buffer(device, &mut self.readback, "footprint readback", size);
        let Some(out) = self.readback.clone() else {
            return Ok(None);
        };
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("footprint group"),
            layout: &self.layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: table.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: bits.as_entire_binding(),
                },
            ],
        });
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("footprints"),
        });
        encoder.clear_buffer(&bits, 0, Some(size));
        {
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("footprint pass"),
                color_attachments: &[],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &target.depth,
                    depth_ops: Some(wgpu::Operations {
                        load: wgpu::LoadOp::Load,
                        store: wgpu::StoreOp::Store,
                    }),
                    stencil_ops: None,
                }),
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            pass.set_bind_group(0, with.frame_group, &[]);
            pass.set_bind_group(2, &group, &[]);
            with.drones.draw(&mut pass, &self.pipelines[p].1, &ranges);
        }
        encoder.copy_buffer_to_buffer(&bits, 0, &out, 0, size);
        let submitted = queue.submit([encoder.finish()]);
        readback::read_mapped(device, submitted, &out, size, |bytes| {
            for (i, e) in entries.iter().enumerate() {
                let (start, end) = (e.offset[0] as usize * 4, e.offset[1] as usize * 4);
                let drone_bits = bytes.get(start..end).unwrap_or(&[]);
                if start < end {
                    ids.add_alone_pixels(i, popcount(drone_bits));
                }
            }
        })?;
        Ok(Some(1))
    }

    /// The index of the footprint pipelines for `msaa` samples, built on first use.
    fn pipelines_for(&mut self, with: &PassInputs<'_>, msaa: u32) -> usize {
        if let Some(i) = self.pipelines.iter().position(|(m, _)| *m == msaa) {
            return i;
        }
        let depth = depth_test(DEPTH_FORMAT, false, wgpu::CompareFunction::Always);
        let pipelines = (with.drones).footprint_pipelines(with.factory, msaa, &self.layout, depth);
        self.pipelines.push((msaa, pipelines));
        self.pipelines.len() - 1
    }
}

/// The footprint table of the drones `alone` names (scene order; the
/// others' entries empty) and the 32-bit words their bitmasks take: one bit
/// per pixel of a drone's rect, row by row, each drone's from a new word.
/// `offset[1]` is where a drone's bits end.
fn table(rects: &[Option<Rect>], alone: &[bool]) -> (Vec<Entry>, u64) {
    let mut words = 0u64;
    let entries = (rects.iter().zip(alone))
        .map(|(rect, &named)| match rect.filter(|_| named) {
            Some(r) => {
                let start = words;
                words += (u64::from(r.width()) * u64::from(r.height())).div_ceil(32);
                // Past u32 words the caller counts in layer passes instead.
                let word = |w: u64| u32::try_from(w).unwrap_or(u32::MAX);
                Entry {
                    rect: [r.x0, r.y0, r.x1, r.y1],
                    offset: [word(start), word(words), 0, 0],
                }
            }
            None => Entry::default(),
        })
        .collect();
    (entries, words)
}

/// Set bits in little-endian 32-bit words.
fn popcount(bytes: &[u8]) -> u64 {
    (bytes.chunks_exact(4))
        .map(|w| u64::from(u32::from_le_bytes([w[0], w[1], w[2], w[3]]).count_ones()))
        .sum()
}

/// A buffer of at least `size` bytes with `usage` in `slot` (the one there
/// when large enough, else a new one of the next power of two).
fn grown(
    device: &wgpu::Device,
    slot: &mut Option<wgpu::Buffer>,
    label: &str,
    size: u64,
    usage: wgpu::BufferUsages,
) -> wgpu::Buffer {
    match slot {
        Some(b) if b.size() >= size => b.clone(),
        _ => {
            let buffer = device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: size.next_power_of_two().max(16),
                usage,
                mapped_at_creation: false,
            });
            *slot = Some(buffer.clone());
            buffer
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_named_drone_gets_its_own_words_and_bits_count_once() {
        let r = |x0, y0, x1, y1| Some(Rect { x0, y0, x1, y1 });
        // 10×4 = 40 px: 2 words; 33×1: 2 words; the unnamed and the rectless none.
        let rects = [r(0, 0, 10, 4), r(5, 5, 6, 6), r(0, 0, 33, 1), None];
        let (entries, words) = table(&rects, &[true, false, true, true]);
        assert_eq!(words, 4);
        assert_eq!(entries[0].offset[..2], [0, 2]);
        assert_eq!(entries[1].offset[..2], [0, 0], "not named: empty");
        assert_eq!(entries[1].rect, [0; 4]);
        assert_eq!(entries[2].offset[..2], [2, 4]);
        assert_eq!(entries[2].rect, [0, 0, 33, 1]);
        assert_eq!(entries[3].offset[..2], [0, 0]);
        let words: [u32; 2] = [0b1011, 1 << 31];
        assert_eq!(popcount(bytemuck::cast_slice(&words)), 4);
    }
}
