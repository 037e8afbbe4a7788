//! The frame plan: every decision about a frame's GPU work that needs no GPU.
//!
//! From the drones' boxes and rects ([`super::regions::drone_rects`]) and
//! what is asked (colour, visibility, sample count), [`FramePlan::new`]
//! decides the passes (the main pass, then one per overlap layer: drones
//! whose boxes are apart, drawn alone for their unoccluded counts; a drone
//! that only drones wholly behind it overlap is whole in the main pass and
//! needs none; or the main pass alone, [`FramePlan::main_pass`], whose ids
//! then tell which drones need a layer, planned by [`FramePlan::layer_passes`]),
//! each pass's disjoint rects ([`regions::cover`]), where each rect is resolved
//! to in the atlas (MSAA: shelves as wide as the frame, [`regions::pack_shelves`])
//! and where every read-back rect lands in the one readback buffer. The
//! renderer then only encodes what the plan says and collects what it reads.

use super::RenderError;
use super::ids;
use super::readback::{Read, plan_reads};
use super::regions::{self, DepthRange, Rect};
use super::visibility::{self, occlusion_layers};
use crate::scene::projection::PixelBox;

/// What a frame asks of its plan.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct PlanRequest {
    /// The frame in pixels.
    pub size_px: (u32, u32),
    /// Samples per pixel (1: no resolve, the targets are read directly).
    pub msaa: u32,
    pub color: bool,
    pub visibility: bool,
    /// Draw only the drones' regions (false: the whole frame as one region).
    pub regions: bool,
    /// Scenery may hide drones in the main pass: every drone's unoccluded
    /// count then comes from a layer pass.
    pub scenery: bool,
}

/// One pass: its disjoint rects and the drones drawn in them (scene indices).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub(super) struct PassPlan {
    pub rects: Vec<Rect>,
    pub drones: Vec<usize>,
}

/// A frame's passes, atlas places and reads (see the module docs).
#[derive(Clone, Debug, PartialEq, Eq)]
pub(super) struct FramePlan {
    pub request: PlanRequest,
    /// The main pass first, then the overlap layers (visibility only).
    pub passes: Vec<PassPlan>,
    /// Per drone: whether its unoccluded count comes from a layer pass.
    pub overlapping: Vec<bool>,
    /// Per pass, each rect's top-left corner in the texture it is read
    /// from: the atlas when resolved, else the frame itself.
    pub places: Vec<Vec<(u32, u32)>>,
    /// Atlas rows the resolves need (0 without MSAA).
    pub atlas_rows: u32,
    /// The main pass's colour rects in the readback buffer (colour only).
    pub color_reads: Vec<Read>,
    /// Per pass, its id rects in the readback buffer (visibility only).
    pub id_reads: Vec<Vec<Read>>,
    /// Bytes of the readback buffer the reads use.
    pub readback_size: u64,
}

impl FramePlan {
    /// The plan of a frame whose drones have amodal `boxes`, pixel `rects`
    /// and `depths` (scene order, as [`regions::drone_rects`] and
    /// [`regions::drone_depths`] give them; no depths: any overlapping
    /// drone may hide another).
    pub(super) fn new(
        request: PlanRequest,
        boxes: &[Option<PixelBox>],
        rects: &[Option<Rect>],
        depths: &[Option<DepthRange>],
    ) -> Result<Self, RenderError> {
        let n = rects.len();
        let (layers, overlapping) = if request.visibility {
            let (layers, overlapping) = layers(boxes, depths, request)?;
            (members(layers, &overlapping), overlapping)
        } else {
            (Vec::new(), vec![false; n])
        };
        Ok(Self::of(request, rects, Some(0..n), layers, overlapping))
    }

    /// The main pass alone, its layers left for [`FramePlan::layer_passes`]
    /// once it is read: `overlapping` names the drones that may need one
    /// (as [`FramePlan::new`]'s), of which the main pass's ids tell the
    /// ones that do ([`super::ids::shows_front`]).
    pub(super) fn main_pass(
        request: PlanRequest,
        boxes: &[Option<PixelBox>],
        rects: &[Option<Rect>],
        depths: &[Option<DepthRange>],
    ) -> Result<Self, RenderError> {
        let n = rects.len();
        let overlapping = if request.visibility {
            hidden(boxes, depths, request)?
        } else {
            vec![false; n]
        };
        Ok(Self::of(
            request,
            rects,
            Some(0..n),
            Vec::new(),
            overlapping,
        ))
    }

