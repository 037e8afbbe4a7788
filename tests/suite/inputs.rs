//! Every bad input gets a named error (or a loud warning) before anything is
//! written: unknown fields with the nearest known name, counts that overflow,
//! sizes past the adapter's limits or memory, files that are not regular files,
//! node graphs that explode, degenerate scenes, and bad command-line values.
//! docs/reliability.md section 5 lists each class and its message.

use crate::common;

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

use swarmshot::model::{self, ModelError};
use swarmshot::preset::{
    DeviceLimits, ModelSource, ModelSpec, Placement, Preset, Resolution, Sky, SkyImageSource,
    Volume,
};

fn swarmshot() -> Command {
    Command::new(env!("CARGO_BIN_EXE_swarmshot"))
}

fn errors_of(p: &Preset) -> Vec<String> {
    p.validate()
        .err()
        .unwrap_or_default()
        .iter()
        .map(ToString::to_string)
        .collect()
}

#[track_caller]
fn assert_error(p: &Preset, field: &str, needle: &str) {
    let errors = errors_of(p);
    assert!(
        errors
            .iter()
            .any(|e| e.starts_with(&format!("{field}:")) && e.contains(needle)),
        "expected an error on `{field}` mentioning {needle:?}, got {errors:#?}"
    );
}

fn write_preset(dir: &Path, name: &str, p: &Preset) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, p.to_ron()).expect("write preset");
    path
}

fn mkfifo(path: &Path) {
    let ok = Command::new("mkfifo")
        .arg(path)
        .status()
        .expect("mkfifo runs")
        .success();
    assert!(ok, "mkfifo {}", path.display());
}

// ---- unknown fields -------------------------------------------------------

#[test]
fn misspelt_fields_are_refused_with_their_path_and_the_nearest_name() {
    let e = Preset::from_ron("(camera: (fovy_deg: 20.0))")
        .expect_err("unknown field")
        .to_string();
    assert!(
        e.contains("unknown field `fovy_deg` in `camera`")
            && e.contains("did you mean `fov_y_deg`?"),
        "{e}"
    );
    let e = Preset::from_ron("(sed: 3)")
        .expect_err("unknown top-level field")
        .to_string();
    assert!(
        e.contains("`sed` in the preset") && e.contains("did you mean `seed`?"),
        "{e}"
    );
    // Inside an enum's struct variant, and deeper in a sweep.
    let e = Preset::from_ron(
        "(placement: Randomized(count: (1, 3), volume: Box(size_m: (1.0, 1.0, 1.0)), min_seperation_m: 0.5))",
    )
    .expect_err("misspelt variant field")
        .to_string();
    assert!(
        e.contains("`placement`") && e.contains("did you mean `min_separation_m`?"),
        "{e}"
    );
    let e = Preset::from_ron("(plane: (ry: (start: 0.0, end: 90.0, stp: 45.0)))")
        .expect_err("misspelt sweep field")
        .to_string();
    assert!(
        e.contains("`plane.ry`") && e.contains("did you mean `step`?"),
        "{e}"
    );
    // Unknown variants too, with the list they may take.
    let e = Preset::from_ron("(render: (resolution: Uhd4K))")
        .expect_err("variant")
        .to_string();
    assert!(
        e.contains("`render.resolution`") && e.contains("did you mean `Uhd4k`?"),
        "{e}"
    );
    let e = Preset::from_ron("(output: (label_formats: [Yolo, Cocoa]))")
        .expect_err("variant")
        .to_string();
    assert!(
        e.contains("`output.label_formats[1]`") && e.contains("did you mean `Coco`?"),
        "{e}"
    );
    // Something far from every name gets the list, not a guess.
    let e = Preset::from_ron("(camera: (banana: 1.0))")
        .expect_err("unknown")
        .to_string();
    assert!(
        !e.contains("did you mean") && e.contains("fov_y_deg"),
        "{e}"
    );
}

#[test]
fn preset_files_with_unknown_fields_fail_check_naming_the_file() {
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("typo.ron");
    std::fs::write(&path, "(\n  camera: (\n    fovy_deg: 20.0,\n  ),\n)\n").expect("write");
    let out = swarmshot().arg("check").arg(&path).output().expect("runs");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(
        err.contains("typo.ron") && err.contains("3:5") && err.contains("fov_y_deg"),
        "{err}"
    );
}

// ---- counts and sizes -----------------------------------------------------

