//! The thermal fit's blur and the drones' edges (the module docs of [`super`]).
//!
//! - **Modelled scene**: `blur_px` from the scene's sharpest edges (the blur σ statistic),
//!   changed in quadrature by the gap to the real median; with those inside and the small
//!   drones' edges wider than the real range, lowered by the edges' gap as over plates
//!   (below): the rendered scene's own edges are soft (on svanstrom-ir its blur σ read
//!   0.60 px with `blur_px` 0, inside the footage's 0.58–1.01), so a blur the scene's
//!   edges allow can still be too much for the drones' (a fitted 0.53 px: 3.49 px edges
//!   against 2.41; at 0, 2.94 and the small drones' peak contrast inside).
//! - **The warm spot's heat** (modelled scene): with the blur at 0 and the small drones'
//!   edges still wider than the real range, half the spot's `spot_k` moves into `skin_k`
//!   each round ([`flatten_spot`]; the centre's temperature kept, the peak contrast rule
//!   then scales both). The edge width walks out from the drone's peak: under a warm spot
//!   over a cooler skin it crosses the skin's plateau before the hull, a drone warm all
//!   over falls at its hull (svanstrom-ir's small drones are flat-topped, most clipped at
//!   255). On the odd-fitted modelled preset all the heat in the skin took the edges from
//!   3.30 to 2.60 px against the held-out 2.03–2.87.
//! - **Over plates**: the plates went through the footage's optics, and `blur_px` blurs
//!   only what is drawn over them (`sensor::thermal::blur_drawn`), so it follows the small
//!   drones' edge width instead: a Gaussian's 90→10 % edge is [`EDGE_PER_SIGMA`] σ wide,
//!   and a blur of σ widens an edge w to √(w² + (1.687 σ)²), so σ² moves by
//!   (real² − synthetic²) / 1.687².
//! - **The warm spot's size** (over plates): with the blur at 0 and the small drones' edges
//!   still wider than the real range, `spot_share` × (synthetic / real edge width)⁴ (within
//!   ×2 a round, within [`SPOT_SHARE`]). One Gaussian spot
//!   is as wide at its edge as 0.81 × its core (√ of the pixels over half its peak); a
//!   broader spot on the same hull is cut off by the hull's edge, a flatter top with a
//!   sharper fall. Measured over the svanstrom-ir plates (docs/realism.md): 0.45 → 0.9 →
//!   1.8 took the edge width 2.88 → 2.44 → 2.22 px (d log w / d log share ≈ 0.24, hence
//!   the 4th power). A drone with parts (`motor_k` / `battery_k`) has no spot: unchanged.
//!   Not in a modelled scene: there the blur statistic reads the texture's fronts (blur σ
//!   1.3 px against the footage's 0.8 on svanstrom-ir, `blur_px` driven to 0), the drones'
//!   edges then fall short and a spot rule narrowed the spot to make up for the blur; tried
//!   on the six splits of docs/realism.md it moved on two and both lost a statistic.

use super::{outside, r3, stat};
use crate::gap::measure::EDGE_PER_SIGMA;
use crate::gap::report::Report;
use crate::preset::thermal::{Signature, Thermal};

/// Limits of the fitted warm spot's σ as a share of the half box.
pub const SPOT_SHARE: (f64, f64) = (0.05, 4.0);

/// The largest blur the fit sets, px.
const MAX_BLUR_PX: f64 = 8.0;

