//! The thermal fit's horizon (modelled scene; the module docs of [`super`]): where the
//! footage's horizon lies ([`crate::gap::horizon`]) sets the line of sight's elevation,
//! and how much the lower third reads above the upper third sets the ground's
//! temperature.
//!
//! - **Elevation, first fit** ([`elevation_fit`]): a horizon at row r (a share of the
//!   height from the top) lies there when the line of sight looks e = atan((r − ½) · 2 ·
//!   tan(fov_y / 2)) above it. When at least half the footage's frames show a horizon,
//!   each frame gives its e, a frame without one counting as sky alone ([`clear`]: the
//!   horizon just under the frame); `camera.observer.elevation_deg` becomes the uniform
//!   range whose quartiles are those e's (its ends half the inter-quartile range beyond
//!   them). With fewer, the footage looks at the sky: the range's lower end is raised to
//!   [`clear`] when below it (the base's width kept), so no frame shows the ground.
//! - **Elevation, rounds** ([`adjust_elevation`]): when the horizon row lies outside the
//!   footage's range (both sides showing one in at least half their frames), the range
//!   moves by e(real median) − e(synthetic median): the modelled scenery stands on the
//!   horizon, so the rows the step is measured at sit a little above it.
//! - **Ground** ([`adjust_ground`]): when at least half the footage's frames show a
//!   horizon and the vertical gradient (lower third − upper third) lies outside its range,
//!   `ground_k` += (real − synthetic) / `agc_max_gain` (levels at the gain control's
//!   largest gain; within ±[`MAX_GROUND_STEP_K`] a round and the temperatures' range). The
//!   gradient, not the horizon's own step: the step is the scenery's edge (on
//!   svanstrom-ir a hot tree line under a dark band the camera's processing draws), where
//!   the thirds weigh the ground as a whole against the sky.
//! - **Detail enhancement, first fit** ([`detail_fit`]): when at least half the footage's
//!   frames show a horizon and their median halo (the darkest band over it against the sky
//!   a quarter of the height higher) is at most [`DEEP_HALO`], `thermal.detail` at gain
//!   [`FITTED_DETAIL_GAIN`] and the default reach: the dark band a camera's detail
//!   enhancement draws over a warm tree line. The rounds do not move it (a rule that did
//!   made the fit worse: docs/realism.md, "The dark band").
//! - **Texture** ([`texture_on_ground`]): when most of the footage's frames show a
//!   horizon, a texture the rounds add lies on the ground and the scenery alone
//!   (`thermal.texture.ground_only`): such footage's sky is smooth and its structure
//!   the scenery's.

use super::super::camera::Footage;
use super::{outside, r3, stat};
use crate::gap::report::{Report, Summary};
use crate::preset::Preset;
use crate::preset::thermal::Detail;

/// How far (degrees) above the frame's lower edge a frame without a horizon puts it:
/// the modelled scenery stands a little above the horizon.
pub const CLEAR_MARGIN_DEG: f64 = 1.5;
/// The most `ground_k` moves in a round, kelvin.
pub const MAX_GROUND_STEP_K: f64 = 20.0;

/// The elevation (degrees) that puts the horizon at row share `row` of a frame whose
/// vertical field of view is `fov_y_deg`.
pub fn elevation_for_row(row: f64, fov_y_deg: f64) -> f64 {
    ((row - 0.5) * 2.0 * (0.5 * fov_y_deg).to_radians().tan())
        .atan()
        .to_degrees()
}

/// The least elevation (degrees) at which a frame shows no horizon: the horizon
/// [`CLEAR_MARGIN_DEG`] under the frame's lower edge.
pub fn clear(fov_y_deg: f64) -> f64 {
    0.5 * fov_y_deg + CLEAR_MARGIN_DEG
}

/// The first fit's elevation range (module docs), with a note; nothing without an
/// observer or with a backplate (the plates carry their horizons).
pub fn elevation_fit(p: &mut Preset, footage: &Footage, notes: &mut Vec<String>) {
    let fov = p.camera.fov_y_deg;
    let Some(o) = p.camera.observer.as_mut().filter(|_| p.backplate.is_none()) else {
        return;
    };
    let e_clear = clear(fov);
    let (with, frames) = (
        footage
            .per_frame
            .iter()
            .filter(|f| f.horizon.is_some())
            .count(),
        footage.per_frame.len(),
    );
    let before = o.elevation_deg;
    if frames == 0 {
        return;
    }
    if 2 * with >= frames {
        let es: Vec<f64> = footage
            .per_frame
            .iter()
            .map(|f| {
                f.horizon
                    .map_or(e_clear, |h| elevation_for_row(f64::from(h.row), fov))
            })
            .collect();
        let Some(q) = super::super::camera::quartiles(&es) else {
            return;
        };
        let half = 0.5 * (q.q75 - q.q25).max(0.02);
        o.elevation_deg = (r3((q.q25 - half).max(-89.0)), r3((q.q75 + half).min(89.0)));
        notes.push(format!(
            "camera.observer.elevation_deg {before:?} → {:?}: {with} of {frames} frames show a horizon (median row {:.3} of the height), the line of sight {:.2}° [{:.2} – {:.2}] above it at fov_y {fov}°",
            o.elevation_deg,
            median_row(footage).unwrap_or(f64::NAN),
            q.median,
            q.q25,
            q.q75
        ));
    } else if before.0 < e_clear {
        let width = (before.1 - before.0).max(0.0);
        o.elevation_deg = (r3(e_clear), r3((e_clear + width).min(89.0)));
        notes.push(format!(
            "camera.observer.elevation_deg {before:?} → {:?}: {with} of {frames} frames show a horizon, so the line of sight looks at least {e_clear}° up (no ground in frame at fov_y {fov}°)",
            o.elevation_deg
        ));
    }
}