#[test]
fn grid_counts_whose_product_overflows_are_refused() {
    let mut p = Preset::default();
    p.placement = Placement::Structured {
        x_count: u32::MAX,
        y_count: u32::MAX,
        z_count: u32::MAX,
        load_factor: 2.0,
    };
    assert_error(&p, "placement", "more than 2⁶⁴");
    p.placement = Placement::Structured {
        x_count: 2000,
        y_count: 2000,
        z_count: 2000,
        load_factor: 2.0,
    };
    assert_error(&p, "placement", "8000000000 drones per frame");
}

#[test]
fn frames_too_large_for_memory_or_the_adapter_are_refused() {
    let mut p = common::tiny_preset();
    p.render.resolution = Resolution::Custom {
        width: 16384,
        height: 16384,
    };
    p.render.msaa = 4;
    assert_error(&p, "render.resolution", "of memory per frame");

    // Within the fixed cap, the device's limits decide.
    let mut p = common::tiny_preset();
    p.render.resolution = Resolution::Custom {
        width: 8192,
        height: 4096,
    };
    assert!(p.validate().is_ok(), "{:?}", p.validate());
    let limits = DeviceLimits {
        max_texture_side: 4096,
        max_buffer_bytes: 64 << 20,
        memory_bytes: Some(1 << 30),
    };
    let errors: Vec<String> = p
        .check_limits(&limits)
        .expect_err("over every limit")
        .iter()
        .map(ToString::to_string)
        .collect();
    let all = errors.join("\n");
    assert!(
        all.contains("render.resolution.width: 8192 px")
            && all.contains("largest texture side, 4096 px"),
        "{all}"
    );
    assert!(all.contains("readback buffer"), "{all}");
    assert!(all.contains("but only 1.0 GiB is available"), "{all}");
    // The id layer's scale counts against the texture side.
    let mut q = common::tiny_preset();
    q.labels.id_scale = 4;
    q.render.resolution = Resolution::Custom {
        width: 2048,
        height: 1024,
    };
    let e = q.check_limits(&limits).expect_err("8192-wide id layer");
    assert!(e[0].to_string().contains("id scale 4"), "{e:?}");
    let roomy = DeviceLimits {
        max_texture_side: 16384,
        max_buffer_bytes: 1 << 30,
        memory_bytes: None,
    };
    assert!(common::tiny_preset().check_limits(&roomy).is_ok());
}

#[test]
fn check_refuses_a_resolution_the_adapter_or_memory_cannot_hold() {
    let dir = tempfile::tempdir().expect("tempdir");
    let mut p = common::tiny_preset();
    p.render.resolution = Resolution::Custom {
        width: 16384,
        height: 16384,
    };
    p.render.msaa = 4;
    let path = write_preset(dir.path(), "huge.ron", &p);
    let out = swarmshot().arg("check").arg(&path).output().expect("runs");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{err}");
    assert!(err.contains("render.resolution"), "{err}");
}

// ---- files ----------------------------------------------------------------

fn with_model(path: &Path) -> Preset {
    let mut p = common::tiny_preset();
    p.models = vec![ModelSpec {
        source: ModelSource::File(path.to_owned()),
        ..ModelSpec::default()
    }];
    p
}

#[test]
fn models_must_be_regular_files_of_bounded_size() {
    let dir = tempfile::tempdir().expect("tempdir");
    let fifo = dir.path().join("pipe.glb");
    mkfifo(&fifo);
    let start = Instant::now();
    for (path, needle) in [
        (fifo.as_path(), "FIFO"),
        (Path::new("/dev/zero"), "a device"),
        (dir.path(), "a folder"),
    ] {
        let e = model::load_file(path).expect_err("not a regular file");
        assert!(matches!(e, ModelError::Io { .. }), "{e:?}");
        let msg = e.to_string();
        assert!(
            msg.contains(needle) && msg.contains("not a regular file"),
            "{msg}"
        );
    }
    assert!(
        start.elapsed() < Duration::from_secs(5),
        "refused without opening"
    );

    // A .gltf whose buffer URI names a FIFO or a device is refused before the reader opens it.
    let (mut json, _) = common::triangle_gltf();
    json["asset"] = serde_json::json!({"version": "2.0"});
    // (An absolute path is refused before that unless the model allows it: tests/suite/gltf_uris.rs.)
    let allow = model::UriPolicy {
        allow_outside_folder: true,
    };
    for uri in ["pipe.glb", "/dev/zero"] {
        json["buffers"] = serde_json::json!([{"uri": uri, "byteLength": 42}]);
        let path = dir.path().join("external.gltf");
        std::fs::write(&path, json.to_string()).expect("write");
        let e = model::load_file_with(&path, allow).expect_err("buffer URI is not a regular file");
        assert!(
            matches!(e, ModelError::Buffer { .. }) && e.to_string().contains("not a regular file"),
            "{e}"
        );
    }
    assert!(start.elapsed() < Duration::from_secs(5));
}

