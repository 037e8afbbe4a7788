//! How far a frame's upsampled background lies from the same sky shaded at
//! every pixel: the reduced passes (the procedural environment at half
//! resolution, an HDR image sky at a quarter) upsampled as a frame's are
//! (`render/upsample.rs`: each texel encoded, the levels interpolated),
//! against the pass shaded at the frame's own resolution and encoded.

use glam::{Mat3, Vec3};

use super::equirect::{self, Equirect, ReducedView};
use super::procedural::{self, Passes, Procedural, View};
use super::uniforms::EnvUniforms;
use crate::render::upsample::{Texels, Tone, encode_source, upsample_reduced};
use crate::sky::{EnvironmentName, FrameEnvironment};

/// The frame the skies are compared at, and the camera's focal length.
const FRAME: (u32, u32) = (960, 540);
const FOCAL: f32 = 830.0;

/// A camera pitched `pitch` radians up, yawed `yaw` about the vertical.
fn rotation(pitch: f32, yaw: f32) -> Mat3 {
    let (forward, down) = (
        Vec3::new(0.0, pitch.sin(), pitch.cos()),
        Vec3::new(0.0, -pitch.cos(), pitch.sin()),
    );
    Mat3::from_rotation_y(yaw) * Mat3::from_cols(Vec3::X, down, forward)
}

/// Mean and greatest per-channel difference in levels of `a` and `b` (RGBA8).
fn error(a: &[u8], b: &[u8]) -> (f64, u8) {
    let diffs = a
        .chunks_exact(4)
        .zip(b.chunks_exact(4))
        .flat_map(|(p, q)| (0..3).map(move |c| p[c].abs_diff(q[c])));
    let (sum, n, max) = diffs.fold((0u64, 0u64, 0u8), |(s, n, m), d| {
        (s + u64::from(d), n + 1, m.max(d))
    });
    (sum as f64 / n as f64, max)
}

/// `planes` (`size` texels) interpolated bilinearly in linear light to the
/// frame (centred, exact weights in `f32`): how the upsampling blended
/// before it interpolated levels.
fn linear(planes: &[Vec<f32>; 3], size: (u32, u32)) -> [Vec<f32>; 3] {
    let taps = |out: u32, source: u32| -> Vec<(usize, usize, f32)> {
        (0..out)
            .map(|i| {
                let t = (i as f32 + 0.5) / out as f32 * source as f32 - 0.5;
                let (base, last) = (t.floor(), source as usize - 1);
                let clamp = |v: f32| (v.max(0.0) as usize).min(last);
                (clamp(base), clamp(base + 1.0), t - base)
            })
            .collect()
    };
    let (columns, rows) = (taps(FRAME.0, size.0), taps(FRAME.1, size.1));
    let w = size.0 as usize;
    planes.each_ref().map(|p| {
        let at = |x: usize, y: usize| p[y * w + x];
        rows.iter()
            .flat_map(|&(r0, r1, wy)| {
                columns.iter().map(move |&(c0, c1, wx)| {
                    let top = at(c0, r0) + (at(c1, r0) - at(c0, r0)) * wx;
                    let bottom = at(c0, r1) + (at(c1, r1) - at(c0, r1)) * wx;
                    top + (bottom - top) * wy
                })
            })
            .collect()
    })
}

/// `reduced` (planes of `size` texels) upsampled to the frame through
/// `tone`, and interpolated in linear light ([`linear`]), each against
/// `full` (planes of the frame's size) encoded: the mean and greatest
/// difference in levels of each, printed after `what`.
fn compare(
    (reduced, size): (&[Vec<f32>; 3], (u32, u32)),
    full: &[Vec<f32>; 3],
    tone: Tone,
    what: &str,
) -> [(f64, u8); 2] {
    let centre = (FRAME.0 as f32 / 2.0, FRAME.1 as f32 / 2.0);
    let (mut levels, mut up, mut truth, mut lin) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let texels = Texels::Planes(reduced);
    upsample_reduced(
        texels,
        size,
        (FRAME, centre),
        (tone, 1.0),
        &mut levels,
        &mut up,
    );
    let frame = (FRAME.0 as usize, FRAME.1 as usize);
    encode_source(&Texels::Planes(full), frame, (tone, 1.0), &mut truth);
    let blended = linear(reduced, size);
    encode_source(&Texels::Planes(&blended), frame, (tone, 1.0), &mut lin);
    let errors = [error(&up, &truth), error(&lin, &truth)];
    eprintln!(
        "{what}: levels interpolated {:?}, light {:?}",
        errors[0], errors[1]
    );
    errors
}

