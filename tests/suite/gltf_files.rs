//! glTF loading against the real third-party files in tests/data and
//! against small broken or unusual files written into a tempdir.

use std::path::{Path, PathBuf};

use swarmshot::model::{CpuModel, ModelError, WrapMode, load_file};

fn testdata(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(rel)
}

fn gltf_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let mut entries: Vec<_> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .flatten()
        .map(|e| e.path())
        .collect();
    entries.sort();
    for p in entries {
        if p.is_dir() {
            gltf_files(&p, out);
        } else if matches!(p.extension().and_then(|e| e.to_str()), Some("gltf" | "glb")) {
            out.push(p);
        }
    }
}

fn assert_sane(path: &Path, m: &CpuModel) {
    let tris = m.triangle_count();
    assert!(
        tris > 0 && tris < 5_000_000,
        "{}: {tris} triangles",
        path.display()
    );
    assert_eq!(m.indices.len() % 3, 0);
    for &i in &m.indices {
        let v = &m.vertices[i as usize];
        assert!(
            v.position
                .iter()
                .all(|c| c.is_finite() && c.abs() <= 0.5 + 1e-4),
            "{}: position {:?} outside the unit span",
            path.display(),
            v.position
        );
        assert!(
            v.color
                .iter()
                .chain(&v.uv)
                .chain(&v.material)
                .all(|c| c.is_finite())
        );
    }
    // Draw ranges tile the index buffer, and name textures that exist.
    let mut next = 0;
    for d in &m.draws {
        assert_eq!(
            d.indices.start,
            next,
            "{}: draw ranges must be contiguous",
            path.display()
        );
        next = d.indices.end;
        assert!(d.texture.is_none_or(|t| t < m.textures.len()));
    }
    assert_eq!(next as usize, m.indices.len());
    let (lo, hi) = m.aabb;
    assert!(
        ((hi - lo).max_element() - 1.0).abs() < 1e-6,
        "{}: normalised span is {}",
        path.display(),
        (hi - lo).max_element()
    );
    assert!(m.source_span.is_finite() && m.source_span > 0.0);
}

#[test]
fn every_bundled_gltf_file_loads_or_fails_with_its_documented_error() {
    let mut files = Vec::new();
    gltf_files(&testdata("gltf"), &mut files);
    gltf_files(&testdata("uav"), &mut files);
    // 15 Khronos samples (one Draco variant among them) and 2 UAV models: tests/data/README.md.
    assert_eq!(
        files.len(),
        17,
        "expected the bundled test files, found {files:?}"
    );
    let (mut loaded, mut draco) = (0, 0);
    for path in &files {
        let result = load_file(path);
        if path
            .components()
            .any(|c| c.as_os_str().to_string_lossy().contains("Draco"))
        {
            match result {
                Err(ModelError::UnsupportedExtension { file, extension }) => {
                    assert_eq!(extension, "KHR_draco_mesh_compression");
                    assert_eq!(file, *path);
                    let msg = load_file(path)
                        .err()
                        .map(|e| e.to_string())
                        .unwrap_or_default();
                    assert!(
                        msg.contains(&path.display().to_string()) && msg.contains("Draco"),
                        "{msg}"
                    );
                    draco += 1;
                }
                other => panic!(
                    "{}: expected UnsupportedExtension, got {other:?}",
                    path.display()
                ),
            }
        } else {
            let m = result.unwrap_or_else(|e| panic!("{}: {e}", path.display()));
            assert_sane(path, &m);
            loaded += 1;
        }
    }
    assert_eq!(draco, 1);
    assert_eq!(loaded, 16);
}

