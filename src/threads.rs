//! Work on a second thread where the system grants one. A cluster job's
//! task limit (`ulimit -u`, a cgroup's `pids.max`) can refuse a thread, and
//! `Scope::spawn` then panics; work that only overlaps with the caller's
//! loses the overlap instead: it runs on the caller when it is joined.

use std::thread::{Scope, ScopedJoinHandle};

/// A task started by [`spawn_or_defer`]: on its own thread, or waiting to
/// run on the caller's.
pub enum Task<'scope, T, F> {
    Thread(ScopedJoinHandle<'scope, T>),
    Deferred(F),
}

/// `f` on a thread of `scope`, or, when the system refuses one, kept to run
/// when the task is joined.
pub fn spawn_or_defer<'scope, T, F>(scope: &'scope Scope<'scope, '_>, f: F) -> Task<'scope, T, F>
where
    T: Send + 'scope,
    F: FnOnce() -> T + Send + Clone + 'scope,
{
    match std::thread::Builder::new().spawn_scoped(scope, f.clone()) {
        Ok(handle) => Task::Thread(handle),
        Err(_) => Task::Deferred(f),
    }
}

impl<T, F: FnOnce() -> T> Task<'_, T, F> {
    /// The task's result: its thread's (`Err` holding a panic there), or
    /// the deferred task run now.
    pub fn join(self) -> std::thread::Result<T> {
        match self {
            Task::Thread(handle) => handle.join(),
            Task::Deferred(f) => Ok(f()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_task_gives_its_result_on_a_thread_or_deferred() {
        std::thread::scope(|s| {
            let on_thread = spawn_or_defer(s, || 6 * 7);
            assert!(matches!(on_thread, Task::Thread(_)));
            assert_eq!(on_thread.join().expect("no panic"), 42);
        });
        let deferred: Task<'_, i32, _> = Task::Deferred(|| 6 * 7);
        assert_eq!(deferred.join().expect("no panic"), 42);
    }
}
