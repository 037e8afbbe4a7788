//! Shared test fixtures: a GPU context that fails loudly, and small presets.
#![allow(dead_code)]

pub mod cli;

use std::path::{Path, PathBuf};

use swarmshot::preset::sweep::SweepRange;
use swarmshot::preset::{
    AttitudeRanges, Formation, FormationShape, ImageFormat, LabelFormat, Motion, Placement, Preset,
    Resolution, SequenceCamera, SequenceSpec, Volume,
};
use swarmshot::render::GpuContext;

/// The headless adapter CI installs (lavapipe). Panics with the reason if none
/// is found: a rendering test must never pass by skipping.
pub fn gpu() -> GpuContext {
    match GpuContext::headless() {
        Ok(ctx) => ctx,
        Err(e) => panic!("rendering tests need a wgpu adapter (CI installs Mesa lavapipe): {e}"),
    }
}

/// A path that does not exist yet inside a fresh temporary folder, which is removed (with
/// whatever was written under the path) when this is dropped: a test's output folder that
/// a failing or passing run alike leaves nothing of.
pub struct Scratch {
    _root: tempfile::TempDir,
    path: PathBuf,
}

impl Scratch {
    /// A fresh folder whose name starts `swarmshot-{name}-`, and `name` inside it.
    pub fn new(name: &str) -> Self {
        let root = tempfile::Builder::new()
            .prefix(&format!("swarmshot-{name}-"))
            .tempdir()
            .expect("a temporary folder");
        let path = root.path().join(name);
        Self { _root: root, path }
    }
}

impl std::ops::Deref for Scratch {
    type Target = Path;
    fn deref(&self) -> &Path {
        &self.path
    }
}

impl AsRef<Path> for Scratch {
    fn as_ref(&self) -> &Path {
        &self.path
    }
}

/// Path into tests/data, the bundled third-party files (see tests/data/README.md).
pub fn testdata(rel: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(rel)
}

/// A copy of the bundled real frames (`tests/data/real`) in `to`, `row` (a YOLO line,
/// e.g. a bird's) added to every label file; `to/images` holds the frames.
pub fn real_frames_with_row(to: &Path, row: &str) {
    for sub in ["images", "labels"] {
        std::fs::create_dir_all(to.join(sub)).expect("dir");
        for e in std::fs::read_dir(testdata("real").join(sub)).expect("read") {
            let p = e.expect("entry").path();
            let copy = to.join(sub).join(p.file_name().expect("name"));
            std::fs::copy(&p, &copy).expect("copy");
            if sub == "labels" {
                let mut text = std::fs::read_to_string(&copy).expect("label");
                text.push_str(row);
                text.push('\n');
                std::fs::write(&copy, text).expect("label");
            }
        }
    }
}

/// A small, fast preset: 320×180 PNG, a few drones, a 2×1×2 sweep.
pub fn tiny_preset() -> Preset {
    let mut p = Preset {
        name: "tiny".into(),
        seed: 7,
        placement: Placement::Randomized {
            count: (3, 6),
            count_distribution: Default::default(),
            volume: Volume::Box {
                size_m: (6.0, 3.0, 6.0),
            },
            min_separation_m: 0.7,
        },
        repeats: 2,
        ..Preset::default()
    };
    p.camera.y = SweepRange::new(-0.2, 0.2, 0.4);
    p.camera.z = SweepRange::fixed(0.9);
    p.plane.ry = SweepRange::new(0.0, 90.0, 90.0);
    p.render.resolution = Resolution::Custom {
        width: 320,
        height: 180,
    };
    p.render.msaa = 1;
    p.output.image_format = ImageFormat::Png;
    p
}

/// A procedural environment (the pasture, clouds 0.6, seed 3): a background
/// the renderer shades on the CPU (lavapipe) and uploads tile by tile.
pub fn procedural_sky() -> swarmshot::preset::Sky {
    swarmshot::preset::Sky::Procedural {
        environment: swarmshot::preset::EnvironmentName::BeautifulPasture,
        sun_elevation_deg: None,
        sun_azimuth_deg: None,
        turbidity: None,
        cloud_cover: Some(0.6),
        seed: Some(3),
        exposure_ev: 0.0,
        sun_ev: 0.0,
    }
}

/// One drone (a 1×1×1 grid) at `camera_z` (the CameraZ sweep value), seen
/// at 240×160 with MSAA 4 from two camera heights, labelled by its visible box.
pub fn single_drone_preset(camera_z: f64) -> Preset {
    let mut p = Preset::default();
    p.placement = Placement::Structured {
        x_count: 1,
        y_count: 1,
        z_count: 1,
        load_factor: 1.0,
    };
    p.render.resolution = Resolution::Custom {
        width: 240,
        height: 160,
    };
    p.render.msaa = 4;
    p.camera.z = SweepRange::fixed(camera_z);
    p.camera.y = SweepRange::new(-0.6, 0.6, 1.2);
    p.repeats = 1;
    p.labels.box_method = swarmshot::preset::BoxMethod::Visible;
    p
}

