//! Reading pixels back from the GPU, for every path of the renderer: the
//! row layout of a copy into a mappable buffer ([`padded_row`], [`Read`],
//! [`plan_reads`]), the copies ([`Readback::copy_from`], [`encode_reads`]),
//! waiting for one submission and mapping ([`read_mapped`], [`wait`]), and
//! pasting read rects into a frame's pixels ([`paste`]).
//!
//! Planning is CPU-only (the frame plan uses it without a GPU); the rest
//! takes the device.

use super::regions::Rect;
use super::{ReadbackError, RenderError};

/// Round `bytes` up to the copy row alignment.
pub(super) fn padded_row(bytes: u32) -> u32 {
    bytes.div_ceil(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT) * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT
}

/// One rect read back: the frame rect, where it is in the texture copied
/// (the atlas, or the frame itself), where its rows start in the readback
/// buffer, and their (padded) length in bytes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct Read {
    pub rect: Rect,
    pub origin: (u32, u32),
    pub offset: u64,
    pub row: u32,
}

/// Lay `rects` (`bpp` bytes a pixel; in the texture at `places`) out one
/// after the other in the readback buffer from `*size`, each starting on a
/// 256-byte boundary.
pub(super) fn plan_reads(
    rects: &[Rect],
    places: &[(u32, u32)],
    bpp: u32,
    size: &mut u64,
) -> Vec<Read> {
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
pub(super) fn encode_reads(
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

/// Paste RGBA8 `reads` from the mapped `bytes` into `rgba`, a frame `width`
/// pixels wide, at their frame rects.
pub(super) fn paste(bytes: &[u8], reads: &[Read], rgba: &mut [u8], width: u32) {
    let stride = width as usize * 4;
    for read in reads {
        let w = read.rect.width() as usize * 4;
        for y in 0..read.rect.height() as usize {
            let src = read.offset as usize + y * read.row as usize;
            let dst = (read.rect.y0 as usize + y) * stride + read.rect.x0 as usize * 4;
            rgba[dst..dst + w].copy_from_slice(&bytes[src..src + w]);
        }
    }
}

/// A mappable buffer of at least `size` bytes in `slot`: the one there when
/// it is large enough, else a new one of the next power of two.
pub(super) fn ensure_buffer(
    device: &wgpu::Device,
    slot: &mut Option<wgpu::Buffer>,
    label: &str,
    size: u64,
) {
    if size > 0 && slot.as_ref().is_none_or(|b| b.size() < size) {
        *slot = Some(device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: size.next_power_of_two(),
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        }));
    }
}

/// Wait for the GPU to finish `submitted`, reading nothing (the queue stays
/// in step with the CPU).
pub(super) fn wait(
    device: &wgpu::Device,
    submitted: wgpu::SubmissionIndex,
) -> Result<(), RenderError> {
    device
        .poll(wgpu::PollType::Wait {
            submission_index: Some(submitted),
            timeout: None,
        })
        .map(|_| ())
        .map_err(|e| ReadbackError::from(e).into())
}

/// Map the first `len` bytes of `buffer`, wait for the GPU to finish
/// `submitted` (only it: other renderers on the device keep their own
/// submissions in flight), hand the bytes to `f`, and unmap (the buffer is
/// reused by the next frame).
pub(super) fn read_mapped<T>(
    device: &wgpu::Device,
    submitted: wgpu::SubmissionIndex,
    buffer: &wgpu::Buffer,
    len: u64,
    f: impl FnOnce(&[u8]) -> T,
) -> Result<T, RenderError> {
    let slice = buffer.slice(..len);
    let (tx, rx) = std::sync::mpsc::channel();
    slice.map_async(wgpu::MapMode::Read, move |r| {
        let _ = tx.send(r);
    });
    wait(device, submitted)?;
    rx.recv()
        .map_err(ReadbackError::from)?
        .map_err(ReadbackError::from)?;
    let out = {
        let view = slice.get_mapped_range().map_err(ReadbackError::from)?;
        f(&view)
    };
    buffer.unmap();
    Ok(out)
}

