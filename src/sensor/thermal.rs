//! The thermal camera's physics and sensor (issue 41; docs/realism.md,
//! "Thermal camera"): band radiance from temperature, the clear sky's
//! radiance by elevation, and the camera's chain on a radiance plane —
//! the optics' blur, fixed-pattern and temporal noise, automatic gain
//! control to 8-bit grey.
//!
//! Radiance is the 8–14 µm band integral of Planck's law, W·m⁻²·sr⁻¹
//! ([`band_radiance`]). The clear sky's band emissivity at elevation e is
//! `ε(e) = 1 − (1 − ε_z)^(1/sin e)` (the sky's path length grows as
//! 1/sin e), its radiance `ε(e)·B(T_air)`: coldest at the zenith, the air's
//! at the horizon. The camera works on the plane the pipeline composes
//! (`pipeline::thermal`): a Gaussian blur of σ px, then per pixel the fixed
//! pattern (from the preset seed alone: the same in every frame) and the
//! temporal noise (NETD; the deviates of [`super::noise`] under the frame's
//! key), then a linear gain that maps the frame's low and high percentiles
//! to levels 0 and 255, capped at `agc_max_gain` levels per kelvin, their
//! middle at `agc_mid_level`. It knows the preset's `thermal` section and
//! seeds, nothing of scenes, the GPU or files.

use std::sync::OnceLock;

use crate::preset::thermal::{MAX_TEMPERATURE_K, Thermal};

use super::noise::{Key, deviate};

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
    clear: Vec<f32>,
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
        let clear = (0..=SKY_STEPS)
            .map(|k| {
                let s = k as f64 / SKY_STEPS as f64;
                (sky_emissivity(t.zenith_emissivity, s) * air) as f32
            })
            .collect();
        Self {
            clear,
            ground: radiance(t.ground_k),
            cloud: radiance(t.cloud_k),
            air: air as f32,
        }
    }

    /// The clear sky's radiance at sin(elevation) `s` (the ground's below 0).
    #[inline(always)]
    pub fn clear(&self, s: f32) -> f32 {
        if s < 0.0 {
            return self.ground;
        }
        let k = ((s * SKY_STEPS as f32) as usize).min(SKY_STEPS);
        self.clear[k]
    }
}

/// The fixed pattern of a `w`×`h` sensor in radiance units: per-pixel and
/// per-column offsets (σ `fixed_pattern_mk` each, split 3:1 in variance)
/// and the radial shading (`shading_k` at the corners, ∝ ρ²), from
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
    out
}

/// Salt of the fixed pattern's key (under the preset seed).
pub const FIXED_PATTERN_SALT: u64 = 0x5448_4552_4D46_504E; // "THERMFPN"
/// Salt of a frame's temporal noise key (under the frame seed).
pub const NOISE_SALT: u64 = 0x5448_4552_4D4E_4F49; // "THERMNOI"

/// The camera's chain on a composed radiance plane: blur, fixed pattern
/// and temporal noise (key from `noise_seed`), gain control; the grey
/// frame as RGBA8 (R = G = B, A = 255).
pub fn develop(
    t: &Thermal,
    plane: &mut [f32],
    (w, h): (u32, u32),
    pattern: &[f32],
    noise_seed: u64,
) -> Vec<u8> {
    blur(plane, (w as usize, h as usize), t.blur_px as f32);
    let sigma = (t.netd_mk * 1e-3) as f32 * radiance_per_kelvin(t.air_k);
    let key = Key::new(noise_seed);
    for (i, (v, p)) in plane.iter_mut().zip(pattern).enumerate() {
        *v += p + sigma * deviate(key.bits(i as u32));
    }
    let (lo, hi) = percentiles(plane, t.agc_percentiles);
    let cap = t.agc_max_gain as f32 / radiance_per_kelvin(t.air_k);
    let scale = (255.0 / (hi - lo).max(1e-6)).min(cap);
    let offset = t.agc_mid_level as f32 - (lo + hi) * 0.5 * scale;
    let mut out = vec![255u8; plane.len() * 4];
    for (px, v) in out.chunks_exact_mut(4).zip(plane.iter()) {
        let g = (v * scale + offset).clamp(0.0, 255.0).round() as u8;
        px[..3].fill(g);
    }
    out
}

/// Histogram bins of the gain control's percentiles.
const AGC_BINS: usize = 4096;

