//! Optical flow (`output.masks.flow`, issue 41) end to end (renders on
//! lavapipe): each frame's KITTI PNG carries its drones' pixels onto
//! where the next frame's instance image shows them, the still background
//! has zero flow, the last frame of a sequence has none, flow off writes
//! nothing, and a preset without a sequence is refused naming the field.

use crate::common;

use std::collections::BTreeMap;
use std::path::Path;
use std::sync::atomic::AtomicBool;

use swarmshot::pipeline::{BatchOptions, FramePipeline, run_batch};
use swarmshot::preset::sweep::SweepRange;
use swarmshot::preset::{Motion, Placement, Preset, SequenceCamera, SequenceSpec};

/// Five drones in a wedge crossing a fixed camera in 6 steps, 320×180.
fn sequence_preset(flow: bool) -> Preset {
    // The MOT tests' wedge, nearer, one sequence of 6 steps.
    let mut p = common::sequence_preset();
    p.name = "flow".into();
    if let Placement::Formation(f) = &mut p.placement {
        f.count = 5;
        f.spacing = 3.0;
    }
    p.camera.z = SweepRange::fixed(0.9);
    p.repeats = 1;
    p.models[0].size_m = 1.2;
    p.output.label_formats = common::tiny_preset().output.label_formats;
    p.output.split.train = 1.0;
    p.output.split.val = 0.0;
    p.output.split.test = 0.0;
    p.output.masks.instance_png = true;
    p.output.masks.flow = flow;
    p.sequence = Some(SequenceSpec {
        steps: 6,
        motion: Motion {
            translate_m: (3.0, 0.5, -1.0),
            turn_deg: 12.0,
            bank_deg: 6.0,
            ..Motion::default()
        },
        camera: SequenceCamera::Fixed,
        frame_rate: 10,
    });
    p
}

fn run(preset: &Preset, dir: &Path) {
    run_batch(
        &FramePipeline::new(preset.clone()).expect("pipeline"),
        &BatchOptions::new(dir),
        &common::gpu(),
        &AtomicBool::new(false),
        |_| {},
    )
    .expect("batch runs");
}

/// Each file under `dir` by its path relative to `dir`.
fn files(dir: &Path) -> BTreeMap<String, std::path::PathBuf> {
    let mut out = BTreeMap::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).expect("read_dir").flatten() {
            let p = e.path();
            if p.is_dir() {
                stack.push(p);
            } else {
                let rel = p.strip_prefix(dir).expect("inside").to_string_lossy();
                out.insert(rel.replace('\\', "/"), p);
            }
        }
    }
    out
}

/// Each drone's pixels (x, y) in an instance PNG (id = drone + 1).
fn instances(path: &Path) -> BTreeMap<u16, Vec<(f64, f64)>> {
    let img = match image::open(path) {
        Ok(image::DynamicImage::ImageLuma16(g)) => g,
        other => panic!(
            "{}: not a 16-bit grey PNG: {:?}",
            path.display(),
            other.err()
        ),
    };
    let mut out: BTreeMap<u16, Vec<(f64, f64)>> = BTreeMap::new();
    for (x, y, p) in img.enumerate_pixels() {
        if p.0[0] > 0 {
            out.entry(p.0[0])
                .or_default()
                .push((f64::from(x), f64::from(y)));
        }
    }
    out
}

fn mean(points: &[(f64, f64)]) -> (f64, f64) {
    let n = points.len() as f64;
    let (sx, sy) = points
        .iter()
        .fold((0.0, 0.0), |(a, b), &(x, y)| (a + x, b + y));
    (sx / n, sy / n)
}

