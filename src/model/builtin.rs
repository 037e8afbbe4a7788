//! The built-in UAV models: one table of names and embedded GLB files
//! (`assets/models/NAME.glb`, made by `swarmshot assets` from the mesh builder
//! in `tools::assets`). They load through the same glTF path as user models.

/// A built-in model: its preset name and its embedded GLB.
pub struct Builtin {
    pub name: &'static str,
    pub glb: &'static [u8],
}

macro_rules! builtins {
    ($($name:literal),* $(,)?) => {
        /// Every built-in model, in the order they are offered.
        pub const BUILTINS: &[Builtin] = &[
            $(Builtin { name: $name, glb: include_bytes!(concat!("../../assets/models/", $name, ".glb")) },)*
        ];
        /// Names of the built-in models, in the order they are offered.
        pub const NAMES: &[&str] = &[$($name),*];
    };
}

builtins!(
    "quad_x",
    "quad_plus",
    "hexacopter",
    "octocopter",
    "fixed_wing",
    "flying_wing_vtol",
    "coaxial_heli",
    "heavy_lift",
);

/// The embedded GLB of a built-in model.
pub fn glb(name: &str) -> Option<&'static [u8]> {
    BUILTINS.iter().find(|b| b.name == name).map(|b| b.glb)
}
