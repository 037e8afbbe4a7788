//! The built-in confusers (issue 22): birds, aircraft and a balloon that a
//! preset's `confusers` place around the swarm, as one table of names and
//! embedded GLB files (`assets/models/NAME.glb`, made by `swarmshot assets`
//! from `tools::confusers`). They load through the same glTF path as drones.
//!
//! A bird has `FLAP_POSES` flap poses and a gliding pose (the preset's
//! confuser kinds name them: `preset::confusers::bird_model`). The loader
//! centres each model on its bounding box and scales it to a unit span; a
//! pose's [`PoseFrame`] says where that box sits and how large it is against
//! the gliding pose, so the scene keeps a bird's body still and its size
//! constant while its wings beat.

macro_rules! confusers {
    ($($name:literal),* $(,)?) => {
        /// Every built-in confuser model: (name, GLB).
        pub const MODELS: &[(&str, &[u8])] = &[
            $(($name, include_bytes!(concat!("../../assets/models/", $name, ".glb"))),)*
        ];
        /// Names of the built-in confuser models.
        pub const NAMES: &[&str] = &[$($name),*];
    };
}

confusers!(
    "bird_sparrow_0",
    "bird_sparrow_1",
    "bird_sparrow_2",
    "bird_sparrow_3",
    "bird_sparrow_4",
    "bird_sparrow_5",
    "bird_sparrow_6",
    "bird_sparrow_7",
    "bird_sparrow_glide",
    "bird_gull_0",
    "bird_gull_1",
    "bird_gull_2",
    "bird_gull_3",
    "bird_gull_4",
    "bird_gull_5",
    "bird_gull_6",
    "bird_gull_7",
    "bird_gull_glide",
    "bird_raptor_0",
    "bird_raptor_1",
    "bird_raptor_2",
    "bird_raptor_3",
    "bird_raptor_4",
    "bird_raptor_5",
    "bird_raptor_6",
    "bird_raptor_7",
    "bird_raptor_glide",
    "light_aircraft",
    "airliner",
    "helicopter",
    "balloon",
);

/// The embedded GLB of a built-in confuser.
pub fn glb(name: &str) -> Option<&'static [u8]> {
    MODELS.iter().find(|m| m.0 == name).map(|m| m.1)
}

/// Where a bird pose's bounding box sits, in units of the gliding pose's
/// largest span, relative to the body's centre (the generator's origin).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PoseFrame {
    /// Bounding-box centre.
    pub centre: [f64; 3],
    /// Largest span.
    pub span: f64,
}

/// The frame of a bird pose (`None` for a model that is not a bird pose).
pub fn pose_frame(name: &str) -> Option<PoseFrame> {
    POSE_FRAMES
        .iter()
        .find(|(n, _)| *n == name)
        .map(|&(_, (centre, span))| PoseFrame { centre, span })
}

/// Measured from the generator (`tools::confusers`'s test checks them).
#[rustfmt::skip]
const POSE_FRAMES: &[(&str, ([f64; 3], f64))] = &[
    ("bird_sparrow_0", ([0.000000, 0.165317, -0.038545], 0.813961)),
    ("bird_sparrow_1", ([0.000000, 0.139320, -0.038545], 0.813961)),
    ("bird_sparrow_2", ([0.000000, 0.012948, -0.038545], 0.984121)),
    ("bird_sparrow_3", ([0.000000, -0.082161, -0.038545], 0.840621)),
    ("bird_sparrow_4", ([0.000000, -0.139787, -0.038545], 0.813961)),
    ("bird_sparrow_5", ([0.000000, -0.113789, -0.038545], 0.813961)),
    ("bird_sparrow_6", ([0.000000, 0.000000, -0.038545], 0.984121)),
    ("bird_sparrow_7", ([0.000000, 0.107692, -0.038545], 0.840621)),
    ("bird_sparrow_glide", ([0.000000, 0.000000, -0.038545], 1.000000)),
    ("bird_gull_0", ([0.000000, 0.139566, -0.015038], 0.766823)),
    ("bird_gull_1", ([0.000000, 0.115123, -0.015038], 0.836279)),
    ("bird_gull_2", ([0.000000, 0.013370, -0.015038], 0.992802)),
    ("bird_gull_3", ([0.000000, -0.068978, -0.015038], 0.919656)),
    ("bird_gull_4", ([0.000000, -0.124528, -0.015038], 0.766823)),
    ("bird_gull_5", ([0.000000, -0.100085, -0.015038], 0.836279)),
    ("bird_gull_6", ([0.000000, 0.000000, -0.015038], 0.992802)),
    ("bird_gull_7", ([0.000000, 0.084017, -0.015038], 0.919656)),
    ("bird_gull_glide", ([0.000000, 0.004988, -0.015038], 1.000000)),
    ("bird_raptor_0", ([0.000000, 0.111288, -0.033429], 0.871571)),
    ("bird_raptor_1", ([0.000000, 0.088358, -0.033429], 0.919199)),
    ("bird_raptor_2", ([0.000000, 0.004641, -0.033429], 1.009608)),
    ("bird_raptor_3", ([0.000000, -0.049601, -0.033429], 0.961819)),
    ("bird_raptor_4", ([0.000000, -0.094573, -0.033429], 0.871571)),
    ("bird_raptor_5", ([0.000000, -0.071644, -0.033429], 0.919199)),
    ("bird_raptor_6", ([0.000000, 0.000000, -0.033429], 1.009608)),
    ("bird_raptor_7", ([0.000000, 0.066316, -0.033429], 0.961819)),
    ("bird_raptor_glide", ([0.000000, 0.028635, -0.033429], 1.000000)),
];
