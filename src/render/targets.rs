//! The full-size targets of one size and sample count, allocated once and
//! never cleared: colour (multisampled with MSAA, else single-sample), the
//! instance ids ([`IdLayer`]), depth, the cached background
//! ([`BackgroundCache`]), the atlas the resolves write and the readbacks.
//! The region passes draw into them ([`super::frame`]); what is in them is
//! the passes' business, not theirs.

use super::background::BackgroundCache;
use super::gpu;
use super::id_layer::IdLayer;
use super::readback::Readback;
use super::{COLOR_FORMAT, DEPTH_FORMAT};

/// Full-size targets of one size and sample count, and the cached background.
pub(super) struct FrameTargets {
    pub(super) width: u32,
    pub(super) height: u32,
    pub(super) msaa: u32,
    pub(super) msaa_color: Option<wgpu::TextureView>,
    /// The single-sample colour target MSAA 1 draws into.
    pub(super) single: Option<(wgpu::Texture, wgpu::TextureView)>,
    /// The instance ids the passes draw, resolve and read back.
    pub(super) ids: IdLayer,
    pub(super) depth: wgpu::TextureView,
    /// The cached background of this size.
    pub(super) background: BackgroundCache,
    /// Binds the multisampled colour and ids for the resolves (MSAA only).
    pub(super) resolve_group: Option<wgpu::BindGroup>,
    /// Where the resolves write (MSAA only).
    pub(super) atlas: Atlas,
    /// Full-frame readback (id images).
    pub(super) readback: Readback,
    /// Readback of the regions (colour and ids), grown as needed and reused.
    pub(super) regions_readback: Option<wgpu::Buffer>,
}

/// The bind group layouts the targets are bound with: the background (the
/// region passes' "clear") and the resolves' multisampled inputs.
pub(super) struct TargetLayouts<'l> {
    pub background: &'l wgpu::BindGroupLayout,
    pub resolve: &'l wgpu::BindGroupLayout,
}

impl FrameTargets {
    /// The targets of `width`×`height` pixels and `msaa` samples.
    pub(super) fn new(
        device: &wgpu::Device,
        (width, height): (u32, u32),
        msaa: u32,
        layouts: TargetLayouts<'_>,
    ) -> Self {
        let texture = |label: &str, format, samples, usage| {
            super::gpu::texture_2d(device, label, (width, height), (format, samples), usage)
        };
        let attachment = wgpu::TextureUsages::RENDER_ATTACHMENT;
        let copy = wgpu::TextureUsages::COPY_SRC;
        let bind = wgpu::TextureUsages::TEXTURE_BINDING;
        let single = (msaa <= 1).then(|| {
            let color = texture("region colour", COLOR_FORMAT, 1, attachment | copy);
            let view = color.create_view(&Default::default());
            (color, view)
        });
        let msaa_color = (msaa > 1).then(|| {
            texture(
                "region colour (msaa)",
                COLOR_FORMAT,
                msaa,
                attachment | bind,
            )
            .create_view(&Default::default())
        });
        let ids = IdLayer::new(device, (width, height), msaa);
        let depth = texture("region depth", DEPTH_FORMAT, msaa, attachment)
            .create_view(&Default::default());
        let background = BackgroundCache::new(device, layouts.background, width, height);
        let resolve_group = msaa_color.as_ref().map(|color| {
            device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("region resolve"),
                layout: layouts.resolve,
                entries: &[
                    wgpu::BindGroupEntry {
                        binding: 0,
                        resource: wgpu::BindingResource::TextureView(color),
                    },
                    wgpu::BindGroupEntry {
                        binding: 1,
                        resource: wgpu::BindingResource::TextureView(ids.view()),
                    },
                ],
            })
        });
        Self {
            width,
            height,
            msaa,
            msaa_color,
            single,
            ids,
            depth,
            background,
            resolve_group,
            atlas: Atlas::default(),
            readback: Readback::new(device, "frame readback (full)", width, height),
            regions_readback: None,
        }
    }

    /// An atlas of at least `rows` rows (of `width` pixels) for the colour
    /// when `color` and for the id samples when `ids`.
    pub(super) fn ensure_atlas(
        &mut self,
        device: &wgpu::Device,
        size: (u32, u32),
        asked: (bool, bool),
    ) {
        self.atlas.ensure(device, size, asked, &mut self.ids);
    }

    /// The colour view the region passes draw into: multisampled with MSAA,
    /// else the single-sample target.
    pub(super) fn color_view(&self) -> Option<&wgpu::TextureView> {
        (self.msaa_color.as_ref()).or(self.single.as_ref().map(|(_, view)| view))
    }
}

