//! The convex hull the labeller projects (its min/max give the amodal box)
//! and the renderer uses as "where a drone can put pixels".
//!
//! The hull itself comes from the `chull` crate, whose exact big-integer
//! predicates make it robust but slow: on a model of a few thousand vertices
//! it was the longest single-threaded step of loading. Most of those vertices
//! lie well inside the hull, so an Akl–Toussaint pre-filter drops them first:
//! the extreme points in a few dozen fixed directions span an inner hull (small,
//! so cheap to build exactly), and a point strictly inside every face of it, by
//! a margin far above floating-point error, cannot be on the full hull. `chull`
//! then runs on the survivors in their original order, which yields the
//! corners the unfiltered run yields, in the same order. Points that lie on a
//! face or an edge without being corners `chull` keeps or not by the random
//! order of its hash sets, with or without the filter; they lie within the
//! hull of the corners, so no projected min/max depends on them (the tests
//! compare the two runs on every built-in and bundled model and on random
//! and degenerate clouds).

use glam::DVec3;

/// Clouds of at most this many points are their own hull (a cube's corners:
/// nothing to drop that would repay the exact hull's cost).
pub const KEPT_AS_IS: usize = 8;

/// The vertices of the convex hull of `points`; if the hull is degenerate
/// (flat or collinear geometry) every point is kept, which gives the same box.
pub fn convex_hull_vertices(points: &[DVec3]) -> Vec<DVec3> {
    if points.len() <= KEPT_AS_IS {
        return points.to_vec();
    }
    // Should the filtered run fail where the full one would not (it should
    // not: the survivors hold every extreme point), the full run decides.
    if let Some(hull) = outside_inner_hull(points).and_then(|kept| exact_hull(&kept)) {
        return hull;
    }
    exact_hull(points).unwrap_or_else(|| points.to_vec())
}

/// Point `p` as `chull` hands it back: `chull` works on each coordinate
/// divided by `f64::EPSILON` and truncated to a whole number (a big
/// integer), and returns that number times `f64::EPSILON`. Coordinates of
/// magnitude 1 or more come back as they were; smaller ones lose the bits
/// below `f64::EPSILON` (and −0 becomes 0), so a hull vertex need not be
/// bit for bit one of the points it came from.
pub fn as_chull_returns(p: DVec3) -> DVec3 {
    p.to_array()
        .map(|c| {
            let t = (c / f64::EPSILON).trunc() * f64::EPSILON;
            // A whole number of zero is +0 whatever the sign it came from.
            if t == 0.0 { 0.0 } else { t }
        })
        .into()
}

/// `chull`'s hull vertices (in input order), or `None` when it finds the
/// points degenerate or returns fewer than a tetrahedron's corners.
fn exact_hull(points: &[DVec3]) -> Option<Vec<DVec3>> {
    let input: Vec<Vec<f64>> = points.iter().map(|p| p.to_array().to_vec()).collect();
    let hull = chull::ConvexHullWrapper::try_new(&input, None).ok()?;
    let (vertices, _) = hull.vertices_indices();
    let out: Vec<DVec3> = vertices
        .iter()
        .filter(|v| v.len() == 3)
        .map(|v| DVec3::new(v[0], v[1], v[2]))
        .collect();
    (out.len() >= 4).then_some(out)
}

/// Below this many points the exact hull is cheap and filtering saves nothing.
const MIN_POINTS_TO_FILTER: usize = 64;

/// Relative margin of the inside test: some ten million times the rounding
/// error of the plane distances, so no rounding can drop a hull vertex.
const MARGIN: f64 = 1e-9;

/// Absolute floor of the margin: `chull` rounds coordinates to multiples of
/// `f64::EPSILON`, which a cloud of tiny extent would otherwise not cover.
const MARGIN_FLOOR: f64 = 1e-12;

/// The points not strictly inside the hull of the extreme points in fixed
/// directions, in their original order; `None` when that inner hull cannot
/// be built (degenerate clouds keep the unfiltered path and its fallbacks).
fn outside_inner_hull(points: &[DVec3]) -> Option<Vec<DVec3>> {
    if points.len() < MIN_POINTS_TO_FILTER {
        return None;
    }
    let mut extremes: Vec<usize> = directions()
        .filter_map(|d| extreme_index(points, d))
        .collect();
    extremes.sort_unstable();
    extremes.dedup();
    let seeds: Vec<DVec3> = extremes.iter().map(|&i| points[i]).collect();
    let faces = outward_faces(&seeds, points)?;
    let kept: Vec<DVec3> = points
        .iter()
        .filter(|p| !faces.iter().all(|f| f.depth(**p) > f.margin))
        .copied()
        .collect();
    Some(kept)
}

