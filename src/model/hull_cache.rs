//! Convex hulls kept on disk between runs, beside the levels of detail
//! ([`super::lod_cache`]: the same folder, `$SWARMSHOT_CACHE_DIR` and `off`,
//! atomic writes). The exact hull ([`super::convex_hull_vertices`], `chull`'s
//! big-integer predicates) is made every time a model loads: on the
//! 9 434-triangle Crazyflie (4 779 distinct positions, 232 hull vertices)
//! about 30 ms of one core, a tenth of a later run's start-up; reading the
//! 5 kB file back well under a millisecond.
//!
//! One `.hull` file per point set, named by its key: the BLAKE3 hash of the
//! format's magic, the crate's version and the points' bytes (everything the
//! hull is computed from). The file holds the hull's vertices in order, then
//! a BLAKE3 checksum. A file is used only when its length, checksum, magic
//! and key check out and every vertex is one of the points (or one as
//! `chull` returns it: [`hull::as_chull_returns`]); anything else is
//! ignored and computed over. A hit returns exactly the vertices the run that
//! wrote it computed (tested); which of the points lying on a face without
//! being corners `chull` keeps varies from run to run, and no label or pixel
//! depends on them (`hull.rs`), so the outputs never depend on the cache.

use std::collections::HashSet;
use std::path::Path;

use glam::DVec3;

use super::{hull, lod_cache};

/// Format of the files (bumped when the layout or the hull's recipe changes).
const MAGIC: &[u8; 8] = b"SWHUL\x00\x00\x01";

/// Below this many points the hull is the points themselves
/// ([`hull::KEPT_AS_IS`]). Every larger cloud is worth a file: `chull` takes
/// 2–3 ms of one core on a confuser's 90-point pose (a bird's wings at one
/// phase of their beat), a hit well under a tenth of that.
const MIN_POINTS_TO_CACHE: usize = hull::KEPT_AS_IS + 1;

/// The vertices of the convex hull of `points` ([`hull::convex_hull_vertices`]):
/// read from the cache folder ([`lod_cache::cache_dir`]) when a valid file
/// for them is there, else computed and written there.
pub fn cached_hull(points: &[DVec3]) -> Vec<DVec3> {
    if points.len() < MIN_POINTS_TO_CACHE {
        return hull::convex_hull_vertices(points);
    }
    cached_hull_in(lod_cache::cache_dir().as_deref(), points)
}

/// [`cached_hull`] with an explicit folder (`None`: compute, no cache).
pub fn cached_hull_in(dir: Option<&Path>, points: &[DVec3]) -> Vec<DVec3> {
    let Some(dir) = dir else {
        return hull::convex_hull_vertices(points);
    };
    let key = key(points);
    let file = dir.join(file_name(&key));
    if let Some(vertices) = read(&file, &key, points) {
        return vertices;
    }
    let vertices = hull::convex_hull_vertices(points);
    // A cache that cannot be written costs the next run the hull, nothing else.
    let _ = lod_cache::write(dir, &file, &encode(&key, &vertices));
    vertices
}

/// The file name of a key.
pub fn file_name(key: &[u8; 32]) -> String {
    lod_cache::keyed_name(key, "hull")
}

/// What the hull is computed from: the format, the crate version and the points.
pub fn key(points: &[DVec3]) -> [u8; 32] {
    let mut h = blake3::Hasher::new();
    h.update(MAGIC);
    h.update(env!("CARGO_PKG_VERSION").as_bytes());
    h.update(&(points.len() as u64).to_le_bytes());
    for p in points {
        for c in p.to_array() {
            h.update(&c.to_bits().to_le_bytes());
        }
    }
    *h.finalize().as_bytes()
}

