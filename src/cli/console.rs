//! What the frame-making commands print and how they stop: the preset's
//! warnings, the progress bar, a finished run's counts, and the clean stop on
//! SIGINT/SIGTERM (and SIGHUP, SIGUSR1, SIGXCPU) with the command that continues it.

use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

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
    use swarmshot::text::plural;
    format!(
        "{} ({} train / {} val / {} test), {} (small {} / medium {} / large {})",
        plural(s.frames, "frame", "frames"),
        s.frames_per_split[0],
        s.frames_per_split[1],
        s.frames_per_split[2],
        plural(s.boxes, "box", "boxes"),
        s.small,
        s.medium,
        s.large,
    )
}

/// The signals that stop a run cleanly. Beside Ctrl-C and `kill`: SIGHUP
/// (the terminal or SSH session closed), SIGUSR1 (Slurm's `--signal=USR1@T`
/// warning before the time limit) and SIGXCPU (the soft `ulimit -t` CPU
/// limit). Their default action ended the process mid-frame, with no line
/// saying what stopped it or how to continue.
const STOP_SIGNALS: [std::ffi::c_int; 5] = {
    use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM, SIGUSR1, SIGXCPU};
    [SIGINT, SIGTERM, SIGHUP, SIGUSR1, SIGXCPU]
};

/// The signal that last asked for a stop (0: none), for [`stopped`]'s message.
static STOP_SIGNAL: std::sync::LazyLock<std::sync::Arc<AtomicUsize>> =
    std::sync::LazyLock::new(|| std::sync::Arc::new(AtomicUsize::new(0)));

/// A flag set by the first of [`STOP_SIGNALS`]: the batch stops between
/// frames (docs/reliability.md, "Clean stop"); a second signal ends the
/// process at once.
pub(crate) fn stop_on_signals() -> anyhow::Result<std::sync::Arc<AtomicBool>> {
    let flag = std::sync::Arc::new(AtomicBool::new(false));
    for signal in STOP_SIGNALS {
        // Registered first, so it sees the flag as the earlier signal left it.
        signal_hook::flag::register_conditional_shutdown(signal, 1, flag.clone())
            .context("installing the signal handler")?;
        signal_hook::flag::register_usize(signal, STOP_SIGNAL.clone(), signal as usize)
            .context("installing the signal handler")?;
        signal_hook::flag::register(signal, flag.clone())
            .context("installing the signal handler")?;
    }
    Ok(flag)
}

/// The refusal after a clean stop: what stopped it, what is complete and how to continue.
pub(crate) fn stopped(done: u64, total: u64, resume: &str) -> anyhow::Error {
    anyhow::anyhow!(
        "stopped by {} after {done} of {}: every frame before it is complete and checkpointed, nothing half-written is left; continue with: {resume}",
        stop_signal_name(),
        swarmshot::text::plural(total, "frame", "frames")
    )
}

/// The name of the signal that stopped the run; Ctrl-C and `kill` keep
/// the one name they always had.
fn stop_signal_name() -> &'static str {
    use signal_hook::consts::{SIGHUP, SIGUSR1, SIGXCPU};
    match STOP_SIGNAL.load(Ordering::SeqCst) as std::ffi::c_int {
        SIGHUP => "SIGHUP",
        SIGUSR1 => "SIGUSR1",
        SIGXCPU => "SIGXCPU (the CPU-time limit, `ulimit -t`)",
        _ => "SIGINT/SIGTERM",
    }
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
