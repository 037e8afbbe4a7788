//! The generator of the built-in confusers (issue 22): birds in three sizes
//! with their flap poses and a gliding pose, a light aircraft, an airliner, a
//! helicopter and a hot-air balloon. Low-poly on purpose: they are seen at
//! 5–30 px, where only the silhouette and the overall tone count.
//!
//! Each bird has [`FLAP_POSES`] flap poses (`bird_SPECIES_K.glb`, phase
//! `K / FLAP_POSES` of the wing beat) and `bird_SPECIES_glide.glb`. The
//! loader centres every model on its bounding box and scales it to a unit
//! span, so a pose whose wings are up would shrink and shift; the scene undoes
//! that with each pose's frame ([`crate::model::confusers::pose_frame`]),
//! which a test checks against this generator.

use std::f32::consts::{FRAC_PI_2, TAU};

use glam::{Quat, Vec3};

use super::mesh::{Material, MeshBuilder};
pub use crate::preset::confusers::FLAP_POSES;

/// Build the GLB of a built-in confuser (what `assets/models/NAME.glb` must contain).
pub fn generate_glb(name: &str) -> Option<Vec<u8>> {
    Some(build(name)?.to_glb(name))
}

/// The mesh of a built-in confuser.
pub fn build(name: &str) -> Option<MeshBuilder> {
    match name {
        "light_aircraft" => Some(light_aircraft()),
        "airliner" => Some(airliner()),
        "helicopter" => Some(helicopter()),
        "balloon" => Some(balloon()),
        _ => {
            let rest = name.strip_prefix("bird_")?;
            let (species, pose) = rest.split_once('_')?;
            let shape = BirdShape::of(species)?;
            let wings = if pose == "glide" {
                shape.glide()
            } else {
                let k: usize = pose.parse().ok()?;
                (k < FLAP_POSES).then(|| shape.flap(k as f32 / FLAP_POSES as f32))?
            };
            Some(bird(&shape, wings))
        }
    }
}

const fn mat(name: &'static str, rgb: [f32; 3], roughness: f32) -> Material {
    Material {
        name,
        base_color: [rgb[0], rgb[1], rgb[2], 1.0],
        metallic: 0.0,
        roughness,
    }
}

/// A bird's proportions, in units of its gliding wingspan (≈ 1).
struct BirdShape {
    body: Material,
    wing: Material,
    tip: Material,
    beak: Material,
    /// Half body length and body radius.
    body_half_len: f32,
    body_r: f32,
    /// Wing chords at the root, the wrist and the tip; the wrist's distance from the root.
    chords: [f32; 3],
    wrist: f32,
    /// Flap amplitude of the inner and outer wing (radians), and the gliding dihedral.
    amplitude: [f32; 2],
    dihedral: f32,
    /// Tail half width and length.
    tail: [f32; 2],
}

/// The wing angles of one pose: inner and outer panel about the body axis (radians, up positive).
#[derive(Clone, Copy)]
struct Wings {
    inner: f32,
    outer: f32,
}

