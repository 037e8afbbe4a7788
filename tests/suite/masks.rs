//! Masks and maps (`output.masks`, issue 22): COCO RLE read back with
//! pycocotools' rules (a decoder written here), instance PNGs and YOLO
//! segmentation labels checked against the manifest's visible pixels and
//! boxes, through the camera model too; masks off adds nothing; deterministic.

use crate::common;

use std::collections::BTreeMap;
use std::path::Path;
use std::sync::atomic::AtomicBool;

use serde_json::Value;
use swarmshot::pipeline::{BatchOptions, FramePipeline, run_batch};
use swarmshot::preset::camera_model::{CameraModel, Psf};
use swarmshot::preset::masks::MaskOutputs;
use swarmshot::preset::{BoxMethod, FilteredDrones, LabelFormat, Placement, Preset, Volume};

const ALL: MaskOutputs = MaskOutputs {
    coco_rle: true,
    yolo_seg: true,
    instance_png: true,
    depth: true,
    depth_unit_mm: 1,
    flow: false,
};

/// The tiny preset, crowded (drones hide each other), 4× MSAA (pixels shared
/// at edges), every drone in COCO (crowd instead of dropped).
fn preset(masks: MaskOutputs) -> Preset {
    let mut p = common::tiny_preset();
    p.placement = Placement::Randomized {
        count: (8, 14),
        count_distribution: Default::default(),
        volume: Volume::Box {
            size_m: (3.0, 2.0, 3.0),
        },
        min_separation_m: 0.36,
    };
    p.render.msaa = 4;
    p.labels.box_method = BoxMethod::Visible;
    p.labels.filtered = FilteredDrones::Crowd;
    p.output.label_formats = vec![LabelFormat::Yolo, LabelFormat::Coco];
    p.output.masks = masks;
    p
}

fn run(preset: &Preset, dir: &Path, frames: u64, encoder_threads: usize) {
    let mut options = BatchOptions::new(dir);
    options.limit = Some(frames);
    options.encoder_threads = encoder_threads;
    run_batch(
        &FramePipeline::new(preset.clone()).expect("pipeline"),
        &options,
        &common::gpu(),
        &AtomicBool::new(false),
        |_| {},
    )
    .expect("batch runs");
}

fn json(path: &Path) -> Value {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    serde_json::from_str(&text).expect("valid JSON")
}

/// pycocotools' `rleFrString` (maskApi.c), written from its C source:
/// 5-bit groups offset by 48, 0x20 = more groups follow, 0x10 in the last
/// group = negative, and from the fourth count on a difference from the
/// count two before.
fn rle_from_string(s: &str) -> Vec<u64> {
    let b = s.as_bytes();
    let mut counts: Vec<i64> = Vec::new();
    let mut p = 0;
    while p < b.len() {
        let (mut x, mut k, mut more) = (0i64, 0, true);
        while more {
            let c = i64::from(b[p]) - 48;
            x |= (c & 0x1f) << (5 * k);
            more = c & 0x20 != 0;
            p += 1;
            k += 1;
            if !more && c & 0x10 != 0 {
                x |= -1i64 << (5 * k);
            }
        }
        if counts.len() > 2 {
            x += counts[counts.len() - 2];
        }
        counts.push(x);
    }
    counts
        .into_iter()
        .map(|c| u64::try_from(c).expect("count ≥ 0"))
        .collect()
}

/// The mask's pixels (x, y): runs alternate background/object from a
/// background run, over the image in column-major order (pycocotools' `rleDecode`).
fn rle_pixels(counts: &[u64], height: u64, width: u64) -> Vec<(u64, u64)> {
    assert_eq!(
        counts.iter().sum::<u64>(),
        height * width,
        "runs cover the image"
    );
    let mut out = Vec::new();
    let mut at = 0;
    for (i, &c) in counts.iter().enumerate() {
        if i % 2 == 1 {
            out.extend((at..at + c).map(|k| (k / height, k % height)));
        }
        at += c;
    }
    out
}

