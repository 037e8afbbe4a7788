//! Benchmarks that produce the tables in docs/: label error against run time
//! (`swarmshot bench accuracy`) and frame time by resolution × MSAA × passes
//! (part of the same report). Run them from a release build.
//!
//! The reference box of a drone is its visible box in an instance-id pass
//! rendered at 4× the output resolution (divided by 4). Each method's box is
//! compared with it edge by edge (|Δ| in output pixels) and by IoU, over
//! every drone that is visible in the reference.

use std::fmt::Write as _;
use std::path::Path;
use std::time::Instant;

use anyhow::Context;

use crate::annotate::PixelBox;
use crate::pipeline::FramePipeline;
use crate::preset::sweep::SweepRange;
use crate::preset::{BoxMethod, FilteredDrones, Placement, Preset, Resolution, Volume};
use crate::render::GpuContext;
use crate::render::visibility::pixel_stats;

/// One scene family of the accuracy report.
pub struct BenchScene {
    pub name: &'static str,
    pub preset: Preset,
}

/// The fixed scenes: single drones at many attitudes, dense overlapping
/// swarms, tiny distant drones; `frames` each, at `width`×`height`.
pub fn accuracy_scenes(frames: u32, width: u32, height: u32) -> Vec<BenchScene> {
    let base = |seed: u64| {
        let mut p = Preset::default();
        p.seed = seed;
        p.render.resolution = Resolution::Custom { width, height };
        p.labels.min_box_px = 0.0;
        p.labels.filtered = FilteredDrones::Drop;
        p.attitude.roll_deg = (-60.0, 60.0);
        p.attitude.pitch_deg = (-60.0, 60.0);
        p.repeats = frames;
        p
    };
    let mut single = base(11);
    single.placement = Placement::Structured {
        x_count: 1,
        y_count: 1,
        z_count: 1,
        load_factor: 1.0,
    };
    single.camera.z = SweepRange::fixed(1.5);
    let mut dense = base(12);
    dense.placement = Placement::Randomized {
        count: (40, 60),
        count_distribution: Default::default(),
        volume: Volume::Box {
            size_m: (3.0, 1.5, 3.0),
        },
        min_separation_m: 0.36,
    };
    // Like the quickstart's small boxes: 10–30 px drones at any attitude
    // (thin legs and edge-on rotors), some overlapping.
    let mut small = base(14);
    small.placement = Placement::Randomized {
        count: (10, 15),
        count_distribution: Default::default(),
        volume: Volume::Box {
            size_m: (8.0, 4.0, 8.0),
        },
        min_separation_m: 0.7,
    };
    small.attitude.roll_deg = (-90.0, 90.0);
    small.attitude.pitch_deg = (-90.0, 90.0);
    small.camera.z = SweepRange::fixed(f64::from(width.min(1920)) / 1920.0 * 0.9);
    let mut tiny = base(13);
    tiny.placement = Placement::Randomized {
        count: (10, 20),
        count_distribution: Default::default(),
        volume: Volume::Box {
            size_m: (150.0, 60.0, 150.0),
        },
        min_separation_m: 2.0,
    };
    vec![
        BenchScene {
            name: "single drones",
            preset: single,
        },
        BenchScene {
            name: "dense swarm",
            preset: dense,
        },
        BenchScene {
            name: "tiny distant",
            preset: tiny,
        },
        BenchScene {
            name: "small (10–30 px)",
            preset: small,
        },
    ]
}

/// A box method as benchmarked: the method plus, for `Visible`, the id-pass scale.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MethodSetting {
    pub method: BoxMethod,
    pub id_scale: u32,
    /// Through the benchmark's camera model ([`bench_camera`]): the visible
    /// box is then the pixels the drone changes in the camera image.
    pub camera: bool,
    /// With haze of this meteorological visibility (metres) on the drones
    /// (`atmosphere`; with `camera`, faded pixels that change the picture by
    /// less than a level leave the visible box).
    pub haze_visibility_m: Option<f64>,
}

/// The camera of the accuracy benchmark's camera rows: a Gaussian lens
/// blur of σ 1 px, read noise 1 level and a little shot noise.
pub fn bench_camera() -> crate::preset::camera_model::CameraModel {
    crate::preset::camera_model::CameraModel {
        psf: crate::preset::camera_model::Psf::Gaussian {
            sigma_px: (1.0, 1.0),
        },
        read_noise_levels: (1.0, 1.0),
        shot_noise_gain: (0.02, 0.02),
        ..Default::default()
    }
}

