//! Issue 25, the input half: hostile presets that used to hang, blow up or
//! mislead are bounded, refused with a named error, or warned about.
//! The CLI cases run `swarmshot` as a child, as a user would.

use crate::common;

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

use swarmshot::model::{self, ModelError};
use swarmshot::preset::{ModelSpec, Placement, Preset, Volume};
use swarmshot::render::RenderError;
use swarmshot::scene::projection::PixelBox;

fn swarmshot() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_swarmshot"));
    c.stdin(Stdio::null());
    c
}

/// Run `cmd`, killing it after `limit`: the output, and how long it took.
fn run_within(mut cmd: Command, limit: Duration) -> (Output, Duration) {
    let start = Instant::now();
    let mut child = cmd
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn swarmshot");
    loop {
        if child.try_wait().expect("wait").is_some() {
            break;
        }
        if start.elapsed() > limit {
            let _ = child.kill();
            let out = child.wait_with_output().expect("output");
            panic!(
                "still running after {limit:?}: {}",
                String::from_utf8_lossy(&out.stdout)
            );
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    let took = start.elapsed();
    (child.wait_with_output().expect("output"), took)
}

fn write_preset(dir: &Path, name: &str, p: &Preset) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, p.to_ron()).expect("write preset");
    path
}

/// One frame of 10⁶ drones in a 10 km box.
fn million_drones() -> Preset {
    let mut p = common::tiny_preset();
    p.placement = Placement::Randomized {
        count: (1_000_000, 1_000_000),
        count_distribution: Default::default(),
        volume: Volume::Box {
            size_m: (10_000.0, 10_000.0, 10_000.0),
        },
        min_separation_m: 0.7,
    };
    p.camera.y = swarmshot::preset::sweep::SweepRange::fixed(0.0);
    p.plane.ry = swarmshot::preset::sweep::SweepRange::fixed(0.0);
    p.repeats = 1;
    assert_eq!(p.frame_count(), 1);
    p
}

// ---- no hang --------------------------------------------------------------

#[test]
fn check_of_a_million_drones_per_frame_finishes_within_10_s() {
    let dir = tempfile::tempdir().expect("tempdir");
    let mut p = million_drones();
    p.repeats = 50; // 50 frames of 10⁶: sampled, the estimate would take minutes
    let path = write_preset(dir.path(), "million.ron", &p);
    let (out, took) = run_within(
        {
            let mut c = swarmshot();
            c.arg("check").arg(&path);
            c
        },
        Duration::from_secs(10),
    );
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{text}");
    assert!(
        text.contains("estimate skipped") && text.contains("a rendered batch refuses"),
        "{text}"
    );
    assert!(text.contains("disk: about"), "{text}");
    assert!(took < Duration::from_secs(10), "{took:?}");
}

#[test]
fn batch_of_a_million_drones_is_refused_within_10_s_and_writes_nothing() {
    let dir = tempfile::tempdir().expect("tempdir");
    let path = write_preset(dir.path(), "million.ron", &million_drones());
    let out_dir = dir.path().join("out");
    for args in [
        vec![
            "batch".into(),
            path.clone(),
            "--out".into(),
            out_dir.clone(),
        ],
        vec![
            "frame".into(),
            path.clone(),
            "--out".into(),
            dir.path().join("f.png"),
        ],
    ] {
        let (out, took) = run_within(
            {
                let mut c = swarmshot();
                c.args(&args);
                c
            },
            Duration::from_secs(10),
        );
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{err}");
        assert!(
            err.contains("error: placement: up to 1000000 drones per frame")
                && err.contains("--labels-only"),
            "{err}"
        );
        assert!(took < Duration::from_secs(10));
    }
    assert!(!out_dir.exists(), "nothing written");
    assert!(!dir.path().join("f.png").exists());
}

#[test]
fn drones_piled_on_one_spot_stop_the_layering_with_a_named_error() {
    // 20 000 boxes at the same place: every pair overlaps (2·10⁸ comparisons).
    let b = PixelBox {
        x0: 10.0,
        y0: 10.0,
        x1: 12.0,
        y1: 12.0,
    };
    let boxes = vec![Some(b); 20_000];
    let start = Instant::now();
    let e = swarmshot::render::visibility::overlap_layers(&boxes).expect_err("budget");
    assert!(
        matches!(e, RenderError::TooDense { drones: 20_000, .. }),
        "{e:?}"
    );
    assert!(e.to_string().contains("work budget"), "{e}");
    assert!(start.elapsed() < Duration::from_secs(10));
    // Spread out, the same number is layered as before.
    let spread: Vec<Option<PixelBox>> = (0..20_000)
        .map(|i| {
            let (x, y) = (f64::from(i % 200) * 4.0, f64::from(i / 200) * 4.0);
            Some(PixelBox {
                x0: x,
                y0: y,
                x1: x + 1.0,
                y1: y + 1.0,
            })
        })
        .collect();
    let (layers, overlapping) =
        swarmshot::render::visibility::overlap_layers(&spread).expect("within budget");
    assert_eq!(layers.len(), 1);
    assert!(overlapping.iter().all(|o| !o));
}

