// Resolve of regions (one rect per instance, as in regions.wgsl).
// `fs_main`: the mean of a pixel's colour samples, as a multisample resolve of
// a UNORM target computes it. `fs_ids`: a pixel's instance-id samples side by
// side (x, y, z, w = samples 0..3) in an RGBA32Float target, read back and
// reduced to per-drone visibility on the CPU. `fs_main_ids`: both at once.

@group(0) @binding(0) var samples: texture_multisampled_2d<f32>;
@group(0) @binding(1) var id_samples: texture_multisampled_2d<f32>;

struct ResolveOut {
    @builtin(position) position: vec4<f32>,
};

@vertex
fn vs_main(@builtin(vertex_index) i: u32, @location(0) rect: vec4<f32>) -> ResolveOut {
    var out: ResolveOut;
    out.position = vec4<f32>(rect_corner(rect, i), 0.0, 1.0);
    return out;
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
    return mean_color(vec2<i32>(in.position.xy));
}

struct IdsOut {
    @location(1) ids: vec4<f32>,
};

@fragment
fn fs_ids(in: ResolveOut) -> IdsOut {
    return IdsOut(ids_of(vec2<i32>(in.position.xy)));
}

struct ColorAndIds {
    @location(0) color: vec4<f32>,
    @location(1) ids: vec4<f32>,
};

@fragment
fn fs_main_ids(in: ResolveOut) -> ColorAndIds {
    let p = vec2<i32>(in.position.xy);
    return ColorAndIds(mean_color(p), ids_of(p));
}
