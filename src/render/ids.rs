//! The instance-id layer: its multisampled target, and the reduction of that
//! target to per-drone visibility on the GPU (`shaders/id_reduce.wgsl`), so
//! no id image is read back, only 20 bytes per drone.
//!
//! The id target is drawn in the colour pass (a second colour attachment of
//! the drone pipeline, same fragment shader, same samples), so the ids follow
//! the colour pass's sample pattern by construction: alpha-cutoff fragments
//! discard in both, and a pixel "shows" a drone when any of its samples does.
//! The format is `R32Float` holding the id (exact below 2^24): WebGPU
//! guarantees 4× multisampling for it, not for `R32Uint`.

use std::borrow::Cow;

use super::regions::Rect;
use super::{RenderError, read_mapped};

/// Format of the id target.
pub(super) const ID_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R32Float;
/// Ids are stored as f32: exact up to this many drones.
pub const MAX_DRONES: usize = 1 << 24;
/// Side of the square tiles of the reduction (the compute workgroup).
const TILE: u32 = 8;
/// Words per drone in a stats block: count, !x0, !y0, x1, y1.
const WORDS: usize = 5;
/// Uniform blocks of the reduction are bound at offsets of this many bytes.
const PARAMS_STRIDE: u64 = 256;

/// The reduction shader for `samples` samples per pixel.
pub(super) fn reduce_source(samples: u32) -> String {
    let texture = if samples > 1 {
        "texture_multisampled_2d<f32>"
    } else {
        "texture_2d<f32>"
    };
    format!(
        "const SAMPLES: u32 = {samples}u;\nalias IdTexture = {texture};\n{}",
        include_str!("../../shaders/id_reduce.wgsl")
    )
}

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Params {
    tile_offset: u32,
    tile_count: u32,
    stats_base: u32,
    drones: u32,
}

/// Per-drone results of one reduction: pixel count and pixel box (exclusive ends).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct IdStats {
    pub pixels: u64,
    pub rect: Option<Rect>,
}

/// The reduction pipeline for one sample count, and its reused buffers.
pub(super) struct IdReducer {
    layout: wgpu::BindGroupLayout,
    pipeline: wgpu::ComputePipeline,
    tiles: Option<wgpu::Buffer>,
    params: Option<wgpu::Buffer>,
    stats: Option<wgpu::Buffer>,
    readback: Option<wgpu::Buffer>,
    /// This frame's dispatches: (params offset, tile count).
    dispatches: Vec<(u64, u32)>,
    stats_words: usize,
}

/// Grow `slot` to hold at least `size` bytes.
fn ensure_buffer(
    device: &wgpu::Device,
    slot: &mut Option<wgpu::Buffer>,
    label: &str,
    size: u64,
    usage: wgpu::BufferUsages,
) {
    if slot.as_ref().is_none_or(|b| b.size() < size) {
        *slot = Some(device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: size.max(256).next_power_of_two(),
            usage,
            mapped_at_creation: false,
        }));
    }
}

