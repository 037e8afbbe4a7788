//! The frame's background, cached: the sky, procedural environment or
//! backplate behind the drones, with the near-field scenery composited over
//! it on the CPU, held once per target size as a texture (what the region
//! passes "clear" to) and as RGBA8 on the CPU (what each frame's pixel
//! buffer starts from).
//!
//! The background depends only on what the sky shader reads: it is drawn
//! once per distinct key (frame uniforms less the atmosphere, environment
//! uniforms, sky bind group, size; or the plate, its mirroring and the
//! size; plus the scenery layer's key) without MSAA — the sky shades once
//! per pixel at its centre, so an MSAA sky resolves to the very same value —
//! and read back once into the CPU copy. Each drawn background gets a
//! process-wide generation number ([`super::Painted::background`]), so a
//! frame buffer over the same background restores only what was painted
//! over it.

use std::sync::atomic::{AtomicU64, Ordering};

use super::gpu::{PipelineDesc, PipelineFactory, color_target, covering_pass};
use super::plate::Plates;
use super::readback::{self, Readback};
use super::regions::Rect;
use super::scenery::{self, ClutterLayer};
use super::sky::SkyGpu;
use super::tiles::{take_stale_tiles, upload_tiles, write_part};
use super::upsample::{
    Texels, Tone, encode_source, upsample_levels, upsample_parts, upsample_reduced,
};
use super::{COLOR_FORMAT, FrameUniforms, ReadbackError, RenderError};
use crate::scene::FrameScene;
use crate::scene::backplate::FramePlate;
use crate::sky::FrameSky;

/// Generation numbers of drawn backgrounds, unique in the process, so a
/// buffer recycled into another renderer never matches its background.
static BACKGROUNDS: AtomicU64 = AtomicU64::new(1);

/// One size's cached background: the texture the region passes read, its
/// CPU copy, and what it was drawn from.
pub(super) struct BackgroundCache {
    width: u32,
    height: u32,
    texture: wgpu::Texture,
    view: wgpu::TextureView,
    /// Binds `texture` for the region passes' background "clear".
    pub(super) group: wgpu::BindGroup,
    /// What the cached background was drawn from (see `background_key`).
    key: Option<Vec<u8>>,
    /// The drone-free frame (RGBA8, sRGB-encoded, scenery included); while
    /// `pending`, only its parts under the regions so far.
    rgba: Vec<u8>,
    /// `rgba` before the scenery was composited into it: what `texture`
    /// takes (the region passes draw the scenery themselves); empty when
    /// the frame has no scenery, the texture holds all of it already, or
    /// the background is drawn anew frame after frame (see `unkept`).
    plain: Vec<u8>,
    /// Stale tiles (see `stale`) left without their pixels before the
    /// scenery: `plain` was not kept, the background being drawn anew frame
    /// after frame ([`Backgrounds::update`]). A frame that finds this
    /// background again draws it anew (a camera that stopped moving draws
    /// its background twice).
    unkept: bool,
    /// Generation of the cached background (see [`super::Painted`]); 0: none.
    pub(super) generation: u64,
    /// Full-frame readback of the drawn sky.
    readback: Readback,
    /// A background kept before the camera's exposure, with its key without
    /// the exposure (see `Backgrounds::draw_exposed`).
    unexposed: Option<(Vec<u8>, Vec<u8>)>,
    /// Readback of the procedural environment pass (grown as needed).
    environment_readback: Option<wgpu::Buffer>,
    /// A reduced pass shaded on the CPU (an image sky's, or a procedural
    /// environment's on a CPU adapter; red, green and blue planes), kept
    /// for its memory.
    reduced_texels: [Vec<f32>; 3],
    /// The reduced pass sRGB-encoded at its own resolution (RGBA8), what the
    /// upsampling interpolates ([`super::upsample`]).
    reduced_levels: Vec<u8>,
    /// Backgrounds drawn in a row for this cache's frames (0: the last
    /// frame found its background here): from the second, a frame may take
    /// the pixels ([`BackgroundCache::lend`]).
    drawn_in_a_row: u32,
    /// The key of a background whose pixels a frame took: drawn again, it
    /// is kept (a camera that stopped moving draws its background twice,
    /// not every frame).
    lent: Option<Vec<u8>>,
    /// Per upload tile (`tiles::UPLOAD_TILE` pixels square), row by row: whether `texture` still
    /// lacks that part of `rgba`. A background made on the CPU (upsampled
    /// environment or image sky, backplate) is uploaded only where the
    /// region passes read it, under the frame's regions, when a frame first
    /// needs it ([`BackgroundCache::upload_under`]); empty when the
    /// texture holds the whole background.
    stale: Vec<bool>,
    /// A reduced pass shaded on the CPU not yet upsampled but for the parts
    /// its frame's regions read: the rest is upsampled once the frame's
    /// passes are submitted, while the GPU draws them ([`Self::finish`]).
    pending: Option<Pending>,
}

