//! CPU-side models: glTF import into a plain mesh, normalisation to a unit
//! span, and the convex hull the labeller projects.
//!
//! glTF files (.gltf with .bin or data URIs, .glb) are flattened: every mesh
//! instance of the default scene is baked with the product of its parents'
//! node transforms (negative scale flips the winding), base colour factors and
//! vertex colours are baked per vertex, and the result is centred on its
//! bounding-box centre and scaled so that its largest span is 1. A placed
//! drone is then `translate · rotate · scale(size_m)` of this model.

use std::path::{Path, PathBuf};

use glam::{DMat3, DMat4, DVec3, Vec3};

/// One vertex as the GPU sees it (`shaders/drone.wgsl`, `VertexInput`).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct Vertex {
    pub position: [f32; 3],
    pub normal: [f32; 3],
    /// Linear RGBA base colour (material factor × vertex colour).
    pub color: [f32; 4],
}

/// A model ready to upload and to label: unit largest span, centred at the origin.
#[derive(Clone, Debug)]
pub struct CpuModel {
    pub name: String,
    pub vertices: Vec<Vertex>,
    /// Triangle list, counter-clockwise front faces.
    pub indices: Vec<u32>,
    /// Convex hull vertices (normalised model space); projecting these gives the same box as projecting every vertex.
    pub hull: Vec<DVec3>,
    /// Normalised bounding box, min and max.
    pub aabb: (DVec3, DVec3),
    /// Largest span of the file's geometry, in the file's units.
    pub source_span: f64,
    /// What was skipped while loading (points, lines…).
    pub warnings: Vec<String>,
}

#[derive(Debug, thiserror::Error)]
pub enum ModelError {
    #[error("cannot read model {}: {source}", file.display())]
    Io {
        file: PathBuf,
        source: std::io::Error,
    },
    #[error("model {}: not a valid glTF file: {reason}", file.display())]
    Parse { file: PathBuf, reason: String },
    #[error("model {} requires the glTF extension {extension}, which swarmshot does not support{}", file.display(), hint(extension))]
    UnsupportedExtension { file: PathBuf, extension: String },
    #[error("model {}: cannot load buffer data: {reason}", file.display())]
    Buffer { file: PathBuf, reason: String },
    #[error("model {}: mesh \"{mesh}\" primitive {primitive}: {reason}", file.display())]
    Primitive {
        file: PathBuf,
        mesh: String,
        primitive: usize,
        reason: String,
    },
    #[error("model {} has no triangles to draw", file.display())]
    NoTriangles { file: PathBuf },
    #[error("model {}: geometry is degenerate or not finite (span {span})", file.display())]
    Degenerate { file: PathBuf, span: f64 },
}

fn hint(extension: &str) -> &'static str {
    if extension == "KHR_draco_mesh_compression" {
        " (Draco-compressed meshes; export the model without Draco compression)"
    } else if extension == "KHR_mesh_quantization" {
        " (quantized attributes; export with float positions)"
    } else {
        ""
    }
}

/// Required extensions we can draw correctly.
const SUPPORTED_REQUIRED: &[&str] = &["KHR_materials_unlit", "KHR_texture_transform"];

/// Load a .gltf or .glb file from disk.
pub fn load_file(path: &Path) -> Result<CpuModel, ModelError> {
    let bytes = std::fs::read(path).map_err(|source| ModelError::Io {
        file: path.to_owned(),
        source,
    })?;
    let name = path
        .file_stem()
        .map_or_else(|| "model".into(), |s| s.to_string_lossy().into_owned());
    load_bytes(&bytes, path.parent(), path, &name)
}

/// Load glTF from bytes; `base_dir` resolves external buffers, `file` names the source in errors.
pub fn load_bytes(
    bytes: &[u8],
    base_dir: Option<&Path>,
    file: &Path,
    name: &str,
) -> Result<CpuModel, ModelError> {
    let parse = |e: gltf::Error| ModelError::Parse {
        file: file.to_owned(),
        reason: e.to_string(),
    };
    let unvalidated = gltf::Gltf::from_slice_without_validation(bytes).map_err(parse)?;
    if let Some(ext) = unvalidated
        .document
        .extensions_required()
        .find(|e| !SUPPORTED_REQUIRED.contains(e))
    {
        return Err(ModelError::UnsupportedExtension {
            file: file.to_owned(),
            extension: ext.to_string(),
        });
    }
    let gltf::Gltf { document, blob } = gltf::Gltf::from_slice(bytes).map_err(parse)?;
    let buffers =
        gltf::import_buffers(&document, base_dir, blob).map_err(|e| ModelError::Buffer {
            file: file.to_owned(),
            reason: buffer_reason(&document, e),
        })?;
    let mut builder = Flattener {
        file,
        buffers: &buffers,
        vertices: Vec::new(),
        indices: Vec::new(),
        warnings: Vec::new(),
    };
    let scene = document
        .default_scene()
        .or_else(|| document.scenes().next());
    match scene {
        Some(scene) => {
            for node in scene.nodes() {
                builder.node(&node, DMat4::IDENTITY)?;
            }
        }
        None => {
            // No scene: draw every mesh once, untransformed.
            for mesh in document.meshes() {
                builder.mesh(&mesh, DMat4::IDENTITY)?;
            }
        }
    }
    let Flattener {
        vertices,
        indices,
        warnings,
        ..
    } = builder;
    finish(name, vertices, indices, warnings, file)
}

