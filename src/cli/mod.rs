//! The command line, all of it but `main`: the flags as clap parses them
//! (`args.rs`), the process around a command (`process.rs`), one file per
//! command or family — `batch.rs`, `plan.rs` (`batch --labels-only`),
//! `frame.rs`, `check.rs`, `fit.rs`, `gui.rs`, `reports.rs` (stats, gap,
//! merge), `tools.rs` (bench, gallery, assets) — and what the commands that
//! make frames share: the GPU start and the adapter check (`gpu.rs`), and what
//! they print and how they stop (`console.rs`). `main.rs` parses and
//! dispatches; every command that makes frames goes through
//! [`swarmshot::pipeline::FramePipeline`].

pub(crate) mod args;
pub(crate) mod batch;
pub(crate) mod check;
pub(crate) mod console;
pub(crate) mod fit;
pub(crate) mod frame;
pub(crate) mod gpu;
pub(crate) mod gui;
pub(crate) mod plan;
pub(crate) mod process;
pub(crate) mod reports;
pub(crate) mod tools;
