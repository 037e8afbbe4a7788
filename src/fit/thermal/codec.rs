//! The thermal fit's noise on footage a low-rate codec left sparse (the module docs of
//! [`super`]; modelled scenes only: plates carry the footage's own).
//!
//! A video codec at a low rate keeps a noisy sky's blocks flat and lets the noise through
//! only where a coefficient passes its step, as a whole block's pattern: most of the 2×2
//! high-pass is exactly 0 (the noise σ statistic, 1.4826·MAD, then reads the share of
//! zeros) while the RMS holds the surviving patterns. White noise of any σ reads an RMS
//! 0.9–1.5 × its σ; `svanstrom-ir` (H.264 at about 18 kb/s) reads σ 0.29 and RMS 0.94,
//! 61 % of its high-pass values 0. Footage whose RMS is at least [`SPARSE_RATIO`] × its σ
//! is taken as such, and the fit draws it with the capture chain's earlier compression
//! (`thermal.capture.prior_ac_step`, the DC kept) over stronger noise: for white noise of
//! σₙ levels under an AC step of s, the zero share, and so the σ statistic, follow s / σₙ
//! alone, and the RMS is σₙ × a function of s / σₙ (the 8×8 DCT is linear and the
//! quantiser scales with its step). At s = [`STEP_PER_NOISE`] σₙ about 60 % of the
//! high-pass is 0 (σ ≈ 0.29) and the RMS is [`RMS_PER_NOISE`] σₙ (lib test on this
//! module's own compression and measure). Each round with the footage sparse:
//!
//! - a preset without an AC step gets one: the noise (`netd_mk` and `fixed_pattern_mk`
//!   together) × σₙ / the frames' noise σ, σₙ = real RMS ÷ [`RMS_PER_NOISE`], and
//!   `prior_ac_step` = [`STEP_PER_NOISE`] σₙ;
//! - with one, the RMS outside moves the noise and the step together × real / synthetic
//!   RMS (at most ×2 or ÷2: the same s / σₙ, an RMS in proportion), and the noise σ
//!   outside the step alone × (synthetic / real σ)^[`SIGMA_EXPONENT`] (within ×1.25 or
//!   ÷1.25 a round: the σ statistic falls about as (s / σₙ)^−3.3 near the footage's
//!   zero share, lib test).
//!
//! The white-noise rule of [`super::adjust`] does not run on such footage.

use super::{outside, r3, stat};
use crate::gap::report::Report;
use crate::preset::thermal::{Capture, Thermal};

/// The footage's high-pass RMS ÷ noise σ at or above which its noise reads sparse.
pub const SPARSE_RATIO: f64 = 2.0;
/// The AC step, in σₙ of the noise before it, that leaves about 60 % of the high-pass 0.
pub const STEP_PER_NOISE: f64 = 5.0;
/// The high-pass RMS of white noise of σₙ 1 level under an AC step of [`STEP_PER_NOISE`].
pub const RMS_PER_NOISE: f64 = 0.58;
/// The step's exponent of the σ statistic's ratio (module docs).
pub const SIGMA_EXPONENT: f64 = 0.3;

/// Moves the noise and the earlier compression's AC step on footage whose noise reads
/// sparse (module docs); false, changing nothing, on other footage.
pub(super) fn adjust(t: &mut Thermal, report: &Report, changes: &mut Vec<String>) -> bool {
    let (Some(sigma), Some(rms)) = (stat(report, "noise_sigma"), stat(report, "highpass_rms"))
    else {
        return false;
    };
    let (real_sigma, real_rms) = (sigma.1, rms.1);
    if !(real_sigma > 0.0 && real_rms >= SPARSE_RATIO * real_sigma) {
        return false;
    }
    let step = t.capture.as_ref().map_or(0.0, |c| c.prior_ac_step);
    if step == 0.0 {
        add_step(t, (sigma.2, real_rms), changes);
        return true;
    }
    if outside(rms.0) && rms.2 > 0.0 {
        let k = (real_rms / rms.2).clamp(0.5, 2.0);
        let why = format!(
            "high-pass RMS {:.3} {} the real {real_rms:.3}: the noise and the step together, the same zero share",
            rms.2, rms.0
        );
        scale_noise(t, k, &why, changes);
        set_step(t, step * k, &why, changes);
    }
    if outside(sigma.0) && sigma.2 > 0.0 {
        let step = t.capture.as_ref().map_or(0.0, |c| c.prior_ac_step);
        let k = (sigma.2 / real_sigma)
            .powf(SIGMA_EXPONENT)
            .clamp(1.0 / 1.25, 1.25);
        let why = format!(
            "noise σ {:.3} {} the real {real_sigma:.3}: the share of the high-pass the step zeroes",
            sigma.2, sigma.0
        );
        set_step(t, step * k, &why, changes);
    }
    true
}

