//! The pinhole camera: intrinsics K, extrinsics [R|t], projection to
//! continuous pixel coordinates, and the matching GPU clip transform.
//!
//! Camera frame: x right, y down, z forward (the computer-vision convention,
//! so that `λ·(u, v, 1) = K·(R·X + t)` as in the paper's Eq. 8). Pixel (i, j)
//! covers [i, i+1) × [j, j+1) with (0, 0) the top-left corner of the image.
//! The GPU uses reversed-Z with an infinite far plane (depth = near / z), so
//! depth precision is relative to distance and drones 1 m apart at 5 km keep
//! their order.

use glam::{DMat3, DVec2, DVec3, Mat4, Vec4};
use serde::Serialize;

#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Camera {
    pub width: u32,
    pub height: u32,
    pub fov_y_deg: f64,
    /// Camera centre in world coordinates (metres).
    pub position: DVec3,
    /// R: rotation from world to camera frame.
    pub camera_from_world: DMat3,
    /// Near clipping distance (metres) for rendering and labelling alike.
    pub near_m: f64,
}

impl Camera {
    /// Focal length in pixels: fx = fy = (H/2) / tan(fov_y/2).
    pub fn focal_px(&self) -> f64 {
        f64::from(self.height) * 0.5 / (self.fov_y_deg.to_radians() * 0.5).tan()
    }

    /// What the auto-exposure meter looks through ([`crate::sky::meter`]).
    pub fn meter_view(&self) -> crate::sky::meter::View {
        crate::sky::meter::View {
            width: self.width,
            height: self.height,
            focal_px: self.focal_px(),
            camera_from_world: self.camera_from_world,
        }
    }

    /// Principal point (W/2, H/2).
    pub fn principal_point(&self) -> DVec2 {
        DVec2::new(f64::from(self.width), f64::from(self.height)) * 0.5
    }

    /// The intrinsic matrix K.
    pub fn k(&self) -> DMat3 {
        let f = self.focal_px();
        let c = self.principal_point();
        DMat3::from_cols(
            DVec3::new(f, 0.0, 0.0),
            DVec3::new(0.0, f, 0.0),
            DVec3::new(c.x, c.y, 1.0),
        )
    }

    /// t = −R·C.
    pub fn t(&self) -> DVec3 {
        -(self.camera_from_world * self.position)
    }

    /// World point → camera frame.
    pub fn camera_from_world_point(&self, p: DVec3) -> DVec3 {
        self.camera_from_world * (p - self.position)
    }

    /// Camera-frame point → continuous pixel coordinates; `None` at or behind z = 0.
    pub fn project_camera_point(&self, p: DVec3) -> Option<DVec2> {
        if p.z.is_nan() || p.z <= 0.0 {
            return None;
        }
        let f = self.focal_px();
        let c = self.principal_point();
        Some(DVec2::new(f * p.x / p.z + c.x, f * p.y / p.z + c.y))
    }

    /// The GPU's `clip_from_camera`: reversed-Z, infinite far plane, the same
    /// K as labels use, mapping camera (x right, y down, z forward) to wgpu
    /// clip space (x right, y up, depth in [0, 1] with 1 at the near plane).
    pub fn clip_from_camera(&self) -> Mat4 {
        let f = self.focal_px();
        let (w, h) = (f64::from(self.width), f64::from(self.height));
        let c = self.principal_point();
        // x_ndc = 2u/W − 1, y_ndc = 1 − 2v/H, depth = near/z.
        let sx = 2.0 * f / w;
        let ox = 2.0 * c.x / w - 1.0;
        let sy = -2.0 * f / h;
        let oy = 1.0 - 2.0 * c.y / h;
        Mat4::from_cols(
            Vec4::new(sx as f32, 0.0, 0.0, 0.0),
            Vec4::new(0.0, sy as f32, 0.0, 0.0),
            Vec4::new(ox as f32, oy as f32, 0.0, 1.0),
            Vec4::new(0.0, 0.0, self.near_m as f32, 0.0),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn camera() -> Camera {
        Camera {
            width: 640,
            height: 480,
            fov_y_deg: 60.0,
            position: DVec3::new(1.0, 2.0, 10.0),
            camera_from_world: crate::scene::math::look_at_cv(
                DVec3::new(1.0, 2.0, 10.0),
                DVec3::ZERO,
            )
            .expect("look-at"),
            near_m: 0.01,
        }
    }

    #[test]
    fn gpu_clip_transform_lands_on_the_same_pixel_as_k() {
        let cam = camera();
        let m = cam.clip_from_camera();
        for p in [
            DVec3::new(0.3, -0.2, 5.0),
            DVec3::new(-2.0, 1.0, 30.0),
            DVec3::new(0.0, 0.0, 0.5),
        ] {
            let uv = cam.project_camera_point(p).expect("in front");
            let clip = m * p.as_vec3().extend(1.0);
            let ndc = clip.truncate() / clip.w;
            let u = (f64::from(ndc.x) + 1.0) * 0.5 * 640.0;
            let v = (1.0 - f64::from(ndc.y)) * 0.5 * 480.0;
            assert!(
                (u - uv.x).abs() < 1e-3 && (v - uv.y).abs() < 1e-3,
                "{u},{v} vs {uv}"
            );
            assert!((f64::from(ndc.z) - 0.01 / p.z).abs() < 1e-6);
        }
    }
}