#[test]
fn sky_images_and_presets_must_be_regular_files_and_check_loads_skies() {
    let dir = tempfile::tempdir().expect("tempdir");
    let fifo = dir.path().join("sky.png");
    mkfifo(&fifo);
    let mut p = common::tiny_preset();
    p.sky = Sky::Image {
        source: SkyImageSource::Equirect(fifo.clone()),
        exposure_ev: 0.0,
        rotation_deg: 0.0,
        sun_elevation_deg: 45.0,
        sun_azimuth_deg: 0.0,
    };
    let e = swarmshot::pipeline::FramePipeline::new(p.clone()).expect_err("FIFO sky");
    assert!(e.to_string().contains("FIFO"), "{e}");

    // `check` loads the sky images the batch needs: a missing one fails it.
    p.sky = Sky::Image {
        source: SkyImageSource::Equirect(dir.path().join("missing.hdr")),
        exposure_ev: 0.0,
        rotation_deg: 0.0,
        sun_elevation_deg: 45.0,
        sun_azimuth_deg: 0.0,
    };
    let path = write_preset(dir.path(), "sky.ron", &p);
    let out = swarmshot().arg("check").arg(&path).output().expect("runs");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("missing.hdr"),
        "{err}"
    );

    // A preset that is a FIFO is refused, not waited on.
    let pipe = dir.path().join("preset.ron");
    mkfifo(&pipe);
    let e = Preset::load(&pipe).expect_err("FIFO preset");
    assert!(e.to_string().contains("FIFO"), "{e}");
}

#[test]
fn sky_images_too_large_alone_or_together_are_refused_from_their_headers() {
    use swarmshot::preset::Sky;
    use swarmshot::sky::{EnvironmentAssets, EnvironmentError};
    let tmp = tempfile::tempdir().expect("tmp");
    let image = |name: &str, (w, h): (u32, u32)| {
        let path = tmp.path().join(name);
        std::fs::write(&path, common::png_header(w, h)).expect("png");
        format!("Image(source: Equirect({path:?}))")
    };
    let load = |text: String| EnvironmentAssets::load(&ron::from_str::<Sky>(&text).expect("sky"));
    // 22 000 × 22 000 from a header of a few dozen bytes (1.9 GB as grey
    // bytes, 5.8 GB as linear RGB floats): refused by name, not decoded.
    let e = load(image("huge.png", (22_000, 22_000)))
        .expect_err("huge")
        .to_string();
    assert!(
        e.contains("huge.png") && e.contains("64000000-pixel limit"),
        "{e}"
    );
    // 64 images of 4096 × 2048 (96 MiB each once loaded): refused together
    // before any is decoded; 16 of them are within the budget, and go on to
    // be decoded (these headers have no pixels, so that fails, naming one).
    let choices: Vec<String> = (0..64)
        .map(|i| image(&format!("s{i}.png"), (4096, 2048)))
        .collect();
    let random = |n: usize| format!("Random(choices: [{}])", choices[..n].join(", "));
    let e = load(random(64)).expect_err("64 images");
    assert!(
        matches!(e, EnvironmentError::Memory { images: 64, .. }),
        "{e:?}"
    );
    let text = e.to_string();
    assert!(
        text.contains("6144 MiB") && text.contains("2048 MiB"),
        "{text}"
    );
    let e = load(random(16)).expect_err("no pixels");
    assert!(matches!(e, EnvironmentError::Image { .. }), "{e:?}");
}

