//! The background texture's fit (`thermal.texture`; the module docs of [`super`]): the
//! first fit's RMS from the footage's gradient energy, the rounds' RMS from the gradient
//! energy gap (a texture added when the frames lack structure), and the sharpness from the
//! Canny edge share gap.

use super::{footage_median, r3, ratio, stat};
use crate::fit::camera::Footage;
use crate::gap::report::Report;
use crate::preset::Preset;

/// The first fit's background texture (module docs): the base's texture at the RMS the
/// footage's median gradient energy asks; none when the base has none (the rounds add one
/// when the frames lack structure the footage has: [`adjust_texture`]) or the footage has
/// no frame to measure.
pub(super) fn texture_fit(p: &mut Preset, footage: &Footage, notes: &mut Vec<String>) {
    let Some(t) = p.thermal.as_mut() else {
        return;
    };
    let Some(mut x) = t.texture else {
        return;
    };
    let Some((m, frames)) = footage_median(footage, |f| f.gradient_energy) else {
        return;
    };
    let unit = set_texture_rms(&mut x, m, t.agc_max_gain, footage.size);
    notes.push(format!(
        "thermal.texture rms_k {} K, slope {}, size {}, sharpness {}: the footage's gradient energy {m:.3} levels a pixel (median over {} frames), at the gain control's largest gain of {} levels a kelvin, a texture of 1 K reading {unit:.4} levels a pixel a kelvin",
        x.rms_k,
        x.slope,
        x.size,
        x.sharpness,
        frames,
        t.agc_max_gain
    ));
    t.texture = Some(x);
}

/// Sets `x`'s RMS to the one whose gradient energy reads `levels` a pixel at `gain` levels
/// a kelvin on a `size` frame; returns what 1 K of it reads a kelvin ([`unit_texture_levels`]).
fn set_texture_rms(
    x: &mut crate::preset::thermal::Texture,
    levels: f64,
    gain: f64,
    size: (u32, u32),
) -> f64 {
    let unit = unit_texture_levels(x, size);
    x.rms_k = r3(levels / (gain * unit).max(1e-6)).min(crate::preset::thermal::MAX_TEXTURE_K);
    unit
}

/// Seeds of the fields [`unit_texture_levels`] measures.
const UNIT_SEEDS: [u64; 8] = [1, 2, 3, 4, 5, 6, 7, 8];

/// The gradient energy (levels a pixel, the report's statistic) of `x`'s field at 1 K
/// RMS and 1 level a kelvin on a `w`×`h` frame, the mean over [`UNIT_SEEDS`]: what the first
/// fit divides the footage's by. Measured at 16 levels a kelvin about level 128, so the
/// 8-bit grid does not round it away.
fn unit_texture_levels(x: &crate::preset::thermal::Texture, (w, h): (u32, u32)) -> f64 {
    const GAIN: f32 = 16.0;
    let unit = crate::preset::thermal::Texture { rms_k: 1.0, ..*x };
    let size = (w.clamp(16, 4096), h.clamp(16, 4096));
    let total: f64 = (UNIT_SEEDS.iter())
        .map(|&seed| texture_reading(&unit, (GAIN, 128.0), seed, size) / f64::from(GAIN))
        .sum();
    total / UNIT_SEEDS.len() as f64
}

/// The gradient energy (levels a pixel, as the report measures it) of one field of `x`
/// with seed `seed`, at `gain` levels a kelvin about level `base`, on a `w`×`h` frame
/// rounded to 8 bits.
fn texture_reading(
    x: &crate::preset::thermal::Texture,
    gain_base: (f32, f32),
    seed: u64,
    size: (u32, u32),
) -> f64 {
    let g540 = texture_at_540(x, gain_base, seed, size);
    f64::from(crate::gap::measure::gradient_energy(&g540, None))
}

/// One field of `x` with seed `seed` at `gain` levels a kelvin about level `base` on a
/// `w`×`h` frame, rounded to 8 bits and scaled to 540 px high as the report measures.
fn texture_at_540(
    x: &crate::preset::thermal::Texture,
    (gain, base): (f32, f32),
    seed: u64,
    (w, h): (u32, u32),
) -> image::GrayImage {
    use crate::sensor::thermal::texture::{Anchor, add};
    let mut plane = vec![0f32; w as usize * h as usize];
    let anchor = Anchor {
        seed,
        origin: (0.0, 0.0),
    };
    add(x, gain, anchor, (w, h), &mut plane);
    let grey = image::GrayImage::from_fn(w, h, |x, y| {
        let v = base + plane[(y * w + x) as usize];
        image::Luma([v.round().clamp(0.0, 255.0) as u8])
    });
    crate::gap::measure::gray_at_540(&grey)
}

