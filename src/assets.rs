//! Built-in UAV models: a small mesh builder whose output is written as GLB
//! into `assets/models/` and embedded in the binary, then loaded through the
//! same glTF path as user models (`model::load_bytes`).
//!
//! `swarmshot assets` regenerates the files; a test checks that the committed
//! GLBs equal what the builder makes, byte for byte.

use std::borrow::Cow;
use std::f32::consts::{FRAC_PI_4, TAU};

use glam::{Quat, Vec3};
use serde_json::json;

/// Names of the built-in models, in the order they are offered.
pub const BUILTIN_NAMES: &[&str] = &["quad_x"];

/// The embedded GLB of a built-in model.
pub fn builtin_glb(name: &str) -> Option<&'static [u8]> {
    match name {
        "quad_x" => Some(include_bytes!("../assets/models/quad_x.glb")),
        _ => None,
    }
}

/// Build the GLB of a built-in model from code (what `assets/models/NAME.glb` must contain).
pub fn generate_glb(name: &str) -> Option<Vec<u8>> {
    let builder = match name {
        "quad_x" => quad_x(),
        _ => return None,
    };
    Some(builder.to_glb(name))
}

/// A material: linear base colour, metallic, roughness.
#[derive(Clone, Copy, Debug)]
pub struct Material {
    pub name: &'static str,
    pub base_color: [f32; 4],
    pub metallic: f32,
    pub roughness: f32,
}

/// Accumulates triangles per material.
#[derive(Default)]
pub struct MeshBuilder {
    materials: Vec<Material>,
    /// Per material: positions, normals, indices.
    parts: Vec<(Vec<Vec3>, Vec<Vec3>, Vec<u32>)>,
}

impl MeshBuilder {
    pub fn material(&mut self, m: Material) -> usize {
        self.materials.push(m);
        self.parts.push(Default::default());
        self.materials.len() - 1
    }

    /// Add a flat-shaded quad (counter-clockwise seen from the normal side).
    fn quad(&mut self, mat: usize, corners: [Vec3; 4]) {
        let n = (corners[1] - corners[0])
            .cross(corners[2] - corners[0])
            .normalize_or_zero();
        let (pos, nor, idx) = &mut self.parts[mat];
        let base = pos.len() as u32;
        pos.extend(corners);
        nor.extend([n; 4]);
        idx.extend([base, base + 1, base + 2, base, base + 2, base + 3]);
    }

    /// A box of half-extents `half`, rotated by `rot`, centred at `centre`.
    pub fn cuboid(&mut self, mat: usize, centre: Vec3, half: Vec3, rot: Quat) {
        let c = |x: f32, y: f32, z: f32| centre + rot * (half * Vec3::new(x, y, z));
        let faces = [
            [
                c(1., -1., -1.),
                c(1., 1., -1.),
                c(1., 1., 1.),
                c(1., -1., 1.),
            ],
            [
                c(-1., -1., 1.),
                c(-1., 1., 1.),
                c(-1., 1., -1.),
                c(-1., -1., -1.),
            ],
            [
                c(-1., 1., -1.),
                c(-1., 1., 1.),
                c(1., 1., 1.),
                c(1., 1., -1.),
            ],
            [
                c(-1., -1., 1.),
                c(-1., -1., -1.),
                c(1., -1., -1.),
                c(1., -1., 1.),
            ],
            [
                c(-1., -1., 1.),
                c(1., -1., 1.),
                c(1., 1., 1.),
                c(-1., 1., 1.),
            ],
            [
                c(1., -1., -1.),
                c(-1., -1., -1.),
                c(-1., 1., -1.),
                c(1., 1., -1.),
            ],
        ];
        for f in faces {
            self.quad(mat, f);
        }
    }

    /// A closed cylinder along the rotated Y axis with `segments` sides.
    pub fn cylinder(
        &mut self,
        mat: usize,
        centre: Vec3,
        radius: f32,
        height: f32,
        segments: u32,
        rot: Quat,
    ) {
        let h = height * 0.5;
        let ring = |i: u32| {
            let a = TAU * i as f32 / segments as f32;
            Vec3::new(a.cos() * radius, 0.0, a.sin() * radius)
        };
        let p = |v: Vec3| centre + rot * v;
        for i in 0..segments {
            let (a, b) = (ring(i), ring(i + 1));
            let up = Vec3::Y * h;
            self.quad(mat, [p(a - up), p(a + up), p(b + up), p(b - up)]);
            let (pos, nor, idx) = &mut self.parts[mat];
            for (y, flip) in [(h, false), (-h, true)] {
                let base = pos.len() as u32;
                let n = rot * if flip { Vec3::NEG_Y } else { Vec3::Y };
                pos.extend([p(Vec3::Y * y), p(a + Vec3::Y * y), p(b + Vec3::Y * y)]);
                nor.extend([n; 3]);
                if flip {
                    idx.extend([base, base + 1, base + 2]);
                } else {
                    idx.extend([base, base + 2, base + 1]);
                }
            }
        }
    }

