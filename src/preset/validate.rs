//! Preset validation: every invalid value named by its field path, decided
//! before anything is read or written. One function per preset section.

use super::*;

/// Frames the batch may hold between rendering and encoding (its bounded queues).
pub const QUEUED_FRAMES: u64 = 8;
/// The most memory one frame may need, whatever the machine ([`Preset::frame_memory_bytes`]).
pub const MAX_FRAME_MEMORY_BYTES: u64 = 8 << 30;

/// The most counts a non-uniform count distribution may span (max − min + 1):
/// its probabilities are computed per frame (`scene::placement`).
pub const MAX_COUNT_SPAN: u32 = 100_000;

/// The largest `render.impostor_below_px`: the drones whose error the docs state (docs/realism.md).
pub const MAX_IMPOSTOR_PX: f32 = 32.0;

/// What a device offers, as plain numbers (the caller reads them from its adapter).
#[derive(Clone, Copy, Debug)]
pub struct DeviceLimits {
    /// `max_texture_dimension_2d`.
    pub max_texture_side: u32,
    /// `max_buffer_size`.
    pub max_buffer_bytes: u64,
    /// Memory one frame may use (the CLI passes ¾ of `MemAvailable`, within
    /// the process's `ulimit -v` and `ulimit -d`: [`super::budget::usable_memory_bytes`]), if known.
    pub memory_bytes: Option<u64>,
}

fn gib(bytes: u64) -> String {
    if bytes >= 1 << 30 {
        format!("{:.1} GiB", bytes as f64 / f64::from(1u32 << 30))
    } else {
        format!("{:.1} MiB", bytes as f64 / f64::from(1u32 << 20))
    }
}

/// Collects every problem of a preset, each with its field path.
#[derive(Default)]
pub(crate) struct Validator {
    pub(super) errors: Vec<FieldError>,
}

impl Validator {
    pub(super) fn push(&mut self, field: &str, message: String) {
        self.errors.push(FieldError {
            field: field.to_string(),
            message,
        });
    }

    pub(super) fn check(&mut self, ok: bool, field: &str, message: impl FnOnce() -> String) {
        if !ok {
            self.push(field, message());
        }
    }

    pub(super) fn positive(&mut self, field: &str, value: f64, unit: &str) {
        self.check(value.is_finite() && value > 0.0, field, || {
            format!("{value} must be a finite number > 0 ({unit})")
        });
    }
}

impl Preset {
    /// Check every field; all problems at once, each with its field path.
    pub fn validate(&self) -> Result<(), Vec<FieldError>> {
        let mut v = Validator::default();
        v.check(self.version >= 1, "version", || {
            format!(
                "{} is not a preset version (use {PRESET_VERSION})",
                self.version
            )
        });
        if let Some(problem) = crate::text::name_problem(&self.name) {
            v.push("name", problem);
        }
        self.validate_models(&mut v);
        self.validate_placement(&mut v);
        self.validate_attitude(&mut v);
        self.validate_camera(&mut v);
        self.validate_render(&mut v);
        self.validate_labels(&mut v);
        self.validate_output(&mut v);
        self.validate_motion(&mut v);
        self.validate_masks(&mut v.errors);
        self.validate_instance_ids(&mut v);
        if let Some(c) = &self.camera_model {
            c.validate(self, &mut v);
        }
        if let Some(a) = &self.atmosphere {
            a.validate_into(&mut v);
        }
        if let Some(a) = &self.appearance {
            a.validate_into(&mut v);
        }
        if let Some(c) = &self.clutter {
            c.validate_into(&mut v);
        }
        super::confusers::validate(&self.confusers, &mut v);
        if let Some(b) = &self.backplate {
            b.validate_into(&mut v, self.camera.absolute.is_some());
        }
        if let Some(t) = &self.thermal {
            t.validate_into(&mut v);
            v.check(self.camera_model.is_none(), "thermal", || {
                "cannot be combined with camera_model: the thermal camera has its own noise, blur and gain".into()
            });
            v.check(self.labels.id_scale <= 1, "thermal", || {
                "needs labels.id_scale 1: the thermal picture is made from the id pass's pixels"
                    .into()
            });
            let png = self.output.image_format == super::ImageFormat::Png;
            v.check(t.bits != 16 || png, "thermal.bits", || {
                "16-bit frames are grey PNG: set output.image_format to Png".into()
            });
            let ground_only = t.texture.as_ref().is_some_and(|x| x.ground_only);
            v.check(
                !ground_only || self.backplate.is_none(),
                "thermal.texture.ground_only",
                || "needs a modelled scene: over a backplate there is no ground to find".into(),
            );
            v.check(
                t.detail.is_none() || self.backplate.is_none(),
                "thermal.detail",
                || "needs a modelled scene: the plates hold their own camera's enhancement".into(),
            );
        }
        if let Some(w) = &self.weather {
            w.validate_into(&mut v);
            // What the weather hides is read pixel by pixel at the output's resolution.
            let measured = self.labels.needs_id_pass();
            v.check(!measured || self.labels.id_scale <= 1, "labels.id_scale", || {
                format!(
                    "{} cannot be combined with weather: drones' pixels under rain or snow are measured at the output's own (id_scale 1)",
                    self.labels.id_scale
                )
            });
        }
        if let Some(o) = &self.camera.observer {
            o.validate_into(&mut v);
            v.check(self.camera.absolute.is_none(), "camera.observer", || {
                "cannot be combined with camera.absolute: choose one camera".into()
            });
        }
        if v.errors.is_empty() {
            Ok(())
        } else {
            Err(v.errors)
        }
    }

