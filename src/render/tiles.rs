//! The tiles in which a layer made on the CPU (a cached background, the
//! scenery) is uploaded to its texture: only the tiles under the regions a
//! frame draws, each once, when a frame first needs them, and the upload
//! of one part ([`write_part`]). Plain arithmetic on [`Rect`]s, shared by
//! the background and the scenery.

use super::regions::Rect;

/// Side (pixels) of the tiles in which a layer made on the CPU (a
/// background, the scenery) is uploaded.
const UPLOAD_TILE: u32 = 64;

/// The tiles across and down of a `width`×`height` layer.
pub(super) fn upload_tiles((width, height): (u32, u32)) -> (u32, u32) {
    (width.div_ceil(UPLOAD_TILE), height.div_ceil(UPLOAD_TILE))
}

/// The parts of a `size` layer to upload before a frame draws `rects`:
/// the `stale` tiles (per [`UPLOAD_TILE`]-square tile, row by row: not yet
/// uploaded) under them, joined along each row of tiles, now marked
/// uploaded; `stale` is emptied once nothing in it is stale.
pub(super) fn take_stale_tiles<'r>(
    stale: &mut Vec<bool>,
    size: (u32, u32),
    rects: impl IntoIterator<Item = &'r Rect>,
) -> Vec<Rect> {
    let (across, down) = upload_tiles(size);
    let mut parts = Vec::new();
    if stale.len() != across as usize * down as usize {
        stale.clear();
        return parts;
    }
    let mut wanted = vec![false; stale.len()];
    for r in rects {
        let (tx0, tx1) = (r.x0 / UPLOAD_TILE, r.x1.div_ceil(UPLOAD_TILE).min(across));
        let (ty0, ty1) = (r.y0 / UPLOAD_TILE, r.y1.div_ceil(UPLOAD_TILE).min(down));
        for ty in ty0..ty1 {
            let row = (ty * across) as usize;
            wanted[row + tx0 as usize..row + tx1.max(tx0) as usize].fill(true);
        }
    }
    for (w, s) in wanted.iter_mut().zip(stale.iter_mut()) {
        *w &= *s;
        *s &= !*w;
    }
    for ty in 0..down {
        let row = (ty * across) as usize;
        let mut tx = 0;
        while tx < across {
            if !wanted[row + tx as usize] {
                tx += 1;
                continue;
            }
            let start = tx;
            while tx < across && wanted[row + tx as usize] {
                tx += 1;
            }
            let y0 = ty * UPLOAD_TILE;
            parts.push(Rect {
                x0: start * UPLOAD_TILE,
                y0,
                x1: (tx * UPLOAD_TILE).min(size.0),
                y1: (y0 + UPLOAD_TILE).min(size.1),
            });
        }
    }
    if !stale.contains(&true) {
        stale.clear();
    }
    parts
}

/// Upload the part `part` of `rgba` (a layer `width` pixels wide, 4 bytes
/// a pixel) into the same place of `texture`.
pub(super) fn write_part(
    queue: &wgpu::Queue,
    texture: &wgpu::Texture,
    rgba: &[u8],
    width: u32,
    part: &Rect,
) {
    let offset = (u64::from(part.y0) * u64::from(width) + u64::from(part.x0)) * 4;
    queue.write_texture(
        wgpu::TexelCopyTextureInfo {
            texture,
            mip_level: 0,
            origin: wgpu::Origin3d {
                x: part.x0,
                y: part.y0,
                z: 0,
            },
            aspect: wgpu::TextureAspect::All,
        },
        rgba,
        wgpu::TexelCopyBufferLayout {
            offset,
            bytes_per_row: Some(width * 4),
            rows_per_image: None,
        },
        wgpu::Extent3d {
            width: part.x1 - part.x0,
            height: part.y1 - part.y0,
            depth_or_array_layers: 1,
        },
    );
}