/// What [`BackgroundCache::finish`] upsamples `reduced_levels` with: the
/// pass's size and the camera's principal point.
#[derive(Clone, Copy, Debug)]
struct Pending {
    size: (u32, u32),
    centre: (f32, f32),
}

impl BackgroundCache {
    /// An empty cache of `width`×`height`, its texture bound with `layout`.
    pub(super) fn new(
        device: &wgpu::Device,
        layout: &wgpu::BindGroupLayout,
        width: u32,
        height: u32,
    ) -> Self {
        // COPY_DST: a backplate's pixels are written, not drawn.
        let texture = super::gpu::texture_2d(
            device,
            "background",
            (width, height),
            (COLOR_FORMAT, 1),
            wgpu::TextureUsages::RENDER_ATTACHMENT
                | wgpu::TextureUsages::TEXTURE_BINDING
                | wgpu::TextureUsages::COPY_SRC
                | wgpu::TextureUsages::COPY_DST,
        );
        let view = texture.create_view(&Default::default());
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("region background"),
            layout,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: wgpu::BindingResource::TextureView(&view),
            }],
        });
        Self {
            width,
            height,
            texture,
            view,
            group,
            key: None,
            rgba: Vec::new(),
            plain: Vec::new(),
            unkept: false,
            generation: 0,
            readback: Readback::new(device, "background readback", width, height),
            unexposed: None,
            environment_readback: None,
            reduced_texels: Default::default(),
            reduced_levels: Vec::new(),
            drawn_in_a_row: 0,
            lent: None,
            stale: Vec::new(),
            pending: None,
        }
    }

    /// Every tile of the cache stale: the texture holds none of `rgba` yet.
    fn mark_stale(&mut self) {
        let (across, down) = upload_tiles((self.width, self.height));
        self.stale = vec![true; across as usize * down as usize];
    }

    /// Drop the cached background (the sky images or plates changed): the
    /// next frame draws it again.
    pub(super) fn forget(&mut self) {
        self.finish();
        self.key = None;
        self.unexposed = None;
        self.stale.clear();
    }

    /// Write into the texture the stale tiles (see `stale`) under `rects`,
    /// each row of tiles in runs, from the background without the scenery.
    /// While the upsampling is pending, those tiles are upsampled first.
    fn upload_under<'r>(&mut self, queue: &wgpu::Queue, rects: impl IntoIterator<Item = &'r Rect>) {
        let size = (self.width, self.height);
        let parts = take_stale_tiles(&mut self.stale, size, rects);
        if let Some(p) = self.pending {
            let levels = &self.reduced_levels;
            upsample_parts(levels, (p.size, size), p.centre, &parts, &mut self.rgba);
        }
        let source = if self.plain.is_empty() {
            &self.rgba
        } else {
            &self.plain
        };
        for part in &parts {
            write_part(queue, &self.texture, source, self.width, part);
        }
    }

    /// Upsample the rest of a pending background ([`Self::pending`]): `rgba`
    /// then holds all of it (the parts made before get the same bytes).
    pub(super) fn finish(&mut self) {
        if let Some(p) = self.pending.take() {
            let frame = (self.width, self.height);
            let levels = &self.reduced_levels;
            upsample_levels(levels, p.size, (frame, p.centre), &mut self.rgba);
        }
    }

    /// The drone-free frame; whole, once [`Self::finish`] has run.
    pub(super) fn pixels(&self) -> &[u8] {
        debug_assert!(
            self.pending.is_none(),
            "a background read before it was finished"
        );
        &self.rgba
    }

    /// Whether a frame that paints over the background may take its pixels
    /// ([`BackgroundCache::lend`]) instead of a copy: when they were drawn
    /// for this frame and the frame before drew its own too (a camera that
    /// moves every frame).
    pub(super) fn lendable(&self) -> bool {
        self.drawn_in_a_row >= 2
    }

    /// The background's pixels, taken by a frame ([`BackgroundCache::lendable`]):
    /// the cache then holds no background (`replacement`'s memory, its
    /// contents stale; the next frame draws again).
    pub(super) fn lend(&mut self, replacement: Vec<u8>) -> Vec<u8> {
        debug_assert!(
            self.pending.is_none(),
            "a background lent before it was finished"
        );
        self.lent = self.key.take();
        self.unkept = false;
        self.generation = 0;
        self.stale.clear();
        std::mem::replace(&mut self.rgba, replacement)
    }

    /// A fresh generation for what the cache now holds.
    fn renew(&mut self) {
        self.generation = BACKGROUNDS.fetch_add(1, Ordering::Relaxed);
    }
}

