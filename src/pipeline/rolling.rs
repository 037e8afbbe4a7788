//! The rolling shutter's geometry (issue 41, `camera_model.rolling_shutter`):
//! row y is exposed at τ(y) = readout · y / height after the frame's time.
//!
//! The scene at τ is exact: the frame is built again at τ = readout
//! ([`crate::scene::build_frame_at`]) and, in between, each drone's
//! position is linear and its attitude the SLERP of the two (eqs. 4–5 are
//! linear and a great-circle arc in the step), a following camera's
//! position linear; the camera turns by the drawn yaw rate about its own
//! vertical axis, R(τ) = R_y(ω·τ)ᵀ·R(0).
//!
//! The picture is made from the rendered frame and its drone-free frame
//! ([`crate::sensor::rolling`]): the background is the sky at infinity, so
//! each row is the rendered background through the rotation homography of
//! its time (the optical flow's [`BackgroundFlow`], exact for the sky); each
//! drone's pixels are moved row by row by the shift of its centre's image at
//! that row's time (exact for the drone's position; its own turn and change
//! of size during the readout are not drawn: docs/realism.md gives the
//! error). The amodal box is of the hull with each point at its own row's
//! time (a fixed-point iteration on the row it lands on).

use glam::DVec3;

use crate::annotate::PixelBox;
use crate::annotate::flow::{
    BackgroundFlow, FrameFlow, Pose, ROW_ITERATIONS, RowClock, TimedFrame, rolling_drone_flow,
    settle_on_row,
};
use crate::preset::Preset;
use crate::scene::camera::Camera;
use crate::scene::math::slerp;
use crate::scene::projection::LabelGeometry;
use crate::scene::{DronePose, FrameError, FrameScene, build_frame_at};
use crate::sensor::PixelRect;
use crate::sensor::pool::Picture;
use crate::sensor::rolling::{Shear, shear, shear_over, turn_background_twice};

use super::streaks;

/// A frame's rolling shutter: its scene at the first and the last row's time.
pub struct Shutter {
    /// Each row's time and the camera's turn by then (one clock with the flow's).
    clock: RowClock,
    camera: Camera,
    /// The camera's position at τ = readout (a following camera moves).
    end_position: DVec3,
    drones: Vec<DronePose>,
    end_drones: Vec<DronePose>,
    /// Per drone: where it is drawn and its shift per row (`None`: not in view).
    shears: Vec<Option<Shear>>,
}

impl Shutter {
    /// The shutter of `scene` (`None`: no rolling shutter, or a readout of 0).
    pub fn of(
        preset: &Preset,
        geometry: &[LabelGeometry],
        scene: &FrameScene,
    ) -> Result<Option<Self>, FrameError> {
        let Some(draw) = scene.camera_model.and_then(|d| d.rolling_shutter) else {
            return Ok(None);
        };
        if draw.readout_s.is_nan() || draw.readout_s <= 0.0 {
            return Ok(None);
        }
        let end = build_frame_at(preset, scene.index, scene.redraw, draw.readout_s)?;
        let mut shutter = Self {
            clock: RowClock {
                readout_s: draw.readout_s,
                yaw_rad_s: draw.yaw_rate_deg_s.to_radians(),
            },
            camera: scene.camera,
            end_position: end.camera.position,
            drones: scene.drones.clone(),
            end_drones: end.drones,
            shears: Vec::new(),
        };
        shutter.shears = (scene.drones.iter().enumerate())
            .map(|(i, d)| {
                let rect = streaks::drawn_rect(scene, d, geometry)?;
                let rows = (0..scene.camera.height).map(|y| shutter.shift(i, f64::from(y)));
                Some(Shear {
                    rect,
                    shift_px: rows.collect(),
                })
            })
            .collect();
        Ok(Some(shutter))
    }

    /// The time of row `y` (its index; the clock takes pixel-centre
    /// coordinates, row y's centre at y + ½).
    fn time_of_row(&self, y: f64) -> f64 {
        self.clock.time_at(y + 0.5, self.camera.height)
    }

    /// The camera at `tau` seconds after the frame's time.
    pub fn camera_at(&self, tau: f64) -> Camera {
        let a = tau / self.clock.readout_s;
        Camera {
            position: self.camera.position + a * (self.end_position - self.camera.position),
            camera_from_world: self.clock.turned(&self.camera, tau),
            ..self.camera
        }
    }

    /// The shutter's row clock, as the optical flow takes it.
    pub fn clock(&self) -> RowClock {
        self.clock
    }

