//! Dataset statistics: the paper's Table 2 quantities (images, resolution,
//! instances, drones per image, small/medium/large) with per-split,
//! per-model, per-environment and per-distance breakdowns and histograms.
//!
//! One code path: the batch and the labels-only plan feed every written
//! frame through [`DatasetStats::add`] into `stats.json`, and
//! `swarmshot stats DIR` feeds the manifest's records through
//! [`DatasetStats::add_facts`], which `add` calls too, so both give the
//! same numbers. Boxes are measured from their coordinates rounded as the
//! files hold them (1e-6 px), so a box on a class boundary falls the same
//! way in both.

use std::collections::BTreeMap;

use crate::annotate::{DroneLabel, LabelStatus};
use crate::scene::{FrameScene, SplitName};

/// Size classes by √(w·h): small below this, pixels.
pub const SMALL_BELOW_PX: f64 = 32.0;
/// Large above this, pixels.
pub const LARGE_ABOVE_PX: f64 = 96.0;
/// Box-size histogram: bins of this many pixels of √(w·h) …
pub const SIZE_BIN_PX: f64 = 4.0;
/// … this many of them (the last also holds everything larger).
pub const SIZE_BINS: usize = 64;
/// Distance histogram: bins of this many metres …
pub const DISTANCE_BIN_M: f64 = 2.0;
/// … this many of them (the last also holds everything farther).
pub const DISTANCE_BINS: usize = 100;
/// The per-distance breakdown's upper edges (metres; the last group is open).
pub const DISTANCE_GROUPS_M: [f64; 7] = [5.0, 10.0, 20.0, 50.0, 100.0, 200.0, 500.0];

/// Counts of one group of boxes (a split, a model, an environment, a distance range).
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default)]
pub struct Breakdown {
    /// Frames in the group (splits and environments; 0 for models and distances).
    pub frames: u64,
    pub boxes: u64,
    pub small: u64,
    pub medium: u64,
    pub large: u64,
}

impl Breakdown {
    fn add_box(&mut self, size_px: f64) {
        self.boxes += 1;
        match size_class(size_px) {
            SizeClass::Small => self.small += 1,
            SizeClass::Medium => self.medium += 1,
            SizeClass::Large => self.large += 1,
        }
    }

    /// Shares of small, medium and large boxes, percent (0 with no box).
    pub fn shares_percent(&self) -> [f64; 3] {
        let n = self.boxes.max(1) as f64;
        [self.small, self.medium, self.large].map(|c| 100.0 * c as f64 / n)
    }
}

enum SizeClass {
    Small,
    Medium,
    Large,
}

fn size_class(size_px: f64) -> SizeClass {
    if size_px < SMALL_BELOW_PX {
        SizeClass::Small
    } else if size_px <= LARGE_ABOVE_PX {
        SizeClass::Medium
    } else {
        SizeClass::Large
    }
}

