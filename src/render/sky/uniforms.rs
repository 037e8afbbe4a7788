//! The environment's uniform block (`Env` in shaders/environment.wgsl) and
//! what a procedural environment writes into it.

use glam::Vec3;

use super::{HALF_SCALE, QUARTER_SCALE};
use crate::sky::meter::{FAR_SILHOUETTE_M, NEAR_SILHOUETTE_M};
use crate::sky::{self, EnvironmentName, FrameEnvironment, HAZE_TABLE, Lighting, Preetham};

/// Layout matches `Env` in `shaders/environment.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub(super) struct EnvUniforms {
    pub(super) mode: [f32; 4],
    pub(super) sun_color: [f32; 4],
    pub(super) perez: [[f32; 4]; 5],
    pub(super) zenith_yxy: [f32; 4],
    pub(super) pattern: [f32; 4],
    pub(super) ground_a: [f32; 4],
    pub(super) ground_b: [f32; 4],
    pub(super) far: [f32; 4],
    pub(super) far_params: [f32; 4],
    pub(super) near: [f32; 4],
    pub(super) light: [f32; 4],
    pub(super) ambient: [f32; 4],
    pub(super) band: [f32; 4],
    pub(super) sky_k: [f32; 4],
    /// [`Preetham::haze_table`] (procedural environments; zeros otherwise).
    pub(super) haze_table: [[f32; 4]; HAZE_TABLE],
}

impl Default for EnvUniforms {
    fn default() -> Self {
        bytemuck::Zeroable::zeroed()
    }
}

const _: () = assert!(std::mem::size_of::<EnvUniforms>() == (18 + HAZE_TABLE) * 16);

/// The elevation (rad) above which none of `style`'s silhouettes reaches
/// (`silhouette_height` in environment.wgsl), or -1 when it has none. The
/// tallest shape, the skyline, reaches 1.08 times its height; 1.1 leaves
/// room for rounding.
fn band_top(style: &sky::EnvironmentStyle) -> f32 {
    let heights = [
        (style.far != sky::Silhouette::None).then_some(style.far_height_deg),
        (style.near != sky::Silhouette::None).then_some(style.near_height_deg),
    ];
    heights
        .into_iter()
        .flatten()
        .map(|deg| 1.1 * deg.max(0.0).to_radians())
        .reduce(f32::max)
        .unwrap_or(-1.0)
}

impl EnvUniforms {
    /// The uniforms of procedural environment `name` at `exposure`, its
    /// sunlight × `sunlight`, for the frame's environment draws and sun, hazed
    /// by the frame's atmosphere (if any); and the lighting it gives the drones.
    pub(super) fn procedural(
        name: EnvironmentName,
        (exposure, sunlight): (f32, f32),
        env: &FrameEnvironment,
        sun: Vec3,
        atmosphere_visibility_m: Option<f64>,
    ) -> (Self, Lighting) {
        let mut u = Self::default();
        let style = name.style();
        let lighting = sky::procedural_lighting(&style, env, exposure, sunlight);
        let model = Preetham::new(env.turbidity as f32, sun);
        let t = sky::sun_transmittance(env.turbidity as f32, sun.y.clamp(-1.0, 1.0).asin());
        u.mode = [1.0, sky::SKY_EXPOSURE * exposure, 0.0, 0.0];
        u.sun_color = [t.x, t.y, t.z, env.cloud_cover.clamp(0.0, 1.0) as f32];
        for (k, row) in model.perez.iter().enumerate() {
            u.perez[k] = [row[0], row[1], row[2], 0.0];
        }
        // Fog visibility shrinks with turbidity.
        let visibility_m = 9000.0 / env.turbidity.max(1.0) as f32;
        u.zenith_yxy = [
            model.zenith[0],
            model.zenith[1],
            model.zenith[2],
            visibility_m,
        ];
        let offset = crate::sky::meter::pattern_offset(env.pattern_seed);
        u.pattern = [
            offset[0],
            offset[1],
            style.ground as u32 as f32,
            style.far as u32 as f32,
        ];
        let rgb = |c: [f32; 3], w: f32| [c[0], c[1], c[2], w];
        u.ground_a = rgb(style.ground_albedo[0], 0.0);
        u.ground_b = rgb(style.ground_albedo[1], 0.0);
        u.far = rgb(style.far_albedo, style.far_height_deg.to_radians());
        u.far_params = [
            if style.snow_caps { 1.0 } else { 0.0 },
            style.near as u32 as f32,
            style.near_height_deg.to_radians(),
            HALF_SCALE as f32,
        ];
        u.near = rgb(style.near_albedo, 0.0);
        let top = band_top(&style);
        u.band = [
            top,
            if top < 0.0 { -2.0 } else { top.sin() },
            QUARTER_SCALE as f32,
            0.0,
        ];
        let (sky_k, haze_k) = model.shader_factors();
        u.sky_k = rgb(sky_k, 0.0);
        let table = model.haze_table(haze_k, u.mode[1]);
        u.haze_table.copy_from_slice(&table);
        if let Some(v) = atmosphere_visibility_m {
            // The frame's atmosphere: the ground's fog and the silhouettes'
            // haze follow the same Koschmieder law as the drones'.
            let k = crate::scene::realism::KOSCHMIEDER;
            u.zenith_yxy[3] = (v / k) as f32;
            u.ground_a[3] = 1.0 - (-k * FAR_SILHOUETTE_M / v).exp() as f32;
            u.ground_b[3] = 1.0 - (-k * NEAR_SILHOUETTE_M / v).exp() as f32;
            u.near[3] = 1.0;
        }
        u.light = rgb(lighting.sun_color, 0.0);
        u.ambient = rgb(lighting.zenith, 0.0);
        (u, lighting)
    }
}
