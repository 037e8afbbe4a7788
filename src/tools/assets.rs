//! The generator of the built-in UAV models: the multirotors here, the fixed
//! wings and the helicopter in `assets_aircraft.rs`, all built with
//! [`super::mesh::MeshBuilder`] and written as GLB into `assets/models/` (the
//! table in `model::builtin` embeds those files), then loaded through the same
//! glTF path as user models.
//!
//! `swarmshot assets` regenerates the files; a test checks that the committed
//! GLBs equal what the builder makes, byte for byte.

use std::f32::consts::{FRAC_PI_2, FRAC_PI_4, TAU};

use glam::{Quat, Vec2, Vec3};

use super::assets_aircraft as aircraft;
use super::mesh::{
    ACCENT_RED, ALUMINIUM, BLUE, CARBON, DARK_GREY, MOTOR, Material, MeshBuilder, ORANGE, ROTOR,
    SHELL_GREY, WHITE, YELLOW, skids,
};

/// Build the GLB of a built-in model from code (what `assets/models/NAME.glb` must contain).
pub fn generate_glb(name: &str) -> Option<Vec<u8>> {
    let builder = match name {
        "quad_x" => quad_x(),
        "quad_plus" => quad_plus(),
        "hexacopter" => hexacopter(),
        "octocopter" => octocopter(),
        "fixed_wing" => aircraft::fixed_wing(),
        "flying_wing_vtol" => aircraft::flying_wing_vtol(),
        "coaxial_heli" => aircraft::coaxial_heli(),
        "heavy_lift" => heavy_lift(),
        _ => return None,
    };
    Some(builder.to_glb(name))
}

