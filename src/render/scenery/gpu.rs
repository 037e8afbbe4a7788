//! The scenery's GPU side: the layer uploaded where the region passes
//! read it, and the overlay pass that draws it over the drones with its
//! sample mask and depth (`shaders/clutter.wgsl`).

use std::hash::{Hash, Hasher};

use super::{ClutterLayer, SceneryLight, rasterize_into};
use crate::render::gpu::{
    PassViews, PipelineDesc, PipelineFactory, depth_test, load_pass, texture_entry,
};
use crate::render::regions::PassDraws;
use crate::render::{COLOR_FORMAT, DEPTH_FORMAT, FrameUniforms};
use crate::scene::FrameScene;
use crate::scene::clutter::Shape;

/// A cache key of what the layer depends on.
fn layer_key(scene: &FrameScene, samples: u32, light: &SceneryLight) -> u64 {
    let mut h = std::collections::hash_map::DefaultHasher::new();
    let mut f = |v: f64| v.to_bits().hash(&mut h);
    let cam = &scene.camera;
    for v in cam
        .position
        .to_array()
        .into_iter()
        .chain(cam.camera_from_world.to_cols_array())
    {
        f(v);
    }
    f(cam.fov_y_deg);
    f(cam.near_m);
    let light_values = [light.sun, light.ambient, light.horizon].concat();
    for v in light_values
        .into_iter()
        .chain([light.extinction_per_m, light.exposure])
    {
        f(f64::from(v));
    }
    for p in scene.clutter.iter().flat_map(|c| &c.primitives) {
        match &p.shape {
            Shape::Segment {
                a,
                b,
                radius_a_m,
                radius_b_m,
            } => {
                for v in a.to_array().into_iter().chain(b.to_array()) {
                    f(v);
                }
                f(*radius_a_m);
                f(*radius_b_m);
            }
            Shape::Polygon(points) => {
                for v in points.iter().flat_map(|p| p.to_array()) {
                    f(v);
                }
            }
        }
        for v in p.albedo.into_iter().chain([p.sun_facing]) {
            f(f64::from(v));
        }
    }
    (cam.width, cam.height, samples).hash(&mut h);
    h.finish()
}

/// The scenery part of the frame: the layer (CPU and textures), its
/// upload and the overlay pipelines.
pub(in crate::render) struct SceneryGpu {
    layout: wgpu::BindGroupLayout,
    module: wgpu::ShaderModule,
    pipelines: Vec<SceneryPipelines>,
    /// The uploaded layer's key, its size and bind group.
    uploaded: Option<(u64, (u32, u32), wgpu::BindGroup)>,
    /// The layer's textures (colour, depth) of `uploaded`'s size, reused
    /// from layer to layer.
    textures: Option<(wgpu::Texture, wgpu::Texture)>,
    /// Per tile (see `tiles::take_stale_tiles`): whether the textures
    /// still lack the layer there. A layer is written only under the
    /// regions the scenery pass draws, when a frame first needs it.
    stale: Vec<bool>,
    /// The CPU layer (for the background composite).
    layer: Option<ClutterLayer>,
}

/// The overlay pipelines for one sample count.
struct SceneryPipelines {
    samples: u32,
    with_color: wgpu::RenderPipeline,
    ids_only: wgpu::RenderPipeline,
}

/// What the scenery pass draws over: the rect buffer, a pass's draws (their
/// rects) and the targets' sample count.
pub(in crate::render) struct SceneryDraw<'a> {
    pub rects: &'a wgpu::Buffer,
    pub draws: &'a PassDraws,
    pub samples: u32,
}

/// Rasterise and upload `scene`'s scenery into `slot` (made on first use)
/// unless the same layer is already there; its key, or `None` (and nothing
/// built) without clutter.
pub(in crate::render) fn prepare(
    slot: &mut Option<SceneryGpu>,
    factory: &PipelineFactory,
    scene: &FrameScene,
    uniforms: &FrameUniforms,
    samples: u32,
) -> Option<u64> {
    let clutter = scene.clutter.as_ref()?;
    if clutter.primitives.is_empty() {
        return None;
    }
    let gpu = slot.get_or_insert_with(|| SceneryGpu::new(factory));
    gpu.ensure_pipelines(factory, samples);
    let light = SceneryLight::from_uniforms(uniforms);
    let key = layer_key(scene, samples, &light);
    if gpu.uploaded.as_ref().map(|u| u.0) == Some(key) {
        return Some(key);
    }
    let mut layer = gpu.layer.take().unwrap_or_default();
    rasterize_into(scene, samples, &light, &mut layer);
    let (width, height) = (layer.width, layer.height);
    let group = match gpu.uploaded.take() {
        Some((_, size, group)) if size == (width, height) && gpu.textures.is_some() => group,
        _ => gpu.make_textures(factory.device(), (width, height)),
    };
    let (across, down) = crate::render::tiles::upload_tiles((width, height));
    gpu.stale = vec![true; across as usize * down as usize];
    gpu.uploaded = Some((key, (width, height), group));
    gpu.layer = Some(layer);
    Some(key)
}

