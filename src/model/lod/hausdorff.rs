//! The error bound of a level: a triangle soup with a bounding volume
//! hierarchy for nearest-point queries ([`Surface`]), and an upper bound of
//! the symmetric Hausdorff distance between two such surfaces, found by
//! sampling with bisection ([`hausdorff_bound`], [`one_sided_worst`]).

use glam::DVec3;

/// A triangle soup with a bounding volume hierarchy for nearest-point queries.
pub(super) struct Surface {
    /// Triangles of non-zero area, in BVH leaf order.
    pub(super) triangles: Vec<[DVec3; 3]>,
    nodes: Vec<Node>,
    /// The same triangles in index order, with their sorted vertex indices.
    pub(super) source: Vec<[DVec3; 3]>,
    pub(super) keys: Vec<[u32; 3]>,
    /// `keys`, sorted, for lookups.
    pub(super) keys_sorted: Vec<[u32; 3]>,
    /// Every position the triangles use, once.
    pub(super) corners: Vec<DVec3>,
    /// For each vertex index, its position's place in `corners` (`u32::MAX`: unused).
    corner_of: Vec<u32>,
}

/// A BVH node: its box and either two children or a run of triangles.
struct Node {
    lo: DVec3,
    hi: DVec3,
    /// Inner: (left child, right child); leaf: (first triangle, count) with `leaf` set.
    a: usize,
    b: usize,
    leaf: bool,
}

/// Triangles per BVH leaf at most: 2 measured 6 % faster than 4 (and as
/// fast as 1) on the 9 434-triangle Crazyflie's levels; the bounds do not
/// depend on it.
const LEAF_TRIANGLES: usize = 2;

impl Surface {
    pub(super) fn new(positions: &[DVec3], indices: &[u32]) -> Self {
        let mut source = Vec::new();
        let mut keys = Vec::new();
        let mut used = vec![false; positions.len()];
        for t in indices.chunks_exact(3) {
            let tri = [t[0], t[1], t[2]].map(|i| positions[i as usize]);
            let [a, b, c] = tri;
            if (b - a).cross(c - a).length_squared() > 0.0 {
                let mut key = [t[0], t[1], t[2]];
                key.sort_unstable();
                source.push(tri);
                keys.push(key);
                for i in key {
                    used[i as usize] = true;
                }
            }
        }
        // Each position once (split normals repeat positions): the largest
        // distance over the corners does not depend on their order or repeats.
        let mut seen = std::collections::HashMap::new();
        let mut corners = Vec::new();
        let corner_of = (positions.iter().zip(&used))
            .map(|(p, &u)| {
                if !u {
                    return u32::MAX;
                }
                *seen
                    .entry(p.to_array().map(f64::to_bits))
                    .or_insert_with(|| {
                        corners.push(*p);
                        corners.len() as u32 - 1
                    })
            })
            .collect();
        let mut keys_sorted = keys.clone();
        keys_sorted.sort_unstable();
        let mut triangles = source.clone();
        let mut nodes = Vec::new();
        if !triangles.is_empty() {
            let n = triangles.len();
            build_node(&mut triangles, 0, n, &mut nodes);
        }
        Self {
            triangles,
            nodes,
            source,
            keys,
            keys_sorted,
            corners,
            corner_of,
        }
    }

