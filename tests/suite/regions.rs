//! Region rendering equals full-frame rendering: every pixel within one 8-bit
//! level of the frame drawn whole, and of the full-frame path (`render_rgba`:
//! the whole sky redrawn, the hardware resolve) over a sky it draws alike
//! (a sky pass shaded at a reduced size is interpolated there by the GPU's
//! sampler in light, by the frame path in sRGB levels: within their measured
//! difference), and visibility identical to a reduction over the whole
//! frame. Over a gradient sky, a procedural environment, an image sky, MSAA
//! 1× and 4×, drones cut by the image border and by the near plane, and no
//! drones; the background is drawn once for frames that share it, and a
//! sky drawn over the last one (not cleared first) leaves nothing of it.

use crate::common;

use glam::DVec3;
use swarmshot::pipeline::FramePipeline;
use swarmshot::preset::sweep::SweepRange;
use swarmshot::preset::{Placement, Preset, Resolution, Sky, SkyImageSource, Volume};
use swarmshot::render::{RenderRequest, Renderer};
use swarmshot::scene::FrameScene;

/// The frame's colour alone, with MSAA 4 (the sky and background tests).
const COLOUR_MSAA4: RenderRequest = RenderRequest {
    msaa: 4,
    color: true,
    visibility: false,
};

fn preset(sky: Sky, msaa: u32) -> Preset {
    let mut p = Preset::default();
    p.seed = 5;
    p.render.resolution = Resolution::Custom {
        width: 400,
        height: 240,
    };
    p.render.msaa = msaa;
    p.placement = Placement::Randomized {
        count: (8, 14),
        count_distribution: Default::default(),
        // Wider than the view: some drones are cut by the border.
        volume: Volume::Box {
            size_m: (14.0, 5.0, 8.0),
        },
        min_separation_m: 0.5,
    };
    p.camera.z = SweepRange::fixed(0.35);
    p.repeats = 3;
    p.sky = sky;
    p
}

/// An equirect sky image written to a temporary folder (no third-party file needed).
fn image_sky(dir: &std::path::Path) -> Sky {
    let (w, h) = (256u32, 128u32);
    let img = image::RgbImage::from_fn(w, h, |x, y| {
        let v = (y * 255 / h) as u8;
        image::Rgb([v, (x * 255 / w) as u8, 255 - v / 2])
    });
    let path = dir.join("sky.png");
    img.save(&path).expect("write sky image");
    Sky::Image {
        source: SkyImageSource::Equirect(path),
        exposure_ev: 0.0,
        rotation_deg: 30.0,
        sun_elevation_deg: 40.0,
        sun_azimuth_deg: 10.0,
    }
}

/// How far two frames may differ: the greatest difference of a value and
/// the mean difference, in 8-bit levels.
#[derive(Clone, Copy)]
struct Tolerance {
    worst: u8,
    mean: f64,
}

/// Frames drawn alike: one level at most (rounding and the resolve).
const ALIKE: Tolerance = Tolerance {
    worst: 1,
    mean: 1.0,
};

/// A sky pass at a reduced size interpolated in light against in levels:
/// they differ where the pass has sharp edges (its own error against every
/// pixel is up to 60 levels there, 0.5 on average: docs/environments.md,
/// "How far the upsampling lies from every pixel").
const INTERPOLATED: Tolerance = Tolerance {
    worst: 64,
    mean: 0.5,
};

fn assert_close(a: &[u8], b: &[u8], what: &str, tolerance: Tolerance) {
    assert_eq!(a.len(), b.len(), "{what}");
    let diffs = || a.iter().zip(b).map(|(x, y)| x.abs_diff(*y));
    let worst = diffs().max().unwrap_or(0);
    let mean = diffs().map(f64::from).sum::<f64>() / a.len().max(1) as f64;
    assert!(
        worst <= tolerance.worst && mean <= tolerance.mean,
        "{what}: a pixel differs by {worst} levels, {mean:.3} on average"
    );
}

