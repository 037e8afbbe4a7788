//! Pictures of what ships: a contact sheet of the built-in models and one
//! frame per named environment (for docs/, the golden-image tests and the
//! environment benchmark). Everything is rendered by the ordinary renderer
//! from ordinary presets, so these images show exactly what datasets get.

use std::time::Instant;

use glam::{DQuat, DVec3};

use crate::model::builtin::NAMES as BUILTIN_NAMES;
use crate::pipeline::FramePipeline;
use crate::preset::sweep::SweepRange;
use crate::preset::{
    Formation, FormationShape, ModelSource, ModelSpec, Placement, Preset, Resolution, Sky, Volume,
};
use crate::render::GpuContext;
use crate::scene::DronePose;
use crate::scene::math::{EulerDeg, look_at_cv};
use crate::sky::EnvironmentName;

/// The preset of one environment picture: a small mixed swarm seen level with
/// the horizon, so sky, clouds, silhouettes and ground are all in view.
pub fn environment_preset(sky: Sky, width: u32, height: u32) -> Preset {
    let models = ["quad_x", "fixed_wing", "hexacopter", "heavy_lift"]
        .iter()
        .map(|n| ModelSpec {
            source: ModelSource::Builtin((*n).into()),
            size_m: 1.0,
            class: "uav".into(),
            ..ModelSpec::default()
        })
        .collect();
    let mut p = Preset {
        name: "environment".into(),
        seed: 11,
        models,
        sky,
        ..Preset::default()
    };
    p.placement = Placement::Randomized {
        count: (8, 8),
        count_distribution: Default::default(),
        volume: Volume::Box {
            size_m: (10.0, 3.0, 10.0),
        },
        min_separation_m: 2.0,
    };
    p.camera.y = SweepRange::fixed(0.15);
    p.camera.z = SweepRange::fixed(1.0);
    p.camera.fov_y_deg = 60.0;
    p.render.resolution = Resolution::Custom { width, height };
    p.render.msaa = 4;
    p
}

/// A named environment with a fixed pattern seed (for pictures and golden images).
pub fn fixed_environment(name: EnvironmentName) -> Sky {
    match Sky::procedural(name) {
        Sky::Procedural {
            environment,
            sun_elevation_deg,
            sun_azimuth_deg,
            turbidity,
            cloud_cover,
            exposure_ev,
            sun_ev,
            ..
        } => Sky::Procedural {
            environment,
            sun_elevation_deg,
            sun_azimuth_deg,
            turbidity,
            cloud_cover,
            seed: Some(7),
            exposure_ev,
            sun_ev,
        },
        other => other,
    }
}

/// Render frame 0 of `preset` to RGBA.
pub fn render_preset(ctx: &GpuContext, preset: &Preset) -> anyhow::Result<Vec<u8>> {
    let pipeline = FramePipeline::new(preset.clone())?;
    let mut renderer = pipeline.renderer(ctx);
    Ok(pipeline.make(&mut renderer, 0)?.rgba)
}

/// One frame per named environment, at `width`×`height`.
pub fn environment_frames(
    ctx: &GpuContext,
    width: u32,
    height: u32,
) -> anyhow::Result<Vec<(EnvironmentName, Vec<u8>)>> {
    EnvironmentName::ALL
        .iter()
        .map(|&name| {
            Ok((
                name,
                render_preset(
                    ctx,
                    &environment_preset(fixed_environment(name), width, height),
                )?,
            ))
        })
        .collect()
}

/// A `columns`-wide contact sheet of the built-in models, each 1 m across,
/// seen from 30° above at a three-quarter angle over the default gradient sky.
pub fn model_contact_sheet(
    ctx: &GpuContext,
    tile: u32,
    columns: u32,
) -> anyhow::Result<image::RgbaImage> {
    let models = BUILTIN_NAMES
        .iter()
        .map(|n| ModelSpec {
            source: ModelSource::Builtin((*n).into()),
            size_m: 1.0,
            class: (*n).into(),
            ..ModelSpec::default()
        })
        .collect();
    let mut preset = Preset {
        models,
        ..Preset::default()
    };
    close_up_stage(&mut preset, tile);
    let pipeline = FramePipeline::new(preset)?;
    close_up_sheet(
        ctx,
        &pipeline,
        (tile, columns),
        DVec3::new(1.0, 0.95, 1.35),
        0..BUILTIN_NAMES.len(),
    )
}

/// A close-up sheet's preset settings: one object, `tile`-pixel square frames,
/// the sheets' gradient sky.
pub(crate) fn close_up_stage(preset: &mut Preset, tile: u32) {
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
}