    /// `output.masks.instance_png` and `depth`: every object a frame draws
    /// takes a 16-bit instance id, its confusers after its drones. Drones
    /// alone past the limit are `validate_masks`' error; this one is for the
    /// confusers that push a frame past it (the batch found it only when it
    /// wrote the first such frame's instance PNG).
    fn validate_instance_ids(&self, v: &mut Validator) {
        let m = &self.output.masks;
        let limit = super::masks::MAX_INSTANCE_ID as u64;
        let (drones, confusers) = (self.max_drones_per_frame(), self.max_confusers_per_frame());
        if !(m.instance_png || m.depth) || drones > limit || drones + confusers <= limit {
            return;
        }
        let field = if m.instance_png {
            "output.masks.instance_png"
        } else {
            "output.masks.depth"
        };
        v.push(
            field,
            format!(
                "a frame may hold {drones} drones (placement) and {confusers} confusers (confusers[*].count): {} instance ids, but a 16-bit instance image names at most {limit}; lower placement's count or the confusers' counts by {}",
                drones + confusers,
                drones + confusers - limit
            ),
        );
    }

    /// The model list: sizes and classes (built-in names: `pipeline::check`).
    fn validate_models(&self, v: &mut Validator) {
        if self.models.is_empty() {
            v.push("models", "at least one model is needed".into());
        }
        for (i, m) in self.models.iter().enumerate() {
            v.positive(&format!("models[{i}].size_m"), m.size_m, "metres");
            // NaN is named once, by `positive`.
            let within = m.size_m.is_nan() || m.size_m <= 1000.0;
            v.check(within, &format!("models[{i}].size_m"), || {
                format!("{} m is larger than the 1000 m limit", m.size_m)
            });
            v.check(
                !m.class.trim().is_empty(),
                &format!("models[{i}].class"),
                || "class name is empty".into(),
            );
            if let Some(problem) = crate::text::name_problem(&m.class) {
                v.push(&format!("models[{i}].class"), problem);
            }
        }
    }

