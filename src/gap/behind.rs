//! What lies behind a labelled drone — sky, vegetation, ground or a building — judged
//! from the ring of pixels around its box by a few fixed rules on colour and texture
//! (no learning, no context beyond the ring). The rules, per ring pixel:
//!
//! 1. **green** — HSV hue 60–170°, saturation ≥ [`GREEN_SATURATION`], brightest channel
//!    ≥ 20 levels: vegetation (foliage, grass, fields in leaf);
//! 2. **smooth** (Sobel magnitude / 8 under [`SMOOTH_LEVELS_PER_PX`] levels per pixel)
//!    and **sky-coloured** — blue (hue 180–260°, saturation ≥ 0.08) or pale and
//!    colourless (saturation < 0.25, luminance ≥ [`PALE_SKY_LEVEL`]: overcast, haze,
//!    cloud): sky;
//! 3. smooth otherwise (dark or brown or grey and flat): ground;
//! 4. **textured** and not green: *structure*.
//!
//! The ring is a **building** when at least [`BUILDING_SHARE`] of its pixels are
//! structure and their gradients are mostly axis-aligned (at least [`AXIS_SHARE`] of
//! their gradient magnitude within 15° of horizontal or vertical, each of the two at
//! least [`EACH_AXIS_SHARE`]: walls, roofs, windows; a wall's flat parts read sky or
//! ground pixel by pixel, so the building is decided on its edges). Otherwise the
//! structure counts as vegetation (branches, bare or autumn trees, foliage in shadow)
//! and the ring's class is the one with the most pixels (ties: sky, vegetation,
//! ground). The ring is the drone statistics' ring ([`super::measure::Ring`]) less the
//! 2 px next to the box, where a drone's blur halo lies.
//!
//! Limits, stated in docs/realism.md: made for visible-light colour footage (a thermal
//! frame is grey: its smooth rings read sky when pale and ground when dark); coarse
//! non-green ground (ploughed fields, gravel, rock) reads vegetation, a flat pale road or
//! snow reads sky, heavy sensor noise (σ ≳ 6 levels) makes a sky textured, and a loose
//! box's ring may lie wholly on what is beside the drone rather than behind it.

use image::RgbImage;

use super::PixelBox;
pub use super::measure::Behind;
use super::measure::{Luma, Ring, saturation_hue};

/// A ring pixel with a Sobel magnitude / 8 under this (levels per pixel) is smooth.
pub const SMOOTH_LEVELS_PER_PX: f32 = 3.0;
/// The least HSV saturation of a green (vegetation) pixel.
pub const GREEN_SATURATION: f32 = 0.15;
/// The least luminance of a pale, colourless sky pixel (overcast, haze, cloud).
pub const PALE_SKY_LEVEL: f32 = 100.0;
/// The least share of the structure's gradient magnitude within 15° of an axis for a
/// building, and of each axis.
pub const AXIS_SHARE: f32 = 0.6;
/// The least share of a ring's pixels that are structure for a building.
pub const BUILDING_SHARE: f32 = 0.25;
pub const EACH_AXIS_SHARE: f32 = 0.15;
/// The band next to the box left out of the ring (the drone's blur halo), pixels.
const HALO_PX: i64 = 2;

/// What the ring's pixels were counted as.
#[derive(Default)]
struct Counts {
    sky: usize,
    green: usize,
    ground: usize,
    structure: usize,
    /// Gradient magnitude of the structure pixels: all, near-vertical gradient
    /// (horizontal edges), near-horizontal gradient (vertical edges).
    energy: f32,
    along_y: f32,
    along_x: f32,
}

impl Counts {
    fn add(&mut self, rgb: &RgbImage, l: &Luma, x: usize, y: usize) {
        let p = rgb.get_pixel(x as u32, y as u32);
        let c = [f32::from(p[0]), f32::from(p[1]), f32::from(p[2])];
        let (s, h) = saturation_hue(c);
        if (60.0..=170.0).contains(&h) && s >= GREEN_SATURATION && c[1] >= 20.0 {
            self.green += 1;
            return;
        }
        let (gx, gy) = sobel(l, x, y);
        let g = (gx * gx + gy * gy).sqrt();
        if g < SMOOTH_LEVELS_PER_PX {
            let blue = (180.0..=260.0).contains(&h) && s >= 0.08;
            let pale = s < 0.25 && l.at(x, y) >= PALE_SKY_LEVEL;
            if blue || pale {
                self.sky += 1;
            } else {
                self.ground += 1;
            }
            return;
        }
        self.structure += 1;
        self.energy += g;
        let tan15 = 15f32.to_radians().tan();
        let (ax, ay) = (gx.abs(), gy.abs());
        if ay <= tan15 * ax {
            self.along_x += g;
        } else if ax <= tan15 * ay {
            self.along_y += g;
        }
    }

    fn class(&self) -> Option<Behind> {
        let all = self.sky + self.green + self.ground + self.structure;
        if all == 0 {
            return None;
        }
        let e = self.energy.max(f32::MIN_POSITIVE);
        let building = self.structure as f32 >= BUILDING_SHARE * all as f32
            && (self.along_x + self.along_y) / e >= AXIS_SHARE
            && self.along_x / e >= EACH_AXIS_SHARE
            && self.along_y / e >= EACH_AXIS_SHARE;
        if building {
            return Some(Behind::Building);
        }
        let counts = [self.sky, self.green + self.structure, self.ground];
        let best = *counts.iter().max()?;
        let i = counts.iter().position(|&c| c == best)?;
        Some(Behind::ALL[i])
    }
}

/// The Sobel gradient at (x, y), divided by 8 (levels per pixel), edges clamped.
fn sobel(l: &Luma, x: usize, y: usize) -> (f32, f32) {
    let xs = [x.saturating_sub(1), x, (x + 1).min(l.width - 1)];
    let ys = [y.saturating_sub(1), y, (y + 1).min(l.height - 1)];
    let v = |i: usize, j: usize| l.at(xs[i], ys[j]);
    let gx = (v(2, 0) + 2.0 * v(2, 1) + v(2, 2)) - (v(0, 0) + 2.0 * v(0, 1) + v(0, 2));
    let gy = (v(0, 2) + 2.0 * v(1, 2) + v(2, 2)) - (v(0, 0) + 2.0 * v(1, 0) + v(2, 0));
    (gx / 8.0, gy / 8.0)
}

/// What lies behind the drone in box `b` (module docs); `None` when the ring has no pixel.
pub fn classify(rgb: &RgbImage, l: &Luma, b: PixelBox) -> Option<Behind> {
    let r = Ring::around(b, l.width, l.height)?;
    // The box grown by the halo band: its pixels are left out.
    let (hx0, hy0, hx1, hy1) = (
        r.x0 - HALO_PX,
        r.y0 - HALO_PX,
        r.x1 + HALO_PX,
        r.y1 + HALO_PX,
    );
    let mut counts = Counts::default();
    for y in r.ry0..r.ry1 {
        let in_band = y >= hy0 && y < hy1;
        for x in r.rx0..r.rx1 {
            if in_band && x >= hx0 && x < hx1 {
                continue;
            }
            counts.add(rgb, l, x as usize, y as usize);
        }
    }
    counts.class()
}
