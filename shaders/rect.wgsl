// Corner `i` (0..6: two triangles) of a rect given in normalised device
// coordinates as (x0, y0, x1, y1).
fn rect_corner(rect: vec4<f32>, i: u32) -> vec2<f32> {
    // (x0, y0) (x1, y0) (x0, y1) | (x0, y1) (x1, y0) (x1, y1)
    let right = i == 1u || i == 4u || i == 5u;
    let down = i == 2u || i == 3u || i == 5u;
    return vec2<f32>(select(rect.x, rect.z, right), select(rect.y, rect.w, down));
}
