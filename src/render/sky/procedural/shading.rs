//! environment.wgsl's procedural environment per ray, on the CPU: the
//! frame's constants read from the uniforms the GPU passes get
//! ([`Procedural`]), and a part of a row's pixels shaded in loops over its
//! runs of rays ([`Row`]), each specialised for the frame's kinds (ground, silhouettes,
//! clouds) outside the loop, as the GPU's pipelines are by their override
//! constants, so that the loop body is straight-line code that vectorises.

use std::ops::Range;

use glam::{Vec2, Vec3};

use super::super::uniforms::EnvUniforms;
use crate::simd::math::{acos, asin, exp, fract, small_uint, smoothstep};
use crate::sky::noise::{fbm, silhouette_height, silhouette_of, step, vnoise};
use crate::sky::{HAZE_TABLE, Silhouette};

/// A frame's procedural environment: its uniforms as the shader reads
/// them, and the products of them that are the same for every pixel.
pub(in crate::render::sky) struct Procedural<'a> {
    /// `haze_table`: handed to each loop as an argument of its own (a
    /// table read through the struct might alias the loop's outputs, for
    /// all the compiler knows, and the loop would not vectorise).
    table: &'a Table,
    /// Radiance → display scale (`mode.y`).
    k: f32,
    sun: Vec3,
    sun_color: Vec3,
    cover: f32,
    perez: [Vec3; 5],
    sky_k: Vec3,
    light: Vec3,
    ambient: Vec3,
    seed: Vec2,
    ground: u8,
    ground_albedo: [Vec3; 2],
    /// The ground's light (sun and sky) and fog distance scale (m).
    ground_light: Vec3,
    fog_m: f32,
    far: (Silhouette, f32),
    near: (Silhouette, f32),
    snow_caps: bool,
    far_shade: Vec3,
    snow_shade: Vec3,
    near_shade: Vec3,
    far_haze: f32,
    near_haze: f32,
    /// The sine of the elevation above which no silhouette reaches (−2: none).
    upper: f32,
}

/// The horizon haze's table (`Preetham::haze_table`).
type Table = [[f32; 4]; HAZE_TABLE];

fn rgb(v: [f32; 4]) -> Vec3 {
    Vec3::new(v[0], v[1], v[2])
}

impl<'a> Procedural<'a> {
    /// The environment of uniforms `u` (a procedural one: `mode.x` 1) with
    /// the sun toward `sun` (world frame, unit).
    pub(in crate::render::sky) fn new(u: &'a EnvUniforms, sun: Vec3) -> Self {
        let (light, ambient) = (rgb(u.light), rgb(u.ambient));
        let sun_up = sun.y.max(0.0);
        let atmosphere = u.near[3] > 0.5;
        Self {
            table: &u.haze_table,
            k: u.mode[1],
            sun,
            sun_color: rgb(u.sun_color),
            cover: u.sun_color[3],
            perez: std::array::from_fn(|i| rgb(u.perez[i])),
            sky_k: rgb(u.sky_k),
            light,
            ambient,
            seed: Vec2::new(u.pattern[0], u.pattern[1]),
            ground: u.pattern[2].round().clamp(0.0, 3.0) as u8,
            ground_albedo: [rgb(u.ground_a), rgb(u.ground_b)],
            ground_light: light * sun_up + ambient,
            fog_m: u.zenith_yxy[3],
            far: (silhouette_of(u.pattern[3]), u.far[3]),
            near: (silhouette_of(u.far_params[1]), u.far_params[2]),
            snow_caps: u.far_params[0] > 0.5,
            far_shade: rgb(u.far) * (light * sun_up * 0.6 + ambient * 0.8),
            snow_shade: Vec3::new(0.85, 0.87, 0.9) * (light * sun_up * 0.5 + ambient),
            near_shade: rgb(u.near) * (light * sun_up * 0.5 + ambient * 0.7),
            far_haze: if atmosphere { u.ground_a[3] } else { 0.55 },
            near_haze: if atmosphere { u.ground_b[3] } else { 0.25 },
            upper: u.band[1],
        }
    }

    /// The sine of the elevation above which a sky pixel is the upper
    /// sky's (no silhouette reaches it); −2 when there is no silhouette.
    pub(super) fn upper_line(&self) -> f32 {
        self.upper
    }

    /// Whether the sky has a cloud layer (`upper_sky`'s test).
    fn clouds(&self) -> bool {
        self.cover > 0.001
    }

    /// `preetham`: the Preetham radiance of ray `dir`, clamped at the horizon.
    #[inline(always)]
    fn preetham(&self, dir: Vec3) -> Vec3 {
        let d = Vec3::new(dir.x, dir.y.max(0.001), dir.z);
        let d = d * (1.0 / d.dot(d).sqrt());
        let cos_gamma = d.dot(self.sun).clamp(-1.0, 1.0);
        let [a, b, c, dd, e] = self.perez;
        let f_theta = 1.0 / d.y.max(0.01);
        let f = Vec3::new(
            1.0 + a.x * exp(b.x * f_theta),
            1.0 + a.y * exp(b.y * f_theta),
            1.0 + a.z * exp(b.z * f_theta),
        );
        let gamma = acos(cos_gamma);
        let c2 = cos_gamma * cos_gamma;
        let g = Vec3::new(
            1.0 + c.x * exp(dd.x * gamma) + e.x * c2,
            1.0 + c.y * exp(dd.y * gamma) + e.y * c2,
            1.0 + c.z * exp(dd.z * gamma) + e.z * c2,
        );
        let yxy = self.sky_k * f * g;
        yxy_to_rgb(yxy)
    }

