//! Every integration test in one test binary (`cargo test --test suite`):
//! one crate to compile and one executable to link instead of one per file,
//! which keeps the test build and its disk use small. Each file is a module
//! named after what it tests (`cargo test --test suite lens::` runs one);
//! `tests/slurm.rs` stays its own binary, as CI builds it alone without the
//! desktop app.

#[path = "../common/mod.rs"]
mod common;

#[cfg(feature = "app")]
#[path = "../common/app.rs"]
mod app_common;

mod app_audit;
mod architecture;
mod backplates;
mod batch;
mod bounded;
mod bounds_audit;
mod camera_model;
mod camera_motion;
mod camera_stiff;
mod cli;
mod clutter;
mod confusers;
mod determinism_audit;
mod docs_truth;
mod encode;
mod environments;
mod extreme;
mod fit;
mod fit_swarm;
mod fit_thermal;
mod fit_video;
mod flow;
mod footage_audit;
mod fuzz;
mod gap;
mod gap_overlay;
mod gltf_files;
mod gltf_spec;
mod gltf_uris;
mod gui;
mod gui_masks;
mod gui_round3;
mod gui_round4;
mod gui_tools;
mod gui_trial;
mod hostile;
mod impostors;
mod inputs;
mod io_audit;
mod lens;
mod limits_audit;
mod lod;
mod masks;
mod models;
mod mot;
mod motion;
mod output_trust;
mod plan;
mod plan_crash;
mod preset;
mod projection;
mod real_sets;
mod realism;
mod regions;
mod rolling_shutter;
mod rotors;
mod runs_audit;
mod safety;
mod scale;
mod shaders;
mod split;
mod surfaces;
mod thermal;
mod trial;
mod trust_four;
mod visibility;
mod visible_boxes;
mod weather;
