//! Backplates on disk: a folder of JPEG/PNG still frames (and optional
//! `NAME.plate.ron` sidecars), decoded once with bounded memory and
//! resampled to the output size (scaled to cover it, centred, cropped).
//! Every problem is an error naming the file, found before anything is
//! written (the pipeline loads plates when it is built).

use std::path::{Path, PathBuf};
use std::sync::Arc;

use serde::Deserialize;

use crate::preset::backplate::{Backplate, PlateHorizon, hfov_ok, horizon_ok};

/// The largest plate file read.
pub const MAX_PLATE_FILE_BYTES: u64 = 64 << 20;
/// The largest decoded plate side; larger images are refused.
pub const MAX_PLATE_SIDE: u32 = 12_000;
/// The smallest plate side: a smaller image would be enlarged into blur.
pub const MIN_PLATE_SIDE: u32 = 64;
/// The most plates a folder may hold.
pub const MAX_PLATES: usize = 4096;
/// The most memory all plates, resampled to the output size, may take.
pub const MAX_PLATE_MEMORY_BYTES: u64 = 2 << 30;
/// The largest sidecar read.
const MAX_SIDECAR_BYTES: u64 = 64 << 10;

#[derive(Debug, thiserror::Error)]
pub enum PlateError {
    #[error("backplate {}: {reason}", file.display())]
    File { file: PathBuf, reason: String },
    #[error("backplate.folder {}: {reason}", folder.display())]
    Folder { folder: PathBuf, reason: String },
}

/// What the camera of a plate saw, as the scene needs it (no pixels).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlateGeometry {
    /// The plate's decoded size in pixels.
    pub width_px: u32,
    pub height_px: u32,
    /// Horizontal field of view of the whole plate, degrees.
    pub hfov_deg: f64,
    pub horizon: PlateHorizon,
}

/// The part of a plate that covers an output of `size`: the centred crop
/// with the output's aspect ratio, `(x0, y0, width, height)` in plate pixels.
pub fn cover_crop(plate: (u32, u32), size: (u32, u32)) -> (u32, u32, u32, u32) {
    let (pw, ph) = (u64::from(plate.0), u64::from(plate.1));
    let (w, h) = (u64::from(size.0.max(1)), u64::from(size.1.max(1)));
    // The widest crop of the output's aspect that fits the plate.
    let (cw, ch) = if pw * h >= ph * w {
        (((ph * w + h / 2) / h).clamp(1, pw), ph)
    } else {
        (pw, ((pw * h + w / 2) / w).clamp(1, ph))
    };
    (
        ((pw - cw) / 2) as u32,
        ((ph - ch) / 2) as u32,
        cw as u32,
        ch as u32,
    )
}

impl PlateGeometry {
    /// Vertical field of view (degrees) and horizon row (pixels from the
    /// top, `None` when unknown) of this plate resampled to an output of `size`.
    pub fn in_output(&self, size: (u32, u32)) -> (f64, Option<f64>) {
        let (_, y0, _, ch) = cover_crop((self.width_px, self.height_px), size);
        // Focal length of the plate in plate pixels, then in output pixels (vertical scale).
        let f_plate = f64::from(self.width_px) * 0.5 / (self.hfov_deg.to_radians() * 0.5).tan();
        let scale = f64::from(size.1) / f64::from(ch);
        let f_out = f_plate * scale;
        let fov_y_deg = 2.0 * (f64::from(size.1) * 0.5 / f_out).atan().to_degrees();
        let horizon = match self.horizon {
            PlateHorizon::Row(r) => Some((r * f64::from(self.height_px) - f64::from(y0)) * scale),
            PlateHorizon::Unknown => None,
        };
        (fov_y_deg, horizon)
    }
}

/// One loaded plate: its geometry and its pixels at the output size.
#[derive(Clone, Debug)]
pub struct Plate {
    pub file: PathBuf,
    pub geometry: PlateGeometry,
    /// The output size `rgba` was resampled to.
    pub size: (u32, u32),
    /// Tightly packed RGBA8 (sRGB, alpha 255), `size.0 × size.1`.
    pub rgba: Arc<Vec<u8>>,
    /// Mean linear colour of the upper and the lower half (the drones' ambient light).
    pub mean_upper: [f32; 3],
    pub mean_lower: [f32; 3],
}