    /// The camera and drone `i`'s pose at image row `y`'s time (the depth
    /// map's rows).
    pub fn row_pose(&self, i: usize, y: u32) -> Option<(Camera, DronePose)> {
        let tau = self.time_of_row(f64::from(y));
        Some((self.camera_at(tau), self.pose_at(i, tau)?))
    }

    /// The camera and drone `i`'s position and rotation at `tau` (the flow's).
    pub fn at(&self, i: usize, tau: f64) -> Option<(Camera, Pose)> {
        let d = self.pose_at(i, tau)?;
        Some((self.camera_at(tau), (d.position, d.rotation)))
    }

    /// Drone `i`'s pose at `tau`.
    fn pose_at(&self, i: usize, tau: f64) -> Option<DronePose> {
        let (d0, d1) = (self.drones.get(i)?, self.end_drones.get(i)?);
        let a = tau / self.clock.readout_s;
        Some(DronePose {
            position: d0.position + a * (d1.position - d0.position),
            rotation: slerp(d0.rotation, d1.rotation, a),
            ..*d0
        })
    }

    /// How far drone `i`'s centre's image has moved at row `y`'s time
    /// (NaN when it is not in front of the camera then).
    fn shift(&self, i: usize, y: f64) -> (f64, f64) {
        let tau = self.time_of_row(y);
        let image =
            |cam: &Camera, p: DVec3| cam.project_camera_point(cam.camera_from_world_point(p));
        let (Some(d0), Some(d)) = (self.drones.get(i), self.pose_at(i, tau)) else {
            return (f64::NAN, f64::NAN);
        };
        match (
            image(&self.camera, d0.position),
            image(&self.camera_at(tau), d.position),
        ) {
            (Some(a), Some(b)) => ((b - a).x, (b - a).y),
            _ => (f64::NAN, f64::NAN),
        }
    }

    /// Where drone `i`'s pixels can be in the shuttered picture: where its
    /// rows take them (not where it was rendered: a fast pan moves it far).
    pub fn near(&self, i: usize) -> Option<PixelRect> {
        let s = self.shears.get(i)?.as_ref()?;
        s.reach(self.camera.width, self.camera.height)
    }

    /// Where the rendered pixels of `rect` (drone `i`'s rendered visible
    /// box) are in the shuttered picture: the rows and columns they reach.
    pub fn moved(&self, i: usize, rect: PixelRect) -> Option<PixelRect> {
        let s = self.shears.get(i)?.as_ref()?;
        s.reach_of(rect, self.camera.width, self.camera.height)
    }

    /// Where row y's pixels take the drone-free background from: row y's
    /// camera once, then its knots' rotation flow.
    fn row_sources(&self) -> impl Fn(f64, &[f64], &mut [(f64, f64)]) + Sync + '_ {
        move |y: f64, xs: &[f64], out: &mut [(f64, f64)]| {
            let cam = self.camera_at(self.clock.time_at(y, self.camera.height));
            BackgroundFlow::new(&cam, &self.camera).row_sources(y, xs, out);
        }
    }

    /// The drone-free frame under the shutter: `background` through each
    /// row's rotation homography (`None` when the camera holds still: the
    /// rendered one is it); [`Self::apply`] makes it with its copy.
    #[cfg(test)]
    fn turned(&self, background: &[u8]) -> Option<Picture> {
        if self.clock.yaw_rad_s == 0.0 {
            return None;
        }
        let size = (self.camera.width, self.camera.height);
        let sources = self.row_sources();
        Some(crate::sensor::rolling::turn_background(
            background, size, &sources,
        ))
    }

    /// The shuttered picture of `frame` over the shuttered drone-free frame,
    /// and that drone-free frame when it is not `background` itself (the
    /// camera turns). All RGBA8. With `visible` (each drone's rendered
    /// visible box, when measured), a drone's pixels are taken from its
    /// visible box alone, and a drone that shows none is not moved: the
    /// pixels of a drone in front, which its drawn rect also holds, stay
    /// with that drone instead of being drawn again where this one goes.
    pub fn apply(
        &self,
        frame: &[u8],
        background: &[u8],
        visible: Option<&[Option<PixelRect>]>,
    ) -> Shuttered {
        let size = (self.camera.width, self.camera.height);
        let shears: Vec<Shear> = (self.shears.iter().enumerate())
            .filter_map(|(i, s)| {
                let s = s.as_ref()?;
                let Some(visible) = visible else {
                    return Some(s.clone());
                };
                let rect = s.rect.meet(visible.get(i).copied().flatten()?)?;
                Some(Shear {
                    rect,
                    shift_px: s.shift_px.clone(),
                })
            })
            .collect();
        if self.clock.yaw_rad_s == 0.0 {
            return (shear(frame, background, background, size, &shears), None);
        }
        // The turned frame and its copy made together; the drones drawn over the copy.
        let (turned, mut out) = turn_background_twice(background, size, &self.row_sources());
        shear_over(&mut out, frame, background, size, &shears);
        (out, Some(turned))
    }

    /// Drone `i`'s amodal box: each hull point where it is imaged at the
    /// time of the row it lands on (fixed-point iteration from its row at
    /// the frame's time), unclipped; `None` when no point is in front.
    pub fn amodal(&self, i: usize, geom: &LabelGeometry) -> Option<PixelBox> {
        let point = |v: DVec3, tau: f64| {
            let d = self.pose_at(i, tau)?;
            let cam = self.camera_at(tau);
            let world = d.position + d.rotation * (v * d.size_m);
            let p = cam.camera_from_world_point(world);
            (p.z >= cam.near_m)
                .then(|| cam.project_camera_point(p))
                .flatten()
        };
        let points = geom.hull.iter().filter_map(|&v| {
            settle_on_row(point(v, 0.0)?, ROW_ITERATIONS, |y| {
                point(v, self.clock.time_at(y, self.camera.height))
            })
        });
        PixelBox::from_points(points)
    }
}

