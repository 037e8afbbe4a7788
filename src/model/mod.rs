//! CPU-side models: glTF import into a plain mesh, normalisation to a unit
//! span, and the convex hull the labeller projects.
//!
//! glTF files (.gltf with .bin or data URIs, .glb) are flattened: every mesh
//! instance of the default scene is baked with the product of its parents'
//! node transforms (negative scale flips the winding), base colour factors and
//! vertex colours are baked per vertex, and the result is centred on its
//! bounding-box centre and scaled so that its largest span is 1. A placed
//! drone is then `translate · rotate · scale(size_m)` of this model.
//!
//! Materials: base colour factor × vertex colour is baked per vertex, the
//! base colour texture (PNG/JPEG, with its sampler's wrap modes and
//! `KHR_texture_transform` baked into the UVs) is kept per draw range, and
//! metallic/roughness factors, `KHR_materials_unlit` and the alpha cutoff of
//! `MASK` materials travel per vertex. Triangles are grouped by texture so a
//! model costs one draw call per distinct texture. `EXT_mesh_gpu_instancing`
//! nodes are expanded into copies. Points and lines are skipped with a warning;
//! a texture that cannot be decoded is dropped with a warning (the factor
//! colour remains). Everything else that is wrong is a typed [`ModelError`]
//! naming the file — never a panic, never a silently empty model.

pub mod builtin;
pub mod confusers;
pub mod lod;
pub mod uri;

use std::collections::BTreeMap;
use std::ops::Range;
use std::path::{Path, PathBuf};

use glam::{DMat3, DMat4, DQuat, DVec3, Vec3};

pub use uri::UriPolicy;

/// One vertex as the GPU sees it (`shaders/drone.wgsl`, `VertexInput`).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct Vertex {
    pub position: [f32; 3],
    pub normal: [f32; 3],
    /// Linear RGBA base colour (material factor × vertex colour).
    pub color: [f32; 4],
    /// Base colour texture coordinates (`KHR_texture_transform` applied).
    pub uv: [f32; 2],
    /// Metallic factor, roughness factor, unlit (0 or 1), alpha cutoff (0: opaque;
    /// −1: glTF `alphaMode: BLEND`, drawn translucent by its alpha, see `DrawRange::alpha_blend`).
    pub material: [f32; 4],
}

/// How a texture repeats outside [0, 1] (the glTF sampler's wrapS / wrapT).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WrapMode {
    Repeat,
    MirroredRepeat,
    ClampToEdge,
}

/// A decoded base colour texture: sRGB-encoded RGBA8, at most [`MAX_TEXTURE_SIDE`] a side.
#[derive(Clone, Debug)]
pub struct CpuTexture {
    pub name: String,
    pub width: u32,
    pub height: u32,
    pub rgba8: Vec<u8>,
    /// (u, v) wrap modes.
    pub wrap: [WrapMode; 2],
}

/// A run of indices drawn with one texture (`None`: untextured) and one
/// kind of surface.
#[derive(Clone, Debug, PartialEq)]
pub struct DrawRange {
    pub indices: Range<u32>,
    pub texture: Option<usize>,
    /// glTF `doubleSided`: back faces are drawn (with flipped normals).
    /// Otherwise they are culled, as the glTF specification asks.
    pub double_sided: bool,
    /// glTF `alphaMode: MASK`: fragments below the cutoff are discarded.
    /// Draws without it use a pipeline with no discard (early depth test).
    pub alpha_mask: bool,
    /// Holds glTF `alphaMode: BLEND` triangles (vertex `material[3]` = −1): drawn
    /// with a pipeline that turns their alpha into MSAA coverage (`shaders/drone.wgsl`,
    /// `coverage_mask`). Such triangles share ranges with opaque ones (the ranges and
    /// so the levels of detail are those of the opaque model).
    pub alpha_blend: bool,
}

/// `Vertex::material[3]` of glTF `alphaMode: BLEND` materials.
pub const BLEND_MARK: f32 = -1.0;

/// Textures are downscaled to this side: drones are small in the frame, so
/// larger textures only cost memory.
pub const MAX_TEXTURE_SIDE: u32 = 1024;

/// A model ready to upload and to label: unit largest span, centred at the origin.
#[derive(Clone, Debug)]
pub struct CpuModel {
    pub name: String,
    pub vertices: Vec<Vertex>,
    /// Triangle list, counter-clockwise front faces, grouped by texture.
    pub indices: Vec<u32>,
    /// The index ranges and the texture each is drawn with; they cover `indices`.
    pub draws: Vec<DrawRange>,
    /// Base colour textures referenced by `draws`.
    pub textures: Vec<CpuTexture>,
    /// Convex hull vertices (normalised model space); projecting these gives the same box as projecting every vertex.
    pub hull: Vec<DVec3>,
    /// Normalised bounding box, min and max.
    pub aabb: (DVec3, DVec3),
    /// Largest span of the file's geometry, in the file's units.
    pub source_span: f64,
    /// What was skipped while loading (points, lines, undecodable textures…).
    pub warnings: Vec<String>,
}

