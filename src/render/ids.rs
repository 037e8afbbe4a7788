//! The instance-id layer: its multisampled target, and the reduction of that
//! target to per-drone visibility.
//!
//! The id target is drawn in the colour pass (a second colour attachment of
//! the drone pipeline, same fragment shader, same samples), so the ids follow
//! the colour pass's sample pattern by construction: alpha-cutoff fragments
//! discard in both, and a pixel "shows" a drone when any of its samples does.
//! The format is `R32Float` holding the id (exact below 2^24): WebGPU
//! guarantees 4× multisampling for it, not for `R32Uint`.
//!
//! With MSAA the region resolve (`shaders/resolve.wgsl`) writes each pixel's
//! id samples side by side into a single-sample `RGBA32Float` target, read
//! back with the picture's regions; without MSAA the id target itself is read
//! back. [`tally`] then counts, on the CPU, each drone's pixels and its box.

use super::readback::Read;
use super::regions::Rect;

/// Format of the id target.
pub(super) const ID_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R32Float;
/// Ids are stored as f32: exact up to this many drones.
pub const MAX_DRONES: usize = 1 << 24;
/// Format of the single-sample target holding a pixel's four id samples.
pub(super) const ID_SAMPLES_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Float;

/// Bytes per pixel of the ids read back for `samples` samples per pixel.
pub(super) fn id_bytes_per_pixel(samples: u32) -> u32 {
    if samples > 1 { 16 } else { 4 }
}

/// Per-drone results of one reduction: pixel count and pixel box (exclusive ends).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct IdStats {
    pub pixels: u64,
    pub rect: Option<Rect>,
}

/// Per-drone running totals of a tally: pixel count and box (exclusive ends).
#[derive(Clone, Copy, Debug)]
pub(super) struct Tally {
    pixels: u64,
    x0: u32,
    y0: u32,
    x1: u32,
    y1: u32,
}

impl Default for Tally {
    fn default() -> Self {
        Self {
            pixels: 0,
            x0: u32::MAX,
            y0: u32::MAX,
            x1: 0,
            y1: 0,
        }
    }
}

impl Tally {
    fn add(&mut self, x: u32, y: u32) {
        self.pixels += 1;
        self.x0 = self.x0.min(x);
        self.y0 = self.y0.min(y);
        self.x1 = self.x1.max(x + 1);
        self.y1 = self.y1.max(y + 1);
    }

    /// Add `pixels` counted elsewhere (no places: the box stays as it is).
    pub(super) fn add_count(&mut self, pixels: u64) {
        self.pixels += pixels;
    }

    pub(super) fn stats(&self) -> IdStats {
        IdStats {
            pixels: self.pixels,
            rect: (self.pixels > 0 && self.x0 < self.x1).then_some(Rect {
                x0: self.x0,
                y0: self.y0,
                x1: self.x1,
                y1: self.y1,
            }),
        }
    }
}

/// Count the pixels of `rect` (its id samples read back: `samples` f32 per
/// pixel, rows `row` bytes apart) into `tallies` (drone `id - 1`): each pixel
/// counts once for every distinct drone any of its samples shows, and widens
/// that drone's box. Id 0 (no drone) and ids past `tallies` are ignored.
pub(super) fn tally(bytes: &[u8], row: usize, rect: &Rect, samples: u32, tallies: &mut [Tally]) {
    let n = tallies.len() as u32;
    let mut record = |id: u32, x: u32, y: u32| {
        if id != 0 && id <= n {
            tallies[(id - 1) as usize].add(x, y);
        }
    };
    let id = |b: &[u8]| f32::from_le_bytes([b[0], b[1], b[2], b[3]]) as u32;
    let pixel = id_bytes_per_pixel(samples) as usize;
    let width = rect.width() as usize;
    for (dy, line) in bytes.chunks(row).take(rect.height() as usize).enumerate() {
        let y = rect.y0 + dy as u32;
        for (dx, p) in line[..width * pixel].chunks_exact(pixel).enumerate() {
            let x = rect.x0 + dx as u32;
            if samples == 1 || p[..4] == p[4..8] && p[..8] == p[8..] {
                // One sample, or four equal ones (a pixel inside one surface).
                record(id(p), x, y);
                continue;
            }
            let [a, b, c, d] = [id(p), id(&p[4..]), id(&p[8..]), id(&p[12..])];
            record(a, x, y);
            if b != a {
                record(b, x, y);
            }
            if c != a && c != b {
                record(c, x, y);
            }
            if d != a && d != b && d != c {
                record(d, x, y);
            }
        }
    }
}