/// The file's bytes: magic, key, vertex count, the vertices' coordinates,
/// then the BLAKE3 hash of all that.
pub fn encode(key: &[u8; 32], vertices: &[DVec3]) -> Vec<u8> {
    let mut out = Vec::with_capacity(8 + 32 + 4 + vertices.len() * 24 + 32);
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(key);
    out.extend_from_slice(&(vertices.len() as u32).to_le_bytes());
    for v in vertices {
        for c in v.to_array() {
            out.extend_from_slice(&c.to_bits().to_le_bytes());
        }
    }
    let sum = *blake3::hash(&out).as_bytes();
    out.extend_from_slice(&sum);
    out
}

/// The vertices in `bytes` when it is a valid cache file for `points` (`key`).
pub fn decode(bytes: &[u8], key: &[u8; 32], points: &[DVec3]) -> Option<Vec<DVec3>> {
    let (body, sum) = bytes.split_at_checked(bytes.len().checked_sub(32)?)?;
    if blake3::hash(body).as_bytes() != sum {
        return None;
    }
    let (head, coords) = body.split_at_checked(8 + 32 + 4)?;
    if &head[..8] != MAGIC || &head[8..40] != key {
        return None;
    }
    let n = u32::from_le_bytes(head[40..44].try_into().ok()?) as usize;
    if coords.len() != n.checked_mul(24)? || n > points.len() {
        return None;
    }
    let vertices: Vec<DVec3> = coords
        .chunks_exact(24)
        .map(|c| {
            let f = |i: usize| {
                f64::from_bits(u64::from_le_bytes(
                    c[i..i + 8].try_into().unwrap_or_default(),
                ))
            };
            DVec3::new(f(0), f(8), f(16))
        })
        .collect();
    // A vertex is one of the points, or one as `chull` returns it.
    let known: HashSet<[u64; 3]> = points
        .iter()
        .flat_map(|&p| [p, hull::as_chull_returns(p)])
        .map(|p| p.to_array().map(f64::to_bits))
        .collect();
    let ours = vertices
        .iter()
        .all(|v| known.contains(&v.to_array().map(f64::to_bits)));
    (ours && (n >= 4 || n == points.len())).then_some(vertices)
}

