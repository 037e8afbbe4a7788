//! The inverse's Newton steps for four points at once in AVX2 lanes
//! (issue 41): a Brown–Conrady draw's [`LensGeometry::newton_step`] with
//! each lane's operations those of the scalar step, in its order (IEEE
//! additions, multiplications and divisions, no fused multiply-add), so
//! each lane's steps and result are the scalar ones bit for bit (tested). A
//! step where a live lane's point lies near or past the fold radius (the
//! scalar mapping's other branches) is taken in scalar for all four.

use std::arch::x86_64::*;

use super::{LensDraw, LensGeometry, NEWTON_STEPS};

/// Four points' coordinates, one a lane.
type V = __m256d;

/// A Brown–Conrady draw's coefficients, each in every lane.
struct Coefficients {
    k: [V; 3],
    p1: V,
    p2: V,
    two_p1: V,
    two_p2: V,
}

/// [`LensDraw::distort`] (Brown–Conrady) in four lanes: its operations in order.
#[target_feature(enable = "avx2")]
#[inline]
fn distort(c: &Coefficients, (x, y): (V, V)) -> (V, V) {
    let (one, two) = (_mm256_set1_pd(1.0), _mm256_set1_pd(2.0));
    let (add, mul) = (_mm256_add_pd, _mm256_mul_pd);
    let r2 = add(mul(x, x), mul(y, y));
    let inner = add(c.k[1], mul(r2, c.k[2]));
    let radial = add(one, mul(r2, add(c.k[0], mul(r2, inner))));
    let xy_term = |t: V| mul(mul(t, x), y);
    let u = add(
        add(mul(x, radial), xy_term(c.two_p1)),
        mul(c.p2, add(r2, mul(mul(two, x), x))),
    );
    let v = add(
        add(mul(y, radial), mul(c.p1, add(r2, mul(mul(two, y), y)))),
        xy_term(c.two_p2),
    );
    (u, v)
}

/// The four lanes.
#[target_feature(enable = "avx2")]
#[inline]
fn lanes(v: V) -> [f64; 4] {
    let mut a = [0.0; 4];
    // SAFETY: `a` holds four f64; storeu takes any alignment.
    #[allow(unsafe_code)]
    unsafe {
        _mm256_storeu_pd(a.as_mut_ptr(), v)
    };
    a
}

/// Four lanes from `a`.
#[target_feature(enable = "avx2")]
#[inline]
fn vector(a: [f64; 4]) -> V {
    _mm256_setr_pd(a[0], a[1], a[2], a[3])
}

/// |x| in every lane.
#[target_feature(enable = "avx2")]
#[inline]
fn abs(x: V) -> V {
    _mm256_andnot_pd(_mm256_set1_pd(-0.0), x)
}

impl LensGeometry {
    /// [`Self::inverse_n4`] of a Brown–Conrady draw in AVX2 lanes: each
    /// lane steps until its own step ends (converged or singular), as the
    /// scalar loop does; `None` for another model.
    #[target_feature(enable = "avx2")]
    pub(super) fn inverse_n4_avx2(&self, d: [(f64, f64); 4]) -> Option<[(f64, f64); 4]> {
        let LensDraw::BrownConrady { k1, k2, k3, p1, p2 } = self.draw else {
            return None;
        };
        let c = Coefficients {
            k: [k1, k2, k3].map(|k| _mm256_set1_pd(k)),
            p1: _mm256_set1_pd(p1),
            p2: _mm256_set1_pd(p2),
            two_p1: _mm256_set1_pd(2.0 * p1),
            two_p2: _mm256_set1_pd(2.0 * p2),
        };
        let target = (vector(d.map(|p| p.0)), vector(d.map(|p| p.1)));
        let mut p = target;
        let mut live = _mm256_castsi256_pd(_mm256_set1_epi64x(-1));
        for _ in 0..NEWTON_STEPS {
            match self.step4(&c, p, target, live) {
                Some((next, still)) => (p, live) = (next, still),
                None => (p, live) = self.scalar_step4(p, target, live),
            }
            if _mm256_movemask_pd(live) == 0 {
                break;
            }
        }
        let (x, y) = (lanes(p.0), lanes(p.1));
        Some(std::array::from_fn(|i| (x[i], y[i])))
    }

    /// One Newton step of the `live` lanes from `p` towards `target`
    /// ([`Self::newton_step`]'s operations): the points and the lanes
    /// still live after it; `None` when a live lane's mapping leaves the
    /// inner branch of [`Self::forward_n`].
    #[target_feature(enable = "avx2")]
    #[inline]
    fn step4(&self, c: &Coefficients, p: (V, V), d: (V, V), live: V) -> Option<((V, V), V)> {
        let (add, sub, mul, div) = (_mm256_add_pd, _mm256_sub_pd, _mm256_mul_pd, _mm256_div_pd);
        let lim = _mm256_set1_pd(self.r_lim * self.r_lim * (1.0 - 1e-9));
        // Whether every live lane's point is inside `forward_n`'s first test.
        let inner = |(x, y): (V, V)| {
            let r2 = add(mul(x, x), mul(y, y));
            let outside = _mm256_andnot_pd(_mm256_cmp_pd::<_CMP_LT_OQ>(r2, lim), live);
            _mm256_movemask_pd(outside) == 0
        };
        let h = mul(
            _mm256_set1_pd(1e-7),
            add(add(_mm256_set1_pd(1.0), abs(p.0)), abs(p.1)),
        );
        let (px, py) = ((add(p.0, h), p.1), (p.0, add(p.1, h)));
        if !(inner(p) && inner(px) && inner(py)) {
            return None;
        }
        let (f, fx, fy) = (distort(c, p), distort(c, px), distort(c, py));
        let e = (sub(f.0, d.0), sub(f.1, d.1));
        let converged = _mm256_cmp_pd::<_CMP_LT_OQ>(add(abs(e.0), abs(e.1)), _mm256_set1_pd(1e-14));
        let (a, b) = (div(sub(fx.0, f.0), h), div(sub(fy.0, f.0), h));
        let (cc, dd) = (div(sub(fx.1, f.1), h), div(sub(fy.1, f.1), h));
        let det = sub(mul(a, dd), mul(b, cc));
        let singular = _mm256_or_pd(
            _mm256_cmp_pd::<_CMP_UNORD_Q>(det, det),
            _mm256_cmp_pd::<_CMP_LE_OQ>(abs(det), _mm256_set1_pd(1e-12)),
        );
        let next = (
            sub(p.0, div(sub(mul(dd, e.0), mul(b, e.1)), det)),
            sub(p.1, div(sub(mul(a, e.1), mul(cc, e.0)), det)),
        );
        let still = _mm256_andnot_pd(_mm256_or_pd(converged, singular), live);
        let keep = |old: V, new: V| _mm256_blendv_pd(old, new, still);
        Some(((keep(p.0, next.0), keep(p.1, next.1)), still))
    }

    /// [`Self::step4`] lane by lane in scalar ([`Self::newton_step`]).
    #[target_feature(enable = "avx2")]
    fn scalar_step4(&self, p: (V, V), d: (V, V), live: V) -> ((V, V), V) {
        let [mut x, mut y, dx, dy] = [p.0, p.1, d.0, d.1].map(|v| lanes(v));
        let mut l = lanes(live);
        for i in 0..4 {
            if l[i].to_bits() == 0 {
                continue;
            }
            match self.newton_step((x[i], y[i]), (dx[i], dy[i])) {
                Some(next) => (x[i], y[i]) = next,
                None => l[i] = 0.0,
            }
        }
        ((vector(x), vector(y)), vector(l))
    }
}
