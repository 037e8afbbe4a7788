//! Work and disk estimates made before a run starts: how many drones a frame
//! can hold, whether a rendered frame stays within its work budget, how many
//! frames `check` samples, and how much disk a dataset needs.

use super::*;

/// The most drones a rendered frame may hold (`batch`, `frame`, the app):
/// rendering, visibility layers and label files grow with every drone, and
/// a frame past this would run for minutes. Labels-only plans
/// (`batch --labels-only`) take up to [`MAX_DRONES_PER_FRAME`].
pub const MAX_RENDERED_DRONES_PER_FRAME: u64 = 100_000;

/// `check` estimates boxes from the first frames whose objects (drones and
/// confusers) add up to at most this many (none when a frame holds more).
pub const CHECK_SAMPLE_DRONES: u64 = 200_000;

/// Bytes per pixel of an image, measured on the quickstart preset's frames
/// (gradient sky, 1920×1080: 62.7 kB a JPEG at quality 85, 206.8 kB a PNG).
/// Image skies and busy environments compress less; the estimate is typical,
/// not an upper bound.
const JPEG_Q85_BYTES_PER_PIXEL: f64 = 0.030;
const PNG_BYTES_PER_PIXEL: f64 = 0.10;
/// Label bytes (YOLO, COCO, manifest) per frame and per drone placed,
/// and the ledger's bytes per frame, measured on the same run (10 frames,
/// 84 drones: 108.8 kB of labels, 14.2 kB of ledger).
const LABEL_BYTES_PER_FRAME: f64 = 1500.0;
const LABEL_BYTES_PER_DRONE: f64 = 1100.0;
const LEDGER_BYTES_PER_FRAME: f64 = 1400.0;

/// A labels-only plan's bytes on disk per frame (its label file's 4 KiB
/// block, the manifest's camera, the COCO image record) and per object
/// (drone or confuser: its manifest record, 590 bytes; its COCO
/// annotation, 290, counted twice since the part file and the assembled
/// `instances_*.json` stand side by side until the parts are deleted; its
/// YOLO line, 40), and its ledger per frame. Measured on plans of the
/// quickstart preset with 10 000 drones a frame in a 60 × 30 × 60 m box
/// (108 frames: 0.85 KB a drone once finished, 1.1 KB before the parts go)
/// and with 10⁶ drones a frame (0.97 KB a drone before the parts go).
/// Typical, not an upper bound, like [`Preset::disk_estimate`].
const PLAN_BYTES_PER_FRAME: f64 = 5000.0;
const PLAN_BYTES_PER_OBJECT: f64 = 1100.0;
const PLAN_LEDGER_BYTES_PER_FRAME: f64 = 200.0;
/// A labels-only plan's memory per object it holds (its pose, its label,
/// its records as text, and what planning the frame needs meanwhile), and
/// what the process holds besides: measured peaks (`/usr/bin/time -v`,
/// docs/datasets.md) of 1.92 GB for plans holding one frame of 10⁶ drones
/// and 18 MB for the quickstart's, with some room. An upper bound for
/// those presets, so a plan refused for its memory would not have fit.
const PLAN_MEMORY_BYTES_PER_OBJECT: f64 = 2200.0;
const PLAN_MEMORY_BASE_BYTES: f64 = 64.0 * 1024.0 * 1024.0;

/// What a dataset of some frames needs on disk (an estimate).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DiskEstimate {
    pub frames: u64,
    pub image_bytes: f64,
    pub label_bytes: f64,
    pub ledger_bytes: f64,
}

impl DiskEstimate {
    /// Everything together.
    pub fn total_bytes(&self) -> f64 {
        self.image_bytes + self.label_bytes + self.ledger_bytes
    }
}

/// Bytes for a message: `1.2 GiB`, `37.0 TiB`.
pub fn human_bytes(bytes: f64) -> String {
    const UNITS: [&str; 6] = ["B", "KiB", "MiB", "GiB", "TiB", "PiB"];
    let mut v = bytes.max(0.0);
    let mut unit = 0;
    while v >= 1024.0 && unit + 1 < UNITS.len() {
        v /= 1024.0;
        unit += 1;
    }
    if unit == 0 {
        format!("{v:.0} B")
    } else {
        format!("{v:.1} {}", UNITS[unit])
    }
}

