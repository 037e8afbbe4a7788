//! The statistics drawn: histograms of training boxes per image, box size
//! and distance from the camera, as PNGs written into a report folder.

use super::{DISTANCE_BIN_M, DatasetStats, SIZE_BIN_PX, StatsError};
use crate::write::OutputError;
use crate::write::folder::outdir::OutDir;
use crate::write::folder::tree::Tree;

/// The histograms' folder inside the dataset when `--plots` is not given.
pub const DEFAULT_PLOTS: &str = "stats-plots";

/// Refuse a histogram folder `plots` that exists and is not a folder, or
/// that is, or lies inside, one of the `dataset`'s
/// [`crate::write::DATA_FOLDERS`] (compared canonically, `plots` as far as
/// it exists): its PNGs would be read as frames.
pub fn check_plots_dir(
    dataset: &std::path::Path,
    plots: &std::path::Path,
) -> Result<(), StatsError> {
    if std::fs::metadata(plots).is_ok_and(|m| !m.is_dir()) {
        return Err(StatsError::PlotsNotAFolder {
            plots: plots.to_owned(),
        });
    }
    let (Ok(dataset), Ok(real)) = (
        dataset.canonicalize(),
        crate::input::canonical_as_far_as_it_exists(plots),
    ) else {
        return Ok(());
    };
    let first = real
        .strip_prefix(&dataset)
        .ok()
        .and_then(|rel| rel.iter().next());
    match crate::write::DATA_FOLDERS
        .iter()
        .find(|f| first.is_some_and(|c| c == **f))
    {
        Some(folder) => Err(StatsError::PlotsInside {
            plots: plots.to_owned(),
            folder,
        }),
        None => Ok(()),
    }
}

/// The folder the histograms go into, opened once: `plots` as the user
/// named it (created when missing), or by default `stats-plots` made and
/// opened below the dataset's handle without following a link (a link put
/// there, e.g. in a dataset someone else packed, would send the PNGs to
/// wherever it points).
pub fn open_plots_dir(
    dataset: &std::path::Path,
    plots: Option<&std::path::Path>,
) -> Result<OutDir, StatsError> {
    if let Some(plots) = plots {
        return Ok(OutDir::create(plots)?);
    }
    let mut tree = Tree::open(dataset)?;
    tree.mkdir(DEFAULT_PLOTS)?;
    let fd = (tree.open_dir(DEFAULT_PLOTS)?).ok_or_else(|| OutputError::Refused {
        path: dataset.join(DEFAULT_PLOTS),
        reason: "was removed while swarmshot made it".into(),
    })?;
    Ok(OutDir::from_tree(Tree::from_fd(
        dataset.join(DEFAULT_PLOTS),
        fd,
    )))
}

/// Draw the three histograms (training boxes per image, box size √(w·h),
/// distance from the camera) as PNGs into `out`; returns their paths. Text
/// needs the DejaVu Sans font (Debian: fonts-dejavu-core); without it the
/// bars are drawn unlabelled.
pub fn write_histograms(
    stats: &DatasetStats,
    out: &mut OutDir,
) -> Result<Vec<std::path::PathBuf>, StatsError> {
    let per_frame: Vec<u64> = {
        let max = stats
            .boxes_per_frame
            .keys()
            .next_back()
            .copied()
            .unwrap_or(0) as usize;
        let mut v = vec![0; max + 1];
        for (&k, &n) in &stats.boxes_per_frame {
            v[k as usize] = n;
        }
        v
    };
    // Up to the last bin with a count (the first bin of an all-zero
    // histogram; none of an empty one, a dataset of no frames).
    let trim = |v: &[u64]| {
        let end = v
            .iter()
            .rposition(|&n| n > 0)
            .map_or(v.len().min(1), |i| i + 1);
        v[..end].to_vec()
    };
    let plots = [
        (
            "boxes_per_image.png",
            "training boxes per image",
            per_frame,
            1.0,
            "boxes",
        ),
        (
            "box_size.png",
            "box size sqrt(w*h); small < 32 px < medium < 96 px < large",
            trim(&stats.size_histogram),
            SIZE_BIN_PX,
            "px",
        ),
        (
            "distance.png",
            "distance from the camera",
            trim(&stats.distance_histogram),
            DISTANCE_BIN_M,
            "m",
        ),
    ];
    let font = font();
    let mut written = Vec::new();
    for (file, title, counts, width, unit) in plots {
        let png =
            draw_histogram(title, &counts, width, unit, font).map_err(|e| StatsError::Io {
                path: out.path().join(file),
                source: std::io::Error::other(e.to_string()),
            })?;
        written.push(out.write(file, &png)?);
    }
    Ok(written)
}

/// DejaVu Sans registered with plotters once, if the system has it (also `gap`'s histograms).
pub(crate) fn font() -> bool {
    static FONT: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    *FONT.get_or_init(|| {
        let Some(bytes) = [
            "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf",
            "/usr/share/fonts/TTF/DejaVuSans.ttf",
        ]
        .iter()
        .find_map(|p| std::fs::read(p).ok()) else {
            return false;
        };
        let bytes: &'static [u8] = Box::leak(bytes.into_boxed_slice());
        plotters::style::register_font("sans-serif", plotters::style::FontStyle::Normal, bytes)
            .is_ok()
    })
}

/// A histogram drawn as PNG bytes (written by the caller through [`crate::write::folder::outdir::OutDir`]).
fn draw_histogram(
    title: &str,
    counts: &[u64],
    bin_width: f64,
    unit: &str,
    font: bool,
) -> Result<Vec<u8>, Box<dyn std::error::Error>> {
    use plotters::prelude::*;
    let (w, h) = (900i32, 500i32);
    let mut rgb = vec![0u8; (w * h * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut rgb, (w as u32, h as u32)).into_drawing_area();
        root.fill(&WHITE)?;
        let (left, right, top, bottom) = (70, w - 20, 50, h - 50);
        let max = counts.iter().copied().max().unwrap_or(0).max(1) as f64;
        let n = counts.len().max(1) as f64;
        let bar = f64::from(right - left) / n;
        for (i, &c) in counts.iter().enumerate() {
            let x0 = left + (i as f64 * bar) as i32;
            let x1 = (left + ((i + 1) as f64 * bar) as i32 - 1).max(x0);
            let y = bottom - (c as f64 / max * f64::from(bottom - top)) as i32;
            root.draw(&Rectangle::new(
                [(x0, y), (x1, bottom)],
                BLUE.mix(0.7).filled(),
            ))?;
        }
        root.draw(&PathElement::new(
            vec![(left, top), (left, bottom), (right, bottom)],
            BLACK,
        ))?;
        if font {
            let style = ("sans-serif", 16).into_font();
            root.draw(&Text::new(
                title.to_owned(),
                (left, 15),
                ("sans-serif", 20).into_font(),
            ))?;
            root.draw(&Text::new(
                format!("{}", max as u64),
                (5, top),
                style.clone(),
            ))?;
            root.draw(&Text::new("0".to_owned(), (50, bottom - 8), style.clone()))?;
            let last = n * bin_width;
            root.draw(&Text::new(
                format!("0 {unit}"),
                (left, bottom + 10),
                style.clone(),
            ))?;
            root.draw(&Text::new(
                format!("{last} {unit}"),
                (right - 90, bottom + 10),
                style,
            ))?;
        }
        root.present()?;
    }
    let img = image::RgbImage::from_raw(w as u32, h as u32, rgb).ok_or("histogram buffer size")?;
    let mut png = Vec::new();
    img.write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)?;
    Ok(png)
}
