//! GPU side of the environments (`@group(1)` of the sky pipeline): one
//! uniform block rewritten per frame, and one bind group per uploaded sky
//! image (plus a default one with 1×1 placeholders for the gradient and
//! procedural skies). [`SkyGpu::prepare`] turns a frame's environment into
//! the uniforms and the drones' [`Lighting`].
//!
//! Procedural environments are drawn at half resolution per axis into an
//! RGBA16F target by their own pass ([`SkyGpu::encode_environment`]) and
//! sampled bilinearly by the sky pass: a quarter of the shading work, and the
//! sky pass itself then costs what the gradient costs. The environment is
//! soft (clouds, haze, distant silhouettes); drones stay at full resolution.

use glam::Vec3;
use half::slice::HalfFloatSliceExt;
use wgpu::util::DeviceExt;

use super::gpu::{PipelineDesc, PipelineFactory, Program, sampler_entry, texture_entry};
use super::horizon::Horizon;

use crate::sky::{
    self, EnvironmentAssets, FrameEnvironment, FrameSky, Lighting, SkyImage, SkyImageKind,
};

/// What the sky's reduced passes are drawn with besides the sky's own
/// things: the renderer's pipeline maker and the frame uniforms' group.
pub(super) struct SkyPassContext<'a> {
    pub factory: &'a PipelineFactory,
    pub frame_group: &'a wgpu::BindGroup,
}

/// The sky a frame shows and its horizon (for the environment's parts).
pub(super) struct FrameSkyDraw<'a> {
    pub sky: &'a FrameSky,
    pub horizon: Horizon,
}

pub(super) struct SkyGpu {
    /// `@group(1)` of sky.wgsl.
    layout: wgpu::BindGroupLayout,
    /// sky.wgsl, laid out with the frame uniforms and [`SkyGpu::layout`]:
    /// every sky pipeline (the full-frame path's, the background's, the
    /// reduced passes') is made from it.
    pub(super) program: Program,
    uniforms: wgpu::Buffer,
    /// Placeholders only: the gradient sky and the environment pass itself.
    default_group: wgpu::BindGroup,
    /// The half-resolution environment target and the group that samples it
    /// (the full-frame path's sky pass).
    half: Option<ReducedTarget>,
    /// The quarter-resolution target of the sky above the silhouettes and
    /// the group that samples it (the half-resolution pass).
    quarter: Option<ReducedTarget>,
    /// An image sky's reduced-resolution target (see [`SkyGpu::image_scale`])
    /// and its size.
    image_target: Option<(wgpu::Texture, wgpu::TextureView, (u32, u32))>,
    /// The pipeline of `fs_image`, built on first use.
    image_pipeline: Option<wgpu::RenderPipeline>,
    /// The group of image `.0` that samples the image pass's target (the
    /// full-frame path's sky pass, [`SkyGpu::prepare_upsampled`]).
    upsampled: Option<(usize, wgpu::BindGroup)>,
    /// Per uploaded image: its bind group and CPU summary (for lighting).
    images: Vec<(wgpu::BindGroup, SkyImage)>,
    /// Per uploaded image: its equirect texture's view (`None` for cube maps),
    /// for the group that samples the image pass's target.
    image_views: Vec<Option<wgpu::TextureView>>,
    placeholder_2d: wgpu::TextureView,
    placeholder_cube: wgpu::TextureView,
    sampler: wgpu::Sampler,
    half_sampler: wgpu::Sampler,
    /// The pipelines of `fs_environment`, one per environment's kinds
    /// (ground, far and near silhouette: see `ENV_GROUND` in
    /// environment.wgsl), built on first use.
    pipelines: super::context::EnvironmentPipelines,
    /// The device's environment pipelines, which `pipelines` copies from.
    shared: super::context::SharedPipelines,
    /// The uniforms last written (part of the background cache key).
    written: EnvUniforms,
}

/// One of the procedural environment's reduced-resolution targets.
struct ReducedTarget {
    width: u32,
    height: u32,
    texture: wgpu::Texture,
    view: wgpu::TextureView,
    /// Samples `view` as `env_half`.
    group: wgpu::BindGroup,
}

/// Full-resolution pixels per environment-pass pixel, per axis.
const HALF_SCALE: u32 = 2;

/// Full-resolution pixels per pixel of the pass of the sky above the
/// silhouettes (smooth: the Preetham sky and the clouds), per axis.
const QUARTER_SCALE: u32 = 4;