/// Counts gathered while writing (`stats.json`), or read back from a manifest.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default)]
pub struct DatasetStats {
    pub frames: u64,
    pub frames_per_split: [u64; 3],
    /// Training boxes (status kept): the paper's instances.
    pub boxes: u64,
    /// √(w·h) < 32, 32–96, > 96 px.
    pub small: u64,
    pub medium: u64,
    pub large: u64,
    pub truncated: u64,
    /// Filtered drones kept as COCO ignore regions.
    pub crowd: u64,
    /// Drones in front of the camera that got no training box.
    pub filtered: u64,
    pub drones_placed: u64,
    /// The dataset is a labels-only plan: no images.
    pub labels_only: bool,
    /// Where the training boxes come from: the box method, and whether
    /// `Visible` boxes were measured or estimated (a labels-only plan).
    pub boxes_from: String,
    /// Frames by image size, "W×H".
    pub resolutions: BTreeMap<String, u64>,
    /// Frames by their number of training boxes.
    pub boxes_per_frame: BTreeMap<u32, u64>,
    /// Boxes per √(w·h) bin of [`SIZE_BIN_PX`] pixels (the last bin open).
    pub size_histogram: Vec<u64>,
    /// Boxes per camera-distance bin of [`DISTANCE_BIN_M`] metres (the last bin open).
    pub distance_histogram: Vec<u64>,
    pub per_split: BTreeMap<String, Breakdown>,
    pub per_model: BTreeMap<String, Breakdown>,
    pub per_environment: BTreeMap<String, Breakdown>,
    /// Boxes by the drone's distance from the camera, "A–B m".
    pub per_distance: BTreeMap<String, Breakdown>,
    /// Training boxes by class (presets with `confusers` only: a multi-class dataset).
    #[serde(skip_serializing_if = "BTreeMap::is_empty")]
    pub per_class: BTreeMap<String, Breakdown>,
    /// Unlabelled hard negatives (confusers without a class) in front of the camera.
    #[serde(skip_serializing_if = "is_zero")]
    pub negatives: u64,
    /// Hard negatives by kind (their best box's size class).
    #[serde(skip_serializing_if = "BTreeMap::is_empty")]
    pub per_negative: BTreeMap<String, Breakdown>,
}

fn is_zero(n: &u64) -> bool {
    *n == 0
}

/// One frame as the statistics see it (from a scene or a manifest line).
pub struct FrameFacts<'a> {
    pub split: SplitName,
    pub width: u32,
    pub height: u32,
    pub environment: &'a str,
    pub drones_placed: u64,
    /// Count boxes by class too (the preset has confusers).
    pub count_classes: bool,
}

/// One labelled drone as the statistics see it.
pub struct BoxFacts<'a> {
    /// The model's name (a confuser: its kind).
    pub model: &'a str,
    /// The class name ("" when unknown or a hard negative).
    pub class: &'a str,
    pub status: LabelStatus,
    /// The written box, `[x0, y0, x1, y1]` rounded to 1e-6 px as the files hold it.
    pub xyxy: [f64; 4],
    pub truncated: bool,
    /// Rounded to 1e-6 m as the manifest holds it.
    pub distance_m: f64,
}

fn distance_group(d: f64) -> &'static str {
    static NAMES: std::sync::OnceLock<Vec<String>> = std::sync::OnceLock::new();
    let names = NAMES.get_or_init(|| {
        let mut lo = 0.0;
        let mut names = Vec::new();
        for hi in DISTANCE_GROUPS_M {
            names.push(format!("{lo:>3}–{hi} m"));
            lo = hi;
        }
        names.push(format!("≥ {lo} m"));
        names
    });
    let group = DISTANCE_GROUPS_M
        .iter()
        .position(|&hi| d < hi)
        .unwrap_or(DISTANCE_GROUPS_M.len());
    names.get(group).map_or("", String::as_str)
}

/// Count into `map[key]`, made 0 first when missing (the key is copied only then).
fn count_in(map: &mut BTreeMap<String, Breakdown>, key: &str, count: impl FnOnce(&mut Breakdown)) {
    match map.get_mut(key) {
        Some(b) => count(b),
        None => count(map.entry(key.to_owned()).or_default()),
    }
}

impl DatasetStats {
    /// Count one written frame (its scene and the labels written for it).
    pub fn add(
        &mut self,
        scene: &FrameScene,
        labels: &[DroneLabel],
        model_names: &[String],
        classes: &[String],
    ) {
        let r6 = super::r6;
        let boxes: Vec<BoxFacts<'_>> = labels
            .iter()
            .map(|l| BoxFacts {
                model: match scene.confuser(l.drone) {
                    Some(c) => c.kind.name(),
                    None => (scene.drones.get(l.drone))
                        .and_then(|d| model_names.get(d.model))
                        .map_or("?", String::as_str),
                },
                class: classes.get(l.class_id).map_or("", String::as_str),
                status: l.status,
                xyxy: super::box_xyxy(&l.bbox),
                truncated: l.truncated,
                distance_m: r6(l.distance_m),
            })
            .collect();
        self.add_facts(
            &FrameFacts {
                split: scene.split,
                width: scene.camera.width,
                height: scene.camera.height,
                environment: &scene.environment_name,
                drones_placed: scene.drone_count() as u64,
                count_classes: scene.confusers_on,
            },
            &boxes,
        );
    }