impl MethodSetting {
    pub fn label(&self) -> String {
        match self.method {
            BoxMethod::Visible if self.camera => match self.haze_visibility_m {
                Some(v) => format!(
                    "Visible (id pass {}×), camera σ 1 px, haze V {v} m",
                    self.id_scale
                ),
                None => format!("Visible (id pass {}×), camera σ 1 px", self.id_scale),
            },
            BoxMethod::Visible => format!("Visible (id pass {}×)", self.id_scale),
            BoxMethod::Amodal => "Amodal".into(),
            BoxMethod::PaperAabb => "PaperAabb".into(),
        }
    }
}

/// One row of the accuracy table.
#[derive(Clone, Debug)]
pub struct AccuracyRow {
    pub scene: &'static str,
    pub setting: MethodSetting,
    pub msaa: u32,
    pub boxes: usize,
    pub mean_edge_px: f64,
    pub worst_edge_px: f64,
    pub mean_iou: f64,
    /// Picture + labels (`FramePipeline::make_scene`: one pass draws the
    /// drones for both when the method needs visibility), per frame.
    pub frame_ms: f64,
    /// Labels alone (`FramePipeline::labels`: geometry, plus the
    /// visibility-only pass when the method needs it), per box.
    pub label_us_per_box: f64,
}

fn ms(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}

/// Run the accuracy benchmark.
pub fn accuracy(
    ctx: &GpuContext,
    frames: u32,
    width: u32,
    height: u32,
) -> anyhow::Result<Vec<AccuracyRow>> {
    let settings = [
        MethodSetting {
            method: BoxMethod::PaperAabb,
            id_scale: 1,
            camera: false,
            haze_visibility_m: None,
        },
        MethodSetting {
            method: BoxMethod::Amodal,
            id_scale: 1,
            camera: false,
            haze_visibility_m: None,
        },
        MethodSetting {
            method: BoxMethod::Visible,
            id_scale: 1,
            camera: false,
            haze_visibility_m: None,
        },
        MethodSetting {
            method: BoxMethod::Visible,
            id_scale: 2,
            camera: false,
            haze_visibility_m: None,
        },
        MethodSetting {
            method: BoxMethod::Visible,
            id_scale: 1,
            camera: true,
            haze_visibility_m: None,
        },
        MethodSetting {
            method: BoxMethod::Visible,
            id_scale: 1,
            camera: true,
            haze_visibility_m: Some(HAZE_VISIBILITY_M),
        },
    ];
    let mut rows = Vec::new();
    for scene_def in accuracy_scenes(frames, width, height) {
        let base = FramePipeline::new(scene_def.preset.clone())?;
        let mut renderer = base.renderer(ctx);
        let n_frames = scene_def.preset.frame_count();
        let references = reference_boxes(&base, &mut renderer, n_frames)?;
        for setting in settings {
            for msaa in [1, 4] {
                let mut preset = scene_def.preset.clone();
                preset.labels.box_method = setting.method;
                preset.labels.id_scale = setting.id_scale;
                preset.camera_model = setting.camera.then(bench_camera);
                preset.atmosphere =
                    (setting.haze_visibility_m).map(|v| crate::preset::atmosphere::Atmosphere {
                        visibility_m: (v, v),
                    });
                preset.render.msaa = msaa;
                let pipeline = base.update(preset)?;
                // Warm-up: pipelines and targets are built on first use.
                pipeline.make(&mut renderer, 0)?;
                let mut errors = Errors::default();
                let (mut frame_ms, mut label_ms, mut boxes) = (0.0, 0.0, 0usize);
                for index in 0..n_frames {
                    let scene = pipeline.scene(index)?;
                    let t = Instant::now();
                    pipeline.labels(&mut renderer, &scene)?;
                    label_ms += ms(t);
                    let t = Instant::now();
                    let labels = pipeline.make_scene(&mut renderer, scene)?.labels;
                    frame_ms += ms(t);
                    let refs = &references[index as usize];
                    boxes += score(&labels, refs, setting.method, (width, height), &mut errors);
                }
                let mean = |v: &[f64]| {
                    if v.is_empty() {
                        f64::NAN
                    } else {
                        v.iter().sum::<f64>() / v.len() as f64
                    }
                };
                rows.push(AccuracyRow {
                    scene: scene_def.name,
                    setting,
                    msaa,
                    boxes,
                    mean_edge_px: mean(&errors.edges),
                    worst_edge_px: errors.worst,
                    mean_iou: mean(&errors.ious),
                    frame_ms: frame_ms / n_frames as f64,
                    label_us_per_box: label_ms * 1e3 / boxes.max(1) as f64,
                });
            }
        }
    }
    Ok(rows)
}

