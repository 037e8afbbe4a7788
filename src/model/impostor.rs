//! Impostors: a model's silhouette seen from [`DIRECTIONS`] directions, baked
//! once on the CPU (the tiles on rayon's threads) into one atlas of
//! [`TILE`]² tiles, and a quad per
//! direction that carries its tile. A drone too small for its mesh to matter
//! is drawn as the quad of the direction nearest its view (in model space,
//! so the drone's pose orients and scales it like its mesh).
//!
//! Each tile is an orthographic view along its direction: per texel the
//! front-most triangle's base colour (vertex colour × texture, sRGB-encoded)
//! with alpha 255; glTF BLEND triangles (rotor discs) over it at their alpha;
//! uncovered texels are alpha 0 with the tile's mean colour (so mip levels do
//! not darken the edge). A quad lies in the plane through the model's centre
//! across its direction; its normal is the mean normal of what its tile shows
//! (the lighting of a flat card), its metallic/roughness the mean of the
//! texels'. Its vertices' `material[3]` is [`IMPOSTOR_MARK`]: the drone shader
//! turns the atlas alpha into MSAA coverage, as it does for BLEND triangles.

use glam::{DVec2, DVec3};
use rayon::prelude::*;

use super::{BLEND_MARK, CpuModel, CpuTexture, Vertex, WrapMode};

/// View directions baked per model (a Fibonacci sphere).
pub const DIRECTIONS: usize = 128;
/// Texels a side of one direction's tile.
pub const TILE: u32 = 64;
/// Tiles per atlas row.
const COLUMNS: u32 = 16;
/// Share of a tile's side left empty around the silhouette.
const MARGIN: f64 = 0.04;
/// `Vertex::material[3]` of impostor quads: alpha is coverage, as with
/// [`BLEND_MARK`], but not scaled by a drawn look's rotor opacity.
pub const IMPOSTOR_MARK: f32 = -2.0;

/// A model's impostor: its directions, one quad each (4 vertices, 6
/// indices, direction `k`'s at `4k` and `6k`) and the atlas of their tiles.
#[derive(Clone, Debug)]
pub struct Impostor {
    /// Unit vectors in model space, from the model towards the viewer.
    pub directions: Vec<DVec3>,
    pub vertices: Vec<Vertex>,
    pub indices: Vec<u32>,
    pub atlas: CpuTexture,
}

/// The index of the direction of `directions` nearest `towards_viewer`
/// (model space, any length).
pub fn nearest(directions: &[DVec3], towards_viewer: DVec3) -> usize {
    let mut best = (f64::NEG_INFINITY, 0);
    for (k, d) in directions.iter().enumerate() {
        let dot = d.dot(towards_viewer);
        if dot > best.0 {
            best = (dot, k);
        }
    }
    best.1
}

/// `n` unit vectors spread evenly over the sphere (Fibonacci lattice).
fn fibonacci_sphere(n: usize) -> Vec<DVec3> {
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    (0..n)
        .map(|i| {
            let y = 1.0 - (i as f64 + 0.5) / n as f64 * 2.0;
            let r = (1.0 - y * y).max(0.0).sqrt();
            let a = golden * i as f64;
            DVec3::new(r * a.cos(), y, r * a.sin())
        })
        .collect()
}

/// Right and up of a viewer at `d` looking at the origin (`d` unit).
fn basis(d: DVec3) -> (DVec3, DVec3) {
    let up = if d.y.abs() < 0.99 { DVec3::Y } else { DVec3::X };
    let right = up.cross(d).normalize();
    (right, d.cross(right))
}

/// What one texel of a tile holds while baking.
#[derive(Clone, Copy, Default)]
struct Texel {
    depth: f64,
    covered: bool,
    color: [f64; 4],
    normal: DVec3,
    material: [f64; 2],
}

/// One tile being baked: its frame (direction, right, up, centre, side).
struct Tile {
    d: DVec3,
    right: DVec3,
    up: DVec3,
    centre: DVec2,
    side: f64,
}

