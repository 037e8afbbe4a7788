//! The drones' part of the frame ([`Drones`]): each model's vertices and
//! its levels of detail in one index buffer, the draws of each level by
//! surface kind, drone.wgsl and the drone pipelines built in the surface
//! variants the meshes use, the choice of a drone's level, the instances
//! (grouped by model and level, uploaded into one reused buffer) and the
//! instanced draws. With impostors ([`Drones::set_impostors`]) a drone
//! smaller than their threshold is drawn as the quad of its model's
//! impostor ([`super::impostor`]) nearest its view: its "level" is then the
//! model's level count + the direction's index.

use std::ops::Range;
use std::sync::Arc;

use wgpu::util::DeviceExt;

use super::gpu::{PipelineDesc, PipelineFactory, Program, depth_test};
use super::impostor::GpuImpostor;
use super::{DEPTH_FORMAT, INSTANCE_ATTRS, InstanceRaw, material};
use crate::model::impostor::Impostor;
use crate::model::lod::LodChain;
use crate::model::{CpuModel, Vertex};
use crate::scene::camera::Camera;
use crate::scene::projection::LabelGeometry;
use crate::scene::{DronePose, FrameScene};

/// The drones' part of the frame: what every pass that draws drones (the
/// full-frame path's, the region passes, the id passes) draws them with.
pub(super) struct Drones {
    /// drone.wgsl, laid out with the frame uniforms and the material.
    program: Program,
    meshes: Vec<GpuMesh>,
    /// Each model's hull: where its drones can put pixels.
    geometry: Vec<LabelGeometry>,
    /// The surface kinds the meshes' draws use: the pipeline variants to build.
    surfaces: [bool; Surface::COUNT],
    /// The material of untextured draw ranges (1×1 white).
    white_texture: wgpu::BindGroup,
    /// How `@group(1)` (a draw's texture) is laid out.
    material_layout: wgpu::BindGroupLayout,
    /// How `@group(0)` (the frame uniforms) is laid out.
    frame_layout: wgpu::BindGroupLayout,
    /// Each model's impostor (empty: none), drawn for drones under
    /// `impostor_below_px` pixels (0: never).
    impostors: Vec<Option<GpuImpostor>>,
    impostor_below_px: f64,
    /// Silhouette error allowed to a level of detail, in pixels (0: full detail).
    lod_error_px: f64,
    /// The instances of the frame's draws, reused and grown as needed.
    instances: Option<wgpu::Buffer>,
}

/// A frame's drone instances of one pass, grouped by (model, level of detail).
pub(super) type InstanceRanges = Vec<(MeshLevel, Range<u32>)>;

pub(super) struct GpuMesh {
    vertices: wgpu::Buffer,
    /// Every level's indices, level 0 (the full mesh) first.
    indices: wgpu::Buffer,
    /// Levels of detail, finest first (see [`crate::model::lod`]).
    levels: Vec<GpuLevel>,
    /// The levels' chain, which picks a drone's level (`None`: full detail).
    chain: Option<Arc<LodChain>>,
    textures: Vec<wgpu::BindGroup>,
}

/// One level of detail of a [`GpuMesh`].
struct GpuLevel {
    draws: Vec<GpuDraw>,
}

/// An index range drawn with one texture bind group (`None`: the white one)
/// and the pipeline variant its surface needs.
struct GpuDraw {
    indices: Range<u32>,
    texture: Option<usize>,
    surface: Surface,
}

/// What a draw's material asks of the drone pipeline: back faces culled
/// unless double-sided (as glTF specifies), the alpha test only for masked
/// materials (without `discard` the depth test runs before shading), and the
/// texture fetch only for textured ones (untextured ranges would multiply by
/// the 1×1 white texture's exact 1.0: same bytes, a sampler run per fragment).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct Surface {
    double_sided: bool,
    alpha_mask: bool,
    textured: bool,
    /// Holds glTF BLEND triangles: the `_blend` fragment entries, which turn
    /// alpha into MSAA coverage (`shaders/drone.wgsl`, `coverage_mask`).
    alpha_blend: bool,
}