/// The haze row's visibility: the accuracy scenes' drones are metres away, so a
/// short visibility fades them by a visible share (t = exp(−3.912·d/V)).
const HAZE_VISIBILITY_M: f64 = 30.0;

/// Each frame's reference boxes: the drones' pixels in an id pass at 4× the
/// frame's size, scaled back.
fn reference_boxes(
    base: &FramePipeline,
    renderer: &mut crate::render::Renderer,
    n_frames: u64,
) -> anyhow::Result<Vec<Vec<Option<PixelBox>>>> {
    let mut references: Vec<Vec<Option<PixelBox>>> = Vec::new();
    for index in 0..n_frames {
        let scene = base.scene(index)?;
        let mut big = scene.clone();
        big.camera.width *= 4;
        big.camera.height *= 4;
        let ids = renderer.render_ids(&big, &|_| true)?;
        references.push(
            pixel_stats(&ids, scene.drones.len())
                .into_iter()
                .map(|(b, _)| {
                    b.map(|b| PixelBox {
                        x0: b.x0 / 4.0,
                        y0: b.y0 / 4.0,
                        x1: b.x1 / 4.0,
                        y1: b.y1 / 4.0,
                    })
                })
                .collect(),
        );
    }
    Ok(references)
}

/// Edge errors, IoUs and the worst edge error of the boxes scored so far.
#[derive(Default)]
struct Errors {
    edges: Vec<f64>,
    ious: Vec<f64>,
    worst: f64,
}

/// Score one frame's labels against its reference boxes; returns the boxes scored.
fn score(
    labels: &[crate::annotate::DroneLabel],
    references: &[Option<PixelBox>],
    method: BoxMethod,
    (width, height): (u32, u32),
    errors: &mut Errors,
) -> usize {
    let mut boxes = 0;
    for l in labels {
        let Some(reference) = references.get(l.drone).copied().flatten() else {
            continue;
        };
        let b = match method {
            BoxMethod::Visible => match l.visibility.and_then(|v| v.visible_box) {
                Some(b) => b,
                None => continue,
            },
            BoxMethod::Amodal => l.amodal.clip(f64::from(width), f64::from(height)),
            BoxMethod::PaperAabb => l.paper_aabb.clip(f64::from(width), f64::from(height)),
        };
        boxes += 1;
        for (a, r) in [
            (b.x0, reference.x0),
            (b.y0, reference.y0),
            (b.x1, reference.x1),
            (b.y1, reference.y1),
        ] {
            let e = (a - r).abs();
            errors.worst = errors.worst.max(e);
            errors.edges.push(e);
        }
        errors.ious.push(b.iou(&reference));
    }
    boxes
}

/// One row of the frame-time table.
#[derive(Clone, Debug)]
pub struct TimingRow {
    pub width: u32,
    pub height: u32,
    pub msaa: u32,
    pub passes: &'static str,
    pub frame_ms: f64,
}

/// Median frame time of the quickstart-like scene by resolution × MSAA × passes.
pub fn timings(ctx: &GpuContext, preset: &Preset, frames: u64) -> anyhow::Result<Vec<TimingRow>> {
    let mut rows = Vec::new();
    for (width, height) in [(960, 540), (1920, 1080), (4096, 2160)] {
        for msaa in [1, 4] {
            for (passes, method) in [
                ("colour", BoxMethod::Amodal),
                ("colour + id", BoxMethod::Visible),
            ] {
                let mut p = preset.clone();
                p.render.resolution = Resolution::Custom { width, height };
                p.render.msaa = msaa;
                p.labels.box_method = method;
                if method != BoxMethod::Visible {
                    // The visibility filters need ids too: off, so "colour" is colour alone.
                    p.labels.min_visible_pixels = 0;
                    p.labels.min_visible_fraction = 0.0;
                }
                let pipeline = FramePipeline::new(p)?;
                let mut renderer = pipeline.renderer(ctx);
                let mut times = Vec::new();
                for index in 0..frames.min(pipeline.frame_count()) {
                    let scene = pipeline.scene(index)?;
                    let t = Instant::now();
                    let frame = pipeline.make_scene(&mut renderer, scene)?;
                    renderer.recycle(frame.rgba, frame.painted);
                    times.push(ms(t));
                }
                times.sort_by(f64::total_cmp);
                // The first frame builds pipelines and targets: drop it when there are others.
                let times = if times.len() > 2 {
                    &times[..times.len() - 1]
                } else {
                    &times[..]
                };
                rows.push(TimingRow {
                    width,
                    height,
                    msaa,
                    passes,
                    frame_ms: times[times.len() / 2],
                });
            }
        }
    }
    Ok(rows)
}

