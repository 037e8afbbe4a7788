//! An equirect image sky's reduced pass, on the CPU: per pass pixel the
//! image's bilinear sample in the direction of the full-resolution pixel at
//! its centre, times the exposure (what `image_radiance` in
//! environment.wgsl gives), for the background's upsampling
//! (render/upsample.rs) to interpolate.
//!
//! It is cheap shading (a ray, two arc tangents, four texels a pixel) that
//! lavapipe ran with a submission, a wait and a readback of its own: on the
//! CPU it takes a fraction of that wall time, and its values are those of
//! plain `f32` arithmetic (no FMA, no driver's approximations), so they are
//! the same on every machine and adapter.

use std::f32::consts::{PI, TAU};

use crate::simd::math::atan2;

use glam::Mat3;

#[cfg(target_arch = "x86_64")]
mod gather;

/// An equirect image: RGB `f32` texels, row-major, top row first
/// (`SkyImageKind::Equirect`).
#[derive(Clone, Copy)]
pub(super) struct Equirect<'a> {
    pub rgb: &'a [f32],
    pub width: u32,
    pub height: u32,
}

/// What a reduced pass looks through: the camera's rotation (world from
/// camera), its intrinsics `[fx, fy, cx, cy]` (full-resolution pixels),
/// the full-resolution pixels per pass pixel, the image's rotation about
/// the vertical axis (radians) and the exposure multiplier.
#[derive(Clone, Copy, Debug)]
pub(super) struct ReducedView {
    pub world_from_camera: Mat3,
    pub intrinsics: [f32; 4],
    pub scale: f32,
    pub rotation: f32,
    pub exposure: f32,
}

/// The largest value a pass texel holds (the GPU pass clamped to it to stay
/// finite in half floats; kept so the tone map sees the same range).
const MAX_RADIANCE: f32 = 60_000.0;

/// `image` shaded for `view` at `size` (pass pixels) into `out`: red,
/// green and blue `f32` planes, rows one after the other (alpha 1). Rows in
/// parallel (each row's values depend only on its own index). An image
/// with no texels, or fewer than its size says, gives zeros.
pub(super) fn shade(
    image: Equirect<'_>,
    view: &ReducedView,
    size: (u32, u32),
    out: &mut [Vec<f32>; 3],
) {
    let (w, h) = (size.0 as usize, size.1 as usize);
    // Every value is written below (no clearing pass over the old contents).
    out.iter_mut().for_each(|p| p.resize(w * h, 0.0));
    let (iw, ih) = (image.width as usize, image.height as usize);
    if w == 0 || iw == 0 || ih == 0 || image.rgb.len() < iw * ih * 3 {
        out.iter_mut().for_each(|p| p.fill(0.0));
        return;
    }
    // The image turns by +rotation: rays turn by −rotation into its frame
    // (`rotate_y(dir, −rotation)` in environment.wgsl).
    let into_image = Mat3::from_rotation_y(-view.rotation) * view.world_from_camera;
    // The same operations in every build (simd.rs): the same values.
    super::plane_rows(
        out.each_mut().map(|p| &mut p[..]),
        w,
        || Row::new(w),
        #[inline(always)]
        |row, j, rgb| {
            row.rays(&into_image, view, j);
            row.coordinates((iw as f32, ih as f32));
            row.sample(image, view.exposure, rgb);
        },
    );
}

/// One row's scratch: per pass pixel its ray (image frame, not
/// normalised: only its direction is used), then its texel coordinates.
struct Row {
    x: Vec<f32>,
    y: Vec<f32>,
    z: Vec<f32>,
}

impl Row {
    fn new(w: usize) -> Self {
        Self {
            x: vec![0.0; w],
            y: vec![0.0; w],
            z: vec![0.0; w],
        }
    }

    /// Row `j`'s rays: through the centre of the full-resolution pixel at
    /// each pass pixel's centre times the scale.
    #[inline(always)]
    fn rays(&mut self, m: &Mat3, view: &ReducedView, j: usize) {
        let rays = (&mut self.x[..], &mut self.y[..], &mut self.z[..]);
        super::row_rays(m, view.intrinsics, (view.scale, j), rays);
    }

