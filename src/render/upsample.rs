//! The procedural environment's upsampling, on the CPU: the environment
//! pass draws at half resolution per axis (linear RGB, half floats), and
//! the frame's background is its bilinear upsampling, sRGB-encoded to 8 bits.
//!
//! On the GPU this was a full-frame pass (a filtered texture fetch and an
//! sRGB `pow` per pixel) and a full-frame readback; lavapipe spent more CPU
//! on it than the whole frame's drones. Here it is separable and exact:
//! the same sample positions and weights as the GPU pass's clamping
//! bilinear sampler (`uv = position / (2 · principal point)`), the
//! interpolation in `f32`, and the sRGB encoding of
//! [`srgb_u8`] rounded exactly (a table of the 255 decision thresholds, not
//! a `pow` approximation). It differs from the GPU pass by at most one
//! 8-bit level where lavapipe's `pow` and filtering round the other way
//! (docs/benchmarks.md states how many pixels).

use std::sync::LazyLock;

/// Bucket count of [`SrgbTable`]'s first guess.
const GUESS_BUCKETS: usize = 4096;

/// Linear values where the sRGB-encoded 8-bit value steps up, and a first
/// guess per bucket of linear values.
struct SrgbTable {
    /// `thresholds[k]`: the least linear value encoded as `k` (k ≥ 1);
    /// `thresholds[0]` is `-inf`.
    thresholds: [f32; 256],
    /// The encoded value at each bucket's low end.
    guess: [u8; GUESS_BUCKETS + 1],
}

/// The sRGB transfer function on linear `x` in [0, 1].
fn srgb(x: f64) -> f64 {
    if x <= 0.003_130_8 {
        x * 12.92
    } else {
        1.055 * x.powf(1.0 / 2.4) - 0.055
    }
}

/// The inverse of [`srgb`].
fn linear(s: f64) -> f64 {
    if s <= 0.040_45 {
        s / 12.92
    } else {
        ((s + 0.055) / 1.055).powf(2.4)
    }
}

static SRGB: LazyLock<SrgbTable> = LazyLock::new(|| {
    let mut thresholds = [f32::NEG_INFINITY; 256];
    for (k, t) in thresholds.iter_mut().enumerate().skip(1) {
        // The least f32 whose encoding rounds to k: start at the exact
        // crossing and step to the f32 where the rounding turns.
        let mut v = linear((k as f64 - 0.5) / 255.0) as f32;
        let encoded = |v: f32| (srgb(f64::from(v)) * 255.0).round_ties_even();
        while encoded(v) >= k as f64 {
            v = f32::from_bits(v.to_bits() - 1);
        }
        while encoded(v) < k as f64 {
            v = f32::from_bits(v.to_bits() + 1);
        }
        *t = v;
    }
    let mut guess = [0u8; GUESS_BUCKETS + 1];
    for (b, g) in guess.iter_mut().enumerate() {
        let v = b as f32 / GUESS_BUCKETS as f32;
        *g = thresholds.iter().rposition(|&t| t <= v).unwrap_or(0) as u8;
    }
    SrgbTable { thresholds, guess }
});

/// Linear `x` sRGB-encoded and rounded to 8 bits (clamped to [0, 1], NaN → 0),
/// as `linear_to_srgb` in common.wgsl and an `Rgba8Unorm` store would.
#[cfg(test)]
fn srgb_u8(x: f32) -> u8 {
    SRGB.encode(x)
}

impl SrgbTable {
    #[inline]
    fn encode(&self, x: f32) -> u8 {
        let table = self;
        let x = if x > 0.0 { x.min(1.0) } else { 0.0 };
        // Each bucket spans less than one level, so one step at most.
        let mut k = table.guess[(x * GUESS_BUCKETS as f32) as usize];
        while k < 255 && x >= table.thresholds[usize::from(k) + 1] {
            k += 1;
        }
        k
    }
}

/// Where output pixels sample along one axis: the two texels and the
/// second's weight, as a clamping bilinear sampler at
/// `(i + 0.5) / (2 · centre)` of `source` texels.
fn taps(out: u32, source: u32, centre: f32) -> Vec<(usize, usize, f32)> {
    let last = source.saturating_sub(1) as usize;
    (0..out)
        .map(|i| {
            let uv = (i as f32 + 0.5) / (2.0 * centre);
            let t = uv * source as f32 - 0.5;
            let base = t.floor();
            let w = t - base;
            let clamp = |v: f32| (v.max(0.0) as usize).min(last);
            (clamp(base), clamp(base + 1.0), w)
        })
        .collect()
}