/// The texture's RMS × real / synthetic gradient energy (at most ×2 or ÷2 a round)
/// when that lies outside. A preset without a texture gets the default one when the
/// gradient energy is below, at the RMS whose gradient energy makes up the gap in
/// quadrature (independent structures' gradients add so), √(real² − synthetic²) over the
/// gain control's largest gain and what 1 K of it reads at the frame's size.
pub(super) fn adjust_texture(
    t: &mut crate::preset::thermal::Thermal,
    report: &Report,
    size: (u32, u32),
    may_add: bool,
    changes: &mut Vec<String>,
) {
    let Some(x) = t.texture.as_mut() else {
        let Some(("below", real, m)) = stat(report, "gradient_energy").filter(|_| may_add) else {
            return;
        };
        let mut x = crate::preset::thermal::Texture::default();
        let gap = (real * real - m * m).max(0.0).sqrt();
        let unit = set_texture_rms(&mut x, gap, t.agc_max_gain, size);
        changes.push(format!(
            "thermal.texture added: rms_k {} K, slope {}, size {}, sharpness {} (gradient_energy {m:.3} below the real {real:.3}: the gap in quadrature {gap:.3} levels a pixel, at {} levels a kelvin, 1 K reading {unit:.4})",
            x.rms_k, x.slope, x.size, x.sharpness, t.agc_max_gain
        ));
        t.texture = Some(x);
        return;
    };
    if let Some((k, why)) = ratio(report, "gradient_energy", 2.0) {
        let r2 = r3(x.rms_k * k).min(crate::preset::thermal::MAX_TEXTURE_K);
        if r2 != x.rms_k {
            changes.push(format!("thermal.texture rms_k {} → {r2} ({why})", x.rms_k));
            x.rms_k = r2;
        }
    }
    adjust_sharpness(x, report, changes);
}

/// The sharpnesses the rounds set. Below 0.25 the clipped field reads as a Gaussian one
/// (clip(s·g) ≈ s·g for |s·g| ≪ 1); the Canny share grows with the sharpness up to about
/// 3 and no further (the default texture at 10 K, 4 levels a kelvin, 320×256, medians of
/// 16 fields: 0.0014, 0.008, 0.025, 0.030 and 0.028 at 0.5, 1, 2, 3 and 6), so the rounds
/// raise it no higher.
const FITTED_SHARPNESS: (f64, f64) = (0.25, 3.0);

/// The texture's sharpness × the square root of real / synthetic Canny edge share (at
/// most ×2 or ÷2 a round, within [`FITTED_SHARPNESS`], never raising one already above
/// it) when that lies outside: at one gradient energy a sharper field gathers its change
/// into more fronts, which Canny marks, about as the sharpness squared between 0.5 and 2
/// (the figures at [`FITTED_SHARPNESS`]; the whole ratio overshoots back and forth). The
/// RMS follows the gradient energy in the same round. A Gaussian field (0) whose frames
/// read too few edges is given sharpness 1.
fn adjust_sharpness(
    x: &mut crate::preset::thermal::Texture,
    report: &Report,
    changes: &mut Vec<String>,
) {
    let Some((k, why)) = ratio(report, "canny_edge_share", 4.0) else {
        return;
    };
    let k = k.sqrt();
    let (lo, hi) = FITTED_SHARPNESS;
    let s2 = match x.sharpness {
        0.0 if k > 1.0 => 1.0,
        0.0 => return,
        s if k > 1.0 => r3((s * k).min(hi.max(s))),
        s => r3((s * k).max(lo.min(s))),
    };
    if s2 != x.sharpness {
        changes.push(format!(
            "thermal.texture sharpness {} → {s2} ({why})",
            x.sharpness
        ));
        x.sharpness = s2;
    }
}

#[cfg(test)]
mod tests {
    use super::super::adjust;
    use super::super::tests::{row_report, thermal_preset};
    use super::*;

    /// Gradient energies of frames of a texture of `rms_k` (the default shape; seeds
    /// `seeds`) at 4 levels a kelvin about level 100, rounded to 8 bits, measured as the
    /// report does.
    fn texture_levels(rms_k: f64, seeds: std::ops::Range<u64>) -> Vec<f64> {
        let x = crate::preset::thermal::Texture {
            rms_k,
            ..Default::default()
        };
        (seeds.map(|seed| texture_reading(&x, (4.0, 100.0), seed, (160, 128)))).collect()
    }

