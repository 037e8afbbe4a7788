//! The one way a frame is made.
//!
//! A [`FramePipeline`] is built once from a validated preset: it loads the
//! models and sky images the preset names (and only those) into [`Assets`],
//! and from then on a frame index goes straight through
//! scene ([`crate::scene::build_frame`]) → render + measure
//! ([`crate::render::Renderer`]) → labels ([`crate::annotate::label_frame`]).
//! The batch ([`batch::run_batch`]), the `frame` command, the desktop app's
//! preview, the benchmarks and the gallery all call it; none of them rebuilds
//! that chain or reaches into its parts.
//!
//! The pipeline holds CPU data only. GPU state lives in a [`Renderer`] made by
//! [`FramePipeline::renderer`] for the pipeline's assets, so one pipeline can
//! feed renderers on several devices, and a host (the preview) can keep its
//! renderer while the preset changes as long as the assets stay the same.

pub mod batch;
mod camera;
pub mod check;
pub mod inputs;
mod lens;
mod overdraw;
pub mod plan;
mod rolling;
mod sink;
mod streaks;
mod thermal;
pub mod weather;

use std::path::{Path, PathBuf};
use std::sync::Arc;

use anyhow::Context as _;

use crate::annotate::masks::FrameMasks;
use crate::annotate::visibility::{PixelHit, Visibility};
use crate::annotate::{DroneLabel, label_frame};
use crate::model::lod::LodChain;
use crate::model::{self, CpuModel, ModelError};
use crate::preset::{
    BoxMethod, FieldError, ImageFormat, LabelSettings, ModelSource, ModelSpec, Preset,
};
use crate::render::visibility;
use crate::render::{GpuContext, Painted, RenderError, RenderRequest, Renderer};
use crate::scene::projection::LabelGeometry;
use crate::scene::{FrameError, FrameScene, MAX_DRAWS, build_frame, build_frame_draw};
use crate::sensor::CameraDraw;
use crate::sky::{EnvironmentAssets, EnvironmentError};

pub use batch::{BatchOptions, BatchReport, Progress, check_cache_apart, run_batch};
pub use plan::{PlanOptions, PlanReport, run_plan};