/// Mean linear RGB of rows `rows` of an RGBA8 (sRGB) image `width` wide.
fn mean_linear(rgba: &[u8], width: u32, rows: std::ops::Range<u32>) -> [f32; 3] {
    let row = width as usize * 4;
    let px = &rgba
        [(rows.start as usize * row).min(rgba.len())..(rows.end as usize * row).min(rgba.len())];
    let table: Vec<f64> = (0..=255u8).map(super::srgb_to_linear).collect();
    let mut sum = [0f64; 3];
    for p in px.chunks_exact(4) {
        for c in 0..3 {
            sum[c] += table[usize::from(p[c])];
        }
    }
    let n = (px.len() / 4).max(1) as f64;
    sum.map(|s| (s / n) as f32)
}

impl Plate {
    /// The plate's file name (for the manifest and breakdowns).
    pub fn name(&self) -> String {
        self.file.file_name().map_or_else(
            || self.file.display().to_string(),
            |n| n.to_string_lossy().into_owned(),
        )
    }
}

/// A plate's own camera, from `NAME.plate.ron` beside it.
#[derive(Debug, Default, Deserialize)]
#[serde(default, deny_unknown_fields)]
struct Sidecar {
    hfov_deg: Option<f64>,
    horizon: Option<PlateHorizon>,
}

fn has_plate_extension(path: &Path) -> bool {
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase());
    matches!(ext.as_deref(), Some("jpg" | "jpeg" | "png"))
}

/// A plate-folder entry (a plate or a sidecar) under the rules models follow
/// (`model::uri`): a link must lead to a file inside the folder (its target
/// is never read otherwise), and what it names must be a regular file, not a
/// device, FIFO or socket. `Ok(false)` for a folder.
fn check_entry(path: &Path, real_folder: &Path) -> Result<bool, PlateError> {
    let err = |reason: String| PlateError::File {
        file: path.to_owned(),
        reason,
    };
    let own = std::fs::symlink_metadata(path).map_err(|e| err(e.to_string()))?;
    if own.file_type().is_symlink() {
        let target = path
            .canonicalize()
            .map_err(|e| err(format!("is a link that leads nowhere ({e})")))?;
        if !target.starts_with(real_folder) {
            return Err(err(format!(
                "is a link that leads out of the plate folder (to {}); only files inside backplate.folder are read",
                target.display()
            )));
        }
    }
    let meta = std::fs::metadata(path).map_err(|e| err(e.to_string()))?;
    if meta.is_dir() {
        return Ok(false);
    }
    if !meta.is_file() {
        return Err(err(format!(
            "{}, not a regular file",
            crate::input::file_kind(&meta)
        )));
    }
    Ok(true)
}

/// The plate files of `folder`, in file-name order. A plate's name must be
/// UTF-8 (it is recorded in the manifest as text); a link must stay inside
/// the folder; a FIFO, device or socket with a plate's name is refused.
pub fn plate_files(folder: &Path) -> Result<Vec<PathBuf>, PlateError> {
    let err = |reason: String| PlateError::Folder {
        folder: folder.to_owned(),
        reason,
    };
    let real_folder = folder.canonicalize().map_err(|e| err(e.to_string()))?;
    let entries = std::fs::read_dir(folder).map_err(|e| err(e.to_string()))?;
    let mut files = Vec::new();
    for entry in entries {
        let entry = entry.map_err(|e| err(e.to_string()))?;
        let path = entry.path();
        if !has_plate_extension(&path) {
            continue;
        }
        if entry.file_name().to_str().is_none() {
            return Err(PlateError::File {
                file: path,
                reason: format!(
                    "the file name {:?} is not UTF-8: plates are recorded by name in the manifest, so rename it",
                    entry.file_name()
                ),
            });
        }
        if check_entry(&path, &real_folder)? {
            files.push(path);
            if files.len() > MAX_PLATES {
                return Err(err(format!("more than {MAX_PLATES} plates")));
            }
        }
    }
    files.sort();
    if files.is_empty() {
        return Err(err("holds no .jpg, .jpeg or .png file".into()));
    }
    Ok(files)
}

