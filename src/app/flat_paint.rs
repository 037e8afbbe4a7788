//! The window's two large areas, its background and the preview picture,
//! painted by a small wgpu pipeline of the app's own (paint callbacks in
//! egui's render pass) instead of as egui meshes.
//!
//! Why: on a CPU rasteriser (Mesa's lavapipe) egui's mesh shader costs about
//! 50 ns of CPU a pixel (texture filtering with derivatives, dithering, blend),
//! so the panels' fills (the whole window) and the 960×540 picture cost about
//! 120 ms of CPU per window pass, and the preview render shares those two
//! cores. A flat fill and a texel copy without blending cost about 1 ms and
//! 4 ms (docs/gui.md, "Preview latency"). Everything else (text, widgets,
//! boxes) is still egui's, drawn over these.
//!
//! The picture is copied texel for texel (nearest texel to each pixel centre,
//! no filtering): at 1:1, which is how the pane draws it, exactly the preview's
//! pixels. The pipelines are made for the window's format with one sample per
//! pixel (eframe's default `multisampling: 0`, and egui_kittest's renderer).

use egui::{Color32, Rect};
use wgpu::util::DeviceExt;

use eframe::egui_wgpu::{self, CallbackResources, CallbackTrait, ScreenDescriptor};

use crate::render::{PipelineDesc, PipelineFactory, texture_entry, uniform_entry};

const SHADER: &str = include_str!("../../shaders/flat_paint.wgsl");

/// A uniform colour and a texture, what one flat paint reads.
#[derive(Clone)]
struct Binding {
    colour: wgpu::Buffer,
    group: wgpu::BindGroup,
}

/// The pipelines and the two areas' bindings, made once with the window's render state.
pub struct FlatPainter {
    device: wgpu::Device,
    layout: wgpu::BindGroupLayout,
    fill: wgpu::RenderPipeline,
    picture: wgpu::RenderPipeline,
    srgb_target: bool,
    /// The background's colour and a placeholder texture.
    background: Binding,
    /// The preview picture's tint and texture, once a picture came.
    shown: Option<Binding>,
}

impl FlatPainter {
    pub fn new(render_state: &egui_wgpu::RenderState) -> Self {
        let device = render_state.device.clone();
        let factory = PipelineFactory::new(&device);
        let module = factory.shader("flat paint", SHADER.to_owned());
        let layout = factory.bind_group_layout(
            "flat paint",
            &[
                uniform_entry(0, wgpu::ShaderStages::FRAGMENT),
                texture_entry(1, false, wgpu::TextureViewDimension::D2, false),
            ],
        );
        let pipeline_layout = factory.layout("flat paint", &[&layout]);
        let srgb_target = render_state.target_format.is_srgb();
        let constants = [("SRGB_TARGET", if srgb_target { 1.0 } else { 0.0 })];
        let targets = [Some(wgpu::ColorTargetState {
            format: render_state.target_format,
            blend: None,
            write_mask: wgpu::ColorWrites::ALL,
        })];
        let pipeline = |entry: &str| {
            factory.render(&PipelineDesc {
                constants: &constants,
                ..PipelineDesc::new(entry, &pipeline_layout, &module, entry, &targets)
            })
        };
        let (fill, picture) = (pipeline("fs_fill"), pipeline("fs_picture"));
        let placeholder = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("flat paint placeholder"),
            size: wgpu::Extent3d {
                width: 1,
                height: 1,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: wgpu::TextureFormat::Rgba8Unorm,
            usage: wgpu::TextureUsages::TEXTURE_BINDING,
            view_formats: &[],
        });
        Self {
            background: binding(
                &device,
                &layout,
                &placeholder.create_view(&Default::default()),
            ),
            device,
            layout,
            fill,
            picture,
            srgb_target,
            shown: None,
        }
    }

    /// Show `view` (a preview picture, [`crate::render::COLOR_FORMAT`]) from now on.
    pub fn set_picture(&mut self, view: &wgpu::TextureView) {
        self.shown = Some(binding(&self.device, &self.layout, view));
    }

    /// The window's background: `colour` over all of `rect`, drawn before anything else.
    pub fn background(&self, rect: Rect, colour: Color32) -> egui::Shape {
        let [r, g, b, a] = self.colour_value(colour);
        let paint = FlatPaint {
            pipeline: self.fill.clone(),
            binding: self.background.clone(),
            params: [r, g, b, a, 0.0, 0.0, 1.0, 1.0],
        };
        egui_wgpu::Callback::new_paint_callback(rect, paint).into()
    }

    /// `part` of the current picture (in 0..1 of its width and height; all of it:
    /// 0, 0, 1, 1) over `rect`, tinted with `tint` as egui tints an image, each pixel
    /// the nearest texel (zoomed in: the preview's pixels as blocks); None before the
    /// first picture.
    pub fn picture_part(&self, rect: Rect, tint: Color32, part: Rect) -> Option<egui::Shape> {
        let binding = self.shown.clone()?;
        let [r, g, b, a] = tint.to_normalized_gamma_f32();
        let paint = FlatPaint {
            pipeline: self.picture.clone(),
            binding,
            params: [
                r,
                g,
                b,
                a,
                part.min.x,
                part.min.y,
                part.width(),
                part.height(),
            ],
        };
        Some(egui_wgpu::Callback::new_paint_callback(rect, paint).into())
    }

    /// A colour as the window's target stores it (linear for an sRGB target, as egui writes it).
    fn colour_value(&self, colour: Color32) -> [f32; 4] {
        if self.srgb_target {
            egui::Rgba::from(colour).to_array()
        } else {
            colour.to_normalized_gamma_f32()
        }
    }
}

fn binding(
    device: &wgpu::Device,
    layout: &wgpu::BindGroupLayout,
    view: &wgpu::TextureView,
) -> Binding {
    let colour = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("flat paint colour"),
        contents: bytemuck::cast_slice(&[1.0f32, 1.0, 1.0, 1.0, 0.0, 0.0, 1.0, 1.0]),
        usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
    });
    let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("flat paint"),
        layout,
        entries: &[
            wgpu::BindGroupEntry {
                binding: 0,
                resource: colour.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 1,
                resource: wgpu::BindingResource::TextureView(view),
            },
        ],
    });
    Binding { colour, group }
}

/// One flat paint: a pipeline, its binding and what to write into it (the colour,
/// then the part of the picture shown: left, top, width, height in 0..1).
struct FlatPaint {
    pipeline: wgpu::RenderPipeline,
    binding: Binding,
    params: [f32; 8],
}

impl CallbackTrait for FlatPaint {
    fn prepare(
        &self,
        _device: &wgpu::Device,
        queue: &wgpu::Queue,
        _screen: &ScreenDescriptor,
        _encoder: &mut wgpu::CommandEncoder,
        _resources: &mut CallbackResources,
    ) -> Vec<wgpu::CommandBuffer> {
        let bytes: &[u8] = bytemuck::cast_slice(&self.params);
        queue.write_buffer(&self.binding.colour, 0, bytes);
        Vec::new()
    }

    fn paint(
        &self,
        _info: egui::PaintCallbackInfo,
        pass: &mut wgpu::RenderPass<'static>,
        _resources: &CallbackResources,
    ) {
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &self.binding.group, &[]);
        pass.draw(0..3, 0..1);
    }
}
