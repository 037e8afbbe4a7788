//! The preview renderer: the batch's own frame path drawing the selected
//! frame, uploaded into a fresh texture that egui then shows.
//!
//! Threading (the choice issue 3 leaves open): every preview render runs on a
//! worker thread ([`super::worker::LatestWorker`]) that owns a
//! [`PreviewRenderer`]. It shares eframe's wgpu device and queue, makes the
//! picture, uploads it and waits for *its own* submission on the worker
//! thread, so the measured time includes the GPU and the UI thread never
//! waits. Each render goes into a new colour texture, so the texture egui is
//! showing is never written while it is on screen; the UI swaps the new one
//! in with `update_egui_texture_from_wgpu_texture`.
//!
//! The picture is the batch's by construction: the frame is built by the
//! same [`FramePipeline`] and made by its [`FramePipeline::make_scene`]
//! (the renderer's region path, its targets and background cache), with
//! only the camera changed: the frame's own camera at the pane's pixel size
//! (same aspect ratio, so the intrinsics scale with it: focal length ∝
//! height, principal point at the centre), or the inspect view's orbit
//! camera. The camera model runs only in the "through the camera" view.
//! Labels stay in output pixels; the overlay scales them. This module knows
//! nothing of egui, so the benchmark drives it headless.

use std::sync::Arc;
use std::time::Instant;

use glam::DVec3;
use serde::{Deserialize, Serialize};

use crate::annotate::DroneLabel;
use crate::pipeline::{FramePipeline, PipelineError};
use crate::preset::Preset;
use crate::preset::sweep::decode_mixed_radix;
use crate::render::{COLOR_FORMAT, GpuContext, RenderError, Renderer};
use crate::scene::camera::Camera;
use crate::scene::math::{look_at_cv, plane_rotation};
use crate::scene::{FrameError, FrameScene, camera_position};

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