/// Moves `blur_px` and, failing that, the drone's `spot_share` (module docs); the changes,
/// in words, into `changes`.
pub(super) fn adjust_blur(
    t: &mut Thermal,
    report: &Report,
    over_plates: bool,
    changes: &mut Vec<String>,
) {
    let edges = stat(report, "small_drone_edge_width_px").filter(|(v, _, _)| outside(v));
    let b = t.blur_px;
    let by_edges = |(v, real, m): (&str, f64, f64), why: &str| {
        let s2 = b * b + (real * real - m * m) / (EDGE_PER_SIGMA * EDGE_PER_SIGMA);
        (
            s2,
            format!("small drones' edge width {m:.3} px {v} the real {real:.3}; {why}"),
        )
    };
    let scene = stat(report, "blur_sigma_px");
    let wanted = if over_plates {
        edges.map(|e| by_edges(e, "over plates the blur takes only what is drawn"))
    } else if let Some((v, real, m)) = scene.filter(|(v, _, _)| outside(v)) {
        let s2 = real * real - m * m + b * b;
        Some((
            s2,
            format!("blur σ {m:.3} {v} the real {real:.3}, in quadrature"),
        ))
    } else {
        // The scene's edges read right: drones' edges too wide take blur away.
        (edges.filter(|e| e.0 == "above" && scene.is_some())).map(|e| {
            by_edges(
                e,
                "the scene's blur σ inside, the drones' edges take it away",
            )
        })
    };
    if let Some((s2, why)) = wanted {
        let b2 = r3(s2.max(0.0).sqrt().min(MAX_BLUR_PX));
        if b2 != b {
            changes.push(format!("thermal.blur_px {b} → {b2} ({why})"));
            t.blur_px = b2;
            return;
        }
    }
    let Some((v, real, m)) = edges else {
        return;
    };
    let d = &mut t.drone;
    if v != "above" || d.has_parts() || real <= 0.0 {
        return;
    }
    if !over_plates {
        flatten_spot(d, (m, real), changes);
        return;
    }
    let k = (m / real).powi(4).min(2.0);
    let s2 = r3((d.spot_share * k).clamp(SPOT_SHARE.0, SPOT_SHARE.1));
    if s2 != d.spot_share {
        changes.push(format!(
            "thermal.drone spot_share {} → {s2} (small drones' edge width {m:.3} px {v} the real {real:.3} with no blur to take away: a broader, flatter spot)",
            d.spot_share
        ));
        d.spot_share = s2;
    }
}

/// A modelled scene's drones whose edges stay wider than the real range with no blur to
/// take away: half the warm spot's heat moved into the skin, the centre's temperature
/// (skin + spot) kept, so the drone's top is flatter and falls at its hull.
fn flatten_spot(d: &mut Signature, (m, real): (f64, f64), changes: &mut Vec<String>) {
    let moved = 0.5 * d.spot_k;
    let (s2, p2) = (r3(d.skin_k + moved), r3(d.spot_k - moved));
    if (s2, p2) == (d.skin_k, d.spot_k) {
        return;
    }
    changes.push(format!(
        "thermal.drone skin_k {} → {s2}, spot_k {} → {p2} (small drones' edge width {m:.3} px above the real {real:.3} with no blur to take away: half the spot's heat into the skin, a flatter top)",
        d.skin_k, d.spot_k
    ));
    (d.skin_k, d.spot_k) = (s2, p2);
}

#[cfg(test)]
mod tests {
    use super::super::tests::row_report;
    use super::*;

    /// One report with the small drones' edge width and the blur σ rows.
    fn report(edges: (&[f64], &[f64]), blur: (&[f64], &[f64])) -> Report {
        let mut r = row_report("small_drone_edge_width_px", edges.0, edges.1);
        let b = row_report("blur_sigma_px", blur.0, blur.1);
        r.statistics.extend(b.statistics);
        r
    }

    fn thermal(blur_px: f64, spot_share: f64) -> Thermal {
        let mut t = Thermal {
            blur_px,
            ..Thermal::default()
        };
        t.drone.spot_share = spot_share;
        t
    }

    const REAL_EDGES: [f64; 5] = [2.0, 2.1, 2.25, 2.5, 2.8];
    const SCENE_BLUR: [f64; 5] = [0.6, 0.7, 0.8, 0.9, 1.0];

    /// Over plates: edges too wide with no blur to take away broaden the spot; too narrow
    /// add the blur that widens a Gaussian edge to the real median (in quadrature); the
    /// scene's blur σ (the plates' own) moves nothing.
    #[test]
    fn over_plates_the_drones_edges_set_the_blur_then_the_spot() {
        let mut changes = Vec::new();
        let wide = report((&REAL_EDGES, &[2.8, 2.9, 3.0]), (&SCENE_BLUR, &[0.8]));
        let mut t = thermal(0.0, 0.45);
        adjust_blur(&mut t, &wide, true, &mut changes);
        assert_eq!((t.blur_px, t.drone.spot_share), (0.0, 0.9), "{changes:?}");
        let mut t = thermal(1.0, 0.45);
        adjust_blur(&mut t, &wide, true, &mut changes);
        assert_eq!(t.drone.spot_share, 0.45, "the blur goes first");
        let s = (1.0 - (2.9f64.powi(2) - 2.25f64.powi(2)) / EDGE_PER_SIGMA.powi(2)).max(0.0);
        assert_eq!(t.blur_px, r3(s.sqrt()));
        let narrow = report((&REAL_EDGES, &[1.2, 1.3, 1.4]), (&SCENE_BLUR, &[0.1]));
        let mut t = thermal(0.0, 0.45);
        adjust_blur(&mut t, &narrow, true, &mut changes);
        let want = ((2.25f64.powi(2) - 1.3f64.powi(2)) / EDGE_PER_SIGMA.powi(2)).sqrt();
        assert_eq!((t.blur_px, t.drone.spot_share), (r3(want), 0.45));
        // A blur of that σ on a Gaussian edge of 1.3 px gives the real median.
        let w = (1.3f64.powi(2) + (EDGE_PER_SIGMA * t.blur_px).powi(2)).sqrt();
        assert!((w - 2.25).abs() < 0.01, "{w}");
        let inside = report((&REAL_EDGES, &[2.2]), (&SCENE_BLUR, &[0.1]));
        let mut t = thermal(0.0, 0.45);
        adjust_blur(&mut t, &inside, true, &mut changes);
        assert_eq!((t.blur_px, t.drone.spot_share), (0.0, 0.45));
    }