    /// Distance from `p` to the surface and the triangle (index into
    /// `triangles`) at that distance; once a triangle within `enough` is
    /// found, the search stops and returns that (smaller) distance. The
    /// triangle `hint` is tried first: when it is within `enough` it is the
    /// answer (a caller that only asks "within `enough`?" gets the same
    /// answer as from the full search); otherwise its distance bounds the
    /// search, so a distance above `enough` is the exact nearest distance.
    pub(super) fn nearest(&self, p: DVec3, enough: f64, hint: usize) -> (f64, usize) {
        let enough_sq = enough.max(0.0).powi(2);
        let (mut best_sq, mut best) = (f64::INFINITY, hint);
        if let Some(t) = self.triangles.get(hint) {
            let d_sq = (closest_point_on_triangle(p, t) - p).length_squared();
            if d_sq <= enough_sq {
                return (d_sq.sqrt(), hint);
            }
            // A bound to prune with; only a nearer triangle replaces it.
            best_sq = d_sq;
        }
        // Depth-first with the nearer child on top: at most one pending
        // sibling per level, and median splits keep the depth near log2(n).
        // Each pending node with its box's distance (computed once, when its
        // parent ordered the children).
        let mut stack = [(0usize, 0.0f64); 128];
        let mut len = 0;
        if let Some(root) = self.nodes.first() {
            stack[0] = (0, box_distance_sq(p, root.lo, root.hi));
            len = 1;
        }
        while len > 0 {
            len -= 1;
            let (i, box_sq) = stack[len];
            if box_sq >= best_sq {
                continue;
            }
            let node = &self.nodes[i];
            if node.leaf {
                for (k, t) in (node.a..).zip(&self.triangles[node.a..node.a + node.b]) {
                    let d_sq = (closest_point_on_triangle(p, t) - p).length_squared();
                    if d_sq < best_sq {
                        (best_sq, best) = (d_sq, k);
                    }
                }
                if best_sq <= enough_sq {
                    break;
                }
            } else {
                let (l, r) = (&self.nodes[node.a], &self.nodes[node.b]);
                let dl = box_distance_sq(p, l.lo, l.hi);
                let dr = box_distance_sq(p, r.lo, r.hi);
                // Nearer child on top of the stack.
                let (far, near) = if dl <= dr {
                    ((node.b, dr), (node.a, dl))
                } else {
                    ((node.a, dl), (node.b, dr))
                };
                if len + 2 > stack.len() {
                    // Unreachable with median splits; a guard, not a panic.
                    continue;
                }
                stack[len] = far;
                stack[len + 1] = near;
                len += 2;
            }
        }
        (best_sq.sqrt(), best)
    }

    /// Whether some triangle has every corner of `t` closer than
    /// `limit_sq.sqrt()` ([`Surface::within`] for any triangle, not one):
    /// only nodes whose box is that close to all three corners are opened.
    fn any_within_of(&self, t: &[DVec3; 3], limit_sq: f64) -> bool {
        let near = |node: &Node| {
            t.iter()
                .all(|&v| box_distance_sq(v, node.lo, node.hi) < limit_sq)
        };
        let mut stack = [0usize; 128];
        let mut len = usize::from(self.nodes.first().is_some_and(near));
        while len > 0 {
            len -= 1;
            let node = &self.nodes[stack[len]];
            if node.leaf {
                if (node.a..node.a + node.b).any(|k| self.within(t, k, limit_sq)) {
                    return true;
                }
                continue;
            }
            for child in [node.a, node.b] {
                if near(&self.nodes[child]) && len < stack.len() {
                    stack[len] = child;
                    len += 1;
                }
            }
        }
        false
    }

    /// Whether every point of `t` lies closer than `limit_sq.sqrt()` to
    /// triangle `k` (distance to a triangle is convex, so its largest value
    /// over `t` is at a corner of `t`).
    fn within(&self, t: &[DVec3; 3], k: usize, limit_sq: f64) -> bool {
        self.triangles.get(k).is_some_and(|near| {
            t.iter()
                .all(|&v| (closest_point_on_triangle(v, near) - v).length_squared() < limit_sq)
        })
    }
}

