//! Where a grey frame's horizon lies and how it steps: the row across which the mean level
//! changes most between the [`band`] rows above and the rows below, when that change is
//! at least [`MIN_STEP`] levels and the same across the frame ([`STRIPES`] stripes of
//! columns all step the same way by at least half of it within a band of that row, so a
//! tilted horizon counts and a lone tree, mast or cloud edge does not). Overlay pixels
//! are left out, and the rows within a twentieth of the height of the top and bottom
//! (border lines). `swarmshot fit` sets a thermal preset's line of sight's elevation by
//! the rows and its ground's temperature by the steps.

use super::measure::{Luma, OverlayMask};

/// The least change (levels) of the mean level across a horizon: a thermal sky's
/// gradient toward the horizon changes by a level or two over a band.
pub const MIN_STEP: f32 = 12.0;
/// Stripes of columns that must each step the same way.
pub const STRIPES: usize = 4;

/// A frame's horizon: its row as a share of the height (from the top), the step, the
/// mean level of the band below less the band above (positive: the ground reads
/// brighter), and the halo: the darkest band between the horizon and a band
/// [`HALO_REACH`] of the height higher, less that band (negative: a dark band over the
/// horizon, as a camera's detail enhancement draws over a warm tree line, or over the
/// trees when the horizon found is their foot; 0 for a sky warming towards the horizon;
/// `None` when the higher band lies out of the frame).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Horizon {
    pub row: f32,
    pub step: f32,
    pub halo: Option<f32>,
}

/// How far above the horizon's band (a share of the height) the halo's reference band
/// lies: past the reach of a camera's detail enhancement, within a typical frame's sky.
pub const HALO_REACH: f64 = 0.25;

/// The rows each side of a horizon that its step compares: a 32nd of the height, at
/// least 4.
pub fn band(h: usize) -> usize {
    (h / 32).max(4)
}

/// The horizon of a grey frame `l` ([module docs](self)), `None` when it shows none.
pub fn horizon(l: &Luma, overlay: Option<OverlayMask>) -> Option<Horizon> {
    let (w, h) = (l.width, l.height);
    let k = band(h);
    if w < 4 * STRIPES || h < 32 {
        return None;
    }
    let stripes: Vec<Vec<(f64, usize)>> = (0..STRIPES)
        .map(|s| row_sums(l, overlay, s * w / STRIPES..(s + 1) * w / STRIPES))
        .collect();
    let whole: Vec<(f64, usize)> = (0..h)
        .map(|y| {
            stripes
                .iter()
                .fold((0.0, 0), |(a, n), s| (a + s[y].0, n + s[y].1))
        })
        .collect();
    let (lo, hi) = ((h / 20).max(k), h - (h / 20).max(k));
    let (y, step) = (lo..hi)
        .filter_map(|y| step_at(&whole, y, k).map(|s| (y, s)))
        .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))?;
    if step.abs() < f64::from(MIN_STEP) {
        return None;
    }
    let agrees = |s: &Vec<(f64, usize)>| {
        (y.saturating_sub(k).max(lo)..(y + k).min(hi))
            .filter_map(|yy| step_at(s, yy, k))
            .any(|v| v * step.signum() >= 0.5 * step.abs())
    };
    let far = (HALO_REACH * h as f64).round() as usize;
    let halo = (y >= lo + far + k)
        .then(|| {
            let reference = mean(&whole[y - far - k..y - far])?;
            let darkest = (y - far..=y)
                .filter_map(|b| mean(&whole[b - k..b]))
                .min_by(f64::total_cmp)?;
            Some(darkest - reference)
        })
        .flatten();
    let tenth = |v: f64| ((v * 10.0).round() / 10.0) as f32;
    stripes.iter().all(agrees).then(|| Horizon {
        row: ((y as f64 / h as f64) * 1000.0).round() as f32 / 1000.0,
        step: tenth(step),
        halo: halo.map(tenth),
    })
}

/// Per row, the sum and count of the pixels in columns `cols` that are not overlay.
fn row_sums(
    l: &Luma,
    overlay: Option<OverlayMask>,
    cols: std::ops::Range<usize>,
) -> Vec<(f64, usize)> {
    (0..l.height)
        .map(|y| {
            let i0 = y * l.width;
            cols.clone()
                .filter(|&x| !overlay.is_some_and(|m| m[i0 + x]))
                .fold((0.0, 0), |(s, n), x| (s + f64::from(l.y[i0 + x]), n + 1))
        })
        .collect()
}