    /// The placement mode's counts, volume and separation.
    fn validate_placement(&self, v: &mut Validator) {
        match &self.placement {
            Placement::Structured {
                x_count,
                y_count,
                z_count,
                load_factor,
            } => {
                for (name, c) in [
                    ("x_count", x_count),
                    ("y_count", y_count),
                    ("z_count", z_count),
                ] {
                    v.check(*c >= 1, &format!("placement.{name}"), || {
                        format!("{c} drones along an axis; must be at least 1")
                    });
                }
                let total = u64::from(*x_count)
                    .checked_mul(u64::from(*y_count))
                    .and_then(|n| n.checked_mul(u64::from(*z_count)));
                v.check(total.is_some_and(|n| n <= MAX_DRONES_PER_FRAME), "placement", || {
                    let total = total.map_or_else(|| "more than 2⁶⁴".to_string(), |n| n.to_string());
                    format!("{x_count}×{y_count}×{z_count} = {total} drones per frame, more than the limit of {MAX_DRONES_PER_FRAME}")
                });
                v.check(load_factor.is_finite() && *load_factor >= 1.0 && *load_factor <= 1e6, "placement.load_factor", || {
                    format!("{load_factor} is out of range [1, 1e6]: below 1 the grid spacing is smaller than a drone and drones overlap")
                });
            }
            Placement::Formation(f) => f.validate_into(v, "placement"),
            Placement::Randomized {
                count: (lo, hi),
                count_distribution,
                volume,
                min_separation_m,
            } => {
                validate_count_distribution(v, (*lo, *hi), count_distribution, volume);
                v.check(*lo >= 1, "placement.count", || {
                    format!("minimum count {lo} must be at least 1")
                });
                v.check(hi >= lo, "placement.count", || {
                    format!("minimum {lo} is more than maximum {hi}")
                });
                v.check(
                    u64::from(*hi) <= MAX_DRONES_PER_FRAME,
                    "placement.count",
                    || format!("{hi} drones is more than the limit of {MAX_DRONES_PER_FRAME}"),
                );
                v.check(
                    min_separation_m.is_finite() && *min_separation_m >= 0.0,
                    "placement.min_separation_m",
                    || format!("{min_separation_m} must be a finite distance ≥ 0 m"),
                );
                match volume {
                    Volume::Box { size_m: (x, y, z) } => {
                        for (axis, s) in [("x", x), ("y", y), ("z", z)] {
                            v.check(
                                s.is_finite() && *s >= 0.0 && *s <= 1e6,
                                &format!("placement.volume.size_m.{axis}"),
                                || format!("{s} is out of range [0, 1e6] metres"),
                            );
                        }
                    }
                    Volume::Density { per_m3 } => {
                        v.positive("placement.volume.per_m3", *per_m3, "drones per m³");
                        // The cube holding the largest count must stay a finite, bounded size.
                        let side = (f64::from(*hi) / per_m3).cbrt();
                        v.check(
                            per_m3.is_nan() || *per_m3 <= 0.0 || (side.is_finite() && side <= 1e6),
                            "placement.volume.per_m3",
                            || format!("{per_m3} drones per m³ puts {hi} drones in a cube {side:.3e} m wide, larger than the 1e6 m limit"),
                        );
                    }
                    Volume::DensitySweep { size_m, per_m3 } => {
                        super::formation::validate_density_sweep(v, *size_m, *per_m3)
                    }
                }
                if let Volume::Box { size_m } = volume
                    && *size_m == (0.0, 0.0, 0.0)
                    && *hi > 1
                {
                    v.push(
                        "placement.volume.size_m",
                        format!("the volume is a point (0 × 0 × 0 m): up to {hi} drones would all sit at the same spot; give it a size"),
                    );
                }
                if v.errors.is_empty() {
                    let fraction = Self::packing_fraction(*hi, volume, *min_separation_m);
                    v.check(fraction <= MAX_PACKING_FRACTION, "placement.min_separation_m", || {
                        format!(
                            "{hi} drones {min_separation_m} m apart fill {:.0}% of the volume; at most {:.0}% can be placed at random (enlarge the volume or lower the count or separation)",
                            fraction * 100.0,
                            MAX_PACKING_FRACTION * 100.0
                        )
                    });
                }
            }
        }
    }

    /// The attitude ranges.
    fn validate_attitude(&self, v: &mut Validator) {
        for (name, (lo, hi)) in [
            ("roll_deg", self.attitude.roll_deg),
            ("pitch_deg", self.attitude.pitch_deg),
            ("yaw_deg", self.attitude.yaw_deg),
        ] {
            v.check(
                lo.is_finite() && hi.is_finite() && lo <= hi && lo >= -360.0 && hi <= 360.0,
                &format!("attitude.{name}"),
                || format!("({lo}, {hi}) must be finite degrees with min ≤ max within [-360, 360]"),
            );
        }
    }

