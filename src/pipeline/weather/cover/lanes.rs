//! A particle's rows eight columns at once (AVX2): each lane the same IEEE
//! operations in the same order as [`super::coverage`] and the inner rows'
//! formula in [`super::draw`] (Rust fuses no multiply and add; `min`/`max`
//! with the constant second and `clamp` as `min(1, max(0, x))` keep the
//! scalar's NaN and zero results), so the same factors and the same bytes.
//! Lanes past a row's last column, or where the coverage is not above 0,
//! multiply by exactly 1 (every lane is stored whole: a masked store costs
//! tens of cycles on AMD's cores).
//!
//! A narrow particle ([`NARROW`] columns or fewer) is evaluated over its
//! bounds' columns on every row: outside the columns [`super::reach`] (or
//! the inner rows' band) gives, its coverage is not above 0, so the same
//! pixels are multiplied, by the same factors, without solving each row's
//! interval. Most of rain's and snow's particles are far and small (their
//! bounds four to six columns wide): those at most eight wide take one
//! chunk a row, those at most four two rows a chunk.

use std::arch::x86_64::*;

use super::{Prepared, SLACK, Transmit, columns, reach};

/// Particles whose bounds are at most this many columns wide are evaluated
/// over their bounds: two vectors cost less than a row's interval.
const NARROW: u32 = 16;

/// `p` (not tested for depth) into `t.all`, eight columns at a time.
#[target_feature(enable = "avx2")]
pub(super) fn draw_avx2(t: &mut Transmit, p: &Prepared) {
    let [x0, y0, x1, y1] = p.bounds;
    let width = t.width as usize;
    let narrow = x1 - x0 <= NARROW;
    let consts = Consts::of(p);
    if x1 - x0 <= 4 {
        return two_rows_a_chunk(t, p, &consts);
    }
    if x1 - x0 <= 8 {
        return one_chunk_rows(t, p, &consts);
    }
    for y in y0.max(t.rows.start)..y1.min(t.rows.end) {
        let row = (y - t.rows.start) as usize * width;
        let py = y as f32 + 0.5;
        let from_a = py - p.a[1];
        if p.inner.0 < from_a && from_a < p.inner.1 {
            let across = from_a * p.slope;
            let cols = if narrow {
                (x0, x1)
            } else {
                let span = (across - p.half - SLACK, across + p.half + SLACK);
                columns(span, p.a[0], (x0, x1))
            };
            let centre = p.a[0] + across;
            each_chunk(t.all, row, cols, |x| consts.inner(x, centre));
        } else {
            let cols = if narrow {
                (x0, x1)
            } else {
                reach(p, py, (x0, x1))
            };
            let pya = _mm256_set1_ps(py - p.a[1]);
            each_chunk(t.all, row, cols, |x| consts.coverage(p, x, pya));
        }
    }
}

/// A particle at most eight columns wide: over its bounds' columns, one
/// chunk a row, two rows at a time (independent work for the core to
/// overlap), each row's coverage as [`draw_avx2`]'s narrow rows.
#[target_feature(enable = "avx2")]
fn one_chunk_rows(t: &mut Transmit, p: &Prepared, consts: &Consts) {
    let [x0, y0, x1, y1] = p.bounds;
    let width = t.width as usize;
    let step = _mm256_setr_ps(0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0);
    let lanes_in = _mm256_cmp_ps::<_CMP_LT_OQ>(step, _mm256_set1_ps((x1 - x0) as f32));
    let centres = _mm256_add_ps(
        _mm256_add_ps(_mm256_set1_ps(x0 as f32), step),
        _mm256_set1_ps(0.5),
    );
    let cover = |y: u32| {
        let from_a = (y as f32 + 0.5) - p.a[1];
        if p.inner.0 < from_a && from_a < p.inner.1 {
            let centre = p.a[0] + from_a * p.slope;
            consts.inner(centres, centre).1
        } else {
            consts.coverage(p, centres, _mm256_set1_ps(from_a)).1
        }
    };
    let factor = |c: __m256| factor(consts.alpha, c, lanes_in);
    let at = |y: u32| (y - t.rows.start) as usize * width + x0 as usize;
    let (ys, ye) = (y0.max(t.rows.start), y1.min(t.rows.end));
    let mut y = ys;
    while y + 1 < ye {
        let (f0, f1) = (factor(cover(y)), factor(cover(y + 1)));
        times(t.all, at(y), lanes::<_, 8>(f0));
        times(t.all, at(y + 1), lanes::<_, 8>(f1));
        y += 2;
    }
    if y < ye {
        times(t.all, at(y), lanes::<_, 8>(factor(cover(y))));
    }
}

