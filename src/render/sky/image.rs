//! An image sky's reduced pass: the scale at which an equirect image is
//! drawn (where it is magnified enough), the pass (shaded on the CPU,
//! `equirect`) and, for the full-frame path, its target and the group with
//! which the sky pass samples it.

use super::equirect::{Equirect, ReducedView};
use super::{SkyGpu, make_bind_group};
use crate::sky::{FrameSky, SkyImageKind};

impl SkyGpu {
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
    pub(in crate::render) fn image_scale(
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

    /// Whether `sky` is an HDR image (tone-mapped: `tone_map` in environment.wgsl).
    pub(in crate::render) fn image_is_hdr(&self, sky: &FrameSky) -> bool {
        match sky {
            FrameSky::Image { image, .. } => self.images.get(*image).is_some_and(|(_, i)| i.hdr),
            _ => false,
        }
    }

    /// The scale written with the uniforms last (see [`SkyGpu::prepare`]):
    /// the image pass's, or `None` when the sky is drawn at full resolution.
    pub(in crate::render) fn written_image_scale(&self) -> Option<u32> {
        let scale = self.written.far_params[3];
        (self.written.mode[0] > 1.5 && scale > 1.5).then_some(scale as u32)
    }

    /// The image sky `sky`'s reduced pass (uniforms just written, with its
    /// scale: see [`SkyGpu::image_scale`]) for a `frame`-sized frame seen
    /// through `world_from_camera` and `intrinsics`, shaded on the CPU
    /// (`equirect::shade`) into `texels` (RGBA `f32`); its size, or `None`
    /// when the sky is not drawn reduced.
    pub(in crate::render) fn shade_image(
        &self,
        sky: &FrameSky,
        (world_from_camera, intrinsics): (&[[f32; 4]; 4], [f32; 4]),
        frame: (u32, u32),
        texels: &mut [Vec<f32>; 3],
    ) -> Option<(u32, u32)> {
        let scale = self.written_image_scale()?;
        let FrameSky::Image { image, .. } = sky else {
            return None;
        };
        let SkyImageKind::Equirect { width, height, rgb } = &self.images.get(*image)?.1.kind else {
            return None;
        };
        let image = Equirect {
            rgb,
            width: *width,
            height: *height,
        };
        let view = ReducedView {
            world_from_camera: glam::Mat3::from_mat4(glam::Mat4::from_cols_array_2d(
                world_from_camera,
            )),
            intrinsics,
            scale: scale as f32,
            rotation: self.written.mode[3],
            exposure: self.written.mode[1],
        };
        let size = ((frame.0 / scale).max(1), (frame.1 / scale).max(1));
        super::equirect::shade(image, &view, size, texels);
        Some(size)
    }

    /// The full-frame path's image pass: the image sky `sky`'s reduced pass
    /// ([`SkyGpu::shade_image`]) written into its target (RGBA16F), which
    /// the sky pass then samples.
    pub(in crate::render) fn upload_image(
        &mut self,
        (device, queue): (&wgpu::Device, &wgpu::Queue),
        sky: &FrameSky,
        camera: (&[[f32; 4]; 4], [f32; 4]),
        frame: (u32, u32),
    ) {
        let mut texels = Default::default();
        let Some(size) = self.shade_image(sky, camera, frame, &mut texels) else {
            return;
        };
        if self.image_target.as_ref().is_none_or(|t| t.2 != size) {
            let texture = crate::render::gpu::texture_2d(
                device,
                "image sky (reduced resolution)",
                size,
                (wgpu::TextureFormat::Rgba16Float, 1),
                wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
            );
            let view = texture.create_view(&Default::default());
            self.image_target = Some((texture, view, size));
            self.upsampled = None;
        }
        let Some((texture, _, _)) = &self.image_target else {
            return;
        };
        super::upload::write_half_floats(queue, texture, size, &texels);
    }

    /// Make the group with which the full-frame path's sky pass samples the
    /// image pass's target for `sky` (after [`SkyGpu::encode_image`]); see
    /// [`SkyGpu::bind_group_for`].
    pub(super) fn prepare_upsampled(&mut self, device: &wgpu::Device, sky: &FrameSky) {
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
}

/// [`SkyGpu::image_scale`] of an equirect image `image` (texels) for a
/// `frame`-sized frame of focal length `focal_px` and principal point `centre`.
pub(super) fn reduced_scale(
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