#[test]
fn flow_carries_each_drones_pixels_onto_the_next_frame() {
    let dir = tempfile::tempdir().expect("tempdir");
    let p = sequence_preset(true);
    run(&p, dir.path());
    let all = files(dir.path());
    let find = |kind: &str, index: u64| {
        all.iter()
            .find(|(k, _)| k.starts_with(kind) && k.ends_with(&format!("{index:08}.png")))
            .map(|(_, v)| v.clone())
    };
    let frames = p.frame_count();
    assert_eq!(frames, 7);
    let (mut drones, mut worst, mut moved) = (0, 0.0f64, 0.0f64);
    // The signed error summed over drones: a silhouette of 20–40 px samples
    // its centroid with noise of a pixel or so, which averages out; a wrong
    // flow (zero, or scaled by a wrong depth) does not.
    let mut sum = (0.0f64, 0.0f64);
    for t in 0..frames {
        let flow_path = find("flow/", t);
        if t + 1 == frames {
            assert!(flow_path.is_none(), "the last frame has no next: no flow");
            continue;
        }
        let flow = match image::open(flow_path.expect("a flow PNG per frame with a next")) {
            Ok(image::DynamicImage::ImageRgb16(f)) => f,
            other => panic!("flow is not 16-bit RGB: {:?}", other.err()),
        };
        let now = instances(&find("masks/", t).expect("instance PNG"));
        let next = instances(&find("masks/", t + 1).expect("instance PNG"));
        // The fixed camera's sky does not move: zero flow, valid.
        for (x, y, px) in flow.enumerate_pixels() {
            let on_drone = now
                .values()
                .flatten()
                .any(|&q| q == (f64::from(x), f64::from(y)));
            if !on_drone {
                assert_eq!(px.0, [32_768, 32_768, 1], "background at ({x}, {y})");
            }
        }
        for (id, pixels) in &now {
            let Some(then) = next.get(id) else { continue };
            // Whole drones only (off the border), big enough for a centroid.
            let inside = |ps: &[(f64, f64)]| {
                ps.iter()
                    .all(|&(x, y)| x > 0.0 && y > 0.0 && x < 319.0 && y < 179.0)
            };
            if pixels.len() < 20 || !inside(pixels) || !inside(then) {
                eprintln!("frame {t} drone {id}: {} px, skipped", pixels.len());
                continue;
            }
            let carried: Vec<(f64, f64)> = pixels
                .iter()
                .map(|&(x, y)| {
                    let v = flow.get_pixel(x as u32, y as u32).0;
                    assert_eq!(v[2], 1, "drone pixels are valid");
                    let u = (f64::from(v[0]) - 32_768.0) / 64.0;
                    let w = (f64::from(v[1]) - 32_768.0) / 64.0;
                    (x + u, y + w)
                })
                .collect();
            let (a, b) = (mean(&carried), mean(then));
            let c = mean(pixels);
            eprintln!(
                "frame {t} drone {id} ({} px): flow ({:.2}, {:.2}), shift ({:.2}, {:.2})",
                pixels.len(),
                a.0 - c.0,
                a.1 - c.1,
                b.0 - c.0,
                b.1 - c.1
            );
            sum = (sum.0 + a.0 - b.0, sum.1 + a.1 - b.1);
            worst = worst.max(((a.0 - b.0).powi(2) + (a.1 - b.1).powi(2)).sqrt());
            moved = moved.max(((c.0 - b.0).powi(2) + (c.1 - b.1).powi(2)).sqrt());
            drones += 1;
        }
    }
    eprintln!("{drones} drones: moved up to {moved} px, carried off by up to {worst} px");
    assert!(drones >= 10, "{drones} drones checked");
    // The drones move by pixels a frame; the flow lands them on their next pixels.
    assert!(moved > 3.0, "the drones moved at most {moved} px");
    let mean = (sum.0 / f64::from(drones), sum.1 / f64::from(drones));
    assert!(
        mean.0.abs() < 0.3 && mean.1.abs() < 0.3,
        "carried centroids off the next ones by {mean:?} px on average"
    );
    assert!(
        worst < 2.5,
        "carried centroid off the next one by {worst} px"
    );
}

#[test]
fn flow_off_writes_no_flow_and_on_changes_nothing_else() {
    let (off, on) = (
        tempfile::tempdir().expect("tmp"),
        tempfile::tempdir().expect("tmp"),
    );
    run(&sequence_preset(false), off.path());
    run(&sequence_preset(true), on.path());
    let (a, b) = (files(off.path()), files(on.path()));
    assert!(a.keys().all(|k| !k.starts_with("flow/")));
    for (k, path) in &a {
        if k.ends_with(".png") || k.ends_with(".txt") {
            let other = b
                .get(k)
                .unwrap_or_else(|| panic!("{k} missing with flow on"));
            assert_eq!(std::fs::read(path).ok(), std::fs::read(other).ok(), "{k}");
        }
    }
    let flows = b.keys().filter(|k| k.starts_with("flow/")).count();
    assert_eq!(flows, 6, "one flow PNG per frame with a next");
}

#[test]
fn flow_without_a_sequence_is_refused_naming_the_field() {
    let mut p = sequence_preset(true);
    p.sequence = None;
    let errors = p.validate().expect_err("flow needs a sequence");
    assert!(
        errors.iter().any(|e| e.field == "output.masks.flow"),
        "{errors:?}"
    );
}