/// Where the sidecar of `plate` would be: `NAME.plate.ron` beside it.
fn sidecar_path(plate: &Path) -> PathBuf {
    let stem = plate.file_stem().unwrap_or_default().to_string_lossy();
    plate.with_file_name(format!("{stem}.plate.ron"))
}

/// Feed the plates of `folder` to `hasher`: each plate's name and bytes,
/// then its sidecar's when it has one, in file-name order. Called for a
/// folder whose plates have loaded; each file is read within its bound.
pub fn hash_folder(folder: &Path, hasher: &mut blake3::Hasher) -> Result<(), PlateError> {
    for plate in plate_files(folder)? {
        let sidecar = sidecar_path(&plate);
        let mut files = vec![(plate, MAX_PLATE_FILE_BYTES)];
        if std::fs::symlink_metadata(&sidecar).is_ok() {
            files.push((sidecar, MAX_SIDECAR_BYTES));
        }
        for (file, max) in files {
            let name = file.file_name().unwrap_or_default().as_encoded_bytes();
            hasher.update(&(name.len() as u64).to_le_bytes());
            hasher.update(name);
            let len = crate::input::hash_input_file(&file, max, hasher).map_err(|e| {
                PlateError::File {
                    file: file.clone(),
                    reason: e.to_string(),
                }
            })?;
            hasher.update(&len.to_le_bytes());
        }
    }
    Ok(())
}

/// The sidecar of `plate`, if there is one: checked like a plate
/// ([`check_entry`]) before it is opened, so a link to a file elsewhere is
/// refused without reading (or quoting) that file.
fn read_sidecar(plate: &Path, real_folder: &Path) -> Result<Sidecar, PlateError> {
    let path = sidecar_path(plate);
    let err = |reason: String| PlateError::File {
        file: path.clone(),
        reason,
    };
    match std::fs::symlink_metadata(&path) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Sidecar::default()),
        Err(e) => return Err(err(e.to_string())),
        Ok(_) => {}
    }
    if !check_entry(&path, real_folder)? {
        return Err(err("a folder, not a regular file".into()));
    }
    let bytes =
        crate::input::read_input_file(&path, MAX_SIDECAR_BYTES).map_err(|e| err(e.to_string()))?;
    let text = String::from_utf8(bytes).map_err(|_| err("is not UTF-8 text".into()))?;
    let sidecar: Sidecar = ron::Options::default()
        .with_default_extension(ron::extensions::Extensions::IMPLICIT_SOME)
        .from_str(&text)
        .map_err(|e| err(e.to_string()))?;
    if let Some(h) = sidecar.hfov_deg
        && !hfov_ok(h)
    {
        return Err(err(format!(
            "hfov_deg {h} must be degrees within [1, {}]",
            crate::preset::backplate::MAX_PLATE_HFOV_DEG
        )));
    }
    if let Some(h) = sidecar.horizon
        && !horizon_ok(h)
    {
        return Err(err(format!("horizon {h:?} must be within [-10, 10]")));
    }
    Ok(sidecar)
}

/// Decode one plate into RGBA8 within the size limits: at most
/// [`MAX_PLATE_SIDE`] a side and [`crate::input::MAX_IMAGE_PIXELS`] in all,
/// read from the header before decoding; a truncated JPEG is refused.
fn decode(file: &Path) -> Result<image::RgbaImage, PlateError> {
    let err = |reason: String| PlateError::File {
        file: file.to_owned(),
        reason,
    };
    let bytes = crate::input::read_input_file(file, MAX_PLATE_FILE_BYTES)
        .map_err(|e| err(e.to_string()))?;
    let image = crate::input::decode_image(&bytes, crate::input::MAX_IMAGE_PIXELS, MAX_PLATE_SIDE)
        .map_err(|e| err(e.to_string()))?;
    let (w, h) = (image.width(), image.height());
    if w.min(h) < MIN_PLATE_SIDE {
        return Err(err(format!(
            "{w}×{h} is smaller than the {MIN_PLATE_SIDE}-pixel side a plate needs"
        )));
    }
    Ok(image.to_rgba8())
}

