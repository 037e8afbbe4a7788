//! `swarmshot fit`: a preset fitted to the user's own footage (issue 36).
//!
//! From a folder of real frames (or a video, decoded by the system's `ffmpeg`):
//!
//! 1. [`input`] reads every frame and its YOLO labels, refusing any bad input with a
//!    named [`FitError`] before anything is written;
//! 2. [`camera`] measures the footage with the domain-gap report's statistics
//!    ([`crate::gap::measure_frame`]) and estimates its camera (sensor noise, PSF, JPEG
//!    quality) by inverting the camera model's own forward path on the final bytes,
//!    the noise on a test picture of the footage's own sky ([`sky`]);
//! 3. [`plates`] turns each frame into a backplate with its labelled drones removed
//!    (filled by diffusion from the ring around each box, with the ring's own noise),
//!    written to `OUT/plates/` with a `.plate.ron` sidecar;
//! 4. [`preset_out`] writes `OUT/fitted.ron`: the base preset over those plates, at the
//!    footage's resolution, with the drones' apparent size from the real drones, the
//!    footage's JPEG quality and a camera model that adds only what the plates lack,
//!    each value's origin in a comment;
//! 5. [`search`] closes the loop: renders a sample with the batch's pipeline into
//!    `OUT/rounds/NN/`, runs the gap report against the footage, adjusts, repeats.
//!
//! A thermal base preset (`thermal:` set) fits the thermal camera's values instead of the
//! visible camera model ([`thermal`]) and skips the plates (step 3) unless it has a
//! `backplate` ([`plated`]: then the plates are its thermal scene).
//!
//! Same inputs, same outputs, byte for byte (no clock, no thread count in any file).

pub mod camera;
pub mod drones;
pub mod input;
pub mod out;
pub mod plates;
pub mod preset_out;
pub mod search;
pub mod size_knots;
pub mod sky;
pub mod thermal;
pub mod video;

use std::path::{Path, PathBuf};

use serde::Serialize;

use crate::preset::Preset;

/// What `swarmshot fit` was asked.
#[derive(Clone, Debug)]
pub struct FitOptions {
    /// A folder of real frames (JPEG/PNG, labels in `labels/` or beside them), or a video file.
    pub real: PathBuf,
    /// The output folder (created; must be empty or missing unless `overwrite`).
    pub out: PathBuf,
    /// The base preset (default: [`default_base`]).
    pub base: PathBuf,
    /// Frames rendered per round.
    pub sample: u64,
    /// Fitted rounds at most (0: no rendering, only plates and the first fit).
    pub rounds: usize,
    /// Accept frames without labels (they may hold drones nobody labelled).
    pub unlabelled_ok: bool,
    /// Replace an earlier fit's files in `out`.
    pub overwrite: bool,
    /// At most this many real frames, evenly spaced in name order (0: all).
    pub max_frames: usize,
    /// The plates' horizontal field of view, degrees (`None`: from the base preset).
    pub hfov_deg: Option<f64>,
    /// Frames per second taken from a video.
    pub video_fps: f64,
    /// Plates per frame: the frame, then crops ([`plates::view_crop`]); 1 to
    /// [`plates::MAX_VIEWS`].
    pub views: usize,
    /// The real frames' label classes that are drones (removed from the plates and
    /// measured); rows of other classes stay in the plates as they are.
    pub classes: crate::gap::folder::DroneClasses,
}

/// The base preset without `--base`: the shipped `realistic.ron`
/// ([`crate::preset::shipped`]), or its relative path when it is nowhere to be
/// found (the fit then names it as a file it cannot read).
pub fn default_base() -> PathBuf {
    crate::preset::shipped::find("realistic.ron")
        .unwrap_or_else(|| PathBuf::from("presets/realistic.ron"))
}

impl FitOptions {
    pub fn new(real: impl Into<PathBuf>, out: impl Into<PathBuf>) -> Self {
        Self {
            real: real.into(),
            out: out.into(),
            base: default_base(),
            sample: 64,
            rounds: 4,
            unlabelled_ok: false,
            overwrite: false,
            max_frames: 200,
            hfov_deg: None,
            video_fps: 2.0,
            views: 1,
            classes: crate::gap::folder::DroneClasses::All,
        }
    }
}

