//! The report's contact sheet (`contact_sheet.png`): up to [`SHEET_FRAMES`] real frames
//! on the left half and as many synthetic frames on the right, as thumbnails, so the two
//! can be told apart (or not) by eye at thumbnail size.
//!
//! The frames are chosen evenly over each side's measured frames in name order
//! ([`picks`]: frame `i · n / k` for `i` in `0..k`), so the sheet is the same on every
//! run. Each thumbnail is its frame scaled (Triangle filter) to fit a [`THUMB_W`] ×
//! [`THUMB_H`] cell with its aspect kept, centred on dark grey ([`thumbnail`]); cells
//! fill [`SHEET_COLS`] columns per side, row by row, below a [`HEADER_PX`] band that
//! names each half (a blue bar over the real half, an orange one over the synthetic
//! half, and their folders in text when the system has DejaVu Sans). The sheet's size
//! is fixed: `2 · SHEET_COLS · THUMB_W` by `HEADER_PX + rows · THUMB_H`.

use image::{Rgb, RgbImage};

/// Frames per side on the sheet (fewer when a side has fewer).
pub const SHEET_FRAMES: usize = 8;
/// One thumbnail cell, pixels.
pub const THUMB_W: u32 = 240;
pub const THUMB_H: u32 = 180;
/// Thumbnail columns per side.
pub const SHEET_COLS: u32 = 2;
/// The band above the thumbnails that names the halves.
pub const HEADER_PX: u32 = 28;
/// The empty part of a cell.
const EMPTY: Rgb<u8> = Rgb([32, 32, 32]);
const REAL_COLOUR: Rgb<u8> = Rgb([40, 90, 220]);
const SYNTHETIC_COLOUR: Rgb<u8> = Rgb([230, 120, 20]);

/// The indices of the frames a side of `n` shows.
pub fn picks(n: usize) -> Vec<usize> {
    let k = n.min(SHEET_FRAMES);
    (0..k).map(|i| i * n / k).collect()
}

/// `rgb` scaled to fit a [`THUMB_W`] × [`THUMB_H`] cell, aspect kept, centred on dark grey.
pub fn thumbnail(rgb: &RgbImage) -> RgbImage {
    let (w, h) = (
        u64::from(rgb.width().max(1)),
        u64::from(rgb.height().max(1)),
    );
    let (cw, ch) = (u64::from(THUMB_W), u64::from(THUMB_H));
    let (tw, th) = if w * ch >= h * cw {
        (cw, ((h * cw + w / 2) / w).clamp(1, ch))
    } else {
        (((w * ch + h / 2) / h).clamp(1, cw), ch)
    };
    let small = image::imageops::resize(
        rgb,
        tw as u32,
        th as u32,
        image::imageops::FilterType::Triangle,
    );
    let mut cell = RgbImage::from_pixel(THUMB_W, THUMB_H, EMPTY);
    image::imageops::replace(
        &mut cell,
        &small,
        ((cw - tw) / 2) as i64,
        ((ch - th) / 2) as i64,
    );
    cell
}

/// Rows of cells per side.
fn rows() -> u32 {
    (SHEET_FRAMES as u32).div_ceil(SHEET_COLS)
}

/// The sheet's size in pixels.
pub fn sheet_size() -> (u32, u32) {
    (2 * SHEET_COLS * THUMB_W, HEADER_PX + rows() * THUMB_H)
}

/// Top-left corner of cell `i` of a side (`synthetic`: the right half).
pub fn cell_origin(synthetic: bool, i: usize) -> (u32, u32) {
    let half = if synthetic { SHEET_COLS * THUMB_W } else { 0 };
    let (col, row) = (i as u32 % SHEET_COLS, i as u32 / SHEET_COLS);
    (half + col * THUMB_W, HEADER_PX + row * THUMB_H)
}

/// The sheet: `real` thumbnails left, `synthetic` right (at most [`SHEET_FRAMES`] each,
/// as [`thumbnail`] made them), the header naming each half with its `labels`.
pub fn contact_sheet(
    real: &[RgbImage],
    synthetic: &[RgbImage],
    labels: [&str; 2],
) -> Result<RgbImage, Box<dyn std::error::Error>> {
    let (w, h) = sheet_size();
    let mut sheet = RgbImage::from_pixel(w, h, EMPTY);
    header(&mut sheet, labels)?;
    for (synthetic, thumbs) in [(false, real), (true, synthetic)] {
        for (i, t) in thumbs.iter().take(SHEET_FRAMES).enumerate() {
            let (x, y) = cell_origin(synthetic, i);
            image::imageops::replace(&mut sheet, t, i64::from(x), i64::from(y));
        }
    }
    Ok(sheet)
}

/// The header band: a coloured bar under each half's name.
fn header(sheet: &mut RgbImage, labels: [&str; 2]) -> Result<(), Box<dyn std::error::Error>> {
    use plotters::prelude::*;
    let (w, half) = (sheet.width(), SHEET_COLS * THUMB_W);
    for y in HEADER_PX - 4..HEADER_PX {
        for x in 0..w {
            let c = if x < half {
                REAL_COLOUR
            } else {
                SYNTHETIC_COLOUR
            };
            sheet.put_pixel(x, y, c);
        }
    }
    if !crate::write::stats::font() {
        return Ok(());
    }
    let mut band = vec![32u8; (w * HEADER_PX * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut band, (w, HEADER_PX)).into_drawing_area();
        let style = ("sans-serif", 16).into_font().color(&WHITE);
        for (k, text) in labels.iter().enumerate() {
            let x = 8 + k as i32 * half as i32;
            root.draw(&Text::new(text.to_string(), (x, 4), style.clone()))?;
        }
        root.present()?;
    }
    for y in 0..HEADER_PX - 4 {
        for x in 0..w {
            let i = ((y * w + x) * 3) as usize;
            sheet.put_pixel(x, y, Rgb([band[i], band[i + 1], band[i + 2]]));
        }
    }
    Ok(())
}

/// The sheet as PNG bytes.
pub fn png(sheet: &RgbImage) -> Result<Vec<u8>, Box<dyn std::error::Error>> {
    let mut out = Vec::new();
    sheet.write_to(&mut std::io::Cursor::new(&mut out), image::ImageFormat::Png)?;
    Ok(out)
}
