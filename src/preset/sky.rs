//! The background environment of a preset (`sky`): gradient, procedural
//! environments, sky images and random choices among them, with their
//! validation. The renderer's side is `crate::sky`.

use super::*;

/// Linear RGB of the default gradient sky at the zenith and the horizon (also
/// what a frame draws when its sky has nothing to show).
pub const DEFAULT_ZENITH: (f32, f32, f32) = (0.10, 0.25, 0.60);
pub const DEFAULT_HORIZON: (f32, f32, f32) = (0.62, 0.74, 0.88);

/// The background environment.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum Sky {
    /// A procedural gradient sky with a sun disc; the sun also lights the drones.
    Gradient {
        sun_elevation_deg: f64,
        sun_azimuth_deg: f64,
        /// Linear RGB at the zenith and at the horizon.
        zenith: (f32, f32, f32),
        horizon: (f32, f32, f32),
    },
    /// One of the seven named procedural environments (`EnvironmentName`):
    /// a Preetham sky, clouds, ground and horizon. Unset fields take the
    /// environment's own values.
    Procedural {
        environment: EnvironmentName,
        #[serde(default)]
        sun_elevation_deg: Option<f64>,
        #[serde(default)]
        sun_azimuth_deg: Option<f64>,
        /// Atmospheric turbidity, [1.7, 10] (2 = very clear, 6+ = hazy).
        #[serde(default)]
        turbidity: Option<f64>,
        /// Fraction of the sky under cloud, [0, 1].
        #[serde(default)]
        cloud_cover: Option<f64>,
        /// Seed of the cloud/ground pattern; unset: a new pattern every frame.
        #[serde(default)]
        seed: Option<u32>,
        /// Exposure compensation in stops.
        #[serde(default)]
        exposure_ev: f64,
        /// The sunlight on the scene (drones, ground, scenery, clouds) relative
        /// to the environment's own, in stops; the clear sky's brightness is
        /// unchanged (0: as the environment gives it). Sets the sun-to-sky ratio, which
        /// decides how far a sunlit white drone outshines the sky behind it.
        /// Written only when ≠ 0 (presets without it keep their lock files).
        #[serde(default, skip_serializing_if = "is_zero")]
        sun_ev: f64,
    },
    /// An equirectangular image (.hdr, .exr, .png, .jpg) or six cubemap faces.
    /// The sun that lights the drones is given in the image's frame (azimuth
    /// 0 = the image's centre column) and turns with `rotation_deg`.
    Image {
        source: SkyImageSource,
        /// Exposure in stops (HDR values are then tone mapped).
        #[serde(default)]
        exposure_ev: f64,
        /// Turns the image about the vertical axis (same sense as the sun azimuth).
        #[serde(default)]
        rotation_deg: f64,
        #[serde(default = "default_image_sun_elevation")]
        sun_elevation_deg: f64,
        #[serde(default)]
        sun_azimuth_deg: f64,
    },
    /// Per frame: pick one of `choices`, add a random azimuth offset, and
    /// replace the sun elevation and cloud cover by draws from the ranges given.
    Random {
        choices: Vec<Sky>,
        #[serde(default)]
        azimuth_offset_deg: (f64, f64),
        #[serde(default)]
        sun_elevation_deg: Option<(f64, f64)>,
        #[serde(default)]
        cloud_cover: Option<(f64, f64)>,
        /// An exposure offset in stops drawn per frame and added to the chosen
        /// sky's `exposure_ev` (image and procedural skies); absent: none.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        exposure_ev: Option<(f64, f64)>,
        /// A sunlight offset in stops drawn per frame and added to the chosen
        /// procedural sky's `sun_ev`; absent: none.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        sun_ev: Option<(f64, f64)>,
    },
}

fn default_image_sun_elevation() -> f64 {
    45.0
}

/// Where an image sky's pixels come from; relative paths are relative to the preset file.
#[derive(Clone, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum SkyImageSource {
    /// One equirectangular (2:1 latitude/longitude) image, top row = zenith.
    Equirect(PathBuf),
    /// Six square faces in the OpenGL cubemap convention (+X, −X, +Y up, −Y, +Z, −Z).
    Cubemap {
        px: PathBuf,
        nx: PathBuf,
        py: PathBuf,
        ny: PathBuf,
        pz: PathBuf,
        nz: PathBuf,
    },
    /// A photographic sky shipped with swarmshot (`assets/skies/`, CC0):
    /// one of [`BUILTIN_SKIES`], e.g. `Builtin("quarry_01")`.
    Builtin(String),
}

