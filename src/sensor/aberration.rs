//! Lateral chromatic aberration, the stage after the exposure: the red and
//! blue images scaled radially about the image centre by their drawn scale
//! relative to green (bilinear resampling; each column's taps computed once
//! per band, the contiguous ones read in runs that vectorise, two decoded
//! rows cached per channel). Its rows are the chain's source, which the
//! optics' PSF filters.

use super::CameraDraw;
use super::exposure::{Exposure, decode_row};

/// Each channel's radial scale (`None`: 1, or not a usable scale).
pub(super) fn scales(draw: &CameraDraw) -> [Option<f64>; 3] {
    let ca_of = |s: f64| (s != 1.0 && s.is_finite() && s > 0.0).then_some(s);
    [ca_of(draw.ca_red_scale), None, ca_of(draw.ca_blue_scale)]
}

/// The chain's rows after exposure and chromatic aberration, per channel,
/// over the padded columns `pad0 … pad0 + pw − 1` (each clamped to the
/// image): what the optics' PSF ([`super::psf`]) filters.
pub(super) struct Source<'c, 'a> {
    exposure: &'c Exposure<'a>,
    /// The first padded column (image columns are clamped to the image).
    pad0: i64,
    /// Per channel with aberration: its column taps and decoded-row cache.
    ca: [Option<Aberration>; 3],
    out: Vec<f32>,
}

/// One channel's chromatic aberration over a band's padded columns.
struct Aberration {
    inv: f64,
    centre_y: f64,
    /// First decoded column, and per padded column (c0 − first, c1 − first, fx).
    first: usize,
    taps: Vec<(usize, usize, f32)>,
    /// The taps in runs ([`tap_runs`]), and each column's fx alone.
    runs: Vec<TapRun>,
    fx: Vec<f32>,
    /// Two decoded rows (`keys`: their image rows, −1 none), `first …` wide.
    keys: [i64; 2],
    decoded: [Vec<f32>; 2],
    /// The two rows interpolated vertically.
    mid: Vec<f32>,
}

impl<'c, 'a> Source<'c, 'a> {
    /// The rows of `exposure`'s image with each channel scaled radially by
    /// `scales` ([`scales`]), over `pw` columns from `pad0`.
    pub(super) fn new(
        exposure: &'c Exposure<'a>,
        scales: [Option<f64>; 3],
        pad0: i64,
        pw: usize,
    ) -> Self {
        let (w, h) = (exposure.width, exposure.height);
        let cols: Vec<usize> = (0..pw as i64)
            .map(|j| (pad0 + j).clamp(0, w - 1) as usize)
            .collect();
        let (cx, cy) = (w as f64 / 2.0, h as f64 / 2.0);
        let ca = scales.map(|scale| {
            let inv = 1.0 / scale?;
            let tap = |x: i64| {
                let u = cx + (x as f64 + 0.5 - cx) * inv - 0.5;
                (u.floor() as i64, (u - u.floor()) as f32)
            };
            let raw: Vec<(usize, usize, f32)> = cols
                .iter()
                .map(|&x| {
                    let (i, f) = tap(x as i64);
                    (
                        i.clamp(0, w - 1) as usize,
                        (i + 1).clamp(0, w - 1) as usize,
                        f,
                    )
                })
                .collect();
            let first = raw.iter().map(|t| t.0.min(t.1)).min().unwrap_or(0);
            let end = raw.iter().map(|t| t.0.max(t.1) + 1).max().unwrap_or(1);
            let taps: Vec<(usize, usize, f32)> = raw
                .into_iter()
                .map(|(a, b, f)| (a - first, b - first, f))
                .collect();
            Some(Aberration {
                inv,
                centre_y: cy,
                first,
                runs: tap_runs(&taps),
                fx: taps.iter().map(|t| t.2).collect(),
                taps,
                keys: [-1, -1],
                decoded: [vec![0.0; end - first], vec![0.0; end - first]],
                mid: vec![0.0; end - first],
            })
        });
        Self {
            exposure,
            pad0,
            ca,
            out: vec![0.0; pw],
        }
    }