/// Why a pipeline could not be built or a frame not made.
#[derive(Debug, thiserror::Error)]
pub enum PipelineError {
    #[error("the preset is invalid:\n{}", list(.0))]
    Invalid(Vec<FieldError>),
    #[error(transparent)]
    Model(#[from] ModelError),
    #[error(transparent)]
    Sky(#[from] EnvironmentError),
    #[error(transparent)]
    Plate(#[from] crate::sky::plates::PlateError),
    #[error(transparent)]
    Frame(#[from] FrameError),
    #[error("frame {index}: {source}")]
    Render { index: u64, source: RenderError },
    #[error("frame {index}: the camera model's first compression failed: {reason}")]
    Camera { index: u64, reason: String },
    /// The frame's work would pass a budget (named in `reason`).
    #[error("frame {index}: {reason}")]
    Budget { index: u64, reason: String },
}

fn list(errors: &[FieldError]) -> String {
    errors
        .iter()
        .map(|e| format!("  - {e}"))
        .collect::<Vec<_>>()
        .join("\n")
}

/// What a preset loads from disk: its models (preset order) and sky images
/// (`Sky::image_sources` order). Shared between pipelines of presets that
/// name the same files, so editing other fields never reloads them.
#[derive(Debug)]
pub struct Assets {
    specs: Vec<ModelSpec>,
    /// The confusers' built-in models after the preset's (`preset::confusers::model_slots`).
    confuser_slots: Vec<String>,
    pub models: Vec<CpuModel>,
    /// Each model's levels of detail (finest first), built once at load,
    /// their bounds found as picks need them.
    pub lods: Vec<Arc<LodChain>>,
    pub geometry: Vec<LabelGeometry>,
    pub sky: EnvironmentAssets,
    /// The backplates (`preset.backplate`), resampled to the output size; empty without one.
    pub plates: Vec<crate::sky::plates::Plate>,
    /// What the plates were loaded for (the preset's backplate and output size).
    plates_for: Option<(crate::preset::backplate::Backplate, (u32, u32))>,
    /// Each model's mesh for the depth maps, made on the first depth map.
    depth_meshes: std::sync::OnceLock<Vec<crate::annotate::depth::DepthMesh>>,
    /// Each model's impostor, baked on the first renderer that draws them.
    impostors: std::sync::OnceLock<Vec<crate::model::impostor::Impostor>>,
}

impl Assets {
    /// Load every model and sky image the preset names, and only those.
    pub fn load(preset: &Preset) -> Result<Self, PipelineError> {
        let confuser_slots = crate::preset::confusers::model_slots(&preset.confusers);
        // Model k of the assets: the preset's models, then the confusers' slots.
        let sources: Vec<ModelSource> = (preset.models.iter().map(|m| m.source.clone()))
            .chain(confuser_slots.iter().cloned().map(ModelSource::Builtin))
            .collect();
        // The sky's images decode on a second thread while the models load
        // and their levels are built; the models' errors still come first.
        // A thread the system refuses only loses the overlap: the sky then
        // loads after the models.
        let (models, sky) = std::thread::scope(|s| {
            let sky = crate::threads::spawn_or_defer(s, || EnvironmentAssets::load(&preset.sky));
            let models = load_models(preset, &sources);
            let sky = sky.join().unwrap_or_else(|p| std::panic::resume_unwind(p));
            (models, sky)
        });
        let (models, lods) = models?;
        let geometry = models.iter().map(LabelGeometry::from).collect();
        Ok(Self {
            specs: preset.models.clone(),
            confuser_slots,
            models,
            lods,
            geometry,
            sky: sky?,
            plates: match &preset.backplate {
                Some(b) => crate::sky::plates::load_plates(b, preset.image_size())?,
                None => Vec::new(),
            },
            plates_for: plates_key(preset),
            depth_meshes: std::sync::OnceLock::new(),
            impostors: std::sync::OnceLock::new(),
        })
    }

    /// Each model's [`DepthMesh`](crate::annotate::depth::DepthMesh), made
    /// once (on the first call: presets without depth maps never make them).
    pub fn depth_meshes(&self) -> &[crate::annotate::depth::DepthMesh] {
        self.depth_meshes.get_or_init(|| {
            (self.models.iter())
                .map(crate::annotate::depth::DepthMesh::new)
                .collect()
        })
    }

    /// Each model's impostor, baked once (on the first call: presets
    /// without impostors never bake them) or read from the cache.
    pub fn impostors(&self) -> &[crate::model::impostor::Impostor] {
        (self.impostors).get_or_init(|| {
            self.models
                .iter()
                .map(crate::model::impostor_cache::cached_bake)
                .collect()
        })
    }

    /// Whether these assets are exactly what `preset` names.
    pub fn serve(&self, preset: &Preset) -> bool {
        self.specs == preset.models
            && self.confuser_slots == crate::preset::confusers::model_slots(&preset.confusers)
            && (preset.render.lod_error_px <= 0.0 || !self.lods.is_empty())
            && preset
                .sky
                .image_sources()
                .into_iter()
                .eq(self.sky.images.iter().map(|i| &i.source))
            && self.plates_for == plates_key(preset)
    }
}

fn plates_key(preset: &Preset) -> Option<(crate::preset::backplate::Backplate, (u32, u32))> {
    (preset.backplate.clone()).map(|b| (b, preset.image_size()))
}

/// Load one model from its preset source (a built-in name or a glTF file).
pub fn load_model(source: &ModelSource) -> Result<CpuModel, ModelError> {
    match source {
        ModelSource::Builtin(name) => {
            let file = PathBuf::from(format!("builtin:{name}"));
            let glb = model::builtin::glb(name).or_else(|| model::confusers::glb(name));
            let bytes = glb.ok_or_else(|| ModelError::Parse {
                file: file.clone(),
                reason: "no such built-in model".into(),
            })?;
            model::load_bytes(bytes, None, &file, name)
        }
        ModelSource::File(path) => model::load_file(path),
    }
}

/// The preset's models then the confusers' (`sources`), and their levels
/// of detail when the preset draws with them.
fn load_models(
    preset: &Preset,
    sources: &[ModelSource],
) -> Result<(Vec<CpuModel>, Vec<Arc<LodChain>>), PipelineError> {
    let models = (preset.models.iter().map(load_model_spec))
        .chain(sources[preset.models.len()..].iter().map(load_model))
        .collect::<Result<Vec<_>, _>>()?;
    let lods = if preset.render.lod_error_px > 0.0 {
        (sources.iter().zip(&models))
            .map(|(source, m)| load_lods(source, m))
            .collect::<Result<Vec<_>, _>>()?
    } else {
        Vec::new()
    };
    Ok((models, lods))
}

/// Load one model as a preset names it, with the URI policy it asks for.
pub fn load_model_spec(spec: &ModelSpec) -> Result<CpuModel, ModelError> {
    match &spec.source {
        ModelSource::File(path) => model::load_file_with(
            path,
            model::UriPolicy {
                allow_outside_folder: spec.allow_uris_outside_folder,
            },
        ),
        source @ ModelSource::Builtin(_) => load_model(source),
    }
}

/// The levels of detail of a loaded model. A built-in model's are built
/// once per process and shared (they never change).
fn load_lods(source: &ModelSource, model: &CpuModel) -> Result<Arc<LodChain>, ModelError> {
    use std::collections::HashMap;
    use std::sync::{Mutex, OnceLock};
    static BUILTIN: OnceLock<Mutex<HashMap<String, Arc<LodChain>>>> = OnceLock::new();
    let build = || {
        crate::model::lod_cache::cached_lods(model)
            .map(Arc::new)
            .map_err(|e| ModelError::Parse {
                file: PathBuf::from(&model.name),
                reason: e.to_string(),
            })
    };
    let ModelSource::Builtin(name) = source else {
        return build();
    };
    let cache = BUILTIN.get_or_init(Default::default);
    if let Some(lods) = cache.lock().ok().and_then(|c| c.get(name).cloned()) {
        return Ok(lods);
    }
    let lods = build()?;
    if let Ok(mut c) = cache.lock() {
        c.insert(name.clone(), lods.clone());
    }
    Ok(lods)
}

/// One made frame: its scene, its labels and its pixels.
#[derive(Clone, Debug)]
pub struct Frame {
    pub scene: FrameScene,
    pub labels: Vec<DroneLabel>,
    /// Tightly packed RGBA8, sRGB-encoded, `scene.camera.width × height`.
    pub rgba: Vec<u8>,
    /// What `rgba` holds, for [`Renderer::recycle`].
    pub painted: Painted,
    /// 16-bit grey pixels (the thermal camera's `bits: 16`), written in
    /// place of `rgba` (which then holds them ÷ 257, rounded, for previews).
    pub grey16: Option<Vec<u16>>,
    /// Each drone's visible pixels, when the preset asks for masks (`output.masks`).
    pub masks: Option<FrameMasks>,
}

/// Frame index → scene → pixels and labels, for one validated preset.
#[derive(Clone, Debug)]
pub struct FramePipeline {
    preset: Preset,
    assets: Arc<Assets>,
    classes: Vec<String>,
    class_of_model: Vec<usize>,
    model_names: Vec<String>,
    /// The thermal camera's fixed pattern, made on the first thermal frame.
    thermal_pattern: Arc<std::sync::OnceLock<Vec<f32>>>,
}

impl FramePipeline {
    /// Validate `preset` and load what it names.
    pub fn new(preset: Preset) -> Result<Self, PipelineError> {
        check::validate(&preset).map_err(PipelineError::Invalid)?;
        let assets = Arc::new(Assets::load(&preset)?);
        Ok(Self::with_assets(preset, assets))
    }

    /// Open a preset file (paths resolved against its folder) and build its
    /// pipeline; an invalid field or a model or sky that cannot be loaded is
    /// named with the preset file.
    pub fn open(path: &Path) -> anyhow::Result<Self> {
        Self::open_then(path, |_| {})
    }

    /// [`FramePipeline::open`], handing the preset to `parsed` once it is
    /// read and checked, before its models and images load.
    pub fn open_then(path: &Path, parsed: impl FnOnce(&Preset)) -> anyhow::Result<Self> {
        let preset = Preset::open(path)?;
        parsed(&preset);
        Self::new(preset).with_context(|| format!("preset {}", path.display()))
    }

    /// The pipeline of an edited preset: reuses this pipeline's assets when
    /// the edit did not change which models or sky images it names.
    pub fn update(&self, preset: Preset) -> Result<Self, PipelineError> {
        check::validate(&preset).map_err(PipelineError::Invalid)?;
        let assets = if self.assets.serve(&preset) {
            self.assets.clone()
        } else {
            Arc::new(Assets::load(&preset)?)
        };
        Ok(Self::with_assets(preset, assets))
    }

    fn with_assets(preset: Preset, assets: Arc<Assets>) -> Self {
        let (classes, class_of_model) = preset.classes();
        let model_names = (preset.models.iter().zip(&assets.models))
            .map(|(spec, m)| match &spec.source {
                ModelSource::Builtin(name) => name.clone(),
                ModelSource::File(_) => m.name.clone(),
            })
            .chain(assets.confuser_slots.iter().cloned())
            .collect();
        Self {
            preset,
            assets,
            classes,
            class_of_model,
            model_names,
            thermal_pattern: Arc::default(),
        }
    }

    pub fn preset(&self) -> &Preset {
        &self.preset
    }

    pub fn assets(&self) -> &Arc<Assets> {
        &self.assets
    }

    /// Number of frames the preset makes.
    pub fn frame_count(&self) -> u64 {
        self.preset.frame_count()
    }

    /// Class names, in label order.
    pub fn classes(&self) -> &[String] {
        &self.classes
    }

    /// Each model's name as written to the manifest (preset order).
    pub fn model_names(&self) -> &[String] {
        &self.model_names
    }

    /// The scene of frame `index` (pure: no GPU, no file). With
    /// `labels.min_labelled` set, the first draw whose geometry gives that
    /// many kept boxes (see [`FramePipeline::plan`]).
    pub fn scene(&self, index: u64) -> Result<FrameScene, FrameError> {
        self.plan_draws(index, false).map(|(scene, _)| scene)
    }

    /// Draw frame `index` until its estimated labels hold
    /// `labels.min_labelled` kept boxes (at most [`MAX_DRAWS`] draws); the
    /// labels come back when asked for or computed anyway.
    fn plan_draws(
        &self,
        index: u64,
        want_labels: bool,
    ) -> Result<(FrameScene, Option<Vec<DroneLabel>>), FrameError> {
        let wanted = self.preset.labels.min_labelled;
        let plated = |mut scene: FrameScene| {
            crate::scene::backplate::apply(&mut scene, &self.preset, &self.assets.plates);
            let (images, plates) = (&self.assets.sky.images, &self.assets.plates);
            crate::scene::realism::meter_exposure(&mut scene, images, plates);
            scene
        };
        if wanted == 0 {
            let scene = plated(build_frame(&self.preset, index)?);
            let labels = want_labels.then(|| self.estimate_labels(&scene));
            return Ok((scene, labels));
        }
        for attempt in 0..MAX_DRAWS {
            let scene = plated(build_frame_draw(&self.preset, index, attempt)?);
            let labels = self.estimate_labels(&scene);
            if labels.iter().filter(|l| l.is_kept()).count() >= wanted as usize {
                return Ok((scene, Some(labels)));
            }
        }
        Err(FrameError::TooFewLabelled {
            index,
            wanted,
            attempts: MAX_DRAWS,
        })
    }

    /// The level-of-detail bounds frame `index`'s drones will need, found now
    /// ([`crate::render::bound_picks`]): a batch finds its first frame's on a
    /// thread while it sets up, where a first run's maker would find them
    /// before its first draw.
    pub fn bound_picks_of(&self, index: u64) {
        let Ok(scene) = self.scene(index) else {
            return;
        };
        let render = &self.preset.render;
        let impostor_below_px = render.impostor_below_px.map_or(0.0, f64::from);
        crate::render::bound_picks(
            &scene,
            &self.assets.lods,
            render.lod_error_px,
            impostor_below_px,
        );
    }

    /// A renderer holding this pipeline's models and sky images on `ctx`'s device.
    pub fn renderer(&self, ctx: &GpuContext) -> Renderer {
        self.renderer_with(ctx, false)
    }

    /// [`FramePipeline::renderer`] for making this preset's frames: its
    /// frame targets made and first used before the sky is uploaded
    /// ([`Renderer::prepare_targets`]), so the device zeroes them meanwhile.
    pub fn frame_renderer(&self, ctx: &GpuContext) -> Renderer {
        self.renderer_with(ctx, true)
    }

    fn renderer_with(&self, ctx: &GpuContext, prepared: bool) -> Renderer {
        let mut renderer = Renderer::with_lods(
            ctx,
            &self.assets.models,
            &self.assets.lods,
            self.preset.render.lod_error_px,
        );
        if prepared {
            renderer.prepare_targets(self.preset.image_size(), self.preset.render.msaa);
        }
        if let Some(px) = self.preset.render.impostor_below_px {
            renderer.set_impostors(self.assets.impostors(), f64::from(px));
        }
        renderer.set_environment(&self.assets.sky);
        renderer.set_backplates(&self.assets.plates);
        renderer
    }

    /// Labels from geometry alone, without rendering: an estimate for
    /// previews and statistics. `Visible` boxes and the visibility filters
    /// need pixels, so here `Visible` stands in as `Amodal` and the filters
    /// are off; [`FramePipeline::make`] gives the exact labels.
    pub fn estimate_labels(&self, scene: &FrameScene) -> Vec<DroneLabel> {
        let settings = LabelSettings {
            box_method: match self.preset.labels.box_method {
                BoxMethod::Visible => BoxMethod::Amodal,
                other => other,
            },
            min_visible_pixels: 0,
            min_visible_fraction: 0.0,
            ..self.preset.labels.clone()
        };
        label_frame(
            scene,
            &self.assets.geometry,
            &self.class_of_model,
            &settings,
            None,
        )
    }

    /// Whether `scene`, with its estimated `labels` ([`Self::estimate_labels`]),
    /// is within a rendered frame's work budgets: its fill (`overdraw`) and
    /// its motion blur's samples. The errors [`Self::make_scene`] stops a
    /// frame with, told from geometry alone (`check` asks it of the frames
    /// it samples).
    pub fn check_budgets(
        &self,
        scene: &FrameScene,
        labels: &[DroneLabel],
    ) -> Result<(), PipelineError> {
        overdraw::check(scene, labels)?;
        self.check_blur(scene)
    }

    /// Scene and estimated labels of frame `index`, without rendering
    /// (see [`FramePipeline::estimate_labels`]).
    pub fn plan(&self, index: u64) -> Result<(FrameScene, Vec<DroneLabel>), FrameError> {
        let (scene, labels) = self.plan_draws(index, true)?;
        let labels = labels.unwrap_or_else(|| self.estimate_labels(&scene));
        Ok((scene, labels))
    }

    /// The exact labels of `scene`: runs the renderer's visibility
    /// measurement when the preset's label settings need it, and only then.
    pub fn labels(
        &self,
        renderer: &mut Renderer,
        scene: &FrameScene,
    ) -> Result<Vec<DroneLabel>, RenderError> {
        let measured = self.measure(renderer, scene)?;
        Ok(label_frame(
            scene,
            &self.assets.geometry,
            &self.class_of_model,
            &self.preset.labels,
            measured.as_deref(),
        ))
    }

    fn measure(
        &self,
        renderer: &mut Renderer,
        scene: &FrameScene,
    ) -> Result<Option<Vec<Visibility>>, RenderError> {
        if !self.preset.labels.needs_id_pass() {
            return Ok(None);
        }
        visibility::measure(
            renderer,
            scene,
            self.preset.render.msaa,
            self.preset.labels.id_scale,
        )
        .map(Some)
    }

    /// Make frame `index`: scene, exact labels and pixels.
    pub fn make(&self, renderer: &mut Renderer, index: u64) -> Result<Frame, PipelineError> {
        // A rendered frame's work budget (the app's preview included).
        self.preset
            .check_render_budget()
            .map_err(|e| PipelineError::Invalid(vec![e]))?;
        let scene = self.scene(index)?;
        self.make_scene(renderer, scene)
    }

    /// Whether a frame of this preset reads its drone-free background
    /// ([`Renderer::background_pixels`]) after the render: the thermal
    /// camera, weather and the camera model do. A caller that reads nothing
    /// of the renderer but each frame (a batch) may let frames take their
    /// backgrounds' pixels where this is false ([`Renderer::set_lend_backgrounds`]).
    pub fn reads_backgrounds(&self) -> bool {
        let p = &self.preset;
        p.thermal.is_some() || p.weather.is_some() || p.camera_model.is_some()
    }

    /// What the render keeps besides the picture, and whether the labels
    /// keep the visibility of its pass. One pass draws the drones for both
    /// the picture and the visibility, unless a supersampled measurement
    /// (id_scale > 1) is asked for; each drone's pixels are kept for masks,
    /// the thermal picture, weather and a lens (validation keeps id_scale at
    /// 1 for all of them).
    fn render_layers(&self, renderer: &mut Renderer, scene: &FrameScene) -> (RenderRequest, bool) {
        let labels = &self.preset.labels;
        let masks_on = self.preset.output.masks.any();
        let thermal = self.preset.thermal.is_some();
        let ids_kept = labels.needs_id_pass() || masks_on;
        let together = (ids_kept || thermal) && labels.id_scale <= 1;
        // Through a lens, the visibility comes from the id layer moved with the picture.
        let lensed = scene.camera_model.is_some_and(|d| d.lens.is_some());
        // Under weather the measured drones' pixels are checked one by one.
        let weather = scene.weather.is_some() && together;
        renderer
            .set_pixel_hits(masks_on || thermal || ((weather || lensed) && labels.needs_id_pass()));
        let request = RenderRequest {
            msaa: self.preset.render.msaa,
            color: true,
            visibility: together,
        };
        (request, ids_kept)
    }

    /// Labels and pixels of a scene built by [`FramePipeline::scene`].
    pub fn make_scene(
        &self,
        renderer: &mut Renderer,
        scene: FrameScene,
    ) -> Result<Frame, PipelineError> {
        if overdraw::may_exceed(&scene) {
            overdraw::check(&scene, &self.estimate_labels(&scene))?;
        }
        let index = scene.index;
        let render_error = |source| PipelineError::Render { index, source };
        let masks_on = self.preset.output.masks.any();
        let thermal = self.preset.thermal.as_ref();
        let (request, ids_kept) = self.render_layers(renderer, &scene);
        let shutter = rolling::Shutter::of(&self.preset, &self.assets.geometry, &scene)?;
        let together = request.visibility;
        let mut frame = renderer
            .render_frame(&scene, &request)
            .map_err(render_error)?;
        let mut measured = if together {
            frame.visibility.take().filter(|_| ids_kept)
        } else {
            self.measure(renderer, &scene).map_err(render_error)?
        };
        let (w, h, n) = (scene.camera.width, scene.camera.height, scene.drones.len());
        let mut hits = frame.pixel_hits.take();
        // Rain or snow over the picture (and the drone-free frame under it);
        // the thermal camera draws them into its radiance instead.
        let clear = match thermal {
            Some(_) => None,
            None => weather::over_frame(
                (&scene, &self.assets.geometry),
                renderer,
                &mut frame,
                &mut measured,
                &mut hits,
            ),
        };
        // The thermal picture before the masks: under weather it cuts the hits.
        let grey = thermal.map(|t| {
            // A recycled buffer, not fresh pages, for the grey picture.
            let out = renderer.spare_buffer();
            let background = renderer.background_pixels(&frame.painted);
            let background = background.unwrap_or(&frame.rgba);
            self.thermal_frame(t, &scene, background, (&mut hits, &mut measured), out)
        });
        let lens_visibility = lens_visibility(&scene, &mut hits, measured.as_deref());
        let mut masks = (hits.as_ref())
            .filter(|_| masks_on)
            .map(|hits| FrameMasks::from_hits(w, h, n, hits));
        let mut grey16 = None;
        let (rgba, painted) = match (&scene.camera_model, grey) {
            (_, Some(grey)) => {
                renderer.recycle(frame.rgba, frame.painted);
                grey16 = grey.1;
                (grey.0, Painted::default())
            }
            (None, None) => (frame.rgba, frame.painted),
            (Some(draw), None) => {
                let mut sets = masks.as_ref().map(|_| vec![Vec::new(); n]);
                // A recycled buffer, not fresh pages, for the camera's picture.
                let out = renderer.spare_buffer();
                let background = match &clear {
                    Some(clear) => clear.as_deref(),
                    None => renderer.background_pixels(&frame.painted),
                };
                // Without the drone-free background, the id layer's visibility through the lens.
                if background.is_none()
                    && let Some(v) = lens_visibility
                {
                    measured = Some(v);
                }
                let rgba = self.through_camera(
                    (background, shutter.as_ref()),
                    &scene,
                    draw,
                    (&frame, out),
                    &mut measured,
                    &mut sets,
                )?;
                // Through the camera a drone's pixels are those it changes.
                if let Some(sets) = sets {
                    masks = Some(FrameMasks::from_sets(w, h, &sets));
                }
                // The renderer's buffer (background and all) goes back to it untouched.
                renderer.recycle(frame.rgba, frame.painted);
                (rgba, Painted::default())
            }
        };
        // The weather's drone-free frame goes back to the renderer for the next one.
        if let Some(Some(clear)) = clear {
            renderer.recycle(clear, Painted::default());
        }
        let outputs = self.preset.output.masks;
        if let Some(m) = masks.as_mut().filter(|_| outputs.depth || outputs.flow) {
            let meshes = self.assets.depth_meshes();
            // Under a rolling shutter, each row's depth at its own time.
            let rows = |d: usize, y: u32| shutter.as_ref()?.row_pose(d, y);
            let rows = shutter
                .as_ref()
                .map(|_| &rows as &crate::annotate::depth::RowPose);
            m.depth_m = crate::annotate::depth::depth_m_of_rows(&scene, meshes, m, rows);
            if outputs.flow {
                m.flow = self.flow_to_next(&scene, shutter.as_ref(), m)?;
            }
        }
        let labels = self.final_labels(&scene, shutter.as_ref(), measured.as_deref());
        Ok(Frame {
            scene,
            labels,
            rgba,
            painted,
            grey16,
            masks,
        })
    }
}

impl FramePipeline {
    /// The labels of a made frame from its measured visibility; under a
    /// rolling shutter, with the shutter's amodal boxes.
    fn final_labels(
        &self,
        scene: &FrameScene,
        shutter: Option<&rolling::Shutter>,
        measured: Option<&[Visibility]>,
    ) -> Vec<DroneLabel> {
        let (geometry, settings) = (&self.assets.geometry, &self.preset.labels);
        let Some(s) = shutter else {
            return label_frame(scene, geometry, &self.class_of_model, settings, measured);
        };
        let boxes = |i: usize, drone: &crate::scene::DronePose, geom: &LabelGeometry| {
            let paper = crate::annotate::paper_aabb_box(&scene.camera, drone, geom)?;
            Some((s.amodal(i, geom)?, paper))
        };
        let sources = (geometry.as_slice(), self.class_of_model.as_slice());
        crate::annotate::label_frame_with(scene, sources, settings, measured, &boxes)
    }
}

/// Through a lens: each drone's pixels moved with the picture (`hits`
/// replaced by the moved ones) and the visibility they give, the unoccluded
/// count scaled alike; `None` without a lens or without the pixels.
fn lens_visibility(
    scene: &FrameScene,
    hits: &mut Option<Vec<PixelHit>>,
    measured: Option<&[Visibility]>,
) -> Option<Vec<Visibility>> {
    let l = lens::of(scene)?;
    let (w, h) = (scene.camera.width, scene.camera.height);
    let moved = lens::remap_hits(&l, hits.as_deref()?, (w, h));
    let vis = measured.map(|m| {
        (m.iter().zip(lens::shown(m.len(), &moved)))
            .map(|(v, s)| camera::camera_visibility(v, s))
            .collect::<Vec<_>>()
    });
    *hits = Some(moved);
    vis
}

impl FramePipeline {
    /// The flow of `scene`'s pixels to the next frame of its sequence
    /// (`output.masks.flow`; [`crate::annotate::flow`]): `None` for the
    /// last frame of a sequence. The next frame's scene is built alone, as
    /// any frame can be.
    fn flow_to_next(
        &self,
        scene: &FrameScene,
        shutter: Option<&rolling::Shutter>,
        masks: &FrameMasks,
    ) -> Result<Option<crate::annotate::flow::FrameFlow>, PipelineError> {
        let Some(_) = scene.sequence.filter(|s| s.step < s.steps) else {
            return Ok(None);
        };
        let next = self.scene(scene.index + 1)?;
        let next_shutter = rolling::Shutter::of(&self.preset, &self.assets.geometry, &next)?;
        if shutter.is_none() && next_shutter.is_none() {
            return Ok(Some(crate::annotate::flow::flow_of(
                scene,
                &next,
                &masks.instance,
                &masks.depth_m,
            )));
        }
        Ok(Some(rolling::flow(
            (scene, shutter),
            (&next, next_shutter.as_ref()),
            masks,
        )))
    }

    /// The format frame `scene` is written in: the preset's, with the
    /// camera model's drawn JPEG quality when it has one.
    pub fn image_format(&self, scene: &FrameScene) -> ImageFormat {
        match (self.preset.output.image_format, scene.camera_model) {
            (
                ImageFormat::Jpeg { .. },
                Some(CameraDraw {
                    jpeg_quality: Some(quality),
                    ..
                }),
            ) => ImageFormat::Jpeg { quality },
            (format, _) => format,
        }
    }
}
