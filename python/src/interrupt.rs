//! Long calls a user can stop, with their progress: the work runs on a thread of its own
//! while the calling thread, every 50 ms, checks Python's signals and reports the units of
//! work done. Ctrl-C raises `KeyboardInterrupt` at once; the work stops at its next unit.

use std::panic::{catch_unwind, resume_unwind, AssertUnwindSafe};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{mpsc, Arc};
use std::time::Duration;

use pyo3::prelude::*;

/// How often the calling thread checks the signals and the progress.
const POLL: Duration = Duration::from_millis(50);

/// The payload that unwinds work asked to stop (raised without the panic hook: nothing is
/// printed).
struct Stopped;

/// What the work reports through: [`Ticker::tick`] after each unit of work; the number of
/// units once known ([`Ticker::set_total`]).
#[derive(Clone, Default)]
pub(crate) struct Ticker {
    done: Arc<AtomicUsize>,
    total: Arc<AtomicUsize>,
    stop: Arc<AtomicBool>,
}

impl Ticker {
    /// One more unit done; once the caller has been interrupted, stops the work here.
    pub(crate) fn tick(&self) {
        self.stop_if_asked();
        self.done.fetch_add(1, Ordering::Relaxed);
    }

    /// Stops the work here once the caller has been interrupted (between units of work
    /// that do not count as progress).
    pub(crate) fn stop_if_asked(&self) {
        if self.stop.load(Ordering::Relaxed) {
            resume_unwind(Box::new(Stopped));
        }
    }

    /// The number of units the work will report.
    pub(crate) fn set_total(&self, total: usize) {
        self.total.store(total, Ordering::Relaxed);
    }
}

/// The command line's observer ([`drive::cli::RunObserver`]) of a call through
/// [`interruptible`]: its units of work are the ticker's; an interrupted caller stops the
/// command at its next unit, or before it publishes anything.
pub(crate) struct Observer(pub(crate) Ticker);

impl drive::cli::RunObserver for Observer {
    fn unit_done(&self, total: usize) {
        self.0.set_total(total);
        self.0.tick();
    }

    fn before_publish(&self) {
        self.0.stop_if_asked();
    }
}

/// Runs `work` on a thread of its own, without the GIL, and returns its result. Every
/// 50 ms the calling thread checks Python's signals: an exception a signal handler raises
/// (`KeyboardInterrupt` for Ctrl-C) is raised at once, and the work stops at its next
/// [`Ticker::tick`] (its partial results dropped). `progress`, a Python callable, is called
/// as `progress(done, total)` on the calling thread when the count of units done changes
/// (`total` 0 while unknown); an exception it raises stops the work likewise.
pub(crate) fn interruptible<T: Send + 'static>(
    py: Python<'_>,
    progress: Option<&Bound<'_, PyAny>>,
    work: impl FnOnce(&Ticker) -> T + Send + 'static,
) -> PyResult<T> {
    let ticker = Ticker::default();
    let (tx, rx) = mpsc::channel();
    let worker = ticker.clone();
    std::thread::Builder::new()
        .name("drive-work".into())
        .spawn(move || {
            let result = catch_unwind(AssertUnwindSafe(|| work(&worker)));
            // The caller may have returned (interrupted): nobody receives the result.
            let _ = tx.send(result);
        })
        .map_err(crate::err)?;
    let stop = |e: PyErr| {
        ticker.stop.store(true, Ordering::Relaxed);
        e
    };
    let (mut reported, mut rx) = (0, rx);
    loop {
        // The receiver goes along (it may be sent, not shared) and comes back.
        let (got, back) = py.detach(move || (rx.recv_timeout(POLL), rx));
        rx = back;
        if let Some(progress) = progress {
            let done = ticker.done.load(Ordering::Relaxed);
            if done != reported {
                reported = done;
                let total = ticker.total.load(Ordering::Relaxed);
                progress.call1((done, total)).map_err(stop)?;
            }
        }
        match got {
            Ok(Ok(value)) => return Ok(value),
            Ok(Err(payload)) => {
                if payload.is::<Stopped>() {
                    // Only after an interruption, which has already returned.
                    return Err(crate::err("the work was stopped"));
                }
                // A panic in the work: raised here, where pyo3 turns it into an exception.
                resume_unwind(payload)
            }
            Err(mpsc::RecvTimeoutError::Timeout) => py.check_signals().map_err(stop)?,
            Err(mpsc::RecvTimeoutError::Disconnected) => {
                return Err(crate::err("the work ended without a result"))
            }
        }
    }
}
