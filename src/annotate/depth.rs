//! The depth map of `output.masks.depth`: at every pixel of the instance
//! image, the camera-frame depth z (metres along the optical axis) of the
//! drone the pixel shows, from that drone's full-detail mesh rasterised on
//! the CPU at the pixel centres (the nearest surface; triangles reaching
//! behind the near plane are skipped). A pixel the drone shows only through
//! an MSAA sample off its centre takes the nearest depth of its covered
//! 8-neighbours, else the depth of the drone's centre. Only the drones'
//! pixels are visited: the cost follows their screen area, not the frame's.
//!
//! The work per drone: its mesh's distinct vertex positions transformed
//! and projected once ([`DepthMesh`]: the renderer's vertices repeat a
//! position for each normal and texture coordinate), each vertex's pixel
//! bounds worked out with it, so that a triangle holding no pixel centre of
//! the drone's tile is told by integer comparisons alone, and the
//! remaining triangles walked row by row within a pixel of their edges.
//!
//! Under a rolling shutter ([`depth_m_of_rows`]) each row of a drone's tile
//! is rasterised with the camera and the drone's pose of its own row's
//! time: the depth at the row time.

use glam::{DVec2, DVec3};

use super::masks::FrameMasks;
use crate::model::CpuModel;
use crate::scene::camera::Camera;
use crate::scene::{DronePose, FrameScene};
use row::{Row, Setup};

mod row;

/// Under a rolling shutter: the camera and drone d's pose at image row y's
/// time (`None`: the drone is not known then).
pub type RowPose<'a> = dyn Fn(usize, u32) -> Option<(Camera, DronePose)> + 'a;

/// A model's triangles over its distinct vertex positions, for the depth
/// raster: the same triangles, corners in the same order, as the model's
/// index list (an index past its vertices stays past these positions), so
/// the raster gives the bits the model's own vertices give. quad_x: 1 848
/// vertices at 424 positions. Each triangle keeps whether its material is
/// double-sided: the raster culls the back faces of the others, as the
/// renderer does (glTF; src/render/mesh.rs).
#[derive(Clone, Debug, Default)]
pub struct DepthMesh {
    positions: Vec<DVec3>,
    triangles: Vec<[u32; 3]>,
    double_sided: Vec<bool>,
}

impl DepthMesh {
    pub fn new(model: &CpuModel) -> Self {
        let mut at = std::collections::HashMap::new();
        let mut positions = Vec::new();
        let remap: Vec<u32> = (model.vertices.iter())
            .map(|v| {
                *at.entry(v.position.map(f32::to_bits)).or_insert_with(|| {
                    positions.push(DVec3::from(v.position.map(f64::from)));
                    (positions.len() - 1) as u32
                })
            })
            .collect();
        let corner = |i: u32| remap.get(i as usize).copied().unwrap_or(u32::MAX);
        let triangles = (model.indices.chunks_exact(3))
            .map(|t| [corner(t[0]), corner(t[1]), corner(t[2])])
            .collect();
        // A triangle is double-sided when the draw range holding its first
        // index is (none holds it: single-sided, the glTF default).
        let double_sided = (0..model.indices.len() / 3)
            .map(|t| {
                let first = (3 * t) as u32;
                (model.draws.iter()).any(|d| d.double_sided && d.indices.contains(&first))
            })
            .collect();
        Self {
            positions,
            triangles,
            double_sided,
        }
    }
}

/// Depth (metres) of every pixel of `masks.instance`, in its order.
pub fn depth_m(scene: &FrameScene, models: &[CpuModel], masks: &FrameMasks) -> Vec<f64> {
    let meshes: Vec<DepthMesh> = models.iter().map(DepthMesh::new).collect();
    depth_m_of_meshes(scene, &meshes, masks)
}

/// [`depth_m`] with each model's [`DepthMesh`] made beforehand (the
/// pipeline's assets keep them).
pub fn depth_m_of_meshes(scene: &FrameScene, meshes: &[DepthMesh], masks: &FrameMasks) -> Vec<f64> {
    depth_m_of_rows(scene, meshes, masks, None)
}

