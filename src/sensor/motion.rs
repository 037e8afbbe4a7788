//! Motion blur for sequences (`camera_model.exposure_time_s`): while the
//! shutter is open each drone's image moves by its streak, and the picture
//! is the time average, in linear light, of the drone over the still
//! background. Made on the CPU from the rendered frame and its drone-free
//! background, before the rest of the camera chain.
//!
//! For a streak with shift s (pixels over the exposure, centred on the
//! frame's time) and the drone's difference D = lin(frame) − lin(background)
//! over its own rect, the blurred frame is
//! `lin(background)(p) + (1/n)·Σₖ D(p − tₖ·s)`, tₖ = −½ … ½ in n ≥ 2 equal
//! steps at most ½ px apart, D sampled bilinearly (0 outside the rect).
//! A pixel inside several rects belongs to the first. The drone's own
//! rotation during the exposure and the background's motion (a following
//! camera) are not blurred. Pixels no streak reaches keep their bytes.

use super::PixelRect;
use super::encode::{encode, encode_table};
use super::exposure::decode_table;

/// One drone's motion during the exposure.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Streak {
    /// Where the drone is drawn in the frame (its pixels differ from the
    /// background only inside).
    pub rect: PixelRect,
    /// How far its image moves while the shutter is open, pixels (x, y).
    pub shift_px: (f64, f64),
}

impl Streak {
    /// Whether the streak moves the image at all (≥ 1/100 px).
    pub fn moves(&self) -> bool {
        self.shift_px.0.hypot(self.shift_px.1) >= 0.01
            && self.shift_px.0.is_finite()
            && self.shift_px.1.is_finite()
    }

    /// The pixels the streak can reach: its rect swept by ±shift/2 (plus the
    /// bilinear tap), clamped to the `width`×`height` image.
    pub fn swept(&self, width: u32, height: u32) -> PixelRect {
        let (hx, hy) = (self.shift_px.0.abs() / 2.0, self.shift_px.1.abs() / 2.0);
        let grow = |v: u32, by: f64, max: u32, up: bool| -> u32 {
            let by = by.min(f64::from(u32::MAX / 4)).ceil() as u32 + 1;
            if up {
                v.saturating_add(by).min(max)
            } else {
                v.saturating_sub(by)
            }
        };
        PixelRect {
            x0: grow(self.rect.x0, hx, width, false),
            y0: grow(self.rect.y0, hy, height, false),
            x1: grow(self.rect.x1.min(width), hx, width, true),
            y1: grow(self.rect.y1.min(height), hy, height, true),
        }
    }
}

/// The most bilinear samples (three per pixel and step, one a channel) one
/// frame's motion blur may take: its work budget, about 12 s on one core
/// (20 drones of 2 m crossing a 1920 × 1080 frame in a 1 s exposure needed
/// 5.5·10⁹ and took 69 s). Past it the frame is an error naming
/// `camera_model.exposure_time_s` ([`smear_samples`]).
pub const MAX_SMEAR_SAMPLES: u64 = 1_000_000_000;

/// The bilinear samples [`smear`] takes for `streaks` on a `width`×`height`
/// frame: per moving streak, its swept rect's pixels × its samples × 3
/// channels (saturating).
pub fn smear_samples(streaks: &[Streak], width: u32, height: u32) -> u64 {
    (streaks.iter().filter(|s| s.moves()))
        .map(|s| {
            let r = s.swept(width, height);
            let pixels =
                u64::from(r.x1.saturating_sub(r.x0)) * u64::from(r.y1.saturating_sub(r.y0));
            let n = samples(s.shift_px.0.hypot(s.shift_px.1)) as u64;
            pixels.saturating_mul(n * 3)
        })
        .fold(0u64, u64::saturating_add)
}

/// Samples along a streak of `length_px`: at most ½ px apart, at least 2,
/// at most 512.
fn samples(length_px: f64) -> usize {
    ((2.0 * length_px).ceil() as usize + 1).clamp(2, 512)
}

/// `frame` (RGBA8, `width`×`height`) with every moving streak blurred over
/// `background` (the same frame without drones). Alpha is kept.
pub fn smear(
    frame: &[u8],
    background: &[u8],
    (width, height): (u32, u32),
    streaks: &[Streak],
) -> Vec<u8> {
    let mut out = frame.to_vec();
    let n_px = width as usize * height as usize;
    if frame.len() < n_px * 4 || background.len() < n_px * 4 {
        return out;
    }
    let moving: Vec<&Streak> = streaks.iter().filter(|s| s.moves()).collect();
    let Some(mut acc) = Accumulator::over(&moving, width, height) else {
        return out;
    };
    let mut owned: Vec<PixelRect> = Vec::new();
    for s in &moving {
        let Some(diff) = Difference::of(frame, background, width, height, s.rect, &owned) else {
            continue;
        };
        owned.push(diff.rect);
        acc.add(s, &diff, width, height);
    }
    acc.apply(background, width, &mut out);
    out
}

