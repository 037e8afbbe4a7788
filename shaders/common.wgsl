// Shared per-frame uniforms (must match `render::FrameUniforms`).
struct Frame {
    clip_from_camera: mat4x4<f32>,
    world_from_camera: mat4x4<f32>,
    // (fx, fy, cx, cy) in pixels.
    intrinsics: vec4<f32>,
    // Towards the sun, world frame; w unused.
    sun_dir_world: vec4<f32>,
    // Linear RGB sun radiance scale in w.
    sun_color: vec4<f32>,
    zenith: vec4<f32>,
    horizon: vec4<f32>,
    ground: vec4<f32>,
    // x: 1 with an atmosphere (haze on the drones), y: 3.912 / visibility (per metre).
    atmosphere: vec4<f32>,
    // x: the camera's exposure as a gain on linear light (1 without a camera model).
    exposure: vec4<f32>,
};

@group(0) @binding(0) var<uniform> frame: Frame;

fn linear_to_srgb(c: vec3<f32>) -> vec3<f32> {
    let x = clamp(c, vec3<f32>(0.0), vec3<f32>(1.0));
    let lo = x * 12.92;
    let hi = 1.055 * pow(x, vec3<f32>(1.0 / 2.4)) - 0.055;
    return select(hi, lo, x <= vec3<f32>(0.0031308));
}