/// Why a preview's picture could not be made or uploaded; its message is
/// [`PreviewError::message`].
#[derive(Debug, thiserror::Error)]
pub enum PictureError {
    #[error("preview size {width}×{height} is outside this adapter's 1..{side} px")]
    Size { width: u32, height: u32, side: u32 },
    /// The preset's models (or sky images) could not be loaded.
    #[error(transparent)]
    Load(PipelineError),
    /// The edited preset, or the frame made from it, failed in the pipeline.
    #[error(transparent)]
    Pipeline(#[from] PipelineError),
    #[error(transparent)]
    Frame(#[from] FrameError),
    #[error(transparent)]
    Render(#[from] RenderError),
    #[error("waiting for the preview upload: {0}")]
    Upload(#[from] wgpu::PollError),
}

impl PictureError {
    /// Whether loading the models failed (shown in the Models panel too).
    pub fn models(&self) -> bool {
        matches!(self, Self::Load(_))
    }
}

/// The pipeline of the previewed preset and a renderer holding its assets.
struct Loaded {
    pipeline: FramePipeline,
    renderer: Renderer,
}

/// A preview's picture before it is uploaded.
pub struct PreviewPicture {
    /// Tightly packed RGBA8 (sRGB-encoded) of the request's pane size.
    pub rgba: Vec<u8>,
    /// The frame at output resolution (its labels are in output pixels).
    pub scene: FrameScene,
    pub labels: Vec<DroneLabel>,
    /// The camera the picture was drawn with.
    pub camera: Camera,
    pub inspect: Option<InspectGeometry>,
}

/// Long-lived preview state: the loaded pipeline and its renderer.
pub struct PreviewRenderer {
    ctx: GpuContext,
    loaded: Option<Loaded>,
}

impl PreviewRenderer {
    pub fn new(ctx: GpuContext) -> Self {
        Self { ctx, loaded: None }
    }

    /// Build, render and wait for one preview.
    pub fn render(&mut self, request: &PreviewRequest) -> PreviewResult {
        let start = Instant::now();
        let key = request.key;
        let fail = |e: PictureError| PreviewError {
            key,
            message: e.to_string(),
            models: e.models(),
        };
        let picture = self.picture(request).map_err(fail)?;
        let texture = self.upload(&picture.rgba, key.size_px).map_err(fail)?;
        if let Some(loaded) = self.loaded.as_mut() {
            // Its memory serves the next preview.
            loaded.renderer.recycle(picture.rgba, Default::default());
        }
        Ok(PreviewFrame {
            key,
            texture,
            scene: picture.scene,
            labels: picture.labels,
            camera: picture.camera,
            inspect: picture.inspect,
            render_ms: start.elapsed().as_secs_f64() * 1e3,
        })
    }

    /// The picture of a preview and the labels of its frame, made the way
    /// the batch makes a frame ([`FramePipeline::make_scene`]) with the
    /// view's camera.
    pub fn picture(&mut self, request: &PreviewRequest) -> Result<PreviewPicture, PictureError> {
        let key = request.key;
        let preset = &*request.preset;
        let [width, height] = key.size_px;
        let side = self.ctx.max_texture_side;
        if width == 0 || height == 0 || width > side || height > side {
            return Err(PictureError::Size {
                width,
                height,
                side,
            });
        }
        // A rendered frame's work budget, as the batch checks it before it renders.
        (preset.check_render_budget()).map_err(|e| PipelineError::Invalid(vec![e]))?;
        let loaded = self.load(preset)?;
        let scene = loaded.pipeline.scene(key.frame)?;
        let (camera, inspect) = view_camera(preset, &scene, key.view, width, height);
        let mut drawn = scene.clone();
        drawn.camera = camera;
        if key.view != PreviewView::ThroughCamera {
            drawn.camera_model = None;
        }
        // Drawn as the batch draws the frame: its labels are the batch's.
        let is_the_frame = camera == scene.camera && drawn.camera_model == scene.camera_model;
        let made = (loaded.pipeline).make_scene(&mut loaded.renderer, drawn)?;
        let labels = if is_the_frame {
            made.labels
        } else {
            exact_labels(loaded, preset, &scene)?
        };
        Ok(PreviewPicture {
            rgba: made.rgba,
            scene,
            labels,
            camera,
            inspect,
        })
    }

    /// A new colour texture of `size_px` holding `rgba`, once the upload is done.
    fn upload(
        &self,
        rgba: &[u8],
        [width, height]: [u32; 2],
    ) -> Result<wgpu::TextureView, PictureError> {
        let size = wgpu::Extent3d {
            width,
            height,
            depth_or_array_layers: 1,
        };
        let texture = self.ctx.device.create_texture(&wgpu::TextureDescriptor {
            label: Some("preview colour"),
            size,
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: COLOR_FORMAT,
            usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        });
        let layout = wgpu::TexelCopyBufferLayout {
            offset: 0,
            bytes_per_row: Some(4 * width),
            rows_per_image: Some(height),
        };
        let place = texture.as_image_copy();
        self.ctx.queue.write_texture(place, rgba, layout, size);
        let submission = self.ctx.queue.submit([]);
        (self.ctx.device).poll(wgpu::PollType::Wait {
            submission_index: Some(submission),
            timeout: None,
        })?;
        Ok(texture.create_view(&wgpu::TextureViewDescriptor::default()))
    }

    /// The pipeline of `preset` and its renderer: kept while an edit leaves
    /// the models and sky images alone, rebuilt otherwise.
    fn load(&mut self, preset: &Preset) -> Result<&mut Loaded, PictureError> {
        // Masks are files only: the preview's pictures and labels are the same without them.
        let mut preset = preset.clone();
        preset.output.masks = Default::default();
        let preset = &preset;
        let loaded = match self.loaded.take() {
            Some(l) if l.pipeline.assets().serve(preset) => Loaded {
                pipeline: l.pipeline.update(preset.clone())?,
                renderer: l.renderer,
            },
            _ => {
                let pipeline = FramePipeline::new(preset.clone()).map_err(PictureError::Load)?;
                let renderer = pipeline.renderer(&self.ctx);
                Loaded { pipeline, renderer }
            }
        };
        Ok(self.loaded.insert(loaded))
    }
}

/// The labels the batch writes for `scene` (at the output's size). Through a camera model
/// (blur, a lens, a rolling shutter), under weather and in the thermal picture the batch
/// measures each drone's visibility in the finished picture, so they come from the frame
/// made as the batch makes it; otherwise from the visibility pass alone (no picture).
fn exact_labels(
    loaded: &mut Loaded,
    preset: &Preset,
    scene: &FrameScene,
) -> Result<Vec<DroneLabel>, PictureError> {
    let Loaded { pipeline, renderer } = loaded;
    if scene.camera_model.is_none() && scene.weather.is_none() && preset.thermal.is_none() {
        return Ok(pipeline.labels(renderer, scene)?);
    }
    let frame = pipeline.make_scene(renderer, scene.clone())?;
    renderer.recycle(frame.rgba, frame.painted);
    Ok(frame.labels)
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

#[cfg(test)]
mod tests {
    use super::*;

    /// 3 drones at 128×72 with MSAA, visible boxes and a visibility filter.
    const SMALL: &str = r#"(
        name: "small",
        seed: 5,
        placement: Randomized(count: (3, 3), volume: Box(size_m: (4.0, 2.0, 4.0)), min_separation_m: 0.7),
        camera: (z: (start: 0.5, end: 1.0, step: 0.5)),
        render: (resolution: Custom(width: 128, height: 72), msaa: 4),
        labels: (box_method: Visible, min_visible_pixels: 2),
    )"#;

    fn request(
        preset: &Preset,
        frame: u64,
        size_px: [u32; 2],
        view: PreviewView,
    ) -> PreviewRequest {
        PreviewRequest {
            key: PreviewKey {
                generation: 0,
                frame,
                size_px,
                view,
            },
            preset: Arc::new(preset.clone()),
        }
    }

    /// The background (sky pass and its readback) is drawn again only when
    /// what it shows changes: a new draw of the swarm keeps it, a sky edit does not.
    #[test]
    fn an_edit_that_leaves_the_sky_and_camera_alone_keeps_the_background() {
        let ctx = GpuContext::headless()
            .unwrap_or_else(|e| panic!("rendering tests need a GPU adapter (lavapipe): {e}"));
        let mut preset = Preset::from_ron(SMALL).expect("preset");
        let mut preview = PreviewRenderer::new(ctx);
        let draws = |preview: &mut PreviewRenderer, preset: &Preset| {
            let picture = preview.picture(&request(preset, 0, [128, 72], PreviewView::Camera));
            let rgba = picture.expect("preview").rgba;
            let loaded = preview.loaded.as_ref().expect("loaded");
            (loaded.renderer.background_draws(), rgba)
        };
        let (first, before) = draws(&mut preview, &preset);
        preset.seed += 1;
        let (after_seed, reseeded) = draws(&mut preview, &preset);
        assert_eq!(after_seed, first, "a new swarm redrew the background");
        assert!(reseeded != before, "the new seed drew another swarm");
        let crate::preset::Sky::Gradient {
            sun_elevation_deg, ..
        } = &mut preset.sky
        else {
            panic!("SMALL has the default gradient sky");
        };
        *sun_elevation_deg -= 10.0;
        let (after_sky, _) = draws(&mut preview, &preset);
        assert_eq!(after_sky, first + 1, "a sky edit draws the background once");
    }

    #[test]
    fn the_camera_view_at_output_size_is_the_batch_frame() {
        let ctx = GpuContext::headless()
            .unwrap_or_else(|e| panic!("rendering tests need a GPU adapter (lavapipe): {e}"));
        let preset = Preset::from_ron(SMALL).expect("preset");
        let pipeline = FramePipeline::new(preset.clone()).expect("pipeline");
        let mut batch = pipeline.renderer(&ctx);
        let mut preview = PreviewRenderer::new(ctx);
        for frame in 0..pipeline.frame_count() {
            let made = pipeline.make(&mut batch, frame).expect("batch frame");
            let camera = request(&preset, frame, [128, 72], PreviewView::Camera);
            let picture = preview.picture(&camera).expect("preview");
            assert!(made.rgba == picture.rgba, "frame {frame}: pixels differ");
            assert_eq!(made.labels, picture.labels, "frame {frame}");
            assert!(picture.inspect.is_none());
            // At half the size: the same view, scaled (its own pixels).
            let half = request(&preset, frame, [64, 36], PreviewView::Camera);
            let small = preview.picture(&half).expect("half-size preview");
            assert_eq!(small.rgba.len(), 64 * 36 * 4);
            assert_eq!(small.camera.fov_y_deg, made.scene.camera.fov_y_deg);
            // The inspect view draws from outside: other pixels, same labels.
            let orbit = PreviewView::Inspect(Orbit::default());
            let inspect = preview.picture(&request(&preset, frame, [128, 72], orbit));
            let inspect = inspect.expect("inspect preview");
            assert!(inspect.inspect.is_some() && inspect.rgba != made.rgba);
            assert_eq!(inspect.labels, made.labels);
        }
    }
}
