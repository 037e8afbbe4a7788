//! glTF read as the specification says: `KHR_texture_transform` in glTF's
//! v-down UV space (KhronosGroup/glTF#1563), skinned meshes posed by their
//! joints, and accessors that overrun their data named as such. The files are
//! built here, a few hundred bytes each.

use crate::common;

use std::f32::consts::FRAC_PI_2;
use std::path::Path;

use swarmshot::model::{self, CpuModel, ModelError};

fn load(bytes: &[u8]) -> Result<CpuModel, ModelError> {
    model::load_bytes(bytes, None, Path::new("test.glb"), "test")
}

#[track_caller]
fn assert_close(got: [f32; 2], want: [f32; 2]) {
    assert!(
        (got[0] - want[0]).abs() < 1e-5 && (got[1] - want[1]).abs() < 1e-5,
        "got {got:?}, want {want:?}"
    );
}

#[test]
fn texture_rotation_turns_uvs_counter_clockwise_in_v_down_uv_space() {
    // A quarter turn takes +u to −v: "up" in an image whose v axis points down.
    let quarter = model::uv_transform([0.0, 0.0], FRAC_PI_2, [1.0, 1.0]);
    assert_close(quarter([1.0, 0.0]), [0.0, -1.0]);
    assert_close(quarter([0.0, 1.0]), [1.0, 0.0]);
    // Scale first, then rotate, then offset (T · R · S).
    let trs = model::uv_transform([0.5, 0.25], FRAC_PI_2, [2.0, 3.0]);
    assert_close(trs([1.0, 0.0]), [0.5, -1.75]);
    assert_close(trs([0.0, 1.0]), [3.5, 0.25]);
    // The TextureTransformTest "Rotation" material (rotation 0.3926991 = 22.5°):
    // the sample viewer's matrix (columns (cos, −sin), (sin, cos)).
    let r = std::f32::consts::FRAC_PI_8;
    let m = model::uv_transform([0.0, 0.0], r, [1.0, 1.0]);
    let (s, c) = r.sin_cos();
    assert_close(m([0.3, 0.7]), [c * 0.3 + s * 0.7, -s * 0.3 + c * 0.7]);
}

#[test]
fn the_loader_bakes_the_texture_transform_into_vertex_uvs() {
    let (mut json, mut bin) = common::triangle_gltf();
    let uv_offset = bin.len();
    bin.extend(common::f32_le(&[0.0, 0.0, 1.0, 0.0, 0.0, 1.0]));
    json["bufferViews"]
        .as_array_mut()
        .expect("views")
        .push(serde_json::json!({"buffer": 0, "byteOffset": uv_offset, "byteLength": 24}));
    json["accessors"].as_array_mut().expect("accessors").push(
        serde_json::json!({"bufferView": 2, "componentType": 5126, "count": 3, "type": "VEC2"}),
    );
    json["meshes"][0]["primitives"][0]["attributes"]["TEXCOORD_0"] = serde_json::json!(2);
    json["meshes"][0]["primitives"][0]["material"] = serde_json::json!(0);
    json["extensionsUsed"] = serde_json::json!(["KHR_texture_transform"]);
    json["materials"] = serde_json::json!([{"pbrMetallicRoughness": {"baseColorTexture": {
        "index": 0,
        "extensions": {"KHR_texture_transform": {"rotation": FRAC_PI_2, "offset": [0.5, 0.0]}}
    }}}]);
    json["textures"] = serde_json::json!([{"source": 0}]);
    // An image that does not decode: the UVs are still baked (with a warning).
    json["images"] = serde_json::json!([{"uri": "data:image/png;base64,AAAA"}]);
    let m = load(&common::glb(&json, &bin)).expect("loads");
    let uvs: Vec<[f32; 2]> = m.vertices.iter().map(|v| v.uv).collect();
    assert_close(uvs[0], [0.5, 0.0]);
    assert_close(uvs[1], [0.5, -1.0]);
    assert_close(uvs[2], [1.5, 0.0]);
}