    /// The overlap layers of the drones `alone` names, and only those, as
    /// a plan of their own (ids only, no main pass): drones in one layer
    /// are apart, so each layer shows each of its drones unoccluded.
    pub(super) fn layer_passes(
        request: PlanRequest,
        boxes: &[Option<PixelBox>],
        rects: &[Option<Rect>],
        alone: &[bool],
    ) -> Result<Self, RenderError> {
        let request = PlanRequest {
            color: false,
            scenery: false,
            ..request
        };
        let kept: Vec<Option<PixelBox>> = (boxes.iter().zip(alone))
            .map(|(b, &a)| b.filter(|_| a))
            .collect();
        let (layers, _) = layers(&kept, &[], request)?;
        let layers = members(layers, alone);
        Ok(Self::of(request, rects, None, layers, alone.to_vec()))
    }

    /// The plan of a main pass over `main` (none: layers only), then the
    /// `layers`, with their places and reads.
    fn of(
        request: PlanRequest,
        rects: &[Option<Rect>],
        main: Option<std::ops::Range<usize>>,
        layers: Vec<Vec<usize>>,
        overlapping: Vec<bool>,
    ) -> Self {
        let (width, height) = request.size_px;
        let pass_of = |members: Vec<usize>| -> PassPlan {
            let (rects, drones) = if request.regions {
                regions::cover(rects, members)
            } else {
                let drones = members.into_iter().filter(|&i| rects[i].is_some());
                (vec![Rect::full(width, height)], drones.collect())
            };
            PassPlan { rects, drones }
        };
        let main = main.map(|all| pass_of(all.collect()));
        let passes: Vec<PassPlan> = main
            .into_iter()
            .chain(layers.into_iter().map(pass_of))
            .collect();
        let (places, atlas_rows) = places(&passes, request);
        // The main pass's colour, then the ids of the main pass and of each layer.
        let mut size = 0u64;
        let color_reads = match (request.color, passes.first(), places.first()) {
            (true, Some(main), Some(places)) => plan_reads(&main.rects, places, 4, &mut size),
            _ => Vec::new(),
        };
        let id_reads = if request.visibility {
            // Each pass's id rects, as many bytes a pixel as its id samples.
            let bpp = ids::id_bytes_per_pixel(request.msaa);
            (passes.iter().zip(&places))
                .map(|(pass, places)| plan_reads(&pass.rects, places, bpp, &mut size))
                .collect()
        } else {
            Vec::new()
        };
        Self {
            request,
            passes,
            overlapping,
            places,
            atlas_rows,
            color_reads,
            id_reads,
            readback_size: size,
        }
    }

    /// Whether the passes are resolved into the atlas (MSAA) and read from there.
    pub(super) fn resolved(&self) -> bool {
        self.request.msaa > 1
    }

    /// Every pass's resolve rects (`resolve.wgsl`: the place in an atlas of
    /// `rows` rows as wide as the frame, in its device coordinates, then the
    /// whole-pixel offset back to the frame), and where each pass's begin.
    pub(super) fn resolve_instances(&self, rows: u32) -> (Vec<[f32; 6]>, Vec<u32>) {
        let width = self.request.size_px.0;
        let mut data = Vec::new();
        let mut first = Vec::with_capacity(self.passes.len());
        for (pass, places) in self.passes.iter().zip(&self.places) {
            first.push(data.len() as u32);
            for (r, &(x, y)) in pass.rects.iter().zip(places) {
                let place = Rect {
                    x0: x,
                    y0: y,
                    x1: x + r.width(),
                    y1: y + r.height(),
                };
                let [x0, y0, x1, y1] = rect_ndc(&place, width, rows);
                // Whole pixels, exact in f32 below 2^24.
                let dx = f64::from(r.x0) - f64::from(x);
                let dy = f64::from(r.y0) - f64::from(y);
                data.push([x0, y0, x1, y1, dx as f32, dy as f32]);
            }
        }
        (data, first)
    }
}

