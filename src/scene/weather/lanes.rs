//! The weather's particles made sixteen at once in AVX2: the depths'
//! Newton steps, the half-widths and the two projections of four particles
//! in one register each, four registers side by side (their steps
//! independent, so one's latency hides behind the others'), every lane the
//! scalar code's IEEE operations in its order ([`Maker::one`]:
//! `DepthTable::depth`, `Frustum::prim` and `area`, `View::project`), a
//! lane's Newton steps stopping where its own would (the lanes still
//! running carry the others unchanged); the draws and each particle's last
//! checks (`FrameWeather::mark`) stay scalar. So the particles are the
//! scalar code's, bit for bit (tested).

use std::arch::x86_64::*;

use super::{DepthTable, KNOTS, MAX_STEPS, Maker, Particle};

/// Registers side by side.
const GROUPS: usize = 4;
/// Particles a call makes.
pub(super) const LANES: usize = 4 * GROUPS;

/// [`GROUPS`] registers of four lanes.
type Wide = [__m256d; GROUPS];

/// Particles `first` … `first + 15` (those below `count`), as
/// [`Maker::one`] makes each, into `out` in order; how many. The frustum's depths
/// must be a range (far > near: otherwise every depth is the near one,
/// made by the scalar code).
#[target_feature(enable = "avx2")]
pub(super) fn sixteen(m: &Maker, first: u64, count: u64, out: &mut [Particle; LANES]) -> usize {
    // The draws, by kind: [depth, x, y, diameter][lane].
    let mut u = [[0.0f64; LANES]; 4];
    for l in 0..LANES {
        let i = first + l as u64;
        if i < count {
            for (kind, d) in u.iter_mut().zip(m.draws.of(i)) {
                kind[l] = d;
            }
        }
    }
    let wide = |v: &[f64; LANES]| -> Wide {
        std::array::from_fn(|g| _mm256_setr_pd(v[4 * g], v[4 * g + 1], v[4 * g + 2], v[4 * g + 3]))
    };
    let set = _mm256_set1_pd;
    let fr = m.depths.frustum;
    let z = depths(m.depths, wide(&u[0]));
    let (ux, uy, ud) = (wide(&u[1]), wide(&u[2]), wide(&u[3]));
    let (one, two, half) = (set(1.0), set(2.0), set(0.5));
    let (lo, hi) = m.weather.diameter_mm;
    let (t, f, c) = (m.travel, set(m.view.focal), m.view.centre);
    let mut lanes = [[0.0f64; LANES]; 8];
    for g in 0..GROUPS {
        let z = z[g];
        let hx = _mm256_add_pd(_mm256_mul_pd(set(fr.s.0), z), set(fr.m.0));
        let hy = _mm256_add_pd(_mm256_mul_pd(set(fr.s.1), z), set(fr.m.1));
        let sx = _mm256_mul_pd(hx, _mm256_sub_pd(_mm256_mul_pd(two, ux[g]), one));
        let sy = _mm256_mul_pd(hy, _mm256_sub_pd(_mm256_mul_pd(two, uy[g]), one));
        let d = _mm256_add_pd(set(lo), _mm256_mul_pd(set(hi - lo), ud[g]));
        let d = _mm256_mul_pd(d, set(1e-3));
        let ex = _mm256_add_pd(sx, set(t.x));
        let ey = _mm256_add_pd(sy, set(t.y));
        let ez = _mm256_add_pd(z, set(t.z));
        let project = |x: __m256d, z: __m256d, c: f64| {
            _mm256_add_pd(_mm256_div_pd(_mm256_mul_pd(f, x), z), set(c))
        };
        let zm = _mm256_mul_pd(half, _mm256_add_pd(z, ez));
        let r_px = _mm256_div_pd(_mm256_mul_pd(_mm256_mul_pd(half, d), f), zm);
        let values = [
            z,
            ez,
            project(sx, z, c.x),
            project(sy, z, c.y),
            project(ex, ez, c.x),
            project(ey, ez, c.y),
            zm,
            r_px,
        ];
        for (o, v) in lanes.iter_mut().zip(values) {
            // SAFETY: `o[4g..4g + 4]` holds four f64s.
            #[allow(unsafe_code)]
            unsafe {
                _mm256_storeu_pd(o[4 * g..4 * g + 4].as_mut_ptr(), v)
            };
        }
    }
    let [z, ez, ax, ay, bx, by, zm, r_px] = lanes;
    // `View::project`'s refusal, for either end.
    let seen = |z: f64| !z.is_nan() && z > 0.0;
    let mut made = 0;
    for l in 0..LANES.min((count - first.min(count)) as usize) {
        if !seen(z[l]) || !seen(ez[l]) {
            continue;
        }
        let (a, b) = ((ax[l], ay[l]).into(), (bx[l], by[l]).into());
        if let Some(p) = (m.weather).mark(m.view, (a, b), (zm[l], r_px[l]), m.atmosphere) {
            out[made] = p;
            made += 1;
        }
    }
    made
}

