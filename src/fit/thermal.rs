//! `swarmshot fit` with a thermal base preset (`thermal:` set): the thermal camera's own
//! values fitted to grey infrared footage, without plates (a thermal frame is composed
//! from the id pass, not drawn over a photograph) and without the visible camera model
//! (a thermal preset cannot carry one).
//!
//! The first fit ([`first_fit`]) takes the footage's frame size and its JPEG quality (the
//! output format's; PNG footage gives PNG frames); the drones and the thermal values
//! start at the base preset's (the visible fit's first sizing is calibrated on visible
//! renders, so the rounds size a thermal preset's drones).
//!
//! After each round ([`adjust`]), on the final bytes, every statistic outside the real
//! inter-quartile range that a thermal value moves is moved toward the real median:
//!
//! - **flat-sky noise σ**: the temporal noise and the fixed pattern are both white in the
//!   2×2 high-pass, so the measured σ is proportional to `netd_mk` and `fixed_pattern_mk`
//!   together: both × real / synthetic (at most ×4 or ÷4 a round);
//! - **blur σ**: `blur_px` changed in quadrature by the gap to the real median;
//! - **mean brightness**: `agc_mid_level` += real − synthetic (levels);
//! - **peak contrast of 3–6 px drones**: the drone's `skin_k` and `spot_k` (and its
//!   parts' `motor_k` and `battery_k` when set) × real / synthetic (at most ×2 or ÷2 a
//!   round);
//! - **share of drones darker than their ring**: the drone's `cold_share` += real −
//!   synthetic (the share seen colder than the air; within 0–1), each side's share
//!   estimated as (k + 1)/(n + 2) of its n drones ([`succession`]), so footage without a
//!   dark drone does not drive the share to 0;
//! - **drone core size** or the share under 6 px: `size_px_knots` (and `size_px`'s ends)
//!   by the cores' decile ratios ([`super::size_knots::adjust`]).
//!
//! Not fitted (stated in docs/realism.md): the gradient energy, Canny share and
//! background texture (the scene's structure: the gain control stretches the frame's
//! span to 0–255 whatever `agc_max_gain` allows, so no camera value moves them), the
//! sky's and the ground's temperatures.

use super::camera::Footage;
use super::preset_out::{Fitted, sized_to};
use crate::gap::report::{Report, Summary};
use crate::preset::{ImageFormat, Preset};

/// The first fit of a thermal base (module docs), with one note per value.
pub fn first_fit(base: &Preset, footage: &Footage) -> Fitted {
    let (mut p, mut notes) = sized_to(base, footage);
    match (footage.estimate.jpeg_quality, footage.measured.jpeg_quality) {
        (Some(_), Some(q)) => {
            let quality = q.median.round().clamp(1.0, 100.0) as u8;
            p.output.image_format = ImageFormat::Jpeg { quality };
            notes.push(format!(
                "output JPEG quality {quality}: the footage's quantisation tables (median over {} files)",
                q.n
            ));
        }
        _ => {
            p.output.image_format = ImageFormat::Png;
            notes.push("output PNG: the footage is PNG".into());
        }
    }
    notes.push(
        "thermal and the drones: the base preset's values to start; the rounds below move the noise, blur, level, the drones' temperature and size to the footage's"
            .into(),
    );
    Fitted { preset: p, notes }
}

/// (verdict, real median or share, synthetic median or share) of a statistic.
fn stat(report: &Report, key: &str) -> Option<(&'static str, f64, f64)> {
    let r = report.statistics.iter().find(|r| r.key == key)?;
    let centre = |s: Summary| match s {
        Summary::Distribution { median, .. } => median,
        Summary::Share { share, .. } => share,
    };
    Some((r.verdict, centre(r.real?), centre(r.synthetic?)))
}

/// (verdict, real, synthetic) of a share statistic, each side's share estimated by
/// Laplace's rule of succession, (k + 1) / (n + 2): the mean of the share under a
/// uniform prior after k of n drones. None of 66 drones darker is evidence that the share
/// is small (about 1.5 %), not that it is 0, so the fit never drives a share to 0 on a
/// side that happened to show none; both sides are estimated alike, so equal counts
/// still agree.
fn succession(report: &Report, key: &str) -> Option<(&'static str, f64, f64)> {
    let r = report.statistics.iter().find(|r| r.key == key)?;
    let est = |s: Summary| match s {
        Summary::Share { n, k, .. } => Some((k as f64 + 1.0) / (n as f64 + 2.0)),
        Summary::Distribution { .. } => None,
    };
    Some((r.verdict, est(r.real?)?, est(r.synthetic?)?))
}

fn outside(v: &str) -> bool {
    v == "below" || v == "above"
}

fn r3(v: f64) -> f64 {
    (v * 1000.0).round() / 1000.0
}

/// real / synthetic of an outside statistic with both medians positive, within
/// `[1/limit, limit]`.
fn ratio(report: &Report, key: &str, limit: f64) -> Option<(f64, String)> {
    let (v, t, m) = stat(report, key)?;
    (outside(v) && t > 0.0 && m > 0.0).then(|| {
        (
            (t / m).clamp(1.0 / limit, limit),
            format!("{key} {m:.3} {v} the real {t:.3}"),
        )
    })
}

