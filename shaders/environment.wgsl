// Environments drawn behind the drones (prepended to sky.wgsl): the gradient
// sky, the procedural environments (Preetham sky, fbm clouds, ground plane,
// horizon silhouettes) and image skies. Uniforms mirror `render::sky::EnvUniforms`.

struct Env {
    // x: mode (0 gradient, 1 procedural, 2 equirect, 3 cubemap), y: exposure scale,
    // z: 1 when image values are radiance (tone mapped), w: image rotation (rad).
    mode: vec4<f32>,
    // Direct-sun transmittance (sun disc colour); w: cloud cover.
    sun_color: vec4<f32>,
    perez_a: vec4<f32>,
    perez_b: vec4<f32>,
    perez_c: vec4<f32>,
    perez_d: vec4<f32>,
    perez_e: vec4<f32>,
    // Zenith (Y kcd/m², x, y); w: fog visibility (m).
    zenith_yxy: vec4<f32>,
    // xy: pattern offset, z: ground kind, w: far silhouette kind.
    pattern: vec4<f32>,
    ground_a: vec4<f32>,
    ground_b: vec4<f32>,
    // rgb albedo, w: height (rad).
    far: vec4<f32>,
    // x: snow caps, y: near silhouette kind, z: near height (rad),
    // w: full-resolution pixels per pixel of the environment pass.
    far_params: vec4<f32>,
    // rgb albedo; w: 1 when the frame has an atmosphere (ground_a.w, ground_b.w:
    // the far and near silhouettes' haze; zenith_yxy.w: V / 3.912).
    near: vec4<f32>,
    // Display-linear sunlight and sky ambient (what lights the drones).
    light: vec4<f32>,
    ambient: vec4<f32>,
    // x: the elevation (rad) above which no silhouette reaches (-1: no
    // silhouette); y: its sine (-2: none), the line between ENV_PART 1 and 3;
    // z: full-resolution pixels per pixel of the quarter-resolution pass.
    band: vec4<f32>,
    // Preetham's zenith Yxy over the Perez terms at the zenith (twilight on
    // Y): the frame's constant factor of `preetham`.
    sky_k: vec4<f32>,
    // `horizon_haze` tabulated (`Preetham::haze_table`): its first half over
    // sin(γ/2), its second over cos(γ/2), γ the ray's angle to the sun, each
    // in HAZE_TABLE / 2 even steps from 0 to √½; tone-mapped, not clamped.
    haze_table: array<vec4<f32>, HAZE_TABLE>,
};

const HAZE_TABLE: u32 = 512u;

@group(1) @binding(0) var<uniform> env: Env;
@group(1) @binding(1) var env_equirect: texture_2d<f32>;
@group(1) @binding(2) var env_cube: texture_cube<f32>;
@group(1) @binding(3) var env_sampler: sampler;
// The procedural environment rendered at reduced resolution (fs_environment), and its clamping sampler.
@group(1) @binding(4) var env_half: texture_2d<f32>;
@group(1) @binding(5) var env_half_sampler: sampler;

const TAU: f32 = 6.2831853;

// The environment's kinds fixed when the environment pipeline is built (as
// `pattern.z`, `pattern.w` and `far_params.y`), or -1 to read them from the
// uniforms. Fixed kinds let the shader compiler drop the others: lavapipe
// runs every branch for every pixel under a lane mask, so an environment
// would otherwise pay for all four silhouettes twice, the water and the road.
override ENV_GROUND: f32 = -1.0;
override ENV_FAR: f32 = -1.0;
override ENV_NEAR: f32 = -1.0;
// 0: the whole environment; 1: the sky side of the horizon (dir.y >= 0) up
// to the silhouettes' band top (`env.band`); 2: the ground side; 3: the sky
// above the band, where no silhouette reaches: the `upper_sky` of the
// quarter-resolution pass (4, into its own target) upsampled, and the sun
// disc. render/horizon.rs draws the parts apart; `in_part` says whose a
// pixel is.
override ENV_PART: f32 = 0.0;

// Whether the pixel of ray `dir` (unit) belongs to this pipeline's ENV_PART.
fn in_part(dir: vec3<f32>) -> bool {
    let sky = dir.y >= 0.0;
    // Above the band: above every silhouette (`band_top` in render/sky.rs).
    let upper = sky && (dir.y > env.band.y);
    if (ENV_PART > 2.5) {
        return upper;
    } else if (ENV_PART > 1.5) {
        return !sky;
    } else if (ENV_PART > 0.5) {
        return sky && !upper;
    }
    return true;
}


fn hash12(p: vec2<f32>) -> f32 {
    var p3 = fract(vec3<f32>(p.x, p.y, p.x) * 0.1031);
    p3 += dot(p3, p3.yzx + 33.33);
    return fract((p3.x + p3.y) * p3.z);
}

