//! The thermal picture's background from a thermal backplate (docs/realism.md, "Thermal
//! camera"): a grey frame of the user's own camera, drones removed, stands for the scene's
//! radiance. Its level v becomes the radiance `L(air) + (v − agc_mid_level) · dL/dT(air) /
//! agc_max_gain`: the inverse of [`plate_gain`], the fixed gain a frame over a plate is
//! developed with, so the plate's pixels come back at their own levels. The plate's camera
//! set those levels with its gain control, with the drone in view; a second gain control
//! on the composed frame would move them by what swarmshot draws (a hot drone's pixels
//! raising the high percentile dims and flattens the plate). What is drawn over the plate
//! reads `agc_max_gain` levels per kelvin about the air. The plate already holds its
//! camera's noise, blur and shading: a preset with plates keeps `netd_mk`,
//! `fixed_pattern_mk` and `shading_k` small (`swarmshot fit` starts them at 0), and its
//! `blur_px` blurs only what is drawn over the plate ([`blur_drawn`]): the drones,
//! confusers, texture and weather pass the optics once, as the plate did.

use rayon::prelude::*;

use crate::preset::thermal::Thermal;

use super::develop::{Gain, blur_banded, kernel_radius};
use super::{Scratch, radiance, radiance_per_kelvin};

/// The background's radiance at every pixel into `scratch.plane` (row-major, `w`×`h`)
/// from the level (Rec. 601 luma; a grey plate's grey) of the drone-free `rgba` (pixels
/// it lacks: the air's radiance).
pub fn plate_plane(t: &Thermal, (w, h): (u32, u32), rgba: &[u8], scratch: &mut Scratch) {
    let n = w as usize * h as usize;
    let air = radiance(t.air_k);
    let per_level = per_level(t);
    let mid = t.agc_mid_level as f32;
    let plane = &mut scratch.plane;
    plane.clear();
    plane.resize(n, air);
    (plane.par_chunks_mut(4096).zip(rgba.par_chunks(4096 * 4))).for_each(|(out, px)| {
        for (o, p) in out.iter_mut().zip(px.chunks_exact(4)) {
            let v = 0.299 * f32::from(p[0]) + 0.587 * f32::from(p[1]) + 0.114 * f32::from(p[2]);
            *o = air + (v - mid) * per_level;
        }
    });
    scratch.plate.clear();
    if t.blur_px > 0.0 {
        scratch.plate.extend_from_slice(plane);
    }
}

/// The gain a frame over a plate is developed with: the inverse of [`plate_plane`]'s
/// mapping, so a plate level v comes back as v, and radiance drawn over it at
/// `agc_max_gain` levels per kelvin of the air.
pub fn plate_gain(t: &Thermal) -> Gain {
    let scale = 1.0 / per_level(t);
    Gain::Fixed {
        scale,
        offset: t.agc_mid_level as f32 - radiance(t.air_k) * scale,
    }
}

/// Radiance per plate level: the air's per kelvin over the largest gain.
fn per_level(t: &Thermal) -> f32 {
    radiance_per_kelvin(t.air_k) / t.agc_max_gain as f32
}

/// The optics' blur of σ `sigma` px on what is drawn over the plate: `scratch.plane`
/// becomes the plate [`plate_plane`] kept + the blurred difference, so pixels farther than
/// the kernel from anything drawn keep the plate's value exactly. The difference is
/// blurred as the development blurs (bands of rows on rayon's threads; the same sums as
/// blurring the whole difference plane, its kernel truncated at ⌈3σ⌉, edges clamped) over
/// the rows drawn on, grown by the kernel. Without a kept plate (σ 0 when it was made)
/// nothing changes.
pub fn blur_drawn(sigma: f32, (w, h): (u32, u32), scratch: &mut Scratch) {
    let (w, h) = (w as usize, h as usize);
    let Scratch {
        plane,
        plate,
        drawn,
        rows,
        ..
    } = scratch;
    if sigma <= 0.0 || w == 0 || plate.len() != w * h || plane.len() != w * h {
        return;
    }
    let differs = |y: &usize| plane[y * w..(y + 1) * w] != plate[y * w..(y + 1) * w];
    let (Some(first), Some(last)) = ((0..h).find(differs), (0..h).rfind(differs)) else {
        return;
    };
    let r = kernel_radius(sigma);
    let band = first.saturating_sub(r) * w..(last + 1 + r).min(h) * w;
    let (plane, plate) = (&mut plane[band.clone()], &plate[band.clone()]);
    drawn.clear();
    drawn.par_extend((plane.par_iter().zip(plate)).map(|(a, b)| a - b));
    blur_banded(drawn, (w, band.len() / w), sigma, rows);
    (plane.par_iter_mut().zip(plate).zip(&drawn[..])).for_each(|((o, b), d)| *o = b + d);
}

#[cfg(test)]
mod tests {
    use super::super::{Developed, blur, develop_into};
    use super::*;

