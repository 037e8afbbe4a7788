//! Why a domain-gap report could not be made: every error names its file.

use std::path::PathBuf;

/// Why `swarmshot gap` stopped.
#[derive(Debug, thiserror::Error)]
pub enum GapError {
    #[error(
        "--out {}: is {} --{side} {}: gap would write its report among the frames it measures (and count its histograms as frames next time); choose a folder outside --real and --synthetic",
        out.display(),
        if *same { "the same folder as" } else { "inside" },
        input.display()
    )]
    OutInsideInput {
        out: PathBuf,
        side: &'static str,
        input: PathBuf,
        same: bool,
    },
    #[error(
        "--real {} is {relation} --synthetic {}: the report would measure the dataset's own frames as the footage it is compared with; give a folder of real frames outside the dataset",
        real.display(),
        synthetic.display()
    )]
    SidesOverlap {
        real: PathBuf,
        synthetic: PathBuf,
        relation: &'static str,
    },
    #[error("{}: {reason}", path.display())]
    Input { path: PathBuf, reason: String },
    #[error("{}: line {line}: {reason}", path.display())]
    Label {
        path: PathBuf,
        line: usize,
        reason: String,
    },
    #[error("{}: {source}", path.display())]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
}