impl Preset {
    /// The most drones any frame can hold (the count's upper end, the grid,
    /// the formation, or the densest frame of a density sweep).
    pub fn max_drones_per_frame(&self) -> u64 {
        match &self.placement {
            Placement::Structured {
                x_count,
                y_count,
                z_count,
                ..
            } => u64::from(*x_count)
                .saturating_mul(u64::from(*y_count))
                .saturating_mul(u64::from(*z_count)),
            Placement::Formation(f) => u64::from(f.count),
            Placement::Randomized {
                volume: Volume::DensitySweep { size_m, per_m3 },
                ..
            } => {
                let most = (per_m3.start.max(per_m3.end) * size_m.0 * size_m.1 * size_m.2).round();
                if most.is_finite() && most >= 1.0 {
                    most.min(u64::MAX as f64) as u64
                } else {
                    1
                }
            }
            Placement::Randomized { count: (_, hi), .. } => u64::from(*hi),
        }
    }

    /// The most confusers any frame can hold: each entry's count's upper
    /// end, added up (at most 32 entries of 500).
    pub fn max_confusers_per_frame(&self) -> u64 {
        self.confusers.iter().map(|c| u64::from(c.count.1)).sum()
    }

    /// The most objects any frame draws and labels: its drones, then its
    /// confusers (the scene appends them to the frame's `drones`). Each
    /// takes an instance id and a manifest record.
    pub fn max_objects_per_frame(&self) -> u64 {
        self.max_drones_per_frame()
            .saturating_add(self.max_confusers_per_frame())
    }

    /// A rendered frame's work budget: at most
    /// [`MAX_RENDERED_DRONES_PER_FRAME`] drones. Checked by `batch`, `frame`
    /// and `check` before anything is rendered or written.
    pub fn check_render_budget(&self) -> Result<(), FieldError> {
        let most = self.max_drones_per_frame();
        if most <= MAX_RENDERED_DRONES_PER_FRAME {
            return Ok(());
        }
        Err(FieldError {
            field: "placement".into(),
            message: format!(
                "up to {most} drones per frame is more than the {MAX_RENDERED_DRONES_PER_FRAME} a rendered frame may hold (its work budget: rendering, visibility and labels grow with every drone); lower the count, or plan the labels alone with `batch --labels-only` (up to {MAX_DRONES_PER_FRAME})"
            ),
        })
    }

    /// How many of the first frames `check` samples for its estimate: as
    /// many as fit in [`CHECK_SAMPLE_DRONES`] objects, drones and confusers
    /// (at most 200, and none when a single frame holds more).
    pub fn check_sample_frames(&self) -> u64 {
        let per_frame = self.max_objects_per_frame().max(1);
        (CHECK_SAMPLE_DRONES / per_frame)
            .min(200)
            .min(self.frame_count())
    }

    /// The disk a dataset of `frames` frames needs, estimated from the image
    /// size and format and `drones_per_frame` (the mean drones in view).
    pub fn disk_estimate(&self, frames: u64, drones_per_frame: f64) -> DiskEstimate {
        let (w, h) = self.image_size();
        let pixels = f64::from(w) * f64::from(h);
        let per_pixel = match self.output.image_format {
            // Roughly linear in quality between q50 (half) and q100 (three times).
            ImageFormat::Jpeg { quality } => {
                let q = f64::from(quality.clamp(1, 100));
                JPEG_Q85_BYTES_PER_PIXEL
                    * if q <= 85.0 {
                        q / 85.0
                    } else {
                        1.0 + (q - 85.0) / 7.5
                    }
            }
            ImageFormat::Png => PNG_BYTES_PER_PIXEL,
        };
        let n = frames as f64;
        DiskEstimate {
            frames,
            image_bytes: n * pixels * per_pixel,
            label_bytes: n
                * (LABEL_BYTES_PER_FRAME + LABEL_BYTES_PER_DRONE * drones_per_frame.max(0.0)),
            ledger_bytes: n * LEDGER_BYTES_PER_FRAME,
        }
    }

