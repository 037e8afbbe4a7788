//! Level of detail: a chain of simplified index buffers per model, and the
//! rule that picks one for a drone from its projected size.
//!
//! [`build_lods`] runs once per model at load. Level 0 is the model's own
//! mesh; each further level asks meshoptimizer (the `meshopt` crate) for 70 %
//! of the triangles of the level before, simplifying every draw range apart
//! so each triangle keeps its texture. Levels are index buffers into the
//! model's one vertex buffer, so the GPU keeps a single vertex buffer per
//! model and a level is an index range plus its draw ranges. Each level's
//! error bound is found the first time a pick needs it ([`LodChain`]).
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
//! thin parts). So [`LodChain::error`] is not meshoptimizer's number but an upper
//! bound of the symmetric Hausdorff distance between the level's surface and
//! the full mesh's, computed by sampling (see `hausdorff::one_sided_worst`). An
//! orthographic projection moves no two points further apart than they are,
//! so the silhouettes of the two surfaces are at most `error · size_m ·
//! pixels_per_metre` pixels apart (Hausdorff distance, either direction);
//! [`LodChain::pick`] keeps that within the budget. The tests measure it on rasterised
//! silhouettes ([`SilhouetteFrame::error_px`]).
//!
//! Here: the levels; `chain`: their bounds and the pick; `hausdorff`: the
//! error bound and the surface BVH it queries; `silhouette`: the tests'
//! silhouette metric.

use std::collections::BTreeMap;
use std::mem::size_of;

use glam::DVec3;
use meshopt::{SimplifyOptions, SimplifyVertex, VertexDataAdapter};

use crate::model::{CpuModel, DrawRange, Vertex};

mod chain;
mod hausdorff;
mod silhouette;

pub use chain::{LodChain, OnBound};
use hausdorff::{Surface, level_bound};
pub use silhouette::SilhouetteFrame;

/// One level of detail: an index buffer into the model's own vertex buffer
/// (its error bound is its [`LodChain`]'s).
#[derive(Clone, Debug, PartialEq)]
pub struct Lod {
    /// Triangle list into `CpuModel::vertices`, grouped like `draws`.
    pub indices: Vec<u32>,
    /// The index ranges of `indices` and the texture each is drawn with.
    pub draws: Vec<DrawRange>,
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
/// At most this many simplified levels are made.
pub(crate) const MAX_CANDIDATES: usize = 24;
/// Each candidate level asks meshoptimizer for this fraction of the
/// triangles of the one before. Halving left gaps where one step jumps from
/// a few hundredths of the span to a fifth (quad_x: 378 triangles at 0.024,
/// then 188 at 0.188, as its rotor discs collapse), so drones that could use
/// 256 triangles drew 378; finer steps cost more bounds to compute at load.
const LEVEL_STEP: f64 = 0.7;

/// The recipe of [`build_lods`], bumped whenever what it builds changes,
/// so that [`super::lod_cache`] never returns levels of an older recipe.
const RECIPE: u32 = 2;

/// Everything besides the model that decides the levels (for the cache's key).
pub(crate) fn settings() -> String {
    format!(
        "recipe {RECIPE}; min {MIN_TRIANGLES}, progress {MIN_PROGRESS}, \
         candidates {MAX_CANDIDATES}, step {LEVEL_STEP}; meshopt 0.7, absolute+permissive+prune"
    )
}

/// Build the LOD chain of a model: level 0 is the model's own mesh, each
/// further level has at most [`MIN_PROGRESS`] of the triangles of the one
/// before. The bounds of the levels of at most [`EAGER_SHARE`] of the
/// model's triangles are found on a second thread as the simplifier makes
/// them; the finer levels' when a pick first needs them.
pub fn build_lods(model: &CpuModel) -> Result<LodChain, LodError> {
    validate(model)?;
    let adapter = VertexDataAdapter::new(
        bytemuck::cast_slice(&model.vertices),
        size_of::<Vertex>(),
        0,
    )
    .map_err(|e| LodError::Meshopt {
        model: model.name.clone(),
        reason: e.to_string(),
    })?;
    let positions = positions(model);
    let eager = (model.triangle_count() as f64 * EAGER_SHARE) as usize;
    let (levels, bounded) = std::thread::scope(|s| {
        let (send, take) = std::sync::mpsc::channel::<(usize, Vec<u32>)>();
        // The full mesh's surface first, then each level as it comes. A
        // thread the system refuses (`ulimit -u`) only leaves every bound
        // to the picks.
        let worker = std::thread::Builder::new()
            .spawn_scoped(s, || {
                let full = Surface::new(&positions, &model.indices);
                let errors: Vec<(usize, f32)> = (take.into_iter())
                    .map(|(k, indices)| (k, level_bound(&full, &positions, &indices)))
                    .collect();
                (full, errors)
            })
            .ok();
        let levels = candidates(model, &adapter, &vertex_flags(model), |k, level| {
            if worker.is_some() && level.triangle_count() <= eager {
                let _ = send.send((k, level.indices.clone()));
            }
        });
        drop(send);
        (levels, worker.and_then(|w| w.join().ok()))
    });
    let Some((full, found)) = bounded else {
        return Ok(LodChain::new(levels, &[], positions));
    };
    let mut errors = vec![None; levels.len()];
    for (k, error) in found {
        errors[k] = Some(error);
    }
    Ok(LodChain::new(levels, &errors, positions).with_full(full))
}

/// The levels of at most this share of the model's triangles are bounded as
/// they are made: every drone small enough for the coarse levels needs their
/// bounds, and they are cheap (the 9 434-triangle Crazyflie: 43 of the 230 ms
/// of CPU all its bounds take).
const EAGER_SHARE: f64 = 0.125;

/// Whether `error` can be a level's bound for a model (normalised to a unit
/// span): what a cache file's bound is checked against.
pub(crate) fn plausible_error(error: f32) -> bool {
    hausdorff::plausible_bound(error)
}

/// The model's vertex positions, in double precision (what the bounds measure).
pub(crate) fn positions(model: &CpuModel) -> Vec<DVec3> {
    (model.vertices.iter())
        .map(|v| DVec3::from(v.position.map(f64::from)))
        .collect()
}

/// The model's own mesh, then levels with [`LEVEL_STEP`] of the triangles
/// of the one before, down to a few dozen, each handed to `made` (with its
/// number) as it is made. A level some coarser one matches in error is
/// kept: [`LodChain::pick`] never chooses it.
fn candidates(
    model: &CpuModel,
    adapter: &VertexDataAdapter<'_>,
    locks: &[SimplifyVertex],
    mut made: impl FnMut(usize, &Lod),
) -> Vec<Lod> {
    let total = model.triangle_count();
    let mut lods = vec![Lod {
        indices: model.indices.clone(),
        draws: model.draws.clone(),
    }];
    let mut previous = total;
    while lods.len() <= MAX_CANDIDATES && previous > MIN_TRIANGLES {
        let fraction = (previous as f64 * LEVEL_STEP).floor() / total as f64;
        let level = simplify_level(model, adapter, locks, fraction);
        let count = level.triangle_count();
        if count == 0 || count as f64 > MIN_PROGRESS * previous as f64 {
            break;
        }
        previous = count;
        made(lods.len(), &level);
        lods.push(level);
    }
    lods
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
    Lod { indices, draws }
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

#[cfg(test)]
mod tests;
