//! Level of detail: a chain of simplified index buffers per model, and the
//! rule that picks one for a drone from its projected size.
//!
//! [`build_lods`] runs once per model at load. Level 0 is the model's own
//! mesh; each further level asks meshoptimizer (the `meshopt` crate) for 70 %
//! of the triangles of the level before, simplifying every draw range apart
//! so each triangle keeps its texture, and the levels that [`pick`] would
//! never choose (more triangles than a coarser level of no larger error) are
//! dropped once their error bounds are known. Levels are index buffers into the model's
//! one vertex buffer, so the GPU keeps a single vertex buffer per model and
//! a level is an index range plus its draw ranges.
//!
//! **Errors.** meshoptimizer reports `result_error`, the square root of the
//! largest quadric error of its collapses: for each collapsed vertex, the
//! weighted mean squared distance to the planes of the original triangles
//! merged into it (weights from triangle areas and border edges), or for a
//! pruned component the radius of its vertices around their mean. By
//! default it is relative to the extent of the vertex buffer passed in (the
//! largest side of the axis-aligned box of *all* its vertices, used or not;
//! `meshopt::simplify_scale`); with `SimplifyOptions::ErrorAbsolute`, used
//! here, it is in the positions' own units, i.e. model units (fractions of
//! the largest span, since models are normalised to a span of 1). It is an
//! estimate, not a bound: on the built-in models the silhouette error of a
//! level measured up to 12× its `result_error` (pruned rotors, flattened
//! thin parts). So [`Lod::error`] is not meshoptimizer's number but an upper
//! bound of the symmetric Hausdorff distance between the level's surface and
//! the full mesh's, computed by sampling (see `one_sided_worst`). An
//! orthographic projection moves no two points further apart than they are,
//! so the silhouettes of the two surfaces are at most `error · size_m ·
//! pixels_per_metre` pixels apart (Hausdorff distance, either direction);
//! [`pick`] keeps that within the budget. The tests measure it on rasterised
//! silhouettes ([`SilhouetteFrame::error_px`]).

use std::collections::BTreeMap;
use std::mem::size_of;

use glam::DVec3;
use meshopt::{SimplifyOptions, SimplifyVertex, VertexDataAdapter};

use crate::model::{CpuModel, DrawRange, Vertex};

mod silhouette;
pub use silhouette::SilhouetteFrame;

/// One level of detail: an index buffer into the model's own vertex buffer.
#[derive(Clone, Debug, PartialEq)]
pub struct Lod {
    /// Triangle list into `CpuModel::vertices`, grouped like `draws`.
    pub indices: Vec<u32>,
    /// The index ranges of `indices` and the texture each is drawn with.
    pub draws: Vec<DrawRange>,
    /// Upper bound of the Hausdorff distance between this level's surface and
    /// the full mesh's, in model units (fractions of the model's largest
    /// span); 0 for level 0. Times `size_m · pixels_per_metre` it bounds the
    /// silhouette error in pixels.
    pub error: f32,
}

impl Lod {
    /// Number of triangles.
    pub fn triangle_count(&self) -> usize {
        self.indices.len() / 3
    }
}

/// Why a model's LODs cannot be built: its buffers are inconsistent.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum LodError {
    #[error("model {model}: {len} indices are not a whole number of triangles")]
    NotTriangles { model: String, len: usize },
    #[error("model {model}: index {index} is outside its {vertices} vertices")]
    IndexOutOfRange {
        model: String,
        index: u32,
        vertices: usize,
    },
    #[error(
        "model {model}: draw range {start}..{end} is not whole triangles within its {len} indices"
    )]
    BadDrawRange {
        model: String,
        start: u32,
        end: u32,
        len: usize,
    },
    #[error("model {model}: vertex {vertex} has a position that is not finite")]
    NotFinite { model: String, vertex: usize },
    #[error("model {model}: meshopt refused the vertex buffer: {reason}")]
    Meshopt { model: String, reason: String },
}

/// A level stops the chain once it has this many triangles or fewer.
pub const MIN_TRIANGLES: usize = 48;
/// A level that keeps more than this fraction of the previous level's triangles is not made.
const MIN_PROGRESS: f64 = 0.9;
/// At most this many levels (level 0 included).
pub(crate) const MAX_LEVELS: usize = 16;
/// At most this many simplified levels are made (each needs its error bound).
const MAX_CANDIDATES: usize = 24;
/// Each candidate level asks meshoptimizer for this fraction of the
/// triangles of the one before. Halving left gaps where one step jumps from
/// a few hundredths of the span to a fifth (quad_x: 378 triangles at 0.024,
/// then 188 at 0.188, as its rotor discs collapse), so drones that could use
/// 256 triangles drew 378; finer steps cost more bounds to compute at load.
const LEVEL_STEP: f64 = 0.7;

