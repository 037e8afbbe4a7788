//! Labels-only plans (`batch --labels-only`), `swarmshot stats`, count
//! distributions with `labels.min_labelled`, what each frame records, and
//! the shipped Table 2 preset.

use crate::common;

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::atomic::AtomicBool;

use rand::SeedableRng;
use swarmshot::pipeline::{BatchOptions, FramePipeline, PlanOptions, run_batch, run_plan};
use swarmshot::preset::{BoxMethod, CountDistribution, Placement, Preset, Sky, Volume};
use swarmshot::scene::placement::{count_mean, draw_count};
use swarmshot::write::DatasetStats;

fn swarmshot() -> Command {
    Command::new(env!("CARGO_BIN_EXE_swarmshot"))
}

fn plan(
    pipeline: &FramePipeline,
    dir: &Path,
    limit: Option<u64>,
) -> swarmshot::pipeline::PlanReport {
    let mut options = PlanOptions::new(dir);
    options.limit = limit;
    run_plan(pipeline, &options, &AtomicBool::new(false), |_| {}).expect("plan")
}

/// Every file under `dir`, relative, sorted.
fn files(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_owned()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).expect("read_dir") {
            let p = e.expect("entry").path();
            if p.is_dir() {
                stack.push(p);
            } else {
                out.push(p.strip_prefix(dir).expect("prefix").to_owned());
            }
        }
    }
    out.sort();
    out
}

fn read(path: impl AsRef<Path>) -> String {
    std::fs::read_to_string(path.as_ref())
        .unwrap_or_else(|e| panic!("{}: {e}", path.as_ref().display()))
}

#[test]
fn amodal_plan_is_the_rendered_batch_without_images() {
    let ctx = common::gpu();
    let mut p = common::tiny_preset();
    p.labels.box_method = BoxMethod::Amodal;
    p.sky = Sky::Random {
        choices: vec![
            Sky::procedural(swarmshot::preset::EnvironmentName::Sunset),
            Sky::procedural(swarmshot::preset::EnvironmentName::Daytime),
        ],
        azimuth_offset_deg: (0.0, 0.0),
        sun_elevation_deg: None,
        cloud_cover: None,
        exposure_ev: None,
        sun_ev: None,
    };
    let pipeline = FramePipeline::new(p).expect("pipeline");
    let tmp = tempfile::tempdir().expect("tmp");
    let (rendered, planned) = (tmp.path().join("rendered"), tmp.path().join("plan"));
    let report = run_batch(
        &pipeline,
        &BatchOptions::new(&rendered),
        &ctx,
        &AtomicBool::new(false),
        |_| {},
    )
    .expect("batch");
    let plan_report = plan(&pipeline, &planned, None);
    assert!(!plan_report.estimated);
    assert_eq!(report.stats.frames, 8);
    assert!(report.stats.boxes > 0);

    // Label files, manifest and COCO annotations byte for byte; no images, no data.yaml.
    let labels: Vec<PathBuf> = files(&rendered)
        .into_iter()
        .filter(|f| f.starts_with("labels"))
        .collect();
    assert_eq!(labels.len(), 8);
    for f in &labels {
        assert_eq!(
            read(rendered.join(f)),
            read(planned.join(f)),
            "{}",
            f.display()
        );
    }
    assert_eq!(
        read(rendered.join("manifest.jsonl")),
        read(planned.join("manifest.jsonl"))
    );
    for split in ["train", "val", "test"] {
        let rel = format!("annotations/instances_{split}.json");
        let (a, b) = (read(rendered.join(&rel)), read(planned.join(&rel)));
        let body = |s: &str| s.split_once('\n').map(|(_, rest)| rest.to_owned());
        assert_eq!(body(&a), body(&b), "{rel} past its info line");
        let info: serde_json::Value = serde_json::from_str(&b).expect("coco");
        assert_eq!(info["info"]["labels_only"], true, "{rel} says it is a plan");
    }
    let plan_files = files(&planned);
    assert!(!plan_files.iter().any(|f| f.starts_with("images")));
    assert!(!plan_files.contains(&PathBuf::from("data.yaml")));
    assert!(plan_files.contains(&PathBuf::from("PLAN.txt")));
    assert!(read(planned.join("PLAN.txt")).contains("NO IMAGES"));

    // The same numbers, but the plan's stats.json says what it is.
    let stats = |dir: &Path| -> DatasetStats {
        serde_json::from_str(&read(dir.join("stats.json"))).expect("stats.json")
    };
    let (a, b) = (stats(&rendered), stats(&planned));
    assert!(b.labels_only && !a.labels_only);
    assert_eq!(
        DatasetStats {
            labels_only: false,
            ..b.clone()
        },
        a
    );

    // Each frame records the environment a Random sky chose, its sweep and models.
    let coco: serde_json::Value =
        serde_json::from_str(&read(planned.join("annotations/instances_train.json")))
            .expect("coco");
    for image in coco["images"].as_array().expect("images") {
        let env = image["environment"].as_str().expect("environment");
        assert!(env == "Sunset" || env == "Daytime", "{env}");
        assert_eq!(image["models"], serde_json::json!(["quad_x"]));
        assert!(image["sweep"]["CameraY"].is_number());
    }
    let manifest = read(planned.join("manifest.jsonl"));
    let envs: std::collections::BTreeSet<String> = manifest
        .lines()
        .map(|l| {
            let v: serde_json::Value = serde_json::from_str(l).expect("line");
            v["environment"]["name"].as_str().expect("name").to_owned()
        })
        .collect();
    assert_eq!(envs.len(), 2, "both choices drawn over 8 frames: {envs:?}");

    // A rendered run never continues a plan folder (nor the reverse).
    let err = run_batch(
        &pipeline,
        &BatchOptions::new(&planned),
        &ctx,
        &AtomicBool::new(false),
        |_| {},
    )
    .expect_err("a plan folder is not a rendered run");
    let named = "holds a labels-only plan of this preset (a labels-only plan and a rendered run never continue each other)";
    assert!(format!("{err:#}").contains(named), "{err:#}");
    let err = run_plan(
        &pipeline,
        &PlanOptions::new(&rendered),
        &AtomicBool::new(false),
        |_| {},
    )
    .expect_err("a rendered folder is not a plan");
    let named = "holds a rendered run of this preset";
    assert!(format!("{err:#}").contains(named), "{err:#}");

    // `swarmshot stats` reads the same numbers back from the manifest.
    for dir in [&rendered, &planned] {
        let out = swarmshot()
            .args(["stats", "--json"])
            .arg(dir)
            .output()
            .expect("run");
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let from_manifest: DatasetStats = serde_json::from_slice(&out.stdout).expect("json");
        assert_eq!(from_manifest, stats(dir));
    }
}

