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
//!
//! This file holds the measures and their counting; `table.rs` the report
//! `swarmshot stats` prints, `read.rs` the statistics read back from a
//! dataset's manifest, `plots.rs` the histogram PNGs.

use std::collections::BTreeMap;

use crate::annotate::{DroneLabel, LabelStatus};
use crate::scene::{FrameScene, SplitName};

mod plots;
mod read;
mod table;

pub(crate) use plots::font;
pub use plots::{DEFAULT_PLOTS, check_plots_dir, open_plots_dir, write_histograms};
pub use read::{StatsError, read_dataset};

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
}