/// The built-in photographic skies (`SkyImageSource::Builtin`): name and what it shows.
/// Equirectangular HDR (Radiance 512×256, OpenEXR 1024×512), CC0 (Poly Haven; `assets/skies/SOURCE.txt`).
pub const BUILTIN_SKIES: [(&str, &str); 3] = [
    (
        "quarry_01",
        "daylight over a quarry: blue sky, cumulus, the sun high",
    ),
    (
        "venice_sunset",
        "sunset over the sea and a city skyline, the sun low",
    ),
    (
        "forest",
        "a forest canopy from below: branches and leaves against the sky",
    ),
];

impl SkyImageSource {
    /// The files it reads (none for a built-in sky).
    pub fn paths(&self) -> Vec<&Path> {
        match self {
            Self::Equirect(p) => vec![p],
            Self::Cubemap {
                px,
                nx,
                py,
                ny,
                pz,
                nz,
            } => vec![px, nx, py, ny, pz, nz],
            Self::Builtin(_) => Vec::new(),
        }
    }

    fn paths_mut(&mut self) -> Vec<&mut PathBuf> {
        match self {
            Self::Equirect(p) => vec![p],
            Self::Cubemap {
                px,
                nx,
                py,
                ny,
                pz,
                nz,
            } => [px, nx, py, ny, pz, nz].into(),
            Self::Builtin(_) => Vec::new(),
        }
    }
}

impl Sky {
    /// A named procedural environment with all its defaults.
    pub fn procedural(environment: EnvironmentName) -> Self {
        Self::Procedural {
            environment,
            sun_elevation_deg: None,
            sun_azimuth_deg: None,
            turbidity: None,
            cloud_cover: None,
            seed: None,
            exposure_ev: 0.0,
            sun_ev: 0.0,
        }
    }

    /// Every image this sky references, each once, in order of first appearance.
    pub fn image_sources(&self) -> Vec<&SkyImageSource> {
        let mut out: Vec<&SkyImageSource> = Vec::new();
        let mut visit = vec![self];
        while let Some(sky) = visit.pop() {
            match sky {
                Sky::Image { source, .. } if !out.contains(&source) => out.push(source),
                Sky::Random { choices, .. } => visit.extend(choices.iter().rev()),
                _ => {}
            }
        }
        out
    }

    /// Every image file the sky names (its choices' too).
    pub(super) fn image_paths_mut(&mut self) -> Vec<&mut PathBuf> {
        match self {
            Sky::Image { source, .. } => source.paths_mut(),
            Sky::Random { choices, .. } => {
                choices.iter_mut().flat_map(Sky::image_paths_mut).collect()
            }
            _ => Vec::new(),
        }
    }

    /// Push every invalid value of this sky, fields named under `field`.
    pub(super) fn validate_into(&self, v: &mut Validator, field: &str, nested: bool) {
        let range = |v: &mut Validator, name: &str, value: f64, lo: f64, hi: f64| {
            v.check(
                value.is_finite() && (lo..=hi).contains(&value),
                &format!("{field}.{name}"),
                || format!("{value} is out of range [{lo}, {hi}]"),
            );
        };
        match self {
            Sky::Gradient {
                sun_elevation_deg,
                sun_azimuth_deg,
                zenith,
                horizon,
            } => {
                range(v, "sun_elevation_deg", *sun_elevation_deg, -90.0, 90.0);
                v.check(
                    sun_azimuth_deg.is_finite(),
                    &format!("{field}.sun_azimuth_deg"),
                    || format!("{sun_azimuth_deg} must be finite"),
                );
                for (name, (r, g, b)) in [("zenith", zenith), ("horizon", horizon)] {
                    v.check(
                        [r, g, b]
                            .iter()
                            .all(|c| c.is_finite() && **c >= 0.0 && **c <= 100.0),
                        &format!("{field}.{name}"),
                        || format!("({r}, {g}, {b}) must be linear RGB in [0, 100]"),
                    );
                }
            }
            Sky::Procedural {
                sun_elevation_deg,
                sun_azimuth_deg,
                turbidity,
                cloud_cover,
                exposure_ev,
                sun_ev,
                ..
            } => {
                if let Some(e) = sun_elevation_deg {
                    range(v, "sun_elevation_deg", *e, -10.0, 90.0);
                }
                if let Some(a) = sun_azimuth_deg {
                    range(v, "sun_azimuth_deg", *a, -3600.0, 3600.0);
                }
                if let Some(t) = turbidity {
                    range(v, "turbidity", *t, 1.7, 10.0);
                }
                if let Some(c) = cloud_cover {
                    range(v, "cloud_cover", *c, 0.0, 1.0);
                }
                range(v, "exposure_ev", *exposure_ev, -10.0, 10.0);
                range(v, "sun_ev", *sun_ev, -4.0, 4.0);
            }
            Sky::Image {
                source,
                exposure_ev,
                rotation_deg,
                sun_elevation_deg,
                sun_azimuth_deg,
            } => {
                range(v, "exposure_ev", *exposure_ev, -20.0, 20.0);
                range(v, "rotation_deg", *rotation_deg, -3600.0, 3600.0);
                range(v, "sun_elevation_deg", *sun_elevation_deg, -90.0, 90.0);
                range(v, "sun_azimuth_deg", *sun_azimuth_deg, -3600.0, 3600.0);
                if let SkyImageSource::Builtin(name) = source {
                    v.check(
                        BUILTIN_SKIES.iter().any(|(n, _)| n == name),
                        &format!("{field}.source"),
                        || {
                            let names: Vec<&str> = BUILTIN_SKIES.iter().map(|(n, _)| *n).collect();
                            format!("no built-in sky {name:?} (there are {})", names.join(", "))
                        },
                    );
                }
                let mut source = source.clone();
                for path in source.paths_mut() {
                    v.check(
                        !path.as_os_str().is_empty(),
                        &format!("{field}.source"),
                        || "image path is empty".into(),
                    );
                }
            }
            Sky::Random { .. } => self.validate_random(v, field, nested),
        }
    }