fn check(
    renderer: &mut Renderer,
    scene: &FrameScene,
    msaa: u32,
    (what, full_path): (&str, Tolerance),
) {
    let request = RenderRequest {
        msaa,
        color: true,
        visibility: true,
    };
    let regions = renderer.render_frame(scene, &request).expect("regions");
    let full = renderer.render_rgba(scene, msaa).expect("full frame");
    assert_close(&regions.rgba, &full, what, full_path);
    renderer.set_regions(false);
    let whole = renderer.render_frame(scene, &request).expect("whole frame");
    renderer.set_regions(true);
    assert_close(&whole.rgba, &full, what, full_path);
    assert_close(&regions.rgba, &whole.rgba, what, ALIKE);
    assert_eq!(regions.visibility, whole.visibility, "{what}: visibility");
}

#[test]
fn regions_equal_full_frames_over_skies_msaa_and_edges() {
    let ctx = common::gpu();
    let dir = tempfile::tempdir().expect("tempdir");
    let skies = [
        ("gradient", Preset::default().sky, ALIKE),
        ("procedural", common::procedural_sky(), INTERPOLATED),
        ("image", image_sky(dir.path()), INTERPOLATED),
    ];
    let (mut truncated, mut drones) = (0, 0);
    for (name, sky, full_path) in skies {
        for msaa in [1, 4] {
            let pipeline = FramePipeline::new(preset(sky.clone(), msaa)).expect("preset");
            let mut renderer = pipeline.renderer(&ctx);
            for index in 0..pipeline.frame_count() {
                let scene = pipeline.scene(index).expect("scene");
                let labels = pipeline.estimate_labels(&scene);
                truncated += labels.iter().filter(|l| l.truncated).count();
                drones += scene.drones.len();
                check(
                    &mut renderer,
                    &scene,
                    msaa,
                    (&format!("{name}, msaa {msaa}, frame {index}"), full_path),
                );
            }
            // No drones: the background alone.
            let mut empty = pipeline.scene(0).expect("scene");
            empty.drones.clear();
            check(
                &mut renderer,
                &empty,
                msaa,
                (&format!("{name}, msaa {msaa}, no drones"), full_path),
            );
            // A drone crossing the near plane, filling much of the frame.
            let mut close = pipeline.scene(1).expect("scene");
            close.drones.truncate(1);
            let forward = close.camera.camera_from_world.transpose() * DVec3::Z;
            close.drones[0].position = close.camera.position + forward * close.camera.near_m * 1.5;
            close.drones[0].size_m = 1.0;
            check(
                &mut renderer,
                &close,
                msaa,
                (&format!("{name}, msaa {msaa}, near plane"), full_path),
            );
        }
    }
    assert!(
        drones > 40 && truncated > 3,
        "{drones} drones, {truncated} truncated"
    );
}

#[test]
fn frames_that_share_a_camera_pose_draw_the_background_once() {
    let ctx = common::gpu();
    let pipeline = FramePipeline::new(preset(Preset::default().sky, 4)).expect("preset");
    let mut renderer = pipeline.renderer(&ctx);
    let request = COLOUR_MSAA4;
    // repeats = 3: frames 0..3 share the camera pose and the sky.
    for index in 0..3 {
        let scene = pipeline.scene(index).expect("scene");
        renderer.render_frame(&scene, &request).expect("render");
    }
    assert_eq!(renderer.background_draws(), 1);
    let mut turned = pipeline.scene(0).expect("scene");
    turned.camera.fov_y_deg += 1.0;
    renderer.render_frame(&turned, &request).expect("render");
    assert_eq!(
        renderer.background_draws(),
        2,
        "another fov is another background"
    );
}