impl BirdShape {
    fn of(species: &str) -> Option<Self> {
        Some(match species {
            // House sparrow: stubby rounded wings, long body for its span.
            "sparrow" => Self {
                body: mat("sparrow body", [0.32, 0.22, 0.14], 0.8),
                wing: mat("sparrow wing", [0.38, 0.27, 0.17], 0.8),
                tip: mat("sparrow primaries", [0.16, 0.12, 0.09], 0.8),
                beak: mat("sparrow beak", [0.12, 0.11, 0.1], 0.6),
                body_half_len: 0.3,
                body_r: 0.085,
                chords: [0.24, 0.22, 0.12],
                wrist: 0.2,
                amplitude: [0.8, 0.5],
                dihedral: 0.05,
                tail: [0.08, 0.22],
            },
            // Herring gull: long narrow pointed wings, white body, grey mantle, black tips.
            "gull" => Self {
                body: mat("gull body", [0.82, 0.82, 0.8], 0.6),
                wing: mat("gull mantle", [0.55, 0.57, 0.6], 0.6),
                tip: mat("gull tips", [0.06, 0.06, 0.06], 0.6),
                beak: mat("gull beak", [0.85, 0.65, 0.1], 0.5),
                body_half_len: 0.2,
                body_r: 0.05,
                chords: [0.16, 0.14, 0.05],
                wrist: 0.2,
                amplitude: [0.55, 0.35],
                dihedral: 0.06,
                tail: [0.06, 0.12],
            },
            // Buzzard-like raptor: broad wings with blunt fingered tips, brown.
            "raptor" => Self {
                body: mat("raptor body", [0.3, 0.2, 0.12], 0.75),
                wing: mat("raptor wing", [0.36, 0.25, 0.15], 0.75),
                tip: mat("raptor primaries", [0.1, 0.08, 0.06], 0.75),
                beak: mat("raptor beak", [0.75, 0.62, 0.2], 0.5),
                body_half_len: 0.2,
                body_r: 0.055,
                chords: [0.22, 0.22, 0.14],
                wrist: 0.22,
                amplitude: [0.45, 0.25],
                dihedral: 0.14,
                tail: [0.08, 0.16],
            },
            _ => return None,
        })
    }

    /// The wings at `phase` of the beat (0: top of the upstroke).
    fn flap(&self, phase: f32) -> Wings {
        let a = TAU * phase;
        Wings {
            inner: self.amplitude[0] * a.cos(),
            // The hand lags the arm a little.
            outer: self.amplitude[0] * a.cos() + self.amplitude[1] * (a - 0.6).cos(),
        }
    }

    fn glide(&self) -> Wings {
        Wings {
            inner: self.dihedral,
            outer: self.dihedral * 1.5,
        }
    }
}

/// A bird along +Z (head forward), wings along X, its origin at the body's centre.
fn bird(s: &BirdShape, w: Wings) -> MeshBuilder {
    let mut b = MeshBuilder::default();
    let body = b.material(s.body);
    let wing = b.material(s.wing);
    let tip = b.material(s.tip);
    let beak = b.material(s.beak);
    let (l, r) = (s.body_half_len, s.body_r);
    b.fuselage(
        body,
        &[
            (-l, r * 0.35, r * 0.3, 0.0),
            (-l * 0.4, r * 0.9, r * 0.85, 0.0),
            (l * 0.2, r, r, 0.0),
            (l * 0.7, r * 0.75, r * 0.75, r * 0.2),
            (l, r * 0.45, r * 0.45, r * 0.3),
        ],
        6,
    );
    b.fuselage(
        beak,
        &[
            (l * 0.98, r * 0.2, r * 0.15, r * 0.3),
            (l + r * 0.8, 0.004, 0.004, r * 0.25),
        ],
        4,
    );
    // Tail: a flat fan behind the body.
    let [tw, tl] = s.tail;
    panel(
        &mut b,
        body,
        &[
            (Vec3::new(-tw, 0.0, -l * 0.7), tl * 0.9),
            (Vec3::new(0.0, 0.0, -l * 0.75), tl),
            (Vec3::new(tw, 0.0, -l * 0.7), tl * 0.9),
        ],
        Vec3::NEG_Z,
        Vec3::Y,
        0.06,
    );
    let [c_root, c_wrist, c_tip] = s.chords;
    let le_z = c_root * 0.45;
    for side in [-1.0f32, 1.0] {
        // Panels swing about the body axis (Z): up is +Y for either side.
        let turn = |angle: f32| Quat::from_rotation_z(side * angle);
        let root = Vec3::new(side * r * 0.6, r * 0.3, le_z);
        let inner = turn(w.inner);
        let wrist = root + inner * Vec3::new(side * s.wrist, 0.0, -(c_root - c_wrist) * 0.3);
        let outer = turn(w.outer);
        let half_span = 0.5 - r * 0.6;
        let tip_le =
            wrist + outer * Vec3::new(side * (half_span - s.wrist), 0.0, -(c_wrist - c_tip) * 0.7);
        panel(
            &mut b,
            wing,
            &[(root, c_root), (wrist, c_wrist)],
            Vec3::NEG_Z,
            inner * Vec3::Y,
            0.1,
        );
        panel(
            &mut b,
            tip,
            &[(wrist, c_wrist), (tip_le, c_tip)],
            Vec3::NEG_Z,
            outer * Vec3::Y,
            0.08,
        );
    }
    b
}

