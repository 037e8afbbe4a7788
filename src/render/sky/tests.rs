//! Unit tests of the sky's reduced-resolution choice.
use super::reduced_scale;

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
