//! End to end: a tiny preset through `run_batch`, checked file by file and
//! pixel by pixel, twice for determinism.

use crate::common;

use std::path::Path;
use std::sync::atomic::AtomicBool;

use swarmshot::pipeline::{BatchOptions, FramePipeline, run_batch};
use swarmshot::preset::Preset;

fn run(preset: &Preset, dir: &Path) -> swarmshot::pipeline::BatchReport {
    run_with(preset, BatchOptions::new(dir))
}

fn run_with(preset: &Preset, options: BatchOptions) -> swarmshot::pipeline::BatchReport {
    let ctx = common::gpu();
    run_batch(
        &FramePipeline::new(preset.clone()).expect("pipeline"),
        &options,
        &ctx,
        &AtomicBool::new(false),
        |_| {},
    )
    .expect("batch runs")
}

fn read(path: &Path) -> Vec<u8> {
    std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

fn files_under(dir: &Path) -> Vec<std::path::PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_owned()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).expect("read_dir") {
            let p = e.expect("entry").path();
            if p.is_dir() {
                stack.push(p)
            } else {
                out.push(p)
            }
        }
    }
    out.sort();
    out
}

#[test]
fn tiny_batch_writes_a_consistent_dataset() {
    let mut preset = common::tiny_preset();
    preset.labels.min_box_px = 0.0; // keep every visible drone so "outside every box" means sky
    let dir = tempfile::tempdir().expect("tempdir");
    let report = run(&preset, dir.path());
    let frames = preset.frame_count();
    assert_eq!(report.stats.frames, frames);
    assert!(!report.cancelled);

    let manifest = std::fs::read_to_string(dir.path().join("manifest.jsonl")).expect("manifest");
    let lines: Vec<serde_json::Value> = manifest
        .lines()
        .map(|l| serde_json::from_str(l).expect("manifest line is JSON"))
        .collect();
    assert_eq!(lines.len() as u64, frames);

    let maker = FramePipeline::new(preset.clone()).expect("models");
    let ctx = common::gpu();
    let mut renderer = maker.renderer(&ctx);
    let mut boxes_seen = 0;
    for (i, line) in lines.iter().enumerate() {
        assert_eq!(line["index"], i as u64);
        let split = line["split"].as_str().expect("split");
        let stem = format!("{i:08}");
        let image_path = dir.path().join(format!("images/{split}/{stem}.png"));
        let label_path = dir.path().join(format!("labels/{split}/{stem}.txt"));
        let img = image::open(&image_path).expect("image decodes").to_rgba8();
        assert_eq!(img.dimensions(), (320, 180));
        let text = std::fs::read_to_string(&label_path).expect("label file");
        let mut boxes = Vec::new();
        for row in text.lines() {
            let v: Vec<f64> = row
                .split_whitespace()
                .map(|t| t.parse().expect("number"))
                .collect();
            assert_eq!(v.len(), 5, "{row}");
            assert_eq!(v[0], 0.0);
            assert!(v[1..].iter().all(|x| (0.0..=1.0).contains(x)), "{row}");
            let (cx, cy, w, h) = (v[1] * 320.0, v[2] * 180.0, v[3] * 320.0, v[4] * 180.0);
            boxes.push((cx - w / 2.0, cy - h / 2.0, cx + w / 2.0, cy + h / 2.0));
        }
        boxes_seen += boxes.len();
        // The same frame without drones: pixels outside every box must be this sky.
        let (mut scene, _) = maker.plan(i as u64).expect("frame");
        scene.drones.clear();
        let sky = renderer
            .render_rgba(&scene, preset.render.msaa)
            .expect("render");
        let px = |x: u32, y: u32| -> (&[u8], &[u8]) {
            let o = ((y * 320 + x) * 4) as usize;
            (&img.as_raw()[o..o + 3], &sky[o..o + 3])
        };
        for &(x0, y0, x1, y1) in &boxes {
            let differs = (y0.floor() as u32..(y1.ceil() as u32).min(180))
                .flat_map(|y| (x0.floor() as u32..(x1.ceil() as u32).min(320)).map(move |x| (x, y)))
                .any(|(x, y)| px(x, y).0 != px(x, y).1);
            assert!(
                differs,
                "frame {i}: box {x0:.1},{y0:.1},{x1:.1},{y1:.1} holds no drone pixel"
            );
        }
        for y in 0..180u32 {
            for x in 0..320u32 {
                let (fx, fy) = (f64::from(x) + 0.5, f64::from(y) + 0.5);
                let near_box = boxes.iter().any(|&(x0, y0, x1, y1)| {
                    fx > x0 - 2.0 && fx < x1 + 2.0 && fy > y0 - 2.0 && fy < y1 + 2.0
                });
                if !near_box {
                    assert_eq!(
                        px(x, y).0,
                        px(x, y).1,
                        "frame {i}: pixel ({x},{y}) outside every box is not sky"
                    );
                }
            }
        }
    }
    assert!(
        boxes_seen as u64 >= frames,
        "expected drones in view, got {boxes_seen} boxes"
    );

    // COCO: ids unique, boxes inside the image, every frame once.
    let mut images = 0;
    let mut ann_ids = std::collections::HashSet::new();
    for split in ["train", "val", "test"] {
        let coco: serde_json::Value = serde_json::from_slice(&read(
            &dir.path()
                .join(format!("annotations/instances_{split}.json")),
        ))
        .expect("COCO JSON");
        images += coco["images"].as_array().expect("images").len();
        assert_eq!(coco["categories"][0]["id"], 1);
        for a in coco["annotations"].as_array().expect("annotations") {
            assert!(ann_ids.insert((split, a["id"].as_u64().expect("id"))));
            let b: Vec<f64> = a["bbox"]
                .as_array()
                .expect("bbox")
                .iter()
                .map(|v| v.as_f64().expect("f64"))
                .collect();
            assert!(
                b[0] >= 0.0
                    && b[1] >= 0.0
                    && b[0] + b[2] <= 320.0 + 1e-6
                    && b[1] + b[3] <= 180.0 + 1e-6,
                "{b:?}"
            );
            assert_eq!(a["iscrowd"], 0);
            assert!((a["area"].as_f64().expect("area") - b[2] * b[3]).abs() < 1e-3);
        }
    }
    assert_eq!(images as u64, frames);

    let yaml = std::fs::read_to_string(dir.path().join("data.yaml")).expect("data.yaml");
    // No `path`: Ultralytics takes the YAML's folder as the root (relocatable, tests/suite/scale.rs).
    assert!(!yaml.lines().any(|l| l.starts_with("path:")), "{yaml}");
    assert!(yaml.contains("train: images/train") && yaml.contains("0: \"uav\""));
    let lock = Preset::from_ron(
        &std::fs::read_to_string(dir.path().join("preset.lock.ron")).expect("lock"),
    )
    .expect("lock parses");
    assert_eq!(lock, preset);
}

