//! The preview renderer: the batch's own [`Renderer`] drawing the selected
//! frame into a fresh texture that egui then shows.
//!
//! Threading (the choice issue 3 leaves open): every preview render runs on a
//! worker thread ([`super::worker::LatestWorker`]) that owns a
//! [`PreviewRenderer`]. It shares eframe's wgpu device and queue, encodes the
//! frame with [`Renderer::encode`], submits, and waits for *its own*
//! submission on the worker thread, so the measured time includes the GPU and
//! the UI thread never waits. Each render goes into a new colour texture, so
//! the texture egui is showing is never written while it is on screen; the
//! UI swaps the new one in with `update_egui_texture_from_wgpu_texture`.
//!
//! The picture matches the batch output: the frame is built by the same
//! [`FramePipeline`], and only the camera's pixel size is changed to the pane size
//! (same aspect ratio), so the intrinsics scale with it (focal length ∝ height,
//! principal point at the centre). Labels stay in output pixels; the overlay
//! scales them. This module knows nothing of egui, so the benchmark drives it
//! headless.

use std::sync::Arc;
use std::time::Instant;

use glam::DVec3;
use serde::{Deserialize, Serialize};

use crate::annotate::DroneLabel;
use crate::pipeline::FramePipeline;
use crate::preset::Preset;
use crate::preset::sweep::decode_mixed_radix;
use crate::render::{COLOR_FORMAT, DEPTH_FORMAT, FrameViews, GpuContext, Renderer};
use crate::scene::camera::Camera;
use crate::scene::math::{look_at_cv, plane_rotation};
use crate::scene::{FrameScene, camera_position};

/// At most this many sweep camera positions are drawn in the inspect view.
pub const MAX_INSPECT_CAMERAS: u64 = 2000;
/// Vertical field of view of the inspect view's orbit camera.
pub const INSPECT_FOV_Y_DEG: f64 = 50.0;

/// The inspect view's orbit camera, around the centre of the observation volume.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct Orbit {
    pub yaw_deg: f64,
    pub pitch_deg: f64,
    /// Distance as a fraction of the distance that fits every sweep camera in view.
    pub zoom: f64,
}

impl Default for Orbit {
    fn default() -> Self {
        Self {
            yaw_deg: 40.0,
            pitch_deg: 25.0,
            zoom: 1.0,
        }
    }
}

/// What the preview pane shows.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PreviewView {
    /// Exactly what the batch camera sees for the frame, before the camera model.
    Camera,
    /// The batch camera's frame through the preset's camera model (noise,
    /// blur, JPEG, …), applied on the CPU at the pane's size; the clean
    /// picture when the preset has no camera model.
    ThroughCamera,
    /// The scene from outside, with the volume and the sweep's camera positions.
    Inspect(Orbit),
}

/// Everything that decides a preview picture; a new key means a new render.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PreviewKey {
    /// Bumped by the app whenever the preset changes.
    pub generation: u64,
    pub frame: u64,
    pub size_px: [u32; 2],
    pub view: PreviewView,
}

#[derive(Clone)]
pub struct PreviewRequest {
    pub key: PreviewKey,
    /// The preset with model paths resolved.
    pub preset: Arc<Preset>,
}

/// World-space geometry the inspect view draws over the render.
#[derive(Clone, Debug)]
pub struct InspectGeometry {
    /// The observation volume's box, rotated with the scene (PlaneRX/RY/RZ).
    pub volume_corners: [DVec3; 8],
    /// Camera centres of the sweep (CameraX × CameraY × CameraZ), sampled if there are many.
    pub sweep_cameras: Vec<DVec3>,
    pub sweep_cameras_total: u64,
    /// The selected frame's camera centre.
    pub frame_camera: DVec3,
}

