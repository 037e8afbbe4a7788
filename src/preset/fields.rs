//! One table of the preset's fields (issue 23): for each field path, the label a
//! user sees beside its widget, its tooltip, its unit and the parameter section
//! that holds it. Validation messages name field paths
//! ([`super::FieldError::field`]); the app's panels take their labels, tooltips
//! and units from here and its Problems list names a message's field with the
//! same label, so a field's words live in one place.
//!
//! Paths are written as validation writes them: dotted struct fields, `[]` for
//! a list item (`models[].size_m`; looked up as `models[2].size_m`, and `{n}` in
//! the label becomes the item's number from 1). A path that is not in the table
//! takes its parent's label and its own last part: a sweep's `camera.z.step` is
//! "CameraZ step", `placement.volume.size_m.y` "Volume size y".

/// One field of a preset as the app shows it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Field {
    /// The field path, as validation messages name it.
    pub path: &'static str,
    /// The label beside its widget (also its accessible name).
    pub label: &'static str,
    pub tooltip: &'static str,
    /// Shown after the number (`"°"`, `" m"`, `" px"`; `""` for none).
    pub unit: &'static str,
    /// The parameter section holding its widget (`None`: the general fields above them).
    pub section: Option<&'static str>,
}

/// The parameter sections, as titled in the app's left panel, in order.
pub const SECTIONS: [&str; 15] = [
    MODELS,
    PLACEMENT,
    ATTITUDE,
    CAMERA,
    ROTATION,
    SKYBOX,
    CAMERA_MODEL,
    THERMAL,
    ATMOSPHERE,
    APPEARANCE,
    CLUTTER,
    CONFUSERS,
    WEATHER,
    BACKPLATES,
    OUTPUT,
];

const MODELS: &str = "Models";
const PLACEMENT: &str = "Placement";
const ATTITUDE: &str = "Attitude";
const CAMERA: &str = "Camera";
const ROTATION: &str = "Scene rotation";
const SKYBOX: &str = "Skybox";
const CAMERA_MODEL: &str = "Camera model";
const THERMAL: &str = "Thermal camera";
const ATMOSPHERE: &str = "Atmosphere";
const APPEARANCE: &str = "Drone appearance";
const CLUTTER: &str = "Clutter";
const CONFUSERS: &str = "Confusers";
const WEATHER: &str = "Weather";
const BACKPLATES: &str = "Backplates";
const OUTPUT: &str = "Output";

/// The section of every path under a top-level field.
const SECTION_OF_HEAD: [(&str, &str); 18] = [
    ("models", MODELS),
    ("placement", PLACEMENT),
    ("sequence", PLACEMENT),
    ("attitude", ATTITUDE),
    ("camera", CAMERA),
    ("plane", ROTATION),
    ("sky", SKYBOX),
    ("camera_model", CAMERA_MODEL),
    ("thermal", THERMAL),
    ("atmosphere", ATMOSPHERE),
    ("appearance", APPEARANCE),
    ("clutter", CLUTTER),
    ("confusers", CONFUSERS),
    ("weather", WEATHER),
    ("backplate", BACKPLATES),
    ("render", OUTPUT),
    ("output", OUTPUT),
    ("labels", OUTPUT),
];

/// `f(path, label, unit, tooltip)`: the section follows from the path's head.
const fn f(
    path: &'static str,
    label: &'static str,
    unit: &'static str,
    tooltip: &'static str,
) -> Field {
    Field {
        path,
        label,
        tooltip,
        unit,
        section: section_of_head(path),
    }
}

