//! Attitude conventions and the small pieces of rotation maths the rest builds on.
//!
//! All scene maths is `f64` (glam's `D*` types); only the GPU sees `f32`, and
//! only after positions are made relative to the camera (see `render`).
//!
//! Attitude: yaw ψ about +Y, pitch θ about the body's X, roll φ about the
//! body's Z, applied intrinsically in the order yaw·pitch·roll:
//! `q = q_y(ψ) · q_x(θ) · q_z(φ)`. Presets hold degrees; poses hold unit
//! quaternions.

use glam::{DMat3, DQuat, DVec3};
use serde::{Deserialize, Serialize};

/// Roll/pitch/yaw in degrees (the paper's φ, θ, ψ).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct EulerDeg {
    pub roll: f64,
    pub pitch: f64,
    pub yaw: f64,
}

impl EulerDeg {
    /// The unit quaternion `q_y(yaw) · q_x(pitch) · q_z(roll)`.
    pub fn to_quat(self) -> DQuat {
        let qy = DQuat::from_rotation_y(self.yaw.to_radians());
        let qx = DQuat::from_rotation_x(self.pitch.to_radians());
        let qz = DQuat::from_rotation_z(self.roll.to_radians());
        (qy * qx * qz).normalize()
    }

    /// Inverse of [`EulerDeg::to_quat`]. At pitch ±90° (gimbal lock) yaw and
    /// roll are not separable; all of the rotation about the vertical goes into
    /// yaw and roll is 0. Compare rotations, not angles.
    pub fn from_quat(q: DQuat) -> Self {
        let m = DMat3::from_quat(q.normalize());
        // m = Ry(ψ) Rx(θ) Rz(φ), so m·e_z = (sinψ cosθ, −sinθ, cosψ cosθ).
        // θ from atan2 (well conditioned even at ±90°, unlike asin), ψ from the
        // nose direction, then φ from what is left, R_z(φ) = (Ry(ψ) Rx(θ))ᵀ m, so
        // any error in ψ near gimbal lock is absorbed by φ instead of showing in
        // the rotation.
        let horizontal = m.z_axis.x.hypot(m.z_axis.z);
        let pitch = (-m.z_axis.y).atan2(horizontal);
        let yaw = if horizontal > 1e-12 {
            m.z_axis.x.atan2(m.z_axis.z)
        } else {
            // Gimbal lock: the whole turn about the vertical goes into yaw.
            (-m.x_axis.z).atan2(m.x_axis.x)
        };
        let rest = (DMat3::from_rotation_y(yaw) * DMat3::from_rotation_x(pitch)).transpose() * m;
        let roll = rest.x_axis.y.atan2(rest.x_axis.x);
        Self {
            roll: roll.to_degrees(),
            pitch: pitch.to_degrees(),
            yaw: yaw.to_degrees(),
        }
    }
}

/// Spherical linear interpolation on the shortest arc, stable when the two
/// rotations are (nearly) equal: below a small angle it falls back to a
/// normalised linear blend instead of dividing by sin Ω ≈ 0.
pub fn slerp(q0: DQuat, q1: DQuat, t: f64) -> DQuat {
    let mut q1 = q1;
    let mut dot = q0.dot(q1);
    if dot < 0.0 {
        q1 = -q1;
        dot = -dot;
    }
    if dot > 1.0 - 1e-10 {
        return (q0 * (1.0 - t) + q1 * t).normalize();
    }
    let omega = dot.clamp(-1.0, 1.0).acos();
    let sin_omega = omega.sin();
    let a = ((1.0 - t) * omega).sin() / sin_omega;
    let b = (t * omega).sin() / sin_omega;
    (q0 * a + q1 * b).normalize()
}

/// The scene rotation of PlaneRX/RY/RZ (degrees), in Unity's order (the paper's
/// tool is Unity): Z first, then X, then Y, about the fixed world axes:
/// `R = R_y · R_x · R_z`.
pub fn plane_rotation(rx_deg: f64, ry_deg: f64, rz_deg: f64) -> DQuat {
    (DQuat::from_rotation_y(ry_deg.to_radians())
        * DQuat::from_rotation_x(rx_deg.to_radians())
        * DQuat::from_rotation_z(rz_deg.to_radians()))
    .normalize()
}