/// A finished preview.
pub struct PreviewFrame {
    pub key: PreviewKey,
    /// Colour texture of `key.size_px`, format [`COLOR_FORMAT`].
    pub texture: wgpu::TextureView,
    /// The frame at output resolution (its labels are in output pixels).
    pub scene: FrameScene,
    pub labels: Vec<DroneLabel>,
    /// The camera the picture was drawn with (pane-sized batch camera, or the orbit camera).
    pub camera: Camera,
    pub inspect: Option<InspectGeometry>,
    /// Build + encode + GPU time of this render.
    pub render_ms: f64,
}

/// Why a preview could not be made.
#[derive(Clone, Debug)]
pub struct PreviewError {
    pub key: PreviewKey,
    pub message: String,
    /// The models could not be loaded (shown in the Models panel too).
    pub models: bool,
}

pub type PreviewResult = Result<PreviewFrame, PreviewError>;

/// The pipeline of the previewed preset and a renderer holding its assets.
struct Loaded {
    pipeline: FramePipeline,
    renderer: Renderer,
}

struct Targets {
    size_px: [u32; 2],
    msaa: u32,
    msaa_color: Option<wgpu::TextureView>,
    depth: wgpu::TextureView,
}

/// Long-lived preview state: loaded models, pipelines, depth/MSAA targets.
pub struct PreviewRenderer {
    ctx: GpuContext,
    loaded: Option<Loaded>,
    targets: Option<Targets>,
}

impl PreviewRenderer {
    pub fn new(ctx: GpuContext) -> Self {
        Self {
            ctx,
            loaded: None,
            targets: None,
        }
    }

