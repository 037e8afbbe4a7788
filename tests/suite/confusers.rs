//! Confusers (issue 22): birds labelled as their own class, aircraft as
//! unlabelled hard negatives that never reach YOLO/COCO/MOT but are in the
//! manifest with their boxes, occlude drones, beat their wings continuously
//! through a sequence, and come out the same on every run.

use crate::common;

use std::collections::BTreeMap;
use std::path::Path;
use std::sync::atomic::AtomicBool;

use swarmshot::annotate::LabelStatus;
use swarmshot::pipeline::{BatchOptions, FramePipeline, run_batch};
use swarmshot::preset::confusers::{BirdSpecies, Confuser, ConfuserKind, Flock, FlockShape};
use swarmshot::preset::sweep::SweepRange;
use swarmshot::preset::{LabelFormat, Preset};

fn gulls(labelled: bool) -> Confuser {
    Confuser {
        kind: ConfuserKind::Bird(BirdSpecies::Gull),
        count: (3, 3),
        distance_m: (6.0, 12.0),
        labelled_as: labelled.then(|| "bird".to_string()),
        ..Confuser::default()
    }
}

fn airliner() -> Confuser {
    Confuser {
        kind: ConfuserKind::Airliner,
        count: (1, 1),
        distance_m: (500.0, 700.0),
        ..Confuser::default()
    }
}

