//! The wgpu renderer: one module used by the batch runner, the CLI's `frame`
//! command and the tests (and by the GUI preview). It knows nothing of any UI.
//!
//! [`Renderer`] is composed of parts that own their things (pipelines,
//! targets, uploads), each made through the one [`PipelineFactory`] of
//! `gpu.rs`: the drones (`mesh.rs`: meshes, levels of detail, instances,
//! draws), the sky (`sky.rs`), the plates (`plate.rs`), and, built on the
//! first region frame, the region passes (`frame/passes.rs`), the background
//! (`background.rs`), the scenery (`scenery.rs`) and the frame targets with
//! the id layer (`targets.rs`, `id_layer.rs`). Per-frame data (one uniform
//! block, one instance buffer) is rewritten each frame.
//! [`Renderer::render_frame`] is the pipeline's one call (the batch's and the
//! preview's): it draws only the screen regions the drones can touch over a
//! cached background and measures visibility from the same samples, in three
//! steps: a CPU-only plan (`plan.rs`: passes, overlap layers, atlas places,
//! reads), the encoded passes and the collected readback (`readback.rs`,
//! `ids.rs`). The parts import one way: the frame composes the others; the
//! wgpu descriptors they share are in the leaf `gpu.rs`, the upload tiles in
//! `tiles.rs`, what a device's renderers share (the environment pipelines)
//! in the leaf `shared.rs`; the context (`context.rs`) may make a preset's
//! frame targets before any renderer, for its first renderer to take
//! ([`GpuContext::prepare_frame_targets`]). [`Renderer::encode`] draws a whole [`FrameScene`] into any
//! colour view of the right size; [`Renderer::render_rgba`] is that
//! full-frame path offscreen (the reference the region path is tested against).

mod background;
mod context;
mod frame;
mod gpu;
mod haze;
mod horizon;
mod id_layer;
mod ids;
mod impostor;
mod material;
mod mesh;
mod plan;
mod plate;
mod readback;
pub mod regions;
pub mod scenery;
mod shared;
mod sky;
mod targets;
mod tiles;
mod upsample;
pub mod visibility;

pub use context::{GpuContext, PreparedTargets, quiet_headless_vulkan};
pub use frame::{Painted, RenderRequest, RenderedFrame};
/// The pipeline maker, shared with the desktop app's flat paint.
pub(crate) use gpu::{PipelineDesc, PipelineFactory};
#[cfg(feature = "app")]
pub(crate) use gpu::{texture_entry, uniform_entry};
pub use ids::{MAX_DRONES, PixelHit};
use mesh::DronePipelines;
pub use mesh::bound_picks;
pub use shared::SharedPipelines;

use glam::{DMat4, Mat4};

use crate::model::CpuModel;
use crate::model::lod::LodChain;
use crate::scene::FrameScene;
use crate::sky::{EnvironmentAssets, Lighting};
use mesh::Drones;
use readback::Readback;

/// The colour format of every target: sRGB is encoded in the shaders
/// (`linear_to_srgb` in `shaders/common.wgsl`), so the bytes are the same on
/// every backend, with or without sRGB formats.
pub const COLOR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;
/// The depth format [`Renderer::encode`] expects (reversed-Z).
pub const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    #[error(
        "no GPU adapter found (WGPU_BACKEND={backend}): install Mesa's software Vulkan driver (mesa-vulkan-drivers) or a GPU driver: {reason}"
    )]
    NoAdapter {
        backend: String,
        #[source]
        reason: wgpu::RequestAdapterError,
    },
    #[error("cannot open the GPU device: {0}")]
    Device(#[from] wgpu::RequestDeviceError),
    #[error(
        "render.resolution: {width}×{height} exceeds this adapter's largest texture side of {limit} px"
    )]
    TooLarge { width: u32, height: u32, limit: u32 },
    #[error("reading the frame back from the GPU failed: {0}")]
    Readback(#[from] ReadbackError),
    #[error("{count} drones in one frame: instance ids are exact up to {limit}")]
    TooManyDrones { count: usize, limit: usize },
    #[error(
        "{drones} drones in view overlap so densely on screen that sorting them into visibility layers needs more than {limit} box comparisons (the frame's work budget); spread them out, lower placement.count, or use labels.box_method: Amodal with no visibility filter"
    )]
    TooDense { drones: usize, limit: u64 },
    #[error(
        "backplate: the frame names backplate {plate} ({file}), but the renderer holds {held} plates"
    )]
    BackplateMissing {
        plate: usize,
        file: String,
        held: usize,
    },
    #[error("backplate: a backplate's pixels do not fill its size")]
    BackplateSize,
}