    /// Build, render and wait for one preview.
    pub fn render(&mut self, request: &PreviewRequest) -> PreviewResult {
        let start = Instant::now();
        let key = request.key;
        let fail = |message: String, models: bool| PreviewError {
            key,
            message,
            models,
        };
        let preset = &*request.preset;
        let [width, height] = key.size_px;
        if width == 0
            || height == 0
            || width > self.ctx.max_texture_side
            || height > self.ctx.max_texture_side
        {
            return Err(fail(
                format!(
                    "preview size {width}×{height} is outside this adapter's 1..{} px",
                    self.ctx.max_texture_side
                ),
                false,
            ));
        }
        let loaded = self
            .load(preset)
            .map_err(|(message, models)| fail(message, models))?;
        let scene = loaded
            .pipeline
            .scene(key.frame)
            .map_err(|e| fail(e.to_string(), false))?;
        // The exact labels the batch writes (visibility measured when the preset needs it).
        let labels = loaded
            .pipeline
            .labels(&mut loaded.renderer, &scene)
            .map_err(|e| fail(e.to_string(), false))?;

        let (camera, inspect) = view_camera(preset, &scene, key.view, width, height);
        let mut drawn = scene.clone();
        drawn.camera = camera;

        let msaa = preset.render.msaa;
        let (msaa_color, depth) = self.targets(key.size_px, msaa);
        let texture = self.ctx.device.create_texture(&wgpu::TextureDescriptor {
            label: Some("preview colour"),
            size: wgpu::Extent3d {
                width,
                height,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: COLOR_FORMAT,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT
                | wgpu::TextureUsages::TEXTURE_BINDING
                | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        });
        let view = texture.create_view(&wgpu::TextureViewDescriptor::default());
        if key.view == PreviewView::ThroughCamera && drawn.camera_model.is_some() {
            // The batch's own pipeline at the pane's size: render, read back,
            // camera model on the CPU; the picture is uploaded as it comes.
            let loaded = self
                .loaded
                .as_mut()
                .ok_or_else(|| fail("models are not loaded".into(), true))?;
            let made = loaded
                .pipeline
                .make_scene(&mut loaded.renderer, drawn)
                .map_err(|e| fail(e.to_string(), false))?;
            self.ctx.queue.write_texture(
                wgpu::TexelCopyTextureInfo {
                    texture: &texture,
                    mip_level: 0,
                    origin: wgpu::Origin3d::ZERO,
                    aspect: wgpu::TextureAspect::All,
                },
                &made.rgba,
                wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(4 * width),
                    rows_per_image: Some(height),
                },
                wgpu::Extent3d {
                    width,
                    height,
                    depth_or_array_layers: 1,
                },
            );
            let submission = self.ctx.queue.submit([]);
            self.ctx
                .device
                .poll(wgpu::PollType::Wait {
                    submission_index: Some(submission),
                    timeout: None,
                })
                .map_err(|e| fail(format!("waiting for the preview upload: {e}"), false))?;
            return Ok(PreviewFrame {
                key,
                texture: view,
                scene,
                labels,
                camera,
                inspect,
                render_ms: start.elapsed().as_secs_f64() * 1e3,
            });
        }
        let mut encoder = self
            .ctx
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("preview"),
            });
        let loaded = self
            .loaded
            .as_mut()
            .ok_or_else(|| fail("models are not loaded".into(), true))?;
        let views = match &msaa_color {
            Some(ms) => FrameViews {
                color: ms,
                resolve: Some(&view),
                depth: &depth,
                msaa,
            },
            None => FrameViews {
                color: &view,
                resolve: None,
                depth: &depth,
                msaa,
            },
        };
        loaded.renderer.encode(&mut encoder, &drawn, &views);
        let submission = self.ctx.queue.submit([encoder.finish()]);
        self.ctx
            .device
            .poll(wgpu::PollType::Wait {
                submission_index: Some(submission),
                timeout: None,
            })
            .map_err(|e| fail(format!("waiting for the preview render: {e}"), false))?;
        Ok(PreviewFrame {
            key,
            texture: view,
            scene,
            labels,
            camera,
            inspect,
            render_ms: start.elapsed().as_secs_f64() * 1e3,
        })
    }

    /// The pipeline of `preset` and its renderer: kept while an edit leaves
    /// the models and sky images alone, rebuilt otherwise. Errors say whether
    /// loading the models failed.
    fn load(&mut self, preset: &Preset) -> Result<&mut Loaded, (String, bool)> {
        let loaded = match self.loaded.take() {
            Some(l) if l.pipeline.assets().serve(preset) => Loaded {
                pipeline: l
                    .pipeline
                    .update(preset.clone())
                    .map_err(|e| (e.to_string(), false))?,
                renderer: l.renderer,
            },
            _ => {
                let pipeline =
                    FramePipeline::new(preset.clone()).map_err(|e| (e.to_string(), true))?;
                let renderer = pipeline.renderer(&self.ctx);
                Loaded { pipeline, renderer }
            }
        };
        Ok(self.loaded.insert(loaded))
    }

    /// MSAA colour (when msaa > 1) and depth views of this size, reused while the size holds.
    fn targets(
        &mut self,
        size_px: [u32; 2],
        msaa: u32,
    ) -> (Option<wgpu::TextureView>, wgpu::TextureView) {
        let targets = match self.targets.take() {
            Some(t) if t.size_px == size_px && t.msaa == msaa => t,
            _ => {
                let device = &self.ctx.device;
                let texture = |label: &str, format, samples| {
                    device
                        .create_texture(&wgpu::TextureDescriptor {
                            label: Some(label),
                            size: wgpu::Extent3d {
                                width: size_px[0],
                                height: size_px[1],
                                depth_or_array_layers: 1,
                            },
                            mip_level_count: 1,
                            sample_count: samples,
                            dimension: wgpu::TextureDimension::D2,
                            format,
                            usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
                            view_formats: &[],
                        })
                        .create_view(&wgpu::TextureViewDescriptor::default())
                };
                let msaa_color =
                    (msaa > 1).then(|| texture("preview colour (msaa)", COLOR_FORMAT, msaa));
                let depth = texture("preview depth", DEPTH_FORMAT, msaa);
                Targets {
                    size_px,
                    msaa,
                    msaa_color,
                    depth,
                }
            }
        };
        let views = (targets.msaa_color.clone(), targets.depth.clone());
        self.targets = Some(targets);
        views
    }
}

