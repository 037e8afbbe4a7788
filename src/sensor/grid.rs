//! The sensor grid, when `sensor_scale` < 1: the output's linear picture
//! averaged into sensor pixels (a box filter over each sensor pixel's
//! footprint: output columns ⌊jW/w⌋ … ⌊(j+1)W/w⌋ − 1, rows likewise), the
//! sensor's clipping and noise on those pixels, and the sensor picture
//! scaled back to the output size bilinearly (pixel centres aligned, edges
//! clamped). Here: which sensor rows and columns a window of the output
//! needs, which output rows and columns those average, and the two
//! resamplings of one row.

use super::CameraDraw;
use super::Span;

/// Output size (`w`×`h`) and the sensor's (`sw`×`sh`), each side smaller or equal.
#[derive(Clone, Copy, Debug)]
pub(super) struct Grid {
    pub(super) w: i64,
    pub(super) h: i64,
    pub(super) sw: i64,
    pub(super) sh: i64,
}

impl Grid {
    /// The draw's sensor grid (`None`: the output's own pixels).
    pub(super) fn of(draw: &CameraDraw, width: u32, height: u32) -> Option<Self> {
        let (sw, sh) = draw.sensor_size(width, height);
        ((sw, sh) != (width, height)).then_some(Self {
            w: i64::from(width),
            h: i64::from(height),
            sw: i64::from(sw),
            sh: i64::from(sh),
        })
    }

    /// The sensor columns (rows: [`Self::sensor_rows`]) the output columns `out` read.
    pub(super) fn sensor_cols(&self, out: Span) -> Span {
        sensor_span(out, self.w, self.sw)
    }

    pub(super) fn sensor_rows(&self, out: Span) -> Span {
        sensor_span(out, self.h, self.sh)
    }

    /// The output columns (rows: [`Self::footprint_rows`]) sensor pixels `s` average.
    pub(super) fn footprint_cols(&self, s: Span) -> Span {
        Span {
            start: footprint(s.start, self.w, self.sw).start,
            end: footprint(s.end - 1, self.w, self.sw).end,
        }
    }

    pub(super) fn footprint_rows(&self, s: Span) -> Span {
        Span {
            start: footprint(s.start, self.h, self.sh).start,
            end: footprint(s.end - 1, self.h, self.sh).end,
        }
    }

    /// Output row `y`'s two sensor rows (clamped) and the weight of the second.
    pub(super) fn up_rows(&self, y: i64) -> (i64, i64, f32) {
        let (j, fy) = up_tap(y, self.h, self.sh);
        (j.clamp(0, self.sh - 1), (j + 1).clamp(0, self.sh - 1), fy)
    }
}

/// The output pixels sensor pixel `j` averages on a side of `n` output and
/// `m` sensor pixels: ⌊jn/m⌋ … ⌊(j+1)n/m⌋ − 1, at least one.
#[inline]
pub(super) fn footprint(j: i64, n: i64, m: i64) -> Span {
    let (a, b) = (j * n / m, (j + 1) * n / m);
    Span {
        start: a,
        end: b.max(a + 1),
    }
}

/// Output pixel `x`'s bilinear tap on the sensor (side `n` output, `m`
/// sensor pixels): the first sensor pixel (unclamped) and the second's weight.
#[inline]
pub(super) fn up_tap(x: i64, n: i64, m: i64) -> (i64, f32) {
    let u = (x as f64 + 0.5) * m as f64 / n as f64 - 0.5;
    let i = u.floor();
    (i as i64, (u - i) as f32)
}

/// The sensor pixels (clamped) the output pixels `out` read.
fn sensor_span(out: Span, n: i64, m: i64) -> Span {
    Span {
        start: up_tap(out.start, n, m).0.clamp(0, m - 1),
        end: (up_tap(out.end - 1, n, m).0 + 1).clamp(0, m - 1) + 1,
    }
}

/// One band's box filter into a sensor row: each output row's values
/// averaged over the sensor columns' footprints, summed over the rows of the
/// sensor row's footprint, then divided by their count.
pub(super) struct Down {
    /// Per sensor column, its footprint relative to the first output column read.
    cols: Vec<Span>,
    across: Vec<f32>,
    pub(super) sums: [Vec<f32>; 3],
}

impl Down {
    /// For the sensor columns `s`, read from output columns starting at `first`.
    pub(super) fn new(grid: &Grid, s: Span, first: i64) -> Self {
        let cols: Vec<Span> = (s.start..s.end)
            .map(|j| {
                let f = footprint(j, grid.w, grid.sw);
                Span {
                    start: f.start - first,
                    end: f.end - first,
                }
            })
            .collect();
        let n = cols.len();
        Self {
            cols,
            across: vec![0.0; n],
            sums: std::array::from_fn(|_| vec![0.0; n]),
        }
    }

    /// Start a sensor row.
    pub(super) fn clear(&mut self) {
        for s in &mut self.sums {
            s.fill(0.0);
        }
    }

    /// Add one output row's three channels (from the first output column read).
    pub(super) fn add(&mut self, vals: &[Vec<f32>; 3]) {
        for (sums, row) in self.sums.iter_mut().zip(vals) {
            for (o, f) in self.across.iter_mut().zip(&self.cols) {
                let sum: f32 = row[f.start as usize..f.end as usize].iter().sum();
                *o = sum / (f.end - f.start) as f32;
            }
            for (s, a) in sums.iter_mut().zip(&self.across) {
                *s += a;
            }
        }
    }

    /// End a sensor row that summed `rows` output rows.
    pub(super) fn finish(&mut self, rows: i64) {
        let n = rows as f32;
        for s in &mut self.sums {
            for v in s.iter_mut() {
                *v /= n;
            }
        }
    }
}

/// Per output column of a window, its two sensor columns (relative to the
/// first sensor column held) and the second's weight.
pub(super) fn up_cols(grid: &Grid, out: Span, first: i64) -> Vec<(usize, usize, f32)> {
    (out.start..out.end)
        .map(|x| {
            let (i, f) = up_tap(x, grid.w, grid.sw);
            let at = |i: i64| (i.clamp(0, grid.sw - 1) - first) as usize;
            (at(i), at(i + 1), f)
        })
        .collect()
}

/// One output row from sensor rows `r0`, `r1` (weight `fy` on `r1`).
#[inline(always)]
pub(super) fn up_row(
    r0: &[f32],
    r1: &[f32],
    fy: f32,
    cols: &[(usize, usize, f32)],
    out: &mut [f32],
) {
    for (o, &(c0, c1, fx)) in out.iter_mut().zip(cols) {
        let top = r0[c0] + (r0[c1] - r0[c0]) * fx;
        let bottom = r1[c0] + (r1[c1] - r1[c0]) * fx;
        *o = top + (bottom - top) * fy;
    }
}