/// A mappable buffer that receives a 4-byte-per-pixel texture with rows padded
/// to `COPY_BYTES_PER_ROW_ALIGNMENT`, and gives it back tightly packed.
pub(super) struct Readback {
    buffer: wgpu::Buffer,
    width: u32,
    height: u32,
    padded_row: u32,
}

impl Readback {
    pub(super) fn new(device: &wgpu::Device, label: &str, width: u32, height: u32) -> Self {
        let padded_row = padded_row(width * 4);
        let buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: u64::from(padded_row) * u64::from(height),
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        Self {
            buffer,
            width,
            height,
            padded_row,
        }
    }

    /// Record the copy of `texture` (same size, 4 bytes per pixel) into this buffer.
    pub(super) fn copy_from(&self, encoder: &mut wgpu::CommandEncoder, texture: &wgpu::Texture) {
        let whole = Read {
            rect: Rect::full(self.width, self.height),
            origin: (0, 0),
            offset: 0,
            row: self.padded_row,
        };
        encode_reads(encoder, texture, &self.buffer, &[whole]);
    }

    /// Wait for the GPU, map, and strip the row padding.
    pub(super) fn read(
        &self,
        device: &wgpu::Device,
        submitted: wgpu::SubmissionIndex,
    ) -> Result<Vec<u8>, RenderError> {
        let mut out = Vec::new();
        self.read_into(device, submitted, &mut out)?;
        Ok(out)
    }

    /// [`Readback::read`] into `out`, reusing its memory (a 4K image is
    /// 35 MB: fresh pages cost more than the copy).
    pub(super) fn read_into(
        &self,
        device: &wgpu::Device,
        submitted: wgpu::SubmissionIndex,
        out: &mut Vec<u8>,
    ) -> Result<(), RenderError> {
        let row = (self.width * 4) as usize;
        let len = u64::from(self.padded_row) * u64::from(self.height);
        read_mapped(device, submitted, &self.buffer, len, |view| {
            out.clear();
            out.reserve(row * self.height as usize);
            for y in 0..self.height as usize {
                let start = y * self.padded_row as usize;
                out.extend_from_slice(&view[start..start + row]);
            }
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rect(x0: u32, y0: u32, x1: u32, y1: u32) -> Rect {
        Rect { x0, y0, x1, y1 }
    }

    #[test]
    fn reads_are_aligned_and_disjoint() {
        let rects = [rect(0, 0, 3, 2), rect(10, 5, 77, 9), rect(1, 1, 2, 2)];
        let places = [(0, 0), (3, 0), (70, 0)];
        // Callers start at 0 or where the reads before them ended (aligned).
        let mut size = 256;
        let reads = plan_reads(&rects, &places, 8, &mut size);
        assert_eq!(reads.len(), 3);
        let mut end = 256;
        for (read, r) in reads.iter().zip(&rects) {
            assert!(read.offset >= end, "overlaps the read before");
            assert_eq!(read.offset % 256, 0, "copy offsets are 256-byte aligned");
            assert_eq!(read.row % wgpu::COPY_BYTES_PER_ROW_ALIGNMENT, 0);
            assert!(read.row >= r.width() * 8);
            end = read.offset + u64::from(read.row) * u64::from(r.height());
        }
        assert!(size >= end);
    }

    #[test]
    fn paste_puts_each_rect_at_its_place() {
        let r = rect(1, 1, 3, 2); // 2×1 pixels
        let mut size = 0;
        let reads = plan_reads(&[r], &[(0, 0)], 4, &mut size);
        let mut bytes = vec![0u8; size as usize];
        bytes[..8].copy_from_slice(&[1, 2, 3, 4, 5, 6, 7, 8]);
        let mut rgba = vec![9u8; 4 * 4 * 3];
        paste(&bytes, &reads, &mut rgba, 4);
        let row1 = &rgba[16..32];
        assert_eq!(row1, &[9, 9, 9, 9, 1, 2, 3, 4, 5, 6, 7, 8, 9, 9, 9, 9]);
        assert!(rgba[..16].iter().chain(&rgba[32..]).all(|&b| b == 9));
    }
}
