//! The thermal camera's glue (issue 41; docs/realism.md, "Thermal
//! camera"): a rendered frame becomes a long-wave infrared radiance plane,
//! which [`crate::sensor::thermal::develop`] turns into grey pixels.
//!
//! The plane is composed on the CPU from what the renderer measured, so the
//! renderer stays free of presets and the labels are the visible render's:
//! - every pixel's sin(elevation) from the camera's ray: below the horizon
//!   the ground; above it the clear sky by elevation
//!   ([`crate::sensor::thermal::SkyTable`]), turned towards the clouds'
//!   radiance by the drone-free visible background's greyness (HSV
//!   saturation under `clear_saturation`), and towards the ground's where
//!   the background is coloured but not blue (scenery);
//! - every pixel the id pass gives a drone or confuser (its samples' share
//!   of the pixel): the object's skin and warm spot (a Gaussian about its
//!   projected centre, σ a share of its half box) at its emissivity, the
//!   rest reflecting the background, seen through `exp(−β·d)` of air.

use glam::DVec3;

use crate::annotate::visibility::PixelHit;
use crate::preset::thermal::{Signature, Thermal};
use crate::scene::FrameScene;
use crate::sensor::thermal::{self, SkyTable};

use super::FramePipeline;

impl FramePipeline {
    /// Frame `scene`'s thermal picture (RGBA8 grey) from its drone-free
    /// visible `background` and the id pass's `hits`.
    pub(super) fn thermal_frame(
        &self,
        t: &Thermal,
        scene: &FrameScene,
        background: &[u8],
        hits: &[PixelHit],
    ) -> Vec<u8> {
        let (w, h) = (scene.camera.width, scene.camera.height);
        let sky = SkyTable::new(t);
        let mut plane = background_plane(t, &sky, scene, background);
        let signatures = self.signatures(t, scene);
        let msaa = self.preset.render.msaa.max(1);
        add_objects(&mut plane, scene, hits, (&signatures, msaa), (t, &sky));
        let pattern = self
            .thermal_pattern
            .get_or_init(|| thermal::fixed_pattern(t, self.preset.seed, w, h));
        let own;
        let pattern = if pattern.len() == plane.len() {
            pattern
        } else {
            own = thermal::fixed_pattern(t, self.preset.seed, w, h);
            &own
        };
        let key = crate::seed::mix64(scene.seed ^ crate::seed::mix64(thermal::NOISE_SALT));
        thermal::develop(t, &mut plane, (w, h), pattern, key)
    }

    /// Each drone's signature by its model: the preset's models are
    /// drones; the confusers' by their built-in model's name.
    fn signatures(&self, t: &Thermal, scene: &FrameScene) -> Vec<Signature> {
        let drones = self.preset.models.len();
        (scene.drones.iter())
            .map(|d| match self.model_names.get(d.model) {
                _ if d.model < drones => t.drone,
                Some(name) if name.starts_with("bird_") => t.bird,
                Some(name) if name == "balloon" => t.balloon,
                _ => t.aircraft,
            })
            .collect()
    }
}

/// The background's radiance at every pixel (row-major).
fn background_plane(t: &Thermal, sky: &SkyTable, scene: &FrameScene, rgba: &[u8]) -> Vec<f32> {
    let cam = &scene.camera;
    let (w, h) = (cam.width as usize, cam.height as usize);
    let up = (cam.camera_from_world * DVec3::Y).as_vec3();
    let f = cam.focal_px() as f32;
    let c = cam.principal_point().as_vec2();
    let clear_sat = t.clear_saturation as f32;
    let mut plane = Vec::with_capacity(w * h);
    for y in 0..h {
        let vy = (y as f32 + 0.5 - c.y) / f;
        let row = &rgba[(y * w * 4).min(rgba.len())..((y + 1) * w * 4).min(rgba.len())];
        for x in 0..w {
            let vx = (x as f32 + 0.5 - c.x) / f;
            let s = (up.x * vx + up.y * vy + up.z) / (vx * vx + vy * vy + 1.0).sqrt();
            let clear = sky.clear(s);
            let Some(px) = row.get(x * 4..x * 4 + 3).filter(|_| s >= 0.0) else {
                plane.push(clear);
                continue;
            };
            let (r, g, b) = (f32::from(px[0]), f32::from(px[1]), f32::from(px[2]));
            let (max, min) = (r.max(g).max(b), r.min(g).min(b));
            let sat = if max > 0.0 { (max - min) / max } else { 0.0 };
            let grey = (1.0 - sat / clear_sat).clamp(0.0, 1.0);
            let clear_or_scenery = if b >= max { clear } else { sky.ground };
            let cloud = sky.cloud.max(clear);
            plane.push(clear_or_scenery + (cloud - clear_or_scenery) * grey);
        }
    }
    plane
}

