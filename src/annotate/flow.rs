//! Forward optical flow from a frame to the next of its sequence
//! (`output.masks.flow`, issue 41), exact from geometry rather than
//! estimated from pixels.
//!
//! A drone's pixel (its centre, at the depth the depth map gives it) is
//! unprojected to a world point, carried by that drone's rigid motion from
//! t to t + 1 (its pose at t to its pose at t + 1: eqs. 4–5), and projected
//! by the camera at t + 1; the flow is the shift. The background (sky,
//! ground, backplate) is drawn by direction, at infinity: its flow is the
//! camera's rotation alone, zero where the camera turns nothing. A pixel
//! whose point lies at or behind the camera at t + 1 has no flow (invalid).
//!
//! Under a rolling shutter (`camera_model.rolling_shutter`) each pixel is
//! seen at its row's time ([`RowClock`]) and lands, in the next frame, at the
//! time of the row it lands on there (a fixed point, [`rolling_drone_flow`],
//! [`rolling_background_flow`]): the flow is the shift between the two
//! shuttered pictures.
//!
//! Written as KITTI's 16-bit PNG ([`kitti_rgb16`]): per pixel
//! (u·64 + 2¹⁵, v·64 + 2¹⁵, valid), 0 in all three where invalid.

use glam::{DMat3, DQuat, DVec2, DVec3};

use crate::scene::FrameScene;
use crate::scene::camera::Camera;

/// A rigid body's pose: the position of its centre and its rotation.
pub type Pose = (DVec3, DQuat);

/// What a frame's flow is made of: the cameras at t and t + 1 and the
/// flow of every pixel of the instance image.
#[derive(Clone, Debug, PartialEq)]
pub struct FrameFlow {
    pub camera: Camera,
    pub next_camera: Camera,
    /// Per pixel of the instance image (its order): the drone point's shift
    /// to t + 1 in pixels, `None` where it is at or behind the camera at t + 1.
    pub drones: Vec<Option<DVec2>>,
    /// Under a rolling shutter, each frame's row clock (t, t + 1); `None`:
    /// a global shutter, every row at the frame's time.
    pub clocks: Option<[RowClock; 2]>,
}

/// Fixed-point iterations for the row a point lands on in a rolling-shutter
/// picture (each shrinks the error by the point's vertical image speed over
/// the readout's, far below 1).
pub const ROW_ITERATIONS: usize = 8;

/// Where a point lands in a rolling-shutter picture: from its image
/// `first`, imaged again by `at_row` at the time of the row it lands on,
/// until it moves under 1e-4 px along the rows or after `iterations` more
/// images (`None`: not imaged at some row's time).
pub fn settle_on_row(
    first: DVec2,
    iterations: usize,
    mut at_row: impl FnMut(f64) -> Option<DVec2>,
) -> Option<DVec2> {
    let mut at = first;
    for _ in 0..iterations {
        let next = at_row(at.y)?;
        let moved = (next.y - at.y).abs();
        at = next;
        if moved < 1e-4 {
            break;
        }
    }
    Some(at)
}

/// A frame's rolling readout as the flow sees it: the pixel centres of row
/// coordinate v are exposed τ = readout·(v − 0.5)/height after the frame's
/// time (a row's pixels at its index's time, clamped to the frame's rows),
/// the camera turned by then about its own vertical axis by the yaw rate,
/// R(τ) = R_y(ω·τ)ᵀ·R(0) (`pipeline::rolling`'s camera).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RowClock {
    pub readout_s: f64,
    pub yaw_rad_s: f64,
}

impl RowClock {
    /// The time of a point at row coordinate `v` of a `height`-row picture.
    pub fn time_at(&self, v: f64, height: u32) -> f64 {
        let h = f64::from(height.max(1));
        (v - 0.5).clamp(0.0, h) / h * self.readout_s
    }

    /// `cam`'s rotation `tau` after the frame's time.
    pub fn turned(&self, cam: &Camera, tau: f64) -> DMat3 {
        DMat3::from_rotation_y(self.yaw_rad_s * tau).transpose() * cam.camera_from_world
    }
}

/// The flow of `scene`'s drone pixels (`instance`: row-major index and
/// drone, `depth_m` per entry) to `next`, the following frame of its
/// sequence. A drone missing at t + 1 gives its pixels no flow.
pub fn flow_of(
    scene: &FrameScene,
    next: &FrameScene,
    instance: &[(u32, u32)],
    depth_m: &[f64],
) -> FrameFlow {
    let poses = |s: &FrameScene| -> Vec<Pose> {
        s.drones.iter().map(|d| (d.position, d.rotation)).collect()
    };
    FrameFlow {
        camera: scene.camera,
        next_camera: next.camera,
        drones: drone_flow(
            (&scene.camera, &next.camera),
            (&poses(scene), &poses(next)),
            instance,
            depth_m,
        ),
        clocks: None,
    }
}