/// The recipe of [`build_lods`], bumped whenever what it builds changes,
/// so that [`super::lod_cache`] never returns levels of an older recipe.
const RECIPE: u32 = 1;

/// Everything besides the model that decides the levels (for the cache's key).
pub(crate) fn settings() -> String {
    format!(
        "recipe {RECIPE}; min {MIN_TRIANGLES}, progress {MIN_PROGRESS}, levels {MAX_LEVELS}, \
         candidates {MAX_CANDIDATES}, step {LEVEL_STEP}; meshopt 0.7, absolute+permissive+prune"
    )
}

/// Build the LOD chain of a model: level 0 is the model's own mesh (error 0),
/// each further level has at most [`MIN_PROGRESS`] of the triangles of the one
/// before and a larger error bound.
pub fn build_lods(model: &CpuModel) -> Result<Vec<Lod>, LodError> {
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    build_lods_on(model, threads)
}

/// [`build_lods`] on `threads` threads (the same levels on any number).
fn build_lods_on(model: &CpuModel, threads: usize) -> Result<Vec<Lod>, LodError> {
    validate(model)?;
    let full = Lod {
        indices: model.indices.clone(),
        draws: model.draws.clone(),
        error: 0.0,
    };
    let adapter = VertexDataAdapter::new(
        bytemuck::cast_slice(&model.vertices),
        size_of::<Vertex>(),
        0,
    )
    .map_err(|e| LodError::Meshopt {
        model: model.name.clone(),
        reason: e.to_string(),
    })?;
    let locks = vertex_flags(model);
    let positions: Vec<DVec3> = model
        .vertices
        .iter()
        .map(|v| DVec3::from(v.position.map(f64::from)))
        .collect();
    let full_surface = Surface::new(&positions, &model.indices);
    // Each level's error bound on its own, on the other cores while the
    // simplifier makes the next levels, then on every core (a level's bound
    // does not depend on the others, so the result is the same on any
    // number of threads).
    let queue = Queue::default();
    let (mut lods, errors) = std::thread::scope(|s| {
        let workers: Vec<_> = (1..threads)
            .map(|_| s.spawn(|| bound_levels(&queue, &positions, &full_surface)))
            .collect();
        let lods = {
            // Workers stop waiting however this ends (a panic included).
            let _finish = FinishOnDrop(&queue);
            candidates(model, &adapter, &locks, full, &queue)
        };
        let mut errors = bound_levels(&queue, &positions, &full_surface);
        for w in workers {
            errors.extend(w.join().unwrap_or_default());
        }
        (lods, errors)
    });
    let mut bounded = vec![false; lods.len()];
    for (k, error) in errors {
        if let Some(level) = lods.get_mut(k) {
            level.error = error;
            bounded[k] = true;
        }
    }
    if bounded.iter().skip(1).any(|b| !b) {
        // A worker panicked: keep only the full mesh rather than trust a missing bound.
        lods.truncate(1);
    }
    Ok(keep_useful(lods))
}

/// The candidate levels after `full`, each with [`LEVEL_STEP`] of the
/// triangles of the one before, down to a few dozen; each is handed to
/// `queue` as soon as it is made. `keep_useful` drops the ones `pick` would
/// never choose once their error bounds are known.
fn candidates(
    model: &CpuModel,
    adapter: &VertexDataAdapter<'_>,
    locks: &[SimplifyVertex],
    full: Lod,
    queue: &Queue,
) -> Vec<Lod> {
    let total = model.triangle_count();
    let mut lods = vec![full];
    let mut previous = total;
    while lods.len() <= MAX_CANDIDATES && previous > MIN_TRIANGLES {
        let fraction = (previous as f64 * LEVEL_STEP).floor() / total as f64;
        let level = simplify_level(model, adapter, locks, fraction);
        let count = level.triangle_count();
        if count == 0 || count as f64 > MIN_PROGRESS * previous as f64 {
            break;
        }
        previous = count;
        queue.push(level.indices.clone());
        lods.push(level);
    }
    lods
}

/// The candidate levels' index buffers as the simplifier makes them, for
/// the threads that bound their errors.
#[derive(Default)]
struct Queue {
    state: std::sync::Mutex<QueueState>,
    ready: std::sync::Condvar,
}

#[derive(Default)]
struct QueueState {
    /// Levels 1, 2, … so far.
    levels: Vec<Vec<u32>>,
    /// How many of them a thread has taken.
    taken: usize,
    /// The simplifier is done: no level will be added.
    finished: bool,
}

