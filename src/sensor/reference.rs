//! The test reference of the camera chain (compiled for tests only): the
//! stages on planes of linear f32 (one per channel) covering a window of
//! the image, one full pass per stage, in the order the module docs give,
//! straightforward rather than fast. Every stage reads its source at
//! absolute coordinates clamped to the source's window (the output window
//! grown by [`CameraDraw::reach_px`], clamped to the image), so the
//! window's pixels equal the whole frame's. The registered per-pixel stages
//! ([`super::pixel_stages`]) run on the planes row by row. The tests below
//! compare the sweep ([`super::sweep`]) with it byte for byte.

use rayon::prelude::*;

use super::aberration::{lerp_rows, taps_row};
use super::encode::encode_row;
use super::exposure::luts;
use super::psf::{disc_spans, gaussian_weights};
use super::{CameraDraw, PixelRect, PsfDraw, noise};

/// A window `[x0, x1) × [y0, y1)` in absolute pixels of some grid.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Win {
    x0: i64,
    y0: i64,
    x1: i64,
    y1: i64,
}

impl Win {
    fn w(self) -> usize {
        (self.x1 - self.x0).max(0) as usize
    }
    fn h(self) -> usize {
        (self.y1 - self.y0).max(0) as usize
    }
}

/// One channel over a window.
struct Plane {
    win: Win,
    data: Vec<f32>,
}

impl Plane {
    /// Row `y` (absolute, clamped into the window).
    #[inline]
    fn row(&self, y: i64) -> &[f32] {
        let y = (y.clamp(self.win.y0, self.win.y1 - 1) - self.win.y0) as usize;
        let w = self.win.w();
        &self.data[y * w..(y + 1) * w]
    }

    /// Column index of absolute `x`, clamped into the window.
    #[inline]
    fn col(&self, x: i64) -> usize {
        (x.clamp(self.win.x0, self.win.x1 - 1) - self.win.x0) as usize
    }
}

/// A plane over `win` whose rows `f(absolute y, row)` fills, rows in parallel.
fn rows(win: Win, f: impl Fn(i64, &mut [f32]) + Sync) -> Plane {
    let w = win.w();
    let mut data = vec![0f32; w * win.h()];
    if w > 0 {
        data.par_chunks_mut(w)
            .enumerate()
            .for_each(|(r, row)| f(win.y0 + r as i64, row));
    }
    Plane { win, data }
}