/// A frame under its rolling shutter, as the flow takes it: its row clock
/// and, at τ after its time, the camera and drone d's pose.
pub struct TimedFrame<'a> {
    pub clock: RowClock,
    pub at: &'a (dyn Fn(usize, f64) -> Option<(Camera, Pose)> + Sync),
}

/// Each instance pixel's flow under rolling shutters: unprojected at its
/// depth with the camera of its row's time, carried with drone d from its
/// pose then into its body, and placed with the pose and camera of the
/// next frame's row it lands on (a fixed point from its own row). With
/// readouts of 0, [`drone_flow`]'s numbers.
pub fn rolling_drone_flow(
    frames: (&TimedFrame, &TimedFrame),
    (width, height): (u32, u32),
    instance_depth: (&[(u32, u32)], &[f64]),
) -> Vec<Option<DVec2>> {
    let (f0, f1) = frames;
    let width = width.max(1);
    let (instance, depth_m) = instance_depth;
    (instance.iter().zip(depth_m))
        .map(|(&(i, d), &z)| {
            let centre = DVec2::new(f64::from(i % width), f64::from(i / width)) + 0.5;
            let (cam, (p0, q0)) = (f0.at)(d as usize, f0.clock.time_at(centre.y, height))?;
            let world_from_camera = cam.camera_from_world.transpose();
            let world = world_from_camera * (ray(&cam, centre) * z) + cam.position;
            let body = q0.inverse() * (world - p0);
            let image = |v: f64| {
                let (next, (p1, q1)) = (f1.at)(d as usize, f1.clock.time_at(v, height))?;
                next.project_camera_point(next.camera_from_world_point(p1 + q1 * body))
            };
            Some(settle_on_row(image(centre.y)?, ROW_ITERATIONS - 1, image)? - centre)
        })
        .collect()
}

/// The flow at pixel centre `at` of a point at infinity under rolling
/// shutters: its direction seen by `cams.0` turned to `at`'s row time, found
/// by `cams.1` turned to the time of the row it lands on (a fixed point).
pub fn rolling_background_flow(
    cams: (&Camera, &Camera),
    clocks: [RowClock; 2],
    at: DVec2,
) -> Option<DVec2> {
    let (cam, next) = cams;
    let tau = clocks[0].time_at(at.y, cam.height);
    let direction = clocks[0].turned(cam, tau).transpose() * ray(cam, at);
    let (nf, nc) = (next.focal_px(), next.principal_point());
    let image = |v: f64| {
        let p = clocks[1].turned(next, clocks[1].time_at(v, next.height)) * direction;
        (!p.z.is_nan() && p.z > 0.0)
            .then(|| DVec2::new(nf * p.x / p.z + nc.x, nf * p.y / p.z + nc.y))
    };
    Some(settle_on_row(image(at.y)?, ROW_ITERATIONS - 1, image)? - at)
}

/// Each instance pixel's flow: unprojected at its depth with `cameras.0`,
/// moved from `poses.0[d]` to `poses.1[d]`, projected with `cameras.1`.
pub fn drone_flow(
    cameras: (&Camera, &Camera),
    poses: (&[Pose], &[Pose]),
    instance: &[(u32, u32)],
    depth_m: &[f64],
) -> Vec<Option<DVec2>> {
    let (cam, next) = cameras;
    let width = cam.width.max(1);
    let world_from_camera = cam.camera_from_world.transpose();
    (instance.iter().zip(depth_m))
        .map(|(&(i, d), &z)| {
            let ((p0, q0), (p1, q1)) = (poses.0.get(d as usize)?, poses.1.get(d as usize)?);
            let centre = DVec2::new(f64::from(i % width), f64::from(i / width)) + 0.5;
            let world = world_from_camera * (ray(cam, centre) * z) + cam.position;
            let moved = *p1 + *q1 * (q0.inverse() * (world - *p0));
            let to = next.project_camera_point(next.camera_from_world_point(moved))?;
            Some(to - centre)
        })
        .collect()
}

/// The camera-frame ray through continuous pixel `at`, with z = 1.
fn ray(cam: &Camera, at: DVec2) -> DVec3 {
    let (f, c) = (cam.focal_px(), cam.principal_point());
    DVec3::new((at.x - c.x) / f, (at.y - c.y) / f, 1.0)
}

/// The flow at pixel centre `at` of a point at infinity (the background):
/// the camera's rotation and intrinsics only.
pub fn background_flow(cam: &Camera, next: &Camera, at: DVec2) -> Option<DVec2> {
    BackgroundFlow::new(cam, next).at(at)
}