#[cfg(test)]
thread_local! {
    /// Tests: targets made on this thread are first filled with values no
    /// pass writes ([`FrameTargets::fill_with_garbage`]), as a stale target
    /// or uncleared memory may hold.
    pub(super) static GARBAGE: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

#[cfg(test)]
impl FrameTargets {
    /// Colour, ids and depth cleared to values no pass writes: a frame that
    /// read a texel no pass of its own wrote would show them.
    pub(super) fn fill_with_garbage(&self, device: &wgpu::Device, queue: &wgpu::Queue) {
        let ops = |r: f64, g: f64| wgpu::Operations {
            load: wgpu::LoadOp::Clear(wgpu::Color {
                r,
                g,
                b: 0.6,
                a: 0.3,
            }),
            store: wgpu::StoreOp::Store,
        };
        let attachment = |view, ops| {
            Some(wgpu::RenderPassColorAttachment {
                view,
                depth_slice: None,
                resolve_target: None,
                ops,
            })
        };
        let mut encoder = device.create_command_encoder(&Default::default());
        encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("garbage"),
            color_attachments: &[
                self.color_view()
                    .and_then(|view| attachment(view, ops(0.9, 0.1))),
                attachment(self.ids.view(), ops(7.0, 0.0)),
            ],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: &self.depth,
                depth_ops: Some(wgpu::Operations {
                    load: wgpu::LoadOp::Clear(0.37),
                    store: wgpu::StoreOp::Store,
                }),
                stencil_ops: None,
            }),
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        queue.submit([encoder.finish()]);
    }
}

/// The compact target the resolves write (MSAA only): a pass's rects packed
/// in shelves ([`super::regions::pack_shelves`]) as wide as the
/// frame and as tall as they need, the resolved colour here and the id
/// samples side by side in the id layer's atlas of the same rows
/// ([`IdLayer::atlas_view`]), copied from there into the readback buffer.
/// Passes reuse it one after the other; it grows as needed and never shrinks.
#[derive(Default)]
pub(super) struct Atlas {
    pub(super) rows: u32,
    pub(super) color: Option<(wgpu::Texture, wgpu::TextureView)>,
}

impl Atlas {
    /// At least `rows` rows (of `width` pixels) of the colour when `color`
    /// and of the id layer's atlas when `with_ids`.
    fn ensure(
        &mut self,
        device: &wgpu::Device,
        (width, rows): (u32, u32),
        (color, with_ids): (bool, bool),
        ids: &mut IdLayer,
    ) {
        if rows == 0 && self.rows == 0 {
            return; // nothing to resolve yet (a frame without drones)
        }
        let (mut color, mut with_ids) = (color, with_ids);
        if rows > self.rows {
            self.rows = rows.next_multiple_of(64);
            // Reallocated at the new size below, as far as still wanted.
            color |= self.color.take().is_some();
            with_ids |= ids.drop_atlas();
        }
        if color && self.color.is_none() {
            self.color = Some(gpu::atlas_texture(
                device,
                "resolve atlas (colour)",
                COLOR_FORMAT,
                (width, self.rows),
            ));
        }
        if with_ids {
            ids.ensure_atlas(device, (width, self.rows));
        }
    }
}

#[cfg(test)]
mod tests {
    use crate::pipeline::FramePipeline;
    use crate::preset::Preset;