/// [`depth_m_of_meshes`] with each image row's camera and drone poses from
/// `rows` (a rolling shutter's row times; `None`: the frame's own).
pub fn depth_m_of_rows(
    scene: &FrameScene,
    meshes: &[DepthMesh],
    masks: &FrameMasks,
    rows: Option<&RowPose>,
) -> Vec<f64> {
    let width = masks.width.max(1);
    let cam = &scene.camera;
    let n = scene.drones.len();
    // The instance image's places grouped by drone (a counting sort; ascending within a drone).
    let mut starts = vec![0usize; n + 1];
    for &(_, d) in &masks.instance {
        if (d as usize) < n {
            starts[d as usize + 1] += 1;
        }
    }
    for d in 0..n {
        starts[d + 1] += starts[d];
    }
    let mut order = vec![0usize; starts[n]];
    let mut next = starts.clone();
    for (k, &(_, d)) in masks.instance.iter().enumerate() {
        if (d as usize) < n {
            order[next[d as usize]] = k;
            next[d as usize] += 1;
        }
    }
    let mut out = vec![0.0; masks.instance.len()];
    // One set of buffers for every drone of the frame.
    let mut points = Vec::new();
    let mut z = Vec::new();
    let xy = |k: usize| {
        let i = masks.instance[k].0;
        (i % width, i / width)
    };
    for (d, drone) in scene.drones.iter().enumerate() {
        let ks = &order[starts[d]..starts[d + 1]];
        if ks.is_empty() {
            continue;
        }
        let centre_z = cam.camera_from_world_point(drone.position).z;
        let Some(mesh) = meshes.get(drone.model) else {
            for &k in ks {
                out[k] = centre_z;
            }
            continue;
        };
        let (mut x0, mut y0, mut x1, mut y1) = (u32::MAX, u32::MAX, 0, 0);
        for &k in ks {
            let (x, y) = xy(k);
            (x0, y0) = (x0.min(x), y0.min(y));
            (x1, y1) = (x1.max(x + 1), y1.max(y + 1));
        }
        z.clear();
        z.resize(((x1 - x0) as usize) * ((y1 - y0) as usize), f64::INFINITY);
        let mut tile = Tile {
            x0,
            y0,
            w: x1 - x0,
            h: y1 - y0,
            z,
        };
        let Some(rows) = rows else {
            tile.raster((cam, drone), mesh, &mut points, (y0, y1));
            for &k in ks {
                let (x, y) = xy(k);
                out[k] = tile.at(x, y).unwrap_or(centre_z);
            }
            z = tile.z;
            continue;
        };
        let mut row_centre = vec![centre_z; (y1 - y0) as usize];
        for y in y0..y1 {
            if let Some((cam, pose)) = rows(d, y) {
                tile.raster((&cam, &pose), mesh, &mut points, (y, y + 1));
                row_centre[(y - y0) as usize] = cam.camera_from_world_point(pose.position).z;
            }
        }
        for &k in ks {
            let (x, y) = xy(k);
            out[k] = (tile.at(x, y)).unwrap_or(row_centre[(y - y0) as usize]);
        }
        z = tile.z;
    }
    out
}

/// `x.ceil()` and `x.floor()` without the call into libm that a baseline
/// x86-64 build makes of them (no SSE4.1 `roundsd`): the same value, but
/// +0 where they give -0; every use here turns the result into an integer.
fn ceil(x: f64) -> f64 {
    if x.abs() < 4_503_599_627_370_496.0 {
        let t = x as i64 as f64;
        if t < x { t + 1.0 } else { t }
    } else {
        x.ceil()
    }
}

fn floor(x: f64) -> f64 {
    if x.abs() < 4_503_599_627_370_496.0 {
        let t = x as i64 as f64;
        if t > x { t - 1.0 } else { t }
    } else {
        x.floor()
    }
}

/// A vertex on screen: its pixel position and camera-frame z, and the
/// pixels whose centres lie at or right of / below it (`ceil(x - 0.5)`)
/// and the end of those at or left of / above it (`floor(x - 0.5) + 1`);
/// `None` behind the near plane.
#[derive(Clone, Copy, Debug)]
struct Point {
    pixel: DVec2,
    z: f64,
    first: (i32, i32),
    end: (i32, i32),
}

impl Point {
    fn new(pixel: DVec2, z: f64) -> Self {
        // `as i32` saturates: far off-screen stays off the tile.
        let first = |v: f64| ceil(v - 0.5) as i32;
        let end = |v: f64| (floor(v - 0.5) + 1.0) as i32;
        Self {
            pixel,
            z,
            first: (first(pixel.x), first(pixel.y)),
            end: (end(pixel.x), end(pixel.y)),
        }
    }
}

/// The columns of `cols` whose centres on the line y = `cy` may lie in the
/// triangle: those within a pixel of where the line crosses it. The exact
/// barycentric test still decides each one, so the depths are those of the
/// whole box's walk; the span only skips centres a pixel or more outside
/// (the test's rounding is far below that). The whole range when the line
/// seems to miss (rounding at a vertex).
fn row_span(v: [DVec2; 3], cy: f64, cols: (u32, u32)) -> (u32, u32) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for (p, q) in [(v[0], v[1]), (v[1], v[2]), (v[2], v[0])] {
        if cy < p.y.min(q.y) || cy > p.y.max(q.y) {
            continue;
        }
        let (x0, x1) = if p.y == q.y {
            (p.x.min(q.x), p.x.max(q.x))
        } else {
            let x = p.x + (cy - p.y) * (q.x - p.x) / (q.y - p.y);
            (x, x)
        };
        lo = lo.min(x0);
        hi = hi.max(x1);
    }
    if lo > hi {
        return cols;
    }
    // Centre px + 0.5 within [lo - 1, hi + 1].
    let first = ceil(lo - 1.5).max(f64::from(cols.0)).min(f64::from(cols.1));
    let end = (floor(hi + 0.5) + 1.0).min(f64::from(cols.1)).max(first);
    (first as u32, end as u32)
}

