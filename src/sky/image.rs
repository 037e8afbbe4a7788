//! Image skies: equirectangular files or six cubemap faces, decoded into
//! linear RGB f32 (negative and non-finite values clamped), and their lighting.

use std::path::{Path, PathBuf};

use glam::Vec3;

use super::{Lighting, tone_map};
use crate::preset::{Sky, SkyImageSource};
use crate::simd::math::smoothstep;

#[derive(Debug, thiserror::Error)]
pub enum EnvironmentError {
    #[error("sky image {}: {reason}", file.display())]
    Image { file: PathBuf, reason: String },
    #[error("sky cubemap: face {face} ({}) is {got_w}×{got_h}, but faces must be square and all {want}×{want}", file.display())]
    CubemapFace {
        face: &'static str,
        file: PathBuf,
        got_w: u32,
        got_h: u32,
        want: u32,
    },
    #[error("sky: the preset's {images} sky images take {} MiB once loaded (linear RGB floats, at most {MAX_SKY_SIDE} px on a side), more than the {} MiB sky images may hold; name fewer or smaller images", .bytes >> 20, MAX_SKY_MEMORY_BYTES >> 20)]
    Memory { images: usize, bytes: u64 },
}

/// The largest sky image file read.
pub const MAX_SKY_FILE_BYTES: u64 = 1 << 30;

/// Largest side of an uploaded sky image; larger images are downscaled on load.
pub const MAX_SKY_SIDE: u32 = 4096;

/// The most pixels a sky image (or cubemap face) may have, read from its
/// header before it is decoded: the limit of every image a user names
/// ([`crate::input::MAX_IMAGE_PIXELS`]; an 8K equirectangular image has 34 M).
/// Decoding one at the limit holds at most about 2 GB at once.
pub const MAX_SKY_PIXELS: u64 = crate::input::MAX_IMAGE_PIXELS;

/// The most memory a preset's sky images may hold once loaded (linear RGB
/// f32, each at most [`MAX_SKY_SIDE`] on a side: 96 MiB for a 4096 × 2048
/// image), summed from their headers before any is decoded.
pub const MAX_SKY_MEMORY_BYTES: u64 = 2 << 30;

/// A decoded sky image: linear RGB, negative and non-finite values clamped to 0.
#[derive(Clone, Debug)]
pub struct SkyImage {
    pub source: SkyImageSource,
    pub kind: SkyImageKind,
    /// Radiance values (HDR/EXR: tone mapped) or display values (PNG/JPEG: shown as they are).
    pub hdr: bool,
    /// Mean colour of the upper and lower hemisphere (for the ambient term) and of the brightest spot.
    pub mean_upper: [f32; 3],
    pub mean_lower: [f32; 3],
    pub brightest: [f32; 3],
}

#[derive(Clone, Debug)]
pub enum SkyImageKind {
    /// Row-major RGB f32, top row first.
    Equirect {
        width: u32,
        height: u32,
        rgb: Vec<f32>,
    },
    /// Six square faces (+X, −X, +Y, −Y, +Z, −Z), each side × side RGB f32.
    Cubemap { side: u32, faces: Vec<Vec<f32>> },
}

fn decode_rgb32f(file: &Path) -> Result<(u32, u32, Vec<f32>, bool), EnvironmentError> {
    let err = |reason: String| EnvironmentError::Image {
        file: file.to_owned(),
        reason,
    };
    // A regular file of bounded size only: a FIFO or /dev/zero is refused unopened.
    let bytes =
        crate::input::read_input_file(file, MAX_SKY_FILE_BYTES).map_err(|e| err(e.to_string()))?;
    decode_bytes(bytes, file)
}

/// Feed the bytes of the sky image `file` to `hasher`, read within the
/// loader's bound.
pub fn hash_sky_image(file: &Path, hasher: &mut blake3::Hasher) -> Result<(), EnvironmentError> {
    crate::input::hash_input_file(file, MAX_SKY_FILE_BYTES, hasher)
        .map(|_| ())
        .map_err(|e| EnvironmentError::Image {
            file: file.to_owned(),
            reason: e.to_string(),
        })
}