fn bbox_of(pixels: &[(u64, u64)]) -> Option<[f64; 4]> {
    let x0 = pixels.iter().map(|p| p.0).min()?;
    let y0 = pixels.iter().map(|p| p.1).min()?;
    let x1 = pixels.iter().map(|p| p.0 + 1).max()?;
    let y1 = pixels.iter().map(|p| p.1 + 1).max()?;
    Some([x0 as f64, y0 as f64, x1 as f64, y1 as f64])
}

/// Per frame index: the manifest's drones (each its `label`, or null).
fn manifest(dir: &Path) -> BTreeMap<u64, Vec<Value>> {
    std::fs::read_to_string(dir.join("manifest.jsonl"))
        .expect("manifest")
        .lines()
        .map(|l| {
            let v: Value = serde_json::from_str(l).expect("manifest line");
            let drones = v["drones"].as_array().expect("drones").iter();
            let labels = drones.map(|d| d["label"].clone()).collect();
            (v["index"].as_u64().expect("index"), labels)
        })
        .collect()
}

/// Each COCO annotation as (frame index, the drone's place in the
/// manifest, the annotation): annotations follow the manifest's labelled
/// drones (kept or crowd) in order.
fn annotations(dir: &Path, man: &BTreeMap<u64, Vec<Value>>) -> Vec<(u64, usize, Value)> {
    let mut per_image: BTreeMap<u64, Vec<Value>> = BTreeMap::new();
    for split in ["train", "val", "test"] {
        let coco = json(&dir.join(format!("annotations/instances_{split}.json")));
        for a in coco["annotations"].as_array().expect("annotations") {
            let image = a["image_id"].as_u64().expect("image_id") - 1;
            per_image.entry(image).or_default().push(a.clone());
        }
    }
    let mut out = Vec::new();
    for (index, anns) in per_image {
        let drones: Vec<usize> = (man[&index].iter().enumerate())
            .filter(|(_, l)| matches!(l["status"].as_str(), Some("kept" | "crowd")))
            .map(|(i, _)| i)
            .collect();
        assert_eq!(drones.len(), anns.len(), "frame {index}");
        out.extend(drones.into_iter().zip(anns).map(|(d, a)| (index, d, a)));
    }
    out
}

fn xyxy(v: &Value) -> Option<[f64; 4]> {
    let a = v.as_array()?;
    Some([0, 1, 2, 3].map(|i| a[i].as_f64().expect("number")))
}

/// Each annotated drone's mask (decoded from its RLE), per frame.
type Masks = BTreeMap<(u64, usize), Vec<(u64, u64)>>;

fn check_rle_against_manifest(dir: &Path) -> Masks {
    let man = manifest(dir);
    let mut masks = Masks::new();
    let anns = annotations(dir, &man);
    assert!(anns.len() >= 20, "{} annotations", anns.len());
    for (index, drone, a) in anns {
        let label = &man[&index][drone];
        let seg = &a["segmentation"];
        let size = seg["size"].as_array().expect("size");
        let (h, w) = (
            size[0].as_u64().expect("present"),
            size[1].as_u64().expect("present"),
        );
        assert_eq!((w, h), (320, 180), "size is [height, width]");
        let pixels = rle_pixels(
            &rle_from_string(seg["counts"].as_str().expect("counts")),
            h,
            w,
        );
        let visible = label["visible_pixels"].as_u64().expect("visible_pixels");
        assert_eq!(pixels.len() as u64, visible, "frame {index} drone {drone}");
        assert_eq!(a["area"].as_u64(), Some(visible), "area = visible pixels");
        assert_eq!(
            bbox_of(&pixels),
            xyxy(&label["visible_xyxy"]),
            "frame {index} drone {drone}"
        );
        masks.insert((index, drone), pixels);
    }
    masks
}