impl CpuModel {
    /// Number of triangles.
    pub fn triangle_count(&self) -> usize {
        self.indices.len() / 3
    }
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
    #[error("model {}: the glTF reader failed on malformed data ({reason})", file.display())]
    Malformed { file: PathBuf, reason: String },
    #[error("model {}: the file has {nodes} nodes, more than the limit of {limit} node instances a model may draw", file.display())]
    TooManyNodes {
        file: PathBuf,
        nodes: usize,
        limit: usize,
    },
    #[error("model {}: the node graph expands to more than {limit} node instances (reached at node {node}); nodes shared by several parents form a DAG, and glTF node hierarchies must be trees", file.display())]
    NodeGraph {
        file: PathBuf,
        node: usize,
        limit: usize,
    },
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

/// The largest model file (and each external buffer or image it names) read.
pub const MAX_MODEL_FILE_BYTES: u64 = 512 << 20;

/// Load a .gltf or .glb file from disk: a regular file of at most
/// [`MAX_MODEL_FILE_BYTES`] (FIFOs and devices are refused unopened).
pub fn load_file(path: &Path) -> Result<CpuModel, ModelError> {
    load_file_with(path, UriPolicy::default())
}

/// [`load_file`] with a policy for the files its URIs may name.
pub fn load_file_with(path: &Path, policy: UriPolicy) -> Result<CpuModel, ModelError> {
    let bytes = crate::input::read_input_file(path, MAX_MODEL_FILE_BYTES).map_err(|source| {
        ModelError::Io {
            file: path.to_owned(),
            source,
        }
    })?;
    let name = path
        .file_stem()
        .map_or_else(|| "model".into(), |s| s.to_string_lossy().into_owned());
    load_bytes_with(&bytes, path.parent(), path, &name, policy)
}

/// Load glTF from bytes; `base_dir` resolves external buffers and images,
/// `file` names the source in errors.
pub fn load_bytes(
    bytes: &[u8],
    base_dir: Option<&Path>,
    file: &Path,
    name: &str,
) -> Result<CpuModel, ModelError> {
    load_bytes_with(bytes, base_dir, file, name, UriPolicy::default())
}

/// [`load_bytes`] with a policy for the files its URIs may name.
pub fn load_bytes_with(
    bytes: &[u8],
    base_dir: Option<&Path>,
    file: &Path,
    name: &str,
    policy: UriPolicy,
) -> Result<CpuModel, ModelError> {
    // The gltf crate indexes buffers with values it has not bounds-checked in a
    // few places (image buffer views, sparse indices); a panic there must not
    // take the generator down, so it becomes a typed error like any other.
    // The panic's text names the gltf crate's internals, not the file's
    // problem, so it is not shown; the binary's panic hook stays quiet while
    // [`in_guarded_load`] holds.
    let was = GUARDED.with(|g| g.replace(true));
    let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        load_bytes_inner(bytes, base_dir, file, name, policy)
    }));
    GUARDED.with(|g| g.set(was));
    result.unwrap_or_else(|_| {
        Err(ModelError::Malformed {
            file: file.to_owned(),
            reason: "a panic inside the gltf crate: an accessor, buffer view or image points outside its data".into(),
        })
    })
}

