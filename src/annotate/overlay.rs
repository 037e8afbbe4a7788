//! Label boxes drawn onto pixels, for looking at a frame (`swarmshot frame --overlay`).

use super::DroneLabel;

/// Draw 2-px outlines of the training boxes (red) and of the unlabelled
/// hard negatives (cyan, issue 22) onto tightly packed RGBA pixels.
pub fn draw_overlay(rgba: &mut [u8], width: u32, height: u32, labels: &[DroneLabel]) {
    let kept = labels.iter().filter(|l| l.is_kept());
    draw_boxes(rgba, width, height, kept, [255, 40, 40, 255]);
    let negatives = labels
        .iter()
        .filter(|l| l.status == super::LabelStatus::Negative);
    draw_boxes(rgba, width, height, negatives, [40, 210, 255, 255]);
}

fn draw_boxes<'a>(
    rgba: &mut [u8],
    width: u32,
    height: u32,
    labels: impl Iterator<Item = &'a DroneLabel>,
    colour: [u8; 4],
) {
    let mut put = |x: i64, y: i64| {
        if x >= 0 && y >= 0 && (x as u32) < width && (y as u32) < height {
            let i = ((y as u32 * width + x as u32) * 4) as usize;
            if let Some(px) = rgba.get_mut(i..i + 4) {
                px.copy_from_slice(&colour);
            }
        }
    };
    for l in labels {
        let b = &l.bbox;
        let (x0, y0) = (b.x0.floor() as i64 - 1, b.y0.floor() as i64 - 1);
        let (x1, y1) = (b.x1.ceil() as i64, b.y1.ceil() as i64);
        for t in 0..2 {
            for x in x0 - t..=x1 + t {
                put(x, y0 - t);
                put(x, y1 + t);
            }
            for y in y0 - t..=y1 + t {
                put(x0 - t, y);
                put(x1 + t, y);
            }
        }
    }
}
