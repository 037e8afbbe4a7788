//! The procedural environment's noise and silhouettes, as
//! shaders/environment.wgsl computes them (`hash12`, `vnoise`, `fbm`,
//! `ridged`, `silhouette_height`), in `f32` with the maths of
//! [`crate::simd::math`]: branch-free, so the renderer's CPU pass
//! vectorises a loop of them, and the same values in every SIMD build. The
//! auto-exposure meter ([`super::meter`]) evaluates the same functions.

use glam::Vec2;

use super::Silhouette;
use crate::simd::math::{atan2, fract, smoothstep};

#[inline(always)]
pub(crate) fn hash12(p: Vec2) -> f32 {
    let (x, y) = (fract(p.x * 0.1031), fract(p.y * 0.1031));
    // p3 = (x, y, x); p3 += dot(p3, p3.yzx + 33.33).
    let d = x * (y + 33.33) + y * (x + 33.33) + x * (x + 33.33);
    let (x, y, z) = (x + d, y + d, x + d);
    fract((x + y) * z)
}

#[inline(always)]
pub(crate) fn vnoise(p: Vec2) -> f32 {
    let (ix, iy) = (p.x.floor(), p.y.floor());
    let (fx, fy) = (p.x - ix, p.y - iy);
    let (ux, uy) = (fx * fx * (3.0 - 2.0 * fx), fy * fy * (3.0 - 2.0 * fy));
    let a = hash12(Vec2::new(ix, iy));
    let b = hash12(Vec2::new(ix + 1.0, iy));
    let c = hash12(Vec2::new(ix, iy + 1.0));
    let d = hash12(Vec2::new(ix + 1.0, iy + 1.0));
    #[inline(always)]
    fn lerp(x: f32, y: f32, t: f32) -> f32 {
        x + (y - x) * t
    }
    lerp(lerp(a, b, ux), lerp(c, d, ux), uy)
}

/// At most this many octaves: [`fbm`] and [`ridged`] are written out
/// octave by octave, with no loop and no call through a closure, so that
/// a loop over pixels that calls them is an innermost loop of inlined
/// code, which the compiler vectorises.
const MAX_OCTAVES: u32 = 5;

/// `fbm`: `octaves` (at most [`MAX_OCTAVES`]) of value noise, each at
/// 2.02 times the frequency and half the amplitude of the one before.
#[inline(always)]
pub(crate) fn fbm(p: Vec2, octaves: u32) -> f32 {
    octaves_of::<false>(p, octaves.min(MAX_OCTAVES))
}

/// `ridged`: as [`fbm`] with each octave folded into a ridge (1 − |2n − 1|),
/// at 2.07 times the frequency.
#[inline(always)]
pub(crate) fn ridged(p: Vec2, octaves: u32) -> f32 {
    octaves_of::<true>(p, octaves.min(MAX_OCTAVES))
}

/// The sum of `octaves` octaves of value noise from `p` (`RIDGED`: each
/// folded into a ridge), the amplitude halved at each.
#[inline(always)]
fn octaves_of<const RIDGED: bool>(p: Vec2, octaves: u32) -> f32 {
    #[inline(always)]
    fn octave<const RIDGED: bool>((sum, amp, q): &mut (f32, f32, Vec2), live: bool) {
        if live {
            let n = vnoise(*q);
            let n = if RIDGED {
                1.0 - (2.0 * n - 1.0).abs()
            } else {
                n
            };
            *sum += *amp * n;
            *q = if RIDGED {
                *q * 2.07 + Vec2::new(3.7, 1.3)
            } else {
                *q * 2.02 + Vec2::new(17.1, 9.3)
            };
            *amp *= 0.5;
        }
    }
    let mut state = (0.0, 0.5, p);
    // `octaves` is a constant where this is inlined: each test folds away.
    octave::<RIDGED>(&mut state, octaves > 0);
    octave::<RIDGED>(&mut state, octaves > 1);
    octave::<RIDGED>(&mut state, octaves > 2);
    octave::<RIDGED>(&mut state, octaves > 3);
    octave::<RIDGED>(&mut state, octaves > 4);
    state.0
}

/// The angular height (rad) of a silhouette of `kind` and `height` at
/// azimuth `c` (unit xz), −1 for none: `silhouette_height`.
#[inline(always)]
pub(crate) fn silhouette_height(kind: Silhouette, height: f32, c: Vec2, seed: Vec2) -> f32 {
    match kind {
        Silhouette::None => -1.0,
        Silhouette::Hills => height * (0.3 + 0.7 * fbm(c * 2.5 + seed, 3)),
        Silhouette::Mountains => {
            let r = ridged(c * 3.0 + seed, 5);
            height * (0.1 + 0.9 * r * r) * (0.6 + 0.4 * vnoise(c * 1.3 + Vec2::new(seed.y, seed.x)))
        }
        Silhouette::Skyline => {
            let az = atan2(c.x, c.y);
            let block = (az * 90.0 / std::f32::consts::TAU * 4.0).floor();
            let h = 0.25 + 0.75 * hash12(Vec2::new(block, seed.x));
            let town = smoothstep(0.42, 0.5, vnoise(c * 2.0 + seed));
            height * h * town + height * 0.08
        }
        Silhouette::TreeLine => height * (0.55 + 0.45 * fbm(c * 90.0 + seed, 2)),
    }
}

/// GLSL's `step`: 0 below `edge`, else 1.
#[inline(always)]
pub(crate) fn step(edge: f32, x: f32) -> f32 {
    if x < edge { 0.0 } else { 1.0 }
}

/// The silhouette kind a uniform holds (`pattern.w`, `far_params.y`).
pub(crate) fn silhouette_of(kind: f32) -> Silhouette {
    match kind.round() as i32 {
        1 => Silhouette::Hills,
        2 => Silhouette::Mountains,
        3 => Silhouette::Skyline,
        4 => Silhouette::TreeLine,
        _ => Silhouette::None,
    }
}
