//! `swarmshot fit` with a thermal base preset (`thermal:` set): the thermal camera's own
//! values fitted to grey infrared footage, without the visible camera model (a thermal
//! preset cannot carry one). The scene is modelled (sky, ground, texture: a thermal frame
//! is composed from the id pass), or with a `backplate` in the base the footage's own
//! frames ([`plates_fit`]: plates as the visible fit writes them, read as radiance).
//!
//! The first fit ([`first_fit`]) takes the footage's frame size, its JPEG quality (the
//! output format's; PNG footage gives PNG frames), its drones per labelled frame
//! (`placement.count`) and the volume that spreads them over the frame as the real boxes
//! spread, at the base's apparent sizes (`placement.volume`, the observer's azimuth 0),
//! as the visible fit takes them, and in a modelled scene where their median box centre
//! lies (`camera.observer.centre_at`, [`drones::aim`]: over plates a drone's background is
//! its own plate's about where its drone was, which one centre for all plates does not
//! give); the drones and the thermal values
//! start at the base preset's (the visible fit's first sizing is calibrated on visible
//! renders, so the rounds size a thermal preset's drones).
//!
//! After each round ([`adjust`]), on the final bytes, every statistic outside the real
//! inter-quartile range that a thermal value moves is moved toward the real median:
//!
//! - **flat-sky noise σ**: the temporal noise and the fixed pattern are both white in the
//!   2×2 high-pass, so the measured σ is proportional to `netd_mk` and `fixed_pattern_mk`
//!   together: both × real / synthetic (at most ×4 or ÷4 a round); a preset with none
//!   (over plates both start at 0) whose frames read below the footage gets `netd_mk` from
//!   the gap in quadrature at the gain control's largest gain ([`add_noise`]); in a
//!   modelled scene, footage whose high-pass RMS is at least twice its σ (a low-rate
//!   codec's sparse noise) gets stronger noise under the capture chain's earlier AC step
//!   instead, the two fitted to its σ and RMS ([`codec`]);
//! - **blur σ**: `blur_px` changed in quadrature by the gap to the real median; over
//!   plates (which hold the footage's blur: `blur_px` blurs only what is drawn on them)
//!   by the small drones' edge width instead, and with the blur at 0 and those edges
//!   still too wide, the drone's warm spot's size `spot_share` (over plates) or half its
//!   heat moved into the skin (a modelled scene) ([`edges`]);
//! - **mean brightness**: `agc_mid_level` += real − synthetic (levels); not over plates,
//!   whose frames are developed with the plates' own gain (`sensor::thermal::plate_gain`:
//!   the plates' levels come back as they are, the middle level moves nothing);
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
//! - **capture chain** (`thermal.capture`, the first fit): the footage's border lines
//!   (each edge's outermost rows or columns whose median offset from the line 8 px in is
//!   at least [`BORDER_MIN_LEVELS`]); with an earlier compression in the base, its DC step
//!   × real / synthetic block steps each round ([`adjust_prior`]).
//!
//! - **narcissus** (`thermal.narcissus`): the first fit adds one when the footage's
//!   median centre depth is below −[`NARCISSUS_MIN_LEVELS`] (a dark centre, the same in
//!   frame after frame), its depth in kelvin that many levels at the gain control's
//!   largest gain; the rounds move the depth × real / synthetic centre depth
//!   ([`adjust_narcissus`]).
//!
//! - **background texture** (`thermal.texture`): with one in the base the first fit
//!   sets its RMS to the footage's median gradient energy over the gain control's
//!   largest gain and what 1 K of the base's texture reads ([`texture_fit`]); a round
//!   whose gradient energy is below the real range adds the default texture to a preset
//!   without one, at the RMS of the gap in quadrature; the rounds move the RMS × real /
//!   synthetic gradient energy (at most ×2 or ÷2 a round; [`adjust_texture`]) and its
//!   sharpness × √(real / synthetic Canny edge share) (at most ×2 or ÷2 a round, within
//!   [`texture::FITTED_SHARPNESS`]): at one gradient energy a sharper field puts its
//!   change into more fronts. Its slope and size stay as they are (all in [`texture`]). The
//!   gradient energy, not the median tile σ: a sharp texture's plateaus put a frame's
//!   median tile on a plateau or a front by chance, where a frame's mean gradient grows
//!   with the RMS.
//!
//! - **horizon** (modelled scene; [`horizon`]): the first fit sets the line of sight's
//!   elevation range from the rows where the footage's horizons lie (or, when fewer than
//!   half its frames show one, keeps the ground out of frame); the rounds move it by the
//!   horizon rows' gap and `ground_k` by the vertical gradient's at the gain control's
//!   largest gain. A round that moves the ground adds no texture, and a texture added
//!   while most of the footage's frames show a horizon lies on the ground alone
//!   (`thermal.texture.ground_only`).
//!
//! - **detail enhancement** (`thermal.detail`, modelled scene; [`horizon`]): the first fit
//!   adds one at gain 1 when most of the footage's frames show a horizon with a deep dark
//!   band over it (the gap's horizon halo); the rounds keep it as it is.
//!
//! Not fitted (stated in docs/realism.md): the Canny share of a preset without a texture
//! (it follows the noise), the sky's and the clouds' temperatures.

