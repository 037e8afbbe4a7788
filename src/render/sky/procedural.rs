//! The procedural environment's reduced passes on the CPU, for an adapter
//! that is itself a CPU rasteriser (lavapipe): what `fs_environment` in
//! shaders/sky.wgsl draws, in the same layout — the sky (behind the
//! silhouettes' band too) and the ground below the horizon's margin at a
//! quarter of the resolution per axis, interpolated at half, where the sun
//! disc and the band's silhouettes are drawn over the sky and the ground
//! near the horizon is shaded — for the background's upsampling
//! (render/upsample.rs) to interpolate.
//!
//! On lavapipe the passes cost a frame more CPU than everything else it
//! does (rasterising the parts' polygons, shading under lane masks, the
//! half-float target, its copy and readback). Here each row is split into
//! the runs of its three parts and each part shaded over its runs in place
//! ([`shading`]), into colour planes the upsampling reads as they are, in
//! loops that vectorise to the CPU's widest registers, with the maths of
//! [`crate::simd::math`]: the same values on every machine. A GPU keeps its
//! own passes (environment.rs).

use glam::Mat3;

mod shading;

pub(super) use shading::Procedural;
use shading::{Part, Quarter, Rgba, Row};

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
    /// The quarter-resolution pass (RGB and the sun disc's share,
    /// `upper_sky`), each row widened to the half pass's width as the
    /// sampler interpolates across ([`shading::widen`]): what the half
    /// pass's upper sky blends down.
    quarter: [Vec<f32>; 4],
}

/// The environment `env` for a `frame`-sized frame seen through `view`,
/// into `half`: the half-resolution pass's red, green and blue planes
/// (linear, rows one after the other; alpha 1); its size (`⌈width/2⌉ ×
/// ⌈height/2⌉`).
pub(super) fn shade(
    env: &Procedural,
    view: &View,
    frame: (u32, u32),
    passes: &mut Passes,
    half: &mut [Vec<f32>; 3],
) -> (u32, u32) {
    let quarter_size = (frame.0.div_ceil(QUARTER), frame.1.div_ceil(QUARTER));
    let half_size = (frame.0.div_ceil(HALF), frame.1.div_ceil(HALF));
    let area = |(w, h): (u32, u32)| w as usize * h as usize;
    let widened = (half_size.0, quarter_size.1);
    passes
        .quarter
        .iter_mut()
        .for_each(|p| p.resize(area(widened), 0.0));
    half.iter_mut().for_each(|p| p.resize(area(half_size), 0.0));
    // The quarter pass shades the sky above `-reach` and the ground below
    // it: the texels that the half pass interpolates sample, the sky's at
    // and above the horizon and the ground's below `-2 reach`.
    let reach = reach(view);
    #[cfg(test)]
    let reach = if EVERY_GROUND_PIXEL.get() {
        f32::INFINITY
    } else {
        reach
    };
    let (qw, hw) = (quarter_size.0 as usize, half_size.0 as usize);
    by_rows(
        passes.quarter.each_mut().map(|p| &mut p[..]),
        (hw, qw),
        #[inline(always)]
        |scratch, j, out| quarter_row(scratch, env, view, (j, -reach), out),
    );
    let (quarter, lower) = ((&passes.quarter, widened), -2.0 * reach);
    by_rows(
        half.each_mut().map(|p| &mut p[..]),
        (hw, hw),
        #[inline(always)]
        |scratch, j, [r, g, b]| {
            let Scratch { row, spare } = scratch;
            half_row(
                row,
                env,
                view,
                (j, lower, quarter),
                [r, g, b, &mut spare[3]],
            )
        },
    );
    half_size
}

#[cfg(test)]
thread_local! {
    /// Tests: [`shade`] on this thread shades the ground at every
    /// half-resolution pixel, none interpolated (a reference).
    pub(super) static EVERY_GROUND_PIXEL: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

/// How far (the sine of the elevation) below or above a half-resolution
/// pixel's ray the rays of the quarter texels it samples may lie: their
/// centres lie within 1.5 quarter texels (6 full-resolution pixels) of its
/// own, so their rays at most ≈ 8.5 / f from it. `lower_line` in
/// shaders/sky.wgsl.
fn reach(view: &View) -> f32 {
    let [fx, fy, ..] = view.intrinsics;
    9.0 / fx.abs().min(fy.abs()).max(1e-6)
}

/// A row's scratch on one thread: its rays and parts, and RGBA planes of
/// its width (the quarter pass's row before it is widened; the half pass's
/// alpha, which it does not keep).
struct Scratch {
    row: Row,
    spare: [Vec<f32>; 4],
}

/// `shade(scratch, j, row j of each plane)` for each row `j` of `plane_w`
/// values of `planes` ([`super::plane_rows`], a [`Scratch`] of `row_w`
/// pixels per thread).
#[inline(always)]
fn by_rows<const N: usize>(
    planes: [&mut [f32]; N],
    (plane_w, row_w): (usize, usize),
    shade: impl Fn(&mut Scratch, usize, [&mut [f32]; N]) + Sync + Send,
) {
    let scratch = || Scratch {
        row: Row::new(row_w.max(1)),
        spare: [(); 4].map(|_| vec![0.0; row_w.max(1)]),
    };
    super::plane_rows(planes, plane_w, scratch, shade);
}

/// Row `j`'s unit rays of a pass of `scale` full-resolution pixels per
/// pixel ([`super::row_rays`], normalised).
#[inline(always)]
fn rays(row: &mut Row, view: &View, scale: f32, j: usize) {
    super::row_rays(
        &view.world_from_camera,
        view.intrinsics,
        (scale, j),
        row.rays_mut(),
    );
    row.normalise();
}

/// Quarter-resolution row `j`: the ground where a ray is below `lower`,
/// `upper_sky` elsewhere (the rays below the horizon taken level); widened
/// into `out` (the half pass's width).
#[inline(always)]
fn quarter_row(
    scratch: &mut Scratch,
    env: &Procedural,
    view: &View,
    (j, lower): (usize, f32),
    out: Rgba<'_>,
) {
    let Scratch { row, spare } = scratch;
    rays(row, view, QUARTER as f32, j);
    // Every texel is one part's or the other's: all of `spare` is written.
    row.split(|y| if y < lower { Part::Ground } else { Part::Upper });
    row.level();
    row.upper_sky(env, spare.each_mut().map(|p| &mut p[..]));
    row.ground(env, spare.each_mut().map(|p| &mut p[..]));
    for (quarter, widened) in spare.iter().zip(out) {
        shading::widen(quarter, widened);
    }
}

/// Half-resolution row `j`: each pixel shaded by its part — the ground
/// (below `lower` interpolated from the quarter pass), the band of the
/// silhouettes (over the sky interpolated from the quarter pass), or the
/// sky above it (interpolated, plus the sun disc).
#[inline(always)]
fn half_row(
    row: &mut Row,
    env: &Procedural,
    view: &View,
    (j, lower, quarter): (usize, f32, Quarter<'_>),
    [r, g, b, a]: Rgba<'_>,
) {
    rays(row, view, HALF as f32, j);
    let upper = env.upper_line();
    row.split(|y| Part::of_half(y, (lower, upper)));
    row.ground(env, [r, g, b, a]);
    row.interpolate(env, quarter, j, [&mut *r, &mut *g, &mut *b, &mut *a]);
    row.band(env, [r, g, b, a]);
}