#[test]
fn rle_masks_are_the_visible_pixels_and_instance_ids_match_the_manifest() {
    let dir = tempfile::tempdir().expect("tempdir");
    run(&preset(ALL), dir.path(), 6, 0);
    let masks = check_rle_against_manifest(dir.path());
    let man = manifest(dir.path());
    // Which masks share a pixel with another (MSAA edges: a pixel counts for each drone it shows).
    let mut owners: BTreeMap<(u64, (u64, u64)), Vec<usize>> = BTreeMap::new();
    for ((index, drone), pixels) in &masks {
        for p in pixels {
            owners.entry((*index, *p)).or_default().push(*drone);
        }
    }
    let mut alone_checked = 0;
    for (&index, labels) in &man {
        let split = ["train", "val", "test"]
            .into_iter()
            .find(|s| {
                dir.path()
                    .join(format!("masks/{s}/{index:08}.png"))
                    .exists()
            })
            .expect("an instance PNG per frame");
        let png = image::open(dir.path().join(format!("masks/{split}/{index:08}.png")))
            .expect("PNG decodes");
        let png = match png {
            image::DynamicImage::ImageLuma16(g) => g,
            other => panic!("instance PNG is {:?}, not 16-bit grey", other.color()),
        };
        assert_eq!(png.dimensions(), (320, 180));
        let mut by_id: BTreeMap<usize, Vec<(u64, u64)>> = BTreeMap::new();
        for (x, y, p) in png.enumerate_pixels() {
            let (x, y) = (u64::from(x), u64::from(y));
            let shown = owners.get(&(index, (x, y)));
            if p.0[0] == 0 {
                assert!(
                    shown.is_none(),
                    "frame {index} ({x}, {y}): a drone's pixel is 0"
                );
                continue;
            }
            let drone = usize::from(p.0[0]) - 1;
            assert!(
                drone < labels.len(),
                "id {} past the manifest's drones",
                p.0[0]
            );
            assert!(
                shown.is_some_and(|o| o.contains(&drone)),
                "frame {index} ({x}, {y}): id {} where that drone's mask is not",
                p.0[0]
            );
            by_id.entry(drone).or_default().push((x, y));
        }
        for (drone, pixels) in &by_id {
            let mask = &masks[&(index, *drone)];
            let shares = mask.iter().any(|p| owners[&(index, *p)].len() > 1);
            if !shares {
                // A drone that shares no pixel: its id covers exactly its visible pixels.
                let label = &labels[*drone];
                assert_eq!(
                    pixels.len() as u64,
                    label["visible_pixels"].as_u64().expect("present")
                );
                assert_eq!(bbox_of(pixels), xyxy(&label["visible_xyxy"]));
                alone_checked += 1;
            }
        }
    }
    assert!(alone_checked >= 10, "{alone_checked} drones checked whole");
}

fn grey16(path: &Path) -> image::ImageBuffer<image::Luma<u16>, Vec<u16>> {
    match image::open(path) {
        Ok(image::DynamicImage::ImageLuma16(g)) => g,
        Ok(other) => panic!("{} is {:?}, not 16-bit grey", path.display(), other.color()),
        Err(e) => panic!("{}: {e}", path.display()),
    }
}

/// A drone centre's camera-frame depth z from the manifest's R, t and position.
fn centre_z(camera: &Value, position: &Value) -> f64 {
    let r = &camera["R"][2];
    let t = camera["t"][2].as_f64().expect("t");
    (0..3)
        .map(|k| r[k].as_f64().expect("R") * position[k].as_f64().expect("position"))
        .sum::<f64>()
        + t
}

