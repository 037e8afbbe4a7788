//! Batch orchestration: preset → frames → render → labels → writers.
//!
//! The calling thread builds, labels and renders frames in index order; a pool
//! of encoder threads turns pixels into JPEG/PNG; one sink writes each frame's
//! image, labels and manifest line in index order. Cancelling stops feeding
//! new frames and drains the pipeline, so every written image has its labels.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use anyhow::Context;

use crate::labels::{DroneLabel, LabelGeometry, label_frame};
use crate::model::{self, CpuModel, ModelError};
use crate::output::{DatasetStats, DatasetWriter, encode_image};
use crate::preset::{BoxMethod, ModelSource, Preset};
use crate::render::{GpuContext, Renderer};
use crate::scene::{FrameScene, build_frame};

/// Load every model the preset names (and only those), in preset order.
pub fn load_models(preset: &Preset) -> Result<Vec<CpuModel>, ModelError> {
    preset
        .models
        .iter()
        .map(|spec| match &spec.source {
            ModelSource::Builtin(name) => {
                let file = PathBuf::from(format!("builtin:{name}"));
                let bytes = crate::assets::builtin_glb(name).ok_or_else(|| ModelError::Parse {
                    file: file.clone(),
                    reason: "no such built-in model".into(),
                })?;
                model::load_bytes(bytes, None, &file, name)
            }
            ModelSource::File(path) => model::load_file(path),
        })
        .collect()
}

/// Everything a frame needs besides the preset: loaded models and their label geometry.
pub struct FrameMaker {
    pub preset: Preset,
    pub models: Vec<CpuModel>,
    pub geometry: Vec<LabelGeometry>,
    pub class_of_model: Vec<usize>,
}

impl FrameMaker {
    pub fn new(preset: Preset) -> Result<Self, ModelError> {
        let models = load_models(&preset)?;
        let geometry = models.iter().map(LabelGeometry::from).collect();
        let (_, class_of_model) = preset.classes();
        Ok(Self {
            preset,
            models,
            geometry,
            class_of_model,
        })
    }

    /// Scene and geometric labels of one frame, without rendering: an
    /// estimate for previews and statistics. `Visible` boxes and visibility
    /// filters need pixels, so here they fall back to `Amodal` boxes with no
    /// visibility filter; [`FrameMaker::labels`] gives the exact labels.
    pub fn frame(
        &self,
        index: u64,
    ) -> Result<(FrameScene, Vec<DroneLabel>), crate::scene::FrameError> {
        let scene = build_frame(&self.preset, index)?;
        let mut settings = self.preset.labels.clone();
        if settings.box_method == BoxMethod::Visible {
            settings.box_method = BoxMethod::Amodal;
        }
        settings.min_visible_pixels = 0;
        settings.min_visible_fraction = 0.0;
        let labels = label_frame(
            &scene,
            &self.geometry,
            &self.class_of_model,
            &settings,
            None,
        );
        Ok((scene, labels))
    }

    /// The exact labels of a scene: runs the instance-id passes when the
    /// preset's label settings need them, and only then.
    pub fn labels(
        &self,
        renderer: &mut Renderer,
        scene: &FrameScene,
    ) -> Result<Vec<DroneLabel>, crate::render::RenderError> {
        let visibility = if self.preset.labels.needs_id_pass() {
            Some(crate::visibility::measure(
                renderer,
                scene,
                &self.preset.sky,
                &self.geometry,
                self.preset.labels.id_scale,
            )?)
        } else {
            None
        };
        Ok(label_frame(
            scene,
            &self.geometry,
            &self.class_of_model,
            &self.preset.labels,
            visibility.as_deref(),
        ))
    }

    pub fn model_names(&self) -> Vec<String> {
        self.preset
            .models
            .iter()
            .zip(&self.models)
            .map(|(spec, m)| match &spec.source {
                ModelSource::Builtin(name) => name.clone(),
                ModelSource::File(_) => m.name.clone(),
            })
            .collect()
    }
}

#[derive(Clone, Debug)]
pub struct BatchOptions {
    pub out_dir: PathBuf,
    /// Make only the first N frames.
    pub limit: Option<u64>,
    pub overwrite: bool,
    /// Image encoder threads (0 = one per spare core).
    pub encoder_threads: usize,
}

impl BatchOptions {
    pub fn new(out_dir: impl Into<PathBuf>) -> Self {
        Self {
            out_dir: out_dir.into(),
            limit: None,
            overwrite: false,
            encoder_threads: 0,
        }
    }
}

/// Progress reported after each written frame.
#[derive(Clone, Copy, Debug)]
pub struct Progress {
    pub done: u64,
    pub total: u64,
    pub elapsed: Duration,
}

impl Progress {
    pub fn images_per_s(&self) -> f64 {
        self.done as f64 / self.elapsed.as_secs_f64().max(1e-9)
    }
}

/// What a finished (or cancelled) batch wrote.
#[derive(Clone, Debug)]
pub struct BatchReport {
    pub stats: DatasetStats,
    pub cancelled: bool,
    pub elapsed: Duration,
    pub out_dir: PathBuf,
}

struct Rendered {
    scene: FrameScene,
    labels: Vec<DroneLabel>,
    rgba: Vec<u8>,
}

struct Encoded {
    scene: FrameScene,
    labels: Vec<DroneLabel>,
    bytes: Vec<u8>,
}

