//! The work queue between the simplifier and the threads that bound the
//! levels' errors: the simplifier pushes each candidate level's index buffer
//! as it makes it, the bounding threads take them in order until it is done.

/// The candidate levels' index buffers as the simplifier makes them, for
/// the threads that bound their errors.
#[derive(Default)]
pub(super) struct Queue {
    state: std::sync::Mutex<QueueState>,
    ready: std::sync::Condvar,
}

#[derive(Default)]
struct QueueState {
    /// Levels 1, 2, … so far.
    levels: Vec<Vec<u32>>,
    /// How many of them a thread has taken.
    taken: usize,
    /// The simplifier is done: no level will be added.
    finished: bool,
}

impl Queue {
    pub(super) fn push(&self, indices: Vec<u32>) {
        if let Ok(mut s) = self.state.lock() {
            s.levels.push(indices);
        }
        self.ready.notify_one();
    }

    fn finish(&self) {
        if let Ok(mut s) = self.state.lock() {
            s.finished = true;
        }
        self.ready.notify_all();
    }

    /// The next level nobody has taken (its number and indices), waiting
    /// while the simplifier may still make one; `None` once all are taken.
    pub(super) fn take(&self) -> Option<(usize, Vec<u32>)> {
        let mut s = self.state.lock().ok()?;
        loop {
            if let Some(indices) = s.levels.get(s.taken).cloned() {
                s.taken += 1;
                return Some((s.taken, indices));
            }
            if s.finished {
                return None;
            }
            s = self.ready.wait(s).ok()?;
        }
    }
}

/// Marks the queue finished when dropped.
pub(super) struct FinishOnDrop<'a>(pub(super) &'a Queue);

impl Drop for FinishOnDrop<'_> {
    fn drop(&mut self) {
        self.0.finish();
    }
}
