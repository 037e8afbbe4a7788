//! The thermal camera's glue (issue 41; docs/realism.md, "Thermal
//! camera"): a rendered frame becomes a long-wave infrared radiance plane,
//! which [`crate::sensor::thermal::develop_into`] turns into grey pixels.
//!
//! The plane is composed on the CPU from what the renderer measured, so the
//! renderer stays free of presets and the labels are the visible render's:
//! - the background from the camera's rays and the drone-free visible
//!   background ([`crate::sensor::thermal::sky_plane`]: the ground below
//!   the horizon, the clear sky by elevation above it, turned towards the
//!   clouds' or the scenery's radiance by the pixel's colour); with
//!   backplates, from the drawn plate's levels instead
//!   ([`crate::sensor::thermal::plate_plane`]: a thermal camera's own frames,
//!   already through its optics and its gain control, so the camera's blur
//!   then takes only what is drawn over them,
//!   [`crate::sensor::thermal::blur_drawn`], and the frame is developed with
//!   the plate's own gain, [`crate::sensor::thermal::plate_gain`]);
//! - every pixel the id pass gives a drone or confuser (its samples' share
//!   of the pixel): the object's skin and warm spots ([`parts`]: one
//!   Gaussian about its projected centre, σ a share of its half box, or
//!   with `motor_k` / `battery_k` one at each rotor hub and one at the
//!   body's centre, sized by the part and its distance; with `rotor_k` the
//!   rotor discs' pixels at the air's temperature plus it) at its emissivity, the
//!   rest reflecting the background, seen through `exp(−β·d)` of air; a
//!   share of the objects (`cold_share`, a hash draw of the frame seed and
//!   the object's index) with the skin below the air and no warm spot;
//! - under rain or snow, the particles at the air's radiance
//!   ([`super::weather::over_radiance`]) over the plane and over a copy of
//!   the drone-free one: the hits (masks) and the visibility kept are the
//!   pixels whose radiance the drone still changes.
//!
//! The developed 8-bit frame then goes through the recording's capture
//! chain when the preset asks (`thermal.capture`: an earlier compression,
//! border lines; [`crate::sensor::thermal::capture`]); the labels are the
//! id pass's, so the chain changes no label.
//!
//! Each thread keeps its planes from frame to frame (a thread-local
//! [`Scratch`]).

use glam::DVec3;

use crate::annotate::visibility::{PixelHit, Visibility};
use crate::model::CpuModel;
use crate::preset::thermal::{Signature, Thermal};
use crate::render::Renderer;
use crate::scene::FrameScene;
use crate::scene::camera::Camera;
use crate::sensor::thermal::{self, Developed, Gain, Scratch, SkyTable, View};

use super::{FramePipeline, PipelineError, weather};

mod parts;

use parts::{Disc, Rotors, Warm};

thread_local! {
    /// Each thread's planes, kept from frame to frame.
    static SCRATCH: std::cell::RefCell<Scratch> = std::cell::RefCell::default();
}

/// The camera as the thermal background needs it.
fn view(cam: &Camera) -> View {
    View {
        width: cam.width,
        height: cam.height,
        up: (cam.camera_from_world * DVec3::Y).as_vec3(),
        focal_px: cam.focal_px() as f32,
        principal: cam.principal_point().as_vec2(),
    }
}

/// Salt of the texture's seed (under the environment's pattern seed).
const TEXTURE_SALT: u64 = 0x5448_4552_4D54_4558; // "THERMTEX"

/// Where the frame's picture lies on its environment's texture field: the
/// view axis' azimuth (less the environment's turn, so the field turns with
/// the environment) and elevation, times the focal length, less the
/// principal point; x grows as the camera turns towards its right.
fn texture_anchor(scene: &FrameScene) -> thermal::texture::Anchor {
    let cam = &scene.camera;
    let r = cam.camera_from_world;
    let (right, forward) = (r.row(0), r.row(2));
    let az = forward.x.atan2(forward.z);
    let el = forward.y.clamp(-1.0, 1.0).asin();
    // d(forward)/d(azimuth): the camera's right turns it one way or the other.
    let turn = right.x * az.cos() - right.z * az.sin();
    let az = az - scene.environment.azimuth_offset_deg.to_radians();
    let (f, c) = (cam.focal_px(), cam.principal_point());
    let seed = u64::from(scene.environment.pattern_seed);
    thermal::texture::Anchor {
        seed: crate::seed::mix64(seed ^ TEXTURE_SALT),
        origin: (turn.signum() * f * az - c.x, -f * el - c.y),
    }
}

