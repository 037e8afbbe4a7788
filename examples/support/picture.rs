//! The stage benches' picture (`camera_bench`, `lens_bench`,
//! `rolling_bench`): a sky gradient with some structure, RGBA8 (the
//! stages' cost does not depend on content).

/// A `w`×`h` RGBA8 picture: rows brightening downwards, columns in bands.
pub fn sky(w: u32, h: u32) -> Vec<u8> {
    (0..w * h)
        .flat_map(|i| {
            let (x, y) = (i % w, i / w);
            [
                (90 + y / 12) as u8,
                (130 + y / 10) as u8,
                (200 + (x / 40) % 40) as u8,
                255,
            ]
        })
        .collect()
}