/// [`background_flow`] from `cam` to `next` with the cameras' matrices and
/// intrinsics taken once, for many pixels (the same operations, so the
/// same numbers).
#[derive(Clone, Copy, Debug)]
pub struct BackgroundFlow {
    world_from_camera: DMat3,
    next_from_world: DMat3,
    /// Each camera's focal length and principal point, pixels.
    intrinsics: [(f64, DVec2); 2],
}

impl BackgroundFlow {
    pub fn new(cam: &Camera, next: &Camera) -> Self {
        Self {
            world_from_camera: cam.camera_from_world.transpose(),
            next_from_world: next.camera_from_world,
            intrinsics: [
                (cam.focal_px(), cam.principal_point()),
                (next.focal_px(), next.principal_point()),
            ],
        }
    }

    /// The flow at pixel centre `at` (`None`: the direction is behind the
    /// next camera). [`Camera::project_camera_point`]'s formula.
    pub fn at(&self, at: DVec2) -> Option<DVec2> {
        let [(f, c), (nf, nc)] = self.intrinsics;
        let ray = DVec3::new((at.x - c.x) / f, (at.y - c.y) / f, 1.0);
        let p = self.next_from_world * (self.world_from_camera * ray);
        if p.z.is_nan() || p.z <= 0.0 {
            return None;
        }
        Some(DVec2::new(nf * p.x / p.z + nc.x, nf * p.y / p.z + nc.y) - at)
    }
}

impl BackgroundFlow {
    /// Where the pixel centres of row `y` at columns `xs` take their
    /// background from in the next camera's picture: each (x, y) moved by
    /// [`Self::at`]'s flow, or itself where there is none (`out`, one per
    /// column). [`Self::at`]'s operations in its order, the row's terms of
    /// the first product taken once (the same values), four columns at a
    /// time in AVX2 lanes where the CPU has them: the same numbers.
    pub fn row_sources(&self, y: f64, xs: &[f64], out: &mut [(f64, f64)]) {
        #[cfg(target_arch = "x86_64")]
        if crate::simd::avx2() {
            // SAFETY: the CPU has AVX2 (checked by `avx2`, which
            // `SWARMSHOT_SIMD=base` caps).
            #[allow(unsafe_code)]
            unsafe {
                return self.row_sources_avx2(y, xs, out);
            }
        }
        self.row_sources_in(y, xs, out);
    }

    /// [`Self::row_sources`] compiled for AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn row_sources_avx2(&self, y: f64, xs: &[f64], out: &mut [(f64, f64)]) {
        self.row_sources_in(y, xs, out);
    }

    /// [`Self::row_sources`]' arithmetic, four columns at a time in arrays
    /// (lanes a vector unit takes), the rest one by one.
    #[inline(always)]
    fn row_sources_in(&self, y: f64, xs: &[f64], out: &mut [(f64, f64)]) {
        let [(f, c), (nf, nc)] = self.intrinsics;
        let (w, n) = (self.world_from_camera, self.next_from_world);
        // `at`'s ray is ((x − cx)/f, (y − cy)/f, 1): W·ray = W.x·rx + W.y·ry + W.z·1.
        let ry = (y - c.y) / f;
        let (wy, wz) = (w.y_axis * ry, w.z_axis * 1.0);
        let one = |x: f64| -> (f64, f64) {
            let q = w.x_axis * ((x - c.x) / f) + wy + wz;
            let p = n * q;
            if p.z.is_nan() || p.z <= 0.0 {
                return (x, y);
            }
            let flow = DVec2::new(nf * p.x / p.z + nc.x, nf * p.y / p.z + nc.y) - DVec2::new(x, y);
            (x + flow.x, y + flow.y)
        };
        let len = out.len().min(xs.len());
        let (out, xs) = (&mut out[..len], &xs[..len]);
        for (o, x) in out.chunks_exact_mut(4).zip(xs.chunks_exact(4)) {
            let x: [f64; 4] = [x[0], x[1], x[2], x[3]];
            let rx: [f64; 4] = std::array::from_fn(|l| (x[l] - c.x) / f);
            let q: [[f64; 4]; 3] = std::array::from_fn(|i| {
                std::array::from_fn(|l| w.x_axis[i] * rx[l] + wy[i] + wz[i])
            });
            let p: [[f64; 4]; 3] = std::array::from_fn(|i| {
                std::array::from_fn(|l| {
                    n.x_axis[i] * q[0][l] + n.y_axis[i] * q[1][l] + n.z_axis[i] * q[2][l]
                })
            });
            for l in 0..4 {
                let valid = !(p[2][l].is_nan() || p[2][l] <= 0.0);
                let fx = (nf * p[0][l] / p[2][l] + nc.x) - x[l];
                let fy = (nf * p[1][l] / p[2][l] + nc.y) - y;
                o[l] = if valid {
                    (x[l] + fx, y + fy)
                } else {
                    (x[l], y)
                };
            }
        }
        let done = len / 4 * 4;
        for (o, &x) in out[done..].iter_mut().zip(&xs[done..]) {
            *o = one(x);
        }
    }
}