#[test]
fn depth_covers_the_instance_pixels_and_follows_each_drones_distance() {
    let dir = tempfile::tempdir().expect("tempdir");
    run(&preset(ALL), dir.path(), 6, 0);
    let mut drones_checked = 0;
    let mut pairs_ordered = 0;
    // Drones whose depths vary over their pixels: the surface, not one number per drone.
    let mut surfaces = 0;
    for line in std::fs::read_to_string(dir.path().join("manifest.jsonl"))
        .expect("manifest")
        .lines()
    {
        let frame: Value = serde_json::from_str(line).expect("line");
        let index = frame["index"].as_u64().expect("index");
        let split = frame["split"].as_str().expect("split");
        let ids = grey16(&dir.path().join(format!("masks/{split}/{index:08}.png")));
        let depth = grey16(&dir.path().join(format!("depth/{split}/{index:08}.png")));
        let mut per_drone: BTreeMap<usize, Vec<u16>> = BTreeMap::new();
        for (id, z) in ids.as_raw().iter().zip(depth.as_raw()) {
            assert_eq!(
                *id == 0,
                *z == 0,
                "frame {index}: depth exactly where ids are"
            );
            if *id > 0 {
                per_drone.entry(usize::from(*id) - 1).or_default().push(*z);
            }
        }
        let drones = frame["drones"].as_array().expect("drones");
        // (centre z, median depth) in millimetres, per drone shown.
        let mut seen: Vec<(f64, f64)> = Vec::new();
        for (d, mut zs) in per_drone {
            zs.sort_unstable();
            let median = f64::from(zs[zs.len() / 2]);
            if zs[zs.len() - 1] - zs[0] >= 5 {
                surfaces += 1;
            }
            let drone = &drones[d];
            let centre = 1000.0 * centre_z(&frame["camera"], &drone["position_m"]);
            let half_span = 500.0 * drone["size_m"].as_f64().expect("size_m");
            // The surface seen lies within the drone's half span of its centre.
            assert!(
                (median - centre).abs() <= half_span + 1.0,
                "frame {index} drone {d}: median depth {median} mm, centre {centre} mm"
            );
            seen.push((centre, median));
            drones_checked += 1;
        }
        // Monotone: a drone farther by more than a span has the larger depth.
        for a in &seen {
            for b in &seen {
                if b.0 - a.0 > 350.0 {
                    assert!(b.1 > a.1, "frame {index}: {a:?} against {b:?}");
                    pairs_ordered += 1;
                }
            }
        }
    }
    assert!(
        drones_checked >= 30 && pairs_ordered >= 30 && surfaces >= 10,
        "{drones_checked} drones, {pairs_ordered} pairs, {surfaces} with a surface"
    );
}

#[test]
fn yolo_segments_follow_the_detection_lines() {
    let dir = tempfile::tempdir().expect("tempdir");
    run(&preset(ALL), dir.path(), 4, 0);
    let mut polygons = 0;
    for split in ["train", "val", "test"] {
        let Ok(entries) = std::fs::read_dir(dir.path().join(format!("labels/{split}"))) else {
            continue;
        };
        for e in entries {
            let path = e.expect("entry").path();
            let name = path
                .file_name()
                .expect("present")
                .to_string_lossy()
                .into_owned();
            let det = std::fs::read_to_string(&path).expect("labels");
            let seg =
                std::fs::read_to_string(dir.path().join(format!("seg/labels/{split}/{name}")))
                    .expect("a segmentation file beside each label file");
            assert_eq!(det.lines().count(), seg.lines().count(), "{name}");
            for (d, s) in det.lines().zip(seg.lines()) {
                let d: Vec<f64> = d.split(' ').map(|v| v.parse().expect("present")).collect();
                let s: Vec<f64> = s.split(' ').map(|v| v.parse().expect("present")).collect();
                assert_eq!(d[0], s[0], "class");
                let points = &s[1..];
                assert!(
                    points.len() >= 6 && points.len().is_multiple_of(2),
                    "{name}: {s:?}"
                );
                let (x0, x1) = (d[1] - d[3] / 2.0, d[1] + d[3] / 2.0);
                let (y0, y1) = (d[2] - d[4] / 2.0, d[2] + d[4] / 2.0);
                for xy in points.chunks(2) {
                    let eps = 2e-6;
                    assert!(
                        xy[0] >= x0 - eps && xy[0] <= x1 + eps,
                        "{name}: x {} not in box",
                        xy[0]
                    );
                    assert!(
                        xy[1] >= y0 - eps && xy[1] <= y1 + eps,
                        "{name}: y {} not in box",
                        xy[1]
                    );
                }
                polygons += 1;
            }
        }
    }
    assert!(polygons >= 10, "{polygons} polygons");
}