thread_local! {
    static GUARDED: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

/// Whether this thread is inside a glTF load whose panics become
/// [`ModelError::Malformed`] (a panic hook stays quiet for those).
pub fn in_guarded_load() -> bool {
    GUARDED.with(std::cell::Cell::get)
}

fn load_bytes_inner(
    bytes: &[u8],
    base_dir: Option<&Path>,
    file: &Path,
    name: &str,
    policy: UriPolicy,
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
    check_external_files(&document, base_dir, file, policy)?;
    let buffers = load_buffers(&document, base_dir, blob, file, policy)?;
    let mut builder = Flattener {
        file,
        document: &document,
        base_dir,
        policy,
        buffers: &buffers,
        vertices: Vec::new(),
        buckets: BTreeMap::new(),
        textures: Vec::new(),
        texture_slots: BTreeMap::new(),
        warnings: Vec::new(),
        visits: 0,
        parents: parents(&document),
    };
    let scene = document
        .default_scene()
        .or_else(|| document.scenes().next());
    match scene {
        Some(scene) => {
            for node in scene.nodes() {
                builder.node(&node, DMat4::IDENTITY, 0)?;
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
        buckets,
        textures,
        warnings,
        ..
    } = builder;
    // Group triangles by texture and surface: one draw call per distinct pair.
    let mut indices = Vec::new();
    let mut draws = Vec::new();
    for ((texture, double_sided, alpha_mask), ix) in buckets {
        let alpha_blend = ix.iter().any(|&i| {
            vertices
                .get(i as usize)
                .is_some_and(|v| v.material[3] < 0.0)
        });
        let start = indices.len() as u32;
        indices.extend(ix);
        draws.push(DrawRange {
            indices: start..indices.len() as u32,
            texture,
            double_sided,
            alpha_mask,
            alpha_blend,
        });
    }
    draws.retain(|d| !d.indices.is_empty());
    finish(name, vertices, indices, draws, textures, warnings, file)
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

/// Each node's parent: the first node that lists it as a child.
fn parents(document: &gltf::Document) -> Vec<Option<usize>> {
    let mut parents = vec![None; document.nodes().len()];
    for node in document.nodes() {
        for child in node.children() {
            if let Some(slot) = parents.get_mut(child.index())
                && slot.is_none()
                && child.index() != node.index()
            {
                *slot = Some(node.index());
            }
        }
    }
    parents
}

/// Every buffer and image a .gltf names by a file URI must lie in the
/// model's folder (unless `policy` allows more) and be a regular file of at
/// most [`MAX_MODEL_FILE_BYTES`], checked before anything is read (a URI
/// naming a FIFO or `/dev/zero` would block or grow without end).
fn check_external_files(
    document: &gltf::Document,
    base_dir: Option<&Path>,
    file: &Path,
    policy: UriPolicy,
) -> Result<(), ModelError> {
    let buffer_uris = document.buffers().filter_map(|b| match b.source() {
        gltf::buffer::Source::Uri(uri) => Some(("buffer", b.index(), uri)),
        gltf::buffer::Source::Bin => None,
    });
    let image_uris = document.images().filter_map(|i| match i.source() {
        gltf::image::Source::Uri { uri, .. } => Some(("image", i.index(), uri)),
        gltf::image::Source::View { .. } => None,
    });
    for (what, index, uri) in buffer_uris.chain(image_uris) {
        let err = |problem: String| ModelError::Buffer {
            file: file.to_owned(),
            reason: format!("{what} {index} (URI \"{}\"): {problem}", short_uri(uri)),
        };
        match uri::resolve(uri, base_dir, policy).map_err(err)? {
            uri::Target::Data => {}
            uri::Target::File(path) => {
                if path.exists() {
                    uri::open_regular(&path, MAX_MODEL_FILE_BYTES)
                        .map_err(|e| err(format!("{}: {e}", path.display())))?;
                }
                // A missing file is reported when the buffer is read, naming it.
            }
        }
    }
    Ok(())
}

/// A URI for a message: data URIs and very long ones cut short.
fn short_uri(uri: &str) -> String {
    const MAX_CHARS: usize = 120;
    if uri.starts_with("data:") {
        return "data:…".into();
    }
    let cleaned = crate::preset::printable(uri);
    if cleaned.chars().count() > MAX_CHARS {
        format!("{}…", cleaned.chars().take(MAX_CHARS).collect::<String>())
    } else {
        cleaned
    }
}

/// Every buffer's bytes: the GLB's binary chunk, a data URI (decoded by the
/// glTF reader), or a file in the model's folder read up to its `byteLength`.
fn load_buffers(
    document: &gltf::Document,
    base_dir: Option<&Path>,
    mut blob: Option<Vec<u8>>,
    file: &Path,
    policy: UriPolicy,
) -> Result<Vec<gltf::buffer::Data>, ModelError> {
    let mut out = Vec::with_capacity(document.buffers().len());
    for buffer in document.buffers() {
        let err = |reason: String| ModelError::Buffer {
            file: file.to_owned(),
            reason,
        };
        let mut data = match buffer.source() {
            gltf::buffer::Source::Uri(u) => match uri::resolve(u, base_dir, policy) {
                Ok(uri::Target::File(path)) => {
                    let length = buffer.length() as u64;
                    if length > MAX_MODEL_FILE_BYTES {
                        return Err(err(format!(
                            "buffer {} declares {length} bytes, more than the {MAX_MODEL_FILE_BYTES}-byte limit",
                            buffer.index()
                        )));
                    }
                    uri::read_bounded(&path, length).map_err(|e| {
                        err(format!(
                            "buffer {} (URI \"{}\"): {}: {e}",
                            buffer.index(),
                            short_uri(u),
                            path.display()
                        ))
                    })?
                }
                Ok(uri::Target::Data) => {
                    gltf::buffer::Data::from_source(buffer.source(), None)
                        .map_err(|e| err(buffer_reason(document, e)))?
                        .0
                }
                Err(problem) => {
                    return Err(err(format!(
                        "buffer {} (URI \"{}\"): {problem}",
                        buffer.index(),
                        short_uri(u)
                    )));
                }
            },
            gltf::buffer::Source::Bin => blob
                .take()
                .ok_or_else(|| err(buffer_reason(document, gltf::Error::MissingBlob)))?,
        };
        // The reader pads every buffer to a multiple of four bytes.
        while data.len() % 4 != 0 {
            data.push(0);
        }
        if data.len() < buffer.length() {
            return Err(err(buffer_reason(
                document,
                gltf::Error::BufferLength {
                    buffer: buffer.index(),
                    expected: buffer.length(),
                    actual: data.len(),
                },
            )));
        }
        out.push(gltf::buffer::Data(data));
    }
    Ok(out)
}

/// An image's decoded pixels: from a buffer view or a data URI (by the glTF
/// reader), or from a file in the model's folder read with a bound and
/// decoded as the glTF reader would (the same `image` crate, the same formats).
fn image_data(
    source: gltf::image::Source<'_>,
    base_dir: Option<&Path>,
    buffers: &[gltf::buffer::Data],
    policy: UriPolicy,
) -> Result<gltf::image::Data, String> {
    let gltf::image::Source::Uri { uri: u, mime_type } = source else {
        return gltf::image::Data::from_source(source, Some(Path::new(".")), buffers)
            .map_err(|e| e.to_string());
    };
    let path = match uri::resolve(u, base_dir, policy)? {
        uri::Target::Data => {
            return gltf::image::Data::from_source(source, Some(Path::new(".")), buffers)
                .map_err(|e| e.to_string());
        }
        uri::Target::File(path) => path,
    };
    let encoded = uri::read_bounded(&path, MAX_MODEL_FILE_BYTES)
        .map_err(|e| format!("{}: {e}", path.display()))?;
    use image::ImageFormat::{Jpeg, Png};
    let format = match mime_type {
        Some("image/png") => Some(Png),
        Some("image/jpeg") => Some(Jpeg),
        Some(_) => None,
        None => match u.rsplit('.').next() {
            Some("png") => Some(Png),
            Some("jpg" | "jpeg") => Some(Jpeg),
            _ => None,
        },
    };
    let format = format.ok_or_else(|| gltf::Error::UnsupportedImageEncoding.to_string())?;
    let decoded =
        image::load_from_memory_with_format(&encoded, format).map_err(|e| e.to_string())?;
    // As `gltf::image::Data::new` does.
    use gltf::image::Format;
    use image::DynamicImage as D;
    let format = match &decoded {
        D::ImageLuma8(_) => Format::R8,
        D::ImageLumaA8(_) => Format::R8G8,
        D::ImageRgb8(_) => Format::R8G8B8,
        D::ImageRgba8(_) => Format::R8G8B8A8,
        D::ImageLuma16(_) => Format::R16,
        D::ImageLumaA16(_) => Format::R16G16,
        D::ImageRgb16(_) => Format::R16G16B16,
        D::ImageRgba16(_) => Format::R16G16B16A16,
        D::ImageRgb32F(_) => Format::R32G32B32FLOAT,
        D::ImageRgba32F(_) => Format::R32G32B32A32FLOAT,
        _ => return Err("unsupported image pixel format".into()),
    };
    let (width, height) = (decoded.width(), decoded.height());
    Ok(gltf::image::Data {
        pixels: decoded.into_bytes(),
        format,
        width,
        height,
    })
}

/// `%20` and friends in a relative URI, as the glTF reader decodes them.
fn percent_decode(uri: &str) -> String {
    let bytes = uri.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%'
            && let Some(v) = uri
                .get(i + 1..i + 3)
                .and_then(|h| u8::from_str_radix(h, 16).ok())
        {
            out.push(v);
            i += 3;
            continue;
        }
        out.push(bytes[i]);
        i += 1;
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// Node hierarchies deeper than this are refused (a cycle, or hostile input).
const MAX_NODE_DEPTH: usize = 256;
/// Node instances visited while flattening the scene. glTF requires the
/// nodes to form trees, but a file whose nodes share children (a DAG) would
/// expand exponentially with depth: it is refused once this many are visited.
pub const MAX_NODE_VISITS: usize = 100_000;
/// Expanded geometry beyond this many vertices is refused rather than exhausting memory.
const MAX_VERTICES: usize = 50_000_000;

struct Flattener<'a> {
    file: &'a Path,
    document: &'a gltf::Document,
    base_dir: Option<&'a Path>,
    policy: UriPolicy,
    buffers: &'a [gltf::buffer::Data],
    vertices: Vec<Vertex>,
    /// Triangle indices per texture slot.
    /// Triangle indices per (texture, double-sided, alpha mask).
    buckets: BTreeMap<(Option<usize>, bool, bool), Vec<u32>>,
    textures: Vec<CpuTexture>,
    /// (image, sampler) → slot in `textures` (None: could not be decoded).
    texture_slots: BTreeMap<(usize, Option<usize>), Option<usize>>,
    warnings: Vec<String>,
    /// Node instances visited so far (bounded by [`MAX_NODE_VISITS`]).
    visits: usize,
    /// Each node's parent (the first node listing it as a child), for joint world matrices.
    parents: Vec<Option<usize>>,
}

/// `"name" (#3)` or `#3`, for messages.
fn node_label(node: &gltf::Node<'_>) -> String {
    match node.name() {
        Some(name) => format!("\"{name}\" (#{})", node.index()),
        None => format!("#{}", node.index()),
    }
}

impl Flattener<'_> {
    fn node(
        &mut self,
        node: &gltf::Node<'_>,
        parent: DMat4,
        depth: usize,
    ) -> Result<(), ModelError> {
        if depth > MAX_NODE_DEPTH {
            return Err(ModelError::Malformed {
                file: self.file.to_owned(),
                reason: format!("node hierarchy deeper than {MAX_NODE_DEPTH} (a cycle?)"),
            });
        }
        self.visits += 1;
        if self.visits > MAX_NODE_VISITS {
            let nodes = self.document.nodes().len();
            if nodes > MAX_NODE_VISITS {
                // Many nodes, not a graph that expands: say so.
                return Err(ModelError::TooManyNodes {
                    file: self.file.to_owned(),
                    nodes,
                    limit: MAX_NODE_VISITS,
                });
            }
            return Err(ModelError::NodeGraph {
                file: self.file.to_owned(),
                node: node.index(),
                limit: MAX_NODE_VISITS,
            });
        }
        let local = DMat4::from_cols_array_2d(&node.transform().matrix().map(|c| c.map(f64::from)));
        let world = parent * local;
        if let (Some(mesh), Some(skin)) = (node.mesh(), node.skin()) {
            let joints = self.skin_matrices(node, &skin)?;
            let label = node_label(node);
            self.skinned_mesh(&mesh, world, Some((joints.as_slice(), label.as_str())))?;
        } else if let Some(mesh) = node.mesh() {
            match self.gpu_instances(node)? {
                Some(instances) => {
                    for instance in instances {
                        self.mesh(&mesh, world * instance)?;
                    }
                }
                None => self.mesh(&mesh, world)?,
            }
        }
        for child in node.children() {
            self.node(&child, world, depth + 1)?;
        }
        Ok(())
    }

    /// The per-instance transforms of an `EXT_mesh_gpu_instancing` node, if it has them.
    fn gpu_instances(&mut self, node: &gltf::Node<'_>) -> Result<Option<Vec<DMat4>>, ModelError> {
        let Some(attributes) = node
            .extension_value("EXT_mesh_gpu_instancing")
            .and_then(|e| e.get("attributes"))
            .and_then(|a| a.as_object())
        else {
            return Ok(None);
        };
        let (file, document, buffers) = (self.file, self.document, self.buffers);
        let err = |reason: String| ModelError::Malformed {
            file: file.to_owned(),
            reason: format!("EXT_mesh_gpu_instancing on node {}: {reason}", node.index()),
        };
        let get = |b: gltf::Buffer<'_>| buffers.get(b.index()).map(|d| &d.0[..]);
        let read = |semantic: &str,
                    dims: gltf::accessor::Dimensions|
         -> Result<Option<Vec<[f32; 4]>>, ModelError> {
            let Some(i) = attributes.get(semantic).and_then(serde_json::Value::as_u64) else {
                return Ok(None);
            };
            let a = document
                .accessors()
                .nth(i as usize)
                .ok_or_else(|| err(format!("{semantic} accessor {i} does not exist")))?;
            if a.data_type() != gltf::accessor::DataType::F32 || a.dimensions() != dims {
                return Err(err(format!("{semantic} must be a float {dims:?} accessor")));
            }
            let out = if dims == gltf::accessor::Dimensions::Vec4 {
                gltf::accessor::Iter::<[f32; 4]>::new(a, get).map(Iterator::collect)
            } else {
                gltf::accessor::Iter::<[f32; 3]>::new(a, get)
                    .map(|it| it.map(|[x, y, z]| [x, y, z, 0.0]).collect())
            };
            out.map(Some)
                .ok_or_else(|| err(format!("{semantic} data is missing")))
        };
        let translations = read("TRANSLATION", gltf::accessor::Dimensions::Vec3)?;
        let rotations = read("ROTATION", gltf::accessor::Dimensions::Vec4)?;
        let scales = read("SCALE", gltf::accessor::Dimensions::Vec3)?;
        let count = [&translations, &rotations, &scales]
            .iter()
            .filter_map(|v| v.as_ref().map(Vec::len))
            .max();
        let Some(count) = count else { return Ok(None) };
        let at = |v: &Option<Vec<[f32; 4]>>, i: usize| {
            v.as_ref().and_then(|v| v.get(i)).map(|x| x.map(f64::from))
        };
        let instances = (0..count)
            .map(|i| {
                let t = at(&translations, i).map_or(DVec3::ZERO, |t| DVec3::new(t[0], t[1], t[2]));
                let r =
                    at(&rotations, i).map_or(DQuat::IDENTITY, |r| DQuat::from_array(r).normalize());
                let s = at(&scales, i).map_or(DVec3::ONE, |s| DVec3::new(s[0], s[1], s[2]));
                DMat4::from_scale_rotation_translation(s, r, t)
            })
            .collect();
        Ok(Some(instances))
    }

    /// The texture slot of a glTF texture, decoding it on first use.
    fn texture_slot(&mut self, texture: &gltf::Texture<'_>) -> Option<usize> {
        let image = texture.source();
        let key = (image.index(), texture.sampler().index());
        if let Some(slot) = self.texture_slots.get(&key) {
            return *slot;
        }
        let label = image
            .name()
            .or(texture.name())
            .map_or_else(|| format!("image #{}", image.index()), str::to_string);
        let slot = match image_data(image.source(), self.base_dir, self.buffers, self.policy) {
            Ok(data) => {
                match to_rgba8(&data) {
                    Some(rgba) => {
                        let sampler = texture.sampler();
                        let wrap = |w: gltf::texture::WrappingMode| match w {
                            gltf::texture::WrappingMode::Repeat => WrapMode::Repeat,
                            gltf::texture::WrappingMode::MirroredRepeat => WrapMode::MirroredRepeat,
                            gltf::texture::WrappingMode::ClampToEdge => WrapMode::ClampToEdge,
                        };
                        let (width, height, rgba8) = limit_size(data.width, data.height, rgba);
                        self.textures.push(CpuTexture {
                            name: label,
                            width,
                            height,
                            rgba8,
                            wrap: [wrap(sampler.wrap_s()), wrap(sampler.wrap_t())],
                        });
                        Some(self.textures.len() - 1)
                    }
                    None => {
                        self.warnings.push(format!("texture {label}: unsupported pixel format {:?}; base colour factor used", data.format));
                        None
                    }
                }
            }
            Err(e) => {
                self.warnings.push(format!(
                    "texture {label} cannot be decoded ({e}); base colour factor used"
                ));
                None
            }
        };
        self.texture_slots.insert(key, slot);
        slot
    }

    fn mesh(&mut self, mesh: &gltf::Mesh<'_>, world: DMat4) -> Result<(), ModelError> {
        self.skinned_mesh(mesh, world, None)
    }

    /// The joint matrices `world(joint) · inverseBind(joint)` of a node's
    /// skin: the pose the file's node transforms put the skeleton in.
    fn skin_matrices(
        &mut self,
        node: &gltf::Node<'_>,
        skin: &gltf::Skin<'_>,
    ) -> Result<Vec<DMat4>, ModelError> {
        let (file, buffers) = (self.file, self.buffers);
        let err = |reason: String| ModelError::Malformed {
            file: file.to_owned(),
            reason: format!("node {} skin {}: {reason}", node_label(node), skin.index()),
        };
        let joints: Vec<usize> = skin.joints().map(|j| j.index()).collect();
        let inverse_bind: Vec<DMat4> = match skin.inverse_bind_matrices() {
            Some(accessor) => {
                check_accessor(&accessor, "inverseBindMatrices", buffers).map_err(&err)?;
                skin.reader(|b| buffers.get(b.index()).map(|d| &d.0[..]))
                    .read_inverse_bind_matrices()
                    .ok_or_else(|| err("inverse bind matrices cannot be read".into()))?
                    .map(|m| DMat4::from_cols_array_2d(&m.map(|c| c.map(f64::from))))
                    .collect()
            }
            None => vec![DMat4::IDENTITY; joints.len()],
        };
        if inverse_bind.len() < joints.len() {
            return Err(err(format!(
                "{} inverse bind matrices for {} joints",
                inverse_bind.len(),
                joints.len()
            )));
        }
        joints
            .iter()
            .zip(&inverse_bind)
            .map(|(&joint, ibm)| Ok(self.node_world(joint).map_err(&err)? * *ibm))
            .collect()
    }

    /// A node's world matrix: the product of its ancestors' transforms (the
    /// first parent that lists it, for a file that breaks the tree rule).
    fn node_world(&self, index: usize) -> Result<DMat4, String> {
        let mut m = DMat4::IDENTITY;
        let mut at = Some(index);
        let mut depth = 0;
        while let Some(i) = at {
            depth += 1;
            if depth > MAX_NODE_DEPTH {
                return Err(format!(
                    "joint node {index} has more than {MAX_NODE_DEPTH} ancestors (a cycle?)"
                ));
            }
            let node = self
                .document
                .nodes()
                .nth(i)
                .ok_or_else(|| format!("joint node {i} does not exist"))?;
            let local =
                DMat4::from_cols_array_2d(&node.transform().matrix().map(|c| c.map(f64::from)));
            m = local * m;
            at = self.parents.get(i).copied().flatten();
        }
        Ok(m)
    }

    /// Bake one mesh instance: with `skin` (joint matrices), each vertex is
    /// moved by its weighted joints, as glTF skinning asks (the node's own
    /// transform is then not used); without, by `world`.
    fn skinned_mesh(
        &mut self,
        mesh: &gltf::Mesh<'_>,
        world: DMat4,
        skin: Option<(&[DMat4], &str)>,
    ) -> Result<(), ModelError> {
        let mesh_name = mesh
            .name()
            .map_or_else(|| format!("#{}", mesh.index()), str::to_string);
        let normal_matrix = DMat3::from_mat4(world).inverse().transpose();
        let mut flips = DMat3::from_mat4(world).determinant() < 0.0;
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
            for (semantic, accessor) in primitive.attributes() {
                check_accessor(&accessor, &semantic.to_string(), buffers).map_err(&err)?;
                // Positions and normals are read as float triples only.
                use gltf::accessor::{DataType, Dimensions};
                if matches!(
                    semantic,
                    gltf::Semantic::Positions | gltf::Semantic::Normals
                ) && (accessor.data_type() != DataType::F32
                    || accessor.dimensions() != Dimensions::Vec3)
                {
                    return Err(err(format!(
                        "accessor {} ({}) must be float VEC3, not {:?} {:?}",
                        accessor.index(),
                        semantic.to_string(),
                        accessor.data_type(),
                        accessor.dimensions()
                    )));
                }
            }
            if let Some(accessor) = primitive.indices() {
                check_accessor(&accessor, "indices", buffers).map_err(&err)?;
            }
            let reader = primitive.reader(|b| buffers.get(b.index()).map(|d| &d.0[..]));
            let positions: Vec<[f32; 3]> = reader
                .read_positions()
                .ok_or_else(|| err("no POSITION attribute".into()))?
                .collect();
            if positions.is_empty() {
                continue;
            }
            if self.vertices.len() + positions.len() > MAX_VERTICES {
                return Err(err(format!(
                    "more than {MAX_VERTICES} vertices after expanding instances"
                )));
            }
            let normals: Option<Vec<[f32; 3]>> = reader.read_normals().map(Iterator::collect);
            let colors: Option<Vec<[f32; 4]>> =
                reader.read_colors(0).map(|c| c.into_rgba_f32().collect());
            let material = primitive.material();
            let pbr = material.pbr_metallic_roughness();
            let factor = pbr.base_color_factor();
            let cutoff = match material.alpha_mode() {
                gltf::material::AlphaMode::Mask => material.alpha_cutoff().unwrap_or(0.5).max(1e-6),
                gltf::material::AlphaMode::Blend => BLEND_MARK,
                gltf::material::AlphaMode::Opaque => 0.0,
            };
            let material_params = [
                pbr.metallic_factor(),
                pbr.roughness_factor(),
                if material.unlit() { 1.0 } else { 0.0 },
                cutoff,
            ];
            // Base colour texture: its UV set (possibly overridden by the transform) and the transform itself.
            let mut texture = None;
            let mut uvs: Option<Vec<[f32; 2]>> = None;
            if let Some(info) = pbr.base_color_texture() {
                let transform = info.texture_transform();
                let set = transform
                    .as_ref()
                    .and_then(|t| t.tex_coord())
                    .unwrap_or(info.tex_coord());
                match reader.read_tex_coords(set) {
                    Some(tc) => {
                        let mut coords: Vec<[f32; 2]> = tc.into_f32().collect();
                        if let Some(t) = &transform {
                            let m = uv_transform(t.offset(), t.rotation(), t.scale());
                            for uv in &mut coords {
                                *uv = m(*uv);
                            }
                        }
                        texture = self.texture_slot(&info.texture());
                        uvs = Some(coords);
                    }
                    None => self.warnings.push(format!("mesh \"{mesh_name}\" primitive {p}: base colour texture uses TEXCOORD_{set}, which is missing; texture skipped")),
                }
            }
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
            let n = positions.len();
            if normals.as_ref().is_some_and(|v| v.len() != n)
                || colors.as_ref().is_some_and(|v| v.len() != n)
                || uvs.as_ref().is_some_and(|v| v.len() != n)
            {
                return Err(err("attribute counts differ from the POSITION count".into()));
            }
            // Per-vertex skinning matrices: Σ weight · joint matrix.
            let skinning: Option<Vec<DMat4>> = match skin {
                Some((joint_matrices, node)) => {
                    match (reader.read_joints(0), reader.read_weights(0)) {
                        (Some(joints), Some(weights)) => {
                            let joints: Vec<[u16; 4]> = joints.into_u16().collect();
                            let weights: Vec<[f32; 4]> = weights.into_f32().collect();
                            if joints.len() != n || weights.len() != n {
                                return Err(err(
                                    "JOINTS_0/WEIGHTS_0 counts differ from the POSITION count"
                                        .into(),
                                ));
                            }
                            let mut out = Vec::with_capacity(n);
                            for (j, w) in joints.iter().zip(&weights) {
                                let mut m = DMat4::ZERO;
                                let mut total = 0.0;
                                for (&joint, &weight) in j.iter().zip(w) {
                                    if weight == 0.0 {
                                        continue;
                                    }
                                    let jm = joint_matrices.get(usize::from(joint)).ok_or_else(|| {
                                        err(format!("node {node}: joint {joint} is out of range for its skin's {} joints", joint_matrices.len()))
                                    })?;
                                    m += *jm * f64::from(weight);
                                    total += f64::from(weight);
                                }
                                out.push(if total > 0.0 {
                                    m * (1.0 / total)
                                } else {
                                    world
                                });
                            }
                            if let Some(first) = out.first() {
                                flips = DMat3::from_mat4(*first).determinant() < 0.0;
                            }
                            Some(out)
                        }
                        _ => {
                            self.warnings.push(format!("node {node}: mesh \"{mesh_name}\" primitive {p} has a skin but no JOINTS_0/WEIGHTS_0; drawn with the node's transform"));
                            None
                        }
                    }
                }
                None => None,
            };
            let triangles = triangulate(mode, &raw_indices);
            let base = self.vertices.len() as u32;
            for (i, pos) in positions.iter().enumerate() {
                let (m, nm) = match &skinning {
                    Some(s) => (s[i], DMat3::from_mat4(s[i]).inverse().transpose()),
                    None => (world, normal_matrix),
                };
                let p = m.transform_point3(DVec3::from(pos.map(f64::from)));
                let n = normals
                    .as_ref()
                    .map(|n| (nm * DVec3::from(n[i].map(f64::from))).normalize_or_zero())
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
                    uv: uvs.as_ref().map_or([0.0; 2], |u| u[i]),
                    material: material_params,
                });
            }
            let bucket = self
                .buckets
                .entry((texture, material.double_sided(), cutoff > 0.0))
                .or_default();
            let start = bucket.len();
            for [a, b, c] in triangles {
                let tri = if flips { [a, c, b] } else { [a, b, c] };
                bucket.extend(tri.map(|i| base + i));
            }
            if normals.is_none() {
                compute_normals(&mut self.vertices[base as usize..], &bucket[start..], base);
            }
        }
        Ok(())
    }
}