/// Why reading a frame (or a pass's target) back from the GPU failed.
#[derive(Debug, thiserror::Error)]
pub enum ReadbackError {
    #[error(transparent)]
    Wait(#[from] wgpu::PollError),
    #[error(transparent)]
    Map(#[from] wgpu::BufferAsyncError),
    /// The mapping's callback was dropped without answering.
    #[error(transparent)]
    NoAnswer(#[from] std::sync::mpsc::RecvError),
    #[error(transparent)]
    View(#[from] wgpu::MapRangeError),
    /// A pass that should have drawn into a target had none.
    #[error("{0} has no target")]
    NoTarget(&'static str),
}

/// Per-frame uniforms; layout matches `shaders/common.wgsl` `Frame`.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct FrameUniforms {
    clip_from_camera: [[f32; 4]; 4],
    world_from_camera: [[f32; 4]; 4],
    intrinsics: [f32; 4],
    sun_dir_world: [f32; 4],
    sun_color: [f32; 4],
    zenith: [f32; 4],
    horizon: [f32; 4],
    ground: [f32; 4],
    /// x: 1 when the frame has an atmosphere (haze on the drones), y: 3.912 / V (per metre).
    atmosphere: [f32; 4],
    /// x: the camera's exposure as a gain on linear light, 2^EV (1 without a camera
    /// model): applied before anything is encoded, so what it darkens was not clipped.
    exposure: [f32; 4],
}

impl FrameUniforms {
    fn new(scene: &FrameScene, lighting: &Lighting) -> Self {
        let cam = &scene.camera;
        let world_from_camera = Mat4::from_mat3(cam.camera_from_world.transpose().as_mat3());
        let f = cam.focal_px() as f32;
        let c = cam.principal_point().as_vec2();
        let rgb = |[r, g, b]: [f32; 3]| [r, g, b, 1.0];
        let sun = scene.sun_direction.as_vec3();
        Self {
            clip_from_camera: cam.clip_from_camera().to_cols_array_2d(),
            world_from_camera: world_from_camera.to_cols_array_2d(),
            intrinsics: [f, f, c.x, c.y],
            sun_dir_world: sun.extend(0.0).to_array(),
            sun_color: rgb(lighting.sun_color),
            zenith: rgb(lighting.zenith),
            horizon: rgb(lighting.horizon),
            ground: rgb(lighting.ground),
            atmosphere: match scene.atmosphere {
                Some(a) => [
                    1.0,
                    (crate::scene::realism::KOSCHMIEDER / a.visibility_m) as f32,
                    0.0,
                    0.0,
                ],
                None => [0.0; 4],
            },
            exposure: [exposure_gain(scene), 0.0, 0.0, 0.0],
        }
    }
}

/// The frame's exposure as a gain on linear light: the camera model's drawn
/// 2^EV, 1 without one. The renderer applies it before it encodes (so
/// surfaces brighter than white keep their headroom under a negative EV) and
/// the camera stage does not apply it again (`CameraDraw::after_render`).
fn exposure_gain(scene: &FrameScene) -> f32 {
    scene
        .camera_model
        .as_ref()
        .map_or(1.0, |d| d.exposure_gain() as f32)
}

/// The views one frame is drawn into.
#[derive(Clone, Copy)]
pub struct FrameViews<'a> {
    /// Colour attachment, `msaa`-sampled, format [`COLOR_FORMAT`].
    pub color: &'a wgpu::TextureView,
    /// Single-sample view to resolve into when `msaa > 1`.
    pub resolve: Option<&'a wgpu::TextureView>,
    /// `Depth32Float`, same size and sample count as `color`.
    pub depth: &'a wgpu::TextureView,
    /// Sample count: 1 or 4.
    pub msaa: u32,
}

/// Per-instance data; layout matches `INSTANCE_ATTRS` (locations 3–7, 10–12).
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct InstanceRaw {
    camera_from_model: [f32; 16],
    /// Drone index + 1 (0 is the sky in the id pass).
    id: u32,
    _pad: [u32; 3],
    /// The air light towards the drone (rgb, display-linear); w: 1 when set
    /// (else the shader takes the frame's horizon term). Used only when the frame has an atmosphere.
    air: [f32; 4],
    /// The drawn base colour (rgb, linear); w: 1 when the drone has a drawn look.
    look: [f32; 4],
    /// The drawn look's metalness, roughness, emission factor, rotor opacity.
    look_material: [f32; 4],
}

const INSTANCE_ATTRS: [wgpu::VertexAttribute; 8] = {
    const fn attr(
        shader_location: u32,
        offset: u64,
        format: wgpu::VertexFormat,
    ) -> wgpu::VertexAttribute {
        wgpu::VertexAttribute {
            format,
            offset,
            shader_location,
        }
    }
    use wgpu::VertexFormat::{Float32x4, Uint32};
    // Offsets as laid out by `InstanceRaw` (the id's padding skipped).
    [
        attr(3, 0, Float32x4),
        attr(4, 16, Float32x4),
        attr(5, 32, Float32x4),
        attr(6, 48, Float32x4),
        attr(7, 64, Uint32),
        attr(10, 80, Float32x4),
        attr(11, 96, Float32x4),
        attr(12, 112, Float32x4),
    ]
};

impl InstanceRaw {
    /// Drone `i` of `scene`: camera_from_model built in f64, id `i + 1`.
    fn new(scene: &FrameScene, i: usize) -> Self {
        let cam = &scene.camera;
        let d = &scene.drones[i];
        let translation = cam.camera_from_world_point(d.position);
        let m = DMat4::from_mat3_translation(
            cam.camera_from_world * glam::DMat3::from_quat(d.rotation) * d.size_m,
            translation,
        );
        let air = match scene.atmosphere.and_then(|_| haze::airlight(scene, i)) {
            Some([r, g, b]) => [r, g, b, 1.0],
            None => [0.0; 4],
        };
        let (look, look_material) = match scene.looks.get(i) {
            Some(l) => (
                [l.albedo[0], l.albedo[1], l.albedo[2], 1.0],
                [l.metalness, l.roughness, l.emissive, l.rotor_opacity],
            ),
            None => ([0.0; 4], [0.0; 4]),
        };
        Self {
            camera_from_model: m.as_mat4().to_cols_array(),
            id: i as u32 + 1,
            _pad: [0; 3],
            air,
            look,
            look_material,
        }
    }
}

/// An instance-id image: `ids[y·width + x]` is the index + 1 of the drone seen
/// at pixel (x, y) (its centre sampled, one sample per pixel), 0 where sky.
#[derive(Clone, Debug, PartialEq)]
pub struct IdImage {
    pub width: u32,
    pub height: u32,
    pub ids: Vec<u32>,
}

/// An offscreen target of one size and sample count, with its readback buffer.
struct Target {
    width: u32,
    height: u32,
    msaa: u32,
    /// Multisampled colour, only when msaa > 1.
    msaa_color: Option<wgpu::TextureView>,
    color: wgpu::Texture,
    color_view: wgpu::TextureView,
    depth: wgpu::TextureView,
    readback: Readback,
}

/// The renderer: the parts a frame is drawn with, each owning its
/// pipelines, targets and uploads, all made through one [`PipelineFactory`].
pub struct Renderer {
    device: wgpu::Device,
    queue: wgpu::Queue,
    /// Makes every pipeline and layout of the parts.
    factory: PipelineFactory,
    /// The adapter's backend (what its shaders may do).
    backend: wgpu::Backend,
    max_texture_side: u32,
    frame_buffer: wgpu::Buffer,
    frame_bind_group: wgpu::BindGroup,
    /// The sky and environments: sky.wgsl, its uniforms, images and reduced passes.
    sky: sky::SkyGpu,
    /// The drones: meshes, drone.wgsl, instances and draws.
    drones: Drones,
    /// The full-frame path's pipelines per sample count.
    pipelines: Vec<FullFramePipelines>,
    /// The full-frame path's target ([`Renderer::render_rgba`]).
    target: Option<Target>,
    /// Region rendering and the id layer, created on first use.
    regions: Option<frame::RegionState>,
    /// Draw only the drones' regions (false: the whole frame as one region).
    use_regions: bool,
    /// Keep each visible pixel's drones ([`RenderedFrame::pixel_hits`]) when measuring visibility.
    keep_pixel_hits: bool,
    /// Whether a frame may take its background's pixels ([`Renderer::set_lend_backgrounds`]).
    lend_backgrounds: bool,
    counts: PassCounts,
    /// Frame buffers handed back by the caller ([`Renderer::recycle`]), reused
    /// for the next frames' pixels: a fresh 4K frame (35 MB) is page-faulted
    /// in anew on every allocation.
    spare: Vec<(Vec<u8>, Painted)>,
    spare_limit: usize,
    /// The photographic backgrounds frames may name ([`Renderer::set_backplates`]).
    plates: plate::Plates,
    /// Targets the context made ahead, taken by the first frame of their shape.
    prepared: PreparedTargets,
}

/// The full-frame path's pipelines for one sample count.
struct FullFramePipelines {
    msaa: u32,
    sky: wgpu::RenderPipeline,
    drone: DronePipelines,
}

/// How many passes a renderer has run. Public for tests and benchmarks
/// only ([`Renderer::pass_counts`]); the pipeline never reads it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PassCounts {
    pub color: u64,
    pub ids: u64,
}

/// WGSL sources, each with the shared header prepended (the id reduction
/// once per sample count it is built for).
pub fn shader_sources() -> [(&'static str, String); 6] {
    let common = include_str!("../../shaders/common.wgsl");
    let rect = include_str!("../../shaders/rect.wgsl");
    [
        (
            "sky.wgsl",
            format!(
                "{common}\n{}\n{}",
                include_str!("../../shaders/environment.wgsl"),
                include_str!("../../shaders/sky.wgsl")
            ),
        ),
        (
            "drone.wgsl",
            format!("{common}\n{}", include_str!("../../shaders/drone.wgsl")),
        ),
        (
            "regions.wgsl",
            format!(
                "{common}\n{rect}\n{}",
                include_str!("../../shaders/regions.wgsl")
            ),
        ),
        (
            "resolve.wgsl",
            format!("{rect}\n{}", include_str!("../../shaders/resolve.wgsl")),
        ),
        ("clutter.wgsl", scenery::shader_source()),
        // The desktop app's own (src/app/flat_paint.rs), listed here to be validated with the rest.
        (
            "flat_paint.wgsl",
            include_str!("../../shaders/flat_paint.wgsl").to_owned(),
        ),
    ]
}

impl Renderer {
    /// Build pipelines and upload the models (index = model index in the
    /// preset), drawn at full detail.
    pub fn new(ctx: &GpuContext, models: &[CpuModel]) -> Self {
        Self::with_lods(ctx, models, &[], 0.0)
    }

    /// Like [`Renderer::new`], with each model's chain of levels of detail
    /// (`lods[m]`, from [`crate::model::lod::build_lods`]; a model without
    /// one is drawn at full detail): each drone is drawn with the coarsest
    /// level whose silhouette error stays within `max_error_px` pixels.
    pub fn with_lods(
        ctx: &GpuContext,
        models: &[CpuModel],
        lods: &[std::sync::Arc<LodChain>],
        max_error_px: f64,
    ) -> Self {
        let device = ctx.device.clone();
        let factory = PipelineFactory::new(&device);
        let frame_layout = factory.bind_group_layout(
            "frame uniforms layout",
            &[gpu::uniform_entry(0, wgpu::ShaderStages::VERTEX_FRAGMENT)],
        );
        let frame_buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("frame uniforms"),
            size: std::mem::size_of::<FrameUniforms>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let frame_bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("frame uniforms"),
            layout: &frame_layout,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: frame_buffer.as_entire_binding(),
            }],
        });
        // A CPU rasteriser's environment passes cost more than shading
        // them on the CPU directly (sky/procedural.rs).
        let cpu = ctx.adapter_info.device_type == wgpu::DeviceType::Cpu;
        let sky = sky::SkyGpu::new(&factory, &ctx.queue, ctx.shared.clone(), &frame_layout, cpu);
        let drones = Drones::new(
            (&factory, &ctx.queue),
            &frame_layout,
            models,
            lods,
            max_error_px,
        );
        Self {
            device,
            queue: ctx.queue.clone(),
            factory,
            backend: ctx.adapter_info.backend,
            max_texture_side: ctx.max_texture_side,
            frame_buffer,
            frame_bind_group,
            sky,
            drones,
            pipelines: Vec::new(),
            target: None,
            regions: None,
            use_regions: true,
            keep_pixel_hits: false,
            lend_backgrounds: false,
            counts: PassCounts::default(),
            spare: Vec::new(),
            spare_limit: 2,
            plates: plate::Plates::default(),
            prepared: ctx.prepared.clone(),
        }
    }

    /// Hand back a frame's pixel buffer, unchanged, with what it holds
    /// ([`RenderedFrame::painted`]), once it is no longer needed, so a later
    /// frame can reuse its memory (at most [`Renderer::keep_spares`] are kept).
    pub fn recycle(&mut self, buffer: Vec<u8>, painted: Painted) {
        if self.spare.len() < self.spare_limit {
            self.spare.push((buffer, painted));
        }
    }

    /// A recycled buffer (stale contents) for a picture made on the CPU in
    /// place of the rendered one, such as the thermal camera's; empty when
    /// none is kept.
    pub fn spare_buffer(&mut self) -> Vec<u8> {
        self.spare
            .pop()
            .map(|(buffer, _)| buffer)
            .unwrap_or_default()
    }

    /// Keep up to `n` recycled buffers (2 unless set): as many as a caller
    /// has frames in flight, so none is freed and allocated again (a 4K
    /// buffer is 35 MB of fresh pages).
    pub fn keep_spares(&mut self, n: usize) {
        self.spare_limit = n;
        self.spare.truncate(n);
    }

    /// Let a frame's buffer take its background's own memory instead of a
    /// copy (8 MB at 1080p), where the background was drawn for that frame
    /// and the one before drew its own too (a camera that moves every frame,
    /// a new environment every frame). The renderer then no longer holds
    /// that background: [`Renderer::background_pixels`] gives `None` for
    /// such a frame, so a caller that reads them leaves this off (the
    /// default; a batch's makers turn it on where the preset's frames do
    /// not read them). The pixels are the same either way.
    pub fn set_lend_backgrounds(&mut self, on: bool) {
        self.lend_backgrounds = on;
    }

    /// A buffer holding the background `cache` holds for this frame: its
    /// own pixels where it lends them ([`Renderer::set_lend_backgrounds`]),
    /// else [`Renderer::frame_buffer`]'s copy.
    fn frame_pixels(&mut self, cache: &mut background::BackgroundCache, width: u32) -> Vec<u8> {
        cache.finish();
        if self.lend_backgrounds && cache.lendable() {
            let spare = self.spare.pop().map(|(b, _)| b).unwrap_or_default();
            return cache.lend(spare);
        }
        self.frame_buffer(cache.pixels(), cache.generation, width)
    }

    /// A buffer holding `background` (generation `generation`, rows of
    /// `width` pixels), reusing a recycled one when there is one: one that
    /// already holds the same background gets back only the rects painted
    /// over it, any other a full copy.
    fn frame_buffer(&mut self, background: &[u8], generation: u64, width: u32) -> Vec<u8> {
        let (mut buffer, painted) = self.spare.pop().unwrap_or_default();
        if generation != 0 && painted.background == generation && buffer.len() == background.len() {
            let stride = width as usize * 4;
            for r in &painted.rects {
                let (x0, x1) = (r.x0 as usize * 4, r.x1 as usize * 4);
                for y in r.y0 as usize..r.y1 as usize {
                    let row = y * stride;
                    buffer[row + x0..row + x1].copy_from_slice(&background[row + x0..row + x1]);
                }
            }
        } else {
            buffer.clear();
            buffer.extend_from_slice(background);
        }
        buffer
    }

    /// Draw a drone whose projected size (its span over its centre's depth)
    /// is under `below_px` pixels as its model's impostor (`impostors[m]`,
    /// from [`crate::model::impostor::bake`]; index = model index). Pipelines
    /// built before are dropped (they lack the impostor variant).
    pub fn set_impostors(&mut self, impostors: &[crate::model::impostor::Impostor], below_px: f64) {
        (self.drones).set_impostors((&self.device, &self.queue), impostors, below_px);
        self.pipelines.clear();
        self.regions = None;
    }

    /// Drones per level of detail over the drones of `scene` (for tests and
    /// benchmarks; the pipeline never reads it).
    pub fn level_histogram(&self, scene: &FrameScene) -> Vec<usize> {
        self.drones.level_histogram(scene)
    }

    /// Passes run so far (for tests and benchmarks).
    pub fn pass_counts(&self) -> PassCounts {
        self.counts
    }

    /// Whether the id readback (its resolve pipelines and targets) has been
    /// set up: only on the first frame that measures visibility (for tests).
    pub fn has_id_pipeline(&self) -> bool {
        self.regions
            .as_ref()
            .is_some_and(frame::RegionState::has_id_readback)
    }

    /// Draw only the drones' screen regions (the default), or the whole frame
    /// as one region (`false`: for tests and benchmarks that compare the two).
    pub fn set_regions(&mut self, on: bool) {
        self.use_regions = on;
    }

    /// Keep, with a frame's measured visibility, the drones each pixel shows
    /// ([`RenderedFrame::pixel_hits`]; for masks). Off by default: costs nothing then.
    pub fn set_pixel_hits(&mut self, on: bool) {
        self.keep_pixel_hits = on;
    }

    /// A named error for sizes the adapter cannot render.
    fn check_size(&self, width: u32, height: u32) -> Result<(), RenderError> {
        if width == 0
            || height == 0
            || width > self.max_texture_side
            || height > self.max_texture_side
        {
            return Err(RenderError::TooLarge {
                width,
                height,
                limit: self.max_texture_side,
            });
        }
        Ok(())
    }

    /// The full-frame path's pipelines for `msaa` samples, built on first use.
    fn pipelines(&mut self, msaa: u32) -> usize {
        if let Some(i) = self.pipelines.iter().position(|p| p.msaa == msaa) {
            return i;
        }
        let color = [gpu::color_target(COLOR_FORMAT)];
        let program = &self.sky.program;
        let sky = self.factory.render(&PipelineDesc {
            depth: gpu::depth_test(DEPTH_FORMAT, false, wgpu::CompareFunction::Always),
            samples: msaa,
            ..PipelineDesc::new(
                "sky pipeline",
                &program.layout,
                &program.module,
                "fs_main",
                &color,
            )
        });
        let drone =
            (self.drones).pipelines(&self.factory, "drone pipeline", msaa, "fs_main", &color);
        self.pipelines.push(FullFramePipelines { msaa, sky, drone });
        self.pipelines.len() - 1
    }

    /// Write the frame's uniforms: the camera, and the environment's sky and
    /// lighting; returns the frame uniforms written.
    fn upload_uniforms(&mut self, scene: &FrameScene) -> FrameUniforms {
        let sun = scene.sun_direction.as_vec3();
        let image_scale = self.sky.image_scale(&scene.sky, &scene.camera);
        let mut lighting = self.sky.prepare(
            &self.queue,
            &scene.sky,
            &scene.environment,
            sun,
            scene.atmosphere.map(|a| a.visibility_m),
            image_scale,
        );
        self.plates.lighting(scene, &mut lighting);
        let uniforms = FrameUniforms::new(scene, &lighting);
        self.queue
            .write_buffer(&self.frame_buffer, 0, bytemuck::bytes_of(&uniforms));
        uniforms
    }

    /// Upload the sky images of the preset's environment (see
    /// [`EnvironmentAssets::load`]); frames whose sky names an image that was
    /// not uploaded draw the default gradient.
    pub fn set_environment(&mut self, assets: &EnvironmentAssets) {
        self.sky
            .set_images(&self.device, &self.queue, assets, self.max_texture_side);
        if let Some(state) = &mut self.regions {
            state.forget_backgrounds();
        }
    }

    /// Hold the plates that frames may name (`FramePlate::plate` indexes
    /// them); cached backgrounds are dropped.
    pub fn set_backplates(&mut self, plates: &[crate::sky::plates::Plate]) {
        self.plates = plate::Plates(plates.to_vec());
        if let Some(state) = &mut self.regions {
            state.forget_backgrounds();
        }
    }

    /// Write the instances of the drones `include` accepts (camera_from_model
    /// built in f64), grouped by model; returns each model's instance range.
    fn upload_instances(
        &mut self,
        scene: &FrameScene,
        include: &dyn Fn(usize) -> bool,
    ) -> mesh::InstanceRanges {
        let mut data: Vec<InstanceRaw> = Vec::new();
        let drones = (0..scene.drones.len()).filter(|&i| include(i));
        let ranges = self.drones.instances(scene, drones, &mut data);
        self.drones
            .upload_instances((&self.device, &self.queue), &data);
        ranges
    }

    /// Encode the frame into `views` (any views of the scene camera's size).
    pub fn encode(
        &mut self,
        encoder: &mut wgpu::CommandEncoder,
        scene: &FrameScene,
        views: &FrameViews<'_>,
    ) {
        let FrameViews {
            color,
            resolve,
            depth,
            msaa,
        } = *views;
        let uniforms = self.upload_uniforms(scene);
        let size = (scene.camera.width, scene.camera.height);
        let with = sky::SkyPassContext {
            factory: &self.factory,
            frame_group: &self.frame_bind_group,
        };
        let frame_sky = sky::FrameSkyDraw {
            sky: &scene.sky,
            horizon: horizon::Horizon::of(&uniforms.world_from_camera, uniforms.intrinsics, size),
            sun: glam::Vec4::from(uniforms.sun_dir_world).truncate(),
        };
        let camera = (&uniforms.world_from_camera, uniforms.intrinsics);
        self.sky
            .encode_reduced((&with, &self.queue), encoder, size, (&frame_sky, camera));
        let ranges = self.upload_instances(scene, &|_| true);
        self.counts.color += 1;
        let p = self.pipelines(msaa);
        let FullFramePipelines { sky, drone, .. } = &self.pipelines[p];
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("frame pass"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: color,
                depth_slice: None,
                resolve_target: resolve,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(wgpu::Color::BLACK),
                    store: wgpu::StoreOp::Store,
                },
            })],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: depth,
                // Reversed-Z: 0 is infinitely far.
                depth_ops: Some(wgpu::Operations {
                    load: wgpu::LoadOp::Clear(0.0),
                    store: wgpu::StoreOp::Discard,
                }),
                stencil_ops: None,
            }),
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_bind_group(0, &self.frame_bind_group, &[]);
        pass.set_bind_group(1, self.sky.bind_group_for(&scene.sky), &[]);
        pass.set_pipeline(sky);
        pass.draw(0..3, 0..1);
        self.drones.draw(&mut pass, drone, &ranges);
    }

    fn ensure_target(&mut self, width: u32, height: u32, msaa: u32) -> Result<(), RenderError> {
        self.check_size(width, height)?;
        if self
            .target
            .as_ref()
            .is_some_and(|t| t.width == width && t.height == height && t.msaa == msaa)
        {
            return Ok(());
        }
        let texture = |label: &str, format, samples, usage| {
            gpu::texture_2d(
                &self.device,
                label,
                (width, height),
                (format, samples),
                usage,
            )
        };
        let color = texture(
            "frame colour",
            COLOR_FORMAT,
            1,
            wgpu::TextureUsages::RENDER_ATTACHMENT
                | wgpu::TextureUsages::COPY_SRC
                | wgpu::TextureUsages::TEXTURE_BINDING,
        );
        let msaa_color = (msaa > 1).then(|| {
            texture(
                "frame colour (msaa)",
                COLOR_FORMAT,
                msaa,
                wgpu::TextureUsages::RENDER_ATTACHMENT,
            )
            .create_view(&Default::default())
        });
        let depth = texture(
            "frame depth",
            DEPTH_FORMAT,
            msaa,
            wgpu::TextureUsages::RENDER_ATTACHMENT,
        )
        .create_view(&Default::default());
        let readback = Readback::new(&self.device, "frame readback", width, height);
        let color_view = color.create_view(&Default::default());
        self.target = Some(Target {
            width,
            height,
            msaa,
            msaa_color,
            color,
            color_view,
            depth,
            readback,
        });
        Ok(())
    }

    /// Render offscreen and read back tightly packed RGBA8 (sRGB-encoded) pixels.
    pub fn render_rgba(&mut self, scene: &FrameScene, msaa: u32) -> Result<Vec<u8>, RenderError> {
        let (width, height) = (scene.camera.width, scene.camera.height);
        self.ensure_target(width, height, msaa)?;
        let target = self
            .target
            .take()
            .ok_or(ReadbackError::NoTarget("the full-frame pass"))?;
        let mut encoder = self
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("frame"),
            });
        let views = match &target.msaa_color {
            Some(ms) => FrameViews {
                color: ms,
                resolve: Some(&target.color_view),
                depth: &target.depth,
                msaa,
            },
            None => FrameViews {
                color: &target.color_view,
                resolve: None,
                depth: &target.depth,
                msaa,
            },
        };
        self.encode(&mut encoder, scene, &views);
        target.readback.copy_from(&mut encoder, &target.color);
        let submitted = self.queue.submit([encoder.finish()]);
        let result = target.readback.read(&self.device, submitted);
        self.target = Some(target);
        result
    }
}

/// Write `bytes` at the start of the vertex buffer in `slot`, reused from
/// frame to frame and replaced by one twice as large when too small.
fn write_vertices(
    (device, queue): (&wgpu::Device, &wgpu::Queue),
    slot: &mut Option<wgpu::Buffer>,
    label: &str,
    bytes: &[u8],
) {
    let needed = (bytes.len() as u64).max(256);
    if slot.as_ref().is_none_or(|b| b.size() < needed) {
        *slot = Some(device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: needed.next_power_of_two(),
            usage: wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        }));
    }
    if let Some(buffer) = slot
        && !bytes.is_empty()
    {
        queue.write_buffer(buffer, 0, bytes);
    }
}

/// Linear-to-sRGB as the shaders do it (used by tests that predict pixels).
pub use crate::sky::linear_to_srgb;

const _: () = assert!(std::mem::offset_of!(InstanceRaw, air) == 80);
const _: () = assert!(std::mem::offset_of!(InstanceRaw, look_material) == 112);
// FrameUniforms must be a multiple of 16 bytes for WGSL uniform layout.
const _: () = assert!(std::mem::size_of::<FrameUniforms>().is_multiple_of(16));