#[test]
fn visible_plans_say_their_boxes_are_estimates() {
    let p = common::tiny_preset(); // Visible boxes (the default)
    let tmp = tempfile::tempdir().expect("tmp");
    let preset_path = tmp.path().join("tiny.ron");
    std::fs::write(&preset_path, p.to_ron()).expect("write preset");
    let out = swarmshot()
        .args(["batch", "--labels-only", "--out"])
        .arg(tmp.path().join("plan"))
        .arg(&preset_path)
        .output()
        .expect("run");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("labels only: no images"), "{stdout}");
    assert!(stdout.contains("ESTIMATES"), "{stdout}");
    let stats: DatasetStats =
        serde_json::from_str(&read(tmp.path().join("plan/stats.json"))).expect("stats");
    assert!(stats.labels_only);
    assert!(
        stats.boxes_from.contains("ESTIMATED"),
        "{}",
        stats.boxes_from
    );
    // PLAN.txt points at the field of stats.json that says so.
    let readme = read(tmp.path().join("plan/PLAN.txt"));
    assert!(
        readme.contains("stats.json: \"boxes_from\": \"Visible ESTIMATED"),
        "{readme}"
    );
    let out = swarmshot()
        .arg("stats")
        .arg(tmp.path().join("plan"))
        .output()
        .expect("run");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success());
    assert!(stdout.contains("| images | 8 |"), "{stdout}");
    assert!(stdout.contains("ESTIMATED"), "{stdout}");
    for png in ["boxes_per_image.png", "box_size.png", "distance.png"] {
        let bytes = std::fs::read(tmp.path().join("plan/stats-plots").join(png)).expect(png);
        assert!(bytes.starts_with(b"\x89PNG"), "{png}");
    }
    // Histograms inside the folders its readers walk (labels/ here) are
    // refused before anything is written; beside them they are fine.
    let inside = tmp.path().join("plan/labels/train/plots");
    let out = swarmshot()
        .arg("stats")
        .arg(tmp.path().join("plan"))
        .arg("--plots")
        .arg(&inside)
        .output()
        .expect("run");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("inside the dataset's labels/"),
        "{err}"
    );
    assert!(!inside.exists());
    let beside = tmp.path().join("plan/my-plots");
    let out = (swarmshot().arg("stats").arg(tmp.path().join("plan")))
        .arg("--plots")
        .arg(&beside)
        .output()
        .expect("run");
    assert!(out.status.success() && beside.join("distance.png").is_file());
    // A folder that is not a dataset gets a named error.
    let out = swarmshot()
        .arg("stats")
        .arg(tmp.path())
        .output()
        .expect("run");
    assert!(!out.status.success());
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("is not a swarmshot dataset"),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