/// The worst of `errors` (each method's mean and greatest difference per
/// view): the levels' mean below one level and within 1.25× the light's.
fn assert_near(errors: &[[(f64, u8); 2]]) {
    let [levels, light] = [0, 1].map(|k| {
        errors
            .iter()
            .fold((0.0f64, 0u8), |(m, x), e| (m.max(e[k].0), x.max(e[k].1)))
    });
    assert!(
        levels.0 < 1.0 && levels.0 < light.0 * 1.25,
        "{levels:?} against {light:?}"
    );
}

#[test]
fn an_upsampled_environment_stays_within_a_level_of_its_full_resolution() {
    let mut passes = Passes::default();
    let (mut half, mut full) = (Default::default(), Default::default());
    let mut errors = Vec::new();
    for (n, name) in EnvironmentName::ALL.into_iter().enumerate() {
        let frame = FrameEnvironment {
            choice: 0,
            sun_elevation_deg: 20.0,
            sun_azimuth_deg: 30.0 * n as f64,
            azimuth_offset_deg: 0.0,
            cloud_cover: 0.5,
            turbidity: 3.0,
            pattern_seed: 11 + n as u32,
            exposure_offset_ev: 0.0,
            sun_offset_ev: 0.0,
        };
        let sun = Vec3::new(0.5, 0.35, 0.79).normalize();
        let (u, _) = EnvUniforms::procedural(name, (1.0, 1.0), &frame, sun, None);
        let env = Procedural::new(&u, sun);
        let (cx, cy) = (FRAME.0 as f32 / 2.0, FRAME.1 as f32 / 2.0);
        let view = |k: f32| View {
            world_from_camera: rotation(0.05, 0.4 * n as f32),
            intrinsics: [FOCAL * k, FOCAL * k, cx * k, cy * k],
        };
        let size = procedural::shade(&env, &view(1.0), FRAME, &mut passes, &mut half);
        // A frame twice as large: its half-resolution pass is this frame's pixels.
        let double = (FRAME.0 * 2, FRAME.1 * 2);
        // Its ground shaded at every pixel (its sky still at its quarter:
        // this frame's half).
        procedural::EVERY_GROUND_PIXEL.set(true);
        let reference = procedural::shade(&env, &view(2.0), double, &mut passes, &mut full);
        procedural::EVERY_GROUND_PIXEL.set(false);
        assert_eq!(reference, FRAME);
        errors.push(compare(
            (&half, size),
            &full,
            Tone::Clip,
            &format!("{name:?}"),
        ));
    }
    assert_near(&errors);
}

#[test]
fn an_upsampled_hdr_sky_stays_within_a_level_of_its_full_resolution() {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/data/sky/polyhaven_cc0/venice_sunset_1k.hdr"
    );
    let source = crate::preset::SkyImageSource::Equirect(path.into());
    let sky = crate::sky::load_sky_image(&source).expect("the test sky loads");
    let crate::sky::SkyImageKind::Equirect { width, height, rgb } = &sky.kind else {
        panic!("an equirectangular sky");
    };
    let image = || Equirect {
        rgb,
        width: *width,
        height: *height,
    };
    let (cx, cy) = (FRAME.0 as f32 / 2.0, FRAME.1 as f32 / 2.0);
    let (mut reduced, mut full) = (Default::default(), Default::default());
    let mut errors = Vec::new();
    // Toward the sun and its glow, along the horizon, and up.
    for (pitch, yaw) in [(0.2, 1.1), (0.05, 2.5), (0.6, 4.0)] {
        let view = |scale: u32| ReducedView {
            world_from_camera: rotation(pitch, yaw),
            intrinsics: [FOCAL, FOCAL, cx, cy],
            scale: scale as f32,
            rotation: 0.0,
            exposure: 1.0,
        };
        equirect::shade(image(), &view(1), FRAME, &mut full);
        for scale in [2, 4] {
            let size = (FRAME.0 / scale, FRAME.1 / scale);
            equirect::shade(image(), &view(scale), size, &mut reduced);
            let what = format!("pitch {pitch}, yaw {yaw}, {scale}×");
            errors.push(compare((&reduced, size), &full, Tone::Exponential, &what));
        }
    }
    assert_near(&errors);
}