    /// `horizon_haze`: the tone-mapped sky just above level in the
    /// azimuth of `az_c` (unit xz), interpolated in the frame's table.
    #[inline(always)]
    fn haze(&self, table: &Table, az_c: Vec2) -> Vec3 {
        let d = Vec3::new(az_c.x, 0.02, az_c.y) * 0.999_800_1;
        let cos_gamma = d.dot(self.sun).clamp(-1.0, 1.0);
        let half = HAZE_TABLE / 2;
        let t = (0.5 - 0.5 * cos_gamma.abs()).max(0.0).sqrt()
            * ((half - 1) as f32 * std::f32::consts::SQRT_2);
        let k = t.floor().min((half - 2) as f32);
        let i = small_uint(k) as usize + if cos_gamma >= 0.0 { 0 } else { half };
        // In bounds (i ≤ HAZE_TABLE − 2); the mask lets the compiler see it.
        let (lo, hi) = (table[i % HAZE_TABLE], table[(i + 1) % HAZE_TABLE]);
        let w = t - k;
        mix(rgb(lo), rgb(hi), w).max(Vec3::ZERO)
    }

    /// `upper_sky`: the Preetham sky and (with `CLOUDS`) the cloud layer
    /// of ray `dir`, and the share of the sun disc the clouds leave.
    #[inline(always)]
    fn upper_sky<const CLOUDS: bool>(&self, dir: Vec3, haze: Vec3) -> (Vec3, f32) {
        let col = tone_map(self.preetham(dir) * self.k);
        if !CLOUDS {
            return (col, 1.0);
        }
        let sun = self.sun;
        let uv = Vec2::new(dir.x, dir.z) / (dir.y + 0.05) * 0.9 + self.seed;
        let threshold = mix1(0.72, 0.22, self.cover);
        let coarse = fbm(uv, 2);
        // The GPU skips the finer octaves where they cannot reach the
        // threshold; here every pixel takes them, and keeps them where it would.
        let fine = coarse + 0.25 * fbm(uv * 4.0804 + Vec2::new(70.2, 37.5), 3);
        let n = if coarse + 0.25 > threshold {
            fine
        } else {
            coarse
        };
        let density = smoothstep(threshold, threshold + 0.2, n);
        let toward_sun = fbm(uv + Vec2::new(sun.x, sun.z) * 0.12, 2);
        let self_shadow = (1.0 - (toward_sun - n) * 2.5).clamp(0.45, 1.15);
        let s = dir.dot(sun).max(0.0);
        let s4 = (s * s) * (s * s);
        let silver = s4 * s4 * s4;
        let cloud = (self.ambient * 0.85 + self.light * 0.5 * (0.6 + silver))
            * self_shadow
            * (1.0 - 0.35 * density);
        let fade = smoothstep(0.0, 0.1, dir.y);
        let cloud_far = mix(haze, cloud, smoothstep(0.0, 0.3, dir.y) * 0.7 + 0.3);
        let f = density * fade * 0.95;
        (mix(col, cloud_far.min(Vec3::ONE), f), 1.0 - f)
    }

    /// `sun_disc`: the sun disc's light in direction `dir`.
    #[inline(always)]
    fn sun_disc(&self, dir: Vec3) -> Vec3 {
        self.sun_color * (smoothstep(0.99996, 0.99999, dir.dot(self.sun)) * 3.0)
    }

    /// The ground side of `procedural_sky` for ray `dir` (below the
    /// horizon) with ground kind `GROUND` (2 water, 3 road, else plain).
    #[inline(always)]
    fn ground<const GROUND: u8>(&self, table: &Table, dir: Vec3) -> Vec3 {
        let haze = self.haze(table, azimuth(dir));
        let t = 60.0 / (-dir.y).max(1e-4);
        let p = Vec2::new(dir.x, dir.z) * t + self.seed * 37.0;
        let [ga, gb] = self.ground_albedo;
        let mut albedo = mix(ga, gb, fbm(p * 0.01, 4));
        let fields = vnoise(p * 0.003);
        albedo *= 0.8 + 0.4 * step(0.5, fields);
        if GROUND == 3 {
            // A straight country road with a dashed centre line.
            let across = (p.x - 30.0).abs();
            let line = across < 0.12 && fract(p.y / 12.0) < 0.5;
            let road = if line {
                Vec3::splat(0.6)
            } else {
                Vec3::new(0.05, 0.05, 0.055)
            };
            albedo = if across < 3.5 { road } else { albedo };
        }
        let mut lit = albedo * self.ground_light;
        if GROUND == 2 {
            // Water: the sky reflected with Fresnel, ripples and a sun glint.
            let q = p * 0.35;
            let ripple = (Vec2::new(vnoise(q), vnoise(q + 7.0)) - 0.5) * 0.06;
            let r = Vec3::new(dir.x + ripple.x, -dir.y, dir.z + ripple.y);
            let r = r * (1.0 / r.dot(r).sqrt());
            let reflected = tone_map(self.preetham(r) * self.k);
            let m = 1.0 - (-dir.y).min(1.0);
            let fresnel = 0.02 + 0.98 * (m * m * m * m * m);
            let glint = pow300(r.dot(self.sun).max(0.0)) * self.light * 2.0;
            lit = mix(albedo * self.ambient, reflected, fresnel) + glint;
        }
        let fog = 1.0 - exp(-t / self.fog_m);
        mix(lit, haze, fog)
    }