/// The pixels of `rect` (x0, y0, x1, y1; exclusive ends) whose centres the
/// triangle's bounding box holds, `None` when none: the box's corners
/// rounded, corner by corner (ceil and floor keep the order of min and max).
fn pixel_box(v: [Point; 3], rect: (i32, i32, i32, i32)) -> Option<(u32, u32, u32, u32)> {
    let [a, b, c] = v;
    let px0 = a.first.0.min(b.first.0).min(c.first.0).max(rect.0);
    let py0 = a.first.1.min(b.first.1).min(c.first.1).max(rect.1);
    let px1 = a.end.0.max(b.end.0).max(c.end.0).min(rect.2);
    let py1 = a.end.1.max(b.end.1).max(c.end.1).min(rect.3);
    (px0 < px1 && py0 < py1).then_some((px0 as u32, py0 as u32, px1 as u32, py1 as u32))
}

/// Whether a triangle on screen (pixel y down) turns its back to the
/// camera: clockwise as the viewer sees it, the face the renderer culls
/// (front faces counter-clockwise, `wgpu::FrontFace::Ccw`), as the impostor
/// baker tells it (src/model/impostor.rs). Edge-on triangles are not
/// culled here (they cover no centre).
fn back_facing([a, b, c]: [DVec2; 3]) -> bool {
    (b - a).perp_dot(c - a) > 0.0
}

/// The fewest box columns for which a triangle's rows are walked within
/// their spans ([`row_span`]) rather than whole: below it, working out the
/// span costs more than the centres it skips (the quickstart's depth maps
/// 0.59 ms a frame against 0.69 with spans from 1 column, 0.61 from 17).
const SPAN_MIN_COLUMNS: u32 = 8;

/// A drone's nearest surface depth over a pixel rectangle.
struct Tile {
    x0: u32,
    y0: u32,
    w: u32,
    h: u32,
    /// Nearest z per pixel centre (infinity: not covered).
    z: Vec<f64>,
}

impl Tile {
    /// Draw `drone`'s mesh seen by `cam` over the tile's rows `rows`
    /// (start, end) (`points`: a buffer for its vertices).
    fn raster(
        &mut self,
        (cam, drone): (&Camera, &DronePose),
        mesh: &DepthMesh,
        points: &mut Vec<Option<Point>>,
        rows: (u32, u32),
    ) {
        // Camera-frame vertices and their pixel positions (the camera's
        // `project_camera_point`, its focal length worked out once, not per vertex).
        let (f, c) = (cam.focal_px(), cam.principal_point());
        let simd = crate::simd::avx2();
        points.clear();
        points.extend(mesh.positions.iter().map(|&v| {
            let local = v * drone.size_m;
            let p = cam.camera_from_world_point(drone.position + drone.rotation * local);
            (p.z > cam.near_m && p.z > 0.0)
                .then(|| Point::new(DVec2::new(f * p.x / p.z + c.x, f * p.y / p.z + c.y), p.z))
        }));
        let (x0, y0) = (self.x0 as i32, rows.0.max(self.y0) as i32);
        let x1 = x0 + self.w as i32;
        let y1 = (rows.1.min(self.y0 + self.h) as i32).max(y0);
        for (tri, &both) in mesh.triangles.iter().zip(&mesh.double_sided) {
            let corner = |i: u32| points.get(i as usize).copied().flatten();
            let (Some(a), Some(b), Some(c)) = (corner(tri[0]), corner(tri[1]), corner(tri[2]))
            else {
                continue;
            };
            // Most triangles of a small drone hold no pixel centre: done before any sum.
            let Some(box_) = pixel_box([a, b, c], (x0, y0, x1, y1)) else {
                continue;
            };
            if !both && back_facing([a.pixel, b.pixel, c.pixel]) {
                continue;
            }
            self.triangle([(a.pixel, a.z), (b.pixel, b.z), (c.pixel, c.z)], box_, simd);
        }
    }

