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
    raise_open_file_limit();
    // A panic the glTF loader catches becomes its typed error; nothing else is printed for it.
    let default_hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        if !swarmshot::model::in_guarded_load() {
            default_hook(info);
        }
    }));
}

/// The soft open-file limit `start` raises to, when the hard limit allows:
/// a batch keeps about 30 files open at once on 2 cores (the ledger, the
/// lock, the manifest, six COCO parts, lavapipe's, and each encoder's image
/// and label files), a merge about 40 for 3 shards.
const WANTED_OPEN_FILES: u64 = 4096;

/// The fewest open files a batch or a merge is started with: under it the
/// run would fail midway with EMFILE (a batch under `ulimit -n 24` did after
/// its output folder and ledger were made, a merge of 3 shards under 32 after
/// its folder), so it is refused before anything is written.
pub(crate) const MIN_OPEN_FILES: u64 = 64;

/// Raise the soft open-file limit (`ulimit -Sn`, 1024 by default, lower on
/// some cluster nodes) towards the hard one, as a process may without
/// privilege: what the job's limits allow is used instead of failing on a
/// soft default. Nothing is said if it cannot: [`check_open_files`] names
/// the limit when it is too low to run.
fn raise_open_file_limit() {
    use rustix::process::{Resource, Rlimit, getrlimit, setrlimit};
    let limit = getrlimit(Resource::Nofile);
    let Some(current) = limit.current else {
        return;
    };
    // `None` is unlimited; Linux still caps it (fs.nr_open), so ask for a number.
    let wanted = limit
        .maximum
        .map_or(WANTED_OPEN_FILES, |m| m.min(WANTED_OPEN_FILES));
    if current < wanted {
        let raised = Rlimit {
            current: Some(wanted),
            maximum: limit.maximum,
        };
        // A refusal leaves the limit as it was; check_open_files judges it.
        let _ = setrlimit(Resource::Nofile, raised);
    }
}

/// Refuse, before anything is written, a `command` (`batch`, `merge`) whose
/// open-file limit (after [`raise_open_file_limit`]) is under [`MIN_OPEN_FILES`].
pub(crate) fn check_open_files(command: &str) -> anyhow::Result<()> {
    let limit = rustix::process::getrlimit(rustix::process::Resource::Nofile);
    match limit.current {
        Some(n) if n < MIN_OPEN_FILES => anyhow::bail!(
            "the open-file limit is {n} (`ulimit -n`, hard limit {}), but a {command} needs at least {MIN_OPEN_FILES} files open at once (its ledger, labels and images in flight); raise it with `ulimit -n {MIN_OPEN_FILES}` or ask for it in the job script",
            limit
                .maximum
                .map_or_else(|| "unlimited".to_string(), |m| m.to_string())
        ),
        _ => Ok(()),
    }
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
