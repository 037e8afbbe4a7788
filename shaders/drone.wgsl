// Instanced, lit drone meshes. Instances carry camera_from_model (computed in
// f64 on the CPU, so large world coordinates never reach the GPU).

struct VertexInput {
    @location(0) position: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) color: vec4<f32>,
    @location(8) uv: vec2<f32>,
    // metallic, roughness, unlit (0/1), alpha cutoff (0: opaque; -1: glTF BLEND;
    // -2: an impostor's quad, its alpha coverage as BLEND's, src/model/impostor.rs)
    @location(9) material: vec4<f32>,
};

// The draw range's base colour texture (1×1 white when untextured).
// Whether this pipeline draws alpha-masked materials. Pipelines for the
// others set it false: a shader without `discard` lets the depth test run
// before shading.
override ALPHA_MASK: bool = true;
// Whether this pipeline draws textured ranges; the others skip the fetch of
// the 1×1 white texture (a product with exactly 1.0: the same colour).
override TEXTURED: bool = true;
// Samples per pixel of the target (the `_blend` entries' coverage masks).
override SAMPLES: f32 = 4.0;

@group(1) @binding(0) var base_color_texture: texture_2d<f32>;
@group(1) @binding(1) var base_color_sampler: sampler;

struct Instance {
    @location(3) c0: vec4<f32>,
    @location(4) c1: vec4<f32>,
    @location(5) c2: vec4<f32>,
    @location(6) c3: vec4<f32>,
    // Drone index + 1 (0 is the background in the id target).
    @location(7) id: u32,
    // Air light towards the drone (rgb); w: 1 when set, else the frame's horizon.
    @location(10) air: vec4<f32>,
    // Drawn base colour (rgb); w: 1 when the drone has a drawn look.
    @location(11) look: vec4<f32>,
    // Drawn metalness, roughness, emission factor, rotor opacity (BLEND triangles' alpha factor).
    @location(12) look_material: vec4<f32>,
};

struct VsOut {
    @builtin(position) position: vec4<f32>,
    @location(0) normal_cam: vec3<f32>,
    @location(1) color: vec4<f32>,
    @location(2) uv: vec2<f32>,
    // Constant over a primitive (a glTF material): not interpolated.
    @location(3) @interpolate(flat) material: vec4<f32>,
    @location(4) position_cam: vec3<f32>,
    @location(5) @interpolate(flat) id: u32,
    @location(6) @interpolate(flat) air: vec4<f32>,
    @location(7) @interpolate(flat) look: vec4<f32>,
    @location(8) @interpolate(flat) look_material: vec4<f32>,
};

@vertex
fn vs_main(v: VertexInput, inst: Instance) -> VsOut {
    let camera_from_model = mat4x4<f32>(inst.c0, inst.c1, inst.c2, inst.c3);
    let p_cam = camera_from_model * vec4<f32>(v.position, 1.0);
    var out: VsOut;
    out.position = frame.clip_from_camera * p_cam;
    // Rotation × uniform scale: the matrix itself transforms normals.
    out.normal_cam = (camera_from_model * vec4<f32>(v.normal, 0.0)).xyz;
    out.color = v.color;
    out.uv = v.uv;
    out.material = v.material;
    out.position_cam = p_cam.xyz;
    out.id = inst.id;
    out.air = inst.air;
    out.look = inst.look;
    out.look_material = inst.look_material;
    return out;
}

const PI: f32 = 3.14159265;

@fragment
fn fs_main(in: VsOut, @builtin(front_facing) front: bool) -> @location(0) vec4<f32> {
    return shade(in, front);
}

struct ColorAndId {
    @location(0) color: vec4<f32>,
    // The instance id as f32 (exact below 2^24) in an R32Float target, which
    // WebGPU multisamples everywhere (R32Uint it does not).
    @location(1) id: f32,
};

// Colour and instance id from one fragment: the id target follows the colour
// pass's samples and alpha-cutoff discards by construction.
@fragment
fn fs_ids(in: VsOut, @builtin(front_facing) front: bool) -> ColorAndId {
    var out: ColorAndId;
    out.color = shade(in, front);
    out.id = f32(in.id);
    return out;
}

