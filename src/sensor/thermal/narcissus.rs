//! The optics' narcissus (docs/realism.md, "Thermal camera"): a cooled
//! detector sees its own cold reflection in the lens surfaces, most on the
//! optical axis, so the frame's centre reads colder than the scene. A
//! Gaussian spot about the frame's centre, `depth_k` deep at the centre and
//! of σ `radius` × half the frame's height, subtracted from the fixed
//! pattern's plane: made once per preset like the rest of that plane, so it
//! costs nothing a frame, and absent it leaves the plane as it was.

use crate::preset::thermal::Narcissus;

/// Subtracts the spot from `plane` (`w`×`h`, radiance units, `per_k` of them
/// a kelvin). f64 in a fixed order, rounded once to f32 per pixel.
pub fn subtract(n: &Narcissus, per_k: f32, (w, h): (u32, u32), plane: &mut [f32]) {
    let (w, h) = (w as usize, h as usize);
    if w == 0 || h == 0 || plane.len() < w * h || n.depth_k == 0.0 {
        return;
    }
    let depth = n.depth_k * f64::from(per_k);
    let sigma = n.radius * h as f64 * 0.5;
    let inv = -0.5 / (sigma * sigma).max(1e-12);
    let (cx, cy) = (w as f64 * 0.5, h as f64 * 0.5);
    let across: Vec<f64> = (0..w)
        .map(|x| (x as f64 + 0.5 - cx).powi(2) * inv)
        .collect();
    for (y, row) in plane.chunks_exact_mut(w).take(h).enumerate() {
        let down = (y as f64 + 0.5 - cy).powi(2) * inv;
        for (v, a) in row.iter_mut().zip(&across) {
            *v = (f64::from(*v) - depth * (down + a).exp()) as f32;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_spot_is_deepest_at_the_centre_and_falls_as_a_gaussian() {
        let (w, h) = (64u32, 48u32);
        let n = Narcissus {
            depth_k: 2.0,
            radius: 0.5,
        };
        let mut plane = vec![10.0f32; (w * h) as usize];
        subtract(&n, 0.5, (w, h), &mut plane);
        let at = |x: usize, y: usize| 10.0 - f64::from(plane[y * w as usize + x]);
        // The centre pixels (31.5 px from the left, half a pixel off the axis): ≈ 1.
        assert!((at(32, 24) - 1.0).abs() < 0.01, "{}", at(32, 24));
        // One σ (12 px) out along the row: e^(−1/2) of the depth.
        let one_sigma = at(32 + 12, 24);
        assert!((one_sigma - (-0.5f64).exp()).abs() < 0.03, "{one_sigma}");
        assert!(at(0, 0) < 0.05 && at(0, 0) > 0.0, "{}", at(0, 0));
        // Symmetric about the centre.
        assert!((at(20, 10) - at(43, 37)).abs() < 1e-5);
    }

    #[test]
    fn no_depth_leaves_the_plane_as_it_was() {
        let mut plane: Vec<f32> = (0..96).map(|i| i as f32 * 0.25).collect();
        let before = plane.clone();
        let n = Narcissus::default();
        subtract(&n, 0.7, (12, 8), &mut plane);
        assert_eq!(plane, before);
    }
}
