//! The one ordered sink of the batch and the labels-only plan: workers send
//! their results in any order, keyed by position (a frame index, a chunk
//! number); the sink hands them to the writer in key order, `first`,
//! `first + step`, …, so the output does not depend on how many workers
//! there are or which one finished first. The first error (a worker's or
//! the writer's) sets `failed`, which stops every worker, and ends the sink.

use std::collections::BTreeMap;
use std::sync::atomic::{AtomicBool, Ordering};

/// One worker's result for the item at `key`.
pub(super) struct Keyed<T> {
    pub key: u64,
    pub item: anyhow::Result<T>,
}

/// How the sink ended without an error.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum SinkEnd {
    /// Every worker finished and every item it sent was written.
    Drained,
    /// `cancel` was set: items received but not yet written were dropped.
    Cancelled,
}

/// Receive keyed results from `rx` until every sender is gone and write
/// each with `write` in key order from `first` in steps of `step`. Returns
/// at the first error (after setting `failed`) or when `cancel` is set
/// before the next write.
pub(super) fn write_in_order<T>(
    rx: crossbeam_channel::Receiver<Keyed<T>>,
    (first, step): (u64, u64),
    cancel: &AtomicBool,
    failed: &AtomicBool,
    mut write: impl FnMut(u64, T) -> anyhow::Result<()>,
) -> anyhow::Result<SinkEnd> {
    let stop = |e: anyhow::Error| {
        failed.store(true, Ordering::Relaxed);
        Err(e)
    };
    let mut pending: BTreeMap<u64, T> = BTreeMap::new();
    let mut next = first;
    for Keyed { key, item } in rx {
        match item {
            Ok(item) => {
                pending.insert(key, item);
            }
            Err(e) => return stop(e),
        }
        while let Some(item) = pending.remove(&next) {
            if cancel.load(Ordering::Relaxed) {
                return Ok(SinkEnd::Cancelled);
            }
            if let Err(e) = write(next, item) {
                return stop(e);
            }
            next += step;
        }
    }
    Ok(SinkEnd::Drained)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(sent: &[(u64, Result<u32, &str>)], step: u64, cancel: bool) -> (Vec<u64>, String, bool) {
        let (tx, rx) = crossbeam_channel::unbounded();
        for (key, item) in sent {
            let item = item.map_err(|e| anyhow::anyhow!("{e}"));
            tx.send(Keyed { key: *key, item }).expect("unbounded send");
        }
        drop(tx);
        let (cancel, failed) = (AtomicBool::new(cancel), AtomicBool::new(false));
        let mut written = Vec::new();
        let end = write_in_order(rx, (0, step), &cancel, &failed, |k, _| {
            written.push(k);
            Ok(())
        });
        let end = match end {
            Ok(end) => format!("{end:?}"),
            Err(e) => format!("error: {e}"),
        };
        (written, end, failed.load(Ordering::Relaxed))
    }

    #[test]
    fn writes_in_key_order_with_its_step() {
        let sent = [(6, Ok(3)), (0, Ok(1)), (9, Ok(4)), (3, Ok(2))];
        assert_eq!(
            run(&sent, 3, false),
            (vec![0, 3, 6, 9], "Drained".into(), false)
        );
        // A gap is never written past.
        let gap = [(0, Ok(1)), (2, Ok(3))];
        assert_eq!(run(&gap, 1, false), (vec![0], "Drained".into(), false));
    }

    #[test]
    fn a_worker_error_stops_it_and_sets_failed() {
        let sent = [(0, Ok(1)), (1, Err("frame 1 broke")), (2, Ok(3))];
        let (written, end, failed) = run(&sent, 1, false);
        assert_eq!(written, vec![0]);
        assert_eq!(end, "error: frame 1 broke");
        assert!(failed);
    }

    #[test]
    fn cancel_writes_nothing_more() {
        let sent = [(0, Ok(1)), (1, Ok(2))];
        assert_eq!(run(&sent, 1, true), (vec![], "Cancelled".into(), false));
    }
}
