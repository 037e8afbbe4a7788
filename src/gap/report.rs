//! `swarmshot gap`: reads the real folder and the dataset, measures every frame
//! ([`super::measure_frame`]), summarises each statistic per side (median and inter-quartile
//! range; shares with a 50 % Wilson interval), gives a verdict and the distance outside
//! the real range in IQR widths, proposes camera-model ranges, and writes `report.json`,
//! `report.txt`, one histogram PNG per statistic and `contact_sheet.png`.
//!
//! The fourteen statistics of the original report are *counted* (the "inside on N of 13"
//! that `fit` and docs/realism.md quote); the rows added for fitting — background
//! texture, drone box size and what lies behind the drones — are shown and written with
//! their verdicts but marked not counted ([`StatRow::counted`]).
//!
//! Every input problem (a missing folder, no images, an undecodable, oversized or
//! truncated image, a malformed label line, a label file over [`MAX_LABEL_LINES`] lines)
//! is an error naming the file, found before anything is written; so is an output folder
//! equal to or inside an input folder ([`check_out`]). The output folder holds only the
//! files named here, each written atomically. Frames are the JPEG and PNG files under a
//! side's folder, except inside a folder holding a gap report (`report.json` and
//! `report.txt` side by side): gap never counts its own histograms as frames.

use std::path::{Path, PathBuf};

use serde::Serialize;

use super::behind::Behind;
pub use super::error::GapError;
use super::folder::{ClassTally, DroneClasses, input, label_for, not_a_folder, read_labels, walk};
pub use super::folder::{MAX_BOX_COVERAGE, MAX_LABEL_BYTES, MAX_LABEL_LINES, YOLO_TOLERANCE};
use super::halves::{Agreement, RealHalves, Split};
use super::table::percentile;
pub use super::table::{FEW_REAL_VALUES, Proposal, StatRow, Summary, cell, fmt, iqr_distance};
use super::{FrameStats, measure_frame};

/// Drones whose core is this size range (pixels) get the small-drone rows.
pub const SMALL_CORE_PX: (f32, f32) = (3.0, 6.0);
/// z for a 50 % two-sided interval: the share analogue of an inter-quartile range.
const Z50: f64 = 0.674_489_75;
/// The largest frame file read (its pixels are bounded by
/// [`crate::input::MAX_IMAGE_PIXELS`], read from its header before decoding).
pub const MAX_FRAME_BYTES: u64 = 256 << 20;

/// What `swarmshot gap` was asked.
#[derive(Clone, Debug)]
pub struct GapOptions {
    /// Folder of real frames (JPEG/PNG), with YOLO labels in a sibling `labels/` or beside them.
    pub real: PathBuf,
    /// A swarmshot dataset folder (its `images/` and `labels/`).
    pub synthetic: PathBuf,
    /// At most this many frames per side, evenly spaced in name order (0: all).
    pub max_images: usize,
    /// The real frames' label classes that are drones.
    pub real_classes: DroneClasses,
    /// The dataset's label classes that are drones (`None`: its models' classes,
    /// [`super::folder::dataset_drone_classes`]).
    pub synthetic_classes: Option<DroneClasses>,
}

impl GapOptions {
    /// Every real label row a drone, the dataset's drones by its preset, 200 frames a side.
    pub fn new(real: impl Into<PathBuf>, synthetic: impl Into<PathBuf>) -> Self {
        Self {
            real: real.into(),
            synthetic: synthetic.into(),
            max_images: 200,
            real_classes: DroneClasses::All,
            synthetic_classes: None,
        }
    }
}

/// One side's frames and what was measured on them.
#[derive(Clone, Debug, Default, Serialize)]
pub struct Side {
    /// The folder as given.
    pub dir: String,
    /// The folder, canonical (for [`check_out`]; not written).
    #[serde(skip)]
    pub root: PathBuf,
    /// Images found; `frames` holds the ones measured (`--max-images`).
    pub images_found: usize,
    /// The label classes measured as drones (`all`, or ids such as `0,3`).
    pub drone_classes: String,
    pub labelled_frames: usize,
    /// The label rows read, of the drone classes and of others.
    #[serde(skip)]
    pub rows: ClassTally,
    pub frames: Vec<FrameRecord>,
    /// The contact sheet's thumbnails of this side ([`super::sheet::picks`]; not written).
    #[serde(skip)]
    pub thumbnails: Vec<image::RgbImage>,
}