/// Decode an image's bytes (`file` names it in errors and hints its format).
fn decode_bytes(
    bytes: Vec<u8>,
    file: &Path,
) -> Result<(u32, u32, Vec<f32>, bool), EnvironmentError> {
    let err = |reason: String| EnvironmentError::Image {
        file: file.to_owned(),
        reason,
    };
    check_pixels(dimensions(std::io::Cursor::new(&bytes), file)?, file)?;
    let mut reader = image::ImageReader::new(std::io::Cursor::new(bytes));
    if let Ok(format) = image::ImageFormat::from_path(file) {
        reader.set_format(format);
    }
    let mut reader = reader
        .with_guessed_format()
        .map_err(|e| err(e.to_string()))?;
    let hdr = matches!(
        reader.format(),
        Some(image::ImageFormat::Hdr | image::ImageFormat::OpenExr)
    );
    let mut limits = image::Limits::default();
    // RGBA f32 (16 bytes a pixel) is the most any format decodes to.
    limits.max_alloc = Some(MAX_SKY_PIXELS.saturating_mul(16));
    reader.limits(limits);
    let img = reader.decode().map_err(|e| err(e.to_string()))?;
    let mut rgb = img.to_rgb32f();
    if !hdr {
        // 8-bit images are sRGB-encoded: decode to linear.
        for c in rgb.iter_mut() {
            *c = if *c <= 0.04045 {
                *c / 12.92
            } else {
                ((*c + 0.055) / 1.055).powf(2.4)
            };
        }
    }
    for c in rgb.iter_mut() {
        // NaN and negative radiance become 0; +∞ and huge values the largest f16.
        if c.is_nan() || *c < 0.0 {
            *c = 0.0;
        }
        *c = c.min(65_000.0);
    }
    let (w, h) = rgb.dimensions();
    if w == 0 || h == 0 {
        return Err(err("image is empty".into()));
    }
    let rgb = if w.max(h) > MAX_SKY_SIDE {
        let (nw, nh) = loaded_size((w, h));
        image::imageops::resize(&rgb, nw, nh, image::imageops::FilterType::Triangle)
    } else {
        rgb
    };
    let (w, h) = rgb.dimensions();
    Ok((w, h, rgb.into_raw(), hdr))
}

/// The size an image of `w × h` pixels is kept at: downscaled to at most
/// [`MAX_SKY_SIDE`] on its longer side.
fn loaded_size((w, h): (u32, u32)) -> (u32, u32) {
    if w.max(h) <= MAX_SKY_SIDE {
        return (w, h);
    }
    let s = f64::from(MAX_SKY_SIDE) / f64::from(w.max(h));
    (
        ((f64::from(w) * s) as u32).max(1),
        ((f64::from(h) * s) as u32).max(1),
    )
}

/// An image's width and height from its header, read from `data` (the
/// file's bytes or the open file): nothing is decoded.
fn dimensions<R: std::io::BufRead + std::io::Seek>(
    data: R,
    file: &Path,
) -> Result<(u32, u32), EnvironmentError> {
    let err = |reason: String| EnvironmentError::Image {
        file: file.to_owned(),
        reason,
    };
    let mut reader = image::ImageReader::new(data);
    if let Ok(format) = image::ImageFormat::from_path(file) {
        reader.set_format(format);
    }
    (reader.with_guessed_format())
        .map_err(|e| err(e.to_string()))?
        .into_dimensions()
        .map_err(|e| err(e.to_string()))
}

