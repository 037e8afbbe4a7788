//! Impostors (`render.impostor_below_px`): drones of 2–20 px drawn as the
//! baked silhouette of the nearest view direction, against the full mesh at
//! the same poses. Per drone: the IoU of the visible boxes, the relative
//! difference of the visible pixel counts, and the mean absolute difference
//! in 8-bit levels over the union of the two visible boxes grown by a pixel.
//! The bounds here are what docs/realism.md states, with a little room.

use crate::common;

use glam::{DQuat, DVec3};
use swarmshot::model::impostor;
use swarmshot::pipeline::FramePipeline;
use swarmshot::preset::{ModelSource, ModelSpec, Preset, Resolution};
use swarmshot::render::{RenderRequest, RenderedFrame, Renderer};
use swarmshot::scene::FrameScene;
use swarmshot::scene::projection::PixelBox;

const CF2: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/tests/data/uav/crazyflie2_cf2/cf2.glb"
);
/// Drones per frame: a grid of 8 × 4 cells of 80 × 90 px.
const COLUMNS: usize = 8;
const ROWS: usize = 4;

fn preset(impostor_below_px: Option<f32>) -> Preset {
    let mut p = common::tiny_preset();
    p.models = vec![ModelSpec {
        source: ModelSource::File(CF2.into()),
        size_m: 0.35,
        class: "uav".into(),
        ..ModelSpec::default()
    }];
    p.render.resolution = Resolution::Custom {
        width: 640,
        height: 360,
    };
    p.render.msaa = 4;
    p.render.lod_error_px = 0.0;
    p.render.impostor_below_px = impostor_below_px;
    p
}

/// A tiny xorshift: poses without a dependency.
fn next(state: &mut u64) -> f64 {
    *state ^= *state << 13;
    *state ^= *state >> 7;
    *state ^= *state << 17;
    (*state >> 11) as f64 / (1u64 << 53) as f64
}

/// `scene` with a grid of drones whose sizes run from 2 to 20 px, one per
/// cell, turned at random (seed `seed`).
fn grid_scene(mut scene: FrameScene, seed: u64) -> FrameScene {
    let cam = scene.camera;
    let f = cam.focal_px();
    let template = scene.drones[0].clone();
    let mut state = seed * 2_654_435_761 + 1;
    let n = COLUMNS * ROWS;
    scene.drones = (0..n)
        .map(|j| {
            let size_px = 2.0 + 18.0 * j as f64 / (n - 1) as f64;
            let z = template.size_m * f / size_px;
            let (col, row) = ((j % COLUMNS) as f64, (j / COLUMNS) as f64);
            let px = (col + 0.5) * 80.0 - f64::from(cam.width) * 0.5;
            let py = (row + 0.5) * 90.0 - f64::from(cam.height) * 0.5;
            let p_cam = DVec3::new(px * z / f, py * z / f, z);
            let axis = DVec3::new(next(&mut state) - 0.5, next(&mut state) - 0.5, 0.3)
                .normalize_or(DVec3::Y);
            let mut d = template.clone();
            d.position = cam.position + cam.camera_from_world.transpose() * p_cam;
            d.rotation = DQuat::from_axis_angle(axis, next(&mut state) * std::f64::consts::TAU);
            d
        })
        .collect();
    scene.looks.clear();
    scene
}

fn render(renderer: &mut Renderer, scene: &FrameScene) -> RenderedFrame {
    let request = RenderRequest {
        msaa: 4,
        color: true,
        visibility: true,
    };
    renderer.render_frame(scene, &request).expect("renders")
}

fn iou(a: &PixelBox, b: &PixelBox) -> f64 {
    let w = (a.x1.min(b.x1) - a.x0.max(b.x0)).max(0.0);
    let h = (a.y1.min(b.y1) - a.y0.max(b.y0)).max(0.0);
    let inter = w * h;
    inter / (a.width() * a.height() + b.width() * b.height() - inter)
}

