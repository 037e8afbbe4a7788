//! A contact sheet of the built-in confusers (docs/img/confusers.png, written
//! by `swarmshot gallery`): a gull's flap poses, each bird gliding, the
//! aircraft and the balloon, each drawn by the ordinary pipeline from a preset
//! whose `confusers` load them, close up over a gradient sky.

use glam::DVec3;

use super::gallery::{close_up_sheet, close_up_stage};
use crate::pipeline::FramePipeline;
use crate::preset::Preset;
use crate::preset::confusers::{BirdSpecies, Confuser, ConfuserKind, first_slots};
use crate::render::GpuContext;

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
    close_up_stage(&mut preset, tile);
    let first = first_slots(&preset.confusers);
    let base = preset.models.len();
    let pipeline = FramePipeline::new(preset)?;
    let models = TILES.iter().map(|(kind, pose)| {
        let entry = ConfuserKind::ALL
            .iter()
            .position(|k| k == kind)
            .unwrap_or(0);
        base + first[entry] + pose
    });
    close_up_sheet(
        ctx,
        &pipeline,
        (tile, columns),
        DVec3::new(1.0, 0.8, 1.35),
        models,
    )
}
