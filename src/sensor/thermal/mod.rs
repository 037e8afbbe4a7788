//! The thermal camera's physics and sensor (issue 41; docs/realism.md,
//! "Thermal camera"): band radiance from temperature, the clear sky's
//! radiance by elevation, and the camera's chain on a radiance plane —
//! the optics' blur, fixed-pattern and temporal noise, automatic gain
//! control to 8-bit grey (or 16-bit: [`Developed::Grey16`]).
//!
//! Radiance is the 8–14 µm band integral of Planck's law, W·m⁻²·sr⁻¹
//! ([`band_radiance`]). The clear sky's band emissivity at elevation e is
//! `ε(e) = 1 − (1 − ε_z)^(1/sin e)` (the sky's path length grows as
//! 1/sin e), its radiance `ε(e)·B(T_air)`: coldest at the zenith, the air's
//! at the horizon. [`sky_plane`] composes the background's radiance from
//! the rays and the visible background's colours, [`texture`] the scene's
//! temperature texture when the preset has one; the pipeline adds the
//! objects (`pipeline::thermal`); [`develop_into`] is the camera: the
//! detail enhancement ([`detail`]) when the preset asks, a Gaussian blur of
//! σ px, then per pixel the fixed pattern (from the preset
//! seed alone: the same in every frame) and the temporal noise (NETD; the
//! deviates of [`super::noise`] under the frame's key), then a linear gain
//! that maps the frame's low and high percentiles to levels 0 and 255,
//! capped at `agc_max_gain` levels per kelvin, their middle at
//! `agc_mid_level`. The per-pixel loops run built for AVX-512 or AVX2
//! where the CPU has it (`simd_fn!`: the same operations, so the same bits)
//! and in bands of rows on rayon's threads. [`capture`] is the recording's
//! chain after the camera (an earlier compression, border lines), off
//! unless a preset asks. It knows the preset's `thermal`
//! section and seeds, nothing of scenes, the GPU or files.

use std::sync::OnceLock;

use crate::preset::thermal::{MAX_TEMPERATURE_K, Thermal};

use super::noise::{Key, deviate};