#[derive(Clone, Debug, Serialize)]
pub struct FrameRecord {
    /// Path relative to the side's folder.
    pub file: String,
    #[serde(flatten)]
    pub stats: FrameStats,
}

#[derive(Clone, Debug, Serialize)]
pub struct Report {
    pub real: Side,
    pub synthetic: Side,
    pub statistics: Vec<StatRow>,
    pub proposals: Vec<Proposal>,
    /// The real frames against themselves ([`super::halves`]; `None` with too few).
    pub real_halves: Option<RealHalves>,
}

/// Whether a drone counts for a share (`None`: it has no say).
type DroneFlag = fn(&super::DroneMeasure) -> Option<bool>;

enum Kind {
    Frame(fn(&FrameStats) -> Option<f64>),
    Drone(fn(&super::DroneMeasure) -> Option<f64>),
    Share(DroneFlag),
}

struct Stat {
    key: &'static str,
    name: &'static str,
    unit: &'static str,
    kind: Kind,
    /// Counted among the statistics inside (the original fourteen).
    counted: bool,
}

fn small(d: &super::DroneMeasure) -> bool {
    d.core_px >= SMALL_CORE_PX.0 && d.core_px <= SMALL_CORE_PX.1
}

/// The fourteen statistics of the original report, counted among the
/// statistics inside.
const COUNTED_STATS: [Stat; 14] = [
    Stat {
        counted: true,
        key: "noise_sigma",
        name: "flat-sky noise σ (1.4826·MAD of 2×2 high-pass)",
        unit: "levels",
        kind: Kind::Frame(|f| f.noise_sigma.map(f64::from)),
    },
    Stat {
        counted: true,
        key: "highpass_rms",
        name: "flat-sky high-pass RMS",
        unit: "levels",
        kind: Kind::Frame(|f| f.highpass_rms.map(f64::from)),
    },
    Stat {
        counted: true,
        key: "gradient_energy",
        name: "gradient energy (mean Sobel at 540 px high)",
        unit: "levels/px",
        kind: Kind::Frame(|f| Some(f64::from(f.gradient_energy))),
    },
    Stat {
        counted: true,
        key: "canny_edge_share",
        name: "share of pixels that are Canny edges",
        unit: "",
        kind: Kind::Frame(|f| Some(f64::from(f.canny_edge_share))),
    },
    Stat {
        counted: true,
        key: "sky_saturation",
        name: "sky saturation (HSV)",
        unit: "",
        kind: Kind::Frame(|f| f.sky_saturation.map(f64::from)),
    },
    Stat {
        counted: true,
        key: "sky_hue_deg",
        name: "sky hue (HSV)",
        unit: "deg",
        kind: Kind::Frame(|f| f.sky_hue_deg.map(f64::from)),
    },
    Stat {
        counted: true,
        key: "mean_brightness",
        name: "mean brightness",
        unit: "levels",
        kind: Kind::Frame(|f| Some(f64::from(f.mean_brightness))),
    },
    Stat {
        counted: true,
        key: "blur_sigma_px",
        name: "blur: PSF σ of the sharpest edges (25th pct)",
        unit: "px",
        kind: Kind::Frame(|f| f.blur_sigma_px.map(f64::from)),
    },
    Stat {
        counted: true,
        key: "jpeg_quality",
        name: "JPEG quality (from quantisation tables)",
        unit: "",
        kind: Kind::Frame(|f| f.jpeg_quality.map(f64::from)),
    },
    Stat {
        counted: true,
        key: "drone_core_px",
        name: "drone core size √(pixels > half the peak)",
        unit: "px",
        kind: Kind::Drone(|d| Some(f64::from(d.core_px))),
    },
    Stat {
        counted: true,
        key: "drone_core_under_6px",
        name: "share of drones with a core under 6 px",
        unit: "",
        kind: Kind::Share(|d| Some(d.core_px < 6.0)),
    },
    Stat {
        counted: true,
        key: "drone_darker",
        name: "share of drones darker than their ring",
        unit: "",
        kind: Kind::Share(|d| (d.peak != 0.0).then_some(d.darker)),
    },
    Stat {
        counted: true,
        key: "small_drone_peak_contrast",
        name: "peak contrast of 3–6 px drones",
        unit: "levels",
        kind: Kind::Drone(|d| small(d).then_some(f64::from(d.peak.abs()))),
    },
    Stat {
        counted: true,
        key: "small_drone_edge_width_px",
        name: "edge width (90→10 %) of 3–6 px drones",
        unit: "px",
        kind: Kind::Drone(|d| {
            if small(d) {
                d.edge_width_px.map(f64::from)
            } else {
                None
            }
        }),
    },
];

