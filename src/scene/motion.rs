//! Sequences (the paper's §3.2, equations 3–6): each drone's initial and
//! terminal 6-DoF state and the state at step t of T.
//!
//! Terminal state of drone i, from its initial `(p0, q0)` and the formation
//! centre `c` (the mean initial position): `p_T = c + R_turn·(p0 − c) +
//! translate + Δp_i` and `q_T = R_turn · q0 · q_z(bank) · Δq_i`, where
//! `R_turn` turns about +Y, the bank rolls about each drone's own forward
//! axis, and `Δp_i`, `Δq_i` are the drone's own draws (x, y, z, then roll,
//! pitch, yaw, drone by drone, after the placement's draws). Then
//! `p(t) = p0 + (t/T)·(p_T − p0)` (eq. 4) and `q(t) = SLERP(q0, q_T, t/T)`
//! (eq. 5, shortest arc, see `math::slerp`).

use glam::{DQuat, DVec3};
use rand::Rng;

use super::math::{EulerDeg, slerp};
use crate::preset::Motion;

/// One drone's initial and terminal state.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Endpoints {
    pub p0: DVec3,
    pub q0: DQuat,
    pub p_t: DVec3,
    pub q_t: DQuat,
}

impl Endpoints {
    /// The state at step `t` of `steps` (eqs. 4–5).
    pub fn at(&self, t: u64, steps: u64) -> (DVec3, DQuat) {
        self.at_step(t as f64, steps)
    }

    /// The state at the fractional step `t` of `steps` (eqs. 4–5 between
    /// steps, and beyond `steps` along the same line and arc).
    pub fn at_step(&self, t: f64, steps: u64) -> (DVec3, DQuat) {
        if steps == 0 {
            return (self.p0, self.q0);
        }
        let alpha = t / steps as f64;
        (
            self.p0 + alpha * (self.p_t - self.p0),
            slerp(self.q0, self.q_t, alpha),
        )
    }
}

fn symmetric(rng: &mut impl Rng, half: f64) -> f64 {
    if half > 0.0 {
        rng.random_range(-half..=half)
    } else {
        0.0
    }
}

fn in_range(rng: &mut impl Rng, (lo, hi): (f64, f64)) -> f64 {
    if hi > lo {
        rng.random_range(lo..=hi)
    } else {
        lo
    }
}

/// The terminal state of every drone of `initial` (position, attitude),
/// drawing each drone's own displacement and attitude change from `rng`.
pub fn endpoints(
    initial: &[(DVec3, DQuat)],
    motion: &Motion,
    rng: &mut impl Rng,
) -> Vec<Endpoints> {
    let n = initial.len().max(1) as f64;
    let centre = initial.iter().map(|(p, _)| *p).sum::<DVec3>() / n;
    let turn = DQuat::from_rotation_y(motion.turn_deg.to_radians());
    let bank = DQuat::from_rotation_z(motion.bank_deg.to_radians());
    let (tx, ty, tz) = motion.translate_m;
    let (dx, dy, dz) = motion.displacement_m;
    let a = &motion.attitude_change;
    initial
        .iter()
        .map(|&(p0, q0)| {
            let dp = DVec3::new(symmetric(rng, dx), symmetric(rng, dy), symmetric(rng, dz));
            let dq = EulerDeg {
                roll: in_range(rng, a.roll_deg),
                pitch: in_range(rng, a.pitch_deg),
                yaw: in_range(rng, a.yaw_deg),
            }
            .to_quat();
            Endpoints {
                p0,
                q0,
                p_t: centre + turn * (p0 - centre) + DVec3::new(tx, ty, tz) + dp,
                q_t: (turn * q0 * bank * dq).normalize(),
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    #[test]
    fn states_follow_equations_4_and_5() {
        let q0 = EulerDeg {
            roll: 10.0,
            pitch: -20.0,
            yaw: 30.0,
        }
        .to_quat();
        let q_t = EulerDeg {
            roll: -40.0,
            pitch: 5.0,
            yaw: 150.0,
        }
        .to_quat();
        let e = Endpoints {
            p0: DVec3::new(1.0, 2.0, 3.0),
            q0,
            p_t: DVec3::new(-5.0, 4.0, 11.0),
            q_t,
        };
        let steps = 8u64;
        // Ω from the paper's definition (shortest arc: the sign of q_T chosen so the dot is ≥ 0).
        let (q_t_near, dot) = if q0.dot(q_t) < 0.0 {
            (-q_t, -q0.dot(q_t))
        } else {
            (q_t, q0.dot(q_t))
        };
        let omega = dot.acos();
        for t in 0..=steps {
            let (p, q) = e.at(t, steps);
            let a = t as f64 / steps as f64;
            assert_eq!(p, e.p0 + a * (e.p_t - e.p0), "eq. 4 at t = {t}");
            let expected = q0 * (((1.0 - a) * omega).sin() / omega.sin())
                + q_t_near * ((a * omega).sin() / omega.sin());
            let angle = q.angle_between(expected);
            assert!(angle < 1e-6, "eq. 5 at t = {t}: {angle} rad off");
        }
        assert_eq!(e.at(0, steps).0, e.p0);
        assert!(e.at(steps, steps).1.angle_between(q_t) < 1e-6);
    }

    #[test]
    fn slerp_is_stable_for_equal_and_antipodal_rotations() {
        let q = EulerDeg {
            roll: 1.0,
            pitch: 2.0,
            yaw: 3.0,
        }
        .to_quat();
        for other in [q, -q, (q * DQuat::from_rotation_y(1e-9)).normalize()] {
            for t in [0.0, 0.25, 0.5, 1.0] {
                let r = slerp(q, other, t);
                assert!(r.is_finite() && (r.length() - 1.0).abs() < 1e-12);
                assert!(r.angle_between(q) < 1e-6, "{other:?} at {t}");
            }
        }
        // A half turn: the midpoint is a quarter turn, and finite.
        let half = DQuat::from_rotation_y(std::f64::consts::PI);
        let mid = slerp(DQuat::IDENTITY, half, 0.5);
        assert!(mid.angle_between(DQuat::from_rotation_y(std::f64::consts::FRAC_PI_2)) < 1e-6);
    }

    #[test]
    fn manoeuvre_turns_and_translates_the_formation() {
        let initial = vec![
            (DVec3::new(-1.0, 0.0, 0.0), DQuat::IDENTITY),
            (DVec3::new(1.0, 0.0, 0.0), DQuat::IDENTITY),
        ];
        let motion = Motion {
            translate_m: (0.0, 0.0, 10.0),
            turn_deg: 90.0,
            bank_deg: 0.0,
            ..Motion::default()
        };
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
        let e = endpoints(&initial, &motion, &mut rng);
        assert!(e[0].p_t.distance(DVec3::new(0.0, 0.0, 11.0)) < 1e-12);
        assert!(e[1].p_t.distance(DVec3::new(0.0, 0.0, 9.0)) < 1e-12);
        assert!(
            e[0].q_t
                .angle_between(DQuat::from_rotation_y(std::f64::consts::FRAC_PI_2))
                < 1e-12
        );
    }
}