/// The overlap layers of the drones whose (clipped) boxes are in the frame,
/// and whether each drone may be hidden by another (every drone in view,
/// with scenery): whether its unoccluded count needs a layer pass.
fn layers(
    boxes: &[Option<PixelBox>],
    depths: &[Option<DepthRange>],
    request: PlanRequest,
) -> Result<(Vec<Vec<usize>>, Vec<bool>), RenderError> {
    let clipped = clipped(boxes, request.size_px);
    let (layers, mut overlapping) = occlusion_layers(&clipped, depths)?;
    if request.scenery {
        overlapping = clipped.iter().map(Option::is_some).collect();
    }
    Ok((layers, overlapping))
}

/// [`layers`]' second result alone (the same drones), without sorting the
/// drones into layers ([`visibility::hidden`]).
fn hidden(
    boxes: &[Option<PixelBox>],
    depths: &[Option<DepthRange>],
    request: PlanRequest,
) -> Result<Vec<bool>, RenderError> {
    let clipped = clipped(boxes, request.size_px);
    if request.scenery {
        return Ok(clipped.iter().map(Option::is_some).collect());
    }
    visibility::hidden(&clipped, depths, request.size_px)
}

/// `boxes` clipped to a frame of `width`×`height`; empty ones `None`.
fn clipped(boxes: &[Option<PixelBox>], (width, height): (u32, u32)) -> Vec<Option<PixelBox>> {
    (boxes.iter())
        .map(|b| {
            b.map(|b| b.clip(f64::from(width), f64::from(height)))
                .filter(|b| b.width() > 0.0 && b.height() > 0.0)
        })
        .collect()
}

/// `layers` with only the drones `keep` names, empty layers dropped.
fn members(layers: Vec<Vec<usize>>, keep: &[bool]) -> Vec<Vec<usize>> {
    layers
        .into_iter()
        .map(|l| l.into_iter().filter(|&i| keep[i]).collect::<Vec<_>>())
        .filter(|l| !l.is_empty())
        .collect()
}

/// Each pass's rects' places in the texture read, and the atlas rows used:
/// packed in shelves when resolved (never taller than the frame: a pass
/// whose rects pack worse keeps them where they are), else in place.
fn places(passes: &[PassPlan], request: PlanRequest) -> (Vec<Vec<(u32, u32)>>, u32) {
    let (width, height) = request.size_px;
    let resolved = request.msaa > 1;
    let packed: Vec<(Vec<(u32, u32)>, u32)> = passes
        .iter()
        .map(|pass| {
            let in_place = || (pass.rects.iter().map(|r| (r.x0, r.y0)).collect(), height);
            match resolved.then(|| regions::pack_shelves(&pass.rects, width)) {
                Some((places, rows)) if rows <= height => (places, rows),
                Some(_) => in_place(),
                None => (in_place().0, 0),
            }
        })
        .collect();
    let rows = packed.iter().map(|(_, rows)| *rows).max().unwrap_or(0);
    (packed.into_iter().map(|(places, _)| places).collect(), rows)
}