/// The vertices in `file` when it is a valid cache file for `points`.
fn read(file: &Path, key: &[u8; 32], points: &[DVec3]) -> Option<Vec<DVec3>> {
    // No hull has more vertices than the points: a larger file is not ours.
    let limit = 8 + 32 + 4 + points.len() as u64 * 24 + 32;
    // A regular file of at most `limit` bytes, opened without blocking (a
    // FIFO swapped in at the name neither blocks nor is read).
    let bytes = crate::input::read_input_file(file, limit).ok()?;
    decode(&bytes, key, points)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The distinct positions of a built-in model's triangles (what
    /// `finish_model` hands the hull).
    fn cloud(name: &str) -> Vec<DVec3> {
        let bytes = crate::model::builtin::glb(name).expect("built-in");
        let model = crate::model::load_bytes(bytes, None, Path::new(name), name).expect("loads");
        crate::model::unique_used_positions(&model.vertices, &model.indices)
    }

    /// Every built-in drone's and confuser's hull, written once, is read
    /// back: its file decodes to the vertices the miss computed.
    #[test]
    fn every_built_in_hull_is_read_back() {
        let dir = tempfile::tempdir().expect("temp dir");
        let models = (crate::model::builtin::NAMES.iter())
            .map(|n| (*n, crate::model::builtin::glb(n)))
            .chain(
                (crate::model::confusers::NAMES.iter())
                    .map(|n| (*n, crate::model::confusers::glb(n))),
            );
        for (name, bytes) in models {
            let bytes = bytes.expect("built-in");
            let model =
                crate::model::load_bytes(bytes, None, Path::new(name), name).expect("loads");
            let points = crate::model::unique_used_positions(&model.vertices, &model.indices);
            let first = cached_hull_in(Some(dir.path()), &points);
            let file = dir.path().join(file_name(&key(&points)));
            let bytes = std::fs::read(&file).expect("the cache file is written");
            assert_eq!(
                decode(&bytes, &key(&points), &points),
                Some(first),
                "{name}"
            );
        }
    }

    /// A miss computes the hull and writes the file; a hit reads back
    /// exactly the vertices written, without computing them again.
    #[test]
    fn a_cache_hit_gives_the_vertices_written() {
        let dir = tempfile::tempdir().expect("temp dir");
        let points = cloud("octocopter");
        assert!(
            points.len() >= MIN_POINTS_TO_CACHE,
            "{} points",
            points.len()
        );
        let first = cached_hull_in(Some(dir.path()), &points);
        assert!(
            first.len() >= 4 && first.len() < points.len(),
            "{} vertices",
            first.len()
        );
        let file = dir.path().join(file_name(&key(&points)));
        let bytes = std::fs::read(&file).expect("the cache file is written");
        assert_eq!(decode(&bytes, &key(&points), &points), Some(first.clone()));
        // A file with other (still valid) vertices is what a hit returns: it is read, not recomputed.
        let k = key(&points);
        let fewer = first[..4].to_vec();
        std::fs::write(&file, encode(&k, &fewer)).expect("write");
        assert_eq!(cached_hull_in(Some(dir.path()), &points), fewer);
        let names: Vec<String> = std::fs::read_dir(dir.path())
            .expect("list")
            .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
            .collect();
        assert_eq!(names, [file_name(&k)], "no temporary left behind");
    }

    /// A corrupted or truncated file, one with a vertex that is not one of
    /// the points, and another point set's file are ignored and computed over.
    #[test]
    fn a_corrupt_or_foreign_cache_file_is_computed_over() {
        let dir = tempfile::tempdir().expect("temp dir");
        let points = cloud("hexacopter");
        let k = key(&points);
        let file = dir.path().join(file_name(&k));
        let hull = hull::convex_hull_vertices(&points);
        let good = encode(&k, &hull);
        for at in [0, 9, 45, good.len() / 2, good.len() - 1] {
            let mut bad = good.clone();
            bad[at] ^= 0x10;
            assert_eq!(decode(&bad, &k, &points), None, "byte {at}");
        }
        assert_eq!(decode(&good[..good.len() - 24], &k, &points), None);
        assert_eq!(decode(&[], &k, &points), None);
        let mut foreign = hull.clone();
        foreign[0].x += 1.0;
        assert_eq!(decode(&encode(&k, &foreign), &k, &points), None);
        std::fs::write(&file, encode(&k, &foreign)).expect("write");
        let computed = cached_hull_in(Some(dir.path()), &points);
        assert!(computed.iter().all(|v| points.contains(v)));
        assert_eq!(
            decode(&std::fs::read(&file).expect("rewritten"), &k, &points),
            Some(computed)
        );
        // A FIFO at the name is not opened for reading (it would block): computed over.
        std::fs::remove_file(&file).expect("remove");
        rustix::fs::mknodat(
            rustix::fs::CWD,
            &file,
            rustix::fs::FileType::Fifo,
            rustix::fs::Mode::from_raw_mode(0o644),
            0,
        )
        .expect("mkfifo");
        assert_eq!(cached_hull_in(Some(dir.path()), &points).len(), hull.len());
        // A link to a file that says it is empty and is not (`/proc/self/pagemap`:
        // 256 GiB of page table) is read no further than a hull file can be long.
        if Path::new("/proc/self/pagemap").exists() {
            std::fs::remove_file(&file).expect("remove");
            std::os::unix::fs::symlink("/proc/self/pagemap", &file).expect("symlink");
            assert_eq!(cached_hull_in(Some(dir.path()), &points).len(), hull.len());
        }
        let mut moved = points.clone();
        moved[0].x += 0.5;
        assert_ne!(key(&moved), k);
        assert_eq!(decode(&good, &key(&moved), &moved), None);
    }
}
