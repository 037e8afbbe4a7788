//! The levels of detail of a model and the error bounds found so far, kept
//! on disk between runs: building the levels ([`super::lod::build_lods`],
//! meshoptimizer) costs a preset with a detailed glTF model about 75 ms of
//! CPU at start-up (9 434 triangles), their sampled Hausdorff bounds about
//! 230 ms more when every one is needed, reading them back a few ms. The
//! file is written when the levels are built and again after each pick
//! that found new bounds ([`LodChain::on_bound`]), so a later run finds
//! what the runs before it needed.
//!
//! The cache folder is `$SWARMSHOT_CACHE_DIR/lod` when that variable is
//! set (empty or `off`: no cache at all, nothing read or written), else
//! `lod` in swarmshot's folder of the user's cache folder (`dirs::cache_dir`:
//! `~/.cache/swarmshot` on Linux, `~/Library/Caches/swarmshot` on macOS,
//! `%LOCALAPPDATA%\swarmshot` on Windows). One file per model, named by its
//! key: the BLAKE3 hash of the crate's version, the simplifier's settings
//! and the model's vertex, index and draw-range bytes (everything the
//! levels are computed from), so a changed model, setting or swarmshot
//! version never meets an old file.
//!
//! Files are written atomically (a temporary file in the folder, then a
//! rename) and read defensively: the magic, the key, the length and a
//! BLAKE3 checksum of the contents must match, and every level must be
//! whole triangles of in-range indices and draw ranges of the model, each
//! coarser than the one before, each bound in the range a model's bounds
//! fall in (from the sampling's slack to a few spans) or not yet found; a file
//! failing any check is ignored and rebuilt over. The cache never changes
//! the levels: a hit returns exactly what a build returns, and the bounds a
//! build finds (tested), so the outputs are the same with or without it.
//! Failing to write (read-only home, full disk) only costs the next run the
//! build.
//!
//! The same folder holds the baked impostors ([`super::impostor_cache`],
//! `.imp` files), with the same rules.

use std::path::{Path, PathBuf};

use super::lod::{self, Lod, LodChain, LodError};
use super::{CpuModel, DrawRange};

/// The variable that moves the cache folder (or turns it off: empty or `off`).
pub const CACHE_ENV: &str = "SWARMSHOT_CACHE_DIR";

/// Format of the files (bumped when the layout or the levels' recipe changes).
const MAGIC: &[u8; 8] = b"SWLOD\x00\x00\x02";

/// The model's levels of detail: read from the cache folder when a valid
/// file for this model is there, else built and written there; bounds
/// found later are written there too.
pub fn cached_lods(model: &CpuModel) -> Result<LodChain, LodError> {
    cached_lods_in(cache_dir().as_deref(), model)
}

/// [`cached_lods`] with an explicit folder (`None`: build, no cache).
pub fn cached_lods_in(dir: Option<&Path>, model: &CpuModel) -> Result<LodChain, LodError> {
    let Some(dir) = dir else {
        return lod::build_lods(model);
    };
    let key = key(model);
    let file = dir.join(file_name(&key));
    let chain = match read(&file, &key, model) {
        Some((levels, errors)) => LodChain::new(levels, &errors, lod::positions(model)),
        None => {
            let chain = lod::build_lods(model)?;
            // A cache that cannot be written costs the next run the build, nothing else.
            let _ = write(dir, &file, &encode(&key, &chain, &model.draws));
            chain
        }
    };
    let (dir, draws) = (dir.to_owned(), model.draws.clone());
    chain.on_bound(Box::new(move |chain| {
        let _ = write(&dir, &file, &encode(&key, chain, &draws));
    }));
    Ok(chain)
}

/// The cache folder, from [`CACHE_ENV`] or the user's cache folder.
pub fn cache_dir() -> Option<PathBuf> {
    match std::env::var_os(CACHE_ENV) {
        Some(v) if v.is_empty() || v == "off" => None,
        Some(v) => Some(PathBuf::from(v).join("lod")),
        None => dirs::cache_dir().map(|d| d.join("swarmshot").join("lod")),
    }
}

/// The file name of a key.
pub fn file_name(key: &[u8; 32]) -> String {
    keyed_name(key, "lod")
}

/// A cache file's name: its key in hex, then `.ext` (the levels', hulls' and impostors' files).
pub(super) fn keyed_name(key: &[u8; 32], ext: &str) -> String {
    let hex: String = key.iter().map(|b| format!("{b:02x}")).collect();
    format!("{hex}.{ext}")
}

/// What the levels are computed from: the crate version, the simplifier's
/// settings and the model's buffers.
pub fn key(model: &CpuModel) -> [u8; 32] {
    let mut h = blake3::Hasher::new();
    h.update(MAGIC);
    h.update(env!("CARGO_PKG_VERSION").as_bytes());
    h.update(lod::settings().as_bytes());
    hash_geometry(&mut h, model);
    *h.finalize().as_bytes()
}