/// 4 frames at 320×180 with 3 labelled gulls and one airliner (a hard negative).
fn preset() -> Preset {
    let mut p = common::tiny_preset();
    p.name = "confusers".into();
    p.repeats = 1;
    p.confusers = vec![gulls(true), airliner()];
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

fn manifest(dir: &Path) -> Vec<serde_json::Value> {
    std::fs::read_to_string(dir.join("manifest.jsonl"))
        .expect("manifest")
        .lines()
        .map(|l| serde_json::from_str(l).expect("json line"))
        .collect()
}

fn status(record: &serde_json::Value) -> Option<&str> {
    record["label"]["status"].as_str()
}

#[test]
fn negatives_stay_out_of_yolo_and_coco_and_are_in_the_manifest_with_their_boxes() {
    let dir = tempfile::tempdir().expect("tmp");
    run(&preset(), dir.path());

    let yaml = std::fs::read_to_string(dir.path().join("data.yaml")).expect("data.yaml");
    assert!(
        yaml.contains("0: \"uav\"") && yaml.contains("1: \"bird\""),
        "{yaml}"
    );

    let frames = manifest(dir.path());
    assert_eq!(frames.len(), 4);
    let (mut negatives_seen, mut birds_kept) = (0u32, 0u64);
    let mut coco_per_image: BTreeMap<String, usize> = BTreeMap::new();
    for f in &frames {
        let confusers = f["confusers"].as_array().expect("confusers array");
        assert_eq!(confusers.len(), 4, "3 gulls + 1 airliner");
        let mut yolo_expected: Vec<usize> = Vec::new();
        for d in f["drones"].as_array().expect("drones") {
            assert!(d.get("kind").is_none(), "drones hold no confuser: {d}");
            if status(d) == Some("kept") {
                yolo_expected.push(0);
            }
        }
        for c in confusers {
            match c["kind"].as_str() {
                Some("airliner") => {
                    assert!(c["class"].is_null(), "a negative has no class: {c}");
                    assert_eq!(status(c), Some("negative"), "{c}");
                    let bbox = c["label"]["bbox_xyxy"].as_array().expect("its box");
                    assert_eq!(bbox.len(), 4);
                    let visible = c["label"]["visible_pixels"].as_u64().expect("measured");
                    if visible > 0 {
                        negatives_seen += 1;
                        assert!(c["label"]["visible_xyxy"].is_array(), "{c}");
                    }
                }
                Some("gull") => {
                    assert_eq!(c["class"], "bird", "{c}");
                    if status(c) == Some("kept") {
                        yolo_expected.push(1);
                        birds_kept += 1;
                    }
                }
                other => panic!("unexpected kind {other:?}"),
            }
        }
        // YOLO holds exactly the kept drones and birds: never the airliner.
        let image = f["image"].as_str().expect("image");
        let stem = Path::new(image)
            .file_stem()
            .and_then(|s| s.to_str())
            .expect("stem");
        let split = f["split"].as_str().expect("split");
        let yolo = std::fs::read_to_string(dir.path().join(format!("labels/{split}/{stem}.txt")))
            .expect("yolo file");
        let mut classes: Vec<usize> = yolo
            .lines()
            .map(|l| {
                l.split(' ')
                    .next()
                    .and_then(|c| c.parse().ok())
                    .expect("class")
            })
            .collect();
        classes.sort_unstable();
        yolo_expected.sort_unstable();
        assert_eq!(classes, yolo_expected, "{image}");
        let crowd = (f["drones"].as_array().into_iter().flatten())
            .chain(confusers)
            .filter(|r| status(r) == Some("crowd"))
            .count();
        coco_per_image.insert(image.to_string(), yolo_expected.len() + crowd);
    }
    assert!(
        negatives_seen >= 2,
        "the airliner shows in the frames: {negatives_seen}"
    );
    assert!(
        birds_kept >= 4,
        "labelled gulls get training boxes: {birds_kept}"
    );

    // COCO: the categories name the bird class; annotations are the kept and crowd records only.
    let mut coco_counts: BTreeMap<String, usize> = BTreeMap::new();
    for split in ["train", "val", "test"] {
        let path = dir
            .path()
            .join(format!("annotations/instances_{split}.json"));
        let Ok(text) = std::fs::read_to_string(&path) else {
            continue;
        };
        let coco: serde_json::Value = serde_json::from_str(&text).expect("coco json");
        let names: Vec<&str> = (coco["categories"].as_array().expect("categories").iter())
            .map(|c| c["name"].as_str().expect("name"))
            .collect();
        assert_eq!(names, ["uav", "bird"]);
        let file_of: BTreeMap<u64, String> = (coco["images"].as_array().expect("images").iter())
            .map(|i| {
                let id = i["id"].as_u64().expect("id");
                (
                    id,
                    format!("images/{}", i["file_name"].as_str().expect("file")),
                )
            })
            .collect();
        for image in file_of.values() {
            coco_counts.entry(image.clone()).or_default();
        }
        for a in coco["annotations"].as_array().expect("annotations") {
            let file = &file_of[&a["image_id"].as_u64().expect("image id")];
            *coco_counts.entry(file.clone()).or_default() += 1;
        }
    }
    assert_eq!(coco_counts, coco_per_image);

    // Any frame made alone gives the batch's manifest line, confusers and all.
    let pipeline = FramePipeline::new(preset()).expect("pipeline");
    let ctx = common::gpu();
    let mut renderer = pipeline.renderer(&ctx);
    let lines: Vec<String> = std::fs::read_to_string(dir.path().join("manifest.jsonl"))
        .expect("manifest")
        .lines()
        .map(str::to_owned)
        .collect();
    for (i, batch_line) in lines.iter().enumerate() {
        let frame = pipeline.make(&mut renderer, i as u64).expect("frame alone");
        let image =
            swarmshot::write::image_rel_path(&frame.scene, pipeline.image_format(&frame.scene));
        let alone = swarmshot::write::manifest_line(
            &frame.scene,
            &frame.labels,
            &image,
            pipeline.model_names(),
            pipeline.classes(),
        );
        assert_eq!(&alone, batch_line, "frame {i}");
    }

    // `swarmshot stats` counts the classes and the negatives apart.
    let stats = swarmshot::write::stats::read_dataset(dir.path()).expect("stats");
    assert_eq!(stats.per_class["bird"].boxes, birds_kept);
    assert_eq!(
        stats.negatives, 4,
        "one airliner per frame, all in front of the camera"
    );
    assert_eq!(stats.per_negative["airliner"].boxes, 4);
    let written: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("stats.json")).expect("stats.json"))
            .expect("stats json");
    assert_eq!(written["negatives"], 4);
    assert_eq!(written["per_class"]["bird"]["boxes"], birds_kept);
}