#[test]
fn same_preset_gives_byte_identical_files_with_any_number_of_makers() {
    let preset = common::tiny_preset();
    let a = tempfile::tempdir().expect("tempdir");
    let b = tempfile::tempdir().expect("tempdir");
    run(&preset, a.path());
    // Three frames in flight and two encoders: frames finish out of order.
    let mut options = BatchOptions::new(b.path());
    options.makers = 3;
    options.encoder_threads = 2;
    run_with(&preset, options);
    let fa = files_under(a.path());
    let fb = files_under(b.path());
    assert_eq!(fa.len(), fb.len());
    let mut compared = 0;
    for (x, y) in fa.iter().zip(&fb) {
        let rel = x.strip_prefix(a.path()).expect("prefix");
        assert_eq!(rel, y.strip_prefix(b.path()).expect("prefix"));
        let name = rel.to_string_lossy();
        if name.ends_with(".txt")
            || name.ends_with(".jsonl")
            || name.starts_with("annotations")
            || name.starts_with("images")
            || name.ends_with(".ron")
        {
            assert!(read(x) == read(y), "{name} differs between runs");
            compared += 1;
        }
    }
    assert!(compared as u64 > 2 * preset.frame_count());

    // Any frame made alone has the same labels as in the batch.
    let maker = FramePipeline::new(preset.clone()).expect("models");
    let ctx = common::gpu();
    let mut renderer = maker.renderer(&ctx);
    let frame = maker.make(&mut renderer, 5).expect("single frame");
    let (scene, labels) = (frame.scene, frame.labels);
    let manifest = std::fs::read_to_string(a.path().join("manifest.jsonl")).expect("manifest");
    let line = manifest.lines().nth(5).expect("line 5");
    let names = maker.model_names();
    let (classes, _) = preset.classes();
    let image = format!("images/{}/{:08}.png", scene.split.as_str(), 5);
    assert_eq!(
        swarmshot::write::manifest_line(&scene, &labels, &image, names, &classes),
        line
    );
}

