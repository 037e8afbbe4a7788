//! Unit tests of the sky's reduced-resolution choice.
use super::image::reduced_scale;

/// The focal length (pixels) of a `height`-pixel frame with a vertical field of view of `fov_deg`.
fn focal(height: u32, fov_deg: f32) -> f32 {
    height as f32 / 2.0 / (fov_deg.to_radians() / 2.0).tan()
}

#[test]
fn images_are_drawn_reduced_only_where_a_pass_pixel_spans_at_most_half_a_texel() {
    let hd = (1920, 1080);
    let centre = (960.0, 540.0);
    // A 1024×512 sky at 40°: a texel spans 9.1 of the frame's pixels.
    assert_eq!(
        reduced_scale((1024, 512), hd, focal(1080, 40.0), centre),
        Some(4)
    );
    // At 60° it spans 5.7: 4 would leave less than two pass pixels a texel.
    assert_eq!(
        reduced_scale((1024, 512), hd, focal(1080, 60.0), centre),
        Some(2)
    );
    // 2048×1024 at 60° (2.9) and 4096×2048 at 40° (2.3): full resolution.
    assert_eq!(
        reduced_scale((2048, 1024), hd, focal(1080, 60.0), centre),
        None
    );
    assert_eq!(
        reduced_scale((4096, 2048), hd, focal(1080, 40.0), centre),
        None
    );
    // A wide image is judged by its narrower texels (2π / width).
    assert_eq!(
        reduced_scale((2048, 512), hd, focal(1080, 40.0), centre),
        Some(2)
    );
    // The scale must divide both sides, and the principal point be the centre.
    assert_eq!(
        reduced_scale((1024, 512), (1920, 1082), focal(1082, 40.0), (960.0, 541.0)),
        Some(2)
    );
    assert_eq!(
        reduced_scale((1024, 512), (1921, 1081), focal(1081, 40.0), (960.5, 540.5)),
        None
    );
    assert_eq!(
        reduced_scale((1024, 512), hd, focal(1080, 40.0), (900.0, 540.0)),
        None
    );
    assert_eq!(reduced_scale((0, 0), hd, focal(1080, 40.0), centre), None);
}

/// The batch's makers each have a renderer: the environment pass's
/// pipelines are built once for the device, not once per renderer, and a
/// part is built for the kinds it draws only, so the sky above the band is
/// one pipeline (and the quarter pass's another) for every environment.
#[test]
fn renderers_of_one_device_share_the_environment_pipelines() {
    use crate::pipeline::FramePipeline;
    use crate::preset::Preset;
    let ctx = crate::render::GpuContext::headless()
        .unwrap_or_else(|e| panic!("rendering tests need a GPU adapter (lavapipe): {e}"));
    let preset = Preset::from_ron(
        r#"(
        seed: 3,
        placement: Randomized(count: (2, 2), volume: Box(size_m: (4.0, 2.0, 4.0)), min_separation_m: 0.7),
        camera: (z: (start: 0.5, end: 0.5, step: 0.0)),
        repeats: 2,
        sky: Random(choices: [Procedural(environment: Daytime), Procedural(environment: SnowyBridge)], sun_elevation_deg: (10, 40)),
        render: (resolution: Custom(width: 160, height: 90), msaa: 4),
    )"#,
    )
    .expect("preset");
    let pipeline = FramePipeline::new(preset).expect("pipeline");
    let built = || {
        let shared = ctx.shared.environment.lock().expect("lock");
        shared.iter().map(|(key, _)| *key).collect::<Vec<_>>()
    };
    let (mut a, mut b) = (pipeline.renderer(&ctx), pipeline.renderer(&ctx));
    let frames = 0..pipeline.frame_count().min(6);
    let first: Vec<_> = (frames.clone())
        .map(|i| pipeline.make(&mut a, i).expect("renderer a").rgba)
        .collect();
    let keys = built();
    assert!(keys.len() >= 4, "{keys:?}");
    let second: Vec<_> = (frames.clone())
        .map(|i| pipeline.make(&mut b, i).expect("renderer b").rgba)
        .collect();
    assert_eq!(
        built(),
        keys,
        "the second renderer built pipelines of its own"
    );
    assert!(first == second, "the renderers drew different pixels");
    // The sky above the band (parts 3 and 4) is built for no kind at all.
    let none = (-1.0f32).to_bits();
    for key in keys.iter().filter(|k| f32::from_bits(k[3]) >= 3.0) {
        assert_eq!(key[..3], [none; 3], "{key:?}");
    }
    assert_eq!(
        keys.iter().filter(|k| f32::from_bits(k[3]) >= 3.0).count(),
        2
    );
}

/// The slice conversion of sky texels rounds as `f16::from_f32` does, value
/// for value (infinities, subnormals and halfway cases included), and adds
/// an opaque alpha.
#[test]
fn sky_texels_convert_to_half_floats_as_one_at_a_time() {
    let mut s = 0x9e37_79b9_7f4a_7c15u64;
    let mut next = move || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        s
    };
    let mut rgb: Vec<f32> = (0..3 * 2500)
        .map(|_| f32::from_bits(next() as u32 & 0x7fff_ffff).min(1e6))
        .collect();
    let specials = [
        0.0,
        6.0e-8,
        3.0e-5,
        1.0,
        65504.0,
        65520.0,
        f32::INFINITY,
        1.000_976_6,
    ];
    rgb[..specials.len()].copy_from_slice(&specials);
    let got = super::upload::f16_rgba(&rgb);
    let want: Vec<half::f16> = (rgb.chunks_exact(3))
        .flat_map(|p| [p[0], p[1], p[2], 1.0])
        .map(half::f16::from_f32)
        .collect();
    assert_eq!(got.len(), want.len());
    let bits = |v: &[half::f16]| v.iter().map(|h| h.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(&got), bits(&want));
}