/// A particle at most four columns wide: over its bounds' columns, two
/// rows a chunk (lanes 0–3 a row, 4–7 the next), each lane's coverage
/// as [`draw_avx2`]'s narrow rows give its pixel (an inner row's or any
/// other's, row by row).
#[target_feature(enable = "avx2")]
fn two_rows_a_chunk(t: &mut Transmit, p: &Prepared, consts: &Consts) {
    let [x0, y0, x1, y1] = p.bounds;
    let width = t.width as usize;
    let col = _mm256_setr_ps(0.0, 1.0, 2.0, 3.0, 0.0, 1.0, 2.0, 3.0);
    let next = _mm256_setr_ps(0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 1.0);
    let in_cols = _mm256_cmp_ps::<_CMP_LT_OQ>(col, _mm256_set1_ps((x1 - x0) as f32));
    let centres = _mm256_add_ps(
        _mm256_add_ps(_mm256_set1_ps(x0 as f32), col),
        _mm256_set1_ps(0.5),
    );
    let inner_row = |from_a: f32| p.inner.0 < from_a && from_a < p.inner.1;
    let at = |y: u32| (y - t.rows.start) as usize * width + x0 as usize;
    let (ys, ye) = (y0.max(t.rows.start), y1.min(t.rows.end));
    let mut y = ys;
    while y < ye {
        let two = y + 1 < ye;
        // Each lane's (y as f32 + ½) − a's y: its row's integer, exact.
        let rows = _mm256_add_ps(_mm256_set1_ps(y as f32), next);
        let from_a = _mm256_sub_ps(
            _mm256_add_ps(rows, _mm256_set1_ps(0.5)),
            _mm256_set1_ps(p.a[1]),
        );
        let inner = |from_a: __m256| {
            let centre = _mm256_add_ps(
                _mm256_set1_ps(p.a[0]),
                _mm256_mul_ps(from_a, _mm256_set1_ps(p.slope)),
            );
            consts.inner_at(centres, centre).1
        };
        let (i0, i1) = (
            inner_row((y as f32 + 0.5) - p.a[1]),
            two && inner_row(((y + 1) as f32 + 0.5) - p.a[1]),
        );
        let c = match (i0, i1) {
            (true, true) => inner(from_a),
            (false, false) => consts.coverage(p, centres, from_a).1,
            _ => {
                let upper = _mm256_cmp_ps::<_CMP_EQ_OQ>(next, consts.one);
                let (lo, hi) = (consts.coverage(p, centres, from_a).1, inner(from_a));
                let (lo, hi) = if i0 { (hi, lo) } else { (lo, hi) };
                _mm256_blendv_ps(lo, hi, upper)
            }
        };
        let f = factor(consts.alpha, c, in_cols);
        times(t.all, at(y), lanes::<_, 4>(_mm256_castps256_ps128(f)));
        if two {
            times(
                t.all,
                at(y + 1),
                lanes::<_, 4>(_mm256_extractf128_ps::<1>(f)),
            );
        }
        y += 2;
    }
}