use super::camera::Footage;
use super::drones::{self, CentreSpread};
use super::plates::{PlateCamera, PlateSummary};
use super::preset_out::{Fitted, sized_to};
use crate::gap::report::{Report, Summary};
use crate::preset::{ImageFormat, Preset};
use texture::{adjust_texture, texture_fit};

mod codec;
mod edges;
mod horizon;
mod texture;

/// The first fit of a thermal base (module docs), with one note per value; with `plates`
/// (a base with a backplate) the footage's own frames are the scene ([`plates_fit`]);
/// `centres`: the real boxes' spread over the frame.
pub fn first_fit(
    base: &Preset,
    footage: &Footage,
    plates: Option<(&PlateSummary, &PlateCamera)>,
    centres: Option<CentreSpread>,
) -> Fitted {
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
    notes.extend(drones::fit_count(&mut p, footage));
    if let Some((plates, camera)) = plates {
        plates_fit(&mut p, plates, camera, &mut notes);
    } else {
        capture_fit(&mut p, footage, &mut notes);
        narcissus_fit(&mut p, footage, &mut notes);
        texture_fit(&mut p, footage, &mut notes);
        horizon::elevation_fit(&mut p, footage, &mut notes);
        horizon::detail_fit(&mut p, footage, &mut notes);
    }
    drones::spread(&mut p, centres, &mut notes);
    if plates.is_none() {
        drones::aim(&mut p, centres, &mut notes);
    }
    notes.push(
        "thermal and the drones: the base preset's values to start; the rounds below move the noise, blur, level, the drones' temperature and size to the footage's"
            .into(),
    );
    Fitted { preset: p, notes }
}

/// The footage's drone-free frames as the thermal scene (`backplate`; the plates' levels
/// through the inverse of the gain control, `sensor::thermal::plate_plane`): they carry the
/// camera's noise, fixed pattern, shading, blur, narcissus, border lines and the scene's
/// structure, so those start at none and no capture chain, narcissus or texture is
/// fitted. The rounds can add blur (on what is drawn: the drones' edges, [`edges`]) and,
/// where the plates read cleaner than the footage, noise ([`add_noise`]).
fn plates_fit(
    p: &mut Preset,
    plates: &PlateSummary,
    camera: &PlateCamera,
    notes: &mut Vec<String>,
) {
    super::preset_out::set_plates(p, plates, camera, notes);
    if let Some(t) = p.thermal.as_mut() {
        (t.netd_mk, t.fixed_pattern_mk, t.shading_k, t.blur_px) = (0.0, 0.0, 0.0, 0.0);
        (t.capture, t.narcissus, t.texture) = (None, None, None);
    }
    notes.push(
        "thermal over the plates: netd_mk, fixed_pattern_mk, shading_k and blur_px 0, no capture chain, narcissus or texture (the plates carry the camera's and the scene's)"
            .into(),
    );
}