/// The background sky pipelines, one per sky mode (see `SKY_MODE` in sky.wgsl).
#[derive(Default)]
struct SkyPipelines(Vec<(u32, wgpu::RenderPipeline)>);

impl SkyPipelines {
    /// The background sky pipeline of the sky mode last written, built on first use.
    fn get(&mut self, factory: &PipelineFactory, sky: &SkyGpu) -> &wgpu::RenderPipeline {
        let mode = sky.mode().to_bits();
        let i = match self.0.iter().position(|(m, _)| *m == mode) {
            Some(i) => i,
            None => {
                let constants = [("SKY_MODE", f64::from(sky.mode())), ("EXPOSED", 0.0)];
                let targets = [color_target(COLOR_FORMAT)];
                let program = &sky.program;
                let pipeline = factory.render(&PipelineDesc {
                    constants: &constants,
                    ..PipelineDesc::new(
                        "background sky pipeline",
                        &program.layout,
                        &program.module,
                        "fs_main",
                        &targets,
                    )
                });
                self.0.push((mode, pipeline));
                self.0.len() - 1
            }
        };
        &self.0[i].1
    }
}

/// What the background part draws with: the renderer's pipeline maker and
/// queue, the frame uniforms' group, and the parts it draws from (the sky,
/// the plates).
pub(super) struct BackgroundInputs<'a> {
    pub factory: &'a PipelineFactory,
    pub queue: &'a wgpu::Queue,
    pub frame_group: &'a wgpu::BindGroup,
    pub sky: &'a mut SkyGpu,
    pub plates: &'a Plates,
}

/// A background's key before the exposure, and the exposure's gain.
#[derive(Clone, Copy)]
struct Exposure<'a> {
    base_key: &'a [u8],
    gain: f32,
}

/// What the background part keeps across target sizes: its sky pipelines
/// and how many backgrounds it drew (cache misses, for tests and benchmarks).
#[derive(Default)]
pub(super) struct Backgrounds {
    sky: SkyPipelines,
    pub(super) draws: u64,
}