/// Each lane's factor 1 − `alpha` × `c` where it is in `lanes_in` and its
/// coverage `c` is above 0 (or NaN, as the scalar multiplies), else exactly
/// 1: the same bits once multiplied (the transmittances are never
/// signalling NaNs), where selecting the old value compiles to a masked
/// store.
#[target_feature(enable = "avx2")]
#[inline]
fn factor(alpha: __m256, c: __m256, lanes_in: __m256) -> __m256 {
    let skip = _mm256_cmp_ps::<_CMP_LE_OQ>(c, _mm256_setzero_ps());
    let keep = _mm256_andnot_ps(skip, lanes_in);
    let one = _mm256_set1_ps(1.0);
    _mm256_blendv_ps(one, _mm256_sub_ps(one, _mm256_mul_ps(alpha, c)), keep)
}

/// `all[at..at + N]` times the lanes' factors `fs` (1 where nothing
/// covers), or as many as `all` holds past `at`: a whole chunk in one
/// vector multiply (a loop of a fixed count).
#[target_feature(enable = "avx2")]
#[inline]
fn times<const N: usize>(all: &mut [f32], at: usize, fs: [f32; N]) {
    let from = at.min(all.len());
    let chunk = match all.get_mut(at..at + N) {
        Some(chunk) => chunk,
        None => &mut all[from..],
    };
    for (v, f) in chunk.iter_mut().zip(fs) {
        *v *= f;
    }
}

/// A register's lanes, in order (`V` an `__m128` or `__m256`: `N` floats).
#[inline]
fn lanes<V: Copy, const N: usize>(v: V) -> [f32; N] {
    const { assert!(size_of::<V>() == N * size_of::<f32>()) };
    // SAFETY: `V` is `N` floats, lane 0 first (its size checked above).
    #[allow(unsafe_code)]
    unsafe {
        std::mem::transmute_copy(&v)
    }
}

/// Columns `xs..xe` of the row at `row` in `all`, eight at a time: each
/// pixel times 1 − alpha × `cover` of the lanes' pixel centres (`x + ½`)
/// where that is above 0 (a NaN multiplies too, as the scalar does). A
/// chunk that would reach past `all`'s end goes a pixel at a time.
#[target_feature(enable = "avx2")]
#[inline]
fn each_chunk(
    all: &mut [f32],
    row: usize,
    (xs, xe): (u32, u32),
    cover: impl Fn(__m256) -> (__m256, __m256),
) {
    let step = _mm256_setr_ps(0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0);
    let half = _mm256_set1_ps(0.5);
    let mut x = xs;
    while x < xe {
        let at = row + x as usize;
        let lanes_in = _mm256_cmp_ps::<_CMP_LT_OQ>(step, _mm256_set1_ps((xe - x) as f32));
        let centres = _mm256_add_ps(_mm256_add_ps(_mm256_set1_ps(x as f32), step), half);
        let (alpha, c) = cover(centres);
        let Some(chunk) = all.get_mut(at..at + 8) else {
            tail(&mut all[at..row + xe as usize], alpha, c);
            return;
        };
        let f = factor(alpha, c, lanes_in);
        // SAFETY: `chunk` holds 8 floats.
        #[allow(unsafe_code)]
        unsafe {
            let v = _mm256_loadu_ps(chunk.as_ptr());
            _mm256_storeu_ps(chunk.as_mut_ptr(), _mm256_mul_ps(v, f));
        }
        x += 8;
    }
}

/// The last chunk's pixels (fewer than 8 left in the buffer) one at a time:
/// the lanes' coverages `c` as computed, the same product.
#[target_feature(enable = "avx2")]
#[inline]
fn tail(pixels: &mut [f32], alpha: __m256, c: __m256) {
    let (mut a, mut cs) = ([0.0f32; 8], [0.0f32; 8]);
    // SAFETY: both arrays hold 8 floats.
    #[allow(unsafe_code)]
    unsafe {
        _mm256_storeu_ps(a.as_mut_ptr(), alpha);
        _mm256_storeu_ps(cs.as_mut_ptr(), c);
    }
    for ((v, a), c) in pixels.iter_mut().zip(a).zip(cs) {
        if c > 0.0 || c.is_nan() {
            *v *= 1.0 - a * c;
        }
    }
}