/// Every row of the report: the counted statistics, then the rows added for
/// fitting.
fn stats() -> Vec<Stat> {
    COUNTED_STATS.into_iter().chain(fitting_stats()).collect()
}

/// The rows added for fitting, not counted among the statistics inside.
fn fitting_stats() -> Vec<Stat> {
    use Kind::*;
    let mut v = vec![
        Stat {
            counted: false,
            key: "background_texture",
            name: "background texture: median tile σ at 540 px",
            unit: "levels",
            kind: Frame(|f| f.background_texture.map(f64::from)),
        },
        Stat {
            counted: false,
            key: "vertical_gradient",
            name: "vertical gradient: lower third − upper third",
            unit: "levels",
            kind: Frame(|f| Some(f64::from(f.vertical_gradient))),
        },
        Stat {
            counted: false,
            key: "block_steps",
            name: "block steps: neighbour difference across 8×8 edges − inside",
            unit: "levels",
            kind: Frame(|f| f.block_steps.map(f64::from)),
        },
        Stat {
            counted: false,
            key: "centre_depth",
            name: "centre depth: centre − ring (narcissus)",
            unit: "levels",
            kind: Frame(|f| f.centre_depth.map(f64::from)),
        },
        Stat {
            counted: false,
            key: "horizon_row",
            name: "horizon row (share of the height; frames with one)",
            unit: "",
            kind: Frame(|f| f.horizon.map(|h| f64::from(h.row))),
        },
        Stat {
            counted: false,
            key: "horizon_step",
            name: "horizon step: the band below − above",
            unit: "levels",
            kind: Frame(|f| f.horizon.map(|h| f64::from(h.step))),
        },
        Stat {
            counted: false,
            key: "horizon_halo",
            name: "horizon halo: the band above − a quarter height higher",
            unit: "levels",
            kind: Frame(|f| f.horizon.and_then(|h| h.halo).map(f64::from)),
        },
        Stat {
            counted: false,
            key: "drone_box_px",
            name: "drone box size √(w·h)",
            unit: "px",
            kind: Drone(|d| Some(f64::from(d.box_px))),
        },
    ];
    let behind: [(&str, &str, DroneFlag); 4] = [
        ("behind_sky", "share of drones in front of sky", |d| {
            d.behind.map(|b| b == Behind::Sky)
        }),
        (
            "behind_vegetation",
            "share of drones in front of vegetation",
            |d| d.behind.map(|b| b == Behind::Vegetation),
        ),
        ("behind_ground", "share of drones in front of ground", |d| {
            d.behind.map(|b| b == Behind::Ground)
        }),
        (
            "behind_building",
            "share of drones in front of a building",
            |d| d.behind.map(|b| b == Behind::Building),
        ),
    ];
    v.extend(behind.map(|(key, name, g)| Stat {
        counted: false,
        key,
        name,
        unit: "",
        kind: Share(g),
    }));
    v
}

fn values(side: &Side, kind: &Kind) -> Vec<f64> {
    let mut v = Vec::new();
    for f in &side.frames {
        match kind {
            Kind::Frame(g) => v.extend(g(&f.stats)),
            Kind::Drone(g) => v.extend(f.stats.drones.iter().filter_map(g)),
            Kind::Share(_) => {}
        }
    }
    v.retain(|x| x.is_finite());
    v
}