/// Each object pixel of `hits` over the background plane: its share of the
/// pixel (samples / `msaa`) of the object's radiance through the air.
fn add_objects(
    plane: &mut [f32],
    scene: &FrameScene,
    hits: &[PixelHit],
    (signatures, msaa): (&[Signature], u32),
    (t, sky): (&Thermal, &SkyTable),
) {
    let cam = &scene.camera;
    let w = cam.width as usize;
    // Each object's hit box, for its warm spot's size.
    let mut boxes = vec![(u32::MAX, u32::MAX, 0u32, 0u32); scene.drones.len()];
    for hit in hits {
        if let Some(b) = boxes.get_mut(hit.drone as usize) {
            *b = (
                b.0.min(hit.x),
                b.1.min(hit.y),
                b.2.max(hit.x),
                b.3.max(hit.y),
            );
        }
    }
    let spots: Vec<Option<Spot>> = (scene.drones.iter().zip(&boxes).zip(signatures))
        .map(|((d, b), sig)| Spot::new(t, sky, cam, (d.position, *b), sig))
        .collect();
    let deltas: Vec<(usize, f32)> = (hits.iter())
        .filter_map(|hit| {
            let spot = spots.get(hit.drone as usize)?.as_ref()?;
            let i = hit.y as usize * w + hit.x as usize;
            let behind = *plane.get(i)?;
            let share = f32::from(hit.samples).min(msaa as f32) / msaa as f32;
            Some((i, share * (spot.radiance(hit.x, hit.y, behind) - behind)))
        })
        .collect();
    for (i, d) in deltas {
        plane[i] += d;
    }
}

/// One object's thermal look in this frame.
struct Spot {
    centre: (f32, f32),
    inv_two_sigma2: f32,
    sig: Signature,
    air_k: f64,
    /// exp(−β·d) and the air's radiance.
    transmit: f32,
    air: f32,
}

impl Spot {
    fn new(
        t: &Thermal,
        sky: &SkyTable,
        cam: &crate::scene::camera::Camera,
        (position, hit_box): (DVec3, (u32, u32, u32, u32)),
        sig: &Signature,
    ) -> Option<Self> {
        let (x0, y0, x1, y1) = hit_box;
        if x0 > x1 {
            return None;
        }
        let p = cam.camera_from_world_point(position);
        let box_centre = ((x0 + x1 + 1) as f32 * 0.5, (y0 + y1 + 1) as f32 * 0.5);
        let centre = (cam.project_camera_point(p)).map_or(box_centre, |c| (c.x as f32, c.y as f32));
        let half = ((x1 - x0 + 1).max(y1 - y0 + 1) as f32 * 0.5).max(0.5);
        let sigma = (sig.spot_share as f32 * half).max(0.3);
        Some(Self {
            centre,
            inv_two_sigma2: 1.0 / (2.0 * sigma * sigma),
            sig: *sig,
            air_k: t.air_k,
            transmit: (-t.extinction_per_km * p.length() * 1e-3).exp() as f32,
            air: sky.air,
        })
    }

    /// The radiance reaching pixel (x, y) from this object, `behind` the
    /// background's (what its skin reflects).
    fn radiance(&self, x: u32, y: u32, behind: f32) -> f32 {
        let (dx, dy) = (
            x as f32 + 0.5 - self.centre.0,
            y as f32 + 0.5 - self.centre.1,
        );
        let warm = (-(dx * dx + dy * dy) * self.inv_two_sigma2).exp();
        let temp = self.air_k + self.sig.skin_k + self.sig.spot_k * f64::from(warm);
        let e = self.sig.emissivity as f32;
        let own = e * thermal::radiance(temp) + (1.0 - e) * behind;
        self.transmit * own + (1.0 - self.transmit) * self.air
    }
}
