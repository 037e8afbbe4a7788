//! The id layer of a target set: the instance-id target the passes draw
//! (drone index + 1 per sample, see [`super::ids`]), its resolves (MSAA:
//! the samples side by side into its atlas), and the reduction of its reads
//! to per-drone visibility (where they land in the readback buffer is the
//! frame plan's, [`super::plan`]).
//!
//! Like a picking layer, it rides along with the colour pass: the same
//! draws write both, so the ids follow the picture's samples by construction.

use super::ids::{self, IdStats, PixelHit, Tally};
use super::readback::Read;
use super::visibility::Visibility;
use super::{IdImage, RenderError};
use crate::scene::projection::PixelBox;

/// The id target of one size and sample count.
pub(super) struct IdLayer {
    texture: wgpu::Texture,
    view: wgpu::TextureView,
    /// Where the resolves write each pixel's id samples side by side (MSAA
    /// only): as many rows as the colour atlas, built on first use.
    atlas: Option<(wgpu::Texture, wgpu::TextureView)>,
}

/// Resolves that write a pixel's id samples side by side (`resolve.wgsl`),
/// built on first use: presets that need no visibility never build them.
pub(super) struct IdResolve {
    /// Ids only (overlap layers, frames without colour).
    pub ids: wgpu::RenderPipeline,
    /// Colour and ids in one pass (the main pass of a frame with both).
    pub color_ids: wgpu::RenderPipeline,
}

impl IdResolve {
    /// Both resolves, from `build(label, fragment entry, targets)`.
    pub(super) fn new(
        build: impl Fn(&str, &str, &[Option<wgpu::ColorTargetState>]) -> wgpu::RenderPipeline,
    ) -> Self {
        let color = super::gpu::color_target(super::COLOR_FORMAT);
        let id_samples = super::gpu::color_target(ids::ID_SAMPLES_FORMAT);
        Self {
            ids: build(
                "region id resolve pipeline",
                "fs_ids",
                &[None, id_samples.clone()],
            ),
            color_ids: build(
                "region colour + id resolve pipeline",
                "fs_main_ids",
                &[color, id_samples],
            ),
        }
    }
}

impl IdLayer {
    /// The id target of `width`×`height` pixels and `msaa` samples: drawn,
    /// read by the resolves, copied back.
    pub(super) fn new(device: &wgpu::Device, (width, height): (u32, u32), msaa: u32) -> Self {
        let texture = super::gpu::texture_2d(
            device,
            "instance ids",
            (width, height),
            (ids::ID_FORMAT, msaa),
            wgpu::TextureUsages::RENDER_ATTACHMENT
                | wgpu::TextureUsages::TEXTURE_BINDING
                | wgpu::TextureUsages::COPY_SRC,
        );
        let view = texture.create_view(&Default::default());
        Self {
            texture,
            view,
            atlas: None,
        }
    }

    /// An atlas of `size` (width, rows) for the resolved id samples, unless one is there.
    pub(super) fn ensure_atlas(&mut self, device: &wgpu::Device, size: (u32, u32)) {
        if self.atlas.is_none() {
            let label = "resolve atlas (id samples)";
            let format = ids::ID_SAMPLES_FORMAT;
            self.atlas = Some(super::gpu::atlas_texture(device, label, format, size));
        }
    }

    /// Drop the atlas (the colour atlas grows); returns whether there was one.
    pub(super) fn drop_atlas(&mut self) -> bool {
        self.atlas.take().is_some()
    }

    /// Where the resolves write the id samples (MSAA only).
    pub(super) fn atlas_view(&self) -> Option<&wgpu::TextureView> {
        self.atlas.as_ref().map(|(_, view)| view)
    }

    /// The texture the ids are read from: the atlas when the passes are
    /// resolved (MSAA), the id target itself otherwise.
    pub(super) fn read_source(&self, resolved: bool) -> Option<&wgpu::Texture> {
        if resolved {
            self.atlas.as_ref().map(|(texture, _)| texture)
        } else {
            Some(&self.texture)
        }
    }

    pub(super) fn view(&self) -> &wgpu::TextureView {
        &self.view
    }

    /// The id target: copied from directly without MSAA.
    pub(super) fn texture(&self) -> &wgpu::Texture {
        &self.texture
    }
}

/// An id image read back whole (f32 ids, tightly packed).
pub(super) fn id_image(bytes: &[u8], width: u32, height: u32) -> IdImage {
    let values: Vec<f32> = bytemuck::pod_collect_to_vec(bytes);
    IdImage {
        width,
        height,
        ids: values.into_iter().map(|v| v as u32).collect(),
    }
}

/// Per-drone tallies of a frame's id reads: what the frame shows of each
/// drone (the main pass) and what it shows alone (the overlap layers).
pub(super) struct IdCollect {
    msaa: u32,
    seen: Vec<Tally>,
    alone: Vec<Tally>,
    hits: Option<Vec<PixelHit>>,
}

