//! The drones fitted to the real drones (issue 36, item 4): how many a frame holds, how
//! large they appear and so how near they are, on which side of their ring's brightness
//! they lie, and how much haze lies between.
//!
//! **First fit** ([`first_fit`]):
//! - `placement.count`: the drone counts of the real labelled frames that hold a drone,
//!   as a `Table` of the counts seen with their frequencies (a single count: that count);
//! - `models[].size_m` ([`fit_models`]): every model at one span, the median of the
//!   base's. The footage cannot tell a near small drone from a far large one; a mix of
//!   0.35–2 m spans at one distance would draw a 5.7:1 spread of sizes whatever the real
//!   cores' spread, and size for the median model puts the smallest under the labels'
//!   2 px (dropped, left in the frame unlabelled). At one span every model appears at the
//!   sizes `size_px` draws, and `size_px` carries the real spread;
//! - `camera.observer.size_px`: the real drones' core IQR ÷ [`CORE_PER_PX`];
//! - `placement.volume` ([`fit_volume`]): as deep as half the nearest distance of the
//!   look-at point (D = f·size_m / size_px, f the plates' focal length in pixels), so the
//!   apparent size follows `size_px` (a drone lies at most a quarter of D nearer or
//!   farther; with the base volume, realistic.ron's 12×6×60 m, drones sized for a
//!   look-at point 3 m away lie up to 30 m behind the camera or far beyond it); as wide
//!   and as high as makes the drones' centres spread over the frame as the real boxes'
//!   centres do ([`CentreSpread`]: their 5th–95th percentile, which a uniform spread
//!   covers over [`CENTRE_SPAN`] of its width), at the look-at point's nearest distance,
//!   the observer's azimuth fixed at 0 so the volume's x is the frame's width (without
//!   enough labelled drones: a cube). The minimum separation is scaled into it;
//! - `camera.observer.centre_at` ([`aim`], the thermal fit of a modelled scene): the real
//!   boxes' median centre, where the volume's centre is drawn, when it lies at least
//!   [`AIM_MIN_SHARE`] from the frame's centre.
//!
//! **After a round** ([`adjust`]):
//! - drone core size or the share under 6 px outside: the ends of `size_px` scaled by the
//!   real over the synthetic cores' lower and upper quartiles (their spread as well as
//!   their median), the volume scaled with the nearest distance (the same spread of
//!   centres over the frame);
//! - share darker than the ring outside: with k the odds ratio real / synthetic, the dark
//!   materials' weights (black, dark grey, coloured: [`is_dark`]) × k and the odds of a lit (emissive) drone ÷ k (thermal footage
//!   shows drones brighter than their ring; lit drones are how a preset draws that);
//! - the small drones' peak contrast outside (at least [`MIN_DRONES`] synthetic ones): the
//!   haze's visibility (Koschmieder's law, the blend in linear light toward the air
//!   light, under a plate the plate's own sky): the round's small drones' median ring
//!   level and contrast give the drone's level without haze, and the transmittance
//!   exp(−3.912·d/V) at the look-at distance d that brings the contrast to the real
//!   median, through the sRGB curve (a dark drone on a bright sky loses contrast in sRGB
//!   far faster than its transmittance falls); done first, at the distances the round
//!   had, and not in a round that moves the PSF (which lowers a small drone's peak too);
//!   when the size then moves the look-at point, the visibility moves with it (the same
//!   transmittance there).

use std::collections::BTreeMap;

use super::camera::{Footage, quartiles};
use crate::gap;
use crate::gap::report::{Report, SMALL_CORE_PX};
use crate::preset::appearance::{Appearance, DroneColor};
use crate::preset::atmosphere::{Atmosphere, MAX_VISIBILITY_M};
use crate::preset::{CountDistribution, Placement, Preset, Volume};

/// The drone core size (√ of the pixels over half the peak) per pixel of a model's
/// apparent size (its largest span), averaged over a preset's model mix: measured on
/// `presets/realistic.ron` (size_px 16–44 gives cores of median 4.4 px for a median
/// model of 1.1 m against the 2 m largest: 4.4 / (30 · 1.1 / 2)). The loop corrects it.
pub const CORE_PER_PX: f64 = 0.27;

/// The fitted volume's depth as a share of the look-at point's nearest distance.
pub const VOLUME_PER_DISTANCE: f64 = 0.5;