fn flags(side: &Side, g: DroneFlag) -> Vec<bool> {
    side.frames
        .iter()
        .flat_map(|f| f.stats.drones.iter().filter_map(g))
        .collect()
}

/// Median and quartiles (linear interpolation between order statistics).
pub fn distribution(values: &[f64]) -> Option<Summary> {
    if values.is_empty() {
        return None;
    }
    let mut s = values.to_vec();
    s.sort_by(f64::total_cmp);
    Some(Summary::Distribution {
        n: s.len(),
        median: percentile(&s, 0.5),
        q25: percentile(&s, 0.25),
        q75: percentile(&s, 0.75),
    })
}

/// A share with its 50 % Wilson score interval.
pub fn share(flags: &[bool]) -> Option<Summary> {
    let n = flags.len();
    if n == 0 {
        return None;
    }
    let k = flags.iter().filter(|&&b| b).count();
    let (nf, p) = (n as f64, k as f64 / n as f64);
    let z2 = Z50 * Z50;
    let centre = (p + z2 / (2.0 * nf)) / (1.0 + z2 / nf);
    let half = Z50 / (1.0 + z2 / nf) * (p * (1.0 - p) / nf + z2 / (4.0 * nf * nf)).sqrt();
    Some(Summary::Share {
        n,
        k,
        share: p,
        // The interval holds its own share; rounding must not lift 0 of n above 0.
        low: (centre - half).clamp(0.0, p),
        high: (centre + half).clamp(p, 1.0),
    })
}

fn verdict(real: Option<Summary>, synthetic: Option<Summary>) -> &'static str {
    match (real, synthetic) {
        (Some(r), Some(s)) => {
            let (lo, hi) = r.range();
            let c = s.centre();
            if c < lo {
                "below"
            } else if c > hi {
                "above"
            } else {
                "inside"
            }
        }
        _ => "n/a",
    }
}

/// Measures one side: every image under `dir` (sorted by path), at most `max` of them.
fn measure_side(
    dir: &Path,
    max: usize,
    dataset: bool,
    classes: &DroneClasses,
) -> Result<Side, GapError> {
    if !dir.is_dir() {
        return Err(not_a_folder(dir));
    }
    let canonical = dir.canonicalize().map_err(|source| GapError::Io {
        path: dir.to_path_buf(),
        source,
    })?;
    let root = if dataset {
        let images = dir.join("images");
        if !images.is_dir() {
            return Err(input(
                dir,
                "not a swarmshot dataset: it has no images/ folder (`swarmshot batch --out` makes one)",
            ));
        }
        images
    } else {
        dir.to_path_buf()
    };
    let mut images = Vec::new();
    walk(&root, 0, &mut images)?;
    images.sort();
    if images.is_empty() {
        return Err(input(&root, "no .jpg, .jpeg or .png image in it"));
    }
    let found = images.len();
    let picked: Vec<PathBuf> = if max > 0 && found > max {
        (0..max).map(|i| images[i * found / max].clone()).collect()
    } else {
        images
    };
    let mut frames = Vec::with_capacity(picked.len());
    let mut labelled = 0;
    let mut rows = ClassTally::default();
    let shown = super::sheet::picks(picked.len());
    let mut thumbnails = Vec::with_capacity(shown.len());
    for (i, p) in picked.into_iter().enumerate() {
        let bytes =
            crate::input::read_input_file(&p, MAX_FRAME_BYTES).map_err(|source| GapError::Io {
                path: p.clone(),
                source,
            })?;
        let img = crate::input::decode_image(&bytes, crate::input::MAX_IMAGE_PIXELS, u32::MAX)
            .map_err(|e| input(&p, e.to_string()))?
            .to_rgb8();
        let (w, h) = img.dimensions();
        if w < 16 || h < 16 {
            return Err(input(&p, format!("{w}×{h} is smaller than one 16 px tile")));
        }
        let boxes = match label_for(&root, &p)? {
            Some(lp) => {
                labelled += 1;
                read_labels(&lp, (w, h), classes, &mut rows)?
            }
            None => Vec::new(),
        };
        let is_jpeg = bytes.starts_with(&[0xFF, 0xD8]);
        let stats = measure_frame(&img, &boxes, is_jpeg.then_some(bytes.as_slice()));
        let file = p
            .strip_prefix(dir)
            .unwrap_or(&p)
            .to_string_lossy()
            .replace('\\', "/");
        frames.push(FrameRecord { file, stats });
        if shown.contains(&i) {
            thumbnails.push(super::sheet::thumbnail(&img));
        }
    }
    Ok(Side {
        dir: dir.display().to_string(),
        root: canonical,
        images_found: found,
        drone_classes: classes.to_string(),
        labelled_frames: labelled,
        rows,
        frames,
        thumbnails,
    })
}

