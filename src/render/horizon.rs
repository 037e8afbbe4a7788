//! The horizon line on screen, for drawing the procedural environment as
//! two draws: the sky side and the ground side of the horizon, each with a
//! shader holding only its own branch (lavapipe runs every branch of a
//! shader for every pixel under a lane mask). Each side's polygon is the
//! target clipped to its half-plane widened by a few pixels; the shader
//! discards the pixels of the other side, so every pixel is drawn exactly
//! once, by the same arithmetic as the one-draw shader.

/// Target pixels each side's polygon reaches past the horizon line.
const MARGIN_PX: f32 = 4.0;

/// The horizon as `a·x + b·y + c` over full-resolution pixel coordinates
/// (x right, y down), positive on the sky side (the ray's world `y` up),
/// from the frame's `world_from_camera` (columns) and intrinsics
/// (fx, fy, cx, cy), as `fs_environment` builds its rays.
pub(super) fn horizon_line(world_from_camera: &[[f32; 4]; 4], intrinsics: [f32; 4]) -> [f32; 3] {
    let [fx, fy, cx, cy] = intrinsics;
    let a = world_from_camera[0][1] / fx;
    let b = world_from_camera[1][1] / fy;
    let c = world_from_camera[2][1] - a * cx - b * cy;
    [a, b, c]
}

/// The triangles (normalised device coordinates) covering the part of a
/// `size` target (each texel `scale` full-resolution pixels) on one side of
/// `line` (`sky`: where it is ≥ 0, else ≤ 0), widened by [`MARGIN_PX`].
pub(super) fn side_triangles(
    line: [f32; 3],
    sky: bool,
    size: (u32, u32),
    scale: f32,
) -> Vec<[f32; 2]> {
    let [a, b, c] = line;
    let (w, h) = (size.0 as f32 * scale, size.1 as f32 * scale);
    let sign = if sky { 1.0 } else { -1.0 };
    let margin =
        MARGIN_PX * scale * (a.abs() + b.abs()) + 1e-4 * (a.abs() * w + b.abs() * h + c.abs());
    let value = |p: [f32; 2]| {
        let (x, y) = ((p[0] + 1.0) * 0.5 * w, (1.0 - p[1]) * 0.5 * h);
        sign * (a * x + b * y + c) + margin
    };
    let square = [[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]];
    let mut polygon: Vec<[f32; 2]> = Vec::with_capacity(5);
    for i in 0..4 {
        let (p, q) = (square[i], square[(i + 1) % 4]);
        let (vp, vq) = (value(p), value(q));
        if vp >= 0.0 {
            polygon.push(p);
        }
        if (vp >= 0.0) != (vq >= 0.0) {
            let t = vp / (vp - vq);
            polygon.push([p[0] + (q[0] - p[0]) * t, p[1] + (q[1] - p[1]) * t]);
        }
    }
    let mut triangles = Vec::new();
    for i in 1..polygon.len().saturating_sub(1) {
        triangles.extend([polygon[0], polygon[i], polygon[i + 1]]);
    }
    triangles
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

    #[test]
    fn each_pixel_lies_in_the_polygon_of_its_side() {
        // A tilted horizon across a 40×20 target (2 pixels a texel).
        let line = [0.3, -1.0, 12.0];
        let (size, scale) = ((40, 20), 2.0);
        let sky = side_triangles(line, true, size, scale);
        let ground = side_triangles(line, false, size, scale);
        assert!(!sky.is_empty() && !ground.is_empty());
        for y in 0..20 {
            for x in 0..40 {
                let (qx, qy) = (x as f32 + 0.5, y as f32 + 0.5);
                let f = line[0] * qx * scale + line[1] * qy * scale + line[2];
                let ndc = [qx / 20.0 - 1.0, 1.0 - qy / 10.0];
                let polygon = if f >= 0.0 { &sky } else { &ground };
                assert!(covers(polygon, ndc), "pixel ({x}, {y}) f {f}");
            }
        }
        // Far from the line, a pixel is on one side only.
        assert!(!covers(&ground, [-0.95, -0.95]) || !covers(&sky, [-0.95, -0.95]));
    }

    #[test]
    fn a_horizon_off_screen_leaves_one_side_empty() {
        let line = [0.0, 0.0, 1.0]; // looking up: all sky
        assert!(side_triangles(line, false, (10, 10), 2.0).is_empty());
        assert_eq!(side_triangles(line, true, (10, 10), 2.0).len(), 6);
    }

    #[test]
    fn the_line_is_zero_where_rays_are_level() {
        // Camera looking along +z with y up: world_from_camera flips y (image y down).
        let m = [
            [1.0, 0.0, 0.0, 0.0],
            [0.0, -1.0, 0.0, 0.0],
            [0.0, 0.0, 1.0, 0.0],
            [0.0, 0.0, 0.0, 1.0],
        ];
        let [a, b, c] = horizon_line(&m, [100.0, 100.0, 50.0, 40.0]);
        assert!(
            (a * 50.0 + b * 40.0 + c).abs() < 1e-6,
            "the principal point is level"
        );
        assert!(a * 50.0 + b * 10.0 + c > 0.0, "above it is sky");
    }
}
