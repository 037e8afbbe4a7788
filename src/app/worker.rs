//! A background thread that always works on the newest request.
//!
//! The UI submits a request whenever its inputs change; while the thread is
//! busy, requests pile up and only the last one is served, so dragging a
//! slider never queues a backlog of stale renders. Each answer is followed by
//! a call to `wake` (the app passes `egui::Context::request_repaint`), so the
//! UI thread only ever polls a channel and never waits.

use crossbeam_channel::{Receiver, Sender};

/// A thread that turns the newest `Req` into a `Resp`.
pub struct LatestWorker<Req, Resp> {
    requests: Sender<Req>,
    responses: Receiver<Resp>,
}

impl<Req: Send + 'static, Resp: Send + 'static> LatestWorker<Req, Resp> {
    /// Start the thread; it ends when this handle is dropped.
    pub fn spawn(
        name: &str,
        wake: impl Fn() + Send + 'static,
        mut work: impl FnMut(Req) -> Resp + Send + 'static,
    ) -> std::io::Result<Self> {
        let (requests, request_rx) = crossbeam_channel::unbounded::<Req>();
        let (response_tx, responses) = crossbeam_channel::unbounded::<Resp>();
        std::thread::Builder::new()
            .name(name.to_owned())
            .spawn(move || {
                while let Ok(mut request) = request_rx.recv() {
                    while let Ok(newer) = request_rx.try_recv() {
                        request = newer;
                    }
                    if response_tx.send(work(request)).is_err() {
                        break;
                    }
                    wake();
                }
            })?;
        Ok(Self {
            requests,
            responses,
        })
    }

    /// Queue a request; older unserved requests are skipped.
    pub fn submit(&self, request: Req) {
        // The thread only stops when this handle is dropped, so sending cannot fail while we hold it.
        let _ = self.requests.send(request);
    }

    /// The newest answer that arrived since the last call, if any.
    pub fn latest(&self) -> Option<Resp> {
        self.responses.try_iter().last()
    }
}