/// The share of a uniform spread's width its 5th–95th percentile covers.
pub const CENTRE_SPAN: f64 = 0.9;

/// The fewest labelled drones a [`CentreSpread`] is taken from.
pub const MIN_CENTRES: usize = 8;

/// How far the labelled drones' box centres spread over the frame: the 5th to 95th
/// percentile of their x and y, as shares of the frame's width and height.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CentreSpread {
    pub x: f64,
    pub y: f64,
    /// The centres' median x and y, as shares of the frame.
    pub median: (f64, f64),
    /// Drones it was taken from.
    pub n: usize,
}

impl CentreSpread {
    /// The spread of `centres` (x, y as shares of the frame's width and height);
    /// `None` under [`MIN_CENTRES`] of them.
    pub fn of(centres: impl Iterator<Item = (f64, f64)>) -> Option<Self> {
        let (mut xs, mut ys): (Vec<f64>, Vec<f64>) = centres
            .filter(|(x, y)| x.is_finite() && y.is_finite())
            .unzip();
        if xs.len() < MIN_CENTRES {
            return None;
        }
        let span = |v: &mut Vec<f64>| {
            v.sort_by(f64::total_cmp);
            gap::percentile(v, 0.95) - gap::percentile(v, 0.05)
        };
        let (x, y) = (span(&mut xs), span(&mut ys));
        Some(Self {
            x,
            y,
            median: (gap::percentile(&xs, 0.5), gap::percentile(&ys, 0.5)),
            n: xs.len(),
        })
    }
}

fn r3(v: f64) -> f64 {
    (v * 1000.0).round() / 1000.0
}

fn largest_model(p: &Preset) -> f64 {
    p.models.iter().map(|m| m.size_m).fold(0.0, f64::max)
}

/// The focal length in pixels of the frames `p` renders: the plates' horizontal field
/// of view over the width, else the camera's vertical one over the height.
pub fn focal_px(p: &Preset) -> f64 {
    let (w, h) = p.render.resolution.size();
    match &p.backplate {
        Some(b) => f64::from(w) * 0.5 / (b.hfov_deg.to_radians() * 0.5).tan(),
        None => f64::from(h) * 0.5 / (p.camera.fov_y_deg.to_radians() * 0.5).tan(),
    }
}

/// The look-at point's distance range (nearest, farthest), metres.
fn distances(p: &Preset) -> Option<(f64, f64)> {
    let obs = p.camera.observer.as_ref()?;
    Some(match obs.size_px {
        Some((lo, hi)) => {
            let fs = focal_px(p) * largest_model(p);
            (fs / hi.max(1e-6), fs / lo.max(1e-6))
        }
        None => obs.distance_m,
    })
}

/// The first fit's drones: count, spans, apparent size and volume (module docs); one
/// note per value. `centres`: the real boxes' spread over the frame.
pub fn first_fit(
    p: &mut Preset,
    footage: &Footage,
    centres: Option<CentreSpread>,
    notes: &mut Vec<String>,
) {
    if let Some(note) = fit_count(p, footage) {
        notes.push(note);
    }
    if let Some(note) = fit_models(p) {
        notes.push(note);
    }
    let mut observer = p.camera.observer.clone().unwrap_or_default();
    p.camera.absolute = None;
    let (w, h) = footage.size;
    if let Some(core) = footage.measured.drone_core_px {
        let per = 1.0 / CORE_PER_PX;
        let max_px = 2.0 * f64::from(w.max(h));
        let hi = (core.q75 * per)
            .max(core.q25 * per + 0.5)
            .clamp(1.0, max_px);
        let (lo, hi) = (r3((core.q25 * per).clamp(0.5, hi)), r3(hi));
        observer.size_px = Some((lo, hi));
        notes.push(format!(
            "camera.observer.size_px ({lo}, {hi}): the real drones' cores (IQR {:.2}–{:.2} px, {} drones) / {CORE_PER_PX} core px per px of a model's span (measured on realistic.ron); the distance follows from the plates' field of view",
            core.q25, core.q75, core.n,
        ));
    } else {
        notes.push(
            "camera.observer: the base preset's (no labelled drone to size the drones from)".into(),
        );
    }
    p.camera.observer = Some(observer);
    spread(p, centres, notes);
}