    /// Sweeps, camera, repeats, frame count and sky.
    fn validate_camera(&self, v: &mut Validator) {
        for (name, range) in self.sweep_axes() {
            if let Err(e) = range.count() {
                let field = match e {
                    SweepError::NotFinite { .. } | SweepError::TooMany { .. } => name.to_string(),
                    SweepError::ZeroStep { .. } | SweepError::WrongSign { .. } => {
                        format!("{name}.step")
                    }
                };
                v.push(&field, e.to_string());
            }
        }
        let has_zero = |r: SweepRange| {
            let Ok(n) = r.count() else { return false };
            if r.start == r.end || r.step == 0.0 {
                return r.start == 0.0;
            }
            let i = (-r.start / r.step).round();
            i >= 0.0 && (i as u64) < n && r.value(i as u64) == 0.0
        };
        if has_zero(self.camera.x) && has_zero(self.camera.y) && has_zero(self.camera.z) {
            v.push(
                "camera.z",
                "CameraX, CameraY and CameraZ are all 0 in some frame: the camera would sit at the centre it looks at".into(),
            );
        }
        v.check(
            self.camera.fov_y_deg.is_finite()
                && self.camera.fov_y_deg > 0.5
                && self.camera.fov_y_deg < 170.0,
            "camera.fov_y_deg",
            || {
                format!(
                    "{} is out of range (0.5, 170) degrees",
                    self.camera.fov_y_deg
                )
            },
        );
        v.check(self.repeats >= 1, "repeats", || {
            format!("{} must be at least 1", self.repeats)
        });
        let frames = self.frame_count();
        v.check(frames <= MAX_FRAMES, "frames", || format!("camera sweeps × plane sweeps × repeats (× sequence steps) = {frames} frames, more than the limit of {MAX_FRAMES}"));
        self.sky.validate_into(v, "sky", false);
    }

    /// Resolution and MSAA.
    fn validate_render(&self, v: &mut Validator) {
        let (w, h) = self.image_size();
        for (name, side) in [("width", w), ("height", h)] {
            v.check(
                (1..=MAX_IMAGE_SIDE).contains(&side),
                &format!("render.resolution.{name}"),
                || format!("{side} px is out of range [1, {MAX_IMAGE_SIDE}]"),
            );
        }
        let lod = self.render.lod_error_px;
        v.check((0.0..=4.0).contains(&lod), "render.lod_error_px", || {
            format!("{lod} is outside 0–4 px (0 draws every drone at full detail)")
        });
        if let Some(px) = self.render.impostor_below_px {
            v.check(
                (0.0..=MAX_IMPOSTOR_PX).contains(&px),
                "render.impostor_below_px",
                || {
                    format!(
                        "{px} is outside 0–{MAX_IMPOSTOR_PX} px (impostors are for small drones)"
                    )
                },
            );
        }
        v.check(matches!(self.render.msaa, 1 | 4), "render.msaa", || {
            format!("{} is not supported; use 1 or 4", self.render.msaa)
        });
        match self.frame_memory_bytes() {
            Some(bytes) if bytes <= MAX_FRAME_MEMORY_BYTES => {}
            bytes => v.push(
                "render.resolution",
                format!(
                    "{w}×{h} with MSAA {} and id scale {} needs about {} of memory per frame, more than the {} limit",
                    self.render.msaa,
                    self.labels.id_scale,
                    bytes.map_or_else(|| "more than 2⁶⁴ bytes".into(), gib),
                    gib(MAX_FRAME_MEMORY_BYTES)
                ),
            ),
        }
    }

    /// About how many bytes of memory making one frame needs (GPU targets,
    /// readback and the batch's queued frames), or `None` if it overflows.
    /// An estimate that errs high: colour and depth per MSAA sample, the
    /// resolved colour, the id layer and its depth at `id_scale`², the
    /// readback copy and [`QUEUED_FRAMES`] frames waiting for the encoders.
    pub fn frame_memory_bytes(&self) -> Option<u64> {
        let (w, h) = self.image_size();
        let pixels = u64::from(w).checked_mul(u64::from(h))?;
        let msaa = u64::from(self.render.msaa.max(1));
        let id = u64::from(self.labels.id_scale.max(1)).checked_pow(2)?;
        let per_pixel = msaa
            .checked_mul(8)?
            .checked_add(id.checked_mul(msaa)?.checked_mul(8)?)?
            .checked_add(4 + 4)?
            .checked_add(4 * QUEUED_FRAMES)?;
        pixels.checked_mul(per_pixel)
    }