/// Feed `model`'s vertex, index and draw-range bytes to `h` (the part of a
/// cache key that names the model; [`super::impostor_cache`] shares it).
pub(super) fn hash_geometry(h: &mut blake3::Hasher, model: &CpuModel) {
    h.update(&(model.vertices.len() as u64).to_le_bytes());
    h.update(bytemuck::cast_slice(&model.vertices));
    h.update(&(model.indices.len() as u64).to_le_bytes());
    h.update(bytemuck::cast_slice(&model.indices));
    h.update(&(model.draws.len() as u64).to_le_bytes());
    for d in &model.draws {
        h.update(&d.indices.start.to_le_bytes());
        h.update(&d.indices.end.to_le_bytes());
        h.update(&d.texture.map_or(u64::MAX, |t| t as u64).to_le_bytes());
        h.update(&[
            u8::from(d.double_sided),
            u8::from(d.alpha_mask),
            u8::from(d.alpha_blend),
        ]);
    }
}

/// The file's bytes: magic, key, the levels after level 0 (each: error
/// bound, NaN when not found yet, index count, indices, draw count, draws
/// as (source draw, start, end)), then the BLAKE3 hash of all that.
/// `draws` are the model's.
pub fn encode(key: &[u8; 32], chain: &LodChain, draws: &[DrawRange]) -> Vec<u8> {
    let mut out = Vec::new();
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(key);
    let errors = chain.known_errors();
    let rest = chain.levels().iter().zip(&errors).skip(1);
    out.extend_from_slice(&(rest.len() as u32).to_le_bytes());
    for (l, error) in rest {
        // A bound that failed to compute (infinite) is looked for again.
        let error = error.filter(|e| e.is_finite()).unwrap_or(f32::NAN);
        out.extend_from_slice(&error.to_le_bytes());
        out.extend_from_slice(&(l.indices.len() as u32).to_le_bytes());
        out.extend_from_slice(bytemuck::cast_slice(&l.indices));
        out.extend_from_slice(&(l.draws.len() as u32).to_le_bytes());
        for d in &l.draws {
            // The model's draw range this one simplifies (same texture and flags).
            let source = draws
                .iter()
                .position(|m| same_look(m, d))
                .unwrap_or(usize::MAX);
            out.extend_from_slice(&(source as u32).to_le_bytes());
            out.extend_from_slice(&d.indices.start.to_le_bytes());
            out.extend_from_slice(&d.indices.end.to_le_bytes());
        }
    }
    let sum = blake3::hash(&out);
    out.extend_from_slice(sum.as_bytes());
    out
}

fn same_look(a: &DrawRange, b: &DrawRange) -> bool {
    a.texture == b.texture
        && a.double_sided == b.double_sided
        && a.alpha_mask == b.alpha_mask
        && a.alpha_blend == b.alpha_blend
}

/// The levels in `bytes` for `model` and their bounds found so far, or
/// `None` when anything is off.
pub fn decode(
    bytes: &[u8],
    key: &[u8; 32],
    model: &CpuModel,
) -> Option<(Vec<Lod>, Vec<Option<f32>>)> {
    let (body, sum) = bytes.split_at_checked(bytes.len().checked_sub(32)?)?;
    if blake3::hash(body).as_bytes() != sum {
        return None;
    }
    let mut r = Reader(body);
    if r.take(8)? != MAGIC || r.take(32)? != key {
        return None;
    }
    let mut lods = vec![Lod {
        indices: model.indices.clone(),
        draws: model.draws.clone(),
    }];
    let mut errors = vec![Some(0.0)];
    for _ in 0..r.u32()? {
        let error = f32::from_le_bytes(r.take(4)?.try_into().ok()?);
        let n = r.u32()? as usize;
        let indices: Vec<u32> = r
            .take(n.checked_mul(4)?)?
            .chunks_exact(4)
            .map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect();
        let mut draws = Vec::new();
        for _ in 0..r.u32()? {
            let source = model.draws.get(r.u32()? as usize)?;
            let (start, end) = (r.u32()?, r.u32()?);
            draws.push(DrawRange {
                indices: start..end,
                ..source.clone()
            });
        }
        let level = Lod { indices, draws };
        let error = (!error.is_nan()).then_some(error);
        if !plausible(&level, error, model, lods.last()?) || lods.len() > lod::MAX_CANDIDATES {
            return None;
        }
        lods.push(level);
        errors.push(error);
    }
    r.0.is_empty().then_some((lods, errors))
}