/// The first AC step (module docs), from the frames' noise σ (`synthetic_sigma`, white
/// noise: its σₙ) and the footage's RMS.
fn add_step(t: &mut Thermal, (synthetic_sigma, real_rms): (f64, f64), changes: &mut Vec<String>) {
    let noise = real_rms / RMS_PER_NOISE;
    let why = format!(
        "the footage's high-pass RMS {real_rms:.3} at least {SPARSE_RATIO} × its noise σ: a codec's sparse noise, σₙ {noise:.3} levels under an AC step of {STEP_PER_NOISE} σₙ"
    );
    if synthetic_sigma > 0.0 {
        scale_noise(t, (noise / synthetic_sigma).clamp(0.25, 8.0), &why, changes);
    }
    set_step(t, STEP_PER_NOISE * noise, &why, changes);
}

/// `netd_mk` and `fixed_pattern_mk` × `k`.
fn scale_noise(t: &mut Thermal, k: f64, why: &str, changes: &mut Vec<String>) {
    let (n2, f2) = (r3(t.netd_mk * k), r3(t.fixed_pattern_mk * k));
    changes.push(format!(
        "thermal.netd_mk {} → {n2}, fixed_pattern_mk {} → {f2} ({why})",
        t.netd_mk, t.fixed_pattern_mk
    ));
    (t.netd_mk, t.fixed_pattern_mk) = (n2, f2);
}

/// `thermal.capture.prior_ac_step` at `step` (within 1–255; a capture chain added when
/// the preset has none).
fn set_step(t: &mut Thermal, step: f64, why: &str, changes: &mut Vec<String>) {
    let c = t.capture.get_or_insert_with(Capture::default);
    let s2 = r3(step.clamp(1.0, 255.0));
    if s2 != c.prior_ac_step {
        changes.push(format!(
            "thermal.capture.prior_ac_step {} → {s2} ({why})",
            c.prior_ac_step
        ));
        c.prior_ac_step = s2;
    }
}

#[cfg(test)]
mod tests {
    use super::super::tests::row_report;
    use super::*;
    use crate::gap::measure::{Luma, flat_sky};