impl Shutter {
    /// Each drone's motion-blur streak starts from where its rows took it.
    pub fn move_streaks(&self, streaks: &mut [Option<crate::sensor::motion::Streak>]) {
        for (i, streak) in streaks.iter_mut().enumerate() {
            if let (Some(s), Some(near)) = (streak.as_mut(), self.near(i)) {
                s.rect = near;
            }
        }
    }
}

/// The shuttered picture and, when the camera turns, its drone-free frame.
pub type Shuttered = (Picture, Option<Picture>);

/// Frame `index`'s rendered `frame` and drone-free `background` under
/// `shutter` ([`Shutter::apply`], with each drone's rendered `visible` box
/// when measured); `None` without a shutter. The shutter needs the
/// drone-free background: an error names it when not cached.
pub(super) fn shuttered(
    shutter: Option<&Shutter>,
    index: u64,
    (frame, visible): (&[u8], Option<&[Option<PixelRect>]>),
    background: Option<&[u8]>,
) -> Result<Option<Shuttered>, super::PipelineError> {
    let Some(s) = shutter else {
        return Ok(None);
    };
    let background = background.ok_or_else(|| super::PipelineError::Camera {
        index,
        reason: "rolling shutter: the drone-free background is not cached".into(),
    })?;
    Ok(Some(s.apply(frame, background, visible)))
}