/// The 98 directions from the origin to the points of the 5×5×5 grid around
/// it (one per line through it). On cf2.glb (4 779 distinct positions, 232
/// hull vertices) their extremes leave 1 398 points to the exact hull and
/// halve its time; the 26 of the 3×3×3 grid left 1 830 and saved less.
fn directions() -> impl Iterator<Item = DVec3> {
    let steps = [-2, -1, 0, 1, 2];
    steps
        .into_iter()
        .flat_map(move |x| steps.into_iter().map(move |y| (x, y)))
        .flat_map(move |(x, y)| steps.into_iter().map(move |z| [x, y, z]))
        // Vectors of even steps only repeat a direction of the smaller grid (or are zero).
        .filter(|d: &[i32; 3]| d.iter().any(|c| c % 2 != 0))
        .map(|[x, y, z]| DVec3::new(f64::from(x), f64::from(y), f64::from(z)))
}

/// The index of the point farthest along `d`, the first of equal ones.
fn extreme_index(points: &[DVec3], d: DVec3) -> Option<usize> {
    let mut best: Option<(usize, f64)> = None;
    for (i, p) in points.iter().enumerate() {
        let s = d.dot(*p);
        if best.is_none_or(|(_, b)| s > b) {
            best = Some((i, s));
        }
    }
    best.map(|(i, _)| i)
}

/// One face plane of a hull, its normal pointing outward.
struct Face {
    origin: DVec3,
    normal: DVec3,
    /// How far inside the plane a point must be to count as inside.
    margin: f64,
}

impl Face {
    /// How far `p` lies inside the plane (negative: outside).
    fn depth(&self, p: DVec3) -> f64 {
        self.normal.dot(self.origin - p)
    }
}

/// The outward face planes of the hull of `seeds`, built exactly by `chull`,
/// with margins for points within the extent of `cloud`; `None` when that
/// hull is degenerate or a face's orientation is in doubt.
fn outward_faces(seeds: &[DVec3], cloud: &[DVec3]) -> Option<Vec<Face>> {
    let input: Vec<Vec<f64>> = seeds.iter().map(|p| p.to_array().to_vec()).collect();
    let hull = chull::ConvexHullWrapper::try_new(&input, None).ok()?;
    let (corners, indices) = hull.vertices_indices();
    let corners: Vec<DVec3> = corners
        .iter()
        .map(|v| match v.as_slice() {
            [x, y, z] => Some(DVec3::new(*x, *y, *z)),
            _ => None,
        })
        .collect::<Option<_>>()?;
    if corners.len() < 4 || indices.len() < 12 || indices.len() % 3 != 0 {
        return None;
    }
    // The centroid of a solid's corners lies strictly inside it: it tells
    // outward from inward whatever winding `chull` gave a face.
    let centroid = corners.iter().sum::<DVec3>() / corners.len() as f64;
    let (lo, hi) = cloud.iter().chain(&corners).fold(
        (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
        |(lo, hi), p| (lo.min(*p), hi.max(*p)),
    );
    let extent = Extent {
        reach: lo.abs().max(hi.abs()).max_element(),
        diagonal: (hi - lo).length(),
    };
    indices
        .chunks_exact(3)
        .map(|t| {
            let [a, b, c] = [t[0], t[1], t[2]].map(|i| corners.get(i).copied());
            face([a?, b?, c?], centroid, &extent)
        })
        .collect()
}

/// The size of the cloud the faces test: what the rounding error scales with.
struct Extent {
    /// The largest coordinate magnitude.
    reach: f64,
    /// The bounding box's diagonal: the farthest a point can be from a face's origin.
    diagonal: f64,
}

/// The outward plane of a triangle, with a margin that grows with the
/// triangle's ill-conditioning (a sliver's normal is known less precisely);
/// `None` when the centroid is too close to the plane to orient it.
fn face([a, b, c]: [DVec3; 3], centroid: DVec3, extent: &Extent) -> Option<Face> {
    let cross = (b - a).cross(c - a);
    let length = cross.length();
    if !(length > 0.0 && length.is_finite()) {
        return None;
    }
    let condition = ((b - a).length() * (c - a).length() / length).max(1.0);
    let margin = MARGIN * (extent.reach + extent.diagonal * condition) + MARGIN_FLOOR;
    let mut normal = cross / length;
    let inward = normal.dot(a - centroid);
    if inward.abs() <= margin {
        return None;
    }
    if inward < 0.0 {
        normal = -normal;
    }
    Some(Face {
        origin: a,
        normal,
        margin,
    })
}

#[cfg(test)]
mod tests;
