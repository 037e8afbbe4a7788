//! The procedural environment's reduced passes on the CPU, for an adapter
//! that is itself a CPU rasteriser (lavapipe): what `fs_environment` in
//! shaders/sky.wgsl draws, in the same layout — the sky above the
//! silhouettes' band at a quarter of the resolution per axis, everything
//! else at half, the upper sky's half-resolution pixels interpolated from
//! the quarter's with the sun disc added — for the background's upsampling
//! (render/upsample.rs) to interpolate.
//!
//! On lavapipe the passes cost a frame more CPU than everything else it
//! does (rasterising the parts' polygons, shading under lane masks, the
//! half-float target, its copy and readback). Here each row's pixels are
//! sorted into the three parts and each part shaded over its own pixels
//! ([`shading`]) in loops that vectorise to the CPU's widest registers, with
//! the maths of [`crate::simd::math`]: the same values on every machine. A
//! GPU keeps its own passes (environment.rs).

use glam::{Mat3, Vec3};
use rayon::prelude::*;

mod shading;

pub(super) use shading::Procedural;

/// Full-resolution pixels per pixel of the half- and quarter-resolution passes.
const HALF: u32 = super::HALF_SCALE;
const QUARTER: u32 = super::QUARTER_SCALE;

/// What the passes look through: the camera's rotation (world from
/// camera) and intrinsics `[fx, fy, cx, cy]` (full-resolution pixels).
#[derive(Clone, Copy, Debug)]
pub(super) struct View {
    pub world_from_camera: Mat3,
    pub intrinsics: [f32; 4],
}

/// The passes' memory, kept from frame to frame.
#[derive(Default)]
pub(in crate::render) struct Passes {
    /// The quarter-resolution pass (RGB and the sun disc's share, `upper_sky`).
    quarter: Vec<f32>,
}

/// The environment `env` for a `frame`-sized frame seen through `view`,
/// into `half`: RGBA `f32` texels of the half-resolution pass, rows one
/// after the other, alpha 1; its size (`⌈width/2⌉ × ⌈height/2⌉`).
pub(super) fn shade(
    env: &Procedural,
    view: &View,
    frame: (u32, u32),
    passes: &mut Passes,
    half: &mut Vec<f32>,
) -> (u32, u32) {
    let quarter_size = (frame.0.div_ceil(QUARTER), frame.1.div_ceil(QUARTER));
    let half_size = (frame.0.div_ceil(HALF), frame.1.div_ceil(HALF));
    let quarter = &mut passes.quarter;
    quarter.resize(quarter_size.0 as usize * quarter_size.1 as usize * 4, 0.0);
    half.resize(half_size.0 as usize * half_size.1 as usize * 4, 0.0);
    // Quarter texels a half-resolution upper pixel may sample: their centres
    // lie within 1.5 quarter texels (6 full-resolution pixels) of its own,
    // so their rays at most ≈ 8.5 / f below it.
    let [fx, fy, ..] = view.intrinsics;
    let reach = 9.0 / fx.abs().min(fy.abs()).max(1e-6);
    let needed = env.upper_line().max(0.0) - reach;
    by_rows(
        quarter,
        quarter_size.0 as usize,
        #[inline(always)]
        |row, j, texels| row.quarter(env, view, j, needed, texels),
    );
    let quarter = (&passes.quarter[..], quarter_size);
    by_rows(
        half,
        half_size.0 as usize,
        #[inline(always)]
        |row, j, texels| row.half(env, view, j, quarter, texels),
    );
    half_size
}

/// `shade(row, j, texels)` for each row `j` of `w` RGBA texels of `texels`,
/// in parallel on rayon's threads (each row's values depend only on its
/// index), compiled for the CPU's widest SIMD level.
fn by_rows(texels: &mut [f32], w: usize, shade: impl Fn(&mut Row, usize, &mut [f32]) + Sync) {
    texels
        .par_chunks_mut(w.max(1) * 4)
        .enumerate()
        .for_each_init(
            || Row::new(w),
            |row, (j, texels)| {
                crate::simd::widest(
                    #[inline(always)]
                    || shade(row, j, texels),
                )
            },
        );
}

/// One row's scratch: per pixel its ray, then the pixels of one part
/// (their indices and rays, gathered), and what they are shaded.
struct Row {
    x: Vec<f32>,
    y: Vec<f32>,
    z: Vec<f32>,
    part: shading::Part,
}

impl Row {
    fn new(w: usize) -> Self {
        Self {
            x: vec![0.0; w],
            y: vec![0.0; w],
            z: vec![0.0; w],
            part: shading::Part::new(w),
        }
    }

    /// Row `j`'s unit rays of a pass of `scale` full-resolution pixels
    /// per pixel ([`super::row_rays`], normalised).
    #[inline(always)]
    fn rays(&mut self, view: &View, scale: f32, j: usize) {
        let rays = (&mut self.x[..], &mut self.y[..], &mut self.z[..]);
        super::row_rays(&view.world_from_camera, view.intrinsics, (scale, j), rays);
        for ((x, y), z) in self.x.iter_mut().zip(&mut self.y).zip(&mut self.z) {
            let d = Vec3::new(*x, *y, *z);
            let d = d * (1.0 / d.dot(d).sqrt());
            (*x, *y, *z) = (d.x, d.y, d.z);
        }
    }

    /// Quarter-resolution row `j`: `upper_sky` where a ray is above
    /// `needed` (the rays below the horizon taken level), zeros elsewhere.
    #[inline(always)]
    fn quarter(
        &mut self,
        env: &Procedural,
        view: &View,
        j: usize,
        needed: f32,
        texels: &mut [f32],
    ) {
        self.rays(view, QUARTER as f32, j);
        texels.fill(0.0);
        let rays = (&self.x[..], &self.y[..], &self.z[..]);
        let part = &mut self.part;
        part.gather(rays, |y| y > needed);
        part.level();
        part.upper_sky(env);
        part.scatter(texels);
    }

    /// Half-resolution row `j`: each pixel shaded by its part — the
    /// ground, the band of the silhouettes, or the sky above it
    /// (interpolated from the quarter pass, plus the sun disc).
    #[inline(always)]
    fn half(
        &mut self,
        env: &Procedural,
        view: &View,
        j: usize,
        quarter: (&[f32], (u32, u32)),
        texels: &mut [f32],
    ) {
        self.rays(view, HALF as f32, j);
        let upper = env.upper_line();
        let rays = (&self.x[..], &self.y[..], &self.z[..]);
        let part = &mut self.part;
        part.gather(rays, |y| y < 0.0);
        part.ground(env);
        part.scatter(texels);
        part.gather(rays, |y| y >= 0.0 && y <= upper);
        part.band(env);
        part.scatter(texels);
        // `y > upper` written so that a ray that is not a number lands here:
        // every texel is written, none kept from the frame before.
        part.gather(rays, |y| !(y < 0.0 || y <= upper));
        part.interpolate(env, quarter, j);
        part.scatter(texels);
    }
}
