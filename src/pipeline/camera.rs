//! A rendered frame through the camera model (issue 21), the pipeline's
//! camera glue: a rolling shutter's rows ([`super::rolling`]) first, the
//! motion blur's streaks ([`super::streaks`]) smeared next, each drone's
//! visibility measured as the camera shows it
//! ([`crate::sensor::changed_pixels_each`]), the lens's resampling
//! ([`super::lens`]) before the chain, the chain applied
//! ([`crate::sensor::apply`]) and the drawn first compression. The chain
//! itself is [`crate::sensor`]'s.

use crate::annotate::visibility::Visibility;
use crate::render::RenderedFrame;
use crate::render::visibility::CellGrid;
use crate::scene::FrameScene;
use crate::scene::projection::PixelBox;
use crate::sensor::{self, CameraDraw, PixelRect};

use super::{FramePipeline, PipelineError, lens, rolling, streaks};

impl FramePipeline {
    /// The rendered frame through the camera model `draw` (written into
    /// `rgba`, a recycled buffer whose old bytes never show),
    /// and each measured drone's visibility as the camera shows it: the
    /// pixels where the drone changes the noise-free camera image by at
    /// least one 8-bit level against the drone-free background under the
    /// same draw (docs/conventions.md, "The camera model and the labels").
    /// `background` is that drone-free frame (under the frame's weather, if
    /// any); with a rolling `shutter`, both are shuttered first.
    pub(super) fn through_camera(
        &self,
        (background, shutter): (Option<&[u8]>, Option<&rolling::Shutter>),
        scene: &FrameScene,
        draw: &CameraDraw,
        (frame, mut rgba): (&RenderedFrame, Vec<u8>),
        measured: &mut Option<Vec<Visibility>>,
        sets: &mut Option<Vec<Vec<(u32, u32)>>>,
    ) -> Result<Vec<u8>, PipelineError> {
        let (w, h) = (scene.camera.width, scene.camera.height);
        // The renderer drew the frame (and its background) at the drawn exposure.
        let draw = &draw.after_render();
        // The rolling shutter (issue 41): each row at its own time, first.
        let visible: Option<Vec<Option<PixelRect>>> = (measured.as_ref())
            .map(|vis| vis.iter().map(|v| v.visible_box.map(pixel_rect)).collect());
        let rendered = (frame.rgba.as_slice(), visible.as_deref());
        let shuttered = rolling::shuttered(shutter, scene.index, rendered, background)?;
        let (rendered, background) = match &shuttered {
            Some((f, turned)) => (f.as_slice(), turned.as_deref().or(background)),
            None => (frame.rgba.as_slice(), background),
        };
        // Motion blur (sequences): each drone smeared along its streak next.
        let streaks = self.frame_streaks(scene, draw, shutter);
        let blurred = if streaks.iter().flatten().any(|s| s.moves()) {
            let background = background.ok_or_else(|| PipelineError::Camera {
                index: scene.index,
                reason: "motion blur: the drone-free background is not cached".into(),
            })?;
            let list: Vec<sensor::motion::Streak> = streaks.iter().flatten().copied().collect();
            smear_budget(&list, (w, h), scene.index)?;
            Some(sensor::motion::smear(rendered, background, (w, h), &list))
        } else {
            None
        };
        let source: &[u8] = blurred.as_deref().unwrap_or(rendered);
        // The lens (issue 41): the picture resampled once, before the sensor.
        let lens = lens::of(scene);
        let lensed = lens.as_ref().map(|l| l.map.remap(source));
        let source: &[u8] = lensed.as_deref().unwrap_or(source);
        if let Some(vis) = measured.as_mut() {
            if background.is_none() {
                // The rendered visibility stays, and so do the rendered masks.
                *sets = None;
            }
            let near = label_rects(vis, shutter, &streaks, lens.as_ref(), (w, h));
            // Through a lens, the drone-free background is resampled where the labels read it.
            let reach = draw.reach_px(w, h) * 2;
            let lensed_background = (lens.as_ref().zip(background)).map(|(l, b)| {
                let areas: Vec<PixelRect> = (near.iter().flatten())
                    .map(|&(_, r)| PixelRect {
                        x0: r.x0.saturating_sub(reach),
                        y0: r.y0.saturating_sub(reach),
                        x1: r.x1.saturating_add(reach),
                        y1: r.y1.saturating_add(reach),
                    })
                    .collect();
                lens::background(&l.map, source, b, &areas)
            });
            let background = lensed_background.as_deref().or(background);
            let mut rivals = Rivals::new(&near, draw.reach_px(w, h), (w, h));
            let mut others = Vec::new();
            for (i, v) in vis.iter_mut().enumerate() {
                let Some(background) = background else {
                    continue;
                };
                let Some((own, search)) = near[i] else {
                    // Seen in the render, but its rows took it out of the picture.
                    if shutter.is_some() && v.visible_box.is_some() {
                        *v = camera_visibility(v, None);
                    }
                    continue;
                };
                rivals.of(i, search, &mut others);
                let mut set = sets.as_mut().and_then(|s| s.get_mut(i));
                let changed = sensor::changed_pixels_each(
                    source,
                    background,
                    (w, h),
                    draw,
                    (own, search, &others),
                    &mut |x, y| {
                        if let Some(set) = set.as_mut() {
                            set.push((x, y));
                        }
                    },
                );
                *v = camera_visibility(v, changed);
            }
        }
        sensor::apply_into((source, w, h), draw, &mut rgba);
        if let Some(quality) = draw.recompress_quality {
            rgba = crate::write::jpeg_round_trip(&rgba, w, h, quality).map_err(|e| {
                PipelineError::Camera {
                    index: scene.index,
                    reason: e.to_string(),
                }
            })?;
        }
        Ok(rgba)
    }

