// Near-field scenery (prepended: rect.wgsl). Drawn over a region pass's
// rects after the drones: each pixel's scenery from the CPU-rasterised
// layer (colour, and in alpha the bit mask of the samples it covers), at
// its depth (reversed-Z: near / z), id 0. The sample mask limits the write
// to the covered samples and the depth test (greater: nearer) to those where
// the scenery is in front of the drone, so the id samples the visibility
// tally reads lose exactly the hidden drone samples.

@group(0) @binding(0) var layer_color: texture_2d<f32>;
@group(0) @binding(1) var layer_depth: texture_2d<f32>;

struct RegionOut {
    @builtin(position) position: vec4<f32>,
};

@vertex
fn vs_main(@builtin(vertex_index) i: u32, @location(0) rect: vec4<f32>) -> RegionOut {
    var out: RegionOut;
    out.position = vec4<f32>(rect_corner(rect, i), 0.0, 1.0);
    return out;
}

struct SceneryOut {
    @location(0) color: vec4<f32>,
    @location(1) id: f32,
    @builtin(frag_depth) depth: f32,
    @builtin(sample_mask) mask: u32,
};

struct SceneryIds {
    @location(1) id: f32,
    @builtin(frag_depth) depth: f32,
    @builtin(sample_mask) mask: u32,
};

fn layer_mask(c: vec4<f32>) -> u32 {
    return u32(round(c.a * 255.0));
}

@fragment
fn fs_main(in: RegionOut) -> SceneryOut {
    let p = vec2<i32>(in.position.xy);
    let c = textureLoad(layer_color, p, 0);
    let mask = layer_mask(c);
    if mask == 0u {
        discard;
    }
    return SceneryOut(vec4<f32>(c.rgb, 1.0), 0.0, textureLoad(layer_depth, p, 0).r, mask);
}

@fragment
fn fs_ids(in: RegionOut) -> SceneryIds {
    let p = vec2<i32>(in.position.xy);
    let mask = layer_mask(textureLoad(layer_color, p, 0));
    if mask == 0u {
        discard;
    }
    return SceneryIds(0.0, textureLoad(layer_depth, p, 0).r, mask);
}