impl Surface {
    pub(super) const COUNT: usize = 16;
    /// Impostor quads: single-sided, textured, the atlas alpha as coverage.
    const IMPOSTOR: Surface = Surface {
        double_sided: false,
        alpha_mask: false,
        textured: true,
        alpha_blend: true,
    };
    const ALL: [Surface; Self::COUNT] = {
        let mut all = [Surface::of(0); Self::COUNT];
        let mut i = 0;
        while i < Self::COUNT {
            all[i] = Surface::of(i);
            i += 1;
        }
        all
    };
    const fn of(index: usize) -> Self {
        Self {
            double_sided: index & 1 != 0,
            alpha_mask: index & 2 != 0,
            textured: index & 4 != 0,
            alpha_blend: index & 8 != 0,
        }
    }
    fn from_draw(d: &crate::model::DrawRange) -> Self {
        Self {
            double_sided: d.double_sided,
            alpha_mask: d.alpha_mask,
            textured: d.texture.is_some(),
            alpha_blend: d.alpha_blend,
        }
    }
    fn index(self) -> usize {
        usize::from(self.double_sided)
            | usize::from(self.alpha_mask) << 1
            | usize::from(self.textured) << 2
            | usize::from(self.alpha_blend) << 3
    }
}

/// A drone pipeline (one fragment entry, sample count and targets) in the
/// variants the renderer's meshes use, indexed by [`Surface::index`].
pub(super) struct DronePipelines([Option<wgpu::RenderPipeline>; Surface::COUNT]);

/// What one instanced draw shares: a model and its level of detail.
pub(super) type MeshLevel = (usize, usize);

/// Upload `models` (and the coarser levels of `lods[m]`, when given) and
/// the textures of their materials; returns the meshes and which surface
/// kinds their draws use (the drone pipeline variants to build).
fn upload_meshes(
    (device, queue): (&wgpu::Device, &wgpu::Queue),
    material_bgl: &wgpu::BindGroupLayout,
    models: &[CpuModel],
    lods: &[Arc<LodChain>],
) -> (Vec<GpuMesh>, [bool; Surface::COUNT]) {
    let meshes = models
        .iter()
        .enumerate()
        .map(|(k, m)| {
            // Level 0 is the model's own mesh; coarser levels follow in one index buffer.
            let mut indices = m.indices.clone();
            let gpu_draw = |d: &crate::model::DrawRange, base: u32| GpuDraw {
                indices: d.indices.start + base..d.indices.end + base,
                texture: d.texture,
                surface: Surface::from_draw(d),
            };
            let mut levels = vec![GpuLevel {
                draws: m.draws.iter().map(|d| gpu_draw(d, 0)).collect(),
            }];
            let chain = lods.get(k);
            for lod in chain.map_or(&[][..], |c| c.levels().get(1..).unwrap_or(&[])) {
                let base = indices.len() as u32;
                indices.extend_from_slice(&lod.indices);
                levels.push(GpuLevel {
                    draws: lod.draws.iter().map(|d| gpu_draw(d, base)).collect(),
                });
            }
            GpuMesh {
                vertices: device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                    label: Some(&format!("{} vertices", m.name)),
                    contents: bytemuck::cast_slice(&m.vertices),
                    usage: wgpu::BufferUsages::VERTEX,
                }),
                indices: device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                    label: Some(&format!("{} indices", m.name)),
                    contents: bytemuck::cast_slice(&indices),
                    usage: wgpu::BufferUsages::INDEX,
                }),
                levels,
                chain: chain.cloned(),
                textures: m
                    .textures
                    .iter()
                    .map(|t| {
                        let label = format!("{} texture {}", m.name, t.name);
                        material::upload(device, queue, material_bgl, t, &label)
                    })
                    .collect(),
            }
        })
        .collect::<Vec<GpuMesh>>();
    let mut surfaces = [false; Surface::COUNT];
    for d in meshes.iter().flat_map(|m| &m.levels).flat_map(|l| &l.draws) {
        surfaces[d.surface.index()] = true;
    }
    (meshes, surfaces)
}