    /// Each drone's streak under `draw` (the draw after rendering), moved
    /// by a rolling `shutter`: what the motion blur smears.
    fn frame_streaks(
        &self,
        scene: &FrameScene,
        draw: &CameraDraw,
        shutter: Option<&rolling::Shutter>,
    ) -> Vec<Option<sensor::motion::Streak>> {
        let mut streaks = streaks::streaks(&self.preset, &self.assets.geometry, scene, draw);
        if let Some(s) = shutter {
            s.move_streaks(&mut streaks);
        }
        streaks
    }

    /// Whether `scene`'s motion blur stays within its work budget
    /// ([`smear_budget`]), from geometry alone, before anything is drawn:
    /// its streaks as [`Self::through_camera`] makes them.
    pub(super) fn check_blur(&self, scene: &FrameScene) -> Result<(), PipelineError> {
        let Some(draw) = &scene.camera_model else {
            return Ok(());
        };
        let shutter = rolling::Shutter::of(&self.preset, &self.assets.geometry, scene)?;
        let streaks = self.frame_streaks(scene, &draw.after_render(), shutter.as_ref());
        let list: Vec<sensor::motion::Streak> = streaks.iter().flatten().copied().collect();
        smear_budget(
            &list,
            (scene.camera.width, scene.camera.height),
            scene.index,
        )
    }
}

/// Per measured drone, where its changed pixels are measured from and
/// looked for in the picture (`None`: not visible in the render): its
/// rendered visible box, and under a rolling shutter that box moved by its
/// rows (the pixels claimed against the other drones) and where its drawn
/// rect's rows go (the search: a neighbour's pixels its difference holds
/// move with it); swept by its streak, then through the lens.
fn label_rects(
    vis: &[Visibility],
    shutter: Option<&rolling::Shutter>,
    streak_of: &[Option<sensor::motion::Streak>],
    frame_lens: Option<&lens::FrameLens>,
    (w, h): (u32, u32),
) -> Vec<Option<(PixelRect, PixelRect)>> {
    let finish = |i: usize, r: Option<PixelRect>| {
        let grown = streaks::grown(r, streak_of.get(i).copied().flatten(), (w, h));
        grown.map(|r| frame_lens.map_or(r, |l| lens::footprint(&l.geo, r)))
    };
    (vis.iter().enumerate())
        .map(|(i, v)| {
            let own = v.visible_box.map(pixel_rect);
            let (own, search) = match shutter {
                Some(s) => {
                    let moved = own.and_then(|o| s.moved(i, o));
                    (moved, moved.map(|m| s.near(i).map_or(m, |n| m.union(n))))
                }
                None => (own, own),
            };
            Some((finish(i, own)?, finish(i, search)?))
        })
        .collect()
}