/// A particle's constants in lanes.
struct Consts {
    ax: __m256,
    dx: __m256,
    dy: __m256,
    /// r + ½, r², `len`, 1 / len, 1 / len².
    rh: __m256,
    r2: __m256,
    len: __m256,
    inv_len: __m256,
    inv_len2: __m256,
    k: __m256,
    alpha: __m256,
    zero: __m256,
    one: __m256,
    half: __m256,
}

impl Consts {
    #[target_feature(enable = "avx2")]
    #[inline]
    fn of(p: &Prepared) -> Self {
        let s = _mm256_set1_ps;
        Self {
            ax: s(p.a[0]),
            dx: s(p.d[0]),
            dy: s(p.d[1]),
            rh: s(p.r + 0.5),
            r2: s(p.r * p.r),
            len: s(p.len),
            inv_len: s(p.inv_len),
            inv_len2: s(p.inv_len2),
            k: s(p.k),
            alpha: s(p.alpha),
            zero: _mm256_setzero_ps(),
            one: s(1.0),
            half: s(0.5),
        }
    }

    /// `x.clamp(0.0, 1.0)` lane by lane (NaN kept, −0 kept).
    #[target_feature(enable = "avx2")]
    #[inline]
    fn clamp01(&self, x: __m256) -> __m256 {
        _mm256_min_ps(self.one, _mm256_max_ps(self.zero, x))
    }

    /// An inner row's coverage at `px`: `(r + ½ − k·|px − centre|).min(1)`.
    #[target_feature(enable = "avx2")]
    #[inline]
    fn inner(&self, px: __m256, centre: f32) -> (__m256, __m256) {
        self.inner_at(px, _mm256_set1_ps(centre))
    }

    /// [`Consts::inner`] with each lane's own centre (its row's).
    #[target_feature(enable = "avx2")]
    #[inline]
    fn inner_at(&self, px: __m256, centre: __m256) -> (__m256, __m256) {
        let off = abs(_mm256_sub_ps(px, centre));
        let c = _mm256_sub_ps(self.rh, _mm256_mul_ps(self.k, off));
        (self.alpha, _mm256_min_ps(c, self.one))
    }

    /// [`super::coverage`] at `px` on the row `pya` below a.
    #[target_feature(enable = "avx2")]
    #[inline]
    fn coverage(&self, p: &Prepared, px: __m256, pya: __m256) -> (__m256, __m256) {
        let pxa = _mm256_sub_ps(px, self.ax);
        let mul = _mm256_mul_ps;
        let (add, sub) = (_mm256_add_ps, _mm256_sub_ps);
        let capsule = |ex: __m256, ey: __m256| {
            let dist = _mm256_sqrt_ps(add(mul(ex, ex), mul(ey, ey)));
            self.clamp01(sub(self.rh, dist))
        };
        if p.inv_len2 == 0.0 {
            return (self.alpha, capsule(pxa, pya));
        }
        let along = add(mul(pxa, self.dx), mul(pya, self.dy));
        if p.solid {
            let s = mul(along, self.inv_len);
            let e = mul(abs(sub(mul(pxa, self.dy), mul(pya, self.dx))), self.inv_len);
            let edge = self.clamp01(sub(self.rh, e));
            let h = _mm256_sqrt_ps(_mm256_max_ps(sub(self.r2, mul(e, e)), self.zero));
            let h = _mm256_max_ps(h, self.half);
            let over = sub(
                _mm256_min_ps(add(s, h), self.len),
                _mm256_max_ps(sub(s, h), self.zero),
            );
            let time = mul(_mm256_max_ps(over, self.zero), self.inv_len);
            return (self.alpha, mul(edge, _mm256_min_ps(time, self.one)));
        }
        let t = self.clamp01(mul(along, self.inv_len2));
        let ex = sub(pxa, mul(t, self.dx));
        let ey = sub(pya, mul(t, self.dy));
        (self.alpha, capsule(ex, ey))
    }
}

/// `|x|` lane by lane.
#[target_feature(enable = "avx2")]
#[inline]
fn abs(x: __m256) -> __m256 {
    _mm256_andnot_ps(_mm256_set1_ps(-0.0), x)
}