/// A pixel rect in normalised device coordinates (y up), for `rect.wgsl`.
pub(super) fn rect_ndc(r: &Rect, width: u32, height: u32) -> [f32; 4] {
    let x = |v: u32| (f64::from(v) / f64::from(width) * 2.0 - 1.0) as f32;
    let y = |v: u32| (1.0 - f64::from(v) / f64::from(height) * 2.0) as f32;
    [x(r.x0), y(r.y0), x(r.x1), y(r.y1)]
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    fn request(msaa: u32) -> PlanRequest {
        PlanRequest {
            size_px: (320, 180),
            msaa,
            color: true,
            visibility: true,
            regions: true,
            scenery: false,
        }
    }

    fn pixel_box(x0: f64, y0: f64, x1: f64, y1: f64) -> Option<PixelBox> {
        Some(PixelBox { x0, y0, x1, y1 })
    }

    /// Boxes and rects as the renderer derives them.
    fn drones(boxes: &[Option<PixelBox>], (w, h): (u32, u32)) -> Vec<Option<Rect>> {
        boxes
            .iter()
            .map(|b| b.and_then(|b| regions::pixel_rect(&b, w, h)))
            .collect()
    }

    fn random_boxes(rng: &mut impl Rng, n: usize, (w, h): (u32, u32)) -> Vec<Option<PixelBox>> {
        (0..n)
            .map(|_| {
                let x0 = rng.random_range(-20.0..f64::from(w));
                let y0 = rng.random_range(-20.0..f64::from(h));
                let side = rng.random_range(0.5..60.0);
                pixel_box(x0, y0, x0 + side, y0 + side * 0.7)
            })
            .collect()
    }

    fn covered(rects: &[Rect], (w, h): (u32, u32)) -> Vec<u8> {
        let mut cover = vec![0u8; (w * h) as usize];
        for r in rects {
            for y in r.y0..r.y1 {
                for x in r.x0..r.x1 {
                    cover[(y * w + x) as usize] += 1;
                }
            }
        }
        cover
    }

    #[test]
    fn overlapping_drones_get_layers_and_apart_ones_none() {
        let size = request(4).size_px;
        // 0 and 1 overlap; 2 is far from both.
        let boxes = [
            pixel_box(10.0, 10.0, 30.0, 30.0),
            pixel_box(20.0, 20.0, 40.0, 40.0),
            pixel_box(200.0, 100.0, 220.0, 120.0),
        ];
        let plan = FramePlan::new(request(4), &boxes, &drones(&boxes, size), &[]).expect("plan");
        assert_eq!(plan.overlapping, [true, true, false]);
        let layers: Vec<&[usize]> = plan.passes[1..].iter().map(|p| &p.drones[..]).collect();
        assert_eq!(layers, [&[0][..], &[1][..]], "each overlapping drone alone");
        assert_eq!(plan.passes[0].drones, [0, 1, 2]);
        assert_eq!(
            plan.id_reads.len(),
            3,
            "ids of the main pass and each layer"
        );

        // Without visibility: one pass, no layers, no id reads.
        let colour_only = PlanRequest {
            visibility: false,
            ..request(4)
        };
        let plan = FramePlan::new(colour_only, &boxes, &drones(&boxes, size), &[]).expect("plan");
        assert_eq!(plan.passes.len(), 1);
        assert!(plan.id_reads.is_empty() && plan.overlapping.iter().all(|o| !o));

        // Scenery: every drone in view is measured alone.
        let scenery = PlanRequest {
            scenery: true,
            ..request(4)
        };
        let plan = FramePlan::new(scenery, &boxes, &drones(&boxes, size), &[]).expect("plan");
        assert_eq!(plan.overlapping, [true, true, true]);
        let alone: usize = plan.passes[1..].iter().map(|p| p.drones.len()).sum();
        assert_eq!(alone, 3);
    }

    #[test]
    fn only_drones_that_may_be_hidden_get_layers() {
        let size = request(4).size_px;
        // 0 and 1 overlap, 2 overlaps 1; 3 is apart.
        let boxes = [
            pixel_box(10.0, 10.0, 30.0, 30.0),
            pixel_box(20.0, 20.0, 40.0, 40.0),
            pixel_box(35.0, 35.0, 50.0, 50.0),
            pixel_box(200.0, 100.0, 220.0, 120.0),
        ];
        let rects = drones(&boxes, size);
        let depth = |near: f64, far: f64| Some(DepthRange { near, far });
        let plan_of = |depths: &[Option<DepthRange>]| {
            FramePlan::new(request(4), &boxes, &rects, depths).expect("plan")
        };
        let alone = |plan: &FramePlan| -> Vec<usize> {
            let mut drones: Vec<usize> = plan.passes[1..]
                .iter()
                .flat_map(|p| p.drones.clone())
                .collect();
            drones.sort_unstable();
            drones
        };
        // 0 in front of 1 in front of 2: only 1 and 2 can be hidden.
        let plan = plan_of(&[
            depth(5.0, 5.5),
            depth(6.0, 6.5),
            depth(7.0, 7.5),
            depth(9.0, 9.5),
        ]);
        assert_eq!(plan.overlapping, [false, true, true, false]);
        assert_eq!(alone(&plan), [1, 2]);
        // 2 in front of 1 in front of 0: 0 and 1 can be hidden.
        let plan = plan_of(&[
            depth(7.0, 7.5),
            depth(6.0, 6.5),
            depth(5.0, 5.5),
            depth(9.0, 9.5),
        ]);
        assert_eq!(plan.overlapping, [true, true, false, false]);
        assert_eq!(alone(&plan), [0, 1]);
        // Depth ranges that meet or interleave, or are unknown: both may hide the other.
        for depths in [
            vec![depth(5.0, 6.0), depth(6.0, 7.0), depth(7.0, 8.0), None],
            vec![depth(5.0, 6.0), depth(5.5, 7.0), depth(6.5, 8.0), None],
            vec![None, depth(6.0, 7.0), None, None],
            vec![],
        ] {
            assert_eq!(
                plan_of(&depths).overlapping,
                [true, true, true, false],
                "{depths:?}"
            );
        }
        // Behind by less than the margin: still measured alone.
        let close = 5.5 * (1.0 + 1e-6);
        let plan = plan_of(&[depth(5.0, 5.5), depth(close, 6.5), depth(7.0, 7.5), None]);
        assert_eq!(plan.overlapping, [true, true, true, false]);
        // Scenery may hide any drone: every drone is measured alone.
        let scenery = PlanRequest {
            scenery: true,
            ..request(4)
        };
        let depths = [
            depth(5.0, 5.5),
            depth(6.0, 6.5),
            depth(7.0, 7.5),
            depth(9.0, 9.5),
        ];
        let plan = FramePlan::new(scenery, &boxes, &rects, &depths).expect("plan");
        assert_eq!(plan.overlapping, [true; 4]);
    }

    #[test]
    fn random_plans_cover_exactly_pack_within_the_frame_and_read_apart() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(23);
        for case in 0..60 {
            let msaa = if case % 3 == 0 { 1 } else { 4 };
            let req = request(msaa);
            let size = req.size_px;
            let n = rng.random_range(0..30);
            let boxes = random_boxes(&mut rng, n, size);
            let rects = drones(&boxes, size);
            let plan = FramePlan::new(req, &boxes, &rects, &[]).expect("plan");
            // Each pass covers exactly the union of its drones' rects, once.
            for pass in &plan.passes {
                let mut want = vec![0u8; (size.0 * size.1) as usize];
                for &i in &pass.drones {
                    let cover = covered(&[rects[i].expect("a drawn drone has a rect")], size);
                    for (w, c) in want.iter_mut().zip(cover) {
                        *w |= c;
                    }
                }
                assert_eq!(covered(&pass.rects, size), want, "case {case}");
            }
            // Places: inside the atlas (frame wide, at most frame tall), disjoint.
            assert!(plan.atlas_rows <= size.1);
            for (pass, places) in plan.passes.iter().zip(&plan.places) {
                let placed: Vec<Rect> = (pass.rects.iter().zip(places))
                    .map(|(r, &(x, y))| Rect {
                        x0: x,
                        y0: y,
                        x1: x + r.width(),
                        y1: y + r.height(),
                    })
                    .collect();
                for p in &placed {
                    assert!(p.x1 <= size.0 && p.y1 <= size.1, "case {case}: {p:?}");
                    assert!(!plan.resolved() || p.y1 <= plan.atlas_rows);
                }
                assert!(covered(&placed, size).iter().all(|&c| c <= 1));
            }
            // Reads: aligned, disjoint, within the readback size.
            let mut reads: Vec<(Read, u32)> = (plan.color_reads.iter().map(|r| (*r, 4)))
                .chain(plan.id_reads.iter().flatten().map(|r| (*r, 0)))
                .collect();
            reads.sort_by_key(|(r, _)| r.offset);
            let mut end = 0;
            for (read, bpp) in reads {
                assert!(read.offset >= end && read.offset % 256 == 0, "case {case}");
                assert!(read.row >= read.rect.width() * bpp.max(4));
                end = read.offset + u64::from(read.row) * u64::from(read.rect.height());
            }
            assert!(end <= plan.readback_size);
            // One resolve rect per rect, each pass's after the one before.
            let (resolve, first) = plan.resolve_instances(plan.atlas_rows.max(1));
            let counts: Vec<usize> = plan.passes.iter().map(|p| p.rects.len()).collect();
            assert_eq!(resolve.len(), counts.iter().sum::<usize>());
            let starts: Vec<u32> = (counts.iter().scan(0, |at, &c| {
                let start = *at;
                *at += c as u32;
                Some(start)
            }))
            .collect();
            assert_eq!(first, starts);
        }
    }

    #[test]
    fn layer_passes_hold_each_named_drone_once_apart_and_nothing_else() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        let req = request(4);
        let size = req.size_px;
        let boxes = random_boxes(&mut rng, 40, size);
        let rects = drones(&boxes, size);
        let main = FramePlan::main_pass(req, &boxes, &rects, &[]).expect("plan");
        assert_eq!(main.passes.len(), 1, "the main pass alone");
        assert_eq!(
            main.overlapping,
            FramePlan::new(req, &boxes, &rects, &[])
                .expect("plan")
                .overlapping
        );
        // Every other candidate named, as if the main pass showed a drone in front of it.
        let alone: Vec<bool> = (main.overlapping.iter().enumerate())
            .map(|(i, &o)| o && i % 2 == 0)
            .collect();
        assert!(alone.iter().filter(|&&a| a).count() >= 5);
        let plan = FramePlan::layer_passes(req, &boxes, &rects, &alone).expect("plan");
        assert!(!plan.request.color && plan.color_reads.is_empty());
        assert_eq!(plan.id_reads.len(), plan.passes.len());
        let mut seen: Vec<usize> = plan.passes.iter().flat_map(|p| p.drones.clone()).collect();
        seen.sort_unstable();
        let named: Vec<usize> = (0..40)
            .filter(|&i| alone[i] && rects[i].is_some())
            .collect();
        assert_eq!(seen, named, "each named drone in one layer, no other drone");
        for pass in &plan.passes {
            for (k, &a) in pass.drones.iter().enumerate() {
                for &b in &pass.drones[k + 1..] {
                    // Apart as the layers see them: clipped to the frame, 1 px padded.
                    let (w, h) = (f64::from(size.0), f64::from(size.1));
                    let (ba, bb) = (
                        boxes[a].expect("box").clip(w, h),
                        boxes[b].expect("box").clip(w, h),
                    );
                    let apart = ba.x1 + 1.0 <= bb.x0 - 1.0
                        || bb.x1 + 1.0 <= ba.x0 - 1.0
                        || ba.y1 + 1.0 <= bb.y0 - 1.0
                        || bb.y1 + 1.0 <= ba.y0 - 1.0;
                    assert!(apart, "{a} and {b} share a layer");
                }
            }
        }
    }

    #[test]
    fn whole_frame_mode_is_one_rect_with_the_drones_in_view() {
        let req = PlanRequest {
            regions: false,
            visibility: false,
            ..request(1)
        };
        let boxes = [pixel_box(10.0, 10.0, 20.0, 20.0), None];
        let plan = FramePlan::new(req, &boxes, &drones(&boxes, req.size_px), &[]).expect("plan");
        assert_eq!(plan.passes[0].rects, [Rect::full(320, 180)]);
        assert_eq!(plan.passes[0].drones, [0]);
        assert_eq!(plan.places[0], [(0, 0)], "read in place without MSAA");
        assert_eq!(plan.atlas_rows, 0);
        assert_eq!(plan.readback_size, 320 * 4 * 180);
    }

    #[test]
    fn rect_ndc_maps_the_frame_corners() {
        assert_eq!(
            rect_ndc(&Rect::full(640, 360), 640, 360),
            [-1.0, 1.0, 1.0, -1.0]
        );
    }
}