/// The KHR_texture_transform matrix `translation · rotation · scale` as a function on UVs.
///
/// glTF's UV space has v pointing down, and `rotation` turns the UVs
/// counter-clockwise *as seen in that space*: (1, 0) goes to (0, −1) for a
/// quarter turn. The rotation matrix is therefore `[cos sin; −sin cos]`
/// (rows), the transpose of the GLSL listing in the extension's README, which
/// is counter-clockwise only in a v-up space (KhronosGroup/glTF#1563; the
/// sample viewer, three.js, Babylon.js and Blender all use this one).
pub fn uv_transform(
    offset: [f32; 2],
    rotation: f32,
    scale: [f32; 2],
) -> impl Fn([f32; 2]) -> [f32; 2] {
    let (sin, cos) = rotation.sin_cos();
    move |[u, v]| {
        let (su, sv) = (u * scale[0], v * scale[1]);
        [
            cos * su + sin * sv + offset[0],
            -sin * su + cos * sv + offset[1],
        ]
    }
}

/// A named error if `accessor` (used as `semantic`) reads past the end of
/// its buffer view, or its view past the end of its buffer's data. The glTF
/// reader answers such an accessor with "no data", which would otherwise
/// read as a missing attribute.
fn check_accessor(
    accessor: &gltf::Accessor<'_>,
    semantic: &str,
    buffers: &[gltf::buffer::Data],
) -> Result<(), String> {
    let index = accessor.index();
    let out = |what: String| format!("accessor {index} ({semantic}) is out of bounds: {what}");
    let view_fits = |view: &gltf::buffer::View<'_>| -> Result<usize, String> {
        let data = buffers.get(view.buffer().index()).map_or(0, |d| d.0.len());
        let end = view.offset().checked_add(view.length());
        if end.is_none_or(|end| end > data) {
            return Err(out(format!(
                "its buffer view {} spans bytes {}..{} of buffer {}, which holds {data} bytes",
                view.index(),
                view.offset(),
                end.map_or_else(|| "overflow".into(), |e| e.to_string()),
                view.buffer().index()
            )));
        }
        Ok(view.length())
    };
    let count = accessor.count();
    if let Some(view) = accessor.view() {
        let length = view_fits(&view)?;
        let size = accessor.size();
        let stride = view.stride().unwrap_or(size);
        let end = count
            .checked_sub(1)
            .and_then(|n| n.checked_mul(stride))
            .and_then(|n| n.checked_add(size))
            .and_then(|n| n.checked_add(accessor.offset()));
        if count > 0 && end.is_none_or(|end| end > length) {
            return Err(out(format!(
                "{count} elements of {size} bytes (stride {stride}) from byte {} need {} bytes of buffer view {}, which has {length}",
                accessor.offset(),
                end.map_or_else(|| "more than 2⁶⁴".into(), |e| e.to_string()),
                view.index()
            )));
        }
    }
    if let Some(sparse) = accessor.sparse() {
        let n = sparse.count();
        let indices = sparse.indices();
        let values = sparse.values();
        let parts = [
            (
                "sparse indices",
                indices.view(),
                indices.offset(),
                indices.index_type().size(),
            ),
            (
                "sparse values",
                values.view(),
                values.offset(),
                accessor.size(),
            ),
        ];
        for (what, view, offset, size) in parts {
            let length = view_fits(&view)?;
            let end = n.checked_mul(size).and_then(|b| b.checked_add(offset));
            if end.is_none_or(|end| end > length) {
                return Err(out(format!(
                    "{what}: {n} × {size} bytes from byte {offset} overrun buffer view {} ({length} bytes)",
                    view.index()
                )));
            }
        }
        if n > count {
            return Err(format!(
                "accessor {index} ({semantic}) has {n} sparse entries for {count} elements"
            ));
        }
        // Each sparse index names an element to replace: it must be below the count.
        let view = indices.view();
        let data = buffers
            .get(view.buffer().index())
            .map_or(&[][..], |d| &d.0[..]);
        let size = indices.index_type().size();
        let start = view.offset() + indices.offset();
        for k in 0..n {
            let at = start + k * size;
            let Some(bytes) = data.get(at..at + size) else {
                break;
            };
            let value = bytes
                .iter()
                .rev()
                .fold(0u64, |v, &b| (v << 8) | u64::from(b));
            if value >= count as u64 {
                return Err(format!(
                    "accessor {index} ({semantic}): sparse index {value} (entry {k}) is out of range for {count} elements"
                ));
            }
        }
    }
    Ok(())
}