/// The least distance of the footage's median box centre from the frame's centre (as
/// a share of the frame's width or height) that [`aim`] moves the volume's centre for.
pub const AIM_MIN_SHARE: f64 = 0.02;

/// `camera.observer.centre_at` at the footage's median box centre when it lies at least
/// [`AIM_MIN_SHARE`] from the frame's centre (an observer with `size_px` only: its depth
/// is what sizes the drones).
pub fn aim(p: &mut Preset, centres: Option<CentreSpread>, notes: &mut Vec<String>) {
    let (Some(c), Some(o)) = (centres, p.camera.observer.as_mut()) else {
        return;
    };
    let (x, y) = (
        r3(c.median.0.clamp(0.0, 1.0)),
        r3(c.median.1.clamp(0.0, 1.0)),
    );
    if o.size_px.is_none() || ((x - 0.5).abs() < AIM_MIN_SHARE && (y - 0.5).abs() < AIM_MIN_SHARE) {
        return;
    }
    o.centre_at = Some((x, y));
    notes.push(format!(
        "camera.observer.centre_at ({x}, {y}): the footage's median box centre ({} drones), where the volume's centre is drawn",
        c.n
    ));
}

/// The volume the drones spread over ([`fit_volume`]) with the observer's azimuth at 0,
/// so the volume's x is the frame's width, when the footage's `centres` and the
/// observer's `size_px` are known.
pub fn spread(p: &mut Preset, centres: Option<CentreSpread>, notes: &mut Vec<String>) {
    if let Some(o) = p.camera.observer.as_mut()
        && centres.is_some()
        && o.size_px.is_some()
    {
        o.azimuth_deg = (0.0, 0.0);
    }
    notes.extend(fit_volume(p, centres));
}

/// Every model at one span, the median of the base's (module docs); `None` when they
/// already share one.
pub fn fit_models(p: &mut Preset) -> Option<String> {
    let sizes: Vec<f64> = p.models.iter().map(|m| m.size_m).collect();
    let span = r3(quartiles(&sizes)?.median);
    if sizes.iter().all(|&s| s == span) {
        return None;
    }
    for m in &mut p.models {
        m.size_m = span;
    }
    Some(format!(
        "models[].size_m {sizes:?} → {span} m each (the median): the footage cannot tell a near small drone from a far large one, so every model appears at the sizes size_px draws from the real cores (a mix of spans at one distance would spread them {:.1}:1 and put the smallest under the labels' 2 px)",
        sizes.iter().fold(0.0, |a: f64, &b| a.max(b))
            / sizes.iter().fold(f64::MAX, |a, &b| a.min(b)).max(1e-9)
    ))
}

/// The count range and its draw for frames holding `counts` drones (frames without a
/// drone left out); `None` when no frame holds one.
pub fn count_draw(counts: impl Iterator<Item = usize>) -> Option<((u32, u32), CountDistribution)> {
    let mut seen: BTreeMap<u32, usize> = BTreeMap::new();
    for n in counts.filter(|&n| n > 0) {
        *seen
            .entry(u32::try_from(n).unwrap_or(u32::MAX))
            .or_default() += 1;
    }
    let (&lo, &hi) = (seen.keys().next()?, seen.keys().next_back()?);
    let draw = if seen.len() == 1 {
        CountDistribution::Uniform
    } else {
        CountDistribution::Table(seen.iter().map(|(&n, &k)| (n, k as f64)).collect())
    };
    Some(((lo, hi), draw))
}

/// `placement.count` from the real frames' drone counts (randomized placement only).
pub fn fit_count(p: &mut Preset, footage: &Footage) -> Option<String> {
    let labelled = || footage.per_frame.iter().filter(|f| f.labelled);
    let ((lo, hi), draw) = count_draw(labelled().map(|f| f.drones))?;
    let Placement::Randomized {
        count,
        count_distribution,
        ..
    } = &mut p.placement
    else {
        return None;
    };
    let table = !draw.is_uniform();
    *count = (lo, hi);
    *count_distribution = draw;
    Some(format!(
        "placement.count ({lo}, {hi}){}: the drones per labelled frame of the footage ({} frames with a drone)",
        if table {
            ", each count drawn as often as the footage shows it"
        } else {
            ""
        },
        labelled().filter(|f| f.drones > 0).count()
    ))
}

