use std::path::{Path, PathBuf};

use glam::DVec3;
use rand::{Rng, SeedableRng};

use super::*;

/// What `convex_hull_vertices` returned before the pre-filter: `chull` on
/// every point, all points when it fails.
fn unfiltered(points: &[DVec3]) -> Vec<DVec3> {
    if points.len() <= 8 {
        return points.to_vec();
    }
    exact_hull(points).unwrap_or_else(|| points.to_vec())
}

/// The hull must be the unfiltered one: the same points in the same order
/// (then the projected min/max, hence every label, cannot change). `chull`
/// walks hash sets in a random order, so of the points that lie on a face
/// or edge without being a corner, a run may keep some and the next run
/// others; two results may differ in those only, never in a corner: every
/// point one result has and the other lacks lies on the other's hull.
/// Returns whether the two were equal point for point.
fn assert_same_as_unfiltered(what: &str, points: &[DVec3]) -> bool {
    let filtered = convex_hull_vertices(points);
    let reference = unfiltered(points);
    let bits = |v: &[DVec3]| -> Vec<[u64; 3]> {
        v.iter().map(|p| p.to_array().map(f64::to_bits)).collect()
    };
    if bits(&filtered) == bits(&reference) {
        return true;
    }
    assert!(
        filtered.len() >= 4 && reference.len() >= 4,
        "{what}: {} hull points, unfiltered {}",
        filtered.len(),
        reference.len()
    );
    assert_on_hull_of(what, &filtered, &reference);
    assert_on_hull_of(what, &reference, &filtered);
    false
}

/// Every point of `extra` that `hull` lacks lies inside or on the hull of `hull`.
fn assert_on_hull_of(what: &str, extra: &[DVec3], hull: &[DVec3]) {
    let all: Vec<DVec3> = extra.iter().chain(hull).copied().collect();
    let faces = faces_of(hull, &all);
    assert!(faces.len() >= 4, "{what}: no hull faces");
    let tolerance = 1e-9
        * all
            .iter()
            .map(|p| p.abs().max_element())
            .fold(0.0, f64::max);
    for p in extra.iter().filter(|p| !hull.contains(p)) {
        let outside = faces.iter().map(|f| -f.depth(*p)).fold(f64::MIN, f64::max);
        assert!(
            outside <= tolerance,
            "{what}: {p} is {outside:e} outside the other hull: a corner differs"
        );
    }
}

/// The outward faces of the hull of `points`, less the triangles `chull`
/// leaves with three points on a line where faces hold points on edges
/// (the others still bound the hull).
fn faces_of(points: &[DVec3], cloud: &[DVec3]) -> Vec<Face> {
    let input: Vec<Vec<f64>> = points.iter().map(|p| p.to_array().to_vec()).collect();
    let hull = chull::ConvexHullWrapper::try_new(&input, None).expect("a solid hull");
    let (corners, indices) = hull.vertices_indices();
    let corners: Vec<DVec3> = corners
        .iter()
        .map(|v| DVec3::new(v[0], v[1], v[2]))
        .collect();
    let centroid = corners.iter().sum::<DVec3>() / corners.len() as f64;
    let reach = cloud
        .iter()
        .map(|p| p.abs().max_element())
        .fold(0.0, f64::max);
    let extent = Extent {
        reach,
        diagonal: 4.0 * reach,
    };
    indices
        .chunks_exact(3)
        .filter_map(|t| face([t[0], t[1], t[2]].map(|i| corners[i]), centroid, &extent))
        .collect()
}

/// The points `finish` hands to the hull of a loaded model.
fn hull_input(model: &crate::model::CpuModel) -> Vec<DVec3> {
    crate::model::unique_used_positions(&model.vertices, &model.indices)
}

#[test]
fn hull_of_a_cube_with_inner_points_is_its_corners() {
    let mut pts = Vec::new();
    for i in 0..3 {
        for j in 0..3 {
            for k in 0..3 {
                pts.push(DVec3::new(f64::from(i), f64::from(j), f64::from(k)) * 0.5);
            }
        }
    }
    let hull = convex_hull_vertices(&pts);
    // Corners must be present; the body centre must not.
    for c in [DVec3::ZERO, DVec3::ONE, DVec3::new(1.0, 0.0, 1.0)] {
        assert!(
            hull.iter().any(|h| (*h - c).length() < 1e-12),
            "{c} missing"
        );
    }
    assert!(
        !hull
            .iter()
            .any(|h| (*h - DVec3::splat(0.5)).length() < 1e-12)
    );
}

#[test]
fn builtin_models_keep_their_unfiltered_hull() {
    for b in crate::model::builtin::BUILTINS {
        let model = crate::model::load_bytes(b.glb, None, Path::new(b.name), b.name)
            .unwrap_or_else(|e| panic!("{}: {e}", b.name));
        let points = hull_input(&model);
        assert!(
            outside_inner_hull(&points).is_some_and(|kept| kept.len() < points.len()),
            "{}: the pre-filter dropped nothing",
            b.name
        );
        // Not point for point: octocopter, coaxial_heli and heavy_lift have
        // points on faces that the unfiltered `chull` itself keeps or not from run to run.
        assert_same_as_unfiltered(b.name, &points);
    }
}

