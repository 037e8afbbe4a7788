//! The report's histogram PNGs: one statistic's real (blue) and synthetic (orange) values
//! over shared bins, each side normalised to its own count, drawn with plotters.

use super::table::{fmt, percentile};

/// Real (blue) and synthetic (orange) histograms over shared bins, each normalised to its
/// own count, encoded as PNG.
pub(super) fn histogram_png(
    title: &str,
    unit: &str,
    real: &[f64],
    synthetic: &[f64],
) -> Result<Vec<u8>, Box<dyn std::error::Error>> {
    use plotters::prelude::*;
    const BINS: usize = 24;
    let (w, h) = (900u32, 500u32);
    // The 2nd–98th percentile of both sides together, so a few outliers do not squash the
    // rest; values beyond fall into the end bins.
    let mut all: Vec<f64> = real.iter().chain(synthetic.iter()).copied().collect();
    all.sort_by(f64::total_cmp);
    let lo = percentile(&all, 0.02);
    let mut hi = percentile(&all, 0.98);
    if hi <= lo {
        hi = lo + 1.0;
    }
    let bin = |v: f64| (((v - lo) / (hi - lo) * BINS as f64).max(0.0) as usize).min(BINS - 1);
    let hist = |v: &[f64]| {
        let mut c = [0f64; BINS];
        for &x in v {
            c[bin(x)] += 1.0;
        }
        let n = v.len().max(1) as f64;
        c.map(|x| x / n)
    };
    let (hr, hs) = (hist(real), hist(synthetic));
    let top = hr
        .iter()
        .chain(hs.iter())
        .copied()
        .fold(0.0, f64::max)
        .max(1e-9);
    let mut buf = vec![255u8; (w * h * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        root.fill(&WHITE)?;
        let (left, right, ptop, bottom) = (70i32, w as i32 - 20, 50i32, h as i32 - 50);
        let bw = f64::from(right - left) / BINS as f64;
        let orange = RGBColor(230, 120, 20);
        for (k, (counts, color, shift)) in [(&hr, BLUE, 0.0), (&hs, orange, 0.5)].iter().enumerate()
        {
            let _ = k;
            for (i, &c) in counts.iter().enumerate() {
                if c <= 0.0 {
                    continue;
                }
                let x0 = left + ((i as f64 + shift) * bw) as i32;
                let x1 = (left + ((i as f64 + shift + 0.5) * bw) as i32 - 1).max(x0);
                let y = bottom - (c / top * f64::from(bottom - ptop)) as i32;
                root.draw(&Rectangle::new(
                    [(x0, y), (x1, bottom)],
                    color.mix(0.8).filled(),
                ))?;
            }
        }
        root.draw(&PathElement::new(
            vec![(left, ptop), (left, bottom), (right, bottom)],
            BLACK,
        ))?;
        if crate::write::stats::font() {
            let style = ("sans-serif", 16).into_font();
            root.draw(&Text::new(
                title.to_owned(),
                (left, 12),
                ("sans-serif", 20).into_font(),
            ))?;
            root.draw(&Text::new(
                format!("real (n={})", real.len()),
                (right - 260, 40),
                style.clone().color(&BLUE),
            ))?;
            root.draw(&Text::new(
                format!("synthetic (n={})", synthetic.len()),
                (right - 130, 40),
                style.clone().color(&orange),
            ))?;
            root.draw(&Text::new(
                format!("{} {unit}", fmt(lo)),
                (left, bottom + 10),
                style.clone(),
            ))?;
            root.draw(&Text::new(
                format!("{} {unit}", fmt(hi)),
                (right - 110, bottom + 10),
                style.clone(),
            ))?;
            root.draw(&Text::new(
                format!("{:.0} %", top * 100.0),
                (5, ptop),
                style,
            ))?;
        }
        root.present()?;
    }
    let img = image::RgbImage::from_raw(w, h, buf).ok_or("plot buffer size")?;
    let mut png = Vec::new();
    img.write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)?;
    Ok(png)
}