/// A mesh of `vertices` positions (a fan of triangles, so every position is
/// used; `indices` u16 indices cycling over the first three when given)
/// placed by `nodes` nodes: a GLB of a few kilobytes.
fn instanced_mesh_glb(vertices: usize, indices: Option<usize>, nodes: usize) -> Vec<u8> {
    let mut bin = common::f32_le(
        &(0..vertices)
            .flat_map(|i| {
                let a = i as f32 * 0.01;
                [a.cos(), a.sin(), 0.0]
            })
            .collect::<Vec<f32>>(),
    );
    let positions = bin.len();
    let mut primitive = serde_json::json!({"attributes": {"POSITION": 0}, "mode": 6});
    let mut accessors = vec![serde_json::json!({"bufferView": 0, "componentType": 5126,
        "count": vertices, "type": "VEC3", "min": [-1.0, -1.0, 0.0], "max": [1.0, 1.0, 0.0]})];
    let mut views =
        vec![serde_json::json!({"buffer": 0, "byteOffset": 0, "byteLength": positions})];
    if let Some(n) = indices {
        bin.extend((0..n).flat_map(|i| ((i % 3) as u16).to_le_bytes()));
        views.push(serde_json::json!({"buffer": 0, "byteOffset": positions, "byteLength": 2 * n}));
        accessors.push(serde_json::json!({"bufferView": 1, "componentType": 5123, "count": n, "type": "SCALAR"}));
        primitive = serde_json::json!({"attributes": {"POSITION": 0}, "indices": 1});
    }
    let json = serde_json::json!({
        "bufferViews": views,
        "accessors": accessors,
        "meshes": [{"name": "m", "primitives": [primitive]}],
        "nodes": vec![serde_json::json!({"mesh": 0}); nodes],
        "scenes": [{"nodes": (0..nodes).collect::<Vec<_>>()}],
        "scene": 0
    });
    common::glb(&json, &bin)
}

#[test]
fn a_small_file_that_places_a_mesh_too_often_is_refused_before_it_is_baked() {
    // 9 000 nodes × 1 000 vertices: 9 M vertices (576 MB baked) from a 12 KB
    // buffer; 90 000 nodes × 600 indices: 54 M indices. Each refused by name
    // from the accessors' counts, before a vertex is allocated.
    for (bytes, what) in [
        (instanced_mesh_glb(1000, None, 9000), "9000000 vertices"),
        (
            instanced_mesh_glb(3, Some(600), 90_000),
            "54000000 triangle indices",
        ),
    ] {
        let start = Instant::now();
        let e = model::load_bytes(&bytes, None, Path::new("many.glb"), "many").expect_err(what);
        assert!(matches!(e, ModelError::TooLarge { .. }), "{e:?}");
        let text = e.to_string();
        assert!(text.contains("many.glb") && text.contains(what), "{text}");
        assert!(
            start.elapsed() < Duration::from_secs(10),
            "{:?}",
            start.elapsed()
        );
    }
    // Under the limits the same file loads: 100 nodes × 1 000 vertices.
    let m = model::load_bytes(
        &instanced_mesh_glb(1000, None, 100),
        None,
        Path::new("few.glb"),
        "few",
    )
    .expect("100 instances load");
    assert_eq!(m.vertices.len(), 100_000);
}

#[test]
fn a_node_graph_that_doubles_at_every_level_is_refused_not_expanded() {
    // Level i holds nodes a_i and b_i; both list a_{i+1} and b_{i+1} as
    // children, so the flattened scene would hold 2^40 triangles. 2 KB of JSON.
    let (mut json, bin) = common::triangle_gltf();
    let levels = 40;
    let mut nodes = Vec::new();
    for i in 0..levels {
        let children = if i + 1 < levels {
            serde_json::json!([2 * (i + 1), 2 * (i + 1) + 1])
        } else {
            serde_json::json!([])
        };
        for _ in 0..2 {
            nodes.push(serde_json::json!({"mesh": 0, "children": children}));
        }
    }
    json["nodes"] = serde_json::Value::Array(nodes);
    json["scenes"] = serde_json::json!([{"nodes": [0, 1]}]);
    let bytes = common::glb(&json, &bin);
    let start = Instant::now();
    let e = model::load_bytes(&bytes, None, Path::new("dag.glb"), "dag").expect_err("DAG");
    assert!(matches!(e, ModelError::NodeGraph { .. }), "{e:?}");
    assert!(
        e.to_string().contains("dag.glb") && e.to_string().contains("DAG"),
        "{e}"
    );
    assert!(
        start.elapsed() < Duration::from_secs(20),
        "{:?}",
        start.elapsed()
    );
}

// ---- degenerate scenes ----------------------------------------------------