fn buffer_reason(document: &gltf::Document, e: gltf::Error) -> String {
    let uris: Vec<String> = document
        .buffers()
        .filter_map(|b| match b.source() {
            gltf::buffer::Source::Uri(uri) if !uri.starts_with("data:") => Some(uri.to_string()),
            _ => None,
        })
        .collect();
    if uris.is_empty() {
        e.to_string()
    } else {
        format!("{e} (buffers: {})", uris.join(", "))
    }
}

struct Flattener<'a> {
    file: &'a Path,
    buffers: &'a [gltf::buffer::Data],
    vertices: Vec<Vertex>,
    indices: Vec<u32>,
    warnings: Vec<String>,
}

impl Flattener<'_> {
    fn node(&mut self, node: &gltf::Node<'_>, parent: DMat4) -> Result<(), ModelError> {
        let local = DMat4::from_cols_array_2d(&node.transform().matrix().map(|c| c.map(f64::from)));
        let world = parent * local;
        if let Some(mesh) = node.mesh() {
            self.mesh(&mesh, world)?;
        }
        for child in node.children() {
            self.node(&child, world)?;
        }
        Ok(())
    }

    fn mesh(&mut self, mesh: &gltf::Mesh<'_>, world: DMat4) -> Result<(), ModelError> {
        let mesh_name = mesh
            .name()
            .map_or_else(|| format!("#{}", mesh.index()), str::to_string);
        let normal_matrix = DMat3::from_mat4(world).inverse().transpose();
        let flips = DMat3::from_mat4(world).determinant() < 0.0;
        for (p, primitive) in mesh.primitives().enumerate() {
            let err = |reason: String| ModelError::Primitive {
                file: self.file.to_owned(),
                mesh: mesh_name.clone(),
                primitive: p,
                reason,
            };
            use gltf::mesh::Mode;
            let mode = primitive.mode();
            if !matches!(
                mode,
                Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
            ) {
                self.warnings.push(format!("mesh \"{mesh_name}\" primitive {p}: {mode:?} skipped (only triangles are drawn)"));
                continue;
            }
            let buffers = self.buffers;
            let reader = primitive.reader(|b| buffers.get(b.index()).map(|d| &d.0[..]));
            let positions: Vec<[f32; 3]> = reader
                .read_positions()
                .ok_or_else(|| err("no POSITION attribute".into()))?
                .collect();
            if positions.is_empty() {
                continue;
            }
            let normals: Option<Vec<[f32; 3]>> = reader.read_normals().map(Iterator::collect);
            let colors: Option<Vec<[f32; 4]>> =
                reader.read_colors(0).map(|c| c.into_rgba_f32().collect());
            let factor = primitive
                .material()
                .pbr_metallic_roughness()
                .base_color_factor();
            let raw_indices: Vec<u32> = match reader.read_indices() {
                Some(ix) => ix.into_u32().collect(),
                None => (0..positions.len() as u32).collect(),
            };
            if let Some(bad) = raw_indices.iter().find(|&&i| i as usize >= positions.len()) {
                return Err(err(format!(
                    "index {bad} is out of range for {} vertices",
                    positions.len()
                )));
            }
            if normals.as_ref().is_some_and(|n| n.len() != positions.len())
                || colors.as_ref().is_some_and(|c| c.len() != positions.len())
            {
                return Err(err("attribute counts differ from the POSITION count".into()));
            }
            let triangles = triangulate(mode, &raw_indices);
            let base = self.vertices.len() as u32;
            for (i, pos) in positions.iter().enumerate() {
                let p = world.transform_point3(DVec3::from(pos.map(f64::from)));
                let n = normals
                    .as_ref()
                    .map(|n| (normal_matrix * DVec3::from(n[i].map(f64::from))).normalize_or_zero())
                    .unwrap_or(DVec3::ZERO);
                let c = colors.as_ref().map_or([1.0; 4], |c| c[i]);
                self.vertices.push(Vertex {
                    position: p.as_vec3().to_array(),
                    normal: n.as_vec3().to_array(),
                    color: [
                        c[0] * factor[0],
                        c[1] * factor[1],
                        c[2] * factor[2],
                        c[3] * factor[3],
                    ],
                });
            }
            let start = self.indices.len();
            for [a, b, c] in triangles {
                let tri = if flips { [a, c, b] } else { [a, b, c] };
                self.indices.extend(tri.map(|i| base + i));
            }
            if normals.is_none() {
                compute_normals(
                    &mut self.vertices[base as usize..],
                    &self.indices[start..],
                    base,
                );
            }
        }
        Ok(())
    }
}

