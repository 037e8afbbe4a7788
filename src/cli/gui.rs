//! `swarmshot gui [PRESET]` (and `swarmshot` alone): the desktop app, or the
//! refusal of a headless build.

use std::path::PathBuf;

/// The desktop app, when this binary was built with it (the `app` feature, on by default).
#[cfg(feature = "app")]
pub(crate) fn run(preset: Option<PathBuf>) -> anyhow::Result<()> {
    // SAFETY: `main` calls this right after parsing, while the process has one thread.
    #[allow(unsafe_code)]
    unsafe {
        swarmshot::app::quiet_vulkan_on_plain_x11()
    };
    swarmshot::app::run_or_exit(preset);
    Ok(())
}

/// A headless build (`--no-default-features`) has no desktop app.
#[cfg(not(feature = "app"))]
pub(crate) fn run(_preset: Option<PathBuf>) -> anyhow::Result<()> {
    anyhow::bail!(
        "this swarmshot was built without the desktop app (cargo build --no-default-features, for cluster nodes); `swarmshot gui` needs a build with the default features. The batch, check, frame, merge and bench commands are all here: see swarmshot --help"
    )
}