    /// Count one frame from its facts: what [`DatasetStats::add`] and
    /// `swarmshot stats` (reading the manifest) both call.
    pub fn add_facts(&mut self, frame: &FrameFacts<'_>, boxes: &[BoxFacts<'_>]) {
        if self.size_histogram.len() != SIZE_BINS {
            self.size_histogram.resize(SIZE_BINS, 0);
        }
        if self.distance_histogram.len() != DISTANCE_BINS {
            self.distance_histogram.resize(DISTANCE_BINS, 0);
        }
        self.frames += 1;
        self.frames_per_split[frame.split as usize] += 1;
        self.drones_placed += frame.drones_placed;
        *self
            .resolutions
            .entry(format!("{}×{}", frame.width, frame.height))
            .or_default() += 1;
        count_in(&mut self.per_split, frame.split.as_str(), |b| b.frames += 1);
        count_in(&mut self.per_environment, frame.environment, |b| {
            b.frames += 1
        });
        let mut kept = 0u32;
        for b in boxes {
            match b.status {
                LabelStatus::Kept => {}
                LabelStatus::Crowd => {
                    self.crowd += 1;
                    continue;
                }
                LabelStatus::Filtered => {
                    self.filtered += 1;
                    continue;
                }
                LabelStatus::Negative => {
                    self.negatives += 1;
                    let [x0, y0, x1, y1] = b.xyxy;
                    let size = ((x1 - x0) * (y1 - y0)).max(0.0).sqrt();
                    count_in(&mut self.per_negative, b.model, |g| g.add_box(size));
                    continue;
                }
            }
            kept += 1;
            let [x0, y0, x1, y1] = b.xyxy;
            let size = ((x1 - x0) * (y1 - y0)).max(0.0).sqrt();
            self.boxes += 1;
            match size_class(size) {
                SizeClass::Small => self.small += 1,
                SizeClass::Medium => self.medium += 1,
                SizeClass::Large => self.large += 1,
            }
            self.truncated += u64::from(b.truncated);
            let bin = |v: f64, width: f64, n: usize| ((v / width).max(0.0) as usize).min(n - 1);
            self.size_histogram[bin(size, SIZE_BIN_PX, SIZE_BINS)] += 1;
            self.distance_histogram[bin(b.distance_m, DISTANCE_BIN_M, DISTANCE_BINS)] += 1;
            for group in [
                self.per_split.get_mut(frame.split.as_str()),
                self.per_environment.get_mut(frame.environment),
            ]
            .into_iter()
            .flatten()
            {
                group.add_box(size);
            }
            count_in(&mut self.per_model, b.model, |g| g.add_box(size));
            if frame.count_classes {
                count_in(&mut self.per_class, b.class, |g| g.add_box(size));
            }
            count_in(&mut self.per_distance, distance_group(b.distance_m), |g| {
                g.add_box(size)
            });
        }
        *self.boxes_per_frame.entry(kept).or_default() += 1;
    }

    /// Add the counts of `other` (statistics of other frames) to these: the
    /// same statistics as adding its frames one by one after these
    /// (every field is a count). A plan's workers count their chunks and
    /// its writer merges them. `labels_only` and `boxes_from` stay these.
    pub fn merge(&mut self, other: &DatasetStats) {
        // Destructured, so a field added later cannot be forgotten here.
        let DatasetStats {
            frames,
            frames_per_split,
            boxes,
            small,
            medium,
            large,
            truncated,
            crowd,
            filtered,
            drones_placed,
            labels_only: _,
            boxes_from: _,
            resolutions,
            boxes_per_frame,
            size_histogram,
            distance_histogram,
            per_split,
            per_model,
            per_environment,
            per_distance,
            per_class,
            negatives,
            per_negative,
        } = other;
        self.negatives += negatives;
        self.frames += frames;
        for (a, b) in self.frames_per_split.iter_mut().zip(frames_per_split) {
            *a += b;
        }
        self.boxes += boxes;
        self.small += small;
        self.medium += medium;
        self.large += large;
        self.truncated += truncated;
        self.crowd += crowd;
        self.filtered += filtered;
        self.drones_placed += drones_placed;
        for (k, n) in resolutions {
            *self.resolutions.entry(k.clone()).or_default() += n;
        }
        for (k, n) in boxes_per_frame {
            *self.boxes_per_frame.entry(*k).or_default() += n;
        }
        for (mine, theirs) in [
            (&mut self.size_histogram, size_histogram),
            (&mut self.distance_histogram, distance_histogram),
        ] {
            if mine.len() < theirs.len() {
                mine.resize(theirs.len(), 0);
            }
            for (a, b) in mine.iter_mut().zip(theirs) {
                *a += b;
            }
        }
        for (mine, theirs) in [
            (&mut self.per_split, per_split),
            (&mut self.per_model, per_model),
            (&mut self.per_environment, per_environment),
            (&mut self.per_distance, per_distance),
            (&mut self.per_class, per_class),
            (&mut self.per_negative, per_negative),
        ] {
            for (k, b) in theirs {
                let a = mine.entry(k.clone()).or_default();
                let Breakdown {
                    frames,
                    boxes,
                    small,
                    medium,
                    large,
                } = b;
                a.frames += frames;
                a.boxes += boxes;
                a.small += small;
                a.medium += medium;
                a.large += large;
            }
        }
    }

    /// Fewest, mean and most training boxes per frame (the paper's "UAVs per image").
    pub fn boxes_per_frame_range(&self) -> (u32, f64, u32) {
        let min = self.boxes_per_frame.keys().next().copied().unwrap_or(0);
        let max = self
            .boxes_per_frame
            .keys()
            .next_back()
            .copied()
            .unwrap_or(0);
        (min, self.boxes as f64 / self.frames.max(1) as f64, max)
    }

    /// Shares of small, medium and large boxes, percent.
    pub fn shares_percent(&self) -> [f64; 3] {
        let n = self.boxes.max(1) as f64;
        [self.small, self.medium, self.large].map(|c| 100.0 * c as f64 / n)
    }

    /// The report `swarmshot stats` prints: Table 2, then the breakdowns.
    pub fn table(&self) -> String {
        use std::fmt::Write as _;
        let mut s = String::new();
        let (min, mean, max) = self.boxes_per_frame_range();
        let [small, medium, large] = self.shares_percent();
        let resolutions: Vec<String> = self
            .resolutions
            .iter()
            .map(|(r, n)| {
                if self.resolutions.len() == 1 {
                    r.clone()
                } else {
                    format!("{r} ({n})")
                }
            })
            .collect();
        let _ = writeln!(s, "| quantity | value |\n|---|---|");
        let _ = writeln!(s, "| images | {} |", self.frames);
        let _ = writeln!(s, "| resolution | {} |", resolutions.join(", "));
        let _ = writeln!(s, "| instances (training boxes) | {} |", self.boxes);
        let _ = writeln!(
            s,
            "| UAVs per image (min / mean / max) | {min} / {mean:.2} / {max} |"
        );
        let _ = writeln!(
            s,
            "| small (√(w·h) < 32 px) | {small:.1} % ({}) |",
            self.small
        );
        let _ = writeln!(s, "| medium (32–96 px) | {medium:.1} % ({}) |", self.medium);
        let _ = writeln!(s, "| large (> 96 px) | {large:.1} % ({}) |", self.large);
        let _ = writeln!(
            s,
            "| drones placed / truncated / crowd / filtered | {} / {} / {} / {} |",
            self.drones_placed, self.truncated, self.crowd, self.filtered
        );
        let mut section = |title: &str, map: &BTreeMap<String, Breakdown>, frames: bool| {
            let _ = writeln!(
                s,
                "\n| {title} | {}boxes | small | medium | large |\n|---|{}---|---|---|---|",
                if frames { "images | " } else { "" },
                if frames { "---|" } else { "" }
            );
            for (name, b) in map {
                let [sm, me, la] = b.shares_percent();
                let images = if frames {
                    format!("{} | ", b.frames)
                } else {
                    String::new()
                };
                let _ = writeln!(
                    s,
                    "| {name} | {images}{} | {sm:.1} % | {me:.1} % | {la:.1} % |",
                    b.boxes
                );
            }
        };
        section("split", &self.per_split, true);
        section("model", &self.per_model, false);
        section("environment", &self.per_environment, true);
        section("distance from camera", &self.per_distance, false);
        if !self.per_class.is_empty() {
            section("class", &self.per_class, false);
        }
        if self.negatives > 0 {
            section("hard negative (manifest only)", &self.per_negative, false);
        }
        s
    }
}