/// [`super::develop`] before the sharpening, on planes of the window grown
/// by the reach: every stage a pass over three f32 planes. Computed from a
/// window of the input `reach_px` wider than `out`, so they are the bytes
/// the whole frame gets there.
pub(super) fn develop_planes(
    rgba: &[u8],
    width: u32,
    height: u32,
    draw: &CameraDraw,
    out: PixelRect,
    noisy: bool,
) -> Vec<u8> {
    let (wi, hi) = (i64::from(width), i64::from(height));
    let out = Win {
        x0: i64::from(out.x0).clamp(0, wi),
        y0: i64::from(out.y0).clamp(0, hi),
        x1: i64::from(out.x1).clamp(0, wi),
        y1: i64::from(out.y1).clamp(0, hi),
    };
    if out.w() == 0 || out.h() == 0 || rgba.len() < (width as usize) * (height as usize) * 4 {
        return Vec::new();
    }
    let reach = i64::from(draw.reach_px(width, height));
    let win = Win {
        x0: (out.x0 - reach).max(0),
        y0: (out.y0 - reach).max(0),
        x1: (out.x1 + reach).min(wi),
        y1: (out.y1 + reach).min(hi),
    };
    let centre = (f64::from(width) / 2.0, f64::from(height) / 2.0);

    // 1. Decode, with exposure and white balance folded into the table.
    let luts = luts(draw);
    let mut planes: [Plane; 3] = std::array::from_fn(|c| {
        let lut = &luts[c];
        rows(win, |y, row| {
            let start = (y as usize * width as usize + win.x0 as usize) * 4 + c;
            for (o, px) in row.iter_mut().zip(rgba[start..].iter().step_by(4)) {
                *o = lut[*px as usize];
            }
        })
    });

    // 2. Lateral chromatic aberration: red and blue scaled about the centre.
    for (c, scale) in [(0, draw.ca_red_scale), (2, draw.ca_blue_scale)] {
        if scale != 1.0 && scale.is_finite() && scale > 0.0 {
            planes[c] = radial(&planes[c], scale, centre);
        }
    }

    // 3. The PSF.
    match draw.psf {
        PsfDraw::Gaussian { sigma_px } if draw.psf.support_px() > 0 && sigma_px > 0.0 => {
            let weights = gaussian_weights(sigma_px);
            for p in &mut planes {
                *p = gaussian(p, &weights);
            }
        }
        PsfDraw::Disc { radius_px } if draw.psf.support_px() > 0 => {
            for p in &mut planes {
                *p = disc(p, radius_px);
            }
        }
        _ => {}
    }

    // 4. The per-pixel stages (vignetting, saturation, …), row by row.
    for stage in super::pixel_stages(draw, width, height) {
        let mut f = stage.band(win.x0, win.w());
        let w = win.w();
        let [a, b, c] = &mut planes;
        for (r, ((a, b), c)) in a
            .data
            .chunks_mut(w)
            .zip(b.data.chunks_mut(w))
            .zip(c.data.chunks_mut(w))
            .enumerate()
        {
            f(win.y0 + r as i64, [a, b, c]);
        }
    }

    // 5. The sensor grid.
    let (sw, sh) = draw.sensor_size(width, height);
    let resampled = (sw, sh) != (width, height);
    let swin = if resampled {
        let (sw, sh) = (i64::from(sw), i64::from(sh));
        let s = Win {
            x0: win.x0 * sw / wi,
            y0: win.y0 * sh / hi,
            x1: ((win.x1 * sw + wi - 1) / wi).min(sw),
            y1: ((win.y1 * sh + hi - 1) / hi).min(sh),
        };
        for p in &mut planes {
            *p = box_down(p, s, (wi, hi), (sw, sh));
        }
        s
    } else {
        win
    };

    // 6–7. Full well, noise, clipping.
    let noise_on = noisy && (draw.shot_noise_gain > 0.0 || draw.read_noise_levels > 0.0);
    if noise_on {
        sensor_noise(&mut planes, swin, u64::from(sw), draw);
    } else {
        for p in &mut planes {
            p.data.par_iter_mut().for_each(|v| *v = v.clamp(0.0, 1.0));
        }
    }

    // 5 (continued). Back to the output grid, over `out` only.
    let planes: [Plane; 3] = if resampled {
        let [a, b, c] = planes;
        [a, b, c].map(|p| bilinear_up(&p, out, (wi, hi), (i64::from(sw), i64::from(sh))))
    } else {
        planes
    };

    // 8. Encode `out`.
    encode_window(&planes, out, rgba, width)
}

/// The RGBA8 bytes of `out` from the linear planes (sRGB by the encode table),
/// alpha taken from the input frame.
fn encode_window(planes: &[Plane; 3], out: Win, rgba: &[u8], width: u32) -> Vec<u8> {
    let ow = out.w();
    let mut bytes = vec![0u8; ow * out.h() * 4];
    bytes
        .par_chunks_mut(ow * 4)
        .enumerate()
        .for_each(|(r, line)| {
            let y = out.y0 + r as i64;
            let src: [&[f32]; 3] = std::array::from_fn(|c| {
                let row = planes[c].row(y);
                let x0 = planes[c].col(out.x0);
                &row[x0..x0 + ow]
            });
            let first = (y as usize * width as usize + out.x0 as usize) * 4;
            encode_row(src, &rgba[first..first + ow * 4], line, false);
        });
    bytes
}

/// The plane magnified by `scale` about `centre` (bilinear). The map is
/// separable (x′ depends on x alone, y′ on y), so the taps of each column
/// are computed once, and each row is the two source rows interpolated
/// vertically, then horizontally.
fn radial(p: &Plane, scale: f64, centre: (f64, f64)) -> Plane {
    let inv = 1.0 / scale;
    let tap = |x: i64, c: f64| {
        let u = c + (x as f64 + 0.5 - c) * inv - 0.5;
        (u.floor() as i64, (u - u.floor()) as f32)
    };
    let cols: Vec<(usize, usize, f32)> = (p.win.x0..p.win.x1)
        .map(|x| {
            let (i, f) = tap(x, centre.0);
            (p.col(i), p.col(i + 1), f)
        })
        .collect();
    rows(p.win, |y, row| {
        let (yi, fy) = tap(y, centre.1);
        let mut mid = vec![0f32; p.win.w()];
        lerp_rows(p.row(yi), p.row(yi + 1), fy, &mut mid);
        taps_row(&mid, &cols, row);
    })
}