fn vnoise(p: vec2<f32>) -> f32 {
    let i = floor(p);
    let f = fract(p);
    let u = f * f * (3.0 - 2.0 * f);
    let a = hash12(i);
    let b = hash12(i + vec2<f32>(1.0, 0.0));
    let c = hash12(i + vec2<f32>(0.0, 1.0));
    let d = hash12(i + vec2<f32>(1.0, 1.0));
    return mix(mix(a, b, u.x), mix(c, d, u.x), u.y);
}

fn fbm(p: vec2<f32>, octaves: i32) -> f32 {
    var sum = 0.0;
    var amp = 0.5;
    var q = p;
    for (var i = 0; i < octaves; i++) {
        sum += amp * vnoise(q);
        q = q * 2.02 + vec2<f32>(17.1, 9.3);
        amp *= 0.5;
    }
    return sum;
}

fn ridged(p: vec2<f32>, octaves: i32) -> f32 {
    var sum = 0.0;
    var amp = 0.5;
    var q = p;
    for (var i = 0; i < octaves; i++) {
        sum += amp * (1.0 - abs(2.0 * vnoise(q) - 1.0));
        q = q * 2.07 + vec2<f32>(3.7, 1.3);
        amp *= 0.5;
    }
    return sum;
}

fn tone_map(x: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(1.0) - exp(-x);
}

// The Perez terms of the ray's elevation (cosine of its zenith angle) and
// of its angle to the sun (given as that angle's cosine too).
fn perez_f(cos_theta: f32) -> vec3<f32> {
    return 1.0 + env.perez_a.xyz * exp(env.perez_b.xyz / max(cos_theta, 0.01));
}

fn perez_g(cos_gamma: f32) -> vec3<f32> {
    let gamma = acos(cos_gamma);
    return 1.0 + env.perez_c.xyz * exp(env.perez_d.xyz * gamma) + env.perez_e.xyz * cos_gamma * cos_gamma;
}

fn yxy_to_rgb(y: f32, cx: f32, cy_in: f32) -> vec3<f32> {
    let cy = max(cy_in, 1e-4);
    let x = cx / cy * y;
    let z = (1.0 - cx - cy) / cy * y;
    return max(vec3<f32>(
        3.2406 * x - 1.5372 * y - 0.4986 * z,
        -0.9689 * x + 1.8758 * y + 0.0415 * z,
        0.0557 * x - 0.2040 * y + 1.0570 * z,
    ), vec3<f32>(0.0));
}

// Preetham radiance (linear sRGB, kcd/m²), clamped at the horizon; the
// frame's constant factors come with the uniforms (`Preetham::shader_factors`).
fn preetham(dir: vec3<f32>) -> vec3<f32> {
    let d = normalize(vec3<f32>(dir.x, max(dir.y, 0.001), dir.z));
    let cos_gamma = clamp(dot(d, frame.sun_dir_world.xyz), -1.0, 1.0);
    let yxy = env.sky_k.xyz * perez_f(d.y) * perez_g(cos_gamma);
    return yxy_to_rgb(yxy.x, yxy.y, yxy.z);
}

// The tone-mapped sky 0.02 above level in the azimuth of `az_c` (unit, xz):
// what hazes the ground and the silhouettes. It depends on the ray's angle γ
// to the sun only: interpolated in the frame's table.
fn horizon_haze(az_c: vec2<f32>) -> vec3<f32> {
    // (az_c.x, 0.02, az_c.y) normalised: 1 / sqrt(1.0004).
    let d = vec3<f32>(az_c.x, 0.02, az_c.y) * 0.99980006;
    let cos_gamma = clamp(dot(d, frame.sun_dir_world.xyz), -1.0, 1.0);
    // sin(γ/2) toward the sun, cos(γ/2) away from it.
    let half = HAZE_TABLE / 2u;
    let t = sqrt(max(0.5 - 0.5 * abs(cos_gamma), 0.0)) * (f32(half - 1u) * 1.4142135);
    let k = min(u32(t), half - 2u);
    let i = k + select(half, 0u, cos_gamma >= 0.0);
    return max(mix(env.haze_table[i].rgb, env.haze_table[i + 1u].rgb, t - f32(k)), vec3<f32>(0.0));
}