    /// A renderer whose targets were made and first used before its sky was
    /// uploaded (`FramePipeline::frame_renderer`, the batch's) holds the
    /// preset's targets before its first frame, makes no others for it, and
    /// makes the same frames as one that makes them at its first frame; so
    /// does one taking the targets its context made ahead
    /// (`GpuContext::prepare_frame_targets`).
    #[test]
    fn prepared_targets_make_the_same_frames() {
        let ctx = crate::render::GpuContext::headless()
            .unwrap_or_else(|e| panic!("rendering tests need a GPU adapter (lavapipe): {e}"));
        let preset = Preset::from_ron(
            r#"(
            seed: 3,
            placement: Randomized(count: (4, 7), volume: Box(size_m: (6.0, 3.0, 20.0)), min_separation_m: 0.7),
            camera: (z: (start: 0.6, end: 0.6, step: 0.0)),
            repeats: 3,
            sky: Procedural(environment: Daytime),
            render: (resolution: Custom(width: 200, height: 120), msaa: 4),
            labels: (box_method: Visible, min_visible_fraction: 0.2),
        )"#,
        )
        .expect("preset");
        let pipeline = FramePipeline::new(preset).expect("pipeline");
        let mut plain = pipeline.renderer(&ctx);
        let mut prepared = pipeline.frame_renderer(&ctx);
        assert!(plain.target_shapes().is_empty());
        assert_eq!(prepared.target_shapes(), [(200, 120, 4)]);
        let mut labelled = false;
        for i in 0..pipeline.frame_count() {
            let a = pipeline.make(&mut plain, i).expect("frame");
            let b = pipeline.make(&mut prepared, i).expect("frame");
            assert!(a.rgba == b.rgba, "frame {i}: pixels differ");
            assert_eq!(a.labels, b.labels, "frame {i}: labels differ");
            labelled |= !a.labels.is_empty();
        }
        assert!(labelled, "no drone labelled");
        assert_eq!(prepared.target_shapes(), [(200, 120, 4)]);
        // Made ahead by the context: taken by the first frame of their
        // shape, the same frames again; another shape releases them.
        ctx.prepare_frame_targets((200, 120), 4);
        assert!(ctx.prepared.is_held());
        let mut taking = pipeline.renderer(&ctx);
        let first = pipeline.make(&mut taking, 0).expect("frame");
        assert!(!ctx.prepared.is_held());
        assert_eq!(taking.target_shapes(), [(200, 120, 4)]);
        assert!(first.rgba == pipeline.make(&mut plain, 0).expect("frame").rgba);
        ctx.prepare_frame_targets((64, 48), 1);
        assert!(ctx.prepared.is_held());
        pipeline
            .make(&mut pipeline.renderer(&ctx), 1)
            .expect("frame");
        assert!(!ctx.prepared.is_held());
        // A size the device cannot draw is not made.
        ctx.prepare_frame_targets((ctx.max_texture_side + 1, 8), 4);
        assert!(!ctx.prepared.is_held());
    }

    /// The frame's targets are never cleared (wgpu zeroes them once, before
    /// their first use): every texel a frame reads, one of its own passes
    /// wrote, whatever the frames before left there. So targets that
    /// start out holding values no pass writes give the same pixels, labels
    /// and masks, with and without MSAA, drones close and far, clutter in
    /// front of them and a full-frame id image (the occlusion counts).
    #[test]
    fn frames_never_read_what_their_passes_did_not_write() {
        let ctx = crate::render::GpuContext::headless()
            .unwrap_or_else(|e| panic!("rendering tests need a GPU adapter (lavapipe): {e}"));
        for msaa in [4, 1] {
            let preset = Preset::from_ron(&format!(
                r#"(
                seed: 11,
                placement: Randomized(count: (3, 6), volume: Box(size_m: (6.0, 3.0, 20.0)), min_separation_m: 0.7),
                camera: (z: (start: 0.6, end: 0.6, step: 0.0)),
                repeats: 3,
                sky: Procedural(environment: Daytime),
                render: (resolution: Custom(width: 192, height: 108), msaa: {msaa}),
                labels: (box_method: Visible, min_visible_fraction: 0.2),
                output: (masks: (coco_rle: true, instance_png: true)),
                clutter: Some((trees: (count: (2, 2), distance_m: (8.0, 12.0), height_m: (6.0, 8.0), branch_levels: 3))),
            )"#
            ))
            .expect("preset");
            let pipeline = FramePipeline::new(preset).expect("pipeline");
            let make = |garbage: bool| {
                std::thread::scope(|s| {
                    s.spawn(|| {
                        super::GARBAGE.set(garbage);
                        let mut renderer = pipeline.renderer(&ctx);
                        (0..pipeline.frame_count())
                            .map(|i| {
                                let f = pipeline.make(&mut renderer, i).expect("frame");
                                (f.rgba, f.labels, f.masks)
                            })
                            .collect::<Vec<_>>()
                    })
                    .join()
                    .expect("renderer thread")
                })
            };
            let (clean, garbage) = (make(false), make(true));
            assert_eq!(clean.len(), 3);
            assert!(
                clean.iter().any(|(_, labels, _)| !labels.is_empty()),
                "MSAA {msaa}: no drone labelled"
            );
            for (i, (a, b)) in clean.iter().zip(&garbage).enumerate() {
                assert!(a.0 == b.0, "MSAA {msaa}, frame {i}: pixels differ");
                assert_eq!(a.1, b.1, "MSAA {msaa}, frame {i}: labels differ");
                assert_eq!(a.2, b.2, "MSAA {msaa}, frame {i}: masks differ");
            }
        }
    }
}