    /// Check the preset against what the device can do (texture side, buffer
    /// size) and the memory there is; every problem named by its field.
    pub fn check_limits(&self, limits: &DeviceLimits) -> Result<(), Vec<FieldError>> {
        let mut v = Validator::default();
        let (w, h) = self.image_size();
        let id_scale = self.labels.id_scale.max(1);
        for (name, side) in [("width", w), ("height", h)] {
            let needed = u64::from(side) * u64::from(id_scale);
            v.check(
                needed <= u64::from(limits.max_texture_side),
                &format!("render.resolution.{name}"),
                || {
                    format!(
                        "{side} px (× id scale {id_scale} = {needed}) is more than this adapter's largest texture side, {} px",
                        limits.max_texture_side
                    )
                },
            );
        }
        // The readback buffer holds one RGBA8 frame with rows padded to 256 bytes.
        let row = (u64::from(w) * 4).div_ceil(256) * 256;
        let readback = row * u64::from(h);
        v.check(
            readback <= limits.max_buffer_bytes,
            "render.resolution",
            || {
                format!(
                    "{w}×{h} needs a {} readback buffer, more than this adapter's largest buffer, {}",
                    gib(readback),
                    gib(limits.max_buffer_bytes)
                )
            },
        );
        if let (Some(available), Some(needed)) = (limits.memory_bytes, self.frame_memory_bytes()) {
            v.check(needed <= available, "render.resolution", || {
                format!(
                    "{w}×{h} with MSAA {} needs about {} of memory per frame, but only {} is available (three quarters of the free memory, within the process's `ulimit -v` and `ulimit -d`)",
                    self.render.msaa,
                    gib(needed),
                    gib(available)
                )
            });
        }
        if v.errors.is_empty() {
            Ok(())
        } else {
            Err(v.errors)
        }
    }

    /// What is allowed but probably not meant: drones that can overlap, a
    /// scene with no room. Printed loudly by `check`, `batch` and `frame`.
    pub fn warnings(&self) -> Vec<FieldError> {
        let mut v = Validator::default();
        let span = self.max_model_size_m();
        match &self.placement {
            Placement::Randomized {
                count: (_, hi),
                volume,
                min_separation_m,
                ..
            } if *hi > 1 => {
                v.check(
                    *min_separation_m >= span,
                    "placement.min_separation_m",
                    || format!("{min_separation_m} m is smaller than the largest drone's span ({span} m): drones can overlap and their boxes merge; raise it to at least {span}"),
                );
                if let Volume::Density { per_m3 } = volume {
                    let spacing = per_m3.powf(-1.0 / 3.0);
                    v.check(spacing >= span, "placement.volume.per_m3", || {
                        format!("{per_m3} drones per m³ leaves {spacing:.3} m per drone, less than the largest drone's span ({span} m): drones crowd and overlap")
                    });
                }
            }
            _ => {}
        }
        // Class names that differ only by case, spaces or look-alike letters
        // become separate classes: almost never what was meant.
        let mut seen: Vec<(String, &str, usize)> = Vec::new();
        for (i, m) in self.models.iter().enumerate() {
            let skeleton = crate::text::skeleton(&m.class);
            match seen.iter().find(|(s, name, _)| *s == skeleton && *name != m.class) {
                Some((_, name, j)) => v.push(
                    &format!("models[{i}].class"),
                    format!(
                        "\"{}\" and \"{}\" (models[{j}].class) differ only by case, spaces or look-alike letters, yet become two classes; give both the same name",
                        crate::text::printable(&m.class),
                        crate::text::printable(name)
                    ),
                ),
                None => seen.push((skeleton, &m.class, i)),
            }
        }
        v.errors
    }