#[test]
fn refuses_foreign_non_empty_folder_unless_overwrite() {
    let preset = common::tiny_preset();
    let dir = tempfile::tempdir().expect("tempdir");
    std::fs::write(dir.path().join("notes.txt"), "mine").expect("write");
    let ctx = common::gpu();
    let mut opts = BatchOptions::new(dir.path());
    opts.limit = Some(2);
    let err = run_batch(
        &FramePipeline::new(preset.clone()).expect("pipeline"),
        &opts,
        &ctx,
        &AtomicBool::new(false),
        |_| {},
    )
    .expect_err("must refuse");
    assert!(err.to_string().contains("not empty"), "{err}");
    assert!(!dir.path().join("manifest.jsonl").exists());

    opts.overwrite = true;
    run_batch(
        &FramePipeline::new(preset.clone()).expect("pipeline"),
        &opts,
        &ctx,
        &AtomicBool::new(false),
        |_| {},
    )
    .expect("overwrite works");
    assert_eq!(
        std::fs::read_to_string(dir.path().join("notes.txt")).expect("user file kept"),
        "mine"
    );
    // Re-running the same preset into its own output needs no flag.
    opts.overwrite = false;
    let report = run_batch(
        &FramePipeline::new(preset.clone()).expect("pipeline"),
        &opts,
        &ctx,
        &AtomicBool::new(false),
        |_| {},
    )
    .expect("own output");
    assert_eq!(report.stats.frames, 2);
    let mut other = preset.clone();
    other.seed += 1;
    assert!(
        run_batch(
            &FramePipeline::new(other.clone()).expect("pipeline"),
            &opts,
            &ctx,
            &AtomicBool::new(false),
            |_| {}
        )
        .is_err()
    );
}

#[test]
fn cancel_leaves_every_image_with_its_label() {
    let preset = common::tiny_preset();
    let dir = tempfile::tempdir().expect("tempdir");
    let ctx = common::gpu();
    let cancel = AtomicBool::new(false);
    let report = run_batch(
        &FramePipeline::new(preset.clone()).expect("pipeline"),
        &BatchOptions::new(dir.path()),
        &ctx,
        &cancel,
        |p| {
            if p.done >= 3 {
                cancel.store(true, std::sync::atomic::Ordering::Relaxed);
            }
        },
    )
    .expect("batch");
    assert!(report.cancelled);
    assert!(report.stats.frames >= 3 && report.stats.frames < preset.frame_count());
    let images: Vec<_> = files_under(&dir.path().join("images"));
    assert_eq!(images.len() as u64, report.stats.frames);
    for img in images {
        let rel = img
            .strip_prefix(dir.path().join("images"))
            .expect("prefix")
            .with_extension("txt");
        assert!(dir.path().join("labels").join(rel).exists());
    }
    let manifest = std::fs::read_to_string(dir.path().join("manifest.jsonl")).expect("manifest");
    assert_eq!(manifest.lines().count() as u64, report.stats.frames);
}
