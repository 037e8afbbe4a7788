//! Levels of detail in the renderer: small drones are drawn with simplified
//! meshes, and what is drawn stays within the error budget of the full mesh:
//! the same drones are labelled, visible boxes move by at most a pixel, and
//! no pixel away from a drone changes.

use crate::common;

use swarmshot::pipeline::{Frame, FramePipeline};
use swarmshot::preset::{
    BoxMethod, ModelSource, ModelSpec, Placement, Preset, Resolution, Volume, sweep::SweepRange,
};

/// Octocopters (2 092 triangles, the richest built-in) far enough to cover
/// 10–40 px, several of them overlapping.
fn preset(lod_error_px: f64) -> Preset {
    let mut p = common::tiny_preset();
    p.models = vec![ModelSpec {
        source: ModelSource::Builtin("octocopter".into()),
        size_m: 0.6,
        class: "uav".into(),
        ..ModelSpec::default()
    }];
    p.placement = Placement::Randomized {
        count: (12, 12),
        count_distribution: Default::default(),
        volume: Volume::Box {
            size_m: (12.0, 5.0, 12.0),
        },
        min_separation_m: 0.9,
    };
    p.camera.z = SweepRange::fixed(1.6);
    p.render.resolution = Resolution::Custom {
        width: 640,
        height: 360,
    };
    p.render.msaa = 4;
    p.render.lod_error_px = lod_error_px;
    p.labels.box_method = BoxMethod::Visible;
    p.labels.min_box_px = 0.0;
    p.labels.min_visible_pixels = 0;
    p.labels.min_visible_fraction = 0.0;
    p
}

fn frames(preset: Preset, count: u64) -> (Vec<Frame>, Vec<Vec<usize>>) {
    let pipeline = FramePipeline::new(preset).expect("pipeline");
    let ctx = common::gpu();
    let mut renderer = pipeline.renderer(&ctx);
    (0..count)
        .map(|i| {
            let frame = pipeline.make(&mut renderer, i).expect("frame");
            let levels = renderer.level_histogram(&frame.scene);
            (frame, levels)
        })
        .unzip()
}

#[test]
fn small_drones_are_drawn_coarser_within_a_pixel_of_the_full_mesh() {
    const FRAMES: u64 = 4;
    let (lod, lod_levels) = frames(preset(0.5), FRAMES);
    let (full, full_levels) = frames(preset(0.0), FRAMES);
    // Full detail draws every drone at level 0; the budget lets most drop.
    for levels in &full_levels {
        assert_eq!(levels.len(), 1, "{levels:?}");
    }
    let coarse: usize = lod_levels
        .iter()
        .map(|l| l.iter().skip(1).sum::<usize>())
        .sum();
    let all: usize = lod_levels.iter().map(|l| l.iter().sum::<usize>()).sum();
    assert!(
        2 * coarse > all,
        "only {coarse} of {all} drones got a coarser level: {lod_levels:?}"
    );

    let mut compared = 0;
    for (a, b) in lod.iter().zip(&full) {
        assert_eq!(a.scene, b.scene);
        let ids = |f: &Frame| f.labels.iter().map(|l| l.drone).collect::<Vec<_>>();
        assert_eq!(
            ids(a),
            ids(b),
            "frame {}: labelled drones differ",
            a.scene.index
        );
        for (la, lb) in a.labels.iter().zip(&b.labels) {
            assert_eq!(la.amodal, lb.amodal, "amodal boxes come from the full hull");
            for (ea, eb) in [
                (la.bbox.x0, lb.bbox.x0),
                (la.bbox.y0, lb.bbox.y0),
                (la.bbox.x1, lb.bbox.x1),
                (la.bbox.y1, lb.bbox.y1),
            ] {
                assert!(
                    (ea - eb).abs() <= 1.0,
                    "frame {} drone {}: visible box {:?} vs full mesh {:?}",
                    a.scene.index,
                    la.drone,
                    la.bbox,
                    lb.bbox
                );
            }
            compared += 1;
        }
        // Away from the drones (outside every amodal box grown by 2 px) nothing changes.
        let (w, h) = (
            a.scene.camera.width as usize,
            a.scene.camera.height as usize,
        );
        let near_drone = |x: usize, y: usize| {
            b.labels.iter().any(|l| {
                let (fx, fy) = (x as f64 + 0.5, y as f64 + 0.5);
                fx > l.amodal.x0 - 2.0
                    && fx < l.amodal.x1 + 2.0
                    && fy > l.amodal.y0 - 2.0
                    && fy < l.amodal.y1 + 2.0
            })
        };
        for y in 0..h {
            for x in 0..w {
                let k = 4 * (y * w + x);
                if a.rgba[k..k + 4] != b.rgba[k..k + 4] {
                    assert!(
                        near_drone(x, y),
                        "frame {}: pixel ({x}, {y}) changed away from every drone",
                        a.scene.index
                    );
                }
            }
        }
    }
    assert!(compared >= 20, "only {compared} boxes compared");
}

