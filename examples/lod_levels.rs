//! Prints each built-in model's levels of detail (triangles, error bound, build time) and
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
        let lods = swarmshot::model::lod::build_lods(m).unwrap();
        let ms = t.elapsed().as_secs_f64() * 1e3;
        let levels: Vec<String> = lods
            .iter()
            .map(|l| format!("{} ({:.4})", l.triangle_count(), l.error))
            .collect();
        println!("{}: built in {ms:.0} ms: {}", m.name, levels.join(", "));
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