/// A thin lifting panel with a diamond section (four points: leading edge,
/// upper and lower crest at 35 % chord, trailing edge): a quarter of an
/// airfoil's triangles, which is all a bird 5–30 px wide needs.
fn panel(
    b: &mut MeshBuilder,
    mat: usize,
    sections: &[(Vec3, f32)],
    chord_dir: Vec3,
    thickness_dir: Vec3,
    thickness: f32,
) {
    let rings: Vec<Vec<Vec3>> = sections
        .iter()
        .map(|&(le, chord)| {
            let crest = le + chord_dir * (0.35 * chord);
            let t = thickness_dir * (0.5 * thickness * chord);
            vec![le, crest + t, le + chord_dir * chord, crest - t]
        })
        .collect();
    b.loft(mat, &rings);
}

const AIRCRAFT_WHITE: Material = mat("white paint", [0.8, 0.8, 0.78], 0.35);
const STRIPE_BLUE: Material = mat("blue stripe", [0.08, 0.16, 0.45], 0.4);
const WINDOWS: Material = mat("windows", [0.04, 0.06, 0.09], 0.1);
const ENGINE_GREY: Material = Material {
    name: "engine",
    base_color: [0.5, 0.5, 0.52, 1.0],
    metallic: 0.7,
    roughness: 0.35,
};
const ROTOR_DARK: Material = mat("rotor", [0.1, 0.1, 0.11], 0.6);

/// A high-wing single-engine light aircraft (Cessna-like, ~11 m span), +Z forward.
fn light_aircraft() -> MeshBuilder {
    let mut b = MeshBuilder::default();
    let paint = b.material(AIRCRAFT_WHITE);
    let stripe = b.material(STRIPE_BLUE);
    let glass = b.material(WINDOWS);
    let prop = b.material(ROTOR_DARK);
    // Metres: fuselage 8.3 m long.
    b.fuselage(
        paint,
        &[
            (4.0, 0.45, 0.5, 0.0),
            (3.0, 0.6, 0.7, 0.05),
            (1.2, 0.6, 0.75, 0.15),
            (-1.5, 0.35, 0.45, 0.25),
            (-4.3, 0.12, 0.2, 0.45),
        ],
        8,
    );
    b.fuselage(
        glass,
        &[
            (2.1, 0.4, 0.1, 0.6),
            (1.8, 0.58, 0.3, 0.6),
            (0.2, 0.58, 0.3, 0.65),
            (-0.4, 0.3, 0.1, 0.65),
        ],
        6,
    );
    // High wing on top of the cabin, 11 m span, 1.5 m chord.
    b.airfoil_surface(
        paint,
        &[
            (Vec3::new(-5.5, 0.95, 1.7), 1.3),
            (Vec3::new(0.0, 0.95, 1.8), 1.6),
            (Vec3::new(5.5, 0.95, 1.7), 1.3),
        ],
        Vec3::NEG_Z,
        Vec3::Y,
        0.12,
    );
    // Struts.
    for side in [-1.0f32, 1.0] {
        let from = Vec3::new(side * 0.55, -0.35, 1.0);
        let to = Vec3::new(side * 2.6, 0.9, 1.1);
        let dir = (to - from).normalize();
        b.cylinder(
            paint,
            (from + to) * 0.5,
            0.05,
            (to - from).length(),
            5,
            Quat::from_rotation_arc(Vec3::Y, dir),
        );
        // Main wheels.
        b.cylinder(
            prop,
            Vec3::new(side * 1.2, -1.0, 1.0),
            0.25,
            0.15,
            8,
            Quat::from_rotation_z(FRAC_PI_2),
        );
    }
    // Tail.
    b.airfoil_surface(
        paint,
        &[
            (Vec3::new(-1.7, 0.45, -3.3), 0.8),
            (Vec3::new(0.0, 0.45, -3.2), 1.0),
            (Vec3::new(1.7, 0.45, -3.3), 0.8),
        ],
        Vec3::NEG_Z,
        Vec3::Y,
        0.1,
    );
    b.airfoil_surface(
        stripe,
        &[
            (Vec3::new(0.0, 0.5, -2.9), 1.4),
            (Vec3::new(0.0, 1.9, -3.6), 0.8),
        ],
        Vec3::NEG_Z,
        Vec3::X,
        0.1,
    );
    // Spinner and a two-blade propeller (a spinning prop is nearly transparent; its blades show).
    b.cylinder(
        prop,
        Vec3::new(0.0, 0.0, 4.05),
        0.15,
        0.3,
        8,
        Quat::from_rotation_x(FRAC_PI_2),
    );
    b.cuboid(
        prop,
        Vec3::new(0.0, 0.0, 4.2),
        Vec3::new(0.06, 0.95, 0.03),
        Quat::from_rotation_z(0.5),
    );
    b
}

