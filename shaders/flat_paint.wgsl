// The app's flat paint (src/app/flat_paint.rs): the window's background as one fill and the
// preview picture copied texel for texel, drawn in egui's render pass instead of as egui meshes.

// The fill's colour (the picture's tint), and the part of the picture shown: its
// top-left and size in 0..1 of the picture (0, 0, 1, 1: all of it; smaller: zoomed in).
struct Paint {
    colour: vec4<f32>,
    part: vec4<f32>,
};

@group(0) @binding(0) var<uniform> paint: Paint;
@group(0) @binding(1) var picture: texture_2d<f32>;

override SRGB_TARGET: bool = false;

struct Varyings {
    @builtin(position) position: vec4<f32>,
    @location(0) uv: vec2<f32>,
};

// One triangle covering the callback's viewport; uv 0..1 across it.
@vertex
fn vs_main(@builtin(vertex_index) i: u32) -> Varyings {
    let uv = vec2<f32>(f32((i << 1u) & 2u), f32(i & 2u));
    return Varyings(vec4<f32>(uv.x * 2.0 - 1.0, 1.0 - uv.y * 2.0, 0.0, 1.0), uv);
}

@fragment
fn fs_fill() -> @location(0) vec4<f32> {
    return paint.colour;
}

fn linear_from_srgb(c: vec3<f32>) -> vec3<f32> {
    return select(pow((c + 0.055) / 1.055, vec3<f32>(2.4)), c / 12.92, c < vec3<f32>(0.04045));
}

// The picture's sRGB-encoded bytes, tinted as egui tints an image (in gamma space).
@fragment
fn fs_picture(v: Varyings) -> @location(0) vec4<f32> {
    let size = textureDimensions(picture);
    let uv = paint.part.xy + v.uv * paint.part.zw;
    let texel = min(vec2<u32>(uv * vec2<f32>(size)), size - vec2<u32>(1u));
    let c = textureLoad(picture, texel, 0) * paint.colour;
    if SRGB_TARGET {
        return vec4<f32>(linear_from_srgb(c.rgb), c.a);
    }
    return c;
}