/// KITTI's encoding of one flow vector: (u·64 + 2¹⁵, v·64 + 2¹⁵, 1),
/// clamped to 16 bits; (0, 0, 0) when invalid.
pub fn kitti(flow: Option<DVec2>) -> [u16; 3] {
    let q = |x: f64| (x * 64.0 + 32_768.0).round().clamp(0.0, 65_535.0) as u16;
    flow.map_or([0; 3], |f| [q(f.x), q(f.y), 1])
}

/// The whole frame's flow as KITTI's row-major RGB16 samples: the
/// background's, then each instance pixel's (`instance`: row-major index,
/// drone) over it.
pub fn kitti_rgb16(flow: &FrameFlow, instance: &[(u32, u32)]) -> Vec<u16> {
    let (cam, next) = (&flow.camera, &flow.next_camera);
    let (w, h) = (cam.width as usize, cam.height as usize);
    let still = cam.camera_from_world == next.camera_from_world
        && cam.focal_px() == next.focal_px()
        && cam.principal_point() == next.principal_point();
    let turns = (flow.clocks.iter().flatten()).any(|c| c.yaw_rad_s != 0.0 && c.readout_s > 0.0);
    let mut out = if let Some(clocks) = flow.clocks.filter(|_| turns || !still) {
        rolling_background_rgb16(cam, next, clocks)
    } else if still {
        // Every direction lands where it was: zero flow, valid.
        [32_768u16, 32_768, 1].repeat(w * h)
    } else {
        let mut out = Vec::with_capacity(w * h * 3);
        let background = BackgroundFlow::new(cam, next);
        for y in 0..h {
            for x in 0..w {
                let at = DVec2::new(x as f64, y as f64) + 0.5;
                out.extend(kitti(background.at(at)));
            }
        }
        out
    };
    for (&(i, _), &f) in instance.iter().zip(&flow.drones) {
        if let Some(px) = out.get_mut(i as usize * 3..i as usize * 3 + 3) {
            px.copy_from_slice(&kitti(f));
        }
    }
    out
}

/// The background's flow under rolling shutters as KITTI's RGB16 samples,
/// row by row on rayon's threads ([`rolling_background_row`]).
fn rolling_background_rgb16(cam: &Camera, next: &Camera, clocks: [RowClock; 2]) -> Vec<u16> {
    use rayon::prelude::*;
    let (w, h) = (cam.width as usize, cam.height as usize);
    let mut out = vec![0u16; w * h * 3];
    out.par_chunks_mut((w * 3).max(1))
        .enumerate()
        .for_each_init(
            || vec![None; w],
            |flows, (y, row)| {
                rolling_background_row((cam, next), clocks, y as u32, flows);
                for (px, f) in row.chunks_exact_mut(3).zip(flows.iter()) {
                    px.copy_from_slice(&kitti(*f));
                }
            },
        );
    out
}

/// Columns between the points where [`rolling_background_row`] starts
/// solving a row exactly.
pub const FLOW_KNOT_PX: usize = 32;

/// How far (pixels) a segment's midpoint may lie from the line between its
/// ends for the segment to be filled linearly: a tenth of KITTI's 1/64 px.
pub const FLOW_LINEAR_TOLERANCE_PX: f64 = 1.0 / 640.0;

/// Row `y`'s background flow under rolling shutters at the pixel centres
/// of `row` (one entry a column): [`rolling_background_flow`] solved at
/// every [`FLOW_KNOT_PX`]-th column and the last, then each segment between
/// solved points halved until its midpoint's solution lies within
/// [`FLOW_LINEAR_TOLERANCE_PX`] of the line between its ends, which then
/// fills it (the field is smooth: a rotation homography per row time);
/// a segment with an end behind the next camera is solved at every pixel.
pub fn rolling_background_row(
    cams: (&Camera, &Camera),
    clocks: [RowClock; 2],
    y: u32,
    row: &mut [Option<DVec2>],
) {
    let Some(last) = row.len().checked_sub(1) else {
        return;
    };
    let solve = |x: usize| {
        let at = DVec2::new(x as f64, f64::from(y)) + 0.5;
        rolling_background_flow(cams, clocks, at)
    };
    row[0] = solve(0);
    let mut a = 0;
    while a < last {
        let b = (a + FLOW_KNOT_PX).min(last);
        row[b] = solve(b);
        fill_segment(row, (a, b), &solve);
        a = b;
    }
}