/// `DepthTable::depth` of shares `u` (each in [0, 1)).
#[target_feature(enable = "avx2")]
fn depths(t: &DepthTable, u: Wide) -> Wide {
    let set = _mm256_set1_pd;
    let (near, far) = t.frustum.depth;
    let fr = t.frustum;
    let ((sx, sy), (mx, my)) = (fr.s, fr.m);
    let (cubic, square, linear) = (set(sx * sy), set(sx * my + sy * mx), set(mx * my));
    let (two, three, four) = (set(2.0), set(3.0), set(4.0));
    let (lo, hi, tol) = (set(near), set(far), set(1e-7 * far));
    let sign = set(-0.0);
    let mut z = [set(0.0); GROUPS];
    let mut target = [set(0.0); GROUPS];
    for g in 0..GROUPS {
        let at = _mm256_mul_pd(u[g], set(KNOTS as f64));
        let k = _mm_min_epi32(_mm256_cvttpd_epi32(at), _mm_set1_epi32(KNOTS as i32 - 1));
        let mut ks = [0i32; 4];
        // SAFETY: `ks` holds four i32s.
        #[allow(unsafe_code)]
        unsafe {
            _mm_storeu_si128(ks.as_mut_ptr().cast(), k)
        };
        let knot = |j: usize| {
            let v = ks.map(|k| t.knots[k as usize + j]);
            _mm256_setr_pd(v[0], v[1], v[2], v[3])
        };
        let (z0, z1) = (knot(0), knot(1));
        let frac = _mm256_sub_pd(at, _mm256_cvtepi32_pd(k));
        z[g] = _mm256_add_pd(z0, _mm256_mul_pd(frac, _mm256_sub_pd(z1, z0)));
        target[g] = _mm256_add_pd(set(t.base), _mm256_mul_pd(u[g], set(t.volume)));
    }
    let mut running = [_mm256_castsi256_pd(_mm256_set1_epi64x(-1)); GROUPS];
    for _ in 0..MAX_STEPS {
        let mut any = 0;
        for g in 0..GROUPS {
            let zg = z[g];
            let zz = _mm256_mul_pd(zg, zg);
            let terms = _mm256_add_pd(
                _mm256_div_pd(_mm256_mul_pd(cubic, _mm256_mul_pd(zz, zg)), three),
                _mm256_div_pd(_mm256_mul_pd(square, zz), two),
            );
            let prim = _mm256_mul_pd(four, _mm256_add_pd(terms, _mm256_mul_pd(linear, zg)));
            let hx = _mm256_add_pd(_mm256_mul_pd(set(sx), zg), set(mx));
            let hy = _mm256_add_pd(_mm256_mul_pd(set(sy), zg), set(my));
            let area = _mm256_mul_pd(_mm256_mul_pd(four, hx), hy);
            let step = _mm256_div_pd(_mm256_sub_pd(prim, target[g]), area);
            // `f64::clamp(near, far)`: NaN stays NaN.
            let mut next = _mm256_sub_pd(zg, step);
            next = _mm256_blendv_pd(next, lo, _mm256_cmp_pd::<_CMP_LT_OQ>(next, lo));
            next = _mm256_blendv_pd(next, hi, _mm256_cmp_pd::<_CMP_GT_OQ>(next, hi));
            z[g] = _mm256_blendv_pd(zg, next, running[g]);
            let done = _mm256_cmp_pd::<_CMP_LE_OQ>(_mm256_andnot_pd(sign, step), tol);
            running[g] = _mm256_andnot_pd(done, running[g]);
            any |= _mm256_movemask_pd(running[g]);
        }
        if any == 0 {
            break;
        }
    }
    z
}