/// The sky passes draw over their last frame's texels without clearing
/// them (one full-screen triangle writes every one): frames of a moving
/// camera, gradient or image sky, each equal the frame a fresh renderer
/// makes alone. (A sky shader that discarded texels where the view turned
/// away, as the camera sweeps, fails this; checked by hand.)
#[test]
fn sky_passes_drawn_over_the_last_frame_leave_nothing_of_it() {
    let ctx = common::gpu();
    let dir = tempfile::tempdir().expect("tempdir");
    let request = COLOUR_MSAA4;
    for sky in [Preset::default().sky, image_sky(dir.path())] {
        let mut p = preset(sky, 4);
        p.repeats = 1;
        p.camera.x = SweepRange::new(-0.6, 0.6, 0.4); // four poses, a new sky each
        let pipeline = FramePipeline::new(p).expect("preset");
        let mut after_others = pipeline.renderer(&ctx);
        for index in 0..pipeline.frame_count() {
            let scene = pipeline.scene(index).expect("scene");
            let got = after_others.render_frame(&scene, &request).expect("render");
            let alone = (pipeline.renderer(&ctx))
                .render_frame(&scene, &request)
                .expect("render");
            assert!(got.rgba == alone.rgba, "frame {index}");
        }
        assert_eq!(after_others.background_draws(), pipeline.frame_count());
    }
}

/// A frame buffer handed back to the renderer is reused: over the same
/// background only the rects the previous frame painted are restored, over
/// any other background (another pose, another renderer's) it is copied
/// whole. Either way each frame equals the same frame made in a fresh buffer.
#[test]
fn recycled_frame_buffers_make_the_same_frames() {
    let ctx = common::gpu();
    let mut p = preset(Preset::default().sky, 4);
    p.camera.y = SweepRange::new(-0.2, 0.2, 0.2); // three poses, 9 frames
    let pipeline = FramePipeline::new(p).expect("preset");
    let request = RenderRequest {
        msaa: 4,
        color: true,
        visibility: true,
    };
    let mut fresh = pipeline.renderer(&ctx);
    let mut reusing = pipeline.renderer(&ctx);
    let mut other = pipeline.renderer(&ctx);
    // repeats = 3: frames 0..3 share a camera pose, 3..6 the next one.
    for index in 0..6 {
        let scene = pipeline.scene(index).expect("scene");
        let expected = fresh.render_frame(&scene, &request).expect("render");
        let got = reusing.render_frame(&scene, &request).expect("render");
        assert_eq!(got.rgba, expected.rgba, "frame {index}");
        assert_eq!(got.visibility, expected.visibility, "frame {index}");
        if index % 2 == 0 {
            reusing.recycle(got.rgba, got.painted);
        } else {
            // Another renderer's frame over another background (a wider
            // view), with its own drones painted: it must not pass for ours.
            let mut wide = pipeline.scene(index + 1).expect("scene");
            wide.camera.fov_y_deg += 10.0;
            let foreign = other.render_frame(&wide, &request).expect("render");
            assert_ne!(foreign.rgba, got.rgba);
            reusing.recycle(foreign.rgba, foreign.painted);
        }
    }
    assert_eq!(reusing.background_draws(), 2);
}

/// A frame may take its background's pixels instead of a copy
/// (`set_lend_backgrounds`) when the background was drawn for it and the
/// frame before drew its own too: the same frames as copies, over recycled
/// buffers too, and the renderer then holds no background for that frame.
/// A camera that stops after moving draws its background once more (the
/// frame after a lent one), not on every frame.
#[test]
fn frames_that_take_their_backgrounds_pixels_are_the_frames_copied() {
    let ctx = common::gpu();
    let pipeline = FramePipeline::new(preset(Preset::default().sky, 4)).expect("preset");
    let mut copying = pipeline.renderer(&ctx);
    let mut lending = pipeline.renderer(&ctx);
    lending.set_lend_backgrounds(true);
    // Frames 0..4 widen the view frame by frame (a new background each),
    // then it stays: frames 4..8 share one background.
    for index in 0..8 {
        let mut scene = pipeline.scene(0).expect("scene");
        scene.camera.fov_y_deg = 40.0 + index.min(4) as f64;
        let want = copying.render_frame(&scene, &COLOUR_MSAA4).expect("render");
        let got = lending.render_frame(&scene, &COLOUR_MSAA4).expect("render");
        assert!(got.rgba == want.rgba, "frame {index}");
        assert!(copying.background_pixels(&want.painted).is_some());
        // Lent from the second new background in a row: frames 1..=4.
        let lent = (1..=4).contains(&index);
        assert_eq!(
            lending.background_pixels(&got.painted).is_none(),
            lent,
            "frame {index}"
        );
        copying.recycle(want.rgba, want.painted);
        lending.recycle(got.rgba, got.painted);
    }
    assert_eq!(copying.background_draws(), 5);
    assert_eq!(lending.background_draws(), 6);
}