    /// The rays as texel coordinates of `image` (`u · width − ½`,
    /// `v · height − ½`): u the azimuth, `0.5 − atan2(x, z) / 2π` in [0, 1]
    /// (the shader's `fract` is the sampler's repeat, [`Row::sample`]), v
    /// the polar angle over π (the shader's `acos(y)` of the unit ray, here
    /// `atan2(√(x² + z²), y)` of the ray as it is). Written over `x` and
    /// `y`; no call in the loop, so it vectorises.
    #[inline(always)]
    fn coordinates(&mut self, (iw, ih): (f32, f32)) {
        for ((x, y), z) in self.x.iter_mut().zip(&mut self.y).zip(&self.z) {
            let (dx, dy, dz) = (*x, *y, *z);
            let u = 0.5 - atan2(dx, dz) / TAU;
            let v = atan2((dx * dx + dz * dz).sqrt(), dy) / PI;
            // Kept finite and near the image (a NaN becomes −1), so that
            // every build truncates them alike.
            *x = (u * iw - 0.5).max(-1.0).min(iw);
            *y = (v * ih - 0.5).max(-1.0).min(ih);
        }
    }

    /// Each pixel's bilinear sample of `image` at its texel coordinates
    /// (columns repeat, rows clamp to the edge, as the GPU's sampler did),
    /// times `exposure`, clamped to [0, [`MAX_RADIANCE`]], into the row's
    /// red, green and blue planes `rgb`: eight pixels at a time in AVX2
    /// where the CPU has it ([`gather::sample8`], the same operations on the
    /// same values).
    #[inline(always)]
    fn sample(&self, image: Equirect<'_>, exposure: f32, mut rgb: [&mut [f32]; 3]) {
        let n = self
            .x
            .len()
            .min(self.y.len())
            .min(rgb.iter().map(|p| p.len()).min().unwrap_or(0));
        let mut done = 0;
        #[cfg(target_arch = "x86_64")]
        if crate::simd::avx2() {
            while done + 8 <= n {
                let at = done..done + 8;
                let coordinates = (&self.x[at.clone()], &self.y[at.clone()]);
                let px = rgb.each_mut().map(|p| &mut p[at.clone()]);
                // SAFETY: the CPU has AVX2 (checked above); `shade` checked
                // that `image` holds its texels.
                #[allow(unsafe_code)]
                unsafe {
                    gather::sample8(image, exposure, coordinates, px);
                }
                done += 8;
            }
        }
        for i in done..n {
            let taps = Taps::at(image, (self.x[i], self.y[i]));
            for (k, plane) in rgb.iter_mut().enumerate() {
                let texels = taps.texels.map(|t| image.rgb[t as usize + k]);
                plane[i] = blend(texels, (taps.wx, taps.wy), exposure);
            }
        }
    }
}

/// A bilinear sample's four texels (the offsets of their red values in
/// the image's `rgb`: top left, top right, bottom left, bottom right) and
/// its weights across and down.
struct Taps {
    texels: [u32; 4],
    wx: f32,
    wy: f32,
}

impl Taps {
    /// The sample of `image` at texel coordinates `(tx, ty)` (finite, in
    /// [−1, width] × [−1, height]): columns repeat, rows clamp to the edge.
    #[inline(always)]
    fn at(image: Equirect<'_>, (tx, ty): (f32, f32)) -> Self {
        let (iw, ih) = (image.width as i32, image.height as i32);
        let (x0, y0) = (tx.floor(), ty.floor());
        // x0 in [−1, iw]: −1 is the last column, iw the first.
        let c0 = (x0 as i32).clamp(-1, iw - 1);
        let c0 = if c0 < 0 { iw - 1 } else { c0 };
        let c1 = if c0 + 1 == iw { 0 } else { c0 + 1 };
        let r0 = (y0 as i32).clamp(0, ih - 1);
        let r1 = (y0 as i32 + 1).clamp(0, ih - 1);
        let at = |r: i32, c: i32| ((r * iw + c) * 3) as u32;
        Self {
            texels: [at(r0, c0), at(r0, c1), at(r1, c0), at(r1, c1)],
            wx: tx - x0,
            wy: ty - y0,
        }
    }
}

