//! Fault injection for the crash and concurrency tests (tests/suite/safety.rs,
//! tests/suite/output_trust.rs, tests/suite/trust_four.rs), internal to the dataset
//! folder: no public item, compiled in only with the `test-hooks` feature
//! that `cargo test` turns on. It is driven by environment variables because
//! the tests stop and kill a separate `swarmshot` process.

#[cfg(feature = "test-hooks")]
use std::path::PathBuf;

/// Fault injection for tests/suite/safety.rs: with `SWARMSHOT_STALL_AT` set to a
/// path relative to the dataset folder, the batch sleeps after that file's
/// temporary copy is written and before it is renamed into place; set to
/// `checkpoint:N`, after frame N's files and records are written and before
/// its checkpoint; set to `overwrite:deleting`, after the first file
/// `--overwrite` deletes; set to `frame:writing`, after `swarmshot frame` has
/// made its frame and before it writes a file; set to `frame:staged`, after `swarmshot frame` has
/// written every file's temporary copy and before it renames the first. A
/// test kills the process there. With
/// `SWARMSHOT_STALL_UNTIL` set to a path as well, it waits only until that
/// path exists (a barrier: tests/suite/output_trust.rs runs a second batch
/// meanwhile), and says it has stopped by creating that path with
/// `.stalled` added. Only with the `test-hooks` feature, which `cargo test` turns on
/// (Cargo.toml); shipped builds have no such hook.
#[cfg(feature = "test-hooks")]
pub(crate) fn stall_if_asked(point: &str) {
    static AT: std::sync::OnceLock<Option<String>> = std::sync::OnceLock::new();
    let at = AT.get_or_init(|| std::env::var("SWARMSHOT_STALL_AT").ok());
    if at.as_deref() == Some(point) {
        let until = std::env::var_os("SWARMSHOT_STALL_UNTIL").map(PathBuf::from);
        if let Some(until) = &until {
            let mut stalled = until.clone().into_os_string();
            stalled.push(".stalled");
            let _ = std::fs::write(stalled, point);
        }
        let start = std::time::Instant::now();
        while start.elapsed() < std::time::Duration::from_secs(300) {
            if until.as_ref().is_some_and(|p| p.exists()) {
                return;
            }
            std::thread::sleep(std::time::Duration::from_millis(20));
        }
    }
}

/// Without `test-hooks` (every shipped build) there is no fault injection.
#[cfg(not(feature = "test-hooks"))]
pub(crate) fn stall_if_asked(_point: &str) {}