/// The memory `source`'s images take once loaded (RGB f32 at
/// [`loaded_size`]), from their headers, each refused above
/// [`MAX_SKY_PIXELS`]: nothing is decoded.
fn loaded_bytes(source: &SkyImageSource) -> Result<u64, EnvironmentError> {
    let bytes = |(w, h): (u32, u32)| u64::from(w) * u64::from(h) * 12;
    if let SkyImageSource::Builtin(name) = source {
        // An unknown name is refused when the image is loaded.
        let Some((file, data)) = super::builtin::sky(name) else {
            return Ok(0);
        };
        let size = dimensions(std::io::Cursor::new(data), Path::new(file))?;
        return Ok(bytes(loaded_size(size)));
    }
    let mut total = 0u64;
    for file in source.paths() {
        let (opened, _) = crate::input::open_input_file(file, MAX_SKY_FILE_BYTES).map_err(|e| {
            EnvironmentError::Image {
                file: file.to_owned(),
                reason: e.to_string(),
            }
        })?;
        let size = dimensions(std::io::BufReader::new(opened), file)?;
        check_pixels(size, file)?;
        total = total.saturating_add(bytes(loaded_size(size)));
    }
    Ok(total)
}

/// A sky image of more than [`MAX_SKY_PIXELS`] refused by name.
fn check_pixels((w, h): (u32, u32), file: &Path) -> Result<(), EnvironmentError> {
    let pixels = u64::from(w) * u64::from(h);
    if pixels <= MAX_SKY_PIXELS {
        return Ok(());
    }
    Err(EnvironmentError::Image {
        file: file.to_owned(),
        reason: format!(
            "{w}×{h} is {pixels} pixels, more than the {MAX_SKY_PIXELS}-pixel limit for a sky \
             image; it would be shown at most {MAX_SKY_SIDE} px wide: downscale it first"
        ),
    })
}

/// The pixels of an equirectangular source (a file or a built-in sky); `None` for a cubemap.
#[allow(clippy::type_complexity)]
fn equirect_pixels(
    source: &SkyImageSource,
) -> Result<Option<(u32, u32, Vec<f32>, bool)>, EnvironmentError> {
    match source {
        SkyImageSource::Equirect(path) => decode_rgb32f(path).map(Some),
        SkyImageSource::Builtin(name) => {
            let (file, bytes) =
                super::builtin::sky(name).ok_or_else(|| EnvironmentError::Image {
                    file: PathBuf::from(format!("builtin:{name}")),
                    reason: "no such built-in sky".into(),
                })?;
            decode_bytes(bytes.to_vec(), Path::new(file)).map(Some)
        }
        SkyImageSource::Cubemap { .. } => Ok(None),
    }
}

/// Load one sky image (equirectangular file, built-in sky or six cubemap faces).
pub fn load_sky_image(source: &SkyImageSource) -> Result<SkyImage, EnvironmentError> {
    match source {
        SkyImageSource::Equirect(_) | SkyImageSource::Builtin(_) => {
            let Some((width, height, rgb, hdr)) = equirect_pixels(source)? else {
                return Err(EnvironmentError::Image {
                    file: PathBuf::from("sky"),
                    reason: "not an equirectangular source".into(),
                });
            };
            let rows = |r: std::ops::Range<u32>| mean_rows(&rgb, width, r);
            let (mean_upper, mean_lower) = (rows(0..height / 2), rows(height / 2..height));
            let brightest = brightest(&rgb);
            Ok(SkyImage {
                source: source.clone(),
                kind: SkyImageKind::Equirect { width, height, rgb },
                hdr,
                mean_upper,
                mean_lower,
                brightest,
            })
        }
        SkyImageSource::Cubemap { .. } => {
            let names = ["px", "nx", "py", "ny", "pz", "nz"];
            let mut faces = Vec::with_capacity(6);
            let mut side = 0;
            let mut any_hdr = false;
            for (i, path) in source.paths().into_iter().enumerate() {
                let (w, h, rgb, hdr) = decode_rgb32f(path)?;
                if i == 0 {
                    side = w;
                }
                if w != h || w != side {
                    return Err(EnvironmentError::CubemapFace {
                        face: names[i],
                        file: path.to_owned(),
                        got_w: w,
                        got_h: h,
                        want: side,
                    });
                }
                any_hdr |= hdr;
                faces.push(rgb);
            }
            let mean = |fs: &[&Vec<f32>]| {
                let m: Vec<[f32; 3]> = fs.iter().map(|f| mean_rows(f, side, 0..side)).collect();
                std::array::from_fn(|c| m.iter().map(|x| x[c]).sum::<f32>() / m.len() as f32)
            };
            let mean_upper = mean(&[&faces[2], &faces[0], &faces[1], &faces[4], &faces[5]]);
            let mean_lower = mean(&[&faces[3]]);
            let brightest = brightest(&faces.concat());
            Ok(SkyImage {
                source: source.clone(),
                kind: SkyImageKind::Cubemap { side, faces },
                hdr: any_hdr,
                mean_upper,
                mean_lower,
                brightest,
            })
        }
    }
}