    /// A Random sky's ranges and choices (each choice validated, not Random itself).
    fn validate_random(&self, v: &mut Validator, field: &str, nested: bool) {
        let Sky::Random {
            choices,
            azimuth_offset_deg,
            sun_elevation_deg,
            cloud_cover,
            exposure_ev,
            sun_ev,
        } = self
        else {
            return;
        };
        if nested {
            v.push(
                field,
                "a Random sky cannot be one of another Random sky's choices".into(),
            );
        }
        if choices.is_empty() {
            v.push(
                &format!("{field}.choices"),
                "at least one choice is needed".into(),
            );
        }
        let pair = |v: &mut Validator, name: &str, (a, b): (f64, f64), lo: f64, hi: f64| {
            v.check(
                a.is_finite() && b.is_finite() && lo <= a && a <= b && b <= hi,
                &format!("{field}.{name}"),
                || format!("({a}, {b}) must be an ordered (min, max) within [{lo}, {hi}]"),
            );
        };
        pair(
            v,
            "azimuth_offset_deg",
            *azimuth_offset_deg,
            -3600.0,
            3600.0,
        );
        if let Some(r) = sun_elevation_deg {
            pair(v, "sun_elevation_deg", *r, -10.0, 90.0);
        }
        if let Some(r) = cloud_cover {
            pair(v, "cloud_cover", *r, 0.0, 1.0);
        }
        if let Some(r) = exposure_ev {
            pair(v, "exposure_ev", *r, -10.0, 10.0);
        }
        if let Some(r) = sun_ev {
            pair(v, "sun_ev", *r, -4.0, 4.0);
        }
        for (i, c) in choices.iter().enumerate() {
            c.validate_into(v, &format!("{field}.choices[{i}]"), true);
        }
    }
}

impl Default for Sky {
    fn default() -> Self {
        Self::Gradient {
            sun_elevation_deg: 40.0,
            sun_azimuth_deg: 135.0,
            zenith: DEFAULT_ZENITH,
            horizon: DEFAULT_HORIZON,
        }
    }
}

fn is_zero(v: &f64) -> bool {
    *v == 0.0
}

/// The paper's seven Unity skyboxes, as procedural environments.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum EnvironmentName {
    Daytime,
    Sunset,
    BeautifulPasture,
    SnowyBridge,
    SmallHarbour,
    Tellsplatte,
    CountryRoad,
}

impl EnvironmentName {
    pub const ALL: [Self; 7] = [
        Self::Daytime,
        Self::Sunset,
        Self::BeautifulPasture,
        Self::SnowyBridge,
        Self::SmallHarbour,
        Self::Tellsplatte,
        Self::CountryRoad,
    ];

    pub fn as_str(self) -> &'static str {
        match self {
            Self::Daytime => "Daytime",
            Self::Sunset => "Sunset",
            Self::BeautifulPasture => "BeautifulPasture",
            Self::SnowyBridge => "SnowyBridge",
            Self::SmallHarbour => "SmallHarbour",
            Self::Tellsplatte => "Tellsplatte",
            Self::CountryRoad => "CountryRoad",
        }
    }
}