impl Drones {
    /// Upload `models` (with `lods`, see [`super::Renderer::with_lods`]) and
    /// make drone.wgsl's program, laid out after `frame_layout` (`@group(0)`).
    pub(super) fn new(
        (factory, queue): (&PipelineFactory, &wgpu::Queue),
        frame_layout: &wgpu::BindGroupLayout,
        models: &[CpuModel],
        lods: &[Arc<LodChain>],
        max_error_px: f64,
    ) -> Self {
        let device = factory.device();
        let material_layout = material::bind_group_layout(factory);
        let [_, (name, source), ..] = super::shader_sources();
        let program = factory.program(name, source, &[frame_layout, &material_layout]);
        let white_texture = material::white(device, queue, &material_layout);
        let (meshes, surfaces) = upload_meshes((device, queue), &material_layout, models, lods);
        Self {
            program,
            meshes,
            geometry: models.iter().map(LabelGeometry::from).collect(),
            surfaces,
            white_texture,
            material_layout,
            frame_layout: frame_layout.clone(),
            impostors: Vec::new(),
            impostor_below_px: 0.0,
            lod_error_px: if max_error_px.is_finite() {
                max_error_px.max(0.0)
            } else {
                0.0
            },
            instances: None,
        }
    }

    /// Upload `impostors` (index = model index) and draw a drone with its
    /// model's below `below_px` pixels (its span over its centre's depth).
    /// Pipelines built before miss the impostor variant: call this first.
    pub(super) fn set_impostors(
        &mut self,
        (device, queue): (&wgpu::Device, &wgpu::Queue),
        impostors: &[Impostor],
        below_px: f64,
    ) {
        let layout = &self.material_layout;
        self.impostors = (impostors.iter())
            .map(|i| Some(GpuImpostor::new((device, queue), layout, i)))
            .collect();
        self.impostor_below_px = if below_px.is_finite() { below_px } else { 0.0 };
        self.surfaces[Surface::IMPOSTOR.index()] |= !impostors.is_empty();
    }

    /// The impostor level drone `i` of `scene` is drawn with, if any: when
    /// its projected size is under the threshold, the model's level count +
    /// the direction (in model space) nearest the camera's.
    fn impostor_level(&self, scene: &FrameScene, i: usize) -> Option<usize> {
        let d = &scene.drones[i];
        let cam = &scene.camera;
        if !drawn_as_impostor(cam, d, self.impostor_below_px) {
            return None;
        }
        let impostor = self.impostors.get(d.model)?.as_ref()?;
        let levels = self.meshes.get(d.model)?.levels.len();
        // The camera (the origin) seen from the drone, in model space.
        let centre = cam.camera_from_world_point(d.position);
        let rotation = cam.camera_from_world * glam::DMat3::from_quat(d.rotation);
        Some(levels + impostor.nearest(rotation.transpose() * -centre))
    }

    /// Each model's hull (index = model index).
    pub(super) fn geometry(&self) -> &[LabelGeometry] {
        &self.geometry
    }
    /// The level of detail drone `i` of `scene` is drawn with: the coarsest
    /// whose error, scaled by the drone's size over the depth of its nearest
    /// possible point, is within the renderer's pixel budget (level 0 when
    /// any part of the drone may be at or behind the camera plane).
    fn level_of(&self, scene: &FrameScene, i: usize) -> usize {
        if let Some(level) = self.impostor_level(scene, i) {
            return level;
        }
        let d = &scene.drones[i];
        let Some(mesh) = self.meshes.get(d.model) else {
            return 0;
        };
        let Some(chain) = (mesh.chain.as_ref()).filter(|_| self.lod_error_px > 0.0) else {
            return 0;
        };
        if mesh.levels.len() < 2 {
            return 0;
        }
        pick_level(chain, &scene.camera, d, self.lod_error_px)
    }

    /// Drones drawn per level of detail, over the drones of `scene`.
    pub(super) fn level_histogram(&self, scene: &FrameScene) -> Vec<usize> {
        let mut counts = Vec::new();
        for i in 0..scene.drones.len() {
            let level = self.level_of(scene, i);
            if counts.len() <= level {
                counts.resize(level + 1, 0);
            }
            counts[level] += 1;
        }
        counts
    }

    /// The instances of `drones` (in scene order, drone index + 1 as id)
    /// appended to `data`, grouped by (model, level of detail); each
    /// group's instance range in `data`.
    pub(super) fn instances(
        &self,
        scene: &FrameScene,
        drones: impl IntoIterator<Item = usize>,
        data: &mut Vec<InstanceRaw>,
    ) -> InstanceRanges {
        let mut order: Vec<(MeshLevel, usize)> = (drones.into_iter())
            .map(|i| ((scene.drones[i].model, self.level_of(scene, i)), i))
            .collect();
        order.sort_unstable();
        let mut ranges: InstanceRanges = Vec::new();
        for (key, i) in order {
            let idx = data.len() as u32;
            data.push(InstanceRaw::new(scene, i));
            match ranges.last_mut() {
                Some((k, r)) if *k == key => r.end = idx + 1,
                _ => ranges.push((key, idx..idx + 1)),
            }
        }
        ranges
    }