/// RGB texels as RGBA half floats (alpha 1), rounded to nearest as
/// `f16::from_f32`; converted a row of texels at a time by the `half`
/// crate's slice conversion (F16C where the CPU has it: a 1k sky image is
/// two million values, on the first frame's path).
fn f16_rgba(rgb: &[f32]) -> Vec<half::f16> {
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

impl SkyGpu {
    /// The sky's things, its pipelines laid out after `frame_layout` (`@group(0)`).
    pub(super) fn new(
        factory: &PipelineFactory,
        queue: &wgpu::Queue,
        shared: super::context::SharedPipelines,
        frame_layout: &wgpu::BindGroupLayout,
    ) -> Self {
        let device = factory.device();
        let texture = |binding, view_dimension| texture_entry(binding, true, view_dimension, false);
        let layout = factory.bind_group_layout(
            "environment layout",
            &[
                super::gpu::uniform_entry(0, wgpu::ShaderStages::FRAGMENT),
                texture(1, wgpu::TextureViewDimension::D2),
                texture(2, wgpu::TextureViewDimension::Cube),
                sampler_entry(3),
                texture(4, wgpu::TextureViewDimension::D2),
                sampler_entry(5),
            ],
        );
        let [(sky_name, sky_src), ..] = super::shader_sources();
        let program = factory.program(sky_name, sky_src, &[frame_layout, &layout]);
        let uniforms = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("environment uniforms"),
            size: std::mem::size_of::<EnvUniforms>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("environment sampler"),
            address_mode_u: wgpu::AddressMode::Repeat,
            address_mode_v: wgpu::AddressMode::ClampToEdge,
            address_mode_w: wgpu::AddressMode::ClampToEdge,
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            ..Default::default()
        });
        let half_sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("environment upsampler"),
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            ..Default::default()
        });
        let placeholder_2d = Self::texture(device, queue, "sky placeholder", 1, 1, 1, &[0.0; 3])
            .create_view(&Default::default());
        let placeholder_cube =
            Self::texture(device, queue, "sky cube placeholder", 1, 1, 6, &[0.0; 18]).create_view(
                &wgpu::TextureViewDescriptor {
                    dimension: Some(wgpu::TextureViewDimension::Cube),
                    ..Default::default()
                },
            );
        let default_group = make_bind_group(
            device,
            &layout,
            &uniforms,
            (&sampler, &half_sampler),
            "environment (placeholders)",
            [&placeholder_2d, &placeholder_cube, &placeholder_2d],
        );
        Self {
            layout,
            program,
            uniforms,
            default_group,
            half: None,
            quarter: None,
            image_target: None,
            image_pipeline: None,
            upsampled: None,
            image_views: Vec::new(),
            images: Vec::new(),
            placeholder_2d,
            placeholder_cube,
            sampler,
            half_sampler,
            pipelines: Vec::new(),
            shared,
            written: EnvUniforms::default(),
        }
    }

    fn texture(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        label: &str,
        width: u32,
        height: u32,
        layers: u32,
        rgb: &[f32],
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
            bytemuck::cast_slice(&f16_rgba(rgb)),
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
    pub(super) fn set_images(
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
            let group = match &image.kind {
                SkyImageKind::Equirect { width, height, rgb }
                    if (*width).max(*height) <= max_side =>
                {
                    let view = Self::texture(device, queue, &label, *width, *height, 1, rgb)
                        .create_view(&Default::default());
                    let group = self.bind_group(device, &label, &view, &self.placeholder_cube);
                    equirect = Some(view);
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
            self.images.push((group, image.clone()));
            self.image_views.push(equirect);
        }
    }

    /// Whether a frame's environment needs the environment pass.
    pub(super) fn is_procedural(sky: &FrameSky) -> bool {
        matches!(sky, FrameSky::Procedural { .. })
    }

    /// Draw the procedural environment of the uniforms just written into the
    /// half-resolution target (resized to the frame's `width`×`height` as
    /// needed), in the parts of render/horizon.rs for the frame's `horizon`.
    /// The sky above the silhouettes' band is drawn first at a quarter of
    /// the resolution; the half-resolution pass interpolates it there.
    pub(super) fn encode_environment(
        &mut self,
        with: &SkyPassContext<'_>,
        encoder: &mut wgpu::CommandEncoder,
        frame: (u32, u32),
        horizon: Horizon,
    ) {
        let device = with.factory.device();
        let band_top = self.written.band[0];
        let half = self.ensure_target(device, HALF_SCALE, frame);
        let draws = horizon.parts(band_top, half, HALF_SCALE as f32);
        let upper = draws.iter().any(|(part, _)| *part == 3).then(|| {
            let quarter = self.ensure_target(device, QUARTER_SCALE, frame);
            let parts = horizon.parts(band_top, quarter, QUARTER_SCALE as f32);
            let polygon = parts.into_iter().find(|(part, _)| *part == 3);
            (4, polygon.map_or_else(Vec::new, |(_, t)| t))
        });
        let upper_pipeline = upper
            .as_ref()
            .map(|(part, _)| self.environment_pipeline(with, *part));
        let pipelines: Vec<usize> = draws
            .iter()
            .map(|(part, _)| self.environment_pipeline(with, *part))
            .collect();
        let vertices: Vec<[f32; 2]> = upper
            .iter()
            .chain(&draws)
            .flat_map(|(_, t)| t.iter().copied())
            .collect();
        let Some(half) = &self.half else {
            return;
        };
        if vertices.is_empty() {
            return;
        }
        let buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("environment parts"),
            contents: bytemuck::cast_slice(&vertices),
            usage: wgpu::BufferUsages::VERTEX,
        });
        let mut first = 0u32;
        let mut draw =
            |pass: &mut wgpu::RenderPass<'_>, triangles: &[[f32; 2]], pipeline: usize| {
                let count = triangles.len() as u32;
                pass.set_pipeline(&self.pipelines[pipeline].1);
                pass.set_vertex_buffer(0, buffer.slice(..));
                pass.draw(first..first + count, 0..1);
                first += count;
            };
        // The placeholder group while a target is drawn (it cannot sample
        // itself); the half-resolution pass samples the quarter's.
        let mut group = &self.default_group;
        if let (Some((_, triangles)), Some(pipeline), Some(quarter)) =
            (&upper, upper_pipeline, &self.quarter)
        {
            let mut pass = super::gpu::clear_pass(
                encoder,
                "environment pass (quarter resolution)",
                &quarter.view,
            );
            pass.set_bind_group(0, with.frame_group, &[]);
            pass.set_bind_group(1, &self.default_group, &[]);
            draw(&mut pass, triangles, pipeline);
            group = &quarter.group;
        }
        let mut pass = super::gpu::clear_pass(encoder, "environment pass", &half.view);
        pass.set_bind_group(0, with.frame_group, &[]);
        pass.set_bind_group(1, group, &[]);
        for ((_, triangles), pipeline) in draws.iter().zip(pipelines) {
            draw(&mut pass, triangles, pipeline);
        }
    }

    /// The environment target of `scale` (full-resolution pixels per pixel:
    /// [`HALF_SCALE`] or [`QUARTER_SCALE`]) for a `width`×`height` frame,
    /// (re)made when its size changes; its size.
    fn ensure_target(
        &mut self,
        device: &wgpu::Device,
        scale: u32,
        (width, height): (u32, u32),
    ) -> (u32, u32) {
        let (w, h) = (width.div_ceil(scale).max(1), height.div_ceil(scale).max(1));
        let (slot, label) = if scale == QUARTER_SCALE {
            (&mut self.quarter, "environment (quarter resolution)")
        } else {
            (&mut self.half, "environment (half resolution)")
        };
        if slot.as_ref().is_none_or(|t| (t.width, t.height) != (w, h)) {
            let (texture, view) = reduced_texture(device, label, (w, h));
            let group = make_bind_group(
                device,
                &self.layout,
                &self.uniforms,
                (&self.sampler, &self.half_sampler),
                label,
                [&self.placeholder_2d, &self.placeholder_cube, &view],
            );
            *slot = Some(ReducedTarget {
                width: w,
                height: h,
                texture,
                view,
                group,
            });
        }
        (w, h)
    }

    /// The environment pipeline of the written environment's ground and
    /// silhouette kinds for draw `part` (0: whole, 1: the sky up to the
    /// silhouettes' band top, 2: ground side, 3: the sky above the band,
    /// 4: the quarter-resolution pass's sky above the band), built on first
    /// use; its index in `self.pipelines`. A part is built only for the
    /// kinds it draws (the others are -1, never read): the ground side for
    /// its ground, the band for its silhouettes, the sky above the band for
    /// none. Environments that share them share the part's pipeline: each
    /// pipeline costs lavapipe tens of milliseconds of shader compilation.
    fn environment_pipeline(&mut self, with: &SkyPassContext<'_>, part: u32) -> usize {
        let (ground, far, near) = (
            self.written.pattern[2],
            self.written.pattern[3],
            self.written.far_params[1],
        );
        let kinds = match part {
            0 => [ground, far, near],
            1 => [-1.0, far, near],
            2 => [ground, -1.0, -1.0],
            _ => [-1.0; 3],
        };
        let key = [kinds[0], kinds[1], kinds[2], part as f32].map(f32::to_bits);
        if let Some(i) = self.pipelines.iter().position(|(k, _)| *k == key) {
            return i;
        }
        // Another renderer of the device may have built it; building it
        // under the lock makes one that wants it meanwhile wait, not build
        // it again.
        let shared = self.shared.environment.clone();
        let mut shared = shared
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        if let Some((_, pipeline)) = shared.iter().find(|(k, _)| *k == key) {
            self.pipelines.push((key, pipeline.clone()));
            return self.pipelines.len() - 1;
        }
        let constants = [
            ("ENV_GROUND", f64::from(kinds[0])),
            ("ENV_FAR", f64::from(kinds[1])),
            ("ENV_NEAR", f64::from(kinds[2])),
            ("ENV_PART", f64::from(part)),
        ];
        let pipeline =
            environment_pipeline(with, &self.program, &constants, part > 0, "fs_environment");
        shared.push((key, pipeline.clone()));
        self.pipelines.push((key, pipeline));
        self.pipelines.len() - 1
    }

    /// The target of the image pass (`image`) or of the environment pass
    /// (RGBA16F, linear) and its size.
    pub(super) fn reduced_target(&self, image: bool) -> Option<(&wgpu::Texture, (u32, u32))> {
        if image {
            let (texture, _, size) = self.image_target.as_ref()?;
            return Some((texture, *size));
        }
        let t = self.half.as_ref()?;
        Some((&t.texture, (t.width, t.height)))
    }

    /// The scale (full-resolution pixels per pass pixel, per axis: 4 or 2)
    /// at which `sky`, an equirect image, is drawn for `camera`'s frame
    /// (whose principal point must be its centre); `None`: drawn at full resolution (a cube map, a gradient or
    /// procedural sky, an off-centre principal point, no scale dividing both
    /// sides, or an image too sharp for it).
    ///
    /// A scale is taken only where the image is magnified at least twice
    /// as much: at the frame's centre, where its pixels span the widest
    /// angle (≈ 1/f radians), a pass pixel spans at most half a texel
    /// (π / image height radians, or 2π / width if that is less). The pass
    /// then samples the bilinearly magnified image at twice its own texel
    /// rate or more, and the CPU's bilinear upsampling differs from sampling
    /// it at every pixel only around the texels' own corners.
    pub(super) fn image_scale(
        &self,
        sky: &FrameSky,
        camera: &crate::scene::camera::Camera,
    ) -> Option<u32> {
        let FrameSky::Image { image, .. } = sky else {
            return None;
        };
        let SkyImageKind::Equirect {
            width: iw,
            height: ih,
            ..
        } = self.images.get(*image)?.1.kind
        else {
            return None;
        };
        let c = camera.principal_point().as_vec2();
        let frame = (camera.width, camera.height);
        reduced_scale((iw, ih), frame, camera.focal_px() as f32, (c.x, c.y))
    }

    /// The full-frame path's reduced pass for `sky` (uniforms just
    /// written), if it has one: the procedural environment's, or the image
    /// pass's when the image is drawn reduced; the sky pass then samples it.
    /// `horizon`: the frame's, for the environment's parts.
    pub(super) fn encode_reduced(
        &mut self,
        with: &SkyPassContext<'_>,
        encoder: &mut wgpu::CommandEncoder,
        size: (u32, u32),
        frame_sky: &FrameSkyDraw<'_>,
    ) {
        let sky = frame_sky.sky;
        if Self::is_procedural(sky) {
            self.encode_environment(with, encoder, size, frame_sky.horizon);
        } else if self.written_image_scale().is_some() {
            self.encode_image(with, encoder, size, sky);
            self.prepare_upsampled(with.factory.device(), sky);
        }
    }

    /// Whether `sky` is an HDR image (tone-mapped: `tone_map` in environment.wgsl).
    pub(super) fn image_is_hdr(&self, sky: &FrameSky) -> bool {
        match sky {
            FrameSky::Image { image, .. } => self.images.get(*image).is_some_and(|(_, i)| i.hdr),
            _ => false,
        }
    }

    /// The scale written with the uniforms last (see [`SkyGpu::prepare`]):
    /// the image pass's, or `None` when the sky is drawn at full resolution.
    pub(super) fn written_image_scale(&self) -> Option<u32> {
        let scale = self.written.far_params[3];
        (self.written.mode[0] > 1.5 && scale > 1.5).then_some(scale as u32)
    }

    /// Draw the image sky `sky` (uniforms just written, with its scale: see
    /// [`SkyGpu::image_scale`]) into the image pass's target for a
    /// `width`×`height` frame.
    pub(super) fn encode_image(
        &mut self,
        with: &SkyPassContext<'_>,
        encoder: &mut wgpu::CommandEncoder,
        (width, height): (u32, u32),
        sky: &FrameSky,
    ) {
        let device = with.factory.device();
        let Some(scale) = self.written_image_scale() else {
            return;
        };
        let size = ((width / scale).max(1), (height / scale).max(1));
        if self.image_target.as_ref().is_none_or(|t| t.2 != size) {
            let (texture, view) = reduced_texture(device, "image sky (reduced resolution)", size);
            self.image_target = Some((texture, view, size));
            self.upsampled = None;
        }
        let pipeline = self.image_pipeline.get_or_insert_with(|| {
            environment_pipeline(with, &self.program, &[], false, "fs_image")
        });
        let (Some((_, view, _)), FrameSky::Image { image, .. }) = (&self.image_target, sky) else {
            return;
        };
        let Some((group, _)) = self.images.get(*image) else {
            return;
        };
        let mut pass = super::gpu::clear_pass(encoder, "image sky pass", view);
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, with.frame_group, &[]);
        // The image's own group: its placeholder stands for the target being drawn.
        pass.set_bind_group(1, group, &[]);
        pass.draw(0..3, 0..1);
    }

    /// Make the group with which the full-frame path's sky pass samples the
    /// image pass's target for `sky` (after [`SkyGpu::encode_image`]); see
    /// [`SkyGpu::bind_group_for`].
    fn prepare_upsampled(&mut self, device: &wgpu::Device, sky: &FrameSky) {
        let FrameSky::Image { image, .. } = sky else {
            return;
        };
        if self.upsampled.as_ref().is_some_and(|(i, _)| i == image) {
            return;
        }
        let (Some((_, target, _)), Some(Some(equirect))) =
            (&self.image_target, self.image_views.get(*image))
        else {
            return;
        };
        let group = make_bind_group(
            device,
            &self.layout,
            &self.uniforms,
            (&self.sampler, &self.half_sampler),
            "image sky (upsampled)",
            [equirect, &self.placeholder_cube, target],
        );
        self.upsampled = Some((*image, group));
    }

    /// The bind group a frame's environment draws with.
    pub(super) fn bind_group_for(&self, sky: &FrameSky) -> &wgpu::BindGroup {
        match sky {
            FrameSky::Image { image, .. } => match &self.upsampled {
                Some((i, group)) if i == image && self.written_image_scale().is_some() => group,
                _ => self
                    .images
                    .get(*image)
                    .map_or(&self.default_group, |(g, _)| g),
            },
            FrameSky::Procedural { .. } => {
                self.half.as_ref().map_or(&self.default_group, |t| &t.group)
            }
            FrameSky::Gradient { .. } => &self.default_group,
        }
    }

    /// Write the frame's environment uniforms and return the drones' lighting.
    pub(super) fn prepare(
        &mut self,
        queue: &wgpu::Queue,
        sky: &FrameSky,
        env: &FrameEnvironment,
        sun: Vec3,
        atmosphere_visibility_m: Option<f64>,
        image_scale: Option<u32>,
    ) -> Lighting {
        let mut u = EnvUniforms::default();
        let lighting = match *sky {
            FrameSky::Gradient { zenith, horizon } => sky::gradient_lighting(sun, zenith, horizon),
            FrameSky::Procedural {
                environment: name,
                exposure,
                sun: sunlight,
            } => {
                let (uniforms, lighting) = EnvUniforms::procedural(
                    name,
                    (exposure, sunlight),
                    env,
                    sun,
                    atmosphere_visibility_m,
                );
                u = uniforms;
                lighting
            }
            FrameSky::Image {
                image,
                exposure,
                rotation_deg,
            } => {
                match self.images.get(image) {
                    Some((_, image)) => {
                        let mode = match image.kind {
                            SkyImageKind::Equirect { .. } => 2.0,
                            SkyImageKind::Cubemap { .. } => 3.0,
                        };
                        u.mode = [
                            mode,
                            exposure,
                            if image.hdr { 1.0 } else { 0.0 },
                            (rotation_deg as f32).to_radians(),
                        ];
                        // Drawn by the image pass at this scale (0: at full resolution).
                        u.far_params[3] = image_scale.map_or(0.0, |s| s as f32);
                        image.lighting(sun, exposure)
                    }
                    // Not uploaded (the host did not call `set_environment`): the default gradient, never a panic.
                    None => {
                        sky::gradient_lighting(sun, sky::FALLBACK_ZENITH, sky::FALLBACK_HORIZON)
                    }
                }
            }
        };
        queue.write_buffer(&self.uniforms, 0, bytemuck::bytes_of(&u));
        self.written = u;
        lighting
    }

    /// The bytes of the uniforms last written by [`SkyGpu::prepare`].
    pub(super) fn uniform_bytes(&self) -> &[u8] {
        bytemuck::bytes_of(&self.written)
    }

    /// The sky mode last written (`Env.mode.x`: 0 gradient, 1 procedural,
    /// 2 equirect, 3 cubemap), to specialise the background pipeline with.
    pub(super) fn mode(&self) -> f32 {
        self.written.mode[0]
    }
}