/// Mean |Δ| of the RGB levels of `a` and `b` over `area` grown by a pixel.
fn mean_abs_diff(a: &RenderedFrame, b: &RenderedFrame, area: &PixelBox, width: usize) -> f64 {
    let (x0, y0) = (
        (area.x0 - 1.0).max(0.0) as usize,
        (area.y0 - 1.0).max(0.0) as usize,
    );
    let (x1, y1) = ((area.x1 + 1.0) as usize, (area.y1 + 1.0) as usize);
    let (mut sum, mut count) = (0u64, 0u64);
    for y in y0..y1.min(a.rgba.len() / 4 / width) {
        for x in x0..x1.min(width) {
            for c in 0..3 {
                let k = 4 * (y * width + x) + c;
                sum += u64::from(a.rgba[k].abs_diff(b.rgba[k]));
                count += 1;
            }
        }
    }
    sum as f64 / count.max(1) as f64
}

/// Per size band (2–5, 5–10, 10–20 px): the drones compared, and the mean
/// IoU, worst IoU, mean relative pixel-count difference and mean |Δ| levels
/// (over the drones both pictures show), and the drones one picture shows
/// and the other does not.
#[derive(Clone, Copy, Debug, Default)]
struct Band {
    drones: usize,
    iou_sum: f64,
    iou_min: f64,
    pixels_sum: f64,
    levels_sum: f64,
    one_sided: usize,
}

#[test]
fn impostors_stay_close_to_the_full_mesh_for_drones_of_2_to_20_px() {
    let ctx = common::gpu();
    let mesh_pipeline = FramePipeline::new(preset(None)).expect("pipeline");
    let imp_pipeline = FramePipeline::new(preset(Some(24.0))).expect("pipeline");
    let mut mesh = mesh_pipeline.renderer(&ctx);
    let mut imp = imp_pipeline.renderer(&ctx);
    let base = mesh_pipeline.make(&mut mesh, 0).expect("frame").scene;
    let mut bands = [Band {
        iou_min: 1.0,
        ..Band::default()
    }; 3];
    for seed in 1..=4 {
        let scene = grid_scene(base.clone(), seed);
        // Every drone is under 24 px: none is drawn with its mesh (level 0).
        let levels = imp.level_histogram(&scene);
        assert_eq!(levels.first(), Some(&0), "{levels:?}");
        assert_eq!(levels.iter().sum::<usize>(), scene.drones.len());
        let (a, b) = (render(&mut mesh, &scene), render(&mut imp, &scene));
        let (va, vb) = (
            a.visibility.as_ref().expect("vis"),
            b.visibility.as_ref().expect("vis"),
        );
        for (j, (m, i)) in va.iter().zip(vb).enumerate() {
            let size_px = 2.0 + 18.0 * j as f64 / (scene.drones.len() - 1) as f64;
            let band = &mut bands[usize::from(size_px >= 5.0) + usize::from(size_px >= 10.0)];
            let (mb, ib) = match (m.visible_box, i.visible_box) {
                (Some(mb), Some(ib)) => (mb, ib),
                (None, None) => continue,
                _ => {
                    // Seen in one picture only (a drone thinner than a sample).
                    band.one_sided += 1;
                    continue;
                }
            };
            let union = PixelBox {
                x0: mb.x0.min(ib.x0),
                y0: mb.y0.min(ib.y0),
                x1: mb.x1.max(ib.x1),
                y1: mb.y1.max(ib.y1),
            };
            let overlap = iou(&mb, &ib);
            band.drones += 1;
            band.iou_sum += overlap;
            band.iou_min = band.iou_min.min(overlap);
            band.pixels_sum += (i.visible_pixels as f64 - m.visible_pixels as f64).abs()
                / m.visible_pixels.max(1) as f64;
            band.levels_sum += mean_abs_diff(&a, &b, &union, scene.camera.width as usize);
        }
    }
    // Mean IoU ≥, worst IoU ≥, mean pixel-count difference ≤, mean |Δ| levels ≤.
    let bounds = [
        (0.70, 0.25, 0.55, 5.0),
        (0.78, 0.35, 0.35, 6.5),
        (0.88, 0.65, 0.23, 7.5),
    ];
    for (k, band) in bands.iter().enumerate() {
        let n = band.drones as f64;
        let (iou_mean, pixels, levels) =
            (band.iou_sum / n, band.pixels_sum / n, band.levels_sum / n);
        eprintln!(
            "band {k}: {} drones, IoU mean {iou_mean:.3} min {:.3}, pixel count diff {:.1} %, |Δ| {levels:.2} levels, {} in one picture only",
            band.drones,
            band.iou_min,
            pixels * 100.0,
            band.one_sided
        );
    }
    for (k, (band, bound)) in bands.iter().zip(bounds).enumerate() {
        let n = band.drones as f64;
        let (iou_mean, pixels, levels) =
            (band.iou_sum / n, band.pixels_sum / n, band.levels_sum / n);
        assert!(band.one_sided <= band.drones / 8, "band {k}: {band:?}");
        assert!(band.drones >= 16, "band {k}: {band:?}");
        assert!(iou_mean >= bound.0, "band {k}: mean IoU {iou_mean}");
        assert!(
            band.iou_min >= bound.1,
            "band {k}: worst IoU {}",
            band.iou_min
        );
        assert!(
            pixels <= bound.2,
            "band {k}: pixel count difference {pixels}"
        );
        assert!(levels <= bound.3, "band {k}: mean |Δ| {levels} levels");
    }
}