/// Run a batch. `cancel` may be set from another thread at any time.
pub fn run_batch(
    preset: &Preset,
    options: &BatchOptions,
    ctx: &GpuContext,
    cancel: &AtomicBool,
    mut on_progress: impl FnMut(Progress) + Send,
) -> anyhow::Result<BatchReport> {
    let maker = FrameMaker::new(preset.clone())?;
    let total = options
        .limit
        .map_or(preset.frame_count(), |n| n.min(preset.frame_count()));
    let mut writer = DatasetWriter::create(
        &options.out_dir,
        preset,
        maker.model_names(),
        options.overwrite,
    )?;
    let mut renderer = make_renderer(&maker, ctx)?;
    let msaa = preset.render.msaa;
    let format = preset.output.image_format;
    let threads = if options.encoder_threads == 0 {
        std::thread::available_parallelism().map_or(1, |n| n.get().saturating_sub(1).max(1))
    } else {
        options.encoder_threads
    };
    let start = Instant::now();
    let (to_encode, encode_rx) = crossbeam_channel::bounded::<Rendered>(threads * 2);
    let (to_sink, sink_rx) = crossbeam_channel::bounded::<anyhow::Result<Encoded>>(threads * 2);

    let (stats, cancelled, render_result) = std::thread::scope(|s| {
        for _ in 0..threads {
            let rx = encode_rx.clone();
            let tx = to_sink.clone();
            s.spawn(move || {
                for r in rx {
                    let (w, h) = (r.scene.camera.width, r.scene.camera.height);
                    let msg = encode_image(&r.rgba, w, h, format)
                        .map(|bytes| Encoded {
                            scene: r.scene,
                            labels: r.labels,
                            bytes,
                        })
                        .map_err(anyhow::Error::from);
                    if tx.send(msg).is_err() {
                        break;
                    }
                }
            });
        }
        drop(to_sink);
        drop(encode_rx);
        // The sink: reorder by index and write.
        let sink = s.spawn(move || -> anyhow::Result<(DatasetWriter, u64)> {
            let mut pending: BTreeMap<u64, Encoded> = BTreeMap::new();
            let mut next = 0u64;
            let mut first_error = None;
            for msg in sink_rx {
                match msg {
                    Ok(e) => {
                        pending.insert(e.scene.index, e);
                    }
                    Err(e) => {
                        first_error.get_or_insert(e);
                    }
                }
                while let Some(e) = pending.remove(&next) {
                    if first_error.is_none()
                        && let Err(err) = writer.write_frame(&e.scene, &e.labels, &e.bytes)
                    {
                        first_error = Some(err.into());
                    }
                    next += 1;
                    on_progress(Progress {
                        done: next,
                        total,
                        elapsed: start.elapsed(),
                    });
                }
            }
            match first_error {
                Some(e) => Err(e),
                None => Ok((writer, next)),
            }
        });
        let mut render_result = Ok(());
        let mut cancelled = false;
        for index in 0..total {
            if cancel.load(Ordering::Relaxed) {
                cancelled = true;
                break;
            }
            let step = (|| -> anyhow::Result<Rendered> {
                let scene = build_frame(&maker.preset, index)?;
                let labels = maker
                    .labels(&mut renderer, &scene)
                    .with_context(|| format!("labelling frame {index}"))?;
                let rgba = renderer
                    .render_rgba(&scene, &preset.sky, msaa)
                    .with_context(|| format!("rendering frame {index}"))?;
                Ok(Rendered {
                    scene,
                    labels,
                    rgba,
                })
            })();
            match step {
                Ok(r) => {
                    if to_encode.send(r).is_err() {
                        break; // the sink failed; its error is reported below
                    }
                }
                Err(e) => {
                    render_result = Err(e);
                    break;
                }
            }
        }
        drop(to_encode);
        let sink_result = sink
            .join()
            .unwrap_or_else(|_| Err(anyhow::anyhow!("the writer thread panicked")));
        (sink_result, cancelled, render_result)
    });
    render_result?;
    let (writer, _written) = stats?;
    let stats = writer.finish()?;
    Ok(BatchReport {
        stats,
        cancelled,
        elapsed: start.elapsed(),
        out_dir: options.out_dir.clone(),
    })
}

/// A renderer with the maker's models and the sky images its preset
/// references (read here, and only those).
pub fn make_renderer(maker: &FrameMaker, ctx: &GpuContext) -> anyhow::Result<Renderer> {
    let assets = crate::environment::EnvironmentAssets::load(&maker.preset.sky)?;
    let mut renderer = Renderer::new(ctx, &maker.models);
    renderer.set_environment(&assets);
    Ok(renderer)
}

/// Render one frame alone to RGBA (for `swarmshot frame` and the preview).
pub fn render_single(
    maker: &FrameMaker,
    ctx: &GpuContext,
    index: u64,
) -> anyhow::Result<(FrameScene, Vec<DroneLabel>, Vec<u8>)> {
    let scene = build_frame(&maker.preset, index)?;
    let mut renderer = make_renderer(maker, ctx)?;
    let labels = maker.labels(&mut renderer, &scene)?;
    let rgba = renderer.render_rgba(&scene, &maker.preset.sky, maker.preset.render.msaa)?;
    Ok((scene, labels, rgba))
}

/// Draw 2-px box outlines onto RGBA pixels (for `--overlay`).
pub fn draw_overlay(rgba: &mut [u8], width: u32, height: u32, labels: &[DroneLabel]) {
    let colour = [255u8, 40, 40, 255];
    let mut put = |x: i64, y: i64| {
        if x >= 0 && y >= 0 && (x as u32) < width && (y as u32) < height {
            let i = ((y as u32 * width + x as u32) * 4) as usize;
            rgba[i..i + 4].copy_from_slice(&colour);
        }
    };
    for l in labels.iter().filter(|l| l.is_kept()) {
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

/// Convenience for tests and the CLI: load, validate and resolve a preset file.
pub fn load_preset(path: &Path) -> Result<Preset, crate::preset::PresetError> {
    let mut preset = Preset::load(path)?;
    preset.resolve_paths(path.parent().unwrap_or(Path::new(".")));
    Ok(preset)
}