#[test]
fn masks_through_the_camera_model_are_its_changed_pixels() {
    let mut p = preset(MaskOutputs {
        coco_rle: true,
        ..MaskOutputs::default()
    });
    p.camera_model = Some(CameraModel {
        psf: Psf::Gaussian {
            sigma_px: (0.8, 0.8),
        },
        read_noise_levels: (2.0, 2.0),
        ..CameraModel::default()
    });
    let dir = tempfile::tempdir().expect("tempdir");
    run(&p, dir.path(), 3, 0);
    // The manifest's visible pixels and boxes are the changed pixels there:
    // the decoded masks must agree with them.
    check_rle_against_manifest(dir.path());
}

/// Every file of a dataset folder, relative path → bytes.
fn files(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    let mut out = BTreeMap::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).expect("dir") {
            let path = e.expect("entry").path();
            if path.is_dir() {
                stack.push(path);
            } else {
                let rel = path
                    .strip_prefix(dir)
                    .expect("present")
                    .to_string_lossy()
                    .into_owned();
                out.insert(rel, std::fs::read(&path).expect("file"));
            }
        }
    }
    out
}

#[test]
fn masks_off_adds_nothing_and_on_adds_only_masks() {
    let (off, on) = (
        tempfile::tempdir().expect("present"),
        tempfile::tempdir().expect("present"),
    );
    run(&preset(MaskOutputs::default()), off.path(), 3, 0);
    run(&preset(ALL), on.path(), 3, 0);
    let (off_files, on_files) = (files(off.path()), files(on.path()));
    let lock = String::from_utf8(off_files["preset.lock.ron"].clone()).expect("present");
    assert!(
        !lock.contains("masks"),
        "an off preset's lock names no masks"
    );
    assert!(
        String::from_utf8_lossy(&on_files["preset.lock.ron"]).contains("coco_rle: true"),
        "an on preset's lock keeps them"
    );
    assert!(!off_files.keys().any(|f| {
        ["masks/", "seg/", "data-seg.yaml", "depth/"]
            .iter()
            .any(|d| f.starts_with(d))
    }));
    for (rel, bytes) in &off_files {
        if rel.starts_with("images/") || rel.starts_with("labels/") || rel == "manifest.jsonl" {
            assert!(on_files[rel] == *bytes, "{rel} changed with masks on");
        }
    }
    // COCO: the same records but for area and segmentation.
    for split in ["train", "val", "test"] {
        let rel = format!("annotations/instances_{split}.json");
        let (mut a, mut b) = (json(&off.path().join(&rel)), json(&on.path().join(&rel)));
        let off_anns = a["annotations"].as_array_mut().expect("present");
        for ann in off_anns.iter_mut() {
            assert!(
                ann.get("segmentation").is_none(),
                "masks off writes no segmentation"
            );
            let bb = xyxy(&ann["bbox"]).expect("present");
            let area = ann["area"].as_f64().expect("present");
            assert!(
                (area - bb[2] * bb[3]).abs() < 1e-5,
                "off: area is the box's"
            );
            ann.as_object_mut().expect("present").remove("area");
        }
        for ann in b["annotations"].as_array_mut().expect("present") {
            let o = ann.as_object_mut().expect("present");
            assert!(o.remove("segmentation").is_some());
            o.remove("area");
        }
        assert_eq!(a, b, "{rel}");
    }
}

#[test]
fn masks_are_deterministic_across_runs_and_thread_counts() {
    let (a, b) = (
        tempfile::tempdir().expect("present"),
        tempfile::tempdir().expect("present"),
    );
    run(&preset(ALL), a.path(), 4, 1);
    run(&preset(ALL), b.path(), 4, 3);
    let (fa, fb) = (files(a.path()), files(b.path()));
    assert_eq!(fa.keys().collect::<Vec<_>>(), fb.keys().collect::<Vec<_>>());
    assert!(fa.keys().any(|k| k.starts_with("masks/")));
    for (rel, bytes) in &fa {
        assert!(fb[rel] == *bytes, "{rel} differs between runs");
    }
}

