//! Running a library call from Python: the call runs on its own thread with the GIL released,
//! while the calling thread relays its progress to the Python callable and watches for
//! Ctrl-C (`PyErr_CheckSignals`). A KeyboardInterrupt, or an exception raised by the
//! callable, cancels the call through the library's [`Progress::is_cancelled`] and is raised
//! once the call has stopped; a panic is turned into a `SkylodError`, never carried across.

use pyo3::prelude::*;
use skylod::model::{Progress, Stage};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{channel, RecvTimeoutError, Sender};
use std::sync::Mutex;
use std::time::Duration;

pyo3::create_exception!(
    skylod,
    SkylodError,
    pyo3::exceptions::PyException,
    "An error of the skylod library, with its message (file, line:column and gml:id where known)."
);

/// How often the calling thread looks for Ctrl-C while the call runs.
const POLL: Duration = Duration::from_millis(50);

/// One progress call of the library, sent to the calling thread.
enum Event {
    Start(Stage, u64),
    Advance(Stage, u64),
    Finish(Stage),
}

/// The [`Progress`] the library sees: events to the calling thread, cancellation from it.
struct Relay<'a> {
    tx: Mutex<Sender<Event>>,
    cancel: &'a AtomicBool,
}

impl Relay<'_> {
    fn send(&self, e: Event) {
        if let Ok(tx) = self.tx.lock() {
            // The receiver lives until the call ends: a failed send only means it ended.
            let _ = tx.send(e);
        }
    }
}

impl Progress for Relay<'_> {
    fn start(&self, stage: Stage, items: u64, _bytes: u64) {
        self.send(Event::Start(stage, items));
    }
    fn advance(&self, stage: Stage, items: u64, _bytes: u64, _name: Option<&str>) {
        if items > 0 {
            self.send(Event::Advance(stage, items));
        }
    }
    fn finish(&self, stage: Stage) {
        self.send(Event::Finish(stage));
    }
    fn is_cancelled(&self) -> bool {
        self.cancel.load(Ordering::Relaxed)
    }
}

/// The name a stage has in Python (`progress(stage, done, total)`).
pub fn stage_name(s: Stage) -> &'static str {
    match s {
        Stage::Read => "read",
        Stage::Rough => "rough",
        Stage::Bvh => "bvh",
        Stage::Select => "select",
        Stage::Trace => "trace",
        Stage::Write => "write",
        Stage::Sun => "sun",
        _ => "other",
    }
}

/// Counts per stage on the calling thread, for `progress(stage, done, total)`.
#[derive(Default)]
struct Counts(Vec<(Stage, u64, u64)>);

impl Counts {
    fn entry(&mut self, s: Stage) -> &mut (Stage, u64, u64) {
        let k = match self.0.iter().position(|e| e.0 == s) {
            Some(k) => k,
            None => {
                self.0.push((s, 0, 0));
                self.0.len() - 1
            }
        };
        &mut self.0[k]
    }

    /// The call to make for `e`: (stage, done, total).
    fn apply(&mut self, e: Event) -> (Stage, u64, u64) {
        match e {
            Event::Start(s, n) => {
                let x = self.entry(s);
                (x.1, x.2) = (0, n);
                (s, 0, n)
            }
            Event::Advance(s, n) => {
                let x = self.entry(s);
                x.1 += n;
                (s, x.1, x.2)
            }
            Event::Finish(s) => {
                let x = self.entry(s);
                x.1 = x.1.max(x.2);
                (s, x.1, x.2)
            }
        }
    }
}

/// Run `f` on its own thread with the GIL released; relay its progress to `progress`
/// (called on this thread as `progress(stage, done, total)`) and cancel it on Ctrl-C or
/// when `progress` raises. Library errors become `SkylodError`.
pub fn run<T, F>(py: Python<'_>, progress: Option<PyObject>, f: F) -> PyResult<T>
where
    T: Send,
    F: FnOnce(&dyn Progress) -> Result<T, String> + Send,
{
    let cancel = AtomicBool::new(false);
    let (tx, rx) = channel::<Event>();
    let rx = Mutex::new(rx);
    let relay = Relay {
        tx: Mutex::new(tx),
        cancel: &cancel,
    };
    let mut raised: Option<PyErr> = None;
    let mut counts = Counts::default();
    let outcome = std::thread::scope(|scope| {
        // The relay (and its sender) is dropped when `f` returns or unwinds: then the
        // channel disconnects once its last events are read.
        let worker = scope.spawn(move || {
            let relay = relay;
            f(&relay)
        });
        loop {
            let event = py.allow_threads(|| match rx.lock() {
                Ok(rx) => rx.recv_timeout(POLL),
                Err(_) => Err(RecvTimeoutError::Disconnected),
            });
            match event {
                Ok(e) => {
                    let (stage, done, total) = counts.apply(e);
                    if let (Some(cb), None) = (&progress, &raised) {
                        if let Err(err) = cb.call1(py, (stage_name(stage), done, total)) {
                            raised = Some(err);
                            cancel.store(true, Ordering::Relaxed);
                        }
                    }
                }
                Err(RecvTimeoutError::Disconnected) => break,
                Err(RecvTimeoutError::Timeout) => {}
            }
            if raised.is_none() {
                if let Err(err) = py.check_signals() {
                    raised = Some(err);
                    cancel.store(true, Ordering::Relaxed);
                }
            }
        }
        py.allow_threads(|| worker.join())
    });
    if let Some(err) = raised {
        return Err(err);
    }
    match outcome {
        Ok(Ok(t)) => Ok(t),
        Ok(Err(message)) => Err(SkylodError::new_err(message)),
        Err(panic) => {
            let why = panic
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| panic.downcast_ref::<String>().cloned())
                .unwrap_or_default();
            Err(SkylodError::new_err(format!(
                "internal error (please report it): {why}"
            )))
        }
    }
}

/// The message of a library error with its causes, as the command line prints it.
pub fn message(e: &(dyn std::error::Error + 'static)) -> String {
    let mut text = e.to_string();
    let mut cause = e.source();
    while let Some(c) = cause {
        let c_text = c.to_string();
        if !text.contains(&c_text) {
            text.push_str(": ");
            text.push_str(&c_text);
        }
        cause = c.source();
    }
    text
}
