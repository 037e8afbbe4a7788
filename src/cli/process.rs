//! The process around a command: what `main` sets before any thread exists
//! (SIGPIPE, lavapipe's thread count, the panic hook, the headless Vulkan
//! loader's quiet), and how an error ends it (one line on stderr, exit code 1).

use std::process::ExitCode;

/// Set up the process: called first thing in `main`, before any thread exists.
pub(crate) fn start() {
    // Rust ignores SIGPIPE, so printing to a closed pipe (`swarmshot check P | head -1`)
    // panicked; a command-line tool ends quietly there instead, as `ls | head` does.
    #[cfg(unix)]
    // SAFETY: the first thing main does, before any thread exists; SIG_DFL is a valid handler.
    #[allow(unsafe_code)]
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    more_lavapipe_threads();
    // A panic the glTF loader catches becomes its typed error; nothing else is printed for it.
    let default_hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        if !swarmshot::model::in_guarded_load() {
            default_hook(info);
        }
    }));
}

/// Quiet the headless Vulkan loader's start-up messages: called by `main`
/// right after parsing, for every command but the desktop app, while the
/// process still has one thread.
pub(crate) fn quiet_headless_vulkan() {
    // SAFETY: still one thread: nothing has been spawned before this point
    // (`main` calls it after `start` and parsing, before any command runs).
    #[allow(unsafe_code)]
    unsafe {
        swarmshot::render::quiet_headless_vulkan()
    };
}

/// The exit code of a command's result; an error is printed on one line first.
pub(crate) fn exit_code(result: anyhow::Result<()>) -> ExitCode {
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            // `{:#}`: the message and its causes on one line, never a backtrace
            // (RUST_BACKTRACE is for bugs, not for a user's typo).
            eprintln!(
                "error: {}",
                swarmshot::text::for_terminal(&swarmshot::text::one_line(&e))
            );
            ExitCode::FAILURE
        }
    }
}

/// lavapipe, the software Vulkan driver, rasterises on `LP_NUM_THREADS`
/// threads, one per core unless set. The batch's makers and encoders share
/// those cores, and a rasteriser thread they preempt holds up the whole pass
/// while the other core waits for it; two threads more than the cores keep
/// both cores busy (docs/benchmarks.md: −2.5 to −5 % wall time on
/// synthswarm_table2, realistic and peer_moving). A value the user set is
/// kept; a hardware GPU never reads it.
fn more_lavapipe_threads() {
    if std::env::var_os("LP_NUM_THREADS").is_some() {
        return;
    }
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    // SAFETY: called first thing in main, before any thread exists, so
    // nothing reads the environment meanwhile.
    #[allow(unsafe_code)]
    unsafe {
        std::env::set_var("LP_NUM_THREADS", (cores + 2).to_string());
    }
}