impl Backgrounds {
    /// Make `cache` hold `scene`'s background (with the scenery layer of key
    /// `scenery`, when the frame has one, composited from `layer`), drawing
    /// it only when its key changed, and the texture hold it under `under`
    /// (the rects the frame's passes read it under).
    pub(super) fn update<'r>(
        &mut self,
        with: &mut BackgroundInputs<'_>,
        cache: &mut BackgroundCache,
        (scene, uniforms): (&FrameScene, &FrameUniforms),
        (scenery, layer): (Option<u64>, Option<&ClutterLayer>),
        under: impl IntoIterator<Item = &'r Rect>,
    ) -> Result<(), RenderError> {
        // A background left pending by a frame that failed before its passes.
        cache.finish();
        let size = (cache.width, cache.height);
        // What the background shows, before the camera's exposure and the scenery.
        let base_key = match &scene.backplate {
            Some(plate) => Plates::key(plate, size),
            None => background_key(with.sky, uniforms, &scene.sky, size),
        };
        let gain = uniforms.exposure[0];
        let mut key = base_key.clone();
        key.extend(scenery.iter().flat_map(|k| k.to_le_bytes()));
        key.extend_from_slice(&gain.to_le_bytes());
        let found = cache.key.as_ref() == Some(&key);
        if found && !cache.unkept {
            cache.drawn_in_a_row = 0;
            cache.upload_under(with.queue, under);
            return Ok(());
        }
        cache.drawn_in_a_row = match cache.lent.take() {
            Some(lent) if lent == key => 0,
            _ if found => 0,
            _ => cache.drawn_in_a_row.saturating_add(1),
        };
        cache.key = None;
        let kept = (cache.unexposed.as_ref()).filter(|(k, _)| gain != 1.0 && *k == base_key);
        if let Some((_, pixels)) = kept {
            // The same background under another exposure: re-exposed, not drawn.
            cache.rgba.clear();
            cache.rgba.extend_from_slice(pixels);
            super::upsample::expose(&mut cache.rgba, gain);
            cache.renew();
            cache.mark_stale();
        } else {
            let exposure = Exposure {
                base_key: base_key.as_slice(),
                gain,
            };
            self.draw_exposed(with, cache, scene, uniforms, exposure)?;
        }
        // The texture takes the background without the scenery (the region
        // passes draw the scenery themselves), only where the regions read
        // it, not the whole frame: this frame's regions now, before the
        // scenery; the other stale tiles later, from a copy kept for them. A
        // background drawn anew frame after frame (a moving camera's) keeps
        // no copy.
        cache.plain.clear();
        cache.upload_under(with.queue, under);
        cache.unkept = false;
        if let Some(layer) = layer {
            // The scenery is composited over the whole background.
            cache.finish();
            if cache.stale.contains(&true) {
                if cache.lendable() {
                    cache.unkept = true;
                } else {
                    cache.plain.extend_from_slice(&cache.rgba);
                }
            }
            scenery::composite(layer, &mut cache.rgba);
        }
        cache.key = Some(key);
        Ok(())
    }

    /// Draw `cache`'s background for `scene` at exposure `gain`.
    /// The CPU-made pictures (procedural environments, magnified image skies,
    /// backplates) are drawn at the exposure, at no cost of their own, every
    /// time their exposure changes (the same bytes however many frames
    /// came before). The sky shader's background is always drawn unexposed,
    /// kept, and exposed by the table (a static gradient sky under an
    /// exposure range is drawn once).
    fn draw_exposed(
        &mut self,
        with: &mut BackgroundInputs<'_>,
        cache: &mut BackgroundCache,
        scene: &FrameScene,
        uniforms: &FrameUniforms,
        Exposure { base_key, gain }: Exposure<'_>,
    ) -> Result<(), RenderError> {
        /// Where the background's pixels come from.
        enum Source<'a> {
            Plate(&'a FramePlate),
            /// The reduced pass, upsampled on the CPU (an image sky when `Some`).
            Reduced(Option<&'a FrameSky>),
            /// The sky shader, drawn unexposed (`EXPOSED` 0 in sky.wgsl).
            Shader,
        }
        let source = match (&scene.backplate, with.sky.written_image_scale()) {
            (Some(plate), _) => Source::Plate(plate),
            (None, Some(_)) => Source::Reduced(Some(&scene.sky)),
            (None, None) if SkyGpu::is_procedural(&scene.sky) => Source::Reduced(None),
            (None, None) => Source::Shader,
        };
        // Only the sky shader's background is kept unexposed and exposed by
        // the table, on its first frame as on the later ones. A picture made
        // on the CPU (a procedural environment, an image sky, a backplate) is
        // always drawn at the exposure, quantised once: exposing a kept 8-bit
        // copy instead quantises twice, so a frame's pixels depended on
        // whether its maker had drawn the same background before (on the
        // frames before it, the number of makers, a frame made alone).
        let keep = gain != 1.0 && matches!(source, Source::Shader);
        let draw_gain = if keep { 1.0 } else { gain };
        match source {
            Source::Plate(plate) => draw_plate_background(with.plates, cache, plate, draw_gain)?,
            Source::Reduced(image) => {
                draw_reduced_background(with, cache, uniforms, image, draw_gain)?
            }
            Source::Shader => self.draw_background(with, cache, scene)?,
        }
        self.draws += 1;
        if keep {
            // Into the kept copy's memory: no frame-sized allocation per frame.
            let (key, pixels) = cache.unexposed.get_or_insert_with(Default::default);
            key.clear();
            key.extend_from_slice(base_key);
            pixels.clear();
            pixels.extend_from_slice(&cache.rgba);
            super::upsample::expose(&mut cache.rgba, gain);
            // The texture is written from the exposed bytes where the regions need it.
            cache.mark_stale();
        }
        Ok(())
    }

    /// Draw the sky into the background texture (no MSAA) and read it back.
    fn draw_background(
        &mut self,
        with: &BackgroundInputs<'_>,
        cache: &mut BackgroundCache,
        scene: &FrameScene,
    ) -> Result<(), RenderError> {
        let device = with.factory.device();
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("background"),
        });
        {
            let pipeline = self.sky.get(with.factory, with.sky);
            // Not cleared: the sky's full-screen triangle writes every pixel.
            let mut pass = covering_pass(&mut encoder, "background pass", &cache.view);
            pass.set_pipeline(pipeline);
            pass.set_bind_group(0, with.frame_group, &[]);
            pass.set_bind_group(1, with.sky.bind_group_for(&scene.sky), &[]);
            pass.draw(0..3, 0..1);
        }
        cache.readback.copy_from(&mut encoder, &cache.texture);
        let submitted = with.queue.submit([encoder.finish()]);
        // Into the previous background's memory: frame buffers copy from it,
        // and the new generation below tells them it changed.
        let read = cache.readback.read_into(device, submitted, &mut cache.rgba);
        cache.renew();
        cache.stale.clear();
        read
    }
}