/// Build the node over `triangles[start..end]` (median split along the
/// longest axis of the centroids) and return its index.
fn build_node(
    triangles: &mut [[DVec3; 3]],
    start: usize,
    end: usize,
    nodes: &mut Vec<Node>,
) -> usize {
    let run = &mut triangles[start..end];
    let (mut lo, mut hi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
    let (mut clo, mut chi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
    for t in run.iter() {
        for p in t {
            lo = lo.min(*p);
            hi = hi.max(*p);
        }
        let c = (t[0] + t[1] + t[2]) / 3.0;
        clo = clo.min(c);
        chi = chi.max(c);
    }
    let index = nodes.len();
    nodes.push(Node {
        lo,
        hi,
        a: start,
        b: end - start,
        leaf: true,
    });
    if end - start <= LEAF_TRIANGLES {
        return index;
    }
    let axis = (chi - clo).max_position();
    run.sort_by(|s, t| {
        let cs = s[0][axis] + s[1][axis] + s[2][axis];
        let ct = t[0][axis] + t[1][axis] + t[2][axis];
        cs.total_cmp(&ct)
    });
    let mid = start + (end - start) / 2;
    let left = build_node(triangles, start, mid, nodes);
    let right = build_node(triangles, mid, end, nodes);
    nodes[index] = Node {
        lo,
        hi,
        a: left,
        b: right,
        leaf: false,
    };
    index
}

fn box_distance_sq(p: DVec3, lo: DVec3, hi: DVec3) -> f64 {
    let d = (lo - p).max(p - hi).max(DVec3::ZERO);
    d.length_squared()
}

/// The point of triangle `t` nearest to `p` (Ericson, Real-Time Collision Detection, 5.1.5).
fn closest_point_on_triangle(p: DVec3, t: &[DVec3; 3]) -> DVec3 {
    let [a, b, c] = *t;
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + ab * (d1 / (d1 - d3));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + ac * (d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let denom = 1.0 / (va + vb + vc);
    a + ab * (vb * denom) + ac * (vc * denom)
}

/// An upper bound of the symmetric Hausdorff distance between two surfaces
/// (the farthest any point of either lies from the other).
pub(super) fn hausdorff_bound(x: &Surface, y: &Surface) -> f64 {
    let there = one_sided_worst(x, y, 0.0);
    sampled_bound(one_sided_worst(y, x, there))
}

/// The bound may exceed the largest sampled distance by this fraction of it…
const RELATIVE_SLACK: f64 = 0.25;
/// …plus this many model units.
const ABSOLUTE_SLACK: f64 = 1.0 / 128.0;
/// Bisections of one source triangle, at most (a guard against slivers).
pub(super) const MAX_DEPTH: u32 = 48;

/// An upper bound of the farthest any point of `from` lies from `to`.
///
/// Every point `p` of a triangle with centroid `g` satisfies
/// `d(p) ≤ d(g) + |p − g| ≤ d(g) + r`, `r` the farthest vertex from `g`,
/// because distance to a set changes no faster than position. With `w` the
/// largest distance sampled so far, the bound is `B = (1 + ε)·w + δ`
/// ([`RELATIVE_SLACK`], [`ABSOLUTE_SLACK`]): a triangle with `d(g) + r ≤ B`
/// is done; one whose `r ≤ ε·w + δ` raises `w` to `d(g)` (after which it is
/// within `B`); any other is bisected along its longest edge. Triangles
/// that `to` has too (the same three vertices) are at distance 0.
///
/// Shortcuts that leave the result exactly as without them (the tests
/// compare it bit for bit with the plain walk): `w` starts at the largest
/// corner distance `w₀`, and a triangle (or piece) lying wholly within `w₀`
/// of one triangle of `to` cannot raise `w` (a piece raises it only to its
/// own `d(g)`, at most its largest distance; at [`MAX_DEPTH`] bisections a
/// piece is far smaller than δ), so it is skipped; that one
/// triangle is the one found nearest for the piece before (the `hint`),
/// which also answers most "within `B − r`?" queries without the tree.
/// A piece whose radius alone is past `B` (`r > B`) can only be skipped or
/// split, whatever its distance, so it asks the tree only whether any one
/// triangle lies within `w₀` of all of it.
pub(super) fn one_sided_worst(from: &Surface, to: &Surface, start: f64) -> f64 {
    if from.triangles.is_empty() {
        return start;
    }
    if to.triangles.is_empty() {
        return f64::INFINITY;
    }
    let bound = sampled_bound;
    // Distances at the vertices: a lower bound to start pruning with.
    let mut worst = start;
    let mut hint = 0;
    // For each corner, a triangle of `to` within `worst` of it, or its nearest.
    let near_corner: Vec<usize> = (from.corners.iter())
        .map(|&p| {
            let (d, k) = to.nearest(p, worst, hint);
            hint = k;
            worst = worst.max(d);
            k
        })
        .collect();
    // Strictly below w₀, with room for rounding.
    let limit = worst * (1.0 - 1e-9);
    let limit_sq = limit * limit;
    let mut stack: Vec<([DVec3; 3], u32, usize)> = Vec::new();
    for (key, t) in from.keys.iter().zip(&from.source) {
        if to.keys_sorted.binary_search(key).is_ok() {
            continue;
        }
        // The triangle near its first corner is near it too.
        let corner = from.corner_of.get(key[0] as usize);
        let near = corner.and_then(|&c| near_corner.get(c as usize));
        stack.push((*t, 0, near.copied().unwrap_or(hint)));
        while let Some((t, depth, near)) = stack.pop() {
            if to.within(&t, near, limit_sq) {
                continue;
            }
            let [a, b, c] = t;
            let g = (a + b + c) / 3.0;
            let r = (a - g).length().max((b - g).length()).max((c - g).length());
            if r > bound(worst) && depth < MAX_DEPTH {
                // Too large to settle (its radius alone is past the bound),
                // so it is skipped or split, whatever its nearest triangle:
                // skipped when some triangle is within w₀ of all of it.
                if !to.any_within_of(&t, limit_sq) {
                    for half in bisect_longest_edge([a, b, c]) {
                        stack.push((half, depth + 1, near));
                    }
                }
                continue;
            }
            let (d, k) = to.nearest(g, bound(worst) - r, near);
            hint = k;
            if d + r <= bound(worst) {
                continue;
            }
            if r <= bound(worst) - worst || depth >= MAX_DEPTH {
                // Here d > w; after this, d + r ≤ (1 + ε)·d + δ.
                worst = worst.max(d + (r - (bound(d) - d)).max(0.0));
                continue;
            }
            if to.within(&t, k, limit_sq) {
                continue;
            }
            for half in bisect_longest_edge([a, b, c]) {
                stack.push((half, depth + 1, k));
            }
        }
    }
    worst
}

/// The two halves of triangle `[a, b, c]` split at its longest edge's midpoint.
pub(super) fn bisect_longest_edge([a, b, c]: [DVec3; 3]) -> [[DVec3; 3]; 2] {
    let (ab, bc, ca) = ((b - a).length(), (c - b).length(), (a - c).length());
    let [p, q, o] = if ab >= bc && ab >= ca {
        [a, b, c]
    } else if bc >= ca {
        [b, c, a]
    } else {
        [c, a, b]
    };
    let m = (p + q) * 0.5;
    [[p, m, o], [m, q, o]]
}

/// Whether `e` can be a bound this module computed for two surfaces inside
/// a unit-span box: at least the slack δ ([`ABSOLUTE_SLACK`]: the bound of
/// two equal surfaces) and at most the bound of twice the box's diagonal
/// (a sampled distance is at most that diagonal plus a piece's radius).
pub(super) fn plausible_bound(e: f32) -> bool {
    let most = sampled_bound(2.0 * 3f64.sqrt());
    (f64::from(e) >= ABSOLUTE_SLACK) && f64::from(e) <= most
}

/// The error bound of the level `indices` over `positions` against the full
/// mesh's surface `full` (as stored: single precision).
pub(super) fn level_bound(full: &Surface, positions: &[DVec3], indices: &[u32]) -> f32 {
    hausdorff_bound(full, &Surface::new(positions, indices)) as f32
}

/// The Hausdorff bound that a largest sampled distance `w` stands for.
pub(super) fn sampled_bound(w: f64) -> f64 {
    (1.0 + RELATIVE_SLACK) * w + ABSOLUTE_SLACK
}