fn load(rel: &str) -> CpuModel {
    let p = testdata(rel);
    load_file(&p).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn triangle_counts_of_known_files() {
    for (rel, tris) in [
        ("gltf/Box/glTF/Box.gltf", 12),
        ("gltf/Box/glTF-Binary/Box.glb", 12),
        ("gltf/Box/glTF-Embedded/Box.gltf", 12),
        ("gltf/BoxInterleaved/glTF/BoxInterleaved.gltf", 12),
        ("gltf/Triangle/glTF/Triangle.gltf", 1),
        (
            "gltf/TriangleWithoutIndices/glTF/TriangleWithoutIndices.gltf",
            1,
        ),
        // The default scene (1) holds the square, scene 0 the triangle.
        ("gltf/MultipleScenes/glTF/MultipleScenes.gltf", 2),
        // EXT_mesh_gpu_instancing: 125 instances of a 12-triangle box.
        (
            "gltf/SimpleInstancing/glTF-Binary/SimpleInstancing.glb",
            1500,
        ),
        ("gltf/CesiumMilkTruck/glTF-Binary/CesiumMilkTruck.glb", 3624),
    ] {
        assert_eq!(load(rel).triangle_count(), tris, "{rel}");
    }
}

#[test]
fn gpu_instancing_spreads_the_instances_out() {
    let m = load("gltf/SimpleInstancing/glTF-Binary/SimpleInstancing.glb");
    // 125 boxes laid out in space: many distinct box centres, not one box drawn 125 times.
    let mut centres = std::collections::BTreeSet::new();
    for tri in m.indices.chunks(36) {
        let c = tri
            .iter()
            .map(|&i| glam::Vec3::from(m.vertices[i as usize].position))
            .sum::<glam::Vec3>()
            / 36.0;
        centres.insert((c * 100.0).round().as_ivec3().to_array());
    }
    assert_eq!(centres.len(), 125);
}

#[test]
fn base_colour_textures_load_from_files_data_uris_and_glb_views() {
    for rel in [
        "gltf/BoxTextured/glTF/BoxTextured.gltf",
        "gltf/BoxTextured/glTF-Embedded/BoxTextured.gltf",
        "gltf/BoxTextured/glTF-Binary/BoxTextured.glb",
    ] {
        let m = load(rel);
        assert!(m.warnings.is_empty(), "{rel}: {:?}", m.warnings);
        assert_eq!(m.textures.len(), 1, "{rel}");
        let t = &m.textures[0];
        assert_eq!(t.rgba8.len(), (t.width * t.height * 4) as usize);
        assert_eq!(t.wrap, [WrapMode::Repeat, WrapMode::Repeat]);
        // The Cesium logo is not a flat colour.
        let distinct: std::collections::BTreeSet<_> =
            t.rgba8.chunks(4).map(|p| [p[0], p[1], p[2]]).collect();
        assert!(distinct.len() > 10, "{rel}: {} colours", distinct.len());
        assert_eq!(m.draws.len(), 1);
        assert_eq!(m.draws[0].texture, Some(0));
        let uvs: std::collections::BTreeSet<_> =
            m.vertices.iter().map(|v| v.uv.map(f32::to_bits)).collect();
        assert!(uvs.len() > 4, "{rel}: texture coordinates were not read");
    }
    // Two glTF textures sharing one image and sampler decode once; the glass has none.
    let truck = load("gltf/CesiumMilkTruck/glTF-Binary/CesiumMilkTruck.glb");
    assert_eq!(truck.textures.len(), 1);
    assert_eq!(truck.draws.len(), 2);
}

#[test]
fn material_factors_and_alpha_cutoff_travel_per_vertex() {
    let m = load("gltf/AlphaBlendModeTest/glTF-Binary/AlphaBlendModeTest.glb");
    let cutoffs: std::collections::BTreeSet<u32> = m
        .vertices
        .iter()
        .map(|v| (v.material[3] * 100.0).round() as u32)
        .collect();
    // MASK materials with cutoffs 0.25 and 0.75 (and the default 0.5), OPAQUE/BLEND = 0.
    assert!(
        cutoffs.contains(&25) && cutoffs.contains(&75) && cutoffs.contains(&0),
        "{cutoffs:?}"
    );
    let truck = load("gltf/CesiumMilkTruck/glTF-Binary/CesiumMilkTruck.glb");
    assert!(
        truck
            .vertices
            .iter()
            .all(|v| v.material[0] == 0.0 && v.material[1] == 1.0)
    );
}

#[test]
fn vertex_colours_are_baked() {
    let m = load("gltf/BoxVertexColors/glTF-Binary/BoxVertexColors.glb");
    let colours: std::collections::BTreeSet<_> = m
        .vertices
        .iter()
        .map(|v| v.color.map(|c| (c * 50.0) as i32))
        .collect();
    assert!(colours.len() > 3, "{colours:?}");
}

#[test]
fn models_in_millimetres_and_metres_normalise_to_a_unit_span() {
    let vtol = load("uav/px4_standard_vtol_x8/x8_wing.glb");
    let cf2 = load("uav/crazyflie2_cf2/cf2.glb");
    // The X8 wing spans ~2 m, written in millimetres; the Crazyflie ~0.1 m, in metres.
    assert!(vtol.source_span > 500.0, "x8 span {}", vtol.source_span);
    assert!(cf2.source_span < 1.0, "cf2 span {}", cf2.source_span);
    for m in [&vtol, &cf2] {
        let (lo, hi) = m.aabb;
        assert!(((hi - lo).max_element() - 1.0).abs() < 1e-9);
    }
}

// --- Files written for the test ---------------------------------------------

fn write(dir: &Path, name: &str, bytes: &[u8]) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, bytes).expect("write test file");
    p
}

