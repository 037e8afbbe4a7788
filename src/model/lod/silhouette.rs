//! The silhouette metric the tests of [`super`] hold the error bounds to:
//! two index sets of one model rasterised orthographically at a sub-pixel
//! grid and compared by the largest distance between their coverages.

use glam::{DMat3, DVec2, DVec3};

use crate::model::CpuModel;

/// The sub-pixel grid in which two silhouettes of one model are compared:
/// an orthographic view, `samples_per_px`² samples per pixel, covering the
/// box of the model's projected vertices plus a pixel (every LOD of the
/// model fits, since LODs use the model's vertices).
#[derive(Clone, Copy, Debug)]
pub struct SilhouetteFrame {
    /// Rotation from model to view space (x right, y down, z away).
    pub view_from_model: DMat3,
    /// Pixels per model unit (`size_m · pixels_per_metre`).
    pub px_per_unit: f64,
    pub samples_per_px: usize,
    origin_px: DVec2,
    /// Samples along x and y.
    size: [usize; 2],
}

/// A projected triangle in sample units (sample centres at integers), with its box.
struct Projected {
    corners: [DVec2; 3],
    lo: DVec2,
    hi: DVec2,
}

impl SilhouetteFrame {
    pub fn new(
        model: &CpuModel,
        view_from_model: DMat3,
        px_per_unit: f64,
        samples_per_px: usize,
    ) -> Self {
        let (mut lo, mut hi) = (DVec2::INFINITY, DVec2::NEG_INFINITY);
        for v in &model.vertices {
            let q =
                (view_from_model * DVec3::from(v.position.map(f64::from)) * px_per_unit).truncate();
            lo = lo.min(q);
            hi = hi.max(q);
        }
        let origin_px = lo.floor() - 1.0;
        let extent = (hi - origin_px).ceil() + 1.0;
        let size = [extent.x, extent.y].map(|px| {
            if px.is_finite() && px > 0.0 {
                px as usize * samples_per_px
            } else {
                0
            }
        });
        Self {
            view_from_model,
            px_per_unit,
            samples_per_px,
            origin_px,
            size,
        }
    }

    /// The triangles `indices` of `model`, projected; edge-on ones (zero area) cover nothing and are left out.
    fn project(&self, model: &CpuModel, indices: &[u32]) -> Vec<Projected> {
        let ss = self.samples_per_px as f64;
        let at = |i: u32| {
            let p = model
                .vertices
                .get(i as usize)
                .map_or(DVec3::ZERO, |v| DVec3::from(v.position.map(f64::from)));
            let q = (self.view_from_model * p * self.px_per_unit).truncate();
            (q - self.origin_px) * ss - 0.5
        };
        indices
            .chunks_exact(3)
            .filter_map(|t| {
                let corners = [at(t[0]), at(t[1]), at(t[2])];
                let [a, b, c] = corners;
                let area = (b - a).perp_dot(c - a);
                (area != 0.0 && area.is_finite()).then(|| Projected {
                    corners,
                    lo: a.min(b).min(c),
                    hi: a.max(b).max(c),
                })
            })
            .collect()
    }

    /// Which samples the triangles cover (either winding; a sample on an edge counts).
    fn coverage(&self, triangles: &[Projected]) -> Vec<bool> {
        let [width, height] = self.size;
        let mut covered = vec![false; width * height];
        for t in triangles {
            let x0 = t.lo.x.ceil().max(0.0) as usize;
            let y0 = t.lo.y.ceil().max(0.0) as usize;
            let x1 = (t.hi.x.floor() + 1.0).clamp(0.0, width as f64) as usize;
            let y1 = (t.hi.y.floor() + 1.0).clamp(0.0, height as f64) as usize;
            for y in y0..y1 {
                for x in x0..x1 {
                    if inside(&t.corners, DVec2::new(x as f64, y as f64)) {
                        covered[y * width + x] = true;
                    }
                }
            }
        }
        covered
    }

    /// Silhouette error in pixels between two index sets of `model`: the
    /// largest distance from a sample covered by one silhouette but not the
    /// other to the other silhouette (the exact union of its projected
    /// triangles). Infinite when exactly one silhouette is empty.
    pub fn error_px(&self, model: &CpuModel, a: &[u32], b: &[u32]) -> f64 {
        let (ta, tb) = (self.project(model, a), self.project(model, b));
        let (ca, cb) = (self.coverage(&ta), self.coverage(&tb));
        let d_ab = self.farthest(&ca, &cb, &tb);
        let d_ba = self.farthest(&cb, &ca, &ta);
        d_ab.max(d_ba) / self.samples_per_px as f64
    }

    /// Largest distance (samples) from a sample in `from` but not in `to` to the triangles of `to`.
    fn farthest(&self, from: &[bool], to: &[bool], to_triangles: &[Projected]) -> f64 {
        let width = self.size[0].max(1);
        let mut worst = 0.0f64;
        for (k, _) in from
            .iter()
            .zip(to)
            .enumerate()
            .filter(|(_, (f, t))| **f && !**t)
        {
            let p = DVec2::new((k % width) as f64, (k / width) as f64);
            let mut best_sq = f64::INFINITY;
            for t in to_triangles {
                let outside = (t.lo - p).max(p - t.hi).max(DVec2::ZERO);
                if outside.length_squared() >= best_sq {
                    continue;
                }
                best_sq = best_sq.min(distance_sq_to_triangle(&t.corners, p));
            }
            worst = worst.max(best_sq.sqrt());
        }
        worst
    }
}

/// Whether `p` lies in the triangle (either winding, edges included).
fn inside(t: &[DVec2; 3], p: DVec2) -> bool {
    let [a, b, c] = *t;
    let e = [
        (b - a).perp_dot(p - a),
        (c - b).perp_dot(p - b),
        (a - c).perp_dot(p - c),
    ];
    e.iter().all(|&x| x >= 0.0) || e.iter().all(|&x| x <= 0.0)
}

/// Squared distance from `p` to the triangle `t` (0 inside).
fn distance_sq_to_triangle(t: &[DVec2; 3], p: DVec2) -> f64 {
    if inside(t, p) {
        return 0.0;
    }
    let segment = |a: DVec2, b: DVec2| {
        let ab = b - a;
        let s = ((p - a).dot(ab) / ab.length_squared().max(f64::MIN_POSITIVE)).clamp(0.0, 1.0);
        (a + ab * s - p).length_squared()
    };
    let [a, b, c] = *t;
    segment(a, b).min(segment(b, c)).min(segment(c, a))
}
