//! A .gltf's buffer and image URIs are confined to the model's folder,
//! devices are refused however they are named, reads are bounded by the
//! declared length, and sparse indices are bounds-checked (issue 25).

use crate::common;

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use swarmshot::model::{self, ModelError, UriPolicy};

const ALLOW: UriPolicy = UriPolicy {
    allow_outside_folder: true,
};

/// `dir/name.gltf`: the triangle with its buffer at `buffer_uri`
/// (and, when given, a textured material whose image is at `image_uri`).
fn triangle_with_uris(dir: &Path, buffer_uri: &str, image_uri: Option<&str>) -> PathBuf {
    let (mut json, bin) = common::triangle_gltf();
    json["asset"] = serde_json::json!({"version": "2.0"});
    json["buffers"] = serde_json::json!([{"uri": buffer_uri, "byteLength": bin.len()}]);
    if let Some(image) = image_uri {
        json["images"] = serde_json::json!([{"uri": image}]);
        json["textures"] = serde_json::json!([{"source": 0}]);
        json["materials"] =
            serde_json::json!([{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}]);
        json["meshes"][0]["primitives"][0]["material"] = serde_json::json!(0);
    }
    let path = dir.join("model.gltf");
    std::fs::write(&path, json.to_string()).expect("write gltf");
    std::fs::write(dir.join("tri.bin"), &bin).expect("write bin");
    path
}

fn model_dir(root: &Path) -> PathBuf {
    let dir = root.join("a/b");
    std::fs::create_dir_all(&dir).expect("mkdir");
    dir
}

#[test]
fn a_buffer_uri_climbing_out_of_the_folder_is_refused() {
    let root = tempfile::tempdir().expect("tempdir");
    let dir = model_dir(root.path());
    // A real triangle outside the folder: read only when allowed.
    let (_, bin) = common::triangle_gltf();
    std::fs::write(root.path().join("outside.bin"), &bin).expect("write");
    for uri in ["../../etc/passwd", "../../outside.bin", "sub/../../x.bin"] {
        let path = triangle_with_uris(&dir, uri, None);
        let e = model::load_file(&path).expect_err("escape refused");
        let msg = e.to_string();
        assert!(matches!(e, ModelError::Buffer { .. }), "{e:?}");
        assert!(
            msg.contains("out of the model's folder")
                && msg.contains("allow_uris_outside_folder")
                && msg.contains(uri),
            "{msg}"
        );
    }
    // A `..` that stays inside is fine, and the escape is read when allowed.
    std::fs::create_dir_all(dir.join("sub")).expect("mkdir");
    let inside = triangle_with_uris(&dir, "sub/../tri.bin", None);
    assert_eq!(
        model::load_file(&inside).expect("inside").triangle_count(),
        1
    );
    let out = triangle_with_uris(&dir, "../../outside.bin", None);
    let m = model::load_file_with(&out, ALLOW).expect("allowed");
    assert_eq!(m.triangle_count(), 1);
}

#[test]
fn absolute_and_file_uris_are_refused_and_devices_too_when_allowed() {
    let root = tempfile::tempdir().expect("tempdir");
    let dir = model_dir(root.path());
    let start = Instant::now();
    for uri in ["file:///dev/zero", "/dev/zero", "file:/dev/zero"] {
        let path = triangle_with_uris(&dir, uri, None);
        let e = model::load_file(&path).expect_err("absolute refused");
        let msg = e.to_string();
        assert!(
            msg.contains("allow_uris_outside_folder") && msg.contains("buffer 0"),
            "{msg}"
        );
        // Allowed outside, a device is still refused by the opened file's type.
        let e = model::load_file_with(&path, ALLOW).expect_err("device refused");
        assert!(
            e.to_string().contains("a device, not a regular file"),
            "{e}"
        );
    }
    // Images alike: a texture at file:///dev/zero is an error, not 4 GB read.
    for uri in ["file:///dev/zero", "/dev/zero"] {
        let path = triangle_with_uris(&dir, "tri.bin", Some(uri));
        let e = model::load_file(&path).expect_err("image refused");
        assert!(
            e.to_string().contains("image 0")
                && e.to_string().contains("allow_uris_outside_folder"),
            "{e}"
        );
        let e = model::load_file_with(&path, ALLOW).expect_err("device image refused");
        assert!(
            e.to_string().contains("a device, not a regular file"),
            "{e}"
        );
    }
    assert!(
        start.elapsed() < Duration::from_secs(10),
        "{:?}",
        start.elapsed()
    );
}