    /// The sky side below the band's top (`procedural_sky`, `ENV_PART` 1)
    /// for ray `dir`, under silhouettes `far_h` and `near_h` high (rad),
    /// over `sky`, the sky behind them (the quarter pass's, interpolated,
    /// with the sun disc). A ray below either silhouette's height never
    /// shows the sky: there `sky` may be anything.
    #[inline(always)]
    fn band_over(&self, table: &Table, dir: Vec3, (far_h, near_h): (f32, f32), sky: Vec3) -> Vec3 {
        let haze = self.haze(table, azimuth(dir));
        let mut col = sky;
        let elevation = asin(dir.y.clamp(-1.0, 1.0));
        let snow = smoothstep(0.6, 0.75, elevation / far_h.max(1e-4));
        let capped = self.snow_caps && elevation > far_h * 0.6;
        let far = if capped {
            mix(self.far_shade, self.snow_shade, snow)
        } else {
            self.far_shade
        };
        col = if elevation < far_h {
            mix(far, haze, self.far_haze)
        } else {
            col
        };
        if elevation < near_h {
            mix(self.near_shade, haze, self.near_haze)
        } else {
            col
        }
    }
}

/// One row of a pass: its pixels' rays and the runs of them that make each
/// part. A part is shaded over its runs in place, into the pass's RGBA
/// planes ([`Rgba`]), so no pixel is gathered, scattered or interleaved:
/// the parts of a row are a few runs each (where a ray's height crosses a
/// bound).
pub(super) struct Row {
    x: Vec<f32>,
    y: Vec<f32>,
    z: Vec<f32>,
    /// Each [`Part`]'s pixels: ranges of the row, in order.
    runs: [Vec<Range<usize>>; 4],
    /// The silhouettes' heights (far, near) of the band's pixels.
    heights: [Vec<f32>; 2],
    /// The band's pixels under a silhouette, in runs ([`Row::split_hidden`]).
    hidden: Vec<Range<usize>>,
    /// Per pixel: whether a band pixel lies under a silhouette.
    mask: Vec<bool>,
    /// Per pixel: its [`Part`] ([`Row::split`]).
    parts: Vec<u8>,
    /// The band's runs as [`Row::split_hidden`] rebuilds them (their
    /// memory kept from row to row).
    shown: Vec<Range<usize>>,
}

/// The fewest pixels in a run of the band that is shaded without its sky:
/// shorter stretches stay in their run, whose loop runs on vector lanes.
const HIDDEN_RUN: usize = 16;

/// The pixels [`Row::split`] checks at once for a change of part.
const SAME_RUN: usize = 64;

/// A row's RGBA planes, each the row's length.
pub(super) type Rgba<'a> = [&'a mut [f32]; 4];

/// The quarter-resolution pass, its rows widened to the half pass's width
/// ([`widen`]): its RGBA planes and their size.
pub(super) type Quarter<'a> = (&'a [Vec<f32>; 4], (u32, u32));

/// The parts of a pass's pixels, by their ray's height: the ground, the
/// silhouettes' band, the sky above it, and the ground below the horizon's
/// margin, which the half pass interpolates from the quarter pass as it
/// does the sky above the band.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub(super) enum Part {
    Ground = 0,
    Band = 1,
    Upper = 2,
    Lower = 3,
}

impl Part {
    /// The part of a half-resolution pixel whose ray's height is `y`, between
    /// the `lower` line (below it the ground is the quarter pass's,
    /// interpolated) and the environment's `upper` line
    /// ([`Procedural::upper_line`]). A ray that is not a number lands in the
    /// upper sky: every pixel is shaded, none kept from the frame before.
    #[inline(always)]
    pub(super) fn of_half(y: f32, (lower, upper): (f32, f32)) -> Self {
        if y < lower {
            Self::Lower
        } else if y < 0.0 {
            Self::Ground
        } else if y <= upper {
            Self::Band
        } else {
            Self::Upper
        }
    }
}

impl Row {
    pub(super) fn new(w: usize) -> Self {
        let v = || vec![0.0; w];
        Self {
            x: v(),
            y: v(),
            z: v(),
            runs: Default::default(),
            heights: [v(), v()],
            hidden: Vec::new(),
            mask: vec![false; w],
            parts: Vec::new(),
            shown: Vec::new(),
        }
    }

