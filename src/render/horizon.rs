//! The horizon line on screen, for drawing the procedural environment in
//! parts, each with a shader holding only its own branches (lavapipe runs
//! every branch of a shader for every pixel under a lane mask): the ground
//! side of the horizon, the sky side up to the top of the silhouettes' band
//! (hills, mountains, skyline, tree line), and the sky above it, where no
//! silhouette reaches. Each part's polygon covers its pixels with a margin
//! of a few pixels; the shader (`in_part` in environment.wgsl) discards the
//! pixels of the other parts, so every pixel is drawn exactly once, by the
//! same arithmetic as the one-draw shader.

/// Target pixels each part's polygon reaches past its lines.
const MARGIN_PX: f32 = 4.0;

/// The horizon on screen and what bounds the band above it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Horizon {
    /// `a·x + b·y + c` over full-resolution pixel coordinates (x right,
    /// y down): the world `y` of the ray through the pixel, unnormalised
    /// (its camera-frame `z` is 1), positive on the sky side.
    line: [f32; 3],
    /// The longest such ray over the frame (its corners): a ray at
    /// elevation `e` has `line = sin(e)·|ray|`, between `sin(e)` and
    /// `sin(e)·max_ray`.
    max_ray: f32,
}

impl Horizon {
    /// The horizon of a `size` frame from its `world_from_camera` (columns)
    /// and intrinsics (fx, fy, cx, cy), as `fs_environment` builds its rays.
    pub(super) fn of(
        world_from_camera: &[[f32; 4]; 4],
        intrinsics: [f32; 4],
        (width, height): (u32, u32),
    ) -> Self {
        let [fx, fy, cx, cy] = intrinsics;
        let a = world_from_camera[0][1] / fx;
        let b = world_from_camera[1][1] / fy;
        let c = world_from_camera[2][1] - a * cx - b * cy;
        let reach =
            |x: f32, y: f32| (((x - cx) / fx).powi(2) + ((y - cy) / fy).powi(2) + 1.0).sqrt();
        let (w, h) = (width as f32, height as f32);
        let max_ray = reach(0.0, 0.0)
            .max(reach(w, 0.0))
            .max(reach(0.0, h))
            .max(reach(w, h));
        Self {
            line: [a, b, c],
            max_ray,
        }
    }

    /// The environment pass's parts (`ENV_PART` 1: the sky up to the band,
    /// 2: the ground, 3: the sky above the band) with the triangles
    /// (normalised device coordinates) covering each in a `size` target
    /// (each texel `scale` full-resolution pixels); `band_top`: the
    /// elevation (rad) no silhouette reaches above, negative for none (then
    /// part 3 is the whole sky side). Parts off screen are left out.
    pub(super) fn parts(
        &self,
        band_top: f32,
        size: (u32, u32),
        scale: f32,
    ) -> Vec<(u32, Vec<[f32; 2]>)> {
        let strip = |lo, hi| strip_triangles(self.line, (lo, hi), size, scale);
        let parts = if band_top < 0.0 {
            vec![(3, strip(Some(0.0), None)), (2, strip(None, Some(0.0)))]
        } else {
            let s = band_top.min(std::f32::consts::FRAC_PI_2).sin();
            vec![
                (1, strip(Some(0.0), Some(s * self.max_ray))),
                (3, strip(Some(s), None)),
                (2, strip(None, Some(0.0))),
            ]
        };
        parts.into_iter().filter(|(_, t)| !t.is_empty()).collect()
    }
}

/// The triangles (normalised device coordinates) covering the part of a
/// `size` target (each texel `scale` full-resolution pixels) where `line`
/// lies between `lo` and `hi` (each `None`: unbounded), widened by
/// [`MARGIN_PX`].
fn strip_triangles(
    line: [f32; 3],
    (lo, hi): (Option<f32>, Option<f32>),
    size: (u32, u32),
    scale: f32,
) -> Vec<[f32; 2]> {
    let [a, b, c] = line;
    let (w, h) = (size.0 as f32 * scale, size.1 as f32 * scale);
    let at = |p: [f32; 2]| {
        let (x, y) = ((p[0] + 1.0) * 0.5 * w, (1.0 - p[1]) * 0.5 * h);
        a * x + b * y + c
    };
    let margin = |bound: f32| {
        MARGIN_PX * scale * (a.abs() + b.abs())
            + 1e-4 * (a.abs() * w + b.abs() * h + c.abs() + bound.abs())
    };
    let mut polygon = vec![[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]];
    if let Some(lo) = lo {
        polygon = clip(&polygon, |p| at(p) - lo + margin(lo));
    }
    if let Some(hi) = hi {
        polygon = clip(&polygon, |p| hi - at(p) + margin(hi));
    }
    let mut triangles = Vec::new();
    for i in 1..polygon.len().saturating_sub(1) {
        triangles.extend([polygon[0], polygon[i], polygon[i + 1]]);
    }
    triangles
}