/// Any decoded glTF image as RGBA8 (16-bit channels keep their high byte).
fn to_rgba8(data: &gltf::image::Data) -> Option<Vec<u8>> {
    use gltf::image::Format;
    let px = &data.pixels;
    let f32_to_u8 = |c: &[u8]| {
        (f32::from_le_bytes([c[0], c[1], c[2], c[3]]).clamp(0.0, 1.0) * 255.0).round() as u8
    };
    let out: Vec<u8> = match data.format {
        Format::R8 => px.iter().flat_map(|&r| [r, r, r, 255]).collect(),
        Format::R8G8 => px
            .chunks_exact(2)
            .flat_map(|c| [c[0], c[0], c[0], c[1]])
            .collect(),
        Format::R8G8B8 => px
            .chunks_exact(3)
            .flat_map(|c| [c[0], c[1], c[2], 255])
            .collect(),
        Format::R8G8B8A8 => px.clone(),
        Format::R16 => px
            .chunks_exact(2)
            .flat_map(|c| [c[1], c[1], c[1], 255])
            .collect(),
        Format::R16G16 => px
            .chunks_exact(4)
            .flat_map(|c| [c[1], c[1], c[1], c[3]])
            .collect(),
        Format::R16G16B16 => px
            .chunks_exact(6)
            .flat_map(|c| [c[1], c[3], c[5], 255])
            .collect(),
        Format::R16G16B16A16 => px
            .chunks_exact(8)
            .flat_map(|c| [c[1], c[3], c[5], c[7]])
            .collect(),
        Format::R32G32B32FLOAT => px
            .chunks_exact(12)
            .flat_map(|c| {
                [
                    f32_to_u8(&c[0..4]),
                    f32_to_u8(&c[4..8]),
                    f32_to_u8(&c[8..12]),
                    255,
                ]
            })
            .collect(),
        Format::R32G32B32A32FLOAT => px
            .chunks_exact(16)
            .flat_map(|c| {
                [
                    f32_to_u8(&c[0..4]),
                    f32_to_u8(&c[4..8]),
                    f32_to_u8(&c[8..12]),
                    f32_to_u8(&c[12..16]),
                ]
            })
            .collect(),
    };
    (out.len() == data.width as usize * data.height as usize * 4 && !out.is_empty()).then_some(out)
}

