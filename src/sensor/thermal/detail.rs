//! The camera's detail enhancement (`thermal.detail`; docs/realism.md,
//! "Thermal camera"): the radiance `v` becomes `v + gain · (v − base)`, the
//! base a tent-weighted mean of `v` of half-width `size` × the frame's
//! height, as a thermal core's digital detail enhancement raises the local
//! contrast its gain control would flatten. Beside a warm edge (a tree
//! line, a drone) the colder side reads colder still: the dark band above
//! a warm horizon. It runs on the composed radiance plane before the
//! optics' blur and the noise (so `netd_mk` stays the noise the frames
//! show), and the gain control measures the enhanced frame, as a camera's
//! does; it changes no label (labels are the id pass's).
//!
//! The base is made at a coarser resolution, as smooth as it is: the
//! plane's means over cells of side `c` = ⌊reach / [`CELLS_PER_REACH`]⌋ px
//! (at least 1; a partial cell at the right or bottom edge averages its own
//! pixels), two box passes each way over the cells (2r + 1 cells wide, r =
//! (reach / c − 1) / 2 rounded, at least 1; each a mean over the cells
//! inside the frame: a tent of half-width the reach, widened by up to a
//! cell, kept to the frame at its edges), then bilinear between the cells'
//! centres (held at the outer centres). Every sum is f32 in a fixed order,
//! split by rows or cells only, so the bytes do not depend on the machine
//! or the threads.

use rayon::prelude::*;

use crate::preset::thermal::Detail;

/// The tent's half-width in cells, at least: the base's resolution.
pub const CELLS_PER_REACH: usize = 8;

/// The buffers the stage keeps from frame to frame.
#[derive(Debug, Default)]
pub struct Buffers {
    /// The cells' means, then the base at the cells.
    cells: Vec<f32>,
    /// The box passes' other side (the cells transposed).
    spare: Vec<f32>,
    /// The base at each cell row, widened to the frame's columns.
    wide: Vec<f32>,
}

/// The enhancement `d` on `plane` (`w`×`h`, row-major) in place; nothing when
/// its gain is 0 or its reach under a pixel.
pub fn enhance(d: &Detail, plane: &mut [f32], (w, h): (usize, usize), b: &mut Buffers) {
    let reach = (d.size * h as f64).round() as usize;
    if d.gain <= 0.0 || reach == 0 || w == 0 || h == 0 || plane.len() < w * h {
        return;
    }
    let c = (reach / CELLS_PER_REACH).max(1);
    let cells = (w.div_ceil(c), h.div_ceil(c));
    let r = ((reach as f64 / c as f64 - 1.0) * 0.5).round().max(1.0) as usize;
    cell_means(&plane[..w * h], (w, h), c, &mut b.cells);
    tent(&mut b.cells, &mut b.spare, cells, r);
    widen(&b.cells, cells, c, w, &mut b.wide);
    combine(&mut plane[..w * h], w, (&b.wide, c, cells.1), d.gain as f32);
}

/// Each `c`×`c` cell's mean of `plane` into `cells` (row-major), a band of
/// rows a cell high per thread.
fn cell_means(plane: &[f32], (w, h): (usize, usize), c: usize, cells: &mut Vec<f32>) {
    let cw = w.div_ceil(c);
    cells.resize(cw * h.div_ceil(c), 0.0);
    (cells.par_chunks_mut(cw).zip(plane.par_chunks(c * w)))
        .for_each(|(out, band)| cell_row(band, w, c, out));
}

simd_fn! {
    /// One row of cells from the `band` of rows under it: the columns' sums,
    /// then each cell's over its columns, over its pixel count.
    fn cell_row(band: &[f32], w: usize, c: usize, out: &mut [f32]) {
        let mut sums = band[..w].to_vec();
        for row in band.chunks_exact(w).skip(1) {
            for (s, v) in sums.iter_mut().zip(row) {
                *s += v;
            }
        }
        let rows = (band.len() / w) as f32;
        for (o, cols) in out.iter_mut().zip(sums.chunks(c)) {
            *o = cols.iter().sum::<f32>() / (rows * cols.len() as f32);
        }
    }
}

/// Two box passes of half-width `r` along each axis of the `cw`×`ch` cells:
/// along the rows, then along the columns as the rows of the transpose.
fn tent(cells: &mut Vec<f32>, spare: &mut Vec<f32>, (cw, ch): (usize, usize), r: usize) {
    box_lines(cells, cw, r);
    transpose_into(cells, spare, (ch, cw));
    box_lines(spare, ch, r);
    transpose_into(spare, cells, (cw, ch));
}

/// Two box passes of half-width `r` along each line of `len` of `lines`.
fn box_lines(lines: &mut [f32], len: usize, r: usize) {
    lines.par_chunks_mut(len).for_each(|line| {
        let mut other = vec![0.0; len];
        box_line(line, &mut other, r);
        box_line(&other, line, r);
    });
}

/// `dst[i]` = the mean of `src` over `i − r ..= i + r` within the line
/// (running sums).
fn box_line(src: &[f32], dst: &mut [f32], r: usize) {
    let n = src.len();
    let mut sum: f32 = src[..(r + 1).min(n)].iter().sum();
    for i in 0..n {
        let (lo, hi) = (i.saturating_sub(r), (i + r).min(n - 1));
        dst[i] = sum / (hi - lo + 1) as f32;
        if i + r + 1 < n {
            sum += src[i + r + 1];
        }
        if i >= r {
            sum -= src[i - r];
        }
    }
}

