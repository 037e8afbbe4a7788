// Instance-id pass: each fragment stores its drone's id (drone index + 1; 0 is sky)
// into an R32Uint target, depth-tested like the colour pass but without MSAA.

struct IdVertex {
    @location(0) position: vec3<f32>,
};

struct IdInstance {
    @location(3) c0: vec4<f32>,
    @location(4) c1: vec4<f32>,
    @location(5) c2: vec4<f32>,
    @location(6) c3: vec4<f32>,
    @location(7) id: u32,
};

struct IdOut {
    @builtin(position) position: vec4<f32>,
    @location(0) @interpolate(flat) id: u32,
};

@vertex
fn vs_main(v: IdVertex, inst: IdInstance) -> IdOut {
    let camera_from_model = mat4x4<f32>(inst.c0, inst.c1, inst.c2, inst.c3);
    var out: IdOut;
    out.position = frame.clip_from_camera * (camera_from_model * vec4<f32>(v.position, 1.0));
    out.id = inst.id;
    return out;
}

@fragment
fn fs_main(in: IdOut) -> @location(0) u32 {
    return in.id;
}