/// The `(low, high)` percentiles of `plane` to within 1/4096 of its range.
pub fn percentiles(plane: &[f32], (p_lo, p_hi): (f64, f64)) -> (f32, f32) {
    let (mut min, mut max) = (f32::INFINITY, f32::NEG_INFINITY);
    for &v in plane {
        min = min.min(v);
        max = max.max(v);
    }
    if plane.is_empty() || max <= min {
        return (min.min(0.0), min.max(0.0) + 1e-6);
    }
    let scale = (AGC_BINS - 1) as f32 / (max - min);
    let mut hist = vec![0u32; AGC_BINS];
    for &v in plane {
        hist[((v - min) * scale) as usize] += 1;
    }
    let at = |p: f64| {
        let rank = (p / 100.0 * plane.len() as f64).ceil().max(1.0) as u64;
        let mut seen = 0u64;
        for (k, &n) in hist.iter().enumerate() {
            seen += u64::from(n);
            if seen >= rank {
                return min + k as f32 / scale;
            }
        }
        max
    };
    (at(p_lo), at(p_hi))
}

/// A separable Gaussian blur of σ `sigma` px, truncated at ±⌈3σ⌉ (edges clamped).
pub fn blur(plane: &mut [f32], (w, h): (usize, usize), sigma: f32) {
    if sigma <= 0.0 || w == 0 || h == 0 {
        return;
    }
    let r = (3.0 * sigma).ceil() as isize;
    let mut k: Vec<f32> = (-r..=r)
        .map(|d| (-(d * d) as f32 / (2.0 * sigma * sigma)).exp())
        .collect();
    let sum: f32 = k.iter().sum();
    k.iter_mut().for_each(|v| *v /= sum);
    let mut tmp = vec![0.0f32; plane.len()];
    // Rows.
    for (src, dst) in plane.chunks_exact(w).zip(tmp.chunks_exact_mut(w)) {
        for (x, o) in dst.iter_mut().enumerate() {
            let mut acc = 0.0;
            for (j, kv) in k.iter().enumerate() {
                let sx = (x as isize + j as isize - r).clamp(0, w as isize - 1) as usize;
                acc += kv * src[sx];
            }
            *o = acc;
        }
    }
    // Columns: whole rows at a time, so the inner loop runs along memory.
    for y in 0..h {
        let dst = &mut plane[y * w..(y + 1) * w];
        dst.fill(0.0);
        for (j, kv) in k.iter().enumerate() {
            let sy = (y as isize + j as isize - r).clamp(0, h as isize - 1) as usize;
            for (o, s) in dst.iter_mut().zip(&tmp[sy * w..(sy + 1) * w]) {
                *o += kv * s;
            }
        }
    }
}

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
    fn gain_control_maps_the_percentiles_to_the_full_range() {
        let t = Thermal {
            netd_mk: 0.0,
            fixed_pattern_mk: 0.0,
            shading_k: 0.0,
            blur_px: 0.0,
            agc_percentiles: (0.0, 100.0),
            agc_max_gain: 1e4,
            agc_mid_level: 127.5,
            ..Thermal::default()
        };
        let mut plane: Vec<f32> = (0..1000).map(|i| 5.0 + i as f32 * 0.001).collect();
        let pattern = vec![0.0; plane.len()];
        let out = develop(&t, &mut plane, (1000, 1), &pattern, 7);
        let grey: Vec<u8> = out.chunks_exact(4).map(|p| p[0]).collect();
        assert_eq!((grey[0], grey[999]), (0, 255));
        assert!(
            out.chunks_exact(4)
                .all(|p| p[0] == p[1] && p[1] == p[2] && p[3] == 255)
        );
        assert!(grey.windows(2).all(|g| g[0] <= g[1]));
    }

    #[test]
    fn gain_control_keeps_a_low_contrast_scene_low() {
        let t = Thermal {
            netd_mk: 0.0,
            fixed_pattern_mk: 0.0,
            shading_k: 0.0,
            blur_px: 0.0,
            agc_percentiles: (0.0, 100.0),
            ..Thermal::default()
        };
        // A scene spanning one kelvin around the air's temperature.
        let (a, b) = (radiance(t.air_k - 0.5), radiance(t.air_k + 0.5));
        let mut plane: Vec<f32> = (0..100).map(|i| a + (b - a) * i as f32 / 99.0).collect();
        let out = develop(&t, &mut plane, (100, 1), &[0.0; 100], 7);
        let span = i32::from(out[99 * 4]) - i32::from(out[0]);
        assert!(
            (3..=5).contains(&span),
            "{span} levels for 1 K at 4 levels/K"
        );
        assert!(
            (108..=112).contains(&out[50 * 4]),
            "middle at {}",
            out[50 * 4]
        );
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

    #[test]
    fn blur_keeps_the_mean_and_spreads_a_point() {
        let mut p = vec![0.0f32; 81];
        p[40] = 1.0;
        blur(&mut p, (9, 9), 1.0);
        assert!((p.iter().sum::<f32>() - 1.0).abs() < 1e-4);
        assert!(p[40] < 0.2 && p[41] > 0.05 && p[31] > 0.05);
    }
}