/// Linear light of byte `i` of an sRGB buffer.
pub(super) fn lin(dec: &[f32; 256], buf: &[u8], i: usize) -> f32 {
    dec[buf[i] as usize]
}

/// One drone's difference D = lin(frame) − lin(background) over its rect
/// (clamped to the image), 0 where an earlier streak owns the pixel (the
/// rolling shutter's too).
pub(super) struct Difference {
    pub(super) rect: PixelRect,
    w: usize,
    h: usize,
    /// RGB per pixel, row-major over the rect.
    d: Vec<f32>,
}

impl Difference {
    /// D over `rect` of the `width`×`height` frame, or `None` when the
    /// clamped rect is empty. Pixels inside any `owned` rect stay 0.
    pub(super) fn of(
        frame: &[u8],
        background: &[u8],
        width: u32,
        height: u32,
        rect: PixelRect,
        owned: &[PixelRect],
    ) -> Option<Self> {
        let dec = decode_table();
        let r = PixelRect {
            x0: rect.x0.min(width),
            y0: rect.y0.min(height),
            x1: rect.x1.min(width),
            y1: rect.y1.min(height),
        };
        let (rw, rh) = (
            (r.x1.saturating_sub(r.x0)) as usize,
            (r.y1.saturating_sub(r.y0)) as usize,
        );
        if rw == 0 || rh == 0 {
            return None;
        }
        let inside = |o: &PixelRect, x: u32, y: u32| x >= o.x0 && x < o.x1 && y >= o.y0 && y < o.y1;
        let mut d = vec![0f32; rw * rh * 3];
        for y in 0..rh {
            for x in 0..rw {
                let (ax, ay) = (r.x0 + x as u32, r.y0 + y as u32);
                if owned.iter().any(|o| inside(o, ax, ay)) {
                    continue;
                }
                let i = (ay as usize * width as usize + ax as usize) * 4;
                for c in 0..3 {
                    d[(y * rw + x) * 3 + c] = lin(dec, frame, i + c) - lin(dec, background, i + c);
                }
            }
        }
        Some(Self {
            rect: r,
            w: rw,
            h: rh,
            d,
        })
    }

    /// Channel `c` of D at image point (`x`, `y`): bilinear in D's
    /// pixel-centre grid, 0 outside.
    pub(super) fn sample(&self, x: f64, y: f64, c: usize) -> f32 {
        let (u, v) = (
            x - 0.5 - f64::from(self.rect.x0),
            y - 0.5 - f64::from(self.rect.y0),
        );
        let (i0, j0) = (u.floor(), v.floor());
        let (fx, fy) = ((u - i0) as f32, (v - j0) as f32);
        let at = |i: f64, j: f64| -> f32 {
            if i < 0.0 || j < 0.0 || i >= self.w as f64 || j >= self.h as f64 {
                0.0
            } else {
                self.d[(j as usize * self.w + i as usize) * 3 + c]
            }
        };
        let top = at(i0, j0) + (at(i0 + 1.0, j0) - at(i0, j0)) * fx;
        let bottom = at(i0, j0 + 1.0) + (at(i0 + 1.0, j0 + 1.0) - at(i0, j0 + 1.0)) * fx;
        top + (bottom - top) * fy
    }

    /// Image row coordinate `y` on D's pixel-centre grid: its first tap's
    /// row and the second's weight (the same for every x, so a row's
    /// samples find it once: [`Self::sample_rgb_on`]).
    pub(super) fn row_at(&self, y: f64) -> (f64, f32) {
        let v = y - 0.5 - f64::from(self.rect.y0);
        let j0 = v.floor();
        (j0, (v - j0) as f32)
    }

    /// The three channels of D at image point (`x`, row): [`Self::sample`]'s
    /// values, the taps and weights found once, on the row found by
    /// [`Self::row_at`].
    #[inline(always)]
    pub(super) fn sample_rgb_on(&self, (j0, fy): (f64, f32), x: f64) -> [f32; 3] {
        let u = x - 0.5 - f64::from(self.rect.x0);
        let i0 = u.floor();
        let fx = (u - i0) as f32;
        let tap = |i: f64, j: f64| -> [f32; 3] {
            if i < 0.0 || j < 0.0 || i >= self.w as f64 || j >= self.h as f64 {
                return [0.0; 3];
            }
            let o = (j as usize * self.w + i as usize) * 3;
            let rgb = self
                .d
                .get(o..o + 3)
                .and_then(|s| <[f32; 3]>::try_from(s).ok());
            rgb.unwrap_or([0.0; 3])
        };
        let (a, b) = (tap(i0, j0), tap(i0 + 1.0, j0));
        let (c, d) = (tap(i0, j0 + 1.0), tap(i0 + 1.0, j0 + 1.0));
        std::array::from_fn(|k| {
            let top = a[k] + (b[k] - a[k]) * fx;
            let bottom = c[k] + (d[k] - c[k]) * fx;
            top + (bottom - top) * fy
        })
    }
}