/// The middle of the line of sight's elevation range, radians (the plates' when they
/// are drawn, else the observer's).
fn mid_elevation(p: &Preset) -> f64 {
    let (lo, hi) = match (&p.backplate, &p.camera.observer) {
        (Some(b), _) => b.elevation_deg,
        (None, Some(o)) => o.elevation_deg,
        (None, None) => (0.0, 0.0),
    };
    (0.5 * (lo + hi)).clamp(-80.0, 80.0).to_radians()
}

/// `placement.volume` [`VOLUME_PER_DISTANCE`] × the look-at point's nearest distance
/// deep, as wide and high as `centres` asks (a cube without it), the minimum separation
/// within it (module docs); `None` (unchanged) without the observer's `size_px` or a
/// randomized placement.
pub fn fit_volume(p: &mut Preset, centres: Option<CentreSpread>) -> Option<String> {
    p.camera.observer.as_ref()?.size_px?;
    let (near, _) = distances(p)?;
    let depth = r3((VOLUME_PER_DISTANCE * near).max(0.01));
    let f = focal_px(p);
    let (w, h) = p.render.resolution.size();
    let e = mid_elevation(p);
    // Metres across at the nearest distance that a spread of `share` of `px` asks for:
    // the nearest frames spread their drones widest and set the 5th–95th percentile
    // (at the middle distance the single drones of mi-drone-yt, drawn 1.4–3.9 m away,
    // spread over 29 % of the width against the real 19 %).
    let across = |share: f64, px: u32| share * f64::from(px) * near / f / CENTRE_SPAN;
    let (x, y, why) = match centres {
        Some(c) => (
            r3(across(c.x, w).max(0.01)),
            // The frame's height sees y·cos E and the depth's z·sin E.
            r3(((across(c.y, h) - depth * e.sin().abs()) / e.cos().max(0.1)).max(0.01)),
            format!(
                "; {depth} m deep, as wide and high as spreads the centres over {:.0} % × {:.0} % of the frame (the real boxes' 5th–95th percentile, {} drones) at the nearest distance, the observer's azimuth 0 (x across the frame)",
                100.0 * c.x,
                100.0 * c.y,
                c.n
            ),
        ),
        None => (depth, depth, " (a cube)".to_string()),
    };
    let Placement::Randomized {
        count,
        volume,
        min_separation_m,
        ..
    } = &mut p.placement
    else {
        return None;
    };
    // Spheres of the separation's diameter fill at most 1/16 of the box.
    let sep = r3((0.5 * (x * y * depth / f64::from(count.1.max(1))).cbrt()).min(*min_separation_m));
    let new = Volume::Box {
        size_m: (x, y, depth),
    };
    if *volume == new && *min_separation_m == sep {
        return None;
    }
    *volume = new;
    *min_separation_m = sep;
    Some(format!(
        "placement.volume Box({x}, {y}, {depth}) m, min_separation_m {sep}: {VOLUME_PER_DISTANCE} × the look-at point's nearest distance {near:.2} m (focal {f:.0} px × model span {} m / size_px) deep, so the apparent size follows size_px{why}",
        largest_model(p)
    ))
}

/// The volume and its minimum separation × `k` (the look-at distance's change: the
/// drones keep their spread over the frame).
pub(super) fn scale_volume(p: &mut Preset, k: f64) -> Option<String> {
    let Placement::Randomized {
        count,
        volume: Volume::Box { size_m },
        min_separation_m,
        ..
    } = &mut p.placement
    else {
        return None;
    };
    let before = *size_m;
    let s = |v: f64| r3((v * k).max(0.01));
    *size_m = (s(before.0), s(before.1), s(before.2));
    let (x, y, z) = *size_m;
    let sep = r3((0.5 * (x * y * z / f64::from(count.1.max(1))).cbrt()).min(*min_separation_m));
    *min_separation_m = sep.max(0.001);
    (*size_m != before).then(|| {
        format!(
            "placement.volume {before:?} → {:?} m, min_separation_m {sep} (× {k:.3}, the nearest distance's change: the same spread over the frame)",
            *size_m
        )
    })
}