#[test]
fn bird_flap_phase_follows_time_through_a_sequence() {
    let mut p = common::sequence_preset();
    p.confusers = vec![Confuser {
        flock: Some(Flock {
            shape: FlockShape::V,
            ..Flock::default()
        }),
        count: (5, 5),
        ..gulls(true)
    }];
    let pipeline = FramePipeline::new(p.clone()).expect("pipeline");
    let spec = p.sequence.as_ref().expect("sequence");
    let dt = 1.0 / f64::from(spec.frame_rate);
    let len = u64::from(spec.steps) + 1;
    let mut moved = 0;
    for seq in 0..2u64 {
        let scenes: Vec<_> = (0..len)
            .map(|t| pipeline.scene(seq * len + t).expect("scene"))
            .collect();
        for pair in scenes.windows(2) {
            let (a, b) = (&pair[0], &pair[1]);
            assert_eq!(a.confusers.len(), 5);
            assert_eq!(b.confusers.len(), 5);
            for (k, (ca, cb)) in a.confusers.iter().zip(&b.confusers).enumerate() {
                let (pa, pb) = (
                    ca.flap_phase.expect("flapping"),
                    cb.flap_phase.expect("flapping"),
                );
                let hz = ca.flap_hz.expect("beat");
                assert_eq!(Some(hz), cb.flap_hz, "the same bird beats at the same rate");
                let advance = (pb - pa - hz * dt).rem_euclid(1.0);
                assert!(
                    advance.min(1.0 - advance) < 1e-9,
                    "bird {k}: {pa} -> {pb} at {hz} Hz"
                );
                // The pose drawn is the one nearest the phase.
                let da = &a.drones[a.drone_count() + k];
                let want = format!("bird_gull_{}", ((pa * 8.0).round() as usize) % 8);
                assert_eq!(pipeline.model_names()[da.model], want);
                // The bird flies on: its body moves by speed · dt (the pose's box centre within a span).
                let db = &b.drones[b.drone_count() + k];
                let step = (db.position - da.position).length();
                assert!((step - ca.speed_m_s * dt).abs() < ca.span_m, "{step}");
                moved += 1;
            }
        }
    }
    assert_eq!(moved, 2 * 4 * 5);
}

#[test]
fn confuser_datasets_are_byte_identical_run_to_run() {
    let mut p = preset();
    p.confusers.push(Confuser {
        kind: ConfuserKind::Bird(BirdSpecies::Sparrow),
        count: (2, 6),
        distance_m: (3.0, 5.0),
        glide_share: 0.5,
        flock: Some(Flock {
            shape: FlockShape::Cloud,
            ..Flock::default()
        }),
        ..Confuser::default()
    });
    p.output.label_formats = vec![LabelFormat::Yolo, LabelFormat::Coco];
    let (a, b) = (
        tempfile::tempdir().expect("a"),
        tempfile::tempdir().expect("b"),
    );
    run(&p, a.path());
    run(&p, b.path());
    let files = |d: &Path| -> BTreeMap<String, Vec<u8>> {
        walk(d)
            .into_iter()
            .filter(|(rel, _)| !rel.starts_with(".swarmshot"))
            .collect()
    };
    let (fa, fb) = (files(a.path()), files(b.path()));
    assert!(fa.len() > 10, "{:?}", fa.keys().collect::<Vec<_>>());
    assert_eq!(fa.keys().collect::<Vec<_>>(), fb.keys().collect::<Vec<_>>());
    for (name, bytes) in &fa {
        assert!(bytes == &fb[name], "{name} differs between two runs");
    }
}

fn walk(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).expect("read dir").flatten() {
            let path = e.path();
            if path.is_dir() {
                stack.push(path);
            } else {
                let rel = path
                    .strip_prefix(dir)
                    .expect("inside")
                    .to_string_lossy()
                    .into_owned();
                out.push((rel, std::fs::read(&path).expect("read")));
            }
        }
    }
    out.sort();
    out
}