/// Which drones of `candidates` the main pass's ids (`reads` of `bytes`,
/// laid out as in [`tally`]) show something in front of: drone `i` is
/// `true` when a sample inside `rects[i]` shows a drone `j != i` that
/// `may_hide(j, i)` (not wholly behind it), or when its ids are not there.
///
/// The others need no layer pass: a sample that a drone covers alone shows,
/// in the main pass, its own fragment or one at least as near, of a drone
/// not wholly behind it and inside its rect; none shows such a drone, so
/// the main pass shows the drone at every sample it covers alone, and its
/// unoccluded count is its visible count.
pub(super) fn shows_front(
    bytes: &[u8],
    reads: &[Read],
    samples: u32,
    (rects, candidates): (&[Option<Rect>], &[bool]),
    may_hide: &dyn Fn(usize, usize) -> bool,
) -> Vec<bool> {
    let n = rects.len();
    let pixel = id_bytes_per_pixel(samples) as usize;
    let front_in = |i: usize, r: &Rect, read: &Read| {
        let Some(x) = read.rect.intersection(r) else {
            return false;
        };
        (x.y0..x.y1).any(|y| {
            let start = read.offset as usize
                + (y - read.rect.y0) as usize * read.row as usize
                + (x.x0 - read.rect.x0) as usize * pixel;
            let Some(line) = bytes.get(start..start + x.width() as usize * pixel) else {
                return true; // not read: measured alone to be sure
            };
            // The last id seen that cannot hide drone `i` (most runs repeat it).
            let mut behind = 0;
            line.chunks_exact(4).any(|s| {
                let id = f32::from_le_bytes([s[0], s[1], s[2], s[3]]) as u32;
                if id == 0 || id == behind || id as usize > n || id as usize == i + 1 {
                    return false;
                }
                behind = id;
                may_hide(id as usize - 1, i)
            })
        })
    };
    let grid = ReadGrid::new(reads);
    (0..n)
        .map(|i| match (candidates.get(i), rects[i]) {
            (Some(true), Some(r)) => grid.near(&r).any(|k| front_in(i, &r, &reads[k])),
            _ => false,
        })
        .collect()
}

/// The side of a [`ReadGrid`]'s cells in pixels.
const READ_CELL: u32 = 64;

/// Which reads meet each [`READ_CELL`]-px cell of their bounds: a drone's
/// rect is compared with the reads of the cells it touches, not with every
/// read of the frame (thousands of each in a dense swarm).
struct ReadGrid {
    /// The bounds' first cell (in cells) and the grid's size.
    origin: (u32, u32),
    size: (u32, u32),
    /// Where each cell's read indices begin in `indices` (one more entry than cells).
    starts: Vec<usize>,
    indices: Vec<usize>,
}

impl ReadGrid {
    fn new(reads: &[Read]) -> Self {
        let cells = |r: &Rect| {
            (
                r.x0 / READ_CELL,
                r.y0 / READ_CELL,
                r.x1.div_ceil(READ_CELL),
                r.y1.div_ceil(READ_CELL),
            )
        };
        let (mut x0, mut y0, mut x1, mut y1) = (u32::MAX, u32::MAX, 0, 0);
        for read in reads {
            let c = cells(&read.rect);
            (x0, y0, x1, y1) = (x0.min(c.0), y0.min(c.1), x1.max(c.2), y1.max(c.3));
        }
        let (width, height) = (x1.saturating_sub(x0), y1.saturating_sub(y0));
        let mut grid = Self {
            origin: (x0, y0),
            size: (width, height),
            starts: vec![0; (width * height) as usize + 1],
            indices: Vec::new(),
        };
        for read in reads {
            for cell in grid.cells(&read.rect) {
                grid.starts[cell + 1] += 1;
            }
        }
        for k in 1..grid.starts.len() {
            grid.starts[k] += grid.starts[k - 1];
        }
        let mut next = grid.starts.clone();
        grid.indices = vec![0; grid.starts[grid.starts.len() - 1]];
        for (k, read) in reads.iter().enumerate() {
            for cell in grid.cells(&read.rect) {
                grid.indices[next[cell]] = k;
                next[cell] += 1;
            }
        }
        grid
    }

    /// The cells `r` touches, within the grid.
    fn cells(&self, r: &Rect) -> impl Iterator<Item = usize> + use<> {
        let ((ox, oy), (w, h)) = (self.origin, self.size);
        let x0 = (r.x0 / READ_CELL).clamp(ox, ox + w) - ox;
        let x1 = r.x1.div_ceil(READ_CELL).clamp(ox, ox + w) - ox;
        let y0 = (r.y0 / READ_CELL).clamp(oy, oy + h) - oy;
        let y1 = r.y1.div_ceil(READ_CELL).clamp(oy, oy + h) - oy;
        (y0..y1).flat_map(move |y| (x0..x1).map(move |x| (y * w + x) as usize))
    }