/// A binary glTF (GLB) from its JSON document and BIN chunk (padded as the
/// format asks); the document's single buffer is the BIN chunk.
pub fn glb(json: &serde_json::Value, bin: &[u8]) -> Vec<u8> {
    let mut json = json.clone();
    json["asset"] = serde_json::json!({"version": "2.0"});
    json["buffers"] = serde_json::json!([{"byteLength": bin.len()}]);
    let mut j = json.to_string().into_bytes();
    while !j.len().is_multiple_of(4) {
        j.push(b' ');
    }
    let mut b = bin.to_vec();
    while !b.len().is_multiple_of(4) {
        b.push(0);
    }
    let total = 12 + 8 + j.len() + 8 + b.len();
    let mut out = Vec::with_capacity(total);
    out.extend(b"glTF");
    out.extend(2u32.to_le_bytes());
    out.extend((total as u32).to_le_bytes());
    out.extend((j.len() as u32).to_le_bytes());
    out.extend(b"JSON");
    out.extend(j);
    out.extend((b.len() as u32).to_le_bytes());
    out.extend(b"BIN\0");
    out.extend(b);
    out
}

/// Little-endian bytes of f32 values.
pub fn f32_le(v: &[f32]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_le_bytes()).collect()
}

/// One triangle's buffer (3 positions, then 3 u16 indices) and the glTF parts
/// that describe it: accessor 0 = POSITION, accessor 1 = indices, mesh 0.
pub fn triangle_gltf() -> (serde_json::Value, Vec<u8>) {
    let mut bin = f32_le(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0]);
    for i in [0u16, 1, 2] {
        bin.extend(i.to_le_bytes());
    }
    let json = serde_json::json!({
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 36},
            {"buffer": 0, "byteOffset": 36, "byteLength": 6}
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
             "min": [0.0, 0.0, 0.0], "max": [1.0, 1.0, 0.0]},
            {"bufferView": 1, "componentType": 5123, "count": 3, "type": "SCALAR"}
        ],
        "meshes": [{"name": "tri", "primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
        "nodes": [{"mesh": 0}],
        "scenes": [{"nodes": [0]}],
        "scene": 0
    });
    (json, bin)
}

/// 3 sequences of 5 frames (MOT files, COCO videos).
pub fn sequence_preset() -> Preset {
    let mut p = tiny_preset();
    p.name = "mot".into();
    p.placement = Placement::Formation(Formation {
        shape: FormationShape::Wedge {
            half_angle_deg: 40.0,
        },
        count: 4,
        spacing: 4.0,
        heading_deg: (-30.0, 30.0),
        position_jitter: 0.1,
        attitude_jitter: AttitudeRanges::zero(),
        min_separation: 1.0,
    });
    p.camera.y = SweepRange::fixed(0.3);
    p.camera.z = SweepRange::fixed(1.4);
    p.plane.ry = SweepRange::fixed(0.0);
    p.repeats = 3;
    p.labels.min_box_px = 0.0;
    p.output.label_formats = vec![LabelFormat::Yolo, LabelFormat::Coco];
    p.sequence = Some(SequenceSpec {
        steps: 4,
        motion: Motion {
            translate_m: (1.0, 0.5, -2.0),
            turn_deg: 20.0,
            ..Motion::default()
        },
        camera: SequenceCamera::Fixed,
        frame_rate: 10,
    });
    p
}

/// Write `preset` as RON to `dir/name`.
pub fn preset_file(dir: &Path, preset: &Preset, name: &str) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, preset.to_ron()).expect("write preset");
    path
}

/// The renderer's picture of `scene` before the camera stage: drawn at its
/// camera's exposure (the renderer applies it before it encodes), none of the
/// rest of the camera applied. What `sensor::develop` with
/// `CameraDraw::after_render` turns into the frame's noise-free camera image.
pub fn rendered_at_exposure(
    renderer: &mut swarmshot::render::Renderer,
    scene: &swarmshot::scene::FrameScene,
    msaa: u32,
) -> Vec<u8> {
    let request = swarmshot::render::RenderRequest {
        msaa,
        color: true,
        visibility: false,
    };
    renderer.render_frame(scene, &request).expect("render").rgba
}

