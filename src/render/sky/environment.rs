//! The procedural environment's reduced passes: drawn at half resolution
//! (the sky above the silhouettes at a quarter) into RGBA16F targets, in the
//! parts of render/horizon.rs, with pipelines specialised per environment
//! kind and shared between the device's renderers.

use wgpu::util::DeviceExt;

use super::procedural::{self, Procedural};
use super::{HALF_SCALE, QUARTER_SCALE, SkyGpu, SkyPassContext, make_bind_group};
use crate::render::gpu::{PipelineDesc, Program};
use crate::render::horizon::Horizon;

/// One of the procedural environment's reduced-resolution targets.
pub(super) struct ReducedTarget {
    pub(super) width: u32,
    pub(super) height: u32,
    pub(super) texture: wgpu::Texture,
    pub(super) view: wgpu::TextureView,
    /// Samples `view` as `env_half`.
    pub(super) group: wgpu::BindGroup,
}

impl SkyGpu {
    /// Draw the procedural environment of the uniforms just written into the
    /// half-resolution target (resized to the frame's `width`×`height` as
    /// needed), in the parts of render/horizon.rs for the frame's `horizon`.
    /// The sky and the ground are drawn first at a quarter of the
    /// resolution; the half-resolution pass interpolates the sky (behind
    /// the band's silhouettes too) and the ground below its lower line there.
    pub(in crate::render) fn encode_environment(
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
        // Every part samples the quarter-resolution pass: it is drawn first,
        // over all the parts' polygons at its own scale.
        let quarter_pass = (!draws.is_empty()).then(|| {
            let quarter = self.ensure_target(device, QUARTER_SCALE, frame);
            let parts = horizon.parts(band_top, quarter, QUARTER_SCALE as f32);
            (
                4,
                parts.into_iter().flat_map(|(_, t)| t).collect::<Vec<_>>(),
            )
        });
        let quarter_pipeline = quarter_pass
            .as_ref()
            .map(|(part, _)| self.environment_pipeline(with, *part));
        let pipelines: Vec<usize> = draws
            .iter()
            .map(|(part, _)| self.environment_pipeline(with, *part))
            .collect();
        let vertices: Vec<[f32; 2]> = quarter_pass
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
            (&quarter_pass, quarter_pipeline, &self.quarter)
        {
            let mut pass = crate::render::gpu::clear_pass(
                encoder,
                "environment pass (quarter resolution)",
                &quarter.view,
            );
            pass.set_bind_group(0, with.frame_group, &[]);
            pass.set_bind_group(1, &self.default_group, &[]);
            draw(&mut pass, triangles, pipeline);
            group = &quarter.group;
        }
        // Not cleared: the parts' polygons cover every texel and each
        // texel is drawn by its part (`horizon`, `in_part`), so nothing of
        // the frame before shows (suite test `environments::a_frame_of_…`).
        let mut pass = crate::render::gpu::covering_pass(encoder, "environment pass", &half.view);
        pass.set_bind_group(0, with.frame_group, &[]);
        pass.set_bind_group(1, group, &[]);
        for ((_, triangles), pipeline) in draws.iter().zip(pipelines) {
            draw(&mut pass, triangles, pipeline);
        }
    }

    /// The procedural environment of the uniforms just written, shaded on
    /// the CPU (`procedural::shade`) for a `frame`-sized frame seen through
    /// `camera` (world-from-camera matrix and intrinsics) with the sun
    /// toward `sun`, into `texels` (the half-resolution pass's red, green
    /// and blue planes); its size. `None` when this adapter draws the
    /// environment itself or the sky is not procedural.
    pub(in crate::render) fn shade_environment(
        &mut self,
        (world_from_camera, intrinsics): (&[[f32; 4]; 4], [f32; 4]),
        sun: glam::Vec3,
        frame: (u32, u32),
        texels: &mut [Vec<f32>; 3],
    ) -> Option<(u32, u32)> {
        let passes = self.cpu_environment.as_mut()?;
        if self.written.mode[0] != 1.0 {
            return None;
        }
        let env = Procedural::new(&self.written, sun);
        let view = procedural::View {
            world_from_camera: glam::Mat3::from_mat4(glam::Mat4::from_cols_array_2d(
                world_from_camera,
            )),
            intrinsics,
        };
        Some(procedural::shade(&env, &view, frame, passes, texels))
    }

    /// Whether this adapter's procedural environments are shaded on the
    /// CPU ([`SkyGpu::shade_environment`]).
    pub(in crate::render) fn shades_environment_on_cpu(&self) -> bool {
        self.cpu_environment.is_some()
    }

    /// The full-frame path's environment shaded on the CPU
    /// ([`SkyGpu::shade_environment`]) and written into the half-resolution
    /// target that the sky pass samples.
    pub(super) fn upload_environment(
        &mut self,
        (device, queue): (&wgpu::Device, &wgpu::Queue),
        camera: (&[[f32; 4]; 4], [f32; 4]),
        sun: glam::Vec3,
        frame: (u32, u32),
    ) {
        let mut texels = Default::default();
        let Some(size) = self.shade_environment(camera, sun, frame, &mut texels) else {
            return;
        };
        self.ensure_target(device, HALF_SCALE, frame);
        let Some(half) = &self.half else {
            return;
        };
        super::upload::write_half_floats(queue, &half.texture, size, &texels);
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
    /// 4: the quarter-resolution pass's sky and ground), built on first
    /// use; its index in `self.pipelines`. A part is built only for the
    /// kinds it draws (the others are -1, never read): the ground side and
    /// the quarter-resolution pass for their ground, the band for its
    /// silhouettes, the sky above the band for none. Environments that
    /// share them share the part's pipeline: each pipeline costs lavapipe
    /// tens of milliseconds of shader compilation.
    fn environment_pipeline(&mut self, with: &SkyPassContext<'_>, part: u32) -> usize {
        let (ground, far, near) = (
            self.written.pattern[2],
            self.written.pattern[3],
            self.written.far_params[1],
        );
        let kinds = match part {
            0 => [ground, far, near],
            1 => [-1.0, far, near],
            2 | 4 => [ground, -1.0, -1.0],
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
}

/// A reduced pass's target of `size` (RGBA16F, linear) and its view:
/// drawn into, read back for the CPU upsampling (COPY_SRC) and sampled by
/// the full-frame path's sky pass.
pub(super) fn reduced_texture(
    device: &wgpu::Device,
    label: &str,
    (width, height): (u32, u32),
) -> (wgpu::Texture, wgpu::TextureView) {
    let texture = crate::render::gpu::texture_2d(
        device,
        label,
        (width, height),
        (wgpu::TextureFormat::Rgba16Float, 1),
        wgpu::TextureUsages::RENDER_ATTACHMENT
            | wgpu::TextureUsages::TEXTURE_BINDING
            | wgpu::TextureUsages::COPY_SRC
            | wgpu::TextureUsages::COPY_DST,
    );
    let view = texture.create_view(&Default::default());
    (texture, view)
}

/// The pipeline of a reduced pass (`fragment`: `fs_environment`) into an RGBA16F target, with its override `constants`;
/// `polygon`: drawn over given triangles, else one full-screen triangle.
pub(super) fn environment_pipeline(
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
    let targets = [crate::render::gpu::color_target(
        wgpu::TextureFormat::Rgba16Float,
    )];
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
