//! What the frame-making commands print and how they stop: the preset's
//! warnings, the progress bar, a finished run's counts, and the clean stop on
//! SIGINT/SIGTERM with the command that continues it.

use std::sync::atomic::AtomicBool;

use anyhow::Context;
use indicatif::{ProgressBar, ProgressStyle};
use swarmshot::pipeline::FramePipeline;
use swarmshot::preset::Preset;

/// Print the preset's warnings (overlapping drones and the like) to stderr.
pub(crate) fn print_warnings(pipeline: &FramePipeline) {
    for w in swarmshot::pipeline::check::warnings(pipeline.preset()) {
        eprintln!("warning: {}", swarmshot::text::for_terminal(&w.to_string()));
    }
}

/// The progress bar of a batch or plan of `total` frames.
pub(crate) fn frames_bar(total: u64) -> anyhow::Result<ProgressBar> {
    let bar = ProgressBar::new(total);
    bar.set_style(
        ProgressStyle::with_template("{bar:40.cyan/blue} {pos}/{len} frames  {msg}  ETA {eta}")
            .context("progress template")?,
    );
    Ok(bar)
}

/// "N frames (train / val / test), B boxes (small / medium / large)" of a finished run.
pub(crate) fn frames_and_boxes(s: &swarmshot::write::DatasetStats) -> String {
    format!(
        "{} frames ({} train / {} val / {} test), {} boxes (small {} / medium {} / large {})",
        s.frames,
        s.frames_per_split[0],
        s.frames_per_split[1],
        s.frames_per_split[2],
        s.boxes,
        s.small,
        s.medium,
        s.large,
    )
}

/// A flag set by the first SIGINT or SIGTERM: the batch stops between frames
/// (docs/reliability.md, "Clean stop"); a second signal ends the process at once.
pub(crate) fn stop_on_signals() -> anyhow::Result<std::sync::Arc<AtomicBool>> {
    use signal_hook::consts::{SIGINT, SIGTERM};
    let flag = std::sync::Arc::new(AtomicBool::new(false));
    for signal in [SIGINT, SIGTERM] {
        // Registered first, so it sees the flag as the earlier signal left it.
        signal_hook::flag::register_conditional_shutdown(signal, 1, flag.clone())
            .context("installing the signal handler")?;
        signal_hook::flag::register(signal, flag.clone())
            .context("installing the signal handler")?;
    }
    Ok(flag)
}

/// The refusal after a clean stop: what is complete and how to continue.
pub(crate) fn stopped(done: u64, total: u64, resume: &str) -> anyhow::Error {
    anyhow::anyhow!(
        "stopped by SIGINT/SIGTERM after {done} of {total} frames: every frame before it is complete and checkpointed, nothing half-written is left; continue with: {resume}"
    )
}

/// `path` as one shell word, for a command printed to be pasted: as it is
/// when it holds only characters no shell treats specially, else in single
/// quotes (a `'` in it written `'\''`).
pub(crate) fn shell_word(path: &std::path::Path) -> String {
    let text = path.to_string_lossy();
    let plain = |c: char| c.is_ascii_alphanumeric() || "_./@%+=:,-".contains(c);
    if !text.is_empty() && text.chars().all(plain) {
        return text.into_owned();
    }
    format!("'{}'", text.replace('\'', "'\\''"))
}

/// A warning for each split that gets no frame ([`swarmshot::pipeline::check::empty_splits`]).
pub(crate) fn print_empty_splits(preset: &Preset, frames: u64, out: &mut dyn std::io::Write) {
    for w in swarmshot::pipeline::check::empty_splits(preset, frames) {
        let _ = writeln!(out, "warning: {w}");
    }
}

#[cfg(test)]
mod tests {
    use super::shell_word;
    use std::path::Path;

    #[test]
    fn printed_paths_paste_as_one_word() {
        assert_eq!(shell_word(Path::new("out/ds-1")), "out/ds-1");
        assert_eq!(shell_word(Path::new("my data/ds")), "'my data/ds'");
        assert_eq!(shell_word(Path::new("it's")), "'it'\\''s'");
        assert_eq!(shell_word(Path::new("$HOME")), "'$HOME'");
        assert_eq!(shell_word(Path::new("")), "''");
    }
}
