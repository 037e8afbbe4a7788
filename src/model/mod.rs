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
mod flatten;
mod hull;
pub mod hull_cache;
pub mod impostor;
pub mod impostor_cache;
pub mod lod;
pub mod lod_cache;
pub mod uri;

use std::collections::BTreeMap;
use std::ops::Range;
use std::path::{Path, PathBuf};

use glam::{DMat3, DMat4, DQuat, DVec3, Vec3};

use flatten::Flattener;

pub use hull::convex_hull_vertices;
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
    #[error("model {}: its scene expands to {vertices} vertices and {indices} triangle indices (each mesh as often as its nodes and instances place it), more than the {MAX_VERTICES} vertices or {MAX_INDICES} indices a model may have", file.display())]
    TooLarge {
        file: PathBuf,
        vertices: u64,
        indices: u64,
    },
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
    let size = flatten::expanded_size(&document, &buffers).unwrap_or_default();
    if size.vertices > MAX_VERTICES as u64 || size.indices > MAX_INDICES as u64 {
        return Err(ModelError::TooLarge {
            file: file.to_owned(),
            vertices: size.vertices,
            indices: size.indices,
        });
    }
    let mut builder = Flattener {
        file,
        document: &document,
        base_dir,
        policy,
        buffers: &buffers,
        vertices: Vec::with_capacity(size.vertices as usize),
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

/// Every URI of `document`'s buffers and images (`data:` ones too), each
/// with what it is and its index: buffers first, in the document's order.
fn uris(document: &gltf::Document) -> impl Iterator<Item = (&'static str, usize, &str)> {
    let buffer_uris = document.buffers().filter_map(|b| match b.source() {
        gltf::buffer::Source::Uri(uri) => Some(("buffer", b.index(), uri)),
        gltf::buffer::Source::Bin => None,
    });
    let image_uris = document.images().filter_map(|i| match i.source() {
        gltf::image::Source::Uri { uri, .. } => Some(("image", i.index(), uri)),
        gltf::image::Source::View { .. } => None,
    });
    buffer_uris.chain(image_uris)
}

/// Feed the files the model at `path` is read from to `hasher`: the
/// .gltf/.glb and each external buffer or image its URIs name, in the
/// document's order. Called for a model that has loaded, so its URIs were
/// checked against its policy; each file is read within the loader's bound.
pub fn hash_sources(
    path: &Path,
    policy: UriPolicy,
    hasher: &mut blake3::Hasher,
) -> Result<(), ModelError> {
    let io_err = |file: &Path| {
        let file = file.to_owned();
        move |source| ModelError::Io { file, source }
    };
    let bytes = crate::input::read_input_file(path, MAX_MODEL_FILE_BYTES).map_err(io_err(path))?;
    hasher.update(&(bytes.len() as u64).to_le_bytes());
    hasher.update(&bytes);
    let parse = |e: gltf::Error| ModelError::Parse {
        file: path.to_owned(),
        reason: e.to_string(),
    };
    let document = gltf::Gltf::from_slice_without_validation(&bytes)
        .map_err(parse)?
        .document;
    for (_, _, uri) in uris(&document) {
        if let Ok(uri::Target::File(file)) = uri::resolve(uri, path.parent(), policy) {
            let len = crate::input::hash_input_file(&file, MAX_MODEL_FILE_BYTES, hasher)
                .map_err(io_err(&file))?;
            hasher.update(&len.to_le_bytes());
        }
    }
    Ok(())
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
    for (what, index, uri) in uris(document) {
        let err = |problem: String| ModelError::Buffer {
            file: file.to_owned(),
            reason: format!("{what} {index} (URI \"{}\"): {problem}", short_uri(uri)),
        };
        match uri::resolve(uri, base_dir, policy).map_err(|e| err(e.to_string()))? {
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
    let cleaned = crate::text::printable(uri);
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

/// Why a texture image cannot be read (the model then draws its base colour).
#[derive(Debug, thiserror::Error)]
enum TextureError {
    #[error("{0}")]
    Gltf(#[from] gltf::Error),
    #[error("{0}")]
    Uri(#[from] uri::UriError),
    #[error("{}: {source}", path.display())]
    File {
        path: PathBuf,
        source: uri::UriError,
    },
    #[error("{0}")]
    Decode(#[from] image::ImageError),
    #[error("unsupported image pixel format")]
    PixelFormat,
}

/// An image's decoded pixels: from a buffer view or a data URI (by the glTF
/// reader), or from a file in the model's folder read with a bound and
/// decoded as the glTF reader would (the same `image` crate, the same formats).
fn image_data(
    source: gltf::image::Source<'_>,
    base_dir: Option<&Path>,
    buffers: &[gltf::buffer::Data],
    policy: UriPolicy,
) -> Result<gltf::image::Data, TextureError> {
    let gltf::image::Source::Uri { uri: u, mime_type } = source else {
        return Ok(gltf::image::Data::from_source(
            source,
            Some(Path::new(".")),
            buffers,
        )?);
    };
    let path = match uri::resolve(u, base_dir, policy)? {
        uri::Target::Data => {
            return Ok(gltf::image::Data::from_source(
                source,
                Some(Path::new(".")),
                buffers,
            )?);
        }
        uri::Target::File(path) => path,
    };
    let encoded = uri::read_bounded(&path, MAX_MODEL_FILE_BYTES)
        .map_err(|source| TextureError::File { path, source })?;
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
    let format = format.ok_or(gltf::Error::UnsupportedImageEncoding)?;
    let decoded = image::load_from_memory_with_format(&encoded, format)?;
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
        _ => return Err(TextureError::PixelFormat),
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
/// The most vertices a model's scene may expand to (8 M: 512 MB of baked
/// vertices), counted before anything is baked ([`flatten::expanded_size`]):
/// far more than a drone's mesh needs at the sizes it is drawn (a scanned
/// airframe has 1–2 M), and few enough that the baked model, its hull and
/// its levels of detail fit in memory.
const MAX_VERTICES: usize = 8_000_000;
/// The most triangle indices a model's scene may expand to (16 M triangles).
const MAX_INDICES: usize = 48_000_000;

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
    let hull = hull_cache::cached_hull(&used);
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

/// Each position the triangles `indices` use, once, in first-use order:
/// what a model's convex hull is made of.
pub fn unique_used_positions(vertices: &[Vertex], indices: &[u32]) -> Vec<DVec3> {
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

#[cfg(test)]
mod tests {
    use super::*;

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
