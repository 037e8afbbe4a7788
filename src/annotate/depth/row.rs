//! One row of a triangle's pixel walk in the depth raster: at each pixel
//! centre of the row's columns, the triangle's exact barycentric test and
//! depth, kept where nearer. The same f64 operations in the same order
//! one centre at a time ([`walk`]) and four at a time in AVX2 registers
//! ([`walk_avx2`]; Rust never fuses a multiply and an add): the same bits
//! (checked by the tests of `depth.rs`).

use glam::DVec2;

/// A triangle ready for its walk: its corners on screen and their
/// camera-frame z, twice its signed area (non-zero) and a depth no
/// centre of it is nearer than.
#[derive(Clone, Copy, Debug)]
pub(super) struct Setup {
    pub a: DVec2,
    pub b: DVec2,
    pub c: DVec2,
    pub z: [f64; 3],
    pub area: f64,
    pub nearest: f64,
}

/// The centres of a row to walk: those at y = `cy` of the columns from
/// `first` on, `depths` their depths in the tile (one a column).
pub(super) struct Row<'a> {
    pub depths: &'a mut [f64],
    pub cy: f64,
    pub first: u32,
}

/// [`walk`] in AVX2 registers where `simd` (the CPU has AVX2).
#[inline(always)]
pub(super) fn walk_with(t: &Setup, row: Row<'_>, simd: bool) {
    #[cfg(target_arch = "x86_64")]
    if simd {
        // SAFETY: the caller checked that the CPU has AVX2.
        #[allow(unsafe_code)]
        unsafe {
            walk_avx2(t, row);
        }
        return;
    }
    let _ = simd;
    walk(t, row);
}

/// Keep the triangle's depth at each centre of `row` it covers, where
/// nearer than the depth there (one centre at a time).
#[inline(always)]
pub(super) fn walk(t: &Setup, row: Row<'_>) {
    let Setup {
        a,
        b,
        c,
        z: [za, zb, zc],
        area,
        nearest,
    } = *t;
    let Row { depths, cy, first } = row;
    for (px, depth) in (first..).zip(depths.iter_mut()) {
        if nearest >= *depth {
            continue;
        }
        let p = DVec2::new(f64::from(px) + 0.5, cy);
        let (na, nb) = ((c - b).perp_dot(p - b), (a - c).perp_dot(p - c));
        // The weights na / area and nb / area below 0 told by the signs,
        // before dividing: the centres a span's margin holds outside the
        // triangle skip the divisions. (Not a bit moves: the corners are
        // pixel positions, so a non-zero na or nb is far above the
        // quotient's underflow.)
        if (na < 0.0 && area > 0.0) || (na > 0.0 && area < 0.0) {
            continue;
        }
        if (nb < 0.0 && area > 0.0) || (nb > 0.0 && area < 0.0) {
            continue;
        }
        let wa = na / area;
        let wb = nb / area;
        let wc = 1.0 - wa - wb;
        if wa < 0.0 || wb < 0.0 || wc < 0.0 {
            continue;
        }
        let z = 1.0 / (wa / za + wb / zb + wc / zc);
        if z < *depth {
            *depth = z;
        }
    }
}