    /// Channel `c`'s row at image row `y` (clamped).
    #[inline(always)]
    pub(super) fn row(&mut self, c: usize, y: i64) -> &[f32] {
        let exposure = self.exposure;
        let (w, last) = (exposure.width as usize, exposure.height - 1);
        let lut = &exposure.luts[c];
        let image_row = |y: i64| &exposure.rgba[y as usize * w * 4..(y as usize + 1) * w * 4];
        let decode = |y: i64, first: usize, out: &mut [f32]| {
            decode_row(lut, image_row(y), c, first as i64, out);
        };
        match &mut self.ca[c] {
            None => decode_row(
                lut,
                image_row(y.clamp(0, last)),
                c,
                self.pad0,
                &mut self.out,
            ),
            Some(a) => {
                let y = y.clamp(0, last);
                let u = a.centre_y + (y as f64 + 0.5 - a.centre_y) * a.inv - 0.5;
                let (yi, fy) = (u.floor() as i64, (u - u.floor()) as f32);
                let (k0, k1) = (yi.clamp(0, last), (yi + 1).clamp(0, last));
                let first = a.first;
                let s0 = a.slot(k0, k1, |k, out| decode(k, first, out));
                let s1 = a.slot(k1, k0, |k, out| decode(k, first, out));
                let (r0, r1) = (&a.decoded[s0], &a.decoded[s1]);
                lerp_rows(r0, r1, fy, &mut a.mid);
                taps_runs(&a.mid, (&a.taps, &a.fx), &a.runs, &mut self.out);
            }
        }
        &self.out
    }
}

impl Aberration {
    /// The cache slot holding decoded row `k`, filling one that does not
    /// hold `keep` when `k` is missing.
    #[inline(always)]
    fn slot(&mut self, k: i64, keep: i64, fill: impl Fn(i64, &mut [f32])) -> usize {
        if let Some(s) = self.keys.iter().position(|&key| key == k) {
            return s;
        }
        let s = usize::from(self.keys[0] == keep && keep != k);
        fill(k, &mut self.decoded[s]);
        self.keys[s] = k;
        s
    }
}

/// Output columns `start..end` whose aberration taps are (c0 + k, c0 + k + 1)
/// for k = 0, 1, … (`Some(c0)`, a run read as two contiguous slices), or one
/// column with other taps (`None`: at the image's edges).
#[derive(Clone, Copy, Debug)]
pub(super) struct TapRun {
    pub(super) start: usize,
    pub(super) end: usize,
    pub(super) c0: Option<usize>,
}

/// The taps split into [`TapRun`]s.
pub(super) fn tap_runs(taps: &[(usize, usize, f32)]) -> Vec<TapRun> {
    let mut runs = Vec::new();
    let mut j = 0;
    while j < taps.len() {
        let (c0, c1, _) = taps[j];
        let mut end = j + 1;
        if c1 == c0 + 1 {
            while end < taps.len()
                && taps[end].0 == c0 + (end - j)
                && taps[end].1 == taps[end].0 + 1
            {
                end += 1;
            }
        }
        let c0 = (c1 == c0 + 1).then_some(c0);
        runs.push(TapRun { start: j, end, c0 });
        j = end;
    }
    runs
}

/// `out[j]` = `src[c0]` + (`src[c1]` − `src[c0]`)·`fx` for the taps
/// (c0, c1, fx) of column j, as [`taps_row`] computes it, a
/// run of contiguous taps at a time (a loop that vectorises).
#[inline(always)]
pub(super) fn taps_runs(
    src: &[f32],
    (taps, fx): (&[(usize, usize, f32)], &[f32]),
    runs: &[TapRun],
    out: &mut [f32],
) {
    for run in runs {
        let (out, taps) = (&mut out[run.start..run.end], &taps[run.start..run.end]);
        match run.c0 {
            Some(c0) => {
                let n = out.len();
                let (a, b) = (&src[c0..c0 + n], &src[c0 + 1..c0 + 1 + n]);
                let fx = &fx[run.start..run.end];
                for (((o, x), y), f) in out.iter_mut().zip(a).zip(b).zip(fx) {
                    *o = x + (y - x) * f;
                }
            }
            None => taps_row(src, taps, out),
        }
    }
}

/// `out` = `r0` + (`r1` − `r0`)·`fy`, element by element (vectorises).
#[inline(always)]
pub(super) fn lerp_rows(r0: &[f32], r1: &[f32], fy: f32, out: &mut [f32]) {
    for ((o, a), b) in out.iter_mut().zip(r0).zip(r1) {
        *o = a + (b - a) * fy;
    }
}

/// `out[i]` = `src[c0]` + (`src[c1]` − `src[c0]`)·`fx` for the taps (c0, c1, fx).
#[inline(always)]
pub(super) fn taps_row(src: &[f32], taps: &[(usize, usize, f32)], out: &mut [f32]) {
    for (o, &(c0, c1, fx)) in out.iter_mut().zip(taps) {
        *o = src[c0] + (src[c1] - src[c0]) * fx;
    }
}