/// What a run builds for a model and keeps between runs (levels of detail,
/// convex hull: `model::lod_cache`, `model::hull_cache`) never changes its
/// outputs: a batch with the cache off, with a cold one (which it fills)
/// and with that one warm writes the same dataset.
#[test]
fn a_batch_writes_the_same_dataset_with_the_cache_off_cold_and_warm() {
    let dir = tempfile::tempdir().expect("temp dir");
    let file = common::preset_file(dir.path(), &preset(0.5), "lod.ron");
    let cache = dir.path().join("cache");
    let run = |out: &str, cache_dir: &std::ffi::OsStr| {
        let out = dir.path().join(out);
        let args = common::cli::batch_args(&file, &out, &["--limit", "3"]);
        let o = common::cli::command(&args)
            .env("SWARMSHOT_CACHE_DIR", cache_dir)
            .output()
            .expect("run swarmshot");
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        out
    };
    let off = run("off", "off".as_ref());
    let cold = run("cold", cache.as_os_str());
    let kinds: Vec<String> = std::fs::read_dir(cache.join("lod"))
        .expect("the cold run fills the cache")
        .map(|e| {
            e.expect("entry")
                .path()
                .extension()
                .map(|x| x.to_string_lossy().into_owned())
                .unwrap_or_default()
        })
        .collect();
    for kind in ["lod", "hull"] {
        assert!(
            kinds.iter().any(|k| k == kind),
            "no .{kind} file in {kinds:?}"
        );
    }
    let warm = run("warm", cache.as_os_str());
    common::assert_same_dataset(&off, &cold, "a cold cache");
    common::assert_same_dataset(&off, &warm, "a warm cache");
}

/// A batch finds its first frame's level-of-detail bounds on a thread while it
/// sets up (`render::bound_picks`): those must be every bound the renderer's
/// own picks then pass, or the first frame's maker still finds some itself.
/// The peer scene with its camera moved in, so that drones from a few to
/// hundreds of pixels pick levels all along the chain.
#[test]
fn the_bounds_found_ahead_are_all_the_renderers_picks_need() {
    use std::sync::Arc;
    let peer = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("presets/bench/peer.ron");
    let mut preset = Preset::open(&peer).expect("peer.ron");
    preset.camera.z = SweepRange::fixed(0.3);
    let pipeline = FramePipeline::new(preset).expect("pipeline");
    let lod_error_px = pipeline.preset().render.lod_error_px;
    let model = swarmshot::model::load_file(&common::testdata("uav/crazyflie2_cf2/cf2.glb"))
        .expect("cf2.glb");
    let ctx = common::gpu();
    let found = |k: &[Option<f32>]| k.iter().filter(|e| e.is_some()).count();
    let mut beyond_built = 0;
    for index in 0..4 {
        let scene = pipeline.scene(index).expect("scene");
        // A chain as a first run builds it: only its coarse levels bounded.
        let chain = Arc::new(swarmshot::model::lod::build_lods(&model).expect("levels"));
        let built = found(&chain.known_errors());
        let chains = std::slice::from_ref(&chain);
        swarmshot::render::bound_picks(&scene, chains, lod_error_px, 0.0);
        let ahead = chain.known_errors();
        beyond_built += found(&ahead) - built;
        let drones = std::slice::from_ref(&model);
        let renderer = swarmshot::render::Renderer::with_lods(&ctx, drones, chains, lod_error_px);
        let levels = renderer.level_histogram(&scene);
        assert!(levels.len() > 2, "frame {index}: {levels:?}");
        assert_eq!(
            chain.known_errors(),
            ahead,
            "frame {index}: the renderer found more bounds"
        );
    }
    assert!(
        beyond_built > 0,
        "no frame needed a level beyond those bounded as built"
    );
}