/// A reduced pass's target of `size` (RGBA16F, linear) and its view:
/// drawn into, read back for the CPU upsampling (COPY_SRC) and sampled by
/// the full-frame path's sky pass.
fn reduced_texture(
    device: &wgpu::Device,
    label: &str,
    (width, height): (u32, u32),
) -> (wgpu::Texture, wgpu::TextureView) {
    let texture = super::gpu::texture_2d(
        device,
        label,
        (width, height),
        (wgpu::TextureFormat::Rgba16Float, 1),
        wgpu::TextureUsages::RENDER_ATTACHMENT
            | wgpu::TextureUsages::TEXTURE_BINDING
            | wgpu::TextureUsages::COPY_SRC,
    );
    let view = texture.create_view(&Default::default());
    (texture, view)
}

/// [`SkyGpu::image_scale`] of an equirect image `image` (texels) for a
/// `frame`-sized frame of focal length `focal_px` and principal point `centre`.
fn reduced_scale(
    (iw, ih): (u32, u32),
    (width, height): (u32, u32),
    focal_px: f32,
    centre: (f32, f32),
) -> Option<u32> {
    if centre != (width as f32 / 2.0, height as f32 / 2.0) || iw == 0 || ih == 0 {
        return None;
    }
    let texel = (std::f32::consts::PI / ih as f32).min(std::f32::consts::TAU / iw as f32);
    let magnification = focal_px * texel;
    [4u32, 2]
        .into_iter()
        .find(|&s| 2.0 * s as f32 <= magnification && width % s == 0 && height % s == 0)
}

