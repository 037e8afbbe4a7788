//! A model's levels of detail with their error bounds, each bound found the
//! first time a pick needs it ([`LodChain`]).
//!
//! A level's bound costs far more than the level (the 9 434-triangle
//! Crazyflie: 75 ms of CPU for its fifteen levels, about 230 ms for their
//! bounds, most of it in the five finest), and a drone only ever asks for
//! the bounds of the levels coarser than the one it is drawn with. So a
//! pick walks from the coarsest level towards the finest and bounds each
//! level it passes, once for the process; a swarm of small, distant drones
//! never pays for the fine levels. The bound of a level does not depend on
//! when or on which thread it is found, so the level a drone is drawn with
//! does not either.

use std::panic::AssertUnwindSafe;
use std::sync::OnceLock;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

use glam::DVec3;

use super::Lod;
use super::hausdorff::{Surface, level_bound};

/// What is told of bounds found since the last time: the cache's write.
pub type OnBound = Box<dyn Fn(&LodChain) + Send + Sync>;

/// The levels of detail of one model, finest first (level 0 is its own
/// mesh), and the bound of each level's error, found when first needed.
pub struct LodChain {
    levels: Vec<Lod>,
    /// Each level's upper bound of the Hausdorff distance between its
    /// surface and the full mesh's, in model units (0 for level 0).
    errors: Vec<OnceLock<f32>>,
    /// The model's vertex positions, for the bounds.
    positions: Vec<DVec3>,
    /// The full mesh's surface, made for the first bound.
    full: OnceLock<Surface>,
    /// A bound was found since [`LodChain::on_bound`]'s hook last ran.
    fresh: AtomicBool,
    on_bound: OnceLock<OnBound>,
}

impl std::fmt::Debug for LodChain {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LodChain")
            .field("levels", &self.levels.len())
            .field("errors", &self.known_errors())
            .finish()
    }
}

impl LodChain {
    /// `levels` (level 0 the model's own mesh) over `positions`, with the
    /// bounds already known (`errors[k]`; a missing or `None` one is found
    /// when needed; level 0's is 0 whatever is given).
    pub(crate) fn new(levels: Vec<Lod>, errors: &[Option<f32>], positions: Vec<DVec3>) -> Self {
        let errors = (0..levels.len())
            .map(|k| {
                let known = if k == 0 {
                    Some(0.0)
                } else {
                    errors.get(k).copied().flatten()
                };
                known.map_or_else(OnceLock::new, OnceLock::from)
            })
            .collect();
        Self {
            levels,
            errors,
            positions,
            full: OnceLock::new(),
            fresh: AtomicBool::new(false),
            on_bound: OnceLock::new(),
        }
    }

    /// The chain with the full mesh's surface already made (over the same positions).
    pub(super) fn with_full(self, full: Surface) -> Self {
        Self {
            full: OnceLock::from(full),
            ..self
        }
    }

    /// The levels, finest first.
    pub fn levels(&self) -> &[Lod] {
        &self.levels
    }

    /// Level `k`'s error bound in model units (fractions of the model's
    /// largest span), found now if it was not yet: times `size_m ·
    /// pixels_per_metre` it bounds the silhouette error in pixels. A bound
    /// that fails to compute is infinite (the level is never picked).
    pub fn error(&self, k: usize) -> f32 {
        let Some(cell) = self.errors.get(k) else {
            return f32::INFINITY;
        };
        *cell.get_or_init(|| {
            self.fresh.store(true, Ordering::Relaxed);
            std::panic::catch_unwind(AssertUnwindSafe(|| self.compute(k))).unwrap_or(f32::INFINITY)
        })
    }

    fn compute(&self, k: usize) -> f32 {
        let full =
            (self.full).get_or_init(|| Surface::new(&self.positions, &self.levels[0].indices));
        level_bound(full, &self.positions, &self.levels[k].indices)
    }

    /// The bounds found so far (`None`: not yet).
    pub fn known_errors(&self) -> Vec<Option<f32>> {
        self.errors.iter().map(|e| e.get().copied()).collect()
    }

    /// Every level's bound, found on every core.
    pub fn bound_all(&self) {
        let next = AtomicUsize::new(1);
        let work = || {
            loop {
                let k = next.fetch_add(1, Ordering::Relaxed);
                if k >= self.levels.len() {
                    break;
                }
                self.error(k);
            }
        };
        let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
        std::thread::scope(|s| {
            for _ in 1..threads.min(self.levels.len()) {
                // A thread the system refuses is one fewer.
                let _ = std::thread::Builder::new().spawn_scoped(s, work);
            }
            work();
        });
        self.tell();
    }

    /// The coarsest level whose error, times `px_per_unit` (the drone's
    /// size in pixels at the depth of its nearest point), is at most
    /// `max_error_px` (0 when none is, or for non-finite or negative
    /// input). Walks from the coarsest level and bounds the levels it
    /// passes: a level finer than a coarser one of no larger error is never
    /// chosen, whatever the order bounds are found in.
    pub fn pick(&self, px_per_unit: f64, max_error_px: f64) -> usize {
        if !(px_per_unit.is_finite() && px_per_unit >= 0.0 && max_error_px.is_finite()) {
            return 0;
        }
        let level = (1..self.levels.len())
            .rev()
            .find(|&k| f64::from(self.error(k)) * px_per_unit <= max_error_px)
            .unwrap_or(0);
        self.tell();
        level
    }

    /// Run `hook` after a pick (or [`LodChain::bound_all`]) that found new
    /// bounds (once per such call; the first hook set is kept).
    pub fn on_bound(&self, hook: OnBound) {
        let _ = self.on_bound.set(hook);
    }

    fn tell(&self) {
        // A load first: the makers' picks of every drone share the flag's
        // cache line, which a swap on each would write.
        if self.fresh.load(Ordering::Relaxed)
            && self.fresh.swap(false, Ordering::Relaxed)
            && let Some(hook) = self.on_bound.get()
        {
            hook(self);
        }
    }
}
