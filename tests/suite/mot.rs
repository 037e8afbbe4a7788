//! Sequence output end to end (renders on lavapipe): the MOTChallenge layout
//! (`img1/000001.ext` hard links, 1-based `gt/gt.txt`, standard
//! `seqinfo.ini`, sequence maps) read by a reader that follows TrackEval's
//! `MotChallenge2DBox` rules (written here from its source), track ids
//! stable, boxes equal to the YOLO labels, COCO video fields, whole
//! sequences per split, and the byte-identical resume.

use crate::common;

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;
use std::sync::atomic::AtomicBool;

use swarmshot::pipeline::{BatchOptions, FramePipeline, run_batch};
use swarmshot::preset::{Placement, Preset};

/// The shared sequence preset with five drones a wedge, banking as they turn.
fn sequence_preset() -> Preset {
    let mut p = common::sequence_preset();
    if let Placement::Formation(f) = &mut p.placement {
        f.count = 5;
    }
    if let Some(seq) = &mut p.sequence {
        seq.motion.bank_deg = 15.0;
    }
    p
}

fn run(preset: &Preset, dir: &Path) {
    let ctx = common::gpu();
    run_batch(
        &FramePipeline::new(preset.clone()).expect("pipeline"),
        &BatchOptions::new(dir),
        &ctx,
        &AtomicBool::new(false),
        |_| {},
    )
    .expect("batch runs");
}

/// One MOTChallenge ground-truth row: `frame, id, bb_left, bb_top,
/// bb_width, bb_height, conf, class, visibility` (9 comma-separated values;
/// frame and id positive integers, frames counted from 1).
#[derive(Debug, Clone, PartialEq)]
struct GtRow {
    frame: u32,
    id: u32,
    bbox: [f64; 4],
    conf: f64,
    class: i32,
    visibility: f64,
}

fn parse_gt(text: &str) -> Vec<GtRow> {
    text.lines()
        .filter(|l| !l.trim().is_empty())
        .map(|line| {
            let f: Vec<&str> = line.split(',').map(str::trim).collect();
            assert_eq!(f.len(), 9, "gt.txt rows have 9 values: {line}");
            let num = |i: usize| -> f64 { f[i].parse().unwrap_or_else(|_| panic!("{line}")) };
            let row = GtRow {
                frame: f[0].parse().expect("frame is an integer"),
                id: f[1].parse().expect("id is an integer"),
                bbox: [num(2), num(3), num(4), num(5)],
                conf: num(6),
                class: f[7].parse().expect("class is an integer"),
                visibility: num(8),
            };
            assert!(row.frame >= 1 && row.id >= 1, "{line}");
            assert!((0.0..=1.0).contains(&row.visibility), "{line}");
            row
        })
        .collect()
}

/// `seqinfo.ini`: a `[Sequence]` section of `key=value` lines, the
/// MOTChallenge keys only (no comments, no other keys).
fn parse_ini(text: &str) -> BTreeMap<String, String> {
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some("[Sequence]"));
    let ini: BTreeMap<String, String> = lines
        .map(|l| {
            l.split_once('=')
                .unwrap_or_else(|| panic!("not key=value: {l}"))
        })
        .map(|(k, v)| (k.to_owned(), v.to_owned()))
        .collect();
    let keys: Vec<&str> = ini.keys().map(String::as_str).collect();
    let standard = [
        "frameRate",
        "imDir",
        "imExt",
        "imHeight",
        "imWidth",
        "name",
        "seqLength",
    ];
    assert_eq!(keys, standard, "seqinfo.ini holds the standard keys only");
    ini
}

/// What TrackEval's `MotChallenge2DBox` reads of one split, following its
/// rules (trackeval/datasets/mot_challenge_2d_box.py, with `SKIP_SPLIT_FOL`
/// and `SEQMAP_FILE` set): the sequence map's rows after the header name
/// the sequences; each sequence's `seqinfo.ini` gives `seqLength`; its
/// `gt/gt.txt` rows must lie on time steps 1..=seqLength (an extra time
/// step is an error), have at least 8 columns (the 8th the class), and ids
/// unique within a time step. Returns each sequence's rows per time step.
fn trackeval_read(gt_folder: &Path, seqmap: &Path) -> BTreeMap<String, Vec<Vec<GtRow>>> {
    let map = std::fs::read_to_string(seqmap).expect("the seqmap TrackEval needs");
    let mut out = BTreeMap::new();
    for name in map.lines().skip(1).filter(|l| !l.is_empty()) {
        let seq = gt_folder.join(name);
        let ini = parse_ini(&std::fs::read_to_string(seq.join("seqinfo.ini")).expect("ini"));
        let len: usize = ini["seqLength"].parse().expect("seqLength");
        let rows = parse_gt(&std::fs::read_to_string(seq.join("gt/gt.txt")).expect("gt"));
        let mut steps = vec![Vec::new(); len];
        for row in rows {
            assert!(
                (1..=len).contains(&(row.frame as usize)),
                "{name}: time step {}",
                row.frame
            );
            steps[row.frame as usize - 1].push(row);
        }
        for (t, rows) in steps.iter().enumerate() {
            let ids: BTreeSet<u32> = rows.iter().map(|r| r.id).collect();
            assert_eq!(
                ids.len(),
                rows.len(),
                "{name}: ids repeat at time step {}",
                t + 1
            );
        }
        out.insert(name.to_owned(), steps);
    }
    out
}