/// The pipeline of a reduced pass (`fragment`: `fs_environment` or
/// `fs_image`) into an RGBA16F target, with its override `constants`;
/// `polygon`: drawn over given triangles, else one full-screen triangle.
fn environment_pipeline(
    with: &SkyPassContext<'_>,
    program: &Program,
    constants: &[(&str, f64)],
    polygon: bool,
    fragment: &str,
) -> wgpu::RenderPipeline {
    const SIDE_ATTRS: [wgpu::VertexAttribute; 1] = wgpu::vertex_attr_array![0 => Float32x2];
    let side = [Some(wgpu::VertexBufferLayout {
        array_stride: 8,
        step_mode: wgpu::VertexStepMode::Vertex,
        attributes: &SIDE_ATTRS,
    })];
    let targets = [super::gpu::color_target(wgpu::TextureFormat::Rgba16Float)];
    with.factory.render(&PipelineDesc {
        vertex_entry: if polygon { "vs_environment" } else { "vs_main" },
        vertex_constants: constants,
        buffers: if polygon { &side } else { &[] },
        constants,
        ..PipelineDesc::new(
            "environment pipeline",
            &program.layout,
            &program.module,
            fragment,
            &targets,
        )
    })
}

fn make_bind_group(
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

mod uniforms;
use uniforms::EnvUniforms;

#[cfg(test)]
mod tests;