/// Upsample the environment pass's `half` (RGBA, `size` texels, linear) to
/// the frame's `frame` size into `rgba` (RGBA8, sRGB, alpha 255), for a
/// camera whose principal point is `centre` (pixels).
pub(super) fn upsample_environment(
    half: &[f32],
    size: (u32, u32),
    frame: (u32, u32),
    centre: (f32, f32),
    rgba: &mut Vec<u8>,
) {
    let (w, h) = (size.0 as usize, size.1 as usize);
    rgba.clear();
    rgba.resize(frame.0 as usize * frame.1 as usize * 4, 0);
    if w == 0 || h == 0 || half.len() < w * h * 4 {
        return;
    }
    let table = &*SRGB;
    let columns = taps(frame.0, size.0, centre.0);
    let rows = taps(frame.1, size.1, centre.1);
    // One source row pair blended vertically (RGB), reused across output rows.
    let mut blended = vec![0f32; w * 3];
    let stride = frame.0 as usize * 4;
    for (&(r0, r1, wy), line) in rows.iter().zip(rgba.chunks_exact_mut(stride)) {
        let (a, b) = (&half[r0 * w * 4..], &half[r1 * w * 4..]);
        for (x, out) in blended.chunks_exact_mut(3).enumerate() {
            for c in 0..3 {
                let (p, q) = (a[x * 4 + c], b[x * 4 + c]);
                out[c] = p + (q - p) * wy;
            }
        }
        for (&(c0, c1, wx), px) in columns.iter().zip(line.chunks_exact_mut(4)) {
            let (p, q) = (&blended[c0 * 3..c0 * 3 + 3], &blended[c1 * 3..c1 * 3 + 3]);
            px[0] = table.encode(p[0] + (q[0] - p[0]) * wx);
            px[1] = table.encode(p[1] + (q[1] - p[1]) * wx);
            px[2] = table.encode(p[2] + (q[2] - p[2]) * wx);
            px[3] = 255;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_u8_rounds_the_transfer_function_exactly() {
        // Every f32 step across [0, 1] in a fine sweep agrees with the f64 formula.
        for i in 0..=200_000u32 {
            let x = i as f32 / 200_000.0;
            let want = (srgb(f64::from(x)) * 255.0).round_ties_even() as u8;
            assert_eq!(srgb_u8(x), want, "x = {x}");
        }
        assert_eq!(srgb_u8(-0.5), 0);
        assert_eq!(srgb_u8(f32::NAN), 0);
        assert_eq!(srgb_u8(7.0), 255);
        assert_eq!(srgb_u8(1.0), 255);
        // Each threshold is the least value of its level.
        let t = &SRGB.thresholds;
        for (k, &least) in t.iter().enumerate().skip(1) {
            assert_eq!(usize::from(srgb_u8(least)), k);
            let below = f32::from_bits(least.to_bits() - 1);
            assert_eq!(usize::from(srgb_u8(below)), k - 1);
        }
    }

    #[test]
    fn upsampling_interpolates_with_the_samplers_weights() {
        // 2×1 texels (0 and 1 in red) to 4×2 pixels, centre (2, 1): the
        // columns sample at texel coordinates -0.25, 0.25, 0.75, 1.25.
        let half = [0.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 1.0];
        let mut rgba = Vec::new();
        upsample_environment(&half, (2, 1), (4, 2), (2.0, 1.0), &mut rgba);
        assert_eq!(rgba.len(), 4 * 2 * 4);
        let red: Vec<u8> = rgba.chunks_exact(4).map(|p| p[0]).collect();
        let want = [0.0, 0.25, 0.75, 1.0].map(srgb_u8);
        assert_eq!(&red[..4], &want);
        assert_eq!(&red[4..], &want, "rows clamp at the edge");
        assert!(
            rgba.chunks_exact(4)
                .all(|p| p[1] == 0 && p[2] == 0 && p[3] == 255)
        );
    }

    #[test]
    fn a_short_source_gives_a_black_frame_not_a_panic() {
        let mut rgba = vec![9; 3];
        upsample_environment(&[0.5; 4], (2, 2), (4, 4), (2.0, 2.0), &mut rgba);
        assert_eq!(rgba, vec![0; 64]);
    }
}