    /// The disk a labels-only plan of `frames` frames needs (no images),
    /// with `objects_per_frame` drones and confusers a frame on average.
    pub fn plan_disk_estimate(&self, frames: u64, objects_per_frame: f64) -> DiskEstimate {
        let n = frames as f64;
        DiskEstimate {
            frames,
            image_bytes: 0.0,
            label_bytes: n
                * (PLAN_BYTES_PER_FRAME + PLAN_BYTES_PER_OBJECT * objects_per_frame.max(0.0)),
            ledger_bytes: n * PLAN_LEDGER_BYTES_PER_FRAME,
        }
    }

    /// The memory a labels-only plan needs when it holds `objects` drones
    /// and confusers at once (`pipeline::plan::PlanShape`), an estimate.
    pub fn plan_memory_bytes(&self, objects: u64) -> f64 {
        PLAN_MEMORY_BASE_BYTES + PLAN_MEMORY_BYTES_PER_OBJECT * objects as f64
    }
}

/// `MemAvailable` from /proc/meminfo (Linux), in bytes; `None` elsewhere.
pub fn available_memory_bytes() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    proc_kib(&text, "MemAvailable:")?.checked_mul(1024)
}

/// The bytes of memory a run may use: three quarters of `MemAvailable` (the
/// rest is the encoders' and the system's), and no more than the address
/// space this process may still map under its `RLIMIT_AS` and `RLIMIT_DATA`
/// (`ulimit -v`, `ulimit -d`, a cluster job's memory limit): an allocation
/// past those fails, and Rust aborts the process on a failed allocation, so
/// a frame that does not fit must be refused before it starts. `None` when
/// nothing is known.
pub fn usable_memory_bytes() -> Option<u64> {
    let free = available_memory_bytes().map(|b| b / 4 * 3);
    [free, address_space_left_bytes()]
        .into_iter()
        .flatten()
        .min()
}

/// The address space this process may still map: the least of its
/// `RLIMIT_AS` less `VmSize` and its `RLIMIT_DATA` less `VmData` (Linux's
/// /proc/self/status), or `None` when neither limit is set.
pub fn address_space_left_bytes() -> Option<u64> {
    use rustix::process::Resource;
    let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    let left = |resource, field| {
        let limit = rustix::process::getrlimit(resource).current?;
        Some(limit.saturating_sub(proc_kib(&status, field).unwrap_or(0).saturating_mul(1024)))
    };
    [
        left(Resource::As, "VmSize:"),
        left(Resource::Data, "VmData:"),
    ]
    .into_iter()
    .flatten()
    .min()
}

/// The least of the process's `RLIMIT_AS` and `RLIMIT_DATA` (`ulimit -v`,
/// `ulimit -d`), in bytes; `None` when neither is set.
pub fn address_space_limit_bytes() -> Option<u64> {
    use rustix::process::{Resource, getrlimit};
    [
        getrlimit(Resource::As).current,
        getrlimit(Resource::Data).current,
    ]
    .into_iter()
    .flatten()
    .min()
}

/// The value in KiB of a `/proc/meminfo` or `/proc/self/status` line such as
/// `VmSize:  123 kB`.
fn proc_kib(status: &str, field: &str) -> Option<u64> {
    let line = status.lines().find(|l| l.starts_with(field))?;
    line.split_whitespace().nth(1)?.parse().ok()
}

/// Free bytes for an unprivileged user on the filesystem holding `path`
/// (or its nearest existing ancestor), from `statvfs` (rustix); `None` for a
/// filesystem of no size (`/proc`, `/sys`: nothing to estimate against, and
/// creating the folder says what is wrong).
pub fn free_bytes(path: &Path) -> Option<u64> {
    let mut at = Some(path);
    while let Some(p) = at {
        let probe = if p.as_os_str().is_empty() {
            Path::new(".")
        } else {
            p
        };
        if let Ok(s) = rustix::fs::statvfs(probe) {
            return (s.f_blocks > 0).then(|| s.f_bavail.saturating_mul(s.f_frsize));
        }
        at = p.parent();
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_filesystem_of_no_size_has_no_free_bytes_to_estimate_against() {
        let dir = tempfile::tempdir().expect("temp dir");
        assert!(free_bytes(&dir.path().join("not/yet")).is_some_and(|b| b > 0));
        if Path::new("/proc/self").exists() {
            assert_eq!(free_bytes(Path::new("/proc/self/x")), None);
        }
    }
}