/// A level read back is whole triangles of in-range indices, its draw
/// ranges tile its indices in order, it is coarser than the level before,
/// and its bound, when found, lies in the range every bound of a model does.
fn plausible(level: &Lod, error: Option<f32>, model: &CpuModel, finer: &Lod) -> bool {
    let vertices = model.vertices.len();
    let mut at = 0u32;
    let tiles = level.draws.iter().all(|d| {
        let ok = d.indices.start == at && d.indices.end >= d.indices.start;
        at = d.indices.end;
        ok && (d.indices.end - d.indices.start).is_multiple_of(3)
    });
    tiles
        && at as usize == level.indices.len()
        && level.indices.iter().all(|&i| (i as usize) < vertices)
        && error.is_none_or(lod::plausible_error)
        && level.triangle_count() < finer.triangle_count()
}

/// Cursor over a file's bytes.
struct Reader<'a>(&'a [u8]);

impl<'a> Reader<'a> {
    fn take(&mut self, n: usize) -> Option<&'a [u8]> {
        let (head, tail) = self.0.split_at_checked(n)?;
        self.0 = tail;
        Some(head)
    }
    fn u32(&mut self) -> Option<u32> {
        Some(u32::from_le_bytes(self.take(4)?.try_into().ok()?))
    }
}

/// The levels and bounds in `file` when it is a valid cache file for `model`.
fn read(file: &Path, key: &[u8; 32], model: &CpuModel) -> Option<(Vec<Lod>, Vec<Option<f32>>)> {
    // No level has more indices or draws than the model: a larger file is not ours.
    let per_level = model.indices.len() as u64 * 4 + model.draws.len() as u64 * 12 + 12;
    let limit = 1024 + lod::MAX_CANDIDATES as u64 * per_level;
    // A regular file of at most `limit` bytes, opened without blocking (a
    // FIFO swapped in at the name neither blocks nor is read).
    let bytes = crate::input::read_input_file(file, limit).ok()?;
    decode(&bytes, key, model)
}

/// Write `bytes` to `file` in `dir`: a temporary file beside it, then a rename.
pub(super) fn write(dir: &Path, file: &Path, bytes: &[u8]) -> std::io::Result<()> {
    use std::io::Write;
    std::fs::create_dir_all(dir)?;
    let name = file.file_name().unwrap_or_default().to_string_lossy();
    // Unique per process and write: two threads caching the same model
    // never share (or remove) one temporary file.
    static WRITES: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
    let n = WRITES.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let tmp = dir.join(format!(".{name}.{}.{n}.tmp", std::process::id()));
    let result = std::fs::File::create_new(&tmp)
        .and_then(|mut f| f.write_all(bytes).and_then(|()| f.sync_all()))
        .and_then(|()| std::fs::rename(&tmp, file));
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    remove_stale_temporaries(dir, &name);
    result
}

/// A temporary file this old is a killed write's (a write takes milliseconds).
const STALE: std::time::Duration = std::time::Duration::from_secs(600);