/// The flow from `frames.0` to `frames.1` (each scene with its shutter,
/// `None`: a global shutter) of `masks`' drone pixels at their depths, each
/// pixel seen at its row's time in both ([`crate::annotate::flow`]).
pub(super) fn flow(
    frames: (&FrameScene, Option<&Shutter>),
    next: (&FrameScene, Option<&Shutter>),
    masks: &crate::annotate::masks::FrameMasks,
) -> FrameFlow {
    let global = RowClock {
        readout_s: 0.0,
        yaw_rad_s: 0.0,
    };
    let at = |(scene, shutter): (&FrameScene, Option<&Shutter>), i: usize, tau: f64| match shutter {
        Some(s) => s.at(i, tau),
        None => (scene.drones.get(i)).map(|d| (scene.camera, (d.position, d.rotation))),
    };
    let (at0, at1) = (
        |i: usize, tau: f64| at(frames, i, tau),
        |i: usize, tau: f64| at(next, i, tau),
    );
    let clock = |s: Option<&Shutter>| s.map_or(global, Shutter::clock);
    let (f0, f1) = (
        TimedFrame {
            clock: clock(frames.1),
            at: &at0,
        },
        TimedFrame {
            clock: clock(next.1),
            at: &at1,
        },
    );
    let cam = frames.0.camera;
    FrameFlow {
        camera: cam,
        next_camera: next.0.camera,
        drones: rolling_drone_flow(
            (&f0, &f1),
            (cam.width, cam.height),
            (&masks.instance, &masks.depth_m),
        ),
        clocks: Some([f0.clock, f1.clock]),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{DMat3, DQuat};

    /// A 640×480 camera at the origin looking down +z (60° vertical field).
    fn camera() -> Camera {
        Camera {
            width: 640,
            height: 480,
            fov_y_deg: 60.0,
            position: DVec3::ZERO,
            camera_from_world: DMat3::IDENTITY,
            near_m: 0.01,
        }
    }

    fn drone(position: DVec3) -> DronePose {
        DronePose {
            model: 0,
            position,
            rotation: DQuat::IDENTITY,
            euler_deg: crate::scene::math::EulerDeg::from_quat(DQuat::IDENTITY),
            size_m: 1.0,
        }
    }

    fn shutter(readout_s: f64, yaw_deg_s: f64, drones: (DVec3, DVec3)) -> Shutter {
        Shutter {
            clock: RowClock {
                readout_s,
                yaw_rad_s: yaw_deg_s.to_radians(),
            },
            camera: camera(),
            end_position: DVec3::ZERO,
            drones: vec![drone(drones.0)],
            end_drones: vec![drone(drones.1)],
            shears: Vec::new(),
        }
    }

    #[test]
    fn a_pure_camera_yaw_shears_a_vertical_edge_by_f_tan_of_the_turn() {
        let (readout, yaw) = (0.03, 40.0);
        let s = shutter(readout, yaw, (DVec3::Z, DVec3::Z));
        let cam = camera();
        let (w, h) = (cam.width, cam.height);
        // Dark left of the middle column's edge (x = 320), bright right of it.
        let edge = (0..w * h)
            .flat_map(|i| {
                if i % w < 320 {
                    [0, 0, 0, 255]
                } else {
                    [200, 200, 200, 255]
                }
            })
            .collect::<Vec<u8>>();
        let turned = s.turned(&edge).expect("the camera turns");
        for y in (0..h).step_by(37) {
            let row = &turned[(y * w * 4) as usize..((y + 1) * w * 4) as usize];
            // A one-pixel bilinear ramp sampled a pixel apart sums linearly in
            // its position: the edge is W − Σ level / 200 (to 1/200 px).
            let bright: f64 = (0..w).map(|x| f64::from(row[x as usize * 4]) / 200.0).sum();
            let crossing = f64::from(w) - bright;
            // Row y is exposed readout·y/H late: the camera has turned ω·τ to the
            // right, so the edge (at infinity) is f·tan(ω·τ) to the left.
            let tau = readout * f64::from(y) / f64::from(h);
            let want = 320.0 - cam.focal_px() * (yaw.to_radians() * tau).tan();
            assert!(
                (crossing - want).abs() < 0.02,
                "row {y}: {crossing} vs {want}"
            );
        }
        assert!(
            s.turned(&edge).is_some()
                && shutter(readout, 0.0, (DVec3::Z, DVec3::Z))
                    .turned(&edge)
                    .is_none()
        );
    }

    #[test]
    fn a_lateral_drone_shifts_by_its_speed_times_the_row_time() {
        // 4 m/s across at 20 m, a 50 ms readout: f·v·τ/z per row.
        let (readout, v, z) = (0.05, 4.0, 20.0);
        let s = shutter(
            readout,
            0.0,
            (DVec3::new(0.0, 0.0, z), DVec3::new(v * readout, 0.0, z)),
        );
        let f = camera().focal_px();
        for y in [0.0, 100.0, 240.0, 479.0] {
            let (sx, sy) = s.shift(0, y);
            let want = f * v * readout * y / 480.0 / z;
            assert!(
                (sx - want).abs() < 1e-9 && sy.abs() < 1e-9,
                "row {y}: {sx}, {sy} vs {want}"
            );
        }
    }

    #[test]
    fn the_amodal_box_holds_each_hull_point_at_its_own_rows_time() {
        // A drone falling 40 m/s at 10 m while the rows sweep down: its
        // points land where the row's time and their height agree.
        let readout = 0.05;
        let s = shutter(
            readout,
            0.0,
            (
                DVec3::new(0.0, 0.0, 10.0),
                DVec3::new(0.0, 40.0 * readout, 10.0),
            ),
        );
        let geom = LabelGeometry {
            hull: vec![DVec3::new(0.0, -0.5, 0.0), DVec3::new(0.0, 0.5, 0.0)],
            aabb: (DVec3::splat(-0.5), DVec3::splat(0.5)),
        };
        let b = s.amodal(0, &geom).expect("in view");
        let f = camera().focal_px();
        for (v, local) in [(b.y0, -0.5), (b.y1, 0.5)] {
            // The point's height at the time of row v projects to row v.
            let y_m = 40.0 * s.clock.time_at(v, s.camera.height) + local;
            assert!((240.0 + f * y_m / 10.0 - v).abs() < 1e-3, "row {v}");
        }
        assert!(b.y1 - b.y0 > f * 1.0 / 10.0, "stretched by the fall: {b:?}");
    }
}