/// The camera a preview of `view` draws with: the frame's own camera at the
/// pane's pixel size (same aspect, so the intrinsics scale with it), or the
/// inspect view's orbit camera with its scene geometry.
fn view_camera(
    preset: &Preset,
    scene: &FrameScene,
    view: PreviewView,
    width: u32,
    height: u32,
) -> (Camera, Option<InspectGeometry>) {
    match view {
        PreviewView::Camera | PreviewView::ThroughCamera => {
            let mut camera = scene.camera;
            camera.width = width;
            camera.height = height;
            (camera, None)
        }
        PreviewView::Inspect(orbit) => {
            let geometry = inspect_geometry(preset, scene);
            (
                orbit_camera(&orbit, &geometry, scene, width, height),
                Some(geometry),
            )
        }
    }
}

/// The volume box, the sweep's camera positions and the frame's camera, in world metres.
pub fn inspect_geometry(preset: &Preset, scene: &FrameScene) -> InspectGeometry {
    let half = scene.volume_half_extent_m;
    let s = &scene.sweep;
    let rotation = plane_rotation(s.PlaneRX, s.PlaneRY, s.PlaneRZ);
    let volume_corners = std::array::from_fn(|i| {
        let sign = |bit: usize| if i & bit == 0 { -1.0 } else { 1.0 };
        rotation * DVec3::new(sign(1) * half.x, sign(2) * half.y, sign(4) * half.z)
    });
    let axes = [preset.camera.x, preset.camera.y, preset.camera.z];
    let radices = axes.map(|a| a.count().unwrap_or(1));
    let total: u64 = radices.iter().product();
    let stride = total.div_ceil(MAX_INSPECT_CAMERAS).max(1);
    let sweep_cameras = (0..total)
        .step_by(usize::try_from(stride).unwrap_or(usize::MAX))
        .map(|i| {
            let d = decode_mixed_radix(i, &radices);
            camera_position(
                axes[0].value(d[0]),
                axes[1].value(d[1]),
                axes[2].value(d[2]),
                scene.volume_radius_m,
                preset.camera.fov_y_deg,
            )
        })
        .collect();
    InspectGeometry {
        volume_corners,
        sweep_cameras,
        sweep_cameras_total: total,
        frame_camera: scene.camera.position,
    }
}

/// The orbit camera: looks at the volume's centre from a distance that fits
/// every sweep camera (scaled by `zoom`).
pub fn orbit_camera(
    orbit: &Orbit,
    geometry: &InspectGeometry,
    scene: &FrameScene,
    width: u32,
    height: u32,
) -> Camera {
    let reach = geometry
        .sweep_cameras
        .iter()
        .chain(&[geometry.frame_camera])
        .chain(&geometry.volume_corners)
        .map(|p| p.length())
        .fold(scene.volume_radius_m, f64::max)
        .max(1e-3);
    let half_fov = (INSPECT_FOV_Y_DEG.to_radians() * 0.5)
        .min(f64::from(width) / f64::from(height.max(1)) * INSPECT_FOV_Y_DEG.to_radians() * 0.5);
    let distance = reach / half_fov.sin() * 1.05 * orbit.zoom.clamp(0.02, 10.0);
    let (yaw, pitch) = (
        orbit.yaw_deg.to_radians(),
        orbit.pitch_deg.clamp(-89.0, 89.0).to_radians(),
    );
    let position = DVec3::new(
        pitch.cos() * yaw.sin(),
        pitch.sin(),
        pitch.cos() * yaw.cos(),
    ) * distance;
    Camera {
        width,
        height,
        fov_y_deg: INSPECT_FOV_Y_DEG,
        position,
        camera_from_world: look_at_cv(position, DVec3::ZERO).unwrap_or(glam::DMat3::IDENTITY),
        near_m: scene.camera.near_m,
    }
}