/// Every way `fit` refuses or fails; the input errors come before anything is written.
#[derive(Debug, thiserror::Error)]
pub enum FitError {
    #[error("--real {}: no such file or folder", path.display())]
    Missing { path: PathBuf },
    #[error("--real {}: empty folder: no .jpg, .jpeg or .png frame in it", path.display())]
    EmptyFolder { path: PathBuf },
    #[error("{}: 0-byte file", path.display())]
    EmptyFile { path: PathBuf },
    #[error("{}: corrupt image: {reason}", path.display())]
    CorruptImage { path: PathBuf, reason: String },
    /// A frame refused for what it is (not a JPEG or PNG, too large or too small), as
    /// `gap` refuses it.
    #[error("{}: {reason}", path.display())]
    Image { path: PathBuf, reason: String },
    #[error(
        "{frames} frames of {} megapixels in all are more than the {} megapixels fit holds in memory at once; pass --max-frames {fit} or fewer (or smaller frames)",
        pixels / 1_000_000, input::MAX_TOTAL_PIXELS / 1_000_000
    )]
    TooManyPixels {
        frames: usize,
        pixels: u64,
        fit: usize,
    },
    #[error(
        "{frames} frames × {views} views would give plates at {width}×{height} that the fitted preset cannot load (at most {} plates, {} MiB resampled to the frame size); pass --max-frames {fit} or fewer (or fewer --views)",
        crate::sky::plates::MAX_PLATES, crate::sky::plates::MAX_PLATE_MEMORY_BYTES >> 20
    )]
    TooManyPlates {
        frames: usize,
        views: usize,
        width: u32,
        height: u32,
        fit: usize,
    },
    #[error("--hfov {0}: must be degrees within [1, {max}]", max = crate::preset::backplate::MAX_PLATE_HFOV_DEG)]
    Hfov(f64),
    #[error("--video-fps {0}: must be frames a second within (0, {max}]", max = input::MAX_VIDEO_FPS)]
    VideoFps(f64),
    #[error("{}: line {line}: bad label: {reason}", path.display())]
    Label {
        path: PathBuf,
        line: usize,
        reason: String,
    },
    #[error(
        "frames without labels where labels are needed: {count} of {total} frames have no label file (first: {}); they may show drones nobody labelled, which would stay in the plates. Add YOLO labels (labels/NAME.txt, an empty file for a frame without drones) or pass --unlabelled-ok",
        first.display()
    )]
    Unlabelled {
        count: usize,
        total: usize,
        first: PathBuf,
    },
    #[error("--out {} is inside the real folder {}: the report would read its own frames; choose a folder outside it", out.display(), real.display())]
    OutInsideReal { out: PathBuf, real: PathBuf },
    #[error("--out {}: not empty and not an earlier fit; choose an empty folder (or --overwrite an earlier fit's folder)", path.display())]
    OutNotEmpty { path: PathBuf },
    #[error("--real {}: no video decoder: install ffmpeg (swarmshot decodes video with the ffmpeg and ffprobe programs on PATH)", path.display())]
    NoVideoDecoder { path: PathBuf },
    #[error("--real {}: ffmpeg could not decode the video: {reason}", path.display())]
    VideoDecode { path: PathBuf, reason: String },
    #[error("--base {}: {reason}", path.display())]
    Base { path: PathBuf, reason: String },
    #[error("{}: {source}", path.display())]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    /// A frame folder or label file refused as `gap` refuses it.
    #[error(transparent)]
    Frames(#[from] crate::gap::GapError),
    #[error("--views {0}: must be 1 (the frame alone) to {max} (the frame and its crops)", max = plates::MAX_VIEWS)]
    Views(usize),
    /// An entry of `--out` that fit will not overwrite, delete or write through.
    #[error("--out: {} {why}", path.display())]
    NotFits { path: PathBuf, why: String },
    #[error("{0}")]
    Other(String),
}

pub(crate) fn io_err(path: &Path) -> impl FnOnce(std::io::Error) -> FitError + '_ {
    move |source| FitError::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// What was prepared before any rendering: the footage, the plates and the first fit.
#[derive(Debug)]
pub struct Prepared {
    pub options: FitOptions,
    /// The folder of real frames the report reads (the video's decoded frames for a video).
    pub real_dir: PathBuf,
    /// The output folder, as given.
    pub out: PathBuf,
    /// The output folder, opened once: every file is written through it.
    pub out_dir: std::sync::Mutex<out::FitOut>,
    pub footage: camera::Footage,
    pub plates: plates::PlateSummary,
    /// The base preset, its paths resolved.
    pub base: Preset,
    /// The first fit (round 1's preset), its backplate folder relative to `out`.
    pub fitted: preset_out::Fitted,
}