    /// Keep the nearest depth of the triangle at each pixel centre it covers
    /// (either winding) among the pixels `box_` (x0, y0, x1, y1; exclusive
    /// ends; those whose centres its bounding box holds, within the tile);
    /// 1/z is linear in screen space.
    /// Its rows in AVX2 registers where `simd` (the CPU has AVX2; the same bits).
    fn triangle(&mut self, v: [(DVec2, f64); 3], box_: (u32, u32, u32, u32), simd: bool) {
        let [(a, za), (b, zb), (c, zc)] = v;
        let (px0, py0, px1, py1) = box_;
        let area = (b - a).perp_dot(c - a);
        if area.abs() < 1e-12 {
            return;
        }
        // Only triangles of a pixel or more, over more than SPAN_MIN_COLUMNS
        // columns, gain from spans (a span costs three divisions a row; a
        // centre outside is told by two products); the others walk their box.
        let spans = area.abs() >= 1.0 && px1 - px0 > SPAN_MIN_COLUMNS;
        // No centre of the triangle is nearer than its nearest corner (the
        // weights are ≥ 0 and sum to 1 within a few ulps; the margin is far
        // wider), so a pixel already as near as that keeps its depth unread.
        let nearest = za.min(zb).min(zc) * (1.0 - 1e-9);
        let setup = Setup {
            a,
            b,
            c,
            z: [za, zb, zc],
            area,
            nearest,
        };
        for py in py0..py1 {
            let cy = f64::from(py) + 0.5;
            let (sx0, sx1) = if spans {
                row_span([a, b, c], cy, (px0, px1))
            } else {
                (px0, px1)
            };
            let start = ((py - self.y0) * self.w) as usize;
            let (from, to) = ((sx0 - self.x0) as usize, (sx1 - self.x0) as usize);
            let depths = &mut self.z[start + from..start + to];
            row::walk_with(
                &setup,
                Row {
                    depths,
                    cy,
                    first: sx0,
                },
                simd,
            );
        }
    }