    /// A modelled scene: the scene's blur σ sets the blur; with it inside, drones' edges
    /// too wide take blur away (as over plates), then move the spot's heat into the skin,
    /// and too narrow add none; the spot's size stays (module docs); over plates a spot at
    /// its limit or a drone with parts stays.
    #[test]
    fn a_modelled_scene_fits_the_blur_to_the_scene_then_flattens_the_spot() {
        let mut changes = Vec::new();
        let both = report((&REAL_EDGES, &[3.0]), (&SCENE_BLUR, &[1.2]));
        let mut t = thermal(1.0, 0.45);
        adjust_blur(&mut t, &both, false, &mut changes);
        assert_eq!(t.drone.spot_share, 0.45);
        assert_eq!(t.blur_px, r3((0.64f64 - 1.44 + 1.0).sqrt()));
        let wide = report((&REAL_EDGES, &[2.5, 2.6, 2.7]), (&SCENE_BLUR, &[0.8]));
        let mut t = thermal(1.0, 0.45);
        adjust_blur(&mut t, &wide, false, &mut changes);
        let s = 1.0 - (2.6f64.powi(2) - 2.25f64.powi(2)) / EDGE_PER_SIGMA.powi(2);
        assert_eq!((t.blur_px, t.drone.spot_share), (r3(s.sqrt()), 0.45));
        let mut t = thermal(0.0, 0.45);
        let centre = t.drone.skin_k + t.drone.spot_k;
        adjust_blur(&mut t, &wide, false, &mut changes);
        assert_eq!((t.blur_px, t.drone.spot_share), (0.0, 0.45), "no spot rule");
        // With no blur to take away, half the spot's heat goes into the skin.
        assert_eq!(t.drone.spot_k, r3(0.5 * Thermal::default().drone.spot_k));
        assert!((t.drone.skin_k + t.drone.spot_k - centre).abs() < 2e-3);
        assert!(changes.last().is_some_and(|c| c.contains("flatter top")));
        // A drone without a warm spot has no heat to move: no change.
        let mut q = thermal(0.0, 0.45);
        q.drone.spot_k = 0.0;
        let (before, n) = (q.drone, changes.len());
        adjust_blur(&mut q, &wide, false, &mut changes);
        assert_eq!((q.drone, changes.len()), (before, n));
        let mut p = thermal(0.0, 0.45);
        p.drone.motor_k = Some(20.0);
        let parts = p.drone;
        adjust_blur(&mut p, &wide, false, &mut changes);
        assert_eq!(p.drone, parts, "a drone with parts keeps its heat");
        let narrow = report((&REAL_EDGES, &[1.0]), (&SCENE_BLUR, &[0.8]));
        let mut t = thermal(1.0, 0.45);
        adjust_blur(&mut t, &narrow, false, &mut changes);
        assert_eq!((t.blur_px, t.drone.spot_share), (1.0, 0.45));
        let mut t = thermal(0.0, 3.9);
        adjust_blur(&mut t, &wide, true, &mut changes);
        assert_eq!(
            t.drone.spot_share, SPOT_SHARE.1,
            "×2 at most, not past the limit"
        );
        let mut t = thermal(0.0, 0.45);
        t.drone.motor_k = Some(20.0);
        adjust_blur(&mut t, &wide, true, &mut changes);
        assert_eq!(t.drone.spot_share, 0.45);
    }
}