/// The inode of `path` (hard links share it).
fn inode(path: &Path) -> u64 {
    use std::os::unix::fs::MetadataExt;
    std::fs::symlink_metadata(path)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
        .ino()
}

#[test]
fn sequences_write_mot_ground_truth_matching_the_yolo_labels() {
    let p = sequence_preset();
    p.validate().expect("valid");
    let len = 5u64;
    assert_eq!(p.frame_count(), 3 * len);
    let dir = tempfile::tempdir().expect("tempdir");
    run(&p, dir.path());
    let root = dir.path();
    let manifest: Vec<serde_json::Value> = std::fs::read_to_string(root.join("manifest.jsonl"))
        .expect("manifest")
        .lines()
        .map(|l| serde_json::from_str(l).expect("json"))
        .collect();
    let mut rows_seen = 0;
    for seq in 0..3u64 {
        let frames = &manifest[(seq * len) as usize..((seq + 1) * len) as usize];
        let split = frames[0]["split"].as_str().expect("split").to_owned();
        for f in frames {
            assert_eq!(f["split"], split.as_str(), "a sequence stays in one split");
            assert_eq!(f["sequence"]["id"], seq);
        }
        let name = format!("seq-{seq:08}");
        let seq_dir = root.join(format!("mot/{split}/{name}"));
        let ini = parse_ini(&std::fs::read_to_string(seq_dir.join("seqinfo.ini")).expect("ini"));
        assert_eq!(ini["seqLength"], "5");
        assert_eq!(ini["frameRate"], "10");
        assert_eq!(ini["imWidth"], "320");
        assert_eq!(ini["imHeight"], "180");
        assert_eq!(ini["name"], name);
        assert_eq!(ini["imDir"], "img1");
        let read = trackeval_read(
            &root.join(format!("mot/{split}")),
            &root.join(format!("mot/seqmaps/{split}.txt")),
        );
        assert!(read.contains_key(&name), "the seqmap names {name}");
        // img1: frame t of the sequence is the dataset's image, hard-linked.
        let img1: Vec<String> = std::fs::read_dir(seq_dir.join(&ini["imDir"]))
            .expect("img1")
            .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
            .collect();
        assert_eq!(img1.len(), len as usize, "{img1:?}");
        for (t, f) in frames.iter().enumerate() {
            let image = root.join(f["image"].as_str().expect("image"));
            let ext = &ini["imExt"];
            let link = seq_dir.join(format!("img1/{:06}{ext}", t + 1));
            assert_eq!(
                inode(&link),
                inode(&image),
                "{} is the frame's image",
                link.display()
            );
        }
        let rows: Vec<GtRow> = read[&name].iter().flatten().cloned().collect();
        // Frame order, then id order; each (frame, id) once.
        let keys: Vec<(u32, u32)> = rows.iter().map(|r| (r.frame, r.id)).collect();
        let mut sorted = keys.clone();
        sorted.sort();
        sorted.dedup();
        assert_eq!(keys, sorted);
        // Every id is one drone through the sequence: its track id in the manifest.
        let ids: BTreeSet<u32> = rows.iter().map(|r| r.id).collect();
        assert!(ids.len() >= 3, "most of the wedge is in view: {ids:?}");
        for (t, f) in frames.iter().enumerate() {
            let yolo_rel = f["image"]
                .as_str()
                .expect("image")
                .replace("images/", "labels/")
                .replace(".png", ".txt");
            let yolo = std::fs::read_to_string(root.join(yolo_rel)).expect("yolo");
            let yolo: Vec<[f64; 4]> = yolo
                .lines()
                .map(|l| {
                    let v: Vec<f64> = l
                        .split(' ')
                        .skip(1)
                        .map(|x| x.parse().expect("num"))
                        .collect();
                    let (w, h) = (320.0, 180.0);
                    [
                        (v[0] - v[2] / 2.0) * w,
                        (v[1] - v[3] / 2.0) * h,
                        v[2] * w,
                        v[3] * h,
                    ]
                })
                .collect();
            let in_frame: Vec<&GtRow> = rows.iter().filter(|r| r.frame == t as u32 + 1).collect();
            assert_eq!(
                in_frame.len(),
                yolo.len(),
                "frame {t}: gt rows vs YOLO lines"
            );
            let drones = f["drones"].as_array().expect("drones");
            for (row, y) in in_frame.iter().zip(&yolo) {
                // 1-based pixels: the box's corner moves by one pixel.
                let corner = [1.0, 1.0, 0.0, 0.0];
                for ((g, v), c) in row.bbox.iter().zip(y).zip(corner) {
                    let g = g - c;
                    assert!(
                        (g - v).abs() < 1e-3,
                        "frame {t} id {}: gt {:?} vs YOLO {y:?}",
                        row.id,
                        row.bbox
                    );
                }
                assert_eq!(row.conf, 1.0);
                assert_eq!(row.class, 1);
                let d = &drones[row.id as usize - 1];
                assert_eq!(d["track_id"], row.id);
                let xyxy = d["label"]["bbox_xyxy"].as_array().expect("box");
                assert!((xyxy[0].as_f64().expect("x0") + 1.0 - row.bbox[0]).abs() < 1e-5);
            }
            rows_seen += in_frame.len();
        }
    }
    assert!(rows_seen > 20);
    // COCO: video fields as TAO / COCO-VID readers expect.
    let mut videos = 0;
    for split in ["train", "val", "test"] {
        let coco: serde_json::Value = serde_json::from_str(
            &std::fs::read_to_string(root.join(format!("annotations/instances_{split}.json")))
                .expect("coco"),
        )
        .expect("json");
        let vids = coco["videos"].as_array().expect("videos list");
        videos += vids.len();
        for img in coco["images"].as_array().expect("images") {
            let v = img["video_id"].as_u64().expect("video_id");
            assert!(vids.iter().any(|x| x["id"] == v));
            assert!(img["frame_id"].as_u64().expect("frame_id") < len);
        }
        for a in coco["annotations"].as_array().expect("annotations") {
            let v = a["video_id"].as_u64().expect("video_id");
            let track = a["track_id"].as_u64().expect("track_id");
            assert_eq!(track / 1_000_000, v);
        }
    }
    assert_eq!(videos, 3);
}