/// Two nodes draw the same skinned triangle, each with its own one-joint
/// skin; the joints stand 10 m apart. The skinned nodes' own transforms
/// (which glTF says to ignore) would put both at x = 100.
fn two_skeletons(with_joints: bool) -> Vec<u8> {
    let (mut json, mut bin) = common::triangle_gltf();
    if with_joints {
        let j = bin.len();
        bin.extend([0u8; 12]); // JOINTS_0: joint 0 for every vertex (u8 × 4)
        let w = bin.len();
        bin.extend(common::f32_le(&[1.0, 0.0, 0.0, 0.0].repeat(3)));
        let views = json["bufferViews"].as_array_mut().expect("views");
        views.push(serde_json::json!({"buffer": 0, "byteOffset": j, "byteLength": 12}));
        views.push(serde_json::json!({"buffer": 0, "byteOffset": w, "byteLength": 48}));
        let accessors = json["accessors"].as_array_mut().expect("accessors");
        accessors.push(
            serde_json::json!({"bufferView": 2, "componentType": 5121, "count": 3, "type": "VEC4"}),
        );
        accessors.push(
            serde_json::json!({"bufferView": 3, "componentType": 5126, "count": 3, "type": "VEC4"}),
        );
        let attributes = &mut json["meshes"][0]["primitives"][0]["attributes"];
        attributes["JOINTS_0"] = serde_json::json!(2);
        attributes["WEIGHTS_0"] = serde_json::json!(3);
    }
    json["nodes"] = serde_json::json!([
        {"name": "left", "mesh": 0, "skin": 0, "translation": [100.0, 0.0, 0.0]},
        {"name": "right", "mesh": 0, "skin": 1, "translation": [100.0, 0.0, 0.0]},
        {"name": "joint_l", "translation": [-5.0, 0.0, 0.0]},
        {"name": "joint_r", "translation": [5.0, 0.0, 0.0]}
    ]);
    json["skins"] = serde_json::json!([{"joints": [2]}, {"joints": [3]}]);
    json["scenes"] = serde_json::json!([{"nodes": [0, 1, 2, 3]}]);
    common::glb(&json, &bin)
}

#[test]
fn skinned_meshes_are_posed_by_their_joints_not_collapsed() {
    let m = load(&two_skeletons(true)).expect("loads");
    // x runs from −5 (left joint) to 5 + 1 (right joint + triangle width).
    assert!(
        (m.source_span - 11.0).abs() < 1e-4,
        "span {} (both copies collapsed onto one place?)",
        m.source_span
    );
    assert_eq!(m.triangle_count(), 2);
    assert!(m.warnings.is_empty(), "{:?}", m.warnings);
}

#[test]
fn a_skin_without_joint_attributes_is_warned_about_by_node_name() {
    let m = load(&two_skeletons(false)).expect("loads");
    assert!(
        m.warnings
            .iter()
            .any(|w| w.contains("\"left\"") && w.contains("JOINTS_0")),
        "{:?}",
        m.warnings
    );
}

#[test]
fn accessor_overruns_are_named_as_such() {
    let (mut json, bin) = common::triangle_gltf();
    json["accessors"][0]["count"] = serde_json::json!(30);
    let e = load(&common::glb(&json, &bin)).expect_err("overrun");
    let msg = e.to_string();
    assert!(
        msg.contains("accessor 0 (POSITION) is out of bounds") && msg.contains("buffer view 0"),
        "{msg}"
    );
    assert!(!msg.contains("no POSITION"), "{msg}");

    let (mut json, bin) = common::triangle_gltf();
    json["accessors"][1]["byteOffset"] = serde_json::json!(4);
    let msg = load(&common::glb(&json, &bin))
        .expect_err("index overrun")
        .to_string();
    assert!(
        msg.contains("accessor 1 (indices) is out of bounds"),
        "{msg}"
    );
}
