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

/// The batch's makers each have a renderer: on a GPU, the environment pass's
/// pipelines are built once for the device, not once per renderer, and a
/// part is built for the kinds it draws only, so the sky above the band is
/// one pipeline for every environment (the quarter pass one for each ground).
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
    // The GPU's passes, as on a GPU (lavapipe's environment is shaded on the CPU).
    a.sky.cpu_environment = None;
    b.sky.cpu_environment = None;
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
    // The sky above the band (part 3) is built for no kind at all; the
    // quarter pass (part 4) for the grounds of the ground side (part 2).
    let none = (-1.0f32).to_bits();
    let of_part = |part: f32| keys.iter().filter(move |k| f32::from_bits(k[3]) == part);
    assert_eq!(
        of_part(3.0).collect::<Vec<_>>(),
        [&[none, none, none, 3f32.to_bits()]]
    );
    let grounds = |part| {
        let mut g: Vec<u32> = of_part(part).map(|k| k[0]).collect();
        g.sort_unstable();
        g
    };
    assert!(
        of_part(4.0).all(|k| k[1..3] == [none; 2] && k[0] != none),
        "{keys:?}"
    );
    assert_eq!(grounds(4.0), grounds(2.0), "{keys:?}");
    assert!(!grounds(4.0).is_empty());
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

/// On a CPU adapter the procedural environment is shaded on the CPU
/// (`procedural.rs`); it must draw what the GPU's passes draw. Every
/// environment, with and without clouds, the camera looking up, level and
/// down, through the batch's path (the background upsampled on the CPU)
/// and the full-frame path (the sky pass sampling the uploaded texels):
/// no 8-bit value more than 2 levels from lavapipe's passes, and few
/// different at all (1080p table2 frames: at most 1 level, 3.2 % of values).
#[test]
fn the_environment_shaded_on_the_cpu_is_what_the_gpu_passes_draw() {
    use crate::pipeline::FramePipeline;
    use crate::preset::Preset;
    let ctx = crate::render::GpuContext::headless()
        .unwrap_or_else(|e| panic!("rendering tests need a GPU adapter (lavapipe): {e}"));
    assert_eq!(
        ctx.adapter_info.device_type,
        wgpu::DeviceType::Cpu,
        "lavapipe"
    );
    let preset = Preset::from_ron(
        r#"(
        seed: 11,
        placement: Randomized(count: (1, 3), volume: Box(size_m: (6.0, 3.0, 6.0)), min_separation_m: 1.0),
        camera: (y: (start: -6.0, end: 6.0, step: 6.0), z: (start: 0.45, end: 0.45, step: 0.0)),
        repeats: 14,
        sky: Random(
            choices: [
                Procedural(environment: Daytime), Procedural(environment: Sunset),
                Procedural(environment: BeautifulPasture), Procedural(environment: SnowyBridge),
                Procedural(environment: SmallHarbour), Procedural(environment: Tellsplatte),
                Procedural(environment: CountryRoad),
            ],
            azimuth_offset_deg: (0.0, 360.0),
            sun_elevation_deg: (4.0, 60.0),
            cloud_cover: (0.0, 0.8),
        ),
        render: (resolution: Custom(width: 320, height: 180), msaa: 4),
    )"#,
    )
    .expect("preset");
    let pipeline = FramePipeline::new(preset).expect("pipeline");
    let mut cpu = pipeline.renderer(&ctx);
    let mut gpu = pipeline.renderer(&ctx);
    assert!(cpu.sky.shades_environment_on_cpu());
    gpu.sky.cpu_environment = None;
    let (mut values, mut differ, mut worst) = (0usize, 0usize, 0u8);
    let mut compare = |a: &[u8], b: &[u8], what: &str| {
        assert_eq!(a.len(), b.len(), "{what}");
        for (x, y) in a.iter().zip(b) {
            let d = x.abs_diff(*y);
            worst = worst.max(d);
            differ += usize::from(d > 0);
        }
        values += a.len();
        assert!(worst <= 2, "{what}: a value {worst} levels from the GPU's");
    };
    for i in 0..pipeline.frame_count() {
        let a = pipeline.make(&mut cpu, i).expect("cpu environment").rgba;
        let b = pipeline.make(&mut gpu, i).expect("gpu environment").rgba;
        compare(&a, &b, &format!("frame {i}"));
        let scene = pipeline.scene(i).expect("scene");
        let a = cpu
            .render_rgba(&scene, 4)
            .expect("full frame, cpu environment");
        let b = gpu
            .render_rgba(&scene, 4)
            .expect("full frame, gpu environment");
        compare(&a, &b, &format!("frame {i}, full-frame path"));
    }
    let share = differ as f64 / values as f64;
    assert!(share < 0.08, "{:.1} % of values differ", share * 100.0);
}
