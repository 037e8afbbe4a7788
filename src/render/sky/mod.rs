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
//!
//! Here: the sky's things and what a frame draws with ([`SkyGpu::prepare`],
//! [`SkyGpu::bind_group_for`]); `upload`: the sky images' textures and the
//! bind groups; `environment`: the procedural environment's reduced passes;
//! `image`: an image sky's reduced pass and its scale; `uniforms`: the
//! uniform block.

use glam::Vec3;

use super::gpu::{PipelineFactory, Program, sampler_entry, texture_entry};
use super::horizon::Horizon;

use crate::sky::{self, FrameEnvironment, FrameSky, Lighting, SkyImage, SkyImageKind};

/// Full-resolution pixels per environment-pass pixel, per axis.
pub(super) const HALF_SCALE: u32 = 2;

/// Full-resolution pixels per pixel of the pass of the sky above the
/// silhouettes (smooth: the Preetham sky and the clouds), per axis.
pub(super) const QUARTER_SCALE: u32 = 4;

/// What the sky's reduced passes are drawn with besides the sky's own
/// things: the renderer's pipeline maker and the frame uniforms' group.
pub(super) struct SkyPassContext<'a> {
    pub factory: &'a PipelineFactory,
    pub frame_group: &'a wgpu::BindGroup,
}

/// The sky a frame shows, its horizon (for the environment's parts) and
/// its sun.
pub(super) struct FrameSkyDraw<'a> {
    pub sky: &'a FrameSky,
    pub horizon: Horizon,
    /// Toward the sun (world frame, unit).
    pub sun: Vec3,
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
    /// An image sky's reduced pass written for the full-frame path's sky
    /// pass (see [`SkyGpu::upload_image`]), and its size.
    image_target: Option<(wgpu::Texture, wgpu::TextureView, (u32, u32))>,
    /// The group of image `.0` that samples the image pass's target (the
    /// full-frame path's sky pass, [`SkyGpu::prepare_upsampled`]).
    upsampled: Option<(usize, wgpu::BindGroup)>,
    /// Per uploaded image: its bind group and CPU summary (for lighting;
    /// an equirect's texels as its half-float texture holds them, for the
    /// CPU's image pass).
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
    pipelines: super::shared::EnvironmentPipelines,
    /// The device's environment pipelines, which `pipelines` copies from.
    shared: super::shared::SharedPipelines,
    /// The uniforms last written (part of the background cache key).
    written: EnvUniforms,
    /// Whether the procedural environment is shaded on the CPU
    /// (`procedural`: the adapter is itself a CPU rasteriser), and that
    /// pass's memory.
    cpu_environment: Option<procedural::Passes>,
}

impl SkyGpu {
    /// The sky's things, its pipelines laid out after `frame_layout` (`@group(0)`).
    pub(super) fn new(
        factory: &PipelineFactory,
        queue: &wgpu::Queue,
        shared: super::shared::SharedPipelines,
        frame_layout: &wgpu::BindGroupLayout,
        cpu_environment: bool,
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
            cpu_environment: cpu_environment.then(Default::default),
        }
    }

    /// Whether a frame's environment needs the environment pass.
    pub(super) fn is_procedural(sky: &FrameSky) -> bool {
        matches!(sky, FrameSky::Procedural { .. })
    }

    /// The full-frame path's reduced pass for `sky` (uniforms just
    /// written), if it has one: the procedural environment's, or the image
    /// pass's when the image is drawn reduced; the sky pass then samples it.
    /// `horizon`: the frame's, for the environment's parts; `camera`: its
    /// world-from-camera matrix and intrinsics, for the image pass.
    pub(super) fn encode_reduced(
        &mut self,
        (with, queue): (&SkyPassContext<'_>, &wgpu::Queue),
        encoder: &mut wgpu::CommandEncoder,
        size: (u32, u32),
        (frame_sky, camera): (&FrameSkyDraw<'_>, (&[[f32; 4]; 4], [f32; 4])),
    ) {
        let sky = frame_sky.sky;
        let device = with.factory.device();
        if Self::is_procedural(sky) && self.cpu_environment.is_some() {
            self.upload_environment((device, queue), camera, frame_sky.sun, size);
        } else if Self::is_procedural(sky) {
            self.encode_environment(with, encoder, size, frame_sky.horizon);
        } else if self.written_image_scale().is_some() {
            self.upload_image((device, queue), sky, camera, size);
            self.prepare_upsampled(device, sky);
        }
    }

    /// The target of the environment pass (RGBA16F, linear) and its size.
    pub(super) fn environment_target(&self) -> Option<(&wgpu::Texture, (u32, u32))> {
        let t = self.half.as_ref()?;
        Some((&t.texture, (t.width, t.height)))
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

/// Row `j`'s rays of a reduced pass of `scale` full-resolution pixels a
/// pixel, turned by `m` (camera to world, or to an image's frame), not
/// normalised: through the full-resolution position of each pixel's centre
/// (`p` in `fs_environment`), intrinsics `[fx, fy, cx, cy]`.
#[inline(always)]
fn row_rays(
    m: &glam::Mat3,
    [fx, fy, cx, cy]: [f32; 4],
    (scale, j): (f32, usize),
    (x, y, z): (&mut [f32], &mut [f32], &mut [f32]),
) {
    let py = (j as f32 + 0.5) * scale;
    let base = m.y_axis * ((py - cy) / fy) + m.z_axis;
    for (i, ((x, y), z)) in x.iter_mut().zip(y).zip(z).enumerate() {
        let px = (i as f32 + 0.5) * scale;
        let d: Vec3 = m.x_axis * ((px - cx) / fx) + base;
        (*x, *y, *z) = (d.x, d.y, d.z);
    }
}

/// `f(scratch, j, row j of each plane)` for each row `j` of `w` values of
/// `planes` (all of one size: a pass shaded on the CPU), in parallel on
/// rayon's threads, each with its own `scratch` from `init` (a row's values
/// depend only on its index), compiled for the CPU's widest SIMD level:
/// `f` must be marked `#[inline(always)]` ([`crate::simd::widest`]).
fn plane_rows<const N: usize, S>(
    planes: [&mut [f32]; N],
    w: usize,
    init: impl Fn() -> S + Sync + Send,
    f: impl Fn(&mut S, usize, [&mut [f32]; N]) + Sync + Send,
) {
    use rayon::prelude::*;
    let w = w.max(1);
    let mut planes = planes.map(|p| p.chunks_exact_mut(w));
    let h = planes.iter().map(ExactSizeIterator::len).min().unwrap_or(0);
    let rows: Vec<[&mut [f32]; N]> = (0..h)
        .map(|_| planes.each_mut().map(|p| p.next().unwrap_or_default()))
        .collect();
    rows.into_par_iter()
        .enumerate()
        .for_each_init(init, |scratch, (j, row)| {
            crate::simd::widest(
                #[inline(always)]
                || f(scratch, j, row),
            )
        });
}

mod environment;
mod equirect;
mod image;
mod procedural;
mod uniforms;
mod upload;

use environment::ReducedTarget;
use uniforms::EnvUniforms;
use upload::make_bind_group;

#[cfg(test)]
mod fidelity;
#[cfg(test)]
mod tests;
