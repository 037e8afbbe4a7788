//! The thermal picture's background from a thermal backplate (docs/realism.md, "Thermal
//! camera"): a grey frame of the user's own camera, drones removed, stands for the scene's
//! radiance. Its level v becomes the radiance `L(air) + (v − agc_mid_level) · dL/dT(air) /
//! agc_max_gain`: the inverse of the gain control at its largest gain about the air's
//! radiance, so a plate whose levels the gain control spans again at that gain comes back
//! at the same steps (the gain control then places its middle at `agc_mid_level`). The
//! plate already holds its camera's noise, blur and shading: a preset with plates keeps
//! `netd_mk`, `fixed_pattern_mk`, `shading_k` and `blur_px` small (`swarmshot fit` starts
//! them at 0).

use rayon::prelude::*;

use crate::preset::thermal::Thermal;

use super::{Scratch, radiance, radiance_per_kelvin};

/// The background's radiance at every pixel into `scratch.plane` (row-major, `w`×`h`)
/// from the level (Rec. 601 luma; a grey plate's grey) of the drone-free `rgba` (pixels
/// it lacks: the air's radiance).
pub fn plate_plane(t: &Thermal, (w, h): (u32, u32), rgba: &[u8], scratch: &mut Scratch) {
    let n = w as usize * h as usize;
    let air = radiance(t.air_k);
    let per_level = radiance_per_kelvin(t.air_k) / t.agc_max_gain as f32;
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
}
