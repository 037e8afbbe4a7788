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
        "{} is not a swarmshot dataset: {reason} (give the folder `swarmshot batch --out` wrote)",
        path.display()
    )]
    NotADataset {
        path: std::path::PathBuf,
        reason: String,
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
    #[error("--plots {}: inside the dataset's {folder}/, where its readers would take the histograms for frames; give a folder outside it (the default is DIR/stats-plots)", plots.display())]
    PlotsInside {
        plots: std::path::PathBuf,
        folder: &'static str,
    },
    #[error("--plots {}: exists and is not a folder; give a folder for the histograms (the default is DIR/stats-plots)", plots.display())]
    PlotsNotAFolder { plots: std::path::PathBuf },
    #[error(transparent)]
    Write(#[from] crate::write::OutputError),
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

/// How far (pixels) a box may reach past the image's edge and still be one
/// swarmshot wrote: its boxes are clipped to the image and rounded to 1e-6
/// px, so any more is a record it did not write.
const BOX_EDGE_SLACK_PX: f64 = 0.5;

/// Why `l` cannot be a label swarmshot wrote for a `w`×`h` image: its field
/// and the reason (a box not finite, inverted or outside the image; a
/// distance not finite or negative). A few comparisons, so the manifest's
/// parse stays the cost of reading it.
fn check_label(l: &ManifestLabel, w: u32, h: u32) -> Result<(), String> {
    let [x0, y0, x1, y1] = l.bbox_xyxy;
    let s = BOX_EDGE_SLACK_PX;
    let (w, h) = (f64::from(w), f64::from(h));
    // Written so that NaN fails each test.
    if !(x0 >= -s && y0 >= -s && x1 <= w + s && y1 <= h + s) {
        return Err(format!(
            "bbox_xyxy {:?} is not within the {w}×{h} image",
            l.bbox_xyxy
        ));
    }
    if !(x0 <= x1 && y0 <= y1) {
        return Err(format!(
            "bbox_xyxy {:?} is inverted (x0 > x1 or y0 > y1)",
            l.bbox_xyxy
        ));
    }
    if !(l.distance_m.is_finite() && l.distance_m >= 0.0) {
        return Err(format!(
            "distance_m {} is not a finite distance ≥ 0",
            l.distance_m
        ));
    }
    Ok(())
}

/// Why `frame` cannot be a record swarmshot wrote: a camera side outside
/// the sides a preset may have (1 to [`crate::preset::MAX_IMAGE_SIDE`] px), or a label [`check_label`] refuses, named by its field
/// (`drones[3].label.bbox_xyxy …`).
fn check_frame(frame: &ManifestFrame) -> Result<(), String> {
    let (w, h) = (frame.camera.width, frame.camera.height);
    let most = crate::preset::MAX_IMAGE_SIDE;
    if !((1..=most).contains(&w) && (1..=most).contains(&h)) {
        return Err(format!(
            "camera.width × camera.height is {w}×{h}: a preset's image sides are 1 to {most} px"
        ));
    }
    for (i, d) in frame.drones.iter().enumerate() {
        if let Some(l) = &d.label {
            check_label(l, w, h).map_err(|why| format!("drones[{i}].label.{why}"))?;
        }
    }
    for (i, c) in frame.confusers.iter().enumerate() {
        if let Some(l) = &c.label {
            check_label(l, w, h).map_err(|why| format!("confusers[{i}].label.{why}"))?;
        }
    }
    Ok(())
}

/// The fixed part of a frame's manifest record, bytes: camera, sequence,
/// sweep, environment, weather and camera-model draws, index, seed and
/// image path. A record holds under 4 KiB of these; 1 MiB leaves room for
/// every field added later. The strings among them come from the locked
/// preset and are counted apart ([`manifest_line_cap`]).
const FRAME_RECORD_BYTES: u64 = 1 << 20;

/// One drone's or confuser's record, bytes, without its model and class
/// names: about 45 numbers (each at most 24 bytes as the writer prints
/// them) and their keys, under 2 KiB; twice that for the fields added later.
const OBJECT_RECORD_BYTES: u64 = 4 << 10;

/// The most bytes the JSON escape of one byte of a string takes (`\u001f`).
const ESCAPE_BYTES: u64 = 6;

/// The longest `manifest.jsonl` line a dataset of `preset` (whose locked
/// text is `lock_bytes` long) can hold: [`FRAME_RECORD_BYTES`] plus every
/// string of the lock escaped, then for each object a frame may hold
/// (drones and confusers) [`OBJECT_RECORD_BYTES`] plus its longest model
/// name and class escaped. A model's name is its built-in name or its
/// file's stem and a class is the preset's, so both are bounded by the
/// lock's strings. A record never reaches it, so a longer line is refused
/// before it is held whole: memory stays bounded by what the preset allows.
fn manifest_line_cap(preset: &crate::preset::Preset, lock_bytes: u64) -> u64 {
    use crate::preset::ModelSource;
    let model = (preset.models.iter())
        .map(|m| match &m.source {
            ModelSource::Builtin(name) => name.len(),
            ModelSource::File(path) => path.as_os_str().len(),
        })
        .chain([32]) // the confusers' built-in model names
        .max()
        .unwrap_or(0);
    let class = (preset.models.iter().map(|m| m.class.len()))
        .chain(
            preset
                .confusers
                .iter()
                .filter_map(|c| Some(c.labelled_as.as_ref()?.len())),
        )
        .chain([32]) // the confusers' built-in kind names
        .max()
        .unwrap_or(0);
    let names = (model as u64).saturating_add(class as u64);
    let object = OBJECT_RECORD_BYTES.saturating_add(ESCAPE_BYTES.saturating_mul(names));
    FRAME_RECORD_BYTES
        .saturating_add(ESCAPE_BYTES.saturating_mul(lock_bytes))
        .saturating_add(preset.max_objects_per_frame().saturating_mul(object))
}

/// The locked preset of a dataset, read within the preset size limit
/// ([`crate::preset::MAX_PRESET_BYTES`]), and its length in bytes.
fn read_lock(lock_path: &std::path::Path) -> Result<(crate::preset::Preset, u64), StatsError> {
    let io = |source| StatsError::Io {
        path: lock_path.to_owned(),
        source,
    };
    let bytes =
        crate::input::read_input_file(lock_path, crate::preset::MAX_PRESET_BYTES).map_err(io)?;
    let len = bytes.len() as u64;
    let text = String::from_utf8(bytes).map_err(|e| {
        io(std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            format!("not UTF-8 text ({e})"),
        ))
    })?;
    let preset = crate::preset::Preset::from_ron(&text).map_err(|source| StatsError::BadLock {
        path: lock_path.to_owned(),
        source,
    })?;
    Ok((preset, len))
}

/// Read the next line of `reader` into `line` (cleared first), holding at
/// most `cap + 1` bytes of it: `Some(true)` for a line of at most `cap`
/// bytes before its newline, `Some(false)` for a longer one (its start
/// alone read), `None` at the end of the file.
fn read_capped_line(
    reader: &mut impl std::io::BufRead,
    line: &mut Vec<u8>,
    cap: u64,
) -> std::io::Result<Option<bool>> {
    use std::io::{BufRead, Read};
    line.clear();
    let n = reader.take(cap.saturating_add(1)).read_until(b'\n', line)?;
    if n == 0 {
        return Ok(None);
    }
    let body = line.strip_suffix(b"\n").unwrap_or(line);
    Ok(Some((body.len() as u64) <= cap))
}

/// The statistics of the dataset in `dir`, read from its manifest (every
/// frame's poses and boxes) with the writer's own counting; `labels_only`
/// and `boxes_from` from the folder and its locked preset. Refuses a
/// folder without `manifest.jsonl` and `preset.lock.ron` by name, a lock
/// larger than a preset may be, a manifest line longer than any record
/// of the preset can be ([`manifest_line_cap`]) and a record whose values
/// swarmshot cannot have written ([`check_frame`]), by line; the manifest
/// is read a line at a time.
pub fn read_dataset(dir: &std::path::Path) -> Result<DatasetStats, StatsError> {
    let lock_path = dir.join("preset.lock.ron");
    let manifest_path = dir.join(crate::write::formats::manifest::FILE);
    for (path, missing) in [
        (&manifest_path, "manifest.jsonl"),
        (&lock_path, "preset.lock.ron"),
    ] {
        let reason = match std::fs::metadata(path) {
            Err(_) => format!("it has no {missing}"),
            Ok(m) if !m.is_file() => {
                format!("its {missing} is not a regular file (a folder, a device or a pipe)")
            }
            Ok(_) => continue,
        };
        return Err(StatsError::NotADataset {
            path: dir.to_owned(),
            reason,
        });
    }
    let io = |source| StatsError::Io {
        path: manifest_path.clone(),
        source,
    };
    let (preset, lock_bytes) = read_lock(&lock_path)?;
    let cap = manifest_line_cap(&preset, lock_bytes);
    let (file, _) = crate::input::open_input_file(&manifest_path, u64::MAX).map_err(io)?;
    let mut stats = DatasetStats::default();
    let mut line = Vec::new();
    let mut reader = std::io::BufReader::with_capacity(1 << 20, file);
    let mut number = 0u64;
    while let Some(within) = read_capped_line(&mut reader, &mut line, cap).map_err(io)? {
        number += 1;
        let bad = |reason: String| StatsError::BadRecord {
            path: manifest_path.clone(),
            line: number,
            reason,
        };
        if !within {
            return Err(bad(format!(
                "the line is longer than {cap} bytes, the most a frame record of this preset can take ({} objects a frame)",
                preset.max_objects_per_frame()
            )));
        }
        if line.trim_ascii().is_empty() {
            continue;
        }
        // Checked as UTF-8 at once (vectorised), then parsed as text: faster than
        // serde_json checking each string as it goes.
        let text = std::str::from_utf8(&line).map_err(|e| bad(format!("not UTF-8 text ({e})")))?;
        let frame: ManifestFrame = serde_json::from_str(text).map_err(|e| bad(e.to_string()))?;
        check_frame(&frame).map_err(bad)?;
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

#[cfg(test)]
mod tests {
    use super::*;

    /// A frame record with one kept drone box.
    const RECORD: &str = r#"{"split":"train","camera":{"width":320,"height":240},"drones":[{"model":"quad_x","class":"uav","label":{"bbox_xyxy":[10.0,20.0,18.0,26.0],"status":"kept","truncated":false,"distance_m":8.5}}]}"#;

    /// A dataset folder with the default preset's lock and `manifest` as
    /// its manifest.
    fn dataset(manifest: &str) -> tempfile::TempDir {
        let dir = tempfile::tempdir().expect("temp dir");
        let lock = crate::preset::Preset::default().to_ron();
        std::fs::write(dir.path().join("preset.lock.ron"), lock).expect("lock");
        std::fs::write(dir.path().join("manifest.jsonl"), manifest).expect("manifest");
        dir
    }

    /// Set `name` in `dir` to a sparse file of `len` zero bytes (no disk used).
    fn sparse(dir: &std::path::Path, name: &str, len: u64) {
        let f = std::fs::File::create(dir.join(name)).expect("create");
        f.set_len(len).expect("set_len");
    }

    #[test]
    fn a_record_is_counted() {
        let dir = dataset(&format!("{RECORD}\n{RECORD}\n"));
        let stats = read_dataset(dir.path()).expect("stats");
        assert_eq!((stats.frames, stats.boxes), (2, 2));
    }

    #[test]
    fn a_manifest_line_longer_than_a_record_can_be_is_refused_by_line() {
        let dir = dataset(&format!("{RECORD}\n"));
        let preset = crate::preset::Preset::default();
        let cap = manifest_line_cap(&preset, preset.to_ron().len() as u64);
        assert!(cap < 64 << 20, "{cap}");
        // A first line of 64 MiB (zeros, no newline): refused after reading
        // the cap's bytes, not held whole.
        sparse(dir.path(), "manifest.jsonl", 64 << 20);
        let err = read_dataset(dir.path()).expect_err("refused").to_string();
        assert!(err.contains("manifest.jsonl line 1"), "{err}");
        assert!(err.contains(&format!("longer than {cap} bytes")), "{err}");
        // The same past a good line: named by its number.
        let mut text = format!("{RECORD}\n").into_bytes();
        text.extend(std::iter::repeat_n(b' ', cap as usize + 1));
        std::fs::write(dir.path().join("manifest.jsonl"), text).expect("manifest");
        let err = read_dataset(dir.path()).expect_err("refused").to_string();
        assert!(err.contains("manifest.jsonl line 2"), "{err}");
        assert!(err.contains("longer than"), "{err}");
    }

    #[test]
    fn values_swarmshot_cannot_write_are_refused_by_line_and_field() {
        let cases = [
            (
                "[10.0,10.0,5.0,5.0]",
                "8.5",
                "drones[0].label.bbox_xyxy",
                "inverted",
            ),
            (
                "[-1e308,-1e308,1e308,1e308]",
                "8.5",
                "drones[0].label.bbox_xyxy",
                "not within the 320×240 image",
            ),
            (
                "[10.0,20.0,18.0,26.0]",
                "-3.0",
                "drones[0].label.distance_m",
                "not a finite distance",
            ),
        ];
        for (bbox, distance, field, why) in cases {
            let bad = RECORD
                .replace("[10.0,20.0,18.0,26.0]", bbox)
                .replace("8.5", distance);
            let dir = dataset(&format!("{RECORD}\n{bad}\n"));
            let err = read_dataset(dir.path()).expect_err(bbox).to_string();
            assert!(err.contains("manifest.jsonl line 2"), "{err}");
            assert!(err.contains(field) && err.contains(why), "{err}");
        }
        let zero = RECORD.replace("\"width\":320,\"height\":240", "\"width\":0,\"height\":0");
        let dir = dataset(&format!("{zero}\n"));
        let err = read_dataset(dir.path()).expect_err("0×0").to_string();
        assert!(
            err.contains("line 1") && err.contains("camera.width × camera.height is 0×0"),
            "{err}"
        );
        let huge = RECORD.replace("\"width\":320", "\"width\":4294967295");
        let dir = dataset(&format!("{huge}\n"));
        let err = read_dataset(dir.path()).expect_err("huge").to_string();
        assert!(
            err.contains("is 4294967295×240: a preset's image sides are 1 to 16384 px"),
            "{err}"
        );
        // A box on the image's edges is one swarmshot writes.
        let edge = RECORD.replace("[10.0,20.0,18.0,26.0]", "[0.0,0.0,320.0,240.0]");
        read_dataset(dataset(&format!("{edge}\n")).path()).expect("edge box");
    }

    #[test]
    fn a_lock_larger_than_a_preset_may_be_is_refused_unread() {
        let dir = dataset(&format!("{RECORD}\n"));
        sparse(
            dir.path(),
            "preset.lock.ron",
            crate::preset::MAX_PRESET_BYTES + 1,
        );
        let err = read_dataset(dir.path()).expect_err("refused").to_string();
        assert!(err.contains("preset.lock.ron"), "{err}");
        assert!(
            err.contains(&format!("{}-byte limit", crate::preset::MAX_PRESET_BYTES)),
            "{err}"
        );
    }
}