struct IdOnly {
    @location(1) id: f32,
};

// The instance id alone, for passes that only count pixels (the drones of an
// overlap layer drawn alone): the same coverage and alpha-cutoff discards as
// `fs_ids`, without the lighting.
@fragment
fn fs_layer(in: VsOut) -> IdOnly {
    let base = base_color(in);
    if (ALPHA_MASK && in.material.w > 0.0 && base.a < in.material.w) {
        discard;
    }
    return IdOnly(f32(in.id));
}

// Translucency of glTF BLEND triangles (the rotor discs of the built-in
// models) without sorting: the fragment covers the first round(alpha · SAMPLES)
// samples of its pixel (alpha = base colour alpha × the drone's rotor
// opacity), colour, id and depth alike, so the resolved pixel is the disc's
// colour over what lies behind it at that share, and the id samples count
// the drone exactly where its samples show it. Other fragments keep every sample.
fn coverage_mask(in: VsOut) -> u32 {
    if (in.material.w >= 0.0) {
        return 0xffffffffu;
    }
    var alpha = base_color(in).a;
    // A drawn look's rotor opacity fades BLEND triangles, not impostors.
    if (in.look.w > 0.5 && in.material.w > -1.5) {
        alpha = alpha * in.look_material.w;
    }
    let k = u32(round(clamp(alpha, 0.0, 1.0) * SAMPLES));
    return (1u << k) - 1u;
}

struct ColorMasked {
    @location(0) color: vec4<f32>,
    @builtin(sample_mask) mask: u32,
};

@fragment
fn fs_main_blend(in: VsOut, @builtin(front_facing) front: bool) -> ColorMasked {
    return ColorMasked(shade(in, front), coverage_mask(in));
}

struct ColorAndIdMasked {
    @location(0) color: vec4<f32>,
    @location(1) id: f32,
    @builtin(sample_mask) mask: u32,
};

@fragment
fn fs_ids_blend(in: VsOut, @builtin(front_facing) front: bool) -> ColorAndIdMasked {
    return ColorAndIdMasked(shade(in, front), f32(in.id), coverage_mask(in));
}

struct IdOnlyMasked {
    @location(1) id: f32,
    @builtin(sample_mask) mask: u32,
};

@fragment
fn fs_layer_blend(in: VsOut) -> IdOnlyMasked {
    let base = base_color(in);
    if (ALPHA_MASK && in.material.w > 0.0 && base.a < in.material.w) {
        discard;
    }
    return IdOnlyMasked(f32(in.id), coverage_mask(in));
}

// Footprints (src/render/frame/footprint.rs): each counted drone's rect
// (x0, y0, x1, y1) and where its bits begin and end (words), and the bits:
// one per pixel of its rect, row by row.
struct Footprint {
    rect: vec4<u32>,
    offset: vec4<u32>,
};
@group(2) @binding(0) var<storage, read> footprints: array<Footprint>;
@group(2) @binding(1) var<storage, read_write> footprint_bits: array<atomic<u32>>;

// Mark this fragment's pixel in its drone's footprint when it keeps a sample:
// `covered` (the samples the triangle covers) with `mask` (the coverage a
// `_blend` entry writes), unless an alpha cutoff discards it; what a pass
// drawing the drone alone would count for it.
fn mark_footprint(in: VsOut, covered: u32, mask: u32, base: vec4<f32>) {
    let cut = ALPHA_MASK && in.material.w > 0.0 && base.a < in.material.w;
    let f = footprints[in.id - 1u];
    let x = u32(in.position.x);
    let y = u32(in.position.y);
    let inside = x >= f.rect.x && y >= f.rect.y && x < f.rect.z && y < f.rect.w;
    if ((covered & mask) != 0u && !cut && inside) {
        let bit = (y - f.rect.y) * (f.rect.z - f.rect.x) + (x - f.rect.x);
        let word = f.offset.x + bit / 32u;
        if (word < f.offset.y) {
            atomicOr(&footprint_bits[word], 1u << (bit % 32u));
        }
    }
}