/// Separable convolution with `weights` (odd length), edges clamped.
fn gaussian(p: &Plane, weights: &[f32]) -> Plane {
    let r = (weights.len() / 2) as i64;
    let w = p.win.w();
    // Horizontal, through a row padded with clamped edge values.
    let across = rows(p.win, |y, row| {
        let src = p.row(y);
        let padded: Vec<f32> = (p.win.x0 - r..p.win.x1 + r)
            .map(|x| src[p.col(x)])
            .collect();
        for (k, &wk) in weights.iter().enumerate() {
            for (o, s) in row.iter_mut().zip(&padded[k..k + w]) {
                *o += wk * s;
            }
        }
    });
    // Vertical: a weighted sum of whole rows (vectorises).
    rows(p.win, |y, row| {
        for (k, &wk) in weights.iter().enumerate() {
            let src = across.row(y + k as i64 - r);
            for (o, s) in row.iter_mut().zip(src) {
                *o += wk * s;
            }
        }
    })
}

/// A uniform disc: the pixels whose centres lie within `radius_px`, summed
/// row by row from prefix sums (O(radius) per pixel), edges clamped.
fn disc(p: &Plane, radius_px: f64) -> Plane {
    let r = radius_px.floor() as i64;
    let (spans, norm) = disc_spans(radius_px);
    let w = p.win.w();
    // Per source row: prefix sums of the row padded by r clamped values.
    let prefix: Vec<Vec<f64>> = (p.win.y0..p.win.y1)
        .into_par_iter()
        .map(|y| {
            let src = p.row(y);
            let mut acc = 0.0;
            let mut out = Vec::with_capacity(w + 2 * r as usize + 1);
            out.push(0.0);
            for x in p.win.x0 - r..p.win.x1 + r {
                acc += f64::from(src[p.col(x)]);
                out.push(acc);
            }
            out
        })
        .collect();
    let row_of = |y: i64| &prefix[(y.clamp(p.win.y0, p.win.y1 - 1) - p.win.y0) as usize];
    rows(p.win, |y, row| {
        let mut sums = vec![0f64; w];
        for (k, &hw) in spans.iter().enumerate() {
            if hw < 0 {
                continue;
            }
            let pre = row_of(y + k as i64 - r);
            let (lo, hi) = ((r - hw) as usize, (r + hw + 1) as usize);
            for (i, s) in sums.iter_mut().enumerate() {
                *s += pre[i + hi] - pre[i + lo];
            }
        }
        for (o, s) in row.iter_mut().zip(sums) {
            *o = (s * norm) as f32;
        }
    })
}

/// First output pixel of sensor pixel `j` on a side of `n` output and `m` sensor pixels.
#[inline]
fn footprint_start(j: i64, n: i64, m: i64) -> i64 {
    j * n / m
}

/// Box-filter the plane (output grid) into the sensor window `s`.
fn box_down(p: &Plane, s: Win, (w, h): (i64, i64), (sw, sh): (i64, i64)) -> Plane {
    // Horizontal: sensor columns over the source's rows.
    let across = rows(
        Win {
            x0: s.x0,
            x1: s.x1,
            y0: p.win.y0,
            y1: p.win.y1,
        },
        |y, row| {
            let src = p.row(y);
            for (i, o) in row.iter_mut().enumerate() {
                let j = s.x0 + i as i64;
                let (a, b) = (footprint_start(j, w, sw), footprint_start(j + 1, w, sw));
                let sum: f32 = (a..b.max(a + 1)).map(|x| src[p.col(x)]).sum();
                *o = sum / (b.max(a + 1) - a) as f32;
            }
        },
    );
    rows(s, |j, row| {
        let (a, b) = (footprint_start(j, h, sh), footprint_start(j + 1, h, sh));
        let b = b.max(a + 1);
        for y in a..b {
            for (o, v) in row.iter_mut().zip(across.row(y)) {
                *o += v;
            }
        }
        let n = (b - a) as f32;
        for o in row.iter_mut() {
            *o /= n;
        }
    })
}