#[test]
fn mask_settings_are_checked_with_their_field_paths() {
    let mut p = preset(ALL);
    p.labels.id_scale = 2;
    p.output.masks.depth_unit_mm = 0;
    p.output.label_formats = vec![LabelFormat::Yolo];
    let errors = p.validate().expect_err("invalid");
    let fields: Vec<&str> = errors.iter().map(|e| e.field.as_str()).collect();
    assert!(fields.contains(&"output.masks"), "{fields:?}");
    assert!(fields.contains(&"output.masks.coco_rle"), "{fields:?}");
    assert!(!fields.contains(&"output.masks.yolo_seg"), "{fields:?}");
    assert!(fields.contains(&"output.masks.depth_unit_mm"), "{fields:?}");
    let err = Preset::from_ron("(output: (masks: (coco_rle: true, depht: true)))")
        .expect_err("unknown field");
    assert!(err.to_string().contains("depht"), "{err}");
    let on = Preset::from_ron("(output: (masks: (instance_png: true)))").expect("parses");
    assert!(on.output.masks.instance_png);
    assert!(!on.output.masks.coco_rle && !on.output.masks.yolo_seg);
    assert_eq!(Preset::from_ron(&on.to_ron()).expect("round trip"), on);
}

/// Issue 35: confusers take instance ids after the drones. 65 000 drones
/// and 1 500 confusers passed `check`, and the batch failed 20 s in on the
/// first confuser past id 65 535; now `check` refuses it, naming the fields.
#[test]
fn confusers_count_in_the_16_bit_instance_ids_and_check_refuses_up_front() {
    use swarmshot::preset::confusers::{BirdSpecies, Confuser, ConfuserKind};
    let mut p = preset(ALL);
    p.placement = Placement::Randomized {
        count: (65_000, 65_000),
        count_distribution: Default::default(),
        volume: Volume::Box {
            size_m: (1000.0, 1000.0, 1000.0),
        },
        min_separation_m: 0.7,
    };
    p.confusers = vec![
        Confuser {
            kind: ConfuserKind::Bird(BirdSpecies::Gull),
            count: (500, 500),
            ..Confuser::default()
        };
        3
    ];
    assert_eq!(p.max_objects_per_frame(), 66_500);
    for errors in [
        p.validate().expect_err("too many ids"),
        swarmshot::pipeline::check::validate(&p).expect_err("too many ids"),
    ] {
        let e = errors
            .iter()
            .find(|e| e.field == "output.masks.instance_png")
            .unwrap_or_else(|| panic!("{errors:?}"));
        let msg = e.to_string();
        assert!(
            msg.contains("65000 drones (placement)")
                && msg.contains("1500 confusers (confusers[*].count)")
                && msg.contains("66500 instance ids")
                && msg.contains("65535"),
            "{msg}"
        );
    }
    // `swarmshot check` refuses it before loading anything.
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("ids.ron");
    std::fs::write(&path, p.to_ron()).expect("write preset");
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_swarmshot"))
        .arg("check")
        .arg(&path)
        .output()
        .expect("runs");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{err}");
    assert!(
        err.contains("output.masks.instance_png") && err.contains("66500 instance ids"),
        "{err}"
    );
    // Without the instance image and the depth map, ids are not needed.
    p.output.masks.instance_png = false;
    p.output.masks.depth = false;
    if let Err(errors) = p.validate() {
        assert!(
            errors
                .iter()
                .all(|e| !e.to_string().contains("instance ids")),
            "{errors:?}"
        );
    }
    // The depth map alone names its own field; within the ids, no error.
    p.output.masks.depth = true;
    let errors = p.validate().expect_err("depth needs the ids too");
    assert!(
        errors.iter().any(|e| e.field == "output.masks.depth"),
        "{errors:?}"
    );
    p.confusers.truncate(1);
    if let Err(errors) = p.validate() {
        assert!(
            errors
                .iter()
                .all(|e| !e.to_string().contains("instance ids")),
            "{errors:?}"
        );
    }
}