/// The pixels a box covers, whole.
fn pixel_rect(b: PixelBox) -> PixelRect {
    PixelRect {
        x0: b.x0.floor().max(0.0) as u32,
        y0: b.y0.floor().max(0.0) as u32,
        x1: b.x1.ceil().max(0.0) as u32,
        y1: b.y1.ceil().max(0.0) as u32,
    }
}

/// A drone's visibility through the camera: the changed pixels' box and
/// count; the unoccluded count scaled by the same factor, so the visible
/// fraction stays the rendered one (occlusion, not blur).
pub(super) fn camera_visibility(
    rendered: &Visibility,
    changed: Option<(PixelRect, u64)>,
) -> Visibility {
    let Some((r, count)) = changed else {
        return Visibility {
            visible_box: None,
            visible_pixels: 0,
            unoccluded_pixels: rendered.unoccluded_pixels,
        };
    };
    let unoccluded = if rendered.visible_pixels > 0 {
        let scaled = u128::from(rendered.unoccluded_pixels) * u128::from(count);
        u64::try_from(scaled.div_ceil(u128::from(rendered.visible_pixels))).unwrap_or(u64::MAX)
    } else {
        rendered.unoccluded_pixels
    };
    Visibility {
        visible_box: Some(PixelBox {
            x0: f64::from(r.x0),
            y0: f64::from(r.y0),
            x1: f64::from(r.x1),
            y1: f64::from(r.y1),
        }),
        visible_pixels: count,
        unoccluded_pixels: unoccluded.max(count),
    }
}

/// The motion blur's work within its budget ([`sensor::motion::MAX_SMEAR_SAMPLES`]),
/// checked before the blur runs: a frame past it is an error, not minutes of work.
fn smear_budget(
    list: &[sensor::motion::Streak],
    (w, h): (u32, u32),
    index: u64,
) -> Result<(), PipelineError> {
    let samples = sensor::motion::smear_samples(list, w, h);
    let most = sensor::motion::MAX_SMEAR_SAMPLES;
    if samples <= most {
        return Ok(());
    }
    Err(PipelineError::Budget {
        index,
        reason: format!(
            "camera_model.exposure_time_s: the drones' streaks need {samples} samples of motion blur, more than the {most} a frame may (its work budget); shorten the exposure, or make the drones slower, smaller or farther"
        ),
    })
}

/// Per drone, the other drones' rects that may claim pixels of its search
/// area: those in the cells of a grid ([`CellGrid`]) that the area, grown by
/// the camera's reach, touches, each once. A superset of the rivals
/// [`sensor::changed_pixels_each`] keeps (those whose reach meets the area),
/// found without looking at every drone: 100 000 drones through a camera
/// model took 12 s a frame comparing every pair.
struct Rivals<'a> {
    near: &'a [Option<(PixelRect, PixelRect)>],
    reach: u32,
    grid: CellGrid,
    /// Per drone, 1 + the last drone whose list holds it (0: none yet).
    seen: Vec<usize>,
}

impl<'a> Rivals<'a> {
    fn new(near: &'a [Option<(PixelRect, PixelRect)>], reach: u32, size: (u32, u32)) -> Self {
        let grown: Vec<Option<PixelBox>> = (near.iter())
            .map(|r| r.map(|(own, _)| grow(own, reach)))
            .collect();
        Self {
            near,
            reach,
            grid: CellGrid::new(&grown, size),
            seen: vec![0; near.len()],
        }
    }