/// A negative between the camera and a drone hides part of it: the drone's
/// visible pixels drop against the same frame without the negative.
#[test]
fn a_negative_occludes_drones_like_anything_else() {
    let mut p = common::tiny_preset();
    p.repeats = 1;
    p.camera.y = SweepRange::fixed(0.0);
    p.plane.ry = SweepRange::fixed(0.0);
    p.confusers = vec![Confuser {
        kind: ConfuserKind::Balloon,
        count: (1, 1),
        distance_m: (100.0, 100.0),
        ..Confuser::default()
    }];
    let pipeline = FramePipeline::new(p).expect("pipeline");
    let ctx = common::gpu();
    let mut renderer = pipeline.renderer(&ctx);
    let mut scene = pipeline.scene(0).expect("scene");
    let n = scene.drone_count();
    assert!(n >= 1);
    // Put the balloon on the line of sight to drone 0, halfway, sized to cover about half of it.
    let cam = scene.camera.position;
    let target = scene.drones[0].position;
    let size = scene.drones[0].size_m * 0.5;
    let balloon = &mut scene.drones[n];
    balloon.position = cam + (target - cam) * 0.5 + glam::DVec3::new(size * 0.25, 0.0, 0.0);
    balloon.size_m = size;
    let with = pipeline
        .make_scene(&mut renderer, scene.clone())
        .expect("frame");
    let mut without_scene = scene.clone();
    without_scene.drones.truncate(n);
    without_scene.confusers.clear();
    let without = pipeline
        .make_scene(&mut renderer, without_scene)
        .expect("frame");

    let pixels = |labels: &[swarmshot::annotate::DroneLabel], i: usize| {
        labels
            .iter()
            .find(|l| l.drone == i)
            .and_then(|l| l.visibility)
            .map(|v| v.visible_pixels)
            .expect("measured")
    };
    let (hidden, clear) = (pixels(&with.labels, 0), pixels(&without.labels, 0));
    assert!(clear > 5, "drone 0 shows without the balloon: {clear}");
    assert!(
        hidden < clear,
        "the balloon hides part of drone 0: {hidden} of {clear}"
    );
    let negative = with
        .labels
        .iter()
        .find(|l| l.drone == n)
        .expect("the balloon's label");
    assert_eq!(negative.status, LabelStatus::Negative);
    assert!(negative.visibility.expect("measured").visible_pixels > 0);
    // Its pixels are in the picture: the two frames differ.
    assert_ne!(with.rgba, without.rgba);
}

#[test]
fn invalid_confusers_are_named_by_field_path() {
    let mut p = preset();
    p.confusers[0].count = (5, 2);
    p.confusers[1].flock = Some(Flock::default());
    p.confusers[1].distance_m = (0.0, 10.0);
    p.confusers[0].labelled_as = Some(" ".into());
    let errors = p.validate().expect_err("invalid");
    let fields: Vec<&str> = errors.iter().map(|e| e.field.as_str()).collect();
    for want in [
        "confusers[0].count",
        "confusers[0].labelled_as",
        "confusers[1].flock",
        "confusers[1].distance_m",
    ] {
        assert!(fields.contains(&want), "{want} missing from {fields:?}");
    }
    // A preset without confusers saves without the section (its file stays as it was).
    let plain = common::tiny_preset();
    assert!(!plain.to_ron().contains("confusers"));
    let round = Preset::from_ron(&preset().to_ron()).expect("round trip");
    assert_eq!(round.confusers, preset().confusers);
}