impl FramePipeline {
    /// Frame `scene`'s thermal picture (RGBA8 grey into `out`, and the
    /// 16-bit grey levels with `bits: 16`) from its drone-free visible
    /// `background` and the id pass's `hits`; under weather the hits (the
    /// masks) and the `measured` visibility are cut to the pixels whose
    /// radiance the drone still changes ([`Self::radiance_into`]).
    pub(super) fn thermal_frame(
        &self,
        t: &Thermal,
        scene: &FrameScene,
        background: &[u8],
        (hits, measured): (&mut Option<Vec<PixelHit>>, &mut Option<Vec<Visibility>>),
        mut out: Vec<u8>,
    ) -> (Vec<u8>, Option<Vec<u16>>) {
        let (w, h) = (scene.camera.width, scene.camera.height);
        let sky = SkyTable::new(t);
        let pattern = self
            .thermal_pattern
            .get_or_init(|| thermal::fixed_pattern(t, self.preset.seed, w, h));
        let own;
        let pattern = if pattern.len() == w as usize * h as usize {
            pattern
        } else {
            own = thermal::fixed_pattern(t, self.preset.seed, w, h);
            &own
        };
        let key = crate::seed::mix64(scene.seed ^ crate::seed::mix64(thermal::NOISE_SALT));
        // Every byte is written below.
        out.resize(w as usize * h as usize * 4, 0);
        let mut grey16 = (t.bits == 16).then(|| vec![0u16; w as usize * h as usize]);
        // Over a plate the optics blur what is drawn on it, not the plate again
        // (`blur_drawn`, nothing at σ 0), and the frame keeps the plate's own gain.
        let over_plate = self.preset.backplate.is_some();
        let camera = if over_plate && t.blur_px > 0.0 {
            &Thermal {
                blur_px: 0.0,
                ..t.clone()
            }
        } else {
            t
        };
        let gain = if over_plate {
            thermal::plate_gain(t)
        } else {
            Gain::Automatic
        };
        SCRATCH.with_borrow_mut(|scratch| {
            self.radiance_into(t, scene, (background, &sky), (hits, measured), scratch);
            if over_plate {
                thermal::blur_drawn(t.blur_px as f32, (w, h), scratch);
            }
            let to = match grey16.as_mut() {
                Some(g) => Developed::Grey16(g),
                None => Developed::Rgba8(&mut out),
            };
            thermal::develop_into(camera, (w, h), (pattern, key), gain, scratch, to);
        });
        if let Some(c) = &t.capture {
            thermal::capture::apply(c, (w, h), &mut out);
        }
        if let Some(g) = &grey16 {
            thermal::grey16_to_rgba(g, &mut out);
        }
        (out, grey16)
    }

    /// The radiance plane of `scene` into `scratch.plane`: the background,
    /// the objects at their `hits`, and under weather the particles
    /// ([`weather::over_radiance`]), over a copy of the drone-free plane
    /// too; then the hits kept (and `measured` measured) are those whose
    /// radiance still differs from the drone-free plane's.
    fn radiance_into(
        &self,
        t: &Thermal,
        scene: &FrameScene,
        (background, sky): (&[u8], &SkyTable),
        (hits, measured): (&mut Option<Vec<PixelHit>>, &mut Option<Vec<Visibility>>),
        scratch: &mut Scratch,
    ) {
        if self.preset.backplate.is_some() {
            let size = (scene.camera.width, scene.camera.height);
            thermal::plate_plane(t, size, background, scratch);
        } else {
            thermal::sky_plane(t, sky, &view(&scene.camera), background, scratch);
        }
        if let Some(x) = &t.texture {
            let per_k = thermal::radiance_per_kelvin(t.air_k);
            let size = (scene.camera.width, scene.camera.height);
            let anchor = texture_anchor(scene);
            if x.ground_only {
                let mut share = std::mem::take(&mut scratch.share);
                let clear_saturation = t.clear_saturation as f32;
                thermal::ground_share(
                    clear_saturation,
                    &view(&scene.camera),
                    background,
                    &mut share,
                );
                thermal::texture::add_on(x, per_k, anchor, size, &share, &mut scratch.plane);
                scratch.share = share;
            } else {
                thermal::texture::add(x, per_k, anchor, size, &mut scratch.plane);
            }
        }
        let signatures = self.signatures(t, scene);
        let msaa = self.preset.render.msaa.max(1);
        let all = hits.as_deref().unwrap_or_default();
        let mut clear = scene.weather.is_some().then(|| scratch.plane.clone());
        let plane = &mut scratch.plane;
        let models = &self.assets.models;
        add_objects(plane, (scene, models), all, (&signatures, msaa), (t, sky));
        let Some(clear) = clear.as_mut() else {
            return;
        };
        weather::over_radiance(scene, all, (plane, clear), sky.air);
        if let Some(all) = hits.take() {
            let shows = |i: usize| plane.get(i) != clear.get(i);
            let kept =
                weather::keep_showing(measured.as_deref_mut(), all, scene.camera.width, shows);
            *hits = Some(kept);
        }
    }