impl Queue {
    fn push(&self, indices: Vec<u32>) {
        if let Ok(mut s) = self.state.lock() {
            s.levels.push(indices);
        }
        self.ready.notify_one();
    }

    fn finish(&self) {
        if let Ok(mut s) = self.state.lock() {
            s.finished = true;
        }
        self.ready.notify_all();
    }

    /// The next level nobody has taken (its number and indices), waiting
    /// while the simplifier may still make one; `None` once all are taken.
    fn take(&self) -> Option<(usize, Vec<u32>)> {
        let mut s = self.state.lock().ok()?;
        loop {
            if let Some(indices) = s.levels.get(s.taken).cloned() {
                s.taken += 1;
                return Some((s.taken, indices));
            }
            if s.finished {
                return None;
            }
            s = self.ready.wait(s).ok()?;
        }
    }
}

/// Marks the queue finished when dropped.
struct FinishOnDrop<'a>(&'a Queue);

impl Drop for FinishOnDrop<'_> {
    fn drop(&mut self) {
        self.0.finish();
    }
}

/// Error bounds of the levels this thread takes from `queue`: (level, bound).
fn bound_levels(queue: &Queue, positions: &[DVec3], full: &Surface) -> Vec<(usize, f32)> {
    let mut out = Vec::new();
    while let Some((k, indices)) = queue.take() {
        let surface = Surface::new(positions, &indices);
        out.push((k, hausdorff_bound(full, &surface) as f32));
    }
    out
}

/// From levels ordered finest first (level 0 the full mesh), the ones
/// [`pick`] can use well: each coarser level has fewer triangles (by
/// [`MIN_PROGRESS`] at least) and a larger error than the one before — a
/// level with more triangles than a coarser one of no larger error is never
/// the best choice — and at most [`MAX_LEVELS`] of them.
fn keep_useful(lods: Vec<Lod>) -> Vec<Lod> {
    // Walking from the coarsest, keep the levels whose error is below every
    // coarser one's (the Pareto front of triangles against error).
    let mut front: Vec<Lod> = Vec::new();
    for level in lods.into_iter().rev() {
        if front
            .last()
            .is_none_or(|coarser| level.error < coarser.error)
        {
            front.push(level);
        }
    }
    front.reverse();
    let mut kept: Vec<Lod> = Vec::new();
    for level in front {
        let enough = kept.last().is_none_or(|finer| {
            level.triangle_count() as f64 <= MIN_PROGRESS * finer.triangle_count() as f64
        });
        if enough && kept.len() < MAX_LEVELS {
            kept.push(level);
        }
    }
    kept
}

/// Every draw range simplified to `fraction` of its triangles.
fn simplify_level(
    model: &CpuModel,
    adapter: &VertexDataAdapter<'_>,
    locks: &[SimplifyVertex],
    fraction: f64,
) -> Lod {
    let mut indices = Vec::new();
    let mut draws = Vec::new();
    let options =
        SimplifyOptions::ErrorAbsolute | SimplifyOptions::Permissive | SimplifyOptions::Prune;
    for draw in &model.draws {
        let source = &model.indices[draw.indices.start as usize..draw.indices.end as usize];
        let triangles = source.len() / 3;
        let target = ((triangles as f64 * fraction).round() as usize).clamp(1, triangles);
        let out =
            meshopt::simplify_with_locks(source, adapter, locks, target * 3, 1.0, options, None);
        if out.is_empty() {
            continue;
        }
        let start = indices.len() as u32;
        indices.extend_from_slice(&out);
        draws.push(DrawRange {
            indices: start..indices.len() as u32,
            ..draw.clone()
        });
    }
    Lod {
        indices,
        draws,
        error: f32::INFINITY,
    }
}

/// Per-vertex simplifier flags. A position used by more than one draw range
/// is locked, so the ranges, simplified apart, still meet without cracks. A
/// position where the colour, material or texture coordinates change is
/// protected: [`SimplifyOptions::Permissive`] lets the simplifier collapse
/// across the other discontinuities (split normals of flat-shaded parts),
/// but colour boundaries stay where they are.
fn vertex_flags(model: &CpuModel) -> Vec<SimplifyVertex> {
    #[derive(Default)]
    struct Seen {
        range: Option<usize>,
        shared: bool,
        look: Option<[u32; 10]>,
        discontinuous: bool,
    }
    let mut seen: BTreeMap<[u32; 3], Seen> = BTreeMap::new();
    for (r, draw) in model.draws.iter().enumerate() {
        let textured = draw.texture.is_some();
        for &i in &model.indices[draw.indices.start as usize..draw.indices.end as usize] {
            let v = &model.vertices[i as usize];
            let uv = if textured { v.uv } else { [0.0; 2] };
            let mut look = [0u32; 10];
            for (o, c) in look
                .iter_mut()
                .zip(v.color.iter().chain(&v.material).chain(&uv))
            {
                *o = c.to_bits();
            }
            let s = seen.entry(v.position.map(f32::to_bits)).or_default();
            s.shared |= s.range.is_some_and(|x| x != r);
            s.range = Some(r);
            s.discontinuous |= s.look.is_some_and(|x| x != look);
            s.look = Some(look);
        }
    }
    model
        .vertices
        .iter()
        .map(|v| match seen.get(&v.position.map(f32::to_bits)) {
            Some(s) if s.shared => SimplifyVertex::Lock,
            Some(s) if s.discontinuous => SimplifyVertex::Protect,
            _ => SimplifyVertex::None,
        })
        .collect()
}