/// The footage's median horizon halo (levels) at or below which the first fit adds the
/// detail enhancement: twice the least horizon step, a band no sky warming towards the
/// horizon draws.
pub const DEEP_HALO: f64 = -2.0 * crate::gap::horizon::MIN_STEP as f64;
/// The gain the first fit gives it (docs/realism.md, "The dark band": more moved the
/// drones' contrast out on `svanstrom-ir`).
pub const FITTED_DETAIL_GAIN: f64 = 1.0;

/// The first fit's detail enhancement (module docs): gain [`FITTED_DETAIL_GAIN`] at the
/// default reach when at least half the footage's frames show a horizon and their median
/// halo is at or below [`DEEP_HALO`]; a base's own is kept, and nothing over a backplate.
pub fn detail_fit(p: &mut Preset, footage: &Footage, notes: &mut Vec<String>) {
    let Some(t) = p.thermal.as_mut().filter(|t| t.detail.is_none()) else {
        return;
    };
    if p.backplate.is_some() {
        return;
    }
    let frames = footage.per_frame.len();
    let horizons = footage.per_frame.iter().filter_map(|f| f.horizon);
    let with = horizons.clone().count();
    let halos: Vec<f64> = horizons.filter_map(|h| h.halo.map(f64::from)).collect();
    let Some(q) = super::super::camera::quartiles(&halos) else {
        return;
    };
    if 2 * with < frames || q.median > DEEP_HALO {
        return;
    }
    let d = Detail {
        gain: FITTED_DETAIL_GAIN,
        ..Detail::default()
    };
    t.detail = Some(d);
    notes.push(format!(
        "thermal.detail gain {}, size {}: the footage's horizon halo {:.1} levels (median over {} of {frames} frames; at most {DEEP_HALO}): the dark band a camera's detail enhancement draws over warm edges",
        d.gain,
        d.size,
        q.median,
        halos.len()
    ));
}

/// The median horizon row of the footage's frames that show one.
fn median_row(footage: &Footage) -> Option<f64> {
    let rows: Vec<f64> = (footage.per_frame.iter())
        .filter_map(|f| f.horizon.map(|h| f64::from(h.row)))
        .collect();
    super::super::camera::quartiles(&rows).map(|q| q.median)
}

/// Whether at least half of a side's `frames` gave the row `key` a value.
fn mostly(summary: Option<Summary>, frames: usize) -> bool {
    matches!(summary, Some(Summary::Distribution { n, .. }) if frames > 0 && 2 * n >= frames)
}

/// Whether at least half the footage's frames show a horizon, and (`both`) the
/// synthetic frames too.
fn horizons(report: &Report, both: bool) -> bool {
    let Some(r) = report.statistics.iter().find(|r| r.key == "horizon_row") else {
        return false;
    };
    mostly(r.real, report.real.frames.len())
        && (!both || mostly(r.synthetic, report.synthetic.frames.len()))
}

/// The rounds' elevation rule (module docs).
pub fn adjust_elevation(p: &mut Preset, report: &Report, changes: &mut Vec<String>) {
    let fov = p.camera.fov_y_deg;
    let Some(o) = p.camera.observer.as_mut().filter(|_| p.backplate.is_none()) else {
        return;
    };
    if !horizons(report, true) {
        return;
    }
    let Some((v, real, m)) = stat(report, "horizon_row").filter(|s| outside(s.0)) else {
        return;
    };
    let d = elevation_for_row(real, fov) - elevation_for_row(m, fov);
    let (lo, hi) = o.elevation_deg;
    let moved = (
        r3((lo + d).clamp(-89.0, 89.0)),
        r3((hi + d).clamp(-89.0, 89.0)),
    );
    if moved != o.elevation_deg {
        changes.push(format!(
            "camera.observer.elevation_deg {:?} → {moved:?} (horizon row {m:.3} {v} the real {real:.3}: {d:+.3}°)",
            o.elevation_deg
        ));
        o.elevation_deg = moved;
    }
}