    /// The depth at (x, y), else the nearest of its covered 8-neighbours.
    fn at(&self, x: u32, y: u32) -> Option<f64> {
        let get = |x: i64, y: i64| -> Option<f64> {
            let (dx, dy) = (x - i64::from(self.x0), y - i64::from(self.y0));
            if dx < 0 || dy < 0 || dx >= i64::from(self.w) || dy >= i64::from(self.h) {
                return None;
            }
            let z = self.z[(dy as usize) * (self.w as usize) + dx as usize];
            z.is_finite().then_some(z)
        };
        let (x, y) = (i64::from(x), i64::from(y));
        get(x, y).or_else(|| {
            (-1..=1)
                .flat_map(|dy| (-1..=1).map(move |dx| (dx, dy)))
                .filter_map(|(dx, dy)| get(x + dx, y + dy))
                .min_by(f64::total_cmp)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    /// The walk over the triangle's whole box, as before spans: the reference.
    fn whole_box(t: &mut Tile, v: [(DVec2, f64); 3]) {
        let [(a, za), (b, zb), (c, zc)] = v;
        let area = (b - a).perp_dot(c - a);
        if area.abs() < 1e-12 {
            return;
        }
        for py in t.y0..t.y0 + t.h {
            for px in t.x0..t.x0 + t.w {
                let p = DVec2::new(f64::from(px) + 0.5, f64::from(py) + 0.5);
                let wa = (c - b).perp_dot(p - b) / area;
                let wb = (a - c).perp_dot(p - c) / area;
                let wc = 1.0 - wa - wb;
                if wa < 0.0 || wb < 0.0 || wc < 0.0 {
                    continue;
                }
                let z = 1.0 / (wa / za + wb / zb + wc / zc);
                let at = ((py - t.y0) * t.w + (px - t.x0)) as usize;
                if z < t.z[at] {
                    t.z[at] = z;
                }
            }
        }
    }

    /// The code before the nearest-first order, the sign tests and the
    /// shared buffers (commit 794ea63), verbatim but for names and the
    /// renderer's culling of single-sided back faces: the reference. It
    /// fills the same `Tile` (whose `at` did not change) with the old raster.
    mod before {
        use crate::annotate::masks::FrameMasks;
        use crate::model::CpuModel;
        use crate::scene::FrameScene;
        use glam::{DVec2, DVec3};

        use super::super::Tile;

        pub fn depth_m(scene: &FrameScene, models: &[CpuModel], masks: &FrameMasks) -> Vec<f64> {
            let width = masks.width.max(1);
            let cam = &scene.camera;
            // Pixels of each drone in the instance image, with their place in it.
            let mut per_drone: Vec<Vec<(u32, u32, usize)>> = vec![Vec::new(); scene.drones.len()];
            for (k, &(i, d)) in masks.instance.iter().enumerate() {
                if let Some(list) = per_drone.get_mut(d as usize) {
                    list.push((i % width, i / width, k));
                }
            }
            let mut out = vec![0.0; masks.instance.len()];
            for (d, pixels) in per_drone.iter().enumerate() {
                if pixels.is_empty() {
                    continue;
                }
                let drone = &scene.drones[d];
                let centre_z = cam.camera_from_world_point(drone.position).z;
                let Some(model) = models.get(drone.model) else {
                    for &(_, _, k) in pixels {
                        out[k] = centre_z;
                    }
                    continue;
                };
                let x0 = pixels.iter().map(|p| p.0).min().unwrap_or(0);
                let y0 = pixels.iter().map(|p| p.1).min().unwrap_or(0);
                let x1 = pixels.iter().map(|p| p.0 + 1).max().unwrap_or(0);
                let y1 = pixels.iter().map(|p| p.1 + 1).max().unwrap_or(0);
                let tile = raster(scene, d, model, (x0, y0, x1, y1));
                for &(x, y, k) in pixels {
                    out[k] = tile.at(x, y).unwrap_or(centre_z);
                }
            }
            out
        }

        /// The columns of `cols` whose centres on the line y = `cy` may lie in the
        /// triangle: those within a pixel of where the line crosses it. The exact
        /// barycentric test still decides each one, so the depths are those of the
        /// whole box's walk; the span only skips centres a pixel or more outside
        /// (the test's rounding is far below that). The whole range when the line
        /// seems to miss (rounding at a vertex).
        fn row_span(v: [DVec2; 3], cy: f64, cols: (u32, u32)) -> (u32, u32) {
            let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
            for (p, q) in [(v[0], v[1]), (v[1], v[2]), (v[2], v[0])] {
                if cy < p.y.min(q.y) || cy > p.y.max(q.y) {
                    continue;
                }
                let (x0, x1) = if p.y == q.y {
                    (p.x.min(q.x), p.x.max(q.x))
                } else {
                    let x = p.x + (cy - p.y) * (q.x - p.x) / (q.y - p.y);
                    (x, x)
                };
                lo = lo.min(x0);
                hi = hi.max(x1);
            }
            if lo > hi {
                return cols;
            }
            // Centre px + 0.5 within [lo - 1, hi + 1].
            let first = (lo - 1.5)
                .ceil()
                .max(f64::from(cols.0))
                .min(f64::from(cols.1));
            let end = ((hi + 0.5).floor() + 1.0).min(f64::from(cols.1)).max(first);
            (first as u32, end as u32)
        }

        /// A drone's nearest surface depth over a pixel rectangle.
        fn raster(
            scene: &FrameScene,
            d: usize,
            model: &CpuModel,
            rect: (u32, u32, u32, u32),
        ) -> Tile {
            let (x0, y0, x1, y1) = rect;
            let (w, h) = (x1 - x0, y1 - y0);
            let mut tile = Tile {
                x0,
                y0,
                w,
                h,
                z: vec![f64::INFINITY; (w as usize) * (h as usize)],
            };
            let cam = &scene.camera;
            let drone = &scene.drones[d];
            // Camera-frame vertices and their pixel positions (the camera's
            // `project_camera_point`, its focal length worked out once, not per vertex).
            let (f, c) = (cam.focal_px(), cam.principal_point());
            let points: Vec<Option<(DVec2, f64)>> = (model.vertices.iter())
                .map(|v| {
                    let local = DVec3::from(v.position.map(f64::from)) * drone.size_m;
                    let p = cam.camera_from_world_point(drone.position + drone.rotation * local);
                    (p.z > cam.near_m && p.z > 0.0)
                        .then(|| (DVec2::new(f * p.x / p.z + c.x, f * p.y / p.z + c.y), p.z))
                })
                .collect();
            for (t, tri) in model.indices.chunks_exact(3).enumerate() {
                let corner = |i: u32| points.get(i as usize).copied().flatten();
                if let (Some(a), Some(b), Some(c)) =
                    (corner(tri[0]), corner(tri[1]), corner(tri[2]))
                {
                    // Added to that code: the renderer's culling of single-sided back faces.
                    let first = 3 * t as u32;
                    let both =
                        (model.draws.iter()).any(|d| d.double_sided && d.indices.contains(&first));
                    if both || (b.0 - a.0).perp_dot(c.0 - a.0) <= 0.0 {
                        triangle(&mut tile, [a, b, c]);
                    }
                }
            }
            tile
        }

        /// Keep the nearest depth of the triangle at each pixel centre it covers
        /// (either winding); 1/z is linear in screen space.
        fn triangle(tile: &mut Tile, v: [(DVec2, f64); 3]) {
            let [(a, za), (b, zb), (c, zc)] = v;
            let lo = a.min(b).min(c);
            let hi = a.max(b).max(c);
            let (fx0, fy0) = (f64::from(tile.x0), f64::from(tile.y0));
            let px0 = ((lo.x - 0.5).ceil().max(fx0)) as u32;
            let py0 = ((lo.y - 0.5).ceil().max(fy0)) as u32;
            let px1 = ((hi.x - 0.5).floor() + 1.0)
                .min(fx0 + f64::from(tile.w))
                .max(0.0) as u32;
            let py1 = ((hi.y - 0.5).floor() + 1.0)
                .min(fy0 + f64::from(tile.h))
                .max(0.0) as u32;
            // Most triangles of a small drone hold no pixel centre: done before any sum.
            if px0 >= px1 || py0 >= py1 {
                return;
            }
            let area = (b - a).perp_dot(c - a);
            if area.abs() < 1e-12 {
                return;
            }
            // Only triangles of a pixel or more gain from spans; small ones walk their box.
            let spans = area.abs() >= 1.0;
            // No centre of the triangle is nearer than its nearest corner (the
            // weights are ≥ 0 and sum to 1 within a few ulps; the margin is far
            // wider), so a pixel already as near as that keeps its depth unread.
            let nearest = za.min(zb).min(zc) * (1.0 - 1e-9);
            for py in py0..py1 {
                let cy = f64::from(py) + 0.5;
                let (sx0, sx1) = if spans {
                    row_span([a, b, c], cy, (px0, px1))
                } else {
                    (px0, px1)
                };
                for px in sx0..sx1 {
                    let at = ((py - tile.y0) * tile.w + (px - tile.x0)) as usize;
                    if nearest >= tile.z[at] {
                        continue;
                    }
                    let p = DVec2::new(f64::from(px) + 0.5, cy);
                    let wa = (c - b).perp_dot(p - b) / area;
                    let wb = (a - c).perp_dot(p - c) / area;
                    let wc = 1.0 - wa - wb;
                    if wa < 0.0 || wb < 0.0 || wc < 0.0 {
                        continue;
                    }
                    let z = 1.0 / (wa / za + wb / zb + wc / zc);
                    if z < tile.z[at] {
                        tile.z[at] = z;
                    }
                }
            }
        }
    }

    impl Tile {
        /// Draw one triangle as [`Tile::raster`] does.
        fn draw(&mut self, v: [(DVec2, f64); 3]) {
            self.draw_with(v, crate::simd::avx2());
        }

        /// [`Self::draw`], its rows in AVX2 registers where `simd`.
        fn draw_with(&mut self, v: [(DVec2, f64); 3], simd: bool) {
            let (x0, y0) = (self.x0 as i32, self.y0 as i32);
            let rect = (x0, y0, x0 + self.w as i32, y0 + self.h as i32);
            if let Some(box_) = pixel_box(v.map(|(p, z)| Point::new(p, z)), rect) {
                self.triangle(v, box_, simd);
            }
        }
    }

    /// The quickstart's pipeline (1–15 drones a frame, at many distances).
    fn quickstart() -> crate::pipeline::FramePipeline {
        let preset = crate::preset::Preset::from_ron(include_str!("../../presets/quickstart.ron"))
            .expect("quickstart");
        crate::pipeline::FramePipeline::new(preset).expect("pipeline")
    }

    /// Each drone's mask as its whole amodal box; with `off_box`, one pixel
    /// two off the box as well (neither covered nor next to a covered one).
    fn box_sets(
        scene: &FrameScene,
        assets: &crate::pipeline::Assets,
        off_box: bool,
    ) -> Vec<Vec<(u32, u32)>> {
        let cam = &scene.camera;
        (scene.drones.iter())
            .map(|d| {
                let Some(b) = crate::annotate::amodal_box(cam, d, &assets.geometry[d.model]) else {
                    return Vec::new();
                };
                let b = b.clip(f64::from(cam.width), f64::from(cam.height));
                let (x0, y0) = (b.x0.floor() as u32, b.y0.floor() as u32);
                let (x1, y1) = (b.x1.ceil() as u32, b.y1.ceil() as u32);
                let mut set: Vec<(u32, u32)> = (y0..y1)
                    .flat_map(|y| (x0..x1).map(move |x| (x, y)))
                    .collect();
                if off_box && x1 + 2 < cam.width {
                    set.push((x1 + 1, y0));
                }
                set
            })
            .collect()
    }

    #[test]
    fn depth_maps_have_the_bits_of_the_code_before() {
        // Quickstart scenes (1–15 drones, some a few pixels across, some hundreds)
        // with each drone's mask its whole amodal box and a few pixels off it,
        // so the covered centres, the 8-neighbour fallback and the drone's
        // centre all occur; drones overlap, so the instance image splits them.
        let pipeline = quickstart();
        let assets = pipeline.assets();
        let (mut pixels, mut surface, mut centre) = (0, 0, 0);
        for index in (0..pipeline.frame_count()).step_by(5) {
            let scene = pipeline.scene(index).expect("scene");
            let cam = &scene.camera;
            let sets = box_sets(&scene, assets, true);
            let mut masks = FrameMasks::from_sets(cam.width, cam.height, &sets);
            let new = depth_m(&scene, &assets.models, &masks);
            let old = before::depth_m(&scene, &assets.models, &masks);
            assert_eq!(new.len(), old.len());
            for (k, (n, o)) in new.iter().zip(&old).enumerate() {
                assert_eq!(
                    n.to_bits(),
                    o.to_bits(),
                    "frame {index}, pixel {k}: {n} against {o}"
                );
            }
            pixels += new.len();
            masks.depth_m = new;
            for (&(_, d), &z) in masks.instance.iter().zip(&masks.depth_m) {
                let c = cam
                    .camera_from_world_point(scene.drones[d as usize].position)
                    .z;
                if z == c {
                    centre += 1;
                } else {
                    surface += 1;
                }
            }
        }
        assert!(pixels > 100_000, "{pixels} pixels");
        assert!(centre > 10 && surface > 10_000, "{centre} {surface}");
    }

    #[test]
    fn culling_keeps_the_depth_of_closed_meshes_and_drops_back_faces() {
        // The builtin drones are closed: a ray meets a front face before any
        // back face, so culling the back faces keeps the depth of all but a
        // few silhouette centres (where rounding puts a centre in a back face
        // and out of the front faces beside it). Culling the front faces
        // instead would give the far side's depth almost everywhere.
        let pipeline = quickstart();
        let assets = pipeline.assets();
        let culled: Vec<DepthMesh> = assets.models.iter().map(DepthMesh::new).collect();
        assert!(culled.iter().all(|m| m.double_sided.iter().all(|&d| !d)));
        let both: Vec<DepthMesh> = (culled.iter())
            .map(|m| DepthMesh {
                double_sided: vec![true; m.triangles.len()],
                ..m.clone()
            })
            .collect();
        let (mut pixels, mut same) = (0, 0);
        for index in (0..pipeline.frame_count()).step_by(9) {
            let scene = pipeline.scene(index).expect("scene");
            let cam = &scene.camera;
            let sets = box_sets(&scene, assets, false);
            let masks = FrameMasks::from_sets(cam.width, cam.height, &sets);
            let a = depth_m_of_meshes(&scene, &culled, &masks);
            let b = depth_m_of_meshes(&scene, &both, &masks);
            pixels += a.len();
            same += a
                .iter()
                .zip(&b)
                .filter(|(a, b)| a.to_bits() == b.to_bits())
                .count();
        }
        assert!(pixels > 50_000, "{pixels} pixels");
        let share = same as f64 / pixels as f64;
        eprintln!("culled depth = both sides' at {same} of {pixels} pixels");
        assert!(share > 0.999, "{same} of {pixels}");
    }

    /// A quickstart scene seen by a 160×120 camera at the origin looking
    /// down +z, its one drone (model 0, size 3 m) 10 m ahead, unturned.
    fn plate_scene() -> (FrameScene, DronePose) {
        use crate::scene::camera::Camera;
        let mut scene = quickstart().scene(0).expect("scene");
        scene.camera = Camera {
            width: 160,
            height: 120,
            fov_y_deg: 60.0,
            position: DVec3::ZERO,
            camera_from_world: glam::DMat3::IDENTITY,
            near_m: 0.01,
        };
        let mut plate = scene.drones[0].clone();
        (plate.model, plate.position, plate.rotation, plate.size_m) =
            (0, DVec3::new(0.0, 0.0, 10.0), glam::DQuat::IDENTITY, 3.0);
        scene.drones = vec![plate.clone()];
        (scene, plate)
    }

    /// A square plate's corners in its model's plane z = 0.
    fn plate_corners() -> Vec<DVec3> {
        [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)]
            .map(|(x, y)| DVec3::new(x, y, 0.0))
            .to_vec()
    }

    #[test]
    fn single_sided_back_faces_are_culled_and_double_sided_ones_kept() {
        // A plate turned 30° about y (its depth varies across the frame),
        // wound front-on (counter-clockwise as the camera sees it) or back-on.
        use glam::DQuat;
        let (mut scene, mut plate) = plate_scene();
        plate.rotation = DQuat::from_rotation_y(30f64.to_radians());
        scene.drones = vec![plate];
        let positions = plate_corners();
        // Camera y points down: (-1,-1) → (1,-1) → (1,1) turns clockwise on screen.
        let back = vec![[0, 1, 2], [0, 2, 3]];
        let front = vec![[0, 2, 1], [0, 3, 2]];
        let mesh = |triangles: Vec<[u32; 3]>, both: bool| DepthMesh {
            positions: positions.clone(),
            double_sided: vec![both; triangles.len()],
            triangles,
        };
        let set: Vec<(u32, u32)> = (50..70)
            .flat_map(|y| (70..90).map(move |x| (x, y)))
            .collect();
        let masks = FrameMasks::from_sets(160, 120, &[set]);
        let depth = |m: DepthMesh| depth_m_of_meshes(&scene, &[m], &masks);
        let surface = depth(mesh(front.clone(), false));
        let spread = |d: &[f64]| {
            let (lo, hi) = d
                .iter()
                .fold((f64::MAX, f64::MIN), |(l, h), &z| (l.min(z), h.max(z)));
            hi - lo
        };
        assert!(spread(&surface) > 0.1, "the turned plate's depth varies");
        assert_eq!(depth(mesh(front, true)), surface);
        // The other winding: the same surface, rounded in its corners' order.
        let near = |a: &[f64]| a.iter().zip(&surface).all(|(a, b)| (a - b).abs() < 1e-9);
        assert!(near(&depth(mesh(back.clone(), true))));
        // Culled: every pixel falls back to the drone's centre.
        assert!(depth(mesh(back, false)).iter().all(|&z| z == 10.0));
    }

    #[test]
    fn row_spans_give_the_bits_of_the_whole_box_walk() {
        // Random triangles (thin, large, tiny, on pixel centres, off the tile) on one tile.
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(22);
        let tile = |w, h| Tile {
            x0: 3,
            y0: 5,
            w,
            h,
            z: vec![f64::INFINITY; (w * h) as usize],
        };
        let (mut fast, mut slow) = (tile(61, 47), tile(61, 47));
        // The rows one centre at a time, and in AVX2 registers where the CPU has them.
        let mut scalar = tile(61, 47);
        let mut covered = 0;
        for k in 0..3000 {
            let scale = [0.7, 4.0, 30.0, 90.0][k % 4];
            let centre = DVec2::new(rng.random_range(0.0..70.0), rng.random_range(0.0..60.0));
            let mut corner = || {
                let mut p = centre
                    + DVec2::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0)) * scale;
                if rng.random_range(0..4) == 0 {
                    p = p.round() + DVec2::splat(0.5); // exactly on a pixel centre
                }
                (p, rng.random_range(0.5..50.0))
            };
            let v = [corner(), corner(), corner()];
            fast.draw(v);
            scalar.draw_with(v, false);
            whole_box(&mut slow, v);
            let same =
                |t: &Tile| (t.z.iter().zip(&slow.z)).all(|(f, s)| f.to_bits() == s.to_bits());
            assert!(same(&fast), "triangle {k}: {v:?}");
            assert!(same(&scalar), "triangle {k}, one centre at a time: {v:?}");
            covered = fast.z.iter().filter(|z| z.is_finite()).count();
        }
        assert!(covered > 2000, "the triangles cover the tile: {covered}");
    }