// Angular height (rad) of a silhouette of `kind` at azimuth coordinates `c` (unit circle).
fn silhouette_height(kind: f32, height: f32, c: vec2<f32>, seed: vec2<f32>) -> f32 {
    if (kind < 0.5) {
        return -1.0;
    } else if (kind < 1.5) {
        // Hills: smooth, low.
        return height * (0.3 + 0.7 * fbm(c * 2.5 + seed, 3));
    } else if (kind < 2.5) {
        // Mountains: ridged peaks, with a quieter stretch of valley.
        let r = ridged(c * 3.0 + seed, 5);
        return height * (0.1 + 0.9 * r * r) * (0.6 + 0.4 * vnoise(c * 1.3 + seed.yx));
    } else if (kind < 3.5) {
        // Skyline: blocks of buildings over part of the horizon.
        let az = atan2(c.x, c.y);
        let block = floor(az * 90.0 / TAU * 4.0);
        let h = 0.25 + 0.75 * hash12(vec2<f32>(block, seed.x));
        let town = smoothstep(0.42, 0.5, vnoise(c * 2.0 + seed));
        return height * h * town + height * 0.08;
    }
    // Tree line: fine, ragged crowns.
    return height * (0.55 + 0.45 * fbm(c * 90.0 + seed, 2));
}

// The sky without its silhouettes and sun disc: the Preetham sky and the
// cloud layer (rgb), and the share of the sun disc the clouds leave (a).
// The quarter-resolution pass draws it where no silhouette reaches.
fn upper_sky(dir: vec3<f32>, haze: vec3<f32>) -> vec4<f32> {
    let sun = frame.sun_dir_world.xyz;
    let light = env.light.rgb;
    let ambient = env.ambient.rgb;
    var col = tone_map(preetham(dir) * env.mode.y);
    var clear = 1.0;
    // Cloud layer: fbm on a plane above the camera.
    let cover = env.sun_color.w;
    if (cover > 0.001) {
        let uv = vec2<f32>(dir.x, dir.z) / (dir.y + 0.05) * 0.9 + env.pattern.xy;
        let threshold = mix(0.72, 0.22, cover);
        // The first two octaves decide most pixels; the last three add at most 0.25.
        let coarse = fbm(uv, 2);
        var n = coarse;
        if (coarse + 0.25 > threshold) {
            n = coarse + 0.25 * fbm(uv * 4.0804 + vec2<f32>(70.2, 37.5), 3);
        }
        let density = smoothstep(threshold, threshold + 0.2, n);
        let toward_sun = fbm(uv + vec2<f32>(sun.x, sun.z) * 0.12, 2);
        let self_shadow = clamp(1.0 - (toward_sun - n) * 2.5, 0.45, 1.15);
        let silver = pow(max(dot(dir, sun), 0.0), 12.0);
        let cloud = (ambient * 0.85 + light * 0.5 * (0.6 + silver)) * self_shadow * (1.0 - 0.35 * density);
        let fade = smoothstep(0.0, 0.1, dir.y);
        let cloud_far = mix(haze, cloud, smoothstep(0.0, 0.3, dir.y) * 0.7 + 0.3);
        let f = density * fade * 0.95;
        col = mix(col, min(cloud_far, vec3<f32>(1.0)), f);
        clear = 1.0 - f;
    }
    return vec4<f32>(col, clear);
}

// The sun disc's light in direction `dir`.
fn sun_disc(dir: vec3<f32>) -> vec3<f32> {
    return env.sun_color.rgb * smoothstep(0.99996, 0.99999, dot(dir, frame.sun_dir_world.xyz)) * 3.0;
}

// The unit xz direction of the ray's azimuth (haze and silhouettes).
fn azimuth(dir: vec3<f32>) -> vec2<f32> {
    return normalize(vec2<f32>(dir.x, dir.z) + vec2<f32>(1e-6, 0.0));
}

// The silhouettes (far, then near) over `sky`, the sky behind them in ray
// `dir` (unit; at or above the horizon), whose azimuth is `az_c` and
// horizon haze `haze`.
fn silhouettes_over(sky: vec3<f32>, dir: vec3<f32>, az_c: vec2<f32>, haze: vec3<f32>) -> vec3<f32> {
    let sun = frame.sun_dir_world.xyz;
    let light = env.light.rgb;
    let ambient = env.ambient.rgb;
    let seed = env.pattern.xy;
    let elevation = asin(clamp(dir.y, -1.0, 1.0));
    var col = sky;
    // Far silhouette (hills, mountains, skyline), then the near tree line.
    let far_kind = select(env.pattern.w, ENV_FAR, ENV_FAR >= 0.0);
    let far_h = silhouette_height(far_kind, env.far.w, az_c, seed * 0.01);
    if (elevation < far_h) {
        let shade = env.far.rgb * (light * max(sun.y, 0.0) * 0.6 + ambient * 0.8);
        var c = shade;
        if (env.far_params.x > 0.5 && elevation > far_h * 0.6) {
            let snow = vec3<f32>(0.85, 0.87, 0.9) * (light * max(sun.y, 0.0) * 0.5 + ambient);
            c = mix(c, snow, smoothstep(0.6, 0.75, elevation / max(far_h, 1e-4)));
        }
        // With an atmosphere (near.w = 1): the haze of its distance (ground_a.w).
        col = mix(c, haze, select(0.55, env.ground_a.w, env.near.w > 0.5));
    }
    let near_kind = select(env.far_params.y, ENV_NEAR, ENV_NEAR >= 0.0);
    let near_h = silhouette_height(near_kind, env.far_params.z, az_c, seed * 0.013 + vec2<f32>(5.0, 3.0));
    if (elevation < near_h) {
        col = mix(env.near.rgb * (light * max(sun.y, 0.0) * 0.5 + ambient * 0.7), haze, select(0.25, env.ground_b.w, env.near.w > 0.5));
    }
    return col;
}