/// Triangle lists from lists, strips and fans (degenerate triangles dropped).
fn triangulate(mode: gltf::mesh::Mode, ix: &[u32]) -> Vec<[u32; 3]> {
    use gltf::mesh::Mode;
    let tris: Vec<[u32; 3]> = match mode {
        Mode::Triangles => ix.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect(),
        Mode::TriangleStrip => (0..ix.len().saturating_sub(2))
            .map(|i| {
                if i % 2 == 0 {
                    [ix[i], ix[i + 1], ix[i + 2]]
                } else {
                    [ix[i + 1], ix[i], ix[i + 2]]
                }
            })
            .collect(),
        Mode::TriangleFan => (1..ix.len().saturating_sub(1))
            .map(|i| [ix[0], ix[i], ix[i + 1]])
            .collect(),
        _ => Vec::new(),
    };
    tris.into_iter()
        .filter(|[a, b, c]| a != b && b != c && a != c)
        .collect()
}

/// Area-weighted smooth normals for a primitive that has none.
fn compute_normals(vertices: &mut [Vertex], indices: &[u32], base: u32) {
    let mut acc = vec![Vec3::ZERO; vertices.len()];
    for t in indices.chunks_exact(3) {
        let [a, b, c] = [t[0], t[1], t[2]].map(|i| (i - base) as usize);
        let [pa, pb, pc] = [a, b, c].map(|i| Vec3::from(vertices[i].position));
        let n = (pb - pa).cross(pc - pa);
        for i in [a, b, c] {
            acc[i] += n;
        }
    }
    for (v, n) in vertices.iter_mut().zip(acc) {
        v.normal = n.normalize_or_zero().to_array();
    }
}

/// Centre, scale to a unit span, and compute the hull.
fn finish(
    name: &str,
    mut vertices: Vec<Vertex>,
    indices: Vec<u32>,
    warnings: Vec<String>,
    file: &Path,
) -> Result<CpuModel, ModelError> {
    if indices.is_empty() {
        return Err(ModelError::NoTriangles {
            file: file.to_owned(),
        });
    }
    // Bounds over the vertices that triangles use.
    let mut lo = DVec3::splat(f64::INFINITY);
    let mut hi = DVec3::splat(f64::NEG_INFINITY);
    for &i in &indices {
        let p = DVec3::from(vertices[i as usize].position.map(f64::from));
        lo = lo.min(p);
        hi = hi.max(p);
    }
    let span = (hi - lo).max_element();
    if !(span.is_finite() && span > 0.0) {
        return Err(ModelError::Degenerate {
            file: file.to_owned(),
            span,
        });
    }
    let centre = (lo + hi) * 0.5;
    for v in &mut vertices {
        let p = (DVec3::from(v.position.map(f64::from)) - centre) / span;
        v.position = p.as_vec3().to_array();
    }
    let used: Vec<DVec3> = unique_used_positions(&vertices, &indices);
    let hull = convex_hull_vertices(&used);
    Ok(CpuModel {
        name: name.to_string(),
        vertices,
        indices,
        hull,
        aabb: ((lo - centre) / span, (hi - centre) / span),
        source_span: span,
        warnings,
    })
}

fn unique_used_positions(vertices: &[Vertex], indices: &[u32]) -> Vec<DVec3> {
    let mut seen = std::collections::HashSet::new();
    let mut out = Vec::new();
    for &i in indices {
        let p = vertices[i as usize].position;
        if seen.insert(p.map(f32::to_bits)) {
            out.push(DVec3::from(p.map(f64::from)));
        }
    }
    out
}

/// The vertices of the convex hull of `points`; if the hull is degenerate
/// (flat or collinear geometry) every point is kept, which gives the same box.
pub fn convex_hull_vertices(points: &[DVec3]) -> Vec<DVec3> {
    if points.len() <= 8 {
        return points.to_vec();
    }
    let input: Vec<Vec<f64>> = points.iter().map(|p| p.to_array().to_vec()).collect();
    match chull::ConvexHullWrapper::try_new(&input, None) {
        Ok(hull) => {
            let (vertices, _) = hull.vertices_indices();
            let out: Vec<DVec3> = vertices
                .iter()
                .filter(|v| v.len() == 3)
                .map(|v| DVec3::new(v[0], v[1], v[2]))
                .collect();
            if out.len() >= 4 { out } else { points.to_vec() }
        }
        Err(_) => points.to_vec(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
    fn strips_and_fans_triangulate() {
        use gltf::mesh::Mode;
        assert_eq!(
            triangulate(Mode::TriangleStrip, &[0, 1, 2, 3]),
            vec![[0, 1, 2], [2, 1, 3]]
        );
        assert_eq!(
            triangulate(Mode::TriangleFan, &[0, 1, 2, 3]),
            vec![[0, 1, 2], [0, 2, 3]]
        );
    }
}