    #[test]
    fn a_triangle_keeps_the_nearest_depth_at_covered_centres() {
        let mut t = Tile {
            x0: 0,
            y0: 0,
            w: 4,
            h: 4,
            z: vec![f64::INFINITY; 16],
        };
        // A flat triangle at z = 2 over the top-left half, then a nearer one at z = 1.
        let v = |x: f64, y: f64, z: f64| (DVec2::new(x, y), z);
        t.draw([v(0.0, 0.0, 2.0), v(4.0, 0.0, 2.0), v(0.0, 4.0, 2.0)]);
        assert_eq!(t.at(0, 0), Some(2.0));
        assert!(t.z[15].is_infinite(), "(3.5, 3.5) is outside");
        t.draw([v(0.0, 0.0, 1.0), v(0.0, 2.0, 1.0), v(2.0, 0.0, 1.0)]);
        assert_eq!(t.at(0, 0), Some(1.0));
        assert_eq!(t.at(2, 1), Some(2.0));
        assert_eq!(
            t.at(2, 2),
            Some(2.0),
            "uncovered: its nearest covered neighbour"
        );
        assert_eq!(t.at(3, 3), None, "no covered neighbour");
        // 1/z is linear on screen: halfway between z = 1 and z = 3 on screen is z = 1.5.
        let mut s = Tile {
            x0: 0,
            y0: 0,
            w: 2,
            h: 1,
            z: vec![f64::INFINITY; 2],
        };
        s.draw([v(0.5, -10.0, 1.0), v(0.5, 10.0, 1.0), v(2.5, 0.5, 3.0)]);
        assert!((s.z[1] - 1.5).abs() < 1e-9, "{}", s.z[1]);
    }