/// The mean of rows `y..y + k` less that of rows `y − k..y` (`None` when either holds no
/// pixel).
fn step_at(rows: &[(f64, usize)], y: usize, k: usize) -> Option<f64> {
    Some(mean(&rows[y..y + k])? - mean(&rows[y - k..y])?)
}

/// The mean level of `rows`' pixels (`None` when they hold none).
fn mean(rows: &[(f64, usize)]) -> Option<f64> {
    let (s, n) = rows.iter().fold((0.0, 0), |(a, m), &(s, n)| (a + s, m + n));
    (n > 0).then(|| s / n as f64)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A `w`×`h` frame: a sky warming downward by 0.05 levels a row, the ground from row
    /// `at(x)` on `ground` levels above the sky's 100.
    fn frame(w: usize, h: usize, ground: f32, at: impl Fn(usize) -> usize) -> Luma {
        let y = (0..w * h)
            .map(|i| {
                let (x, yy) = (i % w, i / w);
                100.0 + 0.05 * yy as f32 + if yy >= at(x) { ground } else { 0.0 }
            })
            .collect();
        Luma {
            width: w,
            height: h,
            y,
        }
    }

    #[test]
    fn a_level_horizon_is_found_at_its_row_with_its_step() {
        let l = frame(320, 256, 60.0, |_| 182);
        let hz = horizon(&l, None).expect("a horizon");
        assert!((hz.row - 182.0 / 256.0).abs() < 0.002, "{hz:?}");
        assert!((hz.step - 60.4).abs() < 0.5, "{hz:?}");
        // The sky warms 0.05 levels a row: no band is darker than the one a quarter
        // of the height higher.
        assert_eq!(hz.halo, Some(0.0), "{hz:?}");
        // A dark band of 30 levels over the 10 rows above the horizon.
        let mut banded = frame(320, 256, 60.0, |_| 182);
        banded.y[172 * 320..182 * 320]
            .iter_mut()
            .for_each(|v| *v -= 30.0);
        let hz = horizon(&banded, None).expect("a horizon");
        let halo = hz.halo.expect("a quarter of the height of sky above");
        assert!((halo + 30.0 - 64.0 * 0.05).abs() < 0.2, "{hz:?}");
        let dark = frame(320, 256, -40.0, |_| 100);
        let hz = horizon(&dark, None).expect("a darker ground");
        assert!(
            (hz.row - 100.0 / 256.0).abs() < 0.002 && hz.step < -39.0,
            "{hz:?}"
        );
        // 70 rows of sky hold no band a quarter of the height (64 rows) above the
        // horizon's 8 rows and under the top margin's 12.
        let low = horizon(&frame(320, 256, -40.0, |_| 70), None).expect("a horizon");
        assert_eq!(low.halo, None);
    }

    #[test]
    fn a_tilted_horizon_counts_and_a_sky_alone_or_one_mast_does_not() {
        let tilted = frame(320, 256, 60.0, |x| 150 + x / 20);
        let hz = horizon(&tilted, None).expect("tilted by 16 rows over the width");
        assert!((0.58..0.66).contains(&hz.row), "{hz:?}");
        assert_eq!(horizon(&frame(320, 256, 0.0, |_| 0), None), None);
        // A warm block over one stripe of columns only: a mast or a roof, not a horizon.
        let mast = frame(320, 256, 80.0, |x| if x < 60 { 120 } else { 256 });
        assert_eq!(horizon(&mast, None), None);
        // A step too small to be a horizon.
        assert_eq!(horizon(&frame(320, 256, 8.0, |_| 128), None), None);
    }

    #[test]
    fn overlay_pixels_are_left_out() {
        // A bright text band near the top: a step of its own unless left out.
        let mut l = frame(320, 256, 0.0, |_| 0);
        let mut mask = vec![false; 320 * 256];
        for y in 20..40 {
            for x in 0..320 {
                l.y[y * 320 + x] = 250.0;
                mask[y * 320 + x] = true;
            }
        }
        assert!(horizon(&l, None).is_some());
        assert_eq!(horizon(&l, Some(&mask)), None);
    }
}