/// A twin-engine narrow-body airliner (A320-like, ~38 m long, 36 m span), +Z forward.
fn airliner() -> MeshBuilder {
    let mut b = MeshBuilder::default();
    let paint = b.material(AIRCRAFT_WHITE);
    let belly = b.material(mat("belly grey", [0.55, 0.56, 0.58], 0.4));
    let tail = b.material(STRIPE_BLUE);
    let engine = b.material(ENGINE_GREY);
    b.fuselage(
        paint,
        &[
            (19.0, 0.3, 0.3, -0.3),
            (17.5, 1.6, 1.6, -0.1),
            (14.0, 2.0, 2.05, 0.0),
            (-10.0, 2.0, 2.05, 0.0),
            (-16.0, 1.1, 1.2, 0.7),
            (-18.8, 0.3, 0.4, 1.3),
        ],
        10,
    );
    // Swept wing, 36 m span, low on the fuselage.
    b.airfoil_surface(
        belly,
        &[
            (Vec3::new(-17.9, -0.2, -7.5), 1.6),
            (Vec3::new(-6.0, -1.0, -1.2), 4.3),
            (Vec3::new(0.0, -1.3, 2.5), 7.0),
            (Vec3::new(6.0, -1.0, -1.2), 4.3),
            (Vec3::new(17.9, -0.2, -7.5), 1.6),
        ],
        Vec3::NEG_Z,
        Vec3::Y,
        0.11,
    );
    // Engines under the wing.
    for side in [-1.0f32, 1.0] {
        let x = side * 5.8;
        let rings: Vec<Vec<Vec3>> = [(3.0, 0.95), (1.8, 1.05), (-1.0, 0.7)]
            .iter()
            .map(|&(z, rad)| {
                (0..8)
                    .map(|i| {
                        let a = TAU * i as f32 / 8.0;
                        Vec3::new(x + a.cos() * rad, -2.3 + a.sin() * rad, z)
                    })
                    .collect()
            })
            .collect();
        b.loft(engine, &rings);
    }
    // Tailplane and fin.
    b.airfoil_surface(
        paint,
        &[
            (Vec3::new(-6.2, 1.0, -18.5), 1.6),
            (Vec3::new(0.0, 1.0, -14.5), 3.6),
            (Vec3::new(6.2, 1.0, -18.5), 1.6),
        ],
        Vec3::NEG_Z,
        Vec3::Y,
        0.1,
    );
    b.airfoil_surface(
        tail,
        &[
            (Vec3::new(0.0, 1.8, -12.5), 5.5),
            (Vec3::new(0.0, 8.0, -17.0), 2.3),
        ],
        Vec3::NEG_Z,
        Vec3::X,
        0.1,
    );
    b
}