fn procedural_sky(dir: vec3<f32>) -> vec3<f32> {
    let k = env.mode.y;
    let sun = frame.sun_dir_world.xyz;
    let light = env.light.rgb;
    let ambient = env.ambient.rgb;
    let seed = env.pattern.xy;
    let az_c = azimuth(dir);
    let haze = horizon_haze(az_c);
    var col: vec3<f32>;
    if (select((dir.y >= 0.0), (ENV_PART < 1.5), (ENV_PART > 0.5))) {
        let upper = upper_sky(dir, haze);
        col = silhouettes_over(upper.rgb + sun_disc(dir) * upper.a, dir, az_c, haze);
    } else {
        // Ground plane 60 m below the camera.
        let t = 60.0 / max(-dir.y, 1e-4);
        let p = vec2<f32>(dir.x, dir.z) * t + seed * 37.0;
        let kind = select(env.pattern.z, ENV_GROUND, ENV_GROUND >= 0.0);
        var albedo = mix(env.ground_a.rgb, env.ground_b.rgb, fbm(p * 0.01, 4));
        let fields = vnoise(p * 0.003);
        albedo = albedo * (0.8 + 0.4 * step(0.5, fields));
        if (kind > 2.5) {
            // A straight country road with a dashed centre line.
            let across = abs(p.x - 30.0);
            if (across < 3.5) {
                albedo = vec3<f32>(0.05, 0.05, 0.055);
                if (across < 0.12 && fract(p.y / 12.0) < 0.5) {
                    albedo = vec3<f32>(0.6);
                }
            }
        }
        var lit = albedo * (light * max(sun.y, 0.0) + ambient);
        if (kind > 1.5 && kind < 2.5) {
            // Water: the sky reflected with Fresnel, ripples and a sun glint.
            let ripple = (vec2<f32>(vnoise(p * 0.35), vnoise(p * 0.35 + 7.0)) - 0.5) * 0.06;
            let r = normalize(vec3<f32>(dir.x + ripple.x, -dir.y, dir.z + ripple.y));
            let reflected = tone_map(preetham(r) * k);
            let fresnel = 0.02 + 0.98 * pow(1.0 - min(-dir.y, 1.0), 5.0);
            let glint = pow(max(dot(r, sun), 0.0), 300.0) * light * 2.0;
            lit = mix(albedo * ambient, reflected, fresnel) + glint;
        }
        let fog = 1.0 - exp(-t / env.zenith_yxy.w);
        col = mix(lit, haze, fog);
    }
    return col;
}

fn rotate_y(d: vec3<f32>, angle: f32) -> vec3<f32> {
    let c = cos(angle);
    let s = sin(angle);
    return vec3<f32>(d.x * c + d.z * s, d.y, -d.x * s + d.z * c);
}

// The image's value in direction `dir`, times the exposure, before any tone map.
fn image_radiance(dir: vec3<f32>) -> vec3<f32> {
    // Turn the world ray into the image's frame (the image turns by +rotation).
    let d = rotate_y(dir, -env.mode.w);
    var c: vec3<f32>;
    if (env.mode.x < 2.5) {
        let az = atan2(d.x, d.z);
        let uv = vec2<f32>(fract(0.5 - az / TAU), acos(clamp(d.y, -1.0, 1.0)) / 3.14159265);
        c = textureSampleLevel(env_equirect, env_sampler, uv, 0.0).rgb;
    } else {
        c = textureSampleLevel(env_cube, env_sampler, d, 0.0).rgb;
    }
    return c * env.mode.y;
}

// An image's exposed value `c` as display light: HDR images tone-mapped,
// display-referred ones clipped.
fn image_tone(c: vec3<f32>) -> vec3<f32> {
    if (env.mode.z > 0.5) {
        return tone_map(c);
    }
    return min(c, vec3<f32>(1.0));
}

fn image_sky(dir: vec3<f32>) -> vec3<f32> {
    return image_tone(image_radiance(dir));
}