impl SceneryGpu {
    fn new(factory: &PipelineFactory) -> Self {
        let entry = |binding| texture_entry(binding, false, wgpu::TextureViewDimension::D2, false);
        Self {
            layout: factory.bind_group_layout("scenery layout", &[entry(0), entry(1)]),
            module: factory.shader("clutter.wgsl", shader_source()),
            pipelines: Vec::new(),
            uploaded: None,
            textures: None,
            stale: Vec::new(),
            layer: None,
        }
    }

    /// The uploaded layer's key and the layer.
    pub(in crate::render) fn layer(&self) -> Option<(u64, &ClutterLayer)> {
        Some((self.uploaded.as_ref()?.0, self.layer.as_ref()?))
    }

    /// New colour and depth textures of `size` (kept in `self.textures`)
    /// and the group that binds them.
    fn make_textures(
        &mut self,
        device: &wgpu::Device,
        (width, height): (u32, u32),
    ) -> wgpu::BindGroup {
        let texture = |label: &str, format| {
            let usage = wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST;
            crate::render::gpu::texture_2d(device, label, (width, height), (format, 1), usage)
        };
        let color = texture("scenery colour", wgpu::TextureFormat::Rgba8Unorm);
        let depth = texture("scenery depth", wgpu::TextureFormat::R32Float);
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("scenery layer"),
            layout: &self.layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: wgpu::BindingResource::TextureView(
                        &color.create_view(&Default::default()),
                    ),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::TextureView(
                        &depth.create_view(&Default::default()),
                    ),
                },
            ],
        });
        self.textures = Some((color, depth));
        group
    }

    /// Write the prepared layer's stale tiles under `rects` into its
    /// textures (colour and depth, both 4 bytes a pixel).
    pub(in crate::render) fn upload_under<'r>(
        &mut self,
        queue: &wgpu::Queue,
        rects: impl IntoIterator<Item = &'r crate::render::regions::Rect>,
    ) {
        let (Some(layer), Some((color, depth))) = (&self.layer, &self.textures) else {
            return;
        };
        let size = (layer.width, layer.height);
        let colour: &[u8] = bytemuck::cast_slice(&layer.color);
        let depths: &[u8] = bytemuck::cast_slice(&layer.depth);
        for part in crate::render::tiles::take_stale_tiles(&mut self.stale, size, rects) {
            crate::render::tiles::write_part(queue, color, colour, layer.width, &part);
            crate::render::tiles::write_part(queue, depth, depths, layer.width, &part);
        }
    }

    /// The overlay pipelines for `samples`, built on first use.
    fn ensure_pipelines(&mut self, factory: &PipelineFactory, samples: u32) {
        if self.pipelines.iter().any(|p| p.samples == samples) {
            return;
        }
        let layout = factory.layout("scenery pipeline layout", &[&self.layout]);
        let color = crate::render::gpu::color_target(COLOR_FORMAT);
        let id = crate::render::gpu::color_target(crate::render::ids::ID_FORMAT);
        let buffers = [Some(crate::render::gpu::rect_buffer_layout())];
        let make = |label: &str, entry: &str, targets: &[Option<wgpu::ColorTargetState>]| {
            factory.render(&PipelineDesc {
                buffers: &buffers,
                depth: depth_test(DEPTH_FORMAT, true, wgpu::CompareFunction::Greater),
                samples,
                ..PipelineDesc::new(label, &layout, &self.module, entry, targets)
            })
        };
        let with_color = make("scenery pipeline", "fs_main", &[color, id.clone()]);
        let ids_only = make("scenery id pipeline", "fs_ids", &[None, id]);
        self.pipelines.push(SceneryPipelines {
            samples,
            with_color,
            ids_only,
        });
    }

    /// Draw the uploaded scenery over `draw`'s rects, after their drones:
    /// one pass loading the targets (with `views.color`: the colour target too).
    pub(in crate::render) fn encode(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        views: PassViews<'_>,
        draw: &SceneryDraw<'_>,
    ) {
        let (Some((_, _, group)), Some(pipes)) = (
            &self.uploaded,
            self.pipelines.iter().find(|p| p.samples == draw.samples),
        ) else {
            return;
        };
        let mut pass = load_pass(encoder, "scenery pass", views);
        pass.set_pipeline(if views.color.is_some() {
            &pipes.with_color
        } else {
            &pipes.ids_only
        });
        pass.set_bind_group(0, group, &[]);
        pass.set_vertex_buffer(0, draw.rects.slice(..));
        pass.draw(0..6, draw.draws.rect_instances());
    }
}

/// The scenery shader as the renderer compiles it (also validated by tests/suite/shaders.rs).
pub(crate) fn shader_source() -> String {
    format!(
        "{}\n{}",
        include_str!("../../../shaders/rect.wgsl"),
        include_str!("../../../shaders/clutter.wgsl")
    )
}