/// A light utility helicopter (~11 m rotor), +Z forward.
fn helicopter() -> MeshBuilder {
    let mut b = MeshBuilder::default();
    let paint = b.material(mat("red paint", [0.55, 0.06, 0.04], 0.4));
    let glass = b.material(WINDOWS);
    let dark = b.material(ROTOR_DARK);
    let skid = b.material(ENGINE_GREY);
    b.fuselage(
        paint,
        &[
            (2.4, 0.3, 0.4, 0.0),
            (1.8, 0.85, 0.95, 0.0),
            (0.0, 0.9, 1.05, 0.1),
            (-1.2, 0.6, 0.75, 0.25),
            (-1.8, 0.25, 0.3, 0.45),
            (-6.5, 0.1, 0.12, 0.6),
        ],
        8,
    );
    b.fuselage(
        glass,
        &[
            (2.35, 0.3, 0.2, 0.25),
            (1.7, 0.82, 0.6, 0.3),
            (0.8, 0.7, 0.5, 0.5),
        ],
        6,
    );
    b.airfoil_surface(
        paint,
        &[
            (Vec3::new(0.0, 0.6, -5.8), 1.0),
            (Vec3::new(0.0, 1.9, -6.6), 0.6),
        ],
        Vec3::NEG_Z,
        Vec3::X,
        0.12,
    );
    // Main rotor disc (blades blurred), mast, tail rotor.
    b.cylinder(
        dark,
        Vec3::new(0.0, 1.35, 0.0),
        0.12,
        0.5,
        6,
        Quat::IDENTITY,
    );
    // Four blades rather than a disc: a spinning rotor is nearly transparent; its blades show.
    for k in 0..2 {
        b.cuboid(
            dark,
            Vec3::new(0.0, 1.62, 0.0),
            Vec3::new(5.5, 0.04, 0.16),
            Quat::from_rotation_y(FRAC_PI_2 * k as f32 + 0.4),
        );
    }
    b.rotor(
        dark,
        dark,
        Vec3::new(0.25, 1.2, -6.5),
        0.8,
        Quat::from_rotation_z(FRAC_PI_2),
    );
    for side in [-1.0f32, 1.0] {
        b.cylinder(
            skid,
            Vec3::new(side * 0.9, -1.35, 0.1),
            0.06,
            3.6,
            5,
            Quat::from_rotation_x(FRAC_PI_2),
        );
    }
    b
}