impl Prepared {
    /// The output folder's handle (one writer at a time).
    pub fn out_dir(&self) -> std::sync::MutexGuard<'_, out::FitOut> {
        self.out_dir
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
    }

    /// What the user is told before trusting the fit (the CLI prints each as a warning,
    /// the app shows them with the result): footage of mixed frame sizes, and frames
    /// without labels whose drones stay in the plates.
    pub fn warnings(&self) -> Vec<String> {
        let (f, mut out) = (&self.footage, Vec::new());
        if f.size_frames < f.frames {
            out.push(format!(
                "{} of {} frames are {}×{} and the others of other sizes: the fit is one camera's (that size's); fit each camera's frames on their own",
                f.size_frames, f.frames, f.size.0, f.size.1
            ));
        }
        let unlabelled = self.plates.unlabelled / self.plates.views.max(1);
        if unlabelled > 0 {
            out.push(format!(
                "{unlabelled} of {} frames have no labels (--unlabelled-ok): any drone in them stays in its plates, unlabelled",
                f.frames
            ));
        }
        out
    }
}

/// The run's record, written to `OUT/fit.json`.
#[derive(Debug, Serialize)]
pub struct FitRecord {
    pub real: String,
    pub base: String,
    pub frames: usize,
    pub labelled_frames: usize,
    pub drones: usize,
    /// The label classes taken as drones (`--classes`: `all`, or ids such as `0,3`).
    pub drone_classes: String,
    pub rounds: Vec<search::RoundRecord>,
    /// The round whose preset is `fitted.ron` (`None` without rounds: the first fit).
    pub best_round: Option<usize>,
    pub target_inside: usize,
}

/// The numeric options in range, before anything is read or written.
fn check_numbers(options: &FitOptions) -> Result<(), FitError> {
    if !(1..=plates::MAX_VIEWS).contains(&options.views) {
        return Err(FitError::Views(options.views));
    }
    if let Some(v) = options.hfov_deg
        && !crate::preset::backplate::hfov_ok(v)
    {
        return Err(FitError::Hfov(v));
    }
    let fps = options.video_fps;
    if !(fps.is_finite() && fps > 0.0 && fps <= input::MAX_VIDEO_FPS) {
        return Err(FitError::VideoFps(fps));
    }
    Ok(())
}

/// Steps 1–4: read and check the footage (nothing written before it passes), measure
/// it, write the plates, `footage.json` and the first fit (in memory).
pub fn prepare(options: &FitOptions) -> Result<Prepared, FitError> {
    check_numbers(options)?;
    let source = input::check_source(options)?;
    let base = preset_out::load_base(&options.base)?;
    let (real_dir, frames, mut out) = match &source {
        input::Source::Folder(dir) => {
            let frames = input::read_folder(
                dir,
                options.max_frames,
                options.unlabelled_ok,
                &options.classes,
            )?;
            plates::check_names_apart(&frames, options.views)?;
            if plated(&base) {
                let size = camera::common_size(&frames).0;
                plates::check_plate_budget(frames.len(), options.views, size)?;
                plates::check_plate_hfov(&base, size, options.hfov_deg)?;
            }
            let out = out::FitOut::open(&options.out, options.overwrite)?;
            (dir.clone(), frames, out)
        }
        input::Source::Video { path, decoder } => {
            let probe = video::probe(path, decoder)?;
            input::check_video_pixels(path, &probe, options)?;
            if plated(&base) {
                let frames = video::frames_bound(&probe, options);
                let size = (probe.width, probe.height);
                plates::check_plate_budget(frames, options.views, size)?;
                plates::check_plate_hfov(&base, size, options.hfov_deg)?;
            }
            let mut out = out::FitOut::open(&options.out, options.overwrite)?;
            // ffmpeg's `frame_NNNNN.png` names give plates of names apart.
            let decoded = video::decode(path, decoder, &probe, &mut out, options)
                .and_then(|dir| Ok((input::read_folder(&dir, 0, true, &options.classes)?, dir)));
            let (frames, dir) = decoded.inspect_err(|_| out.discard_frames())?;
            (dir, frames, out)
        }
    };
    let footage = camera::measure(&frames);
    let geometry = plates::PlateCamera::from_base(&base, &footage, options.hfov_deg);
    let plates = if !plated(&base) {
        plates::PlateSummary::default()
    } else {
        let dir = out.dir("plates")?;
        let plates = plates::write_plates(&frames, &footage, &geometry, &dir, options.views)?;
        out.verify()?;
        plates
    };
    let centres = drones::CentreSpread::of(frames.iter().flat_map(|f| {
        let (w, h) = f.rgb.dimensions();
        let (w, h) = (f64::from(w.max(1)), f64::from(h.max(1)));
        (f.boxes.iter()).map(move |b| {
            (
                f64::from(b.x0 + b.x1) * 0.5 / w,
                f64::from(b.y0 + b.y1) * 0.5 / h,
            )
        })
    }));
    drop(frames);
    let json =
        serde_json::to_string_pretty(&footage).map_err(|e| FitError::Other(e.to_string()))?;
    out.write("footage.json", json.as_bytes())?;
    let fitted = if base.thermal.is_some() {
        let with = plated(&base).then_some((&plates, &geometry));
        thermal::first_fit(&base, &footage, with, centres)
    } else {
        preset_out::first_fit(&base, &footage, &plates, &geometry, centres)
    };
    Ok(Prepared {
        options: options.clone(),
        real_dir,
        out: options.out.clone(),
        out_dir: std::sync::Mutex::new(out),
        footage,
        plates,
        base,
        fitted,
    })
}