    /// Serialise as a self-contained GLB: one node, one mesh, one primitive per material.
    pub fn to_glb(&self, name: &str) -> Vec<u8> {
        let mut bin: Vec<u8> = Vec::new();
        let mut views = Vec::new();
        let mut accessors = Vec::new();
        let mut primitives = Vec::new();
        let mut push_view = |bin: &mut Vec<u8>, bytes: &[u8], target: u32| {
            while bin.len() % 4 != 0 {
                bin.push(0);
            }
            views.push(json!({"buffer": 0, "byteOffset": bin.len(), "byteLength": bytes.len(), "target": target}));
            bin.extend_from_slice(bytes);
            views.len() - 1
        };
        for (m, (pos, nor, idx)) in self.parts.iter().enumerate() {
            if idx.is_empty() {
                continue;
            }
            let (lo, hi) = pos
                .iter()
                .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), p| {
                    (lo.min(*p), hi.max(*p))
                });
            let pv = push_view(&mut bin, bytemuck::cast_slice(pos), 34962);
            let nv = push_view(&mut bin, bytemuck::cast_slice(nor), 34962);
            let iv = push_view(&mut bin, bytemuck::cast_slice(idx), 34963);
            let a = accessors.len();
            accessors.push(
                json!({"bufferView": pv, "componentType": 5126, "count": pos.len(), "type": "VEC3",
                "min": lo.to_array(), "max": hi.to_array()}),
            );
            accessors.push(json!({"bufferView": nv, "componentType": 5126, "count": nor.len(), "type": "VEC3"}));
            accessors.push(json!({"bufferView": iv, "componentType": 5125, "count": idx.len(), "type": "SCALAR"}));
            primitives.push(json!({"attributes": {"POSITION": a, "NORMAL": a + 1}, "indices": a + 2, "material": m}));
        }
        while bin.len() % 4 != 0 {
            bin.push(0);
        }
        let materials: Vec<_> = self
            .materials
            .iter()
            .map(|m| json!({"name": m.name, "pbrMetallicRoughness": {
                "baseColorFactor": m.base_color, "metallicFactor": m.metallic, "roughnessFactor": m.roughness}}))
            .collect();
        let doc = json!({
            "asset": {"version": "2.0", "generator": "swarmshot mesh builder"},
            "scene": 0,
            "scenes": [{"nodes": [0]}],
            "nodes": [{"name": name, "mesh": 0}],
            "meshes": [{"name": name, "primitives": primitives}],
            "materials": materials,
            "buffers": [{"byteLength": bin.len()}],
            "bufferViews": views,
            "accessors": accessors,
        });
        let json_bytes = serde_json::to_vec(&doc).unwrap_or_default();
        let glb = gltf::binary::Glb {
            header: gltf::binary::Header {
                magic: *b"glTF",
                version: 2,
                length: 0,
            },
            json: Cow::Owned(json_bytes),
            bin: Some(Cow::Owned(bin)),
        };
        glb.to_vec().unwrap_or_default()
    }
}

const CARBON: Material = Material {
    name: "carbon",
    base_color: [0.05, 0.05, 0.055, 1.0],
    metallic: 0.1,
    roughness: 0.5,
};
const SHELL_GREY: Material = Material {
    name: "shell",
    base_color: [0.45, 0.46, 0.48, 1.0],
    metallic: 0.0,
    roughness: 0.4,
};
const MOTOR: Material = Material {
    name: "motor",
    base_color: [0.3, 0.3, 0.32, 1.0],
    metallic: 0.8,
    roughness: 0.3,
};
const ROTOR: Material = Material {
    name: "rotor",
    base_color: [0.12, 0.12, 0.13, 1.0],
    metallic: 0.0,
    roughness: 0.6,
};
const ACCENT_RED: Material = Material {
    name: "accent",
    base_color: [0.7, 0.08, 0.05, 1.0],
    metallic: 0.0,
    roughness: 0.5,
};

/// An X-configuration quadcopter, ~0.35 m motor-to-motor plus props, +Z forward.
fn quad_x() -> MeshBuilder {
    let mut b = MeshBuilder::default();
    let shell = b.material(SHELL_GREY);
    let carbon = b.material(CARBON);
    let motor = b.material(MOTOR);
    let rotor = b.material(ROTOR);
    let accent = b.material(ACCENT_RED);
    // Body and battery.
    b.cuboid(
        shell,
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(0.045, 0.022, 0.075),
        Quat::IDENTITY,
    );
    b.cuboid(
        carbon,
        Vec3::new(0.0, 0.030, -0.005),
        Vec3::new(0.030, 0.010, 0.050),
        Quat::IDENTITY,
    );
    b.cuboid(
        accent,
        Vec3::new(0.0, 0.0, 0.080),
        Vec3::new(0.015, 0.012, 0.008),
        Quat::IDENTITY,
    );
    let arm_len = 0.125;
    for k in 0..4 {
        let angle = FRAC_PI_4 + k as f32 * std::f32::consts::FRAC_PI_2;
        let dir = Vec3::new(angle.sin(), 0.0, angle.cos());
        let rot = Quat::from_rotation_y(angle);
        b.cuboid(
            carbon,
            dir * (arm_len * 0.5 + 0.02),
            Vec3::new(0.009, 0.007, arm_len * 0.5),
            rot,
        );
        let tip = dir * (arm_len + 0.02);
        b.cylinder(
            motor,
            tip + Vec3::Y * 0.012,
            0.014,
            0.024,
            12,
            Quat::IDENTITY,
        );
        b.cylinder(
            rotor,
            tip + Vec3::Y * 0.027,
            0.064,
            0.003,
            24,
            Quat::IDENTITY,
        );
        // Landing legs under the front and rear arms.
        b.cylinder(
            carbon,
            dir * 0.06 + Vec3::new(0.0, -0.045, 0.0),
            0.004,
            0.05,
            6,
            Quat::IDENTITY,
        );
    }
    b
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn builtin_glbs_match_the_generator() {
        for name in BUILTIN_NAMES {
            let generated = generate_glb(name).expect("builtin has a generator");
            let shipped = builtin_glb(name).expect("builtin is embedded");
            assert!(
                generated == shipped,
                "assets/models/{name}.glb is stale: run `cargo run -- assets`"
            );
        }
    }
}
