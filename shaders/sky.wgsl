// The environment behind the drones, drawn as one full-screen triangle: the
// gradient sky with a sun disc (mode 0) or an environment from
// environment.wgsl. Each pixel's ray is built from the same intrinsics the labels use.

struct SkyOut {
    @builtin(position) position: vec4<f32>,
};

@vertex
fn vs_main(@builtin(vertex_index) i: u32) -> SkyOut {
    let uv = vec2<f32>(f32((i << 1u) & 2u), f32(i & 2u));
    var out: SkyOut;
    // Depth 0 is the far end in reversed-Z.
    out.position = vec4<f32>(uv * 2.0 - 1.0, 0.0, 1.0);
    return out;
}

fn sky_radiance(dir: vec3<f32>) -> vec3<f32> {
    let up = dir.y;
    var col: vec3<f32>;
    if (up >= 0.0) {
        col = mix(frame.horizon.rgb, frame.zenith.rgb, pow(up, 0.45));
    } else {
        // Below the horizon: a hazy ground that fades into the horizon colour.
        col = mix(frame.horizon.rgb * 0.85, frame.ground.rgb, clamp(-up * 6.0, 0.0, 1.0));
    }
    let cos_sun = dot(dir, frame.sun_dir_world.xyz);
    // Disc of ~0.6° angular radius plus a soft glow.
    let disc = smoothstep(0.99993, 0.99996, cos_sun);
    let glow = pow(max(cos_sun, 0.0), 64.0) * 0.35;
    return col + frame.sun_color.rgb * (disc * 20.0 + glow);
}

// The sky mode fixed when the pipeline is built (as `Env.mode.x`), or -1 to
// read it from the uniforms. A fixed mode lets the shader compiler drop the
// other branches: a software rasteriser such as lavapipe otherwise runs
// every branch for every pixel under a lane mask.
override SKY_MODE: f32 = -1.0;
// 1: the frame's exposure applied here (a whole frame drawn at once); 0: the
// cached background's pass, exposed afterwards (render/background.rs).
override EXPOSED: f32 = 1.0;

@fragment
fn fs_main(in: SkyOut) -> @location(0) vec4<f32> {
    let k = frame.intrinsics;
    let ray_cam = vec3<f32>((in.position.x - k.z) / k.x, (in.position.y - k.w) / k.y, 1.0);
    let dir = normalize((frame.world_from_camera * vec4<f32>(ray_cam, 0.0)).xyz);
    let mode = select(env.mode.x, SKY_MODE, SKY_MODE >= 0.0);
    var col: vec3<f32>;
    if (mode < 0.5) {
        col = sky_radiance(dir);
    } else if (mode < 1.5) {
        // Drawn at reduced resolution by fs_environment; the principal point is the image centre.
        let uv = in.position.xy / (2.0 * k.zw);
        col = textureSampleLevel(env_half, env_half_sampler, uv, 0.0).rgb;
    } else if (env.far_params.w > 1.5) {
        // Shaded at reduced resolution on the CPU (render/sky/equirect.rs; `image_scale`).
        let uv = in.position.xy / (2.0 * k.zw);
        col = image_tone(textureSampleLevel(env_half, env_half_sampler, uv, 0.0).rgb);
    } else {
        col = image_sky(dir);
    }
    return vec4<f32>(linear_to_srgb(col * select(1.0, frame.exposure.x, EXPOSED > 0.5)), 1.0);
}

// The procedural environment pass over one side's polygon (render/horizon.rs).
@vertex
fn vs_environment(@location(0) ndc: vec2<f32>) -> SkyOut {
    var out: SkyOut;
    out.position = vec4<f32>(ndc, 0.0, 1.0);
    return out;
}

// The height of a ray (the sine of its elevation) below which the ground is
// shaded in the quarter-resolution pass (twice as far below: interpolated
// from it in the half-resolution pass): a quarter texel's ray lies within
// ≈ 8.5 / f of those of the half pixels that sample it (`reach` in
// render/sky/procedural.rs). `k`: the frame's intrinsics.
fn lower_line(k: vec4<f32>) -> f32 {
    return -9.0 / max(min(abs(k.x), abs(k.y)), 1e-6);
}

// The procedural environment pass: each pixel stands for far_params.w ×
// far_params.w full-resolution pixels (band.z × band.z in the quarter-
// resolution pass, ENV_PART 4).
@fragment
fn fs_environment(in: SkyOut) -> @location(0) vec4<f32> {
    let k = frame.intrinsics;
    let p = in.position.xy * select(env.far_params.w, env.band.z, ENV_PART > 3.5);
    let ray_cam = vec3<f32>((p.x - k.z) / k.x, (p.y - k.w) / k.y, 1.0);
    let dir = normalize((frame.world_from_camera * vec4<f32>(ray_cam, 0.0)).xyz);
    let lower = lower_line(k);
    if (ENV_PART > 3.5) {
        // The ground below the lower line (the ground side's polygon).
        if (dir.y < lower) {
            return vec4<f32>(procedural_sky(dir), 1.0);
        }
        // Every pixel of the sky's polygons (above the band and the band's):
        // the half-resolution pass interpolates between them. Rays below the
        // horizon (its margin) are taken level.
        let d = select(dir, normalize(vec3<f32>(dir.x, 0.0, dir.z) + vec3<f32>(1e-6, 0.0, 0.0)), dir.y < 0.0);
        return upper_sky(d, horizon_haze(azimuth(d)));
    }
    // Drawn one part at a time: the other parts' pixels are their draws'.
    if (!in_part(dir)) {
        discard;
    }
    let quarter = p / (env.band.z * vec2<f32>(textureDimensions(env_half)));
    if (ENV_PART > 2.5) {
        // The quarter-resolution pass's upper sky, interpolated at this pixel.
        let upper = textureSampleLevel(env_half, env_half_sampler, quarter, 0.0);
        return vec4<f32>(upper.rgb + sun_disc(dir) * upper.a, 1.0);
    }
    if (ENV_PART > 0.5 && ENV_PART < 1.5) {
        // The band: its silhouettes over the quarter-resolution pass's sky,
        // interpolated at this pixel, and the sun disc.
        let sky = textureSampleLevel(env_half, env_half_sampler, quarter, 0.0);
        let az_c = azimuth(dir);
        let col = silhouettes_over(sky.rgb + sun_disc(dir) * sky.a, dir, az_c, horizon_haze(az_c));
        return vec4<f32>(col, 1.0);
    }
    if (dir.y < 2.0 * lower) {
        // The quarter-resolution pass's ground, interpolated at this pixel.
        return vec4<f32>(textureSampleLevel(env_half, env_half_sampler, quarter, 0.0).rgb, 1.0);
    }
    return vec4<f32>(procedural_sky(dir), 1.0);
}