/// Refuses an output folder equal to or inside an input folder (`inputs`: the side's
/// flag name and folder), comparing canonical paths; an `out` that does not exist yet is
/// resolved through its nearest existing ancestor. A missing input folder is named first.
pub fn check_out(out: &Path, inputs: &[(&'static str, &Path)]) -> Result<(), GapError> {
    for &(_, dir) in inputs {
        if !dir.is_dir() {
            return Err(not_a_folder(dir));
        }
    }
    let real_out =
        crate::input::canonical_as_far_as_it_exists(out).map_err(|source| GapError::Io {
            path: out.to_path_buf(),
            source,
        })?;
    for &(side, dir) in inputs {
        let Ok(real_in) = dir.canonicalize() else {
            continue;
        };
        if real_out.starts_with(&real_in) {
            return Err(GapError::OutInsideInput {
                out: out.to_path_buf(),
                side,
                input: dir.to_path_buf(),
                same: real_out == real_in,
            });
        }
    }
    Ok(())
}

/// Refuses a side whose label rows are all of classes other than the `flag`'s list.
fn check_classes(side: &Side, flag: &str, classes: &DroneClasses) -> Result<(), GapError> {
    (side.rows.check(classes))
        .map_err(|reason| input(Path::new(&side.dir), format!("{flag} {classes}: {reason}")))
}

/// Refuses `--real` and `--synthetic` that are one folder or one inside the
/// other (compared canonically): the report would measure the dataset's
/// own frames as the footage it is compared with.
pub fn check_sides(real: &Path, synthetic: &Path) -> Result<(), GapError> {
    let (Ok(r), Ok(s)) = (real.canonicalize(), synthetic.canonicalize()) else {
        return Ok(());
    };
    if r.starts_with(&s) || s.starts_with(&r) {
        return Err(GapError::SidesOverlap {
            real: real.to_path_buf(),
            synthetic: synthetic.to_path_buf(),
            relation: if r == s {
                "the same folder as"
            } else if r.starts_with(&s) {
                "inside"
            } else {
                "a folder holding"
            },
        });
    }
    Ok(())
}

/// Measures both sides and builds the report (nothing is written).
pub fn run(opts: &GapOptions) -> Result<Report, GapError> {
    check_sides(&opts.real, &opts.synthetic)?;
    let real = measure_side(&opts.real, opts.max_images, false, &opts.real_classes)?;
    check_classes(&real, "--real-classes", &opts.real_classes)?;
    let synthetic_classes = match &opts.synthetic_classes {
        Some(c) => c.clone(),
        None => super::folder::dataset_drone_classes(&opts.synthetic)?,
    };
    let synthetic = measure_side(&opts.synthetic, opts.max_images, true, &synthetic_classes)?;
    if let Some(given) = &opts.synthetic_classes {
        check_classes(&synthetic, "--synthetic-classes", given)?;
    }
    let statistics = compare(&real, &synthetic);
    let proposals = super::propose::propose(&statistics);
    let real_halves = RealHalves::of(real.frames.len(), |first| halves_agree(&real, first));
    Ok(Report {
        real,
        synthetic,
        statistics,
        proposals,
        real_halves,
    })
}

/// Every statistic of `synthetic` against the range of `real`.
fn compare(real: &Side, synthetic: &Side) -> Vec<StatRow> {
    let mut statistics = Vec::new();
    for s in stats() {
        let (r, y) = match s.kind {
            Kind::Share(g) => (share(&flags(real, g)), share(&flags(synthetic, g))),
            ref k => (
                distribution(&values(real, k)),
                distribution(&values(synthetic, k)),
            ),
        };
        statistics.push(StatRow {
            key: s.key,
            name: s.name,
            unit: s.unit,
            per: if matches!(s.kind, Kind::Frame(_)) {
                "frame"
            } else {
                "drone"
            },
            real: r,
            synthetic: y,
            verdict: verdict(r, y),
            iqr_distance: iqr_distance(r, y),
            counted: s.counted,
        });
    }
    statistics
}

/// The two halves of `real`'s frames that `first` makes, each against the other's range.
fn halves_agree(real: &Side, first: Split) -> Agreement {
    let part = |keep: bool| Side {
        frames: (real.frames.iter().enumerate())
            .filter(|(i, _)| first(*i) == keep)
            .map(|(_, f)| f.clone())
            .collect(),
        ..Side::default()
    };
    let (a, b) = (part(true), part(false));
    Agreement([inside(&compare(&a, &b)), inside(&compare(&b, &a))])
}

/// How many counted statistics are inside, of those with a value on both sides.
fn inside(statistics: &[StatRow]) -> (usize, usize) {
    let counted = statistics.iter().filter(|r| r.counted);
    let applicable: Vec<&StatRow> = counted.filter(|r| r.iqr_distance.is_some()).collect();
    let inside = applicable.iter().filter(|r| r.verdict == "inside").count();
    (inside, applicable.len())
}

impl Report {
    /// The statistics whose real range rests on fewer than [`FEW_REAL_VALUES`]
    /// values, named with their counts (`None` when there are none).
    pub fn few_real_values(&self) -> Option<String> {
        let few: Vec<String> = (self.statistics.iter())
            .filter_map(|r| {
                let n = r.real?.n();
                (n < FEW_REAL_VALUES).then(|| format!("{} (n={n})", r.name))
            })
            .collect();
        (!few.is_empty()).then(|| {
            format!(
                "few real values (under {FEW_REAL_VALUES}), so their real range moves with every real frame added and their verdicts are weak: {}; add real frames for these",
                few.join(", ")
            )
        })
    }

    /// How many counted statistics are inside, of those with a value on both sides.
    pub fn inside(&self) -> (usize, usize) {
        inside(&self.statistics)
    }

    /// The side-by-side table, as printed.
    pub fn table(&self) -> String {
        let mut s = format!(
            "real: {} ({} of {} images, {} labelled, {} drones)\nsynthetic: {} ({} of {} images, {} labelled, {} drones)\n\n",
            self.real.dir,
            self.real.frames.len(),
            self.real.images_found,
            self.real.labelled_frames,
            self.real
                .frames
                .iter()
                .map(|f| f.stats.drones.len())
                .sum::<usize>(),
            self.synthetic.dir,
            self.synthetic.frames.len(),
            self.synthetic.images_found,
            self.synthetic.labelled_frames,
            self.synthetic
                .frames
                .iter()
                .map(|f| f.stats.drones.len())
                .sum::<usize>(),
        );
        let line = |a: &str, b: &str, c: &str, d: &str, e: &str, f: &str| {
            format!("{a:<48} {b:<10} {c:<32} {d:<32} {e:<8} {f}\n")
        };
        s += &line(
            "statistic",
            "unit",
            "real median [IQR]",
            "synthetic median [IQR]",
            "verdict",
            "IQRs out",
        );
        let row = |r: &StatRow| {
            let out = r
                .iqr_distance
                .map_or("–".into(), |d| if d == 0.0 { "0".into() } else { fmt(d) });
            line(
                r.name,
                r.unit,
                &cell(r.real),
                &cell(r.synthetic),
                r.verdict,
                &out,
            )
        };
        for r in self.statistics.iter().filter(|r| r.counted) {
            s += &row(r);
        }
        let (inside, applicable) = self.inside();
        s += &format!(
            "counted statistics inside: {inside} of {applicable} (those with a value on both sides)\n"
        );
        if let Some(h) = &self.real_halves {
            s += &h.line();
        }
        s += "\nnot counted (measured for fitting):\n";
        for r in self.statistics.iter().filter(|r| !r.counted) {
            s += &row(r);
        }
        s += "\n(shares: the interval is the 50 % Wilson interval; verdict: the synthetic median or share against the real range; IQRs out: how far outside it, in widths of it; behind: the ring classifier of docs/realism.md)\n";
        if let Some(note) = self.few_real_values() {
            s += &note;
            s += "\n";
        }
        if !self.proposals.is_empty() {
            s += "\nproposed ranges:\n";
            for p in &self.proposals {
                s += &format!("- {}\n", p.text);
            }
        }
        s
    }

    /// The contact sheet of both sides' thumbnails ([`super::sheet`]).
    pub fn contact_sheet(&self) -> Result<image::RgbImage, Box<dyn std::error::Error>> {
        let label = |what: &str, side: &Side| {
            let dir: Vec<char> = side.dir.chars().collect();
            // Each half holds some 55 characters: a long folder keeps its end.
            let dir: String = match dir.len() {
                n if n > 32 => std::iter::once('…')
                    .chain(dir[n - 31..].iter().copied())
                    .collect(),
                _ => side.dir.clone(),
            };
            format!(
                "{what}: {dir} ({} of {})",
                side.thumbnails.len(),
                side.frames.len()
            )
        };
        super::sheet::contact_sheet(
            &self.real.thumbnails,
            &self.synthetic.thumbnails,
            [
                &label("real", &self.real),
                &label("synthetic", &self.synthetic),
            ],
        )
    }

    /// Writes `report.json`, `report.txt`, `hist_<statistic>.png` and `contact_sheet.png`
    /// into `out` (created if missing); returns the files written.
    /// An `out` equal to or inside either side's folder is refused first ([`check_out`]).
    pub fn write(&self, out: &Path) -> Result<Vec<PathBuf>, GapError> {
        check_out(
            out,
            &[
                ("real", &self.real.root),
                ("synthetic", &self.synthetic.root),
            ],
        )?;
        if out.exists() && !out.is_dir() {
            return Err(input(out, "exists and is not a folder"));
        }
        // Opened once; every file written relative to it, never through a link.
        let mut dir =
            crate::write::outdir::OutDir::create(out).map_err(|e| input(out, e.to_string()))?;
        self.write_into(&mut dir)
    }

    /// Writes the files [`Report::write`] writes into the folder `dir` already opened
    /// (relative to its handle, never through a link); returns the files written.
    pub fn write_into(
        &self,
        dir: &mut crate::write::outdir::OutDir,
    ) -> Result<Vec<PathBuf>, GapError> {
        let out = dir.path().to_path_buf();
        let out = out.as_path();
        let mut save = |name: &str, bytes: &[u8]| -> Result<PathBuf, GapError> {
            dir.write(name, bytes)
                .map_err(|e| input(&out.join(name), e.to_string()))
        };
        let mut written = Vec::new();
        let json = serde_json::to_string_pretty(self)
            .map_err(|e| input(&out.join("report.json"), e.to_string()))?;
        written.push(save("report.json", json.as_bytes())?);
        written.push(save("report.txt", self.table().as_bytes())?);
        for s in stats() {
            let (r, y) = match s.kind {
                Kind::Share(_) => continue,
                ref k => (values(&self.real, k), values(&self.synthetic, k)),
            };
            if r.is_empty() && y.is_empty() {
                continue;
            }
            let name = format!("hist_{}.png", s.key);
            let png = super::histogram::histogram_png(s.name, s.unit, &r, &y)
                .map_err(|e| input(&out.join(&name), format!("plot failed: {e}")))?;
            written.push(save(&name, &png)?);
        }
        let name = "contact_sheet.png";
        let png = self
            .contact_sheet()
            .and_then(|sheet| super::sheet::png(&sheet))
            .map_err(|e| input(&out.join(name), format!("contact sheet failed: {e}")))?;
        written.push(save(name, &png)?);
        Ok(written)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A side of `n` frames whose brightness is `level(i)` and whose gradient energy and
    /// Canny share spread alike in every part of it.
    fn side_of(n: usize, level: impl Fn(usize) -> f32) -> Side {
        let frames = (0..n)
            .map(|i| FrameRecord {
                file: format!("{i:04}.png"),
                stats: FrameStats {
                    mean_brightness: level(i),
                    gradient_energy: 1.0 + (i % 3) as f32 * 0.1,
                    canny_edge_share: 0.01 + (i % 3) as f32 * 0.001,
                    ..FrameStats::default()
                },
            })
            .collect();
        Side {
            frames,
            ..Side::default()
        }
    }

    /// Footage that turns darker halfway (two occasions): its alternate halves agree on
    /// every statistic, its first and second halves not on the brightness, either way;
    /// footage alike all along agrees both ways.
    #[test]
    fn halves_of_footage_that_changes_along_it_disagree() {
        let agree = |real: &Side| {
            RealHalves::of(real.frames.len(), |first| halves_agree(real, first)).expect("enough")
        };
        let h = agree(&side_of(
            40,
            |i| if i < 20 { 60.0 } else { 140.0 } + (i % 5) as f32,
        ));
        let Agreement([(a, n), (b, m)]) = h.alternate;
        assert_eq!((a, b), (n, m), "alternate halves: {h:?}");
        assert!(
            n >= 3,
            "brightness, gradient energy and Canny share counted: {h:?}"
        );
        let Agreement([(c, p), (d, q)]) = h.first_second;
        assert_eq!((c + 1, d + 1), (p, q), "first against second: {h:?}");
        let even = agree(&side_of(40, |i| 100.0 + (i % 5) as f32));
        assert_eq!(even.first_second, even.alternate);
    }

    #[test]
    fn quartiles_interpolate_and_shares_bracket() {
        let Some(Summary::Distribution {
            median, q25, q75, ..
        }) = distribution(&[4.0, 1.0, 3.0, 2.0, 5.0])
        else {
            panic!("no summary")
        };
        assert_eq!((median, q25, q75), (3.0, 2.0, 4.0));
        let Some(Summary::Share {
            share, low, high, ..
        }) = share(&[true, true, true, false])
        else {
            panic!("no share")
        };
        assert_eq!(share, 0.75);
        assert!(low < 0.75 && high > 0.75 && high < 1.0, "{low} {high}");
        assert_eq!(
            verdict(distribution(&[1.0, 2.0, 3.0]), distribution(&[0.5])),
            "below"
        );
        assert_eq!(
            verdict(distribution(&[1.0, 2.0, 3.0]), distribution(&[2.2])),
            "inside"
        );
        assert_eq!(verdict(distribution(&[1.0, 2.0, 3.0]), None), "n/a");
    }

    /// None of the real drones and none of the synthetic ones: the same share, inside
    /// (the interval's bound at 0 of n once rounded to 2e-19, and 0 of 70 read "below").
    #[test]
    fn shares_of_none_and_of_all_are_inside_each_other() {
        for n in [1, 70, 152, 1000] {
            let Some(Summary::Share { low, high, .. }) = share(&vec![false; n]) else {
                panic!("no share")
            };
            assert_eq!(low, 0.0, "0 of {n}: {low}");
            assert!(high > 0.0, "0 of {n}: {high}");
            let Some(Summary::Share { low, high, .. }) = share(&vec![true; n]) else {
                panic!("no share")
            };
            assert_eq!(high, 1.0, "{n} of {n}: {high}");
            assert!(low < 1.0, "{n} of {n}: {low}");
        }
        for value in [false, true] {
            assert_eq!(verdict(share(&[value; 152]), share(&[value; 70])), "inside");
        }
    }

    #[test]
    fn quadrature_proposal_reaches_the_target() {
        let a = super::super::propose::add_in_quadrature(2.0, 1.0);
        assert!(((a * a + 1.0).sqrt() - 2.0).abs() < 1e-12);
        assert_eq!(super::super::propose::add_in_quadrature(1.0, 2.0), 0.0);
    }
}