    /// Frames with a 3 K texture: the first fit's unit estimate lands within 20 % of it,
    /// the rounds from 1 K recover it within 15 %; a preset without a texture gets one
    /// within 20 % when its frames read none, and none when they read as much.
    #[test]
    fn the_fit_recovers_a_known_texture_rms() {
        let real = texture_levels(3.0, 0..16);
        let mut sorted = real.clone();
        sorted.sort_by(f64::total_cmp);
        let x = crate::preset::thermal::Texture {
            rms_k: 1.0,
            ..Default::default()
        };
        let first = sorted[sorted.len() / 2] / (4.0 * unit_texture_levels(&x, (160, 128)));
        assert!(
            (first / 3.0 - 1.0).abs() <= 0.2,
            "first estimate {first} K for 3"
        );
        let rms = |p: &Preset| p.thermal.as_ref().and_then(|t| t.texture).map(|x| x.rms_k);
        let mut p = thermal_preset(0.05);
        p.thermal.as_mut().expect("thermal").texture = Some(x);
        let mut log = Vec::new();
        for round in 0..5 {
            let seeds = 100 * (round + 1)..100 * (round + 1) + 16;
            let syn = texture_levels(rms(&p).expect("kept"), seeds);
            log.extend(adjust(&mut p, &row_report("gradient_energy", &real, &syn)));
        }
        let r = rms(&p).expect("kept");
        assert!((r / 3.0 - 1.0).abs() <= 0.15, "RMS {r} K for 3: {log:?}");
        // A preset without one gets the default shape when the gradient energy is below,
        // at the RMS of the gap in quadrature (here all of it: flat frames read 0)...
        let mut q = thermal_preset(0.05);
        q.render.resolution = crate::preset::Resolution::Custom {
            width: 160,
            height: 128,
        };
        let flat = texture_levels(0.0, 0..16);
        adjust(&mut q, &row_report("gradient_energy", &real, &flat));
        let added = rms(&q).expect("added");
        assert!((added / 3.0 - 1.0).abs() <= 0.2, "added {added} K for 3");
        // ...and none when it is inside.
        let mut q = thermal_preset(0.05);
        adjust(&mut q, &row_report("gradient_energy", &real, &real));
        assert_eq!(rms(&q), None);
    }

    /// Gradient energies and Canny edge shares of frames of texture `x` (seeds `seeds`) at
    /// 4 levels a kelvin about level 100, 160×128, measured as the report does.
    fn texture_rows(
        x: &crate::preset::thermal::Texture,
        seeds: std::ops::Range<u64>,
    ) -> (Vec<f64>, Vec<f64>) {
        use crate::gap::measure::{canny_share, gradient_energy};
        let frames: Vec<_> =
            (seeds.map(|seed| texture_at_540(x, (4.0, 100.0), seed, (320, 256)))).collect();
        (
            frames
                .iter()
                .map(|g| f64::from(gradient_energy(g, None)))
                .collect(),
            frames
                .iter()
                .map(|g| f64::from(canny_share(g, None)))
                .collect(),
        )
    }

    /// Frames of a 10 K texture at sharpness 1: from the default sharpness (3) and 5 K,
    /// the rounds bring the sharpness within 35 % of 1 and the RMS within 25 % of 10 K
    /// (both move the Canny share and the gradient energy), and a texture whose frames
    /// read the real edges keeps its sharpness.
    #[test]
    fn the_fit_recovers_a_known_texture_sharpness() {
        use crate::preset::thermal::Texture;
        let truth = Texture {
            rms_k: 10.0,
            sharpness: 1.0,
            ..Default::default()
        };
        let (ge, canny) = texture_rows(&truth, 0..16);
        let report = |x: &Texture, seeds| {
            let (g, c) = texture_rows(x, seeds);
            let mut r = row_report("gradient_energy", &ge, &g);
            r.statistics
                .extend(row_report("canny_edge_share", &canny, &c).statistics);
            r
        };
        let texture = |p: &Preset| p.thermal.as_ref().and_then(|t| t.texture).expect("kept");
        let mut p = thermal_preset(0.05);
        p.thermal.as_mut().expect("thermal").texture = Some(Texture {
            rms_k: 5.0,
            ..Default::default()
        });
        let mut log = Vec::new();
        for round in 0..8 {
            let seeds = 100 * (round + 1)..100 * (round + 1) + 16;
            let r = report(&texture(&p), seeds);
            log.extend(adjust(&mut p, &r));
        }
        let x = texture(&p);
        assert!(
            (x.sharpness - 1.0).abs() <= 0.35,
            "sharpness {}: {log:?}",
            x.sharpness
        );
        assert!(
            (x.rms_k / 10.0 - 1.0).abs() <= 0.25,
            "RMS {} K: {log:?}",
            x.rms_k
        );
        let mut q = thermal_preset(0.05);
        q.thermal.as_mut().expect("thermal").texture = Some(truth);
        adjust(&mut q, &report(&truth, 200..216));
        assert_eq!(texture(&q).sharpness, 1.0);
    }
}