/// (verdict, real centre, synthetic centre) of a statistic with both sides.
fn stat(report: &Report, key: &str) -> Option<(&'static str, f64, f64)> {
    let r = report.statistics.iter().find(|r| r.key == key)?;
    let centre = |s: crate::gap::report::Summary| match s {
        crate::gap::report::Summary::Distribution { median, .. } => median,
        crate::gap::report::Summary::Share { share, .. } => share,
    };
    Some((r.verdict, centre(r.real?), centre(r.synthetic?)))
}

/// How many synthetic values a statistic summarises.
fn synthetic_n(report: &Report, key: &str) -> usize {
    (report.statistics.iter().find(|r| r.key == key))
        .and_then(|r| r.synthetic)
        .map_or(0, |s| s.n())
}

/// The fewest synthetic drones a drone rule acts on (fewer: their median is noise).
pub const MIN_DRONES: usize = 8;

fn outside(v: &str) -> bool {
    v == "below" || v == "above"
}

/// Moves the drones toward the real ones after a round's `report` (module docs); the
/// changes, in words, are appended to `changes`.
/// `psf_moved`: the PSF changes for the next round; it lowers the small drones' peak too,
/// so the haze waits for a round without it (the two together overshoot).
pub fn adjust(preset: &mut Preset, report: &Report, psf_moved: bool, changes: &mut Vec<String>) {
    // The haze first, at the distances the round was rendered with.
    if !psf_moved {
        adjust_haze(preset, report, changes);
    }
    adjust_polarity(preset, report, changes);
    adjust_size(preset, report, changes);
}

fn cores(side: &crate::gap::report::Side) -> Vec<f64> {
    side.frames
        .iter()
        .flat_map(|f| f.stats.drones.iter().map(|d| f64::from(d.core_px)))
        .collect()
}

/// The apparent size: the ends of the size range by the cores' quartile ratios.
pub fn adjust_size(preset: &mut Preset, report: &Report, changes: &mut Vec<String>) {
    let off = |k| stat(report, k).is_some_and(|(v, _, _)| outside(v));
    if !off("drone_core_px") && !off("drone_core_under_6px") {
        return;
    }
    let (Some(real), Some(syn)) = (
        quartiles(&cores(&report.real)),
        quartiles(&cores(&report.synthetic)),
    ) else {
        return;
    };
    let ratio = |r: f64, s: f64| {
        if s > 0.0 {
            (r / s).clamp(0.2, 5.0)
        } else {
            5.0
        }
    };
    let (k_lo, k_hi) = (ratio(real.q25, syn.q25), ratio(real.q75, syn.q75));
    let (w, h) = preset.render.resolution.size();
    let max_px = 2.0 * f64::from(w.max(h));
    let mid = |p: &Preset| distances(p).map(|(a, b)| (a * b).sqrt());
    let d0 = mid(preset);
    let near0 = distances(preset).map(|d| d.0);
    let Some(obs) = &mut preset.camera.observer else {
        return;
    };
    let before = (obs.size_px, obs.distance_m);
    match obs.size_px {
        Some((lo, hi)) => {
            let hi2 = r3((hi * k_hi).clamp(0.5, max_px));
            obs.size_px = Some((r3((lo * k_lo).clamp(0.5, hi2)), hi2));
        }
        None => {
            let (lo, hi) = obs.distance_m;
            let lo2 = r3((lo / k_hi).max(0.01));
            obs.distance_m = (lo2, r3((hi / k_lo).max(lo2)));
        }
    }
    if (obs.size_px, obs.distance_m) == before {
        return;
    }
    changes.push(format!(
        "observer size_px {:?} → {:?}, distance_m {:?} → {:?} (drone cores' IQR {:.2}–{:.2} px against the real {:.2}–{:.2})",
        before.0, obs.size_px, before.1, obs.distance_m, syn.q25, syn.q75, real.q25, real.q75
    ));
    if let (Some(n0), Some((n1, _))) = (near0, distances(preset))
        && n0 > 0.0
        && let Some(note) = scale_volume(preset, n1 / n0)
    {
        changes.push(note);
    }
    // The haze's transmittance at the look-at point stays what the contrast fitted it to.
    let d1 = mid(preset);
    if let (Some(a), Some(d0), Some(d1)) = (&mut preset.atmosphere, d0, d1)
        && d0 > 0.0
        && a.visibility_m.0 < MAX_VISIBILITY_M
    {
        let before = a.visibility_m;
        let scale = |v: f64| (v * d1 / d0).clamp(1.0, MAX_VISIBILITY_M).round();
        a.visibility_m = (scale(before.0), scale(before.1));
        if a.visibility_m != before {
            changes.push(format!(
                "atmosphere.visibility_m {before:?} → {:?} (× the look-at distance's change {d0:.1} → {d1:.1} m: the same transmittance there)",
                a.visibility_m
            ));
        }
    }
}