#[test]
fn count_distributions_draw_their_truncated_law() {
    use CountDistribution::*;
    // Uniform stays the one `random_range` draw of old presets.
    let mut a = rand_chacha::ChaCha8Rng::seed_from_u64(5);
    let mut b = rand_chacha::ChaCha8Rng::seed_from_u64(5);
    for _ in 0..1000 {
        let n = draw_count(&mut a, 1, 15, &Uniform);
        assert_eq!(n, rand::Rng::random_range(&mut b, 1..=15u32));
    }
    for dist in [
        Poisson { mean: 4.0 },
        Geometric { p: 0.3 },
        Table(vec![(2, 1.0), (5, 3.0), (9, 0.5)]),
    ] {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(9);
        let draws: Vec<u32> = (0..40_000)
            .map(|_| draw_count(&mut rng, 1, 12, &dist))
            .collect();
        assert!(draws.iter().all(|n| (1..=12).contains(n)), "{dist:?}");
        let mean = draws.iter().map(|&n| f64::from(n)).sum::<f64>() / draws.len() as f64;
        let expected = count_mean(1, 12, &dist);
        assert!(
            (mean - expected).abs() < 0.05,
            "{dist:?}: {mean} vs {expected}"
        );
        if let Table(_) = dist {
            assert!(draws.iter().all(|n| [2, 5, 9].contains(n)));
            assert!((expected - (2.0 + 15.0 + 4.5) / 4.5).abs() < 1e-9);
        }
    }
    // Truncation conditions, never piles onto the ends: geometric p = 0.5 on (3, 4).
    assert!((count_mean(3, 4, &Geometric { p: 0.5 }) - (3.0 * 2.0 + 4.0) / 3.0).abs() < 1e-9);
}

#[test]
fn presets_name_distribution_errors_and_keep_old_bytes() {
    // An old preset parses, draws uniformly and locks to the same text (no new field).
    let old = "(placement: Randomized(count: (2, 9), volume: Box(size_m: (8.0, 4.0, 8.0)), min_separation_m: 0.7))";
    let p = Preset::from_ron(old).expect("old preset");
    assert!(
        matches!(&p.placement, Placement::Randomized { count_distribution, .. } if count_distribution.is_uniform())
    );
    let lock = p.to_ron();
    assert!(
        !lock.contains("count_distribution") && !lock.contains("min_labelled"),
        "{lock}"
    );
    assert_eq!(Preset::from_ron(&lock).expect("lock"), p);

    let errors = |text: &str| -> Vec<String> {
        let p = Preset::from_ron(text).unwrap_or_else(|e| panic!("{e}"));
        p.validate()
            .expect_err("invalid")
            .iter()
            .map(ToString::to_string)
            .collect()
    };
    let with = |dist: &str| {
        format!(
            "(placement: Randomized(count: (1, 15), count_distribution: {dist}, volume: Box(size_m: (20.0, 10.0, 20.0)), min_separation_m: 0.7))"
        )
    };
    let e = errors(&with("Table([(0, 1.0), (3, -1.0), (3, 1.0)])"));
    assert!(
        e.iter()
            .any(|e| e.starts_with("placement.count_distribution[0]: count 0 is outside")),
        "{e:?}"
    );
    assert!(
        e.iter()
            .any(|e| e.starts_with("placement.count_distribution[1]: weight -1")),
        "{e:?}"
    );
    assert!(
        e.iter()
            .any(|e| e.starts_with("placement.count_distribution[2]: count 3 is listed twice")),
        "{e:?}"
    );
    let e = errors(&with("Poisson(mean: 0.0)"));
    assert!(
        e.iter()
            .any(|e| e.starts_with("placement.count_distribution.mean:")),
        "{e:?}"
    );
    let e = errors(&with("Geometric(p: 1.5)"));
    assert!(
        e.iter()
            .any(|e| e.starts_with("placement.count_distribution.p:")),
        "{e:?}"
    );
    let e = errors(
        "(placement: Randomized(count: (1, 4), volume: Box(size_m: (20.0, 10.0, 20.0)), min_separation_m: 0.7), labels: (min_labelled: 5))",
    );
    assert!(
        e.iter()
            .any(|e| e.starts_with("labels.min_labelled: 5 labelled drones")),
        "{e:?}"
    );
    // Unknown fields are still refused by name.
    let bad =
        Preset::from_ron(&with("Poisson(mean: 3.0, lambda: 2.0)")).expect_err("unknown field");
    assert!(bad.to_string().contains("lambda"), "{bad}");
}