/// A texture just added lies on the ground alone (`ground_only`) when most of the
/// footage's frames show a horizon (module docs).
pub fn texture_on_ground(
    t: &mut crate::preset::thermal::Thermal,
    report: &Report,
    changes: &mut Vec<String>,
) {
    if let Some(x) = t.texture.as_mut().filter(|_| horizons(report, false)) {
        x.ground_only = true;
        changes.push(
            "thermal.texture.ground_only true (most of the footage's frames show a horizon: the structure is the ground's and the scenery's, the sky stays smooth)"
                .into(),
        );
    }
}

/// The rounds' ground rule (module docs).
pub fn adjust_ground(
    t: &mut crate::preset::thermal::Thermal,
    report: &Report,
    changes: &mut Vec<String>,
) {
    if !horizons(report, false) || t.agc_max_gain <= 0.0 {
        return;
    }
    let Some((v, real, m)) = stat(report, "vertical_gradient").filter(|s| outside(s.0)) else {
        return;
    };
    let step = ((real - m) / t.agc_max_gain).clamp(-MAX_GROUND_STEP_K, MAX_GROUND_STEP_K);
    let g2 = r3((t.ground_k + step).clamp(151.0, 399.0));
    if g2 != t.ground_k {
        changes.push(format!(
            "thermal.ground_k {} → {g2} (vertical gradient {m:.1} {v} the real {real:.1}, at the gain control's largest gain of {} levels a kelvin)",
            t.ground_k, t.agc_max_gain
        ));
        t.ground_k = g2;
    }
}

#[cfg(test)]
mod tests {
    use super::super::tests::{row_report, thermal_preset};
    use super::*;
    use crate::gap::report::FrameRecord;

    /// One report of the rows `rows` (key, real, synthetic values) with `frames` frames on
    /// each side.
    fn report(rows: &[(&'static str, &[f64], &[f64])], frames: usize) -> Report {
        let mut r = row_report(rows[0].0, rows[0].1, rows[0].2);
        for &(key, real, syn) in &rows[1..] {
            r.statistics.extend(row_report(key, real, syn).statistics);
        }
        let record = FrameRecord {
            file: String::new(),
            stats: Default::default(),
        };
        r.real.frames = vec![record.clone(); frames];
        r.synthetic.frames = vec![record; frames];
        r
    }

    #[test]
    fn the_horizons_row_gives_the_line_of_sights_elevation() {
        for fov in [8.0, 40.0] {
            assert_eq!(elevation_for_row(0.5, fov), 0.0);
            assert!((elevation_for_row(1.0, fov) - 0.5 * fov).abs() < 1e-9);
            assert!((elevation_for_row(0.0, fov) + 0.5 * fov).abs() < 1e-9);
        }
        // A quarter of the height under the centre at 40°: atan(0.5 tan 20°).
        let e = elevation_for_row(0.75, 40.0);
        assert!((e - (0.5 * 20f64.to_radians().tan()).atan().to_degrees()).abs() < 1e-9);
    }

    /// The ground moves by the thirds' gap at the largest gain only when most of the
    /// footage's frames show a horizon; the elevation by the rows' gap only when most
    /// frames on both sides do.
    #[test]
    fn the_ground_and_the_elevation_follow_the_footages_horizon() {
        let rows: [(&'static str, &[f64], &[f64]); 2] = [
            ("vertical_gradient", &[40.0, 45.0, 50.0], &[10.0]),
            ("horizon_row", &[0.70, 0.71, 0.72], &[0.60, 0.61, 0.62]),
        ];
        let mut p = thermal_preset(0.0);
        p.camera.observer.as_mut().expect("observer").elevation_deg = (1.0, 2.0);
        let t = p.thermal.as_mut().expect("thermal");
        let (g, gain) = (t.ground_k, t.agc_max_gain);
        let mut changes = Vec::new();
        adjust_ground(t, &report(&rows, 6), &mut changes);
        assert_eq!(t.ground_k, r3(g + 35.0 / gain), "{changes:?}");
        adjust_elevation(&mut p, &report(&rows, 6), &mut changes);
        let d = elevation_for_row(0.71, 8.0) - elevation_for_row(0.61, 8.0);
        assert_eq!(
            p.camera.observer.as_ref().expect("observer").elevation_deg,
            (r3(1.0 + d), r3(2.0 + d)),
            "{changes:?}"
        );
        // Three horizons in eight frames: the footage looks at the sky; nothing moves.
        let mut q = thermal_preset(0.0);
        let before = (q.thermal.clone(), q.camera.observer.clone());
        let t = q.thermal.as_mut().expect("thermal");
        adjust_ground(t, &report(&rows, 8), &mut changes);
        adjust_elevation(&mut q, &report(&rows, 8), &mut changes);
        assert_eq!((q.thermal.clone(), q.camera.observer.clone()), before);
    }
}
