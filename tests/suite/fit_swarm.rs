//! `swarmshot fit` on a many-drone footage (issue 36): the fitted preset labels about as
//! many drones a frame as the footage shows (every model drawn at the real cores' sizes,
//! none lost under the labels' 2 px), and its drones' centres spread over the frame as
//! the footage's do (the volume's width and height from the real boxes' spread).

use crate::common;

use std::path::Path;
use std::process::Command;
use std::sync::atomic::AtomicBool;

use swarmshot::fit::drones::CentreSpread;
use swarmshot::pipeline::{BatchOptions, FramePipeline, run_batch};
use swarmshot::preset::Preset;

fn tmp(name: &str) -> common::Scratch {
    common::Scratch::new(&format!("fitswarm-{name}"))
}

/// Drones a frame in the footage.
const SWARM: u32 = 16;

/// The footage: 16 small quadcopters a frame (cores about 3 px) over a clear sky, spread
/// over about 70 % of the frame's width (the volume 8.7 m wide at 9.6 m, f = 274 px).
fn footage_preset() -> Preset {
    let text = format!(
        r#"(
    version: 1,
    name: "swarm_footage",
    seed: 11,
    models: [(source: Builtin("quad_x"), size_m: 0.35, class: "uav")],
    placement: Randomized(count: ({SWARM}, {SWARM}), volume: Box(size_m: (8.7, 4.0, 1.0)), min_separation_m: 0.3),
    camera: (fov_y_deg: 50.0, observer: (elevation_deg: (4.0, 8.0), azimuth_deg: (0.0, 0.0), size_px: Some((10.0, 10.0)))),
    repeats: 100,
    sky: Procedural(environment: Daytime, turbidity: Some(1.9)),
    render: (resolution: Custom(width: 320, height: 256), msaa: 1),
    labels: (box_method: Visible, min_box_px: 2.0, min_visible_pixels: 2, min_labelled: 0),
    output: (image_format: Jpeg(quality: 90), label_formats: [Yolo]),
    camera_model: Some((psf: Gaussian(sigma_px: (0.4, 0.4)), jpeg_quality: Some((90, 90)))),
)"#
    );
    Preset::from_ron(&text).expect("the footage preset parses")
}

/// The base the fit starts from: a 0.35 m quadcopter and a 2 m fixed wing (the mix that
/// put the small model under 2 px when sized for the median).
fn base_preset() -> Preset {
    let mut p = footage_preset();
    p.name = "swarm_base".into();
    p.models.push(swarmshot::preset::ModelSpec {
        source: swarmshot::preset::ModelSource::Builtin("fixed_wing".into()),
        size_m: 2.0,
        class: "uav".into(),
        allow_uris_outside_folder: false,
    });
    p
}

/// The YOLO labels under `dir`: drones per frame and their centres (shares of the frame).
fn labels(dir: &Path) -> (Vec<usize>, Vec<(f64, f64)>) {
    let mut files = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).expect("read dir") {
            let p = e.expect("entry").path();
            if p.is_dir() {
                stack.push(p);
            } else if p.extension().is_some_and(|x| x == "txt")
                && p.components().any(|c| c.as_os_str() == "labels")
            {
                files.push(p);
            }
        }
    }
    files.sort();
    let (mut counts, mut centres) = (Vec::new(), Vec::new());
    for f in &files {
        let text = std::fs::read_to_string(f).expect("label file");
        let rows: Vec<Vec<f64>> = (text.lines())
            .filter(|l| !l.trim().is_empty())
            .map(|l| {
                l.split_whitespace()
                    .map(|v| v.parse().expect("a number"))
                    .collect()
            })
            .collect();
        counts.push(rows.len());
        centres.extend(rows.iter().map(|r| (r[1], r[2])));
    }
    (counts, centres)
}

fn median(v: &[usize]) -> usize {
    let mut v = v.to_vec();
    v.sort_unstable();
    v[v.len() / 2]
}

#[test]
fn a_fitted_swarm_labels_the_footage_s_drones_spread_as_the_footage_s() {
    let dir = tmp("swarm");
    let real = dir.join("real");
    let ctx = common::gpu();
    let pipeline = FramePipeline::new(footage_preset()).expect("valid preset");
    let mut options = BatchOptions::new(&real);
    options.limit = Some(8);
    run_batch(&pipeline, &options, &ctx, &AtomicBool::new(false), |_| {}).expect("batch");
    let (real_counts, real_centres) = labels(&real);
    let real_spread = CentreSpread::of(real_centres.into_iter()).expect("a spread");
    // The footage is what the test says it is: a swarm spread wide.
    assert!(median(&real_counts) >= 14, "{real_counts:?}");
    assert!(real_spread.x > 0.5, "{real_spread:?}");

    let base = dir.join("base.ron");
    std::fs::write(&base, base_preset().to_ron()).expect("write base");
    let out = dir.join("fit");
    let o = Command::new(env!("CARGO_BIN_EXE_swarmshot"))
        .args(["fit", "--real"])
        .arg(&real)
        .arg("--out")
        .arg(&out)
        .arg("--base")
        .arg(&base)
        .args(["--rounds", "1", "--sample", "6"])
        .output()
        .expect("run swarmshot");
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success(),
        "{text}\n{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let fitted = std::fs::read_to_string(out.join("fitted.ron")).expect("fitted.ron");
    let (counts, centres) = labels(&out.join("rounds/01/dataset"));
    let spread = CentreSpread::of(centres.into_iter()).expect("a spread");
    // Every drone drawn is labelled: none lies under the labels' 2 px.
    let (m, want) = (median(&counts), median(&real_counts));
    assert!(
        m + 2 >= want && m <= want + 1,
        "labelled drones a frame {counts:?} against the footage's {real_counts:?}\n{fitted}"
    );
    // The centres cover the frame as the footage's do (within a fifth of its spread).
    for (s, r, axis) in [
        (spread.x, real_spread.x, "x"),
        (spread.y, real_spread.y, "y"),
    ] {
        assert!(
            (s - r).abs() <= 0.2 * r + 0.03,
            "centres' {axis} spread {s:.3} against the footage's {r:.3}\n{fitted}"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}
