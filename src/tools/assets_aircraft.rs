//! The built-in fixed wings and the helicopter (moved out of `assets.rs`,
//! unchanged): the fixed-wing UAV, the flying-wing VTOL and the coaxial
//! helicopter, from [`MeshBuilder`] parts (`mesh.rs`).

use std::f32::consts::FRAC_PI_2;

use glam::{Quat, Vec3};

use super::mesh::{
    ACCENT_RED, CARBON, DARK_GREY, FOAM_GREY, GLASS, MOTOR, MeshBuilder, OLIVE, ROTOR, WHITE,
    YELLOW, skids,
};

/// A conventional fixed-wing UAV (~2 m span): tapered fuselage, dihedral wing, T-less tail, tractor prop.
pub(super) fn fixed_wing() -> MeshBuilder {
    let mut b = MeshBuilder::default();
    let shell = b.material(WHITE);
    let accent = b.material(ACCENT_RED);
    let canopy = b.material(GLASS);
    let motor = b.material(MOTOR);
    let rotor = b.translucent_material(ROTOR);
    // Fuselage along +Z (nose forward): (z, half width, half height, centre height).
    b.fuselage(
        shell,
        &[
            (0.62, 0.02, 0.02, 0.0),
            (0.55, 0.06, 0.065, 0.0),
            (0.3, 0.075, 0.085, 0.01),
            (0.0, 0.07, 0.08, 0.01),
            (-0.4, 0.04, 0.05, 0.02),
            (-0.8, 0.018, 0.025, 0.04),
        ],
        14,
    );
    b.fuselage(
        canopy,
        &[
            (0.42, 0.03, 0.01, 0.07),
            (0.36, 0.045, 0.04, 0.07),
            (0.16, 0.045, 0.04, 0.075),
            (0.05, 0.02, 0.01, 0.075),
        ],
        10,
    );
    // Main wing: root chord 0.3 m, tip chord 0.16 m, 1 m half span, 3° dihedral.
    let dihedral = 0.05;
    let wing =
        |x: f32, chord: f32, y: f32| (Vec3::new(x, 0.03 + y, 0.14 - (0.3 - chord) * 0.3), chord);
    b.airfoil_surface(
        shell,
        &[
            wing(-1.0, 0.16, dihedral),
            wing(-0.08, 0.3, 0.0),
            wing(0.08, 0.3, 0.0),
            wing(1.0, 0.16, dihedral),
        ],
        Vec3::NEG_Z,
        Vec3::Y,
        0.12,
    );
    // Red wing tips.
    for side in [-1.0f32, 1.0] {
        b.airfoil_surface(
            accent,
            &[
                (Vec3::new(side * 1.0, 0.03 + dihedral, 0.098), 0.16),
                (Vec3::new(side * 1.03, 0.03 + dihedral, 0.095), 0.15),
            ],
            Vec3::NEG_Z,
            Vec3::Y,
            0.12,
        );
    }
    // Tail: horizontal stabiliser and fin.
    b.airfoil_surface(
        shell,
        &[
            (Vec3::new(-0.32, 0.04, -0.62), 0.14),
            (Vec3::new(0.0, 0.04, -0.6), 0.18),
            (Vec3::new(0.32, 0.04, -0.62), 0.14),
        ],
        Vec3::NEG_Z,
        Vec3::Y,
        0.1,
    );
    b.airfoil_surface(
        accent,
        &[
            (Vec3::new(0.0, 0.05, -0.58), 0.22),
            (Vec3::new(0.0, 0.3, -0.7), 0.13),
        ],
        Vec3::NEG_Z,
        Vec3::X,
        0.1,
    );
    // Tractor propeller on the nose.
    let spin = Quat::from_rotation_x(FRAC_PI_2);
    b.cylinder(motor, Vec3::new(0.0, 0.0, 0.64), 0.025, 0.04, 12, spin);
    b.rotor(motor, rotor, Vec3::new(0.0, 0.0, 0.67), 0.16, spin);
    b
}