/// Moves a thermal `preset` toward the footage after a round's `report` (module docs);
/// returns what it changed, in words.
pub fn adjust(preset: &mut Preset, report: &Report) -> Vec<String> {
    let mut changes = Vec::new();
    let Some(mut t) = preset.thermal.clone() else {
        return changes;
    };
    if let Some((k, why)) = ratio(report, "noise_sigma", 4.0) {
        let (n2, f2) = (r3(t.netd_mk * k), r3(t.fixed_pattern_mk * k));
        changes.push(format!(
            "thermal.netd_mk {} → {n2}, fixed_pattern_mk {} → {f2} ({why})",
            t.netd_mk, t.fixed_pattern_mk
        ));
        (t.netd_mk, t.fixed_pattern_mk) = (n2, f2);
    }
    if let Some((v, real, m)) = stat(report, "blur_sigma_px")
        && outside(v)
    {
        let b2 = r3((real * real - m * m + t.blur_px * t.blur_px)
            .max(0.0)
            .sqrt()
            .min(8.0));
        if b2 != t.blur_px {
            changes.push(format!(
                "thermal.blur_px {} → {b2} (blur σ {m:.3} {v} the real {real:.3}, in quadrature)",
                t.blur_px
            ));
            t.blur_px = b2;
        }
    }
    if let Some((v, real, m)) = stat(report, "mean_brightness")
        && outside(v)
    {
        let l2 = r3((t.agc_mid_level + real - m).clamp(1.0, 254.0));
        changes.push(format!(
            "thermal.agc_mid_level {} → {l2} (brightness {m:.1} {v} the real {real:.1})",
            t.agc_mid_level
        ));
        t.agc_mid_level = l2;
    }
    if let Some((k, why)) = ratio(report, "small_drone_peak_contrast", 2.0) {
        let d = &mut t.drone;
        let (s2, p2) = (r3(d.skin_k * k), r3(d.spot_k * k));
        changes.push(format!(
            "thermal.drone skin_k {} → {s2}, spot_k {} → {p2} ({why})",
            d.skin_k, d.spot_k
        ));
        (d.skin_k, d.spot_k) = (s2, p2);
        for (name, part) in [("motor_k", &mut d.motor_k), ("battery_k", &mut d.battery_k)] {
            if let Some(v) = part.as_mut() {
                let v2 = r3(*v * k);
                changes.push(format!("thermal.drone {name} {v} → {v2} (the same ratio)"));
                *v = v2;
            }
        }
    }
    if let Some((v, real, m)) = succession(report, "drone_darker")
        && outside(v)
    {
        let d = &mut t.drone;
        let c2 = r3((d.cold_share + real - m).clamp(0.0, 1.0));
        if c2 != d.cold_share {
            changes.push(format!(
                "thermal.drone cold_share {} → {c2} (share darker than their ring {v} the real; (k + 1)/(n + 2) {m:.3} against the real {real:.3})",
                d.cold_share
            ));
            d.cold_share = c2;
        }
    }
    preset.thermal = Some(t);
    super::size_knots::adjust(preset, report, &mut changes);
    changes
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gap::report::{Side, StatRow};

    fn side() -> Side {
        Side {
            dir: String::new(),
            root: Default::default(),
            images_found: 0,
            labelled_frames: 0,
            frames: Vec::new(),
            thumbnails: Vec::new(),
        }
    }

    /// A report whose only row is the share darker than the ring: `real` and `syn` as
    /// (k, n), with the verdict given.
    fn darker(real: (usize, usize), syn: (usize, usize), verdict: &'static str) -> Report {
        let share = |(k, n): (usize, usize)| Summary::Share {
            n,
            k,
            share: k as f64 / n as f64,
            low: 0.0,
            high: 0.01,
        };
        let (r, s) = (share(real), share(syn));
        Report {
            real: side(),
            synthetic: side(),
            statistics: vec![StatRow {
                key: "drone_darker",
                name: "drone_darker",
                unit: "",
                per: "drone",
                real: Some(r),
                synthetic: Some(s),
                verdict,
                iqr_distance: crate::gap::report::iqr_distance(Some(r), Some(s)),
                counted: true,
            }],
            proposals: Vec::new(),
        }
    }

    fn thermal_preset(cold_share: f64) -> Preset {
        let mut p = Preset::load(std::path::Path::new("presets/thermal.ron")).expect("preset");
        p.thermal.as_mut().expect("thermal").drone.cold_share = cold_share;
        p
    }

    fn cold_share(p: &Preset) -> f64 {
        p.thermal.as_ref().expect("thermal").drone.cold_share
    }

    #[test]
    fn footage_without_a_dark_drone_does_not_drive_the_cold_share_to_zero() {
        // 0 of 66 real drones darker, 1 of 96 synthetic: the plain shares (0 against
        // 0.010) would lower the share by a point every round down to 0; by the rule of
        // succession the real 1/68 lies above the synthetic 2/98 by less, and once the
        // synthetic side shows none (1/98) the share rises again.
        let mut p = thermal_preset(0.05);
        adjust(&mut p, &darker((0, 66), (1, 96), "above"));
        let lowered = cold_share(&p);
        assert!(lowered < 0.05 && lowered > 0.04, "{lowered}");
        adjust(&mut p, &darker((0, 66), (0, 96), "inside"));
        assert_eq!(cold_share(&p), lowered, "inside: unchanged");
        let mut q = thermal_preset(0.0);
        adjust(&mut q, &darker((0, 66), (0, 96), "below"));
        assert!(cold_share(&q) > 0.0, "{}", cold_share(&q));
        // Footage with dark drones still raises it by the gap.
        let mut r = thermal_preset(0.0);
        adjust(&mut r, &darker((10, 60), (0, 96), "below"));
        assert!((cold_share(&r) - (11.0 / 62.0 - 1.0 / 98.0)).abs() < 1e-3);
    }
}