    /// The indices of the reads that may meet `r` (a read met in several
    /// cells comes once per cell); every read that meets it is among them.
    fn near(&self, r: &Rect) -> impl Iterator<Item = usize> + '_ {
        (self.cells(r)).flat_map(|c| {
            self.indices[self.starts[c]..self.starts[c + 1]]
                .iter()
                .copied()
        })
    }
}

/// One drone seen at one pixel (plain data, [`super::visibility`]): each
/// drone's hits are exactly the pixels [`tally`] counts for it.
pub use super::visibility::PixelHit;

/// The hits of `rect`'s pixels (read back as in [`tally`]) appended to
/// `out`: one per pixel and distinct drone id in `1..=drones`.
pub(super) fn collect_hits(
    bytes: &[u8],
    row: usize,
    rect: &Rect,
    samples: u32,
    drones: usize,
    out: &mut Vec<PixelHit>,
) {
    let id = |b: &[u8]| f32::from_le_bytes([b[0], b[1], b[2], b[3]]) as u32;
    let pixel = id_bytes_per_pixel(samples) as usize;
    let width = rect.width() as usize;
    for (dy, line) in bytes.chunks(row).take(rect.height() as usize).enumerate() {
        let y = rect.y0 + dy as u32;
        for (dx, p) in line[..width * pixel].chunks_exact(pixel).enumerate() {
            let x = rect.x0 + dx as u32;
            if samples == 1 || p[..4] == p[4..8] && p[..8] == p[8..] {
                // One sample, or four equal ones: most pixels, the sky's included.
                let v = id(p);
                if v != 0 && v as usize <= drones {
                    out.push(PixelHit {
                        x,
                        y,
                        drone: v - 1,
                        samples: samples as u8,
                    });
                }
                continue;
            }
            let ids: &[u8] = &p[..pixel];
            let mut seen: [(u32, u8); 4] = [(0, 0); 4];
            let mut n = 0;
            for s in ids.chunks_exact(4) {
                let v = id(s);
                if v == 0 || v as usize > drones {
                    continue;
                }
                match seen[..n].iter_mut().find(|(d, _)| *d == v) {
                    Some((_, c)) => *c += 1,
                    None => {
                        seen[n] = (v, 1);
                        n += 1;
                    }
                }
            }
            out.extend(seen[..n].iter().map(|&(v, c)| PixelHit {
                x,
                y,
                drone: v - 1,
                samples: c,
            }));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pixels(values: &[[f32; 4]]) -> Vec<u8> {
        values
            .iter()
            .flatten()
            .flat_map(|v| v.to_le_bytes())
            .collect()
    }

    #[test]
    fn a_read_grid_offers_every_read_a_rect_meets() {
        let mut state = 7u64;
        let mut next = |n: u64| {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((state >> 33) % n) as u32
        };
        let mut rect = |most: u64| {
            let (x0, y0) = (next(700) + 100, next(400) + 50);
            Rect {
                x0,
                y0,
                x1: x0 + 1 + next(most),
                y1: y0 + 1 + next(most),
            }
        };
        let reads: Vec<Read> = (0..300)
            .map(|_| Read {
                rect: rect(150),
                origin: (0, 0),
                offset: 0,
                row: 0,
            })
            .collect();
        let grid = ReadGrid::new(&reads);
        let mut offered = 0;
        for _ in 0..2000 {
            let r = rect(40);
            let near: Vec<usize> = grid.near(&r).collect();
            for (k, read) in reads.iter().enumerate() {
                assert!(
                    read.rect.intersection(&r).is_none() || near.contains(&k),
                    "{r:?} misses read {k}"
                );
            }
            offered += near.len();
        }
        assert!(
            offered < 2000 * reads.len() / 4,
            "the grid narrows the reads: {offered}"
        );
        let far = Rect {
            x0: 0,
            y0: 0,
            x1: 50,
            y1: 40,
        };
        assert_eq!(grid.near(&far).count(), 0, "outside every read's cell");
        assert_eq!(ReadGrid::new(&[]).near(&far).count(), 0);
    }

    #[test]
    fn a_pixel_counts_once_per_distinct_drone_of_its_samples() {
        // A 3×1 rect at (10, 20): a pixel inside drone 1, an edge pixel
        // shared by drones 1 and 2 (and the background), a background pixel.
        let rect = Rect {
            x0: 10,
            y0: 20,
            x1: 13,
            y1: 21,
        };
        let bytes = pixels(&[[1.0; 4], [2.0, 0.0, 1.0, 2.0], [0.0; 4]]);
        let mut tallies = vec![Tally::default(); 2];
        tally(&bytes, bytes.len(), &rect, 4, &mut tallies);
        let one = tallies[0].stats();
        let two = tallies[1].stats();
        assert_eq!(one.pixels, 2);
        assert_eq!(
            one.rect,
            Some(Rect {
                x0: 10,
                y0: 20,
                x1: 12,
                y1: 21
            })
        );
        assert_eq!(two.pixels, 1, "two samples of drone 2 count one pixel");
        assert_eq!(
            two.rect,
            Some(Rect {
                x0: 11,
                y0: 20,
                x1: 12,
                y1: 21
            })
        );
    }

    #[test]
    fn hits_are_the_pixels_tally_counts() {
        let rect = Rect {
            x0: 10,
            y0: 20,
            x1: 13,
            y1: 21,
        };
        let bytes = pixels(&[[1.0; 4], [2.0, 0.0, 1.0, 2.0], [0.0; 4]]);
        let mut hits = Vec::new();
        collect_hits(&bytes, bytes.len(), &rect, 4, 2, &mut hits);
        let hit = |x, drone, samples| PixelHit {
            x,
            y: 20,
            drone,
            samples,
        };
        assert_eq!(hits, vec![hit(10, 0, 4), hit(11, 1, 2), hit(11, 0, 1)]);
        let mut tallies = vec![Tally::default(); 2];
        tally(&bytes, bytes.len(), &rect, 4, &mut tallies);
        for (d, t) in tallies.iter().enumerate() {
            let n = hits.iter().filter(|h| h.drone == d as u32).count() as u64;
            assert_eq!(n, t.stats().pixels);
        }
    }

    #[test]
    fn only_drones_shown_behind_another_in_their_rect_need_a_layer() {
        // One read of a 4×1 rect at (0, 0), four samples a pixel: drone 1
        // (id 1) whole at x 0, drone 2 at x 1, drone 3's samples at x 2
        // with one of drone 1's, nothing at x 3.
        let read = Read {
            rect: Rect {
                x0: 0,
                y0: 0,
                x1: 4,
                y1: 1,
            },
            origin: (0, 0),
            offset: 0,
            row: 256,
        };
        let mut bytes = pixels(&[[1.0; 4], [2.0; 4], [3.0, 3.0, 1.0, 3.0], [0.0; 4]]);
        bytes.resize(256, 0);
        let rect = |x0, x1| {
            Some(Rect {
                x0,
                y0: 0,
                x1,
                y1: 1,
            })
        };
        let rects = [rect(0, 2), rect(1, 3), rect(2, 4), rect(3, 4)];
        let candidates = [true, true, true, true];
        // Anything may hide anything: drone 1's rect shows 2, drone 2's
        // shows 1 and 3, drone 3's shows 1; drone 4's rect shows nothing.
        let front = shows_front(&bytes, &[read], 4, (&rects, &candidates), &|_, _| true);
        assert_eq!(front, [true, true, true, false]);
        // Drone 1 is in front of every other one: only it hides anything.
        let front = shows_front(&bytes, &[read], 4, (&rects, &candidates), &|j, _| j == 0);
        assert_eq!(front, [false, true, true, false]);
        // Not a candidate: never; a rect past the bytes read: always.
        let front = shows_front(
            &bytes[..16],
            &[read],
            4,
            (&rects, &[false, true, true, true]),
            &|j, _| j == 0,
        );
        assert_eq!(front, [false, true, true, true]);
    }

    #[test]
    fn rows_are_read_at_their_stride_and_stray_ids_are_ignored() {
        // Two rows of two one-sample pixels, rows padded to 16 bytes.
        let rect = Rect {
            x0: 0,
            y0: 5,
            x1: 2,
            y1: 7,
        };
        let mut bytes = Vec::new();
        for row in [[0.0f32, 7.0], [1.0, 1.0]] {
            bytes.extend(row.iter().flat_map(|v| v.to_le_bytes()));
            bytes.extend([0xAB; 8]); // padding, never read as ids
        }
        let mut tallies = vec![Tally::default(); 1];
        tally(&bytes, 16, &rect, 1, &mut tallies);
        let one = tallies[0].stats();
        assert_eq!(one.pixels, 2, "id 7 is past the frame's one drone");
        assert_eq!(
            one.rect,
            Some(Rect {
                x0: 0,
                y0: 6,
                x1: 2,
                y1: 7
            })
        );
        assert_eq!(Tally::default().stats().rect, None);
    }
}
