// Resolve of regions (one rect per instance, as in regions.wgsl): the mean of
// a pixel's samples, as a multisample resolve of a UNORM target computes it.

@group(0) @binding(0) var samples: texture_multisampled_2d<f32>;

struct ResolveOut {
    @builtin(position) position: vec4<f32>,
};

@vertex
fn vs_main(@builtin(vertex_index) i: u32, @location(0) rect: vec4<f32>) -> ResolveOut {
    var out: ResolveOut;
    out.position = vec4<f32>(rect_corner(rect, i), 0.0, 1.0);
    return out;
}

@fragment
fn fs_main(in: ResolveOut) -> @location(0) vec4<f32> {
    let p = vec2<i32>(in.position.xy);
    let n = textureNumSamples(samples);
    var sum = vec4<f32>(0.0);
    for (var s = 0u; s < n; s++) {
        sum += textureLoad(samples, p, i32(s));
    }
    return sum / f32(n);
}