    /// Write the frame's instances into the (reused, grown as needed) instance buffer.
    pub(super) fn upload_instances(
        &mut self,
        (device, queue): (&wgpu::Device, &wgpu::Queue),
        data: &[InstanceRaw],
    ) {
        let bytes: &[u8] = bytemuck::cast_slice(data);
        let slot = &mut self.instances;
        super::write_vertices((device, queue), slot, "drone instances", bytes);
    }

    /// The drone pipelines for `msaa` samples with fragment entry `entry`
    /// writing `targets` (colour, or colour + instance id), in the surface
    /// variants this renderer's meshes use.
    pub(super) fn pipelines(
        &self,
        factory: &PipelineFactory,
        label: &str,
        msaa: u32,
        entry: &str,
        targets: &[Option<wgpu::ColorTargetState>],
    ) -> DronePipelines {
        let depth = depth_test(DEPTH_FORMAT, true, wgpu::CompareFunction::Greater);
        let layout = &self.program.layout;
        self.variants(factory, (label, layout, depth), (msaa, entry, targets))
    }

    /// The footprint pipelines for `msaa` samples (`fs_footprint`, with
    /// `footprint_layout` at `@group(2)`, `depth` and no colour target: see
    /// `frame/footprint.rs`), in the surface variants the meshes use.
    pub(super) fn footprint_pipelines(
        &self,
        factory: &PipelineFactory,
        msaa: u32,
        footprint_layout: &wgpu::BindGroupLayout,
        depth: Option<wgpu::DepthStencilState>,
    ) -> DronePipelines {
        let groups = [&self.frame_layout, &self.material_layout, footprint_layout];
        let layout = factory.layout("drone footprint pipeline layout", &groups);
        let label = "drone footprint pipeline";
        self.variants(
            factory,
            (label, &layout, depth),
            (msaa, "fs_footprint", &[]),
        )
    }

    /// The drone pipelines (`label`, laid out by `layout`, with `depth`)
    /// for `msaa` samples with fragment entry `entry` (`_blend` appended
    /// for translucent ranges) writing `targets`, one per surface variant
    /// the meshes use.
    fn variants(
        &self,
        factory: &PipelineFactory,
        (label, layout, depth): (&str, &wgpu::PipelineLayout, Option<wgpu::DepthStencilState>),
        (msaa, entry, targets): (u32, &str, &[Option<wgpu::ColorTargetState>]),
    ) -> DronePipelines {
        let vertex_attrs = wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3, 2 => Float32x4, 8 => Float32x2, 9 => Float32x4];
        let buffers = [
            Some(wgpu::VertexBufferLayout {
                array_stride: std::mem::size_of::<Vertex>() as u64,
                step_mode: wgpu::VertexStepMode::Vertex,
                attributes: &vertex_attrs,
            }),
            Some(wgpu::VertexBufferLayout {
                array_stride: std::mem::size_of::<InstanceRaw>() as u64,
                step_mode: wgpu::VertexStepMode::Instance,
                attributes: &INSTANCE_ATTRS,
            }),
        ];
        let variant = |surface: Surface| {
            let flag = |on: bool| if on { 1.0 } else { 0.0 };
            let samples = f64::from(msaa);
            let blend_constants = [
                ("ALPHA_MASK", flag(surface.alpha_mask)),
                ("TEXTURED", flag(surface.textured)),
                ("SAMPLES", samples),
            ];
            // Translucent (glTF BLEND) ranges: the same entry with `_blend`,
            // which also writes the fragment's coverage mask.
            let (entry, constants) = if surface.alpha_blend {
                (format!("{entry}_blend"), &blend_constants[..])
            } else {
                (entry.to_owned(), &blend_constants[..2])
            };
            let module = &self.program.module;
            factory.render(&PipelineDesc {
                buffers: &buffers,
                constants,
                // glTF: single-sided materials cull back faces (meshes are
                // counter-clockwise, negative scales already flipped).
                primitive: wgpu::PrimitiveState {
                    front_face: wgpu::FrontFace::Ccw,
                    cull_mode: (!surface.double_sided).then_some(wgpu::Face::Back),
                    ..Default::default()
                },
                depth: depth.clone(),
                samples: msaa,
                ..PipelineDesc::new(label, layout, module, &entry, targets)
            })
        };
        DronePipelines(Surface::ALL.map(|k| self.surfaces[k.index()].then(|| variant(k))))
    }

    /// Draw instance ranges of the uploaded instances (frame uniforms bound
    /// at group 0), each with its level's draws and their pipelines.
    pub(super) fn draw(
        &self,
        pass: &mut wgpu::RenderPass<'_>,
        pipelines: &DronePipelines,
        ranges: &[(MeshLevel, Range<u32>)],
    ) {
        let Some(instances) = &self.instances else {
            return;
        };
        if ranges.is_empty() {
            return;
        }
        pass.set_vertex_buffer(1, instances.slice(..));
        let mut bound: Option<usize> = None;
        for ((model, level), range) in ranges {
            let Some(mesh) = self.meshes.get(*model) else {
                continue;
            };
            let Some(lod) = mesh.levels.get(*level) else {
                let k = Surface::IMPOSTOR.index();
                let impostor = self.impostors.get(*model).and_then(Option::as_ref);
                if let (Some(impostor), Some(pipeline)) = (impostor, &pipelines.0[k]) {
                    if bound != Some(k) {
                        pass.set_pipeline(pipeline);
                        bound = Some(k);
                    }
                    impostor.draw(pass, level - mesh.levels.len(), range.clone());
                }
                continue;
            };
            pass.set_vertex_buffer(0, mesh.vertices.slice(..));
            pass.set_index_buffer(mesh.indices.slice(..), wgpu::IndexFormat::Uint32);
            for draw in &lod.draws {
                let k = draw.surface.index();
                let Some(pipeline) = &pipelines.0[k] else {
                    continue;
                };
                if bound != Some(k) {
                    pass.set_pipeline(pipeline);
                    bound = Some(k);
                }
                let bind_group = draw
                    .texture
                    .and_then(|t| mesh.textures.get(t))
                    .unwrap_or(&self.white_texture);
                pass.set_bind_group(1, bind_group, &[]);
                pass.draw_indexed(draw.indices.clone(), 0, range.clone());
            }
        }
    }
}