impl Tile {
    fn new(model: &CpuModel, d: DVec3) -> Self {
        let (right, up) = basis(d);
        let (mut lo, mut hi) = (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY));
        for v in &model.vertices {
            let p = DVec3::from(v.position.map(f64::from));
            let q = DVec2::new(p.dot(right), p.dot(up));
            (lo, hi) = (lo.min(q), hi.max(q));
        }
        let span = (hi - lo).max_element().max(1e-6);
        Self {
            d,
            right,
            up,
            centre: (lo + hi) * 0.5,
            side: span * (1.0 + 2.0 * MARGIN),
        }
    }

    /// A model-space point in texel coordinates (x right, y down) and its depth towards the viewer.
    fn texel_of(&self, p: DVec3) -> (DVec2, f64) {
        let q = (DVec2::new(p.dot(self.right), p.dot(self.up)) - self.centre) / self.side;
        let t = f64::from(TILE);
        (DVec2::new((q.x + 0.5) * t, (0.5 - q.y) * t), p.dot(self.d))
    }

    /// The quad's corner `(sx, sy)` (±1 each) in model space.
    fn corner(&self, sx: f64, sy: f64) -> DVec3 {
        let h = self.side * 0.5;
        self.right * (self.centre.x + sx * h) + self.up * (self.centre.y + sy * h)
    }
}

/// The baked directions: unit vectors over the sphere, the same for every model.
pub fn directions() -> Vec<DVec3> {
    fibonacci_sphere(DIRECTIONS)
}

/// The quads' indices, the same for every model: direction `k`'s two
/// triangles over vertices `4k..4k + 4`.
pub fn quad_indices() -> Vec<u32> {
    (0..DIRECTIONS as u32)
        .flat_map(|k| [0, 1, 2, 0, 2, 3].map(|i| 4 * k + i))
        .collect()
}

/// The atlas's width and height in texels.
pub fn atlas_size() -> (u32, u32) {
    (COLUMNS * TILE, (DIRECTIONS as u32).div_ceil(COLUMNS) * TILE)
}

/// What the bake's result depends on besides the model: its settings.
pub fn settings() -> String {
    format!("directions {DIRECTIONS} tile {TILE} columns {COLUMNS} margin {MARGIN}")
}

/// `model`'s atlas texture from its texels (`atlas_size`, RGBA8).
pub fn atlas(model: &CpuModel, rgba8: Vec<u8>) -> CpuTexture {
    let (width, height) = atlas_size();
    CpuTexture {
        name: format!("{} impostor atlas", model.name),
        width,
        height,
        rgba8,
        wrap: [WrapMode::ClampToEdge; 2],
    }
}

/// Bake `model`'s impostor (see [`super::impostor_cache`] for the cached bake).
pub fn bake(model: &CpuModel) -> Impostor {
    let directions = directions();
    let (width, height) = atlas_size();
    let mut rgba8 = vec![0u8; (width * height * 4) as usize];
    let mut vertices = Vec::new();
    // The tiles rasterise apart on rayon's threads (each a pure function of
    // the model and its direction); the atlas is written in order.
    let baked: Vec<(Tile, Vec<Texel>)> = (directions.par_iter())
        .map(|&d| {
            let tile = Tile::new(model, d);
            let texels = bake_tile(model, &tile);
            (tile, texels)
        })
        .collect();
    for (k, (&d, (tile, texels))) in directions.iter().zip(baked).enumerate() {
        let (col, row) = (k as u32 % COLUMNS, k as u32 / COLUMNS);
        let (normal, material) = write_tile(&texels, &mut rgba8, width, (col * TILE, row * TILE));
        let uv_of = |x: u32, y: u32| [x as f32 / width as f32, y as f32 / height as f32];
        let (x0, y0, x1, y1) = (col * TILE, row * TILE, (col + 1) * TILE, (row + 1) * TILE);
        for (sx, sy, uv) in [
            (-1.0, -1.0, uv_of(x0, y1)),
            (1.0, -1.0, uv_of(x1, y1)),
            (1.0, 1.0, uv_of(x1, y0)),
            (-1.0, 1.0, uv_of(x0, y0)),
        ] {
            vertices.push(Vertex {
                position: tile.corner(sx, sy).as_vec3().to_array(),
                normal: normal.try_normalize().unwrap_or(d).as_vec3().to_array(),
                color: [1.0; 4],
                uv,
                material: [material[0] as f32, material[1] as f32, 0.0, IMPOSTOR_MARK],
            });
        }
    }
    Impostor {
        directions,
        vertices,
        indices: quad_indices(),
        atlas: atlas(model, rgba8),
    }
}