/// A border line's smallest offset from the line 8 further in (levels, the median over
/// the footage's frames) to count as one: a smooth shading changes by a few levels over
/// 8 px, the Anti-UAV captures' blanking lines by 20–65.
pub const BORDER_MIN_LEVELS: f64 = 10.0;
/// The footage's median block steps (levels) above which it shows an earlier
/// compression: the final JPEG at quality 95 of a frame without one gives about 0.2.
pub const PRIOR_MIN_STEPS: f64 = 0.35;

/// The capture chain (`thermal.capture`) from the footage's grey frames: each edge's
/// border lines, from the edge inward while the median offset is at least
/// [`BORDER_MIN_LEVELS`], at that median. The earlier compression is the base's: the
/// rounds fit its DC step when the base has one ([`adjust_prior`]); without, a note says
/// whether the footage's median block steps exceed [`PRIOR_MIN_STEPS`] (on the Anti-UAV
/// fitting half, turning it on moved the flat-sky high-pass RMS out of range: the noise
/// fit makes up for the noise it removes; docs/realism.md).
fn capture_fit(p: &mut Preset, footage: &Footage, notes: &mut Vec<String>) {
    let Some(t) = p.thermal.as_mut() else {
        return;
    };
    let lines: Vec<_> = footage
        .per_frame
        .iter()
        .filter_map(|f| f.edge_lines)
        .collect();
    let median = |mut v: Vec<f64>| {
        v.sort_by(f64::total_cmp);
        (!v.is_empty()).then(|| v[v.len() / 2])
    };
    let mut c = t.capture.clone().unwrap_or_default();
    let mut found = false;
    let edges: [(&str, &mut Vec<f64>); 4] = [
        ("top_rows", &mut c.top_rows),
        ("bottom_rows", &mut c.bottom_rows),
        ("left_columns", &mut c.left_columns),
        ("right_columns", &mut c.right_columns),
    ];
    for (e, (name, out)) in edges.into_iter().enumerate() {
        let offsets: Vec<f64> = (0..4)
            .map_while(|k| median(lines.iter().map(|l| f64::from(l[e][k])).collect()))
            .take_while(|m| m.abs() >= BORDER_MIN_LEVELS)
            .map(|m| (m * 10.0).round() / 10.0)
            .collect();
        if !offsets.is_empty() {
            notes.push(format!(
                "thermal.capture.{name} {offsets:?}: the footage's border lines (median offset from the line 8 px in over {} frames, at least {BORDER_MIN_LEVELS} levels)",
                lines.len()
            ));
            *out = offsets;
            found = true;
        }
    }
    if let Some((m, frames)) = footage_median(footage, |f| f.block_steps)
        && m > PRIOR_MIN_STEPS
        && c.prior_dc_step == 0.0
    {
        notes.push(format!(
            "the footage's block steps {m:.2} levels (median over {frames} frames) show an earlier 8×8 compression, not modelled: a base with thermal.capture.prior_dc_step set has it fitted"
        ));
    }
    if found {
        t.capture = Some(c);
    }
}

/// The footage's median centre depth (levels) below which the first fit adds a
/// narcissus: a scene's own structure (a horizon low in the frame, a cloud) moves the
/// centre depth by a few levels either way from frame to frame.
pub const NARCISSUS_MIN_LEVELS: f64 = 8.0;

/// The first fit's narcissus (module docs): none when the base has one or the footage's
/// median centre depth is above −[`NARCISSUS_MIN_LEVELS`].
fn narcissus_fit(p: &mut Preset, footage: &Footage, notes: &mut Vec<String>) {
    let Some(t) = p.thermal.as_mut().filter(|t| t.narcissus.is_none()) else {
        return;
    };
    let Some((m, frames)) = footage_median(footage, |f| f.centre_depth) else {
        return;
    };
    if m >= -NARCISSUS_MIN_LEVELS {
        return;
    }
    let n = crate::preset::thermal::Narcissus {
        depth_k: r3(-m / t.agc_max_gain),
        ..Default::default()
    };
    notes.push(format!(
        "thermal.narcissus depth_k {} K, radius {}: the footage's centre reads {m:.1} levels against the ring about it (median over {} frames), at the gain control's largest gain of {} levels a kelvin",
        n.depth_k,
        n.radius,
        frames,
        t.agc_max_gain
    ));
    t.narcissus = Some(n);
}