/// The noise-free camera image of `scene` under `draw`: [`rendered_at_exposure`],
/// then the rest of the camera (`CameraDraw::after_render`) over the whole frame.
pub fn camera_image(
    renderer: &mut swarmshot::render::Renderer,
    scene: &swarmshot::scene::FrameScene,
    msaa: u32,
    draw: &swarmshot::sensor::CameraDraw,
) -> Vec<u8> {
    let (w, h) = (scene.camera.width, scene.camera.height);
    let rendered = rendered_at_exposure(renderer, scene, msaa);
    let full = swarmshot::sensor::PixelRect {
        x0: 0,
        y0: 0,
        x1: w,
        y1: h,
    };
    swarmshot::sensor::develop(&rendered, w, h, &draw.after_render(), full, false)
}

/// The box of the pixels where two RGBA8 frames of width `w` differ in colour, and how
/// many there are (`None`: none differ).
pub fn changed_box(a: &[u8], b: &[u8], w: u32) -> Option<(swarmshot::sensor::PixelRect, u64)> {
    let mut found: Option<swarmshot::sensor::PixelRect> = None;
    let mut n = 0;
    for (i, (pa, pb)) in a.chunks(4).zip(b.chunks(4)).enumerate() {
        if pa[..3] != pb[..3] {
            n += 1;
            let (x, y) = ((i as u32) % w, (i as u32) / w);
            let r = found.get_or_insert(swarmshot::sensor::PixelRect {
                x0: x,
                y0: y,
                x1: x + 1,
                y1: y + 1,
            });
            r.x0 = r.x0.min(x);
            r.y0 = r.y0.min(y);
            r.x1 = r.x1.max(x + 1);
            r.y1 = r.y1.max(y + 1);
        }
    }
    found.map(|r| (r, n))
}

/// Every file under `dir`, relative, sorted (links listed, not followed).
pub fn files_under(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_owned()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).expect("read_dir") {
            let p = e.expect("entry").path();
            let m = std::fs::symlink_metadata(&p).expect("lstat");
            if m.is_dir() {
                stack.push(p)
            } else {
                out.push(p.strip_prefix(dir).expect("prefix").to_owned())
            }
        }
    }
    out.sort();
    out
}

/// An 8-bit sRGB level as linear light in [0, 1] (the sRGB transfer function).
pub fn srgb_decode(c: u8) -> f64 {
    let s = f64::from(c) / 255.0;
    if s <= 0.04045 {
        s / 12.92
    } else {
        ((s + 0.055) / 1.055).powf(2.4)
    }
}

/// Linear light in [0, 1] sRGB-encoded, in [0, 1] (not rounded).
pub fn srgb_encode(l: f64) -> f64 {
    if l <= 0.003_130_8 {
        l * 12.92
    } else {
        1.055 * l.powf(1.0 / 2.4) - 0.055
    }
}

/// `got` holds exactly the files of `want` (the ledger aside), byte for
/// byte: a continued run against an uninterrupted one in the same folder
/// layout (no path inside a file neutralised; `tests/suite/safety.rs` has that).
pub fn assert_same_dataset(want: &Path, got: &Path, what: &str) {
    let list = |d: &Path| -> Vec<PathBuf> {
        files_under(d)
            .into_iter()
            .filter(|p| p != Path::new(".swarmshot-ledger"))
            .collect()
    };
    let files = list(want);
    assert_eq!(files, list(got), "{what}: file lists differ");
    for rel in &files {
        let read = |d: &Path| std::fs::read(d.join(rel)).expect("read");
        assert!(
            read(want) == read(got),
            "{what}: {} differs from the uninterrupted run",
            rel.display()
        );
    }
}

/// A PNG whose header says `w`×`h` (its pixel data is missing).
pub fn png_header(w: u32, h: u32) -> Vec<u8> {
    fn crc(bytes: &[u8]) -> u32 {
        let mut c = 0xFFFF_FFFFu32;
        for &b in bytes {
            c ^= u32::from(b);
            for _ in 0..8 {
                c = if c & 1 != 0 {
                    0xEDB8_8320 ^ (c >> 1)
                } else {
                    c >> 1
                };
            }
        }
        !c
    }
    let mut ihdr = b"IHDR".to_vec();
    ihdr.extend(w.to_be_bytes());
    ihdr.extend(h.to_be_bytes());
    ihdr.extend([8, 2, 0, 0, 0]);
    let mut out = b"\x89PNG\r\n\x1a\n".to_vec();
    out.extend(13u32.to_be_bytes());
    out.extend(&ihdr);
    out.extend(crc(&ihdr).to_be_bytes());
    out.extend(0u32.to_be_bytes());
    out.extend(b"IDAT");
    out.extend(crc(b"IDAT").to_be_bytes());
    out
}