/// The bytes the sky shader reads, plus what its bind group and size are.
fn background_key(
    sky_gpu: &SkyGpu,
    uniforms: &FrameUniforms,
    sky: &FrameSky,
    size: (u32, u32),
) -> Vec<u8> {
    let group: u64 = match sky {
        FrameSky::Gradient { .. } => 0,
        FrameSky::Procedural { .. } => 1,
        FrameSky::Image { image, .. } => 2 + *image as u64,
    };
    // The sky shaders never read the atmosphere's slot (a procedural
    // environment's fog is in its own uniforms): a new visibility alone
    // keeps the background.
    // Nor the exposure: it is applied after the drawing (`update_background`).
    let sky_uniforms = FrameUniforms {
        atmosphere: [0.0; 4],
        exposure: [0.0; 4],
        ..*uniforms
    };
    let mut key = bytemuck::bytes_of(&sky_uniforms).to_vec();
    key.extend_from_slice(sky_gpu.uniform_bytes());
    key.extend_from_slice(&group.to_le_bytes());
    key.extend_from_slice(&size.0.to_le_bytes());
    key.extend_from_slice(&size.1.to_le_bytes());
    key
}

/// A procedural environment (`image` None) or an image sky magnified
/// enough (`image`: the sky, shaded at the scale its uniforms hold, see
/// [`super::sky::SkyGpu::image_scale`]) as the background: its pass at
/// reduced resolution (the image's, and the environment's on a CPU adapter,
/// shaded on the CPU; else the environment's drawn and read back),
/// upsampled and sRGB-encoded on the CPU ([`super::upsample`]) and uploaded
/// as the background texture where the regions need it (no full-frame sky
/// pass, no full-frame readback).
fn draw_reduced_background(
    with: &mut BackgroundInputs<'_>,
    cache: &mut BackgroundCache,
    uniforms: &FrameUniforms,
    image: Option<&FrameSky>,
    gain: f32,
) -> Result<(), RenderError> {
    let frame = (cache.width, cache.height);
    // Any previous background is overwritten from here on.
    cache.renew();
    let camera = (&uniforms.world_from_camera, uniforms.intrinsics);
    let texels = &mut cache.reduced_texels;
    // The pass shaded on the CPU: its size and tone.
    let shaded = match image {
        Some(sky) => {
            let tone = if with.sky.image_is_hdr(sky) {
                Tone::Exponential
            } else {
                Tone::Clip
            };
            let size = with.sky.shade_image(sky, camera, frame, texels);
            Some((
                size.ok_or(ReadbackError::NoTarget("the image sky's pass"))?,
                tone,
            ))
        }
        None if with.sky.shades_environment_on_cpu() => {
            let sun = glam::Vec4::from(uniforms.sun_dir_world).truncate();
            let size = with.sky.shade_environment(camera, sun, frame, texels);
            Some((
                size.ok_or(ReadbackError::NoTarget("the environment pass"))?,
                Tone::Clip,
            ))
        }
        None => None,
    };
    match shaded {
        Some((size, tone)) => {
            // Encoded now; upsampled where the frame's regions read it when
            // they are uploaded, the rest once its passes are submitted.
            let source = (size.0 as usize, size.1 as usize);
            let texels = Texels::Planes(&cache.reduced_texels);
            encode_source(&texels, source, (tone, gain), &mut cache.reduced_levels);
            let centre = (uniforms.intrinsics[2], uniforms.intrinsics[3]);
            cache
                .rgba
                .resize(frame.0 as usize * frame.1 as usize * 4, 0);
            cache.pending = Some(Pending { size, centre });
        }
        None => draw_environment(with, cache, uniforms, gain)?,
    }
    cache.mark_stale();
    Ok(())
}

