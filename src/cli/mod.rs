//! The CLI's commands that are more than a call into the library: `check`
//! (`check.rs`), and the reports and developer tools (`tools.rs`: stats,
//! gap, merge, bench, gallery, assets). `main.rs` parses the command line
//! and runs the batch, plan and frame commands.

pub(crate) mod check;
pub(crate) mod tools;
