//! Materials decide what the drone pipeline does, as glTF specifies: back
//! faces of single-sided materials are culled, double-sided ones are drawn
//! from both sides, and `MASK` materials discard fragments below their
//! cutoff while `OPAQUE` ones ignore alpha. One quad, built here, is seen
//! from the front and from behind.

use crate::common;

use swarmshot::pipeline::FramePipeline;
use swarmshot::preset::sweep::SweepRange;
use swarmshot::preset::{AttitudeRanges, ModelSource, ModelSpec, Placement, Preset, Resolution};
use swarmshot::render::RenderRequest;

/// A unit quad in the z = 0 plane (counter-clockwise seen from +z) with one
/// material: `double_sided`, base colour alpha `alpha`, and `mask` =
/// Some(cutoff) for `alphaMode: MASK`.
fn quad(double_sided: bool, alpha: f32, mask: Option<f32>) -> Vec<u8> {
    let mut bin = common::f32_le(&[
        -0.5, -0.5, 0.0, 0.5, -0.5, 0.0, 0.5, 0.5, 0.0, -0.5, 0.5, 0.0,
    ]);
    for i in [0u16, 1, 2, 0, 2, 3] {
        bin.extend(i.to_le_bytes());
    }
    let mut material = serde_json::json!({
        "doubleSided": double_sided,
        "pbrMetallicRoughness": {"baseColorFactor": [0.9, 0.2, 0.1, alpha]}
    });
    if let Some(cutoff) = mask {
        material["alphaMode"] = serde_json::json!("MASK");
        material["alphaCutoff"] = serde_json::json!(cutoff);
    }
    let json = serde_json::json!({
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 48},
            {"buffer": 0, "byteOffset": 48, "byteLength": 12}
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
             "min": [-0.5, -0.5, 0.0], "max": [0.5, 0.5, 0.0]},
            {"bufferView": 1, "componentType": 5123, "count": 6, "type": "SCALAR"}
        ],
        "materials": [material],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1, "material": 0}]}],
        "nodes": [{"mesh": 0}],
        "scenes": [{"nodes": [0]}],
        "scene": 0
    });
    common::glb(&json, &bin)
}

/// Visible pixels of the quad seen with yaw 0° and with yaw 180° (one of
/// them shows its front, the other its back), at MSAA `msaa`.
fn pixels_front_and_back(glb: &[u8], msaa: u32) -> (u64, u64) {
    let dir = tempfile::tempdir().expect("tempdir");
    let file = dir.path().join("quad.glb");
    std::fs::write(&file, glb).expect("write glb");
    let ctx = common::gpu();
    let mut seen = [0u64; 2];
    for (k, yaw) in [0.0, 180.0].into_iter().enumerate() {
        let mut p = Preset::default();
        p.models = vec![ModelSpec {
            source: ModelSource::File(file.clone()),
            size_m: 1.0,
            class: "quad".into(),
            ..ModelSpec::default()
        }];
        p.placement = Placement::Structured {
            x_count: 1,
            y_count: 1,
            z_count: 1,
            load_factor: 2.0,
        };
        p.attitude = AttitudeRanges {
            roll_deg: (0.0, 0.0),
            pitch_deg: (0.0, 0.0),
            yaw_deg: (yaw, yaw),
        };
        p.camera.x = SweepRange::fixed(0.0);
        p.camera.y = SweepRange::fixed(0.0);
        p.render.resolution = Resolution::Custom {
            width: 160,
            height: 120,
        };
        p.render.msaa = msaa;
        let pipeline = FramePipeline::new(p).expect("preset");
        let mut renderer = pipeline.renderer(&ctx);
        let scene = pipeline.scene(0).expect("scene");
        assert_eq!(scene.drones.len(), 1);
        let frame = renderer
            .render_frame(
                &scene,
                &RenderRequest {
                    msaa,
                    color: true,
                    visibility: true,
                },
            )
            .expect("render");
        let vis = frame.visibility.expect("visibility");
        seen[k] = vis[0].visible_pixels;
    }
    (seen[0], seen[1])
}

#[test]
fn single_sided_quads_are_culled_from_behind_double_sided_ones_are_not() {
    for msaa in [1, 4] {
        let (a, b) = pixels_front_and_back(&quad(false, 1.0, None), msaa);
        assert!(
            (a > 100 && b == 0) || (a == 0 && b > 100),
            "single-sided, MSAA {msaa}: {a} and {b} pixels (one side only)"
        );
        let (a, b) = pixels_front_and_back(&quad(true, 1.0, None), msaa);
        assert!(
            a > 100 && a == b,
            "double-sided, MSAA {msaa}: {a} and {b} pixels (both sides alike)"
        );
    }
}

#[test]
fn masked_materials_discard_below_their_cutoff_opaque_ones_ignore_alpha() {
    let (a, b) = pixels_front_and_back(&quad(true, 0.3, Some(0.5)), 4);
    assert_eq!((a, b), (0, 0), "alpha 0.3 under a 0.5 cutoff is discarded");
    let (a, b) = pixels_front_and_back(&quad(true, 0.3, Some(0.2)), 4);
    assert!(a > 100 && a == b, "alpha 0.3 over a 0.2 cutoff: {a}, {b}");
    let (a, b) = pixels_front_and_back(&quad(true, 0.3, None), 4);
    assert!(a > 100 && a == b, "OPAQUE ignores alpha: {a}, {b}");
}