// ---- text -----------------------------------------------------------------

#[test]
fn class_and_preset_names_are_bounded_and_printable() {
    let mut p = common::tiny_preset();
    p.models[0].class = "a".repeat(15 << 20);
    let e = p.validate().expect_err("15 MiB class");
    let msg = e[0].to_string();
    assert!(e[0].field == "models[0].class" && msg.contains("more than the limit of 64"));
    assert!(
        msg.len() < 200,
        "the name is not echoed whole: {} bytes",
        msg.len()
    );

    let dir = tempfile::tempdir().expect("tempdir");
    let mut p = common::tiny_preset();
    p.name = "evil\u{1b}[31m".into();
    p.models[0].class = "uav\u{1b}[2J".into();
    let path = write_preset(dir.path(), "ctl.ron", &p);
    let out = swarmshot().arg("check").arg(&path).output().expect("runs");
    assert!(!out.status.success());
    assert!(
        !out.stderr.contains(&0x1b) && !out.stdout.contains(&0x1b),
        "no raw escape byte reaches the terminal"
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("name: \"evil\\u{1b}[31m\" holds the control character U+001B")
            && err.contains("models[0].class"),
        "{err}"
    );
}

#[test]
fn near_duplicate_class_names_are_warned_about() {
    let mut p = common::tiny_preset();
    p.models = ["uav", "uav ", "UAV", "u\u{0430}v", "bird"]
        .into_iter()
        .map(|c| ModelSpec {
            class: c.into(),
            ..ModelSpec::default()
        })
        .collect();
    assert!(p.validate().is_ok());
    let w: Vec<String> = p.warnings().iter().map(ToString::to_string).collect();
    for i in 1..=3 {
        assert!(
            w.iter()
                .any(|w| w.starts_with(&format!("models[{i}].class"))
                    && w.contains(
                        "(models[0].class) differ only by case, spaces or look-alike letters"
                    )),
            "{w:?}"
        );
    }
    assert!(!w.iter().any(|w| w.contains("\"bird\"")), "{w:?}");
}

#[test]
fn a_bom_is_accepted_and_a_fraction_in_an_integer_pair_is_named() {
    let p = Preset::from_ron("\u{feff}(name: \"bom\", seed: 3)").expect("BOM accepted");
    assert_eq!(p.name, "bom");
    let e = Preset::from_ron("(placement: Randomized(count: (1.5, 3)))")
        .expect_err("1.5")
        .to_string();
    assert!(
        e.contains("`1.5` in `placement.count`: an integer (a whole number) was expected"),
        "{e}"
    );
    assert!(!e.contains("Expected comma"), "{e}");
}

#[test]
fn long_numbers_in_messages_are_shortened() {
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("num.ron");
    // 1e300 m is printed by `{}` as a 301-digit number.
    std::fs::write(&path, "(models: [(size_m: 1e300)])").expect("write");
    let out = swarmshot().arg("check").arg(&path).output().expect("runs");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(!err.contains(&"0".repeat(16)), "{err}");
    assert!(
        err.contains("models[0].size_m") && err.contains("(301 digits)"),
        "{err}"
    );
}

#[test]
fn a_million_sibling_nodes_are_called_too_many_not_a_dag() {
    let (mut json, bin) = common::triangle_gltf();
    let n = 1_000_000usize;
    let nodes: Vec<serde_json::Value> = (0..n).map(|_| serde_json::json!({})).collect();
    json["nodes"] = serde_json::Value::Array(nodes);
    json["nodes"][0] = serde_json::json!({"mesh": 0});
    json["scenes"] = serde_json::json!([{"nodes": (0..n).collect::<Vec<_>>()}]);
    let bytes = common::glb(&json, &bin);
    let e = model::load_bytes(&bytes, None, Path::new("flat.glb"), "flat").expect_err("too many");
    assert!(
        matches!(
            e,
            ModelError::TooManyNodes {
                nodes: 1_000_000,
                ..
            }
        ),
        "{e:?}"
    );
    assert!(!e.to_string().contains("DAG"), "{e}");
}

// ---- foresight and empty splits -------------------------------------------

#[test]
fn batch_refuses_a_run_larger_than_the_free_space_before_writing() {
    let dir = tempfile::tempdir().expect("tempdir");
    let mut p = common::tiny_preset();
    p.render.resolution = swarmshot::preset::Resolution::Custom {
        width: 3840,
        height: 2160,
    };
    p.repeats = 10_000_000; // 40 million 4K PNG frames: about 30 TiB
    let path = write_preset(dir.path(), "huge.ron", &p);
    let out_dir = dir.path().join("out");
    let (out, _) = run_within(
        {
            let mut c = swarmshot();
            c.arg("batch").arg(&path).arg("--out").arg(&out_dir);
            c
        },
        Duration::from_secs(30),
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{err}");
    assert!(
        err.contains("frames need about") && err.contains("free"),
        "{err}"
    );
    assert!(!out_dir.exists(), "nothing written");
    // `check` prints the estimate.
    let out = swarmshot().arg("check").arg(&path).output().expect("runs");
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains("disk: about 30.5 TiB for 40000000 frames"),
        "{text}"
    );
}

