//! Tests of [`super`]: the levels, their error bounds, the pick and the silhouette metric.

use std::path::Path;

use glam::{DMat3, DQuat};
use rand::{Rng, SeedableRng};

use super::hausdorff::{
    MAX_DEPTH, bisect_longest_edge, hausdorff_bound, one_sided_worst, sampled_bound,
};
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
        let chain = build_lods(&model).expect("builds");
        chain.bound_all();
        let lods = chain.levels();
        assert_eq!(lods[0].indices, model.indices, "{name}");
        assert_eq!(lods[0].draws, model.draws, "{name}");
        assert_eq!(chain.error(0), 0.0, "{name}");
        assert!(lods.len() >= 4, "{name}: only {} levels", lods.len());
        let last = lods.last().expect("levels");
        assert!(
            last.triangle_count() <= MIN_TRIANGLES * 2,
            "{name}: coarsest level has {} triangles",
            last.triangle_count()
        );
        for (k, pair) in lods.windows(2).enumerate() {
            let (finer, coarser) = (&pair[0], &pair[1]);
            assert!(
                (coarser.triangle_count() as f64) <= MIN_PROGRESS * finer.triangle_count() as f64,
                "{name}"
            );
            let error = chain.error(k + 1);
            assert!(plausible_error(error), "{name}: level {}: {error}", k + 1);
        }
        // The coarsest level is the least faithful.
        let coarsest = chain.error(lods.len() - 1);
        assert!(
            (1..lods.len()).all(|k| chain.error(k) <= coarsest),
            "{name}"
        );
        for lod in lods {
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
    let chain = build_lods(&model).expect("builds");
    let lods = chain.levels();
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

/// A chain of one-triangle levels with the given bounds (all known).
fn known_chain(errors: &[f32]) -> LodChain {
    let level = Lod {
        indices: vec![0, 1, 2],
        draws: Vec::new(),
    };
    let known: Vec<Option<f32>> = errors.iter().copied().map(Some).collect();
    LodChain::new(vec![level; errors.len()], &known, vec![DVec3::ZERO; 3])
}

#[test]
fn building_is_deterministic_and_bounds_do_not_depend_on_when_they_are_found() {
    for name in ["hexacopter", "fixed_wing", "octocopter"] {
        let model = builtin(name);
        let once = build_lods(&model).expect("builds");
        let again = build_lods(&model).expect("builds");
        assert_eq!(once.levels(), again.levels(), "{name}");
        // Bounded while building (the coarse levels), or later by picks in
        // another order, or all on every core: the same bounds.
        let eager = once.known_errors();
        assert!(
            eager.iter().skip(1).any(Option::is_some),
            "{name}: {eager:?}"
        );
        let late = LodChain::new(once.levels().to_vec(), &[], positions(&model));
        for px in [1.0, 300.0, 20.0, 5_000.0] {
            late.pick(px, 0.5);
        }
        once.bound_all();
        again.bound_all();
        late.bound_all();
        let all = once.known_errors();
        assert!(all.iter().all(Option::is_some), "{name}");
        assert_eq!(all, again.known_errors(), "{name}");
        assert_eq!(all, late.known_errors(), "{name}");
        for (k, e) in eager.iter().enumerate() {
            assert!(e.is_none() || *e == all[k], "{name}: level {k}");
        }
    }
}

/// A pick bounds only the levels it passes, from the coarsest: a drone that
/// a coarse level serves never pays for the fine levels' bounds, and the
/// level picked is the one a chain with every bound known picks.
#[test]
fn a_pick_bounds_only_the_levels_it_passes() {
    let cf2 = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/uav/crazyflie2_cf2/cf2.glb");
    let model = crate::model::load_file(&cf2).expect("cf2 loads");
    let built = build_lods(&model).expect("builds");
    let levels = built.levels().to_vec();
    let lazy = LodChain::new(levels.clone(), &[], positions(&model));
    let full = LodChain::new(levels.clone(), &[], positions(&model));
    full.bound_all();
    // 12 px per model unit: a 0.35 m drone 40 m away.
    let k = lazy.pick(12.0, 0.5);
    assert_eq!(k, full.pick(12.0, 0.5));
    assert!(k > 1, "level {k}");
    let known = lazy.known_errors();
    assert!(known[k..].iter().all(Option::is_some), "{known:?}");
    assert!(known[1..k].iter().all(Option::is_none), "{known:?}");
    // The levels eagerly bounded while building are the coarse ones.
    let eager = built.known_errors();
    let first = 1 + eager[1..]
        .iter()
        .position(Option::is_some)
        .expect("some bounded");
    assert!(eager[first..].iter().all(Option::is_some), "{eager:?}");
    assert!(levels[first].triangle_count() as f64 <= model.triangle_count() as f64 * EAGER_SHARE);
    for px in [0.5, 3.0, 12.0, 40.0, 150.0, 600.0, 3_000.0, 1e5] {
        assert_eq!(lazy.pick(px, 0.5), full.pick(px, 0.5), "{px} px a unit");
    }
}

/// The hook runs once after a pick that found bounds, not after one that did not.
#[test]
fn the_hook_hears_of_new_bounds_once() {
    let model = builtin("octocopter");
    let levels = build_lods(&model).expect("builds").levels().to_vec();
    let chain = LodChain::new(levels, &[], positions(&model));
    let calls = std::sync::Arc::new(std::sync::atomic::AtomicUsize::new(0));
    let seen = calls.clone();
    chain.on_bound(Box::new(move |_| {
        seen.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    }));
    let count = || calls.load(std::sync::atomic::Ordering::Relaxed);
    chain.pick(2.0, 0.5);
    assert_eq!(count(), 1);
    chain.pick(2.0, 0.5);
    assert_eq!(count(), 1);
    chain.pick(1e6, 0.5);
    assert_eq!(count(), 2);
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

/// The levels of `model`, with the positions.
fn candidate_levels(model: &CpuModel) -> (Vec<Lod>, Vec<DVec3>) {
    let adapter = VertexDataAdapter::new(
        bytemuck::cast_slice(&model.vertices),
        size_of::<Vertex>(),
        0,
    )
    .expect("adapter");
    let levels = candidates(model, &adapter, &vertex_flags(model), |_, _| {});
    (levels, positions(model))
}

/// The shortcuts of `one_sided_worst` (corners once, hints, pieces within
/// the corner distance skipped) change no bound by a single bit: on every
/// candidate level of every built-in model and of the 9 434-triangle
/// Crazyflie of the start-up benchmark, both directions, and so the chain's
/// bounds are the ones the plain walk gives.
#[test]
fn shortcut_bounds_equal_the_plain_walk_bit_for_bit() {
    let mut models: Vec<CpuModel> = BUILTIN_NAMES.iter().map(|n| builtin(n)).collect();
    let cf2 = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/uav/crazyflie2_cf2/cf2.glb");
    models.push(crate::model::load_file(&cf2).expect("cf2 loads"));
    for model in &models {
        let (levels, positions) = candidate_levels(model);
        assert!(levels.len() > 3, "{}", model.name);
        let chain = build_lods(model).expect("builds");
        assert_eq!(chain.levels(), levels.as_slice(), "{}", model.name);
        let full = Surface::new(&positions, &model.indices);
        for (k, level) in levels.iter().enumerate().skip(1) {
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
            assert_eq!(
                chain.error(k).to_bits(),
                (sampled_bound(back) as f32).to_bits(),
                "{}: level {k}",
                model.name
            );
        }
    }
}

#[test]
fn pick_takes_the_coarsest_level_within_the_budget() {
    // Errors exact in binary, so the comparisons have no rounding.
    let chain = known_chain(&[0.0, 1.0 / 1024.0, 1.0 / 128.0, 1.0 / 8.0]);
    // 0.5 m at 100 px/m: 50 px per model unit; level 2 is 0.39 px, level 3 6.25 px.
    assert_eq!(chain.pick(50.0, 0.5), 2);
    assert_eq!(chain.pick(2.0, 0.5), 3);
    assert_eq!(chain.pick(5_000.0, 0.5), 0);
    // Exactly on the budget is within it.
    assert_eq!(chain.pick(512.0, 0.5), 1);
    assert_eq!(chain.pick(f64::NAN, 0.5), 0);
    assert_eq!(chain.pick(f64::INFINITY, 0.5), 0);
    assert_eq!(chain.pick(-1.0, 0.5), 0);
    assert_eq!(chain.pick(10.0, f64::NAN), 0);
    assert_eq!(known_chain(&[]).pick(10.0, 0.5), 0);
    // A coarser level with a smaller error than a finer one is the coarsest
    // that fits; a finer level that a coarser one matches is never picked.
    let odd = known_chain(&[0.0, 1.0 / 16.0, 1.0 / 64.0]);
    assert_eq!(odd.pick(20.0, 0.5), 2);
    let matched = known_chain(&[0.0, 1.0 / 64.0, 1.0 / 64.0, 1.0 / 4.0]);
    assert_eq!(matched.pick(32.0, 0.5), 2);
    assert_eq!(matched.pick(2.0, 0.5), 3);
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
        let chain = build_lods(&model).expect("builds");
        let lods = chain.levels();
        for (size_px, views) in [
            (4.0, 24),
            (8.0, 24),
            (16.0, 16),
            (32.0, 12),
            (64.0, 6),
            (128.0, 3),
        ] {
            let k = chain.pick(size_px, 0.5);
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
        let chain = build_lods(&model).expect("builds");
        let lods = chain.levels();
        let last = lods.last().expect("levels");
        let size_px = 4.0 / f64::from(chain.error(lods.len() - 1));
        assert!(chain.pick(size_px, 0.5) < lods.len() - 1);
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