/// Rasterise `model` into `tile`: opaque triangles with a depth test, then
/// BLEND ones over them at their alpha.
fn bake_tile(model: &CpuModel, tile: &Tile) -> Vec<Texel> {
    let mut texels = vec![Texel::default(); (TILE * TILE) as usize];
    for blend in [false, true] {
        for draw in &model.draws {
            let texture = draw.texture.and_then(|t| model.textures.get(t));
            let range = draw.indices.start as usize..draw.indices.end as usize;
            let tris = model.indices.get(range).unwrap_or(&[]).chunks_exact(3);
            for tri in tris {
                let Some(v) = triangle(model, tri) else {
                    continue;
                };
                if (v[0].material[3] == BLEND_MARK) != blend {
                    continue;
                }
                raster(tile, v, (texture, draw.double_sided), &mut texels);
            }
        }
    }
    texels
}

/// The vertices of triangle `tri` (indices into `model.vertices`).
fn triangle<'a>(model: &'a CpuModel, tri: &[u32]) -> Option<[&'a Vertex; 3]> {
    let at = |k: usize| model.vertices.get(*tri.get(k)? as usize);
    Some([at(0)?, at(1)?, at(2)?])
}

/// Rasterise one triangle into `texels` (sample at texel centres).
fn raster(
    tile: &Tile,
    v: [&Vertex; 3],
    (texture, double_sided): (Option<&CpuTexture>, bool),
    texels: &mut [Texel],
) {
    let p = v.map(|v| tile.texel_of(DVec3::from(v.position.map(f64::from))));
    let area = edge(p[0].0, p[1].0, p[2].0);
    // Texel y points down: a front face (counter-clockwise seen from the viewer) has negative area here.
    if area == 0.0 || (area > 0.0 && !double_sided) {
        return;
    }
    let lo = p[0].0.min(p[1].0).min(p[2].0).floor().max(DVec2::ZERO);
    let hi = p[0]
        .0
        .max(p[1].0)
        .max(p[2].0)
        .ceil()
        .min(DVec2::splat(f64::from(TILE)));
    let blend = v[0].material[3] == BLEND_MARK;
    for y in lo.y as u32..hi.y as u32 {
        for x in lo.x as u32..hi.x as u32 {
            let c = DVec2::new(f64::from(x) + 0.5, f64::from(y) + 0.5);
            let w = [
                edge(p[1].0, p[2].0, c) / area,
                edge(p[2].0, p[0].0, c) / area,
                edge(p[0].0, p[1].0, c) / area,
            ];
            if w.iter().any(|&w| w < 0.0) {
                continue;
            }
            let depth = w[0] * p[0].1 + w[1] * p[1].1 + w[2] * p[2].1;
            let t = &mut texels[(y * TILE + x) as usize];
            if t.covered && depth <= t.depth {
                continue;
            }
            let color = shade_texel(v, w, texture);
            if blend {
                let a = color[3];
                if a <= 0.0 {
                    continue;
                }
                let under = if t.covered { t.color } else { [0.0; 4] };
                for c in 0..3 {
                    t.color[c] = under[c] * (1.0 - a) + color[c] * a;
                }
                t.color[3] = under[3] + (1.0 - under[3]) * a;
                t.covered = true;
                continue;
            }
            let cutoff = f64::from(v[0].material[3]);
            if cutoff > 0.0 && color[3] < cutoff {
                continue;
            }
            let n = (0..3).fold(DVec3::ZERO, |n, i| {
                n + DVec3::from(v[i].normal.map(f64::from)) * w[i]
            });
            let n = if n.dot(tile.d) < 0.0 { -n } else { n };
            *t = Texel {
                depth,
                covered: true,
                color: [color[0], color[1], color[2], 1.0],
                normal: n.normalize_or_zero(),
                material: [f64::from(v[0].material[0]), f64::from(v[0].material[1])],
            };
        }
    }
}

