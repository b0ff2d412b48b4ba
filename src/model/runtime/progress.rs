//! Progress and cancellation of long work, without printing.
//!
//! The library tells a [`Progress`] what it is doing — a [`Stage`] starts with how many items
//! (files, POIs) and bytes it will go through, advances, finishes — and asks it in every long
//! loop whether the caller wants to stop ([`Progress::is_cancelled`]); a stage that stops
//! returns [`Cancelled`]. The binary draws bars or writes log lines from these calls; an
//! embedding program can forward them to its own UI, or pass [`Silent`].
//!
//! Calls come from worker threads (files and POIs are worked on in parallel), so an
//! implementation must be [`Sync`] and cheap: `advance` is called once per file or POI.
//!
//! # Example
//! ```
//! use skylod::model::{Progress, Stage};
//! use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
//!
//! /// Counts the POIs selected and stops the work once `stop` is set.
//! #[derive(Default)]
//! struct Pois { done: AtomicU64, stop: AtomicBool }
//!
//! impl Progress for Pois {
//!     fn advance(&self, stage: Stage, items: u64, _bytes: u64, _name: Option<&str>) {
//!         if stage == Stage::Select {
//!             self.done.fetch_add(items, Ordering::Relaxed);
//!         }
//!     }
//!     fn is_cancelled(&self) -> bool {
//!         self.stop.load(Ordering::Relaxed)
//!     }
//! }
//!
//! let p = Pois::default();
//! p.advance(Stage::Select, 1, 0, None);
//! assert_eq!(p.done.load(Ordering::Relaxed), 1);
//! assert!(skylod::model::check(&p, Stage::Select).is_ok());
//! p.stop.store(true, Ordering::Relaxed);
//! let e = skylod::model::check(&p, Stage::Select).unwrap_err();
//! assert_eq!(e.to_string(), "cancelled while selecting levels");
//! ```

use std::fmt;

/// A stage of the work, in pipeline order.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum Stage {
    /// Reading input files (items: files, bytes: their size on disk).
    Read,
    /// Building the rough model (items: assets).
    Rough,
    /// Triangulating and building a ray-tracing scene (one item).
    Bvh,
    /// Selecting levels (items: POIs).
    Select,
    /// Tracing POIs against a scene: SVF, sun hours, error bound (items: POIs).
    Trace,
    /// Writing output files (items: files).
    Write,
    /// The sun's positions over the simulated period, the sun table (items: time steps).
    Sun,
}

impl Stage {
    /// What the stage does, for messages ("reading inputs").
    pub fn doing(self) -> &'static str {
        match self {
            Stage::Read => "reading inputs",
            Stage::Rough => "building the rough model",
            Stage::Bvh => "building the scene",
            Stage::Select => "selecting levels",
            Stage::Trace => "tracing",
            Stage::Write => "writing outputs",
            Stage::Sun => "computing the sun's positions",
        }
    }

    /// The name of one item of the stage ("file", "POI", "asset", "scene").
    pub fn item(self) -> &'static str {
        match self {
            Stage::Read | Stage::Write => "file",
            Stage::Rough => "asset",
            Stage::Bvh => "scene",
            Stage::Select | Stage::Trace => "POI",
            Stage::Sun => "time step",
        }
    }
}

impl fmt::Display for Stage {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.doing())
    }
}

/// Receives progress from the library and answers whether to stop. Every method has a
/// default that does nothing, so an implementation overrides only what it needs.
pub trait Progress: Sync {
    /// `stage` begins with `items` items (files, assets, POIs) and `bytes` bytes to go
    /// through (0 when not counted in bytes).
    fn start(&self, stage: Stage, items: u64, bytes: u64) {
        let _ = (stage, items, bytes);
    }

    /// `items` more items and `bytes` more bytes of `stage` are done; `name` names the item
    /// when there is one (a file's path). Called from worker threads, in any order.
    fn advance(&self, stage: Stage, items: u64, bytes: u64, name: Option<&str>) {
        let _ = (stage, items, bytes, name);
    }

    /// `stage` is over (also after a cancellation).
    fn finish(&self, stage: Stage) {
        let _ = stage;
    }

    /// Whether the caller wants the work to stop: long loops ask before each item and
    /// return [`Cancelled`].
    fn is_cancelled(&self) -> bool {
        false
    }
}

/// A [`Progress`] that ignores everything and never cancels.
#[derive(Debug, Clone, Copy, Default)]
pub struct Silent;

impl Progress for Silent {}

/// The work was stopped because [`Progress::is_cancelled`] said so.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("cancelled while {stage}")]
pub struct Cancelled {
    /// The stage that stopped.
    pub stage: Stage,
}

/// `Err(Cancelled)` when `progress` asks to stop.
///
/// # Errors
/// [`Cancelled`] naming `stage`.
pub fn check(progress: &dyn Progress, stage: Stage) -> Result<(), Cancelled> {
    if progress.is_cancelled() {
        Err(Cancelled { stage })
    } else {
        Ok(())
    }
}

/// Start `stage`, run `f`, finish `stage` (whatever `f` returned).
pub fn stage<T>(
    progress: &dyn Progress,
    stage: Stage,
    items: u64,
    bytes: u64,
    f: impl FnOnce() -> T,
) -> T {
    progress.start(stage, items, bytes);
    let r = f();
    progress.finish(stage);
    r
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Mutex;

    #[derive(Default)]
    struct Log(Mutex<Vec<String>>);

    impl Progress for Log {
        fn start(&self, stage: Stage, items: u64, _bytes: u64) {
            if let Ok(mut v) = self.0.lock() {
                v.push(format!("start {stage:?} {items}"));
            }
        }
        fn finish(&self, stage: Stage) {
            if let Ok(mut v) = self.0.lock() {
                v.push(format!("finish {stage:?}"));
            }
        }
    }

    #[test]
    fn stage_starts_and_finishes() {
        let log = Log::default();
        let x = stage(&log, Stage::Bvh, 1, 0, || 42);
        assert_eq!(x, 42);
        assert_eq!(
            *log.0.lock().unwrap(),
            vec!["start Bvh 1".to_string(), "finish Bvh".to_string()]
        );
    }

    #[test]
    fn silent_never_cancels() {
        assert!(check(&Silent, Stage::Read).is_ok());
        assert_eq!(
            Cancelled {
                stage: Stage::Write
            }
            .to_string(),
            "cancelled while writing outputs"
        );
    }
}