fn mean_rows(rgb: &[f32], width: u32, rows: std::ops::Range<u32>) -> [f32; 3] {
    let (start, end) = (
        (rows.start * width * 3) as usize,
        (rows.end * width * 3) as usize,
    );
    let px = &rgb[start.min(rgb.len())..end.min(rgb.len())];
    let n = (px.len() / 3).max(1) as f32;
    let mut sum = [0f64; 3];
    for p in px.chunks_exact(3) {
        for c in 0..3 {
            sum[c] += f64::from(p[c]);
        }
    }
    sum.map(|s| (s / f64::from(n)) as f32)
}

fn brightest(rgb: &[f32]) -> [f32; 3] {
    rgb.chunks_exact(3)
        .max_by(|a, b| (a[0] + a[1] + a[2]).total_cmp(&(b[0] + b[1] + b[2])))
        .map_or([1.0; 3], |p| [p[0], p[1], p[2]])
}

impl SkyImage {
    /// Display value of a radiance (HDR) or of a decoded 8-bit value (LDR).
    pub fn display(&self, c: [f32; 3], exposure: f32) -> Vec3 {
        let v = Vec3::from(c) * exposure;
        if self.hdr {
            tone_map(v)
        } else {
            v.min(Vec3::ONE)
        }
    }

    /// The image's lighting: ambient from the hemisphere means, a sun tinted
    /// like the brightest spot (a visible sun is far brighter than the mean).
    pub fn lighting(&self, sun: Vec3, exposure: f32) -> Lighting {
        let upper = self.display(self.mean_upper, exposure);
        let lower = self.display(self.mean_lower, exposure);
        let b = Vec3::from(self.brightest);
        let mean = Vec3::from(self.mean_upper).element_sum().max(1e-6);
        let sun_visible = b.element_sum() > 8.0 * mean;
        let tint = (b / b.max_element().max(1e-6)).max(Vec3::splat(0.2));
        let strength = if sun_visible { 1.5 } else { 0.6 }
            * smoothstep(-0.03, 0.08, sun.y)
            * exposure.sqrt().min(2.0);
        Lighting {
            sun_color: (tint * strength).to_array(),
            zenith: upper.to_array(),
            horizon: upper.lerp(lower, 0.3).to_array(),
            ground: lower.to_array(),
        }
    }
}

/// The sky images a preset references, loaded once (and only those).
#[derive(Clone, Debug, Default)]
pub struct EnvironmentAssets {
    pub images: Vec<SkyImage>,
}

impl EnvironmentAssets {
    /// Decode every image the sky references (none for procedural and
    /// gradient skies), once their headers say they fit
    /// [`MAX_SKY_PIXELS`] each and [`MAX_SKY_MEMORY_BYTES`] together.
    pub fn load(sky: &Sky) -> Result<Self, EnvironmentError> {
        let sources = sky.image_sources();
        let mut bytes = 0u64;
        for source in &sources {
            bytes = bytes.saturating_add(loaded_bytes(source)?);
        }
        if bytes > MAX_SKY_MEMORY_BYTES {
            return Err(EnvironmentError::Memory {
                images: sources.len(),
                bytes,
            });
        }
        let images = (sources.into_iter())
            .map(load_sky_image)
            .collect::<Result<_, _>>()?;
        Ok(Self { images })
    }

    /// Index of an image by its source.
    pub fn position(&self, source: &SkyImageSource) -> Option<usize> {
        self.images.iter().position(|i| i.source == *source)
    }
}