#[test]
fn degenerate_scenes_are_errors_or_loud_warnings() {
    let mut p = common::tiny_preset();
    p.placement = Placement::Randomized {
        count: (1, 5),
        count_distribution: Default::default(),
        volume: Volume::Box {
            size_m: (0.0, 0.0, 0.0),
        },
        min_separation_m: 0.0,
    };
    assert_error(&p, "placement.volume.size_m", "is a point");

    p.placement = Placement::Randomized {
        count: (1, 5),
        count_distribution: Default::default(),
        volume: Volume::Density { per_m3: 1e-30 },
        min_separation_m: 0.5,
    };
    assert_error(&p, "placement.volume.per_m3", "larger than the 1e6 m limit");

    // Separation smaller than the drone: allowed, but said.
    p.placement = Placement::Randomized {
        count: (2, 5),
        count_distribution: Default::default(),
        volume: Volume::Box {
            size_m: (6.0, 3.0, 6.0),
        },
        min_separation_m: 0.1,
    };
    assert!(p.validate().is_ok());
    let warnings: Vec<String> = p.warnings().iter().map(ToString::to_string).collect();
    assert!(
        warnings
            .iter()
            .any(|w| w.starts_with("placement.min_separation_m:") && w.contains("overlap")),
        "{warnings:?}"
    );
    assert!(common::tiny_preset().warnings().is_empty());

    let dir = tempfile::tempdir().expect("tempdir");
    let path = write_preset(dir.path(), "crowded.ron", &p);
    let out = swarmshot().arg("check").arg(&path).output().expect("runs");
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        text.contains("warning: placement.min_separation_m"),
        "{text}"
    );
}

// ---- the command line -----------------------------------------------------

#[test]
fn bad_command_line_values_are_named_errors_and_write_nothing() {
    let dir = tempfile::tempdir().expect("tempdir");
    let preset = write_preset(dir.path(), "tiny.ron", &common::tiny_preset());
    let out_dir = dir.path().join("out");
    for (args, needle) in [
        (vec!["--threads", "100000"], "--threads 100000"),
        (vec!["--limit", "0"], "--limit 0"),
    ] {
        let out = swarmshot()
            .arg("batch")
            .arg(&preset)
            .arg("--out")
            .arg(&out_dir)
            .args(&args)
            .output()
            .expect("runs");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{args:?}");
        assert!(
            err.contains(needle) && !err.contains("panicked"),
            "{args:?}: {err}"
        );
        assert!(!out_dir.exists(), "{args:?} created the output folder");
    }

    // `frame --out f.bmp` is refused before any file exists.
    let bmp = dir.path().join("f.bmp");
    let out = swarmshot()
        .arg("frame")
        .arg(&preset)
        .arg("--out")
        .arg(&bmp)
        .output()
        .expect("runs");
    assert!(!out.status.success());
    for ext in ["bmp", "txt", "json"] {
        assert!(!bmp.with_extension(ext).exists(), ".{ext} left behind");
    }
}

#[test]
fn a_sky_image_inside_the_output_folder_is_refused_and_frame_never_writes_over_inputs_or_files() {
    let dir = tempfile::tempdir().expect("tempdir");
    let sky = dir.path().join("sky.png");
    image::RgbImage::from_fn(64, 32, |x, y| image::Rgb([x as u8 * 4, y as u8 * 8, 200]))
        .save(&sky)
        .expect("sky");
    let mut p = common::tiny_preset();
    p.sky = swarmshot::preset::Sky::Image {
        source: swarmshot::preset::SkyImageSource::Equirect(sky.clone()),
        exposure_ev: 0.0,
        rotation_deg: 0.0,
        sun_elevation_deg: 40.0,
        sun_azimuth_deg: 0.0,
    };
    let preset = write_preset(dir.path(), "p.json", &p);
    // The batch into the folder that holds its sky image: refused, nothing written.
    let o = swarmshot()
        .arg("batch")
        .arg(&preset)
        .arg("--out")
        .arg(dir.path())
        .output()
        .expect("runs");
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success() && err.contains("sky.png") && err.contains("inside the output folder"),
        "{err}"
    );
    assert_eq!(
        std::fs::read_dir(dir.path()).expect("ls").count(),
        2,
        "{err}"
    );
    let frame = |out: &Path, overwrite: bool| {
        let mut c = swarmshot();
        c.arg("frame").arg(&preset).arg("--out").arg(out);
        if overwrite {
            c.arg("--overwrite");
        }
        c.output().expect("runs")
    };
    // `frame --out p.png` would write its record over the preset p.json, and
    // `--out sky.png` its image over the sky: refused even with --overwrite.
    let (preset_text, sky_bytes) = (
        std::fs::read(&preset).expect("p"),
        std::fs::read(&sky).expect("s"),
    );
    for (out, input) in [("p.png", "p.json"), ("sky.png", "sky.png")] {
        let o = frame(&dir.path().join(out), true);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(
            !o.status.success() && err.contains(input) && err.contains("which the run reads"),
            "{err}"
        );
    }
    assert_eq!(std::fs::read(&preset).expect("p"), preset_text);
    assert_eq!(std::fs::read(&sky).expect("s"), sky_bytes);
    assert_eq!(std::fs::read_dir(dir.path()).expect("ls").count(), 2);
    // A user's notes beside the image are refused without --overwrite, replaced with it.
    let notes = dir.path().join("x.txt");
    std::fs::write(&notes, "user notes").expect("notes");
    let o = frame(&dir.path().join("x.png"), false);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success() && err.contains("x.txt") && err.contains("--overwrite"),
        "{err}"
    );
    assert_eq!(
        std::fs::read_to_string(&notes).expect("notes"),
        "user notes"
    );
    assert!(!dir.path().join("x.png").exists() && !dir.path().join("x.json").exists());
    let o = frame(&dir.path().join("x.png"), true);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_ne!(
        std::fs::read_to_string(&notes).expect("labels"),
        "user notes"
    );
}