/// Resample `image` to cover `size`: the centred crop of the output's aspect, scaled.
pub fn resample_cover(image: &image::RgbaImage, size: (u32, u32)) -> Vec<u8> {
    let (x0, y0, cw, ch) = cover_crop(image.dimensions(), size);
    let crop = image::imageops::crop_imm(image, x0, y0, cw, ch).to_image();
    let mut out = if (cw, ch) == size {
        crop
    } else {
        image::imageops::resize(
            &crop,
            size.0,
            size.1,
            image::imageops::FilterType::CatmullRom,
        )
    };
    // Plates are opaque backgrounds.
    for p in out.pixels_mut() {
        p.0[3] = 255;
    }
    out.into_raw()
}

/// Load every plate of `backplate.folder`, resampled to `size` (the output).
pub fn load_plates(backplate: &Backplate, size: (u32, u32)) -> Result<Vec<Plate>, PlateError> {
    let files = plate_files(&backplate.folder)?;
    let real_folder = backplate
        .folder
        .canonicalize()
        .map_err(|e| PlateError::Folder {
            folder: backplate.folder.clone(),
            reason: e.to_string(),
        })?;
    let per_plate = u64::from(size.0) * u64::from(size.1) * 4;
    let total = per_plate * files.len() as u64;
    if total > MAX_PLATE_MEMORY_BYTES {
        return Err(PlateError::Folder {
            folder: backplate.folder.clone(),
            reason: format!(
                "{} plates at {}×{} would take {} MiB, over the {} MiB limit: use fewer plates or a smaller render.resolution",
                files.len(),
                size.0,
                size.1,
                total >> 20,
                MAX_PLATE_MEMORY_BYTES >> 20
            ),
        });
    }
    files
        .into_iter()
        .map(|file| {
            let sidecar = read_sidecar(&file, &real_folder)?;
            let image = decode(&file)?;
            let geometry = PlateGeometry {
                width_px: image.width(),
                height_px: image.height(),
                hfov_deg: sidecar.hfov_deg.unwrap_or(backplate.hfov_deg),
                horizon: sidecar.horizon.unwrap_or(backplate.horizon),
            };
            let rgba = resample_cover(&image, size);
            let (mean_upper, mean_lower) = (
                mean_linear(&rgba, size.0, 0..size.1 / 2),
                mean_linear(&rgba, size.0, size.1 / 2..size.1),
            );
            Ok(Plate {
                file,
                geometry,
                size,
                rgba: Arc::new(rgba),
                mean_upper,
                mean_lower,
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_cover_crop_keeps_the_output_aspect_and_centres() {
        // A 4:3 plate for a 16:9 output loses rows, top and bottom alike.
        assert_eq!(cover_crop((1600, 1200), (1920, 1080)), (0, 150, 1600, 900));
        // A wide plate for a 4:3 output loses columns.
        assert_eq!(cover_crop((2000, 600), (800, 600)), (600, 0, 800, 600));
        assert_eq!(cover_crop((640, 360), (1920, 1080)), (0, 0, 640, 360));
    }

    #[test]
    fn the_output_geometry_follows_the_crop_and_scale() {
        let g = PlateGeometry {
            width_px: 1600,
            height_px: 1200,
            hfov_deg: 90.0,
            horizon: PlateHorizon::Row(0.75),
        };
        let (fov_y, horizon) = g.in_output((1920, 1080));
        // f = 800 plate px; the crop is 900 rows → 1080: scale 1.2, f_out = 960.
        let want = 2.0 * (540.0f64 / 960.0).atan().to_degrees();
        assert!((fov_y - want).abs() < 1e-9, "{fov_y} {want}");
        // Row 900 of the plate, 150 cropped above: (900 − 150)·1.2 = 900.
        assert!((horizon.expect("a row") - 900.0).abs() < 1e-9);
    }
}