@fragment
fn fs_footprint(in: VsOut, @builtin(sample_mask) covered: u32) {
    mark_footprint(in, covered, 0xffffffffu, base_color(in));
}

@fragment
fn fs_footprint_blend(in: VsOut, @builtin(sample_mask) covered: u32) {
    let mask = coverage_mask(in);
    mark_footprint(in, covered, mask, base_color(in));
}

fn base_color(in: VsOut) -> vec4<f32> {
    if (TEXTURED) {
        return in.color * textureSample(base_color_texture, base_color_sampler, in.uv);
    }
    return in.color;
}

// Haze with range (Koschmieder), in linear light: L0·t + L_air·(1 − t),
// t = exp(−3.912·d/V) with d this surface point's distance from the camera.
fn hazed(in: VsOut, lit: vec3<f32>) -> vec3<f32> {
    if (frame.atmosphere.x < 0.5) {
        return lit;
    }
    let t = exp(-frame.atmosphere.y * length(in.position_cam));
    let air = select(frame.horizon.rgb, in.air.rgb, in.air.w > 0.5);
    return lit * t + air * (1.0 - t);
}

fn shade(in: VsOut, front: bool) -> vec4<f32> {
    var base = base_color(in);
    if (ALPHA_MASK && in.material.w > 0.0 && base.a < in.material.w) {
        discard;
    }
    var material = in.material;
    var emission = vec3<f32>(0.0);
    if (in.look.w > 0.5) {
        // The drone's drawn look replaces its model's colour and surface.
        base = vec4<f32>(in.look.rgb, base.a);
        material = vec4<f32>(in.look_material.x, in.look_material.y, 0.0, material.w);
        emission = in.look.rgb * in.look_material.z;
    }
    if (material.z > 0.5) {
        // KHR_materials_unlit: the base colour as it is.
        return vec4<f32>(linear_to_srgb(hazed(in, base.rgb) * frame.exposure.x), 1.0);
    }
    var n_cam = normalize(in.normal_cam);
    if (!front) {
        n_cam = -n_cam;
    }
    let n = normalize((frame.world_from_camera * vec4<f32>(n_cam, 0.0)).xyz);
    let v = normalize((frame.world_from_camera * vec4<f32>(-in.position_cam, 0.0)).xyz);
    let l = frame.sun_dir_world.xyz;
    let metallic = clamp(material.x, 0.0, 1.0);
    let roughness = clamp(material.y, 0.05, 1.0);
    let n_dot_l = max(dot(n, l), 0.0);
    // Hemispheric ambient: sky from above, ground bounce from below.
    let ambient = mix(frame.ground.rgb, frame.zenith.rgb * 0.6 + frame.horizon.rgb * 0.4, n.y * 0.5 + 0.5);
    let diffuse_color = base.rgb * (1.0 - metallic);
    let f0 = mix(vec3<f32>(0.04), base.rgb, metallic);
    // Normalised Blinn-Phong lobe with the shininess that matches GGX roughness.
    let h = normalize(l + v);
    let shininess = max(2.0 / (roughness * roughness * roughness * roughness) - 2.0, 1.0);
    let fresnel = f0 + (1.0 - f0) * pow(1.0 - max(dot(h, v), 0.0), 5.0);
    let specular = fresnel * ((shininess + 8.0) / (8.0 * PI)) * pow(max(dot(n, h), 0.0), shininess) * n_dot_l;
    let ambient_specular = f0 * ambient * (1.0 - roughness * 0.7);
    let lit = diffuse_color * (n_dot_l * frame.sun_color.rgb + ambient) + specular * frame.sun_color.rgb + ambient_specular + emission;
    // Exposed before the encode clips: a surface brighter than white keeps its headroom.
    return vec4<f32>(linear_to_srgb(hazed(in, lit) * frame.exposure.x), 1.0);
}