/// The table (see the module docs for how paths are written).
#[rustfmt::skip]
pub const FIELDS: &[Field] = &[
    // General, above the sections.
    f("name", "Name", "", "Preset name, written into the dataset's lock file"),
    f("seed", "Seed", "", "Master seed: every frame derives its own random draw from (seed, frame index)"),
    f("repeats", "Repeats", "", "Frames made per sweep combination, each with its own random placement"),
    // Models.
    f("models", "Models", "", "The UAV models instantiated in every frame, with their real size"),
    f("models[].size_m", "Model {n} size", " m", "Real size: the model is scaled so that its largest span is this many metres"),
    f("models[].class", "Model {n} class", "", "Class name written into the labels"),
    f("models[].source", "Model {n}", "", "A built-in model's name or a glTF file"),
    // Placement: the grid, the randomized volume, formations, sequences.
    f("placement", "Placement", "", "How drones are placed in the observation volume"),
    f("placement.x_count", "XCount", "", "Drones along the grid's x axis"),
    f("placement.y_count", "YCount", "", "Drones along the grid's y (vertical) axis"),
    f("placement.z_count", "ZCount", "", "Drones along the grid's z (depth) axis"),
    f("placement.load_factor", "LoadFactor", "", "Grid spacing in multiples of the largest model size (≥ 1: no overlap)"),
    f("placement.count", "Count", "", "Drones per frame: randomized, an inclusive range drawn by the preset's count_distribution (uniform unless the preset names one); a formation, its size"),
    f("placement.count_distribution", "Count distribution", "", "How the count is drawn within its range (uniform unless given)"),
    f("placement.volume", "Volume", "", "The observation volume W, centred at the origin"),
    f("placement.volume.size_m", "Volume size", " m", "Size of the observation volume in metres"),
    f("placement.volume.per_m3", "Density", "", "Global density factor ρ: drones per cubic metre"),
    f("placement.min_separation_m", "Min separation", "", "No two drone centres come closer than this (metres)"),
    f("placement.shape", "Shape", "", "The formation's pattern; each has its own few parameters"),
    f("placement.shape.angle_deg", "Echelon angle", "°", "Degrees from the heading (0 = column, 90 = line abreast)"),
    f("placement.shape.half_angle_deg", "Wedge half angle", "°", "Degrees between each arm and the heading"),
    f("placement.shape.tilt_deg", "Ring tilt", "°", "Degrees the ring's axis leans forward from vertical"),
    f("placement.shape.clusters", "Clusters", "", "Number of dense groups"),
    f("placement.shape.cluster_gap", "Cluster gap", "", "Gap between groups in model spans"),
    f("placement.spacing", "Spacing", "", "Distance between neighbours in multiples of the largest model size (a LoadFactor)"),
    f("placement.heading_deg", "Heading", "°", "Yaw of the formation's forward axis, degrees, drawn per frame"),
    f("placement.position_jitter", "Jitter", "", "Each drone moves up to ± this many model sizes per axis"),
    f("placement.min_separation", "Min separation", "", "No two drone centres come closer than this many model sizes"),
    f("sequence", "Sequence", "", "Each sweep point becomes T + 1 frames of motion (MOT ground truth)"),
    f("sequence.steps", "Steps T", "", "Interpolation steps; a sequence has T + 1 frames"),
    f("sequence.motion.translate_m", "Translate", "", "Translation of the whole formation over the sequence (metres)"),
    f("sequence.motion.turn_deg", "Turn", "°", "Turn of the formation about the vertical, degrees"),
    f("sequence.motion.bank_deg", "Bank", "°", "Each drone rolls by this many degrees"),
    f("sequence.camera", "Camera", "", "Fixed (a ground observer) or following the swarm"),
    // Attitude.
    f("attitude.roll_deg", "Roll", "°", "Per-drone roll range in degrees"),
    f("attitude.pitch_deg", "Pitch", "°", "Per-drone pitch range in degrees"),
    f("attitude.yaw_deg", "Yaw", "°", "Per-drone yaw range in degrees"),
    // Camera.
    f("camera.x", "CameraX", "", "sideways camera offset, in units of the swarm radius R"),
    f("camera.y", "CameraY", "", "vertical camera offset, in units of the swarm radius R"),
    f("camera.z", "CameraZ", "", "relative distance: 1 = the swarm just fills the view"),
    f("camera.fov_y_deg", "Field of view", "°", "Vertical field of view of the camera, degrees"),
    f("camera.absolute", "Absolute camera", "", "A camera placed in metres rather than relative to the swarm"),
    f("camera.observer", "Observer camera", "", "A person on the ground looking up at the swarm: horizon low or out of frame, drones against the sky (CameraX/Y/Z are then not used)"),
    f("camera.observer.elevation_deg", "Observer elevation", "°", "Line of sight, degrees above the horizon, drawn per frame"),
    f("camera.observer.azimuth_deg", "Observer azimuth", "°", "Line of sight's direction from +z towards +x, degrees, drawn per frame"),
    f("camera.observer.distance_m", "Observer distance", " m", "Distance from the camera to the volume's centre in metres, drawn per frame"),
    f("camera.observer.size_px", "Observer apparent size", " px", "Instead of Observer distance: the largest model's size at the volume's centre in pixels, drawn per frame"),
    f("camera.observer.size_px_knots", "Observer size knots", " px", "With Observer apparent size: (quantile, px) pairs the size is drawn from (geometric between knots) instead of uniformly"),
    f("camera.observer.centre_at", "Observer centre at", "", "Where the volume's centre appears: x and y as shares of the frame's width and height from its top-left corner (0.5, 0.5: the centre); the line of sight stays, the camera moves sideways"),
    // Scene rotation.
    f("plane.rx", "PlaneRX", "°", "rotation of the whole swarm about world x, degrees"),
    f("plane.ry", "PlaneRY", "°", "rotation of the whole swarm about world y, degrees"),
    f("plane.rz", "PlaneRZ", "°", "rotation of the whole swarm about world z, degrees"),
    // Skybox.
    f("sky", "Skybox", "", "The background environment; its sun also lights the drones"),
    f("sky.sun_elevation_deg", "Sun elevation", "°", "Sun angle above the horizon, degrees (a procedural environment's own by default)"),
    f("sky.sun_azimuth_deg", "Sun azimuth", "°", "Sun direction from +z towards +x, degrees"),
    f("sky.cloud_cover", "Cloud cover", "", "Fraction of the sky under cloud, 0 to 1"),
    f("sky.azimuth_offset_deg", "Azimuth offset", "°", "A random sky's turn about the vertical, drawn per frame and added to each choice's sun azimuth (and an image's rotation)"),
    f("sky.exposure_ev", "Sky exposure", " EV", "A random sky's exposure offset in stops, drawn per frame and added to the chosen sky's own"),
    f("sky.sun_ev", "Sunlight", " EV", "The sunlight on drones, ground, scenery and clouds against the environment's own, in stops; the clear sky keeps its brightness (0: as the environment gives it)"),
    f("sky.zenith", "Zenith colour", "", "Linear RGB of the sky at this height"),
    f("sky.horizon", "Horizon colour", "", "Linear RGB of the sky at this height"),
    // Camera model.
    f("camera_model", "Camera model", "", "Pass every frame through a camera: optics, sensor noise and image processing, drawn per frame (off: the clean render)"),
    f("camera_model.exposure_ev", "Exposure", " EV", "Exposure change in stops: linear light × 2^EV before the sensor clips (with auto-exposure: the compensation added to the metered EV)"),
    f("camera_model.auto_exposure", "Auto-exposure", " levels", "Meter each frame's background (sky, clouds, silhouettes, ground; an image sky or backplate by its pixels) and expose it to this mean 8-bit level, drawn per frame (off: the exposure is the EV alone)"),
    f("camera_model.white_balance_red", "White balance red", "×", "Gain of the red channel relative to green (1: neutral)"),
    f("camera_model.white_balance_blue", "White balance blue", "×", "Gain of the blue channel relative to green (1: neutral)"),
    f("camera_model.vignetting", "Vignetting", "", "Light lost at the image corner, falling off as r² (0: none, 0.3: corners at 70 %)"),
    f("camera_model.saturation", "Saturation", "×", "Colour saturation of the camera's processing about each pixel's grey (1: unchanged, 0: grey, 1.2: a vivid look)"),
    f("camera_model.sharpen", "Sharpening", "×", "The image processor's unsharp mask on luma, as cameras apply before JPEG (0: none, 1: a step overshoots by a quarter of its height on each side)"),
    f("camera_model.exposure_time_s", "Exposure time", " s", "Motion blur in sequences: how long the shutter is open, at most one frame interval (0: none)"),
    f("camera_model.ca_red_scale", "CA red scale", "×", "Lateral chromatic aberration: the red image's radial scale relative to green (1: none)"),
    f("camera_model.ca_blue_scale", "CA blue scale", "×", "Lateral chromatic aberration: the blue image's radial scale relative to green (1: none)"),
    f("camera_model.shot_noise_gain", "Shot noise gain", " levels", "Shot (Poisson) noise: variance in levels² per linear 8-bit level of signal (0: none)"),
    f("camera_model.read_noise_levels", "Read noise", " levels", "Read (Gaussian) noise σ in linear 8-bit levels (0: none)"),
    f("camera_model.sensor_scale", "Sensor scale", "", "A coarser sensor: its side over the output's, in [0.05, 1]; the picture is sampled by it and scaled back up"),
    f("camera_model.jpeg_quality", "Camera JPEG quality", "", "JPEG quality drawn per frame (1–100), in place of Output's (JPEG output only)"),
    f("camera_model.recompress_quality", "Recompress quality", "", "A first JPEG compression at this quality (1–100), decoded again before the final write, as by a re-upload"),
    f("camera_model.psf", "Optics blur", "", "The lens's point spread function, its size drawn per frame"),
    f("camera_model.psf.sigma_px", "Blur σ", " px", "Standard deviation of the Gaussian PSF in output pixels"),
    f("camera_model.psf.radius_px", "Disc radius", " px", "Radius of the defocus disc in output pixels"),
    f("camera_model.rolling_shutter", "Rolling shutter", "", "Each image row exposed at its own time, the last row one readout after the first, while the drones move and the camera pans: drones lean and the sky shears; labels from the shuttered picture (off: a global shutter)"),
    f("camera_model.rolling_shutter.readout_s", "Readout time", " s", "Time from the first row's exposure to the last row's, drawn per frame (phones and small drone cameras: 10–35 ms)"),
    f("camera_model.rolling_shutter.yaw_rate_deg_s", "Pan rate", "°/s", "The camera's turn rate about its own vertical axis during the readout, drawn per frame (positive: to the right; 0: still)"),
    f("camera_model.lens", "Lens distortion", "", "The lens's geometric distortion, drawn per frame: the picture resampled once through it (scaled to show only rendered pixels), labels through the same mapping (off: a pinhole)"),
    f("camera_model.lens.k1", "k1", "", "Radial coefficient of r² (Brown–Conrady) or θ² (fisheye); Brown–Conrady k1 < 0 is barrel, > 0 pincushion"),
    f("camera_model.lens.k2", "k2", "", "Radial coefficient of r⁴ (Brown–Conrady) or θ⁴ (fisheye)"),
    f("camera_model.lens.k3", "k3", "", "Radial coefficient of r⁶ (Brown–Conrady) or θ⁶ (fisheye)"),
    f("camera_model.lens.k4", "k4", "", "Radial coefficient of θ⁸ (fisheye)"),
    f("camera_model.lens.p1", "p1", "", "Tangential (decentring) coefficient p1, Brown–Conrady, in [−0.1, 0.1]"),
    f("camera_model.lens.p2", "p2", "", "Tangential (decentring) coefficient p2, Brown–Conrady, in [−0.1, 0.1]"),
    // Thermal camera.
    f("thermal", "Thermal camera", "", "Grey long-wave infrared (8–14 µm) frames instead of visible ones: temperatures, the sky, the air, the camera's noise, blur and gain control"),
    f("thermal.air_k", "Air temperature", " K", "Air temperature near the camera, kelvin: the horizon's and the air's radiance"),
    f("thermal.ground_k", "Ground temperature", " K", "Ground and scenery temperature, kelvin"),
    f("thermal.cloud_k", "Cloud temperature", " K", "Cloud base temperature, kelvin (clouds: the visible sky's grey pixels)"),
    f("thermal.zenith_emissivity", "Zenith emissivity", "", "The clear sky's band emissivity at the zenith; towards the horizon 1 − (1 − ε_z)^(1/sin e)"),
    f("thermal.clear_saturation", "Clear-sky saturation", "", "Visible sky pixels at or above this HSV saturation are clear sky; greyer ones are cloud in proportion"),
    f("thermal.extinction_per_km", "Extinction", " /km", "Band extinction β of the air: an object at d km keeps exp(−β·d) of its radiance"),
    f("thermal.netd_mk", "NETD", " mK", "Noise-equivalent temperature difference: the temporal noise σ, millikelvin"),
    f("thermal.fixed_pattern_mk", "Fixed pattern", " mK", "Per-pixel and per-column offsets σ, millikelvin, the same in every frame of the preset"),
    f("thermal.shading_k", "Shading", " K", "Radial shading of optics and housing at the corners, kelvin (negative: darker corners)"),
    f("thermal.blur_px", "Optics blur σ", " px", "The optics' Gaussian blur σ in pixels (0: none)"),
    f("thermal.agc_percentiles", "AGC percentiles", " %", "The frame's percentiles the gain control spreads over levels 0–255"),
    f("thermal.agc_max_gain", "AGC max gain", " levels/K", "The gain control's largest gain: a low-contrast scene stays low in contrast"),
    f("thermal.bits", "Bits", "", "Bits per pixel of the written frames: 8, or 16 (grey PNG; the gain control's levels × 257)"),
    f("thermal.agc_mid_level", "AGC mid level", "", "The level the middle of the percentiles' span maps to"),
    f("thermal.capture", "Capture chain", "", "The recording's chain after the camera on the 8-bit frame: an earlier 8×8 DCT compression, then border lines (absent: none)"),
    f("thermal.capture.prior_dc_step", "Prior compression DC step", "", "The earlier compression's quantiser step for each 8×8 block's DC (JPEG units: 8 keeps the block means in whole levels); 0: no earlier compression"),
    f("thermal.capture.prior_ac_step", "Prior compression AC step", "", "The earlier compression's step for the other 63 coefficients (JPEG units); 0: kept"),
    f("thermal.capture.top_rows", "Border rows at the top", " levels", "Level offsets of the rows from the top edge, row 0 first (blanking lines)"),
    f("thermal.capture.bottom_rows", "Border rows at the bottom", " levels", "Level offsets of the rows from the bottom edge, the last row first"),
    f("thermal.capture.left_columns", "Border columns at the left", " levels", "Level offsets of the columns from the left edge, column 0 first"),
    f("thermal.capture.right_columns", "Border columns at the right", " levels", "Level offsets of the columns from the right edge, the last first"),
    f("thermal.narcissus", "Narcissus", "", "The optics' narcissus: a dark spot at the frame's centre, the same in every frame (absent: none)"),
    f("thermal.narcissus.depth_k", "Narcissus depth", " K", "How much colder the frame's centre reads (negative: warmer)"),
    f("thermal.narcissus.radius", "Narcissus radius", "", "The spot's Gaussian σ as a share of half the frame's height"),
    f("thermal.detail", "Detail enhancement", "", "The camera's detail enhancement: each pixel's difference from its neighbourhood's mean raised, dark halos beside warm edges (absent: none)"),
    f("thermal.detail.gain", "Detail gain", "", "How much the difference from the neighbourhood is raised (0: not)"),
    f("thermal.detail.size", "Detail reach", "", "The neighbourhood's tent half-width as a share of the frame's height"),
    f("thermal.texture", "Background texture", "", "The scene's temperature texture: fractal noise over the background (cloud and air structure, scenery), tied to the sky (absent: none)"),
    f("thermal.texture.rms_k", "Texture RMS", " K", "The texture's RMS over a frame, kelvin"),
    f("thermal.texture.slope", "Texture slope", "", "Its power spectrum's exponent: 2 the same power in every octave, more in the large features, less in the fine"),
    f("thermal.texture.size", "Texture size", "", "The largest features' size, a share of the frame's height"),
    f("thermal.texture.sharpness", "Texture sharpness", "", "How abruptly it steps between warmer and colder patches: 0 a Gaussian field, 3 plateaus joined by fronts, as cloud and scenery"),
    f("thermal.texture.ground_only", "Texture on the ground only", "", "Only on the ground and the scenery, the sky left smooth (needs a modelled scene, no backplate)"),
    f("thermal.drone", "Drone signature", "", "The thermal look of the preset's drones: skin and warm spot"),
    f("thermal.drone.skin_k", "Drone skin", " K", "Skin temperature above the air's, kelvin"),
    f("thermal.drone.emissivity", "Drone emissivity", "", "Skin emissivity (0–1); the rest reflects what lies behind"),
    f("thermal.drone.spot_k", "Drone warm spot", " K", "Warm spot's peak above the skin, kelvin (battery and motors, body core, engine, burner)"),
    f("thermal.drone.spot_share", "Drone spot size", "", "Warm spot's Gaussian σ as a share of the half box size"),
    f("thermal.drone.cold_share", "Drone cold share", "", "Share seen colder than the air: skin that far below it, no warm spot (darker than a warm background)"),
    f("thermal.drone.motor_k", "Drone motors", " K", "Motors' peak above the skin, kelvin: set (or the battery's), the warm spot becomes a spot at each rotor hub and one at the body's centre, sized by the parts and their distance"),
    f("thermal.drone.battery_k", "Drone battery", " K", "Battery's peak above the skin, kelvin, a spot at the body's centre (see the motors)"),
    f("thermal.drone.rotor_k", "Drone rotors", " K", "Spinning rotors' temperature above the air's, kelvin: the rotor discs' pixels take it instead of the skin's (absent: the skin's)"),
    f("thermal.bird", "Bird signature", "", "The thermal look of bird confusers: skin and warm spot"),
    f("thermal.bird.skin_k", "Bird skin", " K", "Skin temperature above the air's, kelvin"),
    f("thermal.bird.emissivity", "Bird emissivity", "", "Skin emissivity (0–1); the rest reflects what lies behind"),
    f("thermal.bird.spot_k", "Bird warm spot", " K", "Warm spot's peak above the skin, kelvin (battery and motors, body core, engine, burner)"),
    f("thermal.bird.spot_share", "Bird spot size", "", "Warm spot's Gaussian σ as a share of the half box size"),
    f("thermal.bird.cold_share", "Bird cold share", "", "Share seen colder than the air: skin that far below it, no warm spot (darker than a warm background)"),
    f("thermal.aircraft", "Aircraft signature", "", "The thermal look of aircraft and helicopter confusers: skin and warm spot"),
    f("thermal.aircraft.skin_k", "Aircraft skin", " K", "Skin temperature above the air's, kelvin"),
    f("thermal.aircraft.emissivity", "Aircraft emissivity", "", "Skin emissivity (0–1); the rest reflects what lies behind"),
    f("thermal.aircraft.spot_k", "Aircraft warm spot", " K", "Warm spot's peak above the skin, kelvin (battery and motors, body core, engine, burner)"),
    f("thermal.aircraft.spot_share", "Aircraft spot size", "", "Warm spot's Gaussian σ as a share of the half box size"),
    f("thermal.aircraft.cold_share", "Aircraft cold share", "", "Share seen colder than the air: skin that far below it, no warm spot (darker than a warm background)"),
    f("thermal.aircraft.motor_k", "Aircraft motors", " K", "Motors' peak above the skin, kelvin: set (or the battery's), the warm spot becomes a spot at each rotor hub and one at the body's centre, sized by the parts and their distance"),
    f("thermal.aircraft.battery_k", "Aircraft battery", " K", "Battery's peak above the skin, kelvin, a spot at the body's centre (see the motors)"),
    f("thermal.aircraft.rotor_k", "Aircraft rotors", " K", "Spinning rotors' temperature above the air's, kelvin: the rotor discs' pixels take it instead of the skin's (absent: the skin's)"),
    f("thermal.balloon", "Balloon signature", "", "The thermal look of balloon confusers: skin and warm spot"),
    f("thermal.balloon.skin_k", "Balloon skin", " K", "Skin temperature above the air's, kelvin"),
    f("thermal.balloon.emissivity", "Balloon emissivity", "", "Skin emissivity (0–1); the rest reflects what lies behind"),
    f("thermal.balloon.spot_k", "Balloon warm spot", " K", "Warm spot's peak above the skin, kelvin (battery and motors, body core, engine, burner)"),
    f("thermal.balloon.spot_share", "Balloon spot size", "", "Warm spot's Gaussian σ as a share of the half box size"),
    f("thermal.balloon.cold_share", "Balloon cold share", "", "Share seen colder than the air: skin that far below it, no warm spot (darker than a warm background)"),
    // Atmosphere.
    f("atmosphere", "Atmosphere", "", "Haze with range on drones, ground and horizon (Koschmieder: contrast × exp(−3.912·d/V))"),
    f("atmosphere.visibility_m", "Visibility", " m", "Meteorological visibility V in metres, drawn per frame: 2 % of a drone's contrast remains at distance V"),
    // Drone appearance.
    f("appearance", "Drone appearance", "", "Draw each drone's material from a palette (off: the models' own glTF materials)"),
    f("appearance.palette", "Palette weights", "", "A drone takes colour k with probability weight_k / Σ weights"),
    f("appearance.roughness", "Roughness", "", "glTF roughness drawn per drone, 0 (mirror) to 1 (matte)"),
    f("appearance.metalness", "Metalness", "", "glTF metalness drawn per drone, 0 to 1"),
    f("appearance.emissive_share", "Lights share", "", "Share of drones that carry lights, 0 to 1 (0: none)"),
    f("appearance.emissive_strength", "Light strength", "×", "Emission of a drone with lights, as a multiple of its colour (linear), drawn per drone"),
    f("appearance.rotor_opacity", "Rotor opacity", "", "Opacity of the spinning rotor discs (the models' glTF BLEND materials), drawn per drone: 1 solid, 0.3 a faint blur the sky shows through (MSAA 4 draws it in quarters)"),
    // Clutter.
    f("clutter", "Clutter", "", "Scenery between the camera and the swarm that hides the drones behind it; labels follow the picture"),
    f("clutter.per_frame", "New scenery every frame", "", "Off: one scenery from the preset seed around every frame's camera"),
    f("clutter.eye_height_m", "Eye height", " m", "Height of the camera above the ground the scenery stands on"),
    f("clutter.tree_lines", "Tree lines", "", "Tree lines along the horizon"),
    f("clutter.tree_lines.count", "Tree lines count", "", "How many tree lines per frame, drawn uniformly in (min, max)"),
    f("clutter.tree_lines.distance_m", "Tree lines distance", " m", "Distance from the camera, metres"),
    f("clutter.tree_lines.height_m", "Tree lines height", " m", "Height above the ground, metres"),
    f("clutter.tree_lines.width_deg", "Tree lines angular width", "°", "Angular width of each band"),
    f("clutter.trees", "Bare trees", "", "Bare trees with fine branches against the sky"),
    f("clutter.trees.count", "Bare trees count", "", "How many bare trees per frame, drawn uniformly in (min, max)"),
    f("clutter.trees.distance_m", "Bare trees distance", " m", "Distance from the camera, metres"),
    f("clutter.trees.height_m", "Bare trees height", " m", "Height above the ground, metres"),
    f("clutter.trees.branch_levels", "Branch levels", "", "Levels of branching above the trunk (each splits into 2–3 thinner branches)"),
    f("clutter.poles", "Poles", "", "Lines of poles with wires"),
    f("clutter.poles.count", "Poles count", "", "How many lines of poles per frame, drawn uniformly in (min, max)"),
    f("clutter.poles.distance_m", "Poles distance", " m", "Distance from the camera, metres"),
    f("clutter.poles.height_m", "Poles height", " m", "Height above the ground, metres"),
    f("clutter.poles.spacing_m", "Poles spacing", " m", "Distance between neighbouring poles"),
    f("clutter.poles.wires", "Wires", "", "Wires per span between two poles"),
    f("clutter.buildings", "Buildings", "", "Buildings and rooftops"),
    f("clutter.buildings.count", "Buildings count", "", "How many buildings per frame, drawn uniformly in (min, max)"),
    f("clutter.buildings.distance_m", "Buildings distance", " m", "Distance from the camera, metres"),
    f("clutter.buildings.height_m", "Buildings height", " m", "Height above the ground, metres"),
    f("clutter.buildings.width_m", "Buildings width", " m", "Width of the front wall"),
    // Weather.
    f("weather", "Weather", "", "Rain streaks or snow flakes in front of the camera; labels keep only the drone pixels that still show"),
    f("weather.kind", "Kind", "", "Rain: translucent streaks that veil drones; Snow: opaque flakes that hide them"),
    f("weather.intensity_per_m3", "Particles per m³", " /m³", "How many drops or flakes per cubic metre of the volume, drawn per frame"),
    f("weather.wind_mps", "Wind speed", " m/s", "Horizontal drift of every particle, drawn per frame"),
    f("weather.wind_dir_deg", "Wind direction", "°", "Direction the wind blows towards, degrees about the vertical from world +X"),
    f("weather.fall_mps", "Fall speed", " m/s", "How fast particles fall (rain 4–9, snow 0.5–1.5), drawn per frame"),
    f("weather.exposure_s", "Exposure time", " s", "A particle's streak is its travel during the exposure"),
    f("weather.diameter_mm", "Particle diameter", " mm", "Drop or flake diameter, drawn per particle"),
    f("weather.opacity", "Opacity", "", "Peak opacity of a streak or flake, 0 to 1 (snow: 1 hides what is behind)"),
    f("weather.depth_m", "Depth range", " m", "Nearest and farthest particle distance along the view axis"),
    // Confusers.
    f("confusers", "Confusers", "", "Birds, aircraft and balloons in the frames: labelled as a class or hard negatives"),
    f("confusers[]", "Confuser {n}", "", "A kind of confuser with its own count and distance"),
    f("confusers[].count", "Confuser {n} count", "", "How many per frame (per sequence), inclusive"),
    f("confusers[].distance_m", "Confuser {n} distance", " m", "Distance from the camera in metres, drawn per object (per flock)"),
    f("confusers[].size_m", "Confuser {n} size", " m", "Largest span in metres (birds: wingspan), drawn per object; off: the kind's typical"),
    f("confusers[].speed_m_s", "Confuser {n} speed", " m/s", "Speed along the heading in m/s, drawn per object (per flock); off: the kind's typical"),
    f("confusers[].labelled_as", "Confuser {n} labelled as", "", "Labelled: its own class in YOLO, COCO and MOT. Unlabelled: a hard negative, in the manifest only (cyan boxes in the preview)"),
    f("confusers[].glide_share", "Confuser {n} gliding share", "", "Share of the birds holding their wings still (0: all flap)"),
    f("confusers[].flap_hz", "Confuser {n} wing beats", " Hz", "Wing beats per second, drawn per bird; off: the species' typical"),
    f("confusers[].flock", "Confuser {n} flock", "", "The entry's birds fly together: one heading and speed, in a formation"),
    f("confusers[].flock.spacing_wingspans", "Confuser {n} flock spacing", " spans", "Distance between neighbours in wingspans (Cloud: the ball's radius per ∛n)"),
    f("confusers[].flock.jitter_wingspans", "Confuser {n} flock jitter", " spans", "Each bird displaced by up to ± this many wingspans per axis"),
    // Backplates.
    f("backplate", "Backplates", "", "Your own still frames of empty sky and horizon as the backgrounds, one drawn per frame; the camera takes their field of view and horizon"),
    f("backplate.folder", "Folder", "", "Folder of .jpg/.jpeg/.png plates of sky and horizon (a plate's NAME.plate.ron may set its own hfov_deg and horizon)"),
    f("backplate.hfov_deg", "Horizontal field of view", "°", "Of the camera that took the plates, degrees (the frames are rendered with it)"),
    f("backplate.horizon", "Horizon", "", "Where the horizon line is in the plates: a row (fraction of the height from the top; the camera's pitch follows) or unknown"),
    f("backplate.elevation_deg", "Elevation", "°", "The line of sight's elevation in the plates, degrees above the horizon, drawn per frame"),
    f("backplate.sun_elevation_deg", "Sun elevation", "°", "The sun that lights the drones: degrees above the horizon, drawn per frame"),
    f("backplate.sun_azimuth_deg", "Sun azimuth", "°", "Relative to the line of sight (0: ahead, the drones backlit; 180: behind the camera), drawn per frame"),
    f("backplate.flip", "Mirror half of the frames", "", "Flip the plate left-right in a random half of the frames"),
    // Output.
    f("render.resolution", "Resolution", "", "Image size of every frame"),
    f("render.resolution.width", "Width", " px", "Image width in pixels"),
    f("render.resolution.height", "Height", " px", "Image height in pixels"),
    f("render.msaa", "MSAA", "", "Multisample anti-aliasing: 1 (off) or 4 samples per pixel"),
    f("render.lod_error_px", "LOD error", " px", "Largest screen error of a model's simplified levels of detail"),
    f("render.impostor_below_px", "Impostors below", " px", "Drones smaller than this are drawn as baked silhouette sprites"),
    f("output.image_format", "Images", "", "Image file format"),
    f("output.image_format.quality", "JPEG quality", "", "JPEG quality, 1–100"),
    f("output.label_formats", "Labels", "", "Annotation formats written next to the images"),
    f("output.split", "Split", "", "Share of frames in each split; the three must sum to 1"),
    f("output.split.by", "Split by", "", "What each split keeps whole"),
    f("output.masks", "Masks", "", "Masks and maps besides the boxes"),
    f("output.masks.coco_rle", "COCO masks", "", "COCO segmentation as RLE of each labelled object's visible pixels"),
    f("output.masks.yolo_seg", "YOLO segmentation", "", "YOLO segmentation labels"),
    f("output.masks.instance_png", "Instance map", "", "An instance-id PNG per frame"),
    f("output.masks.flow", "Optical flow", "", "Sequences: a KITTI 16-bit flow PNG per frame (flow/{split}/NAME.png), exact from geometry, to the next frame"),
    f("output.masks.depth_unit_mm", "Depth unit", " mm", "Depth map step: one grey level is this many millimetres"),
    f("labels.box_method", "Boxes", "", "How each drone's 2D box is computed"),
    f("labels.min_box_px", "Min box", "", "Boxes narrower or shorter than this many pixels are dropped"),
    f("labels.min_visible_pixels", "Min visible px", "", "Drones with fewer visible pixels are filtered (0: off)"),
    f("labels.min_visible_fraction", "Min visible fraction", "", "Drones less visible than this (visible / unoccluded pixels) are filtered (0: off)"),
    f("labels.min_labelled", "Min labelled", "", "Frames with fewer labelled drones are made again with another draw"),
    f("labels.filtered", "Filtered drones", "", "Drop them, or keep them in COCO as iscrowd ignore regions"),
    f("labels.id_scale", "Id pass scale", "", "Resolution factor of the instance-id pass: 2 or 4 give sub-pixel visible boxes (cost × scale²)"),
];