/// Drones drawn as impostors (alpha as MSAA coverage) piled into one 100 px
/// square: each one's unoccluded count, counted for all of them at once in
/// the footprint pass, equals what it shows rendered alone.
#[test]
fn overlapping_impostors_unoccluded_counts_equal_each_drone_alone() {
    let ctx = common::gpu();
    let pipeline = FramePipeline::new(preset(Some(24.0))).expect("pipeline");
    let mut imp = pipeline.renderer(&ctx);
    let base = pipeline.make(&mut imp, 0).expect("frame").scene;
    let mut scene = grid_scene(base, 7);
    let cam = scene.camera;
    let toward = |d: &swarmshot::scene::DronePose, k: usize| {
        // Each drone slid along its line of sight onto a spot near the centre.
        let p_cam = cam.camera_from_world * (d.position - cam.position);
        let (dx, dy) = (
            (k % 6) as f64 * 14.0 - 35.0,
            (k / 6 % 6) as f64 * 12.0 - 30.0,
        );
        let f = cam.focal_px();
        let moved = DVec3::new(dx * p_cam.z / f, dy * p_cam.z / f, p_cam.z);
        cam.position + cam.camera_from_world.transpose() * moved
    };
    for (k, d) in scene.drones.iter_mut().enumerate() {
        d.position = toward(d, k);
    }
    let vis = render(&mut imp, &scene).visibility.expect("vis");
    let mut hidden = 0;
    for (i, v) in vis.iter().enumerate() {
        let mut alone = scene.clone();
        alone.drones = vec![scene.drones[i].clone()];
        let a = render(&mut imp, &alone).visibility.expect("vis")[0];
        assert_eq!(v.unoccluded_pixels, a.visible_pixels, "drone {i}");
        hidden += usize::from(v.visible_pixels < v.unoccluded_pixels);
    }
    assert!(hidden >= 5, "{hidden} drones partly hidden");
}