/// [`walk`] four centres at a time: every lane computes what [`walk`]
/// computes for its centre, and a lane keeps its new depth only where
/// [`walk`] would have stored it (every one of its tests passed).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn walk_avx2(t: &Setup, row: Row<'_>) {
    use std::arch::x86_64::{
        _CMP_GE_OQ, _CMP_GT_OQ, _CMP_LT_OQ, _mm256_add_pd, _mm256_and_pd, _mm256_andnot_pd,
        _mm256_castpd_si256, _mm256_castsi256_pd, _mm256_cmp_pd, _mm256_cmpgt_epi64, _mm256_div_pd,
        _mm256_maskload_pd, _mm256_maskstore_pd, _mm256_movemask_pd, _mm256_mul_pd, _mm256_or_pd,
        _mm256_set_epi64x, _mm256_set_pd, _mm256_set1_epi64x, _mm256_set1_pd, _mm256_setzero_pd,
        _mm256_sub_pd,
    };
    let (Setup { a, b, c, .. }, [za, zb, zc]) = (*t, t.z);
    let (area, nearest) = (t.area, t.nearest);
    let Row { depths, cy, first } = row;
    let n = depths.len();
    // The products that do not move along the row: (c − b).x · (p − b).y
    // and (a − c).x · (p − c).y, the same values `perp_dot` forms.
    let (cb, ac) = (c - b, a - c);
    let (fixed_a, fixed_b) = (cb.x * (cy - b.y), ac.x * (cy - c.y));
    let splat = _mm256_set1_pd;
    let zero = _mm256_setzero_pd();
    let positive = area > 0.0;
    let lane_index = _mm256_set_epi64x(3, 2, 1, 0);
    let steps = _mm256_set_pd(3.0, 2.0, 1.0, 0.0);
    for k in (0..n).step_by(4) {
        // SAFETY: lanes past the row's end are masked off in the load and
        // the store (a masked lane is neither read nor written); the first
        // lane lies inside `depths` (k < n).
        #[allow(unsafe_code)]
        unsafe {
            let live = _mm256_cmpgt_epi64(_mm256_set1_epi64x((n - k) as i64), lane_index);
            let at = depths.as_mut_ptr().add(k);
            let old = _mm256_maskload_pd(at, live);
            // Lanes whose depth is not already as near as the triangle gets.
            let open = _mm256_andnot_pd(
                _mm256_cmp_pd::<_CMP_GE_OQ>(splat(nearest), old),
                _mm256_castsi256_pd(live),
            );
            if _mm256_movemask_pd(open) == 0 {
                continue;
            }
            // f64::from(px) + 0.5, px = first + k + lane: whole numbers, exact.
            let px = _mm256_add_pd(splat(f64::from(first) + k as f64), steps);
            let x = _mm256_add_pd(px, splat(0.5));
            let na = _mm256_sub_pd(
                splat(fixed_a),
                _mm256_mul_pd(splat(cb.y), _mm256_sub_pd(x, splat(b.x))),
            );
            let nb = _mm256_sub_pd(
                splat(fixed_b),
                _mm256_mul_pd(splat(ac.y), _mm256_sub_pd(x, splat(c.x))),
            );
            // The sign tests: outside where a numerator has the sign opposite to the area's.
            let outside = if positive {
                _mm256_or_pd(
                    _mm256_cmp_pd::<_CMP_LT_OQ>(na, zero),
                    _mm256_cmp_pd::<_CMP_LT_OQ>(nb, zero),
                )
            } else {
                _mm256_or_pd(
                    _mm256_cmp_pd::<_CMP_GT_OQ>(na, zero),
                    _mm256_cmp_pd::<_CMP_GT_OQ>(nb, zero),
                )
            };
            let open = _mm256_andnot_pd(outside, open);
            if _mm256_movemask_pd(open) == 0 {
                continue;
            }
            let wa = _mm256_div_pd(na, splat(area));
            let wb = _mm256_div_pd(nb, splat(area));
            let wc = _mm256_sub_pd(_mm256_sub_pd(splat(1.0), wa), wb);
            let negative = _mm256_or_pd(
                _mm256_or_pd(
                    _mm256_cmp_pd::<_CMP_LT_OQ>(wa, zero),
                    _mm256_cmp_pd::<_CMP_LT_OQ>(wb, zero),
                ),
                _mm256_cmp_pd::<_CMP_LT_OQ>(wc, zero),
            );
            let sum = _mm256_add_pd(
                _mm256_add_pd(_mm256_div_pd(wa, splat(za)), _mm256_div_pd(wb, splat(zb))),
                _mm256_div_pd(wc, splat(zc)),
            );
            let z = _mm256_div_pd(splat(1.0), sum);
            let keep = _mm256_and_pd(
                _mm256_andnot_pd(negative, open),
                _mm256_cmp_pd::<_CMP_LT_OQ>(z, old),
            );
            _mm256_maskstore_pd(at, _mm256_castpd_si256(keep), z);
        }
    }
}