/// `swarmshot frame N` alone writes frame N's image, labels and masks with
/// the bytes the batch writes for N (its mask files beside the image).
#[test]
fn frame_alone_writes_the_batchs_image_labels_and_masks() {
    let dir = tempfile::tempdir().expect("tempdir");
    let p = preset(ALL);
    let preset_path = dir.path().join("masks.ron");
    std::fs::write(&preset_path, p.to_ron()).expect("write preset");
    let data = dir.path().join("data");
    run(&p, &data, 4, 1);
    let manifest = std::fs::read_to_string(data.join("manifest.jsonl")).expect("manifest");
    for index in [1u64, 3] {
        let png = dir.path().join(format!("f{index}.png"));
        let status = std::process::Command::new(env!("CARGO_BIN_EXE_swarmshot"))
            .arg("frame")
            .arg(&preset_path)
            .args(["--index", &index.to_string(), "--out"])
            .arg(&png)
            .status()
            .expect("frame runs");
        assert!(status.success());
        let line: Value = serde_json::from_str(manifest.lines().nth(index as usize).expect("line"))
            .expect("json");
        let split = line["split"].as_str().expect("split");
        let stem = format!("{index:08}");
        let pairs = [
            (png.clone(), format!("images/{split}/{stem}.png")),
            (
                png.with_extension("txt"),
                format!("labels/{split}/{stem}.txt"),
            ),
            (
                dir.path().join(format!("f{index}.seg.txt")),
                format!("seg/labels/{split}/{stem}.txt"),
            ),
            (
                dir.path().join(format!("f{index}.mask.png")),
                format!("masks/{split}/{stem}.png"),
            ),
            (
                dir.path().join(format!("f{index}.depth.png")),
                format!("depth/{split}/{stem}.png"),
            ),
        ];
        for (alone, batch) in pairs {
            let a = std::fs::read(&alone).unwrap_or_else(|e| panic!("{}: {e}", alone.display()));
            let b = std::fs::read(data.join(&batch)).expect("batch file");
            assert!(!b.is_empty(), "{batch}");
            assert_eq!(
                a,
                b,
                "frame {index}: {} differs from {batch}",
                alone.display()
            );
        }
        // An instance image that names drones: the frame has visible drones.
        assert!(line["drones"].as_array().is_some_and(|d| !d.is_empty()));
    }
}

/// Ultralytics' image formats (ultralytics/data/utils.py `IMG_FORMATS`).
const IMG_FORMATS: [&str; 11] = [
    "bmp", "dng", "jpeg", "jpg", "mpo", "png", "tif", "tiff", "webp", "pfm", "heic",
];