/// `dst` = `src` (`h` rows of `w`) transposed (`w` rows of `h`).
fn transpose_into(src: &[f32], dst: &mut Vec<f32>, (h, w): (usize, usize)) {
    dst.resize(src.len(), 0.0);
    for (y, row) in src.chunks_exact(w).enumerate().take(h) {
        for (x, v) in row.iter().enumerate() {
            dst[x * h + y] = *v;
        }
    }
}

/// Where pixel `x` lies between the centres of cells of side `c` along an
/// axis of `n` cells: the lower cell, the upper (the same at the ends) and
/// the upper's weight.
fn between(x: usize, c: usize, n: usize) -> (usize, usize, f32) {
    let u = (x as f32 - (c as f32 - 1.0) * 0.5) / c as f32;
    let u = u.clamp(0.0, (n - 1) as f32);
    let i = (u as usize).min(n - 1);
    (i, (i + 1).min(n - 1), u - i as f32)
}

/// Each row of the base at the cells widened to the frame's `w` columns
/// (bilinear along x) into `wide`.
fn widen(cells: &[f32], (cw, ch): (usize, usize), c: usize, w: usize, wide: &mut Vec<f32>) {
    wide.resize(w * ch, 0.0);
    let at: Vec<(usize, usize, f32)> = (0..w).map(|x| between(x, c, cw)).collect();
    (wide.par_chunks_mut(w).zip(cells.par_chunks(cw))).for_each(|(out, row)| {
        for (o, &(i, j, t)) in out.iter_mut().zip(&at) {
            *o = row[i] * (1.0 - t) + row[j] * t;
        }
    });
}

/// `plane` += `gain` · (`plane` − base), the base of each row bilinear
/// between the widened cell rows `wide` (`ch` of them, cells of side `c`).
fn combine(plane: &mut [f32], w: usize, (wide, c, ch): (&[f32], usize, usize), gain: f32) {
    plane.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
        let (i, j, t) = between(y, c, ch);
        let (lo, hi) = (&wide[i * w..(i + 1) * w], &wide[j * w..(j + 1) * w]);
        combine_row(row, lo, hi, t, gain);
    });
}

simd_fn! {
    /// One row of [`combine`]: its base `lo · (1 − t) + hi · t`.
    fn combine_row(row: &mut [f32], lo: &[f32], hi: &[f32], t: f32, gain: f32) {
        for ((v, a), b) in row.iter_mut().zip(lo).zip(hi) {
            let base = a * (1.0 - t) + b * t;
            *v += gain * (*v - base);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A `w`×`h` plane of 0 above row `edge` and `step` from it down.
    fn step_plane((w, h): (usize, usize), edge: usize, step: f32) -> Vec<f32> {
        (0..w * h)
            .map(|i| if i / w >= edge { step } else { 0.0 })
            .collect()
    }

    #[test]
    fn a_warm_edge_gets_the_tents_dark_band_above_it_and_far_rows_keep_their_level() {
        let (w, h, edge, step) = (96, 400, 200, 100.0);
        let d = Detail {
            gain: 1.5,
            size: 0.1,
        };
        let mut plane = step_plane((w, h), edge, step);
        enhance(&d, &mut plane, (w, h), &mut Buffers::default());
        // Half of any even kernel's weight lies beyond its centre: the row
        // just above the edge reads −gain · step / 2, the row below
        // step · (1 + gain / 2).
        let (above, below) = (plane[(edge - 1) * w + w / 2], plane[edge * w + w / 2]);
        assert!((above + 0.75 * step).abs() < 0.04 * step, "{above}");
        assert!((below - 1.75 * step).abs() < 0.04 * step, "{below}");
        // A tent of half-width R puts (R − x)² / 2R² of its weight beyond x,
        // R / 6 rows' worth over the band above the edge (the cells widen
        // it by up to a cell, an eighth of R).
        let band: f32 = (0..edge).map(|y| -plane[y * w + w / 2]).sum::<f32>() / (1.5 * step);
        let reach = 0.1 * h as f32;
        assert!(
            (band - reach / 6.0).abs() < 0.15 * reach / 6.0,
            "{band} rows vs {}",
            reach / 6.0
        );
        for y in (0..edge - 48).chain(edge + 48..h) {
            let want = if y >= edge { step } else { 0.0 };
            assert!((plane[y * w + 7] - want).abs() < 1e-3, "row {y}");
        }
    }

    #[test]
    fn gain_0_changes_nothing_and_a_flat_plane_stays_flat() {
        let (w, h) = (50, 37);
        let mut plane = step_plane((w, h), 20, 3.0);
        let before = plane.clone();
        let off = Detail {
            gain: 0.0,
            ..Detail::default()
        };
        enhance(&off, &mut plane, (w, h), &mut Buffers::default());
        assert_eq!(plane, before);
        let mut flat = vec![41.25f32; w * h];
        enhance(
            &Detail::default(),
            &mut flat,
            (w, h),
            &mut Buffers::default(),
        );
        assert!(flat.iter().all(|v| (v - 41.25).abs() < 1e-4), "{flat:?}");
    }

    #[test]
    fn the_bytes_do_not_depend_on_the_threads() {
        let (w, h) = (333, 217);
        let plane: Vec<f32> = (0..w * h)
            .map(|i| ((i * 7919) % 1013) as f32 * 0.01 + (i / w) as f32 * 0.1)
            .collect();
        let d = Detail {
            gain: 2.0,
            size: 0.2,
        };
        let run = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build();
            let mut p = plane.clone();
            pool.expect("a thread pool")
                .install(|| enhance(&d, &mut p, (w, h), &mut Buffers::default()));
            p.iter().map(|v| v.to_bits()).collect::<Vec<u32>>()
        };
        assert_eq!(run(1), run(3));
        assert_ne!(
            run(1),
            plane.iter().map(|v| v.to_bits()).collect::<Vec<_>>()
        );
    }
}
