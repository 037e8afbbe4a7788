//! A contact sheet of the built-in confusers (docs/img/confusers.png, written
//! by `swarmshot gallery`): a gull's flap poses, each bird gliding, the
//! aircraft and the balloon, each drawn by the ordinary pipeline from a preset
//! whose `confusers` load them, close up over a gradient sky.

use glam::{DQuat, DVec3};

use crate::pipeline::FramePipeline;
use crate::preset::confusers::{BirdSpecies, Confuser, ConfuserKind, first_slots};
use crate::preset::{Placement, Preset, Resolution, Sky};
use crate::render::GpuContext;
use crate::scene::DronePose;
use crate::scene::math::{EulerDeg, look_at_cv};

/// The tiles: (kind, pose within the kind's models: a bird's flap pose k, or 8 = gliding).
const TILES: [(ConfuserKind, usize); 12] = [
    (ConfuserKind::Bird(BirdSpecies::Gull), 0),
    (ConfuserKind::Bird(BirdSpecies::Gull), 2),
    (ConfuserKind::Bird(BirdSpecies::Gull), 4),
    (ConfuserKind::Bird(BirdSpecies::Gull), 6),
    (ConfuserKind::Bird(BirdSpecies::Sparrow), 8),
    (ConfuserKind::Bird(BirdSpecies::Gull), 8),
    (ConfuserKind::Bird(BirdSpecies::Raptor), 8),
    (ConfuserKind::Bird(BirdSpecies::Raptor), 3),
    (ConfuserKind::LightAircraft, 0),
    (ConfuserKind::Helicopter, 0),
    (ConfuserKind::Airliner, 0),
    (ConfuserKind::Balloon, 0),
];

/// A `columns`-wide sheet of `tile`-pixel tiles, each confuser 1 m across
/// (its pose's span), seen from above at a three-quarter angle.
pub fn confuser_contact_sheet(
    ctx: &GpuContext,
    tile: u32,
    columns: u32,
) -> anyhow::Result<image::RgbaImage> {
    let mut preset = Preset {
        confusers: ConfuserKind::ALL
            .iter()
            .map(|&kind| Confuser {
                kind,
                count: (0, 0),
                ..Confuser::default()
            })
            .collect(),
        ..Preset::default()
    };
    preset.placement = Placement::Structured {
        x_count: 1,
        y_count: 1,
        z_count: 1,
        load_factor: 1.0,
    };
    preset.render.resolution = Resolution::Custom {
        width: tile,
        height: tile,
    };
    preset.sky = Sky::Gradient {
        sun_elevation_deg: 55.0,
        sun_azimuth_deg: 150.0,
        zenith: (0.30, 0.42, 0.62),
        horizon: (0.75, 0.8, 0.86),
    };
    let first = first_slots(&preset.confusers);
    let base = preset.models.len();
    let pipeline = FramePipeline::new(preset)?;
    let mut renderer = pipeline.renderer(ctx);
    let rows = (TILES.len() as u32).div_ceil(columns);
    let mut sheet = image::RgbaImage::new(tile * columns, tile * rows);
    for (i, (kind, pose)) in TILES.iter().enumerate() {
        let entry = ConfuserKind::ALL
            .iter()
            .position(|k| k == kind)
            .unwrap_or(0);
        let mut scene = pipeline.scene(0)?;
        let eye = DVec3::new(1.0, 0.8, 1.35).normalize() * 2.3;
        scene.camera.position = eye;
        scene.camera.fov_y_deg = 32.0;
        scene.camera.near_m = 0.01;
        scene.camera.camera_from_world =
            look_at_cv(eye, DVec3::ZERO).unwrap_or(glam::DMat3::IDENTITY);
        let rotation = DQuat::IDENTITY;
        scene.drones = vec![DronePose {
            model: base + first[entry] + pose,
            position: DVec3::ZERO,
            rotation,
            euler_deg: EulerDeg::from_quat(rotation),
            size_m: 1.0,
        }];
        let rgba = pipeline.make_scene(&mut renderer, scene)?.rgba;
        let img = image::RgbaImage::from_raw(tile, tile, rgba)
            .ok_or_else(|| anyhow::anyhow!("tile size"))?;
        let (x, y) = ((i as u32 % columns) * tile, (i as u32 / columns) * tile);
        image::imageops::replace(&mut sheet, &img, i64::from(x), i64::from(y));
    }
    Ok(sheet)
}
