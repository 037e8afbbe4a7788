//! Tests of [`super`]: the levels, their error bounds, the pick and the silhouette metric.

use std::path::Path;

use glam::{DMat3, DQuat};
use rand::{Rng, SeedableRng};

use super::hausdorff::{MAX_DEPTH, bisect_longest_edge, one_sided_worst, sampled_bound};
use super::*;
use crate::model::builtin::{NAMES as BUILTIN_NAMES, glb as builtin_glb};

fn builtin(name: &str) -> CpuModel {
    let glb = builtin_glb(name).expect("built-in");
    crate::model::load_bytes(glb, None, Path::new(name), name).expect("loads")
}

/// A uniformly random rotation (Shoemake), from a seeded generator.
fn random_rotation(rng: &mut impl Rng) -> DMat3 {
    let (u1, u2, u3): (f64, f64, f64) = (rng.random(), rng.random(), rng.random());
    let tau = std::f64::consts::TAU;
    let q = DQuat::from_xyzw(
        (1.0 - u1).sqrt() * (tau * u2).sin(),
        (1.0 - u1).sqrt() * (tau * u2).cos(),
        u1.sqrt() * (tau * u3).sin(),
        u1.sqrt() * (tau * u3).cos(),
    );
    DMat3::from_quat(q.normalize())
}

#[test]
fn levels_shrink_share_the_vertex_buffer_and_keep_textures() {
    for name in BUILTIN_NAMES {
        let model = builtin(name);
        let lods = build_lods(&model).expect("builds");
        assert_eq!(lods[0].indices, model.indices, "{name}");
        assert_eq!(lods[0].draws, model.draws, "{name}");
        assert_eq!(lods[0].error, 0.0, "{name}");
        assert!(lods.len() >= 4, "{name}: only {} levels", lods.len());
        let last = lods.last().expect("levels");
        assert!(
            last.triangle_count() <= MIN_TRIANGLES * 2,
            "{name}: coarsest level has {} triangles",
            last.triangle_count()
        );
        for pair in lods.windows(2) {
            let (finer, coarser) = (&pair[0], &pair[1]);
            assert!(
                (coarser.triangle_count() as f64) <= MIN_PROGRESS * finer.triangle_count() as f64,
                "{name}"
            );
            assert!(coarser.error.is_finite() && coarser.error > 0.0, "{name}");
            // A coarser level of no larger error would make the finer one useless.
            assert!(coarser.error > finer.error, "{name}");
        }
        for lod in &lods {
            assert!(lod.indices.len().is_multiple_of(3) && !lod.indices.is_empty());
            assert!(
                lod.indices
                    .iter()
                    .all(|&i| (i as usize) < model.vertices.len())
            );
            // The draw ranges tile the index buffer, each with one of the model's textures.
            let mut next = 0;
            for d in &lod.draws {
                assert_eq!(d.indices.start, next, "{name}");
                assert!(d.indices.end > d.indices.start, "{name}");
                next = d.indices.end;
                assert!(model.draws.iter().any(|m| m.texture == d.texture));
            }
            assert_eq!(next as usize, lod.indices.len(), "{name}");
        }
    }
}

#[test]
fn each_draw_range_keeps_its_own_vertices() {
    // Two textures on one quad_x: the first half of the triangles in one
    // range, the rest in another; no LOD triangle may mix the two.
    let mut model = builtin("quad_x");
    let half = (model.triangle_count() / 2 * 3) as u32;
    let end = model.indices.len() as u32;
    model.draws = vec![
        DrawRange {
            indices: 0..half,
            texture: Some(0),
            double_sided: false,
            alpha_mask: false,
            alpha_blend: false,
        },
        DrawRange {
            indices: half..end,
            texture: Some(1),
            double_sided: false,
            alpha_mask: false,
            alpha_blend: false,
        },
    ];
    let range_of = |i: u32| model.indices[..half as usize].contains(&i);
    let lods = build_lods(&model).expect("builds");
    assert!(lods.len() >= 3);
    for lod in &lods[1..] {
        for d in &lod.draws {
            let first = d.indices.start == 0;
            assert_eq!(d.texture, Some(if first { 0 } else { 1 }));
            for &i in &lod.indices[d.indices.start as usize..d.indices.end as usize] {
                assert_eq!(range_of(i), first, "index {i} left its draw range");
            }
        }
    }
}