/// Rotation `camera_from_world` of a camera at `eye` looking at `target`, in
/// the computer-vision camera frame (x right, y down, z forward). `up_hint` is
/// world +Y; when the view direction is (anti)parallel to it the camera uses
/// world −Z (looking down) or +Z (looking up) as "up" so the result is a proper
/// rotation, never NaN.
pub fn look_at_cv(eye: DVec3, target: DVec3) -> Option<DMat3> {
    let forward = (target - eye).try_normalize()?;
    let world_up = DVec3::Y;
    let mut right = forward.cross(world_up);
    if right.length_squared() < 1e-18 {
        // Straight above (forward = −Y) or below (forward = +Y).
        let fallback_up = if forward.y < 0.0 {
            DVec3::NEG_Z
        } else {
            DVec3::Z
        };
        right = forward.cross(fallback_up);
    }
    let right = right.normalize();
    let down = forward.cross(right); // completes a right-handed (x right, y down, z forward) frame
    // Rows of camera_from_world are the camera axes expressed in world coordinates.
    Some(DMat3::from_cols(right, down, forward).transpose())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn mat_close(a: DMat3, b: DMat3, tol: f64) -> bool {
        a.to_cols_array()
            .iter()
            .zip(b.to_cols_array())
            .all(|(x, y)| (x - y).abs() < tol)
    }

    #[test]
    fn euler_order_is_yaw_pitch_roll_intrinsic() {
        // Yaw 90° turns the nose (+Z) to +X.
        let q = EulerDeg {
            roll: 0.0,
            pitch: 0.0,
            yaw: 90.0,
        }
        .to_quat();
        assert!((q * DVec3::Z - DVec3::X).length() < 1e-12);
        // Pitch is about the body's X after yaw: yaw 90 then pitch 90 turns the nose down (−Y).
        let q = EulerDeg {
            roll: 0.0,
            pitch: 90.0,
            yaw: 90.0,
        }
        .to_quat();
        assert!((q * DVec3::Z - DVec3::NEG_Y).length() < 1e-12);
        // Roll is about the body's Z (nose axis): it leaves the nose alone.
        let q = EulerDeg {
            roll: 30.0,
            pitch: 10.0,
            yaw: 20.0,
        }
        .to_quat();
        let q_no_roll = EulerDeg {
            roll: 0.0,
            pitch: 10.0,
            yaw: 20.0,
        }
        .to_quat();
        assert!((q * DVec3::Z - q_no_roll * DVec3::Z).length() < 1e-12);
    }

    #[test]
    fn euler_round_trip_including_gimbal_lock() {
        for &(r, p, y) in &[
            (10.0, 20.0, 30.0),
            (-170.0, 89.0, 179.0),
            (45.0, 90.0, 10.0),
            (5.0, -90.0, -60.0),
        ] {
            let e = EulerDeg {
                roll: r,
                pitch: p,
                yaw: y,
            };
            let back = EulerDeg::from_quat(e.to_quat());
            let m0 = DMat3::from_quat(e.to_quat());
            let m1 = DMat3::from_quat(back.to_quat());
            assert!(mat_close(m0, m1, 1e-9), "{e:?} -> {back:?}");
        }
    }

    #[test]
    fn look_at_is_a_rotation_even_straight_down() {
        for eye in [
            DVec3::new(0.0, 10.0, 0.0),
            DVec3::new(0.0, -10.0, 0.0),
            DVec3::new(3.0, 1.0, 5.0),
        ] {
            let m = look_at_cv(eye, DVec3::ZERO).expect("distinct points");
            assert!((m.determinant() - 1.0).abs() < 1e-12);
            assert!(mat_close(m * m.transpose(), DMat3::IDENTITY, 1e-12));
            // The target is straight ahead: camera z axis.
            let dir = m * (DVec3::ZERO - eye).normalize();
            assert!((dir - DVec3::Z).length() < 1e-12);
        }
        assert!(look_at_cv(DVec3::ONE, DVec3::ONE).is_none());
    }

    #[test]
    fn slerp_is_stable_for_equal_and_opposite_quaternions() {
        let q = EulerDeg {
            roll: 1.0,
            pitch: 2.0,
            yaw: 3.0,
        }
        .to_quat();
        let r = slerp(q, q, 0.5);
        assert!(r.is_finite() && (r.length() - 1.0).abs() < 1e-12);
        // -q is the same rotation: the shortest arc is no motion at all.
        let r = slerp(q, -q, 0.3);
        assert!(mat_close(DMat3::from_quat(r), DMat3::from_quat(q), 1e-9));
    }
}
