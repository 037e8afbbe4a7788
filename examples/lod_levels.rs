//! Prints each built-in model's levels of detail (triangles, error bound; the time to build
//! the levels and to bound every one of them, on every core) and
//! the time of its exact convex hull (what `src/model/hull_cache.rs` keeps between runs).
//! Run: `cargo run --release --example lod_levels [FILE.glb ...]`.
#![allow(clippy::unwrap_used)]
use std::path::Path;
use std::time::Instant;

fn main() {
    let mut models = Vec::new();
    for name in swarmshot::model::builtin::NAMES {
        let glb = swarmshot::model::builtin::glb(name).unwrap();
        models.push(swarmshot::model::load_bytes(glb, None, Path::new(name), name).unwrap());
    }
    for file in std::env::args().skip(1) {
        models.push(swarmshot::model::load_file(Path::new(&file)).unwrap());
    }
    for m in &models {
        let t = Instant::now();
        let chain = swarmshot::model::lod::build_lods(m).unwrap();
        let built = t.elapsed().as_secs_f64() * 1e3;
        let t = Instant::now();
        chain.bound_all();
        let bounded = t.elapsed().as_secs_f64() * 1e3;
        let levels: Vec<String> = (chain.levels().iter().enumerate())
            .map(|(k, l)| format!("{} ({:.4})", l.triangle_count(), chain.error(k)))
            .collect();
        println!(
            "{}: levels built in {built:.0} ms, every bound in {bounded:.0} ms: {}",
            m.name,
            levels.join(", ")
        );
        let points = swarmshot::model::unique_used_positions(&m.vertices, &m.indices);
        let t = Instant::now();
        let hull = swarmshot::model::convex_hull_vertices(&points);
        let ms = t.elapsed().as_secs_f64() * 1e3;
        println!(
            "  hull: {} of {} positions in {ms:.1} ms",
            hull.len(),
            points.len()
        );
    }
}
