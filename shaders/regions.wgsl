// Region rendering (prepended: common.wgsl). Every frame draws only the
// screen regions its drones can touch, on full-size targets that are never
// cleared: `fs_main` "clears" a region by writing the cached
// background (one value for every sample of a pixel, as the sky pass itself
// gives: it shades once per pixel at the pixel centre), instance id 0 and
// depth 0 (far, reversed-Z); `fs_clear_ids` does the same without colour,
// for passes that only count pixels; `fs_resolve` averages a region's samples into
// the single-sample colour target, as the hardware resolve does.

// Full-resolution background (the cached sky), single-sample.
@group(0) @binding(0) var background: texture_2d<f32>;

struct RegionOut {
    @builtin(position) position: vec4<f32>,
};

// One instance per rect, in normalised device coordinates (x0, y0, x1, y1):
// two triangles whose edges lie on pixel boundaries, so they cover exactly
// the rect's pixels and samples.
@vertex
fn vs_main(@builtin(vertex_index) i: u32, @location(0) rect: vec4<f32>) -> RegionOut {
    var out: RegionOut;
    out.position = vec4<f32>(rect_corner(rect, i), 0.0, 1.0);
    return out;
}

struct BackgroundOut {
    @location(0) color: vec4<f32>,
    // The instance id (0: no drone), held in an R32Float target (exact below 2^24).
    @location(1) id: f32,
};

@fragment
fn fs_main(in: RegionOut) -> BackgroundOut {
    var out: BackgroundOut;
    out.color = textureLoad(background, vec2<i32>(in.position.xy), 0);
    out.id = 0.0;
    return out;
}

struct IdOnly {
    @location(1) id: f32,
};

// A region "cleared" in the instance-id target only (and depth, by the
// quad's far z), for passes that count pixels without drawing colour.
@fragment
fn fs_clear_ids(in: RegionOut) -> IdOnly {
    return IdOnly(0.0);
}