/// Whether the fit writes plates of the footage: always for a visible base; for a thermal
/// base when it has a `backplate` (its folder is replaced by the plates; without one a
/// thermal preset draws its modelled sky, ground and texture).
fn plated(base: &Preset) -> bool {
    base.thermal.is_none() || base.backplate.is_some()
}

/// What a finished fit gives back for printing.
#[derive(Debug)]
pub struct Finished {
    pub fitted: PathBuf,
    pub record: FitRecord,
    /// The base preset's report (round 00) and the best round's, as tables.
    pub before: Option<String>,
    pub after: Option<String>,
}

/// Step 5 and the end: the rounds (when `options.rounds` > 0 and a GPU context is given),
/// then `fitted.ron` (the best round's preset) and `fit.json`, and the written preset
/// checked as `swarmshot check` checks it (parsed, validated, its models and plates loaded).
pub fn finish(
    prep: &Prepared,
    ctx: Option<&crate::render::GpuContext>,
    cancel: &std::sync::atomic::AtomicBool,
    log: &mut dyn FnMut(String),
) -> Result<Finished, FitError> {
    let outcome = match ctx {
        Some(ctx) if prep.options.rounds > 0 => Some(search::run(prep, ctx, cancel, log)?),
        _ => None,
    };
    let mut header = vec![format!(
        "swarmshot fit: {} fitted to the footage in {} ({} frames, {} labelled, {} drones)",
        prep.options.base.display(),
        prep.options.real.display(),
        prep.footage.frames,
        prep.footage.labelled_frames,
        prep.footage.drones
    )];
    header.push("Where each fitted value comes from:".into());
    header.extend(prep.fitted.notes.iter().map(|n| format!("- {n}")));
    let (preset, rounds, best) = match &outcome {
        Some(o) => {
            for r in &o.rounds {
                header.push(format!(
                    "round {:02} ({}): {} of {} statistics inside{}",
                    r.round,
                    r.preset,
                    r.inside,
                    r.applicable,
                    if Some(r.round) == o.best {
                        " <- this preset"
                    } else {
                        ""
                    }
                ));
                for c in &r.changes {
                    header.push(format!("  then {c}"));
                }
            }
            (o.preset.clone(), o.rounds.clone(), o.best)
        }
        None => {
            header.push("no rounds were rendered (--rounds 0): the first fit, unmeasured".into());
            (prep.fitted.preset.clone(), Vec::new(), None)
        }
    };
    header.push("Reports: rounds/NN/report.txt; the footage's figures: footage.json.".into());
    let text = preset_out::text(&preset, &header);
    let fitted = prep.out_dir().write("fitted.ron", text.as_bytes())?;
    // The written file, as `swarmshot check` reads it.
    crate::pipeline::FramePipeline::open(&fitted)
        .map_err(|e| FitError::Other(format!("the fitted preset does not load: {e:#}")))?;
    let record = FitRecord {
        real: prep.options.real.display().to_string(),
        base: prep.options.base.display().to_string(),
        frames: prep.footage.frames,
        labelled_frames: prep.footage.labelled_frames,
        drones: prep.footage.drones,
        drone_classes: prep.options.classes.to_string(),
        target_inside: rounds.first().map_or(0, |r| r.applicable.saturating_sub(2)),
        rounds,
        best_round: best,
    };
    let json = serde_json::to_string_pretty(&record).map_err(|e| FitError::Other(e.to_string()))?;
    prep.out_dir().write("fit.json", json.as_bytes())?;
    Ok(Finished {
        fitted,
        record,
        before: outcome.as_ref().and_then(|o| o.before.clone()),
        after: outcome.and_then(|o| o.after),
    })
}