/// Twice the signed area of (a, b, c).
fn edge(a: DVec2, b: DVec2, c: DVec2) -> f64 {
    (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x)
}

/// The linear base colour at barycentric `w`: vertex colour × texture (nearest texel).
fn shade_texel(v: [&Vertex; 3], w: [f64; 3], texture: Option<&CpuTexture>) -> [f64; 4] {
    let mut color = [0.0; 4];
    for (c, out) in color.iter_mut().enumerate() {
        *out = (0..3).map(|i| f64::from(v[i].color[c]) * w[i]).sum();
    }
    let Some(t) = texture.filter(|t| t.width > 0 && t.height > 0) else {
        return color;
    };
    let uv = (0..3).fold(DVec2::ZERO, |uv, i| {
        uv + DVec2::from(v[i].uv.map(f64::from)) * w[i]
    });
    let wrap = |u: f64, n: u32| ((u.rem_euclid(1.0) * f64::from(n)) as u32).min(n - 1);
    let (x, y) = (wrap(uv.x, t.width), wrap(uv.y, t.height));
    let at = ((y * t.width + x) * 4) as usize;
    for (c, out) in color.iter_mut().enumerate() {
        let byte = t.rgba8.get(at + c).copied().unwrap_or(255);
        *out *= if c < 3 {
            srgb_to_linear(byte)
        } else {
            f64::from(byte) / 255.0
        };
    }
    color
}

/// Write a baked tile at `origin` of the atlas (`width` texels a row);
/// returns the sum of its covered texels' normals and their mean
/// metallic/roughness.
fn write_tile(
    texels: &[Texel],
    rgba8: &mut [u8],
    width: u32,
    origin: (u32, u32),
) -> (DVec3, [f64; 2]) {
    let covered: Vec<&Texel> = texels.iter().filter(|t| t.covered).collect();
    let n = covered.len().max(1) as f64;
    let mut mean = [0.0; 3];
    let mut material = [0.0; 2];
    let mut normal = DVec3::ZERO;
    for t in &covered {
        for (m, c) in mean.iter_mut().zip(t.color) {
            *m += c / n;
        }
        material[0] += t.material[0] / n;
        material[1] += t.material[1] / n;
        normal += t.normal;
    }
    for (i, t) in texels.iter().enumerate() {
        let (x, y) = (origin.0 + i as u32 % TILE, origin.1 + i as u32 / TILE);
        let at = ((y * width + x) * 4) as usize;
        let (rgb, a) = if t.covered {
            ([t.color[0], t.color[1], t.color[2]], t.color[3])
        } else {
            (mean, 0.0)
        };
        for c in 0..3 {
            rgba8[at + c] = linear_to_srgb(rgb[c]);
        }
        rgba8[at + 3] = (a.clamp(0.0, 1.0) * 255.0).round() as u8;
    }
    (normal, material)
}

fn srgb_to_linear(c: u8) -> f64 {
    let c = f64::from(c) / 255.0;
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

fn linear_to_srgb(c: f64) -> u8 {
    let c = c.clamp(0.0, 1.0);
    let s = if c <= 0.003_130_8 {
        c * 12.92
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    };
    (s * 255.0).round() as u8
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn directions_cover_the_sphere_and_nearest_finds_each() {
        let imp = fibonacci_sphere(DIRECTIONS);
        // Any view lies within 15° of some direction.
        for i in 0..500 {
            let d = fibonacci_sphere(500)[i];
            let best = imp.iter().map(|k| k.dot(d)).fold(f64::MIN, f64::max);
            assert!(best > 15f64.to_radians().cos(), "{d:?}: {best}");
        }
        let (r, u) = basis(imp[3]);
        assert!(r.dot(u).abs() < 1e-12 && r.cross(u).dot(imp[3]) > 0.999);
    }
}
