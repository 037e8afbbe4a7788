// Visibility from the multisampled instance-id target, without reading it
// back: each pixel of the listed tiles counts once for every distinct drone
// any of its samples shows (any-sample coverage: a leg that covers one MSAA
// sample colours the pixel, so it counts), and widens that drone's box.
// `SAMPLES` and `IdTexture` are substituted per sample count by the renderer.

// Per drone, 5 words: pixel count, then !x0, !y0 (kept with atomicMax so a
// zeroed buffer is the empty state), x1, y1 (exclusive).
struct Params {
    tile_offset: u32,
    tile_count: u32,
    // Word offset of this dispatch's block of per-drone stats.
    stats_base: u32,
    drones: u32,
};

@group(0) @binding(0) var ids: IdTexture;
// Tiles of at most 8×8 pixels, (x0, y0, x1, y1) exclusive, inside the regions drawn.
@group(0) @binding(1) var<storage, read> tiles: array<vec4<u32>>;
@group(0) @binding(2) var<storage, read_write> stats: array<atomic<u32>>;
@group(0) @binding(3) var<uniform> params: Params;

@compute @workgroup_size(8, 8, 1)
fn cs_main(@builtin(workgroup_id) group: vec3<u32>, @builtin(local_invocation_id) local: vec3<u32>) {
    let t = group.x + group.y * 65535u;
    if (t >= params.tile_count) {
        return;
    }
    let tile = tiles[params.tile_offset + t];
    let p = tile.xy + local.xy;
    if (p.x >= tile.z || p.y >= tile.w) {
        return;
    }
    var seen: array<u32, SAMPLES>;
    for (var s = 0u; s < SAMPLES; s++) {
        let id = u32(textureLoad(ids, vec2<i32>(p), i32(s)).r);
        seen[s] = id;
        if (id == 0u || id > params.drones) {
            continue;
        }
        var first = true;
        for (var k = 0u; k < s; k++) {
            if (seen[k] == id) {
                first = false;
            }
        }
        if (!first) {
            continue;
        }
        let base = params.stats_base + (id - 1u) * 5u;
        atomicAdd(&stats[base], 1u);
        atomicMax(&stats[base + 1u], ~p.x);
        atomicMax(&stats[base + 2u], ~p.y);
        atomicMax(&stats[base + 3u], p.x + 1u);
        atomicMax(&stats[base + 4u], p.y + 1u);
    }
}
