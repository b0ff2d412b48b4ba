//! Messages and progress on standard error: `--quiet`, `--log-level`, and the
//! [`skylod::model::Progress`] of the library drawn as `indicatif` bars on a terminal or
//! written as plain lines otherwise.
//!
//! Levels: errors always (also with `--quiet`); warnings and the summary lines (one per
//! output written, the closing line of a command) by default; `info` adds one line per
//! stage and per file read or written (the plain-text progress), `debug` a line per tenth of
//! the POIs. Bars (files, bytes, POIs, ETA) are drawn only when standard error is a
//! terminal and `--quiet` is not given; a stage without a count shows a spinner, so no long
//! step is silent.

use indicatif::{MultiProgress, ProgressBar, ProgressDrawTarget, ProgressStyle};
use skylod::model::{Detail, ProgressText};
use skylod::model::{Progress, Stage};
use std::collections::HashMap;
use std::io::IsTerminal;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex, OnceLock};
use std::time::Duration;

/// How much is said on standard error.
#[derive(clap::ValueEnum, Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord)]
pub enum Level {
    /// Errors only.
    Error,
    /// Warnings and the summary lines (the default).
    #[default]
    Warn,
    /// Also one line per stage and per file (progress as text).
    Info,
    /// Also the POIs done, by tenths.
    Debug,
}

/// `--quiet`, `--log-level`: on every command (`global`).
#[derive(clap::Args, Debug, Clone, Copy)]
pub struct LogArgs {
    /// Say nothing on standard error but errors (no progress, no warnings, no summary).
    #[arg(long, short = 'q', global = true)]
    pub quiet: bool,
    /// What is written on standard error: error, warn (warnings and the summary lines),
    /// info (also a line per stage and per file: progress when standard error is not a
    /// terminal), debug. Progress bars are drawn on a terminal whatever the level.
    #[arg(
        long,
        global = true,
        value_enum,
        value_name = "LEVEL",
        default_value = "warn"
    )]
    pub log_level: Level,
}

#[derive(Default)]
struct Logger {
    level: Level,
    bars: Option<MultiProgress>,
}

static LOGGER: OnceLock<Logger> = OnceLock::new();

/// Set by the first SIGINT (Ctrl-C), SIGTERM or SIGHUP: the library's long loops stop at
/// their next item ([`Progress::is_cancelled`]), outputs not yet renamed into place are removed.
static INTERRUPTED: OnceLock<Arc<AtomicBool>> = OnceLock::new();

/// The number of the last of those signals received (0: none).
static SIGNAL: OnceLock<Arc<AtomicUsize>> = OnceLock::new();

fn interrupted() -> &'static Arc<AtomicBool> {
    INTERRUPTED.get_or_init(|| Arc::new(AtomicBool::new(false)))
}

/// SIGINT (Ctrl-C), SIGTERM and SIGHUP ask the running command to stop at its next file or
/// POI, so that no partial or temporary file is left behind; a second one ends the process at
/// once (exit 2 after Ctrl-C, 128 + the signal's number otherwise).
pub fn on_interrupt() {
    #[cfg(unix)]
    {
        use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};
        use signal_hook::flag;
        let signal = SIGNAL.get_or_init(|| Arc::new(AtomicUsize::new(0)));
        for sig in [SIGINT, SIGTERM, SIGHUP] {
            let second = if sig == SIGINT { 2 } else { 128 + sig };
            // Registered first: it runs before the flag is set, so only on the second signal.
            let _ = flag::register_conditional_shutdown(sig, second, Arc::clone(interrupted()));
            let _ = flag::register_usize(sig, Arc::clone(signal), sig as usize);
            let _ = flag::register(sig, Arc::clone(interrupted()));
        }
    }
}

/// The exit code a command stopped by a signal ends with: 128 + the signal's number for
/// SIGTERM (143) and SIGHUP (129), as a shell reports a process the signal killed; `None` when
/// no signal came or it was Ctrl-C (whose cancellation is a fatal error, exit 2).
pub fn signal_exit_code() -> Option<u8> {
    let sig = SIGNAL.get()?.load(Ordering::SeqCst);
    #[cfg(unix)]
    if sig != 0 && sig != signal_hook::consts::SIGINT as usize {
        return u8::try_from(128 + sig).ok();
    }
    let _ = sig;
    None
}

/// Set up messages and progress from the global flags (once, before any command runs).
pub fn init(args: &LogArgs) {
    let tty = std::io::stderr().is_terminal();
    let bars =
        (tty && !args.quiet).then(|| MultiProgress::with_draw_target(ProgressDrawTarget::stderr()));
    let _ = LOGGER.set(Logger {
        level: if args.quiet {
            Level::Error
        } else {
            args.log_level
        },
        bars,
    });
}

fn logger() -> &'static Logger {
    LOGGER.get_or_init(Logger::default)
}

