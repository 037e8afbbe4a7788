//! The footage's own sky as the noise estimate's test picture ([`super::camera`]).
//!
//! What JPEG leaves of a noise depends on the signal under it: a block whose coefficients
//! are all near zero loses the noise's small ones to the quantiser's dead zone, one with
//! a gradient keeps more. So the read noise is inverted on a picture with the footage's
//! gradients, not on one flat colour: [`SKY_TILES`]² flat 16 px tiles of the footage's
//! upper half ([`sample`]: evenly spaced over the frames, in order), each replaced by its
//! least-squares plane per channel (the sky the noise lay on, as near as the tile itself
//! tells) and rounded to 8 bits, in a mosaic on the 16 px grid so that no JPEG block
//! (8 px) or chroma MCU (16 px) straddles two tiles ([`NoisePicture::of`]). The same
//! tiles as the footage has them, in the same mosaic, give the σ the inversion aims at
//! ([`footage_sigma`]): the forward path and the footage are measured on the same tiles.

use image::RgbImage;

use crate::gap::measure::{self, Luma, TILE_PX};

/// Tiles per side of the test picture: 24 × 16 px = 384 px.
pub const SKY_TILES: usize = 24;

/// Pixels of a tile side.
const T: usize = TILE_PX;

/// One flat sky tile of the footage: its RGB pixels, row by row.
#[derive(Clone, Debug, PartialEq)]
pub struct SkyTile(Vec<u8>);

/// The test picture the noise is inverted on (RGBA, `side`² px).
#[derive(Clone, Debug, PartialEq)]
pub struct NoisePicture {
    pub side: u32,
    pub rgba: Vec<u8>,
}

/// Index `k` of `m` evenly spaced over `n` items, in order (repeating when `m > n`).
fn spread(k: usize, m: usize, n: usize) -> usize {
    k * n / m
}

/// At most `cap` of the tiles at `origins` (top-left corners) in `rgb`, evenly spaced.
pub fn sample(rgb: &RgbImage, origins: &[(u32, u32)], cap: usize) -> Vec<SkyTile> {
    let m = origins.len().min(cap);
    (0..m)
        .map(|k| {
            let (x0, y0) = origins[spread(k, m, origins.len())];
            let mut px = Vec::with_capacity(T * T * 3);
            for y in 0..T as u32 {
                for x in 0..T as u32 {
                    px.extend_from_slice(&rgb.get_pixel(x0 + x, y0 + y).0);
                }
            }
            SkyTile(px)
        })
        .collect()
}

impl SkyTile {
    /// Per channel `[mean, slope across, slope down]` (levels, levels per px), by least
    /// squares over the tile's pixels.
    fn planes(&self) -> [[f32; 3]; 3] {
        let c0 = (T as f64 - 1.0) / 2.0;
        // Σ (x − c0)² over the tile's pixels.
        let sxx = (T * T * (T * T - 1)) as f64 / 12.0;
        let mut acc = [[0f64; 3]; 3];
        for (i, p) in self.0.chunks_exact(3).enumerate() {
            let (u, v) = ((i % T) as f64 - c0, (i / T) as f64 - c0);
            for (a, &val) in acc.iter_mut().zip(p) {
                let val = f64::from(val);
                a[0] += val;
                a[1] += u * val;
                a[2] += v * val;
            }
        }
        let area = (T * T) as f64;
        acc.map(|a| {
            [
                (a[0] / area) as f32,
                (a[1] / sxx) as f32,
                (a[2] / sxx) as f32,
            ]
        })
    }
}

/// [`SKY_TILES`]² of `n` tiles (evenly spaced, repeated when fewer) in a mosaic on the
/// 16 px grid, RGBA: pixel (x, y) of tile `j` is `draw(j, x, y)`.
fn mosaic(n: usize, draw: impl Fn(usize, usize, usize) -> [u8; 3]) -> Vec<u8> {
    let side = SKY_TILES * T;
    let mut rgba = vec![255u8; side * side * 4];
    let m = SKY_TILES * SKY_TILES;
    for k in 0..m {
        let j = spread(k, m, n);
        let (x0, y0) = ((k % SKY_TILES) * T, (k / SKY_TILES) * T);
        for y in 0..T {
            for x in 0..T {
                let i = ((y0 + y) * side + x0 + x) * 4;
                rgba[i..i + 3].copy_from_slice(&draw(j, x, y));
            }
        }
    }
    rgba
}

impl NoisePicture {
    /// The tiles' planes in the mosaic (module docs); `None` when there are no tiles.
    pub fn of(tiles: &[SkyTile]) -> Option<Self> {
        if tiles.is_empty() {
            return None;
        }
        let planes: Vec<[[f32; 3]; 3]> = tiles.iter().map(SkyTile::planes).collect();
        let c0 = (T as f32 - 1.0) / 2.0;
        let rgba = mosaic(tiles.len(), |j, x, y| {
            let (u, v) = (x as f32 - c0, y as f32 - c0);
            planes[j].map(|[mean, across, down]| {
                (mean + across * u + down * v).round().clamp(0.0, 255.0) as u8
            })
        });
        Some(Self {
            side: (SKY_TILES * T) as u32,
            rgba,
        })
    }

    /// `sky` with a gentle gradient (0.04 levels/px down, 0.02 across), `side`² px: for
    /// footage without flat sky tiles in its upper half.
    pub fn gradient(sky: [u8; 3], side: u32) -> Self {
        let mut rgba = Vec::with_capacity((side * side * 4) as usize);
        for y in 0..side {
            for x in 0..side {
                let d = 0.04 * (f64::from(y) - f64::from(side) / 2.0)
                    + 0.02 * (f64::from(x) - f64::from(side) / 2.0);
                let c = sky.map(|c| (f64::from(c) + d).round().clamp(0.0, 255.0) as u8);
                rgba.extend_from_slice(&[c[0], c[1], c[2], 255]);
            }
        }
        Self { side, rgba }
    }
}

/// The flat-sky noise σ of `tiles` as the footage has them, in the test picture's
/// mosaic; `None` when there are no tiles.
pub fn footage_sigma(tiles: &[SkyTile]) -> Option<f64> {
    if tiles.is_empty() {
        return None;
    }
    let rgba = mosaic(tiles.len(), |j, x, y| {
        let i = (y * T + x) * 3;
        let px = &tiles[j].0;
        [px[i], px[i + 1], px[i + 2]]
    });
    let side = (SKY_TILES * T) as u32;
    let rgb: Vec<u8> = rgba
        .chunks_exact(4)
        .flat_map(|p| [p[0], p[1], p[2]])
        .collect();
    let img = RgbImage::from_raw(side, side, rgb)?;
    measure::flat_sky(&img, &Luma::from_rgb(&img), &[])
        .noise_sigma
        .map(f64::from)
}