/// Every glTF file under tests/data that loads.
fn bundled_models() -> Vec<PathBuf> {
    fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
        let Ok(entries) = std::fs::read_dir(dir) else {
            return;
        };
        for entry in entries.flatten() {
            let path = entry.path();
            if path.is_dir() {
                walk(&path, out);
            } else if path.extension().is_some_and(|e| e == "glb" || e == "gltf") {
                out.push(path);
            }
        }
    }
    let mut out = Vec::new();
    walk(
        &Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data"),
        &mut out,
    );
    out.sort();
    out
}

#[test]
fn bundled_models_keep_their_unfiltered_hull() {
    let mut checked = 0;
    for path in bundled_models() {
        // Some of them are there to be refused (Draco, points only): not a hull case.
        let Ok(model) = crate::model::load_file(&path) else {
            continue;
        };
        assert_same_as_unfiltered(&path.display().to_string(), &hull_input(&model));
        checked += 1;
    }
    assert!(checked >= 8, "only {checked} bundled models loaded");
}

fn random_point(rng: &mut impl Rng) -> DVec3 {
    DVec3::new(
        rng.random_range(-1.0..1.0),
        rng.random_range(-1.0..1.0),
        rng.random_range(-1.0..1.0),
    )
}

#[test]
fn random_clouds_keep_their_unfiltered_hull() {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
    for n in [70, 300, 2000] {
        let cube: Vec<DVec3> = (0..n).map(|_| random_point(&mut rng)).collect();
        assert!(assert_same_as_unfiltered("random cube", &cube));
        let ball: Vec<DVec3> = cube
            .iter()
            .map(|p| *p * 0.3)
            .filter(|p| p.length() < 0.3)
            .collect();
        assert!(assert_same_as_unfiltered("random ball", &ball));
        // Every point on the sphere is a hull vertex: nothing may be dropped.
        let sphere: Vec<DVec3> = cube.iter().map(|p| p.normalize() * 1e3).collect();
        assert!(assert_same_as_unfiltered("sphere", &sphere));
        let tiny: Vec<DVec3> = cube.iter().map(|p| *p * 1e-9 + 7e-9).collect();
        assert!(assert_same_as_unfiltered("tiny cloud", &tiny));
    }
}

#[test]
fn degenerate_clouds_keep_their_unfiltered_result() {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
    let flat: Vec<DVec3> = (0..200)
        .map(|_| random_point(&mut rng) * DVec3::new(1.0, 1.0, 0.0))
        .collect();
    assert!(assert_same_as_unfiltered("flat", &flat));
    let tilted: Vec<DVec3> = flat
        .iter()
        .map(|p| DVec3::new(p.x, p.y, 0.5 * p.x - 0.25 * p.y))
        .collect();
    assert!(assert_same_as_unfiltered("tilted plane", &tilted));
    let line: Vec<DVec3> = (0..200)
        .map(|i| DVec3::new(1.0, 2.0, 3.0) * (f64::from(i) / 7.0))
        .collect();
    assert!(assert_same_as_unfiltered("collinear", &line));
    let same = vec![DVec3::splat(0.25); 100];
    assert!(assert_same_as_unfiltered("one point", &same));
}

/// Grids: many coplanar points on the faces and edges that are not vertices,
/// where a quickhull's result could depend on the order it meets them.
#[test]
fn grid_cubes_keep_their_unfiltered_hull() {
    for side in [4, 5, 8] {
        let mut grid = Vec::new();
        let mut shell = Vec::new();
        for i in 0..side {
            for j in 0..side {
                for k in 0..side {
                    let p = DVec3::new(f64::from(i), f64::from(j), f64::from(k)) / 7.0 - 0.3;
                    grid.push(p);
                    if [i, j, k].iter().any(|&c| c == 0 || c == side - 1) {
                        shell.push(p);
                    }
                }
            }
        }
        assert_same_as_unfiltered(&format!("grid {side}"), &grid);
        assert_same_as_unfiltered(&format!("grid shell {side}"), &shell);
    }
}

/// `as_chull_returns` is what `chull` hands back: every corner of a cloud
/// whose small coordinates carry bits below `f64::EPSILON` is one of the
/// points so rounded, and some corner is not bit for bit any point.
#[test]
fn chull_returns_points_as_as_chull_returns_says() {
    let tiny = [1.095_142_088_125_555_8e-9, -3.0e-20, -0.0, 7.3e-17];
    let mut points = Vec::new();
    for (i, &t) in tiny.iter().enumerate() {
        let s = 0.1 + i as f64 * 0.037;
        points.extend([
            DVec3::new(t, s, -s),
            DVec3::new(s, t, s * 0.5),
            DVec3::new(-s, -s * 0.7, t),
        ]);
    }
    points.extend([DVec3::ZERO, DVec3::splat(0.3)]);
    let hull = exact_hull(&points).expect("a solid hull");
    let rounded: Vec<DVec3> = points.iter().map(|&p| as_chull_returns(p)).collect();
    let bits = |p: &DVec3| p.to_array().map(f64::to_bits);
    for v in &hull {
        assert!(rounded.iter().any(|r| bits(r) == bits(v)), "{v:?}");
    }
    assert!(
        hull.iter()
            .any(|v| points.iter().all(|p| bits(p) != bits(v))),
        "some corner comes back rounded"
    );
}