    /// The row's rays, to be written (then made unit by [`Row::normalise`]).
    pub(super) fn rays_mut(&mut self) -> (&mut [f32], &mut [f32], &mut [f32]) {
        (&mut self.x, &mut self.y, &mut self.z)
    }

    /// Each ray made unit.
    #[inline(always)]
    pub(super) fn normalise(&mut self) {
        for ((x, y), z) in self.x.iter_mut().zip(&mut self.y).zip(&mut self.z) {
            let d = Vec3::new(*x, *y, *z);
            let d = d * (1.0 / d.dot(d).sqrt());
            (*x, *y, *z) = (d.x, d.y, d.z);
        }
    }

    /// The row's pixels split into their parts by their ray's height `y`
    /// (`part_of(y)`): each pixel's part first, in a loop that vectorises,
    /// then the runs, a chunk of [`SAME_RUN`] pixels at a time where they
    /// all continue the run (a row crosses a bound a few times at most).
    #[inline(always)]
    pub(super) fn split(&mut self, part_of: impl Fn(f32) -> Part) {
        self.runs.iter_mut().for_each(Vec::clear);
        let n = self.y.len();
        self.parts.resize(n, 0);
        for (p, &y) in self.parts.iter_mut().zip(&self.y) {
            *p = part_of(y) as u8;
        }
        let Some(&first) = self.parts.first() else {
            return;
        };
        let (mut part, mut start) = (first, 0);
        for i in (1..n).step_by(SAME_RUN) {
            let chunk = &self.parts[i..(i + SAME_RUN).min(n)];
            // Zero where every part in the chunk is the run's (no early exit: it vectorises).
            if chunk.iter().fold(0, |acc, &p| acc | (p ^ part)) == 0 {
                continue;
            }
            for (k, &p) in chunk.iter().enumerate() {
                if p != part {
                    self.runs[usize::from(part)].push(start..i + k);
                    (part, start) = (p, i + k);
                }
            }
        }
        self.runs[usize::from(part)].push(start..n);
    }

    /// Each of the upper sky's rays below the horizon taken level (the
    /// quarter pass's margin).
    #[inline(always)]
    pub(super) fn level(&mut self) {
        for run in &self.runs[Part::Upper as usize] {
            let x = &mut self.x[run.clone()];
            let (y, z) = (&mut self.y[run.clone()], &mut self.z[run.clone()]);
            for ((x, y), z) in x.iter_mut().zip(y).zip(z) {
                let flat = Vec3::new(*x + 1e-6, 0.0, *z);
                let flat = flat * (1.0 / flat.dot(flat).sqrt());
                let below = *y < 0.0;
                *x = if below { flat.x } else { *x };
                *z = if below { flat.z } else { *z };
                *y = if below { 0.0 } else { *y };
            }
        }
    }

    /// The part's `upper_sky` (RGB and the sun disc's share).
    #[inline(always)]
    pub(super) fn upper_sky(&self, env: &Procedural, out: Rgba<'_>) {
        #[inline(always)]
        fn with<const CLOUDS: bool>(row: &Row, env: &Procedural, out: Rgba<'_>) {
            row.each(
                env,
                (Part::Upper, out),
                #[inline(always)]
                |d, _, t, _| {
                    let (c, a) = env.upper_sky::<CLOUDS>(d, env.haze(t, azimuth(d)));
                    [c.x, c.y, c.z, a]
                },
            );
        }
        if env.clouds() {
            with::<true>(self, env, out);
        } else {
            with::<false>(self, env, out);
        }
    }

    /// The part's ground.
    #[inline(always)]
    pub(super) fn ground(&self, env: &Procedural, out: Rgba<'_>) {
        #[inline(always)]
        fn with<const GROUND: u8>(row: &Row, env: &Procedural, out: Rgba<'_>) {
            row.each(
                env,
                (Part::Ground, out),
                #[inline(always)]
                |d, _, t, _| opaque(env.ground::<GROUND>(t, d)),
            );
        }
        match env.ground {
            2 => with::<2>(self, env, out),
            3 => with::<3>(self, env, out),
            _ => with::<0>(self, env, out),
        }
    }

    /// The part's band over the sky in `out` (the quarter pass's, blended
    /// down: [`Row::interpolate`]): the silhouettes' heights first, then
    /// the sky with its sun disc and the silhouettes over it.
    #[inline(always)]
    pub(super) fn band(&mut self, env: &Procedural, [r, g, b, a]: Rgba<'_>) {
        let seeds = [env.seed * 0.01, env.seed * 0.013 + Vec2::new(5.0, 3.0)];
        for run in &self.runs[Part::Band as usize] {
            let (x, z) = (&self.x[run.clone()], &self.z[run.clone()]);
            for ((kind, height), (heights, seed)) in [env.far, env.near]
                .into_iter()
                .zip(self.heights.iter_mut().zip(seeds))
            {
                silhouettes(kind, height, seed, (x, z), &mut heights[run.clone()]);
            }
        }
        self.split_hidden();
        let runs = &self.runs[Part::Band as usize];
        self.each_in(
            env,
            (runs, Part::Band, [&mut *r, &mut *g, &mut *b, &mut *a]),
            #[inline(always)]
            |d, [f, n], t, [r, g, b, share]| {
                let sky = Vec3::new(r, g, b) + env.sun_disc(d) * share;
                opaque(env.band_over(t, d, (f, n), sky))
            },
        );
        self.each_in(
            env,
            (&self.hidden, Part::Band, [r, g, b, a]),
            #[inline(always)]
            |d, [f, n], t, _| opaque(env.band_over(t, d, (f, n), Vec3::ZERO)),
        );
    }