/// The materials the polarity rule counts as dark: albedo under half the white's (black,
/// dark grey, and the saturated colours at about 0.3, which read darker than a bright
/// ring: on uavswarm-topdown 38 of the 55 synthetic drones darker than their ring were
/// coloured, 5 % of the drones).
fn is_dark(c: DroneColor) -> bool {
    matches!(
        c,
        DroneColor::Black | DroneColor::DarkGrey | DroneColor::Coloured
    )
}

/// Dark materials and lit drones by the odds ratio of the share darker than the ring.
fn adjust_polarity(preset: &mut Preset, report: &Report, changes: &mut Vec<String>) {
    let Some((v, t, m)) = stat(report, "drone_darker") else {
        return;
    };
    if !outside(v) || m <= 0.0 || m >= 1.0 {
        return;
    }
    let odds = |p: f64| p.clamp(0.02, 0.98) / (1.0 - p.clamp(0.02, 0.98));
    let k = (odds(t) / odds(m)).clamp(0.1, 10.0);
    let a = preset.appearance.get_or_insert_with(Appearance::default);
    for (c, w) in &mut a.palette {
        if is_dark(*c) {
            *w = r3((*w * k).max(0.001));
        }
    }
    let e = a.emissive_share;
    // Raising a share of 0 needs a start; lowering one never raises it.
    let lit = if k < 1.0 {
        odds(e.max(0.02))
    } else {
        e / (1.0 - e).max(0.02)
    } / k;
    a.emissive_share = r3((lit / (1.0 + lit)).clamp(0.0, 0.98));
    changes.push(format!(
        "dark drone materials' weights ×{k:.3}, lit drones' share {e} → {} (darker than the ring {:.0} % {v} the real {:.0} %)",
        a.emissive_share,
        m * 100.0,
        t * 100.0
    ));
}