/// The median over the footage's frames of a per-frame figure, and how many frames have it.
fn footage_median(
    footage: &Footage,
    figure: impl Fn(&super::camera::FrameFigures) -> Option<f32>,
) -> Option<(f64, usize)> {
    let mut v: Vec<f64> = footage
        .per_frame
        .iter()
        .filter_map(|f| figure(f).map(f64::from))
        .collect();
    v.sort_by(f64::total_cmp);
    (!v.is_empty()).then(|| (v[v.len() / 2], v.len()))
}

/// The narcissus' depth × real / synthetic centre depth (at most ×2 or ÷2 a round)
/// when it lies outside, both centres reading dark, and the preset has one.
fn adjust_narcissus(
    t: &mut crate::preset::thermal::Thermal,
    report: &Report,
    changes: &mut Vec<String>,
) {
    let Some(n) = t.narcissus.as_mut() else {
        return;
    };
    let Some((v, real, m)) = stat(report, "centre_depth").filter(|s| outside(s.0)) else {
        return;
    };
    if real >= 0.0 || m >= 0.0 {
        return;
    }
    let d2 = r3(n.depth_k * (real / m).clamp(0.5, 2.0)).clamp(
        -crate::preset::thermal::MAX_NARCISSUS_K,
        crate::preset::thermal::MAX_NARCISSUS_K,
    );
    if d2 != n.depth_k {
        changes.push(format!(
            "thermal.narcissus depth_k {} → {d2} (centre depth {m:.2} {v} the real {real:.2})",
            n.depth_k
        ));
        n.depth_k = d2;
    }
}