/// Why a folder's statistics could not be read.
#[derive(Debug, thiserror::Error)]
pub enum StatsError {
    #[error(
        "{} is not a swarmshot dataset: it has no {missing} (give the folder `swarmshot batch --out` wrote)",
        path.display()
    )]
    NotADataset {
        path: std::path::PathBuf,
        missing: &'static str,
    },
    #[error("{}: {source}", path.display())]
    Io {
        path: std::path::PathBuf,
        source: std::io::Error,
    },
    #[error("{} line {line}: not a swarmshot manifest record: {reason}", path.display())]
    BadRecord {
        path: std::path::PathBuf,
        line: u64,
        reason: String,
    },
    #[error("{}: the locked preset cannot be read: {source}", path.display())]
    BadLock {
        path: std::path::PathBuf,
        source: crate::preset::RonError,
    },
}

/// The parts of a manifest line the statistics read.
#[derive(serde::Deserialize)]
struct ManifestFrame {
    split: String,
    camera: ManifestCamera,
    /// Absent in manifests written before environments were recorded.
    #[serde(default)]
    environment: Option<ManifestEnvironment>,
    drones: Vec<ManifestDrone>,
    /// Absent without confusers.
    #[serde(default)]
    confusers: Vec<ManifestConfuser>,
}

#[derive(serde::Deserialize)]
struct ManifestConfuser {
    kind: String,
    class: Option<String>,
    label: Option<ManifestLabel>,
}