/// Whether drone `d` is small enough to be drawn as its model's impostor
/// (`below_px`, 0 for none): its size in pixels over the depth of its centre,
/// with all of it in front of the camera plane.
fn drawn_as_impostor(cam: &Camera, d: &DronePose, below_px: f64) -> bool {
    if below_px <= 0.0 {
        return false;
    }
    let centre = cam.camera_from_world_point(d.position);
    if centre.z - d.size_m * 0.5 * 3f64.sqrt() <= cam.near_m {
        return false;
    }
    // NaN compares false: drawn as a mesh.
    d.size_m * cam.focal_px() / centre.z < below_px
}

/// The level of `chain` drone `d` is drawn with: the coarsest whose error,
/// scaled by the drone's size over the depth of its nearest possible point,
/// is within `lod_error_px` (level 0 when any part of the drone may be at or
/// behind the camera plane). Finds the bounds it passes.
fn pick_level(chain: &LodChain, cam: &Camera, d: &DronePose, lod_error_px: f64) -> usize {
    let nearest = cam.camera_from_world_point(d.position).z - d.size_m * 0.5 * 3f64.sqrt();
    if nearest.is_nan() || nearest <= cam.near_m {
        return 0;
    }
    chain.pick(d.size_m * cam.focal_px() / nearest, lod_error_px)
}

/// The picks a renderer drawing `scene` will make (each model's chain in
/// `chains`, `lod_error_px` and `impostor_below_px` as the renderer's), made
/// ahead of it: the bounds they pass are found here, each once (the picks'
/// levels do not depend on who finds them), so that a thread can find them
/// while a batch sets up. A first run's chains come with only their coarse
/// levels bounded (docs/benchmarks.md, "Start-up").
pub fn bound_picks(
    scene: &FrameScene,
    chains: &[Arc<LodChain>],
    lod_error_px: f64,
    impostor_below_px: f64,
) {
    if lod_error_px <= 0.0 {
        return;
    }
    let cam = &scene.camera;
    for d in &scene.drones {
        let Some(chain) = chains.get(d.model).filter(|c| c.levels().len() >= 2) else {
            continue;
        };
        if !drawn_as_impostor(cam, d, impostor_below_px) {
            pick_level(chain, cam, d, lod_error_px);
        }
    }
}