/// The convex `polygon` clipped to where the affine `value` is ≥ 0.
fn clip(polygon: &[[f32; 2]], value: impl Fn([f32; 2]) -> f32) -> Vec<[f32; 2]> {
    let mut out = Vec::with_capacity(polygon.len() + 1);
    for (i, &p) in polygon.iter().enumerate() {
        let q = polygon[(i + 1) % polygon.len()];
        let (vp, vq) = (value(p), value(q));
        if vp >= 0.0 {
            out.push(p);
        }
        if (vp >= 0.0) != (vq >= 0.0) {
            let t = vp / (vp - vq);
            out.push([p[0] + (q[0] - p[0]) * t, p[1] + (q[1] - p[1]) * t]);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn covers(triangles: &[[f32; 2]], p: [f32; 2]) -> bool {
        triangles.chunks_exact(3).any(|t| {
            let s = |a: [f32; 2], b: [f32; 2]| {
                (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0])
            };
            let d = [s(t[0], t[1]), s(t[1], t[2]), s(t[2], t[0])];
            d.iter().all(|&v| v >= 0.0) || d.iter().all(|&v| v <= 0.0)
        })
    }

    /// A camera pitched up by `pitch` and rolled by `roll` (rad): its
    /// `world_from_camera` columns (camera x right, y down, z forward).
    fn camera(pitch: f32, roll: f32) -> [[f32; 4]; 4] {
        let (sp, cp) = pitch.sin_cos();
        let (sr, cr) = roll.sin_cos();
        // Roll about z, then pitch about x; world y up.
        let right = [cr, sr, 0.0];
        let down = [-sr, cr, 0.0];
        let pitched = |v: [f32; 3]| [v[0], v[1] * cp - v[2] * sp, v[1] * sp + v[2] * cp];
        let (r, d, f) = (pitched(right), pitched(down), pitched([0.0, 0.0, 1.0]));
        // Image y down is world -y when level.
        let col = |v: [f32; 3]| [v[0], -v[1], v[2], 0.0];
        [col(r), col(d), col(f), [0.0, 0.0, 0.0, 1.0]]
    }

    /// The part of the pixel whose ray is `dir` (unit), as `in_part` decides.
    fn part_of(dir: [f32; 3], band_top: f32) -> u32 {
        let sky = dir[1] >= 0.0;
        let upper = sky && dir[1].clamp(-1.0, 1.0).asin() > band_top;
        match (sky, upper) {
            (_, true) => 3,
            (true, false) => 1,
            (false, _) => 2,
        }
    }

    #[test]
    fn each_pixel_lies_in_the_polygon_of_its_part() {
        // A 96×54 frame drawn at 2 pixels a texel, wide field of view, for
        // level, tilted and rolled cameras and bands of several heights.
        let (w, h, scale) = (96u32, 54u32, 2.0f32);
        let intrinsics = [40.0, 40.0, 48.0, 27.0];
        let size = (w / 2, h / 2);
        let mut seen = [false; 4];
        for (pitch, roll) in [(0.0, 0.0), (0.3, 0.0), (-0.2, 0.4), (0.1, -1.2), (1.2, 0.3)] {
            let m = camera(pitch, roll);
            let horizon = Horizon::of(&m, intrinsics, (w, h));
            for band_top in [-1.0, 0.0, 0.02, 0.2, 0.5] {
                let parts = horizon.parts(band_top, size, scale);
                for y in 0..size.1 {
                    for x in 0..size.0 {
                        let (qx, qy) = (x as f32 + 0.5, y as f32 + 0.5);
                        let (px, py) = (qx * scale, qy * scale);
                        let r = [
                            (px - intrinsics[2]) / intrinsics[0],
                            (py - intrinsics[3]) / intrinsics[1],
                            1.0,
                        ];
                        let world: Vec<f32> = (0..3)
                            .map(|k| m[0][k] * r[0] + m[1][k] * r[1] + m[2][k] * r[2])
                            .collect();
                        let len = world.iter().map(|v| v * v).sum::<f32>().sqrt();
                        let dir = [world[0] / len, world[1] / len, world[2] / len];
                        let part = part_of(dir, band_top);
                        seen[part as usize] = true;
                        let ndc = [
                            qx / size.0 as f32 * 2.0 - 1.0,
                            1.0 - qy / size.1 as f32 * 2.0,
                        ];
                        let polygon = parts.iter().find(|(p, _)| *p == part);
                        assert!(
                            polygon.is_some_and(|(_, t)| covers(t, ndc)),
                            "pixel ({x}, {y}) of part {part}, pitch {pitch} roll {roll} band {band_top}"
                        );
                    }
                }
            }
        }
        assert!(seen[1] && seen[2] && seen[3], "every part was exercised");
    }

    #[test]
    fn the_band_is_drawn_narrow_and_the_sky_above_it_apart() {
        // Level camera, band 0.05 rad: the band's polygon stays near the
        // horizon, the upper sky's polygon does not reach the ground side.
        let m = camera(0.0, 0.0);
        let horizon = Horizon::of(&m, [100.0, 100.0, 100.0, 100.0], (200, 200));
        let parts = horizon.parts(0.05, (100, 100), 2.0);
        let polygon = |k: u32| parts.iter().find(|(p, _)| *p == k).map(|(_, t)| t.clone());
        let band = polygon(1).expect("a band");
        let upper = polygon(3).expect("sky above it");
        // The top row of the frame is far above the band; the bottom is ground.
        assert!(!covers(&band, [0.0, 0.95]) && covers(&upper, [0.0, 0.95]));
        assert!(!covers(&upper, [0.0, -0.5]) && !covers(&band, [0.0, -0.5]));
    }

    #[test]
    fn a_horizon_off_screen_leaves_one_side_empty() {
        let line = [0.0, 0.0, 1.0]; // looking up: all sky
        assert!(strip_triangles(line, (None, Some(0.0)), (10, 10), 2.0).is_empty());
        assert_eq!(
            strip_triangles(line, (Some(0.0), None), (10, 10), 2.0).len(),
            6
        );
    }

    #[test]
    fn the_line_is_zero_where_rays_are_level() {
        // Camera looking along +z with y up: world_from_camera flips y (image y down).
        let m = camera(0.0, 0.0);
        let [a, b, c] = Horizon::of(&m, [100.0, 100.0, 50.0, 40.0], (100, 80)).line;
        assert!(
            (a * 50.0 + b * 40.0 + c).abs() < 1e-6,
            "the principal point is level"
        );
        assert!(a * 50.0 + b * 10.0 + c > 0.0, "above it is sky");
    }
}