    /// The band's runs of at least [`HIDDEN_RUN`] pixels whose rays lie
    /// below the far or the near silhouette's height (`band`'s tests, on
    /// the same values) moved to `hidden`: their sky is never shown, so it
    /// is not shaded. The band keeps the rest.
    #[inline(always)]
    fn split_hidden(&mut self) {
        let [far, near] = &self.heights;
        for run in &self.runs[Part::Band as usize] {
            let y = &self.y[run.clone()];
            let (far, near) = (&far[run.clone()], &near[run.clone()]);
            for (((m, y), f), n) in self.mask[run.clone()].iter_mut().zip(y).zip(far).zip(near) {
                let elevation = asin(y.clamp(-1.0, 1.0));
                *m = elevation < *f || elevation < *n;
            }
        }
        let mut band = std::mem::take(&mut self.runs[Part::Band as usize]);
        let mut shown = std::mem::take(&mut self.shown);
        self.hidden.clear();
        shown.clear();
        // The band's runs are maximal (parts lie between them), so the pieces
        // they leave never touch one another.
        for run in band.drain(..) {
            let (mut start, mut at) = (run.start, run.start);
            for stretch in self.mask[run.clone()].chunk_by(|a, b| a == b) {
                let end = at + stretch.len();
                if stretch[0] && stretch.len() >= HIDDEN_RUN {
                    if start < at {
                        shown.push(start..at);
                    }
                    self.hidden.push(at..end);
                    start = end;
                }
                at = end;
            }
            if start < run.end {
                shown.push(start..run.end);
            }
        }
        self.runs[Part::Band as usize] = shown;
        self.shown = band;
    }

    /// The upper sky's, the band's and the lower ground's pixels of
    /// half-resolution row `j`: the quarter pass's RGBA (`quarter`: its rows
    /// widened, [`widen`]) blended down between its two rows at the pixel (a
    /// clamping bilinear sample at the full-resolution position over the
    /// quarter's scale, as the GPU's sampler takes it), plus, in the upper
    /// sky, the sun disc times its share (the band adds its own:
    /// [`Row::band`]).
    #[inline(always)]
    pub(super) fn interpolate(
        &self,
        env: &Procedural,
        (quarter, (qw, qh)): Quarter<'_>,
        j: usize,
        mut out: Rgba<'_>,
    ) {
        let qw = qw as usize;
        let (r0, r1, wy) = tap(j, (qh as usize).saturating_sub(1));
        let row = |r: usize| {
            quarter
                .each_ref()
                .map(|p| p.get(r * qw..(r + 1) * qw).unwrap_or(&[]))
        };
        let (top, bottom) = (row(r0), row(r1));
        if top.iter().chain(&bottom).any(|p| p.len() < self.y.len()) {
            return;
        }
        let [_, band, upper, lower] = &self.runs;
        for run in upper.iter().chain(lower).chain(band) {
            for ((out, top), bottom) in out.iter_mut().zip(top).zip(bottom) {
                let out = &mut out[run.clone()];
                let (top, bottom) = (&top[run.clone()], &bottom[run.clone()]);
                for ((v, t), b) in out.iter_mut().zip(top).zip(bottom) {
                    *v = t + (b - t) * wy;
                }
            }
        }
        self.each(
            env,
            (Part::Upper, out),
            #[inline(always)]
            |d, _, _, [r, g, b, share]| {
                let c = Vec3::new(r, g, b) + env.sun_disc(d) * share;
                [c.x, c.y, c.z, 1.0]
            },
        );
    }