#[test]
fn truncated_glb_missing_bin_and_malformed_json_are_typed_errors_naming_the_file() {
    let dir = tempfile::tempdir().expect("tempdir");
    let glb = std::fs::read(testdata("gltf/Box/glTF-Binary/Box.glb")).expect("Box.glb");
    for cut in [10, 40, glb.len() / 2, glb.len() - 4] {
        let p = write(dir.path(), "truncated.glb", &glb[..cut]);
        let e = load_file(&p).expect_err("truncated GLB must fail");
        assert!(
            matches!(e, ModelError::Parse { .. } | ModelError::Buffer { .. }),
            "cut {cut}: {e:?}"
        );
        assert!(e.to_string().contains("truncated.glb"), "{e}");
    }

    let gltf = std::fs::read(testdata("gltf/Box/glTF/Box.gltf")).expect("Box.gltf");
    let p = write(dir.path(), "nobin.gltf", &gltf);
    let e = load_file(&p).expect_err("missing .bin must fail");
    assert!(matches!(e, ModelError::Buffer { .. }), "{e:?}");
    let msg = e.to_string();
    assert!(
        msg.contains("nobin.gltf") && msg.contains("Box0.bin"),
        "{msg}"
    );

    let p = write(
        dir.path(),
        "bad.gltf",
        br#"{"asset": {"version": "2.0"}, "meshes": [ {"#,
    );
    let e = load_file(&p).expect_err("malformed JSON must fail");
    assert!(matches!(e, ModelError::Parse { .. }), "{e:?}");
    assert!(e.to_string().contains("bad.gltf"));

    let p = write(dir.path(), "empty.glb", b"");
    assert!(matches!(load_file(&p), Err(ModelError::Parse { .. })));
    let e = load_file(&dir.path().join("absent.glb")).expect_err("absent file");
    assert!(matches!(e, ModelError::Io { .. }) && e.to_string().contains("absent.glb"));
}

#[test]
fn required_quantization_is_refused_by_name() {
    let dir = tempfile::tempdir().expect("tempdir");
    let doc = r#"{"asset":{"version":"2.0"},"extensionsUsed":["KHR_mesh_quantization"],"extensionsRequired":["KHR_mesh_quantization"],"meshes":[]}"#;
    let p = write(dir.path(), "quant.gltf", doc.as_bytes());
    match load_file(&p) {
        Err(ModelError::UnsupportedExtension { extension, .. }) => {
            assert_eq!(extension, "KHR_mesh_quantization")
        }
        other => panic!("{other:?}"),
    }
}

/// A glTF document over one external buffer written next to it.
fn gltf_with_buffer(dir: &Path, name: &str, json: serde_json::Value, bin: &[u8]) -> PathBuf {
    let bin_name = format!("{name}.bin");
    write(dir, &bin_name, bin);
    let mut json = json;
    json["asset"] = serde_json::json!({"version": "2.0"});
    json["buffers"] = serde_json::json!([{"uri": bin_name, "byteLength": bin.len()}]);
    write(dir, &format!("{name}.gltf"), json.to_string().as_bytes())
}