    /// Drone `i`'s possible rivals for its `search` area into `out` (cleared):
    /// from the grid's cells under the area, or, where those cells and their
    /// entries outnumber the drones (large areas among crowded cells), every
    /// other drone, so a query never costs more than the pairwise scan.
    fn of(&mut self, i: usize, search: PixelRect, out: &mut Vec<PixelRect>) {
        out.clear();
        let area = grow(search, self.reach);
        let mut work = 0;
        for cell in self.grid.cells_of(&area) {
            work += 1 + self.grid.near(cell).len();
            if work > self.near.len() {
                let others = (self.near.iter().enumerate()).filter(|&(j, _)| j != i);
                out.extend(others.filter_map(|(_, r)| r.map(|(own, _)| own)));
                return;
            }
        }
        for cell in self.grid.cells_of(&area) {
            for &j in self.grid.near(cell) {
                let j = j as usize;
                if j != i && self.seen[j] != i + 1 {
                    self.seen[j] = i + 1;
                    out.extend(self.near[j].map(|(own, _)| own));
                }
            }
        }
    }
}

/// `r` grown by `by` pixels on every side, as a box of pixel edges.
fn grow(r: PixelRect, by: u32) -> PixelBox {
    let by = f64::from(by);
    PixelBox {
        x0: f64::from(r.x0) - by,
        y0: f64::from(r.y0) - by,
        x1: f64::from(r.x1) + by,
        y1: f64::from(r.y1) + by,
    }
}

#[cfg(test)]
mod tests {
    use rand::{Rng, SeedableRng};

    use super::*;

    /// Every drone whose reach meets a drone's search area (the rivals
    /// [`sensor::changed_pixels_each`] keeps) is among [`Rivals::of`]'s, once,
    /// and the drone itself is not: over crowds sparse and dense, small and
    /// large, in and out of the picture, and with drones unseen.
    #[test]
    fn the_grid_finds_every_rival_the_pairwise_scan_does() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        let (w, h) = (640u32, 360u32);
        for (n, most_side) in [(12, 40), (300, 12), (300, 300), (40, 900)] {
            let rect = |rng: &mut rand_chacha::ChaCha8Rng| {
                let (x0, y0) = (rng.random_range(0..w + 40), rng.random_range(0..h + 40));
                let (sw, sh) = (
                    rng.random_range(1..most_side),
                    rng.random_range(1..most_side),
                );
                PixelRect {
                    x0,
                    y0,
                    x1: x0 + sw,
                    y1: y0 + sh,
                }
            };
            let near: Vec<Option<(PixelRect, PixelRect)>> = (0..n)
                .map(|_| {
                    let own = rect(&mut rng);
                    let search = PixelRect {
                        x1: own.x1 + rng.random_range(0..8),
                        ..own
                    };
                    rng.random_bool(0.9).then_some((own, search))
                })
                .collect();
            for reach in [0, 3] {
                let mut rivals = Rivals::new(&near, reach, (w, h));
                let mut found = Vec::new();
                for (i, r) in near.iter().enumerate() {
                    let Some((_, search)) = *r else { continue };
                    rivals.of(i, search, &mut found);
                    let area = grow(search, reach);
                    for (j, o) in near.iter().enumerate() {
                        let Some((own, _)) = *o else { continue };
                        let g = grow(own, reach);
                        let meets =
                            g.x0 < area.x1 && area.x0 < g.x1 && g.y0 < area.y1 && area.y0 < g.y1;
                        let listed = found.iter().filter(|&&f| f == own).count();
                        let twins = (near.iter().enumerate())
                            .filter(|&(k, r)| k != i && r.is_some_and(|(o, _)| o == own))
                            .count();
                        if j != i && meets {
                            assert!(listed >= 1, "n {n}, drone {i}: rival {j} missed");
                        }
                        assert!(
                            listed <= twins,
                            "n {n}, drone {i}: {j} listed {listed} times"
                        );
                    }
                }
            }
        }
    }
}