#[test]
fn only_levels_pick_can_use_are_kept() {
    let level = |triangles: usize, error: f32| Lod {
        indices: vec![0; triangles * 3],
        draws: Vec::new(),
        error,
    };
    let counts = |lods: &[Lod]| lods.iter().map(Lod::triangle_count).collect::<Vec<_>>();
    // 300 is dominated by 200 (fewer triangles, smaller error); 190 keeps
    // more than 90 % of 200's triangles; 20 is the coarsest.
    let kept = keep_useful(vec![
        level(1000, 0.0),
        level(500, 0.01),
        level(300, 0.05),
        level(200, 0.04),
        level(190, 0.06),
        level(20, 0.3),
    ]);
    assert_eq!(counts(&kept), [1000, 500, 200, 20]);
    // Never more than MAX_LEVELS.
    let many: Vec<Lod> = (0..40)
        .map(|k| level(10_000 >> (k / 4).min(12), k as f32 / 100.0))
        .collect();
    assert!(keep_useful(many).len() <= MAX_LEVELS);
}

#[test]
fn building_is_deterministic() {
    for name in ["hexacopter", "fixed_wing"] {
        let model = builtin(name);
        let once = build_lods(&model);
        assert_eq!(once, build_lods(&model), "{name}");
        // The same levels and bounds on any number of threads.
        for threads in [1, 2, 5] {
            assert_eq!(
                once,
                build_lods_on(&model, threads),
                "{name}, {threads} threads"
            );
        }
    }
}

/// The plain walk of [`one_sided_worst`], as it was before its shortcuts
/// (every corner and every piece asks the tree, nothing skipped): the
/// reference the shortcuts must match bit for bit.
fn plain_one_sided_worst(from: &Surface, to: &Surface, start: f64) -> f64 {
    if from.triangles.is_empty() {
        return start;
    }
    if to.triangles.is_empty() {
        return f64::INFINITY;
    }
    let bound = sampled_bound;
    // A hint past the end: no shortcut, the full search every time.
    let distance = |p: DVec3, enough: f64| to.nearest(p, enough, usize::MAX).0;
    let mut worst = start;
    for &p in &from.corners {
        worst = worst.max(distance(p, worst));
    }
    let mut stack: Vec<([DVec3; 3], u32)> = Vec::new();
    for (key, t) in from.keys.iter().zip(&from.source) {
        if to.keys_sorted.binary_search(key).is_ok() {
            continue;
        }
        stack.push((*t, 0));
        while let Some((t, depth)) = stack.pop() {
            let [a, b, c] = t;
            let g = (a + b + c) / 3.0;
            let r = (a - g).length().max((b - g).length()).max((c - g).length());
            let d = distance(g, bound(worst) - r);
            if d + r <= bound(worst) {
                continue;
            }
            if r <= bound(worst) - worst || depth >= MAX_DEPTH {
                worst = worst.max(d + (r - (bound(d) - d)).max(0.0));
                continue;
            }
            for half in bisect_longest_edge([a, b, c]) {
                stack.push((half, depth + 1));
            }
        }
    }
    worst
}

/// The candidate levels of `model` (before `keep_useful`), with the positions.
fn candidate_levels(model: &CpuModel) -> (Vec<Lod>, Vec<DVec3>) {
    let adapter = VertexDataAdapter::new(
        bytemuck::cast_slice(&model.vertices),
        size_of::<Vertex>(),
        0,
    )
    .expect("adapter");
    let full = Lod {
        indices: model.indices.clone(),
        draws: model.draws.clone(),
        error: 0.0,
    };
    let queue = Queue::default();
    let levels = candidates(model, &adapter, &vertex_flags(model), full, &queue);
    let positions = (model.vertices.iter())
        .map(|v| DVec3::from(v.position.map(f64::from)))
        .collect();
    (levels, positions)
}