/// Write `text` on standard error when `level` is enabled, above the bars when there are.
pub fn line(level: Level, text: &str) {
    let l = logger();
    if l.level < level {
        return;
    }
    match &l.bars {
        Some(m) => m.suspend(|| eprintln!("{text}")),
        None => eprintln!("{text}"),
    }
}

/// An error: always written.
macro_rules! error {
    ($($t:tt)*) => { $crate::log::line($crate::log::Level::Error, &format!("error: {}", format_args!($($t)*))) };
}
/// A warning: written unless `--quiet` or `--log-level error`.
macro_rules! warning {
    ($($t:tt)*) => { $crate::log::line($crate::log::Level::Warn, &format!($($t)*)) };
}
/// A summary line (an output written, the closing line): shown with the warnings.
macro_rules! summary {
    ($($t:tt)*) => { $crate::log::line($crate::log::Level::Warn, &format!($($t)*)) };
}
/// Detail shown with `--log-level info`.
macro_rules! info {
    ($($t:tt)*) => { $crate::log::line($crate::log::Level::Info, &format!($($t)*)) };
}
#[allow(unused_imports)]
pub(crate) use {error, info, summary, warning};

/// The progress of the library on standard error: bars on a terminal, else the lines of
/// [`ProgressText`] at `info` (stages, files) and `debug` (POIs by tenths), nothing with `--quiet`.
pub struct Reporter {
    bars: Option<MultiProgress>,
    state: Mutex<HashMap<Stage, StageBar>>,
    text: ProgressText,
}

struct StageBar {
    bar: ProgressBar,
    items: u64,
    done: u64,
    bytes: u64,
}

/// The progress reporter for the current flags.
pub fn reporter() -> Reporter {
    Reporter {
        bars: logger().bars.clone(),
        state: Mutex::new(HashMap::new()),
        text: ProgressText::default(),
    }
}

fn style(template: &str) -> ProgressStyle {
    ProgressStyle::with_template(template).unwrap_or_else(|_| ProgressStyle::default_bar())
}

/// Write a line of [`ProgressText`] at its detail.
fn text_line(l: Option<skylod::model::Line>) {
    let Some(l) = l else { return };
    let level = match l.detail {
        Detail::Info => Level::Info,
        Detail::Debug => Level::Debug,
    };
    line(level, &l.text);
}

impl Reporter {
    fn bar(m: &MultiProgress, stage: Stage, items: u64, bytes: u64) -> ProgressBar {
        let bar = if bytes > 0 {
            ProgressBar::new(bytes).with_style(style(
                "{spinner} {prefix:<26} [{bar:30}] {bytes}/{total_bytes} {msg} ({bytes_per_sec}, ETA {eta})",
            ))
        } else if items > 1 {
            ProgressBar::new(items).with_style(style(
                "{spinner} {prefix:<26} [{bar:30}] {pos}/{len} {msg} (ETA {eta})",
            ))
        } else {
            ProgressBar::new_spinner().with_style(style("{spinner} {prefix:<26} {elapsed}"))
        };
        let bar = m.add(bar);
        bar.set_prefix(stage.doing());
        if bytes > 0 {
            bar.set_message(format!("0/{items} {}s", stage.item()));
        } else if items > 1 {
            bar.set_message(format!("{}s", stage.item()));
        }
        bar.enable_steady_tick(Duration::from_millis(100));
        bar
    }
}

impl Progress for Reporter {
    fn is_cancelled(&self) -> bool {
        interrupted().load(Ordering::Relaxed)
    }

    fn start(&self, stage: Stage, items: u64, bytes: u64) {
        let Some(m) = &self.bars else {
            return text_line(Some(self.text.start(stage, items, bytes)));
        };
        let bar = Reporter::bar(m, stage, items, bytes);
        if let Ok(mut s) = self.state.lock() {
            let done = 0;
            s.insert(
                stage,
                StageBar {
                    bar,
                    items,
                    done,
                    bytes,
                },
            );
        }
    }

    fn advance(&self, stage: Stage, items: u64, bytes: u64, name: Option<&str>) {
        if self.bars.is_none() {
            return text_line(self.text.advance(stage, items, name));
        }
        let Ok(mut s) = self.state.lock() else { return };
        let Some(st) = s.get_mut(&stage) else { return };
        st.done += items;
        if st.bytes > 0 {
            st.bar.inc(bytes);
            (st.bar).set_message(format!("{}/{} {}s", st.done, st.items, stage.item()));
        } else {
            st.bar.inc(items);
        }
    }

    fn finish(&self, stage: Stage) {
        if self.bars.is_none() {
            return text_line(self.text.finish(stage));
        }
        let Ok(mut s) = self.state.lock() else { return };
        if let Some(st) = s.remove(&stage) {
            st.bar.finish_and_clear();
        }
    }
}