/// An sRGB level (0–255, continuous) as linear light.
fn linear(level: f64) -> f64 {
    let c = (level / 255.0).clamp(0.0, 1.0);
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// The transmittance ratio (new / now) that brings the small drones' median peak
/// contrast from `now` to `want` sRGB levels over their median ring level, the blend
/// done in linear light as the renderer does it; `None` when the round shows no small
/// drone or the drone does not differ from its ring.
fn transmittance_ratio(report: &Report, now: f64, want: f64, t_now: f64) -> Option<f64> {
    let small: Vec<_> = (report.synthetic.frames.iter())
        .flat_map(|f| f.stats.drones.iter())
        .filter(|d| (SMALL_CORE_PX.0..=SMALL_CORE_PX.1).contains(&d.core_px))
        .collect();
    let bg = quartiles(
        &small
            .iter()
            .map(|d| f64::from(d.background))
            .collect::<Vec<_>>(),
    )?;
    let darker = 2 * small.iter().filter(|d| d.darker).count() > small.len();
    let sign = if darker { -1.0 } else { 1.0 };
    let air = linear(bg.median);
    // The drone without haze, from what the round shows through transmittance t_now.
    let bare = (linear(bg.median + sign * now) - (1.0 - t_now) * air) / t_now.max(1e-6);
    let gap = bare - air;
    if gap.abs() < 1e-6 {
        return None;
    }
    let t_new = ((linear(bg.median + sign * want) - air) / gap).clamp(1e-3, 1.0);
    Some(t_new / t_now.max(1e-6))
}

/// The haze's visibility from the small drones' peak contrast (module docs).
fn adjust_haze(preset: &mut Preset, report: &Report, changes: &mut Vec<String>) {
    let key = "small_drone_peak_contrast";
    let Some((v, t, m)) = stat(report, key) else {
        return;
    };
    let Some((near, far)) = distances(preset) else {
        return;
    };
    if !outside(v) || m <= 0.0 || t <= 0.0 || synthetic_n(report, key) < MIN_DRONES {
        return;
    }
    let d = (near * far).sqrt();
    let before = preset.atmosphere.as_ref().map(|a| a.visibility_m);
    let t_now = before.map_or(1.0, |(lo, hi)| (-3.912 * d / (lo * hi).sqrt()).exp());
    let Some(r) = transmittance_ratio(report, m, t, t_now) else {
        return;
    };
    if r >= 1.0 && preset.atmosphere.is_none() {
        return;
    }
    let visibility = |v: f64| {
        let inv = 1.0 / v - r.ln() / (3.912 * d);
        if inv <= 1.0 / MAX_VISIBILITY_M {
            MAX_VISIBILITY_M
        } else {
            (1.0 / inv).clamp(1.0, MAX_VISIBILITY_M).round()
        }
    };
    let (lo, hi) = before.unwrap_or((MAX_VISIBILITY_M, MAX_VISIBILITY_M));
    let new = (visibility(lo), visibility(hi));
    if Some(new) == before {
        return;
    }
    preset.atmosphere = Some(Atmosphere { visibility_m: new });
    changes.push(format!(
        "atmosphere.visibility_m {before:?} → {new:?} (small drones' peak contrast {m:.1} {v} the real {t:.1}: transmittance ×{r:.3} at the look-at distance {d:.1} m, blended in linear light)"
    ));
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gap::report::{Side, StatRow, Summary};

    fn realistic() -> Preset {
        let mut p = Preset::load(std::path::Path::new("presets/realistic.ron")).expect("preset");
        p.render.resolution = crate::preset::Resolution::Custom {
            width: 1280,
            height: 720,
        };
        p.backplate = None;
        p
    }

    fn side() -> Side {
        Side {
            drone_classes: "all".into(),
            ..Side::default()
        }
    }

    /// A report with one statistic (real and synthetic centres, real range).
    fn report(key: &'static str, real: (f64, f64, f64), syn: f64, verdict: &'static str) -> Report {
        let dist = |median, q25, q75| Summary::Distribution {
            n: 40,
            median,
            q25,
            q75,
        };
        let share = |share, low, high| Summary::Share {
            n: 40,
            k: 0,
            share,
            low,
            high,
        };
        let shared = key == "drone_darker";
        let (r, s) = if shared {
            (share(real.0, real.1, real.2), share(syn, syn, syn))
        } else {
            (dist(real.0, real.1, real.2), dist(syn, syn, syn))
        };
        Report {
            real: side(),
            synthetic: side(),
            statistics: vec![StatRow {
                key,
                name: key,
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

    #[test]
    fn the_count_follows_the_real_frames() {
        let (range, draw) = count_draw([1, 0, 2, 1, 5, 1].into_iter()).expect("counts");
        assert_eq!(range, (1, 5));
        assert_eq!(
            draw,
            CountDistribution::Table(vec![(1, 3.0), (2, 1.0), (5, 1.0)])
        );
        let (range, draw) = count_draw([1, 1, 0].into_iter()).expect("counts");
        assert_eq!((range, draw), ((1, 1), CountDistribution::Uniform));
        assert!(count_draw([0, 0].into_iter()).is_none());
    }

    #[test]
    fn the_volume_follows_the_nearest_distance_and_validates() {
        let mut p = realistic();
        let obs = p.camera.observer.get_or_insert_with(Default::default);
        obs.size_px = Some((100.0, 200.0));
        let note = fit_volume(&mut p, None).expect("a volume");
        // f = 360 / tan 25° = 772.0 px; nearest D = f · 2 m / 200 px = 7.72 m.
        let f = 360.0 / 25f64.to_radians().tan();
        let side = 0.5 * f * 2.0 / 200.0;
        let Placement::Randomized {
            volume: Volume::Box { size_m },
            min_separation_m,
            ..
        } = &p.placement
        else {
            panic!("randomized placement");
        };
        assert!(
            (size_m.0 - side).abs() < 2e-3,
            "{size_m:?} against {side}: {note}"
        );
        assert_eq!((size_m.0, size_m.0), (size_m.1, size_m.2));
        assert!(*min_separation_m <= 0.5 * size_m.0 / 15f64.cbrt() + 1e-3);
        p.validate().expect("the fitted preset validates");
        // Twice the apparent size: half the distance, half the volume.
        p.camera.observer.as_mut().expect("observer").size_px = Some((200.0, 400.0));
        fit_volume(&mut p, None).expect("a new volume");
        let Placement::Randomized {
            volume: Volume::Box { size_m: half },
            ..
        } = &p.placement
        else {
            panic!("randomized placement");
        };
        assert!((half.0 - 0.5 * side).abs() < 2e-3, "{half:?}");
    }

    #[test]
    fn fewer_dark_drones_mean_lighter_materials_and_more_lit_drones() {
        let mut p = realistic();
        let before = p.appearance.clone().expect("appearance");
        let mut changes = Vec::new();
        // 1 % darker in the footage (thermal) against 40 % synthetic.
        adjust_polarity(
            &mut p,
            &report("drone_darker", (0.01, 0.0, 0.02), 0.4, "above"),
            &mut changes,
        );
        let after = p.appearance.clone().expect("appearance");
        let w = |a: &Appearance, c| a.palette.iter().find(|(k, _)| *k == c).map(|x| x.1);
        assert!(w(&after, DroneColor::Black) < w(&before, DroneColor::Black));
        assert!(w(&after, DroneColor::Coloured) < w(&before, DroneColor::Coloured));
        assert_eq!(w(&after, DroneColor::White), w(&before, DroneColor::White));
        assert_eq!(
            w(&after, DroneColor::LightGrey),
            w(&before, DroneColor::LightGrey)
        );
        assert!(after.emissive_share > before.emissive_share, "{changes:?}");
        // And the other way: more dark drones, fewer lit ones.
        adjust_polarity(
            &mut p,
            &report("drone_darker", (0.99, 0.98, 1.0), 0.6, "below"),
            &mut changes,
        );
        assert!(p.appearance.as_ref().expect("a").emissive_share < after.emissive_share);
        p.validate().expect("valid");
    }

    #[test]
    fn the_haze_brings_the_small_drones_contrast_to_the_real() {
        let mut p = realistic();
        p.camera
            .observer
            .get_or_insert_with(Default::default)
            .size_px = Some((100.0, 100.0));
        let d = 360.0 / 25f64.to_radians().tan() * 2.0 / 100.0;
        let (v0, v0_hi) = p.atmosphere.as_ref().expect("haze").visibility_m;
        // Ten small dark drones 120 levels under a ring of 200; the footage's: 90.
        let mut r = report(
            "small_drone_peak_contrast",
            (90.0, 80.0, 100.0),
            120.0,
            "above",
        );
        let drone = crate::gap::DroneMeasure {
            background: 200.0,
            peak: -120.0,
            core_px: 4.0,
            darker: true,
            edge_width_px: Some(2.0),
            box_px: 6.0,
            behind: None,
        };
        r.synthetic.frames.push(crate::gap::report::FrameRecord {
            file: "a.jpg".into(),
            stats: crate::gap::FrameStats {
                drones: vec![drone; 10],
                ..Default::default()
            },
        });
        let mut changes = Vec::new();
        adjust_haze(&mut p, &r, &mut changes);
        let (v1, v1_hi) = p.atmosphere.as_ref().expect("haze").visibility_m;
        assert!(v1 < v0 && v1_hi < v0_hi, "{changes:?}");
        // Forward, as the renderer blends: the drone without haze from what the round
        // showed through the old transmittance, then through the new one.
        let t = |v: f64, w: f64| (-3.912 * d / (v * w).sqrt()).exp();
        let (t0, t1) = (t(v0, v0_hi), t(v1, v1_hi));
        let air = linear(200.0);
        let bare = (linear(80.0) - (1.0 - t0) * air) / t0;
        let level = 255.0
            * f64::from(crate::sky::linear_to_srgb(
                (t1 * bare + (1.0 - t1) * air) as f32,
            ));
        assert!(
            ((200.0 - level) - 90.0).abs() < 1.5,
            "contrast {} after: {changes:?}",
            200.0 - level
        );
        // Contrast inside: nothing moves.
        let inside = report(
            "small_drone_peak_contrast",
            (90.0, 80.0, 100.0),
            95.0,
            "inside",
        );
        let before = p.atmosphere.clone();
        adjust_haze(&mut p, &inside, &mut changes);
        assert_eq!(p.atmosphere, before);
        p.validate().expect("valid");
    }
}
