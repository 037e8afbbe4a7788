//! Dataset statistics gathered while writing (`stats.json`).

use crate::annotate::{DroneLabel, LabelStatus};
use crate::scene::FrameScene;

/// Counts gathered while writing.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct DatasetStats {
    pub frames: u64,
    pub frames_per_split: [u64; 3],
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
}

impl DatasetStats {
    pub fn add(&mut self, scene: &FrameScene, labels: &[DroneLabel]) {
        self.frames += 1;
        self.frames_per_split[scene.split as usize] += 1;
        self.drones_placed += scene.drones.len() as u64;
        for l in labels {
            match l.status {
                LabelStatus::Kept => {}
                LabelStatus::Crowd => {
                    self.crowd += 1;
                    continue;
                }
                LabelStatus::Filtered => {
                    self.filtered += 1;
                    continue;
                }
            }
            self.boxes += 1;
            let s = l.bbox.area().sqrt();
            if s < 32.0 {
                self.small += 1;
            } else if s <= 96.0 {
                self.medium += 1;
            } else {
                self.large += 1;
            }
            self.truncated += u64::from(l.truncated);
        }
    }
}