#[test]
fn min_labelled_redraws_empty_frames_deterministically() {
    // Drones scattered in a wide volume with a narrow lens: many frames would show none.
    let mut p = common::tiny_preset();
    p.labels.box_method = BoxMethod::Amodal;
    p.camera.fov_y_deg = 20.0;
    p.camera.z = swarmshot::preset::sweep::SweepRange::fixed(0.15);
    p.placement = Placement::Randomized {
        count: (1, 2),
        count_distribution: CountDistribution::Uniform,
        volume: Volume::Box {
            size_m: (60.0, 30.0, 60.0),
        },
        min_separation_m: 0.7,
    };
    p.repeats = 20;
    let kept = |pipeline: &FramePipeline, i: u64| {
        let (scene, labels) = pipeline.plan(i).expect("plan");
        (scene, labels.iter().filter(|l| l.is_kept()).count())
    };
    let without = FramePipeline::new(p.clone()).expect("pipeline");
    let n = without.frame_count();
    let empty = (0..n).filter(|&i| kept(&without, i).1 == 0).count();
    assert!(
        empty > 10,
        "the test needs empty frames to re-draw: {empty} of {n}"
    );
    p.labels.min_labelled = 1;
    let with = FramePipeline::new(p.clone()).expect("pipeline");
    let mut redrawn = 0;
    for i in 0..n {
        let (scene, k) = kept(&with, i);
        assert!(k >= 1, "frame {i}");
        redrawn += usize::from(scene.redraw > 0);
        // Deterministic: the frame alone gives the same draw; split and sky stay the frame's.
        assert_eq!(with.scene(i).expect("scene"), scene);
        let first = without.scene(i).expect("scene");
        assert_eq!(
            (scene.split, &scene.environment),
            (first.split, &first.environment)
        );
        if scene.redraw == 0 {
            assert_eq!(scene, first);
        }
    }
    assert_eq!(redrawn, empty);

    // A bound no draw can meet is a named error.
    p.camera.absolute = Some(swarmshot::preset::AbsoluteCamera {
        position_m: (0.0, 0.0, 500.0),
        look_at_m: (0.0, 0.0, 1000.0),
    });
    let never = FramePipeline::new(p).expect("pipeline");
    let err = never
        .plan(0)
        .expect_err("no draw shows a drone behind the camera");
    assert!(err.to_string().contains("labels.min_labelled = 1"), "{err}");
}

#[test]
fn table2_preset_plans_within_the_papers_tolerances() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("presets/synthswarm_table2.ron");
    let pipeline = FramePipeline::open(&path).expect("preset");
    assert_eq!(pipeline.frame_count(), 7000);
    assert_eq!(pipeline.preset().image_size(), (1920, 1080));
    let mut stats = DatasetStats::default();
    for i in 0..400 {
        let (scene, labels) = pipeline.plan(i).expect("plan");
        stats.add(&scene, &labels, pipeline.model_names(), pipeline.classes());
    }
    let (min, mean, max) = stats.boxes_per_frame_range();
    let [small, medium, large] = stats.shares_percent();
    assert!(min >= 1 && max <= 15, "{min}–{max}");
    assert!((mean - 4.5).abs() <= 0.3, "mean {mean}");
    assert!((small - 67.3).abs() <= 3.0, "small {small}");
    assert!((medium - 25.1).abs() <= 3.0, "medium {medium}");
    assert!((large - 7.6).abs() <= 3.0, "large {large}");
    assert_eq!(
        stats.per_environment.len(),
        7,
        "{:?}",
        stats.per_environment.keys()
    );
}