/// Markdown tables of both reports.
pub fn markdown(acc: &[AccuracyRow], timing: &[TimingRow]) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "| scene | box method | MSAA | boxes | mean edge error (px) | worst edge error (px) | mean IoU | ms / frame | µs / box (labels) |"
    );
    let _ = writeln!(s, "|---|---|---|---|---|---|---|---|---|");
    for r in acc {
        let _ = writeln!(
            s,
            "| {} | {} | {}× | {} | {:.3} | {:.2} | {:.3} | {:.1} | {:.1} |",
            r.scene,
            r.setting.label(),
            r.msaa,
            r.boxes,
            r.mean_edge_px,
            r.worst_edge_px,
            r.mean_iou,
            r.frame_ms,
            r.label_us_per_box
        );
    }
    let _ = writeln!(s);
    let _ = writeln!(s, "| resolution | MSAA | passes | ms / frame (median) |");
    let _ = writeln!(s, "|---|---|---|---|");
    for r in timing {
        let _ = writeln!(
            s,
            "| {}×{} | {}× | {} | {:.1} |",
            r.width, r.height, r.msaa, r.passes, r.frame_ms
        );
    }
    s
}

/// Plot mean edge error against frame time, one series per box method.
pub fn plot(acc: &[AccuracyRow], path: &Path) -> anyhow::Result<()> {
    use plotters::prelude::*;
    let font = [
        "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf",
        "/usr/share/fonts/TTF/DejaVuSans.ttf",
    ]
    .iter()
    .find_map(|p| std::fs::read(p).ok())
    .context("the plot needs the DejaVu Sans font (Debian: fonts-dejavu-core)")?;
    let font: &'static [u8] = Box::leak(font.into_boxed_slice());
    plotters::style::register_font("sans-serif", FontStyle::Normal, font)
        .map_err(|_| anyhow::anyhow!("invalid font file"))?;
    let root = BitMapBackend::new(path, (900, 560)).into_drawing_area();
    root.fill(&WHITE)?;
    let max_t = acc.iter().map(|r| r.frame_ms).fold(1.0, f64::max) * 1.1;
    let finite = || {
        acc.iter()
            .map(|r| r.mean_edge_px)
            .filter(|e| e.is_finite() && *e > 0.0)
    };
    let max_e = finite().fold(0.1, f64::max) * 2.0;
    let min_e = finite().fold(max_e, f64::min) / 2.0;
    let mut chart = ChartBuilder::on(&root)
        .caption(
            "Label error against run time (lavapipe, release build)",
            ("sans-serif", 22),
        )
        .margin(14)
        .x_label_area_size(44)
        .y_label_area_size(60)
        .build_cartesian_2d(0.0..max_t, (min_e..max_e).log_scale())?;
    chart
        .configure_mesh()
        .x_desc("ms per frame (colour pass + labels)")
        .y_desc("mean edge error vs 4× reference (px, log)")
        .label_style(("sans-serif", 14))
        .draw()?;
    let colours = [RED, BLUE, GREEN, MAGENTA];
    let labels: Vec<String> = {
        let mut v: Vec<String> = acc.iter().map(|r| r.setting.label()).collect();
        v.dedup();
        let mut seen = Vec::new();
        for l in v {
            if !seen.contains(&l) {
                seen.push(l);
            }
        }
        seen
    };
    for (k, label) in labels.iter().enumerate() {
        let colour = colours[k % colours.len()];
        // Filled: MSAA 1×; hollow: MSAA 4× (same boxes, slower colour pass).
        let pts: Vec<(f64, f64, bool)> = acc
            .iter()
            .filter(|r| &r.setting.label() == label && r.mean_edge_px.is_finite())
            .map(|r| (r.frame_ms, r.mean_edge_px, r.msaa == 1))
            .collect();
        chart
            .draw_series(pts.iter().map(|&(x, y, filled)| {
                let style = if filled {
                    colour.filled()
                } else {
                    colour.stroke_width(2)
                };
                Circle::new((x, y), 6, style)
            }))?
            .label(label.as_str())
            .legend(move |(x, y)| Circle::new((x + 8, y), 6, colour.filled()));
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.9))
        .border_style(BLACK)
        .label_font(("sans-serif", 15))
        .draw()?;
    root.present()?;
    Ok(())
}