/// In sequences the labelled birds are MOT tracks of their own class; the
/// airliner (a negative) has a track id in the manifest but no MOT row.
#[test]
fn labelled_birds_are_tracked_in_mot_and_negatives_are_not() {
    let mut p = common::sequence_preset();
    p.confusers = vec![gulls(true), airliner()];
    let dir = tempfile::tempdir().expect("tmp");
    run(&p, dir.path());
    let mut expected: BTreeMap<String, usize> = BTreeMap::new();
    let mut negative_ids: BTreeMap<String, Vec<u64>> = BTreeMap::new();
    for f in manifest(dir.path()) {
        let key = format!(
            "mot/{}/{}/gt/gt.txt",
            f["split"].as_str().expect("split"),
            f["sequence"]["name"].as_str().expect("sequence name")
        );
        let records = (f["drones"].as_array().into_iter().flatten())
            .chain(f["confusers"].as_array().into_iter().flatten());
        let labelled = records
            .filter(|r| matches!(status(r), Some("kept" | "crowd")))
            .count();
        *expected.entry(key.clone()).or_default() += labelled;
        for c in f["confusers"].as_array().expect("confusers") {
            if c["kind"] == "airliner" {
                negative_ids
                    .entry(key.clone())
                    .or_default()
                    .push(c["track_id"].as_u64().expect("track id"));
            }
        }
    }
    assert_eq!(expected.len(), 3, "three sequences");
    let mut bird_rows = 0;
    for (path, rows) in &expected {
        let gt = std::fs::read_to_string(dir.path().join(path)).expect("gt.txt");
        let lines: Vec<Vec<&str>> = gt.lines().map(|l| l.split(',').collect()).collect();
        assert_eq!(lines.len(), *rows, "{path}");
        for cols in &lines {
            let id: u64 = cols[1].parse().expect("id");
            assert!(
                !negative_ids[path].contains(&id),
                "{path}: negative track {id} in MOT"
            );
            bird_rows += usize::from(cols[7] == "2");
        }
    }
    assert!(bird_rows > 0, "the gulls are class 2 rows");
}

/// The scene rotation turns confusers as it turns drones: each attitude (so
/// heading) and each flock's formation is rotated by PlaneRX/RY/RZ, while the
/// centres drawn in the camera's view stay put.
#[test]
fn confusers_follow_the_scene_rotation_as_drones_do() {
    let flock = Confuser {
        flock: Some(Flock {
            shape: FlockShape::V,
            ..Flock::default()
        }),
        count: (5, 5),
        ..gulls(false)
    };
    let with_plane = |rx: f64, ry: f64, rz: f64| {
        let mut p = preset();
        p.confusers = vec![flock.clone(), airliner()];
        p.plane.rx = SweepRange::fixed(rx);
        p.plane.ry = SweepRange::fixed(ry);
        p.plane.rz = SweepRange::fixed(rz);
        FramePipeline::new(p)
            .expect("pipeline")
            .scene(0)
            .expect("scene")
    };
    let flat = with_plane(0.0, 0.0, 0.0);
    let turned = with_plane(25.0, 70.0, -15.0);
    let plane = swarmshot::scene::math::plane_rotation(25.0, 70.0, -15.0);
    let (n, m) = (flat.drone_count(), turned.drone_count());
    assert_eq!(n, m);
    // The drones themselves: the same draws, rotated.
    for (a, b) in flat.drones[..n].iter().zip(&turned.drones[..n]) {
        assert!((plane * a.position - b.position).length() < 1e-9);
    }
    let (a, b) = (&flat.drones[n..], &turned.drones[m..]);
    assert_eq!(a.len(), 6);
    assert_eq!(b.len(), 6);
    for (k, (x, y)) in a.iter().zip(b).enumerate() {
        let want = (plane * x.rotation).normalize();
        assert!(
            want.dot(y.rotation).abs() > 1.0 - 1e-12,
            "confuser {k}: {:?} vs {want:?}",
            y.rotation
        );
        // Flying along the rotated heading.
        let (fx, fy) = (x.rotation * glam::DVec3::Z, y.rotation * glam::DVec3::Z);
        assert!((plane * fx - fy).length() < 1e-9, "confuser {k}");
    }
    // The flock's formation turns with it: members' offsets from the leader, rotated.
    for k in 1..5 {
        let (da, db) = (a[k].position - a[0].position, b[k].position - b[0].position);
        assert!(da.length() > 0.1, "member {k} apart from the leader");
        assert!(
            (plane * da - db).length() < 1e-6 * da.length().max(1.0),
            "member {k}"
        );
    }
    // The flock's leader and the airliner stay where they were drawn in the
    // view (their model's centre moves within a span as they turn), but fly
    // another way.
    for k in [0, 5] {
        let span = turned.confusers[k].span_m;
        assert!(
            (a[k].position - b[k].position).length() <= span,
            "confuser {k}"
        );
        assert!(
            a[k].rotation.dot(b[k].rotation).abs() < 0.999,
            "confuser {k}"
        );
    }
}