/// `row` strictly between `a` and `b` (both solved) by halving
/// ([`rolling_background_row`]).
fn fill_segment(
    row: &mut [Option<DVec2>],
    (a, b): (usize, usize),
    solve: &dyn Fn(usize) -> Option<DVec2>,
) {
    if b - a < 2 {
        return;
    }
    let m = a + (b - a) / 2;
    row[m] = solve(m);
    let line = |x: usize, fa: DVec2, fb: DVec2| fa + (fb - fa) * ((x - a) as f64 / (b - a) as f64);
    match (row[a], row[m], row[b]) {
        (Some(fa), Some(fm), Some(fb))
            if (line(m, fa, fb) - fm).abs().max_element() <= FLOW_LINEAR_TOLERANCE_PX =>
        {
            for x in (a + 1..b).filter(|&x| x != m) {
                row[x] = Some(line(x, fa, fb));
            }
        }
        _ => {
            fill_segment(row, (a, m), solve);
            fill_segment(row, (m, b), solve);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn camera(camera_from_world: DMat3, position: DVec3) -> Camera {
        Camera {
            width: 640,
            height: 480,
            fov_y_deg: 50.0,
            position,
            camera_from_world,
            near_m: 0.01,
        }
    }

    /// A row's sources four columns at a time are [`BackgroundFlow::at`]'s
    /// bit for bit: turns small and large (columns whose direction falls
    /// behind the next camera keep their place), rows across the picture.
    #[test]
    fn a_rows_sources_are_the_flow_at_each_column_bit_for_bit() {
        let cam = camera(DMat3::from_rotation_x(0.1), DVec3::ZERO);
        for turn in [0.003, -0.2, 1.9] {
            let next = camera(
                DMat3::from_rotation_y(turn) * DMat3::from_rotation_z(0.01),
                DVec3::ONE,
            );
            let flow = BackgroundFlow::new(&cam, &next);
            let xs: Vec<f64> = (0..23).map(|i| f64::from(i) * 29.3 + 0.5).collect();
            let (mut invalid, mut out) = (0, vec![(0.0, 0.0); xs.len()]);
            for y in [0.5, 133.5, 479.5] {
                flow.row_sources(y, &xs, &mut out);
                for (&x, &got) in xs.iter().zip(&out) {
                    let f = flow.at(DVec2::new(x, y));
                    invalid += usize::from(f.is_none());
                    let want = f.map_or((x, y), |f| (x + f.x, y + f.y));
                    let bits = |p: (f64, f64)| (p.0.to_bits(), p.1.to_bits());
                    assert_eq!(bits(got), bits(want), "turn {turn} at ({x}, {y})");
                }
            }
            assert_eq!(invalid > 0, turn > 1.0, "turn {turn}: {invalid} behind");
        }
    }

    /// A pure yaw by θ (about the camera's y axis): a direction at angle α
    /// right of the axis moves to α − θ, so a pixel at x − cx = f·tan α
    /// (on the middle row) lands at f·tan(α − θ); off the middle row, the
    /// general rotation homography K·R·K⁻¹.
    #[test]
    fn a_pure_camera_yaw_gives_the_rotation_flow_field() {
        let theta = 2f64.to_radians();
        let cam = camera(DMat3::IDENTITY, DVec3::ZERO);
        // Turning the camera right by θ: R' = R_y(−θ)·R in the y-down frame's terms.
        let next = camera(DMat3::from_rotation_y(-theta), DVec3::new(3.0, 1.0, -2.0));
        let (f, c) = (cam.focal_px(), cam.principal_point());
        for x in [0.5, 100.5, 320.5, 500.5, 639.5] {
            let at = DVec2::new(x, c.y);
            let alpha = ((x - c.x) / f).atan();
            let expected = f * (alpha - theta).tan() + c.x - x;
            let flow = background_flow(&cam, &next, at).expect("in front");
            assert!(
                (flow.x - expected).abs() < 1e-9,
                "x {x}: {flow} vs {expected}"
            );
            assert!(flow.y.abs() < 1e-9, "the middle row stays: {flow}");
        }
        // The principal point moves left by f·tan θ.
        let centre = background_flow(&cam, &next, c).expect("in front");
        assert!((centre.x + f * theta.tan()).abs() < 1e-9, "{centre}");
        // Off the middle row: the homography.
        let at = DVec2::new(50.5, 30.5);
        let h = next.k() * next.camera_from_world * cam.k().inverse();
        let p = h * at.extend(1.0);
        let flow = background_flow(&cam, &next, at).expect("in front");
        assert!((flow - (p.truncate() / p.z - at)).length() < 1e-9);
    }

    /// A drone translating sideways by Δ at depth Z, the camera still: each
    /// of its pixels moves by f·Δ/z, z the pixel's own depth.
    #[test]
    fn a_drone_moving_sideways_shifts_by_f_delta_over_depth() {
        let cam = camera(DMat3::IDENTITY, DVec3::ZERO);
        let q = DQuat::from_rotation_y(0.4);
        let (z, delta) = (20.0, 0.3);
        let poses0 = [(DVec3::new(0.0, 0.0, z), q)];
        let poses1 = [(DVec3::new(delta, 0.0, z), q)];
        let instance: Vec<(u32, u32)> = [(300, 230), (320, 240), (331, 251)]
            .iter()
            .map(|&(x, y)| (y * 640 + x, 0))
            .collect();
        let depths = [19.9, 20.0, 20.2];
        let flows = drone_flow((&cam, &cam), (&poses0, &poses1), &instance, &depths);
        for (flow, z) in flows.iter().zip(depths) {
            let flow = flow.expect("in front");
            let expected = cam.focal_px() * delta / z;
            assert!((flow.x - expected).abs() < 1e-9, "{flow} vs {expected}");
            assert!(flow.y.abs() < 1e-9);
        }
        // A drone of another index, or one missing at t + 1, has no flow.
        let flows = drone_flow((&cam, &cam), (&poses0, &[]), &instance, &depths);
        assert!(flows.iter().all(Option::is_none));
    }

    /// A drone turning about its centre: the point on its axis does not
    /// move, a point off it moves by the turn; a point carried behind the
    /// camera has no flow.
    #[test]
    fn a_turning_drone_moves_its_points_about_its_centre() {
        let cam = camera(DMat3::IDENTITY, DVec3::ZERO);
        let centre = DVec3::new(0.0, 0.0, 10.0);
        let turn = DQuat::from_rotation_z(0.5);
        let poses0 = [(centre, DQuat::IDENTITY)];
        let poses1 = [(centre, turn)];
        let c = cam.principal_point();
        let (cx, cy) = (c.x as u32, c.y as u32);
        let instance = [(cy * 640 + cx, 0), (cy * 640 + cx + 40, 0)];
        let flows = drone_flow((&cam, &cam), (&poses0, &poses1), &instance, &[10.0, 10.0]);
        // The pixel centre sits half a pixel off the axis: it turns by 0.5 rad about it.
        let on_axis = DVec2::splat(0.5);
        let expected = DVec2::from_angle(0.5).rotate(on_axis) - on_axis;
        assert!((flows[0].expect("in front") - expected).length() < 1e-9);
        let off = DVec2::new(40.5, 0.5);
        let expected = DVec2::from_angle(0.5).rotate(off) - off;
        assert!((flows[1].expect("in front") - expected).length() < 1e-9);
        let behind = [(DVec3::new(0.0, 0.0, -10.0), DQuat::IDENTITY)];
        let flows = drone_flow((&cam, &cam), (&poses0, &behind), &instance, &[10.0, 10.0]);
        assert_eq!(flows, vec![None, None]);
    }

    #[test]
    fn kitti_encodes_sixty_fourths_about_two_to_the_fifteen() {
        assert_eq!(kitti(Some(DVec2::new(1.5, -2.25))), [32_864, 32_624, 1]);
        assert_eq!(kitti(Some(DVec2::ZERO)), [32_768, 32_768, 1]);
        assert_eq!(kitti(Some(DVec2::new(1e6, -1e6))), [65_535, 0, 1]);
        assert_eq!(kitti(None), [0, 0, 0]);
        let cam = camera(DMat3::IDENTITY, DVec3::ZERO);
        let flow = FrameFlow {
            camera: cam,
            next_camera: cam,
            drones: vec![Some(DVec2::new(1.0, 0.0)), None],
            clocks: None,
        };
        let rgb = kitti_rgb16(&flow, &[(5, 0), (7, 0)]);
        assert_eq!(rgb.len(), 640 * 480 * 3);
        assert_eq!(&rgb[15..18], &[32_832, 32_768, 1]);
        assert_eq!(&rgb[21..24], &[0, 0, 0]);
        assert_eq!(&rgb[0..3], &[32_768, 32_768, 1]);
    }

    /// A frame of the camera `cam` turning at `yaw` rad/s over a readout of
    /// `readout` s, a drone moving from `p` at velocity `v` (m/s), turning
    /// at `spin` rad/s about its vertical axis.
    fn timed(
        readout: f64,
        yaw: f64,
        cam: Camera,
        drone: (DVec3, DVec3, f64),
    ) -> (
        RowClock,
        impl Fn(usize, f64) -> Option<(Camera, Pose)> + Sync,
    ) {
        let clock = RowClock {
            readout_s: readout,
            yaw_rad_s: yaw,
        };
        let at = move |d: usize, tau: f64| {
            let (p, v, spin) = drone;
            let turned = Camera {
                camera_from_world: clock.turned(&cam, tau),
                ..cam
            };
            (d == 0).then(|| (turned, (p + v * tau, DQuat::from_rotation_y(spin * tau))))
        };
        (clock, at)
    }

    /// Pixels around (320, 240) and their depths.
    fn pixels() -> (Vec<(u32, u32)>, Vec<f64>) {
        let instance: Vec<(u32, u32)> = [(300, 230), (320, 240), (331, 301)]
            .iter()
            .map(|&(x, y)| (y * 640 + x, 0))
            .collect();
        (instance, vec![19.9, 20.0, 20.2])
    }

    #[test]
    fn under_a_rolling_shutter_a_still_scene_has_no_flow() {
        let cam = camera(DMat3::IDENTITY, DVec3::ZERO);
        let still = (DVec3::new(0.0, 0.0, 20.0), DVec3::ZERO, 0.0);
        let (c0, at0) = timed(0.03, 0.0, cam, still);
        let (c1, at1) = timed(0.02, 0.0, cam, still);
        let (f0, f1) = (
            TimedFrame {
                clock: c0,
                at: &at0,
            },
            TimedFrame {
                clock: c1,
                at: &at1,
            },
        );
        let (instance, depths) = pixels();
        let flows = rolling_drone_flow((&f0, &f1), (640, 480), (&instance, &depths));
        for f in flows {
            assert!(f.expect("in front").length() < 1e-9, "{f:?}");
        }
        for at in [
            DVec2::new(0.5, 0.5),
            DVec2::new(320.5, 240.5),
            DVec2::new(639.5, 479.5),
        ] {
            let f = rolling_background_flow((&cam, &cam), [c0, c1], at).expect("in front");
            assert!(f.length() < 1e-9, "{f}");
        }
        // Written: every pixel valid and zero.
        let flow = FrameFlow {
            camera: cam,
            next_camera: cam,
            drones: vec![Some(DVec2::ZERO); 3],
            clocks: Some([c0, c1]),
        };
        let rgb = kitti_rgb16(&flow, &instance);
        assert!(rgb.chunks_exact(3).all(|p| p == [32_768, 32_768, 1]));
    }

    #[test]
    fn without_skew_the_rolling_flow_is_the_global_one() {
        // A panning camera (the next frame turned 2°) and a moving, turning
        // drone; readouts of 0: the same numbers as the global flow.
        let cam = camera(DMat3::IDENTITY, DVec3::ZERO);
        let next = camera(DMat3::from_rotation_y(-0.035), DVec3::new(0.5, 0.0, 0.0));
        let moving = (DVec3::new(0.0, 0.0, 20.0), DVec3::new(4.0, 1.0, 0.0), 0.5);
        let (c0, at0) = timed(0.0, 1.0, cam, moving);
        let (c1, at1) = timed(0.0, -1.0, next, moving);
        let (f0, f1) = (
            TimedFrame {
                clock: c0,
                at: &at0,
            },
            TimedFrame {
                clock: c1,
                at: &at1,
            },
        );
        let (instance, depths) = pixels();
        let rolling = rolling_drone_flow((&f0, &f1), (640, 480), (&instance, &depths));
        let pose = |tau: f64| {
            (
                moving.0 + moving.1 * tau,
                DQuat::from_rotation_y(moving.2 * tau),
            )
        };
        let global = drone_flow(
            (&cam, &next),
            (&[pose(0.0)], &[pose(0.0)]),
            &instance,
            &depths,
        );
        assert_eq!(rolling, global);
        for at in [
            DVec2::new(0.5, 0.5),
            DVec2::new(320.5, 240.5),
            DVec2::new(600.5, 400.5),
        ] {
            assert_eq!(
                rolling_background_flow((&cam, &next), [c0, c1], at),
                background_flow(&cam, &next, at)
            );
        }
    }

    #[test]
    fn a_rows_background_flow_is_the_pixelwise_fixed_point_within_a_tenth_of_a_kitti_step() {
        // Typical (20 °/s over 33 ms) and the fastest accepted (±360 °/s over
        // 100 ms, a 36° turn in a readout) pans, the next frame 40 ms on.
        for (readout, yaw) in [(0.033, 20f64.to_radians()), (0.1, 360f64.to_radians())] {
            let cam = camera(DMat3::IDENTITY, DVec3::ZERO);
            let next = camera(DMat3::from_rotation_y(yaw * 0.04).transpose(), DVec3::ZERO);
            let c0 = RowClock {
                readout_s: readout,
                yaw_rad_s: yaw,
            };
            let c1 = RowClock {
                readout_s: readout * 0.8,
                yaw_rad_s: -yaw,
            };
            let (mut worst, mut steps, mut n) = (0.0f64, 0usize, 0usize);
            let mut row = vec![None; cam.width as usize];
            for y in (0..cam.height).step_by(7) {
                rolling_background_row((&cam, &next), [c0, c1], y, &mut row);
                for (x, f) in row.iter().enumerate() {
                    let at = DVec2::new(x as f64, f64::from(y)) + 0.5;
                    let exact = rolling_background_flow((&cam, &next), [c0, c1], at);
                    let (f, exact) = (f.expect("in front"), exact.expect("in front"));
                    worst = worst.max((f - exact).abs().max_element());
                    let (a, b) = (kitti(Some(f)), kitti(Some(exact)));
                    assert!(a[0].abs_diff(b[0]) <= 1 && a[1].abs_diff(b[1]) <= 1);
                    steps += usize::from(a != b);
                    n += 1;
                }
            }
            println!("{yaw} rad/s: worst {worst:.2e} px, {steps} of {n} KITTI samples differ");
            assert!(worst <= 0.1 / 64.0, "{worst} px from the fixed point");
            // Where the fixed point lies within 1/640 px of a rounding edge.
            assert!(steps * 20 <= n, "{steps} of {n} KITTI samples differ");
        }
    }

    #[test]
    fn with_skew_a_points_flow_is_between_its_two_rolling_projections() {
        // Both frames pan (0.6 and −0.4 rad/s) over 30 ms readouts while the
        // drone crosses and turns; the pixel's point is found at the next
        // frame's row v whose time images it on v (bisection, here).
        let cam = camera(DMat3::IDENTITY, DVec3::ZERO);
        let moving = (
            DVec3::new(0.0, 0.0, 20.0),
            DVec3::new(30.0, -20.0, 5.0),
            2.0,
        );
        let after = (moving.0 + moving.1 * 0.04, moving.1, moving.2);
        let (c0, at0) = timed(0.03, 0.6, cam, moving);
        let (c1, at1) = timed(0.03, -0.4, cam, after);
        let (f0, f1) = (
            TimedFrame {
                clock: c0,
                at: &at0,
            },
            TimedFrame {
                clock: c1,
                at: &at1,
            },
        );
        let (instance, depths) = pixels();
        let flows = rolling_drone_flow((&f0, &f1), (640, 480), (&instance, &depths));
        let f = cam.focal_px();
        for ((&(i, _), &z), flow) in instance.iter().zip(&depths).zip(flows) {
            let centre = DVec2::new(f64::from(i % 640), f64::from(i / 640)) + 0.5;
            // At t: the pixel's row time, the turned camera, the point in the drone's body.
            let tau0 = 0.03 * (centre.y - 0.5) / 480.0;
            let r0 = DMat3::from_rotation_y(0.6 * tau0).transpose();
            let ray = DVec3::new((centre.x - 320.0) / f, (centre.y - 240.0) / f, 1.0) * z;
            let world = r0.transpose() * ray;
            let body = DQuat::from_rotation_y(2.0 * tau0).inverse()
                * (world - (moving.0 + moving.1 * tau0));
            // At t + 1: the row v where the point of time τ(v) is imaged.
            let image = |v: f64| {
                let tau = 0.03 * (v - 0.5).clamp(0.0, 480.0) / 480.0;
                let p = after.0 + after.1 * tau + DQuat::from_rotation_y(2.0 * tau) * body;
                let c = DMat3::from_rotation_y(-0.4 * tau).transpose() * p;
                DVec2::new(f * c.x / c.z + 320.0, f * c.y / c.z + 240.0)
            };
            let (mut lo, mut hi) = (0.0, 480.0);
            for _ in 0..60 {
                let mid = 0.5 * (lo + hi);
                if image(mid).y > mid {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            let want = image(lo) - centre;
            let got = flow.expect("in front");
            // The flow's fixed-point iteration stops within ~1e-6 px of the
            // bisection's row; KITTI files store 1/64 px.
            assert!((got - want).length() < 1e-4, "{got} against {want}");
            // Not the flow between the frames' times.
            let global = image(0.5) - centre;
            assert!((got - global).length() > 0.5, "{got} against {global}");
        }
    }
}