impl IdReducer {
    pub(super) fn new(device: &wgpu::Device, samples: u32) -> Self {
        let storage = |binding, read_only| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::COMPUTE,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Storage { read_only },
                has_dynamic_offset: false,
                min_binding_size: None,
            },
            count: None,
        };
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("id reduction layout"),
            entries: &[
                wgpu::BindGroupLayoutEntry {
                    binding: 0,
                    visibility: wgpu::ShaderStages::COMPUTE,
                    ty: wgpu::BindingType::Texture {
                        sample_type: wgpu::TextureSampleType::Float { filterable: false },
                        view_dimension: wgpu::TextureViewDimension::D2,
                        multisampled: samples > 1,
                    },
                    count: None,
                },
                storage(1, true),
                storage(2, false),
                wgpu::BindGroupLayoutEntry {
                    binding: 3,
                    visibility: wgpu::ShaderStages::COMPUTE,
                    ty: wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Uniform,
                        has_dynamic_offset: true,
                        min_binding_size: wgpu::BufferSize::new(
                            std::mem::size_of::<Params>() as u64
                        ),
                    },
                    count: None,
                },
            ],
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("id reduction pipeline layout"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("id_reduce.wgsl"),
            source: wgpu::ShaderSource::Wgsl(Cow::Owned(reduce_source(samples))),
        });
        let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("id reduction pipeline"),
            layout: Some(&pipeline_layout),
            module: &module,
            entry_point: Some("cs_main"),
            compilation_options: Default::default(),
            cache: None,
        });
        Self {
            layout,
            pipeline,
            tiles: None,
            params: None,
            stats: None,
            readback: None,
            dispatches: Vec::new(),
            stats_words: 0,
        }
    }

    /// Upload the tiles of each reduction of this frame: `passes[k]` is
    /// reduced into stats block `blocks[k]` (of `drones` drones each).
    pub(super) fn prepare(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        drones: usize,
        passes: &[(&[Rect], u32)],
        blocks: u32,
    ) {
        let mut tiles: Vec<[u32; 4]> = Vec::new();
        let mut params: Vec<u8> = Vec::new();
        self.dispatches.clear();
        for (k, (rects, block)) in passes.iter().enumerate() {
            let offset = tiles.len() as u32;
            tiles.extend(rects.iter().flat_map(|r| r.tiles(TILE)));
            let p = Params {
                tile_offset: offset,
                tile_count: tiles.len() as u32 - offset,
                stats_base: block * (drones * WORDS) as u32,
                drones: drones as u32,
            };
            params.resize(k * PARAMS_STRIDE as usize, 0);
            params.extend_from_slice(bytemuck::bytes_of(&p));
            self.dispatches
                .push((k as u64 * PARAMS_STRIDE, p.tile_count));
        }
        if tiles.is_empty() {
            tiles.push([0; 4]);
        }
        self.stats_words = drones * WORDS * blocks as usize;
        let stats_bytes = (self.stats_words as u64 * 4).max(4);
        let storage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST;
        ensure_buffer(
            device,
            &mut self.tiles,
            "id reduction tiles",
            (tiles.len() * 16) as u64,
            storage,
        );
        ensure_buffer(
            device,
            &mut self.params,
            "id reduction params",
            params.len().max(1) as u64,
            wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        );
        ensure_buffer(
            device,
            &mut self.stats,
            "id reduction stats",
            stats_bytes,
            storage | wgpu::BufferUsages::COPY_SRC,
        );
        ensure_buffer(
            device,
            &mut self.readback,
            "id reduction readback",
            stats_bytes,
            wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        );
        if let Some(b) = &self.tiles {
            queue.write_buffer(b, 0, bytemuck::cast_slice(&tiles));
        }
        if let (Some(b), false) = (&self.params, params.is_empty()) {
            queue.write_buffer(b, 0, &params);
        }
    }

    /// Zero the stats (before the first reduction of the frame).
    pub(super) fn encode_clear(&self, encoder: &mut wgpu::CommandEncoder) {
        if let Some(stats) = &self.stats {
            encoder.clear_buffer(
                stats,
                0,
                Some((self.stats_words as u64 * 4).max(4).next_multiple_of(4)),
            );
        }
    }

    /// Reduce the id target (`ids`, this reducer's sample count) over pass `k`'s tiles.
    pub(super) fn encode_reduce(
        &self,
        device: &wgpu::Device,
        encoder: &mut wgpu::CommandEncoder,
        ids: &wgpu::TextureView,
        k: usize,
    ) {
        let (Some(tiles), Some(params), Some(stats), Some(&(offset, count))) = (
            &self.tiles,
            &self.params,
            &self.stats,
            self.dispatches.get(k),
        ) else {
            return;
        };
        if count == 0 {
            return;
        }
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("id reduction"),
            layout: &self.layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: wgpu::BindingResource::TextureView(ids),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: tiles.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: stats.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 3,
                    resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                        buffer: params,
                        offset: 0,
                        size: wgpu::BufferSize::new(std::mem::size_of::<Params>() as u64),
                    }),
                },
            ],
        });
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("id reduction pass"),
            timestamp_writes: None,
        });
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &group, &[offset as u32]);
        pass.dispatch_workgroups(count.min(65535), count.div_ceil(65535), 1);
    }

    /// Copy the stats into the mappable buffer (after the last reduction).
    pub(super) fn encode_copy(&self, encoder: &mut wgpu::CommandEncoder) {
        if let (Some(stats), Some(readback)) = (&self.stats, &self.readback)
            && self.stats_words > 0
        {
            encoder.copy_buffer_to_buffer(stats, 0, readback, 0, self.stats_words as u64 * 4);
        }
    }

    /// The mappable buffer and the bytes of this frame in it.
    pub(super) fn readback(&self) -> Option<(&wgpu::Buffer, u64)> {
        self.readback
            .as_ref()
            .filter(|_| self.stats_words > 0)
            .map(|b| (b, self.stats_words as u64 * 4))
    }

    /// Decode block `block` of mapped stats words.
    pub(super) fn decode(words: &[u32], drones: usize, block: usize) -> Vec<IdStats> {
        let base = block * drones * WORDS;
        (0..drones)
            .map(|i| {
                let w = &words[base + i * WORDS..base + (i + 1) * WORDS];
                IdStats {
                    pixels: u64::from(w[0]),
                    rect: (w[0] > 0).then(|| Rect {
                        x0: !w[1],
                        y0: !w[2],
                        x1: w[3],
                        y1: w[4],
                    }),
                }
            })
            .collect()
    }
}

/// Map `buffer[..len]`, wait, and copy it out as u32 words.
pub(super) fn read_words(
    device: &wgpu::Device,
    submitted: wgpu::SubmissionIndex,
    buffer: &wgpu::Buffer,
    len: u64,
) -> Result<Vec<u32>, RenderError> {
    let bytes = read_mapped(device, submitted, buffer, len, |b| b.to_vec())?;
    Ok(bytemuck::pod_collect_to_vec(&bytes))
}