#[test]
fn a_sequence_batch_is_deterministic_and_resumes_byte_identically() {
    let p = sequence_preset();
    let a = tempfile::tempdir().expect("tempdir");
    let b = tempfile::tempdir().expect("tempdir");
    run(&p, a.path());
    // Half the frames (mid-sequence), then the rest by resuming.
    let ctx = common::gpu();
    let pipeline = FramePipeline::new(p.clone()).expect("pipeline");
    // Cancel early (the maker runs a few frames ahead of the writer, so the
    // run stops somewhere in the first two of three sequences), then resume.
    let cancel = AtomicBool::new(false);
    let report = run_batch(
        &pipeline,
        &BatchOptions::new(b.path()),
        &ctx,
        &cancel,
        |p| {
            if p.done >= 2 {
                cancel.store(true, std::sync::atomic::Ordering::SeqCst);
            }
        },
    )
    .expect("first part");
    assert!(report.cancelled);
    let mut opts = BatchOptions::new(b.path());
    opts.resume = true;
    run_batch(&pipeline, &opts, &ctx, &AtomicBool::new(false), |_| {}).expect("resume");
    for rel in [
        "manifest.jsonl",
        "annotations/instances_train.json",
        "annotations/instances_val.json",
        "annotations/instances_test.json",
    ] {
        assert_eq!(
            std::fs::read(a.path().join(rel)).expect(rel),
            std::fs::read(b.path().join(rel)).expect(rel),
            "{rel}"
        );
    }
    let manifest = std::fs::read_to_string(a.path().join("manifest.jsonl")).expect("manifest");
    for line in manifest.lines() {
        let v: serde_json::Value = serde_json::from_str(line).expect("json");
        let seq = v["sequence"]["id"].as_u64().expect("id");
        let split = v["split"].as_str().expect("split");
        let rel = format!("mot/{split}/seq-{seq:08}/gt/gt.txt");
        assert_eq!(
            std::fs::read(a.path().join(&rel)).expect("gt a"),
            std::fs::read(b.path().join(&rel)).expect("gt b"),
            "{rel}"
        );
    }
}