/// The section of a path's top-level field (const: the table is built at compile time).
const fn section_of_head(path: &str) -> Option<&'static str> {
    let bytes = path.as_bytes();
    let mut end = 0;
    while end < bytes.len() && bytes[end] != b'.' && bytes[end] != b'[' {
        end += 1;
    }
    let mut i = 0;
    while i < SECTION_OF_HEAD.len() {
        let (head, section) = SECTION_OF_HEAD[i];
        let h = head.as_bytes();
        if h.len() == end {
            let mut j = 0;
            while j < end && h[j] == bytes[j] {
                j += 1;
            }
            if j == end {
                return Some(section);
            }
        }
        i += 1;
    }
    None
}

/// The table's entry for exactly this path (`models[]` for any item), if any.
pub fn field(path: &str) -> Option<&'static Field> {
    FIELDS.iter().find(|f| f.path == path)
}

/// The field of a table path, for the panels: its words, or the path itself if
/// the table lacks it (a unit test keeps the panels' paths in the table).
pub fn get(path: &'static str) -> Field {
    field(path).copied().unwrap_or(Field {
        path,
        label: path,
        tooltip: "",
        unit: "",
        section: section_of_head(path),
    })
}

/// `models[2].size_m` → (`models[].size_m`, Some(2)); the first index only.
fn generic(path: &str) -> (String, Option<usize>) {
    let Some(open) = path.find('[') else {
        return (path.to_string(), None);
    };
    let Some(close) = path[open..].find(']').map(|c| open + c) else {
        return (path.to_string(), None);
    };
    let index = path[open + 1..close].parse().ok();
    (format!("{}[]{}", &path[..open], &path[close + 1..]), index)
}