#[test]
fn an_impostor_bakes_every_direction_with_a_silhouette_inside_its_tile() {
    let model = swarmshot::model::load_file(std::path::Path::new(CF2)).expect("cf2 loads");
    let start = std::time::Instant::now();
    let baked = impostor::bake(&model);
    eprintln!("cf2 impostor bake: {:?}", start.elapsed());
    assert_eq!(baked.directions.len(), impostor::DIRECTIONS);
    assert_eq!(baked.vertices.len(), 4 * impostor::DIRECTIONS);
    assert_eq!(baked.indices.len(), 6 * impostor::DIRECTIONS);
    let (w, t) = (baked.atlas.width as usize, impostor::TILE as usize);
    for k in 0..impostor::DIRECTIONS {
        let (ox, oy) = ((k * t) % w, (k * t) / w * t);
        let alpha = |x: usize, y: usize| baked.atlas.rgba8[4 * ((oy + y) * w + ox + x) + 3];
        let covered = (0..t * t).filter(|&i| alpha(i % t, i / t) > 0).count();
        // Something is drawn, and the tile's border stays empty (the margin).
        assert!(covered > t * t / 50, "direction {k}: {covered} texels");
        for i in 0..t {
            for (x, y) in [(i, 0), (i, t - 1), (0, i), (t - 1, i)] {
                assert_eq!(alpha(x, y), 0, "direction {k}: border texel ({x}, {y})");
            }
        }
    }
    // The nearest direction of each baked one is itself.
    for (k, d) in baked.directions.iter().enumerate() {
        assert_eq!(impostor::nearest(&baked.directions, *d), k);
    }
}

/// Field by field: `a` and `b` are the same impostor, byte for byte.
fn assert_same(a: &impostor::Impostor, b: &impostor::Impostor, what: &str) {
    assert_eq!(a.directions, b.directions, "{what}: directions");
    assert_eq!(a.vertices, b.vertices, "{what}: vertices");
    assert_eq!(a.indices, b.indices, "{what}: indices");
    let (x, y) = (&a.atlas, &b.atlas);
    assert_eq!(
        (&x.name, x.width, x.height, x.wrap),
        (&y.name, y.width, y.height, y.wrap)
    );
    assert!(x.rgba8 == y.rgba8, "{what}: atlas texels differ");
}

/// The cached bake (`model::impostor_cache`) gives the bake's bytes on a
/// miss and on a hit; a corrupt, truncated or foreign file is never
/// trusted: it is ignored and baked over.
#[test]
fn a_cached_impostor_is_the_bake_and_a_corrupt_file_is_baked_over() {
    use swarmshot::model::impostor_cache::{cached_bake_in, decode, encode, file_name, key};
    let model = swarmshot::model::load_file(std::path::Path::new(CF2)).expect("cf2 loads");
    let baked = impostor::bake(&model);
    let dir = tempfile::tempdir().expect("temp dir");
    let k = key(&model);
    let file = dir.path().join(file_name(&k));
    assert_same(&cached_bake_in(Some(dir.path()), &model), &baked, "miss");
    let good = std::fs::read(&file).expect("the miss writes the file");
    assert_eq!(good, encode(&k, &baked));
    assert_same(&cached_bake_in(Some(dir.path()), &model), &baked, "hit");
    let names: Vec<_> = std::fs::read_dir(dir.path()).expect("list").collect();
    assert_eq!(names.len(), 1, "no temporary file left: {names:?}");
    // A flipped byte anywhere (magic, key, vertices, texels, checksum), a
    // truncated or empty file, or another model's key: not decoded.
    for at in [0, 9, 44, 100, good.len() / 2, good.len() - 1] {
        let mut bad = good.clone();
        bad[at] ^= 0x10;
        assert!(decode(&bad, &k, &model).is_none(), "byte {at}");
    }
    assert!(decode(&good[..good.len() - 40], &k, &model).is_none());
    assert!(decode(&[], &k, &model).is_none());
    let mut moved = model.clone();
    moved.vertices[0].position[0] += 0.5;
    assert_ne!(key(&moved), k);
    assert!(decode(&good, &key(&moved), &moved).is_none());
    // A checksummed file of the right size whose vertices are not quads'.
    let mut odd = baked.clone();
    odd.vertices[3].material[3] = 0.0;
    assert!(decode(&encode(&k, &odd), &k, &model).is_none());
    // On disk: a corrupt file and a truncated one are baked over and rewritten.
    let mut bad = good.clone();
    bad[good.len() / 2] ^= 0x01;
    for (what, bytes) in [("corrupt", &bad[..]), ("truncated", &good[..1000])] {
        std::fs::write(&file, bytes).expect("write");
        assert_same(&cached_bake_in(Some(dir.path()), &model), &baked, what);
        assert!(std::fs::read(&file).expect("rewritten") == good, "{what}");
    }
}