#[derive(serde::Deserialize)]
struct ManifestCamera {
    width: u32,
    height: u32,
}

#[derive(serde::Deserialize)]
struct ManifestEnvironment {
    name: String,
}

#[derive(serde::Deserialize)]
struct ManifestDrone {
    model: Option<String>,
    #[serde(default)]
    class: Option<String>,
    label: Option<ManifestLabel>,
}

/// A manifest record's box as the statistics see it.
fn fact<'a>(model: &'a str, class: &'a Option<String>, l: &ManifestLabel) -> BoxFacts<'a> {
    BoxFacts {
        model,
        class: class.as_deref().unwrap_or(""),
        status: l.status,
        xyxy: l.bbox_xyxy,
        truncated: l.truncated,
        distance_m: l.distance_m,
    }
}

#[derive(serde::Deserialize)]
struct ManifestLabel {
    bbox_xyxy: [f64; 4],
    status: LabelStatus,
    truncated: bool,
    distance_m: f64,
}

/// The statistics of the dataset in `dir`, read from its manifest (every
/// frame's poses and boxes) with the writer's own counting; `labels_only`
/// and `boxes_from` from the folder and its locked preset. Refuses a
/// folder without `manifest.jsonl` and `preset.lock.ron` by name.
pub fn read_dataset(dir: &std::path::Path) -> Result<DatasetStats, StatsError> {
    use std::io::BufRead;
    let lock_path = dir.join("preset.lock.ron");
    let manifest_path = dir.join(super::formats::manifest::FILE);
    for (path, missing) in [
        (&manifest_path, "manifest.jsonl"),
        (&lock_path, "preset.lock.ron"),
    ] {
        if !path.is_file() {
            return Err(StatsError::NotADataset {
                path: dir.to_owned(),
                missing,
            });
        }
    }
    let io = |path: &std::path::Path| {
        let path = path.to_owned();
        move |source| StatsError::Io { path, source }
    };
    let lock = std::fs::read_to_string(&lock_path).map_err(io(&lock_path))?;
    let preset = crate::preset::Preset::from_ron(&lock).map_err(|source| StatsError::BadLock {
        path: lock_path.clone(),
        source,
    })?;
    let file = std::fs::File::open(&manifest_path).map_err(io(&manifest_path))?;
    let mut stats = DatasetStats::default();
    let mut line = String::new();
    let mut reader = std::io::BufReader::with_capacity(1 << 20, file);
    let mut number = 0u64;
    loop {
        line.clear();
        if reader.read_line(&mut line).map_err(io(&manifest_path))? == 0 {
            break;
        }
        number += 1;
        if line.trim().is_empty() {
            continue;
        }
        let bad = |reason: String| StatsError::BadRecord {
            path: manifest_path.clone(),
            line: number,
            reason,
        };
        let frame: ManifestFrame = serde_json::from_str(&line).map_err(|e| bad(e.to_string()))?;
        let split = SplitName::ALL
            .into_iter()
            .find(|s| s.as_str() == frame.split)
            .ok_or_else(|| bad(format!("unknown split {:?}", frame.split)))?;
        let drones = (frame.drones.iter()).filter_map(|d| {
            Some(fact(
                d.model.as_deref().unwrap_or("?"),
                &d.class,
                d.label.as_ref()?,
            ))
        });
        let confusers = (frame.confusers.iter())
            .filter_map(|c| Some(fact(&c.kind, &c.class, c.label.as_ref()?)));
        let boxes: Vec<BoxFacts<'_>> = drones.chain(confusers).collect();
        stats.add_facts(
            &FrameFacts {
                split,
                width: frame.camera.width,
                height: frame.camera.height,
                environment: frame
                    .environment
                    .as_ref()
                    .map_or("unknown", |e| e.name.as_str()),
                drones_placed: frame.drones.len() as u64,
                count_classes: !preset.confusers.is_empty(),
            },
            &boxes,
        );
    }
    stats.labels_only = dir.join(super::PLAN_README).is_file();
    stats.boxes_from = super::dataset::boxes_from(&preset, stats.labels_only);
    Ok(stats)
}

/// Draw the three histograms (training boxes per image, box size √(w·h),
/// distance from the camera) as PNGs into `dir`; returns their paths. Text
/// needs the DejaVu Sans font (Debian: fonts-dejavu-core); without it the
/// bars are drawn unlabelled.
pub fn write_histograms(
    stats: &DatasetStats,
    dir: &std::path::Path,
) -> Result<Vec<std::path::PathBuf>, StatsError> {
    let mut out = super::folder::outdir::OutDir::create(dir).map_err(|e| StatsError::Io {
        path: dir.to_owned(),
        source: std::io::Error::other(e.to_string()),
    })?;
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
    let trim = |v: &[u64]| {
        let end = v.iter().rposition(|&n| n > 0).map_or(1, |i| i + 1);
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
        let path = dir.join(file);
        let png =
            draw_histogram(title, &counts, width, unit, font).map_err(|e| StatsError::Io {
                path: path.clone(),
                source: std::io::Error::other(e.to_string()),
            })?;
        let path = out.write(file, &png).map_err(|e| StatsError::Io {
            path,
            source: std::io::Error::other(e.to_string()),
        })?;
        written.push(path);
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

/// A histogram drawn as PNG bytes (written by the caller through [`super::folder::outdir::OutDir`]).
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