/// Bilinear from the sensor grid (`sw`×`sh`) back to output window `out`.
fn bilinear_up(p: &Plane, out: Win, (w, h): (i64, i64), (sw, sh): (i64, i64)) -> Plane {
    let tap = |x: i64, n: i64, m: i64| {
        let u = (x as f64 + 0.5) * m as f64 / n as f64 - 0.5;
        let i = u.floor();
        (i as i64, (u - i) as f32)
    };
    let cols: Vec<(usize, usize, f32)> = (out.x0..out.x1)
        .map(|x| {
            let (i, f) = tap(x, w, sw);
            (
                p.col(i.clamp(0, sw - 1)),
                p.col((i + 1).clamp(0, sw - 1)),
                f,
            )
        })
        .collect();
    rows(out, |y, row| {
        let (j, fy) = tap(y, h, sh);
        let (r0, r1) = (p.row(j.clamp(0, sh - 1)), p.row((j + 1).clamp(0, sh - 1)));
        for (o, &(c0, c1, fx)) in row.iter_mut().zip(&cols) {
            let top = r0[c0] + (r0[c1] - r0[c0]) * fx;
            let bottom = r1[c0] + (r1[c1] - r1[c0]) * fx;
            *o = top + (bottom - top) * fy;
        }
    })
}

/// Clip at the full well, add Poisson–Gaussian noise (variance in linear
/// 8-bit levels² = gain·signal + read²), clip again. Pixel indices are the
/// sensor's (row-major over a sensor `sensor_w` wide).
fn sensor_noise(planes: &mut [Plane; 3], s: Win, sensor_w: u64, draw: &CameraDraw) {
    let key = noise::Key::new(draw.noise_seed);
    let gain = draw.shot_noise_gain as f32;
    let read2 = (draw.read_noise_levels * draw.read_noise_levels) as f32;
    let w = s.w();
    let [p0, p1, p2] = planes;
    p0.data
        .par_chunks_mut(w)
        .zip(p1.data.par_chunks_mut(w))
        .zip(p2.data.par_chunks_mut(w))
        .enumerate()
        .for_each(|(r, ((a, b), c))| {
            let y = (s.y0 + r as i64) as u64;
            let first = y * sensor_w + s.x0 as u64;
            let mut devs = [vec![0f32; w], vec![0f32; w], vec![0f32; w]];
            let [d0, d1, d2] = &mut devs;
            noise::deviates(key, first, [d0, d1, d2]);
            for (vals, d) in [a, b, c].into_iter().zip(&devs) {
                noise::add(vals, d, gain, read2);
            }
        });
}

#[cfg(test)]
pub(super) mod tests {
    use super::super::{CameraDraw, PixelRect, PsfDraw, apply, apply_into, draw, sweep};
    use super::develop_planes;

    fn neutral() -> CameraDraw {
        draw(&crate::preset::camera_model::CameraModel::default(), 1, 0)
    }

    #[test]
    fn a_neutral_camera_returns_the_input() {
        let (w, h) = (37u32, 11u32);
        let rgba: Vec<u8> = (0..w * h * 4).map(|i| (i * 7 % 256) as u8).collect();
        assert_eq!(apply(&rgba, w, h, &neutral()), rgba);
    }

    /// A recycled buffer's old bytes never show: the chain written over a
    /// dirty buffer, shorter or longer than the frame, gives a new buffer's
    /// bytes for every draw (the sharpening's too).
    #[test]
    fn a_recycled_buffer_gives_a_new_ones_bytes() {
        let (w, h) = (61u32, 29u32);
        let rgba: Vec<u8> = (0..w * h * 4).map(|i| (i * 13 % 251) as u8).collect();
        let mut all = draws();
        all.push(CameraDraw {
            sharpen: 0.8,
            ..all[all.len() - 1]
        });
        for (n, d) in all.iter().enumerate() {
            let fresh = apply(&rgba, w, h, d);
            assert_eq!(fresh.len(), rgba.len(), "draw {n}");
            for len in [0, fresh.len() / 3, fresh.len(), fresh.len() * 2] {
                let mut out = vec![0xA5u8; len];
                apply_into((&rgba, w, h), d, &mut out);
                assert!(out == fresh, "draw {n}, a dirty buffer of {len} bytes");
            }
        }
    }

