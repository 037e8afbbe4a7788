// Instanced, lit drone meshes. Instances carry camera_from_model (computed in
// f64 on the CPU, so large world coordinates never reach the GPU).

struct VertexInput {
    @location(0) position: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) color: vec4<f32>,
};

struct Instance {
    @location(3) c0: vec4<f32>,
    @location(4) c1: vec4<f32>,
    @location(5) c2: vec4<f32>,
    @location(6) c3: vec4<f32>,
};

struct VsOut {
    @builtin(position) position: vec4<f32>,
    @location(0) normal_cam: vec3<f32>,
    @location(1) color: vec4<f32>,
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
    return out;
}

@fragment
fn fs_main(in: VsOut, @builtin(front_facing) front: bool) -> @location(0) vec4<f32> {
    var n_cam = normalize(in.normal_cam);
    if (!front) {
        n_cam = -n_cam;
    }
    let n = normalize((frame.world_from_camera * vec4<f32>(n_cam, 0.0)).xyz);
    let l = frame.sun_dir_world.xyz;
    let diffuse = max(dot(n, l), 0.0) * frame.sun_color.rgb;
    // Hemispheric ambient: sky from above, ground bounce from below.
    let ambient = mix(frame.ground.rgb, frame.zenith.rgb * 0.6 + frame.horizon.rgb * 0.4, n.y * 0.5 + 0.5);
    let lit = in.color.rgb * (diffuse + ambient);
    return vec4<f32>(linear_to_srgb(lit), 1.0);
}