/// One channel's bilinear blend of texels `[a, b, c, d]` (as [`Taps`]
/// orders them) with weights `(wx, wy)`, times `exposure`, clamped to
/// [0, [`MAX_RADIANCE`]] (a NaN to 0).
#[inline(always)]
#[allow(clippy::manual_clamp, reason = "a NaN gives 0, as the GPU pass did")]
fn blend([a, b, c, d]: [f32; 4], (wx, wy): (f32, f32), exposure: f32) -> f32 {
    let top = a + (b - a) * wx;
    let bottom = c + (d - c) * wx;
    let value = (top + (bottom - top) * wy) * exposure;
    value.max(0.0).min(MAX_RADIANCE)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An image whose texels differ everywhere (a smooth field in x and y).
    fn field(w: u32, h: u32) -> Vec<f32> {
        (0..h)
            .flat_map(|r| {
                (0..w).flat_map(move |c| {
                    let (x, y) = (c as f32 / w as f32, r as f32 / h as f32);
                    [0.2 + x, 1.5 - y, 0.5 + (7.0 * x).sin() * y]
                })
            })
            .collect()
    }

    /// The shader's formula in `f64` (`acos` of the normalised ray, `atan2`
    /// of the library): the pass must give its values within `f32` rounding.
    fn reference(image: Equirect<'_>, view: &ReducedView, (i, j): (u32, u32)) -> [f64; 3] {
        let [fx, fy, cx, cy] = view.intrinsics.map(f64::from);
        let s = f64::from(view.scale);
        let ray = glam::DVec3::new(
            ((f64::from(i) + 0.5) * s - cx) / fx,
            ((f64::from(j) + 0.5) * s - cy) / fy,
            1.0,
        );
        let m = glam::DMat3::from_rotation_y(-f64::from(view.rotation))
            * view.world_from_camera.as_dmat3();
        let d = (m * ray).normalize();
        let u = (0.5 - d.x.atan2(d.z) / std::f64::consts::TAU).rem_euclid(1.0);
        let v = d.y.clamp(-1.0, 1.0).acos() / std::f64::consts::PI;
        let (iw, ih) = (i64::from(image.width), i64::from(image.height));
        let (tx, ty) = (u * iw as f64 - 0.5, v * ih as f64 - 0.5);
        let (wx, wy) = (tx - tx.floor(), ty - ty.floor());
        let (c0, r0) = (tx.floor() as i64, ty.floor() as i64);
        let texel = |r: i64, c: i64, k: usize| {
            let (r, c) = (r.clamp(0, ih - 1), c.rem_euclid(iw));
            f64::from(image.rgb[((r * iw + c) * 3) as usize + k])
        };
        std::array::from_fn(|k| {
            let top = texel(r0, c0, k) * (1.0 - wx) + texel(r0, c0 + 1, k) * wx;
            let bottom = texel(r0 + 1, c0, k) * (1.0 - wx) + texel(r0 + 1, c0 + 1, k) * wx;
            (top * (1.0 - wy) + bottom * wy) * f64::from(view.exposure)
        })
    }

    #[test]
    fn the_pass_gives_the_shaders_bilinear_sample_in_each_pixels_direction() {
        let (iw, ih) = (96, 48);
        let rgb = field(iw, ih);
        let image = Equirect {
            rgb: &rgb,
            width: iw,
            height: ih,
        };
        // A camera looking down past the horizon, turned so that the
        // image's seam (azimuth ±π) crosses the pass.
        let world_from_camera = Mat3::from_rotation_y(2.9) * Mat3::from_rotation_x(-0.4);
        let view = ReducedView {
            world_from_camera,
            intrinsics: [300.0, 300.0, 160.0, 120.0],
            scale: 4.0,
            rotation: 0.25,
            exposure: 1.5,
        };
        let size = (80, 60);
        let mut out = Default::default();
        shade(image, &view, size, &mut out);
        assert!(out.iter().all(|p| p.len() == 80 * 60));
        let mut worst = 0f64;
        for j in 0..size.1 {
            for i in 0..size.0 {
                let want = reference(image, &view, (i, j));
                let at = (j * size.0 + i) as usize;
                for (plane, want) in out.iter().zip(want) {
                    let got = f64::from(plane[at]);
                    worst = worst.max((got - want).abs() / want.abs().max(1.0));
                }
            }
        }
        // Measured 1.1e-5: a thousandth of an 8-bit level.
        assert!(worst < 5e-5, "worst relative error {worst:e}");
    }

    /// The AVX2 build's samples are the scalar loop's, bit for bit, at the
    /// image's edges and seam as inside it.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn the_gathered_samples_are_the_scalar_samples() {
        if !crate::simd::avx2() {
            return;
        }
        let (iw, ih) = (37, 19);
        let rgb: Vec<f32> = field(iw, ih).iter().map(|v| v * 3.0 - 1.0).collect();
        let image = Equirect {
            rgb: &rgb,
            width: iw,
            height: ih,
        };
        let mut coords: Vec<(f32, f32)> = Vec::new();
        for (i, x) in [
            -1.0f32, -0.5, -1e-7, 0.0, 0.3, 17.5, 35.999_996, 36.0, 36.5, 37.0,
        ]
        .into_iter()
        .enumerate()
        {
            for y in [-1.0f32, -0.25, 0.0, 9.75, 17.999_998, 18.0, 18.5, 19.0] {
                coords.push((x, y + i as f32 * 1e-3));
            }
        }
        coords.extend((0..200).map(|i| (i as f32 * 0.187 - 1.0, i as f32 * 0.0999 - 1.0)));
        coords.truncate(coords.len() / 8 * 8);
        let (tx, ty): (Vec<f32>, Vec<f32>) = coords.into_iter().unzip();
        let mut got = [(); 3].map(|_| vec![0.0f32; tx.len()]);
        for (k, (x, y)) in tx.chunks(8).zip(ty.chunks(8)).enumerate() {
            let px = got.each_mut().map(|p| &mut p[k * 8..k * 8 + 8]);
            // SAFETY: the CPU has AVX2 (checked above).
            #[allow(unsafe_code)]
            unsafe {
                gather::sample8(image, 1.25, (x, y), px)
            };
        }
        for (i, (&x, &y)) in tx.iter().zip(&ty).enumerate() {
            let taps = Taps::at(image, (x, y));
            let want: Vec<u32> = (0..3)
                .map(|k| {
                    blend(
                        taps.texels.map(|t| rgb[t as usize + k]),
                        (taps.wx, taps.wy),
                        1.25,
                    )
                })
                .map(f32::to_bits)
                .collect();
            let bits: Vec<u32> = got.iter().map(|p| p[i].to_bits()).collect();
            assert_eq!(bits, want, "at ({x}, {y})");
        }
    }

    #[test]
    fn a_pass_over_a_short_image_is_zeros_not_a_panic() {
        let view = ReducedView {
            world_from_camera: Mat3::IDENTITY,
            intrinsics: [10.0, 10.0, 4.0, 4.0],
            scale: 2.0,
            rotation: 0.0,
            exposure: 1.0,
        };
        let rgb = [1.0; 5];
        let image = Equirect {
            rgb: &rgb,
            width: 2,
            height: 1,
        };
        let mut out = [vec![7.0], vec![], vec![7.0; 99]];
        shade(image, &view, (4, 4), &mut out);
        assert!(
            out.iter()
                .all(|p| p.len() == 16 && p.iter().all(|&v| v == 0.0))
        );
    }
}