    /// A plate holding every level, developed with [`plate_gain`] and no noise, comes back
    /// level for level whatever the gain control's settings, and a pixel 1 K warmer than
    /// the air's radiance reads `agc_max_gain` levels above the plate's level there.
    #[test]
    fn over_a_plate_the_levels_come_back_and_a_kelvin_reads_the_largest_gain() {
        let (w, h) = (256u32, 2u32);
        let rgba: Vec<u8> = (0..w * h)
            .flat_map(|i| [(i % w) as u8; 3].into_iter().chain([255]))
            .collect();
        for (air_k, agc_max_gain, agc_mid_level) in [
            (288.0, 4.0, 110.0),
            (260.0, 12.5, 40.0),
            (305.0, 1.0, 250.0),
        ] {
            let t = Thermal {
                air_k,
                agc_max_gain,
                agc_mid_level,
                netd_mk: 0.0,
                fixed_pattern_mk: 0.0,
                blur_px: 0.0,
                ..Thermal::default()
            };
            let mut scratch = Scratch::default();
            plate_plane(&t, (w, h), &rgba, &mut scratch);
            // The second row's level 100 pixel 1 K warmer (a radiance step at the air's slope).
            scratch.plane[(w + 100) as usize] += radiance_per_kelvin(air_k);
            let pattern = vec![0.0; (w * h) as usize];
            let mut out = vec![0u8; (w * h * 4) as usize];
            develop_into(
                &t,
                (w, h),
                (&pattern, 1),
                plate_gain(&t),
                &mut scratch,
                Developed::Rgba8(&mut out),
            );
            for (i, (got, want)) in out.chunks_exact(4).zip(rgba.chunks_exact(4)).enumerate() {
                if i != (w + 100) as usize {
                    assert_eq!(
                        got[0], want[0],
                        "pixel {i} at air {air_k} K, gain {agc_max_gain}, mid {agc_mid_level}"
                    );
                }
            }
            let warm = f64::from(out[((w + 100) * 4) as usize]);
            assert!(
                (warm - (100.0 + agc_max_gain).min(255.0)).abs() <= 1.0,
                "{warm} for 1 K at {agc_max_gain} levels/K"
            );
        }
    }

    /// A 64×48 plate with a sharp vertical step at x = 20 and a drawn 3×3 blob at (44, 30):
    /// after [`blur_drawn`] the step is as sharp as the plate's, every pixel farther than
    /// the kernel from the blob is the plate's to the bit, and the rest is the plate plus
    /// the whole difference plane blurred.
    #[test]
    fn the_blur_takes_what_is_drawn_and_leaves_the_plate() {
        let (w, h) = (64u32, 48u32);
        let t = Thermal {
            blur_px: 1.3,
            ..Thermal::default()
        };
        let rgba: Vec<u8> = (0..w * h)
            .flat_map(|i| {
                let v = if i % w < 20 { 60 } else { 180 };
                [v, v, v, 255]
            })
            .collect();
        let mut scratch = Scratch::default();
        plate_plane(&t, (w, h), &rgba, &mut scratch);
        let plate = scratch.plane.clone();
        let at = |x: u32, y: u32| (y * w + x) as usize;
        for y in 29..32 {
            for x in 43..46 {
                scratch.plane[at(x, y)] += 5.0;
            }
        }
        let mut diff: Vec<f32> = (scratch.plane.iter().zip(&plate))
            .map(|(a, b)| a - b)
            .collect();
        blur(&mut diff, (w as usize, h as usize), 1.3);
        blur_drawn(1.3, (w, h), &mut scratch);
        let r = kernel_radius(1.3) as u32;
        for y in 0..h {
            for x in 0..w {
                let (got, i) = (scratch.plane[at(x, y)], at(x, y));
                if x + r < 43 || x > 45 + r || y + r < 29 || y > 31 + r {
                    assert_eq!(got.to_bits(), plate[i].to_bits(), "({x}, {y})");
                } else {
                    assert_eq!(got.to_bits(), (plate[i] + diff[i]).to_bits(), "({x}, {y})");
                }
            }
        }
        assert_eq!(scratch.plane[at(19, 5)], plate[at(19, 5)]);
        assert_eq!(scratch.plane[at(20, 5)], plate[at(20, 5)]);
        let centre = scratch.plane[at(44, 30)] - plate[at(44, 30)];
        assert!(centre > 0.5 && centre < 5.0, "the blob spread: {centre}");
        // The blob's total is kept (the kernel is normalised, the blob far from the edges).
        let total: f32 = (scratch.plane.iter().zip(&plate)).map(|(a, b)| a - b).sum();
        assert!((total - 45.0).abs() < 1e-3, "{total}");
        // No blur: no plate kept, nothing changes.
        let t0 = Thermal {
            blur_px: 0.0,
            ..Thermal::default()
        };
        plate_plane(&t0, (w, h), &rgba, &mut scratch);
        scratch.plane[at(44, 30)] += 5.0;
        let before = scratch.plane.clone();
        blur_drawn(1.3, (w, h), &mut scratch);
        assert_eq!(scratch.plane, before);
    }
}