    /// The radiance plane (W·m⁻²·sr⁻¹ per pixel, row-major, before the
    /// camera's blur, noise and gain) `scene` makes through this preset's
    /// thermal camera, as [`Self::make_scene`] composes it; `None` without
    /// one. For measuring what a drone changes (the gain control differs
    /// between frames with and without drones).
    pub fn thermal_radiance(
        &self,
        renderer: &mut Renderer,
        scene: &FrameScene,
    ) -> Result<Option<Vec<f32>>, PipelineError> {
        let Some(t) = &self.preset.thermal else {
            return Ok(None);
        };
        let (request, _) = self.render_layers(renderer, scene);
        let mut frame =
            (renderer.render_frame(scene, &request)).map_err(|source| PipelineError::Render {
                index: scene.index,
                source,
            })?;
        let mut hits = frame.pixel_hits.take();
        let mut scratch = Scratch::default();
        let background = renderer.background_pixels(&frame.painted);
        let background = background.unwrap_or(&frame.rgba);
        let sky = SkyTable::new(t);
        let ids = (&mut hits, &mut None);
        self.radiance_into(t, scene, (background, &sky), ids, &mut scratch);
        renderer.recycle(frame.rgba, frame.painted);
        Ok(Some(scratch.plane))
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

/// Each object pixel of `hits` over the background plane: its share of the
/// pixel (samples / `msaa`) of the object's radiance through the air.
fn add_objects(
    plane: &mut [f32],
    (scene, models): (&FrameScene, &[CpuModel]),
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
    let mut discs: Vec<Option<Vec<Disc>>> = vec![None; models.len()];
    let spots: Vec<Option<Spot>> = (scene.drones.iter().zip(&boxes).zip(signatures))
        .enumerate()
        .map(|(k, ((d, b), sig))| {
            if b.0 > b.2 {
                return None;
            }
            let cold = is_cold(scene.seed, k, sig.cold_share);
            let model = models.get(d.model);
            let mut discs_of = |m: &CpuModel| -> Vec<Disc> {
                (discs[d.model].get_or_insert_with(|| parts::rotor_discs(m))).clone()
            };
            let warm = match (cold, model) {
                (true, _) => Vec::new(),
                (false, Some(m)) if sig.has_parts() => parts::part_spots(cam, d, &discs_of(m), sig),
                (false, _) => vec![parts::box_spot(cam, d.position, *b, sig)],
            };
            let rotors = (sig.rotor_k.zip(model))
                .map(|(k, m)| (Rotors::new(cam, d, &discs_of(m)), t.air_k + k));
            Some(Spot::new(
                t,
                sky,
                cam,
                d.position,
                (sig, cold),
                (warm, rotors),
            ))
        })
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

/// Salt of the objects' cold draws (under the frame seed).
const COLD_SALT: u64 = 0x5448_4552_4D43_4F4C; // "THERMCOL"

/// Whether object `index` of the frame with seed `frame_seed` is seen cold
/// ([`Signature::cold_share`]): a uniform draw of its own (a hash of the
/// seed and the index), so no other draw of the frame moves.
fn is_cold(frame_seed: u64, index: usize, share: f64) -> bool {
    if share <= 0.0 {
        return false;
    }
    let bits = crate::seed::mix64(frame_seed ^ crate::seed::mix64(COLD_SALT ^ index as u64));
    ((bits >> 11) as f64 / (1u64 << 53) as f64) < share
}

/// One object's thermal look in this frame.
struct Spot {
    /// Its warm spots ([`parts`]): none when it is seen cold.
    warm: Vec<Warm>,
    /// Its spinning rotors and their temperature (kelvin), with `rotor_k`.
    rotors: Option<(Rotors, f64)>,
    /// The skin's temperature (kelvin) and emissivity.
    skin_k: f64,
    emissivity: f32,
    /// exp(−β·d) and the air's radiance.
    transmit: f32,
    air: f32,
}

impl Spot {
    fn new(
        t: &Thermal,
        sky: &SkyTable,
        cam: &Camera,
        position: DVec3,
        (sig, cold): (&Signature, bool),
        (warm, rotors): (Vec<Warm>, Option<(Rotors, f64)>),
    ) -> Self {
        let p = cam.camera_from_world_point(position);
        Self {
            warm,
            rotors,
            skin_k: if cold {
                t.air_k - sig.skin_k
            } else {
                t.air_k + sig.skin_k
            },
            emissivity: sig.emissivity as f32,
            transmit: (-t.extinction_per_km * p.length() * 1e-3).exp() as f32,
            air: sky.air,
        }
    }

    /// The radiance reaching pixel (x, y) from this object, `behind` the
    /// background's (what its skin reflects).
    fn radiance(&self, x: u32, y: u32, behind: f32) -> f32 {
        let base = match &self.rotors {
            Some((rotors, k)) if rotors.cover(x, y) => *k,
            _ => self.skin_k,
        };
        let temp = (self.warm.iter()).fold(base, |k, w| k + w.peak_k * f64::from(w.at(x, y)));
        let e = self.emissivity;
        let own = e * thermal::radiance(temp) + (1.0 - e) * behind;
        self.transmit * own + (1.0 - self.transmit) * self.air
    }
}

#[cfg(test)]
mod tests {
    use super::{is_cold, texture_anchor};
    use glam::{DMat3, DVec3};

    /// A turn of the camera moves its window on the texture's lattice by the focal
    /// length times the angle: right and up as the picture's x and −y.
    #[test]
    fn a_turned_camera_sees_the_texture_moved_by_its_turn() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("presets/thermal.ron");
        let preset = crate::preset::Preset::open(&path).expect("preset");
        let pipe = super::FramePipeline::new(preset).expect("pipeline");
        let scene = pipe.scene(3).expect("scene");
        let f = scene.camera.focal_px();
        let a = texture_anchor(&scene);
        let delta = 0.01;
        let r = scene.camera.camera_from_world;
        let (right, forward) = (r.row(0), r.row(2));
        let turned = |axis: DVec3, angle: f64| {
            let mut s = scene.clone();
            s.camera.camera_from_world = r * DMat3::from_axis_angle(axis, angle).transpose();
            s
        };
        // About the world's up: towards the camera's right for one sign of the angle.
        let yawed = turned(DVec3::Y, delta);
        let new_forward = yawed.camera.camera_from_world.row(2);
        let towards_right = new_forward.dot(right).signum();
        let b = texture_anchor(&yawed);
        let moved = (b.origin.0 - a.origin.0) * towards_right;
        assert!(
            (moved / (f * delta) - 1.0).abs() < 0.02,
            "{moved} px for {}",
            f * delta
        );
        assert!((b.origin.1 - a.origin.1).abs() < 0.02 * f * delta);
        // About the camera's right, upwards: the window moves up (−y) by f·δ.
        let pitched = turned(right.normalize(), delta);
        let up = pitched.camera.camera_from_world.row(2).y - forward.y;
        let c = texture_anchor(&pitched);
        let moved = (c.origin.1 - a.origin.1) * -up.signum();
        assert!(
            (moved / (f * delta) - 1.0).abs() < 0.05,
            "{moved} px for {}",
            f * delta
        );
        assert_eq!(a.seed, texture_anchor(&scene).seed);
    }

    #[test]
    fn the_cold_draw_takes_its_share_of_the_objects() {
        assert!((0..100).all(|k| !is_cold(7, k, 0.0)));
        assert!((0..100).all(|k| is_cold(7, k, 1.0)));
        let n = (0..20_000).filter(|&k| is_cold(7, k, 0.3)).count();
        assert!((5_700..=6_300).contains(&n), "{n} of 20000 at 0.3");
        // Its own draw: the same seed and index give the same answer.
        assert_eq!(is_cold(9, 3, 0.5), is_cold(9, 3, 0.5));
    }
}