/// The label a user sees for `path` (`camera.z.step` → "CameraZ step",
/// `models[1].size_m` → "Model 2 size"); the path itself when nothing matches.
pub fn label_of(path: &str) -> String {
    let (generic_path, index) = generic(path);
    let number = index.map_or_else(|| "?".to_string(), |i| (i + 1).to_string());
    let mut head = generic_path.as_str();
    let mut tail: Vec<&str> = Vec::new();
    loop {
        if let Some(f) = field(head) {
            let mut label = f.label.replace("{n}", &number);
            for part in tail.iter().rev() {
                label.push(' ');
                label.push_str(part);
            }
            return label;
        }
        match head.rsplit_once('.') {
            Some((parent, last)) => {
                tail.push(last);
                head = parent;
            }
            None => return path.to_string(),
        }
    }
}

/// The section that shows `path` (`None`: the general fields above the sections).
pub fn section_of(path: &str) -> Option<&'static str> {
    section_of_head(path)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn labels_resolve_items_sweep_parts_and_axes() {
        assert_eq!(label_of("camera.z.step"), "CameraZ step");
        assert_eq!(label_of("camera.z"), "CameraZ");
        assert_eq!(label_of("output.split.train"), "Split train");
        assert_eq!(label_of("models[1].size_m"), "Model 2 size");
        assert_eq!(label_of("confusers[0].count"), "Confuser 1 count");
        assert_eq!(label_of("placement.volume.size_m.y"), "Volume size y");
        assert_eq!(label_of("something.new"), "something.new");
        assert_eq!(label_of("atmosphere.visibility_m"), "Visibility");
        assert_eq!(label_of("camera_model.psf.sigma_px"), "Blur σ");
        assert_eq!(label_of("camera.observer.distance_m"), "Observer distance");
        assert_eq!(label_of("backplate.hfov_deg"), "Horizontal field of view");
        assert_eq!(label_of("clutter.poles.height_m"), "Poles height");
        assert_eq!(label_of("confusers[1].flap_hz"), "Confuser 2 wing beats");
        assert_eq!(label_of("camera_model.saturation"), "Saturation");
        assert_eq!(label_of("appearance.rotor_opacity"), "Rotor opacity");
        assert_eq!(get("confusers[].speed_m_s").unit, " m/s");
    }

    #[test]
    fn sections_follow_the_path_head() {
        assert_eq!(section_of("plane.ry.step"), Some("Scene rotation"));
        assert_eq!(section_of("models[0].class"), Some("Models"));
        assert_eq!(section_of("labels.id_scale"), Some("Output"));
        assert_eq!(section_of("sequence.steps"), Some("Placement"));
        assert_eq!(section_of("confusers[2].count"), Some("Confusers"));
        assert_eq!(section_of("seed"), None);
        assert_eq!(
            section_of("cameras"),
            None,
            "a head matches whole, not as a prefix"
        );
        assert_eq!(get("camera.fov_y_deg").section, Some("Camera"));
    }

    #[test]
    fn every_entry_is_unique_labelled_and_in_a_known_section() {
        let mut paths: Vec<&str> = FIELDS.iter().map(|f| f.path).collect();
        paths.sort_unstable();
        let before = paths.len();
        paths.dedup();
        assert_eq!(paths.len(), before, "a path is in the table twice");
        for f in FIELDS {
            assert!(!f.label.is_empty() && !f.tooltip.is_empty(), "{}", f.path);
            if let Some(section) = f.section {
                assert!(SECTIONS.contains(&section), "{}: {section}", f.path);
            } else {
                assert!(["name", "seed", "repeats"].contains(&f.path), "{}", f.path);
            }
        }
    }

    #[test]
    fn angles_carry_degrees() {
        for f in FIELDS {
            if f.path.ends_with("_deg") {
                assert_eq!(f.unit, "°", "{}", f.path);
            }
        }
    }
}