#[test]
fn a_link_out_of_the_folder_and_a_fifo_inside_are_refused() {
    let root = tempfile::tempdir().expect("tempdir");
    let dir = model_dir(root.path());
    let (_, bin) = common::triangle_gltf();
    std::fs::write(root.path().join("outside.bin"), &bin).expect("write");
    std::os::unix::fs::symlink(root.path().join("outside.bin"), dir.join("link.bin"))
        .expect("symlink");
    let path = triangle_with_uris(&dir, "link.bin", None);
    let e = model::load_file(&path).expect_err("link out refused");
    assert!(e.to_string().contains("a link leads out"), "{e}");
    assert_eq!(
        model::load_file_with(&path, ALLOW)
            .expect("allowed")
            .triangle_count(),
        1
    );
    // A FIFO named inside the folder is refused by its type, without blocking.
    let fifo = dir.join("pipe.bin");
    let status = std::process::Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .expect("mkfifo");
    assert!(status.success());
    let start = Instant::now();
    let path = triangle_with_uris(&dir, "pipe.bin", None);
    let e = model::load_file_with(&path, ALLOW).expect_err("fifo refused");
    assert!(e.to_string().contains("FIFO"), "{e}");
    assert!(start.elapsed() < Duration::from_secs(5));
}

#[test]
fn buffer_reads_stop_at_the_declared_byte_length() {
    let root = tempfile::tempdir().expect("tempdir");
    let dir = model_dir(root.path());
    let path = triangle_with_uris(&dir, "big.bin", None);
    // The triangle's 42 bytes, then 64 MiB more that must not be read.
    let (_, bin) = common::triangle_gltf();
    let big = dir.join("big.bin");
    std::fs::write(&big, &bin).expect("write");
    let f = std::fs::OpenOptions::new()
        .append(true)
        .open(&big)
        .expect("open");
    f.set_len(64 << 20).expect("grow");
    let m = model::load_file(&path).expect("loads");
    assert_eq!(m.triangle_count(), 1);
    // A file shorter than its byteLength is a named error.
    std::fs::write(&big, &bin[..20]).expect("write");
    let e = model::load_file(&path).expect_err("short buffer");
    assert!(matches!(e, ModelError::Buffer { .. }), "{e:?}");
}

#[test]
fn sparse_indices_out_of_range_are_a_named_error() {
    let dir = tempfile::tempdir().expect("tempdir");
    for bad in [7u32, 4_000_000_000] {
        let mut bin = f32_bytes(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0]);
        bin.extend(1u32.to_le_bytes());
        bin.extend(bad.to_le_bytes());
        bin.extend(f32_bytes(&[1.0, 0.0, 0.0, 0.0, 1.0, 1.0]));
        let json = serde_json::json!({
            "scenes": [{"nodes": [0]}],
            "nodes": [{"mesh": 0}],
            "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
            "accessors": [
                {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                 "min": [0.0, 0.0, 0.0], "max": [1.0, 1.0, 1.0],
                 "sparse": {"count": 2, "indices": {"bufferView": 1, "componentType": 5125},
                            "values": {"bufferView": 2}}}
            ],
            "bufferViews": [
                {"buffer": 0, "byteOffset": 0, "byteLength": 36},
                {"buffer": 0, "byteOffset": 36, "byteLength": 8},
                {"buffer": 0, "byteOffset": 44, "byteLength": 24}
            ]
        });
        let glb = common::glb(&json, &bin);
        let e = model::load_bytes(&glb, Some(dir.path()), Path::new("sparse.glb"), "sparse")
            .expect_err("sparse index out of range");
        let msg = e.to_string();
        assert!(
            msg.contains(&format!("sparse index {bad}")) && msg.contains("out of range for 3"),
            "{msg}"
        );
    }
}

fn f32_bytes(v: &[f32]) -> Vec<u8> {
    v.iter().flat_map(|f| f.to_le_bytes()).collect()
}