fn f32_bytes(v: &[f32]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_le_bytes()).collect()
}

#[test]
fn node_transforms_compose_and_negative_scale_flips_winding() {
    let dir = tempfile::tempdir().expect("tempdir");
    // One triangle in the XY plane, counter-clockwise seen from +Z.
    let bin = f32_bytes(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0]);
    let json = serde_json::json!({
        "scene": 0,
        "scenes": [{"nodes": [0, 2]}],
        "nodes": [
            {"translation": [10.0, 0.0, 0.0], "children": [1]},
            {"scale": [2.0, 2.0, 2.0], "mesh": 0},
            {"scale": [-1.0, 1.0, 1.0], "mesh": 0}
        ],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0.0, 0.0, 0.0], "max": [1.0, 1.0, 0.0]}],
        "bufferViews": [{"buffer": 0, "byteLength": 36}]
    });
    let p = gltf_with_buffer(dir.path(), "nodes", json, &bin);
    let m = load_file(&p).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(m.triangle_count(), 2);
    // Undo the normalisation: source = normalised * span + centre. The file spans x ∈ [-1, 12].
    assert!((m.source_span - 13.0).abs() < 1e-5, "{}", m.source_span);
    let world =
        |i: u32| glam::DVec3::from(m.vertices[i as usize].position.map(f64::from)) * m.source_span;
    let tri = |t: usize| {
        [
            world(m.indices[3 * t]),
            world(m.indices[3 * t + 1]),
            world(m.indices[3 * t + 2]),
        ]
    };
    let normal = |[a, b, c]: [glam::DVec3; 3]| (b - a).cross(c - a);
    let (t0, t1) = (tri(0), tri(1));
    // Parent translation then child scale: the first triangle spans 2 m and sits 10 m right of the mirrored one.
    assert!(((t0[1] - t0[0]).length() - 2.0).abs() < 1e-4);
    assert!(((t0[0] - t1[0]).x - 10.0).abs() < 1e-4);
    // Both face +Z after the mirrored copy's winding flip.
    assert!(
        normal(t0).z > 0.0 && normal(t1).z > 0.0,
        "{:?} {:?}",
        normal(t0),
        normal(t1)
    );
    // Computed normals agree with the winding.
    assert!(m.vertices.iter().all(|v| v.normal[2] > 0.99));
}

#[test]
fn sparse_accessors_material_factors_and_unlit_are_read() {
    let dir = tempfile::tempdir().expect("tempdir");
    // Base positions are all zero; a sparse accessor moves vertices 1 and 2.
    let mut bin = f32_bytes(&[0.0; 9]); // view 0: base positions (36 bytes)
    bin.extend([1u8, 0, 2, 0]); // view 1: sparse indices (u16), 4 bytes
    bin.extend(f32_bytes(&[1.0, 0.0, 0.0, 0.0, 1.0, 0.0])); // view 2: sparse values, 24 bytes
    bin.extend([0u8, 0, 0, 0, 255, 0, 0, 0, 0, 255, 0, 0]); // view 3: UVs as normalised u8 (stride 4)
    let json = serde_json::json!({
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "materials": [{"pbrMetallicRoughness": {"baseColorFactor": [1.0, 0.5, 0.25, 1.0], "metallicFactor": 0.3, "roughnessFactor": 0.6},
                       "extensions": {"KHR_materials_unlit": {}}}],
        "extensionsUsed": ["KHR_materials_unlit"],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "TEXCOORD_0": 1}, "material": 0}]}],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0.0, 0.0, 0.0], "max": [1.0, 1.0, 0.0],
             "sparse": {"count": 2, "indices": {"bufferView": 1, "componentType": 5123}, "values": {"bufferView": 2}}},
            {"bufferView": 3, "componentType": 5121, "normalized": true, "count": 3, "type": "VEC2"}
        ],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 36},
            {"buffer": 0, "byteOffset": 36, "byteLength": 4},
            {"buffer": 0, "byteOffset": 40, "byteLength": 24},
            {"buffer": 0, "byteOffset": 64, "byteLength": 12, "byteStride": 4}
        ]
    });
    let p = gltf_with_buffer(dir.path(), "sparse", json, &bin);
    let m = load_file(&p).unwrap_or_else(|e| panic!("{e}"));
    // Without the sparse substitution the triangle would be degenerate (a typed error).
    assert_eq!(m.triangle_count(), 1);
    assert!((m.source_span - 1.0).abs() < 1e-6);
    // No base colour texture: UVs are only read for a textured material, so they stay 0 here;
    // the factors and the unlit flag are carried.
    let v = &m.vertices[0];
    assert_eq!(v.color, [1.0, 0.5, 0.25, 1.0]);
    assert_eq!(v.material, [0.3, 0.6, 1.0, 0.0]);
}