impl IdCollect {
    /// Tallies for `drones` drones of `msaa` samples, keeping each visible
    /// pixel's drones when `hits`.
    pub(super) fn new(drones: usize, msaa: u32, hits: bool) -> Self {
        Self {
            msaa,
            seen: vec![Tally::default(); drones],
            alone: vec![Tally::default(); drones],
            hits: hits.then(Vec::new),
        }
    }

    /// Count the mapped `bytes` of `reads` (per pass: the main pass first,
    /// then the layers).
    pub(super) fn add(&mut self, bytes: &[u8], reads: &[Vec<Read>]) {
        let n = self.seen.len();
        for (k, reads) in reads.iter().enumerate() {
            let tallies = if k == 0 {
                &mut self.seen
            } else {
                &mut self.alone
            };
            for read in reads {
                let bytes = &bytes[read.offset as usize..];
                let row = read.row as usize;
                if let (0, Some(hits)) = (k, self.hits.as_mut()) {
                    ids::collect_hits(bytes, row, &read.rect, self.msaa, n, hits);
                }
                ids::tally(bytes, row, &read.rect, self.msaa, tallies);
            }
        }
    }

    /// Count the mapped `bytes` of `reads` (per pass) as what the drones
    /// show alone: the layer passes of a plan of their own.
    pub(super) fn add_alone(&mut self, bytes: &[u8], reads: &[Vec<Read>]) {
        for read in reads.iter().flatten() {
            let bytes = &bytes[read.offset as usize..];
            ids::tally(
                bytes,
                read.row as usize,
                &read.rect,
                self.msaa,
                &mut self.alone,
            );
        }
    }

    /// Count `pixels` as what drone `drone` shows alone (the footprint pass).
    pub(super) fn add_alone_pixels(&mut self, drone: usize, pixels: u64) {
        if let Some(t) = self.alone.get_mut(drone) {
            t.add_count(pixels);
        }
    }

    /// Each drone's visibility (drones that overlap no other, `!overlapping[i]`,
    /// are alone in the main pass) and the pixel hits, when kept.
    pub(super) fn finish(self, overlapping: &[bool]) -> (Vec<Visibility>, Option<Vec<PixelHit>>) {
        let visibility = (self.seen.iter().zip(&self.alone).zip(overlapping))
            .map(|((seen, alone), &overlapping)| {
                let seen = seen.stats();
                visibility_of(seen, if overlapping { alone.stats() } else { seen })
            })
            .collect();
        (visibility, self.hits)
    }
}

fn visibility_of(seen: IdStats, alone: IdStats) -> Visibility {
    Visibility {
        visible_box: seen.rect.map(|r| PixelBox {
            x0: f64::from(r.x0),
            y0: f64::from(r.y0),
            x1: f64::from(r.x1),
            y1: f64::from(r.y1),
        }),
        visible_pixels: seen.pixels,
        unoccluded_pixels: alone.pixels,
    }
}

/// The error for frames with more drones than ids can tell apart.
pub(super) fn check_drones(count: usize) -> Result<(), RenderError> {
    if count >= ids::MAX_DRONES {
        return Err(RenderError::TooManyDrones {
            count,
            limit: ids::MAX_DRONES - 1,
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::regions::Rect;

    #[test]
    fn unoccluded_counts_come_from_the_layers_only_for_overlapping_drones() {
        // One pixel row of two pixels, single-sample: drone 1 then drone 2 in
        // the main pass; drone 1 alone covers both pixels in its layer.
        let rect = Rect {
            x0: 0,
            y0: 0,
            x1: 2,
            y1: 1,
        };
        let main = [1.0f32, 2.0];
        let layer = [1.0f32, 1.0];
        let mut bytes = vec![0u8; 512];
        bytes[..8].copy_from_slice(bytemuck::cast_slice(&main));
        bytes[256..264].copy_from_slice(bytemuck::cast_slice(&layer));
        let read = |offset| Read {
            rect,
            origin: (0, 0),
            offset,
            row: 256,
        };
        let mut collect = IdCollect::new(2, 1, true);
        collect.add(&bytes, &[vec![read(0)], vec![read(256)]]);
        let (vis, hits) = collect.finish(&[true, false]);
        assert_eq!(vis[0].visible_pixels, 1);
        assert_eq!(vis[0].unoccluded_pixels, 2, "from the layer pass");
        assert_eq!(vis[1].visible_pixels, 1);
        assert_eq!(vis[1].unoccluded_pixels, 1, "alone in the main pass");
        assert_eq!(hits.map(|h| h.len()), Some(2), "one hit per shown pixel");
        assert!(check_drones(ids::MAX_DRONES).is_err());
        assert!(check_drones(ids::MAX_DRONES - 1).is_ok());
    }
}