#[test]
fn assets_are_written_into_their_folder_never_through_a_link() {
    // `swarmshot assets --dir D` writes the built-in models' GLBs into D, each
    // file atomically; a link at one of their names is refused, not followed.
    let dir = tempfile::tempdir().expect("tempdir");
    let (models, outside) = (dir.path().join("models"), dir.path().join("outside.txt"));
    std::fs::create_dir_all(&models).expect("mkdir");
    std::fs::write(&outside, "mine").expect("write");
    std::os::unix::fs::symlink(&outside, models.join("hexacopter.glb")).expect("link");
    let o = swarmshot()
        .arg("assets")
        .arg("--dir")
        .arg(&models)
        .output()
        .expect("runs");
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success() && err.contains("hexacopter.glb") && err.contains("link"),
        "{err}"
    );
    assert_eq!(std::fs::read_to_string(&outside).expect("outside"), "mine");
    std::fs::remove_file(models.join("hexacopter.glb")).expect("unlink");
    let o = swarmshot()
        .arg("assets")
        .arg("--dir")
        .arg(&models)
        .output()
        .expect("runs");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    // The same bytes as the models shipped in assets/models.
    let shipped = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/models/hexacopter.glb");
    assert_eq!(
        std::fs::read(models.join("hexacopter.glb")).expect("glb"),
        std::fs::read(shipped).expect("shipped")
    );
}

#[test]
fn user_errors_print_one_line_and_never_a_backtrace() {
    let dir = tempfile::tempdir().expect("tempdir");
    let bad = dir.path().join("bad.ron");
    std::fs::write(&bad, "(camera: (fovy_deg: 20.0))").expect("write");
    let missing_model = write_preset(
        dir.path(),
        "model.ron",
        &with_model(&dir.path().join("absent.glb")),
    );
    for preset in [&bad, &missing_model] {
        let out = swarmshot()
            .arg("check")
            .arg(preset)
            .env("RUST_BACKTRACE", "1")
            .env("RUST_LIB_BACKTRACE", "1")
            .output()
            .expect("runs");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success());
        assert!(err.starts_with("error: "), "{err}");
        assert_eq!(err.trim_end().lines().count(), 1, "{err}");
        // A cause the message already quotes is not repeated after it.
        assert!(err.matches("os error").count() <= 1, "{err}");
        assert!(
            !err.contains("backtrace") && !err.contains("Caused by"),
            "{err}"
        );
    }
}

// ---- absurd camera-model values (issue 35) --------------------------------

#[test]
fn a_sensor_scale_that_would_leave_a_grey_frame_is_refused() {
    let mut p = common::tiny_preset();
    for s in [1e-300, 1e-6, 0.049] {
        p.camera_model = Some(swarmshot::preset::camera_model::CameraModel {
            sensor_scale: Some((s, 0.5)),
            ..Default::default()
        });
        assert_error(&p, "camera_model.sensor_scale", "is under 0.05");
    }
    p.camera_model = Some(swarmshot::preset::camera_model::CameraModel {
        sensor_scale: Some((0.05, 0.5)),
        ..Default::default()
    });
    assert!(errors_of(&p).is_empty(), "{:?}", errors_of(&p));
}
