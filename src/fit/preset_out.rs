//! The fitted preset: the base preset over the footage's plates, at the footage's
//! resolution, with the drones sized from the real drones and a camera model that adds
//! only what the plates do not already carry. Written as the preset's own pretty RON
//! under a comment block that names where every fitted value came from.

use std::path::{Path, PathBuf};

use super::FitError;
use super::camera::Footage;
use super::drones::CentreSpread;
use super::plates::{PlateCamera, PlateSummary};
use crate::preset::backplate::{Backplate, PlateHorizon};
use crate::preset::camera_model::CameraModel;
use crate::preset::{ImageFormat, Preset, Resolution};

/// The first fit and the notes on where each value came from.
#[derive(Clone, Debug)]
pub struct Fitted {
    /// The preset, `backplate.folder` = "plates" (relative to `fitted.ron`).
    pub preset: Preset,
    /// `field: origin` lines for the comment block.
    pub notes: Vec<String>,
}

/// Loads and validates the base preset, its model and sky paths made absolute (so the
/// fitted preset written elsewhere still finds them).
pub fn load_base(path: &Path) -> Result<Preset, FitError> {
    let mut preset = Preset::load(path).map_err(|e| FitError::Base {
        path: path.to_path_buf(),
        reason: e.to_string(),
    })?;
    let dir = path.parent().unwrap_or(Path::new("."));
    let dir = super::input::absolute(if dir.as_os_str().is_empty() {
        Path::new(".")
    } else {
        dir
    });
    preset.resolve_paths(&dir);
    Ok(preset)
}

/// The base preset renamed `NAME_fitted` and set to the footage's frame
/// size, with that note: how every first fit starts.
pub fn sized_to(base: &Preset, footage: &Footage) -> (Preset, Vec<String>) {
    let mut p = base.clone();
    p.name = format!("{}_fitted", base.name);
    let (w, h) = footage.size;
    p.render.resolution = Resolution::Custom {
        width: w,
        height: h,
    };
    let note = if footage.size_frames < footage.frames {
        format!(
            "render.resolution {w}×{h}: the footage's most common frame size ({} of {} frames; the others differ: one camera's frames fit best)",
            footage.size_frames, footage.frames
        )
    } else {
        format!(
            "render.resolution {w}×{h}: the footage's frame size ({} frames)",
            footage.frames
        )
    };
    (p, vec![note])
}

/// The first fitted preset (round 1's); `centres`: the real boxes' spread over the frame.
pub fn first_fit(
    base: &Preset,
    footage: &Footage,
    plates: &PlateSummary,
    camera: &PlateCamera,
    centres: Option<CentreSpread>,
) -> Fitted {
    let (mut p, mut notes) = sized_to(base, footage);
    set_plates(&mut p, plates, camera, &mut notes);
    // The drones: how many, how large, how near (from the real drones).
    super::drones::first_fit(&mut p, footage, centres, &mut notes);
    // The camera model: the plates carry the footage's exposure, colour, noise, blur.
    let jpeg = match (footage.estimate.jpeg_quality, footage.measured.jpeg_quality) {
        (Some(_), Some(q)) => {
            let (lo, hi) = (q.q25.round() as u8, q.q75.round() as u8);
            notes.push(format!(
                "camera_model.jpeg_quality ({lo}, {hi}): the footage's JPEG quantisation tables (IQR over {} files)",
                q.n
            ));
            (lo.clamp(1, 100), hi.clamp(lo.max(1), 100))
        }
        _ => {
            notes.push(
                "camera_model.jpeg_quality (90, 95): the footage is PNG (no quantisation table to read); a high quality adds little to what its codec left"
                    .into(),
            );
            (90, 95)
        }
    };
    p.output.image_format = ImageFormat::Jpeg { quality: jpeg.1 };
    p.camera_model = Some(CameraModel {
        jpeg_quality: Some(jpeg),
        ..CameraModel::default()
    });
    notes.push(
        "camera_model exposure, white balance, saturation, vignetting, noise, PSF: neutral to start (the plates already carry the footage's); the rounds below add what the report finds missing"
            .into(),
    );
    let e = &footage.estimate;
    notes.push(format!(
        "the footage's camera, estimated on the final bytes (footage.json): read noise σ {} linear levels, PSF σ {} px, JPEG {} (at sky colour {:?})",
        e.read_noise_levels
            .map_or("–".into(), |v| format!("{v:.3}")),
        e.psf_sigma_px.map_or("–".into(), |v| format!("{v:.3}")),
        e.jpeg_quality.map_or("– (PNG)".into(), |q| q.to_string()),
        e.sky_rgb
    ));
    Fitted { preset: p, notes }
}

/// `preset` with its backplate folder `folder` (for a round's copy or the renderer).
pub fn with_plates(preset: &Preset, folder: &Path) -> Preset {
    let mut p = preset.clone();
    if let Some(b) = &mut p.backplate {
        b.folder = folder.to_path_buf();
    }
    p
}

/// The fitted preset's text: the comment block, then the preset's pretty RON.
pub fn text(preset: &Preset, header: &[String]) -> String {
    let mut s = String::new();
    for line in header {
        for l in line.lines() {
            s += "// ";
            s += l;
            s += "\n";
        }
    }
    s += &preset.to_ron();
    s += "\n";
    s
}

/// `p`'s backplate: the footage's own frames (the plates written), the camera as fitted;
/// procedural clutter off (the plates hold the footage's scenery).
pub fn set_plates(
    p: &mut Preset,
    plates: &PlateSummary,
    camera: &PlateCamera,
    notes: &mut Vec<String>,
) {
    // Plates: the footage itself.
    let known = plates
        .plates
        .iter()
        .filter(|p| p.horizon_row.is_some())
        .count();
    let sun = (p.backplate.as_ref()).map(|b| (b.sun_elevation_deg, b.sun_azimuth_deg));
    p.backplate = Some(Backplate {
        folder: PathBuf::from("plates"),
        hfov_deg: camera.hfov_deg,
        horizon: PlateHorizon::Unknown,
        elevation_deg: camera.elevation_deg,
        sun_elevation_deg: sun.map_or((20.0, 60.0), |s| s.0),
        sun_azimuth_deg: sun.map_or((-180.0, 180.0), |s| s.1),
        flip: true,
    });
    let views = match plates.views {
        0 | 1 => String::new(),
        v => format!(
            " as {} plates, {v} views of each (the frame and its crops)",
            plates.plates.len()
        ),
    };
    notes.push(format!(
        "backplate: the footage's {} frames with their labelled drones removed (plates/){views}; hfov_deg {} from {}; horizon per plate in its .plate.ron: estimated on {known}, unknown on {} (elevation_deg {:?} from the base observer)",
        plates.plates.len() / plates.views.max(1),
        camera.hfov_deg,
        camera.hfov_source,
        plates.plates.len() - known,
        camera.elevation_deg
    ));
    if plates.unlabelled > 0 {
        notes.push(format!(
            "WARNING: {} plates come from frames without labels (--unlabelled-ok): drones in them were not removed and stay unlabelled in every frame drawn over them",
            plates.unlabelled
        ));
    }
    // The plates show the footage's own scenery: no procedural clutter over it.
    if p.clutter.take().is_some() {
        notes.push("clutter: off (the plates hold the footage's own scenery)".into());
    }
}