/// The shortcuts of `one_sided_worst` (corners once, hints, pieces within
/// the corner distance skipped) change no bound by a single bit: on every
/// candidate level of every built-in model and of the 9 434-triangle
/// Crazyflie of the start-up benchmark, both directions, and so the kept
/// levels are the ones the plain walk gives.
#[test]
fn shortcut_bounds_equal_the_plain_walk_bit_for_bit() {
    let mut models: Vec<CpuModel> = BUILTIN_NAMES.iter().map(|n| builtin(n)).collect();
    let cf2 = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/uav/crazyflie2_cf2/cf2.glb");
    models.push(crate::model::load_file(&cf2).expect("cf2 loads"));
    for model in &models {
        let (mut levels, positions) = candidate_levels(model);
        assert!(levels.len() > 3, "{}", model.name);
        let full = Surface::new(&positions, &model.indices);
        for level in levels.iter_mut().skip(1) {
            let surface = Surface::new(&positions, &level.indices);
            let there = plain_one_sided_worst(&full, &surface, 0.0);
            let back = plain_one_sided_worst(&surface, &full, there);
            assert_eq!(
                one_sided_worst(&full, &surface, 0.0).to_bits(),
                there.to_bits(),
                "{}: {} triangles, full → level",
                model.name,
                level.triangle_count()
            );
            assert_eq!(
                one_sided_worst(&surface, &full, there).to_bits(),
                back.to_bits(),
                "{}: {} triangles, level → full",
                model.name,
                level.triangle_count()
            );
            level.error = sampled_bound(back) as f32;
        }
        assert_eq!(
            build_lods(model).expect("builds"),
            keep_useful(levels),
            "{}",
            model.name
        );
    }
}

#[test]
fn pick_takes_the_coarsest_level_within_the_budget() {
    let level = |error: f32| Lod {
        indices: vec![0, 1, 2],
        draws: Vec::new(),
        error,
    };
    // Errors exact in binary, so the comparisons have no rounding.
    let lods = [
        level(0.0),
        level(1.0 / 1024.0),
        level(1.0 / 128.0),
        level(1.0 / 8.0),
    ];
    // 0.5 m at 100 px/m: 50 px per model unit; level 2 is 0.39 px, level 3 6.25 px.
    assert_eq!(pick(&lods, 0.5, 100.0, 0.5), 2);
    assert_eq!(pick(&lods, 0.5, 4.0, 0.5), 3);
    assert_eq!(pick(&lods, 0.5, 10_000.0, 0.5), 0);
    // Exactly on the budget is within it.
    assert_eq!(pick(&lods, 0.5, 1024.0, 0.5), 1);
    assert_eq!(pick(&lods, f64::NAN, 10.0, 0.5), 0);
    assert_eq!(pick(&lods, 0.5, f64::INFINITY, 0.5), 0);
    assert_eq!(pick(&lods, 0.5, -1.0, 0.5), 0);
    assert_eq!(pick(&lods, 0.5, 10.0, f64::NAN), 0);
    assert_eq!(pick(&[], 0.5, 10.0, 0.5), 0);
    // A coarser level with a smaller error than a finer one is still the coarsest that fits.
    let odd = [level(0.0), level(1.0 / 16.0), level(1.0 / 64.0)];
    assert_eq!(pick(&odd, 1.0, 20.0, 0.5), 2);
}

#[test]
fn hausdorff_bound_brackets_a_known_distance() {
    // A unit square and the same square lifted by 0.1: distance 0.1 both ways.
    let positions = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 0.1],
        [1.0, 0.0, 0.1],
        [1.0, 1.0, 0.1],
        [0.0, 1.0, 0.1],
    ]
    .map(DVec3::from_array);
    let low = Surface::new(&positions, &[0, 1, 2, 0, 2, 3]);
    let high = Surface::new(&positions, &[4, 5, 6, 4, 6, 7]);
    let h = hausdorff_bound(&low, &high);
    assert!((0.1..=sampled_bound(0.1) + 1e-12).contains(&h), "{h}");
    // Half of the square removed: its far corner is √0.5 from the rest.
    let half = Surface::new(&positions, &[0, 1, 2]);
    let h = hausdorff_bound(&low, &half);
    let expected = 0.5f64.sqrt();
    assert!(
        (expected..=sampled_bound(expected) + 1e-12).contains(&h),
        "{h}"
    );
    assert_eq!(hausdorff_bound(&low, &low), sampled_bound(0.0));
    let nothing = Surface::new(&positions, &[]);
    assert_eq!(hausdorff_bound(&low, &nothing), f64::INFINITY);
}