/// A flying-wing VTOL (~1.6 m span): swept wing, two booms with four lift rotors, pusher prop.
pub(super) fn flying_wing_vtol() -> MeshBuilder {
    let mut b = MeshBuilder::default();
    let skin = b.material(FOAM_GREY);
    let accent = b.material(OLIVE);
    let boom = b.material(CARBON);
    let motor = b.material(MOTOR);
    let rotor = b.translucent_material(ROTOR);
    // Centre body.
    b.fuselage(
        skin,
        &[
            (0.34, 0.02, 0.02, 0.0),
            (0.28, 0.08, 0.05, 0.0),
            (0.0, 0.1, 0.06, 0.0),
            (-0.25, 0.07, 0.04, 0.0),
            (-0.32, 0.03, 0.02, 0.0),
        ],
        12,
    );
    // Swept wing: 30° sweep, root chord 0.45 m, tip chord 0.2 m.
    let sweep = 0.5f32;
    let section = |x: f32, chord: f32| (Vec3::new(x, 0.0, 0.2 - x.abs() * sweep), chord);
    b.airfoil_surface(
        skin,
        &[
            section(-0.8, 0.2),
            section(-0.1, 0.45),
            section(0.1, 0.45),
            section(0.8, 0.2),
        ],
        Vec3::NEG_Z,
        Vec3::Y,
        0.1,
    );
    // Winglets.
    for side in [-1.0f32, 1.0] {
        let le = Vec3::new(side * 0.8, 0.0, 0.2 - 0.8 * sweep);
        b.airfoil_surface(
            accent,
            &[(le, 0.2), (le + Vec3::new(side * 0.02, 0.14, -0.08), 0.12)],
            Vec3::NEG_Z,
            Vec3::X,
            0.08,
        );
    }
    // Booms with front and rear lift rotors.
    for side in [-1.0f32, 1.0] {
        let x = side * 0.38;
        b.cylinder(
            boom,
            Vec3::new(x, -0.02, -0.05),
            0.014,
            0.95,
            10,
            Quat::from_rotation_x(FRAC_PI_2),
        );
        for z in [0.42f32, -0.52] {
            b.cylinder(motor, Vec3::new(x, 0.0, z), 0.022, 0.04, 12, Quat::IDENTITY);
            b.rotor(motor, rotor, Vec3::new(x, 0.03, z), 0.19, Quat::IDENTITY);
        }
    }
    // Pusher propeller at the trailing edge.
    let spin = Quat::from_rotation_x(FRAC_PI_2);
    b.cylinder(motor, Vec3::new(0.0, 0.0, -0.34), 0.02, 0.04, 12, spin);
    b.rotor(motor, rotor, Vec3::new(0.0, 0.0, -0.37), 0.12, spin);
    b
}

/// A coaxial helicopter UAV (~1.2 m rotor): pod fuselage, tail boom with fin, two stacked rotors, skids.
pub(super) fn coaxial_heli() -> MeshBuilder {
    let mut b = MeshBuilder::default();
    let shell = b.material(YELLOW);
    let canopy = b.material(GLASS);
    let dark = b.material(DARK_GREY);
    let motor = b.material(MOTOR);
    let rotor = b.translucent_material(ROTOR);
    b.fuselage(
        shell,
        &[
            (0.32, 0.02, 0.03, 0.0),
            (0.26, 0.09, 0.1, 0.0),
            (0.05, 0.11, 0.12, 0.01),
            (-0.15, 0.08, 0.09, 0.02),
            (-0.25, 0.03, 0.035, 0.04),
        ],
        14,
    );
    b.fuselage(
        canopy,
        &[
            (0.3, 0.03, 0.03, 0.03),
            (0.24, 0.085, 0.08, 0.04),
            (0.12, 0.09, 0.08, 0.05),
            (0.08, 0.03, 0.02, 0.05),
        ],
        10,
    );
    // Tail boom and fin.
    b.fuselage(
        dark,
        &[(-0.22, 0.022, 0.022, 0.04), (-0.75, 0.012, 0.012, 0.07)],
        8,
    );
    b.airfoil_surface(
        shell,
        &[
            (Vec3::new(0.0, 0.05, -0.66), 0.12),
            (Vec3::new(0.0, 0.2, -0.76), 0.08),
        ],
        Vec3::NEG_Z,
        Vec3::X,
        0.12,
    );
    b.airfoil_surface(
        shell,
        &[
            (Vec3::new(-0.1, 0.07, -0.66), 0.08),
            (Vec3::new(0.1, 0.07, -0.66), 0.08),
        ],
        Vec3::NEG_Z,
        Vec3::Y,
        0.12,
    );
    // Mast and two counter-rotating rotors.
    b.cylinder(
        motor,
        Vec3::new(0.0, 0.19, 0.02),
        0.018,
        0.16,
        10,
        Quat::IDENTITY,
    );
    b.rotor(
        motor,
        rotor,
        Vec3::new(0.0, 0.16, 0.02),
        0.6,
        Quat::IDENTITY,
    );
    b.rotor(
        motor,
        rotor,
        Vec3::new(0.0, 0.26, 0.02),
        0.6,
        Quat::IDENTITY,
    );
    skids(&mut b, dark, 0.12, 0.45, 0.18, 0.008);
    b
}