    #[test]
    fn under_a_rolling_shutter_each_row_has_the_depth_of_its_time() {
        // A 6 m plate facing the camera (over the whole mask), receding 1 cm per row's time: every
        // covered pixel of row y is 10 + 0.01·y m away. With each row at
        // the frame's own pose, the global map's bits.
        let (scene, plate) = plate_scene();
        let mesh = DepthMesh {
            positions: plate_corners(),
            triangles: vec![[0, 1, 2], [0, 2, 3]],
            double_sided: vec![true; 2],
        };
        let sets = vec![
            (40..80)
                .flat_map(|y| (60..100).map(move |x| (x, y)))
                .collect::<Vec<_>>(),
        ];
        let masks = FrameMasks::from_sets(160, 120, &sets);
        let cam = scene.camera;
        let receding = |_: usize, y: u32| {
            let position = DVec3::new(0.0, 0.0, 10.0 + 0.01 * f64::from(y));
            Some((
                cam,
                DronePose {
                    position,
                    ..plate.clone()
                },
            ))
        };
        let depth = depth_m_of_rows(&scene, std::slice::from_ref(&mesh), &masks, Some(&receding));
        for (&(i, _), &z) in masks.instance.iter().zip(&depth) {
            let want = 10.0 + 0.01 * f64::from(i / 160);
            assert!((z - want).abs() < 1e-9, "pixel {i}: {z} against {want}");
        }
        let still = |_: usize, _: u32| Some((cam, plate.clone()));
        let rows = depth_m_of_rows(&scene, std::slice::from_ref(&mesh), &masks, Some(&still));
        let global = depth_m_of_meshes(&scene, std::slice::from_ref(&mesh), &masks);
        assert_eq!(rows, global);
        assert!(global.iter().all(|&z| (z - 10.0).abs() < 1e-9));
    }
}
