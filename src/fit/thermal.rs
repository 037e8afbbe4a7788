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
//!   synthetic (the share seen colder than the air; within 0–1);
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
    if let Some((v, real, m)) = stat(report, "drone_darker")
        && outside(v)
    {
        let d = &mut t.drone;
        let c2 = r3((d.cold_share + real - m).clamp(0.0, 1.0));
        changes.push(format!(
            "thermal.drone cold_share {} → {c2} (share darker than their ring {m:.3} {v} the real {real:.3})",
            d.cold_share
        ));
        d.cold_share = c2;
    }
    preset.thermal = Some(t);
    super::size_knots::adjust(preset, report, &mut changes);
    changes
}