/// An X-configuration quadcopter, ~0.35 m motor-to-motor plus props, +Z forward.
fn quad_x() -> MeshBuilder {
    let mut b = MeshBuilder::default();
    let shell = b.material(SHELL_GREY);
    let carbon = b.material(CARBON);
    let motor = b.material(MOTOR);
    let rotor = b.translucent_material(ROTOR);
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

/// Materials shared by the multirotor builders.
struct RotorcraftMaterials {
    body: usize,
    arm: usize,
    motor: usize,
    rotor: usize,
    accent: usize,
}

impl RotorcraftMaterials {
    fn new(b: &mut MeshBuilder, body: Material, arm: Material, accent: Material) -> Self {
        Self {
            body: b.material(body),
            arm: b.material(arm),
            motor: b.material(MOTOR),
            rotor: b.translucent_material(ROTOR),
            accent: b.material(accent),
        }
    }
}

/// `n` arms at `first_deg` + k·360/n (yaw from +Z towards +X), each with a motor and a rotor;
/// `coaxial` adds a second, lower rotor under each motor.
#[allow(clippy::too_many_arguments)] // one call per airframe reads better with the layout spelled out
fn rotor_arms(
    b: &mut MeshBuilder,
    m: &RotorcraftMaterials,
    n: u32,
    first_deg: f32,
    arm_len: f32,
    arm_half: Vec2,
    prop_radius: f32,
    coaxial: bool,
) {
    for k in 0..n {
        let angle = first_deg.to_radians() + TAU * k as f32 / n as f32;
        let dir = Vec3::new(angle.sin(), 0.0, angle.cos());
        let rot = Quat::from_rotation_y(angle);
        b.cuboid(
            m.arm,
            dir * (arm_len * 0.5),
            Vec3::new(arm_half.x, arm_half.y, arm_len * 0.5),
            rot,
        );
        let tip = dir * arm_len;
        let motor_r = prop_radius * 0.2;
        b.cylinder(
            m.motor,
            tip + Vec3::Y * (arm_half.y + motor_r * 0.8),
            motor_r,
            motor_r * 1.6,
            12,
            Quat::IDENTITY,
        );
        b.rotor(
            m.motor,
            m.rotor,
            tip + Vec3::Y * (arm_half.y + motor_r * 1.8),
            prop_radius,
            Quat::IDENTITY,
        );
        if coaxial {
            b.cylinder(
                m.motor,
                tip - Vec3::Y * (arm_half.y + motor_r * 0.8),
                motor_r,
                motor_r * 1.6,
                12,
                Quat::IDENTITY,
            );
            b.rotor(
                m.motor,
                m.rotor,
                tip - Vec3::Y * (arm_half.y + motor_r * 1.8),
                prop_radius,
                Quat::IDENTITY,
            );
        }
    }
}

fn quad_plus() -> MeshBuilder {
    let mut b = MeshBuilder::default();
    let m = RotorcraftMaterials::new(&mut b, WHITE, DARK_GREY, ORANGE);
    b.cylinder(m.body, Vec3::ZERO, 0.06, 0.045, 16, Quat::IDENTITY);
    b.cylinder(m.body, Vec3::Y * 0.03, 0.045, 0.02, 16, Quat::IDENTITY);
    rotor_arms(
        &mut b,
        &m,
        4,
        0.0,
        0.17,
        Vec2::new(0.01, 0.008),
        0.075,
        false,
    );
    b.cuboid(
        m.accent,
        Vec3::new(0.0, 0.012, 0.09),
        Vec3::new(0.012, 0.004, 0.04),
        Quat::IDENTITY,
    );
    for k in 0..4 {
        let a = FRAC_PI_4 + k as f32 * FRAC_PI_2;
        b.cylinder(
            m.arm,
            Vec3::new(a.sin() * 0.05, -0.045, a.cos() * 0.05),
            0.004,
            0.05,
            6,
            Quat::IDENTITY,
        );
    }
    b
}

/// A hexacopter (~0.55 m motor to motor): round hull, red accents, skid landing gear.
fn hexacopter() -> MeshBuilder {
    let mut b = MeshBuilder::default();
    let m = RotorcraftMaterials::new(&mut b, DARK_GREY, CARBON, ACCENT_RED);
    b.cylinder(
        m.body,
        Vec3::ZERO,
        0.09,
        0.05,
        6,
        Quat::from_rotation_y(0.0),
    );
    b.fuselage(
        m.accent,
        &[
            (-0.05, 0.05, 0.001, 0.03),
            (-0.03, 0.06, 0.025, 0.03),
            (0.03, 0.06, 0.025, 0.03),
            (0.05, 0.04, 0.001, 0.03),
        ],
        12,
    );
    rotor_arms(
        &mut b,
        &m,
        6,
        30.0,
        0.27,
        Vec2::new(0.012, 0.01),
        0.11,
        false,
    );
    skids(&mut b, m.arm, 0.09, 0.26, 0.12, 0.006);
    b
}

/// An octocopter (~0.9 m): dark body, yellow arms' tips, camera gimbal, tall gear.
fn octocopter() -> MeshBuilder {
    let mut b = MeshBuilder::default();
    let m = RotorcraftMaterials::new(&mut b, DARK_GREY, CARBON, YELLOW);
    b.cylinder(
        m.body,
        Vec3::ZERO,
        0.13,
        0.05,
        8,
        Quat::from_rotation_y(TAU / 16.0),
    );
    b.cylinder(m.accent, Vec3::Y * 0.035, 0.08, 0.02, 16, Quat::IDENTITY);
    rotor_arms(
        &mut b,
        &m,
        8,
        22.5,
        0.42,
        Vec2::new(0.014, 0.012),
        0.13,
        false,
    );
    for k in 0..8 {
        let a = (22.5f32).to_radians() + TAU * k as f32 / 8.0;
        b.cuboid(
            m.accent,
            Vec3::new(a.sin(), 0.0, a.cos()) * 0.36,
            Vec3::new(0.016, 0.014, 0.03),
            Quat::from_rotation_y(a),
        );
    }
    // Gimbal and camera under the body.
    b.cylinder(
        m.motor,
        Vec3::new(0.0, -0.06, 0.04),
        0.012,
        0.05,
        8,
        Quat::IDENTITY,
    );
    b.cuboid(
        m.arm,
        Vec3::new(0.0, -0.1, 0.05),
        Vec3::new(0.035, 0.03, 0.035),
        Quat::IDENTITY,
    );
    skids(&mut b, m.arm, 0.14, 0.4, 0.22, 0.008);
    b
}

/// A coaxial X8 heavy lifter (~1.3 m): four arms with two rotors each, payload box, tall gear.
fn heavy_lift() -> MeshBuilder {
    let mut b = MeshBuilder::default();
    let m = RotorcraftMaterials::new(&mut b, BLUE, ALUMINIUM, YELLOW);
    b.cuboid(
        m.body,
        Vec3::ZERO,
        Vec3::new(0.14, 0.06, 0.2),
        Quat::IDENTITY,
    );
    b.cuboid(
        m.arm,
        Vec3::Y * 0.075,
        Vec3::new(0.09, 0.015, 0.12),
        Quat::IDENTITY,
    );
    rotor_arms(&mut b, &m, 4, 45.0, 0.6, Vec2::new(0.02, 0.02), 0.24, true);
    // Payload crate under the body.
    b.cuboid(
        m.accent,
        Vec3::new(0.0, -0.2, 0.0),
        Vec3::new(0.12, 0.08, 0.12),
        Quat::IDENTITY,
    );
    b.cylinder(
        m.arm,
        Vec3::new(0.0, -0.09, 0.0),
        0.01,
        0.06,
        6,
        Quat::IDENTITY,
    );
    skids(&mut b, m.arm, 0.24, 0.6, 0.32, 0.012);
    b
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::builtin::{NAMES as BUILTIN_NAMES, glb as builtin_glb};

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

    #[test]
    fn builtins_load_as_distinct_multi_material_drones() {
        let mut shapes = Vec::new();
        for name in BUILTIN_NAMES {
            let bytes = builtin_glb(name).expect("embedded");
            let m = crate::model::load_bytes(bytes, None, std::path::Path::new(name), name)
                .expect("loads");
            assert!(
                m.triangle_count() > 300,
                "{name}: {} triangles",
                m.triangle_count()
            );
            assert!(m.warnings.is_empty(), "{name}: {:?}", m.warnings);
            let colours: std::collections::BTreeSet<[u32; 3]> = m
                .vertices
                .iter()
                .map(|v| [v.color[0], v.color[1], v.color[2]].map(f32::to_bits))
                .collect();
            assert!(
                colours.len() >= 4,
                "{name}: only {} materials",
                colours.len()
            );
            let (lo, hi) = m.aabb;
            let e = hi - lo;
            shapes.push((
                (e.x * 20.0).round() as i64,
                (e.y * 20.0).round() as i64,
                (e.z * 20.0).round() as i64,
                m.triangle_count(),
            ));
        }
        let distinct: std::collections::BTreeSet<_> = shapes.iter().collect();
        assert_eq!(distinct.len(), BUILTIN_NAMES.len(), "{shapes:?}");
        assert_eq!(BUILTIN_NAMES.len(), 8);
    }
}
