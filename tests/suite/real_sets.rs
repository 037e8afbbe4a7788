//! Real frames from a camera other than the bundled one (tests/data/real-anti-uav-ir:
//! four thermal frames of the Anti-UAV dataset, MIT; docs/real-sets.md): the domain-gap
//! measures read them and see what a thermal camera shows, white-hot drones brighter than
//! the sky around them, unlike the bundled visible frames' mostly dark drones.

use crate::common;

use swarmshot::gap::{PixelBox, measure_frame};

/// Each frame of `set` with its YOLO boxes in pixels.
fn frames(set: &str) -> Vec<(String, image::RgbImage, Vec<PixelBox>)> {
    let dir = common::testdata(set);
    let mut names: Vec<_> = std::fs::read_dir(dir.join("images"))
        .expect("images folder")
        .map(|e| e.expect("entry").path())
        .collect();
    names.sort();
    names
        .into_iter()
        .map(|path| {
            let rgb = image::open(&path).expect("decode").to_rgb8();
            let (w, h) = (rgb.width() as f32, rgb.height() as f32);
            let stem = path
                .file_stem()
                .expect("stem")
                .to_string_lossy()
                .into_owned();
            let text = std::fs::read_to_string(dir.join("labels").join(format!("{stem}.txt")))
                .expect("label file");
            let boxes = text
                .lines()
                .map(|line| {
                    let v: Vec<f32> = line
                        .split_whitespace()
                        .map(|x| x.parse().expect("number"))
                        .collect();
                    let (cx, cy, bw, bh) = (v[1] * w, v[2] * h, v[3] * w, v[4] * h);
                    PixelBox {
                        x0: cx - bw / 2.0,
                        y0: cy - bh / 2.0,
                        x1: cx + bw / 2.0,
                        y1: cy + bh / 2.0,
                    }
                })
                .collect();
            (stem, rgb, boxes)
        })
        .collect()
}

#[test]
fn thermal_drones_are_measured_brighter_than_their_surroundings() {
    let frames = frames("real-anti-uav-ir");
    assert_eq!(frames.len(), 4, "the bundled thermal frames");
    for (name, rgb, boxes) in &frames {
        let stats = measure_frame(rgb, boxes, None);
        assert_eq!(
            stats.drones.len(),
            boxes.len(),
            "{name}: every drone measured"
        );
        for d in &stats.drones {
            assert!(
                !d.darker,
                "{name}: a white-hot drone measured darker than its ring"
            );
            assert!(d.peak > 20.0, "{name}: peak contrast {} levels", d.peak);
        }
        // A thermal camera is grey: its sky has almost no colour (JPEG chroma aside;
        // the bundled visible frames measure about 0.5).
        if let Some(s) = stats.sky_saturation {
            assert!(s < 0.1, "{name}: sky saturation {s}");
        }
    }
}