    /// Label settings.
    fn validate_labels(&self, v: &mut Validator) {
        v.check(
            self.labels.min_box_px.is_finite() && self.labels.min_box_px >= 0.0,
            "labels.min_box_px",
            || {
                format!(
                    "{} must be a finite number of pixels ≥ 0",
                    self.labels.min_box_px
                )
            },
        );
        v.check(
            self.labels.min_visible_fraction.is_finite()
                && (0.0..=1.0).contains(&self.labels.min_visible_fraction),
            "labels.min_visible_fraction",
            || {
                format!(
                    "{} is out of range [0, 1]",
                    self.labels.min_visible_fraction
                )
            },
        );
        v.check(
            matches!(self.labels.id_scale, 1 | 2 | 4),
            "labels.id_scale",
            || format!("{} is not supported; use 1, 2 or 4", self.labels.id_scale),
        );
        let wanted = self.labels.min_labelled;
        if wanted > 0 {
            let most = match &self.placement {
                Placement::Structured {
                    x_count,
                    y_count,
                    z_count,
                    ..
                } => u64::from(*x_count) * u64::from(*y_count) * u64::from(*z_count),
                Placement::Randomized {
                    volume: Volume::DensitySweep { .. },
                    ..
                } => u64::MAX,
                Placement::Randomized { count: (_, hi), .. } => u64::from(*hi),
                Placement::Formation(f) => u64::from(f.count),
            };
            v.check(u64::from(wanted) <= most, "labels.min_labelled", || {
                format!("{wanted} labelled drones per frame, but the placement puts at most {most} in a frame")
            });
            v.check(self.sequence.is_none(), "labels.min_labelled", || {
                "is not supported in sequence mode (a sequence's draws belong to its first frame); set it to 0".into()
            });
        }
    }

    /// Image format and split shares.
    fn validate_output(&self, v: &mut Validator) {
        if let ImageFormat::Jpeg { quality } = self.output.image_format {
            v.check(
                (1..=100).contains(&quality),
                "output.image_format.quality",
                || format!("{quality} is out of range [1, 100]"),
            );
        }
        let s = &self.output.split;
        let parts = [("train", s.train), ("val", s.val), ("test", s.test)];
        for (name, share) in parts {
            v.check(
                share.is_finite() && (0.0..=1.0).contains(&share),
                &format!("output.split.{name}"),
                || format!("{share} is out of range [0, 1]"),
            );
        }
        let sum = s.train + s.val + s.test;
        v.check((sum - 1.0).abs() < 1e-6, "output.split", || {
            format!("shares sum to {sum}; they must sum to 1")
        });
    }
}

/// The count distribution of randomized placement: its parameters, and
/// every table row within the count range.
fn validate_count_distribution(
    v: &mut Validator,
    (lo, hi): (u32, u32),
    dist: &CountDistribution,
    volume: &Volume,
) {
    let field = "placement.count_distribution";
    if dist.is_uniform() {
        return;
    }
    if matches!(volume, Volume::DensitySweep { .. }) {
        v.push(
            field,
            "a DensitySweep volume fixes each frame's count from the swept density; remove count_distribution".into(),
        );
        return;
    }
    let span = u64::from(hi.saturating_sub(lo)) + 1;
    v.check(span <= u64::from(MAX_COUNT_SPAN), "placement.count", || {
        format!(
            "({lo}, {hi}) spans {span} counts; a count_distribution may span at most {}",
            MAX_COUNT_SPAN
        )
    });
    match dist {
        CountDistribution::Uniform => {}
        CountDistribution::Table(rows) => {
            if rows.is_empty() {
                v.push(field, "the table lists no count".into());
            }
            let mut seen = std::collections::BTreeSet::new();
            for (i, (n, w)) in rows.iter().enumerate() {
                let row = format!("{field}[{i}]");
                v.check((lo..=hi).contains(n), &row, || {
                    format!("count {n} is outside placement.count ({lo}, {hi})")
                });
                v.check(w.is_finite() && *w >= 0.0, &row, || {
                    format!("weight {w} must be a finite number ≥ 0")
                });
                v.check(seen.insert(*n), &row, || {
                    format!("count {n} is listed twice")
                });
            }
            let total: f64 = rows.iter().map(|r| r.1).filter(|w| w.is_finite()).sum();
            v.check(rows.is_empty() || total > 0.0, field, || {
                "the weights sum to 0: no count could be drawn".into()
            });
        }
        CountDistribution::Poisson { mean } => {
            v.check(
                mean.is_finite() && *mean > 0.0 && *mean <= 1e6,
                &format!("{field}.mean"),
                || format!("{mean} is out of range (0, 1e6]"),
            );
        }
        CountDistribution::Geometric { p } => {
            v.check(
                p.is_finite() && *p > 0.0 && *p <= 1.0,
                &format!("{field}.p"),
                || format!("{p} is out of range (0, 1]"),
            );
        }
    }
}