    /// A 256×256 grey sky (a slope of 0.05 levels a pixel) with white noise of `sigma`
    /// levels (a hash of the pixel, Box–Muller), through the capture chain's AC step
    /// `step`; the noise σ and high-pass RMS the report reads.
    fn compressed_sky(sigma: f64, step: f64) -> (f64, f64) {
        let n = 256usize;
        let mut rgba = Vec::with_capacity(n * n * 4);
        for i in 0..n * n {
            let h = crate::seed::mix64(0x5EED ^ i as u64);
            let u1 = ((h >> 11) as f64 + 1.0) / (1u64 << 53) as f64;
            let u2 = (crate::seed::mix64(h) >> 11) as f64 / (1u64 << 53) as f64;
            let z = (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos();
            let g = (100.0 + 0.05 * (i % n) as f64 + sigma * z)
                .round()
                .clamp(0.0, 255.0) as u8;
            rgba.extend_from_slice(&[g, g, g, 255]);
        }
        let c = Capture {
            prior_ac_step: step,
            ..Capture::default()
        };
        crate::sensor::thermal::capture::apply(&c, (n as u32, n as u32), &mut rgba);
        let rgb = image::RgbImage::from_fn(n as u32, n as u32, |x, y| {
            let g = rgba[(y as usize * n + x as usize) * 4];
            image::Rgb([g, g, g])
        });
        let s = flat_sky(&rgb, &Luma::from_rgb(&rgb), &[]);
        (
            f64::from(s.noise_sigma.expect("σ")),
            f64::from(s.highpass_rms.expect("RMS")),
        )
    }

    /// The constants on this crate's own compression and measure: white noise under an AC
    /// step of [`STEP_PER_NOISE`] σₙ reads σ 0.2–0.4 and an RMS of [`RMS_PER_NOISE`] σₙ
    /// (within 20 %) at σₙ 1.5 and 3 (the same zero share at either: the statistic
    /// follows s / σₙ), at least [`SPARSE_RATIO`] × its σ; without the step white noise
    /// reads under that ratio; a larger s / σₙ reads a smaller σ.
    #[test]
    fn a_step_of_five_noise_sigmas_reads_as_sparse_codec_noise() {
        for noise in [1.5, 3.0] {
            let (sigma, rms) = compressed_sky(noise, STEP_PER_NOISE * noise);
            assert!((0.2..=0.4).contains(&sigma), "σₙ {noise}: σ {sigma}");
            assert!(
                (rms / (RMS_PER_NOISE * noise) - 1.0).abs() < 0.2,
                "σₙ {noise}: RMS {rms}"
            );
            assert!(rms >= SPARSE_RATIO * sigma);
            let (white_sigma, white_rms) = compressed_sky(noise, 0.0);
            assert!(
                white_rms < SPARSE_RATIO * white_sigma,
                "{white_sigma} {white_rms}"
            );
            let (wider, _) = compressed_sky(noise, 1.2 * STEP_PER_NOISE * noise);
            assert!(wider < sigma, "{wider} against {sigma}");
        }
    }

    fn report(sigma: (&[f64], &[f64]), rms: (&[f64], &[f64])) -> Report {
        let mut r = row_report("noise_sigma", sigma.0, sigma.1);
        r.statistics
            .extend(row_report("highpass_rms", rms.0, rms.1).statistics);
        r
    }

    fn thermal(step: f64) -> Thermal {
        let mut t = Thermal {
            netd_mk: 40.0,
            fixed_pattern_mk: 20.0,
            ..Thermal::default()
        };
        if step > 0.0 {
            t.capture = Some(Capture {
                prior_ac_step: step,
                ..Capture::default()
            });
        }
        t
    }

    const REAL_SIGMA: [f64; 3] = [0.2, 0.29, 0.35];
    const REAL_RMS: [f64; 3] = [0.5, 0.94, 1.2];

    /// Sparse footage: a preset without a step gets one and the noise σₙ = RMS ÷ 0.58;
    /// with one, the RMS moves noise and step together, the σ the step alone; white
    /// footage (RMS under 2 σ) is left to the white-noise rule.
    #[test]
    fn sparse_footage_fits_the_step_and_the_noise() {
        let mut changes = Vec::new();
        let first = report((&REAL_SIGMA, &[0.31]), (&REAL_RMS, &[0.37]));
        let mut t = thermal(0.0);
        assert!(adjust(&mut t, &first, &mut changes));
        let noise = 0.94 / RMS_PER_NOISE;
        assert_eq!(t.netd_mk, r3(40.0 * noise / 0.31), "{changes:?}");
        assert_eq!(t.fixed_pattern_mk, r3(20.0 * noise / 0.31));
        let step = t.capture.as_ref().expect("a capture chain").prior_ac_step;
        assert_eq!(step, r3(STEP_PER_NOISE * noise));
        let low = report((&REAL_SIGMA, &[0.3]), (&REAL_RMS, &[0.47]));
        let mut t = thermal(8.0);
        adjust(&mut t, &low, &mut changes);
        let k = 0.94 / 0.47;
        assert_eq!(
            (t.netd_mk, t.fixed_pattern_mk),
            (r3(40.0 * k), r3(20.0 * k))
        );
        assert_eq!(t.capture.as_ref().map(|c| c.prior_ac_step), Some(16.0));
        let loud = report((&REAL_SIGMA, &[0.6]), (&REAL_RMS, &[1.0]));
        let mut t = thermal(8.0);
        adjust(&mut t, &loud, &mut changes);
        assert_eq!(t.netd_mk, 40.0, "the RMS inside: the noise stays");
        let want = r3(8.0 * (0.6f64 / 0.29).powf(SIGMA_EXPONENT));
        assert_eq!(t.capture.as_ref().map(|c| c.prior_ac_step), Some(want));
        let white = report((&[0.5, 0.6, 0.7], &[0.3]), (&[0.6, 0.7, 0.8], &[0.35]));
        let mut t = thermal(0.0);
        assert!(!adjust(&mut t, &white, &mut changes));
        assert_eq!((t.netd_mk, t.capture.is_none()), (40.0, true));
    }
}