/// Remove the temporary files of `name` ([`write`]'s `.NAME.PID.N.tmp`)
/// that a process killed between creating and renaming them left, once
/// they are [`STALE`]: regular files only, nothing else in the folder.
fn remove_stale_temporaries(dir: &Path, name: &str) {
    let prefix = format!(".{name}.");
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for entry in entries.flatten().take(10_000) {
        let file_name = entry.file_name();
        let Some(n) = file_name.to_str() else {
            continue;
        };
        let stale = entry
            .metadata()
            .ok()
            .filter(|m| m.is_file())
            .is_some_and(|m| {
                m.modified()
                    .ok()
                    .and_then(|t| t.elapsed().ok())
                    .is_some_and(|age| age > STALE)
            });
        if n.starts_with(&prefix) && n.ends_with(".tmp") && stale {
            let _ = std::fs::remove_file(entry.path());
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::builtin::{NAMES, glb};

    fn builtin(name: &str) -> CpuModel {
        let bytes = glb(name).expect("built-in");
        crate::model::load_bytes(bytes, None, Path::new(name), name).expect("loads")
    }

    /// What a chain holds: its levels and the bounds found so far.
    fn state(chain: &LodChain) -> (Vec<Lod>, Vec<Option<f32>>) {
        (chain.levels().to_vec(), chain.known_errors())
    }

    /// A miss builds and writes the file; the file then gives exactly the
    /// built levels and bounds (read alone, without building), for every
    /// built-in; bounds a pick finds are written back and read by the next run.
    #[test]
    fn a_cache_hit_gives_the_built_levels_and_the_bounds_found() {
        let dir = tempfile::tempdir().expect("temp dir");
        let mut levels = 0;
        for name in NAMES {
            let model = builtin(name);
            let built = lod::build_lods(&model).expect("builds");
            levels += built.levels().len() - 1;
            let first = cached_lods_in(Some(dir.path()), &model).expect("first run");
            assert_eq!(state(&first), state(&built), "{name}");
            let file = dir.path().join(file_name(&key(&model)));
            let read_back = |what: &str| {
                let bytes = std::fs::read(&file).expect("the cache file is written");
                decode(&bytes, &key(&model), &model).unwrap_or_else(|| panic!("{name}: {what}"))
            };
            assert_eq!(read_back("built"), state(&built), "{name}");
            // A near drone's pick bounds every level: written back.
            first.pick(1e6, 0.5);
            built.bound_all();
            assert!(built.known_errors().iter().all(Option::is_some));
            assert_eq!(read_back("bounded"), state(&built), "{name}");
            let hit = cached_lods_in(Some(dir.path()), &model).expect("hit");
            assert_eq!(state(&hit), state(&built), "{name}");
        }
        assert!(levels > NAMES.len(), "simplified levels to cache: {levels}");
        // Only the cache files, no temporary left behind.
        let names: Vec<String> = std::fs::read_dir(dir.path())
            .expect("list")
            .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
            .collect();
        assert_eq!(names.len(), NAMES.len(), "{names:?}");
        assert!(
            names
                .iter()
                .all(|n| n.ends_with(".lod") && !n.starts_with('.'))
        );
    }

    /// A temporary file a killed write left is removed by a later write
    /// of the same file once it is old; a fresh one, another file's and
    /// anything not named like one stay.
    #[test]
    fn a_killed_writes_temporary_file_is_removed_once_stale() {
        let dir = tempfile::tempdir().expect("temp dir");
        let file = dir.path().join("ab.lod");
        let old = std::time::SystemTime::now() - 2 * STALE;
        let place = |n: &str, stale: bool| {
            let path = dir.path().join(n);
            std::fs::write(&path, b"partial").expect("write");
            if stale {
                let f = std::fs::File::options()
                    .write(true)
                    .open(&path)
                    .expect("open");
                f.set_modified(old).expect("age it");
            }
            path
        };
        let killed = place(".ab.lod.4242.0.tmp", true);
        let fresh = place(".ab.lod.4243.0.tmp", false);
        let other = place(".cd.lod.4242.0.tmp", true);
        let user = place("ab.lod.notes", true);
        write(dir.path(), &file, b"levels").expect("write");
        assert_eq!(std::fs::read(&file).expect("written"), b"levels");
        assert!(!killed.exists());
        assert!(fresh.exists() && other.exists() && user.exists());
    }

    /// A corrupted, truncated or foreign file is ignored and rebuilt over;
    /// a changed model has another key.
    #[test]
    fn a_corrupt_cache_file_is_rebuilt() {
        let dir = tempfile::tempdir().expect("temp dir");
        let model = builtin(NAMES[0]);
        let built = lod::build_lods(&model).expect("builds");
        assert!(built.levels().len() > 2, "{} levels", built.levels().len());
        let k = key(&model);
        let file = dir.path().join(file_name(&k));
        let good = encode(&k, &built, &model.draws);
        assert_eq!(decode(&good, &k, &model), Some(state(&built)));
        // A flipped byte anywhere fails the checksum (or the magic / key).
        for at in [0, 9, 45, good.len() / 2, good.len() - 1] {
            let mut bad = good.clone();
            bad[at] ^= 0x10;
            assert_eq!(decode(&bad, &k, &model), None, "byte {at}");
            std::fs::write(&file, &bad).expect("write");
            let rebuilt = cached_lods_in(Some(dir.path()), &model).expect("rebuilt");
            assert_eq!(state(&rebuilt), state(&built));
            assert_eq!(std::fs::read(&file).expect("rewritten"), good, "byte {at}");
        }
        // Truncated, empty, and well-formed files whose indices leave the
        // model or whose bound is not positive.
        assert_eq!(decode(&good[..good.len() - 40], &k, &model), None);
        assert_eq!(decode(&[], &k, &model), None);
        let (mut levels, errors) = state(&built);
        levels[1].indices[0] = model.vertices.len() as u32;
        let foreign = LodChain::new(levels, &errors, Vec::new());
        assert_eq!(
            decode(&encode(&k, &foreign, &model.draws), &k, &model),
            None
        );
        std::fs::write(&file, encode(&k, &foreign, &model.draws)).expect("write");
        let rebuilt = cached_lods_in(Some(dir.path()), &model).expect("rebuilt");
        assert_eq!(state(&rebuilt), state(&built));
        let (levels, mut errors) = state(&built);
        errors[1] = Some(-1.0);
        let negative = LodChain::new(levels, &errors, Vec::new());
        assert_eq!(
            decode(&encode(&k, &negative, &model.draws), &k, &model),
            None
        );
        // Another key (another model) does not read this file.
        let mut moved = model.clone();
        moved.vertices[0].position[0] += 0.5;
        assert_ne!(key(&moved), k);
        assert_eq!(decode(&good, &key(&moved), &moved), None);
    }
}