    /// `shade(ray, inputs, haze table)` for each of `part`'s pixels (the
    /// band's with its silhouettes' heights as inputs), into its place in
    /// `out`, run by run.
    #[inline(always)]
    fn each(
        &self,
        env: &Procedural,
        (part, out): (Part, Rgba<'_>),
        shade: impl Fn(Vec3, [f32; 2], &Table, [f32; 4]) -> [f32; 4] + Copy,
    ) {
        self.each_in(env, (&self.runs[part as usize], part, out), shade);
    }

    /// [`Row::each`] over `runs` (pixels of `part`).
    #[inline(always)]
    fn each_in(
        &self,
        env: &Procedural,
        (runs, part, [r, g, b, a]): (&[Range<usize>], Part, Rgba<'_>),
        shade: impl Fn(Vec3, [f32; 2], &Table, [f32; 4]) -> [f32; 4] + Copy,
    ) {
        let [far, near] = &self.heights;
        for run in runs {
            let (x, y) = (&self.x[run.clone()], &self.y[run.clone()]);
            let z = &self.z[run.clone()];
            let read = match part {
                Part::Band => [&far[run.clone()], &near[run.clone()]],
                Part::Ground | Part::Upper | Part::Lower => [x, x],
            };
            let out = [
                &mut r[run.clone()],
                &mut g[run.clone()],
                &mut b[run.clone()],
                &mut a[run.clone()],
            ];
            lanes(env.table, (x, y, z), read, out, shade);
        }
    }
}

/// A quarter-resolution row (one channel) widened to the half pass's
/// `out.len()` pixels: each pixel's bilinear sample across at its centre
/// ([`tap`]), `q[c0] + (q[c1] − q[c0])·wx`. Inside the row a pixel `2m`
/// samples texels `m − 1` and `m` at ¾, a pixel `2m + 1` texels `m` and
/// `m + 1` at ¼ (what `tap` gives, exactly), so that loop runs without a
/// tap per pixel; the edges take [`tap`]'s clamps.
#[inline(always)]
pub(super) fn widen(q: &[f32], out: &mut [f32]) {
    let Some(last) = q.len().checked_sub(1) else {
        out.fill(0.0);
        return;
    };
    // The pixels 2 ≤ i < 2·last, in pairs (the pass's last pixel may lie
    // past them, on its own).
    let n = out.len();
    let start = n.min(2);
    let end = ((2 * last).min(n) & !1).max(start);
    for (pair, t) in out[start..end].chunks_exact_mut(2).zip(q.windows(3)) {
        pair[0] = t[0] + (t[1] - t[0]) * 0.75;
        pair[1] = t[1] + (t[2] - t[1]) * 0.25;
    }
    for i in (0..start).chain(end..n) {
        let (c0, c1, wx) = tap(i, last);
        out[i] = q[c0] + (q[c1] - q[c0]) * wx;
    }
}

/// Where half-resolution pixel `i` samples the quarter pass along one
/// axis: its two texels (clamped to `last`) and the second's weight. The
/// pixel's centre, `(i + ½)·2` full-resolution pixels, is texel `i/2 − ¼`.
#[inline(always)]
fn tap(i: usize, last: usize) -> (usize, usize, f32) {
    let t = i as f32 * 0.5 - 0.25;
    let t0 = t.floor();
    let c0 = (t0.max(0.0) as usize).min(last);
    let c1 = ((t0 + 1.0).max(0.0) as usize).min(last);
    (c0, c1, t - t0)
}

#[inline(always)]
fn opaque(c: Vec3) -> [f32; 4] {
    [c.x, c.y, c.z, 1.0]
}

/// `shade` over rays `(x, y, z)` and per-pixel `inputs` (all of one
/// length) into `out`, in the build of the widest SIMD level this process runs.
#[inline(always)]
fn lanes(
    table: &Table,
    (x, y, z): (&[f32], &[f32], &[f32]),
    [i0, i1]: [&[f32]; 2],
    [r, g, b, a]: [&mut [f32]; 4],
    shade: impl Fn(Vec3, [f32; 2], &Table, [f32; 4]) -> [f32; 4],
) {
    #[cfg(target_arch = "x86_64")]
    match crate::simd::simd_level() {
        // SAFETY: the CPU has these features (checked by `simd_level`).
        #[allow(unsafe_code)]
        2 => return unsafe { lanes_avx512(x, y, z, i0, i1, table, r, g, b, a, shade) },
        // SAFETY: the CPU has AVX2 (checked by `simd_level`).
        #[allow(unsafe_code)]
        1 => return unsafe { lanes_avx2(x, y, z, i0, i1, table, r, g, b, a, shade) },
        _ => {}
    }
    lanes_base(x, y, z, i0, i1, table, r, g, b, a, shade)
}

/// [`lanes`]' loop over slices of one length, built for each SIMD level in
/// a function of its own that is never inlined: its slice arguments keep
/// their no-alias marks, so the loop vectorises (the haze table's gathers
/// included) without checks at run time.
macro_rules! lanes {
    ($name:ident $(, $features:literal)?) => {
        #[allow(clippy::too_many_arguments, reason = "separate slices keep their no-alias marks")]
        #[inline(never)]
        $(#[target_feature(enable = $features)])?
        fn $name(
            x: &[f32],
            y: &[f32],
            z: &[f32],
            i0: &[f32],
            i1: &[f32],
            table: &Table,
            r: &mut [f32],
            g: &mut [f32],
            b: &mut [f32],
            a: &mut [f32],
            shade: impl Fn(Vec3, [f32; 2], &Table, [f32; 4]) -> [f32; 4],
        ) {
            let n = x.len();
            let (y, z, i0, i1) = (&y[..n], &z[..n], &i0[..n], &i1[..n]);
            let (r, g, b, a) = (&mut r[..n], &mut g[..n], &mut b[..n], &mut a[..n]);
            for k in 0..n {
                let was = [r[k], g[k], b[k], a[k]];
                let c = shade(Vec3::new(x[k], y[k], z[k]), [i0[k], i1[k]], table, was);
                (r[k], g[k], b[k], a[k]) = (c[0], c[1], c[2], c[3]);
            }
        }
    };
}

lanes!(lanes_base);
#[cfg(target_arch = "x86_64")]
lanes!(lanes_avx2, "avx2");
#[cfg(target_arch = "x86_64")]
lanes!(lanes_avx512, "avx512f,avx512bw,avx512dq,avx512vl");

/// The heights of silhouette `kind` (`height` rad high) at rays `(x, z)`
/// into `out`, one loop per kind.
#[inline(always)]
fn silhouettes(
    kind: Silhouette,
    height: f32,
    seed: Vec2,
    (x, z): (&[f32], &[f32]),
    out: &mut [f32],
) {
    #[inline(always)]
    fn fill(out: &mut [f32], x: &[f32], z: &[f32], f: impl Fn(Vec2) -> f32) {
        let n = out.len();
        let (x, z) = (&x[..n], &z[..n]);
        for k in 0..n {
            out[k] = f(azimuth(Vec3::new(x[k], 0.0, z[k])));
        }
    }
    let at = |kind| {
        #[inline(always)]
        move |c| silhouette_height(kind, height, c, seed)
    };
    match kind {
        Silhouette::None => out.fill(-1.0),
        Silhouette::Hills => fill(out, x, z, at(Silhouette::Hills)),
        Silhouette::Mountains => fill(out, x, z, at(Silhouette::Mountains)),
        Silhouette::Skyline => fill(out, x, z, at(Silhouette::Skyline)),
        Silhouette::TreeLine => fill(out, x, z, at(Silhouette::TreeLine)),
    }
}

/// `azimuth`: the unit xz direction of the ray's azimuth.
#[inline(always)]
fn azimuth(dir: Vec3) -> Vec2 {
    let c = Vec2::new(dir.x + 1e-6, dir.z);
    c * (1.0 / c.dot(c).sqrt())
}

/// WGSL's `mix`: `a·(1 − t) + b·t`.
#[inline(always)]
fn mix(a: Vec3, b: Vec3, t: f32) -> Vec3 {
    a * (1.0 - t) + b * t
}

#[inline(always)]
fn mix1(a: f32, b: f32, t: f32) -> f32 {
    a * (1.0 - t) + b * t
}

#[inline(always)]
fn tone_map(x: Vec3) -> Vec3 {
    Vec3::new(1.0 - exp(-x.x), 1.0 - exp(-x.y), 1.0 - exp(-x.z))
}

/// `yxy_to_rgb`: CIE Yxy to linear sRGB, clamped at 0.
#[inline(always)]
fn yxy_to_rgb(yxy: Vec3) -> Vec3 {
    let (y, cx) = (yxy.x, yxy.y);
    let cy = yxy.z.max(1e-4);
    let x = cx / cy * y;
    let z = (1.0 - cx - cy) / cy * y;
    Vec3::new(
        3.2406 * x - 1.5372 * y - 0.4986 * z,
        -0.9689 * x + 1.8758 * y + 0.0415 * z,
        0.0557 * x - 0.2040 * y + 1.0570 * z,
    )
    .max(Vec3::ZERO)
}

/// x³⁰⁰ by squaring (x in [0, 1]).
#[inline(always)]
fn pow300(x: f32) -> f32 {
    let x2 = x * x;
    let x4 = x2 * x2;
    let x8 = x4 * x4;
    let x16 = x8 * x8;
    let x32 = x16 * x16;
    let x64 = x32 * x32;
    let x128 = x64 * x64;
    let x256 = x128 * x128;
    x256 * x32 * x8 * x4
}

#[cfg(test)]
mod tests {
    use super::{HIDDEN_RUN, Part, Procedural, Row, opaque};
    use super::{tap, widen};
    use crate::render::sky::uniforms::EnvUniforms;
    use crate::sky::{EnvironmentName, FrameEnvironment};
    use glam::Vec3;

    /// The band shaded with its hidden runs split off ([`Row::split_hidden`])
    /// is, bit for bit, the band shaded whole over the sky behind it (the
    /// planes' values, with the sun disc): every environment with
    /// silhouettes, with and without clouds, over rows that cross their
    /// tops at many slopes; and some runs were hidden.
    #[test]
    fn the_band_without_its_hidden_sky_is_the_whole_band() {
        let (w, mut hidden) = (480usize, 0usize);
        for (n, name) in EnvironmentName::ALL.into_iter().enumerate() {
            for cover in [0.0, 0.7] {
                let frame = FrameEnvironment {
                    choice: 0,
                    sun_elevation_deg: 25.0,
                    sun_azimuth_deg: 40.0 * n as f64,
                    azimuth_offset_deg: 0.0,
                    cloud_cover: cover,
                    turbidity: 3.0,
                    pattern_seed: 7 + n as u32,
                    exposure_offset_ev: 0.0,
                    sun_offset_ev: 0.0,
                };
                let sun = Vec3::new(0.6, 0.42, 0.68).normalize();
                let (u, _) = EnvUniforms::procedural(name, (1.0, 1.0), &frame, sun, None);
                let env = Procedural::new(&u, sun);
                if env.upper_line() <= 0.0 {
                    continue;
                }
                for tilt in [0.002f32, 0.01, 0.03, 0.06] {
                    let mut row = Row::new(w);
                    let (x, y, z) = row.rays_mut();
                    for k in 0..w {
                        let az = k as f32 * 0.013 + n as f32;
                        (x[k], y[k], z[k]) =
                            (az.cos(), tilt * k as f32 / w as f32 * 6.0 - 0.01, az.sin());
                    }
                    row.normalise();
                    let upper = env.upper_line();
                    row.split(|y| Part::of_half(y, (f32::NEG_INFINITY, upper)));
                    let band: Vec<usize> = row.runs[Part::Band as usize]
                        .iter()
                        .flat_map(|r| r.clone())
                        .collect();
                    // A sky behind the band (RGB and the sun's share), as the
                    // quarter pass's blended down would be.
                    let sky = |k: usize, c: usize| ((k * 7 + c * 3) % 11) as f32 * 0.09;
                    let mut planes: [Vec<f32>; 4] =
                        std::array::from_fn(|c| (0..w).map(|k| sky(k, c)).collect());
                    row.band(&env, planes.each_mut().map(|p| &mut p[..]));
                    hidden += row.hidden.iter().map(|r| r.len()).sum::<usize>();
                    assert!(row.hidden.iter().all(|r| r.len() >= HIDDEN_RUN));
                    for k in band {
                        let d = Vec3::new(row.x[k], row.y[k], row.z[k]);
                        let h = (row.heights[0][k], row.heights[1][k]);
                        let behind = Vec3::new(sky(k, 0), sky(k, 1), sky(k, 2))
                            + env.sun_disc(d) * sky(k, 3);
                        let want = opaque(env.band_over(env.table, d, h, behind));
                        let got = planes.each_ref().map(|p| p[k]);
                        assert_eq!(
                            got.map(f32::to_bits),
                            want.map(f32::to_bits),
                            "{name:?}, cover {cover}, pixel {k}"
                        );
                    }
                }
            }
        }
        assert!(hidden > 1000, "{hidden} hidden pixels");
    }

    /// A row's runs ([`Row::split`]) are its pixels' parts, one by one:
    /// rows of every length around the chunk, with parts that change
    /// inside a chunk, at its edges, on every pixel, never, and at NaN.
    #[test]
    fn a_rows_runs_are_its_pixels_parts() {
        let lines = (-0.05, 0.3);
        let shapes: [fn(usize) -> f32; 5] = [
            |i| (i as f32 - 70.0) * 0.01,
            |i| if i % 2 == 0 { -0.1 } else { 0.5 },
            |i| if i / 64 % 2 == 0 { 0.1 } else { 0.9 },
            |i| if i == 100 { f32::NAN } else { 0.2 },
            |_| 0.7,
        ];
        for w in [1, 2, 63, 64, 65, 130, 200] {
            for shape in shapes {
                let mut row = Row::new(w);
                let ys: Vec<f32> = (0..w).map(shape).collect();
                row.rays_mut().1.copy_from_slice(&ys);
                row.split(|y| Part::of_half(y, lines));
                let mut part = vec![None; w];
                for (p, runs) in row.runs.iter().enumerate() {
                    for window in runs.windows(2) {
                        assert!(window[0].end < window[1].start, "runs apart and in order");
                    }
                    for i in runs.iter().flat_map(Clone::clone) {
                        assert_eq!(part[i].replace(p), None, "pixel {i} in two runs");
                    }
                }
                for (i, y) in ys.iter().enumerate() {
                    let want = Part::of_half(*y, lines) as usize;
                    assert_eq!(part[i], Some(want), "w {w}, pixel {i}, y {y}");
                }
            }
        }
    }

    /// `widen` gives, bit for bit, each pixel's sample at its own [`tap`]
    /// (the edges' clamps included), over rows of any length, with values
    /// that are not numbers or not finite among them.
    #[test]
    fn a_widened_row_is_each_pixels_own_sample() {
        for qw in [1usize, 2, 3, 4, 7, 480] {
            let q: Vec<f32> = (0..qw)
                .map(|c| match c % 7 {
                    3 => f32::NAN,
                    5 => f32::INFINITY,
                    _ => (c as f32 * 0.37).sin() * 3.0,
                })
                .collect();
            for n in [1, 2, 3, 2 * qw - 1, 2 * qw, 2 * qw + 1, 2 * qw + 4] {
                let mut got = vec![-7.0; n];
                widen(&q, &mut got);
                for (i, got) in got.iter().enumerate() {
                    let (c0, c1, wx) = tap(i, qw - 1);
                    let want = q[c0] + (q[c1] - q[c0]) * wx;
                    // Bit for bit, but for which not-a-number.
                    let same = got.to_bits() == want.to_bits() || (got.is_nan() && want.is_nan());
                    assert!(
                        same,
                        "{qw} texels, {n} pixels, pixel {i}: {got} against {want}"
                    );
                }
            }
        }
        let mut out = vec![5.0; 3];
        widen(&[], &mut out);
        assert_eq!(out, [0.0; 3]);
    }
}
