//! The statistics of a finished dataset read back from its manifest
//! (`swarmshot stats DIR`): each record's frame and boxes counted by the
//! writer's own [`DatasetStats::add_facts`], so both give the same numbers.

use crate::annotate::LabelStatus;
use crate::scene::SplitName;

use super::{BoxFacts, DatasetStats, FrameFacts};

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
    let manifest_path = dir.join(crate::write::formats::manifest::FILE);
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
    stats.labels_only = dir.join(crate::write::PLAN_README).is_file();
    stats.boxes_from = crate::write::dataset::boxes_from(&preset, stats.labels_only);
    Ok(stats)
}
