//! Baked impostors kept on disk between runs, beside the levels of detail
//! ([`super::lod_cache`]: the same folder, `$SWARMSHOT_CACHE_DIR` and `off`,
//! atomic writes). Baking ([`super::impostor::bake`]: 128 directions × 64²
//! texels) costs a start-up 0.1–0.2 s of CPU on two cores; reading the
//! 2 MiB file back a few ms.
//!
//! One `.imp` file per model, named by its key: the BLAKE3 hash of the
//! format's magic, the crate's version, the bake's settings and everything
//! the bake reads of the model (vertex, index and draw-range bytes, and each
//! texture's size and texels). The file holds the quads' vertices and the
//! atlas's texels (directions and indices are the same for every model and
//! are not stored), then a BLAKE3 checksum. A file is used only when its
//! length, checksum, magic, key, sizes and every vertex (finite, marked as
//! an impostor quad) check out; anything else is ignored and baked over. A
//! hit returns exactly what a bake returns (tested in `tests/suite/impostors.rs`),
//! so the outputs never depend on the cache.

use std::path::Path;

use super::impostor::{self, IMPOSTOR_MARK, Impostor};
use super::{CpuModel, Vertex, lod_cache};

/// Format of the files (bumped when the layout or the bake's recipe changes).
const MAGIC: &[u8; 8] = b"SWIMP\x00\x00\x01";

/// `model`'s impostor: read from the cache folder
/// ([`lod_cache::cache_dir`]) when a valid file for it is there, else
/// baked and written there.
pub fn cached_bake(model: &CpuModel) -> Impostor {
    cached_bake_in(lod_cache::cache_dir().as_deref(), model)
}

/// [`cached_bake`] with an explicit folder (`None`: bake, no cache).
pub fn cached_bake_in(dir: Option<&Path>, model: &CpuModel) -> Impostor {
    let Some(dir) = dir else {
        return impostor::bake(model);
    };
    let key = key(model);
    let file = dir.join(file_name(&key));
    if let Some(baked) = read(&file, &key, model) {
        return baked;
    }
    let baked = impostor::bake(model);
    // A cache that cannot be written costs the next run the bake, nothing else.
    let _ = lod_cache::write(dir, &file, &encode(&key, &baked));
    baked
}

/// The file name of a key.
pub fn file_name(key: &[u8; 32]) -> String {
    lod_cache::keyed_name(key, "imp")
}

/// What the bake is computed from: the format, the crate version, the
/// bake's settings, the model's buffers and its textures.
pub fn key(model: &CpuModel) -> [u8; 32] {
    let mut h = blake3::Hasher::new();
    h.update(MAGIC);
    h.update(env!("CARGO_PKG_VERSION").as_bytes());
    h.update(impostor::settings().as_bytes());
    lod_cache::hash_geometry(&mut h, model);
    h.update(&(model.textures.len() as u64).to_le_bytes());
    for t in &model.textures {
        h.update(&t.width.to_le_bytes());
        h.update(&t.height.to_le_bytes());
        h.update(&(t.rgba8.len() as u64).to_le_bytes());
        h.update(&t.rgba8);
    }
    *h.finalize().as_bytes()
}

/// The file's bytes: magic, key, vertex count, vertices, atlas width and
/// height, atlas texels, then the BLAKE3 hash of all that.
pub fn encode(key: &[u8; 32], baked: &Impostor) -> Vec<u8> {
    let vertices: &[u8] = bytemuck::cast_slice(&baked.vertices);
    let mut out = Vec::with_capacity(56 + vertices.len() + baked.atlas.rgba8.len() + 32);
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(key);
    out.extend_from_slice(&(baked.vertices.len() as u32).to_le_bytes());
    out.extend_from_slice(vertices);
    out.extend_from_slice(&baked.atlas.width.to_le_bytes());
    out.extend_from_slice(&baked.atlas.height.to_le_bytes());
    out.extend_from_slice(&baked.atlas.rgba8);
    let sum = blake3::hash(&out);
    out.extend_from_slice(sum.as_bytes());
    out
}

/// The length of a valid file: fixed by the bake's settings.
fn file_len() -> usize {
    let (width, height) = impostor::atlas_size();
    let vertices = impostor::DIRECTIONS * 4 * std::mem::size_of::<Vertex>();
    8 + 32 + 4 + vertices + 8 + (width * height * 4) as usize + 32
}

/// The impostor in `bytes` for `model`, or `None` when anything is off.
pub fn decode(bytes: &[u8], key: &[u8; 32], model: &CpuModel) -> Option<Impostor> {
    if bytes.len() != file_len() {
        return None;
    }
    let (body, sum) = bytes.split_at_checked(bytes.len() - 32)?;
    if blake3::hash(body).as_bytes() != sum {
        return None;
    }
    let (head, rest) = body.split_at_checked(44)?;
    let count = u32::from_le_bytes(head[40..44].try_into().ok()?) as usize;
    if &head[..8] != MAGIC || &head[8..40] != key || count != impostor::DIRECTIONS * 4 {
        return None;
    }
    let (vertex_bytes, rest) = rest.split_at_checked(count * std::mem::size_of::<Vertex>())?;
    let vertices: Vec<Vertex> = bytemuck::pod_collect_to_vec(vertex_bytes);
    let (size, rgba8) = rest.split_at_checked(8)?;
    let width = u32::from_le_bytes(size[..4].try_into().ok()?);
    let height = u32::from_le_bytes(size[4..].try_into().ok()?);
    let sound = |v: &Vertex| {
        let floats: &[f32] = bytemuck::cast_slice(std::slice::from_ref(v));
        floats.iter().all(|f| f.is_finite()) && v.material[3] == IMPOSTOR_MARK
    };
    if (width, height) != impostor::atlas_size() || !vertices.iter().all(sound) {
        return None;
    }
    Some(Impostor {
        directions: impostor::directions(),
        vertices,
        indices: impostor::quad_indices(),
        atlas: impostor::atlas(model, rgba8.to_vec()),
    })
}

/// The impostor in `file` when it is a valid cache file for `model`.
fn read(file: &Path, key: &[u8; 32], model: &CpuModel) -> Option<Impostor> {
    // A regular file no longer than ours, opened without blocking (a FIFO
    // swapped in at the name neither blocks nor is read).
    let bytes = crate::input::read_input_file(file, file_len() as u64).ok()?;
    decode(&bytes, key, model)
}
