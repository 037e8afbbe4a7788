//! Every bundled glTF/UAV file (tests/data) loads into a drawable model, or fails with its
//! typed error; broken files fail with an error naming the file.

use crate::common;

use std::path::{Path, PathBuf};

use swarmshot::model::{ModelError, load_file};

fn gltf_files(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_owned()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap_or_else(|e| panic!("{}: {e}", d.display())) {
            let p = e.expect("entry").path();
            if p.is_dir() {
                stack.push(p);
            } else if p.extension().is_some_and(|x| x == "gltf" || x == "glb") {
                out.push(p);
            }
        }
    }
    out.sort();
    out
}

#[test]
fn every_bundled_model_loads_or_fails_typed() {
    let files: Vec<PathBuf> = [common::testdata("gltf"), common::testdata("uav")]
        .iter()
        .flat_map(|d| gltf_files(d))
        .collect();
    // 15 Khronos samples (one Draco variant among them) and 2 UAV models: tests/data/README.md.
    assert_eq!(
        files.len(),
        17,
        "expected the bundled test data, found {files:?}"
    );
    let mut draco = 0;
    for file in files {
        let is_draco = file.to_string_lossy().contains("Draco");
        match load_file(&file) {
            Ok(model) => {
                assert!(!is_draco, "{} should have failed", file.display());
                assert!(
                    !model.indices.is_empty() && model.indices.len() % 3 == 0,
                    "{}",
                    file.display()
                );
                assert!(
                    model
                        .indices
                        .iter()
                        .all(|&i| (i as usize) < model.vertices.len())
                );
                assert!(
                    model.vertices.iter().all(|v| v
                        .position
                        .iter()
                        .chain(&v.normal)
                        .all(|c| c.is_finite()))
                );
                // Normalised: largest span is 1, centred.
                let (lo, hi) = model.aabb;
                assert!(
                    ((hi - lo).max_element() - 1.0).abs() < 1e-6,
                    "{}: span {:?}",
                    file.display(),
                    hi - lo
                );
                assert!(((lo + hi) * 0.5).length() < 1e-6);
                assert!(model.hull.len() >= 3);
            }
            Err(ModelError::UnsupportedExtension { file: f, extension }) => {
                assert!(
                    is_draco,
                    "{}: unexpected unsupported {extension}",
                    file.display()
                );
                assert_eq!(extension, "KHR_draco_mesh_compression");
                assert_eq!(f, file);
                draco += 1;
            }
            Err(e) => panic!("{} failed: {e}", file.display()),
        }
    }
    assert_eq!(
        draco, 1,
        "the Draco variant must be among the files and fail typed"
    );
}

#[test]
fn node_hierarchies_are_applied() {
    // CesiumMilkTruck's wheels sit under transformed nodes: flattened, the truck is longer than tall.
    let truck = load_file(&common::testdata(
        "gltf/CesiumMilkTruck/glTF-Binary/CesiumMilkTruck.glb",
    ))
    .expect("truck loads");
    let (lo, hi) = truck.aabb;
    let span = hi - lo;
    assert!(
        span.max_element() == span.x || span.max_element() == span.z,
        "{span:?}"
    );
    assert!(
        truck.source_span > 1.0,
        "truck is metres long: {}",
        truck.source_span
    );
}

#[test]
fn units_do_not_matter_for_the_real_size() {
    // PX4's VTOL is in millimetres, the Crazyflie in metres: both normalise to a unit span.
    let vtol = load_file(&common::testdata("uav/px4_standard_vtol_x8/x8_wing.glb")).expect("vtol");
    let cf = load_file(&common::testdata("uav/crazyflie2_cf2/cf2.glb")).expect("cf2");
    assert!(
        vtol.source_span > 100.0 * cf.source_span,
        "mm vs m: {} vs {}",
        vtol.source_span,
        cf.source_span
    );
    for m in [&vtol, &cf] {
        assert!(((m.aabb.1 - m.aabb.0).max_element() - 1.0).abs() < 1e-6);
    }
}

#[test]
fn broken_files_give_errors_naming_the_file() {
    let dir = tempfile::tempdir().expect("tempdir");
    let glb = std::fs::read(common::testdata("gltf/Box/glTF-Binary/Box.glb")).expect("Box.glb");

    let truncated = dir.path().join("truncated.glb");
    std::fs::write(&truncated, &glb[..glb.len() / 2]).expect("write");
    let e = load_file(&truncated).expect_err("truncated GLB fails");
    assert!(e.to_string().contains("truncated.glb"), "{e}");

    let malformed = dir.path().join("malformed.gltf");
    std::fs::write(&malformed, "{ \"asset\": { \"version\": ").expect("write");
    let e = load_file(&malformed).expect_err("malformed JSON fails");
    assert!(
        matches!(e, ModelError::Parse { .. }) && e.to_string().contains("malformed.gltf"),
        "{e}"
    );

    let gltf = dir.path().join("Box.gltf");
    std::fs::copy(common::testdata("gltf/Box/glTF/Box.gltf"), &gltf).expect("copy");
    let e = load_file(&gltf).expect_err("missing .bin fails");
    assert!(
        matches!(e, ModelError::Buffer { .. }) && e.to_string().contains("Box0.bin"),
        "{e}"
    );

    let e = load_file(&dir.path().join("nope.glb")).expect_err("missing file fails");
    assert!(
        matches!(e, ModelError::Io { .. }) && e.to_string().contains("nope.glb"),
        "{e}"
    );

    // Garbage bytes of every length up to 64 never panic.
    for n in 0..64 {
        let p = dir.path().join(format!("junk{n}.glb"));
        let mut bytes = b"glTF".to_vec();
        bytes.extend((0..n).map(|i| (i * 37 % 251) as u8));
        std::fs::write(&p, bytes).expect("write");
        assert!(load_file(&p).is_err());
    }
}

#[test]
fn builtin_quad_loads_through_the_gltf_path() {
    let bytes = swarmshot::model::builtin::glb("quad_x").expect("embedded");
    let m = swarmshot::model::load_bytes(bytes, None, Path::new("builtin:quad_x"), "quad_x")
        .expect("loads");
    assert!(m.indices.len() / 3 > 100);
    // Distinct materials survive as distinct vertex colours.
    let colours: std::collections::HashSet<[u32; 4]> = m
        .vertices
        .iter()
        .map(|v| v.color.map(f32::to_bits))
        .collect();
    assert!(colours.len() >= 4);
}
