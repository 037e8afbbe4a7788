//! Developer tools that drive the pipeline: the benchmarks behind docs/, the
//! gallery pictures, and the generator of the built-in models.

pub mod assets;
mod assets_aircraft;
pub mod bench;
pub mod confuser_gallery;
pub mod confusers;
pub mod gallery;
mod mesh;