/// An equirect `.hdr` of `w`×`h` texels whose value falls linearly with the
/// polar angle: texel row r holds 0.2 + 1.6 · (r + ½) / h in every channel,
/// so the image's bilinear interpolation is the same function of the view
/// direction at any size (written to `dir`).
fn ramp_sky(dir: &std::path::Path, (w, h): (u32, u32)) -> Sky {
    let rgb: Vec<image::Rgb<f32>> = (0..h)
        .flat_map(|r| {
            let v = 0.2 + 1.6 * (r as f32 + 0.5) / h as f32;
            (0..w).map(move |_| image::Rgb([v, v, v]))
        })
        .collect();
    let path = dir.join(format!("ramp_{w}x{h}.hdr"));
    let file = std::io::BufWriter::new(std::fs::File::create(&path).expect("create"));
    image::codecs::hdr::HdrEncoder::new(file)
        .encode(&rgb, w as usize, h as usize)
        .expect("write hdr");
    Sky::Image {
        source: SkyImageSource::Equirect(path),
        exposure_ev: 0.0,
        rotation_deg: 0.0,
        sun_elevation_deg: 40.0,
        sun_azimuth_deg: 0.0,
    }
}

/// A sky image magnified enough is drawn at reduced resolution and
/// upsampled on the CPU (render/sky.rs `image_scale`: a 64×32 image at
/// 400×240 and 60° spans 20 pixels a texel, so a quarter of the
/// resolution); a 1024×512 one (1.3 pixels a texel) at full resolution.
/// Over a linear ramp both show the same function of the view direction,
/// so the two frames must agree within the f16 and tone-map roundings
/// (measured: at most 1 level, mean 0.06; a pass drawn 10 % off scale
/// gives mean 0.63, worst 2).
#[test]
fn a_reduced_image_sky_shows_what_the_full_resolution_one_shows() {
    let ctx = common::gpu();
    let dir = tempfile::tempdir().expect("tempdir");
    let request = COLOUR_MSAA4;
    let frame = |sky: Sky| {
        let mut p = preset(sky, 4);
        p.camera.fov_y_deg = 60.0;
        p.camera.y = SweepRange::fixed(0.3);
        let pipeline = FramePipeline::new(p).expect("preset");
        let mut renderer = pipeline.renderer(&ctx);
        let mut scene = pipeline.scene(0).expect("scene");
        scene.drones.clear();
        renderer
            .render_frame(&scene, &request)
            .expect("render")
            .rgba
    };
    let reduced = frame(ramp_sky(dir.path(), (64, 32)));
    let full = frame(ramp_sky(dir.path(), (1024, 512)));
    let diffs: Vec<u8> = reduced
        .iter()
        .zip(&full)
        .map(|(a, b)| a.abs_diff(*b))
        .collect();
    let worst = diffs.iter().copied().max().unwrap_or(0);
    let mean = diffs.iter().map(|&d| f64::from(d)).sum::<f64>() / diffs.len() as f64;
    assert!(
        worst <= 1 && mean < 0.2,
        "worst {worst} levels, mean {mean:.3}"
    );
    // The ramp is visible: the frame is not one flat value.
    let (top, bottom) = (full[4 * 200], full[full.len() - 4 * 200]);
    assert!(top.abs_diff(bottom) > 20, "top {top}, bottom {bottom}");
}