/// The streaks' summed contributions over the bounding box of every swept
/// rect, and which of its pixels any streak reached.
struct Accumulator {
    bbox: PixelRect,
    bw: usize,
    bh: usize,
    /// RGB per pixel, row-major over the box.
    acc: Vec<f32>,
    touched: Vec<bool>,
}

impl Accumulator {
    /// An empty accumulator over the union of the streaks' swept rects, or
    /// `None` when there are no streaks.
    fn over(moving: &[&Streak], width: u32, height: u32) -> Option<Self> {
        let bbox = moving
            .iter()
            .map(|s| s.swept(width, height))
            .reduce(|a, b| PixelRect {
                x0: a.x0.min(b.x0),
                y0: a.y0.min(b.y0),
                x1: a.x1.max(b.x1),
                y1: a.y1.max(b.y1),
            })?;
        let bw = (bbox.x1 - bbox.x0) as usize;
        let bh = (bbox.y1.saturating_sub(bbox.y0)) as usize;
        Some(Self {
            bbox,
            bw,
            bh,
            acc: vec![0f32; bw * bh * 3],
            touched: vec![false; bw * bh],
        })
    }

    /// Adds streak `s`'s time average of `diff` over its swept rect.
    fn add(&mut self, s: &Streak, diff: &Difference, width: u32, height: u32) {
        let n = samples(s.shift_px.0.hypot(s.shift_px.1));
        let weight = 1.0 / n as f32;
        let sw = s.swept(width, height);
        for y in sw.y0..sw.y1 {
            for x in sw.x0..sw.x1 {
                let k = (y - self.bbox.y0) as usize * self.bw + (x - self.bbox.x0) as usize;
                self.touched[k] = true;
                for c in 0..3 {
                    let mut sum = 0f32;
                    for t in 0..n {
                        let t = t as f64 / (n - 1) as f64 - 0.5;
                        let (px, py) = (
                            f64::from(x) + 0.5 - t * s.shift_px.0,
                            f64::from(y) + 0.5 - t * s.shift_px.1,
                        );
                        sum += diff.sample(px, py, c);
                    }
                    self.acc[k * 3 + c] += sum * weight;
                }
            }
        }
    }

    /// Writes lin(background) + the contributions into `out` at every
    /// touched pixel of the `width`-wide image; the rest keep their bytes.
    fn apply(&self, background: &[u8], width: u32, out: &mut [u8]) {
        let dec = decode_table();
        let enc = encode_table();
        let w = width as usize;
        for y in 0..self.bh {
            for x in 0..self.bw {
                let k = y * self.bw + x;
                if !self.touched[k] {
                    continue;
                }
                let i = ((self.bbox.y0 as usize + y) * w + self.bbox.x0 as usize + x) * 4;
                for c in 0..3 {
                    let v = lin(dec, background, i + c) + self.acc[k * 3 + c];
                    out[i + c] = encode(enc, v.clamp(0.0, 1.0));
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A dark square on a grey sky moved by 10 px: the streak is 10 px longer,
    /// its mean light is kept, and a still streak changes nothing.
    #[test]
    fn a_streak_spreads_the_drone_along_its_motion() {
        let (w, h) = (64u32, 32u32);
        let bg: Vec<u8> = (0..w * h).flat_map(|_| [180, 190, 200, 255]).collect();
        let mut frame = bg.clone();
        for y in 12..20 {
            for x in 20..28 {
                let i = ((y * w + x) * 4) as usize;
                frame[i..i + 3].copy_from_slice(&[20, 20, 20]);
            }
        }
        let rect = PixelRect {
            x0: 20,
            y0: 12,
            x1: 28,
            y1: 20,
        };
        let still = Streak {
            rect,
            shift_px: (0.0, 0.0),
        };
        assert_eq!(smear(&frame, &bg, (w, h), &[still]), frame);
        let out = smear(
            &frame,
            &bg,
            (w, h),
            &[Streak {
                rect,
                shift_px: (10.0, 0.0),
            }],
        );
        let row = |buf: &[u8], y: u32| -> Vec<u8> {
            (0..w).map(|x| buf[((y * w + x) * 4) as usize]).collect()
        };
        let changed: Vec<u32> = (0..w)
            .filter(|&x| row(&out, 16)[x as usize] != 180)
            .collect();
        let (first, last) = (changed[0], *changed.last().expect("changed"));
        // 8 px wide, moved 10 px (±5): pixels 15 … 32 change.
        assert!(
            (15..=16).contains(&first) && (31..=32).contains(&last),
            "{first}..{last}"
        );
        // The light removed from the sky is the same (linear, within 1 %).
        let dec = decode_table();
        let deficit = |buf: &[u8]| -> f64 {
            (0..w * h)
                .map(|p| f64::from(dec[180] - dec[buf[(p * 4) as usize] as usize]))
                .sum()
        };
        let (a, b) = (deficit(&frame), deficit(&out));
        assert!((b / a - 1.0).abs() < 0.01, "{a} vs {b}");
        // Rows outside the drone's rows are untouched.
        assert_eq!(row(&out, 5), row(&frame, 5));
    }
}