/// `fn NAME(args) -> R { body }` whose body runs built for AVX-512 or AVX2
/// where the CPU has it, else as built: the same operations (no fused
/// multiply-add), so the same bits either way, 16 or 8 lanes instead of 4
/// (and under AVX-512 a table look-up per lane is one gather).
macro_rules! simd_fn {
    ($(#[$doc:meta])* fn $name:ident($($a:ident: $t:ty),* $(,)?) $(-> $r:ty)? $body:block) => {
        $(#[$doc])*
        fn $name($($a: $t),*) $(-> $r)? {
            #[inline(always)]
            fn plain($($a: $t),*) $(-> $r)? $body
            #[cfg(target_arch = "x86_64")]
            #[target_feature(enable = "avx512f,avx512bw,avx512dq,avx512vl")]
            fn avx512($($a: $t),*) $(-> $r)? {
                plain($($a),*)
            }
            #[cfg(target_arch = "x86_64")]
            #[target_feature(enable = "avx2")]
            fn avx2($($a: $t),*) $(-> $r)? {
                plain($($a),*)
            }
            #[cfg(target_arch = "x86_64")]
            if $crate::sensor::thermal::avx512() {
                // SAFETY: the CPU has these features (checked by `avx512`).
                #[allow(unsafe_code)]
                let out = unsafe { avx512($($a),*) };
                return out;
            }
            #[cfg(target_arch = "x86_64")]
            if $crate::sensor::thermal::avx2() {
                // SAFETY: the CPU has AVX2 (checked by `avx2`).
                #[allow(unsafe_code)]
                let out = unsafe { avx2($($a),*) };
                return out;
            }
            plain($($a),*)
        }
    };
}

pub mod capture;
pub mod detail;
mod develop;
mod narcissus;
mod plate_plane;
mod sky_plane;
pub mod texture;

pub use develop::{Developed, Gain, blur, develop, develop_into, grey16_to_rgba, percentiles};
pub use plate_plane::{blur_drawn, plate_gain, plate_plane};
pub use sky_plane::{View, ground_share, sky_plane};

/// Whether to run the AVX-512 builds: the crate's one SIMD level
/// ([`crate::simd::simd_level`], which `SWARMSHOT_SIMD=avx2` caps).
#[cfg(target_arch = "x86_64")]
fn avx512() -> bool {
    crate::simd::simd_level() >= 2
}

/// Whether to run the AVX2 builds: the crate's one SIMD level
/// ([`crate::simd::simd_level`], which `SWARMSHOT_SIMD=base` caps).
#[cfg(target_arch = "x86_64")]
fn avx2() -> bool {
    crate::simd::simd_level() >= 1
}

/// The buffers the thermal camera reuses from frame to frame.
#[derive(Debug, Default)]
pub struct Scratch {
    /// The radiance plane: [`sky_plane`] fills it, [`develop_into`] develops it.
    pub plane: Vec<f32>,
    /// The blur's output, swapped with `plane` once developed.
    rows: Vec<f32>,
    /// The plate's radiance as [`plate_plane`] made it, kept (when the
    /// camera blurs) so [`blur_drawn`] blurs only what is drawn over it.
    plate: Vec<f32>,
    /// [`blur_drawn`]'s difference from the plate over the rows drawn on.
    drawn: Vec<f32>,
    /// The columns' ray slopes, then their squares.
    slopes: Vec<f32>,
    /// The background's share of ground ([`ground_share`]) for a texture on the ground.
    pub share: Vec<f32>,
    /// The detail enhancement's base ([`detail`]).
    detail: detail::Buffers,
}

/// The band's edges, metres.
const BAND_M: (f64, f64) = (8e-6, 14e-6);
/// Planck's first and second radiation constants: 2hc² (W·m²) and hc/k (m·K).
const C1: f64 = 1.191_042_972e-16;
const C2: f64 = 1.438_776_877e-2;

/// The 8–14 µm band radiance of a black body at `t_k` kelvin, W·m⁻²·sr⁻¹
/// (Simpson's rule on 60 intervals).
pub fn band_radiance(t_k: f64) -> f64 {
    const N: usize = 60;
    let (a, b) = BAND_M;
    let h = (b - a) / N as f64;
    let planck = |l: f64| C1 / (l.powi(5) * ((C2 / (l * t_k)).exp() - 1.0));
    let mut sum = planck(a) + planck(b);
    for k in 1..N {
        let w = if k % 2 == 1 { 4.0 } else { 2.0 };
        sum += w * planck(a + h * k as f64);
    }
    sum * h / 3.0
}

/// The table's first temperature and step, kelvin.
const TABLE_T0: f64 = 150.0;
const TABLE_STEP: f64 = 0.5;

/// [`band_radiance`] by a table (150 K to the hottest accepted, 0.5 K steps,
/// linear in between: within 0.01 % of the integral), built once.
pub fn radiance(t_k: f64) -> f32 {
    static TABLE: OnceLock<Vec<f32>> = OnceLock::new();
    let table = TABLE.get_or_init(|| {
        let n = ((MAX_TEMPERATURE_K - TABLE_T0) / TABLE_STEP) as usize + 2;
        (0..n)
            .map(|k| band_radiance(TABLE_T0 + k as f64 * TABLE_STEP) as f32)
            .collect()
    });
    let x = ((t_k - TABLE_T0) / TABLE_STEP).clamp(0.0, (table.len() - 2) as f64);
    let k = x as usize;
    let f = (x - k as f64) as f32;
    table[k] + (table[k + 1] - table[k]) * f
}

/// dB/dT at `t_k`, W·m⁻²·sr⁻¹ per kelvin (central difference).
pub fn radiance_per_kelvin(t_k: f64) -> f32 {
    ((band_radiance(t_k + 0.5) - band_radiance(t_k - 0.5)) as f32).max(1e-9)
}

/// The clear sky's band emissivity at sin(elevation) `s` (> 0).
pub fn sky_emissivity(zenith: f64, s: f64) -> f64 {
    1.0 - (1.0 - zenith).powf(1.0 / s.max(1e-3))
}

/// The sky's and ground's radiance by sin(elevation): a table over
/// s ∈ [0, 1] for the clear sky (the ground below the horizon is flat).
#[derive(Clone, Debug)]
pub struct SkyTable {
    /// By sin(elevation) from 0 to 1 in [`SKY_STEPS`] steps, then the
    /// ground's (what a ray below the horizon looks up).
    clear: Box<[f32; SKY_STEPS + 2]>,
    /// The ground's radiance (below the horizon) and the clouds'.
    pub ground: f32,
    pub cloud: f32,
    /// The air's own radiance (what extinction mixes in).
    pub air: f32,
}

/// Entries of [`SkyTable`]'s clear-sky table.
const SKY_STEPS: usize = 1024;

impl SkyTable {
    pub fn new(t: &Thermal) -> Self {
        let air = band_radiance(t.air_k);
        let ground = radiance(t.ground_k);
        let mut clear = Box::new([ground; SKY_STEPS + 2]);
        for (k, c) in clear[..=SKY_STEPS].iter_mut().enumerate() {
            let s = k as f64 / SKY_STEPS as f64;
            *c = (sky_emissivity(t.zenith_emissivity, s) * air) as f32;
        }
        Self {
            clear,
            ground,
            cloud: radiance(t.cloud_k),
            air: air as f32,
        }
    }

    /// The clear sky's radiance at sin(elevation) `s` (the ground's below 0).
    #[inline(always)]
    pub fn clear(&self, s: f32) -> f32 {
        self.entry(Self::index(s))
    }

    /// The table's entry that [`Self::clear`] reads for `s`.
    #[inline(always)]
    fn index(s: f32) -> u32 {
        // One look-up without a branch, so a row of them vectorises; the
        // index as `as i32` then `min` would give it (NaN: 0).
        let steps = SKY_STEPS as f32;
        if s < 0.0 {
            SKY_STEPS as u32 + 1
        } else {
            develop::floor(develop::clamp_nan_low(s * steps, steps)) as u32
        }
    }

    /// The table's entry `k` (the ground's past the end).
    #[inline(always)]
    fn entry(&self, k: u32) -> f32 {
        self.clear[(k as usize).min(SKY_STEPS + 1)]
    }
}

/// The fixed pattern of a `w`×`h` sensor in radiance units: per-pixel and
/// per-column offsets (σ `fixed_pattern_mk` each, split 3:1 in variance)
/// and the radial shading (`shading_k` at the corners, ∝ ρ²), less the
/// narcissus' spot when the preset has one ([`narcissus`]), from
/// `preset_seed` alone.
pub fn fixed_pattern(t: &Thermal, preset_seed: u64, w: u32, h: u32) -> Vec<f32> {
    let per_k = radiance_per_kelvin(t.air_k);
    let sigma = (t.fixed_pattern_mk * 1e-3) as f32 * per_k;
    let (pixel_sd, column_sd) = (sigma * 0.75f32.sqrt(), sigma * 0.5);
    let key = Key::new(crate::seed::mix64(preset_seed ^ FIXED_PATTERN_SALT));
    let shading = (t.shading_k as f32) * per_k;
    let (cx, cy) = (w as f32 * 0.5, h as f32 * 0.5);
    let inv_r2 = 1.0 / (cx * cx + cy * cy).max(1.0);
    let columns: Vec<f32> = (0..w)
        .map(|x| column_sd * deviate(key.bits(u32::MAX - x)))
        .collect();
    let mut out = Vec::with_capacity(w as usize * h as usize);
    for y in 0..h {
        let dy = y as f32 + 0.5 - cy;
        for (x, col) in columns.iter().enumerate() {
            let dx = x as f32 + 0.5 - cx;
            let i = y * w + x as u32;
            let rho2 = (dx * dx + dy * dy) * inv_r2;
            out.push(col + pixel_sd * deviate(key.bits(i)) + shading * rho2);
        }
    }
    if let Some(n) = &t.narcissus {
        narcissus::subtract(n, per_k, (w, h), &mut out);
    }
    out
}

/// Salt of the fixed pattern's key (under the preset seed).
pub const FIXED_PATTERN_SALT: u64 = 0x5448_4552_4D46_504E; // "THERMFPN"
/// Salt of a frame's temporal noise key (under the frame seed).
pub const NOISE_SALT: u64 = 0x5448_4552_4D4E_4F49; // "THERMNOI"

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn band_radiance_rises_with_temperature_near_published_values() {
        // 8–14 µm radiance of a 300 K black body: 54.93 W·m⁻²·sr⁻¹ (a fine
        // trapezoid sum of Planck's law; 38 % of σT⁴/π = 146.2).
        let l300 = band_radiance(300.0);
        assert!((l300 - 54.933).abs() < 0.01, "{l300}");
        assert!(band_radiance(310.0) > l300 && l300 > band_radiance(290.0));
        // The table agrees with the integral.
        for t in [200.3, 288.0, 301.7, 900.25] {
            let (a, b) = (f64::from(radiance(t)), band_radiance(t));
            assert!((a - b).abs() / b < 1e-4, "{t}: {a} vs {b}");
        }
    }

    #[test]
    fn the_clear_sky_warms_towards_the_horizon() {
        let t = Thermal::default();
        let sky = SkyTable::new(&t);
        let (zenith, mid, low) = (sky.clear(1.0), sky.clear(0.5), sky.clear(0.05));
        assert!(
            zenith < mid && mid < low && low <= sky.air,
            "{zenith} {mid} {low}"
        );
        assert!((f64::from(zenith) / f64::from(sky.air) - t.zenith_emissivity).abs() < 1e-3);
        assert_eq!(sky.clear(-0.1), sky.ground);
    }

    #[test]
    fn the_fixed_pattern_depends_on_the_preset_seed_only() {
        // The offsets alone: the radial shading would add its own spread.
        let t = Thermal {
            shading_k: 0.0,
            ..Thermal::default()
        };
        let a = fixed_pattern(&t, 3, 64, 32);
        assert_eq!(a, fixed_pattern(&t, 3, 64, 32));
        assert_ne!(a, fixed_pattern(&t, 4, 64, 32));
        let mean = a.iter().sum::<f32>() / a.len() as f32;
        let sd = (a.iter().map(|v| (v - mean).powi(2)).sum::<f32>() / a.len() as f32).sqrt();
        let expected = 0.04 * radiance_per_kelvin(t.air_k);
        assert!(
            sd > 0.8 * expected && sd < 1.6 * expected,
            "{sd} vs {expected}"
        );
    }
}