#[test]
fn points_and_lines_are_skipped_with_a_warning_and_alone_are_an_error() {
    let dir = tempfile::tempdir().expect("tempdir");
    let bin = f32_bytes(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0]);
    let doc = |modes: &[u32]| {
        serde_json::json!({
            "scenes": [{"nodes": [0]}],
            "nodes": [{"mesh": 0}],
            "meshes": [{"primitives": modes.iter().map(|m| serde_json::json!({"attributes": {"POSITION": 0}, "mode": m})).collect::<Vec<_>>()}],
            "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0.0, 0.0, 0.0], "max": [1.0, 1.0, 0.0]}],
            "bufferViews": [{"buffer": 0, "byteLength": 36}]
        })
    };
    let p = gltf_with_buffer(dir.path(), "mixed", doc(&[0, 1, 4]), &bin);
    let m = load_file(&p).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(m.triangle_count(), 1);
    assert_eq!(m.warnings.len(), 2, "{:?}", m.warnings);
    assert!(
        m.warnings[0].contains("Points") && m.warnings[1].contains("Lines"),
        "{:?}",
        m.warnings
    );
    let p = gltf_with_buffer(dir.path(), "lines", doc(&[1, 3]), &bin);
    match load_file(&p) {
        Err(e @ ModelError::NoTriangles { .. }) => assert!(e.to_string().contains("lines.gltf")),
        other => panic!("{other:?}"),
    }
}

#[test]
fn out_of_range_buffer_views_and_undecodable_textures_never_panic() {
    let dir = tempfile::tempdir().expect("tempdir");
    let bin = f32_bytes(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0]);
    let mut uv = f32_bytes(&[0.0, 0.0, 1.0, 0.0, 0.0, 1.0]);
    let mut all = bin.clone();
    all.append(&mut uv);
    all.extend(b"not a png at all");
    let json = serde_json::json!({
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "images": [{"bufferView": 2, "mimeType": "image/png"}],
        "textures": [{"source": 0}],
        "materials": [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "TEXCOORD_0": 1}, "material": 0}]}],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0.0, 0.0, 0.0], "max": [1.0, 1.0, 0.0]},
            {"bufferView": 1, "componentType": 5126, "count": 3, "type": "VEC2"}
        ],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 36},
            {"buffer": 0, "byteOffset": 36, "byteLength": 24},
            {"buffer": 0, "byteOffset": 60, "byteLength": 16}
        ]
    });
    let p = gltf_with_buffer(dir.path(), "badtex", json.clone(), &all);
    let m = load_file(&p).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(m.textures.len(), 0);
    assert!(
        m.warnings.iter().any(|w| w.contains("cannot be decoded")),
        "{:?}",
        m.warnings
    );
    assert_eq!(m.draws.len(), 1);
    assert_eq!(m.draws[0].texture, None);

    // A view past the end of its buffer: an error, not a panic.
    let mut broken = json;
    broken["bufferViews"][0]["byteLength"] = serde_json::json!(4000);
    let p = gltf_with_buffer(dir.path(), "overrun", broken, &all);
    let e = load_file(&p).expect_err("overrun must fail");
    assert!(e.to_string().contains("overrun.gltf"), "{e}");
}