/// A dataset YAML read as Ultralytics reads it, rule by rule: the root is the
/// YAML's folder (no `path:`; `check_det_dataset`), each split is
/// `(root / value).resolve()` (links resolved), a folder's images are every
/// file below it with an image suffix (`get_img_files`: `glob("**/*.*")`),
/// a label is the image path with its last `/images/` replaced by
/// `/labels/` and its suffix by `.txt` (`img2label_paths`), a label file is
/// segments when any row has more than 6 values, else boxes of exactly 5
/// (`verify_image_label`), coordinates in [0, 1]. Returns (images, boxes,
/// segments) over the splits the YAML names.
fn ultralytics_reads(yaml: &Path) -> (u64, u64, u64) {
    let text = std::fs::read_to_string(yaml).expect("yaml");
    assert!(!text.contains("path:"), "{text}");
    let root = yaml.parent().expect("folder");
    let (mut images, mut boxes, mut segments) = (0, 0, 0);
    for line in text.lines() {
        let Some((key, value)) = line.split_once(": ") else {
            continue;
        };
        if !["train", "val", "test"].contains(&key) {
            continue;
        }
        let split = root.join(value).canonicalize().expect("the split resolves");
        let mut found = Vec::new();
        let mut stack = vec![split];
        while let Some(d) = stack.pop() {
            for e in std::fs::read_dir(&d).expect("folder") {
                let path = e.expect("entry").path();
                if path.is_dir() {
                    stack.push(path);
                } else if let Some((_, ext)) = path.to_string_lossy().rsplit_once('.')
                    && IMG_FORMATS.contains(&ext.to_lowercase().as_str())
                {
                    found.push(path.to_string_lossy().into_owned());
                }
            }
        }
        assert!(!found.is_empty(), "{key}: {value} holds no image");
        for image in found {
            images += 1;
            let label = match image.rfind("/images/") {
                Some(at) => format!("{}/labels/{}", &image[..at], &image[at + 8..]),
                None => image.clone(),
            };
            let label = format!("{}.txt", label.rsplit_once('.').expect("suffix").0);
            let Ok(text) = std::fs::read_to_string(&label) else {
                continue; // missing: no labels for this image
            };
            let rows: Vec<Vec<f64>> = text
                .lines()
                .filter(|l| !l.is_empty())
                .map(|l| {
                    l.split_whitespace()
                        .map(|v| v.parse().expect("number"))
                        .collect()
                })
                .collect();
            for row in &rows {
                assert!(row[1..].iter().all(|v| (0.0..=1.0).contains(v)), "{label}");
            }
            if rows.iter().any(|r| r.len() > 6) {
                for row in &rows {
                    assert!(row.len() % 2 == 1, "{label}: a polygon of whole points");
                }
                segments += rows.len() as u64;
            } else {
                assert!(rows.iter().all(|r| r.len() == 5), "{label}");
            }
            boxes += rows.len() as u64;
        }
    }
    (images, boxes, segments)
}

#[test]
fn the_segmentation_dataset_reads_as_ultralytics_reads_it() {
    use std::os::unix::fs::MetadataExt;
    let dir = tempfile::tempdir().expect("tempdir");
    run(&preset(ALL), dir.path(), 6, 0);
    // Segment: every box has its polygon (`verify_labels`: len(segments) == len(boxes)).
    let (images, boxes, segments) = ultralytics_reads(&dir.path().join("data-seg.yaml"));
    assert_eq!(images, 6);
    assert!(boxes > 0);
    assert_eq!(
        segments, boxes,
        "Segment dataset requires equal numbers of boxes and segments"
    );
    // Detect: data.yaml is as it was, boxes only.
    let (images, det_boxes, det_segments) = ultralytics_reads(&dir.path().join("data.yaml"));
    assert_eq!((images, det_boxes, det_segments), (6, boxes, 0));
    // The segmentation images are the dataset's images (hard links, no second copy).
    for split in ["train", "val", "test"] {
        for e in std::fs::read_dir(dir.path().join("images").join(split)).expect("images") {
            let path = e.expect("entry").path();
            let rel = path.strip_prefix(dir.path()).expect("inside");
            let link = dir.path().join("seg").join(rel);
            let (a, b) = (
                std::fs::metadata(&path).expect("image"),
                std::fs::metadata(&link).expect("its link"),
            );
            assert_eq!((a.dev(), a.ino()), (b.dev(), b.ino()), "{}", link.display());
        }
    }
    // A moved copy stays valid (no path is absolute); the links stay links under `cp -a`.
    let moved = dir.path().join("moved");
    let status = std::process::Command::new("cp")
        .arg("-a")
        .arg(dir.path().join("seg"))
        .arg(dir.path().join("data-seg.yaml"))
        .arg(dir.path().join("images"))
        .arg(dir.path().join("labels"))
        .arg({
            std::fs::create_dir(&moved).expect("mkdir");
            &moved
        })
        .status()
        .expect("cp");
    assert!(status.success());
    assert_eq!(ultralytics_reads(&moved.join("data-seg.yaml")).2, segments);
}
