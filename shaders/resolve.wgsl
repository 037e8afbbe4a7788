// Resolve of regions into a compact atlas (one rect per instance).
// `fs_main`: the mean of a pixel's colour samples, as a multisample resolve of
// a UNORM target computes it. `fs_ids`: a pixel's instance-id samples side by
// side (x, y, z, w = samples 0..3) in an RGBA32Float target, read back and
// reduced to per-drone visibility on the CPU. `fs_main_ids`: both at once.
// Each instance is a rect's place in the atlas, in the atlas's normalised
// device coordinates, and the whole-pixel offset from there to the rect in
// the frame, where its samples are read.

@group(0) @binding(0) var samples: texture_multisampled_2d<f32>;
@group(0) @binding(1) var id_samples: texture_multisampled_2d<f32>;

struct ResolveOut {
    @builtin(position) position: vec4<f32>,
    @location(0) @interpolate(flat) offset: vec2<f32>,
};

@vertex
fn vs_main(
    @builtin(vertex_index) i: u32,
    @location(0) rect: vec4<f32>,
    @location(1) offset: vec2<f32>,
) -> ResolveOut {
    var out: ResolveOut;
    out.position = vec4<f32>(rect_corner(rect, i), 0.0, 1.0);
    out.offset = offset;
    return out;
}

// The frame pixel an atlas fragment resolves (pixel centre + whole pixels).
fn source(in: ResolveOut) -> vec2<i32> {
    return vec2<i32>(in.position.xy + in.offset);
}

fn mean_color(p: vec2<i32>) -> vec4<f32> {
    let n = textureNumSamples(samples);
    var sum = vec4<f32>(0.0);
    for (var s = 0u; s < n; s++) {
        sum += textureLoad(samples, p, i32(s));
    }
    return sum / f32(n);
}

// The id target has four samples whenever this pass runs (MSAA 4).
fn ids_of(p: vec2<i32>) -> vec4<f32> {
    return vec4<f32>(
        textureLoad(id_samples, p, 0).r,
        textureLoad(id_samples, p, 1).r,
        textureLoad(id_samples, p, 2).r,
        textureLoad(id_samples, p, 3).r,
    );
}

@fragment
fn fs_main(in: ResolveOut) -> @location(0) vec4<f32> {
    return mean_color(source(in));
}

struct IdsOut {
    @location(1) ids: vec4<f32>,
};

@fragment
fn fs_ids(in: ResolveOut) -> IdsOut {
    return IdsOut(ids_of(source(in)));
}

struct ColorAndIds {
    @location(0) color: vec4<f32>,
    @location(1) ids: vec4<f32>,
};

@fragment
fn fs_main_ids(in: ResolveOut) -> ColorAndIds {
    let p = source(in);
    return ColorAndIds(mean_color(p), ids_of(p));
}