/// One scene of `swarmshot bench frames`.
#[derive(Clone, Debug)]
pub struct FrameRow {
    pub scene: String,
    pub drones: usize,
    pub frames: usize,
    /// Median of `FramePipeline::make_scene` (picture + labels, no encode), first frame left out.
    pub median_ms: f64,
    /// The process's peak resident memory after the scene (Linux `VmHWM`).
    pub peak_rss_mib: Option<f64>,
}

/// One scene of `swarmshot bench frames`: its name, preset, and how many of
/// its frames are timed (from frame 0, in order, as a batch makes them).
pub type FrameScene = (String, Preset, u64);

/// The scenes of issue 9's frame-time targets: 15 drones at 1080p and 4K
/// (the quickstart's camera sweep and swarm volume, every frame: each camera
/// pose, hence each drone size the dataset has, as often as the batch makes
/// it), the same at the sweep's nearest camera alone (its largest drones),
/// 1 500 drones at 1080p (12 frames), and the peer scene when given.
pub fn frame_scenes(quickstart: &Preset, peer: Option<Preset>) -> Vec<FrameScene> {
    let with = |count: u32, size_m: (f64, f64, f64), width: u32, height: u32| {
        let mut p = quickstart.clone();
        p.placement = Placement::Randomized {
            count: (count, count),
            count_distribution: Default::default(),
            volume: Volume::Box { size_m },
            min_separation_m: 0.5,
        };
        p.render.resolution = Resolution::Custom { width, height };
        p
    };
    let swarm = |width, height| with(15, (8.0, 4.0, 8.0), width, height);
    let mut nearest = swarm(1920, 1080);
    nearest.camera.z = SweepRange::fixed(nearest.camera.z.start);
    let all = |p: Preset| {
        let n = p.frame_count();
        (p, n)
    };
    let (hd, hd_frames) = all(swarm(1920, 1080));
    let (uhd, uhd_frames) = all(swarm(3840, 2160));
    let (near, near_frames) = all(nearest);
    let mut scenes = vec![
        ("15 drones, 1920×1080".to_string(), hd, hd_frames),
        (
            "15 drones, 1920×1080, nearest camera".to_string(),
            near,
            near_frames,
        ),
        ("15 drones, 3840×2160".to_string(), uhd, uhd_frames),
        (
            "1 500 drones, 1920×1080".to_string(),
            with(1500, (40.0, 20.0, 40.0), 1920, 1080),
            12,
        ),
    ];
    if let Some(peer) = peer {
        let n = peer.frame_count();
        scenes.push(("peer (15 cf2.glb, HDR sky)".to_string(), peer, n));
    }
    scenes
}

fn peak_rss_mib() -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kib: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib / 1024.0)
}

/// Median frame time (picture + labels, no encode) of each scene, over its
/// frames (at most `max_frames` when given). Each frame's pixels are handed
/// back to the renderer as the batch's encoders do.
pub fn frames(
    ctx: &GpuContext,
    scenes: Vec<FrameScene>,
    max_frames: Option<u64>,
) -> anyhow::Result<Vec<FrameRow>> {
    let mut rows = Vec::new();
    for (name, preset, frames) in scenes {
        let pipeline = FramePipeline::new(preset)?;
        let mut renderer = pipeline.renderer(ctx);
        let mut times = Vec::new();
        let mut drones = 0;
        let count = max_frames.unwrap_or(frames).min(frames).max(2);
        for index in 0..count {
            let scene = pipeline.scene(index % pipeline.frame_count())?;
            drones = drones.max(scene.drones.len());
            let t = Instant::now();
            let frame = pipeline.make_scene(&mut renderer, scene)?;
            renderer.recycle(frame.rgba, frame.painted);
            if index > 0 {
                // The first frame builds pipelines and targets.
                times.push(ms(t));
            }
        }
        times.sort_by(f64::total_cmp);
        rows.push(FrameRow {
            scene: name,
            drones,
            frames: times.len(),
            median_ms: times[times.len() / 2],
            peak_rss_mib: peak_rss_mib(),
        });
    }
    Ok(rows)
}

/// The `bench frames` table.
pub fn frames_markdown(rows: &[FrameRow]) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "| scene | drones | frames | ms / frame (median, render + labels) | peak RSS (MiB) |"
    );
    let _ = writeln!(s, "|---|---|---|---|---|");
    for r in rows {
        let rss = r
            .peak_rss_mib
            .map_or_else(|| "–".to_string(), |m| format!("{m:.0}"));
        let _ = writeln!(
            s,
            "| {} | {} | {} | {:.1} | {} |",
            r.scene, r.drones, r.frames, r.median_ms, rss
        );
    }
    s
}