/// A hot-air balloon (~18 m tall envelope and basket), upright.
fn balloon() -> MeshBuilder {
    let mut b = MeshBuilder::default();
    let bands = [
        b.material(mat("envelope red", [0.7, 0.1, 0.06], 0.7)),
        b.material(mat("envelope yellow", [0.85, 0.62, 0.08], 0.7)),
    ];
    let basket = b.material(mat("basket", [0.35, 0.24, 0.12], 0.9));
    let rope = b.material(ROTOR_DARK);
    // The envelope: rings from the mouth up to the crown, gores in two colours.
    let profile: [(f32, f32); 7] = [
        (1.0, 1.6),
        (4.0, 5.0),
        (7.5, 7.4),
        (10.5, 8.0),
        (13.5, 7.2),
        (15.8, 4.8),
        (17.0, 0.8),
    ];
    const GORES: u32 = 12;
    for g in 0..GORES {
        let a0 = TAU * g as f32 / GORES as f32;
        let a1 = TAU * (g + 1) as f32 / GORES as f32;
        let rings: Vec<Vec<Vec3>> = profile
            .iter()
            .map(|&(y, rad)| {
                let p = |a: f32| Vec3::new(a.cos() * rad, y, a.sin() * rad);
                // A thin wedge: outer arc and a point on the axis close each ring.
                vec![p(a0), p(a1), Vec3::new(0.0, y, 0.0)]
            })
            .collect();
        b.loft(bands[(g % 2) as usize], &rings);
    }
    b.cuboid(
        basket,
        Vec3::new(0.0, -0.6, 0.0),
        Vec3::new(0.7, 0.55, 0.7),
        Quat::IDENTITY,
    );
    for k in 0..4 {
        let a = FRAC_PI_2 * k as f32 + FRAC_PI_2 * 0.5;
        let from = Vec3::new(a.cos() * 0.9, 0.0, a.sin() * 0.9);
        let to = Vec3::new(a.cos() * 1.5, 1.1, a.sin() * 1.5);
        b.cylinder(
            rope,
            (from + to) * 0.5,
            0.04,
            (to - from).length(),
            4,
            Quat::from_rotation_arc(Vec3::Y, (to - from).normalize()),
        );
    }
    b
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::confusers::{NAMES, glb, pose_frame};

    #[test]
    fn confuser_glbs_match_the_generator() {
        for name in NAMES {
            let generated = generate_glb(name).expect("confuser has a generator");
            let shipped = glb(name).expect("confuser is embedded");
            assert!(
                generated == shipped,
                "assets/models/{name}.glb is stale: run `cargo run -- assets`"
            );
        }
    }

    #[test]
    fn confusers_load_small_and_with_their_own_looks() {
        for name in NAMES {
            let bytes = glb(name).expect("embedded");
            assert!(bytes.len() < 48_000, "{name}: {} bytes", bytes.len());
            let m = crate::model::load_bytes(bytes, None, std::path::Path::new(name), name)
                .expect("loads");
            assert!(m.warnings.is_empty(), "{name}: {:?}", m.warnings);
            assert!(m.triangle_count() >= 100, "{name}: {}", m.triangle_count());
        }
    }

    fn centre_span(b: &MeshBuilder) -> (Vec3, f32) {
        let (lo, hi) = b.bounds();
        ((lo + hi) * 0.5, (hi - lo).max_element())
    }

    /// The pose frames the scene uses are the generator's bounding boxes.
    #[test]
    fn pose_frames_match_the_generated_bounding_boxes() {
        for name in NAMES.iter().filter(|n| n.starts_with("bird_")) {
            let (centre, span) = centre_span(&build(name).expect("bird"));
            let stem = name.rsplit_once('_').expect("pose").0;
            let (_, reference) = centre_span(&build(&format!("{stem}_glide")).expect("glide"));
            let frame = pose_frame(name).expect("a bird pose has a frame");
            for k in 0..3 {
                let want = f64::from(centre[k] / reference);
                assert!(
                    (frame.centre[k] - want).abs() < 1e-4,
                    "{name}: centre {k}: {} vs {want}",
                    frame.centre[k]
                );
            }
            let want = f64::from(span / reference);
            assert!(
                (frame.span - want).abs() < 1e-4,
                "{name}: span {} vs {want}",
                frame.span
            );
        }
    }

    /// Consecutive flap poses move the wing tips: the beat is not frozen.
    #[test]
    fn flap_poses_differ_and_cycle() {
        let tips: Vec<f32> = (0..FLAP_POSES)
            .map(|k| build(&format!("bird_gull_{k}")).expect("pose").bounds().1.y)
            .collect();
        let top = tips.iter().copied().fold(f32::MIN, f32::max);
        let bottom = tips.iter().copied().fold(f32::MAX, f32::min);
        assert!(top - bottom > 0.1, "{tips:?}");
        assert!(
            (tips[0] - top).abs() < 1e-6,
            "phase 0 is the top of the upstroke: {tips:?}"
        );
    }
}