/// The procedural environment's passes drawn by the GPU, read back and
/// upsampled into `cache.rgba` (see [`draw_reduced_background`]).
fn draw_environment(
    with: &mut BackgroundInputs<'_>,
    cache: &mut BackgroundCache,
    uniforms: &FrameUniforms,
    gain: f32,
) -> Result<(), RenderError> {
    let frame = (cache.width, cache.height);
    let centre = (uniforms.intrinsics[2], uniforms.intrinsics[3]);
    let device = with.factory.device();
    let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
        label: Some("environment background"),
    });
    let passes = super::sky::SkyPassContext {
        factory: with.factory,
        frame_group: with.frame_group,
    };
    with.sky.encode_environment(
        &passes,
        &mut encoder,
        frame,
        super::horizon::Horizon::of(&uniforms.world_from_camera, uniforms.intrinsics, frame),
    );
    let Some((texture, (w, h))) = with.sky.environment_target() else {
        return Err(ReadbackError::NoTarget("the environment pass").into());
    };
    // RGBA16F: 8 bytes a texel, rows padded to the copy alignment.
    let row =
        (w * 8).div_ceil(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT) * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
    let len = u64::from(row) * u64::from(h);
    if cache
        .environment_readback
        .as_ref()
        .is_none_or(|b| b.size() < len)
    {
        cache.environment_readback = Some(device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("environment readback"),
            size: len,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        }));
    }
    let Some(buffer) = cache.environment_readback.as_ref() else {
        return Ok(()); // just made
    };
    encoder.copy_texture_to_buffer(
        wgpu::TexelCopyTextureInfo {
            texture,
            mip_level: 0,
            origin: wgpu::Origin3d::ZERO,
            aspect: wgpu::TextureAspect::All,
        },
        wgpu::TexelCopyBufferInfo {
            buffer,
            layout: wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(row),
                rows_per_image: Some(h),
            },
        },
        wgpu::Extent3d {
            width: w,
            height: h,
            depth_or_array_layers: 1,
        },
    );
    let submitted = with.queue.submit([encoder.finish()]);
    let (levels, rgba) = (&mut cache.reduced_levels, &mut cache.rgba);
    readback::read_mapped(device, submitted, buffer, len, |bytes| {
        let texels = Texels::F16 {
            bytes,
            stride: row as usize,
        };
        let tone = (Tone::Clip, gain);
        upsample_reduced(texels, (w, h), (frame, centre), tone, levels, rgba);
    })
}

/// A backplate as the background, exposed by `gain`: its pixels written
/// into the texture and kept as the CPU copy (no sky pass, no readback).
fn draw_plate_background(
    plates: &Plates,
    cache: &mut BackgroundCache,
    plate: &FramePlate,
    gain: f32,
) -> Result<(), RenderError> {
    let size = (cache.width, cache.height);
    let made = plates.pixels(plate, size, &mut cache.rgba);
    if made.is_ok() {
        if gain != 1.0 {
            super::upsample::expose(&mut cache.rgba, gain);
        }
        cache.mark_stale();
    }
    // A new generation even on failure: no buffer may match what was overwritten.
    cache.renew();
    made
}