/// A `columns`-wide sheet of `tile`-pixel tiles: model `models[i]` of
/// `pipeline` alone, 1 m across at the origin, seen from 2.3 m along `eye_dir`.
pub(crate) fn close_up_sheet(
    ctx: &GpuContext,
    pipeline: &FramePipeline,
    (tile, columns): (u32, u32),
    eye_dir: DVec3,
    models: impl ExactSizeIterator<Item = usize>,
) -> anyhow::Result<image::RgbaImage> {
    let mut renderer = pipeline.renderer(ctx);
    let rows = (models.len() as u32).div_ceil(columns);
    let mut sheet = image::RgbaImage::new(tile * columns, tile * rows);
    for (i, model) in models.enumerate() {
        let mut scene = pipeline.scene(0)?;
        let eye = eye_dir.normalize() * 2.3;
        scene.camera.position = eye;
        scene.camera.fov_y_deg = 32.0;
        scene.camera.near_m = 0.01;
        scene.camera.camera_from_world =
            look_at_cv(eye, DVec3::ZERO).unwrap_or(glam::DMat3::IDENTITY);
        let rotation = DQuat::IDENTITY;
        scene.drones = vec![DronePose {
            model,
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

/// Median render time (ms, frame rendered and read back) of frame 0 of `preset` over `frames` renders.
pub fn median_frame_ms(ctx: &GpuContext, preset: &Preset, frames: usize) -> anyhow::Result<f64> {
    let pipeline = FramePipeline::new(preset.clone())?;
    let mut renderer = pipeline.renderer(ctx);
    pipeline.make(&mut renderer, 0)?; // warm-up: pipelines, targets
    let mut times: Vec<f64> = (0..frames.max(1))
        .map(|_| {
            let start = Instant::now();
            pipeline
                .make(&mut renderer, 0)
                .map(|_| start.elapsed().as_secs_f64() * 1000.0)
        })
        .collect::<Result<_, _>>()?;
    times.sort_by(f64::total_cmp);
    Ok(times[times.len() / 2])
}

/// The preset of one formation picture (docs/motion.md): twelve drones 1 m
/// across, seen from above at an angle so the shape reads at a glance.
pub fn formation_preset(shape: FormationShape, width: u32, height: u32) -> Preset {
    let mut p = Preset {
        name: format!("formation-{}", shape.name()),
        seed: 5,
        models: vec![ModelSpec {
            source: ModelSource::Builtin("quad_x".into()),
            size_m: 1.0,
            class: "uav".into(),
            ..ModelSpec::default()
        }],
        ..Preset::default()
    };
    let count = if matches!(shape, FormationShape::SphereShell) {
        40
    } else {
        12
    };
    p.placement = Placement::Formation(Formation {
        shape,
        count,
        spacing: 3.0,
        heading_deg: (0.0, 0.0),
        position_jitter: 0.0,
        attitude_jitter: crate::preset::AttitudeRanges::zero(),
        min_separation: 1.0,
    });
    p.camera.x = SweepRange::fixed(0.35);
    p.camera.y = SweepRange::fixed(0.7);
    p.camera.z = SweepRange::fixed(0.85);
    p.camera.fov_y_deg = 50.0;
    p.render.resolution = Resolution::Custom { width, height };
    p.render.msaa = 4;
    p
}

/// One frame per formation shape.
pub fn formation_frames(
    ctx: &GpuContext,
    width: u32,
    height: u32,
) -> anyhow::Result<Vec<(&'static str, Vec<u8>)>> {
    FormationShape::all()
        .into_iter()
        .map(|shape| {
            let name = shape.name();
            Ok((
                name,
                render_preset(ctx, &formation_preset(shape, width, height))?,
            ))
        })
        .collect()
}

/// A strip of `frames` evenly spaced frames of one sequence of
/// `presets/formation_sequence.ron`'s kind: a wedge turning and banking past
/// a fixed camera, each tile `width`×`height`.
pub fn sequence_strip(
    ctx: &GpuContext,
    preset: &Preset,
    frames: u32,
    width: u32,
    height: u32,
) -> anyhow::Result<image::RgbaImage> {
    let mut p = preset.clone();
    p.render.resolution = Resolution::Custom { width, height };
    let pipeline = FramePipeline::new(p)?;
    let mut renderer = pipeline.renderer(ctx);
    let len = pipeline.preset().sequence_len();
    let mut strip = image::RgbaImage::new(width * frames, height);
    for k in 0..frames {
        let index = (u64::from(k) * (len - 1)) / u64::from(frames.max(2) - 1);
        let mut frame = pipeline.make(&mut renderer, index)?;
        crate::annotate::overlay::draw_overlay(&mut frame.rgba, width, height, &frame.labels);
        let img = image::RgbaImage::from_raw(width, height, frame.rgba)
            .ok_or_else(|| anyhow::anyhow!("tile size"))?;
        image::imageops::replace(&mut strip, &img, i64::from(k * width), 0);
    }
    Ok(strip)
}