fn validate(model: &CpuModel) -> Result<(), LodError> {
    let name = || model.name.clone();
    if !model.indices.len().is_multiple_of(3) {
        return Err(LodError::NotTriangles {
            model: name(),
            len: model.indices.len(),
        });
    }
    if let Some(&index) = model
        .indices
        .iter()
        .find(|&&i| i as usize >= model.vertices.len())
    {
        return Err(LodError::IndexOutOfRange {
            model: name(),
            index,
            vertices: model.vertices.len(),
        });
    }
    for d in &model.draws {
        let (start, end) = (d.indices.start, d.indices.end);
        if start > end
            || end as usize > model.indices.len()
            || !start.is_multiple_of(3)
            || !end.is_multiple_of(3)
        {
            return Err(LodError::BadDrawRange {
                model: name(),
                start,
                end,
                len: model.indices.len(),
            });
        }
    }
    if let Some(vertex) = model
        .vertices
        .iter()
        .position(|v| !v.position.iter().all(|c| c.is_finite()))
    {
        return Err(LodError::NotFinite {
            model: name(),
            vertex,
        });
    }
    Ok(())
}

/// A triangle soup with a bounding volume hierarchy for nearest-point queries.
struct Surface {
    /// Triangles of non-zero area, in BVH leaf order.
    triangles: Vec<[DVec3; 3]>,
    nodes: Vec<Node>,
    /// The same triangles in index order, with their sorted vertex indices.
    source: Vec<[DVec3; 3]>,
    keys: Vec<[u32; 3]>,
    /// `keys`, sorted, for lookups.
    keys_sorted: Vec<[u32; 3]>,
    /// Every position the triangles use, once.
    corners: Vec<DVec3>,
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
    fn new(positions: &[DVec3], indices: &[u32]) -> Self {
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
    fn nearest(&self, p: DVec3, enough: f64, hint: usize) -> (f64, usize) {
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
fn hausdorff_bound(x: &Surface, y: &Surface) -> f64 {
    let there = one_sided_worst(x, y, 0.0);
    sampled_bound(one_sided_worst(y, x, there))
}

/// The bound may exceed the largest sampled distance by this fraction of it…
const RELATIVE_SLACK: f64 = 0.25;
/// …plus this many model units.
const ABSOLUTE_SLACK: f64 = 1.0 / 128.0;
/// Bisections of one source triangle, at most (a guard against slivers).
const MAX_DEPTH: u32 = 48;

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
fn one_sided_worst(from: &Surface, to: &Surface, start: f64) -> f64 {
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
fn bisect_longest_edge([a, b, c]: [DVec3; 3]) -> [[DVec3; 3]; 2] {
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

/// The Hausdorff bound that a largest sampled distance `w` stands for.
fn sampled_bound(w: f64) -> f64 {
    (1.0 + RELATIVE_SLACK) * w + ABSOLUTE_SLACK
}

/// The coarsest level whose error, scaled to pixels, is at most `max_error_px`:
/// the largest `k` with `lods[k].error · size_m · pixels_per_metre ≤ max_error_px`
/// (0 when none is, or for non-finite or negative input).
///
/// `pixels_per_metre` is the camera's focal length in pixels over the depth;
/// pass the depth of the drone's nearest point (centre distance minus
/// `size_m·√3/2`) so the bound holds over the whole drone.
pub fn pick(lods: &[Lod], size_m: f64, pixels_per_metre: f64, max_error_px: f64) -> usize {
    let px_per_unit = size_m * pixels_per_metre;
    if !(px_per_unit.is_finite() && px_per_unit >= 0.0 && max_error_px.is_finite()) {
        return 0;
    }
    lods.iter()
        .rposition(|l| f64::from(l.error) * px_per_unit <= max_error_px)
        .unwrap_or(0)
}

#[cfg(test)]
mod tests;