/// The earlier compression's DC step × real / synthetic block steps (at most ×2 or ÷2 a
/// round; ×2 when the synthetic frames show none), when they lie outside and the preset
/// has one.
fn adjust_prior(
    t: &mut crate::preset::thermal::Thermal,
    report: &Report,
    changes: &mut Vec<String>,
) {
    let Some(c) = t.capture.as_mut().filter(|c| c.prior_dc_step > 0.0) else {
        return;
    };
    let Some((v, real, m)) = stat(report, "block_steps").filter(|s| outside(s.0)) else {
        return;
    };
    let k = if m > 0.01 {
        (real / m).clamp(0.5, 2.0)
    } else {
        2.0
    };
    let d2 = r3((c.prior_dc_step * k).clamp(1.0, 255.0));
    if d2 != c.prior_dc_step {
        changes.push(format!(
            "thermal.capture.prior_dc_step {} → {d2} (block steps {m:.3} {v} the real {real:.3})",
            c.prior_dc_step
        ));
        c.prior_dc_step = d2;
    }
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

/// Noise for a preset without any (`netd_mk` and `fixed_pattern_mk` 0, as over plates)
/// whose frames read less than the footage: `netd_mk` the gap in quadrature, √(real² −
/// synthetic²) levels, at the gain control's largest gain (`agc_max_gain` levels a kelvin,
/// where plates sit); the note, or None when it does not apply (the ratio rule then scales
/// what there is).
fn add_noise(t: &mut crate::preset::thermal::Thermal, report: &Report) -> Option<String> {
    let (v, real, m) = stat(report, "noise_sigma")?;
    if v != "below" || t.netd_mk != 0.0 || t.fixed_pattern_mk != 0.0 || t.agc_max_gain <= 0.0 {
        return None;
    }
    let gap = (real * real - m.max(0.0).powi(2)).max(0.0).sqrt();
    let n2 = r3(1000.0 * gap / t.agc_max_gain);
    t.netd_mk = n2;
    Some(format!(
        "thermal.netd_mk 0 → {n2} (noise σ {m:.3} below the real {real:.3}: the gap {gap:.3} levels in quadrature at the gain control's largest gain, {} levels a kelvin)",
        t.agc_max_gain
    ))
}

/// The noise σ as white noise: [`add_noise`] to a preset without any, else `netd_mk` and
/// `fixed_pattern_mk` × real / synthetic σ (at most ×4 or ÷4).
fn white_noise(
    t: &mut crate::preset::thermal::Thermal,
    report: &Report,
    changes: &mut Vec<String>,
) {
    if let Some(note) = add_noise(t, report) {
        changes.push(note);
    } else if let Some((k, why)) = ratio(report, "noise_sigma", 4.0) {
        let (n2, f2) = (r3(t.netd_mk * k), r3(t.fixed_pattern_mk * k));
        changes.push(format!(
            "thermal.netd_mk {} → {n2}, fixed_pattern_mk {} → {f2} ({why})",
            t.netd_mk, t.fixed_pattern_mk
        ));
        (t.netd_mk, t.fixed_pattern_mk) = (n2, f2);
    }
}

/// Moves a thermal `preset` toward the footage after a round's `report` (module docs);
/// returns what it changed, in words.
pub fn adjust(preset: &mut Preset, report: &Report) -> Vec<String> {
    let mut changes = Vec::new();
    let Some(mut t) = preset.thermal.clone() else {
        return changes;
    };
    // Over plates the plates carry the footage's noise as its codec left it.
    if !(preset.backplate.is_none() && codec::adjust(&mut t, report, &mut changes)) {
        white_noise(&mut t, report, &mut changes);
    }
    edges::adjust_blur(&mut t, report, preset.backplate.is_some(), &mut changes);
    // Over plates the levels are the plates' own (`plate_gain`): the middle level moves nothing.
    if let Some((v, real, m)) = stat(report, "mean_brightness")
        && outside(v)
        && preset.backplate.is_none()
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
    adjust_prior(&mut t, report, &mut changes);
    adjust_narcissus(&mut t, report, &mut changes);
    // Over plates the scene's structure is the footage's own: no texture is added or moved.
    // A round that moves the ground adds no texture: the horizon's step is structure too.
    if preset.backplate.is_none() {
        let ground = t.ground_k;
        horizon::adjust_ground(&mut t, report, &mut changes);
        let (size, may_add) = (preset.render.resolution.size(), t.ground_k == ground);
        let had = t.texture.is_some();
        adjust_texture(&mut t, report, size, may_add, &mut changes);
        if !had {
            horizon::texture_on_ground(&mut t, report, &mut changes);
        }
    }
    preset.thermal = Some(t);
    horizon::adjust_elevation(preset, report, &mut changes);
    super::size_knots::adjust(preset, report, &mut changes);
    changes
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gap::report::{Side, StatRow};

    fn side() -> Side {
        Side {
            drone_classes: "all".into(),
            ..Side::default()
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
            real_halves: None,
        }
    }

    /// Frames cleaner than the footage with no noise in the preset (over plates) get the
    /// gap in quadrature as NETD at the largest gain; with noise the ratio rule scales it;
    /// frames as noisy as the footage change nothing.
    #[test]
    fn plates_cleaner_than_the_footage_get_the_noise_gap() {
        let clean = row_report("noise_sigma", &[0.4, 0.5, 0.6], &[0.3]);
        let mut p = thermal_preset(0.0);
        let t = p.thermal.as_mut().expect("thermal");
        (t.netd_mk, t.fixed_pattern_mk, t.agc_max_gain) = (0.0, 0.0, 4.0);
        let changes = adjust(&mut p, &clean);
        let t = p.thermal.as_ref().expect("thermal");
        assert_eq!(
            t.netd_mk, 100.0,
            "√(0.5² − 0.3²) = 0.4 levels at 4 a kelvin: {changes:?}"
        );
        assert_eq!(t.fixed_pattern_mk, 0.0);
        let mut q = thermal_preset(0.0);
        let t = q.thermal.as_mut().expect("thermal");
        (t.netd_mk, t.fixed_pattern_mk) = (30.0, 10.0);
        adjust(&mut q, &clean);
        let t = q.thermal.as_ref().expect("thermal");
        assert_eq!(
            (t.netd_mk, t.fixed_pattern_mk),
            (r3(30.0 * 0.5 / 0.3), r3(10.0 * 0.5 / 0.3))
        );
        let mut r = thermal_preset(0.0);
        let t = r.thermal.as_mut().expect("thermal");
        (t.netd_mk, t.fixed_pattern_mk) = (0.0, 0.0);
        adjust(&mut r, &row_report("noise_sigma", &[0.4, 0.5, 0.6], &[0.5]));
        assert_eq!(r.thermal.as_ref().expect("thermal").netd_mk, 0.0);
    }

    pub(super) fn thermal_preset(cold_share: f64) -> Preset {
        let mut p = Preset::load(std::path::Path::new("presets/thermal.ron")).expect("preset");
        p.thermal.as_mut().expect("thermal").drone.cold_share = cold_share;
        p
    }

    fn cold_share(p: &Preset) -> f64 {
        p.thermal.as_ref().expect("thermal").drone.cold_share
    }

    /// A 96×96 grey sky after the gain control: a slope of 0.2 levels a pixel down and
    /// 0.1 across, noise of σ ≈ 0.6 levels (a hash of `seed` and the pixel), rounded.
    fn sky(seed: u64) -> Vec<u8> {
        let n = 96;
        let mut out = Vec::with_capacity(n * n * 4);
        for i in 0..n * n {
            let (x, y) = ((i % n) as f64, (i / n) as f64);
            let h = crate::seed::mix64(seed.wrapping_mul(1 << 20) ^ i as u64);
            let u = (h >> 11) as f64 / (1u64 << 53) as f64 + ((h & 0x7FF) as f64) / 2048.0;
            let g = (70.0 + 0.1 * x + 0.2 * y + 0.85 * (u - 1.0)).round() as u8;
            out.extend_from_slice(&[g, g, g, 255]);
        }
        out
    }

    /// The block steps of the skies through an earlier compression at DC step `dc`.
    fn block_steps_at(skies: &[Vec<u8>], dc: f64) -> Vec<f64> {
        let c = crate::preset::thermal::Capture {
            prior_dc_step: dc,
            prior_ac_step: 4.0,
            ..Default::default()
        };
        let steps = |f: &Vec<u8>| {
            let mut f = f.clone();
            crate::sensor::thermal::capture::apply(&c, (96, 96), &mut f);
            let grey: Vec<u8> = f.chunks_exact(4).map(|p| p[0]).collect();
            crate::sensor::thermal::capture::block_steps(&grey, (96, 96), |_| false)
        };
        skies.iter().filter_map(steps).map(f64::from).collect()
    }

    /// A report whose only row is the block steps of `real` and `syn` frames.
    fn steps_report(real: &[f64], syn: &[f64]) -> Report {
        row_report("block_steps", real, syn)
    }

    /// A report whose only row is the frame statistic `key` of `real` and `syn` frames.
    pub(super) fn row_report(key: &'static str, real: &[f64], syn: &[f64]) -> Report {
        let (r, s) = (
            crate::gap::report::distribution(real),
            crate::gap::report::distribution(syn),
        );
        let (lo, hi) = match r {
            Some(Summary::Distribution { q25, q75, .. }) => (q25, q75),
            _ => panic!("real frames measured"),
        };
        let m = stat_centre(s);
        let verdict = if m < lo {
            "below"
        } else if m > hi {
            "above"
        } else {
            "inside"
        };
        Report {
            real: side(),
            synthetic: side(),
            statistics: vec![StatRow {
                key,
                name: key,
                unit: "levels",
                per: "frame",
                real: r,
                synthetic: s,
                verdict,
                iqr_distance: crate::gap::report::iqr_distance(r, s),
                counted: false,
            }],
            proposals: Vec::new(),
            real_halves: None,
        }
    }

    fn stat_centre(s: Option<Summary>) -> f64 {
        match s {
            Some(Summary::Distribution { median, .. }) => median,
            _ => f64::NAN,
        }
    }

    #[test]
    fn the_rounds_recover_a_known_earlier_compressions_dc_step() {
        let skies: Vec<Vec<u8>> = (0..12).map(sky).collect();
        let real = block_steps_at(&skies, 24.0);
        let mut p = thermal_preset(0.05);
        let capture = |p: &Preset| p.thermal.as_ref().and_then(|t| t.capture.clone());
        let t = p.thermal.as_mut().expect("thermal");
        t.capture = Some(crate::preset::thermal::Capture {
            prior_dc_step: 8.0,
            prior_ac_step: 4.0,
            ..Default::default()
        });
        let mut log = Vec::new();
        for _ in 0..6 {
            let dc = capture(&p).expect("kept").prior_dc_step;
            let syn = block_steps_at(&skies, dc);
            log.extend(adjust(&mut p, &steps_report(&real, &syn)));
        }
        let dc = capture(&p).expect("kept").prior_dc_step;
        assert!(
            (dc / 24.0 - 1.0).abs() <= 0.25,
            "DC step {dc} for 24: {log:?}"
        );
        // Without an earlier compression in the preset, nothing is added by the rounds.
        let mut q = thermal_preset(0.05);
        adjust(&mut q, &steps_report(&real, &block_steps_at(&skies, 0.0)));
        assert!(capture(&q).is_none());
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

    /// Centre depths of frames of the fixed pattern (the preset's shading and the
    /// narcissus of `depth_k`, seeds `seeds`) at a gain of 3 levels a kelvin: what the
    /// gain control makes of a smooth sky, the sensor's plane measured as the report does.
    fn centre_depths(depth_k: Option<f64>, seeds: std::ops::Range<u64>) -> Vec<f64> {
        let mut t = thermal_preset(0.05).thermal.expect("thermal");
        t.narcissus = depth_k.map(|depth_k| crate::preset::thermal::Narcissus {
            depth_k,
            ..Default::default()
        });
        let per_k = crate::sensor::thermal::radiance_per_kelvin(t.air_k);
        let (w, h) = (160, 128);
        seeds
            .filter_map(|seed| {
                let plane = crate::sensor::thermal::fixed_pattern(&t, seed, w, h);
                let y = plane.iter().map(|v| 100.0 + 3.0 * v / per_k).collect();
                let l = crate::gap::measure::Luma {
                    width: w as usize,
                    height: h as usize,
                    y,
                };
                crate::gap::capture::centre_depth(&l, &[], None).map(f64::from)
            })
            .collect()
    }

    /// Frames with a 6 K narcissus: the rounds from a 2 K one recover it within 15 %; a
    /// preset without one gets none from the rounds (the first fit adds it).
    #[test]
    fn the_rounds_recover_a_known_narcissus_depth() {
        let real = centre_depths(Some(6.0), 0..16);
        let mut p = thermal_preset(0.05);
        let depth = |p: &Preset| {
            p.thermal
                .as_ref()
                .and_then(|t| t.narcissus)
                .map(|n| n.depth_k)
        };
        p.thermal.as_mut().expect("thermal").narcissus = Some(crate::preset::thermal::Narcissus {
            depth_k: 2.0,
            ..Default::default()
        });
        let mut log = Vec::new();
        for round in 0..5 {
            let syn = centre_depths(depth(&p), 100 * (round + 1)..100 * (round + 1) + 16);
            log.extend(adjust(&mut p, &row_report("centre_depth", &real, &syn)));
        }
        let d = depth(&p).expect("kept");
        assert!((d / 6.0 - 1.0).abs() <= 0.15, "depth {d} K for 6: {log:?}");
        let mut q = thermal_preset(0.05);
        adjust(
            &mut q,
            &row_report("centre_depth", &real, &centre_depths(None, 0..16)),
        );
        assert_eq!(depth(&q), None);
    }
}