/// Downscale to at most [`MAX_TEXTURE_SIDE`] a side.
fn limit_size(width: u32, height: u32, rgba: Vec<u8>) -> (u32, u32, Vec<u8>) {
    let side = width.max(height);
    if side <= MAX_TEXTURE_SIDE {
        return (width, height, rgba);
    }
    let scale = f64::from(MAX_TEXTURE_SIDE) / f64::from(side);
    let (w, h) = (
        ((f64::from(width) * scale).round() as u32).max(1),
        ((f64::from(height) * scale).round() as u32).max(1),
    );
    match image::RgbaImage::from_raw(width, height, rgba) {
        Some(img) => (
            w,
            h,
            image::imageops::resize(&img, w, h, image::imageops::FilterType::Triangle).into_raw(),
        ),
        None => (1, 1, vec![255; 4]),
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
    draws: Vec<DrawRange>,
    textures: Vec<CpuTexture>,
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
        if !p.is_finite() {
            return Err(ModelError::Degenerate {
                file: file.to_owned(),
                span: f64::NAN,
            });
        }
        lo = lo.min(p);
        hi = hi.max(p);
    }
    let span = (hi - lo).max_element();
    if !(span.is_finite() && span > 0.0 && lo.is_finite() && hi.is_finite()) {
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
        draws,
        textures,
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
