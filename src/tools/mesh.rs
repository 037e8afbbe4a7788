//! The mesh builder of the built-in models and the parts they share: [`Material`],
//! [`MeshBuilder`] (primitives, airfoils, GLB output), the materials' palette and the
//! skids. The multirotors (`assets.rs`), the fixed wings and the helicopter
//! (`assets_aircraft.rs`) and the confusers (`confusers.rs`) build from it; it imports none
//! of them.

use std::borrow::Cow;
use std::f32::consts::{FRAC_PI_2, TAU};

use glam::{Quat, Vec3};
use serde_json::json;

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
    /// Per material: written with glTF `alphaMode: BLEND` (translucent when the
    /// alpha it is drawn with is below 1; see `translucent_material`).
    blend: Vec<bool>,
    /// Per material: positions, normals, indices.
    parts: Vec<(Vec<Vec3>, Vec<Vec3>, Vec<u32>)>,
}

impl MeshBuilder {
    pub fn material(&mut self, m: Material) -> usize {
        self.materials.push(m);
        self.blend.push(false);
        self.parts.push(Default::default());
        self.materials.len() - 1
    }

    /// A material written with `alphaMode: BLEND` (its alpha stays `m`'s, 1 for
    /// the rotor discs): drawn opaque, and translucent when a preset lowers the
    /// drone's rotor opacity (`appearance.rotor_opacity`, docs/realism.md).
    pub fn translucent_material(&mut self, m: Material) -> usize {
        let i = self.material(m);
        self.blend[i] = true;
        i
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

    /// Connect closed rings of equal length with quads and cap both ends; each
    /// face's winding is chosen so that its normal points away from the axis.
    pub fn loft(&mut self, mat: usize, rings: &[Vec<Vec3>]) {
        let centroid = |r: &[Vec3]| r.iter().copied().sum::<Vec3>() / r.len().max(1) as f32;
        for pair in rings.windows(2) {
            let (a, b) = (&pair[0], &pair[1]);
            let axis_mid = (centroid(a) + centroid(b)) * 0.5;
            let n = a.len().min(b.len());
            for k in 0..n {
                let k1 = (k + 1) % n;
                let quad = [a[k], a[k1], b[k1], b[k]];
                self.oriented_quad(mat, quad, axis_mid);
            }
        }
        if let (Some(first), Some(second), Some(last), Some(before_last)) = (
            rings.first(),
            rings.get(1),
            rings.last(),
            rings.len().checked_sub(2).and_then(|i| rings.get(i)),
        ) {
            self.cap(mat, first, centroid(first) - centroid(second));
            self.cap(mat, last, centroid(last) - centroid(before_last));
        }
    }

    /// A quad whose winding makes its normal point away from `inside`.
    fn oriented_quad(&mut self, mat: usize, q: [Vec3; 4], inside: Vec3) {
        let n = (q[1] - q[0]).cross(q[2] - q[0]) + (q[2] - q[0]).cross(q[3] - q[0]);
        if n.length_squared() < 1e-14 {
            return;
        }
        let centre = (q[0] + q[1] + q[2] + q[3]) * 0.25;
        if n.dot(centre - inside) >= 0.0 {
            self.quad(mat, q);
        } else {
            self.quad(mat, [q[3], q[2], q[1], q[0]]);
        }
    }

    /// A fan over a closed ring, facing `outward`.
    fn cap(&mut self, mat: usize, ring: &[Vec3], outward: Vec3) {
        let c = ring.iter().copied().sum::<Vec3>() / ring.len().max(1) as f32;
        let normal = outward.normalize_or_zero();
        if normal == Vec3::ZERO {
            return;
        }
        let (pos, nor, idx) = &mut self.parts[mat];
        let base = pos.len() as u32;
        pos.push(c);
        pos.extend(ring.iter().copied());
        nor.extend(std::iter::repeat_n(normal, ring.len() + 1));
        let n = ring.len() as u32;
        for k in 0..n {
            let (i, j) = (base + 1 + k, base + 1 + (k + 1) % n);
            let face = (ring[k as usize] - c).cross(ring[((k + 1) % n) as usize] - c);
            if face.length_squared() < 1e-14 {
                continue;
            }
            if face.dot(normal) >= 0.0 {
                idx.extend([base, i, j]);
            } else {
                idx.extend([base, j, i]);
            }
        }
    }

    /// A tapered fuselage along +Z: `stations` are (z, half width, half height, centre height).
    pub fn fuselage(&mut self, mat: usize, stations: &[(f32, f32, f32, f32)], segments: u32) {
        let rings: Vec<Vec<Vec3>> = stations
            .iter()
            .map(|&(z, rx, ry, y)| {
                (0..segments)
                    .map(|i| {
                        let a = TAU * i as f32 / segments as f32;
                        Vec3::new(a.cos() * rx.max(1e-3), y + a.sin() * ry.max(1e-3), z)
                    })
                    .collect()
            })
            .collect();
        self.loft(mat, &rings);
    }

    /// A lifting surface built from symmetric NACA-00xx sections: each section
    /// is (leading-edge point, chord); chords run along `chord_dir`, thickness
    /// along `thickness_dir`.
    pub fn airfoil_surface(
        &mut self,
        mat: usize,
        sections: &[(Vec3, f32)],
        chord_dir: Vec3,
        thickness_dir: Vec3,
        thickness: f32,
    ) {
        let rings: Vec<Vec<Vec3>> = sections
            .iter()
            .map(|&(le, chord)| airfoil_ring(le, chord, chord_dir, thickness_dir, thickness))
            .collect();
        self.loft(mat, &rings);
    }

    /// A rotor: hub cylinder and a thin translucent-looking disc (the blur of the blades).
    pub fn rotor(&mut self, hub: usize, disc: usize, centre: Vec3, radius: f32, axis: Quat) {
        self.cylinder(hub, centre, radius * 0.12, radius * 0.10, 10, axis);
        self.cylinder(
            disc,
            centre + axis * (Vec3::Y * radius * 0.02),
            radius,
            radius * 0.02,
            28,
            axis,
        );
    }

    /// The bounding box of every vertex added so far (min, max).
    pub fn bounds(&self) -> (Vec3, Vec3) {
        (self.parts.iter().flat_map(|p| p.0.iter()))
            .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), p| {
                (lo.min(*p), hi.max(*p))
            })
    }

    /// Serialise as a self-contained GLB: one node, one mesh, one primitive per material.
    pub fn to_glb(&self, name: &str) -> Vec<u8> {
        let mut bin: Vec<u8> = Vec::new();
        let mut views = Vec::new();
        let mut accessors = Vec::new();
        let mut primitives = Vec::new();
        let mut push_view = |bin: &mut Vec<u8>, bytes: &[u8], target: u32| {
            while !bin.len().is_multiple_of(4) {
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
        while !bin.len().is_multiple_of(4) {
            bin.push(0);
        }
        let materials: Vec<_> = self
            .materials
            .iter()
            .zip(&self.blend)
            .map(|(m, &blend)| {
                let mut j = json!({"name": m.name, "pbrMetallicRoughness": {
                "baseColorFactor": m.base_color, "metallicFactor": m.metallic, "roughnessFactor": m.roughness}});
                if blend {
                    j["alphaMode"] = json!("BLEND");
                }
                j
            })
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

pub(super) const CARBON: Material = Material {
    name: "carbon",
    base_color: [0.05, 0.05, 0.055, 1.0],
    metallic: 0.1,
    roughness: 0.5,
};
pub(super) const SHELL_GREY: Material = Material {
    name: "shell",
    base_color: [0.45, 0.46, 0.48, 1.0],
    metallic: 0.0,
    roughness: 0.4,
};
pub(super) const MOTOR: Material = Material {
    name: "motor",
    base_color: [0.3, 0.3, 0.32, 1.0],
    metallic: 0.8,
    roughness: 0.3,
};
pub(super) const ROTOR: Material = Material {
    name: "rotor",
    base_color: [0.12, 0.12, 0.13, 1.0],
    metallic: 0.0,
    roughness: 0.6,
};
pub(super) const ACCENT_RED: Material = Material {
    name: "accent",
    base_color: [0.7, 0.08, 0.05, 1.0],
    metallic: 0.0,
    roughness: 0.5,
};

/// A closed symmetric NACA-00xx section (relative thickness `t`), leading edge at `le`.
fn airfoil_ring(le: Vec3, chord: f32, chord_dir: Vec3, thickness_dir: Vec3, t: f32) -> Vec<Vec3> {
    const STATIONS: [f32; 8] = [0.0, 0.03, 0.1, 0.22, 0.38, 0.56, 0.76, 1.0];
    // Powers as plain products (what `powi` computes at run time): a release build folds
    // `powi` of the constant stations at compile time, rounded once, which moved the
    // built-in models by a unit in the last place from the shipped GLBs.
    let half = |x: f32| {
        let x2 = x * x;
        5.0 * t
            * (0.2969 * x.sqrt() - 0.1260 * x - 0.3516 * x * x + 0.2843 * (x2 * x)
                - 0.1036 * (x2 * x2))
    };
    let point = |x: f32, y: f32| le + chord_dir * (x * chord) + thickness_dir * (y * chord);
    let mut ring = Vec::new();
    // Upper surface from the trailing edge forward, then the lower surface back.
    for &x in STATIONS.iter().rev() {
        ring.push(point(x, half(x).max(0.004)));
    }
    for &x in STATIONS.iter().skip(1) {
        ring.push(point(x, -half(x).max(0.004)));
    }
    ring
}

pub(super) const WHITE: Material = Material {
    name: "white shell",
    base_color: [0.80, 0.80, 0.78, 1.0],
    metallic: 0.0,
    roughness: 0.35,
};
pub(super) const ORANGE: Material = Material {
    name: "orange",
    base_color: [0.85, 0.32, 0.04, 1.0],
    metallic: 0.0,
    roughness: 0.45,
};
pub(super) const YELLOW: Material = Material {
    name: "yellow",
    base_color: [0.85, 0.62, 0.05, 1.0],
    metallic: 0.0,
    roughness: 0.4,
};
pub(super) const DARK_GREY: Material = Material {
    name: "dark grey",
    base_color: [0.16, 0.17, 0.18, 1.0],
    metallic: 0.2,
    roughness: 0.5,
};
pub(super) const OLIVE: Material = Material {
    name: "olive",
    base_color: [0.22, 0.26, 0.14, 1.0],
    metallic: 0.0,
    roughness: 0.6,
};
pub(super) const FOAM_GREY: Material = Material {
    name: "foam grey",
    base_color: [0.52, 0.54, 0.55, 1.0],
    metallic: 0.0,
    roughness: 0.75,
};
pub(super) const BLUE: Material = Material {
    name: "blue",
    base_color: [0.06, 0.18, 0.55, 1.0],
    metallic: 0.1,
    roughness: 0.4,
};
pub(super) const ALUMINIUM: Material = Material {
    name: "aluminium",
    base_color: [0.7, 0.7, 0.72, 1.0],
    metallic: 0.9,
    roughness: 0.35,
};
pub(super) const GLASS: Material = Material {
    name: "canopy",
    base_color: [0.05, 0.08, 0.12, 1.0],
    metallic: 0.0,
    roughness: 0.1,
};

/// Two skids on struts under the body.
pub(super) fn skids(
    b: &mut MeshBuilder,
    mat: usize,
    half_track: f32,
    length: f32,
    height: f32,
    tube_r: f32,
) {
    for side in [-1.0f32, 1.0] {
        let x = side * half_track;
        b.cylinder(
            mat,
            Vec3::new(x, -height, 0.0),
            tube_r,
            length,
            8,
            Quat::from_rotation_x(FRAC_PI_2),
        );
        for z in [-0.3f32, 0.3] {
            let top = Vec3::new(x * 0.6, 0.0, z * length);
            let bottom = Vec3::new(x, -height, z * length);
            let mid = (top + bottom) * 0.5;
            let tilt = Quat::from_rotation_arc(Vec3::Y, (top - bottom).normalize());
            b.cylinder(mat, mid, tube_r * 0.8, (top - bottom).length(), 6, tilt);
        }
    }
}