#[test]
fn silhouette_error_sees_a_shift() {
    // The model against itself: no error; against itself shifted by a
    // quarter of its span (through a translated copy of the vertices): a
    // quarter of the size in pixels.
    let model = builtin("quad_x");
    let frame = SilhouetteFrame::new(&model, DMat3::IDENTITY, 16.0, 8);
    assert_eq!(frame.error_px(&model, &model.indices, &model.indices), 0.0);
    let mut shifted = model.clone();
    let n = model.vertices.len() as u32;
    for v in &model.vertices {
        let mut w = *v;
        w.position[0] += 0.25;
        shifted.vertices.push(w);
    }
    let moved: Vec<u32> = model.indices.iter().map(|i| i + n).collect();
    let frame = SilhouetteFrame::new(&shifted, DMat3::IDENTITY, 16.0, 8);
    let e = frame.error_px(&shifted, &model.indices, &moved);
    assert!((3.5..=4.0).contains(&e), "{e}");
}

/// The honest check: for random attitudes and projected sizes, the
/// silhouette of the level `pick` chooses differs from the full mesh's
/// by at most half a pixel, measured at 8×8 samples per pixel.
#[test]
fn picked_level_is_within_half_a_pixel_of_the_full_silhouette() {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(9);
    for name in BUILTIN_NAMES {
        let model = builtin(name);
        let lods = build_lods(&model).expect("builds");
        for (size_px, views) in [
            (4.0, 24),
            (8.0, 24),
            (16.0, 16),
            (32.0, 12),
            (64.0, 6),
            (128.0, 3),
        ] {
            let k = pick(&lods, 1.0, size_px, 0.5);
            if size_px <= 4.0 {
                assert!(k > 0, "{name}: no LOD used at {size_px} px");
            }
            for _ in 0..views {
                let frame = SilhouetteFrame::new(&model, random_rotation(&mut rng), size_px, 8);
                let e = frame.error_px(&model, &model.indices, &lods[k].indices);
                assert!(e <= 0.5, "{name} at {size_px} px, level {k}: {e} px");
            }
        }
    }
}

#[test]
fn coarsest_level_would_break_the_budget() {
    // The measurement is not blind: the coarsest level, drawn where pick
    // would not allow it, shows an error above half a pixel.
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
    for name in BUILTIN_NAMES {
        let model = builtin(name);
        let lods = build_lods(&model).expect("builds");
        let last = lods.last().expect("levels");
        let size_px = 4.0 / f64::from(last.error);
        assert!(pick(&lods, 1.0, size_px, 0.5) < lods.len() - 1);
        let worst = (0..8)
            .map(|_| {
                let frame = SilhouetteFrame::new(&model, random_rotation(&mut rng), size_px, 8);
                frame.error_px(&model, &model.indices, &last.indices)
            })
            .fold(0.0, f64::max);
        assert!(worst > 0.5, "{name}: {worst} px at {size_px} px");
    }
}

#[test]
fn inconsistent_buffers_are_named_errors() {
    let model = builtin("quad_x");
    let mut bad = model.clone();
    bad.indices[4] = bad.vertices.len() as u32;
    assert!(matches!(
        build_lods(&bad),
        Err(LodError::IndexOutOfRange { .. })
    ));
    let mut bad = model.clone();
    bad.indices.pop();
    assert!(matches!(
        build_lods(&bad),
        Err(LodError::NotTriangles { .. })
    ));
    let mut bad = model.clone();
    bad.draws[0].indices.end += 3;
    assert!(matches!(
        build_lods(&bad),
        Err(LodError::BadDrawRange { .. })
    ));
    let mut bad = model.clone();
    bad.vertices[0].position[1] = f32::NAN;
    assert!(matches!(build_lods(&bad), Err(LodError::NotFinite { .. })));
}