    /// Draws that between them switch every stage on, alone and together,
    /// at ordinary and extreme values, with and without a coarser sensor.
    pub(in super::super) fn draws() -> Vec<CameraDraw> {
        let n = neutral();
        let typical = CameraDraw {
            exposure_ev: 0.4,
            white_balance_red: 1.1,
            white_balance_blue: 0.9,
            psf: PsfDraw::Gaussian { sigma_px: 1.3 },
            vignetting: 0.4,
            ca_red_scale: 1.004,
            ca_blue_scale: 0.993,
            shot_noise_gain: 0.3,
            read_noise_levels: 2.0,
            ..n
        };
        vec![
            n,
            CameraDraw {
                exposure_ev: -0.7,
                ..n
            },
            CameraDraw {
                read_noise_levels: 3.0,
                ..n
            },
            typical,
            CameraDraw {
                psf: PsfDraw::Disc { radius_px: 3.6 },
                ..typical
            },
            CameraDraw {
                psf: PsfDraw::Disc { radius_px: 40.0 },
                ca_red_scale: 1.09,
                ..typical
            },
            CameraDraw {
                psf: PsfDraw::Gaussian { sigma_px: 30.0 },
                ca_blue_scale: 0.9,
                ..typical
            },
            CameraDraw {
                psf: PsfDraw::None,
                ..typical
            },
            CameraDraw {
                exposure_ev: 6.0,
                psf: PsfDraw::Gaussian { sigma_px: 0.2 },
                ..typical
            },
            CameraDraw {
                saturation: 1.4,
                ..typical
            },
            CameraDraw {
                saturation: 0.0,
                ..n
            },
            CameraDraw {
                sensor_scale: Some(0.8),
                ..typical
            },
            CameraDraw {
                sensor_scale: Some(0.37),
                psf: PsfDraw::Disc { radius_px: 2.5 },
                saturation: 1.3,
                ..typical
            },
            CameraDraw {
                sensor_scale: Some(0.5),
                read_noise_levels: 0.0,
                shot_noise_gain: 0.0,
                ..n
            },
        ]
    }

    /// Saturation moves each pixel away from (or towards) its grey, leaves
    /// greys alone, and 1 changes nothing.
    #[test]
    fn saturation_scales_the_distance_from_grey() {
        let (w, h) = (16u32, 8u32);
        let sky = [90u8, 140, 210, 255];
        let grey = [128u8, 128, 128, 255];
        let rgba: Vec<u8> = (0..w * h)
            .flat_map(|i| if i % 2 == 0 { sky } else { grey })
            .collect();
        let whole = PixelRect {
            x0: 0,
            y0: 0,
            x1: w,
            y1: h,
        };
        let spread = |px: &[u8]| {
            i32::from(*px.iter().take(3).max().unwrap_or(&0))
                - i32::from(*px.iter().take(3).min().unwrap_or(&0))
        };
        let at = |s: f64| {
            let d = CameraDraw {
                saturation: s,
                ..neutral()
            };
            sweep::develop(&rgba, w, h, &d, whole, false)
        };
        assert_eq!(at(1.0), rgba, "saturation 1 is the identity");
        let (more, none) = (at(1.3), at(0.0));
        assert!(spread(&more[0..4]) > spread(&sky) + 10, "{:?}", &more[0..4]);
        assert!(
            spread(&none[0..4]) <= 1,
            "saturation 0 is grey: {:?}",
            &none[0..4]
        );
        assert_eq!(&more[4..8], &grey, "a grey pixel stays grey");
    }

    /// The sweep gives the reference's bytes, noise included, on the whole
    /// frame and on windows (also ones touching the edges).
    #[test]
    fn the_sweep_equals_the_planes() {
        let (w, h) = (83u32, 157u32);
        let rgba: Vec<u8> = (0..w * h * 4)
            .map(|i| ((i * 31 + i / 7 + (i / 333) * 5) % 256) as u8)
            .collect();
        let rects = [
            PixelRect {
                x0: 0,
                y0: 0,
                x1: w,
                y1: h,
            },
            PixelRect {
                x0: 20,
                y0: 9,
                x1: 33,
                y1: 30,
            },
            PixelRect {
                x0: 70,
                y0: 140,
                x1: w,
                y1: h,
            },
            PixelRect {
                x0: 0,
                y0: 60,
                x1: 5,
                y1: 140,
            },
        ];
        for (n, d) in draws().iter().enumerate() {
            for r in rects {
                for noisy in [false, true] {
                    let fast = sweep::develop(&rgba, w, h, d, r, noisy);
                    let planes = develop_planes(&rgba, w, h, d, r, noisy);
                    assert!(fast == planes, "draw {n}, {r:?}, noisy {noisy}");
                }
            }
        }
    }
}