#[test]
fn an_empty_shard_and_an_empty_split_are_warned_about_and_data_yaml_names_no_empty_split() {
    let dir = tempfile::tempdir().expect("tempdir");
    let mut p = common::tiny_preset();
    p.repeats = 1;
    p.camera.y = swarmshot::preset::sweep::SweepRange::fixed(0.0);
    p.plane.ry = swarmshot::preset::sweep::SweepRange::fixed(0.0);
    let path = write_preset(dir.path(), "one.ron", &p);
    let out_dir = dir.path().join("shard");
    let out = swarmshot()
        .args(["batch".as_ref(), path.as_os_str(), "--out".as_ref()])
        .arg(&out_dir)
        .args(["--shard", "5/1000000"])
        .output()
        .expect("runs");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(
        err.contains("warning: --shard 5/1000000: this shard holds no frame"),
        "{err}"
    );
    // Said as what it is: an empty dataset written, not an earlier run found complete.
    let said = String::from_utf8_lossy(&out.stdout);
    assert!(
        said.starts_with("wrote an empty dataset (this shard holds no frame) to "),
        "{said}"
    );

    // One frame: it lands in one split; the other two are warned about and
    // data.yaml names neither (val then points at the images there are).
    let out_dir = dir.path().join("one");
    let out = swarmshot()
        .arg("batch")
        .arg(&path)
        .arg("--out")
        .arg(&out_dir)
        .output()
        .expect("runs");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    let yaml = std::fs::read_to_string(out_dir.join("data.yaml")).expect("data.yaml");
    let mut empty = 0;
    for split in ["train", "val", "test"] {
        let files = std::fs::read_dir(out_dir.join("images").join(split)).map_or(0, |d| d.count());
        if files == 0 {
            empty += 1;
            assert!(!yaml.contains(&format!("images/{split}")), "{yaml}");
            assert!(
                err.contains(&format!("warning: output.split.{split}")),
                "{err}"
            );
        } else {
            assert!(yaml.contains(&format!("val: images/{split}")), "{yaml}");
        }
    }
    assert_eq!(empty, 2, "{yaml}");
}

#[test]
fn the_shipped_sequence_preset_fills_every_split() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("presets/formation_sequence.ron");
    let p = Preset::load(&path).expect("loads");
    let counts = swarmshot::scene::split::frame_split_counts(&p, p.frame_count(), 1_000)
        .expect("split per sequence");
    assert!(counts.iter().all(|&n| n > 0), "{counts:?}");
    assert_eq!(counts.iter().sum::<u64>(), p.frame_count());
    // Counted as the frames themselves are split.
    let mut by_frame = [0u64; 3];
    for i in 0..p.frame_count() {
        by_frame[swarmshot::scene::build_frame(&p, i).expect("frame").split as usize] += 1;
    }
    assert_eq!(by_frame, counts);
}

#[test]
fn a_fraction_after_non_ascii_text_is_named_without_a_panic() {
    let e = Preset::from_ron("(name: \"é\", placement: Randomized(count: (é1.5, 3)))")
        .expect_err("not a preset")
        .to_string();
    assert!(!e.is_empty());
    let e = Preset::from_ron("(placement: Randomized(count: (2, 7.25)))")
        .expect_err("fraction")
        .to_string();
    assert!(
        e.contains("an integer (a whole number) was expected"),
        "{e}"
    );
}

#[test]
fn split_counts_match_the_frames_own_splits() {
    let mut p = common::tiny_preset();
    p.repeats = 3; // 4 sweep points × 3 = 12 frames
    for frames in [1u64, 7, 12] {
        let counts =
            swarmshot::scene::split::frame_split_counts(&p, frames, u64::MAX).expect("by frame");
        let mut by_frame = [0u64; 3];
        for i in 0..frames {
            by_frame[swarmshot::scene::build_frame(&p, i).expect("frame").split as usize] += 1;
        }
        assert_eq!(counts, by_frame, "{frames} frames");
    }
    // Whole blocks of 100 draws hold the shares exactly.
    let mut p = common::tiny_preset();
    p.repeats = 80; // 320 frames
    let counts = swarmshot::scene::split::frame_split_counts(&p, 320, u64::MAX).expect("by frame");
    let mut by_draw = [0u64; 3];
    let s = &p.output.split;
    for i in 0..320 {
        let u = swarmshot::seed::split_uniform(p.seed, i);
        by_draw[if u < s.train {
            0
        } else if u < s.train + s.val {
            1
        } else {
            2
        }] += 1;
    }
    assert_eq!(counts, by_draw);
    assert_eq!(
        swarmshot::scene::split::frame_split_counts(&p, 300, u64::MAX),
        Some([210, 30, 60])
    );
}
